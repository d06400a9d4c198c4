"""What a hammer-test engineer expects at the rig (issue 32): keys for every step of a hit, a hit check before the
test, windows drawn on the trace, cursor read-outs, dB or linear magnitude, Hv and the overlay of other sessions'
FRFs — driven like a technician would (pytest-qt, offscreen, the simulated rig)."""

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QKeySequence

from gasfilm.app.gui.measure_tab import SHORTCUTS
from gasfilm.app.gui.settings import SetupState
from gui_driving import arm, configure, hit, open_window, stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    main.activateWindow()
    yield main
    main.controller.shutdown()


def _key(qtbot, window, name: str) -> None:
    """Press the key of the Measure menu's action ``name`` on the window, as a technician (or a foot switch) does."""
    sequence = QKeySequence(SHORTCUTS[name])
    combination = sequence[0]
    qtbot.keyClick(window.tabs.currentWidget(), combination.key(), combination.keyboardModifiers())


def test_every_step_of_a_hit_has_a_key_shown_in_the_menu_and_the_buttons_tooltip(window):
    assert SetupState().auto_accept  # a hit that passes every check is accepted without a key: on by default
    menu = window.measure_menu
    shown = {action.objectName(): action.shortcut().toString() for action in menu.actions() if action.objectName()}
    assert shown == {f"{name}_action": QKeySequence(key).toString() for name, key in SHORTCUTS.items()}
    tab = window.measure_tab
    for button, name in ((tab.hit_check_button, "hit_check"), (tab.arm_button, "arm"), (tab.stop_button, "stop"), (tab.accept_button, "accept"),
                         (tab.reject_button, "reject"), (tab.accept_pending_button, "accept_pending")):
        assert f"({QKeySequence(SHORTCUTS[name]).toString()})" in button.toolTip()


def test_a_technician_arms_accepts_rejects_undoes_and_stops_with_keys_alone(qtbot, window):
    window.setup_tab.auto_accept.setChecked(False)  # every hit waits for a key
    controller = window.controller
    window.tabs.setCurrentWidget(window.setup_tab)
    _key(qtbot, window, "arm")
    qtbot.waitUntil(lambda: controller.state == "armed", timeout=10_000)
    assert window.tabs.currentWidget() is window.measure_tab
    for _ in range(3):
        hit(qtbot, window)
    assert controller.pending_count == 3
    window.measure_tab.select_hit(controller.hits[2].index)  # the technician looks at the newest hit ...
    _key(qtbot, window, "accept")  # ... accepts it: the selected hit waits, so it is the one decided
    qtbot.waitUntil(lambda: controller.hits[2].accepted, timeout=5_000)
    _key(qtbot, window, "accept")  # then the oldest waiting hit
    qtbot.waitUntil(lambda: controller.hits[0].accepted, timeout=5_000)
    _key(qtbot, window, "reject")
    qtbot.waitUntil(lambda: not controller.hits[1].pending, timeout=5_000)
    assert not controller.hits[1].accepted and controller.pending_count == 0
    _key(qtbot, window, "undo")  # the newest accepted hit leaves the average
    qtbot.waitUntil(lambda: not controller.hits[2].accepted, timeout=5_000)
    qtbot.waitUntil(lambda: controller.frf is not None and controller.frf.n_averages == 1, timeout=5_000)
    _key(qtbot, window, "stop")
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    verdicts = [entry.verdict.accepted for entry in controller.hits]
    assert verdicts == [True, False, False]


