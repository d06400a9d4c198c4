"""Run a gasfilm command with one of its writes made to fail, at every write in turn, and compare the session's bytes
before and after (issue 33 item 2): a command that fails leaves its input session byte for byte as it found it, or
completes what it reported (``acquire --append``'s reported hits, the session closed, not "recording"), or completes
saying what it did not store in the session (``fit`` and ``replay`` show what they cannot keep, the session as it was);
its output files are whole or absent; it answers in one line, never an internal error.

Run with ``failing_writes.so`` preloaded (see tests/test_session_journal.py). Each trial forks from this process (the
command modules imported once): the child arms the failure and runs ``gasfilm COMMAND`` in-process on a fresh copy of
the session, its stdout and stderr going to pipes (which the library does not count); the parent checks. Prints one
JSON object per command: the writes counted, the trials, how the failures were answered, how many sessions a left
rollback journal restored, the problems found.

    python command_write_faults.py SHIM MODE [--commands append fit ...] [--every K] [--at N ...]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import re
import selectors
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

MODES = {"disk-full": 1, "one-write": 2}
FAST_SIM = ["--device", "sim", "--pacing", "fast", "--rate", "6400", "--record-s", "0.25", "--hit-interval", "0.3",
            "0.45"]
#: command name → (argv with SESSION, OUT and FOLDER placeholders, what it stores in the session, its outputs)
COMMANDS = {
    "append": (["acquire", *FAST_SIM, "--out", "SESSION", "--append", "--hits", "2"], "hits", []),
    "fit": (["fit", "SESSION", "--models", "SD,Zener", "--out", "OUT"], "fits",
            ["session-figure18.png", "session-figure19.png"]),
    "replay": (["replay", "SESSION", "--exp-end", "0.05"], "FRF 'replay'", []),
    "diagnose": (["diagnose", "SESSION", "--out", "OUT"], "a diagnosis",
                 ["improved-rig.toml", "diagnosis-overlay.png", "diagnosis-residual.png"]),
    "model": (["model", "SESSION", "--model", "SD", "--out", "OUT/model.json"], "nothing",
              ["model.json", "model-error.png", "model-hits.png"]),
    "export-uff": (["export", "SESSION", "--uff", "OUT/frf.uff"], "nothing", ["frf.uff"]),
    "export-csv": (["export", "SESSION", "--csv", "OUT/frf.csv"], "nothing", ["frf.csv"]),
    "campaign": (["campaign", "FOLDER", "--by", "supply_pressure_mpa", "--models", "SD", "--no-diagnosis",
                  "--workers", "1", "--out", "OUT"], "nothing", ["campaign.parquet", "campaign.csv", "campaign.html"]),
}


def make_session(folder: Path) -> Path:
    """A small recorded session holding an FRF and a fit (so that ``model`` has one), with operating conditions."""
    from gasfilm.app.cli import main

    path = folder / "session.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "3",
                 "--condition", "supply_pressure_mpa=0.4"]) == 0
    assert main(["fit", str(path), "--models", "SD", "--out", str(folder / "figures")]) == 0
    shutil.rmtree(folder / "figures")
    return path


def run_child(shim: ctypes.CDLL, argv: list[str], mode: int, at: int) -> tuple[int, str, str, int]:
    """``gasfilm argv`` in a forked child with write ``at`` failing (mode 0: none): exit status, stdout, stderr,
    and the writes it made."""
    out_read, out_write = os.pipe()
    err_read, err_write = os.pipe()
    count_read, count_write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(out_read), os.close(err_read), os.close(count_read)
        os.dup2(out_write, 1)
        os.dup2(err_write, 2)
        sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the child's own streams
        sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
        status = 99
        try:
            from gasfilm.app.cli import main

            shim.failing_writes_arm(mode, at)
            status = main(argv)
        except BaseException as error:  # noqa: BLE001 - what the harness looks for
            print(f"escaped: {type(error).__name__}: {error}", file=sys.stderr)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.write(count_write, str(shim.failing_writes_count()).encode())
            os._exit(status if isinstance(status, int) else 98)
    for fd in (out_write, err_write, count_write):
        os.close(fd)
    chunks: dict[int, bytes] = {out_read: b"", err_read: b"", count_read: b""}
    selector = selectors.DefaultSelector()
    for fd in chunks:
        selector.register(fd, selectors.EVENT_READ)
    while selector.get_map():
        for key, _ in selector.select():
            data = os.read(key.fd, 65536)
            if data:
                chunks[key.fd] += data
            else:
                selector.unregister(key.fd)
                os.close(key.fd)
    _, wait_status = os.waitpid(pid, 0)
    status = os.waitstatus_to_exitcode(wait_status)
    count = int(chunks[count_read] or 0)
    return status, chunks[out_read].decode(errors="replace"), chunks[err_read].decode(errors="replace"), count


def check(name: str, status: int, stdout: str, stderr: str, session: Path, before: bytes, out: Path,
          outputs: list[str]) -> tuple[list[str], bool]:
    """What is wrong after one trial, and whether a left rollback journal had to restore the session."""
    from gasfilm.analysis.session import Session, SessionError

    problems = []
    lines = [line for line in stderr.splitlines() if re.match(r"gasfilm \S+: error: ", line)]  # (not diagnose's progress)
    if "internal error" in stderr or "Traceback" in stderr or "escaped:" in stderr:
        problems.append(f"not an answer: {stderr.strip()[-300:]}")
    elif status not in (0, 1, 2) or (status == 2 and len(lines) != 1):
        problems.append(f"exit {status} with {len(lines)} error lines: {' | '.join(lines)[:300]}")
    journal = session.with_name(session.name + ".journal")
    restored = journal.exists()
    if restored:  # a commit failed and undoing it failed too (the disk refuses every write): the next writer restores
        try:
            Session.open(session, "a").discard()
        except SessionError as error:
            problems.append(f"a journal was left and the session cannot be restored from it: {error}")
    reported = [int(match) for match in re.findall(r"(?m)^accepted hit (\d+)", stdout)]
    if status == 0 and not_stored(stdout):
        if session.read_bytes() != before:
            problems.append("the session changed although the command said its result is not stored in it")
    elif status != 0 and not reported:
        if session.read_bytes() != before:
            problems.append("the session changed although the command failed before reporting anything")
    elif status != 0:  # acquire --append reported hits before it failed: they are stored, the session closed
        try:
            with Session.open(session) as stored:
                count, state = stored.hit_count, stored.status
        except SessionError as error:
            problems.append(f"reported hits {reported}, then the session cannot be read: {error}")
        else:
            if count < 4 + len(reported) or state == "recording":
                problems.append(f"reported hits {reported}: the session holds {count} hits, status {state}")
    else:
        try:
            with Session.open(session) as stored:
                stored.hits()
        except SessionError as error:
            problems.append(f"the command succeeded but the session cannot be read: {error}")
    leftovers = sorted(name for name in os.listdir(session.parent)
                       if name not in (session.name, "out", "folder", "session.log"))
    if leftovers:
        problems.append(f"left beside the session: {leftovers}")
    if out.exists():
        hidden = [name for name in os.listdir(out) if name.startswith(".")]
        present = [name for name in outputs if (out / name).exists()]
        if hidden:
            problems.append(f"partial files left in the output folder: {hidden}")
        if status != 0 and present:
            problems.append(f"the command failed but wrote {present}")
    return problems, restored


def not_stored(stdout: str) -> str | None:
    """What a command that completed says it did not store in the session (``fit``'s note, ``replay``'s result), else
    None."""
    match = re.search(r"(?m)not stored in .*$", stdout)
    return match.group(0) if match else None


def answer(status: int, stdout: str, stderr: str) -> str:
    """How a trial ended: "completed", what it did not store, or the kind of a refusal (its last line), each without
    the command, the paths and the numbers."""
    if status == 0:
        note = not_stored(stdout)
        return re.sub(r"\d+", "N", re.sub(r"(?<![\w/])/\S+?(?=[\s:;)])", "PATH", note))[:80] if note else "completed"
    line = (stderr.strip().splitlines() or ["?"])[-1].split(": error: ")[-1]
    line = re.sub(r"^(--\S+ )?/\S+?: ", "", line)
    return re.sub(r"\d+", "N", line.split(" (")[0])[:80]


def trial_paths(work: Path, source: Path, argv: list[str]) -> tuple[list[str], Path, Path]:
    """A fresh copy of the session (in a campaign folder of its own) and the command with its paths filled in."""
    if work.exists():
        shutil.rmtree(work)
    (work / "folder").mkdir(parents=True)
    session = work / "folder" / "session.h5" if "FOLDER" in argv else work / "session.h5"
    shutil.copyfile(source, session)
    out = work / "out"
    if "OUT/" in " ".join(argv):  # (an output file in a folder that exists)
        out.mkdir()
    filled = [arg.replace("SESSION", str(session)).replace("FOLDER", str(work / "folder"))
              .replace("OUT", str(out)) for arg in argv]
    return filled, session, out


def run_command(shim: ctypes.CDLL, name: str, mode: str, source: Path, work: Path, every: int,
                at: list[int] | None) -> dict:
    argv, stores, outputs = COMMANDS[name]
    started = time.perf_counter()
    run_child(shim, trial_paths(work, source, argv)[0], 0, 0)  # warm-up: caches (fonts, dask) are written once
    filled, session, out = trial_paths(work, source, argv)
    status, stdout, stderr, writes = run_child(shim, filled, 0, 0)
    if status != 0:
        return {"command": name, "writes": writes, "trials": 0, "problems": [f"fails unfailed: {stderr[-500:]}"]}
    positions = at or sorted({*range(1, writes + 1, every), writes})
    problems, answers, restored = [], {}, 0
    for position in positions:
        filled, session, out = trial_paths(work, source, argv)
        before = session.read_bytes()
        status, stdout, stderr, _ = run_child(shim, filled, MODES[mode], position)
        found, was_restored = check(name, status, stdout, stderr, session, before, out, outputs)
        restored += was_restored
        key = answer(status, stdout, stderr)
        answers[key] = answers.get(key, 0) + 1
        problems += [f"{name} {mode} at write {position}: {problem}" for problem in found]
    return {"command": name, "stores": stores, "writes": writes, "trials": len(positions), "answers": answers,
            "restored_from_journal": restored, "problems": problems,
            "seconds": round(time.perf_counter() - started, 1)}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("shim")
    parser.add_argument("mode", choices=sorted(MODES))
    parser.add_argument("--commands", nargs="*", default=list(COMMANDS), choices=list(COMMANDS))
    parser.add_argument("--every", type=int, default=1, help="fail every this many-th write (1: each one)")
    parser.add_argument("--at", type=int, nargs="*", help="the writes to fail (default: every --every-th)")
    args = parser.parse_args()
    shim = ctypes.CDLL(args.shim)
    import logging

    logging.disable(logging.CRITICAL)  # (the child's log lines are not what is checked)
    with tempfile.TemporaryDirectory(prefix="gasfilm-command-faults-") as folder:
        source = make_session(Path(folder))
        for name in args.commands:
            result = run_command(shim, name, args.mode, source, Path(folder) / "work", args.every, args.at)
            print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
