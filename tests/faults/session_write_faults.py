"""Run a session's life with one write made to fail, at every write in turn; check after each that every hit reported
as stored reads back (through gasfilm, then through plain h5py after gasfilm has rebuilt the file).

Run with ``failing_writes.so`` preloaded (see tests/test_session_journal.py), which counts the process's writes to
regular files and fails one of them. Each trial forks: the child arms the failure and lives the session's life,
reporting each step through a pipe once the API call returned; the parent (never armed) checks the result.
Prints one JSON object: the writes counted in the session's life, the trials run, the problems found.

    python session_write_faults.py SHIM MODE [--at N ...] [--every K] [--bytes-step B]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from test_session import new_session, synthetic_hits  # noqa: E402

from gasfilm.analysis.session import Session, SessionError  # noqa: E402
from gasfilm.analysis.validation import Verdict  # noqa: E402

MODES = {"disk-full": 1, "one-write": 2, "disk-full-at-byte": 3}
HITS = synthetic_hits(4, seed=5, samples=256)


def life(path: Path, report) -> None:
    """Create, record three hits, overrule a verdict, store a fit, close; append one more hit; close."""
    session = new_session(path)
    for index in range(3):
        session.append_hit(HITS[index], Verdict(True))
        report(f"hit {index}")
    session.set_verdict(1, Verdict(False, ("double hit",), overridden=True))
    report("verdict 1")
    session.write_fit("SD", {"rms": 0.5, "values": np.arange(4.0)})
    session.close()
    report("closed")
    with Session.open(path, "a") as again:
        again.append_hit(HITS[3], Verdict(True))
        report("hit 3")
    report("closed again")


def run_child(shim: ctypes.CDLL, path: Path, mode: int, at: int) -> tuple[list[str], int, int]:
    """The steps reported by a child that lived the session's life with write ``at`` failing (mode 0: none), and
    the writes and bytes it made."""
    reading, writing = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(reading)
        try:
            shim.failing_writes_arm(mode, at)
            life(path, lambda step: os.write(writing, f"{step}\n".encode()))
        except BaseException as error:  # noqa: BLE001 - the failure being injected, whatever it became
            os.write(writing, f"error {type(error).__name__}: {' '.join(str(error).split())[:200]}\n".encode())
        os.write(writing, f"counts {shim.failing_writes_count()} {shim.failing_writes_bytes()}\n".encode())
        os._exit(0)  # no HDF5 clean-up at exit: the process ends as a crash would leave it
    os.close(writing)
    output = b""
    while chunk := os.read(reading, 65536):
        output += chunk
    os.close(reading)
    os.waitpid(pid, 0)
    lines = output.decode().splitlines()
    counts = [line.split() for line in lines if line.startswith("counts ")]
    writes, written = (int(counts[0][1]), int(counts[0][2])) if counts else (0, 0)
    return [line for line in lines if not line.startswith("counts ")], writes, written


def check(path: Path, steps: list[str]) -> list[str]:
    """What is wrong with the session after the child's failure, given the steps it reported."""
    reported = [int(step.split()[1]) for step in steps if step.startswith("hit ")]
    problems = []
    try:
        with Session.open(path) as session:
            stored = session.hits(check_finite=False)
    except SessionError as error:
        return [f"reading after the failure: {error}"] if reported else []
    for index in reported:
        if index >= len(stored) or not np.array_equal(stored[index].data, HITS[index].data):
            problems.append(f"hit {index} reported but not read back ({len(stored)} hits stored)")
    if "verdict 1" in steps and len(stored) > 1 and stored[1].verdict.accepted:
        problems.append("the overruled verdict of hit 1 is lost")
    try:
        Session.open(path, "a").close()  # rebuilds the file from the journal where one was left
    except SessionError as error:
        return problems + [f"opening for appending after the failure: {error}"]
    with h5py.File(path, "r") as file:  # plain h5py: no gasfilm in between
        rows, records = file["hits/table"][()], file["hits/data"][()]
    for index in reported:
        if index >= len(rows) or not rows[index]["sample_rate_hz"] > 0 or not np.array_equal(records[index],
                                                                                             HITS[index].data):
            problems.append(f"hit {index} reported but not in the file read with plain h5py")
    leftovers = sorted(set(os.listdir(path.parent)) - {path.name})
    if leftovers:
        problems.append(f"left behind: {leftovers}")
    return problems


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("shim")
    parser.add_argument("mode", choices=sorted(MODES))
    parser.add_argument("--at", type=int, nargs="*", help="the writes (or bytes) to fail; default: every one")
    parser.add_argument("--every", type=int, default=1, help="fail every this many-th write (1: each one)")
    parser.add_argument("--bytes-step", type=int, default=4096, help="disk-full-at-byte: every this many bytes")
    args = parser.parse_args()
    shim = ctypes.CDLL(args.shim)
    with tempfile.TemporaryDirectory(prefix="gasfilm-write-faults-") as folder:
        clean = Path(folder) / "clean"
        clean.mkdir()
        steps, writes, written = run_child(shim, clean / "session.h5", 0, 0)
        if steps[-1:] != ["closed again"]:
            print(json.dumps({"writes": writes, "trials": 0, "problems": [f"the life fails unfailed: {steps}"]}))
            return 1
        if args.at:
            positions = args.at
        elif args.mode == "disk-full-at-byte":
            positions = list(range(0, written, args.bytes_step))
        else:
            positions = sorted({*range(1, writes + 1, args.every), writes})
        problems = []
        errors: dict[str, list[int]] = {}
        for at in positions:
            trial = Path(folder) / f"trial-{at}"
            trial.mkdir()
            steps, _, _ = run_child(shim, trial / "session.h5", MODES[args.mode], at)
            error = next((step for step in steps if step.startswith("error")), "none")
            errors.setdefault(error.split(":")[0].removeprefix("error "), []).append(at)
            if error.split(":")[0] not in ("error SessionError", "error SessionWriteError", "none"):
                problems.append(f"{args.mode} at {at}: the API raised {error}")
            problems += [f"{args.mode} at {at} (after {steps[-2:]}): {problem}"
                         for problem in check(trial / "session.h5", steps)]
            shutil.rmtree(trial)
    print(json.dumps({"writes": writes, "bytes": written, "trials": len(positions), "problems": problems,
                      "errors": errors}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
