"""Red-team world, round 8: twelve further rig-physics and measurement faults plus six controls.

Written by a helper that has read neither ``analysis/``, ``app/``, ``drivers/`` nor ``tests/`` (only README.md, docs/,
the CLI's ``--help``, the paper and the earlier rounds' READMEs, keys, generators and scorers). Imports nothing from
gasfilm: numpy, scipy and pyuff only. The synthesis frame is round 7's, rewritten here with this round's hooks.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a half-sine
   of random peak and width starting at a random sub-sample instant; bench taps in ``bench-tap-triggers``);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance (per
   hit where it differs per hit: the compressor's pressure cycle, the bench taps that never reach the mover; the
   whole accelerance replaced where the impactor's reaction drives the base);
3. what the sensors add on the analog signals (the heavy tip in front of the hammer's gauge; the accelerometer that
   lifts off its seat, integrated in time by RK4), white sensor noise on both channels, the NI 9234's 0.5 Hz
   first-order AC coupling on both channels;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal), every
   8th analog point taken, what the logger did to the sampled values (a 50 Hz notch on the response, an autoranging
   conditioner's range gains), quantisation (24 bit on +-5 V with the software's sensitivities);
5. what the exporter did (int16 counts that wrap, two significant digits, trigger-aligned averaging of four hits,
   records cut shorter after hit 8), then UFF 58 (per hit a force record, data type 13 "N", and an acceleration
   record, 12 "m/s^2"; each record's absolute session start in ``abscissa_min``; binary doubles unless the case says:
   ASCII single precision, records in another order, times of day).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam8/generate.py [--out out/redteam8] [--only CASE ...] [--keys-only]
                                                     [--seed-offset N]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pyuff
from scipy import signal

OVERSAMPLE = 8
LEAD_IN_S = 0.004
FORCE_NOISE = 1e-4  # N/sqrt(Hz), white
ACCEL_NOISE = 3e-5  # (m/s^2)/sqrt(Hz), white
AC_CORNER_HZ = 0.5
LSB_V = 10.0 / 2**24  # NI 9234: 24 bit on +-5 V
HAMMER_V_PER_N = 2.25e-3
ACCEL_V_PER_M_S2 = 10.2e-3
MASS, K, C = 25.05, 3.8e7, 3.5e3  # true mover and film unless a case says otherwise
NOMINAL = {"mass_kg": 25.05, "k": 3.78e7, "eta": 3450.0}  # what the user knows (paper SD film)

RIG = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
       "step-change", "friction", "quadratic-damping")
CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error", "polarity")
EVERYTHING = RIG + CHAIN + ("window-damping",)
AMPLITUDE = ("cubic-stiffness", "friction", "quadratic-damping")
TIME = ("drift", "step-change")
MEMORY = ("film-memory", "squeeze-film", "pneumatic-lag")


def without(names, *kept):
    return [n for n in names if n not in kept]


def chain_but(*kept):
    return without(CHAIN, *kept) + ["window-damping"]


@dataclass
class Case:
    name: str
    category: str  # control | rig | measurement
    summary: str
    source: str
    reasoning: str
    seed: int
    cli: str = "mass"  # mass: --mass 25.05; rig: --rig nominal-rig.toml
    rate_hz: float = 12800.0
    record_s: float = 1.0
    pretrigger_s: float = 0.010
    hits: int = 16
    pulse_ms: float = 1.0
    width_spread: float = 0.05
    force_n: float = 200.0
    spread: float = 0.2
    gap_s: tuple = (1.0, 3.0)  # the pause between one record's end and the next hit
    film: tuple = (K, C)  # the true film (k, c)
    extra_z: Callable | None = None  # s -> dynamic stiffness added to the SD film (N/m)
    accel_fn: Callable | None = None  # s -> the whole accelerance (replaces the film + extra_z)
    per_hit_h: Callable | None = None  # (case, rng, s, drawn) -> (hits, nf) accelerance per hit
    pulses_fn: Callable | None = None  # (case, rng) -> (peaks, widths_s) per hit
    chain: Callable | None = None  # (case, rng, force, resp, t, drawn) -> (force, resp), analog, before noise
    sampled: Callable | None = None  # (case, rng, records, drawn) -> records, after sampling, before quantisation
    export: Callable | None = None  # (case, records, starts, drawn) -> (list of (2, n) records, starts)
    ascii_single: bool = False  # UFF 58 as ASCII, single precision (E13.5)
    write_order: str = "time"  # time | force-descending
    time_offset_s: float = 0.0  # added to every abscissa_min (a time of day)
    physics: dict = field(default_factory=dict)
    exact: list = field(default_factory=lambda: [[]])
    acceptable: list = field(default_factory=list)
    partial_ok: list = field(default_factory=list)
    must_not: list = field(default_factory=list)
    must_not_quality: list = field(default_factory=lambda: ["mains", "clip"])
    needs_alternative: dict = field(default_factory=dict)
    expected_quality: list = field(default_factory=list)
    honest_ok: bool = True
    refusal_ok: bool = False
    subtle: bool = False
    mass_told: float = NOMINAL["mass_kg"]


# ------------------------------------------------------------------------------------------------------ helpers

def nextpow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(n)))


def half_sine(t: np.ndarray, start: np.ndarray, width: np.ndarray, peak: np.ndarray) -> np.ndarray:
    u = (t[None, :] - start[:, None]) / width[:, None]
    return np.where((u >= 0) & (u <= 1), peak[:, None] * np.sin(np.pi * np.clip(u, 0, 1)), 0.0)


def sd_accelerance(s: np.ndarray, k: float = K, c: float = C, m: float = MASS) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (k + c * s + m * s**2))


def case_accelerance(case: Case, s: np.ndarray) -> np.ndarray:
    if case.accel_fn is not None:
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.nan_to_num(case.accel_fn(s))
    k, c = case.film
    z = k + c * s
    if case.extra_z is not None:
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            z = z + np.nan_to_num(case.extra_z(s))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (z + MASS * s**2))


def anti_aliasing(rate_hz: float, fine_hz: float | None = None):
    """The module's anti-aliasing filter for a sample rate, realised on the analog grid (default 8x the rate)."""
    fine = fine_hz or OVERSAMPLE * rate_hz
    order, wn = signal.ellipord(0.42 * rate_hz, 0.5 * rate_hz, 0.02, 110, fs=fine)
    return signal.ellip(order, 0.02, 110, wn, btype="low", output="sos", fs=fine)


