"""How fast the simulated NI 9234 streams: 4 channels at 51.2 kS/s, paced "as fast as possible".

Prints the simulated seconds per wall-clock second and per CPU second (the real-time factor; goal ≥ 100× on one
core, issue 18; the CPU figure is the one to read on a shared machine) for the paper's
FOMGF rig with hits every 1.5–3 s, with and without noise, for the rig with every effect (cubic hardening
solved per hit), and for a rigid mover on three pads whose three accelerometers each see their own motion (heave,
roll and pitch: ``fixtures/rigs/three-pads.toml``, issue 34), its hammer at one point and roving. Run: ``.venv/bin/python benchmarks/bench_sim_stream.py [--seconds 60]``.
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


def stream(label: str, seconds: float, sample_rate_hz: float = 51200.0, rig: RigSpec | None = None,
           roving: bool = False, peer: float | None = None, **options) -> float:
    """``roving``: a rigid mover struck at its next hammer point every 10 chunks (the plant moves its hammer)."""
    plant = RigPlant.from_spec(rig)
    device = SimulatedNI9234(plant, seed=1, pacing="fast", **options)
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
        points = plant.spec.rigid_body.point_names if roving else ()
        for chunk in range(chunks):
            if points and chunk % 10 == 0:
                plant.strike_at(points[(chunk // 10) % len(points)])
            device.read(buffer)
    elapsed_s, cpu_s = time.perf_counter() - started, time.process_time() - started_cpu
    simulated_s = chunks * config.chunk_samples / sample_rate_hz
    factor = simulated_s / cpu_s
    ratio = "" if peer is None else f", {factor / peer:.2f}× the first case's"
    print(
        f"{label:44s} {simulated_s:6.1f} s simulated in {elapsed_s:6.2f} s: {simulated_s / elapsed_s:7.1f}× real time, "
        f"{factor:7.1f}× per CPU second ({len(device.sim_hits)} hits, start-up {setup_s * 1e3:.0f} ms{ratio})"
    )
    return factor


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per case (default 60)")
    args = parser.parse_args()
    print(machine_line())
    print("simulated NI 9234, 4 channels at 51.2 kS/s, chunks of 0.1 s")
    peer = stream("FOMGF rig, noise + quantisation", args.seconds)
    stream("FOMGF rig, noise-free", args.seconds, noise=False, quantize=False)
    stream("FOMGF rig, hits every 0.2–0.4 s", args.seconds, hit_interval_s=(0.2, 0.4))
    stream("all-effects rig (cubic hardening per hit)", args.seconds, rig=RigSpec.load(RIGS / "all-effects.toml"))
    stream("rigid mover on 3 pads, 3 accelerometers", args.seconds, rig=RigSpec.load(RIGS / "three-pads.toml"),
           peer=peer)
    stream("rigid mover on 3 pads, roving hammer", args.seconds, rig=RigSpec.load(RIGS / "three-pads.toml"),
           roving=True, peer=peer)


if __name__ == "__main__":
    main()
