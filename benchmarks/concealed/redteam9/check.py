"""Checks of the round-9 generator (no gasfilm): noise-free H1 (force and response as written, after quantisation and
the exporter) of each case against the plain linear film (k 3.8e7, c 3.5e3, 25.05 kg) and, where the case has a
closed form, against its own analytic FRF, 20–1000 Hz; causality (response before the pulse over its peak, in the
analog response and in the written records); the size of each effect against the measurement noise of its own
records (H1 and per hit: the same synthesis with noise against the noise-free one); and per case what the fault does
(written to check.txt beside this file).

    python benchmarks/concealed/redteam9/check.py
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
spec = importlib.util.spec_from_file_location("gen9", HERE / "generate.py")
gen = importlib.util.module_from_spec(spec)
sys.modules["gen9"] = gen
spec.loader.exec_module(gen)

BAND = (20.0, 1000.0)


def as_array(records) -> np.ndarray:
    """Records as one array, cut to the shortest (mixed-length control: a 1 s record cut to 0.5 s is a 0.5 s record)."""
    n = min(r.shape[1] for r in records)
    return np.array([r[:, :n] for r in records])


def six_digits(x: np.ndarray) -> np.ndarray:
    """What ASCII E13.5 keeps (six significant digits)."""
    return np.array([float(f"{v:.5e}") for v in x.ravel()]).reshape(x.shape)


def written(case, noise: bool):
    records, starts, drawn = gen.synthesise(case, noise=noise)
    arr = as_array(records)
    if case.ascii_single:
        arr = six_digits(arr)
    return arr, drawn


def spectra(arr: np.ndarray, rate: float):
    f = np.fft.rfft(arr[:, 0], axis=1)
    a = np.fft.rfft(arr[:, 1], axis=1)
    freq = np.fft.rfftfreq(arr.shape[2], 1 / rate)
    h1 = (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0)
    return freq, h1, f, a


def weighted(per_hit: np.ndarray, f_spec: np.ndarray) -> np.ndarray:
    w = np.abs(f_spec) ** 2
    return (w * per_hit).sum(0) / w.sum(0)


def own_model(case, s, f_spec, drawn):
    """The case's analytic FRF of the written channels, or None (additive disturbances and nonlinear faults)."""
    name = case.name
    h = gen.case_accelerance(case, s)
    if name.startswith("control-") or name in ("belt-drive-inertia", "counterbalance-cylinder",
                                               "journal-cross-coupling"):
        return h
    if name == "pad-creep":
        per = np.stack([gen.sd_accelerance(s, k=k, c=c) for k, c in zip(drawn["film_k_per_hit"],
                                                                        drawn["film_c_per_hit"])])
        return weighted(per, f_spec)
    if name == "force-in-lbf":
        return h * gen.LBF_IN_N
    if name == "export-off-by-one":
        return h * np.exp(s / case.rate_hz)
    if name == "boxcar-smoothed-response":
        _, t = signal.freqz(np.ones(gen.BOXCAR["points"]) / gen.BOXCAR["points"], [1.0],
                            worN=np.abs(s) / (2 * np.pi), fs=case.rate_hz)
        return h * t
    return None


