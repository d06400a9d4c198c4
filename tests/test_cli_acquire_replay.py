"""``gasfilm acquire``, ``replay`` and ``export`` end to end on the simulated rig, and their one-line errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pyuff

from gasfilm.analysis.physics.response import rig_accelerance

from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import compute_frf
from gasfilm.app import cli
from gasfilm.drivers.simulated import SimulatedNI9234
from test_uff import time_record, write_uff

RATE_HZ = 51200.0 / 8  # 6400 S/s: the film's 199 Hz mode and its coherence band well resolved, small files
FAST_SIM = ["--device", "sim", "--pacing", "fast", "--rate", "6400", "--record-s", "0.25",
            "--hit-interval", "0.3", "0.45"]


def gasfilm(capsys, *argv: str) -> tuple[int, str, str]:
    status = cli.main([str(arg) for arg in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def accepted_lines(output: str) -> list[int]:
    return [int(line.split()[2]) for line in output.splitlines() if line.startswith("accepted hit ")]


def test_acquire_append_replay_export(tmp_path, capsys):
    path = tmp_path / "run.h5"
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 6, "--seed", 3,
                               "--double-hit-rate", 0.4)
    assert status == 0, err
    assert len(accepted_lines(out)) == 6
    rejected_lines = [line for line in out.splitlines() if line.startswith("rejected hit ")]
    assert rejected_lines and all(line.endswith("double hit") for line in rejected_lines)
    with Session.open(path) as session:
        assert session.status == "complete" and session.sample_rate_hz == RATE_HZ
        assert session.hit_count == 6 + len(rejected_lines)
        assert [i + 1 for i in session.accepted_indices()] == accepted_lines(out)
        assert RigSpec.from_toml(session.rig_spec_toml).to_toml() == RigSpec.nominal("FOMGF").to_toml()
        first_records = session.accepted_records()
        stored_frf = session.read_frf()
        assert stored_frf.n_averages == 6

    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 2, "--seed", 4, "--append")
    assert status == 0, err
    with Session.open(path) as session:
        records = session.accepted_records()
        assert len(records) == 8
        np.testing.assert_array_equal(records[:6], first_records)

    status, out, err = gasfilm(capsys, "replay", path, "--exp-end", 0.05, "--double-hit-fraction", 0.9, "--json")
    assert status == 0, err
    summary = json.loads(out)
    with Session.open(path) as session:
        assert summary["hits"] == session.hit_count
    assert summary["accepted"] >= 8
    freq_hz = np.arange(20.0, 2000.0, 0.5)
    true_peak_hz = freq_hz[np.argmax(np.abs(rig_accelerance(RigSpec.nominal("FOMGF"), freq_hz)))]
    assert abs(summary["peak_frequency_hz"] - true_peak_hz) <= 4.0  # 4 Hz lines (0.25 s records)
    bands = {(band["low_hz"], band["high_hz"]): band["mean_coherence"] for band in summary["coherence_bands"]}
    assert bands[(100.0, 300.0)] > 0.99
    with Session.open(path) as session:
        assert "replay" in session.result_names("frf")
        assert session.read_frf("replay").window["exponential_end_fraction"] == 0.05
        assert session.status == "complete"

    retriggered = tmp_path / "retriggered.h5"
    status, out, err = gasfilm(capsys, "replay", path, "--trigger-n", 60, "--out", retriggered, "--json")
    assert status == 0, err
    assert json.loads(out)["records_without_trigger"] == 0
    with Session.open(retriggered) as session, Session.open(path) as original:
        assert session.hit_count == original.hit_count
        assert session.record_samples == original.record_samples - int(0.01 * RATE_HZ)  # one pre-trigger shorter
        for new, old in zip(session.hits(), original.hits()):
            assert new.trigger_index == int(0.01 * RATE_HZ) and new.trigger_time_s >= old.trigger_time_s
        assert session.settings["trigger"]["level_n"] == 60
        replayed = session.read_frf()
        np.testing.assert_allclose(replayed.h1, compute_frf(session.accepted_records(), RATE_HZ).h1)

    uff_path, csv_path = tmp_path / "frf.uff", tmp_path / "frf.csv"
    assert gasfilm(capsys, "export", path, "--uff", uff_path)[0] == 0
    assert gasfilm(capsys, "export", path, "--csv", csv_path)[0] == 0
    with Session.open(path) as session:
        frf = session.read_frf("frf")
    h1_set, coherence_set = pyuff.UFF(str(uff_path)).read_sets()[1:3]  # then the hits' time records
    np.testing.assert_allclose(h1_set["data"], frf.h1, rtol=1e-11)
    np.testing.assert_allclose(coherence_set["data"], frf.coherence, rtol=1e-11)
    table = np.loadtxt(csv_path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], frf.freq_hz)
    np.testing.assert_allclose(table[:, 1] + 1j * table[:, 2], frf.h1, rtol=1e-10)
    np.testing.assert_allclose(table[:, 8], frf.coherence, rtol=1e-10)

    # the same hits as UFF time records replay to the same FRF
    with Session.open(path) as session:
        datasets = []
        for hit in session.hits():
            datasets += [time_record(hit.data[0], 1, 3, 13, "N", hit=hit.index, sample_rate_hz=RATE_HZ),
                         time_record(hit.data[1], 2, 3, 12, "m/s^2", hit=hit.index, sample_rate_hz=RATE_HZ)]
    hits_uff = write_uff(tmp_path / "hits.uff", datasets)
    from_uff = tmp_path / "from-uff.h5"
    status, out, err = gasfilm(capsys, "replay", hits_uff, "--out", from_uff, "--json")
    assert status == 0, err
    assert json.loads(out)["hits"] == len(datasets) // 2
    with Session.open(from_uff) as session:
        assert session.sample_rate_hz == RATE_HZ
        assert len(session.accepted_records()) >= 8


class FailingSimulator(SimulatedNI9234):
    """The simulated module, unplugged after a number of reads."""

    reads_before_removal = 40

    def read(self, out, timeout_s=10.0):
        self.reads_before_removal -= 1
        if self.reads_before_removal == 0:
            self.sim_inject_fault("device_removed")
        return super().read(out, timeout_s)


def test_device_error_mid_session_aborts_and_keeps_every_hit(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("gasfilm.drivers.open_device", lambda name, **options: FailingSimulator(**options))
    path = tmp_path / "removed.h5"
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--seconds", 60)
    assert status == 2
    assert err.count("\n") == 1 and "removed mid-stream" in err and "closed as aborted" in err
    reported = accepted_lines(out)
    assert len(reported) >= 5  # 40 reads of 0.1 s with a hit every 0.3–0.45 s
    with Session.open(path) as session:
        assert session.status == "aborted" and "removed mid-stream" in session.status_reason
        assert [i + 1 for i in session.accepted_indices()] == reported
    log = path.with_suffix(".log").read_text()  # the fault is also in the log next to the session
    assert "device fault" in log and "removed mid-stream" in log and f"{len(reported)} accepted hits kept" in log


def run_cli_subprocess(*argv) -> subprocess.Popen:
    environment = {**os.environ, "GASFILM_DEBUG": "0"}
    return subprocess.Popen([sys.executable, "-m", "gasfilm.app.cli", *map(str, argv)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=environment)


def test_bad_inputs_give_one_line_errors_without_traceback(tmp_path, capsys):
    good = tmp_path / "good.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", good, "--hits", 3)[0] == 0
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 3])
    wrong = tmp_path / "photo.h5"
    wrong.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    empty_uff = tmp_path / "empty.uff"
    empty_uff.write_bytes(b"")
    nan_session = tmp_path / "nan.h5"
    nan_session.write_bytes(good.read_bytes())
    with h5py.File(nan_session, "a") as f:
        f["hits/data"][1, 0, 500] = np.nan
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["temperature"] = np.arange(4.0)
    cases = {
        "truncated": (("replay", truncated), "truncated HDF5 file"),
        "truncated export": (("export", truncated, "--csv", tmp_path / "x.csv"), "truncated HDF5 file"),
        "wrong type": (("replay", wrong), "wrong file type: not an HDF5 file"),
        "empty uff": (("replay", empty_uff, "--out", tmp_path / "e.h5"), "empty UFF file"),
        "nan samples": (("replay", nan_session), "hit 2 has NaN samples in channel 0 (hammer)"),
        "foreign": (("export", foreign, "--uff", tmp_path / "x.uff"), "not a gasfilm session"),
        "missing": (("replay", tmp_path / "nothing.h5"), "no such session file"),
        "exists": (("acquire", *FAST_SIM, "--out", good, "--hits", 1), "exists already"),
    }
    processes = {name: run_cli_subprocess(*argv) for name, (argv, _) in cases.items()}
    for name, process in processes.items():
        out, err = process.communicate(timeout=60)
        expected = cases[name][1]
        assert process.returncode == 2, (name, err)
        assert "Traceback" not in err and "Traceback" not in out, name
        assert len(err.splitlines()) == 1, (name, err)
        assert err.startswith("gasfilm ") and expected in err, (name, err)
