"""Live view under load: 4 channels at 51.2 kS/s in real time through the GUI (offscreen), with figures printed.

    python benchmarks/bench_live_view.py                 # 10 minutes, as the issue asks
    python benchmarks/bench_live_view.py --seconds 20    # a quick run
    python benchmarks/bench_live_view.py --hits          # the simulated hammer also hits every 1.5–3 s

The real GUI runs on the simulated NI 9234 with realtime pacing: the reader thread, the acquisition worker
(trigger, validation, session writing) and the Measure tab's 25 Hz redraw of the last 2 s of every channel (peak
downsampling, clip to view). Printed: samples lost (device overflow, chunks dropped by the GUI's mailbox, reader lag
at the end), redraw rate and time per redraw, and the process's CPU share.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QSettings, QTimer  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from gasfilm.app.gui.main_window import MainWindow  # noqa: E402

SAMPLE_RATE_HZ = 51200.0
CHANNELS = 4


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="GUI live view: 4 channels at 51.2 kS/s in real time")
    parser.add_argument("--seconds", type=float, default=600.0, help="streaming time (default 600 s = 10 min)")
    parser.add_argument("--hits", action="store_true", help="let the simulated hammer hit every 1.5–3 s")
    args = parser.parse_args(argv)

    app = QApplication.instance() or QApplication(sys.argv[:1])
    scratch = Path(tempfile.mkdtemp(prefix="gasfilm-bench-live-"))
    window = MainWindow(QSettings(str(scratch / "settings.ini"), QSettings.Format.IniFormat), scratch)
    window.resize(1600, 1000)
    window.show()
    state = window.setup_tab.state()
    state.device = "sim"
    state.sample_rate_hz = SAMPLE_RATE_HZ
    for channel in state.channels[:CHANNELS]:
        channel.enabled = True
    state.trigger = {**state.trigger, "record_s": 1.0}
    state.live_view_s = 2.0
    state.sim_auto_hammer = args.hits
    window.setup_tab.set_state(state)
    window.tabs.setCurrentWidget(window.measure_tab)
    controller = window.controller

    figures: dict[str, float] = {"max_lag_samples": 0.0}
    started: dict[str, float] = {}

    def sample() -> None:
        loop = controller.loop
        if loop is None:
            return
        if "wall" not in started:
            started.update(wall=time.monotonic(), cpu=_cpu_s(), samples=loop.samples_read,
                           redraws=window.measure_tab.redraw_count)
            QTimer.singleShot(int(args.seconds * 1000), finish)
            return
        expected = (time.monotonic() - started["wall"]) * loop.sample_rate_hz + started["samples"]
        figures["max_lag_samples"] = max(figures["max_lag_samples"], expected - loop.samples_read - loop.chunk_samples)

    def finish() -> None:
        loop = controller.loop
        wall = time.monotonic() - started["wall"]
        cpu = _cpu_s() - started["cpu"]
        if loop is not None:
            figures["samples_read"] = loop.samples_read - started["samples"]
            figures["expected"] = wall * loop.sample_rate_hz
            figures["chunk_samples"] = loop.chunk_samples
        stats = controller.acquisition_stats
        figures["dropped_chunks"] = stats.dropped_chunks if stats is not None else float("nan")
        figures["redraws"] = window.measure_tab.redraw_count - started["redraws"]
        figures["redraw_s"] = window.measure_tab.redraw_seconds
        figures["wall"] = wall
        figures["cpu"] = cpu
        figures["hits"] = len(controller.hits)
        controller.stop()
        app.quit()

    sampler = QTimer()
    sampler.timeout.connect(sample)
    sampler.start(1000)
    controller.arm()
    app.exec()
    faults = [text for severity, text in window.banner.history if severity == "error"]
    controller.shutdown()

    if "wall" not in figures:
        print(f"bench_live_view: the acquisition never streamed: {' | '.join(faults)}", file=sys.stderr)
        return 1
    lost_in_mailbox = figures["dropped_chunks"] * figures["chunk_samples"] * CHANNELS
    lag_at_end = max(0.0, figures["expected"] - figures["samples_read"] - figures["chunk_samples"])
    cores = os.cpu_count() or 1
    print(f"gasfilm live view — {CHANNELS} channels at {SAMPLE_RATE_HZ:.0f} S/s, realtime, offscreen, "
          f"{figures['wall']:.0f} s{' with hits' if args.hits else ''}")
    print(f"  device faults:            {len(faults)}{' (' + ' | '.join(faults) + ')' if faults else ''}")
    print(f"  samples read:             {figures['samples_read'] * CHANNELS:,.0f} "
          f"({figures['samples_read'] / figures['expected'] * 100:.2f} % of real time)")
    print(f"  samples lost:             {lost_in_mailbox:,.0f} (chunks dropped by the GUI mailbox: "
          f"{figures['dropped_chunks']:.0f}; device overflow: {'yes' if faults else 'no'})")
    print(f"  reader lag:               {lag_at_end / SAMPLE_RATE_HZ * 1000:.0f} ms at the end, "
          f"max {max(0.0, figures['max_lag_samples']) / SAMPLE_RATE_HZ * 1000:.0f} ms (beyond one chunk)")
    print(f"  redraw rate:              {figures['redraws'] / figures['wall']:.1f} fps (goal ≥ 20), "
          f"{figures['redraw_s'] / max(1, window.measure_tab.redraw_count) * 1000:.1f} ms per redraw")
    print(f"  hits recorded:            {figures['hits']:.0f}")
    print(f"  CPU:                      {figures['cpu'] / figures['wall'] * 100:.0f} % of one core "
          f"({figures['cpu'] / figures['wall'] / cores * 100:.0f} % of the machine's {cores} cores)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