def test_a_hit_check_records_nothing_and_its_proposal_is_applied_with_one_click(qtbot, window, tmp_path):
    controller = window.controller
    window.setup_tab.sim_tip.setCurrentText("soft")  # too soft for the band to 1000 Hz
    _key(qtbot, window, "hit_check")
    qtbot.waitUntil(lambda: controller.state == "armed", timeout=10_000)
    assert controller.hit_checking and "nothing is recorded" in window.session_label.text()
    assert "HIT CHECK" in window.measure_tab.state_label.text()
    assert window.measure_tab.hit_views.currentWidget() is window.measure_tab.hit_check_page
    for number in range(3):
        qtbot.mouseClick(window.measure_tab.hammer_buttons["soft"], Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: len(controller.taps) == number + 1, timeout=10_000)
    proposal = controller.hit_check_proposal
    assert proposal is not None and proposal.taps == 3 and proposal.tip == "medium"
    assert window.measure_tab.proposal_label.toPlainText() == proposal.text()
    assert not window.measure_tab.hit_table.isVisible()  # the empty hit list gives its room to the taps
    assert len(window.measure_tab.tap_pulse_plot.getPlotItem().listDataItems()) == 3
    assert controller.hits == [] and controller.session is None  # nothing recorded ...
    assert not (tmp_path / "sessions").exists() or not any((tmp_path / "sessions").iterdir())  # ... nowhere
    qtbot.mouseClick(window.measure_tab.apply_proposal_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    state = window.setup_tab.state()
    assert state.trigger["level_n"] == proposal.trigger_level_n and state.trigger["record_s"] == proposal.record_s
    assert state.window["force_window_ms"] == proposal.force_window_ms
    assert state.window["exponential_end_fraction"] == proposal.exponential_end_fraction
    assert state.sim_tip == "medium" and controller.setup.sim_tip == "medium"
    assert "hit check applied" in window.banner.history[-1][1]
    # the test proper then records as usual, its hits shown (not the check's taps), the proposal no longer offered
    arm(qtbot, window)
    assert window.measure_tab.hit_views.currentWidget() is window.measure_tab.hit_plot
    assert not window.measure_tab.apply_proposal_button.isEnabled()
    hit(qtbot, window)
    stop(qtbot, window)
    assert len(controller.hits) == 1 and controller.session_path.exists()


def test_windows_dragged_on_the_trace_set_the_windows_and_the_frf_follows(qtbot, window):
    from gasfilm.analysis.spectra import WindowSettings, session_frf

    controller = window.controller
    arm(qtbot, window)
    for _ in range(3):
        hit(qtbot, window)
    stop(qtbot, window)
    tab = window.measure_tab
    entry = controller.hits[1]
    tab.select_hit(entry.index)
    record = entry.record
    peak_s = int(np.argmax(np.abs(record.force_n))) / record.sample_rate_hz
    assert tab.force_window_line.isVisible() and "off" in tab.force_window_line.label.format  # windows off
    tab.force_window_line.setValue(peak_s + 3e-3)  # as a drag does
    qtbot.waitUntil(lambda: window.setup_tab.state().window["force_window_ms"] is not None, timeout=5_000)
    assert window.setup_tab.state().window["force_window_ms"] == pytest.approx(3.0, abs=0.01)
    length_s = (record.n_samples - 1) / record.sample_rate_hz
    assert tab.exp_window_line.scene() is None  # the exponential window is off: no cursor says it is applied
    configure(window, window={**window.setup_tab.state().window, "exponential_end_fraction": 0.01})  # Setup: on
    assert tab.exp_window_line.scene() is not None and tab.exp_window_line.isVisible()
    tab.exp_window_line.setValue(0.1)  # τ = 0.1 s: the window ends at exp(-length/τ)
    qtbot.waitUntil(lambda: window.setup_tab.state().window["exponential_end_fraction"] != 0.01, timeout=5_000)
    end = window.setup_tab.state().window["exponential_end_fraction"]
    assert end == pytest.approx(np.exp(-length_s / 0.1), rel=1e-2)
    window_now = WindowSettings(force_window_ms=3.0, exponential_end_fraction=end)
    expected = session_frf([e.record for e in controller.hits if e.accepted], window_now)
    np.testing.assert_allclose(controller.frf.h1, expected.h1, rtol=1e-9)  # the FRF followed the drag at once
    shown = np.concatenate((tab.h1_curve.yData, tab.h1_outside_curve.yData))
    np.testing.assert_allclose(shown, np.abs(expected.h1[expected.freq_hz > 0]) / 9.80665, rtol=1e-9)
    assert "τ 0.1 s" in tab.exp_window_line.label.format
    # the window shapes are drawn on the trace
    assert np.max(tab.force_window_curve.yData) > 0 and tab.exp_window_curve.yData[-1] < tab.exp_window_curve.yData[0]


def test_every_plot_reads_out_the_point_under_the_cursor_in_its_units(qtbot, window):
    from PySide6.QtCore import QPointF

    item = window.frf_tab.magnitude_plot.getPlotItem()  # log |H| against linear frequency
    window.tabs.setCurrentWidget(window.frf_tab)
    item.vb.setRange(xRange=(100, 300), yRange=(-2, 0), padding=0)
    qtbot.wait(50)
    scene_pos = item.vb.mapViewToScene(QPointF(200.0, np.log10(0.05)))
    item.show_readout(scene_pos)
    assert item.readout.isVisible()
    assert item.readout.textItem.toPlainText() == "Frequency 200 Hz, |H| 0.05 g/N"
    item.show_readout(item.vb.sceneBoundingRect().bottomRight() + QPointF(50, 50))  # outside the view: hidden
    assert not item.readout.isVisible()
    live = window.measure_tab.force_plot.getPlotItem()
    assert live.readout_text(-0.5, 12.0) == "Time before now -0.5 s, Force 12 N"


def test_every_plot_has_its_right_click_menu_built_when_first_asked_for(qtbot, window):
    """pyqtgraph's view menu (View All, each axis's range, mouse mode, export) is there on every plot, built on the
    first right click rather than with the window."""
    item = window.frf_tab.magnitude_plot.getPlotItem()
    assert item.vb.menu is None and item.vb.menuEnabled()
    names = [action.text() for action in item.vb.getContextMenus(None)]
    assert "View All" in names and "Mouse Mode" in names, names
    assert item.vb.getMenu(None) is item.vb.menu is not None
    item.vb.setMenuEnabled(False)
    assert item.vb.getContextMenus(None) == []


def test_magnitude_in_db_or_linear_and_hv_beside_h1_and_h2(qtbot, window):
    controller = window.controller
    arm(qtbot, window)
    for _ in range(2):
        hit(qtbot, window)
    stop(qtbot, window)
    tab = window.frf_tab
    window.tabs.setCurrentWidget(tab)
    frf = controller.frf
    keep = frf.freq_hz > 0
    tab.scale_combo.setCurrentText("dB")
    shown = np.concatenate((tab.h1_curve.yData, tab.h1_outside_curve.yData))
    np.testing.assert_allclose(shown, 20 * np.log10(np.abs(frf.h1[keep]) / 9.80665), rtol=1e-12)
    assert not tab.magnitude_plot.getPlotItem().vb.state["logMode"][1]
    assert tab.magnitude_plot.getPlotItem().getAxis("left").labelUnits == "dB re 1 g/N"
    np.testing.assert_allclose(tab.hv_curve.yData, 20 * np.log10(np.abs(frf.hv[keep]) / 9.80665), rtol=1e-12)
    tab.scale_combo.setCurrentText("linear")
    np.testing.assert_allclose(tab.h2_curve.yData, np.abs(frf.h2[keep]) / 9.80665, rtol=1e-12)
    assert not tab.magnitude_plot.getPlotItem().vb.state["logMode"][1]
    tab.scale_combo.setCurrentText("log")
    assert tab.magnitude_plot.getPlotItem().vb.state["logMode"][1]


def test_other_sessions_frfs_are_drawn_over_this_one_named_with_their_conditions(qtbot, window, tmp_path):
    from gasfilm.analysis.session import Session
    from gasfilm.app.cli import main
    from test_cli_acquire_replay import FAST_SIM

    paths = []
    for pressure in ("0.4", "0.5"):
        path = tmp_path / f"p{pressure}.h5"
        assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "2",
                     "--condition", f"supply_pressure_mpa={pressure}"]) == 0
        paths.append(path)
    window.tabs.setCurrentWidget(window.frf_tab)
    assert window.controller.add_comparisons([*paths, tmp_path / "nosuch.h5"]) == 2
    assert "nosuch.h5" in window.banner.history[-1][1]  # a bad file is one banner line, the others still drawn
    tab = window.frf_tab
    names = [curve.name() for curve in tab._comparison_curves]
    assert names[0] == "p0.4 (supply_pressure_mpa = 0.4 MPa)" and names[2] == "p0.5 (supply_pressure_mpa = 0.5 MPa)"
    with Session.open(paths[1], "r") as session:
        stored = session.read_frf()
    np.testing.assert_allclose(tab._comparison_curves[2].yData, np.abs(stored.h1[stored.freq_hz > 0]) / 9.80665)
    assert tab.clear_compare_button.isEnabled()
    qtbot.mouseClick(tab.clear_compare_button, Qt.MouseButton.LeftButton)
    assert tab._comparison_curves == [] and not tab.clear_compare_button.isEnabled()


