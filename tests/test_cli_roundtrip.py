"""gasfilm reads what it writes, and treats a recording from elsewhere as one (issue 15, items 1–3 and 11): a UFF
export holds the hits' time records that replay/diagnose need and an FRF that fit reads alone; a recording that still
rings at its end gives an FRF with the truncation flagged and the advised window one flag away; export and fit of
files average only the hits replay accepts; one average says its coherence means nothing."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gasfilm.analysis.session import Session
from gasfilm.analysis.uff import read_uff_frf, read_uff_time_records
from test_cli_acquire_replay import FAST_SIM, gasfilm
from test_cli_files import REAL_FILES


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("roundtrip") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "3", "--seed", "5"]) == 0
    return path


def test_export_uff_writes_time_records_that_replay_fit_and_diagnose_read_back(session_path, tmp_path, capsys):
    out = tmp_path / "run.uff"
    status, text, err = gasfilm(capsys, "export", session_path, "--uff", out)
    assert status == 0 and "with the time records of 3 hits" in text, err
    with Session.open(session_path) as session:
        records = session.accepted_records()
        stored = session.read_frf()
    back = read_uff_time_records(out)
    np.testing.assert_allclose(back.records, records, rtol=0, atol=1e-9 * np.max(np.abs(records)))
    frf = read_uff_frf(out)
    assert frf.n_averages == 3 and frf.sample_rate_hz == stored.sample_rate_hz
    np.testing.assert_allclose(frf.h1, stored.h1, rtol=1e-9, atol=1e-12)

    status, text, err = gasfilm(capsys, "replay", out, "--json")
    assert status == 0, err
    assert json.loads(text)["accepted"] == 3
    status, text, err = gasfilm(capsys, "fit", out, "--models", "SD", "--out", tmp_path)
    assert status == 0 and "FRF stored in the file (3 averages)" in text, err


def test_an_frf_only_uff_is_fitted_and_replay_or_diagnose_say_in_one_line_what_is_missing(session_path, tmp_path,
                                                                                         capsys):
    out = tmp_path / "frf-only.uff"
    status, text, err = gasfilm(capsys, "export", session_path, "--uff", out, "--no-time-records")
    assert status == 0, err
    status, text, err = gasfilm(capsys, "fit", out, "--models", "SD", "--out", tmp_path)
    assert status == 0 and "FRF stored in the file" in text, err
    for command in (["replay", out], ["diagnose", out, "--out", tmp_path / "diagnosis"]):
        status, text, err = gasfilm(capsys, *command)
        errors = [line for line in err.splitlines() if not line.startswith("  ")]  # diagnose's progress is indented
        assert status == 2 and len(errors) == 1 and "Traceback" not in err, err
        assert "holds an FRF but no time records" in errors[0] and "gasfilm export" in errors[0]


def test_export_names_what_it_writes_by_its_extension(session_path, tmp_path, capsys):
    for flag, name in (("--uff", "out.csv"), ("--csv", "out.uff")):
        status, _, err = gasfilm(capsys, "export", session_path, flag, tmp_path / name)
        assert status == 2 and f"{flag} {tmp_path / name}" in err and "must end in" in err, err
        assert not (tmp_path / name).exists()
    status, _, err = gasfilm(capsys, "export", session_path, "--csv", tmp_path / "a.csv", "--time-records")
    assert status == 2 and "--time-records" in err


def test_a_ringing_recording_from_elsewhere_gives_its_frf_with_the_truncation_flagged(capsys):
    status, text, err = gasfilm(capsys, "replay", *REAL_FILES, "--json")
    assert status == 0, err  # before: "0 accepted, 5 rejected ... no FRF"
    summary = json.loads(text)
    assert summary["accepted"] == 5 and summary["flagged"] == {"response not decayed": 5}
    assert summary["advised_exp_end"] is not None and 0 < summary["advised_exp_end"] < 1
    assert all(note.startswith("hit ") for note in summary["notes"]) and summary["notes"][0].startswith("hit 1:")
    status, text, err = gasfilm(capsys, "replay", *REAL_FILES)
    assert status == 0 and f"advice: add --exp-end {summary['advised_exp_end']:g}" in text
    assert "leakage" in text
    # the advised window, one flag away, cures it
    status, text, err = gasfilm(capsys, "replay", *REAL_FILES, "--exp-end", f"{summary['advised_exp_end']:g}",
                                "--json")
    assert status == 0 and json.loads(text)["flagged"] == {}, text


def test_export_of_files_averages_only_the_hits_replay_accepts(tmp_path, capsys):
    files = []
    for number, path in enumerate(REAL_FILES[:3]):
        record = np.load(path)
        if number == 1:  # a second impact half way through the record: replay rejects it as a double hit
            pulse = np.flatnonzero(record[1] > 0.5 * record[1].max())
            record[1, pulse + record.shape[1] // 2] += record[1, pulse]
        files.append(tmp_path / f"hit{number}.npy")
        np.save(files[-1], record)
    status, text, err = gasfilm(capsys, "replay", *files, "--json")
    summary = json.loads(text)
    assert summary["accepted"] == 2 and summary["reasons"].get("double hit") == 1, summary
    status, text, err = gasfilm(capsys, "export", *files, "--csv", tmp_path / "frf.csv")
    assert status == 0, err
    assert "2 averages" in text and "1 rejected as `gasfilm replay` rejects them" in text, text


def test_one_average_says_its_coherence_means_nothing(tmp_path, capsys):
    status, text, err = gasfilm(capsys, "replay", REAL_FILES[0], "--exp-end", "0.01")
    assert status == 0, err
    assert "coherence: not meaningful: one average" in text and "mean 1.0000" not in text
    status, text, err = gasfilm(capsys, "replay", REAL_FILES[0], "--exp-end", "0.01", "--json")
    assert json.loads(text)["coherence_note"].startswith("not meaningful")
