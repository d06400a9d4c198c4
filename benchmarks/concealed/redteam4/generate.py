"""Red-team world, round 4 (issue 14): twelve further rig-physics and measurement faults plus four controls.

Written by a helper that has read neither ``analysis/`` nor ``app/`` (only README.md, docs/, the CLI's ``--help``,
the paper and the earlier rounds' READMEs/keys). Imports nothing from gasfilm: numpy, scipy and pyuff only; the
synthesis below is this round's own code.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a
   half-sine of random peak and width starting at a random sub-sample instant, or the case's own force);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance
   s^2/(Z(s) + m s^2) (per hit where the structure differs per hit), or fixed-step RK4 for piecewise-linear films;
3. the sensor (its transfer or non-linearity), white sensor noise on both channels, the IEPE output stage where the
   case says, the NI 9234's 0.5 Hz first-order AC coupling on both channels, disturbances injected after it;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal) and
   decimation by 8 (the ``aliasing`` case only: point sampling without the filter), 24-bit quantisation on +-5 V
   with the sensitivities the software used;
5. UFF 58 (per hit: a force record, data type 13 "N", and an acceleration record, 12 "m/s^2"; each record's
   absolute start in ``abscissa_min``).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam4/generate.py [--out out/redteam4] [--only CASE ...] [--keys-only]
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
LSB_V = 10.0 / 2**24
HAMMER_V_PER_N = 2.25e-3
ACCEL_V_PER_M_S2 = 10.2e-3
MASS, K, C = 25.05, 3.8e7, 3.5e3  # true mover and film unless a case says otherwise
NOMINAL = {"mass_kg": 25.05, "k": 3.78e7, "eta": 3450.0}  # what the user knows (paper SD film)

RIG = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
       "step-change", "friction", "quadratic-damping")
CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error")
EVERYTHING = RIG + CHAIN + ("window-damping",)


def without(names, *kept):
    return [n for n in names if n not in kept]


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
    force_n: float = 200.0
    spread: float = 0.2
    film_k: float = K
    film_c: float = C
    extra_z: Callable | None = None  # s -> dynamic stiffness added to the film (N/m)
    per_hit_h: Callable | None = None  # (case, rng, s) -> (hits, nf) extra accelerance per hit, and drawn dict
    piecewise: dict | None = None  # piecewise-linear film force for RK4
    force_extra: Callable | None = None  # (case, rng, t, t0, widths, peaks, drawn) -> extra measured force (hits, n)
    sensor: Callable | None = None  # (case, rng, accel, freq, nfft, t, t0, peaks, drawn) -> sensor output (m/s^2)
    iepe_limits: tuple | None = None  # (low, high) m/s^2 of the IEPE stage, before the AC coupling (soft knee)
    disturbance: Callable | None = None  # (case, rng, t, drawn) -> (force, accel) added after the coupling
    anti_alias: bool = True
    accel_v_per_unit: float = ACCEL_V_PER_M_S2  # the sensitivity the software used (quantisation step)
    physics: dict = field(default_factory=dict)
    exact: list = field(default_factory=lambda: [[]])
    acceptable: list = field(default_factory=list)
    partial_ok: list = field(default_factory=list)
    must_not: list = field(default_factory=list)
    must_not_quality: list = field(default_factory=list)
    expected_quality: list = field(default_factory=list)
    honest_ok: bool = True
    refusal_ok: bool = False  # a clean one-line refusal (no traceback) counts as honest


# ------------------------------------------------------------------------------------------------------ helpers

def nextpow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(n)))


def half_sine(t: np.ndarray, start: np.ndarray, width: np.ndarray, peak: np.ndarray) -> np.ndarray:
    u = (t[None, :] - start[:, None]) / width[:, None]
    return np.where((u >= 0) & (u <= 1), peak[:, None] * np.sin(np.pi * np.clip(u, 0, 1)), 0.0)


def film_accelerance(case: Case, s: np.ndarray) -> np.ndarray:
    z = case.film_k + case.film_c * s
    if case.extra_z is not None:
        z = z + case.extra_z(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = s**2 / (z + MASS * s**2)
    return np.nan_to_num(h)


def rk4_piecewise(case: Case, f_full: np.ndarray, f_half: np.ndarray, dt: float) -> np.ndarray:
    """m a = F - R(x) - c v with a piecewise-linear R; acceleration (hits, n)."""
    pw = case.piecewise
    k, c = case.film_k, case.film_c

    if pw["kind"] == "choke":  # the gap opens (x < -x_c): the orifice chokes, stiffness k2 beyond
        xc, k2 = pw["x_c_m"], pw["k_beyond_n_per_m"]

        def restoring(x):
            return np.where(x < -xc, -k * xc + k2 * (x + xc), k * x)
    else:  # freeplay: an extra spring k_c beyond a dead zone +-x_b
        xb, kc = pw["x_b_m"], pw["k_c_n_per_m"]

        def restoring(x):
            return k * x + kc * (np.maximum(x - xb, 0) + np.minimum(x + xb, 0))

    def acc(f, x, v):
        return (f - restoring(x) - c * v) / MASS

    hits, n = f_full.shape
    x, v = np.zeros(hits), np.zeros(hits)
    out = np.zeros((hits, n))
    ff, fh = f_full.T.copy(), f_half.T.copy()
    for i in range(n):
        a1 = acc(ff[i], x, v)
        out[:, i] = a1
        a2 = acc(fh[i], x + dt / 2 * v, v + dt / 2 * a1)
        a3 = acc(fh[i], x + dt / 2 * (v + dt / 2 * a1), v + dt / 2 * a2)
        f_next = ff[i + 1] if i + 1 < n else ff[i]
        a4 = acc(f_next, x + dt * (v + dt / 2 * a2), v + dt * a3)
        x = x + dt * v + dt**2 / 6 * (a1 + a2 + a3)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return out


def soft_limit(y: np.ndarray, low: float, high: float, knee: float) -> np.ndarray:
    """Linear inside [low + knee, high - knee], tanh knees saturating at low/high."""
    out = y.copy()
    hi, lo = y > high - knee, y < low + knee
    out[hi] = high - knee + knee * np.tanh((y[hi] - (high - knee)) / knee)
    out[lo] = low + knee - knee * np.tanh(((low + knee) - y[lo]) / knee)
    return out


def anti_aliasing(rate_hz: float):
    fine = OVERSAMPLE * rate_hz
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
    gap = case.record_s + 1.0
    hit_times = 1.5 + np.cumsum(gap + rng.uniform(0, 2.0, case.hits))
    starts = hit_times - case.pretrigger_s
    peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(case.hits)),
                    0.5 * case.force_n, 1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, case.hits)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist()}
    force = half_sine(t, t0, widths, peaks)
    if case.force_extra is not None:
        force = force + case.force_extra(case, rng, t, t0, widths, peaks, drawn)
    nfft = nextpow2(2 * n)
    freq = np.fft.rfftfreq(nfft, 1 / fine)
    s = 2j * np.pi * freq
    if case.piecewise:
        f_half = half_sine(t + 0.5 / fine, t0, widths, peaks)
        accel = rk4_piecewise(case, force, f_half, 1 / fine)
    else:
        h = film_accelerance(case, s)[None, :]
        if case.per_hit_h is not None:
            h = h + case.per_hit_h(case, rng, s, drawn)
        accel = np.fft.irfft(np.fft.rfft(force, nfft, axis=1) * h, nfft, axis=1)[:, :n]
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(accel[:, before]).max() / np.abs(accel).max())
    if case.sensor is not None:
        accel = case.sensor(case, rng, accel, freq, nfft, t, t0, peaks, drawn)
    level = 1.0 if noise else 0.0
    force = force + level * FORCE_NOISE * np.sqrt(fine / 2) * rng.standard_normal(force.shape)
    accel = accel + level * ACCEL_NOISE * np.sqrt(fine / 2) * rng.standard_normal(accel.shape)
    if case.iepe_limits is not None:
        low, high = case.iepe_limits
        drawn["iepe_limited_hits"] = np.flatnonzero((accel.min(axis=1) < low + 0.5) |
                                                    (accel.max(axis=1) > high - 0.5)).tolist()
        drawn["accel_min_m_s2"] = np.round(accel.min(axis=1), 2).tolist()
        accel = soft_limit(accel, low, high, 0.5)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    force = signal.sosfilt(hp, force, axis=1)
    accel = signal.sosfilt(hp, accel, axis=1)
    if case.disturbance is not None:
        df, da = case.disturbance(case, rng, t, drawn)
        force, accel = force + level * df, accel + level * da
    records = np.empty((case.hits, 2, samples))
    sos = anti_aliasing(fs) if case.anti_alias else None
    for row, channel in enumerate((force, accel)):
        filtered = signal.sosfilt(sos, channel, axis=1) if sos is not None else channel
        records[:, row, :] = filtered[:, lead::OVERSAMPLE][:, :samples]
    for row, v_per_unit in ((0, HAMMER_V_PER_N), (1, case.accel_v_per_unit)):
        step = LSB_V / v_per_unit
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    return records, starts, drawn


# ------------------------------------------------------------------------------------------------ case hooks

def vacuum_preload(s):  # vacuum pocket: a negative stiffness that lags behind the vacuum line
    return -0.8e7 / (1 + s * 6e-3)


def location_scatter(case, rng, s, drawn):
    """Pitch mode of the mover (310 Hz, zeta 0.04, J 0.19 kg m^2) seen by an accelerometer 80 mm off the centre
    line; hit offset e per hit ~ N(4 mm, 10 mm): modal constant e d / J."""
    j, d, f_p, z_p = 0.19, 0.08, 310.0, 0.04
    offsets = rng.normal(4e-3, 10e-3, case.hits)
    drawn["hit_offset_mm"] = np.round(offsets * 1e3, 2).tolist()
    w = 2 * np.pi * f_p
    mode = s**2 / (s**2 + 2 * z_p * w * s + w**2)
    return (offsets * d / j)[:, None] * mode[None, :]


def plate_mode_12k(case, rng, s, drawn):
    """The mover's top plate, first bending mode at 12.0 kHz (zeta 0.005, modal constant 0.05 1/kg)."""
    w = 2 * np.pi * 12000.0
    return (0.05 * s**2 / (s**2 + 2 * 0.005 * w * s + w**2))[None, :]


