"""The GUI slips a new user met (issue 15, items 9 and 14–20), checked the way a person would see them (pytest-qt,
offscreen): layout that does not jump, legends clear of the data, banner entries, labels in words with units."""

import numpy as np
import pytest
from PySide6.QtCore import QPoint, Qt

from gasfilm.analysis.capture import MAX_RECORD_S
from gasfilm.analysis.identification import DEFAULT_FIT_BAND_HZ
from gasfilm.analysis.settings import SETTING_LABELS
from gasfilm.app.commands.fit import parse_band
from gasfilm.app.gui.diagnose_tab import finding_title
from gasfilm.app.gui.widgets import TidyPlotItem, field_label
from gui_driving import arm, fits_finish, hit, open_window, stop


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def _geometry(widget, window) -> tuple[int, int, int, int]:
    corner = widget.mapTo(window, QPoint(0, 0))
    return corner.x(), corner.y(), widget.width(), widget.height()


def _legend_covers_extremes(plot) -> list[str]:
    """The curves whose highest or lowest drawn point lies under the plot's (visible) legend."""
    item = plot.getPlotItem()
    legend = item.legend
    if legend is None or not legend.isVisible():
        return []
    covered = []
    box = legend.mapRectToItem(item.vb, legend.boundingRect())
    (x0, x1), (y0, y1) = item.vb.viewRange()
    for curve in item.listDataItems():
        x, y = curve.getData()
        if x is None or len(x) == 0 or not curve.isVisible():
            continue
        finite = np.isfinite(x) & np.isfinite(y)
        x, y = x[finite], y[finite]
        for index in (int(np.argmax(y)), int(np.argmin(y))):
            px = (x[index] - x0) / (x1 - x0) * item.vb.width()
            py = (y1 - y[index]) / (y1 - y0) * item.vb.height()
            if box.contains(px, py):
                covered.append(curve.name() or "curve")
    return covered


def _all_plots(window) -> dict[str, object]:
    measure, frf, identify, diagnose = window.measure_tab, window.frf_tab, window.identify_tab, window.diagnose_tab
    plots = {
        "measure H1": measure.h1_plot, "measure coherence": measure.coherence_plot,
        "force spectrum": measure.spectrum_plot, "live force": measure.force_plot,
        "FRF magnitude": frf.magnitude_plot, "FRF phase": frf.phase_plot, "FRF coherence": frf.coherence_plot,
        "FRF real": frf.real_plot, "FRF imaginary": frf.imag_plot,
        "diagnose overlay": diagnose.overlay_plot, "diagnose residual": diagnose.residual_plot,
        "restoring force stiffness": diagnose.restoring_stiffness_plot,
        "restoring force damping": diagnose.restoring_damping_plot,
    }
    plots.update({f"Fig. 18 {name}": plot for name, plot in identify.fig18.items()})
    plots.update({f"Fig. 19 {name}": plot for name, plot in identify.fig19.items()})
    return plots


def test_empty_plots_have_no_legend_box_and_frequencies_in_hz(window):
    for name, plot in _all_plots(window).items():
        item = plot.getPlotItem()
        assert item.legend is None or not item.legend.isVisible(), name
        bottom = item.getAxis("bottom")
        if bottom.labelUnits == "Hz":
            assert "mHz" not in bottom.labelString(), name


def test_hit_check_and_trigger_labels_are_words_with_units(window):
    setup = window.setup_tab
    for table, form in (("validation", setup.validation_form), ("trigger", setup.trigger_form),
                        ("window", setup.window_form)):
        for name, label in form.labels.items():
            assert label == SETTING_LABELS[table][name][0], (name, label)  # one wording, shared with the report
            assert "_" not in label, (name, label)
            assert name == "slope" or "(" in label, (name, label)  # the unit, or what the number is a fraction of
    for name, label in setup.validation_form.labels.items():
        assert label != field_label(name), (name, label)  # not the internal name ("Min force snr")
    assert setup.validation_form.labels["min_force_snr"] == "Least force peak / noise (ratio)"


