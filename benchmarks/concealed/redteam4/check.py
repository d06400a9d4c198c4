"""Checks of the round-4 generator (no gasfilm): noise-free H1 of each case against the plain linear film
(k 3.8e7 N/m, c 3.5e3 N·s/m, 25.05 kg) and against the case's own analytic accelerance where it is linear, 20–1000 Hz.

    python benchmarks/concealed/redteam4/check.py
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

spec = importlib.util.spec_from_file_location("gen4", Path(__file__).with_name("generate.py"))
gen = importlib.util.module_from_spec(spec)
sys.modules["gen4"] = gen
spec.loader.exec_module(gen)


def h1(records: np.ndarray, rate: float):
    f = np.fft.rfft(records[:, 0], axis=1)
    a = np.fft.rfft(records[:, 1], axis=1)
    freq = np.fft.rfftfreq(records.shape[2], 1 / rate)
    return freq, (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0), f, a


def main() -> None:
    print(f"{'case':26s} {'max dev from plain film':>24s} {'at Hz':>7s} {'RMS dev':>8s}  {'own-model dev':>13s}  per-hit peak Hz (min–max)")
    for case in gen.cases():
        records, _, drawn = gen.synthesise(case, noise=False)
        rate = case.rate_hz
        freq, h, f, a = h1(records, rate)
        band = (freq >= 20) & (freq <= 1000)
        s = 2j * np.pi * freq
        plain = s**2 / (gen.K + gen.C * s + gen.MASS * s**2)
        dev = np.abs(h[band] / plain[band] - 1)
        own = ""
        if case.piecewise is None and case.sensor is None and case.per_hit_h is None and case.iepe_limits is None \
                and case.anti_alias:
            model = gen.film_accelerance(case, s)
            own = f"{np.median(np.abs(h[band] / model[band] - 1)):.1e}"
        per_hit = np.abs(a / f)
        window = (freq >= 100) & (freq <= 400)
        peaks = freq[window][np.argmax(per_hit[:, window], axis=1)]
        print(f"{case.name:26s} {dev.max():24.3%} {freq[band][dev.argmax()]:7.0f} {np.sqrt(np.mean(dev**2)):8.2%}  "
              f"{own:>13s}  {peaks.min():.0f}–{peaks.max():.0f}")


if __name__ == "__main__":
    main()
