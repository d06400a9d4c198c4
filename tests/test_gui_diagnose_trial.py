"""The GUI's side of a new user's trial of the Diagnose tab and of opening sessions: the headline figure is the χ² per
point the command prints, the film's K(ω) and C(ω) are drawn from the diagnosis, and the window's own writer lock is
never taken for another process's."""

import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyqtgraph as pg
import pytest

from gasfilm.analysis.diagnosis.plots import FILM_CURVE_LABELS, film_parts
from gasfilm.analysis.diagnosis.report import chi2_headline, report_text
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
    writer = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom gasfilm.analysis.session import Session\n"
         f"session = Session.open({str(path)!r}, 'a')\nprint('open', flush=True)\nsys.stdin.read()\nsession.close()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "open"
        window.controller.open_session(path)
        severity, text = window.banner.history[-1]
        assert severity == "error" and str(path) in text and "another process is writing this session" in text
        with caplog.at_level(logging.WARNING):
            Session.open(path, "r").close()
        assert any(str(path) in record.getMessage() and "another gasfilm process" in record.getMessage()
                   for record in caplog.records), caplog.text
    finally:
        writer.communicate("", timeout=60)
