"""A ``gasfilm acquire`` process killed with SIGKILL at random moments keeps every hit it reported.

Each run records from the simulated rig into a fresh session and is killed after a random (seeded) delay. Everything
the process printed before it died counts as reported. The session must then open (read-only, and for appending)
and hold every reported hit with the reported verdict. Realtime runs have hits arriving during the run; fast-paced
runs write a hit every few milliseconds, so their kills land in the middle of HDF5 writes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np

from analysis.session import Session
from analysis.validation import Verdict
from test_session import synthetic_hits

KILL_SEED = 20261121
COMMON = ["acquire", "--device", "sim", "--rate", "6400", "--record-s", "0.25", "--hit-interval", "0.3", "0.45",
          "--double-hit-rate", "0.2", "--seconds", "100000"]
#: (pacing, earliest and latest kill after the first output line, in s)
RUNS = [("realtime", 0.3, 3.0)] * 5 + [("fast", 0.05, 1.0)] * 3


def reported_hits(lines: list[str]) -> dict[int, bool]:
    """Hit number (1-based) → accepted, from the ``accepted hit N`` / ``rejected hit N`` lines."""
    hits = {}
    for line in lines:
        words = line.split()
        if len(words) >= 3 and words[0] in ("accepted", "rejected") and words[1] == "hit":
            hits[int(words[2].rstrip(":"))] = words[0] == "accepted"
    return hits


def run_and_kill(path, pacing: str, delay_s: float, seed: int) -> tuple[list[str], str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", *COMMON, "--pacing", pacing, "--seed", str(seed), "--out", str(path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
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


def test_sigkill_at_random_moments_keeps_every_reported_hit(tmp_path):
    rng = np.random.default_rng(KILL_SEED)
    measured = []
    for run, (pacing, earliest_s, latest_s) in enumerate(RUNS):
        path = tmp_path / f"killed-{run}.h5"
        delay_s = float(rng.uniform(earliest_s, latest_s))
        lines, stderr = run_and_kill(path, pacing, delay_s, seed=run)
        assert lines and lines[0].startswith("recording into"), (run, lines, stderr)
        assert not any(line.startswith("session ") for line in lines), "the run ended before it was killed"
        reported = reported_hits(lines)
        with Session.open(path) as session:
            stored = session.verdicts()
            assert session.status == "interrupted"
        assert len(stored) >= len(reported)
        for number, accepted in reported.items():
            assert stored[number - 1].accepted == accepted, (run, number)
        measured.append((pacing, round(delay_s, 2), sum(reported.values()), len(reported), len(stored)))
        if run in (0, len(RUNS) - 1):
            # the killed session is recovered and recording goes on in it
            with Session.open(path, "a") as session:
                assert session.recovered
                hit = session.hits()[0].as_hit_record() if stored else synthetic_hits(1)[0]
                assert session.append_hit(hit, Verdict(True)) == len(stored)
            with Session.open(path) as session:
                assert session.hit_count == len(stored) + 1 and session.status == "complete"
    print("\n(pacing, kill delay s, accepted reported, hits reported, hits stored):", *measured, sep="\n  ")
    assert sum(accepted for _, _, accepted, _, _ in measured) >= 20
