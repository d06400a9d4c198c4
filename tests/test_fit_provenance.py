"""Fits know what they were made from — a fit made on fewer hits than the session now accepts is stale in ``fit``,
the report and campaigns, and ``fit --refit`` makes it current — and commands that only read a session work on one
that cannot be written, saying what they could not store."""

from __future__ import annotations

import errno
import json
import shutil

import numpy as np
import pytest

from gasfilm.analysis.campaign.session_task import CampaignOptions, analyse_session
from gasfilm.analysis.report import read_report_data, report_html
from gasfilm.analysis.session import Session
from gasfilm.analysis.session.journal import RollbackFile
from gasfilm.analysis.spectra import WindowSettings, session_frf
from test_cli_acquire_replay import FAST_SIM, gasfilm


def stored_hits(path) -> dict[str, tuple[int, list[int]]]:
    with Session.open(path) as session:
        return {name: (int(session.read_fit(name)["hit_count"]), [int(i) for i in session.read_fit(name)["hit_indices"]])
                for name in session.result_names("fits")}


@pytest.fixture(scope="module")
def prepared_session(tmp_path_factory):
    """A session of 3 hits with SD fitted, then 2 more hits appended: its stored fit is made on 3 of 5."""
    from gasfilm.app import cli

    path = tmp_path_factory.mktemp("provenance") / "run.h5"
    assert cli.main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "3", "--seed", "3"]) == 0
    assert cli.main(["fit", str(path), "--models", "SD", "--out", str(path.parent / "figures")]) == 0
    assert stored_hits(path) == {"SD": (3, [0, 1, 2])}
    assert cli.main(["acquire", *FAST_SIM, "--out", str(path), "--append", "--hits", "2", "--seed", "4"]) == 0
    return path


@pytest.fixture
def appended_session(prepared_session, tmp_path):
    """A copy of :func:`prepared_session` of the test's own."""
    path = tmp_path / prepared_session.name
    shutil.copyfile(prepared_session, path)
    return path


def test_a_fit_on_fewer_hits_than_accepted_is_stale_in_the_report_and_the_campaign_until_refit(appended_session,
                                                                                               capsys):
    path = appended_session
    data = read_report_data(path)
    assert data.stale == {"SD": "made on 3 of the 5 accepted hits"} and data.fit_hits == {"SD": 3}
    page = report_html(data)
    assert "stale fits: SD made on 3 of the 5 accepted hits" in page and f"gasfilm fit {path.name} --refit" in page
    assert "<td>3 (stale)</td>" in page
    row = analyse_session(str(path), CampaignOptions(models=("SD",), diagnose=False))
    assert row["error"] is None and row["fit_hits"] == 5
    assert row["stored_fits_stale"] == "SD made on 3 of the 5 accepted hits"

    status, out, err = gasfilm(capsys, "fit", path, "--refit")  # one flag: the stored models, their settings
    assert status == 0, err
    assert "FRF averaged now from 5 accepted hits" in out and "made on all 5 accepted hits" in out
    assert stored_hits(path) == {"SD": (5, [0, 1, 2, 3, 4])}
    with Session.open(path) as session:  # the stored FRF is the one the fits were made on
        assert list(session.frf_hit_indices("frf")) == [0, 1, 2, 3, 4]
    assert read_report_data(path).stale == {}
    row = analyse_session(str(path), CampaignOptions(models=("SD",), diagnose=False))
    assert row["stored_fits_stale"] == ""


def test_fit_on_a_stored_frf_of_fewer_hits_says_it_is_stale(appended_session, capsys):
    path = appended_session
    with Session.open(path, "a") as session:  # an FRF of the first 3 hits only (as a viewer stored it before)
        hits = [hit for hit in session.hits() if hit.index < 3]
        session.write_frf(session_frf(hits, session.settings_as("window", WindowSettings)),
                          hit_indices=np.array([0, 1, 2]))
    status, out, err = gasfilm(capsys, "fit", path, "--models", "SD", "--overwrite", "--json")
    assert status == 0, err
    hits = json.loads(out)["hits"]
    assert hits["count"] == 3 and hits["accepted"] == 5
    assert hits["stale"] == ("the FRF 'frf' is made on 3 of the 5 accepted hits, and so are fits on it (--refit "
                             "averages all 5 and fits again)")