def follow_through(case, rng, t, t0, widths, peaks, drawn):
    """The operator lets the hammer rest on the mover after the blow: a 6-14 N, 20-35 ms half-sine push starting
    0.3-1 ms after the pulse ends (the gauge measures it)."""
    push = rng.uniform(6, 14, case.hits)
    dur = rng.uniform(20e-3, 35e-3, case.hits)
    begin = t0 + widths + rng.uniform(0.3e-3, 1e-3, case.hits)
    drawn["push_n"] = np.round(push, 2).tolist()
    drawn["push_ms"] = np.round(dur * 1e3, 1).tolist()
    return half_sine(t, begin, dur, push)


def rebound(case, rng, t, t0, widths, peaks, drawn):
    """In 9 of 16 hits the tip rebounds onto the mover 0.15-0.5 ms after the first contact ends, 40-70 % of the
    first peak, 0.8x its width (merged with the first pulse, not separable by a gap)."""
    which = np.sort(rng.permutation(case.hits)[:9])
    extra = np.zeros((case.hits, t.size))
    info = []
    for hit in which:
        start = t0[hit] + widths[hit] + rng.uniform(0.15e-3, 0.5e-3)
        ratio = rng.uniform(0.4, 0.7)
        extra[hit] = half_sine(t, np.array([start]), np.array([0.8 * widths[hit]]), np.array([ratio * peaks[hit]]))[0]
        info.append({"hit": int(hit) + 1, "second_ms_after_first_start": round(1e3 * (start - t0[hit]), 3),
                     "ratio": round(float(ratio), 3)})
    drawn["rebounds"] = info
    return extra


