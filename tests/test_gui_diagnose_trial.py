"""The GUI's side of a new user's trial of the Diagnose tab and of opening sessions: the headline figure is the χ² per
point the command prints, the film's K(ω) and C(ω) are drawn from the diagnosis, an opened session shows nothing of
the previous one (views, reference spec), and the window's own writer lock is never taken for another process's."""

import logging
from pathlib import Path

import numpy as np
import pyqtgraph as pg
import pytest

from gasfilm.analysis.diagnosis.plots import FILM_CURVE_LABELS, film_parts
from gasfilm.analysis.diagnosis.report import chi2_headline, report_text
from another_writer import held_by_another_process
from gasfilm.analysis.session import Session
from gui_driving import open_window
from test_cli_acquire_replay import FAST_SIM, gasfilm

FIXTURE_RIGS = Path(__file__).resolve().parents[1] / "fixtures" / "rigs"


@pytest.fixture
def window(qtbot, tmp_path):
    main = open_window(qtbot, tmp_path)
    yield main
    main.controller.shutdown()


def recorded(tmp_path, capsys, name: str, rig: str = "sd.toml", hits: int = 4, seed: int = 3):
    """A short simulated session of a fixture rig, recorded by `gasfilm acquire`."""
    path = tmp_path / name
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--rig", FIXTURE_RIGS / rig, "--out", path, "--hits", hits,
                   "--seed", seed)[0] == 0
    return path


def softer_spec(tmp_path):
    """The SD rig's spec with a softer film: the session of sd.toml differs from it (a quick diagnosis)."""
    path = tmp_path / "softer.toml"
    path.write_text((FIXTURE_RIGS / "sd.toml").read_text().replace("k = 37800000.0", "k = 30000000.0"))
    return path


def diagnosed(qtbot, window, reference=None):
    controller = window.controller
    controller.run_diagnosis(str(reference) if reference else None, lambda folder, names: True)
    qtbot.waitUntil(lambda: not controller.job_active("diagnose"), timeout=120_000)
    assert controller.diagnosis is not None, window.banner.history
    return controller.diagnosis


def test_the_diagnose_tabs_headline_is_the_chi2_per_point_the_command_prints(qtbot, window, tmp_path, capsys):
    """Trial finding 1: the tab led with BIC; the command's headline is χ²/point before → after (1 = noise)."""
    window.controller.open_session(recorded(tmp_path, capsys, "run.h5"))
    diagnosis = diagnosed(qtbot, window, softer_spec(tmp_path))
    words = chi2_headline(diagnosis.chi2_per_point_before, diagnosis.chi2_per_point_after)
    assert words in report_text(diagnosis)  # what `gasfilm diagnose` prints
    summary = window.diagnose_tab.summary.text()
    assert words in summary and summary.index(words) < summary.index("BIC"), summary  # first; BIC a detail after it
    assert summary.index(words) < summary.index("RMS")

    window.controller.open_session(tmp_path / "run.h5")  # the stored run says the same
    stored = window.diagnose_tab.summary.text()
    assert "stored" in stored and words in stored and stored.index(words) < stored.index("BIC"), stored


