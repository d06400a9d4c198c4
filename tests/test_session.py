"""HDF5 sessions: round trip, reopen and append, results, bad files, NaN records, recovery after a killed writer."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.signal

from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.recording import HitRecorder
from gasfilm.analysis.session import SCHEMA_VERSION, Session, SessionError
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.validation import ValidationSettings, Verdict, validate_hit
from gasfilm.drivers.interface import default_hammer_and_accelerometer

RATE_HZ = 51200.0 / 20  # 2560 S/s: small records, the physics still resolved (mode at 100 Hz)
MASS_KG = 25.0
NATURAL_HZ = 100.0
DAMPING_RATIO = 0.03
RIG_TOML = 'name = "test rig"\nmass_kg = 25.0\n'


def hammer_pulse(samples: int, start: int, peak_n: float, width_s: float = 0.004) -> np.ndarray:
    """A half-sine force pulse."""
    force = np.zeros(samples)
    width = int(round(width_s * RATE_HZ))
    force[start : start + width] = peak_n * np.sin(np.pi * np.arange(width) / width)
    return force


def accelerance_response(force_n: np.ndarray) -> np.ndarray:
    """Acceleration of a mass-spring-damper driven by ``force_n`` (exact for the sampled input, zero-order hold)."""
    omega = 2 * np.pi * NATURAL_HZ
    system = ([1.0, 0.0, 0.0], [MASS_KG, 2 * DAMPING_RATIO * omega * MASS_KG, MASS_KG * omega**2])
    time_s = np.arange(force_n.size) / RATE_HZ
    _, acceleration, _ = scipy.signal.lsim(system, force_n, time_s)
    return acceleration


def synthetic_hits(count: int, seed: int = 0, samples: int = 2560, double_hit: tuple[int, ...] = ()) -> list[HitRecord]:
    """Hits with a clean pulse (a second one for the indices in ``double_hit``) and a little sensor noise."""
    rng = np.random.default_rng(seed)
    pretrigger = 26
    hits = []
    for index in range(count):
        force = hammer_pulse(samples, pretrigger - 1, rng.uniform(150, 250))
        if index in double_hit:
            force += hammer_pulse(samples, pretrigger + 60, 0.5 * force.max())
        response = accelerance_response(force)
        data = np.stack((force + rng.normal(0, 0.05, samples), response + rng.normal(0, 1e-4, samples)))
        hits.append(
            HitRecord(
                index=index,
                data=data,
                sample_rate_hz=RATE_HZ,
                trigger_index=pretrigger,
                start_time_s=2.0 * index,
                overload=np.array([False, index == count - 1]),
                force_channel=0,
                response_channel=1,
            )
        )
    return hits


def new_session(path, **kwargs) -> Session:
    settings = {"trigger": TriggerSettings(), "validation": ValidationSettings(), "window": WindowSettings()}
    return Session.create(path, default_hammer_and_accelerometer(RATE_HZ), RIG_TOML, settings, **kwargs)


def test_session_round_trip_reopen_append_and_frf(tmp_path):
    path = tmp_path / "s.h5"
    hits = synthetic_hits(6, double_hit=(1,))
    verdicts = [validate_hit(hit) for hit in hits]
    assert verdicts[1].reasons == ("double hit",) and verdicts[5].reasons == ("overload",)
    assert verdicts[0].accepted and verdicts[2].accepted
    with new_session(path, actual_sample_rate_hz=RATE_HZ, device_name="sim") as session:
        assert [session.append_hit(hit, verdict) for hit, verdict in zip(hits[:3], verdicts[:3])] == [0, 1, 2]
        assert session.status == "recording"
    with Session.open(path, "a") as session:
        assert session.status == "complete" and session.hit_count == 3
        assert [session.append_hit(hit, verdict) for hit, verdict in zip(hits[3:], verdicts[3:])] == [3, 4, 5]
        session.set_verdict(1, verdicts[1].overridden_to(True))
        frf = compute_frf(session.accepted_records(), RATE_HZ, WindowSettings(exponential_end_fraction=0.1))
        session.write_frf(frf, hit_indices=session.accepted_indices())
    with Session.open(path) as session:
        assert session.schema_version == SCHEMA_VERSION
        assert session.status == "complete"
        assert session.daq_config == default_hammer_and_accelerometer(RATE_HZ)
        assert session.sample_rate_hz == RATE_HZ and session.device_name == "sim"
        assert session.rig_spec_toml == RIG_TOML
        assert session.settings["trigger"]["level_n"] == TriggerSettings().level_n
        assert session.settings["window"]["exponential_end_fraction"] is None
        stored = session.hits()
        assert len(stored) == session.hit_count == 6
        for hit, verdict, kept in zip(hits, verdicts, stored):
            np.testing.assert_array_equal(kept.data, hit.data)
            np.testing.assert_array_equal(kept.overload, hit.overload)
            assert (kept.start_time_s, kept.trigger_index, kept.sample_rate_hz) == (
                hit.start_time_s, hit.trigger_index, hit.sample_rate_hz)
            if kept.index != 1:
                assert kept.verdict == verdict
        assert stored[1].verdict == Verdict(True, ("double hit",), overridden=True)
        expected = [i for i, v in enumerate(verdicts) if v.accepted or i == 1]
        np.testing.assert_array_equal(session.accepted_indices(), expected)
        np.testing.assert_array_equal(session.accepted_records(), np.stack([hits[i].data for i in expected]))
        np.testing.assert_array_equal(session.frf_hit_indices(), expected)
        read = session.read_frf()
    for name, value in frf.to_dict().items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(getattr(read, name), value, err_msg=name)
        else:
            assert getattr(read, name) == value, name


def test_fit_and_diagnosis_results_round_trip(tmp_path):
    path = tmp_path / "s.h5"
    fit = {"params": np.array([1.5, 2.5e6]), "rms": 0.25, "model": "SD", "converged": True,
           "bounds": {"k": [0, 1e8]}, "h_fit": np.array([1 + 2j, 3 - 1j])}
    with new_session(path) as session:
        session.append_hit(synthetic_hits(1)[0], Verdict(True))
        session.write_fit("SD", fit)
        session.write_diagnosis("mismatch", {"findings": [{"effect": "added mass", "score": 0.5}], "rms_before": 2.0})
        session.write_fit("SD", {**fit, "rms": 0.125})  # replaced, not duplicated
    with Session.open(path) as session:
        read = session.read_fit("SD")
        assert session.result_names("fits") == ["SD"]
        assert read["rms"] == 0.125 and read["model"] == "SD" and read["converged"] is True
        assert read["bounds"] == {"k": [0, 1e8]}
        np.testing.assert_array_equal(read["params"], fit["params"])
        np.testing.assert_array_equal(read["h_fit"], fit["h_fit"])
        assert session.read_diagnosis("mismatch")["findings"][0]["effect"] == "added mass"
        with pytest.raises(SessionError, match="no fits result named 'FOMGF'"):
            session.read_fit("FOMGF")


def test_hit_recorder_stores_every_hit_before_reporting_it(tmp_path):
    hits = synthetic_hits(4, seed=3, double_hit=(2,))
    gap = np.zeros((2, 300))
    stream = np.concatenate([np.concatenate((gap, hit.data), axis=1) for hit in hits] + [gap], axis=1)
    trigger = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=0.5)
    reported = []
    with new_session(tmp_path / "s.h5") as session:

        def on_hit(event):
            # the hit is on disk before the callback hears of it
            assert session.hit_count == event.index + 1
            reported.append(event)

        capture = ImpactCapture(trigger, RATE_HZ, 2)
        recorder = HitRecorder(session, capture, ValidationSettings(), full_scale_si=(446.0, 490.0), on_hit=on_hit)
        events = []
        for start in range(0, stream.shape[1], 333):
            events += recorder.feed(stream[:, start : start + 333], np.zeros(2, bool))
        assert events == reported and [e.index for e in events] == [0, 1, 2, 3]
        assert [e.verdict.accepted for e in events] == [True, True, False, True]
        assert recorder.reason_counts == {"double hit": 1}
        assert (events[-1].accepted_count, events[-1].rejected_count) == (3, 1)
        assert session.hit_count == 4 and session.record_samples == trigger.record_samples(RATE_HZ)


def test_append_checks_record_shape_and_nan(tmp_path):
    hits = synthetic_hits(2)
    with new_session(tmp_path / "s.h5") as session:
        session.append_hit(hits[0], Verdict(True))
        short = HitRecord(1, hits[1].data[:, :100], RATE_HZ, 26, 2.0)
        with pytest.raises(SessionError, match="hit 2 has 100 samples per channel; this session stores 2560"):
            session.append_hit(short, Verdict(True))
        bad = HitRecord(1, hits[1].data.copy(), RATE_HZ, 26, 2.0)
        bad.data[1, 7] = np.nan
        with pytest.raises(SessionError, match="hit 2 has NaN"):
            session.append_hit(bad, Verdict(True))
        assert session.hit_count == 1


def one_line_error(excinfo) -> str:
    message = str(excinfo.value)
    assert "\n" not in message
    return message


def test_bad_files_give_one_line_errors(tmp_path):
    with pytest.raises(SessionError) as missing:
        Session.open(tmp_path / "nothing.h5")
    assert "no such session file" in one_line_error(missing)

    text = tmp_path / "notes.h5"
    text.write_text("hit log\n")
    with pytest.raises(SessionError) as wrong:
        Session.open(text)
    assert "wrong file type" in one_line_error(wrong)

    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(SessionError) as not_session:
        Session.open(foreign, "a")
    assert "not a gasfilm session" in one_line_error(not_session)

    good = tmp_path / "good.h5"
    with new_session(good) as session:
        for hit in synthetic_hits(3):
            session.append_hit(hit, Verdict(True))
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(SessionError) as cut:
        Session.open(truncated)
    assert "truncated HDF5 file" in one_line_error(cut)

    with h5py.File(good, "a") as f:
        f.attrs["schema_version"] = SCHEMA_VERSION + 1
    with pytest.raises(SessionError) as newer:
        Session.open(good)
    assert f"schema_version {SCHEMA_VERSION + 1} is newer" in one_line_error(newer)

    with pytest.raises(SessionError, match="exists already"):
        new_session(good)


def test_nan_samples_on_disk_name_the_hit(tmp_path):
    path = tmp_path / "s.h5"
    with new_session(path) as session:
        for hit in synthetic_hits(3):
            session.append_hit(hit, Verdict(True))
    with h5py.File(path, "a") as f:
        f["hits/data"][2, 1, 100] = np.nan
    with Session.open(path) as session:
        with pytest.raises(SessionError) as nan:
            session.accepted_records()
        assert "hit 3 has NaN samples in channel 1 (accelerometer)" in one_line_error(nan)


def test_writer_killed_without_closing_leaves_a_readable_appendable_session(tmp_path):
    path = tmp_path / "killed.h5"
    script = textwrap.dedent(
        f"""
        import os, signal, sys
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_session import new_session, synthetic_hits
        from gasfilm.analysis.validation import Verdict
        session = new_session({str(path)!r})
        for hit in synthetic_hits(3):
            session.append_hit(hit, Verdict(hit.index != 1, () if hit.index != 1 else ("overload",)))
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=60)
    assert result.returncode == -9, result.stderr.decode()
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(path, "r")  # HDF5 itself refuses the file: the writer never closed it
    with Session.open(path) as session:
        assert session.status == "interrupted" and session.hit_count == 3
        np.testing.assert_array_equal(session.accepted_indices(), [0, 2])
    cut = tmp_path / "killed-and-cut.h5"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size * 2 // 3])
    for mode in ("r", "a"):
        with pytest.raises(SessionError) as truncated:
            Session.open(cut, mode)
        assert "truncated" in one_line_error(truncated)  # "truncated HDF5 file", or "... left open by its writer"
    hits = synthetic_hits(4)
    with Session.open(path, "a") as session:
        assert session.recovered and session.status == "interrupted"
        session.append_hit(hits[3], Verdict(True))
    with Session.open(path) as session:
        assert session.status == "complete" and not session.recovered
        np.testing.assert_array_equal(session.accepted_records(), np.stack([hits[i].data for i in (0, 2, 3)]))


