"""Benchmark the rational approximation for control design: the lowest plant order within a stated error on FOMGF
(vector fitting of the film's impedance, as ``gasfilm model`` does it) beside the order a plain Oustaloup
approximation of each ``s^α`` needs for the same error, and the time each takes.

The films: the paper's Table 1 FOMGF, and FOMGF fitted (default fitter, 20–1000 Hz) on 4 simulated hammer hits of
the paper rig at 6400 S/s. Band: a decade beyond 20–1000 Hz on each side (2 Hz – 10 kHz); error: the largest complex
relative error of the plant's accelerance and of the film's stiffness over it.

    .venv/bin/python benchmarks/bench_control.py [--seed N]
"""

from __future__ import annotations

import argparse
import time

from gasfilm.analysis.control.rational import PlantSource, approximate, oustaloup_order
from gasfilm.analysis.identification import fit_model
from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_MODELS
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import compute_frf
from gasfilm.drivers.interface import default_hammer_and_accelerometer
from gasfilm.drivers.simulated import SimulatedNI9234

SAMPLE_RATE_HZ = 6400.0
RECORD_S = 0.5
BAND_HZ = (20.0, 1000.0)
ERRORS = (0.005, 0.001, 0.0001)


def fitted_fomgf(seed: int) -> PlantSource:
    device = SimulatedNI9234(RigPlant.nominal("FOMGF"), seed=seed, pacing="fast", hit_interval_s=None)
    device.configure(default_hammer_and_accelerometer(SAMPLE_RATE_HZ))
    with device:
        device.start()
        records = device.sim_record_hits(4, int(RECORD_S * SAMPLE_RATE_HZ))
    frf = compute_frf(records, SAMPLE_RATE_HZ).band(*BAND_HZ)
    fit = fit_model(PAPER_MODELS["FOMGF"], frf.freq_hz, frf.h1, PAPER_MASS_KG, seed=seed)
    return PlantSource.from_fit(fit, f"simulated session, seed {seed}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    sources = [PlantSource.from_spec(RigSpec.nominal("FOMGF"), "Table 1"), fitted_fomgf(args.seed)]
    print(f"{'film':<58} {'error':>7} {'VF order':>8} {'VF s':>6} {'Oustaloup order':>15} {'(widened)':>9} "
          f"{'Oust. s':>7}")
    for source in sources:
        for error in ERRORS:
            started = time.perf_counter()
            model = approximate(source, max_error=error)
            vf_s = time.perf_counter() - started
            started = time.perf_counter()
            order, reached, widen = oustaloup_order(source, model.band_hz, error)
            oustaloup_s = time.perf_counter() - started
            oustaloup = str(order) if order is not None else f"> N=40 ({100 * reached:.2g} %)"
            print(f"{source.description[:58]:<58} {100 * error:>6.2g}% {model.order:>8d} {vf_s:>6.2f} "
                  f"{oustaloup:>15} {widen:>8g}× {oustaloup_s:>7.2f}")
            assert model.max_error_band <= error and model.stable and model.passive.passed, model.summary()


if __name__ == "__main__":
    main()