def test_the_diagnose_tab_draws_the_films_stiffness_and_damping_against_the_specs(qtbot, window, tmp_path, capsys):
    """Trial finding 2: the film's K(ω) and C(ω) (the paper's eqs. 19–20), which the diagnosis draws into
    diagnosis-film.png, had no view in the GUI. Drawn from the diagnosis's own numbers, with their units."""
    window.controller.open_session(recorded(tmp_path, capsys, "run.h5"))
    diagnosis = diagnosed(qtbot, window, softer_spec(tmp_path))
    tab = window.diagnose_tab
    tab.views.setCurrentIndex(1)
    freq_hz, (stiffness, damping), written_label = film_parts(diagnosis)
    for plot, part, unit in ((tab.film_stiffness_plot, stiffness, "N/m"), (tab.film_damping_plot, damping, "N·s/m")):
        item = plot.getPlotItem()
        assert item.getAxis("left").labelUnits == unit and item.getAxis("bottom").labelUnits == "Hz"
        curves = {curve.name(): curve for curve in item.listDataItems() if curve.name()}
        assert set(curves) == {FILM_CURVE_LABELS["recorded"], FILM_CURVE_LABELS["given_film"], written_label,
                               FILM_CURVE_LABELS["apparent"]}
        for name, values in ((FILM_CURVE_LABELS["recorded"], part.recorded),
                             (FILM_CURVE_LABELS["given_film"], part.given_film), (written_label, part.written_film),
                             (FILM_CURVE_LABELS["apparent"], part.apparent)):
            x, y = curves[name].getOriginalDataset()
            np.testing.assert_allclose(x, freq_hz)
            np.testing.assert_allclose(y, values)
        (low, high), (shown_low, shown_high) = part.view_range(), item.vb.targetRange()[1]
        assert np.isclose(shown_low, low) and shown_high >= high * (1 - 1e-9)  # as the PNG (and room for the legend)
        assert any(isinstance(entry, pg.FillBetweenItem) for entry in item.items)  # the ±2σ band
    # the softer film as given against the film the recordings show (37.8 MN/m)
    assert np.allclose(stiffness.given_film, 30e6, rtol=0.01) and abs(np.median(stiffness.recorded) / 37.8e6 - 1) < 0.02
    assert f"M = {diagnosis.improved.moving_mass_kg:.4g} kg" in tab.film_label.text()

    window.controller.open_session(tmp_path / "run.h5")  # a stored diagnosis keeps no spectra: it says so
    assert not tab.film_stiffness_plot.getPlotItem().listDataItems()
    assert "run Diagnose" in tab.film_label.text()


def _shown_views(qtbot, window) -> dict:
    """Every plot's view range, each tab shown and drawn; plots linked to another (they follow it) and plots with a
    locked aspect (their range follows the widget's shape) are left out."""
    views = {}
    for index in range(window.tabs.count()):
        window.tabs.setCurrentIndex(index)
        for _ in range(2):
            qtbot.wait(150)
            window.grab()
        tab = window.tabs.widget(index)
        for number, plot in enumerate(tab.findChildren(pg.PlotWidget)):
            view = plot.getPlotItem().vb
            if view.linkedView(0) is not None or view.linkedView(1) is not None or view.state["aspectLocked"]:
                continue
            views[(window.tabs.tabText(index), number, plot.getPlotItem().titleLabel.text)] = view.viewRange()
    return views


def test_an_opened_session_shows_every_plot_as_a_fresh_window_shows_it(qtbot, tmp_path, capsys):
    """Trial finding 3: after File ▸ Open the plots kept the previous session's ranges (a zoom on its resonance
    showed an empty plot of the next). Every plot must show the opened session as a window that opened it first."""
    first = recorded(tmp_path, capsys, "first.h5", rig="three-modes.toml", hits=3, seed=1)
    second = recorded(tmp_path, capsys, "second.h5", hits=3, seed=2)
    fresh = open_window(qtbot, tmp_path)
    fresh.controller.open_session(second)
    expected = _shown_views(qtbot, fresh)
    fresh.controller.shutdown()
    fresh.close()

    window = open_window(qtbot, tmp_path)
    try:
        window.controller.open_session(first)
        _shown_views(qtbot, window)
        for plot in window.findChildren(pg.PlotWidget):  # the technician zooms everywhere
            view = plot.getPlotItem().vb
            (x0, x1), (y0, y1) = view.viewRange()
            view.setRange(xRange=(x0 + 0.3 * (x1 - x0), x0 + 0.4 * (x1 - x0)),
                          yRange=(y0 + 0.3 * (y1 - y0), y0 + 0.4 * (y1 - y0)), padding=0)
        magnitude = window.frf_tab.magnitude_plot.getPlotItem()  # the mouse rests on it: a read-out of the first
        magnitude.show_readout(magnitude.vb.sceneBoundingRect().center())
        assert magnitude.readout.isVisible()
        window.tabs.setCurrentIndex(0)
        window.controller.open_session(second)
        shown = _shown_views(qtbot, window)
        assert not magnitude.readout.isVisible()  # (it named a point of the first session)
    finally:
        window.controller.shutdown()
    assert shown.keys() == expected.keys()
    stale = {key: (shown[key], expected[key]) for key in expected
             if not np.allclose(shown[key], expected[key], rtol=1e-3, atol=1e-9)}
    assert not stale, stale


