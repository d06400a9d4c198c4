"""How fast the simulated NI 9234 streams: 4 channels at 51.2 kS/s, paced "as fast as possible".

Prints the simulated seconds per wall-clock second and per CPU second (the real-time factor; goal ≥ 100× on one
core, issue 18; the CPU figure is the one to read on a shared machine) for the paper's
FOMGF rig with hits every 1.5–3 s, with and without noise, and for the rig with every effect (cubic hardening
solved per hit). Run: ``.venv/bin/python benchmarks/bench_sim_stream.py [--seconds 60]``.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # one core, as the goal says (set before numpy loads)

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import ADCOverloadWarning
from gasfilm.drivers.interface import ChannelConfig, ChannelKind, DaqConfig
from gasfilm.drivers.simulated import SimulatedNI9234
from machine import machine_line  # benchmarks/machine.py

RIGS = Path(__file__).resolve().parents[1] / "fixtures" / "rigs"


def four_channels(sample_rate_hz: float) -> DaqConfig:
    return DaqConfig(
        channels=(
            ChannelConfig("ai0", ChannelKind.FORCE, 11.2, "mV/N", name="hammer"),
            ChannelConfig("ai1", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)", name="accelerometer x"),
            ChannelConfig("ai2", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)", name="accelerometer y"),
            ChannelConfig("ai3", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)", name="accelerometer z"),
        ),
        sample_rate_hz=sample_rate_hz,
    )


def stream(label: str, seconds: float, sample_rate_hz: float = 51200.0, rig: RigSpec | None = None, **options) -> None:
    device = SimulatedNI9234(RigPlant.from_spec(rig), seed=1, pacing="fast", **options)
    config = four_channels(sample_rate_hz)
    device.configure(config)
    buffer = np.empty((4, config.chunk_samples))
    chunks = int(round(seconds * sample_rate_hz / config.chunk_samples))
    started_setup = time.perf_counter()
    device.start()
    setup_s = time.perf_counter() - started_setup
    started, started_cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ADCOverloadWarning)
        for _ in range(chunks):
            device.read(buffer)
    elapsed_s, cpu_s = time.perf_counter() - started, time.process_time() - started_cpu
    simulated_s = chunks * config.chunk_samples / sample_rate_hz
    print(
        f"{label:44s} {simulated_s:6.1f} s simulated in {elapsed_s:6.2f} s: {simulated_s / elapsed_s:7.1f}× real time, "
        f"{simulated_s / cpu_s:7.1f}× per CPU second ({len(device.sim_hits)} hits, start-up {setup_s * 1e3:.0f} ms)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per case (default 60)")
    args = parser.parse_args()
    print(machine_line())
    print("simulated NI 9234, 4 channels at 51.2 kS/s, chunks of 0.1 s")
    stream("FOMGF rig, noise + quantisation", args.seconds)
    stream("FOMGF rig, noise-free", args.seconds, noise=False, quantize=False)
    stream("FOMGF rig, hits every 0.2–0.4 s", args.seconds, hit_interval_s=(0.2, 0.4))
    stream("all-effects rig (cubic hardening per hit)", args.seconds, rig=RigSpec.load(RIGS / "all-effects.toml"))


if __name__ == "__main__":
    main()
