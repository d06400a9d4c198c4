"""The GUI a hammer tester expects (issue 10, items 7, 9, 13, 14): sessions never mixed, pending hits never stored as
accepted, damaged settings, the layout at the default size, force spectrum, overlay and the accept rules.

Driven on the simulated rig with Qt offscreen (pytest-qt), like tests/test_gui.py.
"""

import dataclasses

import numpy as np
import pytest
from PySide6.QtCore import Qt, QTimer

from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.app.gui.main_window import DEFAULT_WINDOW_SIZE, MainWindow
from gasfilm.app.gui.sensors import load_sensor_library
from gasfilm.app.gui.settings import SETTINGS_KEY, SetupState, load_setup
from gasfilm.app.gui.workers import PENDING_REASON
from gasfilm.drivers.errors import SettingError
from gui_driving import arm as _arm
from gui_driving import configure as _configure
from gui_driving import gui_settings as _settings
from gui_driving import hit as _hit
from gui_driving import open_window
from gui_driving import stop as _stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def _answer_dialog_with(qtbot, window, button_text: str) -> list[str]:
    """Click ``button_text`` in the pending-hits question as soon as it shows (after answering "Stop and quit" to
    the question quitting while armed asks first); returns the pending-hits question's texts."""
    asked: list[str] = []

    def answer() -> None:
        running = window.running_dialog
        if running is not None:
            next(b for b in running.buttons() if b.text().replace("&", "") == "Stop and quit").click()
            QTimer.singleShot(20, answer)
            return
        box = window.pending_dialog
        if box is None:
            QTimer.singleShot(20, answer)
            return
        asked.append(box.text())
        button = next(b for b in box.buttons() if b.text().replace("&", "") == button_text)
        button.click()

    QTimer.singleShot(20, answer)
    return asked


# --- item 14: what a tester looks at ------------------------------------------------------------------------------


def test_trigger_level_force_spectrum_usable_band_and_overlay_after_hits(qtbot, window, tmp_path):
    _configure(window, sample_rate_hz=51200.0 / 4)  # wide enough a band to see the pulse's roll-off and nulls
    controller, tab = window.controller, window.measure_tab
    controller.new_session(tmp_path / "spectrum.h5")
    _arm(qtbot, window)
    assert tab.trigger_line.isVisible() and tab.trigger_line.value() == pytest.approx(20.0)
    assert tab.trigger_line.label.toPlainText() == "trigger 20 N"
    for tip in ("medium", "medium", "soft"):
        _hit(qtbot, window, tip)
    _stop(qtbot, window)

    # the selected (last) hit's force spectrum, in dB re its low-frequency level, with the usable band shaded
    level = tab.hit_spectrum_curve.yData
    assert level is not None and len(level) > 100 and abs(level[0]) < 1.0 and np.nanmin(level) < -20.0
    low, high = tab.spectrum_band.getRegion()
    assert 0 < low < 10 and 100 < high < 51200.0 / 8
    assert f"{high:.0f} Hz" in tab.spectrum_label.text()
    # the running H1 is black only inside the usable band, grey above it (the hammer's spectral nulls)
    assert tab.h1_curve.xData.max() <= tab.h1_outside_curve.xData.min()
    assert len(tab.h1_outside_curve.xData) > 0
    # the overlay holds every accepted hit's pulse and response
    assert len(tab._overlay_curves) == 2 * controller.accepted_count == 6
    assert "3 accepted hits" in tab.overlay_force_plot.getPlotItem().titleLabel.text

    # logarithmic frequency axes keep the band where it was (view coordinates are then log10 f)
    qtbot.mouseClick(tab.log_frequency, Qt.MouseButton.LeftButton)
    assert tab.h1_plot.getPlotItem().ctrl.logXCheck.isChecked()
    log_low, log_high = tab.h1_band.getRegion()
    assert 10**log_high == pytest.approx(float(tab.usable_label.text().split("–")[1].split()[0]), rel=0.01)
    window.frf_tab.log_frequency.setChecked(True)
    window.frf_tab._band_typed()
    assert 10 ** window.frf_tab.region.getRegion()[1] == pytest.approx(controller.fit_band_hz[1])


