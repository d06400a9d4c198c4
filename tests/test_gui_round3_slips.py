"""The GUI slips of issue 32 item 13, seen as a technician sees them (pytest-qt, offscreen, the simulated rig)."""

import os
import warnings

import numpy as np
import pytest
from PySide6.QtCore import Qt, QTimer

from gui_driving import arm, fits_finish, hit, open_window, stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def _answer(qtbot, window, attribute: str, button_text: str) -> None:
    """Click ``button_text`` in the window's question ``attribute`` as soon as it shows."""

    def answer() -> None:
        box = getattr(window, attribute)
        if box is None:
            QTimer.singleShot(20, answer)
            return
        next(b for b in box.buttons() if b.text().replace("&", "") == button_text).click()

    QTimer.singleShot(20, answer)


def test_a_window_starts_without_numpy_overflow_warnings(qtbot, tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        main = open_window(qtbot, tmp_path)
        qtbot.wait(100)
    main.controller.shutdown()
    assert not [w for w in caught if "overflow" in str(w.message)], [str(w.message) for w in caught]


def test_the_status_bar_names_the_new_session_and_dialogs_open_beside_it(qtbot, window, tmp_path):
    controller = window.controller
    assert window.dialog_folder() == tmp_path / "sessions"  # never the process's working directory
    assert window.proposed_path("-report.html") == tmp_path / "sessions" / "gasfilm-report.html"
    path = tmp_path / "rig" / "b17.h5"
    controller.new_session(path)
    assert window.session_label.text() == f"Session: {path} (new: the next Arm records into it)"
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    assert window.session_label.text() == f"Session: {path}"
    assert window.dialog_folder() == path.parent
    assert window.proposed_path("-report.html") == path.with_name("b17-report.html")
    # the report from the GUI gets the same mode as the command line's (the umask's), not 0600
    previous = os.umask(0o022)
    try:
        written = window.write_report(path.with_name("b17-report.html"))
    finally:
        os.umask(previous)
    assert written.stat().st_mode & 0o777 == 0o644


def test_a_stop_first_refusal_goes_once_stopped_and_quitting_while_armed_asks(qtbot, window):
    controller = window.controller
    arm(qtbot, window)
    hit(qtbot, window)
    controller.run_fits(["SD"], "default", (20.0, 1000.0))
    assert window.banner.isVisible() and window.banner.text.startswith("stop the acquisition before fitting")
    stop(qtbot, window)
    assert not window.banner.isVisible()
    arm(qtbot, window)
    _answer(qtbot, window, "running_dialog", "Cancel")
    window.close()
    assert window.isVisible() and controller.acquiring  # asked, and staying was chosen
    _answer(qtbot, window, "running_dialog", "Stop and quit")
    window.close()
    qtbot.waitUntil(lambda: not window.isVisible(), timeout=10_000)
    assert not controller.acquiring and len(controller.hits) == 1


def test_hand_verdicts_read_by_hand_and_mixed_tips_are_warned(qtbot, window):
    controller, tab = window.controller, window.measure_tab
    arm(qtbot, window)
    hit(qtbot, window, "hard")
    hit(qtbot, window, "hard")
    assert not tab.mixed_tips_warning
    hit(qtbot, window, "soft")  # a 2 ms pulse among 0.25 ms ones
    stop(qtbot, window)
    assert "mixed tips" in tab.mixed_tips_warning and "mixed tips" in tab.overlay_force_plot.getPlotItem().titleLabel.text
    assert any("mixed tips" in text for _, text in window.banner.history)
    tab.select_hit(controller.hits[2].index)
    qtbot.mouseClick(tab.reject_button, Qt.MouseButton.LeftButton)
    assert tab.hit_table.item(2, 3).text() == "rejected (by hand)"
    assert not tab.mixed_tips_warning  # the odd hit out, the average is of one tip again


def test_table2_marks_the_lowest_bic_and_the_parameters_at_a_bound_and_shows_every_parameter(qtbot, window):
    controller, tab = window.controller, window.identify_tab
    arm(qtbot, window)
    for _ in range(3):
        hit(qtbot, window)
    stop(qtbot, window)
    window.tabs.setCurrentWidget(tab)
    tab.set_selected_models(["SD", "FOMGF", "FOBGF"])
    qtbot.mouseClick(tab.run_button, Qt.MouseButton.LeftButton)
    fits_finish(qtbot, window, 3)
    header = [tab.table.horizontalHeaderItem(c).text().replace("\n", " ") for c in range(tab.table.columnCount())]
    assert header[2] == "Parameters" and header[9] == "At bound" and header[10] == "Hits"
    bic = [tab.table.item(r, 8).text() for r in range(3)]
    assert sum(text.endswith(" *") for text in bic) == 1
    from gasfilm.analysis.identification import best_by_bic

    best = best_by_bic(controller.comparison).model_name
    assert tab.table.item(bic.index(next(t for t in bic if t.endswith("*"))), 1).text() == best
    for r in range(3):
        fit = controller.fits[tab.table.item(r, 1).text()]
        assert tab.table.item(r, 9).text() == (", ".join(fit.at_bound) or "—")
    row = next(r for r in range(3) if tab.table.item(r, 1).text() == "FOBGF")
    tab.table.selectRow(row)
    qtbot.mouseClick(tab.control_button, Qt.MouseButton.LeftButton)  # its summary must not squeeze the table
    qtbot.wait(50)
    parameters = tab.parameters
    shown = parameters.viewport().height() // parameters.rowHeight(0)
    assert parameters.rowCount() == len(controller.fits["FOBGF"].params) and shown >= parameters.rowCount()


def test_the_banner_and_the_diagnose_tab_give_one_time_for_the_diagnosis(qtbot, window):
    import re

    controller = window.controller
    arm(qtbot, window)
    for _ in range(3):
        hit(qtbot, window)
    stop(qtbot, window)
    window.tabs.setCurrentWidget(window.diagnose_tab)
    qtbot.mouseClick(window.diagnose_tab.run_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not controller.job_active("diagnose") and controller.diagnosis is not None,
                    timeout=90_000)
    banner = next(text for _, text in reversed(window.banner.history) if text.startswith("diagnosis finished"))
    said = re.search(r"finished in ([0-9.]+) s", banner).group(1)
    assert window.diagnose_tab.summary.text().endswith(f"hits, {said} s")


def test_the_gui_diagnosis_writes_where_the_command_does_and_asks_before_replacing(qtbot, window, tmp_path):
    from gasfilm.app.cli import main
    from test_cli_acquire_replay import FAST_SIM

    path = tmp_path / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "3"]) == 0
    assert main(["diagnose", str(path)]) == 0
    earlier = (tmp_path / "run-diagnosis" / "improved-rig.toml").read_text()
    controller = window.controller
    controller.open_session(path)
    asked = []
    controller.run_diagnosis(None, lambda folder, names: asked.append((folder, names)) or False)
    assert asked and asked[0][0] == tmp_path / "run-diagnosis" and "improved-rig.toml" in asked[0][1]
    assert not controller.job_active("diagnose") and "are kept" in window.banner.history[-1][1]
    assert (tmp_path / "run-diagnosis" / "improved-rig.toml").read_text() == earlier


def test_every_tab_fits_the_windows_default_size(qtbot, window):
    """New-user trial of issue 32: the new controls (FRF tab's |H| scale and comparison, the sensors' serial and
    calibration date, Table 2's heading) widened the window past its default 1500 px: the Setup tab was cut off."""
    from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE

    for tab in (window.setup_tab, window.measure_tab, window.frf_tab, window.identify_tab, window.diagnose_tab):
        assert tab.minimumSizeHint().width() <= DEFAULT_WINDOW_SIZE[0] - 24, type(tab).__name__
    assert window.minimumSizeHint().width() <= DEFAULT_WINDOW_SIZE[0]
