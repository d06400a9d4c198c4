"""The technician's GUI driven like a person would, on the simulated rig (Qt offscreen, pytest-qt)."""

import time

import numpy as np
import pytest
from PySide6.QtCore import Qt

from gasfilm.analysis.session import Session
from gasfilm.app.gui.main_window import MainWindow
from gasfilm.app.gui.sensors import DEFAULT_SENSOR_LIBRARY, load_sensor_library
from gasfilm.app.gui.settings import load_setup
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import ChannelKind
from gui_driving import arm as _arm
from gui_driving import fits_finish
from gui_driving import gui_settings as _settings
from gui_driving import hit as _hit
from gui_driving import SAMPLE_RATE_HZ, SIM_SPEED, open_window
from gui_driving import stop as _stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def test_full_hammer_session_through_the_gui(qtbot, window, tmp_path):
    controller = window.controller
    session_path = tmp_path / "hammer.h5"
    controller.new_session(session_path)
    _arm(qtbot, window)
    armed_at = time.monotonic()
    assert window.measure_tab.hammer_box.isVisible() and window.measure_tab.hammer_box.isEnabled()
    qtbot.waitUntil(lambda: window.measure_tab.redraw_count > 3, timeout=5_000)  # the live view draws

    for number in range(6):
        _hit(qtbot, window, ("soft", "medium", "hard")[number % 3] if number else "medium")
        if number == 2:
            rejected_index = controller.hits[-1].index
            window.measure_tab.select_hit(rejected_index)
            qtbot.mouseClick(window.measure_tab.reject_button, Qt.MouseButton.LeftButton)
            qtbot.waitUntil(lambda: not controller.hits[rejected_index].verdict.accepted, timeout=5_000)
    assert len(controller.hits) == 6
    assert all(entry.automatic.accepted for entry in controller.hits), [e.automatic for e in controller.hits]
    qtbot.waitUntil(lambda: controller.frf is not None and controller.frf.n_averages == 5, timeout=5_000)
    assert "accepted 5" in window.measure_tab.counter_label.text()
    assert "rejected 1" in window.measure_tab.counter_label.text()
    streamed_s, elapsed_s = controller.acquisition_stats.samples_read / SAMPLE_RATE_HZ, time.monotonic() - armed_at
    _stop(qtbot, window)
    # the simulator streamed at the Setup tab's speed, SIM_SPEED times real time (at real time: below 1.3 times)
    assert streamed_s > SIM_SPEED / 2 * elapsed_s, (streamed_s, elapsed_s)

    # FRF and coherence shown
    window.tabs.setCurrentWidget(window.frf_tab)
    frf = controller.frf
    inside, outside = window.frf_tab.h1_curve, window.frf_tab.h1_outside_curve  # outside: grey, force too low
    shown_magnitude = np.concatenate((inside.yData, outside.yData))
    np.testing.assert_allclose(shown_magnitude, np.abs(frf.h1[frf.freq_hz > 0]) / 9.80665)  # g/N, as every tab
    measure_h1 = window.measure_tab.h1_curve, window.measure_tab.h1_outside_curve
    np.testing.assert_allclose(np.concatenate([curve.yData for curve in measure_h1]), shown_magnitude)
    shown_freq, shown_coherence = window.frf_tab.coherence_curve.xData, window.frf_tab.coherence_curve.yData
    band = (shown_freq >= 20) & (shown_freq <= 800)
    assert np.mean(shown_coherence[band]) > 0.9

    # identification of SD and FOMGF in the background
    window.tabs.setCurrentWidget(window.identify_tab)
    window.identify_tab.set_selected_models(["SD", "FOMGF"])
    qtbot.mouseClick(window.identify_tab.run_button, Qt.MouseButton.LeftButton)
    fits_finish(qtbot, window, 2)
    assert window.identify_tab.table.rowCount() == 2
    assert window.identify_tab.table.item(0, 1).text() == "FOMGF"  # the simulated film is the paper's FOMGF

    # diagnosis against the session's rig spec
    window.tabs.setCurrentWidget(window.diagnose_tab)
    qtbot.mouseClick(window.diagnose_tab.run_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not controller.job_active("diagnose"), timeout=60_000)
    assert controller.diagnosis is not None, window.banner.history
    notes_header = "".join(f"# {note}\n" for note in controller.diagnosis.notes)  # the spec file opens with them
    assert window.diagnose_tab.findings.count() >= 1
    shown_findings = [window.diagnose_tab.findings.item(i).text() for i in range(window.diagnose_tab.findings.count())]
    # the film's restoring force is shown beside the overlay, one scatter per hit and the linear film's line
    assert controller.diagnosis.restoring_force is not None
    assert len(window.diagnose_tab.restoring_stiffness_plot.getPlotItem().listDataItems()) >= 2
    assert "restoring force" in window.diagnose_tab.restoring_label.text()

    # save; then play the improved spec on the simulated rig (a new session)
    shown_h1 = frf.h1.copy()
    shown_coherence_all = frf.coherence.copy()
    assert controller.save_session() == session_path
    report = window.write_report(tmp_path / "hammer-report.html").read_text(encoding="utf-8")
    assert "Verdict: <b>" in report and controller.diagnosis.verdict in report and "<td>FOMGF</td>" in report
    assert window.diagnose_tab.play_button.isEnabled()
    qtbot.mouseClick(window.diagnose_tab.play_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: controller.state == "armed", timeout=10_000)
    assert controller.session_path != session_path
    # the improved spec plays in the new session only: the Setup tab and the saved setup keep their rig spec (issue 10.7)
    improved = (session_path.parent / f"{session_path.stem}-improved-rig.toml").read_text()
    assert improved.startswith(notes_header)
    assert controller.session.rig_spec_toml == improved[len(notes_header):]
    assert controller.setup.rig_spec_path == window.setup_tab.state().rig_spec_path == ""
    assert load_setup(window.settings)[0].rig_spec_path == ""
    _hit(qtbot, window)
    _stop(qtbot, window)

    # reopen: the FRF is the one shown before saving
    controller.open_session(session_path)
    np.testing.assert_array_equal(controller.frf.h1, shown_h1)
    np.testing.assert_array_equal(controller.frf.coherence, shown_coherence_all)
    assert set(controller.fits) == {"SD", "FOMGF"}
    assert [entry.verdict.accepted for entry in controller.hits].count(False) == 1
    assert controller.hits[rejected_index].verdict.overridden
    # and the diagnosis tab shows the stored findings again
    tab = window.diagnose_tab
    assert [tab.findings.item(i).text() for i in range(tab.findings.count())] == shown_findings
    assert "stored" in tab.summary.text() and "Stored diagnosis" in tab.status.text()