def test_coherence_rule_holds_a_hit_and_accept_all_pending_takes_it(qtbot, window, tmp_path):
    _configure(window, min_coherence=1.0)  # no real average reaches γ² = 1: the second hit must wait
    controller = window.controller
    path = tmp_path / "coherence.h5"
    controller.new_session(path)
    _arm(qtbot, window)
    _hit(qtbot, window)
    _hit(qtbot, window, "hard")
    second = controller.hits[1]
    assert controller.hits[0].accepted and second.pending
    assert any(reason.startswith("coherence") for reason in second.automatic.reasons)
    assert controller.frf.n_averages == 1
    assert window.measure_tab.accept_pending_button.isEnabled()
    qtbot.mouseClick(window.measure_tab.accept_pending_button, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: controller.pending_count == 0 and controller.frf.n_averages == 2, timeout=5_000)
    _stop(qtbot, window)
    with Session.open(path) as stored:
        assert [verdict.accepted for verdict in stored.verdicts()] == [True, True]


def test_target_averages_stop_the_acquisition(qtbot, window, tmp_path):
    _configure(window, target_averages=2)
    controller = window.controller
    controller.new_session(tmp_path / "target.h5")
    _arm(qtbot, window)
    assert "accepted 0 of 2" in window.measure_tab.counter_label.text()
    _hit(qtbot, window)
    _hit(qtbot, window)
    qtbot.waitUntil(lambda: controller.state == "idle", timeout=10_000)
    assert ("info", "target of 2 averages reached: acquisition stopped") in window.banner.history
    # Session ▸ Write a report: the same report as `gasfilm report`
    report = window.write_report(tmp_path / "target-report")
    assert report.suffix == ".html" and "Hits: 2 accepted of 2" in report.read_text(encoding="utf-8")


def test_identify_and_diagnose_are_refused_while_armed_with_a_reason(qtbot, window, tmp_path):
    controller = window.controller
    controller.new_session(tmp_path / "armed.h5")
    _arm(qtbot, window)
    _hit(qtbot, window)
    qtbot.mouseClick(window.identify_tab.run_button, Qt.MouseButton.LeftButton)
    assert not controller.job_active("fit")
    assert window.banner.severity == "warning" and "stop the acquisition before fitting" in window.banner.text
    assert "Stop the acquisition" in window.identify_tab.run_button.toolTip()
    qtbot.mouseClick(window.diagnose_tab.run_button, Qt.MouseButton.LeftButton)
    assert not controller.job_active("diagnose") and "before running the diagnosis" in window.banner.text
    _stop(qtbot, window)


# --- item 7: sessions never mixed ---------------------------------------------------------------------------------


def test_rearm_after_a_rig_change_records_a_new_session_and_hit_times_continue(qtbot, window, tmp_path):
    controller = window.controller
    first = tmp_path / "first.h5"
    controller.new_session(first)
    _arm(qtbot, window)
    _hit(qtbot, window)
    _stop(qtbot, window)
    first_end_s = controller.hits[0].record.time_s()[-1]
    _arm(qtbot, window)  # nothing changed: the same session, its time line continues
    _hit(qtbot, window)
    _stop(qtbot, window)
    assert controller.session_path == first and len(controller.hits) == 2
    assert controller.hits[1].record.start_time_s > first_end_s
    assert controller.frf.n_averages == 2

    heavier = tmp_path / "heavier-rig.toml"
    dataclasses.replace(RigSpec.nominal("FOMGF"), mass_kg=40.0).save(heavier)
    _configure(window, rig_spec_path=str(heavier))
    _arm(qtbot, window)
    assert controller.session_path != first
    assert any("rig spec" in text and "new session" in text for _, text in window.banner.history)
    _hit(qtbot, window)
    _stop(qtbot, window)
    assert len(controller.hits) == 1 and controller.frf.n_averages == 1  # the running H1 holds one rig only
    with Session.open(first) as stored:
        assert stored.hit_count == 2 and "25.05" in stored.rig_spec_toml
        times = [hit.trigger_time_s for hit in stored.hits()]
        assert times[1] > times[0]
    with Session.open(controller.session_path) as stored:
        assert stored.hit_count == 1 and "mass_kg = 40" in stored.rig_spec_toml


