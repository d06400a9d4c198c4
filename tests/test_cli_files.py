"""One command line for every file: sessions, UFF 58 time records and the shipped .npy real recording go through
replay, fit and export alike."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.app.cli import main
from test_uff import time_record, write_uff
from test_cli_acquire_replay import FAST_SIM, gasfilm

REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"
REAL_FILES = sorted(REAL.glob("measurements_*.npy"))
REAL_RATE_HZ = 25_600.0
#: The README's import command: the lightly damped structure still rings at 1 s, so it is windowed as
#: tests/test_real_data.py does.
REAL_WINDOW = ["--force-window-ms", "2", "--exp-end", "0.01"]


def real_records() -> np.ndarray:
    return np.stack([np.load(path)[1:] for path in REAL_FILES])


@pytest.fixture(scope="module")
def hits_uff(tmp_path_factory) -> tuple[Path, np.ndarray]:
    folder = tmp_path_factory.mktemp("files")
    session_path = folder / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(session_path), "--hits", "4", "--seed", "7"]) == 0
    with Session.open(session_path) as session:
        records = session.accepted_records()
    datasets = []
    for index, record in enumerate(records):
        datasets += [time_record(record[0], 1, 3, 13, "N", hit=index, sample_rate_hz=6400.0),
                     time_record(record[1], 2, 3, 12, "m/s^2", hit=index, sample_rate_hz=6400.0)]
    return write_uff(folder / "hits.uff", datasets), records


def test_replay_of_a_uff_file_prints_without_out(capsys, hits_uff):
    path, records = hits_uff
    status, out, err = gasfilm(capsys, "replay", path, "--json")
    assert status == 0, err
    summary = json.loads(out)
    assert summary["hits"] == len(records) and summary["accepted"] == len(records)
    assert summary["result"].startswith("printed only")
    assert sorted(p.name for p in path.parent.iterdir()) == ["hits.uff", "run.h5", "run.log"]  # nothing written


def test_export_and_fit_read_uff_time_records(tmp_path, capsys, hits_uff):
    path, records = hits_uff
    csv = tmp_path / "uff.csv"
    assert gasfilm(capsys, "export", path, "--csv", csv)[0] == 0
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    expected = compute_frf(records, 6400.0).h1
    np.testing.assert_allclose(table[:, 1] + 1j * table[:, 2], expected, rtol=0, atol=1e-9 * np.max(np.abs(expected)))
    status, out, err = gasfilm(capsys, "fit", path, "--models", "SD", "--out", tmp_path)
    assert status == 0, err
    assert "averaged from 4 of the 4 hits of uff records" in out and "not a mass on a gas film" not in err
    assert (tmp_path / "hits-figure18.png").stat().st_size > 0


def test_the_real_npy_recording_comes_in_with_one_command(tmp_path, capsys):
    session_path = tmp_path / "real.h5"
    status, out, err = gasfilm(capsys, "replay", *REAL_FILES, *REAL_WINDOW, "--out", session_path, "--json")
    assert status == 0, err
    summary = json.loads(out)
    assert summary["hits"] == 5 and summary["accepted"] == 5, summary
    expected = compute_frf(real_records(), REAL_RATE_HZ,
                           WindowSettings(force_window_ms=2.0, exponential_end_fraction=0.01))
    with Session.open(session_path) as session:
        assert session.sample_rate_hz == pytest.approx(REAL_RATE_HZ, rel=1e-9) and session.hit_count == 5
        np.testing.assert_allclose(session.read_frf().h1, expected.h1, rtol=1e-9)
    # not a mass on a film: fit warns in one line, and still answers
    status, out, err = gasfilm(capsys, "fit", session_path, "--models", "SD", "--band", "100:1000")
    assert status == 0, err
    warnings = [line for line in err.splitlines() if "not a mass on a gas film" in line]
    assert len(warnings) == 1 and warnings[0].startswith("gasfilm fit: WARNING: |H1| at the top of the band"), err
    assert "k" in out and "N/m" in out


def test_bad_npy_records_are_one_line(tmp_path, capsys):
    wrong_shape = tmp_path / "two-rows.npy"
    np.save(wrong_shape, np.zeros((2, 100)))
    uneven = tmp_path / "uneven.npy"
    record = np.load(REAL_FILES[0])
    record[0, 10] += 1e-3
    np.save(uneven, record)
    for path, expected in ((wrong_shape, "expected a float array of 3 rows"), (uneven, "not an evenly spaced time")):
        status, _, err = gasfilm(capsys, "replay", path)
        assert status == 2 and err.count("\n") == 1 and expected in err, err
    status, _, err = gasfilm(capsys, "replay", REAL_FILES[0], wrong_shape.with_suffix(".uff"))
    assert status == 2 and "only as .npy records" in err, err