def test_record_length_rule_is_the_command_lines(window, qtbot):
    """Record length beyond the CLI's limit is refused on the Setup tab and by Arm, naming the field the user sees."""
    state = window.setup_tab.state()
    state.trigger = {**state.trigger, "record_s": 5 * MAX_RECORD_S}
    window.setup_tab.set_state(state)
    assert "Record length (s): 100 s is longer than a hammer test needs" in window.setup_tab.problem()
    window.controller.arm()
    assert window.controller.state == "idle" and not window.controller.acquiring
    assert "Record length (s)" in window.banner.text
    assert not list((window.controller.session_dir).glob("*.h5"))


def test_default_fit_band_is_the_command_lines(window):
    assert window.controller.fit_band_hz == DEFAULT_FIT_BAND_HZ == parse_band(None, 51200.0)
    assert "20–1000 Hz" in window.identify_tab.band_label.text()


def test_failed_arm_leaves_no_session_file_and_nothing_to_decide(qtbot, tmp_path):
    window = open_window(qtbot, tmp_path, device="NoSuchDevice1")
    try:
        qtbot.mouseClick(window.measure_tab.arm_button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: window.banner.severity == "error", timeout=10_000)
        qtbot.waitUntil(lambda: window.controller.state == "idle" and not window.controller.acquiring, timeout=10_000)
        assert "nothing was recorded" in window.banner.text and "safe" not in window.banner.text
        assert not list((tmp_path / "sessions").glob("*.h5")), "a failed Arm left a session file behind"
        assert window.controller.session is None
        assert not window.measure_tab.accept_button.isEnabled() and not window.measure_tab.reject_button.isEnabled()
    finally:
        window.controller.shutdown()


def test_live_force_view_keeps_the_trigger_level_in_view(qtbot, window):
    arm(qtbot, window)
    measure = window.measure_tab
    qtbot.waitUntil(lambda: measure.redraw_count > 5, timeout=10_000)
    qtbot.wait(200)
    (_, _), (low, high) = measure.force_plot.getPlotItem().vb.viewRange()
    level = window.controller.running_trigger().level_n
    assert low < level < high, (low, high)
    assert measure.force_plot.getPlotItem().legend is None  # channels named in the title: no box over the newest hit
    assert "hammer" in measure.force_plot.getPlotItem().titleLabel.text
    stop(qtbot, window)