def test_quit_with_pending_hits_asks_and_never_stores_them_as_accepted(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path, auto_accept=False)
    path = tmp_path / "pending.h5"
    main.controller.new_session(path)
    _arm(qtbot, main)
    _hit(qtbot, main)
    _hit(qtbot, main)
    assert main.controller.pending_count == 2

    asked = _answer_dialog_with(qtbot, main, "Cancel")
    assert not main.close()  # Ctrl+Q / the window's close button: Cancel keeps the window and the acquisition
    assert asked == ["2 hits wait for your decision."] and main.controller.acquiring

    _answer_dialog_with(qtbot, main, "Keep undecided")
    assert main.close()
    assert not main.controller.acquiring
    with Session.open(path) as stored:
        verdicts = stored.verdicts()
        assert [v.accepted for v in verdicts] == [False, False]
        assert all(PENDING_REASON in v.reasons for v in verdicts)

    # reopened, they wait again; quitting with "Accept all" stores them as accepted (the user said so)
    again = MainWindow(_settings(tmp_path), session_dir=tmp_path / "sessions")
    qtbot.addWidget(again)
    again.controller.open_session(path)
    assert again.controller.pending_count == 2 and again.controller.frf is None
    _answer_dialog_with(qtbot, again, "Accept all")
    assert again.close()
    with Session.open(path) as stored:
        assert [v.accepted for v in stored.verdicts()] == [True, True]
        assert all(PENDING_REASON not in v.reasons for v in stored.verdicts())


# --- item 9: damaged settings -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "stored",
    [
        "{not json",
        "[1, 2, 3]",
        '{"channels": 5}',
        '{"channels": [{"physical_channel": "ai0", "sensitivity": "high"}]}',
        '{"trigger": {"level_n": "twenty"}}',
        '{"sample_rate_hz": "fast"}',
        '{"sim_seed": 1e400}',
        '{"window": [1]}',
        '{"channels": [{"physical_channel": "ai0", "kind": "pressure"}]}',
    ],
)
def test_damaged_stored_settings_give_the_defaults_and_one_line(tmp_path, stored):
    settings = _settings(tmp_path)
    settings.setValue(SETTINGS_KEY, stored)
    settings.sync()
    state, problem = load_setup(_settings(tmp_path))
    assert state == SetupState()
    assert "damaged" in problem and "gui-settings.ini" in problem and "\n" not in problem


def test_the_window_starts_on_damaged_settings_with_a_banner(qtbot, tmp_path):
    settings = _settings(tmp_path)
    settings.setValue(SETTINGS_KEY, '{"channels": [{"physical_channel": "ai0", "sensitivity": "high"}]}')
    settings.sync()
    main = MainWindow(_settings(tmp_path), session_dir=tmp_path)
    qtbot.addWidget(main)
    main.show()
    assert main.banner.isVisible() and main.banner.severity == "warning"
    assert "damaged" in main.banner.text and "channels[0].sensitivity" in main.banner.text
    defaults = SetupState()
    state = main.setup_tab.state()
    assert (state.channels, state.sample_rate_hz, state.trigger["level_n"]) == (
        defaults.channels, defaults.sample_rate_hz, defaults.trigger["level_n"]
    )
    main.close()  # the defaults are stored: the next start is clean
    state, problem = load_setup(_settings(tmp_path))
    assert problem == "" and state.channels == defaults.channels


