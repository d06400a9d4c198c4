"""Screenshots of every tab after a simulated hammer session: ``python -m gasfilm.app.gui.screenshots [--out DIR]``.

Runs the real GUI offscreen on the simulated rig: the paper's FOMGF film on 25.05 kg with a small extra mode of the
mover that the design spec leaves out. It arms, hits with the virtual hammer, rejects one hit by hand, fits the
paper's nine models, diagnoses the session against the design spec (which finds the extra mode), and writes one PNG
per tab (and the Measure tab's hit check, force spectrum and overlay views) to ``docs/screenshots/`` (the README links them). Settings go to a temporary folder, not the user's.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QSettings  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER  # noqa: E402
from gasfilm.analysis.physics.effects import ExtraMode  # noqa: E402
from gasfilm.analysis.physics.spec import RigSpec  # noqa: E402
from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE, MainWindow  # noqa: E402

DEFAULT_OUT = Path(__file__).resolve().parents[2] / "docs" / "screenshots"
HITS = 8
REJECTED_HIT = 3
TIPS = ("medium", "hard", "medium", "soft")
#: What the simulated rig really is: the design spec plus a mode the design leaves out.
HIDDEN_MODE = ExtraMode(freq_hz=640.0, damping_ratio=0.03, mass_kg=0.6)


def _wait_until(app: QApplication, condition: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"screenshots: timed out after {timeout_s:g} s waiting for {what}")
        app.processEvents()
        time.sleep(0.01)


def _settle(app: QApplication, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.01)


def _save(window: MainWindow, tab, path: Path, app: QApplication) -> Path:
    window.tabs.setCurrentWidget(tab)
    _settle(app, 0.3)
    if not window.grab().save(str(path)):
        raise OSError(f"screenshots: cannot write {path}")
    print(f"  wrote {path}", file=sys.stderr)
    return path


def take_screenshots(out_dir: Path) -> list[Path]:
    """Run a simulated session through the GUI and write ``setup.png`` … ``diagnose-film.png`` into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    app = QApplication.instance() or QApplication(sys.argv[:1])
    scratch = Path(tempfile.mkdtemp(prefix="gasfilm-screenshots-"))
    window = MainWindow(QSettings(str(scratch / "settings.ini"), QSettings.Format.IniFormat), scratch)
    window.resize(*DEFAULT_WINDOW_SIZE)  # what a technician sees at start: nothing may be cut off at this size
    window.show()
    controller = window.controller
    design_spec = scratch / "design-rig.toml"
    true_spec = scratch / "true-rig.toml"
    RigSpec.nominal("FOMGF").save(design_spec)
    RigSpec.nominal("FOMGF").with_effects(HIDDEN_MODE).save(true_spec)
    state = window.setup_tab.state()
    state.device = "sim"
    state.rig_spec_path = str(true_spec)
    state.sample_rate_hz = 51200.0 / 4
    state.trigger = {**state.trigger, "record_s": 1.0, "pretrigger_s": 0.01, "level_n": 20.0}
    state.live_view_s = 3.0
    window.setup_tab.set_state(state)
    written = [_save(window, window.setup_tab, out_dir / "setup.png", app)]

    controller.start_hit_check()  # the technician's trial taps before the test (nothing is recorded)
    _wait_until(app, lambda: controller.state == "armed", 20, "the hit check to stream")
    _settle(app, 0.5)
    for number in range(3):
        controller.virtual_hit("soft")
        _wait_until(app, lambda n=number: len(controller.taps) == n + 1, 20, f"tap {number + 1}")
        _settle(app, 0.3)
    written.append(_save(window, window.measure_tab, out_dir / "measure-hit-check.png", app))
    controller.stop()
    _wait_until(app, lambda: controller.state == "idle", 20, "the hit check to stop")
    window.measure_tab.hit_views.setCurrentIndex(0)

    controller.new_session(scratch / "session.h5")
    controller.arm()
    _wait_until(app, lambda: controller.state == "armed", 20, "the simulated device to stream")
    _settle(app, 0.5)
    for number in range(HITS):
        controller.virtual_hit(TIPS[number % len(TIPS)])
        _wait_until(app, lambda n=number: len(controller.hits) == n + 1, 20, f"hit {number + 1}")
        if number == REJECTED_HIT:
            controller.decide(controller.hits[-1].index, False)
        _settle(app, 0.4)
    controller.virtual_hit("medium")
    _settle(app, 0.35)
    written.append(_save(window, window.measure_tab, out_dir / "measure.png", app))
    measure = window.measure_tab
    measure.hit_views.setCurrentIndex(1)
    written.append(_save(window, measure, out_dir / "measure-force-spectrum.png", app))
    measure.hit_views.setCurrentIndex(2)
    written.append(_save(window, measure, out_dir / "measure-overlay.png", app))
    measure.hit_views.setCurrentIndex(0)
    controller.stop()
    _wait_until(app, lambda: controller.state == "idle", 20, "the acquisition to stop")
    written.append(_save(window, window.frf_tab, out_dir / "frf.png", app))

    window.identify_tab.set_selected_models(list(PAPER_MODEL_ORDER))
    window.identify_tab.run_fits()
    _wait_until(app, lambda: not controller.job_active("fit"), 300, "the fits")
    written.append(_save(window, window.identify_tab, out_dir / "identify.png", app))
    window.identify_tab.figures.setCurrentIndex(1)
    written.append(_save(window, window.identify_tab, out_dir / "identify-errors.png", app))

    window.diagnose_tab.reference_path.setText(str(design_spec))
    controller.run_diagnosis(str(design_spec))
    _wait_until(app, lambda: not controller.job_active("diagnose"), 300, "the diagnosis")
    written.append(_save(window, window.diagnose_tab, out_dir / "diagnose.png", app))
    window.diagnose_tab.views.setCurrentIndex(1)  # the film's K(ω) and C(ω) against the spec's
    written.append(_save(window, window.diagnose_tab, out_dir / "diagnose-film.png", app))
    window.diagnose_tab.views.setCurrentIndex(0)
    failures = [text for severity, text in window.banner.history if severity == "error"]
    controller.shutdown()
    window.close()
    if failures:
        raise RuntimeError("screenshots: the session reported errors: " + " | ".join(failures))
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"folder for the PNGs (default {DEFAULT_OUT})")
    args = parser.parse_args(argv)
    take_screenshots(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
