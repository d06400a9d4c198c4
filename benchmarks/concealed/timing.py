"""Benchmark: full diagnosis of a 20-hit session (load, replay, recalibration, forward selection, improved spec,
figures), as ``gasfilm diagnose`` runs it, on sessions from the simulated NI 9234. Prints the wall time of each and
the CPU time of this process and of the forked copy that shares the candidate fits (``analysis/diagnosis/parallel.py``).

    python benchmarks/concealed/timing.py              # both processes (the default on 2 cores)
    python benchmarks/concealed/timing.py --alone      # one process: worker_processes(1)
    python benchmarks/concealed/timing.py --rounds 3   # each session diagnosed three times, the best wall time kept
"""

from __future__ import annotations

import argparse
import contextlib
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from generate import NOMINAL  # noqa: E402
from machine import machine_line  # noqa: E402
from sessions import record_session  # noqa: E402

from gasfilm.analysis.diagnosis import diagnose  # noqa: E402
from gasfilm.analysis.diagnosis.parallel import worker_processes  # noqa: E402
from gasfilm.analysis.diagnosis.plots import write_outputs  # noqa: E402
from gasfilm.analysis.physics.effects import AddedMass, ChannelDelay, CubicStiffness, Drift, ExtraMode  # noqa: E402

SESSIONS = {
    "clean": (),
    "delay + added mass": (ChannelDelay(channel="acceleration", delay_s=0.7e-6), AddedMass(mass_kg=0.012)),
    "extra mode + drift": (ExtraMode(freq_hz=700.0, damping_ratio=0.02, mass_kg=0.012), Drift(fraction_per_hour=0.14)),
    "hardening film (exact nonlinear replay)": (CubicStiffness(k3_n_per_m3=5.5e15),),
}


def _cpu_s() -> tuple[float, float]:
    """CPU seconds of this process and of its finished children (the forked copies)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, children.ru_utime + children.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--alone", action="store_true", help="one process (no forked copy for the candidate fits)")
    parser.add_argument("--rounds", type=int, default=1, help="diagnoses of each session; the fastest is printed")
    args = parser.parse_args()
    print(machine_line(), flush=True)
    with tempfile.TemporaryDirectory() as folder, (worker_processes(1) if args.alone else contextlib.nullcontext()):
        for seed, (name, effects) in enumerate(SESSIONS.items()):
            path = record_session(NOMINAL.with_effects(*effects), Path(folder) / f"{seed}.h5", 20, seed=500 + seed)
            best: tuple[float, float, float] | None = None
            for _ in range(args.rounds):
                started, (own_started, children_started) = time.monotonic(), _cpu_s()
                result = diagnose(path, NOMINAL)
                write_outputs(result, Path(folder) / f"out{seed}")
                elapsed = time.monotonic() - started
                own, children = _cpu_s()
                if best is None or elapsed < best[0]:
                    best = (elapsed, own - own_started, children - children_started)
            elapsed, own_cpu, children_cpu = best
            found = ", ".join(f.effect for f in result.findings) or "nothing"
            print(f"{name:42s} 20 hits: {elapsed:5.1f} s wall, CPU {own_cpu:5.1f} s + {children_cpu:4.1f} s in the "
                  f"copy (found: {found}; goal ≤ 3 s wall on 2 idle cores)", flush=True)


if __name__ == "__main__":
    main()
