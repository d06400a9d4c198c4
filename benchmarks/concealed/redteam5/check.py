"""Checks of the round-5 generator (no gasfilm): noise-free H1 of each case against the plain linear film
(k 3.8e7 N/m, c 3.5e3 N·s/m, 25.05 kg) and, where the case is linear and time-invariant with one accelerance for every
hit, against its own analytic accelerance (times the channels' transfer ratio), 20–1000 Hz (20 Hz–0.4 fs at 2.048
kS/s); causality (response before the pulse over its peak).

    python benchmarks/concealed/redteam5/check.py
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

spec = importlib.util.spec_from_file_location("gen5", Path(__file__).with_name("generate.py"))
gen = importlib.util.module_from_spec(spec)
sys.modules["gen5"] = gen
spec.loader.exec_module(gen)

OWN_MODEL = {"control-few-short", "control-3hits-10k24", "control-2k048-40hits", "control-noise-step",
             "dynamic-brake", "drive-point-pad", "gravity-dc"}


def h1(records: np.ndarray, rate: float):
    f = np.fft.rfft(records[:, 0], axis=1)
    a = np.fft.rfft(records[:, 1], axis=1)
    freq = np.fft.rfftfreq(records.shape[2], 1 / rate)
    return freq, (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0), f, a


def main() -> None:
    print(f"{'case':24s} {'max dev from plain film':>24s} {'at Hz':>7s} {'RMS dev':>8s}  {'own-model dev (median)':>22s}"
          f"  {'acausal':>8s}")
    for case in gen.cases():
        records, _, drawn = gen.synthesise(case, noise=False)
        rate = case.rate_hz
        freq, h, f, a = h1(records, rate)
        band = (freq >= 20) & (freq <= min(1000, 0.4 * rate))
        s = 2j * np.pi * freq
        plain = gen.sd_accelerance(s)
        dev = np.abs(h[band] / plain[band] - 1)
        own = ""
        if case.name in OWN_MODEL:
            model = gen.case_accelerance(case, s)
            if case.accel_dc_coupled:
                with np.errstate(divide="ignore", invalid="ignore"):
                    model = model / gen.ac_coupling(s)
            own = f"{np.median(np.abs(h[band] / model[band] - 1)):.1e}"
        print(f"{case.name:24s} {dev.max():24.3%} {freq[band][dev.argmax()]:7.0f} {np.sqrt(np.mean(dev**2)):8.2%}  "
              f"{own:>22s}  {drawn['acausal_fraction']:8.1e}")


if __name__ == "__main__":
    main()
