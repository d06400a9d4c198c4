"""The GUI's fit and diagnosis against the command line's, with the live view running: wall times and their ratio.

    python benchmarks/bench_gui_jobs.py                       # SD and FOMGF, the diagnosis; 3 rounds
    python benchmarks/bench_gui_jobs.py --models all --rounds 5

A session of 6 hits is recorded through the real GUI (offscreen) on the simulated rig at the Setup tab's defaults
(12 800 S/s, 1 s records). Then, in rounds, each job runs three ways in the same process:

* **CLI**: what ``gasfilm fit`` and ``gasfilm diagnose`` call (``fit_model`` + ``compare_models``; ``diagnose`` +
  ``write_outputs``), on the main thread with nothing else running;
* **GUI, quiet**: the Identify/Diagnose tab's job on its worker thread, that tab shown, the window otherwise idle;
* **GUI, live view**: the same job, with *Arm* pressed just after it started: the simulated device streams in real
  time through the acquisition worker into the Measure tab's live view (25 frames per second; 5 while a job runs)
  while the job runs.

A GUI run is timed from the click (the controller's ``run_fits`` / ``run_diagnosis``) until the result is shown and
the job has ended: the results stored in the session, the job's tab redrawn when it is the one shown (with the live
view, the Measure tab is shown; the Identify tab draws the fits when it is next shown), the acquisition still running
(stopping it afterwards is not timed). Each starts once the job process the GUI keeps
ready has warmed up (``job_process_ready``), as it has when a technician clicks seconds after the previous result;
so does each CLI run (the warm-up of the next job process must not slow it down).

Printed: the median wall time of each, the ratio GUI-with-live-view / CLI (goal ≤ 1.5) and the process's CPU use.
Figures from a shared machine vary: the rounds alternate the three ways so that load affects them alike.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

# The heavy imports are inside the functions: the GUI's job processes import this script again as their main module,
# and must find it as light as the ``gasfilm`` command they are started from in real use.

HITS = 6
GOAL_RATIO = 1.5


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _wait(app: Any, condition: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"bench_gui_jobs: timed out after {timeout_s:g} s waiting for {what}")
        app.processEvents()
        time.sleep(0.005)


def _record_session(app: Any, window: Any, folder: Path) -> None:
    controller = window.controller
    state = window.setup_tab.state()
    state.device = "sim"
    state.sim_auto_hammer = False
    window.setup_tab.set_state(state)
    controller.new_session(folder / "bench.h5")
    controller.arm()
    _wait(app, lambda: controller.state == "armed", 30, "the simulated device to stream")
    for number in range(HITS):
        controller.virtual_hit("medium")
        _wait(app, lambda n=number: len(controller.hits) == n + 1, 30, f"hit {number + 1}")
    controller.stop()
    _wait(app, lambda: controller.state == "idle", 30, "the acquisition to stop")
    controller.save_session()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="GUI fit and diagnosis vs the CLI's, with the live view running")
    parser.add_argument("--models", default="SD,FOMGF", help="comma-separated models or 'all' (default SD,FOMGF)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of CLI / GUI quiet / GUI live (default 3)")
    parser.add_argument("--no-diagnosis", action="store_true", help="time the fit only")
    args = parser.parse_args(argv)
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from gasfilm.analysis.diagnosis import diagnose, load_recordings
    from gasfilm.analysis.diagnosis.plots import write_outputs
    from gasfilm.analysis.identification import compare_models, fit_model
    from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER, get_model
    from gasfilm.app.gui.main_window import MainWindow
    from gasfilm.app.gui.workers import job_process_ready, warm_up_job_processes

    warm_up_job_processes()
    models = list(PAPER_MODEL_ORDER) if args.models == "all" else [m.strip() for m in args.models.split(",")]

    app = QApplication.instance() or QApplication(sys.argv[:1])
    scratch = Path(tempfile.mkdtemp(prefix="gasfilm-bench-jobs-"))
    window = MainWindow(QSettings(str(scratch / "settings.ini"), QSettings.Format.IniFormat), scratch)
    window.show()
    controller = window.controller
    _record_session(app, window, scratch)
    frf = controller.frf
    low, high = controller.fit_band_hz
    band = (frf.freq_hz >= low) & (frf.freq_hz <= high)
    freq_hz, h = frf.freq_hz[band], frf.h1[band]
    mass_kg = controller.rig_spec_of_session().mass_kg
    spec = controller.rig_spec_of_session()

    def cli_fit() -> None:
        fits = [fit_model(get_model(name), freq_hz, h, mass_kg, decay_rate_1_s=frf.decay_rate_1_s) for name in models]
        compare_models(fits, freq_hz, h)

    def cli_diagnose() -> None:
        write_outputs(diagnose(load_recordings(controller.session_path), spec), scratch / "cli-diagnosis")

    job_tabs = {"fit": window.identify_tab, "diagnose": window.diagnose_tab}

    def gui_job(name: str, start: Callable[[], None], live: bool) -> Callable[[], None]:
        def run() -> tuple[float, float]:
            started, cpu_started = time.perf_counter(), _cpu_s()
            start()
            if not controller.job_active(name):
                raise RuntimeError(f"bench_gui_jobs: the GUI refused the {name}: {window.banner.history[-1:]}")
            if live:
                window.tabs.setCurrentWidget(window.measure_tab)
                controller.arm()
            _wait(app, lambda: not controller.job_active(name), 900, f"the GUI's {name}")
            wall, cpu_s = time.perf_counter() - started, _cpu_s() - cpu_started
            if live:  # (stopping the acquisition afterwards is not part of the job)
                controller.stop()
                _wait(app, lambda: controller.state == "idle", 30, "the acquisition to stop")
            errors = [text for severity, text in window.banner.history if severity == "error"]
            if errors:
                raise RuntimeError(f"bench_gui_jobs: {errors[-1]}")
            return wall, cpu_s
        return run

    def cli_job(work: Callable[[], None]) -> Callable[[], tuple[float, float]]:
        def run() -> tuple[float, float]:
            started, cpu_started = time.perf_counter(), _cpu_s()
            work()
            return time.perf_counter() - started, _cpu_s() - cpu_started
        return run

    def gui_fit() -> None:
        controller.run_fits(models, "default", (low, high))

    def gui_diagnose() -> None:
        controller.run_diagnosis(None)

    jobs = [("fit", f"fit of {', '.join(models)}", cli_fit, gui_fit)]
    if not args.no_diagnosis:
        jobs.append(("diagnose", f"diagnosis of {HITS} hits", cli_diagnose, gui_diagnose))
    print(f"gasfilm GUI jobs vs CLI — {os.cpu_count()} cores, {frf.n_averages} hits at {frf.sample_rate_hz:g} S/s, "
          f"band {low:g}–{high:g} Hz ({band.sum()} lines), {args.rounds} rounds")
    worst = 0.0
    for name, title, cli, gui_start in jobs:
        ways = {"CLI": cli_job(cli), "GUI, quiet": gui_job(name, gui_start, False), "GUI, live view": gui_job(name, gui_start, True)}
        times: dict[str, list[float]] = {way: [] for way in ways}
        cpu: dict[str, list[float]] = {way: [] for way in ways}
        ways["GUI, quiet"]()  # untimed: the first job waits for the job processes' fork server to be ready
        for _ in range(args.rounds):
            for way, run in ways.items():
                if way != "CLI":
                    window.tabs.setCurrentWidget(job_tabs[name])
                    _wait(app, lambda: True, 1, "")
                if not job_process_ready(60):  # (also before the CLI's run: its warm-up must not slow that)
                    raise TimeoutError("bench_gui_jobs: no job process ready after 60 s")
                wall, cpu_s = run()
                times[way].append(wall)
                cpu[way].append(cpu_s / wall)
        medians = {way: statistics.median(values) for way, values in times.items()}
        ratio = medians["GUI, live view"] / medians["CLI"]
        worst = max(worst, ratio)
        print(f"  {title}:")
        for way in ways:
            print(f"    {way:15s} {medians[way]:7.2f} s median  (runs {', '.join(f'{t:.2f}' for t in times[way])} s; "
                  f"CPU {statistics.median(cpu[way]) * 100:.0f} % of one core)")
        print(f"    GUI with live view / CLI: {ratio:.2f}  (goal ≤ {GOAL_RATIO:g}: {'met' if ratio <= GOAL_RATIO else 'NOT met'})")
    controller.shutdown()
    window.close()
    return 0 if worst <= GOAL_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
