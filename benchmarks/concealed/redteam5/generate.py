"""Red-team world, round 5 (issue 14): twelve further rig-physics and measurement faults plus four controls.

Written by a helper that has read neither ``analysis/``, ``app/`` nor ``tests/`` (only README.md, docs/, the CLI's
``--help``, the paper and the earlier rounds' READMEs, keys, generators and scorers). Imports nothing from gasfilm:
numpy, scipy and pyuff only; the synthesis below is this round's own code.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a half-sine
   of random peak and width starting at a random sub-sample instant);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance (per
   hit where it differs per hit), or fixed-step RK4 (Nystrom form) on the analog grid where the rig is nonlinear or
   time-varying;
3. the sensor (its gain, added signals), white sensor noise on both channels, the NI 9234's 0.5 Hz first-order AC
   coupling on both channels (the response channel DC-coupled in ``gravity-dc`` only);
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal),
   sampling every 8th analog point (at jittered instants in ``sampling-jitter``), 24-bit quantisation on +-5 V with
   the sensitivities the software used;
5. what the exporter did (``detrended-export``, ``zero-padded-export``, ``record-pairing``), then UFF 58 (per hit a
   force record, data type 13 "N", and an acceleration record, 12 "m/s^2"; each record's absolute start in
   ``abscissa_min``, 0 for every record in ``control-few-short``, as some exporters write).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam5/generate.py [--out out/redteam5] [--only CASE ...] [--keys-only]
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
G = 9.80665
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
    extra_z: Callable | None = None  # s -> dynamic stiffness added to the SD film (N/m)
    accelerance: Callable | None = None  # (case, s) -> the whole accelerance (replaces the film's)
    per_hit_h: Callable | None = None  # (case, rng, s, drawn) -> (hits, nf) accelerance per hit
    rk4: Callable | None = None  # (case, rng, force, f_half, dt, t, drawn) -> acceleration (hits, n)
    sensor: Callable | None = None  # (case, rng, accel, t, drawn) -> sensor output in m/s^2 as the software reads it
    accel_noise: float = ACCEL_NOISE
    accel_noise_scale: Callable | None = None  # (case) -> (hits,) factors
    accel_dc_coupled: bool = False
    accel_offset: float = 0.0  # m/s^2 static output (DC-coupled channel only)
    jitter_s: float = 0.0  # RMS sampling-clock jitter, common to both channels
    export: Callable | None = None  # (case, records, starts, drawn) -> records, starts
    zero_abscissa: bool = False
    accel_v_per_unit: float = ACCEL_V_PER_M_S2
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
    if case.accelerance is not None:
        return case.accelerance(case, s)
    z = K + C * s
    if case.extra_z is not None:
        z = z + case.extra_z(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (z + MASS * s**2))


def ac_coupling(s: np.ndarray) -> np.ndarray:
    return s / (s + 2 * np.pi * AC_CORNER_HZ)


def rk4_nystrom(acc, n: int, dt: float, shape: tuple) -> np.ndarray:
    """x'' = acc(i, stage, x, v), stage 0 at t_i, 1 at t_i + dt/2, 2 at t_i + dt; returns acc at every t_i."""
    x, v = np.zeros(shape), np.zeros(shape)
    out = np.empty((n,) + shape)
    for i in range(n):
        a1 = acc(i, 0, x, v)
        out[i] = a1
        a2 = acc(i, 1, x + dt / 2 * v, v + dt / 2 * a1)
        a3 = acc(i, 1, x + dt / 2 * (v + dt / 2 * a1), v + dt / 2 * a2)
        a4 = acc(i, 2, x + dt * (v + dt / 2 * a2), v + dt * a3)
        x = x + dt * v + dt**2 / 6 * (a1 + a2 + a3)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
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
    hit_times = 1.5 + np.cumsum(case.record_s + 1.0 + rng.uniform(0, 2.0, case.hits))
    starts = hit_times - case.pretrigger_s
    peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(case.hits)),
                    0.5 * case.force_n, 1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, case.hits)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist()}
    force = half_sine(t, t0, widths, peaks)
    if case.rk4 is not None:
        f_half = half_sine(t + 0.5 / fine, t0, widths, peaks)
        accel = case.rk4(case, rng, force, f_half, 1 / fine, t, drawn)
    else:
        nfft = nextpow2(2 * n)
        s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
        h = case.per_hit_h(case, rng, s, drawn) if case.per_hit_h is not None else case_accelerance(case, s)[None, :]
        accel = np.fft.irfft(np.fft.rfft(force, nfft, axis=1) * h, nfft, axis=1)[:, :n]
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(accel[:, before]).max() / np.abs(accel).max())
    if case.sensor is not None:
        accel = case.sensor(case, rng, accel, t, drawn)
    level = 1.0 if noise else 0.0
    scale = case.accel_noise_scale(case)[:, None] if case.accel_noise_scale is not None else 1.0
    force = force + level * FORCE_NOISE * np.sqrt(fine / 2) * rng.standard_normal(force.shape)
    accel = accel + level * scale * case.accel_noise * np.sqrt(fine / 2) * rng.standard_normal(accel.shape)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    force = signal.sosfilt(hp, force, axis=1)
    if not case.accel_dc_coupled:
        accel = signal.sosfilt(hp, accel, axis=1)
    records = np.empty((case.hits, 2, samples))
    sos = anti_aliasing(fs)
    if case.jitter_s:
        jitter = case.jitter_s * rng.standard_normal((case.hits, samples))
        drawn["jitter_rms_us"] = float(np.std(jitter) * 1e6)
    for row, channel in enumerate((force, accel)):
        filtered = signal.sosfilt(sos, channel, axis=1)
        if row == 1 and case.accel_dc_coupled:
            # a DC-coupled channel has sat at its static output for ever: the filter is in its steady state
            filtered = filtered + case.accel_offset
        if case.jitter_s:
            pos = lead + OVERSAMPLE * np.arange(samples)[None, :] + jitter * fine
            base = np.clip(np.floor(pos).astype(int), 0, n - 2)
            frac = pos - base
            rows = np.arange(case.hits)[:, None]
            records[:, row, :] = (1 - frac) * filtered[rows, base] + frac * filtered[rows, base + 1]
        else:
            records[:, row, :] = filtered[:, lead::OVERSAMPLE][:, :samples]
    for row, v_per_unit in ((0, HAMMER_V_PER_N), (1, case.accel_v_per_unit)):
        step = LSB_V / v_per_unit
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    if case.export is not None:
        records, starts = case.export(case, records, starts, drawn)
    return records, starts, drawn


# ------------------------------------------------------------------------------------------------ case hooks

def dynamic_brake(s):
    """The linear motor's drive is disabled with dynamic braking: its phases are shorted, the back-EMF drives a
    current through R + sL: force -K_f^2 v/(R + sL) = -(c_b s/(1 + s tau)) x, c_b = K_f^2/R, tau = L/R."""
    kf, r, l_h = 52.9, 4.0, 6e-3
    return (kf**2 / r) * s / (1 + s * l_h / r)


def pad_accelerance(case, s):
    """Hit on a 50 g cover pad (on 5e7 N/m, zeta 0.03) screwed to the mover; accelerometer on the mover itself."""
    mp, kp, zp = 0.05, 5e7, 0.03
    m = MASS - mp
    kp_s = kp + 2 * zp * np.sqrt(kp * mp) * s
    z = K + C * s
    with np.errstate(divide="ignore", invalid="ignore"):
        det = (mp * s**2 + kp_s) * (m * s**2 + z + kp_s) - kp_s**2
        return np.nan_to_num(s**2 * kp_s / det)


def wrong_axis(case, rng, s, drawn):
    """The exporter took the triaxial accelerometer's Y axis (lateral): 4 % transverse sensitivity to the vertical
    motion, plus the mover's lateral film mode (310 Hz, zeta 0.03) driven by the hit's lateral component sin(theta),
    theta 3-8 deg per hit."""
    theta = np.deg2rad(rng.uniform(3, 8, case.hits))
    drawn["hit_angle_deg"] = np.round(np.rad2deg(theta), 2).tolist()
    w = 2 * np.pi * 310.0
    lateral = sd_accelerance(s, k=MASS * w**2, c=2 * 0.03 * MASS * w)
    return 0.04 * sd_accelerance(s)[None, :] + np.sin(theta)[:, None] * lateral[None, :]


def loose_part(case, rng, force, f_half, dt, t, drawn):
    """A 1.2 kg fixture lies loose on the mover (part of the 25.05 kg): stiff unilateral contact (1e9 N/m, zeta 0.2);
    it lifts off whenever the mover accelerates downward (along the hit) faster than g."""
    mp, kc = 1.2, 1e9
    cc = 2 * 0.2 * np.sqrt(kc * mp)
    mr = MASS - mp
    d0 = mp * G / kc
    hits, n = force.shape
    ff, fh = force.T.copy(), f_half.T.copy()
    lifted = np.zeros(hits, bool)

    def acc(i, stage, x, v):
        nonlocal lifted
        f = ff[i] if stage == 0 else fh[i] if stage == 1 else ff[min(i + 1, n - 1)]
        d = x[:, 1] - x[:, 0] + d0
        normal = np.where(d > 0, np.maximum(kc * d + cc * (v[:, 1] - v[:, 0]), 0.0), 0.0)
        if stage == 0:
            lifted |= normal <= 0
        out = np.empty_like(x)
        out[:, 0] = (f - K * x[:, 0] - C * v[:, 0] + normal - mp * G) / mr
        out[:, 1] = G - normal / mp
        return out

    accel = rk4_nystrom(acc, n, dt, (hits, 2))[:, :, 0].T
    drawn["lift_off_hits"] = (np.flatnonzero(lifted) + 1).tolist()
    return accel


def stiffness_fluctuation(case, rng, force, f_half, dt, t, drawn):
    """Turbulent pressure fluctuation in the recesses modulates the film stiffness: k(t) = K (1 + e(t)), e band-
    limited 20-600 Hz, 2 % RMS, an independent realisation per record (parametric, multiplicative noise)."""
    hits, n = force.shape
    sos = signal.butter(2, (20, 600), btype="band", output="sos", fs=1 / dt)
    e = signal.sosfiltfilt(sos, rng.standard_normal((hits, n + 1)), axis=1)
    e *= 0.02 / e.std(axis=1, keepdims=True)
    eh = 0.5 * (e[:, :-1] + e[:, 1:])
    ee, eh = e.T.copy(), eh.T.copy()
    ff, fh = force.T.copy(), f_half.T.copy()

    def acc(i, stage, x, v):
        if stage == 0:
            f, k = ff[i], K * (1 + ee[i])
        elif stage == 1:
            f, k = fh[i], K * (1 + eh[i])
        else:
            f, k = ff[min(i + 1, n - 1)], K * (1 + ee[min(i + 1, n)])
        return ((f - k * x[:, 0] - C * v[:, 0]) / MASS)[:, None]

    return rk4_nystrom(acc, n, dt, (hits, 1))[:, :, 0].T


def sensor_swap(case, rng, accel, t, drawn):
    """After hit 8 the accelerometer was replaced by another of the same type: its calibrated sensitivity is
    9.75 mV/(m/s^2), the software still uses the first's 10.2 (-4.4 % for hits 9-16)."""
    gain = np.where(np.arange(case.hits) >= 8, 9.75 / 10.2, 1.0)
    return accel * gain[:, None]


