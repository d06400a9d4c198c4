"""Nothing is replaced unless the user asked (--overwrite), a link stands for the file it points to, and an output
path that cannot be written is one line before any work — the same for every command."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gasfilm.analysis.session import Session
from gasfilm.app.cli import main
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture(scope="module")
def session_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("outputs") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "2"]) == 0
    return path


def assert_one_line(status: int, err: str, *expected: str) -> None:
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for text in expected:
        assert text in err, err


@pytest.mark.parametrize("flag", ["--csv", "--uff"])
def test_export_replaces_a_file_only_with_overwrite_and_writes_where_a_link_points(tmp_path, capsys, session_path,
                                                                                   flag):
    target = tmp_path / f"frf.{flag[2:]}"
    target.write_text("the user's notes\n")
    assert_one_line(*gasfilm(capsys, "export", session_path, flag, target)[::2], f"{flag} {target}",
                    "exists already", "--overwrite")
    assert target.read_text() == "the user's notes\n"
    assert gasfilm(capsys, "export", session_path, flag, target, "--overwrite")[0] == 0
    assert target.read_text() != "the user's notes\n"

    shared = tmp_path / "shared"
    shared.mkdir()
    exported = shared / f"frf.{flag[2:]}"
    exported.write_text("last week's export\n")
    link = tmp_path / f"link.{flag[2:]}"
    link.symlink_to(exported)
    assert_one_line(*gasfilm(capsys, "export", session_path, flag, link)[::2], "exists already",
                    str(exported), "--overwrite")
    assert exported.read_text() == "last week's export\n"
    assert gasfilm(capsys, "export", session_path, flag, link, "--overwrite")[0] == 0
    assert link.is_symlink() and link.resolve() == exported  # the link kept, the file it points to replaced
    assert exported.read_text() != "last week's export\n" and exported.stat().st_size > 0
    assert sorted(os.listdir(shared)) == [exported.name]  # nothing left beside it


def test_unwritable_output_paths_are_one_line_before_the_work(tmp_path, capsys, session_path):
    for argv, flag in (
        (("export", session_path, "--uff", "/proc/x.uff"), "--uff /proc/x.uff"),
        (("export", session_path, "--csv", tmp_path / "no-folder" / "x.csv"), "does not exist"),
        (("export", session_path, "--csv", tmp_path), "is a folder"),
        (("fit", session_path, "--models", "SD", "--out", "/proc/nope"), "--out /proc/nope"),
        (("replay", session_path, "--out", "/proc/replayed.h5"), "--out /proc/replayed.h5"),
        (("diagnose", session_path, "--out", "/proc/diagnosis"), "--out /proc/diagnosis"),
        (("demo", "--out", "/proc/demo.h5"), "--out /proc/demo.h5"),
    ):
        status, out, err = gasfilm(capsys, *argv)
        assert_one_line(status, err, flag)
        assert out == ""  # refused before anything was computed or printed


def test_every_command_refuses_to_replace_an_existing_output(tmp_path, capsys, session_path):
    existing = tmp_path / "existing.h5"
    existing.write_text("a text file, not a session\n")
    for argv in (("demo", "--out", existing, "--hits", 1), ("replay", session_path, "--out", existing),
                 ("acquire", *FAST_SIM, "--out", existing, "--hits", 1)):
        status, out, err = gasfilm(capsys, *argv)
        assert_one_line(status, err, f"--out {existing}", "exists already")
    assert existing.read_text() == "a text file, not a session\n"

    figures = tmp_path / "figures"
    figures.mkdir()
    stale = figures / f"{session_path.stem}-figure18.png"
    stale.write_bytes(b"an earlier figure")
    assert_one_line(*gasfilm(capsys, "fit", session_path, "--models", "SD", "--out", figures)[::2], str(stale))
    assert stale.read_bytes() == b"an earlier figure"

    diagnosis = tmp_path / "diagnosis"
    diagnosis.mkdir()
    (diagnosis / "improved-rig.toml").write_text("# my spec\n")
    assert_one_line(*gasfilm(capsys, "diagnose", session_path, "--out", diagnosis)[::2], "improved-rig.toml",
                    "exists already")
    assert (diagnosis / "improved-rig.toml").read_text() == "# my spec\n"


def test_replay_out_with_overwrite_replaces_a_session(tmp_path, capsys, session_path):
    target = tmp_path / "replayed.h5"
    assert gasfilm(capsys, "replay", session_path, "--out", target)[0] == 0
    assert_one_line(*gasfilm(capsys, "replay", session_path, "--out", target, "--exp-end", 0.1)[::2], "exists")
    assert gasfilm(capsys, "replay", session_path, "--out", target, "--exp-end", 0.1, "--overwrite")[0] == 0
    with Session.open(target) as session:
        assert session.read_frf().window["exponential_end_fraction"] == 0.1
    assert not any(name.endswith(".probe") for name in os.listdir(tmp_path))  # the write test leaves nothing


def test_demo_without_out_never_replaces_an_earlier_demo(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    earlier = tmp_path / "out" / "demo-session.h5"
    earlier.parent.mkdir()
    earlier.write_text("an earlier demo\n")
    status, out, err = gasfilm(capsys, "demo", "--hits", 1, "--no-fit")
    assert status == 0, err
    assert "out/demo-session-2.h5" in out
    assert earlier.read_text() == "an earlier demo\n"
    with Session.open(tmp_path / "out" / "demo-session-2.h5") as session:
        assert len(session.accepted_indices()) == 1