def detectability(clean: np.ndarray, noisy: np.ndarray, rate: float):
    """The effect against the records' own noise, in χ² terms over 20–1000 Hz. The noise of hit i's FRF numerator at a
    line is n_i = (A_noisy − A_clean) − H_ref (F_noisy − F_clean); its variance S(f) is the mean of |n_i|² over the
    hits, smoothed over 21 lines. Mean effect: χ² of H1 (noise-free) against the plain film, Σ_f |H1 − H|² Σ_i|F_i|²/S.
    Scatter: χ² of each hit against the noise-free H1 (what no single linear film can take up),
    Σ_i Σ_f |A_i − H1 F_i|²/S. Reported per point and over √N (the noise's
    expectation being N (1 per point) and its spread √N."""
    freq, h1, f, a = spectra(clean, rate)
    _, _, fn, an = spectra(noisy, rate)
    band = (freq >= BAND[0]) & (freq <= BAND[1])
    plain = gen.sd_accelerance(2j * np.pi * freq)
    n = (an - a) - h1[None, :] * (fn - f)
    var = np.mean(np.abs(n) ** 2, axis=0)
    var = np.convolve(var, np.ones(21) / 21, mode="same")
    ef = np.sum(np.abs(f) ** 2, axis=0)
    chi_mean = np.sum(np.abs(h1[band] - plain[band]) ** 2 * ef[band] / var[band])
    lines = int(band.sum())
    resid = a[:, band] - h1[None, band] * f[:, band]
    chi_scatter = np.sum(np.abs(resid) ** 2 / var[None, band])
    points = lines * clean.shape[0]
    return chi_mean / lines, chi_mean / np.sqrt(lines), chi_scatter / points, chi_scatter / np.sqrt(points)