@pytest.mark.parametrize(
    "text, words",
    [
        ("sensor = 3", "array of tables"),
        ("sensor = [1, 2]", "must be a table"),
        ('[[sensor]]\nmodel = "X"\ntype = ["force"]\nsensitivity = 1.0\nunits = "mV/N"', "type"),
        ('[[sensor]]\nmodel = "X"\ntype = "force"\nsensitivity = nan\nunits = "mV/N"', "sensitivity"),
        ('[[sensor]]\nmodel = "X"\ntype = "force"\nsensitivity = true\nunits = "mV/N"', "sensitivity"),
        ('[[sensor]]\nmodel = "X"\ntype = "force"\nsensitivity = 1.0\nunits = 7', "units"),
        (b"\xff\xfe not utf-8", "UTF-8"),
    ],
)
def test_sensor_library_reader_raises_only_setting_errors(tmp_path, text, words):
    path = tmp_path / "library.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(SettingError) as caught:
        load_sensor_library(path)
    assert "library.toml" in str(caught.value) and words in str(caught.value)
    with pytest.raises(SettingError):
        load_sensor_library(tmp_path)  # a folder


# --- item 13: the layout at the default size ----------------------------------------------------------------------


def test_nothing_is_cut_off_at_the_default_size_and_banners_do_not_shift_the_tabs(qtbot, window, tmp_path):
    assert (window.width(), window.height()) == DEFAULT_WINDOW_SIZE
    window.tabs.setCurrentWidget(window.setup_tab)
    qtbot.wait(50)
    table = window.setup_tab.table
    assert not table.verticalScrollBar().isVisible() and not table.horizontalScrollBar().isVisible()
    shown_rows = sum(table.rowHeight(row) for row in range(table.rowCount()))
    assert table.viewport().height() >= shown_rows
    for column in range(table.columnCount()):  # every header fits its column
        label = table.horizontalHeaderItem(column).text()
        assert table.columnWidth(column) >= table.fontMetrics().horizontalAdvance(label)
    for row in range(table.rowCount()):
        sensor = window.setup_tab.channel_cell(row, "Sensor")
        assert sensor.width() >= sensor.sizeHint().width() - 2, sensor.currentText()
    for editor in window.setup_tab.trigger_form.findChildren(type(window.setup_tab.min_coherence)):
        assert editor.decimals() <= 4

    # empty plots show no empty legends
    window.tabs.setCurrentWidget(window.measure_tab)
    assert not window.measure_tab.h1_plot.getPlotItem().legend.isVisible()
    assert window.measure_tab.force_plot.getPlotItem().legend is None  # channels are named in the live titles

    # a banner takes no room from the tabs
    top_before = window.tabs.mapTo(window, window.tabs.rect().topLeft()).y()
    window.banner.show_message("hammer: overload on ai0", "warning")
    qtbot.wait(50)
    assert window.tabs.mapTo(window, window.tabs.rect().topLeft()).y() == top_before

    # the Reasons column shows its text whole (rows wrap) and the live plots clear when another session opens
    controller = window.controller
    controller.new_session(tmp_path / "layout.h5")
    _arm(qtbot, window)
    _hit(qtbot, window)
    qtbot.waitUntil(lambda: window.measure_tab.redraw_count > 2, timeout=5_000)
    _stop(qtbot, window)
    hit_table = window.measure_tab.hit_table
    reasons = hit_table.item(0, 4)
    assert hit_table.visualItemRect(reasons).right() <= hit_table.viewport().width()
    assert any(curve.xData is not None and len(curve.xData) for curve in window.measure_tab._live_curves)
    controller.close_session()
    controller.open_session(tmp_path / "layout.h5")
    assert controller.session_path == tmp_path / "layout.h5" and len(controller.hits) == 1
    assert all(item.xData is None or len(item.xData) == 0  # cleared (the trigger-level span item stays, empty)
               for item in window.measure_tab.force_plot.getPlotItem().listDataItems())
    assert not window.measure_tab.trigger_line.isVisible()
