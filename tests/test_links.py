"""One rule for symbolic links (issue 33 item 1): a link stands for what it points to, read or written in place, and the
link itself is never replaced by a copy — sessions, output files and output folders alike, for every command.

Before, ``replay``, ``fit``, ``diagnose`` and ``acquire --append`` given a link to a session replaced the link by a
regular file holding the new hits or results (the session never got them), while output folders given as links were
followed: two rules."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from gasfilm.analysis.session import Session
from gasfilm.app.cli import main
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("links") / "recorded.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "5"]) == 0
    return path


@pytest.fixture
def shared_session(recorded, tmp_path) -> tuple[Path, Path]:
    """A session on a "shared drive" (a folder of its own) and a link to it in the working folder."""
    drive = tmp_path / "drive"
    drive.mkdir()
    real = drive / "real.h5"
    shutil.copyfile(recorded, real)
    work = tmp_path / "work"
    work.mkdir()
    link = work / "link.h5"
    link.symlink_to(real)
    return real, link


def assert_written_in_place(real: Path, link: Path) -> None:
    """The link is still a link to the session, and nothing was left beside either (a journal, a hidden file)."""
    assert link.is_symlink() and link.resolve() == real
    assert set(os.listdir(link.parent)) - {link.name} <= {"figures"}  # (the folder fit was asked to draw into)
    assert [name for name in os.listdir(real.parent) if name.startswith(".") or name.endswith(".journal")] == []


def test_a_session_named_through_a_link_gets_the_new_hits_and_results_in_place(shared_session, tmp_path, capsys):
    real, link = shared_session
    status, out, err = gasfilm(capsys, "replay", link, "--exp-end", "0.05", "--json")
    assert status == 0, err
    assert "FRF group 'replay' in" in json.loads(out)["result"]
    status, _, err = gasfilm(capsys, "fit", link, "--models", "SD", "--out", tmp_path / "work" / "figures")
    assert status == 0, err
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", link, "--append", "--hits", "1")
    assert status == 0, err
    assert_written_in_place(real, link)
    with Session.open(real) as session:  # the session itself holds them, not a copy that replaced the link
        assert "replay" in session.result_names("frf") and session.result_names("fits") == ["SD"]
        assert session.hit_count >= 5 and session.status == "complete"


def test_diagnose_through_a_link_stores_its_run_in_the_session(shared_session, tmp_path, capsys):
    real, link = shared_session
    status, _, err = gasfilm(capsys, "diagnose", link, "--out", tmp_path / "diagnosis")
    assert status == 0, err
    assert_written_in_place(real, link)
    with Session.open(real) as session:
        assert "latest" in session.result_names("diagnoses")


def test_a_new_session_named_as_a_link_replaces_the_file_it_points_to(shared_session, recorded, tmp_path, capsys):
    real, link = shared_session
    status, _, err = gasfilm(capsys, "replay", recorded, "--out", link)
    assert status == 2 and "exists already" in err and str(real) in err
    status, _, err = gasfilm(capsys, "replay", recorded, "--out", link, "--overwrite", "--exp-end", "0.05")
    assert status == 0, err
    assert_written_in_place(real, link)
    with Session.open(real) as session:
        assert session.settings["replay"]["source"] == [str(recorded)]
    dangling = tmp_path / "work" / "new.h5"
    dangling.symlink_to(tmp_path / "drive" / "new.h5")
    status, _, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", dangling, "--hits", "1")
    assert status == 0, err
    assert dangling.is_symlink() and (tmp_path / "drive" / "new.h5").is_file()


def test_output_files_and_folders_named_as_links_are_written_where_they_point(recorded, tmp_path, capsys):
    with Session.open(recorded) as session:
        assert session.result_names("fits") == []
    fitted = tmp_path / "fitted.h5"
    shutil.copyfile(recorded, fitted)
    assert gasfilm(capsys, "fit", fitted, "--models", "SD", "--out", tmp_path / "figures")[0] == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    kept = elsewhere / "model.json"
    kept.write_text("{}")
    link = tmp_path / "model.json"
    link.symlink_to(kept)
    status, _, err = gasfilm(capsys, "model", fitted, "--model", "SD", "--out", link)
    assert status == 2 and "exists already" in err
    status, _, err = gasfilm(capsys, "model", fitted, "--model", "SD", "--out", link, "--overwrite")
    assert status == 0, err
    assert link.is_symlink() and json.loads(kept.read_text())["order"] >= 1
    folder_link = tmp_path / "out-link"
    folder_link.symlink_to(elsewhere)
    status, _, err = gasfilm(capsys, "fit", fitted, "--models", "SD", "--out", folder_link, "--overwrite")
    assert status == 0, err
    assert folder_link.is_symlink() and (elsewhere / "fitted-figure18.png").is_file()