def test_device_fault_shows_banner_and_keeps_every_accepted_hit(qtbot, window, tmp_path):
    controller = window.controller
    session_path = tmp_path / "fault.h5"
    controller.new_session(session_path)
    _arm(qtbot, window)
    for _ in range(3):
        _hit(qtbot, window)
    accepted = controller.accepted_count
    assert accepted == 3
    controller.inject_fault("device_removed")
    qtbot.waitUntil(lambda: window.banner.isVisible() and window.banner.severity == "error", timeout=10_000)
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    assert "removed" in window.banner.text
    assert not window.banner.isWindow()  # non-modal: a strip inside the main window
    assert window.measure_tab.arm_button.isEnabled()
    with Session.open(session_path) as stored:
        assert len(stored.accepted_indices()) == accepted


@pytest.mark.parametrize("kind, words", [("overflow", "overflow"), ("open_sensor", "open IEPE sensor")])
def test_other_device_faults_reach_the_banner(qtbot, window, tmp_path, kind, words):
    controller = window.controller
    controller.new_session(tmp_path / f"{kind}.h5")
    _arm(qtbot, window)
    _hit(qtbot, window)
    controller.inject_fault(kind)
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    assert window.banner.severity == "error" and words in window.banner.text
    with Session.open(tmp_path / f"{kind}.h5") as stored:
        assert len(stored.accepted_indices()) == 1


@pytest.mark.filterwarnings("ignore::drivers.errors.ADCOverloadWarning")  # the simulator warns as DAQmx does
def test_overload_rejects_the_clipped_hit_and_warns(qtbot, window, tmp_path):
    controller = window.controller
    controller.new_session(tmp_path / "overload.h5")
    _arm(qtbot, window)
    controller.inject_fault("overload")
    _hit(qtbot, window)
    entry = controller.hits[0]
    assert not entry.verdict.accepted and "overload" in entry.automatic.reasons
    qtbot.waitUntil(lambda: window.banner.isVisible(), timeout=5_000)
    assert window.banner.severity == "warning" and "overload" in window.banner.text
    assert controller.state == "armed"  # an overload taints one hit; acquisition goes on
    _stop(qtbot, window)


