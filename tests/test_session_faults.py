"""Sessions under faults: a write error or full disk mid-recording, two writers creating the same file at once,
SIGTERM/SIGHUP, leftovers of killed creations, runaway rejections and the size limit.

Each fault is real: a write limit the kernel enforces (RLIMIT_FSIZE: HDF5's writes fail with EFBIG exactly as on a full
disk), a 2 MB tmpfs where the test may mount one (root), real signals, real concurrent processes.
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import signal
import subprocess
import sys

import numpy as np
import pytest

from gasfilm.analysis.capture import ImpactCapture, TriggerSettings
from gasfilm.analysis.recording import HitRecorder, RecordingStopped
from gasfilm.analysis.session import Session, SessionError, SessionWriteError
from gasfilm.analysis.validation import ValidationSettings, Verdict
from test_kill_safety import reported_hits
from test_session import RATE_HZ, new_session, synthetic_hits

ACQUIRE = [sys.executable, "-m", "gasfilm.app.cli", "acquire", "--device", "sim", "--rate", "6400", "--record-s", "0.25",
           "--hit-interval", "0.3", "0.45", "--seed", "3"]
RACE_ROUNDS = 24


def check_reported_hits_stored(path, stdout: str, status: str) -> dict[int, bool]:
    """Every hit the output reported is in the session with its verdict; the session opens, without NaN records."""
    reported = reported_hits(stdout.splitlines())
    with Session.open(path) as session:
        assert session.status == status, session.status_reason
        hits = session.hits()  # raises on NaN samples
        assert len(hits) >= len(reported)
        for number, accepted in reported.items():
            assert hits[number - 1].verdict.accepted == accepted
    with Session.open(path, "a") as session:  # recovered (if need be) and appendable
        assert session.hit_count == len(hits)
    return reported


def limit_file_size(limit_bytes: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit then fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return apply


def test_write_error_stops_acquire_with_one_line_and_keeps_every_reported_hit(tmp_path):
    path = tmp_path / "limited.h5"
    run = subprocess.run([*ACQUIRE, "--pacing", "fast", "--seconds", "1000", "--out", str(path)], capture_output=True,
                         text=True, timeout=120, preexec_fn=limit_file_size(600_000))
    assert run.returncode == 2, run.stderr  # not 139: no crash when the process exits
    assert run.stderr.count("\n") == 1 and "writing a new hit failed (File too large)" in run.stderr, run.stderr
    reported = check_reported_hits_stored(path, run.stdout, "interrupted")
    assert f"recording stopped, the {len(reported)} hits before it are kept" in run.stderr
    assert len(reported) >= 10
    assert not any(line.startswith("session ") for line in run.stdout.splitlines())


def mount_small_tmpfs(folder) -> bool:
    if os.geteuid() != 0:
        return False
    folder.mkdir()
    return subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(folder)],
                          capture_output=True).returncode == 0


def test_full_disk_stops_acquire_with_one_line_and_a_closed_session(tmp_path):
    disk = tmp_path / "disk"
    if not mount_small_tmpfs(disk):
        pytest.skip("mounting a 2 MB tmpfs needs root")
    try:
        path = disk / "full.h5"
        run = subprocess.run([*ACQUIRE, "--pacing", "fast", "--seconds", "1000", "--out", str(path)],
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 2, run.stderr
        assert run.stderr.count("\n") == 1 and "disk full" in run.stderr, run.stderr
        reported = check_reported_hits_stored(path, run.stdout, "aborted")
        assert len(reported) >= 10
    finally:
        subprocess.run(["umount", str(disk)], check=False)


def test_write_error_in_the_api_keeps_the_session_readable(tmp_path):
    """In a child limited to a file size: the hit that fails is not counted (the session is rolled back to the hit
    before), nothing more is written, and the session is closed as interrupted, saying why."""
    path = tmp_path / "api.h5"
    script = (
        "import sys\n"
        f"sys.path.insert(0, {os.path.dirname(__file__)!r})\n"
        "from test_session import new_session, synthetic_hits\n"
        "from gasfilm.analysis.session import SessionWriteError\n"
        "from gasfilm.analysis.validation import Verdict\n"
        f"session = new_session({str(path)!r})\n"
        "hit = synthetic_hits(1)[0]\n"
        "try:\n"
        "    while True:\n"
        "        session.append_hit(hit, Verdict(True))\n"
        "except SessionWriteError as error:\n"
        "    print(session.hit_count, error)\n"
        "for again in (lambda: session.append_hit(hit, Verdict(True)), lambda: session.write_fit('x', {'a': 1})):\n"
        "    try:\n"
        "        again()\n"
        "    except SessionWriteError as error:\n"
        "        print(error)\n"
        "session.close('aborted', 'disk full')\n"
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60,
                         preexec_fn=limit_file_size(500_000))
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""  # no "Exception ignored" tracebacks from h5py
    lines = run.stdout.splitlines()
    kept = int(lines[0].split()[0])
    assert f"the {kept} hits before it are kept" in lines[0] and kept >= 5
    assert all("writing failed earlier (File too large)" in line for line in lines[1:3])
    with Session.open(path) as session:
        assert session.status == "interrupted" and session.hit_count == kept
        np.testing.assert_array_equal(session.accepted_records()[-1], synthetic_hits(1)[0].data)


def race_worker(path_stem: str, worker: int, rounds: int, barrier, results) -> None:
    hits = synthetic_hits(2, seed=worker)
    for round_ in range(rounds):
        barrier.wait(30)
        try:
            session = new_session(f"{path_stem}-{round_}.h5")
        except SessionError as error:
            results.put((round_, worker, "lost", str(error)))
            continue
        with session:
            for hit in hits:
                session.append_hit(hit, Verdict(True))
        results.put((round_, worker, "won", [float(hit.data[0].max()) for hit in hits]))


def test_two_processes_creating_the_same_session_at_once_one_wins(tmp_path):
    # forked workers start at once (no imports); no HDF5 file is open in this process when they fork
    context = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn")
    barrier, results = context.Barrier(2), context.Queue()
    workers = [context.Process(target=race_worker, args=(str(tmp_path / "race"), worker, RACE_ROUNDS, barrier, results))
               for worker in range(2)]
    for process in workers:
        process.start()
    outcomes = [results.get(timeout=60) for _ in range(2 * RACE_ROUNDS)]
    for process in workers:
        process.join(30)
        assert process.exitcode == 0
    for round_ in range(RACE_ROUNDS):
        this_round = {worker: (result, detail) for r, worker, result, detail in outcomes if r == round_}
        winners = [worker for worker, (result, _) in this_round.items() if result == "won"]
        assert len(winners) == 1, this_round
        loser_message = this_round[1 - winners[0]][1]
        # the loser either finds the winner's file made, or still being written (the winner holds its lock)
        assert ("exists already" in loser_message or "another process is writing this session" in loser_message) \
            and "\n" not in loser_message, loser_message
        with Session.open(tmp_path / f"race-{round_}.h5") as session:  # the winner's reported hits, no other
            assert [float(hit.data[0].max()) for hit in session.hits()] == this_round[winners[0]][1]
    assert not list(tmp_path.glob(".race*"))  # no hidden building files left


def test_sigterm_and_sighup_close_the_session_like_ctrl_c(tmp_path):
    names = ("SIGTERM", "SIGHUP")
    processes = {name: subprocess.Popen([*ACQUIRE, "--seconds", "1000", "--out", str(tmp_path / f"{name}.h5")],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for name in names}
    outputs = {}
    for name, process in processes.items():
        lines = []
        for line in process.stdout:
            lines.append(line)
            if line.startswith("accepted hit 2"):
                process.send_signal(getattr(signal, name))
                break
        outputs[name] = "".join(lines) + process.stdout.read()
    for name, process in processes.items():
        path = tmp_path / f"{name}.h5"
        assert process.wait(60) == 128 + getattr(signal, name), process.stderr.read()
        assert f"stopped by {name}: session {path} closed" in outputs[name]
        check_reported_hits_stored(path, outputs[name], "aborted")
        with Session.open(path) as session:
            assert session.status_reason == f"stopped by {name}"


def test_a_stop_signal_as_recording_starts_closes_the_session(tmp_path):
    """Issue 15 item 25: SIGTERM or SIGHUP the moment "recording into …" is printed (the handlers are installed before
    anything is printed) ends the run through the cleanup: its message, status 128 + signal, the session aborted."""
    names = ("SIGTERM", "SIGHUP")
    processes = {name: subprocess.Popen([*ACQUIRE, "--seconds", "1000", "--out", str(tmp_path / f"{name}.h5")],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for name in names}
    for name, process in processes.items():
        first = process.stdout.readline()
        process.send_signal(getattr(signal, name))
        assert first.startswith("recording into"), first + process.stderr.read()
        rest = process.stdout.read()
        assert process.wait(60) == 128 + getattr(signal, name), process.stderr.read()
        path = tmp_path / f"{name}.h5"
        assert f"stopped by {name}: session {path} closed" in rest
        with Session.open(path) as session:
            assert session.status == "aborted" and session.status_reason == f"stopped by {name}"


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_leftovers_of_killed_creations_are_removed(tmp_path):
    path = tmp_path / "s.h5"
    gone = dead_pid()
    leftover = tmp_path / f".s.h5.{gone}.creating"
    other_session = tmp_path / f".other.h5.{gone}.creating"
    live = tmp_path / f".s.h5.{os.getppid()}.creating"  # a live process (pytest's parent) may still be building
    for file in (leftover, other_session, live):
        file.write_bytes(b"half-built")
    with new_session(path) as session:
        session.append_hit(synthetic_hits(1)[0], Verdict(True))
    assert not leftover.exists()
    assert other_session.exists() and live.exists()
    leftover.write_bytes(b"half-built")
    with Session.open(path, "a"):
        assert not leftover.exists()


def rejected_stream(count: int) -> np.ndarray:
    hits = synthetic_hits(count, double_hit=tuple(range(count)))
    gap = np.zeros((2, 300))
    return np.concatenate([np.concatenate((gap, hit.data), axis=1) for hit in hits] + [gap], axis=1)


def test_recorder_stops_after_a_run_of_rejected_hits(tmp_path):
    trigger = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=0.5)
    stream = rejected_stream(8)
    with new_session(tmp_path / "s.h5") as session:
        recorder = HitRecorder(session, ImpactCapture(trigger, RATE_HZ, 2), ValidationSettings(),
                               max_consecutive_rejections=5)
        with pytest.raises(RecordingStopped) as stopped:
            for start in range(0, stream.shape[1], 500):
                recorder.feed(stream[:, start : start + 500], np.zeros(2, bool))
        assert "stopped after 5 consecutive rejected hits (last: double hit)" in str(stopped.value)
        assert session.hit_count == 5 and recorder.rejected_count == 5


def test_size_limit_refuses_to_grow_the_session(tmp_path):
    path = tmp_path / "s.h5"
    hits = synthetic_hits(6)
    with pytest.raises(SessionWriteError, match="reached its size limit") as refused:
        with new_session(path) as session:
            session.size_limit_bytes = os.path.getsize(path) + 3 * hits[0].data.nbytes
            for hit in hits:
                session.append_hit(hit, Verdict(False, ("double hit",)))  # rejected hits count too
    assert "\n" not in str(refused.value)
    with Session.open(path) as session:
        assert session.status == "aborted" and 1 <= session.hit_count < 6
        np.testing.assert_array_equal(session.hits()[-1].data, hits[session.hit_count - 1].data)