# -------------------------------------------------------------------------------------------------- synthesis

def synthesise(case: Case, noise: bool = True):
    rng = np.random.default_rng(case.seed)
    fs = case.rate_hz
    fine = OVERSAMPLE * fs
    samples = int(round(case.record_s * fs))
    lead = int(round(LEAD_IN_S * fine))
    n = samples * OVERSAMPLE + lead
    t = (np.arange(n) - lead) / fine
    h = case.hits
    hit_times = 1.5 + np.cumsum(case.record_s + rng.uniform(*case.gap_s, h))
    if case.pulses_fn is not None:
        peaks, widths = case.pulses_fn(case, rng)
    else:
        peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(h)), 0.5 * case.force_n,
                        1.5 * case.force_n)
        widths = case.pulse_ms * 1e-3 * rng.uniform(1 - case.width_spread, 1 + case.width_spread, h)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, h)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist(),
             "_t0": t0, "_widths": widths, "_peaks": peaks, "_hit_times": hit_times}
    force = half_sine(t, t0, widths, peaks)
    starts = hit_times - case.pretrigger_s
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    hh = case.per_hit_h(case, rng, s, drawn) if case.per_hit_h is not None else case_accelerance(case, s)[None, :]
    resp = np.fft.irfft(np.fft.rfft(force, nfft, axis=1) * hh, nfft, axis=1)[:, :n]
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(resp[:, before]).max() / max(np.abs(resp).max(), 1e-300))
    if case.chain is not None:
        force, resp = case.chain(case, rng, force, resp, t, drawn)
    level = 1.0 if noise else 0.0
    force = force + level * FORCE_NOISE * np.sqrt(fine / 2) * rng.standard_normal(force.shape)
    resp = resp + level * ACCEL_NOISE * np.sqrt(fine / 2) * rng.standard_normal(resp.shape)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    force = signal.sosfilt(hp, force, axis=1)
    resp = signal.sosfilt(hp, resp, axis=1)
    records = np.empty((h, 2, samples))
    sos = anti_aliasing(fs)
    records[:, 0, :] = signal.sosfilt(sos, force, axis=1)[:, lead::OVERSAMPLE][:, :samples]
    records[:, 1, :] = signal.sosfilt(sos, resp, axis=1)[:, lead::OVERSAMPLE][:, :samples]
    if case.sampled is not None:
        records = case.sampled(case, rng, records, drawn)
    steps = (LSB_V / HAMMER_V_PER_N, LSB_V / ACCEL_V_PER_M_S2)
    for row, step in enumerate(steps):
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    records = list(records)
    if case.export is not None:
        records, starts = case.export(case, records, starts, drawn)
    return records, starts, drawn


def public(drawn: dict) -> dict:
    return {k: v for k, v in drawn.items() if not k.startswith("_")}


# ------------------------------------------------------------------------------------------------ case hooks

# rig --------------------------------------------------------------------------------------------------------

def extra_mode_z(s, m_e, f_e, zeta_e):
    """A mass on a spring-damper riding on the mover (the catalogue's extra-mode form)."""
    w = 2 * np.pi * f_e
    k_e, c_e = m_e * w**2, 2 * zeta_e * m_e * w
    return m_e * s**2 * (k_e + c_e * s) / (m_e * s**2 + c_e * s + k_e)


MU_TMD = 1.0 / MASS
TMD = {"tmd_mass_kg": 1.0, "freq_hz": round(float(np.sqrt(K / MASS) / (2 * np.pi) / (1 + MU_TMD)), 2),
       "damping_ratio": round(float(np.sqrt(3 * MU_TMD / (8 * (1 + MU_TMD) ** 3))), 4)}


def tuned_mass_damper(s):
    """Den Hartog's optimum absorber on the mover: 1.0 kg (mass ratio 0.04) tuned to f_n/(1 + mu), damped at
    sqrt(3 mu / 8 (1 + mu)^3)."""
    return extra_mode_z(s, TMD["tmd_mass_kg"], TMD["freq_hz"], TMD["damping_ratio"])


HOUDAILLE = {"absorber_mass_kg": 0.75, "c_ns_per_m": 1000.0}


def viscous_absorber(s):
    """Untuned viscous (Lanchester/Houdaille) damper: a free mass in a silicone-oil housing bolted to the mover, coupled
    by the oil's shear alone (no spring): Z = m_d c_d s^2 / (m_d s + c_d) -- a mass below c_d/(2 pi m_d) = 212 Hz, a
    dashpot above."""
    m, c = HOUDAILLE["absorber_mass_kg"], HOUDAILLE["c_ns_per_m"]
    return m * c * s**2 / (m * s + c)


COUNTERWEIGHT = {"counterweight_mass_kg": 10.5, "freq_hz": 70.0, "damping_ratio": 0.02}


def counterweight(s):
    """Weight-relief counterweight: 10 kg (+0.5 kg of pulley inertia) on a steel cable over an overhead pulley,
    hooked to the mover: a heavy mass riding on the cable's spring (2.03e6 N/m), 70 Hz, zeta 0.02."""
    return extra_mode_z(s, COUNTERWEIGHT["counterweight_mass_kg"], COUNTERWEIGHT["freq_hz"], COUNTERWEIGHT["damping_ratio"])


COMPRESSOR = {"k_amplitude": 0.015, "c_amplitude": 0.006, "period_s": 75.0, "fall_s": 65.0}


