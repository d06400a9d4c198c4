"""Checks of the round-10 generator (no gasfilm): per case, the noise-free H1 of the records as written (force and
response after the sensors, the AC coupling, the anti-aliasing filter, decimation and quantisation) against the plain
film (k 3.8e7, c 3.5e3, 25.05 kg) and, where the case is linear, against its own analytic FRF; causality; the peak
voltages against the module's ±5 V; the size of the whole case AND OF EACH OF ITS EFFECTS against the measurement
noise of its own records (each effect: the case with it against the case without it, everything else equal); and what
each case does, in numbers (written to check.txt beside this file).

The band of every figure is the case's own hammer band: 20 Hz up to where the noise-free force spectrum falls 20 dB
below its low-frequency level (at most 0.4 fs) — the band a diagnosis can read.

    python benchmarks/concealed/redteam10/check.py [--only CASE ...]
"""
from __future__ import annotations

import argparse
import importlib.util
import io
import sys
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
from scipy import signal

HERE = Path(__file__).resolve().parent
spec = importlib.util.spec_from_file_location("gen10", HERE / "generate.py")
gen = importlib.util.module_from_spec(spec)
sys.modules["gen10"] = gen
spec.loader.exec_module(gen)


def written(case, noise: bool, on=None):
    records, _, drawn = gen.synthesise(case, noise=noise, on=on)
    return np.array(records), drawn


def spectra(arr: np.ndarray, rate: float):
    f = np.fft.rfft(arr[:, 0], axis=1)
    a = np.fft.rfft(arr[:, 1], axis=1)
    freq = np.fft.rfftfreq(arr.shape[2], 1 / rate)
    h1 = (np.conj(f) * a).sum(0) / (np.abs(f) ** 2).sum(0)
    return freq, h1, f, a


def hammer_band(freq, f_spec, rate) -> tuple[float, float]:
    level = np.sqrt(np.mean(np.abs(f_spec) ** 2, axis=0))
    low = np.median(level[(freq > 5) & (freq < 50)])
    above = np.nonzero((level < 0.1 * low) & (freq > 50))[0]
    top = freq[above[0]] if above.size else freq[-1]
    return 20.0, float(min(top, 0.4 * rate))


def noise_variance(clean, noisy, rate, h_ref):
    """S(f): the variance of a hit's FRF numerator noise, n_i = (A_noisy − A_clean) − H (F_noisy − F_clean), mean
    over hits, smoothed over 21 lines."""
    _, _, f, a = spectra(clean, rate)
    _, _, fn, an = spectra(noisy, rate)
    n = (an - a) - h_ref[None, :] * (fn - f)
    var = np.mean(np.abs(n) ** 2, axis=0)
    return np.convolve(var, np.ones(21) / 21, mode="same")


def sizes(clean_a, clean_b, var, band, rate):
    """(χ² per line of H1_a against H1_b, its ÷√N, per-hit χ² per point of a against b): in noise units."""
    freq, h_a, f_a, a_a = spectra(clean_a, rate)
    _, h_b, f_b, a_b = spectra(clean_b, rate)
    sel = (freq >= band[0]) & (freq <= band[1])
    ef = np.sum(np.abs(f_a) ** 2, axis=0)
    chi_mean = np.sum(np.abs(h_a[sel] - h_b[sel]) ** 2 * ef[sel] / var[sel])
    lines = int(sel.sum())
    per_hit_b = a_b[:, sel] / f_b[:, sel]
    resid = a_a[:, sel] - per_hit_b * f_a[:, sel]
    chi_hits = np.sum(np.abs(resid) ** 2 / var[None, sel])
    return chi_mean / lines, chi_mean / np.sqrt(lines), chi_hits / (lines * clean_a.shape[0])


