"""Driving the GUI like a technician on the simulated rig (Qt offscreen, pytest-qt), shared by the GUI tests.

Realtime pacing at 3200 S/s with 0.5 s records, streamed at four times real time, keeps a whole hammer session within
seconds.
"""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PySide6.QtCore import QSettings, Qt

from gasfilm.app.gui.main_window import MainWindow

SAMPLE_RATE_HZ = 51200.0 / 16
RECORD_S = 0.5
#: The simulated module streams four seconds of signal a second: what these tests check (hits, verdicts, the FRF, the
#: jobs, the session) does not depend on the pace, and a hit is recorded in an eighth of a second instead of half.
SIM_SPEED = 4.0


def gui_settings(tmp_path) -> QSettings:
    return QSettings(str(tmp_path / "gui-settings.ini"), QSettings.Format.IniFormat)


def configure(main: MainWindow, **changes) -> None:
    """The simulated rig at 3200 S/s, 0.5 s records, four times real time, no windows, the hammer only when clicked;
    then ``changes``."""
    state = main.setup_tab.state()
    state.device = "sim"
    state.sample_rate_hz = SAMPLE_RATE_HZ
    state.trigger = {**state.trigger, "record_s": RECORD_S, "pretrigger_s": 0.01}
    state.window = {**state.window, "force_window_ms": None, "exponential_end_fraction": None}
    state.sim_auto_hammer = False
    state.sim_speed = SIM_SPEED
    state.auto_accept = True
    state.auto_reject = True
    for name, value in changes.items():
        setattr(state, name, value)
    main.setup_tab.set_state(state)


def open_window(qtbot, tmp_path, **changes) -> MainWindow:
    main = MainWindow(gui_settings(tmp_path), session_dir=tmp_path / "sessions")
    qtbot.addWidget(main)
    configure(main, **changes)
    main.show()
    return main


def arm(qtbot, window) -> None:
    qtbot.mouseClick(window.measure_tab.arm_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: window.controller.state == "armed", timeout=10_000)


def hit(qtbot, window, tip: str = "medium") -> None:
    controller = window.controller
    before = len(controller.hits)
    qtbot.mouseClick(window.measure_tab.hammer_buttons[tip], Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: len(controller.hits) == before + 1, timeout=10_000)


def stop(qtbot, window) -> None:
    qtbot.mouseClick(window.measure_tab.stop_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: window.controller.state == "idle", timeout=10_000)


def fits_finish(qtbot, window, models: int, timeout_ms: int = 90_000) -> None:
    """Wait for the fit job just started to end with ``models`` fits; when it does not start or ends without them,
    fail at once with what the banner says (before, a refused or failed fit looked like a fit that never ended)."""
    controller = window.controller
    assert controller.job_active("fit"), f"the fit did not start: {window.banner.text!r}"
    qtbot.waitUntil(lambda: not controller.job_active("fit"), timeout=timeout_ms)
    assert len(controller.fits) == models, f"{len(controller.fits)} of {models} fits: {window.banner.text!r}"
