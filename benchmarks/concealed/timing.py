"""Benchmark: full diagnosis of a 20-hit session (load, replay, recalibration, forward selection, improved spec,
figures), as ``gasfilm diagnose`` runs it, on sessions from the simulated NI 9234. Prints the wall time of each.

    python benchmarks/concealed/timing.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generate import NOMINAL  # noqa: E402
from sessions import record_session  # noqa: E402

from gasfilm.analysis.diagnosis import diagnose  # noqa: E402
from gasfilm.analysis.diagnosis.plots import write_outputs  # noqa: E402
from gasfilm.analysis.physics.effects import AddedMass, ChannelDelay, CubicStiffness, Drift, ExtraMode  # noqa: E402

SESSIONS = {
    "clean": (),
    "delay + added mass": (ChannelDelay(channel="acceleration", delay_s=0.7e-6), AddedMass(mass_kg=0.012)),
    "extra mode + drift": (ExtraMode(freq_hz=700.0, damping_ratio=0.02, mass_kg=0.012), Drift(fraction_per_hour=0.14)),
    "hardening film (exact nonlinear replay)": (CubicStiffness(k3_n_per_m3=5.5e15),),
}


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        for seed, (name, effects) in enumerate(SESSIONS.items()):
            path = record_session(NOMINAL.with_effects(*effects), Path(folder) / f"{seed}.h5", 20, seed=500 + seed)
            started, started_cpu = time.monotonic(), time.process_time()
            result = diagnose(path, NOMINAL)
            write_outputs(result, Path(folder) / f"out{seed}")
            elapsed, cpu = time.monotonic() - started, time.process_time() - started_cpu
            found = ", ".join(f.effect for f in result.findings) or "nothing"
            print(f"{name:42s} 20 hits: {elapsed:5.1f} s wall, {cpu:5.1f} s CPU  (found: {found}; goal ≤ 3 s on 2 "
                  f"idle cores; on a shared machine the CPU time is the figure to compare)")


if __name__ == "__main__":
    main()