def sawtooth(t, period, fall):
    """+1 at cut-out falling linearly to -1 over ``fall`` s (the receiver discharging), back to +1 over the rest
    (the compressor loading)."""
    u = np.mod(t, period)
    return np.where(u < fall, 1 - 2 * u / fall, -1 + 2 * (u - fall) / (period - fall))


def compressor_cycling(case, rng, s, drawn):
    """The bearing's supply follows the shop compressor's receiver (load/unload between cut-in and cut-out through a
    regulator of poor inlet rejection): a sawtooth of the supply pressure; film k x (1 + 0.015 u), c x (1 + 0.006 u)."""
    phase = rng.uniform(0, COMPRESSOR["period_s"])
    u = sawtooth(drawn["_hit_times"] + phase, COMPRESSOR["period_s"], COMPRESSOR["fall_s"])
    k = K * (1 + COMPRESSOR["k_amplitude"] * u)
    c = C * (1 + COMPRESSOR["c_amplitude"] * u)
    drawn["film_k_per_hit"] = np.round(k, -2).tolist()
    drawn["film_c_per_hit"] = np.round(c, 2).tolist()
    drawn["pressure_phase_s"] = round(float(phase), 3)
    return np.stack([sd_accelerance(s, k=ki, c=ci) for ki, ci in zip(k, c)])


REACTION = {"base_mass_kg": 120.0, "isolator_hz": 30.0, "isolator_zeta": 0.08}


def reaction_impactor(s):
    """An automatic (solenoid) impactor clamped to the breadboard that carries the bearing: the mover gets F, the
    breadboard (120 kg on elastomer isolators, 30 Hz, zeta 0.08) the reaction -F and the film's force.
    H = s^2 (M s^2 + Z_i) / (m M s^4 + (m (Z + Z_i) + M Z) s^2 + Z Z_i) = s^2 / (m s^2 + Z (1 + m s^2/(M s^2 + Z_i)))."""
    big_m = REACTION["base_mass_kg"]
    wi = 2 * np.pi * REACTION["isolator_hz"]
    zi = big_m * wi**2 + 2 * REACTION["isolator_zeta"] * big_m * wi * s
    z = K + C * s
    return s**2 * (big_m * s**2 + zi) / (MASS * big_m * s**4 + (MASS * (z + zi) + big_m * z) * s**2 + z * zi)


# measurement ------------------------------------------------------------------------------------------------

TIP = {"head_kg": 0.160, "tip_calibrated_kg": 0.004, "tip_used_kg": 0.010}
TIP_RATIO = (TIP["head_kg"] + TIP["tip_calibrated_kg"]) / (TIP["head_kg"] + TIP["tip_used_kg"])


def heavy_tip(case, rng, force, resp, t, drawn):
    """A 10 g tip (steel stud + extender) in front of the gauge, calibrated with the 4 g standard tip: the gauge reads
    the force that decelerates the 160 g head only, F_read = F (m_h + m_t0)/(m_h + m_t) = 0.965 F."""
    return force * TIP_RATIO, resp


TAPS = {"records": 20, "taps_at": [4, 9, 13, 17], "tap_force_n": [30.0, 60.0], "tap_width_ms": [0.4, 0.6]}


def bench_tap_pulses(case, rng):
    peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(case.hits)), 0.5 * case.force_n,
                    1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    for i in TAPS["taps_at"]:
        peaks[i] = rng.uniform(*TAPS["tap_force_n"])
        widths[i] = rng.uniform(*TAPS["tap_width_ms"]) * 1e-3
    return peaks, widths


def bench_taps(case, rng, s, drawn):
    """Between blows the operator rests the hammer on the steel bench; four times its tip taps the bench hard enough to
    trigger: the gauge reads a real pulse, the mover gets nothing (its accelerance row is zero: the response is the
    sensor's noise alone)."""
    hh = np.repeat(case_accelerance(case, s)[None, :], case.hits, axis=0)
    hh[TAPS["taps_at"]] = 0.0
    drawn["bench_tap_records"] = [i + 1 for i in TAPS["taps_at"]]
    return hh


INT16 = {"range_factor": 1.5, "first_hit_n": 150.0}


def int16_pulses(case, rng):
    peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(case.hits)), 0.5 * case.force_n,
                    1.5 * case.force_n)
    peaks[0] = INT16["first_hit_n"]
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    return peaks, widths


def int16_wrap(case, records, starts, drawn):
    """The exporter stores each channel as int16 counts, its scale set from the first record (1.5 x its peak, a gentle
    set-up tap); counts beyond +-32767 wrap around (two's complement) instead of saturating."""
    out = []
    wrapped = [[], []]
    scales = [INT16["range_factor"] * np.abs(records[0][row]).max() / 32767 for row in (0, 1)]
    for i, rec in enumerate(records):
        new = rec.copy()
        for row in (0, 1):
            q = np.round(rec[row] / scales[row]).astype(np.int64)
            w = (q + 32768) % 65536 - 32768
            if np.any(w != q):
                wrapped[row].append(i + 1)
            new[row] = w * scales[row]
        out.append(new)
    drawn["int16_step"] = [float(scales[0]), float(scales[1])]
    drawn["wrapped_force_records"] = wrapped[0]
    drawn["wrapped_response_records"] = wrapped[1]
    return out, starts


NOTCH = {"freq_hz": 50.0, "q": 2.0}


def mains_notch(case, rng, records, drawn):
    """The logger's 'mains filter' left on for the response channel: a second-order IIR notch at 50 Hz, Q 2 (scipy's
    iirnotch, causal, run on every record from its first sample), after sampling."""
    b, a = signal.iirnotch(NOTCH["freq_hz"], NOTCH["q"], fs=case.rate_hz)
    out = records.copy()
    out[:, 1] = signal.lfilter(b, a, records[:, 1], axis=1)
    return out


LIFTOFF = {"sensor_kg": 0.030, "hold_n": 0.030 * 9.81, "mount_hz": 10000.0, "mount_zeta": 0.05,
           "integrate_s": 0.25, "substeps": 8}


