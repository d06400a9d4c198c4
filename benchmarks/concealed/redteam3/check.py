"""Physics checks of the round-3 generator (no gasfilm import): the chain, the RK4 path, and how far each linear rig
case is from the best spring-damper (what a recalibration alone could absorb).

    python benchmarks/concealed/redteam3/check.py
"""

from __future__ import annotations

import dataclasses
import importlib.util
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

spec = importlib.util.spec_from_file_location("redteam3_generate", Path(__file__).with_name("generate.py"))
g = importlib.util.module_from_spec(spec)
sys.modules["redteam3_generate"] = g
spec.loader.exec_module(g)


def h1(records: np.ndarray) -> np.ndarray:
    force = np.fft.rfft(records[:, 0], axis=1)
    accel = np.fft.rfft(records[:, 1], axis=1)
    return np.sum(accel * force.conj(), 0) / np.sum(np.abs(force) ** 2, 0)


def main() -> int:
    cases = {c.name: c for c in g.cases()}
    print("1. noise-free H1 (rectangular, 1 s records, AC coupling and anti-aliasing on both channels) vs the "
          "analytic accelerance, 20–1500 Hz")
    for name in ("control-clean", "supply-line-resonance", "porous-restrictor", "soft-foundation", "rate-mislabel"):
        case = cases[name]
        records, _, _ = g.synthesise(case, noise=False)
        freq = np.fft.rfftfreq(records.shape[2], 1 / case.sample_rate_hz)
        band = (freq >= 20) & (freq <= 1500)
        err = np.abs(h1(records)[band] / g.accelerance(case, freq[band]) - 1)
        print(f"   {name:24s} median {np.median(err):.1e}, max {err.max():.1e}")
    print("2. RK4 path with the negative damping switched off vs the frequency-domain path (hammer-onset)")
    onset = dataclasses.replace(cases["hammer-onset"], hits=3, nonlinear={"negative_c_ns_per_m": 0.0,
                                                                           "saturation_m_s": 1e-3})
    linear = dataclasses.replace(onset, nonlinear=None)
    a, _, _ = g.synthesise(onset, noise=False)
    b, _, _ = g.synthesise(linear, noise=False)
    print(f"   max |difference| / peak = {np.abs(a[:, 1] - b[:, 1]).max() / np.abs(b[:, 1]).max():.1e}")
    print("3. linear rig cases: the best spring-damper on the told mass (k, c free) against the truth, 20–1500 Hz")
    freq = np.linspace(20, 1500, 1481)
    s = 2j * np.pi * freq
    for name in ("supply-line-resonance", "porous-restrictor", "soft-foundation", "control-rarefaction"):
        truth = g.accelerance(cases[name], freq)

        def residual(p: np.ndarray) -> np.ndarray:
            r = (s**2 / (p[0] * 1e7 + p[1] * 1e3 * s + 25.05 * s**2) - truth) / np.abs(truth)
            return np.concatenate([r.real, r.imag])

        fit = least_squares(residual, [3.8, 3.5])
        r = residual(fit.x)
        rel = np.hypot(r[:len(freq)], r[len(freq):])
        print(f"   {name:24s} k {fit.x[0]:.4f}e7, c {fit.x[1]:.4f}e3: |H| off by up to {rel.max():.2%} "
              f"(at {freq[rel.argmax()]:.0f} Hz), RMS {np.sqrt(np.mean(rel**2)):.2%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