def quadratic_sensor(case, rng, accel, freq, nfft, t, t0, peaks, drawn):
    """Capacitive MEMS accelerometer (+-2 g) with 1 % FS quadratic non-linearity: a(1 + g a), g = 5.1e-4 s^2/m."""
    return accel * (1 + 5.1e-4 * accel)


def zero_shift(case, rng, accel, freq, nfft, t, t0, peaks, drawn):
    """Each shock leaves a step offset in the piezo element (domain switching): 0.01 m/s^2 x (F/200 N)^2, rising
    over the first swing (0.3 ms), then held (the sensor's own time constant 2 s; the 0.5 Hz coupling follows)."""
    shift = 0.01 * (peaks / 200.0) ** 2 * rng.uniform(0.7, 1.3, case.hits)
    drawn["zero_shift_m_s2"] = np.round(shift, 5).tolist()
    u = np.clip((t[None, :] - t0[:, None] - 0.5e-3) / 0.3e-3, 0, 1)
    decay = np.exp(-np.maximum(t[None, :] - t0[:, None], 0) / 2.0)
    return accel + shift[:, None] * u * decay


def dielectric_slope(case, rng, accel, freq, nfft, t, t0, peaks, drawn):
    """PZT sensitivity falling 2.8 %/decade (dielectric relaxation, constant-Q): T(s) = (s/(2 pi 100 Hz))^-0.012,
    phase -1.08 deg at every frequency (causal fractional integrator; the DC bin takes the first line's value)."""
    s = 2j * np.pi * freq
    tr = np.empty_like(s)
    tr[1:] = (s[1:] / (2 * np.pi * 100.0)) ** -0.012
    tr[0] = tr[1].real
    n = accel.shape[1]
    return np.fft.irfft(np.fft.rfft(accel, nfft, axis=1) * tr, nfft, axis=1)[:, :n]