def sensor_liftoff(case, rng, force, resp, t, drawn):
    """The accelerometer's magnet base on the aluminium mover holds nothing: the 30 g sensor rests on the hit face under
    gravity alone (plus its 10 kHz contact). When the mover accelerates along the hit direction faster than g it
    separates, falls freely (at g) while the mover runs ahead, and lands with an impact. RK4 (8 substeps per
    analog step) on the relative coordinate w = x_mover - x_sensor, contact force N = max(0, k_c (d0 - w) - c_c w')."""
    m_s = LIFTOFF["sensor_kg"]
    f_hold = LIFTOFF["hold_n"]
    wm = 2 * np.pi * LIFTOFF["mount_hz"]
    k_c, c_c = m_s * wm**2, 2 * LIFTOFF["mount_zeta"] * m_s * wm
    d0 = f_hold / k_c
    fine = OVERSAMPLE * case.rate_hz
    dt = 1 / fine
    sub = LIFTOFF["substeps"]
    h = dt / sub
    lead = int(round(LEAD_IN_S * fine))
    stop = lead + int(round(LIFTOFF["integrate_s"] * fine))
    a_m = resp[:, :stop]
    nh = resp.shape[0]
    w = np.zeros(nh)
    v = np.zeros(nh)

    def accel(w_, v_, am):
        contact = np.maximum(0.0, k_c * (d0 - w_) - c_c * v_) * (w_ < d0)
        return am - (f_hold - contact) / m_s

    rel = np.zeros_like(a_m)  # w'' (so that the sensor reads a_m - w'')
    gap = np.zeros(nh)
    flight = np.zeros(nh)
    for j in range(stop - 1):
        a0, a1 = a_m[:, j], a_m[:, j + 1]
        rel[:, j] = accel(w, v, a0)
        for k in range(sub):
            fa = a0 + (a1 - a0) * (k / sub)
            fb = a0 + (a1 - a0) * ((k + 0.5) / sub)
            fc = a0 + (a1 - a0) * ((k + 1) / sub)
            k1v = accel(w, v, fa)
            k1w = v
            k2v = accel(w + 0.5 * h * k1w, v + 0.5 * h * k1v, fb)
            k2w = v + 0.5 * h * k1v
            k3v = accel(w + 0.5 * h * k2w, v + 0.5 * h * k2v, fb)
            k3w = v + 0.5 * h * k2v
            k4v = accel(w + h * k3w, v + h * k3v, fc)
            k4w = v + h * k3v
            w = w + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w)
            v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        gap = np.maximum(gap, w)
        flight += (w > d0) * dt
    rel[:, stop - 1] = accel(w, v, a_m[:, stop - 1])
    out = resp.copy()
    out[:, :stop] = a_m - rel
    drawn["max_gap_um"] = np.round(gap * 1e6, 4).tolist()
    drawn["flight_ms"] = np.round(flight * 1e3, 3).tolist()
    drawn["records_with_liftoff"] = [i + 1 for i in range(nh) if gap[i] > 2 * d0]
    return force, out


def liftoff_pulses(case, rng):
    peaks = rng.uniform(100.0, 350.0, case.hits)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    return peaks, widths


def significant(x: np.ndarray, digits: int) -> np.ndarray:
    """Round to ``digits`` significant decimal digits (as '%.{digits - 1}e' prints), zeros kept."""
    out = np.zeros_like(x)
    nz = x != 0
    e = np.floor(np.log10(np.abs(x[nz])))
    scale = 10.0 ** (e - (digits - 1))
    out[nz] = np.round(x[nz] / scale) * scale
    return out


def two_digit_export(case, records, starts, drawn):
    """The export went through a CSV written with '%.1e' (one decimal in scientific notation: two significant digits),
    read back into the UFF writer: every sample of both channels rounded to 2 digits -- a relative (floating)
    rounding, up to 5 % of each value, that vanishes in the quiet tails and is largest during the pulse and the first
    swings."""
    out = [np.stack([significant(r[0], 2), significant(r[1], 2)]) for r in records]
    err = np.concatenate([(o - r).ravel() for o, r in zip(out, records)])
    drawn["rounding_error_rms"] = float(np.sqrt(np.mean(err**2)))
    return out, starts


AUTORANGE = {"threshold_m_s2": 5.0, "high_range_gain": 0.986}


def autorange(case, rng, records, drawn):
    """An autoranging conditioner on the accelerometer: a record is taken on the high range (+-200 m/s^2) when the
    previous record peaked above 5 m/s^2, else on the low range (+-20 m/s^2); the high range's gain is 1.4 % low
    (0.12 dB, just outside a typical +-0.1 dB per-range accuracy) and the exporter scaled both ranges alike."""
    out = records.copy()
    high = [False]
    for i in range(1, records.shape[0]):
        high.append(bool(np.abs(records[i - 1, 1]).max() > AUTORANGE["threshold_m_s2"]))
    gains = np.where(high, AUTORANGE["high_range_gain"], 1.0)
    out[:, 1] *= gains[:, None]
    drawn["high_range_records"] = [i + 1 for i, x in enumerate(high) if x]
    drawn["response_gain_per_record"] = gains.tolist()
    return out


def level_spread_peaks(case, rng):
    return rng.uniform(60.0, 400.0, case.hits), case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)


# controls ---------------------------------------------------------------------------------------------------

def time_averaged(case, records, starts, drawn):
    """The logger's 'triggered averaging': every exported record is the sample-by-sample mean of four consecutive
    trigger-aligned records (both channels), at the first one's time: 32 hits -> 8 records."""
    arr = np.array(records)
    groups = arr.reshape(-1, 4, *arr.shape[1:]).mean(axis=1)
    drawn["records_written"] = int(groups.shape[0])
    return list(groups), np.asarray(starts)[::4]