def test_session_through_the_gui_without_slips(qtbot, window):
    """One session, hit → stop → fit → diagnose, with everything a new user tripped over checked on the way."""
    controller, measure = window.controller, window.measure_tab
    window.tabs.setCurrentWidget(measure)
    arm(qtbot, window)
    for tip in ("medium", "hard", "medium", "soft"):
        hit(qtbot, window, tip)

    # Layout: the force spectrum and the overlay views move neither the hit list nor their own tab bar.
    qtbot.wait(100)
    before = (_geometry(measure.hit_table, window), _geometry(measure.hit_views.tabBar(), window))
    for page in (1, 2, 0):
        measure.hit_views.setCurrentIndex(page)
        qtbot.wait(50)
        after = (_geometry(measure.hit_table, window), _geometry(measure.hit_views.tabBar(), window))
        assert after == before, (page, before, after)
    measure.hit_views.setCurrentIndex(1)
    stop(qtbot, window)

    # After Stop the Identify and Diagnose tabs say what can be done now, not that they wait.
    assert "waits" not in window.identify_tab.status.text()
    assert "waits" not in window.diagnose_tab.status.text()
    assert window.identify_tab.run_button.isEnabled() and window.diagnose_tab.run_button.isEnabled()

    # A fit reports in the banner.
    window.tabs.setCurrentWidget(window.identify_tab)
    window.identify_tab.set_selected_models(["SD", "FOMGF"])
    window.identify_tab.run_fits()
    fits_finish(qtbot, window, 2)
    assert window.banner.severity == "info" and window.banner.text.startswith("fit finished: 2 models"), \
        window.banner.history

    # The diagnosis: its progress shows and moves nothing in its row; it reports in the banner.
    window.tabs.setCurrentWidget(window.diagnose_tab)
    diagnose_tab = window.diagnose_tab
    qtbot.wait(50)
    row_before = (_geometry(diagnose_tab.reference_path, window), _geometry(diagnose_tab.run_button, window))
    diagnose_tab.run_button.click()
    qtbot.waitUntil(lambda: diagnose_tab.progress.isVisible(), timeout=5_000)
    assert diagnose_tab.elapsed.text().startswith("running")
    row_running = (_geometry(diagnose_tab.reference_path, window), _geometry(diagnose_tab.run_button, window))
    assert row_running == row_before
    qtbot.waitUntil(lambda: not controller.job_active("diagnose"), timeout=120_000)
    assert controller.diagnosis is not None, window.banner.history
    assert window.banner.text.startswith("diagnosis finished"), window.banner.history
    assert f"verdict {controller.diagnosis.verdict}" in window.banner.text

    # Findings are listed where their details say they are.
    for finding in controller.diagnosis.findings:
        assert finding.where.split(";")[0] in finding_title(finding)

    # Legends: shown only with data, never over a curve's highest or lowest point.
    for tab in (window.measure_tab, window.frf_tab, window.identify_tab, window.diagnose_tab):
        window.tabs.setCurrentWidget(tab)
        qtbot.wait(100)
    for name, plot in _all_plots(window).items():
        item = plot.getPlotItem()
        if isinstance(item, TidyPlotItem):
            item.tidy_legend()
        if item.legend is not None and any(c.getData()[0] is not None and len(c.getData()[0]) for c in item.listDataItems()):
            assert item.legend.isVisible(), name
        assert not _legend_covers_extremes(plot), (name, _legend_covers_extremes(plot))


def test_sigterm_closes_the_session_without_asking(qtbot, tmp_path):
    """``kill`` (SIGTERM) or a closed terminal (SIGHUP): the window quits like *Quit* without a dialog — waiting hits
    stay undecided — and the session file is closed cleanly with every hit."""
    window = open_window(qtbot, tmp_path, auto_accept=False)
    controller = window.controller
    controller.new_session(tmp_path / "signal.h5")
    arm(qtbot, window)
    hit(qtbot, window)
    assert controller.pending_count == 1
    window.close_on_signal(15)
    assert window.pending_dialog is None and not window.isVisible()
    from gasfilm.analysis.session import Session

    with Session.open(tmp_path / "signal.h5") as session:
        assert session.status == "complete" and session.hit_count == 1


def test_a_legend_makes_room_when_every_corner_holds_an_extreme(qtbot):
    """Point clouds reaching all four corners (the restoring force's sections, one cloud per hit): the legend is put
    above the data, not over a curve's highest or lowest point (it once covered one under load)."""
    from gasfilm.app.gui.widgets import make_plot

    plot = make_plot("clouds", ("r", "N"), ("v", "mm/s"))
    qtbot.addWidget(plot)
    plot.resize(500, 350)
    plot.show()
    rng = np.random.default_rng(1)
    for corner_x, corner_y in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
        plot.plot(corner_x + 0.05 * rng.standard_normal(40), corner_y + 0.05 * rng.standard_normal(40), pen=None,
                  symbol="o", symbolSize=2)
    plot.plot([-1.0, 1.0], [-1.0, 1.0], name="linear film c = 3.5e+03 N·s/m")
    qtbot.wait(50)
    item = plot.getPlotItem()
    item.tidy_legend()
    qtbot.wait(50)
    assert item.legend.isVisible()
    assert not _legend_covers_extremes(plot)
