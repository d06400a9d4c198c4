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


BANDS_HZ = ((20, 50), (50, 100), (100, 300), (300, 1000), (1000, 2000))


def band_errors(freq: np.ndarray, measured: np.ndarray, model: np.ndarray, level: np.ndarray,
                digits: int = 2) -> str:
    """Median and max |measured/model − 1| per band, where the force spectrum is within 20 dB of its start."""
    parts = []
    for lo, hi in BANDS_HZ:
        band = (freq >= lo) & (freq < hi) & (level > 0.1)
        if band.sum() >= 3:
            error = np.abs(measured[band] / model[band] - 1)
            parts.append(f"{lo}-{hi} Hz {100 * np.median(error):.{digits}g} % (max {100 * error.max():.{digits}g} %)")
    return "; ".join(parts)


def noiseless_h1(case: generate.Case, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    quiet, _, _ = generate.synthesise(case, noise=False)
    return h1(quiet[:, 0], quiet[:, 1], fs)


def check_exported_windowed(case, force, accel, fs, drawn) -> str:
    """Noiseless H1 of the windowed records = the accelerance at s = σ + jω; the noise falls as e^{-σt}."""
    sigma = drawn["export_decay_rate_1_s"]
    freq, noiseless, level = noiseless_h1(case, fs)
    model = generate.accelerance(case, freq, case.film_k, case.film_c, decay_rate_1_s=sigma)
    pre = accel[:, : int(0.008 * fs)].std()
    tail = accel[:, -int(0.1 * fs):].std()
    return (f" σ {sigma:.3f} 1/s; noiseless H1 / accelerance(σ + jω) − 1: {band_errors(freq, noiseless, model, level)}"
            f" | response noise pre-trigger {pre:.2g}, last 0.1 s {tail:.2g} m/s² (e^(-σT) ≈ "
            f"{np.exp(-sigma * 0.95):.3g}) | force after the window: {np.abs(force[:, int(0.02 * fs):]).max():.1g} N")


def check_coarse_adc(case, force, accel, fs, drawn) -> str:
    lsb = drawn["lsb"]
    off_grid = max(np.abs(force / lsb["force_n"] - np.round(force / lsb["force_n"])).max(),
                   np.abs(accel / lsb["accel_m_s2"] - np.round(accel / lsb["accel_m_s2"])).max())
    tail = accel[:, -accel.shape[1] // 4:]
    freq, measured, level = h1(force, accel, fs)
    model = generate.accelerance(case, freq, case.film_k, case.film_c)
    _, noiseless, _ = noiseless_h1(case, fs)
    return (f" LSB {lsb['force_n']:.4g} N, {lsb['accel_m_s2']:.4g} m/s² (off grid ≤ {off_grid:.1g} LSB); "
            f"tail samples exactly 0: {100 * np.mean(tail == 0):.0f} %, tail RMS {tail.std():.3g} m/s² vs "
            f"LSB/√12 = {lsb['accel_m_s2'] / np.sqrt(12):.3g}; "
            f"peak |a| {np.abs(accel).max() / lsb['accel_m_s2']:.0f} LSB"
            f" | H1/analytic − 1: {band_errors(freq, measured, model, level)}"
            f" | rounding only (no ADC noise): {band_errors(freq, noiseless, model, level)}")


def check_floor(case, force, accel, fs, drawn) -> str:
    freq, measured, level = h1(force, accel, fs)
    model = generate.accelerance(case, freq, case.film_k, case.film_c)
    _, noiseless, _ = noiseless_h1(case, fs)
    tail = accel[:, -accel.shape[1] // 4:]
    spectrum = np.abs(np.fft.rfft(tail, axis=1)) ** 2
    tail_freq = np.fft.rfftfreq(tail.shape[1], 1 / fs)
    share = {f0: spectrum[:, np.abs(tail_freq - f0) <= 3].sum() / spectrum[:, 1:].sum() for f0 in (37.0, 74.0)}
    return (f" floor on the mover {drawn['floor_rms_on_mover_m_s2']:.2g} m/s² RMS; tail power at 37/74 Hz "
            f"{100 * share[37.0]:.0f} / {100 * share[74.0]:.0f} % | noiseless H1/analytic − 1: "
            f"{band_errors(freq, noiseless, model, level, 1)} | with noise and floor: "
            f"{band_errors(freq, measured, model, level)}")


def check_late_trigger(case, force, accel, fs, drawn) -> str:
    """The FRF reads high by about the impulse fraction missing from the force record."""
    fraction = np.array(drawn["impulse_fraction_before_record"])
    weights = np.array(drawn["peak_force_n"]) ** 2
    expected = np.sum(weights * fraction) / np.sum(weights)
    freq, noiseless, level = noiseless_h1(case, fs)
    model = generate.accelerance(case, freq, case.film_k, case.film_c)
    ratio = noiseless / model - 1
    parts = [f"{lo}-{hi} Hz {100 * np.median(ratio[(freq >= lo) & (freq < hi)].real):+.3f} %"
             for lo, hi in ((20, 100), (100, 300), (300, 1000))]
    return (f" force at the first sample {force[:, 0].min():.1f}–{force[:, 0].max():.1f} N; impulse before the "
            f"record {100 * fraction.min():.2f}–{100 * fraction.max():.2f} % (|F|²-weighted mean "
            f"{100 * expected:.3f} %) | noiseless Re(H1/analytic) − 1: " + "; ".join(parts))


def resonance_per_hit(force: np.ndarray, accel: np.ndarray, fs: float, zero_pad: int = 8) -> np.ndarray:
    """Frequency (Hz) of each hit's |A/F| peak between 150 and 260 Hz, on a zero-padded grid."""
    n = force.shape[1] * zero_pad
    freq = np.fft.rfftfreq(n, 1 / fs)
    ratio = np.abs(np.fft.rfft(accel, n, axis=1) / np.fft.rfft(force, n, axis=1))
    band = (freq > 150) & (freq < 260)
    return freq[band][np.argmax(ratio[:, band], axis=1)]


def check_softening_hardening(case, force, accel, fs, drawn) -> str:
    peaks = np.array(drawn["peak_force_n"])
    res = resonance_per_hit(force, accel, fs)
    order = np.argsort(peaks)
    groups = np.array_split(order, 4)
    return " per-hit |H| peak by force quartile: " + "; ".join(
        f"{peaks[g].min():.0f}–{peaks[g].max():.0f} N → {res[g].mean():.2f} Hz" for g in groups)


def check_hvac(case, force, accel, fs, drawn) -> str:
    times = np.array(drawn["hit_times_s"])
    ks = np.array(drawn["film_k_per_hit_n_per_m"])
    res = resonance_per_hit(force, accel, fs)
    trend = np.polyfit(times - times[0], ks / 3.8e7 - 1, 1)[0] * (times[-1] - times[0])
    predicted = np.sqrt(ks / case.mass_kg) / (2 * np.pi)
    return (f" session {times[-1] - times[0]:.0f} s; k per hit {100 * (ks.min() / 3.8e7 - 1):+.2f} … "
            f"{100 * (ks.max() / 3.8e7 - 1):+.2f} %, least-squares trend over the session {100 * trend:+.2f} %; "
            f"per-hit |H| peak {res.min():.1f}–{res.max():.1f} Hz, correlation with √(k/m) "
            f"{np.corrcoef(res, predicted)[0, 1]:.2f}")


SECOND_ROUND = {
    "control-exported-windowed": check_exported_windowed,
    "control-coarse-adc": check_coarse_adc,
    "control-floor-compressor": check_floor,
    "control-late-trigger": check_late_trigger,
    "softening-hardening": check_softening_hardening,
    "hvac-cycling": check_hvac,
}


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
        if case.name in SECOND_ROUND:
            line += SECOND_ROUND[case.name](case, force, accel, fs, drawn)
        elif not case.nonlinear and case.per_hit_film is None and case.per_hit_delay_s is None:
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
        pre = max(int(case.pretrigger_s * fs * 0.8), 1)
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
                      {"kind": "touchdown", "clearance_m": 1.0, "contact_k_n_per_m": 1e9, "contact_c_ns_per_m": 0.0},
                      {"kind": "quintic", "a3": 0.0, "a5": 0.0, "scale_m": 10e-6}):
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
