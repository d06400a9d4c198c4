"""Red-team world, round 9: twelve further rig-physics and measurement faults plus four controls.

Written by a helper that has read neither ``analysis/``, ``app/``, ``drivers/`` nor ``tests/`` (only README.md, docs/,
the CLI's ``--help``, the paper and the earlier rounds' READMEs, keys, generators and scorers). Imports nothing from
gasfilm: numpy, scipy and pyuff only. The synthesis frame is round 8's (itself round 7's), with this round's hooks.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a half-sine
   of random peak and width starting at a random sub-sample instant);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance (a
   dynamic stiffness beside the film: the belt drive's reflected motor inertia, the counterbalance cylinder's throttled
   air spring; the whole accelerance replaced for the spinning journal's cross-coupled film; per hit for the pad's
   logarithmic creep);
3. what the sensors see beside the hit, on the analog signals (the on-board fan's unbalance, ground-borne shocks from
   a press, a phone's TDMA buzz demodulated in the accelerometer's amplifier, a starved IEPE supply that limits the
   hammer's falling slew rate), white sensor noise on both channels, the NI 9234's 0.5 Hz first-order AC coupling on
   both channels;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal), every
   8th analog point taken, what the logger did to the sampled values (an 8-point running mean on the response, a
   stuck ADC bit on the response), quantisation (24 bit on +-5 V with the software's sensitivities);
5. what the exporter did (the force written in lbf but labelled N, the force one sample late), then UFF 58 (per hit a
   force record, data type 13 "N", and an acceleration record, 12 "m/s^2" -- or "g" with values in g; each record's
   absolute session start in ``abscissa_min``; binary doubles; by hit, or grouped by channel).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam9/generate.py [--out out/redteam9] [--only CASE ...] [--keys-only]
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
    write_order: str = "time"  # time | force-descending | grouped (all forces, then all responses)
    resp_unit: str = "m/s^2"  # m/s^2 | g (the response written in g, labelled g)
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

def extra_mode_z(s, m_e, f_e, zeta_e):
    """A mass on a spring-damper riding on the mover (the catalogue's extra-mode form)."""
    w = 2 * np.pi * f_e
    k_e, c_e = m_e * w**2, 2 * zeta_e * m_e * w
    return m_e * s**2 * (k_e + c_e * s) / (m_e * s**2 + c_e * s + k_e)


# rig --------------------------------------------------------------------------------------------------------

BELT = {"rotor_inertia_kg_m2": 2.4e-4, "pulley_radius_m": 0.02, "reflected_mass_kg": 0.6, "freq_hz": 140.0,
        "damping_ratio": 0.04}
BELT["belt_stiffness_n_per_m"] = round(BELT["reflected_mass_kg"] * (2 * np.pi * BELT["freq_hz"]) ** 2, -2)


def belt_drive(s):
    """A belt-driven axis with its motor unpowered: the motor's rotor inertia J reflected through the pulley,
    J/r^2 = 0.6 kg, hangs on the mover through the two belt spans (4.6e5 N/m): a mass on a spring riding on the
    mover (140 Hz, zeta 0.04 from the belt's cords)."""
    return extra_mode_z(s, BELT["reflected_mass_kg"], BELT["freq_hz"], BELT["damping_ratio"])


CYLINDER = {"air_spring_n_per_m": 4.0e6, "tau_ms": 1.0}


def counterbalance_cylinder(s):
    """A vertical axis counterbalanced by a pneumatic cylinder whose chamber feeds a large reservoir through a
    throttle: slowly the pressure stays the reservoir's (no stiffness); above the throttle's corner the chamber is
    closed and is an air spring k_a = n p A^2 / V: Z = k_a s tau / (1 + s tau) (a Maxwell element to ground)."""
    tau = CYLINDER["tau_ms"] * 1e-3
    return CYLINDER["air_spring_n_per_m"] * s * tau / (1 + s * tau)


CROSS = {"cross_coupled_n_per_m": 2.5e6, "speed_rpm": 30000}


def journal_cross_coupling(s):
    """A spinning aerostatic journal hit radially: the film's cross-coupled stiffness k_xy = -k_yx = k_c (the
    rotation drags the gas round), isotropic direct film Z = k + c s: the direct accelerance in x is
    s^2 (Z + m s^2) / ((Z + m s^2)^2 + k_c^2): forward whirl less damped, backward more, at the same frequency."""
    z = K + C * s + MASS * s**2
    return s**2 * z / (z**2 + CROSS["cross_coupled_n_per_m"] ** 2)


FAN = {"force_1x_n": 0.3, "force_2x_n": 0.1, "speed_hz": [46.0, 46.6]}


def fan_unbalance(case, rng, force, resp, t, drawn):
    """The axis' amplifier is cooled by a fan bolted to the mover (2760-2800 rpm, speed wandering between records):
    its residual unbalance and misalignment put a rotating force on the mover, 0.3 N at 1x and 0.1 N at 2x, with a
    phase unrelated to the hammer; the mover answers through its own accelerance (steady state)."""
    h = resp.shape[0]
    speeds = rng.uniform(*FAN["speed_hz"], h)
    out = resp.copy()
    for harmonic, amp in ((1, FAN["force_1x_n"]), (2, FAN["force_2x_n"])):
        f = harmonic * speeds
        hh = case_accelerance(case, 2j * np.pi * f)
        phase = rng.uniform(0, 2 * np.pi, h)
        out += np.abs(hh)[:, None] * amp * np.cos(2 * np.pi * f[:, None] * t[None, :] + phase[:, None]
                                                  + np.angle(hh)[:, None])
    drawn["fan_speed_hz"] = np.round(speeds, 3).tolist()
    return force, out


SHOCK = {"records": 5, "base_peak_m_s2": 0.15, "width_ms": 6.0, "at_s": [0.08, 0.7]}


def floor_shocks(case, rng, force, resp, t, drawn):
    """A mechanical press in the next bay: in five records a ground-borne shock (a 6 ms half-sine of 0.15 m/s^2 at the
    rig's base) arrives at a random moment after the hit; the mover answers through the film's transmissibility
    (k + c s)/(m s^2 + c s + k), ringing at its own resonance."""
    h, n = resp.shape
    chosen = np.sort(rng.choice(h, SHOCK["records"], replace=False))
    at = rng.uniform(*SHOCK["at_s"], SHOCK["records"])
    base = np.zeros((SHOCK["records"], n))
    base[:] = half_sine(t, at, np.full(SHOCK["records"], SHOCK["width_ms"] * 1e-3),
                        np.full(SHOCK["records"], SHOCK["base_peak_m_s2"]))
    fine = OVERSAMPLE * case.rate_hz
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    trans = (K + C * s) / (MASS * s**2 + C * s + K)
    moved = np.fft.irfft(np.fft.rfft(base, nfft, axis=1) * trans, nfft, axis=1)[:, :n]
    out = resp.copy()
    out[chosen] += moved
    drawn["shock_records"] = [int(i) + 1 for i in chosen]
    drawn["shock_at_s"] = np.round(at, 4).tolist()
    return force, out


CREEP = {"k_per_decade": 0.05, "c_share": 0.5, "t0_s": 4.0}


def pad_creep(case, rng, s, drawn):
    """The bearing pads are bonded with epoxy; the supply was switched on (preload applied) just before the session:
    the adhesive creeps logarithmically, the gap closes and the film stiffens: k(t) = k (1 + 0.05 log10(1 + t/4 s)),
    c(t) = c (1 + 0.025 log10(1 + t/4 s)), t the hit's time from the preload."""
    u = np.log10(1 + drawn["_hit_times"] / CREEP["t0_s"])
    k = K * (1 + CREEP["k_per_decade"] * u)
    c = C * (1 + CREEP["c_share"] * CREEP["k_per_decade"] * u)
    drawn["film_k_per_hit"] = np.round(k, -2).tolist()
    drawn["film_c_per_hit"] = np.round(c, 2).tolist()
    return np.stack([sd_accelerance(s, k=ki, c=ci) for ki, ci in zip(k, c)])


# measurement ------------------------------------------------------------------------------------------------

LBF_IN_N = 4.4482216152605


def force_in_lbf(case, records, starts, drawn):
    """The exporter's channel table kept the hammer in the US template's unit: force values in lbf, the record still
    labelled N (data type 13): the force reads 1/4.448 of the truth."""
    out = [np.stack([r[0] / LBF_IN_N, r[1]]) for r in records]
    drawn["force_scale"] = 1 / LBF_IN_N
    return out, starts


SLEW = {"supply_ma": 1.03, "sensor_bias_ma": 1.0, "cable_nf": 33.0}
SLEW["slew_v_per_s"] = round((SLEW["supply_ma"] - SLEW["sensor_bias_ma"]) * 1e-3 / (SLEW["cable_nf"] * 1e-9), 1)


def iepe_slew(case, rng, force, resp, t, drawn):
    """A battery conditioner on its last legs (1.03 mA of IEPE current) drives the hammer through 330 m of cable
    (33 nF): the sensor's output stage can pull the cable down no faster than (I - 1 mA)/C = 909 V/s (PCB's long-cable
    rule); rising edges follow. The pulse's fall is stretched for every hit whose fall is steeper than that
    (peak above ~130 N at 1 ms)."""
    volts = force * HAMMER_V_PER_N
    limit = SLEW["slew_v_per_s"] / (OVERSAMPLE * case.rate_hz)
    fine = OVERSAMPLE * case.rate_hz
    stop = int(round((LEAD_IN_S + case.pretrigger_s + 0.03) * fine))
    out = volts.copy()
    v = volts[:, 0].copy()
    for j in range(1, stop):
        v = np.maximum(volts[:, j], v - limit)
        out[:, j] = v
    tail = out[:, stop - 1] - volts[:, stop - 1]
    drawn["slew_left_v_at_30ms"] = np.round(tail, 6).tolist()
    read = out / HAMMER_V_PER_N
    drawn["impulse_read_over_true"] = np.round(read.sum(1) / force.sum(1), 5).tolist()
    return read, resp


BOXCAR = {"points": 8}


def boxcar(case, rng, records, drawn):
    """The logger's 'smoothing' option left on for the response: a trailing 8-point running mean (causal FIR,
    delay 3.5 samples, nulls at fs/8 = 1600 Hz and its multiples)."""
    out = records.copy()
    out[:, 1] = signal.lfilter(np.ones(BOXCAR["points"]) / BOXCAR["points"], [1.0], records[:, 1], axis=1)
    return out


GSM = {"frame_ms": 4.615, "burst_ms": 0.577, "level_m_s2": 0.01, "records_from": 4, "records_to": 9}


def gsm_buzz(case, rng, force, resp, t, drawn):
    """A phone on the bench next to the accelerometer's cable takes a call during records 4-9: its GSM bursts
    (577 us every 4.615 ms TDMA frame, 216.7 Hz) are rectified in the sensor's amplifier (RF rectification): a
    rectangular train of 0.01 m/s^2 equivalent (its mean taken out by the coupling, the call being steady), phase
    random per record."""
    out = resp.copy()
    frame, burst = GSM["frame_ms"] * 1e-3, GSM["burst_ms"] * 1e-3
    rows = list(range(GSM["records_from"] - 1, GSM["records_to"]))
    for i in rows:
        phase = rng.uniform(0, frame)
        u = np.mod(t + phase, frame)
        train = (u < burst).astype(float)
        out[i] += GSM["level_m_s2"] * (train - burst / frame)
    drawn["buzz_records"] = [i + 1 for i in rows]
    return force, out


def off_by_one(case, records, starts, drawn):
    """The exporter wrote each force record from one sample before its response record (an off-by-one in the
    writer's index): the force is one sample (78.1 us) late against the response."""
    out = []
    for r in records:
        f = np.empty_like(r[0])
        f[1:] = r[0][:-1]
        f[0] = r[0][0]
        out.append(np.stack([f, r[1]]))
    drawn["force_late_s"] = 1 / case.rate_hz
    return out, starts


STUCK = {"bit": 8, "channel": "response"}


def stuck_bit(case, rng, records, drawn):
    """Bit 8 of the response channel's 24-bit ADC word is stuck at 1 (a failed line on the module's data bus): every
    code whose bit 8 is 0 reads 256 LSB (0.0148 m/s^2) high."""
    step = LSB_V / ACCEL_V_PER_M_S2
    out = records.copy()
    q = np.round(records[:, 1] / step).astype(np.int64)
    u = q & 0xFFFFFF
    u = u | (1 << STUCK["bit"])
    signed = np.where(u >= 1 << 23, u - (1 << 24), u)
    out[:, 1] = signed * step
    drawn["stuck_step_m_s2"] = float((1 << STUCK["bit"]) * step)
    drawn["share_of_samples_changed"] = float(np.mean(signed != q))
    return out




# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    everything = list(EVERYTHING)
    control_quality = ["mains", "clip", "double"]
    not_rig = list(RIG)
    listed = [
        # ---------------------------------------------------------------------------------------- controls
        Case("control-6k4-64hits", "control",
             "the module at 51.2 kS/s / 8 = 6 400 S/s, 0.5 s records, 20 ms pre-trigger, 64 hits (0.5–1.5 s apart); "
             "linear film",
             "NI 9234 data sheet (f_s = 51.2 kS/s / n, n = 1…31); ISO 7626-5 (averaging many impacts); Brandt (2011) "
             "§13.7",
             "A legal rate, many averages, records long enough for the film's decay (14 ms): nothing to claim.",
             seed=901, rate_hz=6400.0, record_s=0.5, pretrigger_s=0.020, hits=64, gap_s=(0.5, 1.5),
             must_not=everything, must_not_quality=control_quality),
        Case("control-grouped-channels", "control",
             "UFF 58 written grouped by channel: the 16 force records first (hits 1–16), then the 16 acceleration "
             "records, each record named by its hit and carrying its own absolute start; linear film",
             "I-DEAS universal file, data set 58 (each set self-describing: no order between sets is prescribed); "
             "pyuff; LMS/Siemens Test.Lab UFF export ('per channel' ordering)",
             "A legal ordering of self-describing data sets; records pair by hit name and start time. Nothing to "
             "claim; a refusal is an error here.", seed=902, write_order="grouped", must_not=everything,
             must_not_quality=control_quality),
        Case("control-half-pretrigger", "control",
             "1 s records with a 0.5 s pre-trigger (the hit in the middle of each record); linear film",
             "Brandt (2011) §13.7 (pre-trigger length); NI-DAQmx reference-triggered acquisition (pre-trigger samples "
             "up to the whole record)",
             "A long but legal pre-trigger: half of each record is quiet before the hit, 0.5 s after it is ample. "
             "Nothing to claim.", seed=903, pretrigger_s=0.5, must_not=everything,
             must_not_quality=control_quality),
        Case("control-g-units", "control",
             "the acceleration records written in g (values ÷ 9.80665) and labelled 'g' (data type 12, acceleration), "
             "as many analysers export; force in N; linear film",
             "I-DEAS universal file, data set 58, record 8 (ordinate axis units label); ISO 80000-3 (standard "
             "acceleration of free fall g_n = 9.80665 m/s²); Brandt (2011) §2.2",
             "The unit is written on the record: read in g, the FRF is the film's. Nothing to claim; a level note "
             "(a factor 9.81) would mean the label was not read.", seed=904, resp_unit="g", must_not=everything,
             must_not_quality=control_quality + ["level:"]),
        # --------------------------------------------------------------------------------------------- rig
        Case("belt-drive-inertia", "rig",
             "a belt-driven axis with its motor unpowered: the rotor's inertia 2.4e-4 kg·m² reflected through the "
             "20 mm pulley (0.6 kg) hangs on the mover through the belt's two spans (4.6e5 N/m): a mass on a spring "
             "riding on the mover, 140 Hz, ζ 0.04",
             "Altintas, Manufacturing Automation (2nd ed. 2012) §6.2 (inertia reflected through a transmission, "
             "J/r²); Slocum, Precision Machine Design (1992) §9.3 (belt drives, belt stiffness); Ewins (2000) §2.3",
             "A new cause whose law is the catalogue's extra mode exactly, with ordinary values (0.6 kg, in band, "
             "ζ 0.04): extra-mode is exact; an added mass only a partial description; chain, time and amplitude "
             "terms are wrong.", seed=911, extra_z=belt_drive, physics=dict(BELT), exact=[["extra-mode"]],
             partial_ok=["added-mass"], must_not=without(RIG, "extra-mode", "added-mass") + chain_but()),
        Case("counterbalance-cylinder", "rig",
             "a vertical axis counterbalanced by a pneumatic cylinder whose chamber feeds a reservoir through a "
             "throttle: an air spring 4.0e6 N/m behind a 1.0 ms lag, Z = k_a sτ/(1 + sτ) (a Maxwell element to "
             "ground): at 159 Hz +2.0e6 N/m and +2000 N·s/m",
             "Lee & Kim, 'Analytical modeling of a pneumatic spring with an auxiliary chamber through an orifice' "
             "(J. Mech. Sci. Technol. 2007); Harris' Shock and Vibration Handbook (6th ed. 2010) ch. 33 (air springs "
             "with surge tanks); Slocum (1992) §8.7 (counterbalancing vertical axes)",
             "A standard linear solid beside the film: film-memory at α = 1 (k_m 4e6, η 4000) is its exact law. A "
             "pneumatic lag or squeeze film only partly; amplitude, time, added mass and chain terms are wrong.",
             seed=912, extra_z=counterbalance_cylinder, physics=dict(CYLINDER), exact=[["film-memory"]],
             partial_ok=["pneumatic-lag", "squeeze-film"],
             must_not=list(AMPLITUDE) + list(TIME) + ["added-mass"] + chain_but()),
        Case("journal-cross-coupling", "rig",
             "the mover is a spinning aerostatic journal (30 000 rpm) hit radially: the rotation drags the gas round, "
             "a cross-coupled film stiffness k_xy = −k_yx = 2.5e6 N/m beside the direct film: forward whirl damped at "
             "ζ 0.024, backward at 0.089, at the same 196 Hz",
             "Lund, 'Calculation of stiffness and damping properties of gas bearings', J. Lubr. Technol. 90 (1968) "
             "793; Childs, Turbomachinery Rotordynamics (1993) ch. 3; Vance, Zeidan & Murphy, Machinery Vibration and "
             "Rotordynamics (2010) §3.5 (cross-coupled stiffness and whirl)",
             "Two coupled directions seen through one: H = s² Z/(Z² + k_c²), a pole pair split in damping, not in "
             "frequency. No catalogue term has it; an extra mode or a memory term only partly. Not explained is "
             "right; amplitude, time and chain terms are wrong.", seed=913, accel_fn=journal_cross_coupling,
             physics=dict(CROSS), exact=[["cross-coupled-stiffness"]],
             partial_ok=["extra-mode", "film-memory", "pneumatic-lag", "squeeze-film"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        Case("fan-unbalance", "rig",
             "the axis amplifier's cooling fan is bolted to the mover (46.0–46.6 Hz, wandering between records): its "
             "unbalance puts 0.3 N at 1× and 0.1 N at 2× on the mover, phase unrelated to the hammer (response "
             "≈ 7e-4 m/s² at 46 Hz, 1e-3 m/s² at 93 Hz)",
             "ISO 21940-11:2016 (balance quality grades, residual unbalance); Rao, Mechanical Vibrations (5th ed. "
             "2011) §3.11 (rotating unbalance); Brandt (2011) §13.7 (disturbances during impact tests)",
             "A steady periodic disturbance on the mover, not in step with the hits: a noted narrowband interference "
             "(not mains: 46 Hz is 8 % off 50 Hz) and parameters-only, or not explained, are right. Every term is "
             "wrong; a mains note is wrong.", seed=914, chain=fan_unbalance, physics=dict(FAN),
             exact=[["fan-unbalance"]], acceptable=[[]], must_not=everything,
             expected_quality=["narrowband lines at 46 and 93 Hz (floor-vibration kind), not mains"]),
        Case("floor-shocks", "rig",
             "a press in the next bay: in 5 of 16 records a ground-borne shock (6 ms half-sine, 0.15 m/s² at the base) "
             "arrives 0.08–0.7 s after the hit; the mover rings through the film's transmissibility",
             "Gordon, 'Generic vibration criteria for vibration-sensitive equipment', Proc. SPIE 1619 (1991); ISO "
             "10137:2007 (vibration from machinery in buildings); Brandt (2011) §13.7 (reject disturbed hits)",
             "Extra transients in some records, unrelated to the hammer: leaving those hits out (a note) and "
             "parameters-only, or not explained naming them, are right; every term (a step, a drift, an amplitude "
             "law) is wrong.", seed=915, chain=floor_shocks, physics=dict(SHOCK), exact=[["floor-shocks"]],
             acceptable=[[]], must_not=everything, expected_quality=["the shocked records named or left out"]),
        Case("pad-creep", "rig",
             "epoxy-bonded pads creep after the preload was applied just before the session: k (1 + 0.05 "
             "log10(1 + t/4 s)), c (1 + 0.025 log10(…)): k +1.5 % at the first hit, +5.7 % at the last (≈ 46 s), "
             "fast at first, slower later",
             "Findley, Lai & Onaran, Creep and Relaxation of Nonlinear Viscoelastic Materials (1976) ch. 2 "
             "(logarithmic creep); Slocum (1992) §8.5 (replicated and bonded bearing surfaces); Powell, Design of "
             "Aerostatic Bearings (1970) ch. 3 (stiffness against gap)",
             "A film that changes along the session, logarithmically: a drift term describes the trend (acceptable, "
             "and partial beside an honest rest), a step only partly. Not explained naming a trend is right. "
             "Amplitude, memory, mass and chain terms are wrong.", seed=916, per_hit_h=pad_creep,
             physics=dict(CREEP), exact=[["pad-creep"]], acceptable=[["drift"]], partial_ok=["drift", "step-change"],
             must_not=list(AMPLITUDE) + ["added-mass", "extra-mode"] + list(MEMORY) + chain_but()),
        # ------------------------------------------------------------------------------------- measurement
        Case("force-in-lbf", "measurement",
             "the exporter wrote the force in lbf (the channel table's US template) while the record says N (data type "
             "13): every force value ÷ 4.448, the FRF × 4.448",
             "NIST SP 811 (2008) App. B (1 lbf = 4.448 221 615 N); I-DEAS universal file data set 58 (ordinate "
             "units); Avitabile, Modal Testing (2017) ch. 5 (check calibrations and units before reading an FRF)",
             "A units error of the force channel: the level is 4.45× any mover of 25 kg. A level note and not "
             "explained, a refusal, or a force sensitivity error are right; any rig term (a mass a quarter of the "
             "told one is out of range) is wrong.", seed=921, export=force_in_lbf,
             physics={"force_scale": round(1 / LBF_IN_N, 6)}, exact=[["force-units"]],
             acceptable=[["sensitivity-error"]], refusal_ok=True, must_not=list(RIG) + chain_but("sensitivity-error"),
             expected_quality=["level: about 4.45× (lbf against N)"]),
        Case("iepe-slew-limit", "measurement",
             "the hammer on a conditioner with 1.03 mA of IEPE current and 330 m of cable (33 nF): the output falls no "
             "faster than 909 V/s (404 kN/s): the fall of every pulse above ≈ 130 N is stretched into a ramp, the "
             "force read carries up to ≈ 15 % more impulse late in the pulse",
             "PCB Piezotronics, 'Driving long cables' (IEPE technical note: f_max = 10⁹ (I_c − 1)/(2π C V)); Lally, "
             "'IEPE and ICP sensors' (PCB); McConnell & Varoto (2008) ch. 6",
             "A level-dependent distortion of the force channel: the lure is an amplitude term (friction, quadratic "
             "damping). Not explained is right; every term is wrong.", seed=922, chain=iepe_slew,
             physics=dict(SLEW), exact=[["iepe-slew-limit"]], acceptable=[], must_not=everything),
        Case("boxcar-smoothed-response", "measurement",
             "the logger's 'smoothing' left on for the response: a trailing 8-point running mean (delay 3.5 samples "
             "= 273 µs; |T| 0.976 and −19° at 196 Hz, 0.64 at 800 Hz, 0 at 1600 Hz)",
             "Smith, The Scientist and Engineer's Guide to DSP (1997) ch. 15 (moving average filters, response "
             "sin(πfM)/(M sin(πf))); Oppenheim & Schafer (2010) §5.1",
             "A low-pass FIR with a pure delay and nulls in band on one channel: a channel delay describes its phase "
             "only partly (the droop and the null are left); not explained is right. Rig terms, AC coupling, "
             "cross-talk, sensitivity are wrong.", seed=923, sampled=boxcar, physics=dict(BOXCAR),
             exact=[["boxcar-smoothing"]], partial_ok=["channel-delay"],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("gsm-buzz", "measurement",
             "a phone beside the accelerometer cable during records 4–9: GSM bursts (577 µs every 4.615 ms, 216.7 Hz "
             "and harmonics) rectified in the sensor's amplifier, 0.01 m/s² equivalent, phase random per record",
             "ETSI TS 145 002 (GSM TDMA frame 4.615 ms, 8 slots of 577 µs); Kitchin & Counts, 'Reducing RFI "
             "rectification errors in in-amp circuits' (Analog Devices AN-671, 2003); IEC 61000-4-3",
             "An additive interference train in some records, near the film's resonance: a note (interference, "
             "lines) and parameters-only, or not explained naming those records, are right. Every term, and a mains "
             "note, are wrong.", seed=924, chain=gsm_buzz, physics=dict(GSM), exact=[["gsm-buzz"]],
             acceptable=[[]], must_not=everything, expected_quality=["interference lines at 216.7 Hz × n in 4–9"]),
        Case("export-off-by-one", "measurement",
             "the exporter wrote each force record from one sample before its response record (an index off by one): "
             "the force is 78.1 µs late against the response",
             "Brandt (2011) §11.3 (time delay between channels: phase 360° f τ); IEEE Std 1057-2017 (channel-to-channel "
             "skew); Ewins (2000) §3.9",
             "A constant delay between the channels: channel-delay (response 78 µs early) is exact; rig terms, AC "
             "coupling, cross-talk, sensitivity are wrong.", seed=925, export=off_by_one,
             physics={"force_late_us": 78.125}, exact=[["channel-delay"]],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("stuck-adc-bit", "measurement",
             "bit 8 of the response channel's 24-bit word stuck at 1: every code whose bit 8 is 0 reads 256 LSB "
             "(0.0148 m/s²) high: a periodic, value-dependent error, half of all samples, also in the quiet parts",
             "IEEE Std 1241-2010 §4.1 (ADC faults: missing codes, stuck bits); Kester, The Data Conversion Handbook "
             "(Analog Devices 2005) ch. 5",
             "A deterministic nonlinearity of one channel's converter: no physics. Parameters-only (a quantisation or "
             "noise note is fine) or not explained are right; every term is wrong.", seed=926, sampled=stuck_bit,
             physics=dict(STUCK), exact=[["stuck-adc-bit"]], acceptable=[[]], must_not=everything),
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
    scale = 1 / 9.80665 if case.resp_unit == "g" else 1.0
    channels = (((0, 13, "N"), (1, 12, case.resp_unit)),)
    if case.write_order == "grouped":  # all forces, then all responses
        plan = [(hit, ch) for ch in channels[0] for hit in order]
    else:
        plan = [(hit, ch) for hit in order for ch in channels[0]]
    for hit, (row, dtype, unit) in plan:
        record, start = records[hit], float(starts[hit]) + case.time_offset_s
        values = record[row] * (scale if row == 1 else 1.0)
        values = np.asarray(values, dtype=float)
        sets.append(pyuff.prepare_58(
            binary=0 if case.ascii_single else 1, id1=f"{case.name} hit {hit + 1}", id2="redteam9 generator",
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
    parser.add_argument("--out", type=Path, default=Path("out/redteam9"))
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
