"""Physics checks of the red-team data, from the written UFF files (independent of gasfilm).

- controls (and the linear faults): H1 (cross- over auto-spectrum, rectangular window over the whole record, all hits)
  against the generator's own analytic accelerance, per band;
- nonlinear and time-varying cases: what the records show (limit-cycle level in the pre-trigger, clipped hits, …).

    python benchmarks/concealed/redteam/check.py [--data out/redteam] [--only CASE ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pyuff

sys.path.insert(0, str(Path(__file__).resolve().parent))
import generate  # noqa: E402


def read(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """(force (hits, n), acceleration (hits, n), sample rate Hz) from a generator UFF file."""
    sets = pyuff.UFF(str(path)).read_sets()
    force = np.array([s["data"] for s in sets if s["ordinate_spec_data_type"] == generate.DATA_TYPE_FORCE])
    accel = np.array([s["data"] for s in sets if s["ordinate_spec_data_type"] == generate.DATA_TYPE_ACCELERATION])
    return force, accel, 1.0 / sets[0]["abscissa_inc"]


def h1(force: np.ndarray, accel: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    spec_f = np.fft.rfft(force, axis=1)
    spec_a = np.fft.rfft(accel, axis=1)
    freq = np.fft.rfftfreq(force.shape[1], 1 / fs)
    cross = np.sum(spec_a * np.conj(spec_f), axis=0)
    auto = np.sum(np.abs(spec_f) ** 2, axis=0)
    level = np.abs(spec_f).mean(axis=0)
    return freq, cross / auto, level / level[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/redteam"))
    parser.add_argument("--only", nargs="+")
    args = parser.parse_args(argv)
    for case in generate.cases():
        if args.only and case.name not in args.only:
            continue
        path = args.data / f"{case.name}.uff"
        if not path.exists():
            continue
        force, accel, fs = read(path)
        drawn = json.loads((args.data / f"{case.name}.drawn.json").read_text())
        line = f"{case.name:24s}"
        if not case.nonlinear and case.per_hit_film is None and case.per_hit_delay_s is None:
            freq, measured, level = h1(force, accel, fs)
            quiet, _, _ = generate.synthesise(case, noise=False)
            _, noiseless, _ = h1(quiet[:, 0], quiet[:, 1], fs)
            model = generate.accelerance(case, freq, case.film_k, case.film_c)
            parts = []
            for lo, hi in ((20, 50), (50, 100), (100, 300), (300, 1000), (1000, 2000), (2000, 3000)):
                band = (freq >= lo) & (freq < hi) & (level > 0.1)
                if band.sum() < 3:
                    continue
                error = np.abs(measured[band] / model[band] - 1)
                exact = np.abs(noiseless[band] / model[band] - 1)
                parts.append(f"{lo}-{hi} Hz {100 * np.median(error):.2g} % (max {100 * error.max():.2g} %; "
                             f"noiseless max {100 * exact.max():.1g} %)")
            line += " H1/analytic − 1: " + "; ".join(parts)
        pre = int(case.pretrigger_s * fs * 0.8)
        line += f" | pre-trigger RMS {np.sqrt(np.mean(accel[:, :pre] ** 2)):.2g} m/s²"
        line += f" | peak |a| {np.max(np.abs(accel)):.3g} m/s², peak F {np.max(force):.4g} N"
        tail = accel[:, -accel.shape[1] // 4:]
        line += f" | tail RMS {np.sqrt(np.mean(tail ** 2)):.2g}"
        if "clipped_hits" in drawn:
            line += f" | clipped hits {drawn['clipped_hits']}"
        print(line)
    selftest()
    return 0


def selftest() -> None:
    """The RK4 path with its nonlinearity switched off reproduces the frequency-domain path; the describing-function
    limit cycle of the pneumatic-hammer case."""
    import dataclasses

    from scipy.optimize import brentq

    base = dataclasses.replace(next(c for c in generate.cases() if c.name == "control-nominal"), hits=4,
                               record_s=0.5)
    linear, _, _ = generate.synthesise(base)
    peak = np.abs(linear[:, 1]).max()
    for nonlinear in ({"kind": "gap", "gap_m": 1e3, "quadratic_factor": 0.0},
                      {"kind": "dahl", "sigma0_n_per_m": 0.0, "fc_n": 3.0, "sign_smoothing_m_s": 1e-6},
                      {"kind": "touchdown", "clearance_m": 1.0, "contact_k_n_per_m": 1e9, "contact_c_ns_per_m": 0.0}):
        other, _, _ = generate.synthesise(dataclasses.replace(base, nonlinear=nonlinear))
        print(f"RK4 ({nonlinear['kind']}, switched off) vs frequency domain: max |Δa| = "
              f"{np.abs(other[:, 1] - linear[:, 1]).max() / peak:.2g} of the peak")
    hammer = next(c for c in generate.cases() if c.name == "pneumatic-hammer")
    c, cn, vs = hammer.film_c, hammer.nonlinear["negative_c_ns_per_m"], hammer.nonlinear["saturation_m_s"]
    theta = np.linspace(0, 2 * np.pi, 4001)[:-1]
    velocity = brentq(lambda v: c - cn * 2 / v * np.mean(vs * np.tanh(v * np.sin(theta) / vs) * np.sin(theta)),
                      1e-7, 1e-3)
    omega = np.sqrt(hammer.film_k / hammer.mass_kg)
    print(f"pneumatic-hammer limit cycle (describing function): {velocity:.3g} m/s, "
          f"{velocity * omega:.3g} m/s² amplitude ({velocity * omega / np.sqrt(2):.3g} RMS)")


if __name__ == "__main__":
    sys.exit(main())
