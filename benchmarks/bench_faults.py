"""Fault injection benchmark: every write of a session's life and of every command that touches a session, made to fail
in turn (issue 15 items 23–24, issue 33 items 2–3).

Builds tests/faults/failing_writes.c (a preloaded library that makes one of the process's writes fail: the disk full
from write N on, write N alone failing with EIO, or the disk full at byte B) and runs, with it preloaded:
``tests/faults/session_write_faults.py`` (create, three hits, a verdict, a fit, close, reopen, a hit, close: every
reported hit must read back) and ``tests/faults/command_write_faults.py`` (``acquire --append``, ``fit``, ``replay``,
``diagnose``, ``model``, ``export --uff/--csv``, ``campaign``: a command that fails leaves its session byte for byte
as it found it or completes what it reported, answers in one line, leaves no partial output). Prints, per command and
mode, the writes counted, the trials, how the failures were answered, how many sessions a left rollback journal
restored, and the problems (0 is the goal). Run:
``.venv/bin/python benchmarks/bench_faults.py [--every 1] [--commands append fit …] [--modes disk-full one-write]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FAULTS = Path(__file__).resolve().parents[1] / "tests" / "faults"
COMMANDS = ("append", "fit", "replay", "diagnose", "model", "export-uff", "export-csv", "campaign")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, default=1, help="fail every this many-th write (1: each one)")
    parser.add_argument("--commands", nargs="*", default=list(COMMANDS), choices=COMMANDS)
    parser.add_argument("--modes", nargs="*", default=["disk-full", "one-write"], choices=["disk-full", "one-write"])
    parser.add_argument("--no-session-life", action="store_true", help="only the commands")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gasfilm-faults-") as folder:
        shim = Path(folder) / "failing_writes.so"
        subprocess.run(["cc", "-shared", "-fPIC", "-O1", "-o", str(shim), str(FAULTS / "failing_writes.c"), "-ldl"],
                       check=True)
        env = dict(os.environ, LD_PRELOAD=str(shim), PYTHONDONTWRITEBYTECODE="1")
        totals = {"trials": 0, "problems": 0}
        if not args.no_session_life:
            print("a session's life (every reported hit must read back):")
            for mode, options in (("disk-full", ["--every", str(args.every)]), ("one-write", ["--every", str(args.every)]),
                                  ("disk-full-at-byte", ["--bytes-step", "4096"])):
                started = time.perf_counter()
                run = subprocess.run([sys.executable, str(FAULTS / "session_write_faults.py"), str(shim), mode,
                                      *options], env=env, capture_output=True, text=True)
                result = json.loads(run.stdout.splitlines()[-1])
                totals["trials"] += result["trials"]
                totals["problems"] += len(result["problems"])
                print(f"  {mode:<18} {result['writes']:>4} writes, {result['trials']:>4} trials, "
                      f"{len(result['problems'])} problems, answers {result['errors']} "
                      f"({time.perf_counter() - started:.0f} s)", flush=True)
                for problem in result["problems"][:5]:
                    print(f"      {problem}")
        print("commands (a failed one leaves its session byte for byte as it was, or completes what it reported):")
        for mode in args.modes:
            run = subprocess.Popen([sys.executable, str(FAULTS / "command_write_faults.py"), str(shim), mode,
                                    "--commands", *args.commands, "--every", str(args.every)], env=env,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            for line in run.stdout:
                if not line.startswith("{"):
                    continue
                result = json.loads(line)
                totals["trials"] += result["trials"]
                totals["problems"] += len(result["problems"])
                answered = ", ".join(f"{count} × {answer}" for answer, count in sorted(
                    result.get("answers", {}).items(), key=lambda item: -item[1]))
                print(f"  {result['command']:<10} {mode:<9} {result['writes']:>4} writes, {result['trials']:>4} "
                      f"trials, {len(result['problems'])} problems, {result.get('restored_from_journal', 0)} restored "
                      f"from a left journal ({result.get('seconds', 0):.0f} s): {answered}", flush=True)
                for problem in result["problems"][:5]:
                    print(f"      {problem}")
            run.wait()
        print(f"in all: {totals['trials']} trials, {totals['problems']} problems")
    return 0


if __name__ == "__main__":
    sys.exit(main())