def test_refit_refuses_what_it_cannot_take_from_the_stored_fits(appended_session, capsys):
    path = appended_session
    status, _, err = gasfilm(capsys, "fit", path, "--refit", "--frf", "frf")
    assert status == 2 and "leave --frf out" in err
    with Session.open(path, "a") as session:
        session.write_fit("Zener", {**session.read_fit("SD"), "model_name": "Zener", "network": "k2 || (k1 -- "
                                    "dashpot(eta1))", "band_hz": [30.0, 500.0]})
    status, _, err = gasfilm(capsys, "fit", path, "--refit")
    assert status == 2 and "--refit: the stored fits differ in --band" in err and len(err.strip().splitlines()) == 1


@pytest.fixture
def read_only(monkeypatch):
    """The session's file refuses to be opened for writing (as a read-only file does for a user who is not root)."""
    opened = RollbackFile.__init__

    def refuse(self, path, writable, *args, **kwargs):
        if writable:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        opened(self, path, writable, *args, **kwargs)

    monkeypatch.setattr(RollbackFile, "__init__", refuse)


def test_commands_that_read_a_session_work_on_a_read_only_one_and_say_what_they_could_not_store(
        appended_session, read_only, tmp_path, capsys):
    path = appended_session
    before = path.read_bytes()
    out_dir = tmp_path / "figures"
    status, out, err = gasfilm(capsys, "fit", path, "--models", "SD", "--out", out_dir)
    assert status == 0, err
    assert "note: the fits are not stored in the session" in out and "Permission denied" in out
    assert (out_dir / "run-figure18.png").exists()
    status, out, err = gasfilm(capsys, "fit", path, "--refit", "--out", out_dir, "--json")
    assert status == 0, err
    assert json.loads(out)["stored_note"].startswith("the fits and the FRF are not stored in the session")
    status, out, err = gasfilm(capsys, "replay", path)
    assert status == 0, err
    assert f"result: not stored in {path}" in out
    assert path.read_bytes() == before  # nothing was written into it
    assert stored_hits(path) == {"SD": (3, [0, 1, 2])}


def test_the_gui_opens_a_read_only_session_read_only_and_says_so(appended_session, read_only, qtbot, tmp_path):
    from gui_driving import open_window

    window = open_window(qtbot, tmp_path)
    try:
        controller = window.controller
        controller.open_session(appended_session)
        assert controller.session is not None and not controller.session.writable
        assert len(controller.hits) == 5 and "SD" in controller.fits
        assert any("opened read-only" in text for _severity, text in window.banner.history)
        assert controller.stale_fits() == {"SD": "made on 3 of the 5 accepted hits"}
    finally:
        controller.shutdown()


def test_the_gui_marks_fits_made_before_more_hits_stale_and_refits_them_in_one_click(appended_session, qtbot,
                                                                                    tmp_path):
    """The issue's trial: a session reopened after more hits showed its older fits in Table 2 without a word. Now
    its Hits column marks them with the hits they used, the Refit button offers all of them, and one click fits
    them again (kept in the session); a verdict changed afterwards marks them again."""
    from PySide6.QtCore import Qt

    from gui_driving import open_window

    window = open_window(qtbot, tmp_path)
    controller, tab = window.controller, window.identify_tab
    try:
        controller.open_session(appended_session)
        hits_column = list(identify_columns()).index("Hits")
        assert controller.stale_fits() == {"SD": "made on 3 of the 5 accepted hits"}
        mark = tab.table.item(0, hits_column)
        assert mark.text() == "3 ⚠ stale" and "made on 3 of the 5 accepted hits" in mark.toolTip()
        assert tab.refit_button.isEnabled() and tab.refit_button.text() == "Refit on all 5 hits"
        qtbot.mouseClick(tab.refit_button, Qt.MouseButton.LeftButton)
        qtbot.waitUntil(lambda: not controller.job_active("fit") and controller.fit_hits("SD").count == 5,
                        timeout=60_000)
        assert tab.table.item(0, hits_column).text() == "5" and not tab.refit_button.isEnabled()
        assert stored_hits(appended_session) == {"SD": (5, [0, 1, 2, 3, 4])}  # stored at once
        controller.decide(4, False)  # the technician rejects the last hit: the fit averages it
        assert tab.table.item(0, hits_column).text() == "5 ⚠ stale" and tab.refit_button.text() == "Refit on all 4 hits"
    finally:
        controller.shutdown()


def identify_columns() -> tuple[str, ...]:
    from gasfilm.app.gui.identify_tab import TABLE2_COLUMNS

    return TABLE2_COLUMNS