def own_h1(case, freq, f_spec, drawn):
    """The case's analytic H1 (linear cases): Σ|F_i|² H_i T_r,i / T_f over Σ|F_i|², or None."""
    if case.time_domain is not None:
        return None
    s = 2j * np.pi * freq
    parts = case.model(case, s, dict(drawn), {k["id"] for k in case.kinds}) if case.model else {}
    h = parts.get("h")
    if h is None:
        h = gen.sd_accelerance(s, *case.film, m=case.mass)[None, :]
    if parts.get("resp_tf") is not None:
        h = h * parts["resp_tf"]
    w = np.abs(f_spec) ** 2
    h = np.broadcast_to(h, f_spec.shape)
    model = (w * h).sum(0) / w.sum(0)
    if parts.get("force_tf") is not None:
        model = model / parts["force_tf"][0]
    return model


def describe(case, drawn) -> str:
    """What the case does, in numbers."""
    name = case.name
    f = np.linspace(5, 2500, 249501)
    s = 2j * np.pi * f
    plain = gen.sd_accelerance(s)

    def extrema(h, lo=20, hi=1500):
        sel = (f > lo) & (f < hi)
        mag = np.abs(h[sel])
        fs = f[sel]
        return ([round(float(fs[i]), 1) for i in signal.argrelmax(mag)[0]],
                [round(float(fs[i]), 1) for i in signal.argrelmin(mag)[0]])

    def at(h, freqs):
        return ", ".join(f"{x:.0f} Hz {np.abs(h[np.argmin(abs(f - x))]) / np.abs(plain[np.argmin(abs(f - x))]):.3f}×"
                         for x in freqs)
    on = {k["id"] for k in case.kinds}
    if name == "mover-plate-modes":
        h = gen.plate_modes(case, s, {}, on)["h"][0]
        p, d = extrema(h)
        return f"peaks {p} Hz, dips {d} Hz (plain film: peak 196.7 Hz); |H/H_plain| at {at(h, (500, 600, 650, 900))}"
    if name == "heavy-seismic-accelerometer":
        parts = gen.seismic_sensor(case, s, {}, on)
        h = parts["h"][0] * parts["resp_tf"][0]
        p, d = extrema(h)
        return (f"peaks {p} Hz, dips {d} Hz; |H/H_plain| at {at(h, (100, 197, 400, 600, 1000))}; the reading "
                f"alone |T| at 500 Hz {abs(gen.second_order(np.array([2j*np.pi*500]), 750, 0.03)[0]):.3f}")
    if name == "tip-extender-resonance":
        t = gen.second_order(s, gen.EXTENDER["resonance_hz"], gen.EXTENDER["damping_ratio"], zero=True)
        return f"the FRF × 1/T: " + ", ".join(f"{x:.0f} Hz {abs(1 / t[np.argmin(abs(f - x))]):.3f}"
                                                 for x in (200, 500, 1000, 1300, 1450))
    if name == "stud-backing-off":
        fr, zz = gen.stud_frequencies(case.hits)
        t1k = [abs(gen.second_order(np.array([2j * np.pi * 1000.0]), fi, zi, zero=True)[0]) for fi, zi in zip(fr, zz)]
        return (f"mount resonance per hit {np.round(fr, 0).astype(int).tolist()} Hz; |T(1 kHz)| per hit "
                f"{np.round(t1k, 3).tolist()}")
    if name == "joint-microslip-mode":
        return f"per-hit mode (peak of the mode's FRF, half-power ζ): {drawn.get('joint_per_hit', 'see below')}"
    if name == "wiper-seal-relaxation":
        z = gen.wiper_seal_z(s)
        return "added K, C: " + "; ".join(
            f"{x:.0f} Hz +{z[np.argmin(abs(f - x))].real:.3g} N/m, +{z[np.argmin(abs(f - x))].imag / (2 * np.pi * x):.0f} "
            f"N·s/m" for x in (20, 50, 197, 500, 1000))
    if name == "pocket-and-plenum-lags":
        out = []
        for x in (20, 64, 197, 796, 1000):
            z = sum(gen.lag_z(np.array([2j * np.pi * x]), gen.LAGS[p]["k_n_per_m"], gen.LAGS[p]["tau_s"])[0]
                    for p in ("pockets", "plenum"))
            out.append(f"{x} Hz K {gen.LAGS['film_k_n_per_m'] + z.real:.4g} N/m, C "
                       f"{gen.LAGS['film_c_ns_per_m'] + z.imag / (2 * np.pi * x):.0f} N·s/m")
        mover = np.array([gen.MASS, gen.LAGS["film_c_ns_per_m"], gen.LAGS["film_k_n_per_m"]])
        den = np.polymul([gen.LAGS["pockets"]["tau_s"], 1], [gen.LAGS["plenum"]["tau_s"], 1])
        poly = np.polyadd(np.polymul(mover, den),
                          np.polyadd(gen.LAGS["pockets"]["k_n_per_m"] * np.array([gen.LAGS["plenum"]["tau_s"], 1]),
                                     gen.LAGS["plenum"]["k_n_per_m"] * np.array([gen.LAGS["pockets"]["tau_s"], 1])))
        stable = bool(np.all(np.roots(poly).real < 0))
        return "; ".join(out) + f"; all poles stable: {stable}"
    if name == "gantry-beam-torsion":
        h = gen.gantry_beam(case, s, {}, on)["h"][0]
        p, d = extrema(h)
        return f"system poles (Hz, ζ) {gen.gantry_poles()}; |H| peaks {p}, dips {d}"
    if name == "shaker-left-attached":
        h = gen.shaker_attached(case, s, {}, on)["h"][0]
        p, d = extrema(h)
        z = gen.shaker_z(s)
        return (f"system poles (Hz, ζ) {gen.shaker_poles()}; |H| peaks {p}, dips {d}; added at 50 Hz "
                f"{z[np.argmin(abs(f - 50))].real:.3g} N/m, {z[np.argmin(abs(f - 50))].imag / (2 * np.pi * 50):.0f} N·s/m")
    if name == "cable-clamp-and-graphite":
        h = gen.clamp_and_graphite(case, s, {}, on)["h"][0]
        p, d = extrema(h)
        m = gen.CLAMP["memory"]
        z = gen.memory_z(s, m["k_m_n_per_m"], m["eta"], m["alpha"])
        return (f"peaks {p}, dips {d}; memory adds at 100/300/1000 Hz: " + ", ".join(
            f"+{z[np.argmin(abs(f - x))].real:.3g} N/m +{z[np.argmin(abs(f - x))].imag / (2 * np.pi * x):.0f} N·s/m"
            for x in (100, 300, 1000)))
    if name == "charge-sensor-on-voltage-input":
        t = gen.charge_on_voltage(case, s, {}, on)["resp_tf"][0]
        return (f"corner {gen.CHARGE['corner_hz']:.1f} Hz, gain {gen.CHARGE['gain']:.4f}; |T| at "
                + ", ".join(f"{x} Hz {abs(t[np.argmin(abs(f - x))]):.3f}" for x in (20, 100, 197, 373, 1000)))
    if name == "three-at-once":
        return (f"delay {gen.THREE['delay_s'] * 1e6:.2f} µs (phase −{360 * 1000 * gen.THREE['delay_s']:.1f}° at "
                f"1 kHz); +{gen.THREE['added_mass_kg']} kg (resonance {196.7 * np.sqrt(25.05 / 25.65):.1f} Hz); film "
                f"k −4 %, c +3 % over {drawn['hit_times_s'][-1] - drawn['hit_times_s'][0]:.0f} s")
    if name == "indicator-stand-set-down":
        h = gen.accelerance(s, gen.K + gen.C * s + gen.extra_mode_z(s, 0.22, 48.0, 0.03), gen.MASS + 1.05)
        p, d = extrema(h, 10, 1000)
        return f"hits 9–16: peaks {p}, dips {d}; pause before hit 9: {drawn['hit_times_s'][8] - drawn['hit_times_s'][7]:.1f} s"
    if name == "warming-isolator-mode":
        return f"mode per hit {drawn.get('isolator_hz')} Hz over {drawn['hit_times_s'][-1] - drawn['hit_times_s'][0]:.0f} s"
    if name == "clogging-orifice":
        return (f"pocket τ per hit {drawn.get('pocket_tau_ms')} ms, film k {drawn.get('film_k_n_per_m')[0]:.4g} → "
                f"{drawn.get('film_k_n_per_m')[-1]:.4g} N/m over {drawn['hit_times_s'][-1] - drawn['hit_times_s'][0]:.0f} s")
    if name == "pulsating-supply":
        line = abs(gen.sd_accelerance(np.array([2j * np.pi * 24.6]))[0]) * gen.PULSE["force_amplitude_n"]
        return f"steady line {line:.2e} m/s² at 24.6 Hz; stiffness ±2.5 %, damping ±1 % within each hit"
    if name == "walking-magnet-sensor":
        return (f"modal constant per hit {drawn.get('modal_constant_per_hit_1_per_kg')} 1/kg (640 Hz, ζ 0.006); |H1| "
                f"averages them (mean ≈ 0): the per-hit scatter is the effect")
    if name.startswith("control-"):
        k, c = case.film
        return (f"film k {k:.3g}, c {c:.3g}: {np.sqrt(k / gen.MASS) / (2 * np.pi):.1f} Hz, ζ "
                f"{c / (2 * np.sqrt(k * gen.MASS)):.4f}; rate {case.rate_hz:.2f} S/s, {case.hits} hits, forces "
                f"{min(drawn['peak_force_n'])}–{max(drawn['peak_force_n'])} N, session "
                f"{drawn['hit_times_s'][-1] - drawn['hit_times_s'][0]:.0f} s")
    return ""