def mixed_lengths(case, records, starts, drawn):
    """After hit 8 the operator shortened the record length to 0.5 s: records 9-16 hold 6400 samples."""
    half = records[0].shape[1] // 2
    out = [r if i < 8 else r[:, :half].copy() for i, r in enumerate(records)]
    drawn["record_samples"] = [int(r.shape[1]) for r in out]
    return out, starts


# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    everything = list(EVERYTHING)
    control_quality = ["mains", "clip", "double"]
    listed = [
        # ---------------------------------------------------------------------------------------- controls
        Case("control-5k12-long", "control",
             "the module at 51.2 kS/s / 10 = 5 120 S/s with 4 s records (20 480 samples), a 0.25 s pre-trigger and "
             "10 hits; linear film; `--rig` nominal",
             "NI 9234 data sheet (f_s = 51.2 kS/s / n); Brandt (2011) §13.7 (record length and resolution)",
             "A legal rate four times lower than usual with records four times longer and a long pre-trigger: the "
             "band ends near 2.1 kHz, the resolution is 0.25 Hz. Nothing to claim.", seed=801, cli="rig",
             rate_hz=5120.0, record_s=4.0, pretrigger_s=0.25, hits=10, must_not=everything,
             must_not_quality=control_quality),
        Case("control-steel-tip-taps", "control",
             "light taps with a steel tip: 0.2 ms pulses at 30 N ± 20 % (impulse ≈ 0.004 N·s, 3 % of a usual "
             "blow), 48 hits at 25.6 kS/s, 0.25 s records, 5 ms pre-trigger; linear film",
             "PCB impact hammer tip charts (steel tip: bandwidth ≈ 5 kHz); ISO 7626-5 (impact excitation, "
             "averaging many light impacts)",
             "A wide hammer band, a low level and many averages on a linear film: only the noise per hit is "
             "larger. Nothing to claim.", seed=802, rate_hz=25600.0, record_s=0.25, pretrigger_s=0.005, hits=48,
             pulse_ms=0.2, force_n=30.0, must_not=everything, must_not_quality=control_quality),
        Case("control-ascii-uff", "control",
             "the exporter wrote UFF 58 as ASCII in single precision (ord_data_type 2, E13.5: six significant "
             "digits, 80-column lines) instead of binary doubles; linear film",
             "I-DEAS universal file format, data set 58 (ASCII records, E13.5 for single precision); pyuff",
             "A different but legal file encoding that keeps six digits (below the 24-bit steps of the large "
             "values, far below the noise). Nothing to claim.", seed=803, ascii_single=True, must_not=everything,
             must_not_quality=control_quality),
        Case("control-sorted-timeofday", "control",
             "records written in descending order of their peak force (not in time order), each with its start "
             "as seconds since midnight (≈ 52 380 s, 14:33) in abscissa_min; linear film",
             "I-DEAS universal file format, data set 58 (abscissa minimum, E13.5); Brandt (2011) §13.7",
             "The file's order is not the session's order and the times are times of day; the times themselves are "
             "right. Nothing changes over the session: nothing to claim (no drift, no step).", seed=804,
             write_order="force-descending", time_offset_s=52380.0, must_not=everything,
             must_not_quality=control_quality),
        Case("control-time-averaged", "control",
             "the logger's triggered time averaging: each of the 8 records is the mean of 4 consecutive trigger-"
             "aligned hits (32 hits, 200 N ± 20 %, sub-sample starts differing), both channels alike; linear film",
             "Brandt (2011) §10.3 (time-domain / synchronous averaging); Ewins (2000) §4.3",
             "The same linear operation on both channels of a linear system: the FRF of every averaged record is "
             "exact; the averaged pulses are a little smeared (by ≤ 1 sample). Nothing to claim.", seed=805,
             hits=32, export=time_averaged, must_not=everything, must_not_quality=control_quality),
        Case("control-mixed-lengths", "control",
             "the operator shortened the record length after hit 8: records 1–8 are 1 s (12 800 samples), records "
             "9–16 are 0.5 s (6 400 samples); linear film",
             "Brandt (2011) §13.7 (record length); ISO 7626-5",
             "Two record lengths in one file; each is long enough for the film's ring-down (e^-35 at 0.5 s). Nothing "
             "to claim.", seed=806, export=mixed_lengths, must_not=everything, must_not_quality=control_quality),
        # ---------------------------------------------------------------------------------------------- rig
        Case("tuned-mass-damper", "rig",
             f"a tuned mass damper bolted to the mover: {TMD['tmd_mass_kg']} kg on a spring-damper, Den Hartog's optimum "
             f"for the mass ratio 0.04: {TMD['freq_hz']} Hz, ζ {TMD['damping_ratio']}: the film's single peak "
             "becomes two lower ones (177 and 213 Hz, 41 % and 52 % of the plain peak's height)",
             "Den Hartog, Mechanical Vibrations (4th ed. 1956) §3.3 (optimum absorber tuning and damping); "
             "Ormondroyd & Den Hartog, Trans. ASME APM-50-7 (1928); Rivin, Handbook on Stiffness & Damping in "
             "Mechanical Design (2010) ch. 8 (dynamic vibration absorbers in machine tools)",
             "A mass on a spring-damper riding on the mover is exactly the catalogue's extra-mode (1.0 kg, 189 Hz, "
             "ζ 0.116): exact. Its damping ratio is high for 'a peak of its own' and it sits on the film's resonance: "
             "not explained is honest. An added mass only as a partial description (below the tuning it moves with "
             "the mover). Film laws (memory, squeeze, lag) re-describe the mover's damping and are false; amplitude, "
             "time and chain terms are wrong.", seed=811, extra_z=tuned_mass_damper, physics=dict(TMD),
             exact=[["extra-mode"]], partial_ok=["added-mass"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        Case("viscous-absorber", "rig",
             "an untuned viscous (Houdaille) damper on the mover: a 0.75 kg mass in a silicone-oil housing coupled "
             "by shear alone (c 1000 N·s/m, no spring): Z = m c s²/(m s + c): +0.71 kg and +53 N·s/m at 50 Hz, "
             "+0.40 kg and +460 N·s/m at 196 Hz, +0.03 kg and +957 N·s/m at 1 kHz",
             "Den Hartog, Mechanical Vibrations (4th ed. 1956) §3.10 (untuned viscous vibration damper); Brock, "
             "J. Appl. Mech. 13 (1946) A-284; Rivin (2010) ch. 8",
             "A mass that rides on the mover through a dashpot: an extra mode with no spring (ζ → ∞), beyond the "
             "catalogue's ζ ≤ 0.5. An extra mode is the right topology (acceptable); an added mass (the low band), "
             "film-memory or squeeze-film (damping rising with frequency) only as partial descriptions beside an "
             "honest rest. A pneumatic lag lowers the damping (false). Amplitude, time and chain terms are wrong.",
             seed=812, extra_z=viscous_absorber, physics=dict(HOUDAILLE), exact=[["viscous-absorber"]],
             acceptable=[["extra-mode"]], partial_ok=["added-mass", "film-memory", "squeeze-film"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        Case("counterweight", "rig",
             "a weight-relief counterweight: 10 kg (+0.5 kg pulley inertia) on a steel cable over an overhead "
             "pulley, hooked to the mover: a 10.5 kg mass riding on the cable's 2.03e6 N/m, 70 Hz, ζ 0.02 -- moving "
             "with the mover below 70 Hz (+10.5 kg; a peak at 67 Hz, a dip at 71 Hz), decoupled above it (the cable "
             "adds 5 % stiffness: the film's peak 197 → 203 Hz)",
             "Slocum, Precision Machine Design (1992) §7.6 (counterbalancing of vertical axes); Rivin (2010) ch. 2 "
             "(stiffness of wire ropes); Ewins (2000) §2.3",
             "Exactly the catalogue's extra-mode, 10.5 kg at 70 Hz: exact, although the catalogue calls a mode of "
             "more than a fifth of the mover absurd; not explained is honest. An added mass only partial (below 70 "
             "Hz). Film laws false; amplitude, time and chain terms wrong.", seed=813, extra_z=counterweight,
             physics=dict(COUNTERWEIGHT) | {"cable_k_n_per_m": round(COUNTERWEIGHT["counterweight_mass_kg"]
                                                                      * (2 * np.pi * 70.0) ** 2, -3)},
             exact=[["extra-mode"]], partial_ok=["added-mass"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        Case("compressor-cycling", "rig",
             "the bearings' supply follows the shop compressor's load/unload cycle through a regulator of poor inlet "
             "rejection: a sawtooth (65 s falling, 10 s recovering, period 75 s): film k × (1 ± 1.5 %), c × "
             "(1 ± 0.6 %); 24 hits over ≈ 3 min (2.5 cycles, hits 5–11 s apart)",
             "Atlas Copco, Compressed Air Manual (8th ed. 2015) §3.5 (load/unload regulation, pressure band); Powell, "
             "Design of Aerostatic Bearings (1970) ch. 3 (stiffness vs supply pressure); Al-Bender, Precision Eng. "
             "33 (2009) 117",
             "The film changes over the session along a sawtooth: several falls and quick recoveries. Drift (one "
             "trend) and step-change (one jump) each describe a part (partial, beside an honest rest); not explained "
             "is honest. Mass, mode, memory, amplitude and chain terms are wrong.", seed=814,
             per_hit_h=compressor_cycling, hits=24, gap_s=(4.0, 10.0), physics=dict(COMPRESSOR), subtle=True,
             exact=[["compressor-cycling"]], partial_ok=["drift", "step-change"],
             must_not=["added-mass", "extra-mode"] + list(MEMORY) + list(AMPLITUDE) + chain_but()),
        Case("reaction-impactor", "rig",
             "an automatic impactor clamped to the breadboard that carries the bearing (120 kg on elastomer "
             "isolators, 30 Hz, ζ 0.08): the mover gets F, the breadboard the reaction −F: a resonance/anti-resonance "
             "pair at 27/30 Hz, |H| −25 % at 50–100 Hz, the film effectively × (1 + m/M) = 1.21 well above 30 Hz "
             "(resonance 197 → 217 Hz); hits 200 N ± 2 %",
             "ISO 7626-2:2015 §5 (the exciter's reaction must not reach the structure's support); Ewins (2000) "
             "§3.3 (exciter attachment and support); Brandt (2011) §13.6",
             "The base moves, kicked by the reaction: the FRF is the mover's on a film whose impedance is multiplied "
             "by 1 + m s²/(M s² + Z_i). No catalogue term has it; an extra mode near 30 Hz (it would have to weigh "
             "≈ 220 kg) only as a partial description. Not explained is right. A recalibrated film alone (21 % "
             "stiffer) or any chain term (the low band's drop is no AC coupling) is wrong; amplitude and time terms "
             "wrong.", seed=815, accel_fn=reaction_impactor, spread=0.02, width_spread=0.01,
             physics=dict(REACTION), exact=[["reaction-impactor"]], acceptable=[], partial_ok=["extra-mode"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        # ------------------------------------------------------------------------------------- measurement
        Case("heavy-tip", "measurement",
             "the hammer calibrated with its 4 g standard tip was used with a 10 g tip (steel stud and extender) in "
             "front of the gauge: the gauge reads the force on the 160 g head only, 164/170 = 0.965 of the contact "
             "force: the FRF reads +3.7 % at every frequency",
             "McConnell & Varoto, Vibration Testing (2nd ed. 2008) ch. 6 (impact hammer: gauge force = m_h/(m_h + "
             "m_t) × contact force); PCB Piezotronics impact hammer manuals (sensitivity with tips and extenders); "
             "Dally, Riley & McConnell (1993) ch. 5 (mass cancellation)",
             "A uniform gain of the force channel: sensitivity-error (force −3.5 %, or response +3.7 %) is exact; an "
             "added mass (−0.88 kg) with sensitivity-error as its alternative is acceptable. Other rig terms, delay, "
             "AC coupling, cross-talk are wrong.", seed=821, chain=heavy_tip, subtle=True,
             physics=dict(TIP) | {"gauge_ratio": round(TIP_RATIO, 5)}, exact=[["sensitivity-error"]],
             acceptable=[["added-mass"]], needs_alternative={"added-mass": "sensitivity-error"},
             must_not=without(RIG, "added-mass") + chain_but("sensitivity-error")),
        Case("bench-tap-triggers", "measurement",
             "20 records, 4 of them (records 5, 10, 14, 18) triggered by the hammer's tip tapping the steel bench "
             "between blows (30–60 N, 0.4–0.6 ms): a real force pulse in the force record, nothing but noise in the "
             "response",
             "Brandt (2011) §13.7 (triggering and checking impacts); Avitabile, Modal Testing (2017) ch. 5 (reject "
             "bad hits); Halvorsen & Brown, Sound and Vibration 11 (1977) 8",
             "Four records whose force never reached the mover: their FRF is zero. Leaving them out (a note) and "
             "parameters-only, or not explained naming them, are right; every term (an added mass, a per-hit step, "
             "a sensitivity) is wrong.", seed=822, hits=TAPS["records"], pulses_fn=bench_tap_pulses,
             per_hit_h=bench_taps, physics=dict(TAPS), exact=[["bench-tap-triggers"]], acceptable=[[]],
             must_not=everything, expected_quality=["the four tap records named and left out"]),
        Case("int16-wrap", "measurement",
             "the exporter stores each channel as int16 counts scaled from the first (gentle, 150 N) record's peak × "
             "1.5 (±225 N, ≈ ±8 m/s²); the heavier hits' counts wrap around (two's complement) instead of "
             "saturating: their pulses and first swings jump by −2 × full scale",
             "Oppenheim & Schafer, Discrete-Time Signal Processing (3rd ed. 2010) §6.7 (overflow: wrap-around vs "
             "saturation in two's-complement arithmetic); IEEE Std 1241-2010 §4 (over-range)",
             "Corrupted records, worse for heavier hits: the lure is an amplitude term. Leaving the wrapped hits out "
             "(a clip/spike note) and parameters-only, not explained, or a refusal are right; every term is wrong.",
             seed=823, pulses_fn=int16_pulses, export=int16_wrap, physics=dict(INT16), exact=[["int16-wrap"]],
             acceptable=[[]], must_not=everything, must_not_quality=["mains"], refusal_ok=True,
             expected_quality=["clip or spikes: the wrapped hits left out"]),
        Case("mains-notch", "measurement",
             "the logger's 'mains filter' was on for the response channel: a causal second-order notch at 50 Hz, "
             "Q 2 (−3 dB 39–64 Hz): |H| → 0 at 50 Hz, −33 % at 40 Hz, −5 % and +18° at 100 Hz, and a phase lead "
             "that reaches the film: +7.8° and −0.9 % at 196 Hz, +1.4° at 1 kHz",
             "Smith, The Scientist and Engineer's Guide to DSP (1997) ch. 19 (notch filters); Widmann, Schröger & "
             "Maess, J. Neurosci. Methods 250 (2015) 34 (what notch filters do to transients); SciPy iirnotch",
             "A filter on the response channel: above the notch its phase is that of an AC coupling at 25 Hz "
             "(partial, beside an honest rest); the dip at 50 Hz is no rig physics (an extra mode, a lag or a memory "
             "are wrong), nor a delay, cross-talk or sensitivity. Not explained is right.", seed=824,
             sampled=mains_notch, physics=dict(NOTCH), exact=[["mains-notch"]], partial_ok=["ac-coupling"],
             must_not=list(RIG) + ["channel-delay", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("sensor-liftoff", "measurement",
             "the accelerometer's magnet base sits on the aluminium mover: nothing but gravity holds the 30 g "
             "sensor: whenever the mover accelerates along the hit faster than g (during the pulse of hits above "
             "≈ 290 N) it lifts off (0.03–0.2 µm, 0.6–1.8 ms), reads g instead of the mover, and lands with an "
             "impact on its 10 kHz contact (spikes of up to ≈ 30 m/s² after the anti-aliasing filter); hits "
             "100–350 N",
             "ISO 5348:2021 (mechanical mounting of accelerometers: magnets need a ferromagnetic seat and limit the "
             "acceleration); Serridge & Licht, Piezoelectric Accelerometer and Vibration Preamplifier Handbook "
             "(B&K 1987) ch. 4",
             "A nonlinear fault of the sensor's seat, worse for heavier hits: friction, quadratic damping or a "
             "cubic spring are the lures (wrong). Leaving the distorted hits out (an overload or clip note) and "
             "parameters-only, or not explained, are right; every term is wrong.", seed=825, chain=sensor_liftoff,
             pulses_fn=liftoff_pulses, physics=dict(LIFTOFF) | {"force_range_n": [100.0, 350.0]},
             exact=[["sensor-liftoff"]], acceptable=[[]], must_not=everything, must_not_quality=["mains"],
             expected_quality=["overload or spikes: the lift-off hits left out"]),
        Case("two-digit-export", "measurement",
             "the export went through a CSV written with '%.1e': every sample of both channels kept to two "
             "significant digits (up to 5 % of each value: 10 N steps on a 200 N pulse, 0.1 m/s² steps on a "
             "5 m/s² swing, nothing that matters in the quiet tails)",
             "Goldberg, ACM Computing Surveys 23 (1991) 5 (relative rounding); Widrow & Kollár, Quantization Noise "
             "(2008) ch. 12–13 (floating-point quantisation noise ∝ the signal)",
             "A rounding error that exists only where the signal is large, so the noise measured in the quiet parts "
             "underestimates it near the pulse and the resonance: no physics. Parameters-only (a quantisation note "
             "is fine) or not explained are right; every term is wrong.", seed=826, export=two_digit_export,
             physics={"significant_digits": 2}, subtle=True, exact=[["two-digit-export"]], acceptable=[[]],
             must_not=everything),
        Case("autorange-gain", "measurement",
             "an autoranging conditioner on the accelerometer takes a record on its high range (±200 m/s²) when the "
             "previous record peaked above 5 m/s², else on its low range (±20 m/s²); the high range reads 1.4 % low "
             "and the exporter scaled both alike; hits 60–400 N, so the records after a hit above ≈ 140 N (about three "
             "quarters) are 1.4 % low, set by the previous hit's level, not their own",
             "Brandt (2011) §11.4 (input ranges and autoranging); IEEE Std 1057-2017 (gain error per range); NI "
             "447x/446x specifications (gain accuracy per input range ±0.1 dB)",
             "A per-record gain of the response channel, random across the session and uncorrelated with the "
             "record's own level: a sensitivity error or an added mass (with the sensitivity alternative) describe "
             "only the mean (partial). Parameters-only or not explained are right; step, drift, amplitude and other "
             "rig or chain terms are wrong.", seed=827, sampled=autorange, pulses_fn=level_spread_peaks, subtle=True,
             physics=dict(AUTORANGE) | {"force_range_n": [60.0, 400.0]}, exact=[["autorange-gain"]],
             acceptable=[[]], partial_ok=["sensitivity-error", "added-mass"],
             must_not=without(RIG, "added-mass") + chain_but("sensitivity-error")),
    ]
    return listed


NOMINAL_TOML = f"""# what the user knows: the paper's spring-damper film on the nominal mover (docs/rig-spec.md)
name = "nominal SD rig (user's spec)"
mass_kg = {NOMINAL['mass_kg']}

[film]
model = "SD"

[film.parameters]
k = {NOMINAL['k']}
eta = {NOMINAL['eta']}

[sensors.force]
sensitivity_mv_per_n = 2.25
noise_n_per_sqrt_hz = 0.0001

[sensors.acceleration]
sensitivity_mv_per_m_s2 = 10.2
noise_m_s2_per_sqrt_hz = 3e-05
"""


def answer_key(case: Case) -> dict:
    allowed = sorted(set().union(*map(set, case.exact), *map(set, case.acceptable)))
    truth = {"mass_kg": MASS, "film_k_n_per_m": case.film[0], "film_c_ns_per_m": case.film[1],
             "sample_rate_hz": case.rate_hz, "record_s": case.record_s, "hits": case.hits,
             "pretrigger_s": case.pretrigger_s, "pulse_ms": case.pulse_ms, "force_n": case.force_n,
             "force_spread": case.spread} | case.physics
    return {
        "case": case.name, "uff": f"{case.name}.uff", "category": case.category, "summary": case.summary,
        "source": case.source, "reasoning": case.reasoning, "cli": case.cli,
        "cli_arguments": (["--rig", "nominal-rig.toml"] if case.cli == "rig" else ["--mass", f"{case.mass_told:g}"]),
        "truth": truth, "control": case.category == "control", "subtle": case.subtle,
        "exact": [sorted(x) for x in case.exact], "acceptable": [sorted(x) for x in case.acceptable],
        "allowed": allowed, "partial_ok": sorted(case.partial_ok), "must_not_claim": sorted(set(case.must_not)),
        "must_not_quality": sorted(case.must_not_quality), "needs_alternative": case.needs_alternative,
        "empty_needs_recalibrated": {}, "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "refusal_ok": case.refusal_ok, "expected_quality": case.expected_quality,
    }


def write_uff(path: Path, records: list, starts: np.ndarray, case: Case, drawn: dict) -> None:
    sets = []
    dt = 1.0 / case.rate_hz
    order = list(range(len(records)))
    if case.write_order == "force-descending":
        order.sort(key=lambda i: -float(np.max(records[i][0])))
    drawn["file_order"] = [i + 1 for i in order]
    for hit in order:
        record, start = records[hit], float(starts[hit]) + case.time_offset_s
        for values, dtype, unit in ((record[0], 13, "N"), (record[1], 12, "m/s^2")):
            values = np.asarray(values, dtype=float)
            sets.append(pyuff.prepare_58(
                binary=0 if case.ascii_single else 1, id1=f"{case.name} hit {hit + 1}", id2="redteam8 generator",
                id3="", id4="", id5="", func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3,
                ord_data_type=2 if case.ascii_single else 4,
                abscissa_spacing=1, abscissa_min=start, abscissa_inc=dt, abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s", ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="NONE", data=values, x=start + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add", force_double=not case.ascii_single)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam8"))
    parser.add_argument("--only", nargs="+", metavar="CASE")
    parser.add_argument("--keys-only", action="store_true")
    parser.add_argument("--seed-offset", type=int, default=0)
    args = parser.parse_args(argv)
    listed = cases()
    if args.only:
        unknown = set(args.only) - {c.name for c in listed}
        if unknown:
            print(f"--only: unknown case(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        listed = [c for c in listed if c.name in args.only]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "nominal-rig.toml").write_text(NOMINAL_TOML)
    began_all = time.perf_counter()
    for case in listed:
        case.seed += args.seed_offset
        began = time.perf_counter()
        (args.out / f"{case.name}.key.json").write_text(json.dumps(answer_key(case), indent=1, ensure_ascii=False))
        if args.keys_only:
            continue
        records, starts, drawn = synthesise(case)
        time.sleep(0.01)
        write_uff(args.out / f"{case.name}.uff", records, starts, case, drawn)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(public(drawn), indent=1))
        peak_a = max(np.abs(r[1]).max() for r in records)
        peak_f = max(np.abs(r[0]).max() for r in records)
        print(f"{case.name:28s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak |a| {peak_a:.3g}, "
              f"peak |F| {peak_f:.0f}, acausal {drawn['acausal_fraction']:.1e}")
    if not args.keys_only:
        print(f"total {time.perf_counter() - began_all:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