@pytest.mark.parametrize("writes", ["", "session.write_fit('Zener', {'k1': 2.0}); session.add_diagnosis({'verdict': 'consistent'})"])
def test_a_viewer_killed_keeps_the_stored_results_and_the_status(tmp_path, writes):
    """New-user trial: the GUI opens a session for writing just to view it; killed (kill -9, or Ctrl-C ignored and
    then killed), the file was left open for writing outside SWMR mode, which HDF5 cannot read at all — the next
    command rebuilt the session from its journal and every stored FRF, fit and diagnosis was gone, the session marked
    'interrupted'. Opened for writing, a session now stays readable on disk after every change."""
    path = tmp_path / "viewed.h5"
    with new_session(path) as session:
        for hit in synthetic_hits(2):
            session.append_hit(hit, Verdict(True))
        session.write_fit("SD", {"k": 1.0})
        session.add_diagnosis({"verdict": "missing physics"})
    script = textwrap.dedent(
        f"""
        import os, signal
        from gasfilm.analysis.session import Session
        session = Session.open({str(path)!r}, "a")
        {writes}
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=60)
    assert result.returncode == -9, result.stderr.decode()
    fits = ["SD", "Zener"] if writes else ["SD"]
    for mode in ("r", "a", "r"):
        with Session.open(path, mode) as session:
            assert session.result_names("fits") == fits and session.hit_count == 2
            assert len(session.result_names("diagnoses")) == (3 if writes else 2)  # runs and 'latest'
            assert session.status == "complete"


def test_live_session_can_be_read_but_not_taken_over(tmp_path):
    path = tmp_path / "live.h5"
    script = textwrap.dedent(
        f"""
        import sys
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_session import new_session, synthetic_hits
        from gasfilm.analysis.validation import Verdict
        hits = synthetic_hits(3)
        with new_session({str(path)!r}) as session:
            for hit in hits[:2]:
                session.append_hit(hit, Verdict(True))
            print("two", flush=True)
            sys.stdin.readline()
            session.append_hit(hits[2], Verdict(False, ("overload",)))
            print("three", flush=True)
            sys.stdin.readline()
        """
    )
    writer = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "two"
        with pytest.raises(SessionError, match="another process is writing this session"):
            Session.open(path, "a")
        with pytest.raises(SessionError, match="another process is writing this session"):
            new_session(path, overwrite=True)
        with Session.open(path) as reader:
            assert reader.status == "recording" and not reader.recovered
            assert reader.hit_count == 2 and reader.accepted_records().shape == (2, 2, 2560)
        writer.stdin.write("\n")
        writer.stdin.flush()
        assert writer.stdout.readline().strip() == "three"
        with Session.open(path) as reader:  # read while recording, in SWMR mode
            assert [v.accepted for v in reader.verdicts()] == [True, True, False]
        writer.stdin.write("\n")
        writer.stdin.flush()
        assert writer.wait(30) == 0
    finally:
        writer.kill()
    with Session.open(path, "a") as session:
        assert session.status == "complete" and session.hit_count == 3 and not session.recovered


def test_a_process_reading_the_session_it_writes_itself_says_nothing_of_another_process(tmp_path, caplog):
    """The GUI diagnosing the session it has open read its own writer lock as another process's and warned "open for
    writing in another gasfilm process"; asking for its own lock again said "another process is writing"."""
    import logging

    from gasfilm.analysis.session.files import WriterLock

    path = tmp_path / "own.h5"
    with new_session(path) as session:
        session.append_hit(synthetic_hits(1)[0], Verdict(True))
        assert WriterLock.held_here(path) and WriterLock.held_by_a_writer(path)
        with caplog.at_level(logging.WARNING):
            with Session.open(path) as reader:
                assert reader.hit_count == 1
        assert "another" not in caplog.text
        with pytest.raises(SessionError, match="this process has the session open for writing already"):
            Session.open(path, "a")
    assert not WriterLock.held_here(path) and not WriterLock.held_by_a_writer(path)  # released with the session
