"""A ``gasfilm acquire`` process killed with SIGKILL at random moments keeps every hit it reported.

Each run records from the simulated rig into a fresh session and is killed after a random (seeded) delay. Everything
the process printed before it died counts as reported. The session must then open (read-only, and for appending,
which rewrites it into a clean file) and hold every reported hit with the reported verdict. The simulator gives the
same samples for the same seed whatever the pacing, so every stored hit must also equal, record and table row, the
same hit of an uninterrupted reference run. Realtime runs have hits arriving during the run; fast-paced runs write a
hit every few milliseconds, so their kills land in the middle of HDF5 writes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from gasfilm.analysis.session import Session

KILL_SEED = 20261121
SIM_SEED = 6
ACQUIRE = ["acquire", "--device", "sim", "--rate", "6400", "--record-s", "0.25", "--hit-interval", "0.3", "0.45",
           "--double-hit-rate", "0.2", "--seed", str(SIM_SEED)]
#: (pacing, earliest and latest kill after the first output line, in s)
RUNS = [("realtime", 0.3, 3.0)] * 4 + [("fast", 0.05, 1.0)] * 4


def reported_hits(lines: list[str]) -> dict[int, bool]:
    """Hit number (1-based) → accepted, from the ``accepted hit N`` / ``rejected hit N`` lines."""
    hits = {}
    for line in lines:
        words = line.split()
        if len(words) >= 3 and words[0] in ("accepted", "rejected") and words[1] == "hit":
            hits[int(words[2].rstrip(":"))] = words[0] == "accepted"
    return hits


def acquire(*argv: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "gasfilm.app.cli", *ACQUIRE, *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def run_and_kill(path, pacing: str, delay_s: float) -> tuple[list[str], str]:
    process = acquire("--pacing", pacing, "--seconds", "100000", "--out", str(path))
    lines: list[str] = []
    started = threading.Event()

    def collect() -> None:
        for line in process.stdout:
            lines.append(line.rstrip("\n"))
            started.set()
        started.set()

    reader = threading.Thread(target=collect, daemon=True)
    reader.start()
    assert started.wait(60), "gasfilm acquire printed nothing"
    time.sleep(delay_s)
    os.kill(process.pid, signal.SIGKILL)
    process.wait(30)
    reader.join(30)  # whatever the process printed before it died is still in the pipe: it was reported
    return lines, process.stderr.read()


def stored_hits(path, mode: str) -> tuple[str, list]:
    with Session.open(path, mode) as session:
        return session.status, session.hits()


def test_sigkill_at_random_moments_keeps_every_reported_hit(tmp_path):
    rng = np.random.default_rng(KILL_SEED)
    delays_s = [float(rng.uniform(earliest_s, latest_s)) for _, earliest_s, latest_s in RUNS]
    paths = [tmp_path / f"killed-{run}.h5" for run in range(len(RUNS))]
    reference_path = tmp_path / "reference.h5"

    def reference_run() -> None:
        # 60 s of signal, some 160 hits: several times what a fast-paced run reports before its kill (at most 1 s)
        process = acquire("--pacing", "fast", "--seconds", "60", "--out", str(reference_path))
        assert process.wait(120) == 0, process.stderr.read()

    def fast_runs() -> dict[int, tuple[list[str], str]]:
        return {run: run_and_kill(paths[run], pacing, delays_s[run])
                for run, (pacing, _, _) in enumerate(RUNS) if pacing == "fast"}

    # realtime runs mostly wait for the simulated clock and the reference run for its commits to reach the disk, so
    # they run side by side with the fast-paced runs, which keep a core busy and run one after the other
    with ThreadPoolExecutor(max_workers=len(RUNS) + 2) as pool:
        reference_done = pool.submit(reference_run)
        fast = pool.submit(fast_runs)
        realtime = {run: pool.submit(run_and_kill, paths[run], pacing, delays_s[run])
                    for run, (pacing, _, _) in enumerate(RUNS) if pacing == "realtime"}
        outputs = {run: future.result() for run, future in realtime.items()} | fast.result()
        reference_done.result()
    reference = stored_hits(reference_path, "r")[1]

    measured = []
    for run, (pacing, _, _) in enumerate(RUNS):
        lines, stderr = outputs[run]
        assert lines and lines[0].startswith("recording into"), (run, lines, stderr)
        assert not any(line.startswith("session ") for line in lines), "the run ended before it was killed"
        reported = reported_hits(lines)
        assert len(reference) > len(reported) + 1, "make the reference run longer"
        for mode in ("r", "a"):  # read as left by the kill, then recovered for appending
            status, hits = stored_hits(paths[run], mode)
            assert status == "interrupted", (run, mode)
            assert len(hits) >= len(reported), (run, mode)
            for number, accepted in reported.items():
                assert hits[number - 1].verdict.accepted == accepted, (run, mode, number)
            for hit in hits:
                same = reference[hit.index]
                assert np.array_equal(hit.data, same.data), (run, mode, hit.index)
                assert (hit.verdict, hit.start_time_s, hit.trigger_index) == (
                    same.verdict, same.start_time_s, same.trigger_index), (run, mode, hit.index)
        measured.append((pacing, round(delays_s[run], 2), sum(reported.values()), len(reported), len(hits)))
    print("\n(pacing, kill delay s, accepted hits reported, hits reported, hits stored):", *measured, sep="\n  ")
    assert sum(accepted for _, _, accepted, _, _ in measured) >= 20
