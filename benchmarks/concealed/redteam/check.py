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
            model = generate.accelerance(case, freq, case.film_k, case.film_c)
            parts = []
            for lo, hi in ((20, 50), (50, 100), (100, 300), (300, 1000), (1000, 2000), (2000, 3000)):
                band = (freq >= lo) & (freq < hi) & (level > 0.1)
                if band.sum() < 3:
                    continue
                error = np.abs(measured[band] / model[band] - 1)
                parts.append(f"{lo}-{hi} Hz {100 * np.median(error):.2g} % (max {100 * error.max():.2g} %)")
            line += " H1/analytic − 1: " + "; ".join(parts)
        pre = int(case.pretrigger_s * fs * 0.8)
        line += f" | pre-trigger RMS {np.sqrt(np.mean(accel[:, :pre] ** 2)):.2g} m/s²"
        line += f" | peak |a| {np.max(np.abs(accel)):.3g} m/s², peak F {np.max(force):.4g} N"
        tail = accel[:, -accel.shape[1] // 4:]
        line += f" | tail RMS {np.sqrt(np.mean(tail ** 2)):.2g}"
        if "clipped_hits" in drawn:
            line += f" | clipped hits {drawn['clipped_hits']}"
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