def test_user_decides_pending_hits_when_auto_accept_is_off(qtbot, window, tmp_path):
    state = window.setup_tab.state()
    state.auto_accept = False
    window.setup_tab.set_state(state)
    controller = window.controller
    controller.new_session(tmp_path / "manual.h5")
    _arm(qtbot, window)
    _hit(qtbot, window)
    entry = controller.hits[0]
    assert entry.pending and controller.frf is None
    assert "waiting for you 1" in window.measure_tab.counter_label.text()
    qtbot.mouseClick(window.measure_tab.accept_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: controller.frf is not None, timeout=5_000)
    assert controller.hits[0].accepted and not controller.hits[0].pending
    _stop(qtbot, window)


def test_setup_is_remembered_between_runs(qtbot, tmp_path):
    first = MainWindow(_settings(tmp_path), session_dir=tmp_path)
    qtbot.addWidget(first)
    state = first.setup_tab.state()
    state.sample_rate_hz = 51200.0 / 8
    state.trigger = {**state.trigger, "level_n": 35.0}
    state.channels[2].enabled = True
    state.channels[2].sensor_model = "PCB 352C33"
    state.channels[2].sensitivity = 100.0
    state.channels[2].units = "mV/g"
    state.response_channel = "ai2"
    state.sim_speed = 2.5
    first.setup_tab.set_state(state)
    first.close()
    second = MainWindow(_settings(tmp_path), session_dir=tmp_path)
    qtbot.addWidget(second)
    remembered = second.setup_tab.state()
    assert remembered.sample_rate_hz == 51200.0 / 8
    assert remembered.trigger["level_n"] == 35.0
    assert remembered.channels[2].enabled and remembered.channels[2].sensor_model == "PCB 352C33"
    assert remembered.response_channel == "ai2" and remembered.sim_speed == 2.5
    assert load_setup(_settings(tmp_path)) == (remembered, "")
    second.close()


def test_sensor_picked_from_library_sets_sensitivity_and_invalid_setup_is_named(qtbot, window):
    tab = window.setup_tab
    sensor_combo = tab.channel_cell(0, "Sensor")
    sensor_combo.setCurrentIndex(sensor_combo.findData("PCB 086C03"))
    assert tab.state().channels[0].sensitivity == 2.25
    trigger = tab.trigger_form.values()
    tab.trigger_form.set_values({**trigger, "pretrigger_s": 2.0})
    tab.trigger_form.changed.emit()
    assert "pretrigger_s" in tab.problem_label.text()
    tab.trigger_form.set_values(trigger)
    coupling = tab.channel_cell(1, "Coupling")
    coupling.setCurrentText("DC")
    assert "coupling" in tab.problem_label.text() and "IEPE" in tab.problem_label.text()
    qtbot.mouseClick(window.measure_tab.arm_button, Qt.MouseButton.LeftButton)
    assert window.banner.isVisible() and "coupling" in window.banner.text
    assert window.controller.state == "idle"


def test_sensor_library_holds_the_papers_sensors_and_rejects_bad_files(tmp_path):
    sensors = {sensor.key: sensor for sensor in load_sensor_library(DEFAULT_SENSOR_LIBRARY)}
    hammer, accelerometer = sensors["PCB 086C02"], sensors["PCB 352B"]
    calibrated = sensors["PCB 352B s/n LW210001"]  # one calibrated sensor, named by its serial number
    assert (calibrated.model, calibrated.serial, calibrated.sensitivity) == ("PCB 352B", "LW210001", 10.31)
    assert (hammer.kind, hammer.sensitivity, hammer.units) == (ChannelKind.FORCE, 11.2, "mV/N")
    assert (accelerometer.kind, accelerometer.sensitivity, accelerometer.units) == (
        ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)"
    )
    bad = tmp_path / "bad.toml"
    bad.write_text('[[sensor]]\nmodel = "X"\ntype = "force"\nsensitivity = 1.0\nunits = "mV/g"\n')
    with pytest.raises(SettingError) as caught:
        load_sensor_library(bad)
    assert "bad.toml" in str(caught.value) and "units" in str(caught.value) and "\n" not in str(caught.value)