def main() -> None:
    listed = gen.cases()
    print(f"{'case':26s} {'|H1| vs plain max':>17s} {'at Hz':>6s} {'complex max/RMS':>16s} {'own model med/max':>18s} "
          f"{'mean χ²/line':>12s} {'(÷√N)':>8s} {'scatter χ²/pt':>13s} {'(÷√N)':>8s} {'acausal an.':>11s} "
          f"{'pre/peak wr.':>12s}")
    for case in listed:
        clean, drawn = written(case, noise=False)
        noisy, _ = written(case, noise=True)
        rate = case.rate_hz
        freq, h, f_spec, a_spec = spectra(clean, rate)
        band = (freq >= BAND[0]) & (freq <= BAND[1])
        s = 2j * np.pi * freq
        plain = gen.sd_accelerance(s)
        dev = np.abs(np.abs(h[band]) / np.abs(plain[band]) - 1)
        cdev = np.abs(h[band] / plain[band] - 1)
        mean_pt, mean_z, scat_pt, scat_z = detectability(clean, noisy, rate)
        model = own_model(case, s, f_spec, drawn)
        own = ""
        if model is not None:
            rel = np.abs(h[band] / model[band] - 1)
            if case.name == "mains-notch":  # the notch's zero: relative error there is meaningless
                rel = rel[np.abs(freq[band] - gen.NOTCH["freq_hz"]) > 2]
            own = f"{np.median(rel):.1e}/{rel.max():.1e}"
        pre = int(round((case.pretrigger_s - 0.2e-3) * rate))
        wr = np.abs(clean[:, 1, :pre]).max() / np.abs(clean[:, 1]).max()
        print(f"{case.name:26s} {dev.max():17.2%} {freq[band][dev.argmax()]:6.0f} "
              f"{f'{cdev.max():.1%}/{np.sqrt(np.mean(cdev**2)):.1%}':>16s} {own:>18s} {mean_pt:12.3g} {mean_z:8.3g} "
              f"{scat_pt:13.3g} {scat_z:8.3g} {drawn['acausal_fraction']:11.1e} {wr:12.1e}")
    print("\n(mean χ²/line: the noise-free H1 against the plain film (k 3.8e7, c 3.5e3, 25.05 kg) in units of H1's own "
          "noise (the same synthesis with noise), per analysis line (1 = one noise variance), 20–1000 Hz; (÷√N): the "
          "χ² over its spread √N — beyond ≈ 5 it is seen. A recalibrated film takes some of it up (controls: the "
          "film is the plain one). scatter χ²/pt: each hit against the noise-free H1, per hit and line: what no single "
          "linear film takes up (0 for a linear time-invariant case, the noise adding 1 on top). Controls: what their "
          "processing leaves.)\n")

    by = {c.name: c for c in listed}
    f = np.linspace(5, 1500, 149501)
    s = 2j * np.pi * f
    plain = gen.sd_accelerance(s)

    def peaks(h):
        idx = signal.argrelmax(np.abs(h))[0]
        return [(round(float(f[i]), 1), round(float(np.abs(h[i]) / np.abs(plain).max()), 3)) for i in idx]

    def dips(h):
        return [round(float(f[i]), 1) for i in signal.argrelmin(np.abs(h))[0]]

    print(f"plain film: peak at {f[np.argmax(np.abs(plain))]:.1f} Hz")
    h = gen.case_accelerance(by["belt-drive-inertia"], s)
    print(f"belt-drive-inertia: {gen.BELT}; peaks {peaks(h)}, dips {dips(h)}")
    for fr in (50.0, 159.0, 196.0, 1000.0):
        z = gen.counterbalance_cylinder(np.array([2j * np.pi * fr]))[0]
        print(f"counterbalance-cylinder at {fr:.0f} Hz: +{z.real:.3e} N/m, +{z.imag / (2 * np.pi * fr):.0f} N·s/m")
    tau = gen.CYLINDER["tau_ms"] * 1e-3
    k_m, eta = gen.CYLINDER["air_spring_n_per_m"], gen.CYLINDER["air_spring_n_per_m"] * tau
    zz = gen.counterbalance_cylinder(s) - k_m * eta * s / (k_m + eta * s)
    print(f"  the same as film-memory alpha 1, k_m {k_m:.3g}, eta {eta:.3g}: max |difference| {np.abs(zz).max():.1e} N/m")
    h = gen.journal_cross_coupling(s)
    z = gen.K + gen.C * s + gen.MASS * s**2
    print(f"journal-cross-coupling: peaks {peaks(h)}, dips {dips(h)}; |H|/|H_plain| at the plain peak "
          f"{np.abs(h[np.argmax(np.abs(plain))]) / np.abs(plain).max():.3f}")
    kc = gen.CROSS["cross_coupled_n_per_m"]
    for sign, label in ((1, "backward"), (-1, "forward")):
        r = np.roots([gen.MASS, gen.C, gen.K + sign * 1j * kc])
        r = r[np.argmax(r.imag)]
        print(f"  {label} whirl pole: {abs(r.imag) / (2 * np.pi):.2f} Hz, ζ {-r.real / abs(r):.4f}")
    print(f"  poles unstable? {any(np.roots(np.polymul([gen.MASS, gen.C, gen.K], [gen.MASS, gen.C, gen.K]) + np.array([0, 0, 0, 0, kc**2])).real > 0)}")
    hf = gen.case_accelerance(by["fan-unbalance"], np.array([2j * np.pi * 46.3, 2j * np.pi * 92.6]))
    print(f"fan-unbalance: response 1x {np.abs(hf[0]) * gen.FAN['force_1x_n']:.2e} m/s², 2x "
          f"{np.abs(hf[1]) * gen.FAN['force_2x_n']:.2e} m/s² (amplitudes)")
    for name in ("fan-unbalance", "floor-shocks", "gsm-buzz", "iepe-slew-limit", "stuck-adc-bit", "pad-creep",
                 "export-off-by-one"):
        _, drawn = written(by[name], noise=False)
        keep = {k: v for k, v in drawn.items() if k not in ("hit_times_s", "peak_force_n", "pulse_width_ms",
                                                            "acausal_fraction", "file_order") and not k.startswith("_")}
        print(f"{name}: {keep}")
    b8 = np.ones(8) / 8
    for fr in (196.0, 800.0, 1600.0):
        _, t8 = signal.freqz(b8, [1.0], worN=[fr], fs=12800.0)
        print(f"boxcar at {fr:.0f} Hz: |T| {np.abs(t8[0]):.4f}, phase {np.degrees(np.angle(t8[0])):+.2f}°")
    case = by["control-g-units"]
    print(f"control-g-units: response written ÷ 9.80665, labelled 'g'; control-grouped-channels: forces first")


if __name__ == "__main__":
    buffer = io.StringIO()
    with redirect_stdout(buffer):
        main()
    text = buffer.getvalue()
    print(text, end="")
    (HERE / "check.txt").write_text(text)