def joint_per_hit(case, clean_mode_only, drawn):
    """Per hit: the peak and half-power width of the joint mode's own FRF (the mode's part of the response)."""
    out = []
    rate = case.rate_hz
    freq, _, f, a = spectra(clean_mode_only, rate)
    sel = (freq > 350) & (freq < 700)
    for i in np.argsort(drawn["_peaks"]):
        h = np.abs(a[i, sel] / f[i, sel])
        fb = freq[sel]
        fine = np.linspace(fb[0], fb[-1], 20000)
        hf = np.interp(fine, fb, h)
        k = np.argmax(hf)
        half = fine[hf > hf[k] / np.sqrt(2)]
        out.append((round(float(drawn["_peaks"][i])), round(float(fine[k]), 1),
                    round(float((half.max() - half.min()) / (2 * fine[k])), 4)))
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", metavar="CASE")
    args = parser.parse_args(argv)
    listed = [c for c in gen.cases() if not args.only or c.name in args.only]
    print(f"{'case':32s} {'band Hz':>11s} {'|H1/H_plain−1| max/RMS':>22s} {'own model med/max':>18s} "
          f"{'mean χ²/line':>12s} {'(÷√N)':>9s} {'scatter χ²/pt':>13s} {'peak V F/a':>11s} {'pre/peak':>9s}")
    effect_rows = []
    notes = []
    for case in listed:
        clean, drawn = written(case, noise=False)
        noisy, _ = written(case, noise=True)
        rate = case.rate_hz
        freq, h1, f_spec, _ = spectra(clean, rate)
        band = hammer_band(freq, f_spec, rate)
        sel = (freq >= band[0]) & (freq <= band[1])
        plain = gen.sd_accelerance(2j * np.pi * freq, *(case.film if case.category == "control" else (gen.K, gen.C)))
        dev = np.abs(h1[sel] / plain[sel] - 1)
        var = noise_variance(clean, noisy, rate, h1)
        # the whole case against the plain film: the plain film's records with the same draws
        plain_case = gen.Case(case.name, "control", "", "", "", case.seed, **{
            k: getattr(case, k) for k in ("rate_hz", "record_s", "pretrigger_s", "hits", "pulse_ms", "width_spread",
                                          "force_n", "spread", "force_range", "gap_s", "extra_gap", "accel_v",
                                          "accel_noise", "force_noise")})
        plain_clean, _ = written(plain_case, noise=False)
        if case.category == "control":
            plain_case.film, plain_case.model = case.film, case.model
            plain_clean, _ = written(plain_case, noise=False)
        whole = sizes(clean, plain_clean, var, band, rate)
        model = own_h1(case, freq, f_spec, drawn)
        own = ""
        if model is not None:
            rel = np.abs(h1[sel] / model[sel] - 1)
            own = f"{np.median(rel):.1e}/{rel.max():.1e}"
        pre = int(round((case.pretrigger_s - 0.3e-3) * rate))
        pv = f"{drawn['peak_volts'][0]:.2f}/{drawn['peak_volts'][1]:.2f}"
        wr = np.abs(clean[:, 1, :pre]).max() / np.abs(clean[:, 1]).max()
        print(f"{case.name:32s} {band[0]:4.0f}–{band[1]:5.0f} {f'{dev.max():.1%} / {np.sqrt(np.mean(dev**2)):.1%}':>22s} "
              f"{own:>18s} {whole[0]:12.3g} {whole[1]:9.3g} {whole[2]:13.3g} "
              f"{pv:>11s} {wr:9.1e}",
              flush=True)
        ids = [k["id"] for k in case.kinds if k["place"]]
        for kid in ids:
            without, _ = written(case, noise=False, on={k["id"] for k in case.kinds} - {kid})
            size = sizes(clean, without, var, band, rate)
            effect_rows.append((case.name, kid, next(k["kind"] for k in case.kinds if k["id"] == kid), size))
            if case.name == "joint-microslip-mode" and kid == "mode":
                mode_only = clean.copy()
                mode_only[:, 1] = clean[:, 1] - without[:, 1]
                drawn["joint_per_hit"] = joint_per_hit(case, mode_only, drawn)
        notes.append(f"- **{case.name}**: {describe(case, drawn)}")
    print("\n(band: 20 Hz to where the noise-free force spectrum is 20 dB below its low-frequency level, ≤ 0.4 fs. "
          "|H1/H_plain − 1|: the noise-free H1 against the plain film k 3.8e7, c 3.5e3, 25.05 kg (a control: its own film). own model: the "
          "noise-free H1 against the case's analytic FRF (linear cases). mean χ²/line: the whole case's H1 against the "
          "plain film's H1 of the same draws, in units of H1's own noise (the same synthesis with noise), per line; "
          "(÷√N): that χ² over its spread √N — beyond ≈ 5 it is seen. scatter χ²/pt: each hit of the case against the "
          "plain film's hit, per hit and line. peak V: the largest force and response at the module's input (range "
          "±5 V). pre/peak: the written response before the pulse over its peak.)\n")
    print("Each effect against its own noise (the case with it against the case without it, all else equal):\n")
    print("| case | effect | mean χ²/line | (÷√N) | per-hit χ²/pt |")
    print("| --- | --- | --- | --- | --- |")
    for name, kid, label, (m, z, h) in effect_rows:
        print(f"| {name} | {kid}: {label} | {m:.3g} | {z:.3g} | {h:.3g} |")
    print("\nWhat each case does:\n")
    print("\n".join(notes))


if __name__ == "__main__":
    buffer = io.StringIO()
    with redirect_stdout(buffer):
        main()
    text = buffer.getvalue()
    print(text, end="")
    if "--only" not in sys.argv:
        (HERE / "check.txt").write_text(text)