def pyroelectric(case, rng, accel, t, drawn):
    """The bearing's exhaust air (cooled by its expansion) flows over a compression-type accelerometer: temperature
    fluctuations give a pyroelectric output, a random baseline below ~2 Hz, 0.1 m/s^2 RMS before the coupling."""
    fine = 1 / (t[1] - t[0])
    warm = int(4 * fine)
    sos = signal.butter(2, 2.0, output="sos", fs=fine)
    wander = signal.sosfilt(sos, rng.standard_normal((case.hits, t.size + warm)), axis=1)[:, warm:]
    wander *= 0.1 / wander.std(axis=1, keepdims=True)
    drawn["pyro_rms_m_s2"] = 0.1
    return accel + wander


def noise_step(case):
    """The compressor switches on after hit 8: broadband floor and flow noise on the response, 5x the sensor noise."""
    return np.where(np.arange(case.hits) >= 8, 5.0, 1.0)


def detrend_export(case, records, starts, drawn):
    """The exporting script applied scipy.signal.detrend (linear, the default) to every record of both channels."""
    return signal.detrend(records, axis=2, type="linear"), starts


def zero_pad_export(case, records, starts, drawn):
    """The recorder stored 0.3 s per hit; the exporter padded every record with exact zeros to 1 s."""
    out = records.copy()
    out[:, :, int(round(0.3 * case.rate_hz)):] = 0.0
    return out, starts


