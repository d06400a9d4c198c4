"""Checks of the round-6 generator (no gasfilm): noise-free H1 (force and response as written, after quantisation and
the exporter) of each case against the plain linear film of the case (k, c, 25.05 kg) and, where the case has a
closed form, against its own analytic FRF, 20–1000 Hz; causality (response before the pulse over its peak, in the
analog response before the chain, and in the written records).

    python benchmarks/concealed/redteam6/check.py
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
from scipy import signal

spec = importlib.util.spec_from_file_location("gen6", Path(__file__).with_name("generate.py"))
gen = importlib.util.module_from_spec(spec)
sys.modules["gen6"] = gen
spec.loader.exec_module(gen)


def h1(records: np.ndarray, rate: float):
    f = np.fft.rfft(records[:, 0], axis=1)
    a = np.fft.rfft(records[:, 1], axis=1)
    freq = np.fft.rfftfreq(records.shape[2], 1 / rate)
    return freq, (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0), f


def own_model(case, s, f_spec, drawn):
    """The case's analytic FRF of the written channels, or None."""
    h = gen.case_accelerance(case, s)
    name = case.name
    if name.startswith("control-") or name in ("transport-delay", "soft-payload", "twin-carriage"):
        return h
    if name == "capacitive-crosstalk":
        return h + drawn["leak_m_s2_per_n_per_s"] * s
    if name == "multiplexed-daq":
        return h * np.exp(s * case.response_advance_s) + drawn["ghost_m_s2_per_n"]
    if name == "differentiated-displacement":
        dt = 1 / case.rate_hz
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.nan_to_num(h * (1 - np.exp(-s * dt)) ** 2 / dt**2 / s**2)
    if name == "zero-phase-highpass":
        sos = signal.butter(2, 10.0, btype="high", output="sos", fs=case.rate_hz)
        _, t = signal.sosfreqz(sos, worN=np.abs(s) / (2 * np.pi), fs=case.rate_hz)
        return h * np.abs(t) ** 2
    if name == "swapped-cables":
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.nan_to_num((gen.HAMMER_V_PER_N / gen.ACCEL_V_PER_M_S2) ** 2 / h)
    if name == "two-sided-hits":
        sign = np.asarray(drawn["response_sign"])
        w = (np.abs(f_spec) ** 2)
        return h * (sign[:, None] * w).sum(0) / w.sum(0)
    return None


def main() -> None:
    print(f"{'case':28s} {'max |H1| dev vs plain':>22s} {'at Hz':>7s} {'RMS dev':>8s} {'complex max/RMS':>16s}  {'own-model dev (median/max)':>27s}"
          f"  {'acausal (analog)':>16s}  {'pre-pulse/peak (written)':>24s}")
    for case in gen.cases():
        records, _, drawn = gen.synthesise(case, noise=False)
        if case.export is not None:
            pass
        rate = case.rate_hz
        freq, h, f_spec = h1(records, rate)
        band = (freq >= 20) & (freq <= min(1000, 0.4 * rate))
        s = 2j * np.pi * freq
        plain = gen.sd_accelerance(s, k=case.film[0], c=case.film[1])
        dev = np.abs(np.abs(h[band]) / np.abs(plain[band]) - 1)
        cdev = np.abs(h[band] / plain[band] - 1)
        model = own_model(case, s, f_spec, drawn)
        own = ""
        if model is not None:
            rel = np.abs(h[band] / model[band] - 1)
            own = f"{np.median(rel):.1e} / {rel.max():.1e}"
        pre = int(round((case.pretrigger_s - 0.2e-3) * rate))
        written = np.abs(records[:, 1, :pre]).max() / np.abs(records[:, 1]).max()
        print(f"{case.name:28s} {dev.max():22.2%} {freq[band][dev.argmax()]:7.0f} {np.sqrt(np.mean(dev**2)):8.2%} "
              f"{f'{cdev.max():.1%}/{np.sqrt(np.mean(cdev**2)):.1%}':>16s}  "
              f"{own:>27s}  {drawn['acausal_fraction']:16.1e}  {written:24.1e}")
    # exporter steps whose size shows only with noise: the same draw with and without the step
    import dataclasses
    for name in ("wavelet-denoised",):
        case = next(c for c in gen.cases() if c.name == name)
        with_step, _, _ = gen.synthesise(case)
        plain_case = dataclasses.replace(case, export=None, overlap=False)
        without, _, _ = gen.synthesise(plain_case)
        freq, ha, _ = h1(with_step, case.rate_hz)
        _, hb, _ = h1(without, case.rate_hz)
        band = (freq >= 20) & (freq <= 1000)
        dev = np.abs(np.abs(ha[band]) / np.abs(hb[band]) - 1)
        tail = slice(int(0.7 * with_step.shape[2]), None)
        ratio = with_step[:, 1, tail].std() / without[:, 1, tail].std()
        print(f"{name} (with noise, vs the same draw without the step): |H1| max {dev.max():.2%} at "
              f"{freq[band][dev.argmax()]:.0f} Hz, RMS {np.sqrt(np.mean(dev**2)):.2%}; response tail RMS ratio "
              f"{ratio:.3g}")
    # float32: the rounding the exporter adds, against the 24-bit step of the response
    case = next(c for c in gen.cases() if c.name == "control-float32")
    records, _, _ = gen.synthesise(case)
    err = np.abs(records.astype(np.float32).astype(float) - records).max(axis=(0, 2))
    print(f"\ncontrol-float32: largest float32 rounding force {err[0]:.2e} N, response {err[1]:.2e} m/s^2 "
          f"(24-bit steps {gen.LSB_V / gen.HAMMER_V_PER_N:.2e} N, {gen.LSB_V / gen.ACCEL_V_PER_M_S2:.2e} m/s^2)")


if __name__ == "__main__":
    main()
