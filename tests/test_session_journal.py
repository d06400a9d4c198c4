"""The session's rollback journal (issue 15 items 23 and 24, issue 33 items 2 and 7): no failed write, full disk,
damaged metadata or kill loses a hit that was reported as stored, gasfilm (then plain h5py) reads every such hit back,
and a session written in place is always as its last commit left it (or restored to it, byte for byte).

The write faults are real: a preloaded library (tests/faults/failing_writes.c) makes one of the process's writes
to regular files fail — Python's and HDF5's alike — and tests/faults/session_write_faults.py runs a session's life
with each write failing in turn; a small tmpfs filled by another process where the test may mount one (root).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from gasfilm.analysis.session import Session, SessionError
from gasfilm.analysis.validation import Verdict
from test_kill_safety import reported_hits
from test_session import new_session, synthetic_hits
from test_session_faults import ACQUIRE

FAULTS = Path(__file__).parent / "faults"


@pytest.fixture(scope="module")
def failing_writes(tmp_path_factory) -> Path:
    """The fault-injection library, built for this machine."""
    if not sys.platform.startswith("linux") or shutil.which("cc") is None:
        pytest.skip("the write-fault library needs Linux and a C compiler")
    library = tmp_path_factory.mktemp("faults") / "failing_writes.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-O1", "-o", str(library), str(FAULTS / "failing_writes.c"), "-ldl"],
                   check=True, capture_output=True)
    return library


def preloaded(library: Path, **variables: str) -> dict[str, str]:
    return dict(os.environ, LD_PRELOAD=str(library), PYTHONDONTWRITEBYTECODE="1", **variables)


def plain_h5py_hits(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The committed hits as plain h5py reads them: (table rows, records)."""
    with h5py.File(path, "r") as file:
        rows, records = file["hits/table"][()], file["hits/data"][()]
    count = min(len(rows), len(records))
    return rows[:count], records[:count]


@pytest.mark.parametrize("mode, every", [("disk-full", 11), ("one-write", 7), ("disk-full-at-byte", 0)])
def test_a_failed_write_anywhere_in_a_session_loses_no_reported_hit(failing_writes, mode, every):
    """Create, three hits, an overruled verdict, a fit, close, append a hit, close — with write N failing (the disk
    full from N on, or N alone failing with EIO) for every 11th or 7th N (primes: each run lands on other writes), or
    the disk full at every 30 kB: after each, every
    hit reported is read back by gasfilm and, once gasfilm has opened the session for writing, by plain h5py.
    (``session_write_faults.py SHIM MODE`` without ``--every`` runs every write, 101, and every 4096 bytes, 167
    positions: 0 problems in each mode.)"""
    options = ["--bytes-step", "30000"] if mode == "disk-full-at-byte" else ["--every", str(every)]
    run = subprocess.run([sys.executable, str(FAULTS / "session_write_faults.py"), str(failing_writes), mode,
                          *options], env=preloaded(failing_writes), capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr[-2000:]
    result = json.loads(run.stdout.splitlines()[-1])
    assert result["problems"] == []
    assert result["writes"] > 50 and result["trials"] >= (result["writes"] // every if every else 10)
    assert set(result["errors"]) >= {"SessionWriteError"}  # the failures did happen and were reported as such


def mount_tmpfs(folder: Path, size: str) -> bool:
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    folder.mkdir()
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                          capture_output=True).returncode == 0


def fill(folder: Path) -> Path:
    """Another process's file that takes every free byte of the disk."""
    filler = folder / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT | os.O_EXCL)
    try:
        for block in (65536, 1):
            try:
                while True:
                    os.write(fd, b"\0" * block)
            except OSError:
                pass
    finally:
        os.close(fd)
    return filler


def check_every_reported_hit_kept(path: Path, stdout: str, append_with_cli: bool = True) -> int:
    """Every reported hit reads back (gasfilm, then plain h5py after an append: `acquire --append`, or opening it for
    writing through the API); returns how many were reported."""
    reported = reported_hits(stdout.splitlines())
    with Session.open(path) as session:
        hits = session.hits()
        assert len(hits) >= len(reported)
        assert all(hits[number - 1].verdict.accepted == accepted for number, accepted in reported.items())
        records = [hit.data for hit in hits]
    if append_with_cli:
        append = subprocess.run([*ACQUIRE, "--pacing", "fast", "--seconds", "1", "--append", "--out", str(path)],
                                capture_output=True, text=True, timeout=120)
        assert append.returncode == 0, append.stderr
    else:
        Session.open(path, "a").close()
    rows, stored = plain_h5py_hits(path)
    assert len(rows) >= len(records) + append_with_cli
    assert all(np.array_equal(a, b) for a, b in zip(stored, records))
    assert not path.with_name(path.name + ".journal").exists()
    return len(reported)