def test_an_opened_session_clears_the_reference_spec_typed_for_the_previous_one(qtbot, window, tmp_path, capsys):
    """Trial finding 3: the Reference rig spec typed for one session stayed for the next (a diagnosis against the
    wrong rig). Opened, a session starts from its own spec, or from the one its stored diagnosis was made against."""
    controller, tab = window.controller, window.diagnose_tab
    plain = recorded(tmp_path, capsys, "plain.h5", hits=3)
    against = recorded(tmp_path, capsys, "against.h5", hits=3, seed=4)
    reference = softer_spec(tmp_path)
    assert gasfilm(capsys, "diagnose", against, "--rig", reference, "--no-figures")[0] == 0

    controller.open_session(plain)
    tab.reference_path.setText(str(tmp_path / "design-of-another-rig.toml"))
    tab.status.setText("Diagnosis complete.")
    controller.open_session(against)  # its stored diagnosis was made against the softer spec
    assert tab.reference_path.text() == str(reference)
    controller.open_session(plain)  # no stored diagnosis: its own spec (the field empty)
    assert tab.reference_path.text() == "" and "complete" not in tab.status.text()


def test_reopening_the_session_the_window_has_open_is_not_refused_as_another_processes(qtbot, window, tmp_path,
                                                                                       capsys, caplog):
    """Trial finding 4: File ▸ Open of the session the window had open said "another process is writing this
    session": the lock was the window's own. It opens again, writable, with every hit."""
    path = recorded(tmp_path, capsys, "run.h5", hits=3)
    controller = window.controller
    controller.open_session(path)
    said = len(window.banner.history)
    with caplog.at_level(logging.WARNING):
        controller.open_session(path)
    assert all("another" not in text and severity != "error" for severity, text in window.banner.history[said:]), \
        window.banner.history
    assert controller.session is not None and controller.session.writable and controller.accepted_count == 3
    assert not [record for record in caplog.records if "another" in record.getMessage()]


def test_diagnosing_the_open_session_says_nothing_of_another_process(qtbot, window, tmp_path, capsys, caplog):
    """Trial finding 4: Diagnose read the window's own session and warned "open for writing in another gasfilm
    process" on the terminal."""
    path = recorded(tmp_path, capsys, "run.h5", hits=3)
    window.controller.open_session(path)
    with caplog.at_level(logging.WARNING):
        diagnosed(qtbot, window)
        Session.open(path, "r").close()  # a look at its own session from the same process
    assert not [record for record in caplog.records if "another" in record.getMessage()], caplog.text


def test_a_session_another_process_writes_is_still_refused_naming_the_file(qtbot, window, tmp_path, capsys, caplog):
    """What finding 4 must keep: a lock held by another process is said, naming the file."""
    path = recorded(tmp_path, capsys, "held.h5", hits=3)
    with held_by_another_process(path):
        window.controller.open_session(path)
        severity, text = window.banner.history[-1]
        assert severity == "error" and str(path) in text and "another process is writing this session" in text
        with caplog.at_level(logging.WARNING):
            Session.open(path, "r").close()
        assert any(str(path) in record.getMessage() and "another gasfilm process" in record.getMessage()
                   for record in caplog.records), caplog.text