def test_operator_test_object_and_sensors_with_serials_and_calibration_dates_reach_the_session_and_report(
        qtbot, window, tmp_path, monkeypatch):
    import gasfilm.drivers as drivers
    from gasfilm.analysis.report import write_report
    from gasfilm.analysis.session import Session
    from gasfilm.drivers.interface import TedsSensor

    setup = window.setup_tab
    setup.operator.setText("A. Technician")
    setup.operator.editingFinished.emit()
    setup.test_object.setText("bearing B-17 on mover M2")
    setup.test_object.editingFinished.emit()
    hammer = setup.channel_cell(0, "Sensor")
    hammer.setCurrentIndex(hammer.findData("PCB 086C02 s/n LW41203"))  # the lab's own hammer, from the library
    row = setup.state().channels[0]
    assert (row.sensitivity, row.serial, row.calibration_date) == (11.42, "LW41203", "2026-03-02")
    # the accelerometer has a TEDS chip, read through the NI 9234 (here: the driver's answer stands in for it)
    monkeypatch.setattr(drivers, "read_teds", lambda device, channels: {
        "ai0": None, "ai1": TedsSensor(12, 35201, 77001, "2A", 100.7, "mV/g")})
    qtbot.mouseClick(setup.teds_button, Qt.MouseButton.LeftButton)
    accelerometer = setup.state().channels[1]
    assert (accelerometer.sensitivity, accelerometer.units, accelerometer.serial) == (100.7, "mV/g", "77001")
    assert "serial 77001" in accelerometer.teds and "ai0 no TEDS" in window.banner.history[-1][1]
    setup.channel_cell(1, "Calibrated").setText("2025-13-40")
    setup.channel_cell(1, "Calibrated").editingFinished.emit()
    assert "ai1 calibration date" in setup.problem_label.text()  # a date that is none is named
    setup.channel_cell(1, "Calibrated").setText("2025-11-30")
    setup.channel_cell(1, "Calibrated").editingFinished.emit()

    path = tmp_path / "who.h5"
    window.controller.new_session(path)
    arm(qtbot, window)
    hit(qtbot, window)
    stop(qtbot, window)
    with Session.open(path, "r") as session:
        settings = session.settings
    assert settings["test"] == {"operator": "A. Technician", "test_object": "bearing B-17 on mover M2"}
    by_channel = {entry["channel"]: entry for entry in settings["sensors"]}
    assert by_channel["ai0"]["serial"] == "LW41203" and by_channel["ai0"]["calibration_date"] == "2026-03-02"
    assert by_channel["ai1"]["calibration_date"] == "2025-11-30" and "TEDS: manufacturer 12" in by_channel["ai1"]["teds"]
    report = write_report(path, tmp_path / "who.html").read_text(encoding="utf-8")
    for text in ("A. Technician", "bearing B-17 on mover M2", "LW41203", "2026-03-02", "77001", "2025-11-30",
                 "TEDS: manufacturer 12, model 35201"):
        assert text in report, text