def _record(qtbot, window, path, hits: int) -> None:
    window.controller.new_session(path)
    _arm(qtbot, window)
    for _ in range(hits):
        _hit(qtbot, window)
    _stop(qtbot, window)


def test_exports_of_the_frf(qtbot, window, tmp_path):
    controller = window.controller
    _record(qtbot, window, tmp_path / "export.h5", 2)
    csv = controller.export_csv(tmp_path / "frf.csv")
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 1] + 1j * table[:, 2], controller.frf.h1)
    uff = controller.export_uff(tmp_path / "frf.uff")
    assert uff.stat().st_size > 0
    window.tabs.setCurrentWidget(window.frf_tab)
    png = window.export_png(tmp_path / "frf.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_replay_with_other_validation_settings(qtbot, window, tmp_path):
    controller = window.controller
    _record(qtbot, window, tmp_path / "replay.h5", 2)
    controller.decide(controller.hits[1].index, False)
    state = window.setup_tab.state()
    state.validation = {**state.validation, "min_force_snr": 1e12}
    window.setup_tab.set_state(state)
    controller.replay()
    assert controller.hits[0].automatic.reasons == ("force too low",)
    assert not controller.hits[0].verdict.accepted
    assert not controller.hits[1].verdict.accepted and controller.hits[1].verdict.overridden  # kept as set by hand
    assert controller.frf is None
    with Session.open(tmp_path / "replay.h5") as stored:
        assert [v.accepted for v in stored.verdicts()] == [False, False]
        assert stored.verdicts()[0].reasons == ("force too low",)


def test_fit_runs_in_the_background_and_can_be_cancelled(qtbot, window, tmp_path):
    controller = window.controller
    _record(qtbot, window, tmp_path / "cancel.h5", 2)
    window.identify_tab.set_selected_models(["FOMGF", "FOBGF", "FOTGF"])
    window.identify_tab.method_combo.setCurrentIndex(window.identify_tab.method_combo.findData("gapso"))
    qtbot.mouseClick(window.identify_tab.run_button, Qt.MouseButton.LeftButton)
    assert controller.job_active("fit") and window.identify_tab.cancel_button.isEnabled()
    qtbot.waitUntil(lambda: window.identify_tab.progress.value() > 0, timeout=20_000)
    assert window.measure_tab.arm_button.isEnabled()  # the GUI thread is free while the fit runs
    qtbot.mouseClick(window.identify_tab.cancel_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: not controller.job_active("fit"), timeout=20_000)
    assert controller.fits == {}
    assert ("info", "fit: cancelled") in window.banner.history
    assert window.identify_tab.run_button.isEnabled()


def test_switching_to_a_tab_paints_each_plot_once(qtbot, window):
    """Qt activates a plot's scene whenever its view is shown (and deactivates it when hidden); every plot item then
    repainted itself and dropped its cached axis pixmap, so a tab switch painted each plot three times, and a job's
    result waited behind that. The scenes stay active."""
    import pyqtgraph as pg
    from PySide6.QtCore import QEvent, QObject

    paints: dict[int, int] = {}

    class CountPaints(QObject):
        def eventFilter(self, viewport, event):  # noqa: N802
            if event.type() == QEvent.Type.Paint:
                paints[id(viewport)] = paints.get(id(viewport), 0) + 1
            return False

    counter = CountPaints()
    views = window.measure_tab.findChildren(pg.GraphicsView)
    assert len(views) >= 3
    for view in views:
        view.viewport().installEventFilter(counter)
    def settle() -> None:  # until the event loop has nothing more to paint (on a loaded machine it takes longer)
        for _ in range(20):
            before = sum(paints.values())
            qtbot.wait(200)
            if sum(paints.values()) == before:
                return

    window.activateWindow()
    for _ in range(2):  # (the first visit also lays the tab out)
        window.tabs.setCurrentWidget(window.identify_tab)
        settle()
        paints.clear()
        window.tabs.setCurrentWidget(window.measure_tab)
        settle()
    shown = [view for view in views if view.isVisible()]
    assert len(shown) >= 3
    assert [paints.get(id(view.viewport()), 0) for view in shown] == [1] * len(shown)