def pairing_shift(case, records, starts, drawn):
    """The exporter lost the first response record: force record i is paired with the response of hit i + 1."""
    out = np.empty((case.hits - 1,) + records.shape[1:])
    out[:, 0] = records[:-1, 0]
    out[:, 1] = records[1:, 1]
    drawn["pairs"] = "force i with response i+1"
    return out, starts[:-1]


# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    allnl = ["cubic-stiffness", "friction", "quadratic-damping"]
    listed = [
        Case("control-few-short", "control",
             "a real recorder's habits: 4 hits at 25.6 kS/s, 0.5 ms pre-trigger, 0.06 s records still ringing at the "
             "end (≈ 1.5 % of the peak), every record's abscissa_min 0 (no session time); linear film",
             "NI 9234 datasheet (25.6 kS/s); Brandt (2011) §13.7 (short records, leakage)",
             "Nothing beyond the film; few hits, little pre-trigger, truncated ringing, no hit times.", seed=501,
             rate_hz=25600.0, record_s=0.06, pretrigger_s=0.0005, hits=4, zero_abscissa=True,
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip", "double"]),
        Case("control-3hits-10k24", "control",
             "3 light hits (80 N ± 20 %) at 10.24 kS/s, 2 s records, 50 ms pre-trigger (`--rig` nominal); linear film",
             "NI 9234 datasheet (51.2 kS/s / n, n = 5)",
             "A plain linear session at a coerced rate with long records and few light hits.", seed=502, cli="rig",
             rate_hz=10240.0, record_s=2.0, pretrigger_s=0.05, hits=3, force_n=80.0,
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip", "double"]),
        Case("control-2k048-40hits", "control",
             "40 hits at 2.048 kS/s (0.42 fs = 860 Hz), 0.5 s records, 5 ms pre-trigger, soft tip (2 ms pulse); "
             "linear film", "NI 9234 datasheet (51.2 kS/s / 25); PCB hammer tip charts (soft tips)",
             "A plain linear session with many hits at a low rate and a soft tip.", seed=503, rate_hz=2048.0,
             record_s=0.5, pretrigger_s=0.005, hits=40, pulse_ms=2.0,
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip", "double"]),
        Case("control-noise-step", "control",
             "the compressor switches on after hit 8: the response noise is 5× higher (broadband) in hits 9–16; "
             "linear film", "Brandt (2011) §13 (non-stationary noise between averages); ISO 7626-5",
             "Non-stationary noise between hits, no physics: averaging weights should handle it, nothing to claim.",
             seed=504, accel_noise_scale=noise_step,
             must_not=list(EVERYTHING), must_not_quality=["mains", "clip", "double"]),
        # ---------------------------------------------------------------------------------------------- rig
        Case("dynamic-brake", "rig",
             "the linear motor's drive is disabled with dynamic braking (phases shorted): back-EMF damping "
             "K_f²/(R + sL), K_f 52.9 N/A, R 4 Ω, L 6 mH: c_b 700 N·s/m with a 1.5 ms lag, i.e. Z += c_b s/(1 + sτ) "
             "(at 196 Hz ≈ +3.6e5 N/m, +150 N·s/m: +1 % k, +4 % c)",
             "Gieras, Piech & Tomczuk, Linear Synchronous Motors (2nd ed., CRC 2011) (back-EMF, braking); Krishnan, "
             "Permanent Magnet Synchronous and Brushless DC Motor Drives (CRC 2010) (dynamic braking); Slocum, "
             "Precision Machine Design (1992) (air-bearing stages with linear motors)",
             "A Maxwell branch beside the film (a damper in series with the winding's inductance): exactly a film "
             "memory of order 1; the squeeze film's trend (stiffer and less damped with frequency) is the same. "
             "Absorbed into k and c within the noise (parameters-only) is fair. Mass, modes, amplitude, time or chain "
             "terms are wrong.", seed=511, extra_z=dynamic_brake, subtle=True,
             physics={"c_brake_ns_per_m": 52.9**2 / 4.0, "tau_s": 1.5e-3},
             exact=[["dynamic-brake"]], acceptable=[["film-memory"], ["squeeze-film"], []],
             must_not=without(RIG, "film-memory", "squeeze-film") + list(CHAIN) + ["window-damping"]),
        Case("loose-part-liftoff", "rig",
             "a 1.2 kg fixture lies loose on the mover (included in the 25.05 kg): stiff unilateral contact; it lifts "
             "off whenever the mover accelerates along the hit faster than g — in most hits (400 N ± 30 %, a heavy-handed operator), "
             "for part of the first swings; the mass is then 23.85 kg",
             "Ibrahim, Vibro-Impact Dynamics (Springer 2009); Pfeiffer & Glocker, Multibody Dynamics with Unilateral "
             "Contacts (Wiley 1996); Ewins (2000) §4 (nonlinearity checks: hit-level dependence)",
             "Amplitude-dependent mass (and impact loss): the strong hits ring higher and lose energy at the landings; "
             "weak hits are the plain film. An amplitude term (cubic, friction, quadratic damping) is only a partial "
             "description beside an honest rest; added mass, modes, memory, time and chain terms are wrong.",
             seed=512, rk4=loose_part, force_n=400.0, spread=0.3,
             physics={"part_kg": 1.2, "contact_n_per_m": 1e9, "lift_off_above_m_s2": G},
             exact=[["loose-part"]], partial_ok=allnl,
             must_not=without(RIG, *allnl) + list(CHAIN) + ["window-damping"]),
        Case("stiffness-fluctuation", "rig",
             "turbulent recess pressure modulates the film stiffness: k(t) = 3.8e7 (1 + e(t)), e 20–600 Hz, 2 % RMS, "
             "independent per record (multiplicative noise on the response, no mean change)",
             "Zhu, Chen et al., Tribol. Int. 48 (2012) (pressure fluctuation and micro-vibration of aerostatic "
             "bearings); Ibrahim, Parametric Random Vibration (Wiley 1985)",
             "Noise proportional to the response, absent in the quiet tails: the average FRF is the film's. "
             "Parameters-only or an honest 'not explained' (scatter) are right; any term is false.",
             seed=513, rk4=stiffness_fluctuation, subtle=True, physics={"k_fluctuation_rms": 0.02,
                                                                         "band_hz": [20, 600]},
             exact=[["stiffness-fluctuation"]], acceptable=[[]], must_not=list(EVERYTHING)),
        Case("drive-point-pad", "rig",
             "the operator hits a 50 g cover pad screwed to the mover (5e7 N/m, ζ 0.03: a 5.0 kHz local mode between "
             "the hit and the mover); the accelerometer is on the mover: the in-band FRF rises by ≈ (f/5 kHz)² "
             "(+4 % at 1 kHz)",
             "Ewins, Modal Testing (2000) §3.7 (drive point); McConnell & Varoto, Vibration Testing (2nd ed. 2008) "
             "ch. 6 (impact testing: local flexibility at the hit point)",
             "A real local mode above the band, not collocated with the response: an extra/structure mode is a fair "
             "description; an added mass, memory or chain term is wrong.",
             seed=514, accelerance=pad_accelerance, subtle=True,
             physics={"pad_kg": 0.05, "pad_n_per_m": 5e7, "pad_hz": 5033},
             exact=[["drive-point-pad"]], acceptable=[["extra-mode"]],
             must_not=without(RIG, "extra-mode") + list(CHAIN) + ["window-damping"]),
        # ------------------------------------------------------------------------------------- measurement
        Case("gravity-dc", "measurement",
             "a DC-coupled MEMS accelerometer (±2 g, 40.8 mV/(m/s²), 2e-4 (m/s²)/√Hz) on an NI 9234 channel set to "
             "DC with IEPE off: every response record sits on +9.93 m/s² (1 g plus 0.13 zero-g offset); the force "
             "channel keeps its 0.5 Hz coupling",
             "Analog Devices ADXL354/355 data sheet (DC response, 0 g offset); NI 9234 user manual (AC/DC coupling, "
             "IEPE off)",
             "A static offset on the response and no 0.5 Hz corner there: nothing physical. The force channel's "
             "coupling is then not matched on the response: an `ac-coupling` on the force (0.5 Hz) is true.",
             seed=521, accel_dc_coupled=True, accel_offset=G * np.cos(np.deg2rad(1.5)) + 0.13, accel_noise=2e-4,
             accel_v_per_unit=0.0408, physics={"offset_m_s2": G * np.cos(np.deg2rad(1.5)) + 0.13},
             exact=[["dc-coupled-response"]], acceptable=[[], ["ac-coupling"]],
             must_not=without(EVERYTHING, "ac-coupling")),
        Case("sampling-jitter", "measurement",
             "a recorder whose sampling clock jitters 3 µs RMS (white, the same instants on both channels): errors "
             "∝ the signals' slopes, largest during the pulse and the first swings, absent in the quiet tails",
             "Brannon, Analog Devices AN-501 'Aperture uncertainty and ADC system performance' (2000); Kester, Data "
             "Conversion Handbook (ADI 2005) §2",
             "Signal-dependent noise on both channels (an errors-in-variables H1), no physics. Parameters-only or "
             "an honest not-explained; any term is false.",
             seed=522, jitter_s=3e-6, physics={"jitter_rms_s": 3e-6},
             exact=[["sampling-jitter"]], acceptable=[[]], must_not=list(EVERYTHING)),
        Case("detrended-export", "measurement",
             "the exporting script detrended every record of both channels (scipy.signal.detrend, linear, its "
             "default): the force records lose their mean ≈ impulse/T and a slope; the FRF's low band is biased "
             "(≈ 2 % at 10 Hz, 0.1 % at 200 Hz)",
             "Bendat & Piersol, Random Data (4th ed. 2010) §11.1 (trend removal and its bias); SciPy/MATLAB "
             "`detrend` defaults", "A processing step on transient records, no physics. Nothing, or a note, or not "
             "explained; rig terms are false.", seed=523, export=detrend_export, subtle=True,
             exact=[["detrended-export"]], acceptable=[[]],
             must_not=list(RIG) + ["window-damping", "channel-delay", "cross-talk", "sensitivity-error"]),
        Case("sensor-swap", "measurement",
             "after hit 8 the accelerometer was swapped for another of the same type (calibrated 9.75 instead of "
             "10.2 mV/(m/s²)); the software kept 10.2: hits 9–16 read 4.4 % low at every frequency",
             "ISO 16063-21 (calibration by comparison, per serial number); PCB 352C33 data sheet (10.2 mV/(m/s²) "
             "± 10 % nominal); Serridge & Licht (B&K 1987) §6",
             "A step of the chain's gain, not of the rig: a sensitivity error (for the session's mean) is a fair "
             "partial description; an added mass only with that alternative; step-change/drift of the film (the "
             "resonance does not move) is wrong.",
             seed=524, sensor=sensor_swap, subtle=True, physics={"gain_after_hit_8": 9.75 / 10.2},
             exact=[["sensor-swap"]], acceptable=[["sensitivity-error"], ["added-mass"]],
             needs_alternative={"added-mass": "sensitivity-error"},
             must_not=without(RIG, "added-mass") + ["channel-delay", "ac-coupling", "cross-talk", "window-damping"]),
        Case("zero-padded-export", "measurement",
             "the recorder kept 0.3 s per hit; the exporter padded every record with exact zeros to 1 s (the last "
             "70 % of both channels are 0.0)",
             "Brandt (2011) §9.3 (zero padding: interpolation, not information); UFF 58 (number of values per record)",
             "The quiet tails hold no noise at all: noise from them is zero. Nothing physical.",
             seed=525, export=zero_pad_export, exact=[["zero-padded"]], acceptable=[[]], must_not=list(EVERYTHING)),
        Case("pyroelectric-baseline", "measurement",
             "cool exhaust air over a compression-type accelerometer: pyroelectric output, a random baseline below "
             "≈ 2 Hz of 0.1 m/s² RMS (before the 0.5 Hz coupling), not locked to the hits",
             "Serridge & Licht, Piezoelectric Accelerometer Handbook (B&K 1987) (temperature transients); PCB "
             "'Introduction to piezoelectric accelerometers' (temperature transient sensitivity, shear vs "
             "compression)",
             "A slow additive baseline on the response: leakage into the lowest lines. Nothing physical; any term is "
             "false.", seed=526, sensor=pyroelectric, exact=[["pyroelectric"]], acceptable=[[]],
             must_not=list(EVERYTHING)),
        Case("record-pairing", "measurement",
             "the exporter lost the first response record: each force record is paired with the NEXT hit's response "
             "(15 pairs; forces differ ± 20 %, sub-sample starts differ)",
             "Bendat & Piersol (2010) ch. 9 (coherence of unrelated input/output pairs); Brandt (2011) §13.7",
             "Force and response of different events: per-pair gains scatter ±20 % and phases by up to one sample; no "
             "physics describes it. A refusal or not explained (with low coherence) is right.",
             seed=527, hits=16, export=pairing_shift, exact=[["record-pairing"]], must_not=list(EVERYTHING),
             refusal_ok=True),
        Case("wrong-axis", "measurement",
             "the exporter took the triaxial accelerometer's Y (lateral) axis: 4 % transverse sensitivity to the "
             "vertical motion plus the mover's lateral film mode (310 Hz, ζ 0.03) driven by sin θ of each hit "
             "(θ 3–8°)",
             "PCB triaxial accelerometer manuals (axis orientation labels); Avitabile, Modal Testing (2017) ch. 5 "
             "(channel-table errors); ISO 5348",
             "The FRF is not the mover's vertical accelerance (its level is 4–14 % of it, a lateral mode dominates). "
             "A level note, refusal or not explained is right; any term is false.",
             seed=528, per_hit_h=wrong_axis, exact=[["wrong-axis"]],
             must_not=without(EVERYTHING, "extra-mode"), refusal_ok=True),
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
    truth = {"mass_kg": MASS, "film_k_n_per_m": K, "film_c_ns_per_m": C, "sample_rate_hz": case.rate_hz,
             "record_s": case.record_s, "hits": case.hits, "pretrigger_s": case.pretrigger_s,
             "pulse_ms": case.pulse_ms, "force_n": case.force_n, "force_spread": case.spread} | case.physics
    return {
        "case": case.name, "uff": f"{case.name}.uff", "category": case.category, "summary": case.summary,
        "source": case.source, "reasoning": case.reasoning, "cli": case.cli,
        "cli_arguments": (["--rig", "nominal-rig.toml"] if case.cli == "rig" else ["--mass", f"{NOMINAL['mass_kg']:g}"]),
        "truth": truth, "control": case.category == "control", "subtle": case.subtle,
        "exact": [sorted(x) for x in case.exact], "acceptable": [sorted(x) for x in case.acceptable],
        "allowed": allowed, "partial_ok": sorted(case.partial_ok), "must_not_claim": sorted(case.must_not),
        "must_not_quality": sorted(case.must_not_quality), "needs_alternative": case.needs_alternative,
        "empty_needs_recalibrated": {}, "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "refusal_ok": case.refusal_ok, "expected_quality": case.expected_quality,
    }


def write_uff(path: Path, records: np.ndarray, starts: np.ndarray, rate_hz: float, name: str,
              zero_abscissa: bool = False) -> None:
    sets = []
    dt = 1.0 / rate_hz
    for hit, (record, start) in enumerate(zip(records, starts)):
        start = 0.0 if zero_abscissa else float(start)
        for values, dtype, unit in ((record[0], 13, "N"), (record[1], 12, "m/s^2")):
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"{name} hit {hit + 1}", id2="redteam5 generator", id3="", id4="", id5="",
                func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, ord_data_type=4, abscissa_spacing=1,
                abscissa_min=start, abscissa_inc=dt, abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s", ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="NONE", data=np.asarray(values, dtype=float),
                x=start + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam5"))
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
        write_uff(args.out / f"{case.name}.uff", records, starts, case.rate_hz, case.name, case.zero_abscissa)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1))
        print(f"{case.name:24s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak |a| "
              f"{np.abs(records[:, 1]).max():.3g}, peak F {records[:, 0].max():.0f} N, acausal "
              f"{drawn['acausal_fraction']:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