def velocity_labelled(case, rng, accel, freq, nfft, t, t0, peaks, drawn):
    """A laser vibrometer (velocity decoder, 5 mm/s per V) on the accelerometer's channel, the software still
    scaling it by 10.2 mV/(m/s^2): the file's 'acceleration' is v x 200 V/(m/s) / 0.0102 V/(m/s^2)."""
    s = 2j * np.pi * freq
    integ = np.zeros_like(s)
    integ[1:] = 1 / s[1:]
    n = accel.shape[1]
    velocity = np.fft.irfft(np.fft.rfft(accel, nfft, axis=1) * integ, nfft, axis=1)[:, :n]
    velocity -= velocity[:, :1]  # at rest before the hit
    return velocity * 200.0 / ACCEL_V_PER_M_S2


def microvibration(case, rng, t, drawn):
    """Turbulence in the bearing's recesses drives the mover: white force 2e-3 N/sqrt(Hz) to 2 kHz, through the
    mover's accelerance (nm-level micro-vibration, peaked at the film's resonance), uncorrelated with the hammer."""
    fine = OVERSAMPLE * case.rate_hz
    n = t.size
    nfft = nextpow2(n + int(0.5 * fine))
    freq = np.fft.rfftfreq(nfft, 1 / fine)
    white = 2e-3 * np.sqrt(fine / 2) * rng.standard_normal((case.hits, nfft))
    spec = np.fft.rfft(white, axis=1) * np.where(freq < 2000, 1.0, 0.0) * film_accelerance(case, 2j * np.pi * freq)
    accel = np.fft.irfft(spec, nfft, axis=1)[:, nfft - n:]
    drawn["microvibration_rms_m_s2"] = float(np.std(accel))
    return np.zeros_like(accel), accel


def emi_spikes(case, rng, t, drawn):
    """A solenoid valve on the supply switches at random: each switching couples an inductive kick (3-8 m/s^2
    equivalent, either sign, decaying in 50 us) into the accelerometer cable after the AC coupling; 1-2 events in
    7 of 16 records, not locked to the hits."""
    accel = np.zeros((case.hits, t.size))
    which = np.sort(rng.permutation(case.hits)[:7])
    info = []
    for hit in which:
        for _ in range(rng.integers(1, 3)):
            at = rng.uniform(0.0, case.record_s - 0.01)
            amp = rng.uniform(3.0, 8.0) * rng.choice([-1, 1])
            u = t - at
            accel[hit] += np.where(u >= 0, amp * np.exp(-np.maximum(u, 0) / 50e-6), 0.0)
            info.append({"hit": int(hit) + 1, "at_s": round(float(at), 4), "amplitude_m_s2": round(float(amp), 3)})
    drawn["spikes"] = info
    return np.zeros_like(accel), accel


# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    allnl = ["cubic-stiffness", "friction", "quadratic-damping"]
    listed = [
        Case("control-clean", "control", "spring-damper film only (k 3.8e7 N/m, c 3.5e3 N·s/m, 25.05 kg), 16 hits",
             "—", "Nothing beyond the film; the nominal spec differs in k by 0.5 % and c by 1.4 %.", seed=401,
             cli="rig", must_not=list(EVERYTHING), must_not_quality=["mains", "clip", "double"]),
        Case("control-51k2", "control", "the module's top rate 51.2 kS/s, 0.25 s records, 5 ms pre-trigger, 16 hits; "
             "linear film only", "NI 9234 datasheet (51.2 kS/s / n)",
             "A plain linear session at another rate and record length.", seed=402, cli="rig", rate_hz=51200.0,
             record_s=0.25, pretrigger_s=0.005, must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        Case("control-microvibration", "control",
             "turbulence in the recesses drives the mover: white force 2e-3 N/√Hz to 2 kHz through the accelerance "
             "(≈ 2 nm RMS at the film's resonance), uncorrelated with the hammer; linear film",
             "Zhu, Chen et al., Tribol. Int. 48 (2012) (micro-vibration of aerostatic bearings from vortex shedding "
             "in the recess); Chen & Lin, Tribol. Int. 2010",
             "An uncorrelated response noise peaked at the film's own resonance. It lowers coherence near 196 Hz; it is "
             "noise, not physics.", seed=403, disturbance=microvibration,
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        Case("control-follow-through", "control",
             "after each blow the operator lets the hammer rest on the mover: a 6–14 N, 20–35 ms push follows the "
             "1 ms pulse; the gauge measures it; linear film",
             "Brandt, Noise and Vibration Analysis (2011) §13.7; Avitabile, Modal Testing (2017) ch. 5 (hammer "
             "technique)",
             "The measured force is the force on the mover; the FRF over the whole record is unbiased. A force window "
             "that cuts the push biases the low frequencies: that is processing, never physics.",
             seed=404, force_extra=follow_through, must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        # ---------------------------------------------------------------------------------------------- rig
        Case("orifice-choking", "rig",
             "orifice flow chokes when the gap opens: film stiffness 3.8e7 N/m, falling to 2.3e7 N/m (0.6 k) for "
             "gap openings beyond 1.5 µm (bilinear, asymmetric); hits reach ≈ 4 µm",
             "Powell, Design of Aerostatic Bearings (1970) ch. 2 (choked orifice, p_pocket/p_supply < 0.528); "
             "Stout & Barrans, Tribol. Int. 33 (2000) 803; Worden & Tomlinson (2001) (bilinear stiffness)",
             "An amplitude-dependent, asymmetric stiffness (softer on the opening side): the resonance falls with the "
             "hit force and even harmonics appear. No catalogue term has that shape; cubic stiffness describes a part "
             "only beside an unexplained rest. No damping term, nothing linear.",
             seed=411, piecewise={"kind": "choke", "x_c_m": 1.5e-6, "k_beyond_n_per_m": 0.6 * K},
             physics={"x_c_m": 1.5e-6, "k_beyond_n_per_m": 0.6 * K},
             exact=[["orifice-choking"]], partial_ok=["cubic-stiffness"],
             must_not=without(RIG, "cubic-stiffness") + list(CHAIN), must_not_quality=["mains", "clip"]),
        Case("cable-chain-freeplay", "rig",
             "the cable chain is tied to the mover with clearance: an extra 6e6 N/m spring engages beyond ±2 µm "
             "(freeplay, symmetric hardening) beside the 3.8e7 N/m film; hits reach ≈ 4 µm",
             "Worden & Tomlinson, Nonlinearity in Structural Dynamics (2001) ch. 2 (bilinear/freeplay); Kerschen et "
             "al., MSSP 20 (2006) 505",
             "Amplitude-dependent hardening with a dead zone: the resonance rises with the hit force, odd harmonics. "
             "Cubic stiffness is a partial description only; damping, drift, linear terms are wrong.",
             seed=412, piecewise={"kind": "freeplay", "x_b_m": 2e-6, "k_c_n_per_m": 6e6},
             physics={"x_b_m": 2e-6, "k_c_n_per_m": 6e6},
             exact=[["freeplay"]], partial_ok=["cubic-stiffness"],
             must_not=without(RIG, "cubic-stiffness") + list(CHAIN), must_not_quality=["mains", "clip"]),
        Case("vacuum-preload", "rig",
             "vacuum-preloaded bearing: film 4.6e7 N/m, 3.5e3 N·s/m beside the vacuum pocket's lagging negative "
             "stiffness −0.8e7/(1 + s·6 ms): static 3.8e7 N/m, ≈ 4.6e7 at the 215 Hz resonance, +860 N·s/m there",
             "Slocum, Precision Machine Design (1992) §8.6 (vacuum preloaded air bearings); Belforte et al., "
             "Tribol. Int. 40 (2007) 1 (pneumatic dynamics of supply volumes)",
             "−k_v/(1 + sτ) = −k_v + k_v·sτ/(1 + sτ): a recalibrated stiffness plus a Maxwell branch, i.e. exactly a "
             "film memory of order 1 (or a Zener film). Added mass, extra mode, amplitude or time terms are wrong.",
             seed=413, film_k=4.6e7, extra_z=vacuum_preload,
             physics={"k_vacuum_n_per_m": -0.8e7, "tau_vacuum_s": 6e-3},
             exact=[["vacuum-preload"]], acceptable=[["film-memory"]], partial_ok=["pneumatic-lag", "squeeze-film"],
             must_not=without(RIG, "film-memory", "pneumatic-lag", "squeeze-film") + list(CHAIN),
             must_not_quality=["mains", "clip"]),
        # ------------------------------------------------------------------------------------- measurement
        Case("hit-location-scatter", "measurement",
             "the operator's hit point wanders: offset N(4 mm, 10 mm) from the centre line per hit excites the "
             "mover's pitch mode (310 Hz, ζ 0.04, J 0.19 kg·m²), seen by the accelerometer 80 mm off the line: "
             "a per-hit modal constant e·d/J of mean 1.7e-3 1/kg, SD 4.2e-3 1/kg (both signs)",
             "Ewins, Modal Testing (2000) §3.7; Avitabile (2017) ch. 5 (roving/fixed hammer consistency); "
             "Brandt (2011) §13.7",
             "A real pitch mode whose residue changes sign and size from hit to hit: the average shows a small mode at "
             "310 Hz and the hits scatter there. An extra mode at 310 Hz is acceptable (it exists); drift, step, "
             "amplitude terms, an added mass or chain terms are wrong.",
             seed=421, per_hit_h=location_scatter, physics={"pitch_hz": 310, "offset_mean_mm": 4, "offset_sd_mm": 10},
             exact=[["hit-location-scatter"]], acceptable=[["extra-mode"]],
             must_not=without(RIG, "extra-mode") + list(CHAIN), must_not_quality=["mains", "clip"]),
        Case("rebound-close", "measurement",
             "the tip rebounds onto the mover in 9 of 16 hits 0.15–0.5 ms after the first contact ends (40–70 % of "
             "the peak): merged double pulses that no gap separates; the gauge measures both; linear film",
             "Brandt (2011) §13.7 (double hits); Halvorsen & Brown, Sound and Vibration 11 (1977) 8; PCB hammer "
             "manuals",
             "The measured force is what drove the mover: H is unbiased; the force spectrum has shallow dips near "
             "1/(2Δ). Rejecting or keeping the hits are both fine; any physics is false.",
             seed=422, force_extra=rebound, physics={"rebound_hits": 9},
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        Case("sensor-nonlinearity", "measurement",
             "capacitive MEMS accelerometer (±2 g) with 1 % FS quadratic non-linearity: reads a(1 + 5.1e-4 s²/m·a) "
             "(0.4 % at the 7–9 m/s² peaks); linear film",
             "ISO 16063-11 / IEEE 1293 (amplitude linearity); Endevco/PCB MEMS data sheets (non-linearity ≤ 1 % FS)",
             "An instantaneous sensor non-linearity on the acceleration, not a film force law: even harmonics that "
             "scale with the hit. Any film amplitude term (cubic, friction, quadratic damping) sends the user to the "
             "bearing: must not. Honest not-explained is right.",
             seed=423, sensor=quadratic_sensor, physics={"quadratic_s2_per_m": 5.1e-4},
             exact=[["sensor-nonlinearity"]], must_not=list(EVERYTHING), must_not_quality=["mains"]),
        Case("zero-shift", "measurement",
             "piezo zero shift after each shock: a step offset of ≈ 0.01 m/s² × (F/200 N)² (±30 %) after the first "
             "swing, held by the sensor (τ 2 s) and decaying through the 0.5 Hz coupling",
             "Chu, Endevco TP 290 (1987) 'Zero shift of piezoelectric accelerometers'; Plumlee, Sandia SAND77-1911 "
             "(1979); Walter, Sound and Vibration 41 (2007)",
             "A non-linear offset in the acceleration channel whose spectrum ~Δ/ω dominates the low band (3× the true "
             "response at 20 Hz). An AC-coupling corner, a mass/stiffness change or any film term is wrong; a note on "
             "the low band or an honest not-explained is right.",
             seed=424, sensor=zero_shift, physics={"shift_m_s2_at_200n": 0.01},
             exact=[["zero-shift"]], must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        Case("dielectric-slope", "measurement",
             "PZT accelerometer whose sensitivity falls 2.8 %/decade (dielectric relaxation): reads a·(f/100 Hz)^−0.012 "
             "with a constant −1.08° phase (causal); linear film",
             "Holland, IEEE Trans. Sonics Ultrason. 14 (1967) 18 (complex piezoelectric coefficients); Serridge & "
             "Licht, Piezoelectric Accelerometer Handbook (B&K 1987) §4; ISO 16063-21",
             "A fractional-order tilt of the measurement chain (1.9 % high at 20 Hz, 2.7 % low at 1 kHz). A film "
             "memory, squeeze film, pneumatic lag or added mass would put a measurement property into the bearing. "
             "Parameters-only (absorbed by k and c within the noise) or honest not-explained are right.",
             seed=425, sensor=dielectric_slope, physics={"exponent": -0.012, "reference_hz": 100},
             exact=[["dielectric-slope"]], acceptable=[[]],
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
        Case("iepe-overload", "measurement",
             "3 V/g seismic accelerometer (0.306 V/(m/s²)) with a low IEPE bias: its output stage saturates softly "
             "below −6.5 m/s² (2 V under the bias) before the AC coupling; hits 240 N ± 20 %: most hits' first "
             "negative swings are cut, the coupling turns the lost area into a decaying offset",
             "PCB 'Introduction to piezoelectric accelerometers' (output bias and dynamic range); NI 9234 manual "
             "(IEPE compliance, AC coupling); Walter, Sound and Vibration 41 (2007) (overload, baseline shift)",
             "Asymmetric saturation of the sensor's amplifier, then the coupling: a non-linearity of the chain. Any "
             "film amplitude term, drift or step is wrong; a clipping note or honest not-explained is right.",
             seed=426, force_n=240.0, iepe_limits=(-6.5, 40.0), accel_v_per_unit=0.306,
             physics={"low_limit_m_s2": -6.5, "sensitivity_v_per_m_s2": 0.306},
             exact=[[]], must_not=list(EVERYTHING), must_not_quality=["mains"], expected_quality=["clip"]),
        Case("velocity-as-acceleration", "measurement",
             "a laser vibrometer (velocity decoder 5 mm/s per V) on the accelerometer's channel; the software still "
             "scales it by 10.2 mV/(m/s²) and labels it m/s²: the file's 'acceleration' is 19 608 × velocity",
             "Polytec LDV manuals (velocity decoders); ISO 7626-1 (mobility vs accelerance); Ewins (2000) §2",
             "The FRF is a mobility times a constant: no mass line (falls as 1/f above the resonance). No film or "
             "chain term makes that an accelerance of a mass on a film; every claim is false. A clean refusal ('not a "
             "mass on a film'), or not explained, is right.",
             seed=427, sensor=velocity_labelled, physics={"velocity_scale": 200.0 / ACCEL_V_PER_M_S2},
             exact=[["velocity-labelled-acceleration"]], must_not=list(EVERYTHING), refusal_ok=True),
        Case("aliasing", "measurement",
             "a recorder without an anti-aliasing filter (point sampling at 12.8 kS/s) and a hard tip (0.3 ms): the "
             "mover plate's 12.0 kHz bending mode (ζ 0.005, 0.05 1/kg) folds to 800 Hz; both channels fold alike",
             "Brandt (2011) §3.2 (aliasing); NI 9234 datasheet (delta-sigma with alias rejection); Ewins (2000) §3.8",
             "The in-band FRF gains a spurious peak at 800 Hz (there is no mode there; the force spectrum is not "
             "attenuated above 0.45 fs — a tell). An extra mode at 800 Hz is false physics.",
             seed=428, anti_alias=False, per_hit_h=plate_mode_12k, pulse_ms=0.3, force_n=150.0,
             physics={"plate_mode_hz": 12000, "alias_hz": 800, "zeta": 0.005, "modal_constant_per_kg": 0.05},
             exact=[["aliasing"]], must_not=list(EVERYTHING), must_not_quality=["mains"]),
        Case("emi-spikes", "measurement",
             "a solenoid valve on the supply line switches at random: inductive kicks (3–8 m/s² equivalent, 50 µs) in "
             "the accelerometer cable, 1–2 per record in 7 of 16 records, not locked to the hits; linear film",
             "Ott, Electromagnetic Compatibility Engineering (2009) ch. 4 (inductive switching transients); Brandt "
             "(2011) §11 (transients in acquisition)",
             "Impulsive interference uncorrelated with the hammer; the band-limited blips raise the noise of a few "
             "hits. Nothing physical; a quality note on the hits or honest not-explained.",
             seed=429, disturbance=emi_spikes, must_not=list(EVERYTHING), must_not_quality=["mains", "clip"]),
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
    truth = {"mass_kg": MASS, "film_k_n_per_m": case.film_k, "film_c_ns_per_m": case.film_c,
             "sample_rate_hz": case.rate_hz, "record_s": case.record_s, "hits": case.hits,
             "pretrigger_s": case.pretrigger_s, "pulse_ms": case.pulse_ms, "force_n": case.force_n,
             "force_spread": case.spread} | case.physics
    return {
        "case": case.name, "uff": f"{case.name}.uff", "category": case.category, "summary": case.summary,
        "source": case.source, "reasoning": case.reasoning, "cli": case.cli,
        "cli_arguments": (["--rig", "nominal-rig.toml"] if case.cli == "rig" else ["--mass", f"{NOMINAL['mass_kg']:g}"]),
        "truth": truth, "control": case.category == "control",
        "exact": [sorted(x) for x in case.exact], "acceptable": [sorted(x) for x in case.acceptable],
        "allowed": allowed, "partial_ok": sorted(case.partial_ok), "must_not_claim": sorted(case.must_not),
        "must_not_quality": sorted(case.must_not_quality), "needs_alternative": {},
        "empty_needs_recalibrated": {}, "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "refusal_ok": case.refusal_ok, "expected_quality": case.expected_quality,
    }


def write_uff(path: Path, records: np.ndarray, starts: np.ndarray, rate_hz: float, name: str) -> None:
    sets = []
    dt = 1.0 / rate_hz
    for hit, (record, start) in enumerate(zip(records, starts)):
        for values, dtype, unit in ((record[0], 13, "N"), (record[1], 12, "m/s^2")):
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"{name} hit {hit + 1}", id2="redteam4 generator", id3="", id4="", id5="",
                func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, ord_data_type=4, abscissa_spacing=1,
                abscissa_min=float(start), abscissa_inc=dt, abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s", ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="NONE", data=np.asarray(values, dtype=float),
                x=float(start) + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam4"))
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
    for case in listed:
        case.seed += args.seed_offset
        began = time.perf_counter()
        (args.out / f"{case.name}.key.json").write_text(json.dumps(answer_key(case), indent=1, ensure_ascii=False))
        if args.keys_only:
            continue
        records, starts, drawn = synthesise(case)
        time.sleep(0.01)
        write_uff(args.out / f"{case.name}.uff", records, starts, case.rate_hz, case.name)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1))
        print(f"{case.name:26s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak |a| "
              f"{np.abs(records[:, 1]).max():.3g}, peak F {records[:, 0].max():.0f} N, acausal "
              f"{drawn['acausal_fraction']:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
