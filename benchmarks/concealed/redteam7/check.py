"""Checks of the round-7 generator (no gasfilm): noise-free H1 (force and response as written, after quantisation and
the exporter) of each case against the plain linear film of the case (k, c, 25.05 kg) and, where the case has a
closed form, against its own analytic FRF, 20–1000 Hz (20–400 Hz for the soft tip); causality (response before the
pulse over its peak, in the analog response before the chain and in the written records); and per case the size of
what the fault does (written to check.txt beside this file).

    python benchmarks/concealed/redteam7/check.py
"""
from __future__ import annotations

import importlib.util
import io
import sys
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
from scipy import signal

HERE = Path(__file__).resolve().parent
spec = importlib.util.spec_from_file_location("gen7", HERE / "generate.py")
gen = importlib.util.module_from_spec(spec)
sys.modules["gen7"] = gen
spec.loader.exec_module(gen)


def h1(records: np.ndarray, rate: float):
    f = np.fft.rfft(records[:, 0], axis=1)
    a = np.fft.rfft(records[:, 1], axis=1)
    freq = np.fft.rfftfreq(records.shape[2], 1 / rate)
    return freq, (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0), f, a


def weighted(per_hit: np.ndarray, f_spec: np.ndarray) -> np.ndarray:
    w = np.abs(f_spec) ** 2
    return (w * per_hit).sum(0) / w.sum(0)


def own_model(case, s, f_spec, drawn):
    """The case's analytic FRF of the written channels, or None."""
    name = case.name
    h = gen.case_accelerance(case, s)
    if name in ("control-17k07", "control-heavy-hits", "control-soft-tip", "control-impulse-normalised",
                "eddy-current-preload", "pocket-thermal-relaxation", "bellows-cover"):
        return h
    if name == "filter-delay-mismatch":
        return h * np.exp(s * case.response_advance_s)
    if name == "charge-amp-short-tc":
        return h * s / (s + 2 * np.pi * gen.CHARGE["corner_hz"])
    if name == "interpolated-response":
        fine = gen.OVERSAMPLE * case.rate_hz
        f = np.abs(s) / (2 * np.pi)
        _, slow = signal.sosfreqz(gen.anti_aliasing(case.rate_hz / 2, fine), worN=f, fs=fine)
        _, fast = signal.sosfreqz(gen.anti_aliasing(case.rate_hz), worN=f, fs=fine)
        advance = drawn["filter_delay_difference_removed_s"]
        return h * np.exp(s * advance) * slow / fast * (1 + np.cos(2 * np.pi * f / case.rate_hz)) / 2
    if name == "coolant-filling":
        per = np.stack([gen.sd_accelerance(s, m=m) for m in drawn["mover_mass_kg"]])
        return weighted(per, f_spec)
    if name == "hand-on-mover":
        zh = gen.hand_impedance(s)
        grip = np.asarray(drawn["grip_factor"])
        with np.errstate(divide="ignore", invalid="ignore"):
            per = np.nan_to_num(s[None, :] ** 2 / (gen.K + gen.C * s[None, :] + gen.MASS * s[None, :] ** 2
                                                   + grip[:, None] * zh[None, :]))
        return weighted(per, f_spec)
    return None