def test_a_disk_filled_by_another_process_during_acquisition_keeps_every_reported_hit(tmp_path):
    """Issue 15 item 23, literally: a small tmpfs filled by another process while `acquire` records."""
    disk = tmp_path / "disk"
    if not mount_tmpfs(disk, "6m"):
        pytest.skip("mounting a tmpfs needs root")
    process = None
    try:
        path = disk / "s.h5"
        process = subprocess.Popen([*ACQUIRE, "--seconds", "1000", "--out", str(path)], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True)
        lines = []
        for line in process.stdout:
            lines.append(line)
            if line.startswith("accepted hit 5"):
                filler = fill(disk)
                break
        stdout = "".join(lines) + process.stdout.read()
        stderr = process.stderr.read()
        assert process.wait(60) == 2, stderr
        assert stderr.count("\n") == 1 and "No space left on device" in stderr, stderr
        filler.unlink()
        assert check_every_reported_hit_kept(path, stdout) >= 5
    finally:
        if process is not None and process.poll() is None:
            process.kill()
            process.wait()
        subprocess.run(["umount", str(disk)], check=False)


def test_a_disk_full_from_any_write_of_acquire_keeps_every_reported_hit(failing_writes, tmp_path):
    """Issue 15 item 23 where no tmpfs can be mounted: `acquire` with the disk full from its N-th write on (during a
    hit's journal entry, during its HDF5 write)."""
    for at in (60, 200):
        path = tmp_path / f"full-{at}.h5"
        run = subprocess.run([*ACQUIRE, "--pacing", "fast", "--seconds", "1000", "--out", str(path)],
                             env=preloaded(failing_writes, FAILING_WRITES_MODE="1", FAILING_WRITES_AT=str(at)),
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
        assert "No space left on device" in run.stderr and "internal error" not in run.stderr
        check_every_reported_hit_kept(path, run.stdout, append_with_cli=False)


def metadata_bit_flips(path: Path, rng: np.random.Generator, flips: int) -> Path:
    """A copy of the session with ``flips`` bits flipped outside the hit records (in HDF5's metadata)."""
    records = []
    with h5py.File(path, "r") as file:
        file["hits/data"].id.chunk_iter(lambda chunk: records.append((chunk.byte_offset, chunk.size)))
    data = bytearray(path.read_bytes())
    metadata = np.ones(len(data), dtype=bool)
    for offset, size in records:
        metadata[offset:offset + size] = False
    positions = np.flatnonzero(metadata)
    for position in rng.choice(positions, flips, replace=False):
        data[position] ^= 1 << int(rng.integers(8))
    damaged = path.with_name(f"damaged-{rng.integers(1 << 30)}.h5")
    damaged.write_bytes(bytes(data))
    return damaged


def test_appending_to_a_session_with_damaged_metadata_keeps_its_hits(tmp_path):
    """Issue 15 item 24: a few bits flipped in the metadata of a session that still reads; appending to it either is
    refused in one line (the file untouched) or works — the 7 hits are never lost, nothing but a SessionError
    escapes, and plain h5py reads the result."""
    original = tmp_path / "seven.h5"
    hits = synthetic_hits(8, samples=512)
    with new_session(original) as session:
        for hit in hits[:7]:
            session.append_hit(hit, Verdict(True))
    rng = np.random.default_rng(24)
    appended = refused = 0
    for _ in range(30):
        damaged = metadata_bit_flips(original, rng, 3)
        try:
            with Session.open(damaged) as session:
                before = [hit.data for hit in session.hits()]
        except SessionError:
            continue  # the damage shows on reading: nothing to append to
        try:
            with Session.open(damaged, "a") as session:
                session.append_hit(hits[7], Verdict(True))
            appended += 1
        except SessionError:
            refused += 1
        with Session.open(damaged) as session:
            after = [hit.data for hit in session.hits()]
        assert len(after) >= len(before) and all(np.array_equal(a, b) for a, b in zip(after, before))
        if len(after) > len(before):
            rows, records = plain_h5py_hits(damaged)
            assert len(rows) == 8 and np.array_equal(records[7], hits[7].data)
    assert appended >= 10


def killed_during_a_commit(path: Path, hits: list, at: int) -> bytes:
    """A child that records ``hits[:-1]`` into a new session, then is killed during the commit of the last hit, after
    its ``at``-th write into the session file once the rollback journal is written; returns the file's bytes as the
    last complete commit left them."""
    reading, writing = os.pipe()
    pid = os.fork()
    if pid == 0:
        from gasfilm.analysis.session import journal

        os.close(reading)
        session = new_session(path)
        for hit in hits[:-1]:
            session.append_hit(hit, Verdict(True))
        committed = memoryview(path.read_bytes())
        while committed:  # (a pipe takes a large write in parts when a signal comes meanwhile)
            committed = committed[os.write(writing, committed):]
        os.close(writing)
        writes = []
        real_pwrite, real_write_journal = journal._pwrite_all, journal.RollbackFile._write_journal

        def write_journal(store, old):
            real_write_journal(store, old)
            writes.append("journal")

        def pwrite(fd, data, offset):
            if writes:
                writes.append(offset)
                if len(writes) > at:
                    os.kill(os.getpid(), signal.SIGKILL)
            real_pwrite(fd, data, offset)

        journal._pwrite_all, journal.RollbackFile._write_journal = pwrite, write_journal
        session.append_hit(hits[-1], Verdict(True))
        os._exit(3)  # the commit had fewer writes than ``at``
    os.close(writing)
    committed = b""
    while chunk := os.read(reading, 1 << 16):
        committed += chunk
    os.close(reading)
    os.waitpid(pid, 0)
    return committed


def test_a_writer_killed_during_a_commit_leaves_the_last_commit_restored(tmp_path):
    """Killed after the journal is written and after each of the commit's writes into the file in turn: a reader
    sees the session as at its last commit (applying the journal in memory, writing nothing), the next writer
    restores the file to those bytes exactly, appends, and plain h5py reads every hit."""
    hits = synthetic_hits(4, samples=512)
    for at in range(1, 9):
        path = tmp_path / f"killed-{at}.h5"
        committed = killed_during_a_commit(path, hits[:3], at)
        journal = tmp_path / f"killed-{at}.h5.journal"
        if not journal.exists():
            assert at > 1  # (the commit's writes were fewer)
            break
        on_disk = path.read_bytes()
        with Session.open(path) as session:
            assert session.recovered and session.hit_count == 2 and session.status == "interrupted"
            assert all(np.array_equal(hit.data, original.data) for hit, original in zip(session.hits(), hits))
        assert path.read_bytes() == on_disk and journal.exists()
        session = Session.open(path, "a")
        assert not journal.exists()
        session.discard()
        assert path.read_bytes() == committed  # restored byte for byte
        with Session.open(path, "a") as session:
            assert session.recovered and session.hit_count == 2
            session.append_hit(hits[3], Verdict(True))
        rows, records = plain_h5py_hits(path)
        assert len(rows) == 3 and np.array_equal(records[2], hits[3].data) and np.array_equal(records[1], hits[1].data)


def test_an_incomplete_journal_is_ignored_and_removed(tmp_path):
    """A journal cut short (its writer killed while writing it, before the file changed) or damaged restores
    nothing: the session reads as the file holds it, and the next writer removes the journal."""
    path = tmp_path / "s.h5"
    hits = synthetic_hits(2, samples=512)
    with new_session(path) as session:
        for hit in hits:
            session.append_hit(hit, Verdict(True))
    before = path.read_bytes()
    journal = tmp_path / "s.h5.journal"
    journal.write_bytes(b"gasfilm rollback journal 1\n" + bytes(40))
    with Session.open(path) as session:
        assert session.hit_count == 2
    with Session.open(path, "a") as session:
        assert session.hit_count == 2
    assert not journal.exists() and path.read_bytes() == before


def test_a_session_written_nothing_to_is_left_byte_for_byte(tmp_path):
    """Opened for writing and closed (a viewer, a command that failed before storing anything), or a change discarded:
    the file is as it was, byte for byte."""
    path = tmp_path / "s.h5"
    hits = synthetic_hits(2, samples=512)
    with new_session(path) as session:
        session.append_hit(hits[0], Verdict(True))
    before = path.read_bytes()
    with Session.open(path, "a") as session:
        session.verdicts()
    assert path.read_bytes() == before
    session = Session.open(path, "a")
    session.update_settings({"note": "never committed"})
    session.discard()
    assert path.read_bytes() == before
    with pytest.raises(RuntimeError), Session.updating(path) as session:
        session.write_fit("SD", {"k": 1.0})
        session.write_fit("Zener", {"k": 2.0})
        raise RuntimeError("the command failed before it reported anything")
    assert path.read_bytes() == before
    with Session.updating(path) as session:
        session.write_fit("SD", {"k": 1.0})
        session.write_fit("Zener", {"k": 2.0})
    with Session.open(path) as session:
        assert session.result_names("fits") == ["SD", "Zener"] and session.status == "complete"


def test_results_and_settings_are_kept_when_opened_for_writing_again(tmp_path):
    path = tmp_path / "s.h5"
    hits = synthetic_hits(2, samples=512)
    with new_session(path) as session:
        for hit in hits:
            session.append_hit(hit, Verdict(True))
        session.write_fit("SD", {"rms": 0.25, "values": np.arange(3.0), "nested": {"a": [1, 2]}})
        session.update_settings({"replay": {"source": "x.uff"}})
    with Session.open(path, "a") as session:
        session.update_settings({"window": {"force_window_ms": 12.5}})
    with Session.open(path) as session:
        assert session.status == "complete"
        assert session.read_fit("SD")["nested"] == {"a": [1, 2]}
        assert session.settings["replay"] == {"source": "x.uff"}
        assert session.settings["window"] == {"force_window_ms": 12.5}
        assert session.hit_count == 2