def main() -> None:
    print(f"{'case':28s} {'max |H1| dev vs plain':>22s} {'at Hz':>7s} {'RMS dev':>8s} {'complex max/RMS':>16s}  "
          f"{'own-model dev (median/max)':>27s}  {'acausal (analog)':>16s}  {'pre-pulse/peak (written)':>24s}")
    listed = gen.cases()
    for case in listed:
        records, _, drawn = gen.synthesise(case, noise=False)
        rate = case.rate_hz
        freq, h, f_spec, _ = h1(records, rate)
        top = 400 if case.name == "control-soft-tip" else 1000
        band = (freq >= 20) & (freq <= top)
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
    print("\n(control-dithered-16bit and popcorn-noise add their dither / telegraph signal even in the noise-free "
          "run: their deviations are that noise, not a bias.)\n")

    by = {c.name: c for c in listed}

    # what each fault does, in numbers (with noise where it is about noise)
    case = by["force-gauge-nonlinearity"]
    records, _, drawn = gen.synthesise(case, noise=False)
    freq, _, f_spec, a_spec = h1(records, case.rate_hz)
    low = (freq > 30) & (freq < 150)
    plain = gen.sd_accelerance(2j * np.pi * freq[low])
    gain = np.array([np.median(np.abs(a_spec[i, low] / f_spec[i, low] / plain)) - 1 for i in range(case.hits)])
    peaks = np.asarray(drawn["peak_force_n"])
    slope = np.polyfit(peaks, gain, 1)[0]
    print(f"force-gauge-nonlinearity: per-hit |H| gain 30–150 Hz from {gain.min():+.2%} (at {peaks[gain.argmin()]:.0f} N) "
          f"to {gain.max():+.2%} (at {peaks[gain.argmax()]:.0f} N), slope {slope * 100:.2e} %/N "
          f"(model 0.785 β F: {0.785 * gen.GAUGE['beta_per_n'] * 100:.4f} %/N)")

    case = by["force-window-cut"]
    records, _, drawn = gen.synthesise(case, noise=False)
    cut = np.asarray(drawn["impulse_fraction_cut"])
    print(f"force-window-cut: impulse missing from the force records {cut.min():.1%} … {cut.max():.1%} "
          f"(median {np.median(cut):.1%})")

    case = by["hammer-head-ringing"]
    records, _, drawn = gen.synthesise(case, noise=False)
    freq, h, f_spec, _ = h1(records, case.rate_hz)
    plain = gen.sd_accelerance(2j * np.pi * freq)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(h / plain)
    zone = (freq > 700) & (freq < 1200)
    print(f"hammer-head-ringing: ringing {min(drawn['ringing_amplitude_n']):.1f}–{max(drawn['ringing_amplitude_n']):.1f} N; "
          f"|H1|/|H| in 700–1200 Hz from {ratio[zone].min():.3f} ({freq[zone][ratio[zone].argmin()]:.0f} Hz) "
          f"to {ratio[zone].max():.3f} ({freq[zone][ratio[zone].argmax()]:.0f} Hz); at 100 Hz {ratio[np.argmin(abs(freq - 100))]:.4f}")

    case = by["adc-midscale-dnl"]
    records, _, drawn = gen.synthesise(case)
    tail = slice(int(0.75 * records.shape[2]), None)
    print(f"adc-midscale-dnl (with noise): response samples exactly 0: {drawn['zero_fraction_response']:.1%} "
          f"(last quarter of the records: {np.mean(records[:, 1, tail] == 0):.1%}); force last quarter "
          f"{np.mean(records[:, 0, tail] == 0):.1%}")
    fs = case.rate_hz
    last = [np.flatnonzero(row[: int(0.5 * fs)])[-1] / fs for row in records[:, 1]]
    peak = np.abs(records[:, 1]).max(axis=1).mean()
    dead = gen.DNL["dead_lsb"] * gen.LSB16_V / gen.ACCEL_V_PER_M_S2
    ring = np.log(peak / dead) / (0.057 * 2 * np.pi * 196)
    print(f"  the response's last non-zero sample: {np.median(last) * 1e3:.0f} ms into the record (median; "
          f"{min(last) * 1e3:.0f}–{max(last) * 1e3:.0f}); a linear film at ζ 0.057 rings down from "
          f"{peak:.1f} m/s² to the dead band ({dead:.3f} m/s²) in {ring * 1e3:.0f} ms after the hit")

    case = by["popcorn-noise"]
    with_rts, _, drawn = gen.synthesise(case)
    base = gen.Case(**{**case.__dict__, "chain": None})
    without, _, _ = gen.synthesise(base)
    tail = slice(int(0.75 * with_rts.shape[2]), None)
    def psd_band(x, lo, hi):
        f, p = signal.welch(x[:, 1, tail], fs=case.rate_hz, nperseg=1024, axis=-1)
        sel = (f >= lo) & (f <= hi)
        return p[:, sel].mean()
    for lo, hi in ((5, 20), (20, 50), (100, 300)):
        print(f"popcorn-noise: response tail PSD {lo}–{hi} Hz × {psd_band(with_rts, lo, hi) / psd_band(without, lo, hi):.3g} "
              f"the white floor")
    print(f"  telegraph switches per record: {min(drawn['telegraph_switches_per_record'])}–"
          f"{max(drawn['telegraph_switches_per_record'])}")

    case = by["coolant-filling"]
    _, _, drawn = gen.synthesise(case, noise=False)
    m = drawn["mover_mass_kg"]
    print(f"coolant-filling: mover mass {m[0]:.3f} → {m[-1]:.3f} kg over {drawn['hit_times_s'][-1] - drawn['hit_times_s'][0]:.1f} s")

    case = by["hand-on-mover"]
    _, _, drawn = gen.synthesise(case, noise=False)
    print(f"hand-on-mover: grip factors {min(drawn['grip_factor']):.2f}–{max(drawn['grip_factor']):.2f}; hand impedance at "
          f"196 Hz {gen.hand_impedance(np.array([2j * np.pi * 196]))[0].imag / (2 * np.pi * 196):.0f} N·s/m")

    case = by["interpolated-response"]
    _, _, drawn = gen.synthesise(case, noise=False)
    print(f"interpolated-response: filter-delay difference removed {drawn['filter_delay_difference_removed_s'] * 1e6:.1f} µs")

    case = by["control-dithered-16bit"]
    with_d, _, _ = gen.synthesise(case)
    plain = gen.Case(**{**case.__dict__, "sampled": None, "quant_steps": None})
    without_d, _, _ = gen.synthesise(plain)
    err = (with_d - without_d)[:, :, -2000:]
    print(f"control-dithered-16bit: error against the 24-bit record (tails) force {err[:, 0].std():.3f} N, response "
          f"{err[:, 1].std():.4f} m/s² RMS (0.5 LSB = {0.5 * gen.QUANT16[0]:.3f} N, {0.5 * gen.QUANT16[1]:.4f} m/s²)")

    case = by["control-impulse-normalised"]
    _, _, drawn = gen.synthesise(case, noise=False)
    imp = np.asarray(drawn["impulse_n_s"])
    print(f"control-impulse-normalised: impulses {imp.min():.4f}–{imp.max():.4f} N·s (records × {1 / imp.max():.1f}–"
          f"{1 / imp.min():.1f})")


if __name__ == "__main__":
    buffer = io.StringIO()
    with redirect_stdout(buffer):
        main()
    text = buffer.getvalue()
    print(text, end="")
    (HERE / "check.txt").write_text(text)
