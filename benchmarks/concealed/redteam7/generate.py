"""Red-team world, round 7: thirteen further rig-physics and measurement faults plus five controls.

Written by a helper that has read neither ``analysis/``, ``app/``, ``drivers/`` nor ``tests/`` (only README.md, docs/,
the CLI's ``--help``, the paper and the earlier rounds' READMEs, keys, generators and scorers). Imports nothing from
gasfilm: numpy, scipy and pyuff only. The synthesis frame is round 6's, rewritten here with this round's hooks.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a half-sine
   of random peak and width starting at a random sub-sample instant);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance (per
   hit where it differs per hit: the coolant filling the mover, the operator's hand);
3. what the sensors and the wiring add on the analog signals (the hammer head's ringing and the loose gauge's
   compression on the force; the charge amplifier's short time constant and the amplifier's popcorn noise on the
   response), white sensor noise on both channels, the NI 9234's 0.5 Hz first-order AC coupling on both channels;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal), every
   8th analog point taken (in ``interpolated-response`` the response through the same design at half the rate, every
   16th point, then linearly interpolated), what the DAQ did to the sampled values (a 16-bit logger's mid-scale DNL,
   dither), quantisation (24 bit on +-5 V with the software's sensitivities unless the case says);
5. what the exporter did (a force window cut too short, records normalised by their impulse), then UFF 58 (per hit a
   force record, data type 13 "N", and an acceleration record, 12 "m/s^2"; each record's absolute session start in
   ``abscissa_min``; binary doubles).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam7/generate.py [--out out/redteam7] [--only CASE ...] [--keys-only]
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
LSB16_V = 20.0 / 2**16  # a 16-bit logger on +-10 V
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
    film: tuple = (K, C)  # the true film (k, c)
    extra_z: Callable | None = None  # s -> dynamic stiffness added to the SD film (N/m)
    per_hit_h: Callable | None = None  # (case, rng, s, drawn) -> (hits, nf) accelerance per hit
    peaks_fn: Callable | None = None  # (case, rng) -> (hits,) peak forces
    chain: Callable | None = None  # (case, rng, force, resp, t, drawn) -> (force, resp), analog, before noise
    sampled: Callable | None = None  # (case, rng, records, drawn) -> records, after sampling, before quantisation
    response_advance_s: float = 0.0  # the response sampled this much BEFORE its true time (negative: late)
    resp_rate_div: int = 1  # the response recorded at rate / div, then linearly interpolated to the rate
    quant_steps: tuple | None = None  # (force N, response m/s^2) per LSB; default 24 bit +-5 V
    export: Callable | None = None  # (case, records, starts, drawn) -> records, starts
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


def low_frequency_group_delay(sos, fine_hz: float, f_hz: float = 20.0) -> float:
    """The filter's group delay (s) at a low frequency, from the phase slope."""
    f = np.array([f_hz - 1.0, f_hz + 1.0])
    _, h = signal.sosfreqz(sos, worN=f, fs=fine_hz)
    phase = np.unwrap(np.angle(h))
    return float(-(phase[1] - phase[0]) / (2 * np.pi * (f[1] - f[0])))


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
    hit_times = 1.5 + np.cumsum(case.record_s + 1.0 + rng.uniform(0, 2.0, h))
    if case.peaks_fn is not None:
        peaks = case.peaks_fn(case, rng)
    else:
        peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(h)), 0.5 * case.force_n,
                        1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, h)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, h)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist(),
             "_t0": t0, "_widths": widths, "_peaks": peaks, "_hit_times": hit_times}
    force = half_sine(t, t0, widths, peaks)
    starts = hit_times - case.pretrigger_s
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    hh = case.per_hit_h(case, rng, s, drawn) if case.per_hit_h is not None else case_accelerance(case, s)[None, :]
    advance = case.response_advance_s
    if case.resp_rate_div > 1:
        # the response module's filter (same design at the lower rate) delays more: the logger removed the
        # difference of the two nominal (low-frequency) filter delays, i.e. the response is advanced by it
        slow = anti_aliasing(fs / case.resp_rate_div, fine)
        fast = anti_aliasing(fs)
        extra = low_frequency_group_delay(slow, fine) - low_frequency_group_delay(fast, fine)
        drawn["filter_delay_difference_removed_s"] = extra
        advance = advance + extra
    if advance:
        hh = hh * np.exp(s * advance)[None, :]
    resp = np.fft.irfft(np.fft.rfft(force, nfft, axis=1) * hh, nfft, axis=1)[:, :n]
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(resp[:, before]).max() / np.abs(resp).max())
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
    if case.resp_rate_div > 1:
        div = case.resp_rate_div
        slow = anti_aliasing(fs / div, fine)
        coarse = signal.sosfilt(slow, resp, axis=1)[:, lead::OVERSAMPLE * div]
        grid = np.arange(samples)
        at = np.arange(coarse.shape[1]) * div
        records[:, 1, :] = np.array([np.interp(grid, at, row) for row in coarse])
    else:
        records[:, 1, :] = signal.sosfilt(sos, resp, axis=1)[:, lead::OVERSAMPLE][:, :samples]
    if case.sampled is not None:
        records = case.sampled(case, rng, records, drawn)
    steps = case.quant_steps or (LSB_V / HAMMER_V_PER_N, LSB_V / ACCEL_V_PER_M_S2)
    for row, step in enumerate(steps):
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    if case.export is not None:
        records, starts = case.export(case, records, starts, drawn)
    return records, starts, drawn


def public(drawn: dict) -> dict:
    return {k: v for k, v in drawn.items() if not k.startswith("_")}


# ------------------------------------------------------------------------------------------------ case hooks

# rig --------------------------------------------------------------------------------------------------------

EDDY = {"k_magnet": -3.0e6, "c_eddy": 800.0, "tau_skin": 1.0e-3}


def eddy_preload(s):
    """Magnetic preload: the magnets' negative stiffness, and eddy currents in the mover's aluminium plate moving in the
    magnets' field: a damper whose field diffuses into the plate (skin effect), c_e s / sqrt(1 + s tau): a viscous
    damper at low frequency, a sqrt(s) law (45 degrees) above 1/(2 pi tau) = 160 Hz."""
    return EDDY["k_magnet"] + EDDY["c_eddy"] * s / np.sqrt(1 + s * EDDY["tau_skin"])


POCKET = {"delta_k": 1.2e6, "tau_thermal": 0.8e-3}


def pocket_thermal(s):
    """The recess air is isothermal at low frequency and adiabatic at high: its part of the film stiffness rises by
    (gamma - 1) = 40 % across the thermal relaxation, Z += dk s tau / (1 + s tau)."""
    return POCKET["delta_k"] * s * POCKET["tau_thermal"] / (1 + s * POCKET["tau_thermal"])


BELLOWS = {"k_lo": 1.12e6, "f_lo_hz": 1.0, "gamma": 0.1257, "mass_kg": 1.0}


def bellows_stiffness(s):
    """Rubber: near-constant loss factor (0.2) from a causal fractional law k_lo (1 + s / w_lo)^gamma."""
    return BELLOWS["k_lo"] * (1 + s / (2 * np.pi * BELLOWS["f_lo_hz"])) ** BELLOWS["gamma"]


def bellows(s):
    """A rubber bellows way cover between the mover and the base: a distributed spring (its convolutions) with mass,
    fixed at the base: Z = k(s) theta coth(theta), theta = s sqrt(m / k(s)); low frequency k + m s^2 / 3, the first
    surge resonance (the mover blocked) near 800 Hz."""
    k = bellows_stiffness(s)
    theta = s * np.sqrt(BELLOWS["mass_kg"] / k)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = k * theta / np.tanh(theta)
    return np.where(np.abs(s) > 0, z, k)


COOLANT = {"delta_mass_kg": 0.35, "tau_s": 25.0}


def coolant_filling(case, rng, s, drawn):
    """The coil's cooling channels fill as the chiller purges their air: the mover gains 0.35 kg (1 - e^{-t/25 s})
    from the first hit on; the film is unchanged."""
    t = drawn["_hit_times"] - drawn["_hit_times"][0]
    dm = COOLANT["delta_mass_kg"] * (1 - np.exp(-t / COOLANT["tau_s"]))
    drawn["mover_mass_kg"] = np.round(MASS + dm, 4).tolist()
    return np.stack([sd_accelerance(s, m=MASS + d) for d in dm])


HAND = {"c0": 40.0, "m1": 0.05, "k1": 4.0e4, "c1": 60.0, "m2": 0.8, "k2": 6.0e3, "c2": 120.0, "grip": (0.7, 1.3)}


def hand_impedance(s):
    """Hand-arm driving-point impedance (lumped, after ISO 10068's structure): skin damping, palm tissue (50 g on
    4e4 N/m, 60 N.s/m) and hand-forearm (0.8 kg on 6e3 N/m, 120 N.s/m) riding on the contact."""
    z = HAND["c0"] * s
    for m, k, c in ((HAND["m1"], HAND["k1"], HAND["c1"]), (HAND["m2"], HAND["k2"], HAND["c2"])):
        with np.errstate(divide="ignore", invalid="ignore"):
            z = z + np.nan_to_num(m * s**2 * (k + c * s) / (m * s**2 + c * s + k))
    return z


def hand_on_mover(case, rng, s, drawn):
    """The operator steadies the mover with the other hand during every hit; the grip varies per hit (x 0.7-1.3)."""
    grip = rng.uniform(*HAND["grip"], case.hits)
    drawn["grip_factor"] = np.round(grip, 4).tolist()
    zh = hand_impedance(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s[None, :]**2 / (K + C * s[None, :] + MASS * s[None, :]**2 + grip[:, None] * zh[None, :]))


# measurement ------------------------------------------------------------------------------------------------

RING = {"fraction": 0.04, "freq_hz": 950.0, "tau_s": 3.0e-3}


def hammer_ringing(case, rng, force, resp, t, drawn):
    """After contact the hammer head (loose on its handle) rings at 950 Hz: the gauge's front mass oscillates and the
    gauge reads it, but no force reaches the mover (the response is computed from the contact force only)."""
    t_end = drawn["_t0"] + drawn["_widths"]
    amp = RING["fraction"] * drawn["_peaks"] * rng.uniform(0.8, 1.2, case.hits)
    freq = RING["freq_hz"] * rng.uniform(0.99, 1.01, case.hits)
    u = t[None, :] - t_end[:, None]
    ring = np.where(u > 0, amp[:, None] * np.exp(-np.clip(u, 0, None) / RING["tau_s"])
                    * np.sin(2 * np.pi * freq[:, None] * np.clip(u, 0, None)), 0.0)
    drawn["ringing_amplitude_n"] = np.round(amp, 2).tolist()
    return force + ring, resp


GAUGE = {"beta_per_n": 1.4e-4}


def gauge_compression(case, rng, force, resp, t, drawn):
    """The hammer's preload stud worked loose: the quartz stack's output compresses, F_read = F (1 - beta F)."""
    return force * (1 - GAUGE["beta_per_n"] * force), resp


def level_spread_peaks(case, rng):
    return rng.uniform(60.0, 400.0, case.hits)


CHARGE = {"corner_hz": 4.0}


def charge_amp(case, rng, force, resp, t, drawn):
    """A charge amplifier between a charge-mode accelerometer and the module, its time constant on 'short':
    first-order high-pass at 4 Hz (tau 40 ms) on the response only, ahead of the module's own 0.5 Hz coupling."""
    fine = OVERSAMPLE * case.rate_hz
    sos = signal.butter(1, CHARGE["corner_hz"], btype="high", output="sos", fs=fine)
    return force, signal.sosfilt(sos, resp, axis=1)


POPCORN = {"level_m_s2": 0.02, "dwell_high_s": 0.04, "dwell_low_s": 0.06}


def popcorn(case, rng, force, resp, t, drawn):
    """Burst (popcorn) noise of the accelerometer's built-in amplifier: a random telegraph signal, 0 or +0.02 m/s^2,
    mean dwell 60 ms low and 40 ms high, in every record (quiet tails included), not locked to the hits."""
    out = resp.copy()
    switches = []
    for i in range(case.hits):
        state = rng.random() < POPCORN["dwell_high_s"] / (POPCORN["dwell_high_s"] + POPCORN["dwell_low_s"])
        now = t[0]
        level = np.zeros_like(t)
        count = 0
        while now < t[-1]:
            dwell = rng.exponential(POPCORN["dwell_high_s"] if state else POPCORN["dwell_low_s"])
            if state:
                level[(t >= now) & (t < now + dwell)] = POPCORN["level_m_s2"]
            now += dwell
            state = not state
            count += 1
        out[i] += level
        switches.append(count)
    drawn["telegraph_switches_per_record"] = switches
    return force, out


DNL = {"dead_lsb": 5.0, "input_noise_lsb": 0.8}


def midscale_dnl(case, rng, records, drawn):
    """A 16-bit SAR logger (+-10 V) whose mid-scale (major-carry) transition is 10 LSB wide: inputs within +-5.5 LSB
    of zero read 0, beyond they read 5 LSB closer to zero (a dead band), on both channels; its input noise 0.8 LSB."""
    out = records.copy()
    for row, sens in enumerate((HAMMER_V_PER_N, ACCEL_V_PER_M_S2)):
        v = records[:, row] * sens + DNL["input_noise_lsb"] * LSB16_V * rng.standard_normal(records[:, row].shape)
        dead = DNL["dead_lsb"] * LSB16_V
        v = np.sign(v) * np.maximum(np.abs(v) - dead, 0.0)
        out[:, row] = v / sens
    drawn["zero_fraction_response"] = float(np.mean(out[:, 1] == 0.0))
    return out


def tpdf_dither(case, rng, records, drawn):
    """A 16-bit logger (+-10 V) with triangular (TPDF) dither of +-1 LSB added before its quantiser."""
    out = records.copy()
    for row, sens in enumerate((HAMMER_V_PER_N, ACCEL_V_PER_M_S2)):
        lsb = LSB16_V / sens
        out[:, row] += lsb * (rng.uniform(-0.5, 0.5, out[:, row].shape) + rng.uniform(-0.5, 0.5, out[:, row].shape))
    return out


QUANT16 = (LSB16_V / HAMMER_V_PER_N, LSB16_V / ACCEL_V_PER_M_S2)

WINDOW = {"before_ms": 0.3, "open_ms": 0.6, "taper_ms": 0.15}


def short_force_window(case, records, starts, drawn):
    """The exporter's force window, set for a hard tip: open from 0.3 ms before the trigger (first sample above 5 %
    of the peak) to 0.6 ms after it, then a 0.15 ms half-cosine to zero; the response is left as it is. With this
    1 ms tip the window closes inside the pulse: the pulse's last third (18-25 % of its impulse) is not in the file."""
    fs = case.rate_hz
    out = records.copy()
    t = np.arange(records.shape[2]) / fs
    cut = []
    for i in range(records.shape[0]):
        f = records[i, 0]
        trig = np.argmax(f > 0.05 * f.max()) / fs
        lo, hi = trig - WINDOW["before_ms"] * 1e-3, trig + WINDOW["open_ms"] * 1e-3
        taper = WINDOW["taper_ms"] * 1e-3
        w = np.where((t >= lo) & (t <= hi), 1.0, 0.0)
        tail = (t > hi) & (t < hi + taper)
        w[tail] = 0.5 * (1 + np.cos(np.pi * (t[tail] - hi) / taper))
        pulse = (t >= lo) & (t <= trig + 3 * case.pulse_ms * 1e-3)
        cut.append(float(1 - (f * w)[pulse].sum() / f[pulse].sum()))
        out[i, 0] = f * w
    drawn["impulse_fraction_cut"] = np.round(cut, 4).tolist()
    return out, starts


def impulse_normalised(case, records, starts, drawn):
    """The exporter divided both channels of every hit by that hit's force impulse (N.s): 'unit-impulse records'."""
    fs = case.rate_hz
    lo, hi = int((case.pretrigger_s - 1e-3) * fs), int((case.pretrigger_s + 3 * case.pulse_ms * 1e-3) * fs)
    impulse = records[:, 0, lo:hi].sum(axis=1) / fs
    drawn["impulse_n_s"] = np.round(impulse, 6).tolist()
    return records / impulse[:, None, None], starts


# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    everything = list(EVERYTHING)
    control_quality = ["mains", "clip", "double"]
    chain_but = lambda *kept: without(CHAIN, *kept) + ["window-damping"]  # noqa: E731
    listed = [
        # ---------------------------------------------------------------------------------------- controls
        Case("control-17k07", "control",
             "the module at 51.2 kS/s / 3 = 17 066.7 S/s (a rate that is no round number), 0.6 s records "
             "(10 240 samples), 8 ms pre-trigger, 12 hits; linear film",
             "NI 9234 data sheet (f_s = 51.2 kS/s / n, n = 1 … 31)",
             "A legal module rate whose sample interval is not a round number: nothing to claim.", seed=701,
             rate_hz=51200.0 / 3, record_s=0.6, pretrigger_s=0.008, hits=12, must_not=everything,
             must_not_quality=control_quality, physics={"rate_divisor": 3}),
        Case("control-heavy-hits", "control",
             "10 heavy hits, 600 N ± 10 % (1.35 V of the ±5 V range), 2 s records; linear film; `--rig` nominal",
             "ISO 7626-5 (impact excitation; level within the transducers' ranges); PCB 086C03 data sheet (±2200 N)",
             "A linear film hit hard: the FRF is the same; no amplitude term.", seed=702, cli="rig", hits=10,
             record_s=2.0, force_n=600.0, spread=0.1, must_not=everything, must_not_quality=control_quality),
        Case("control-soft-tip", "control",
             "a soft rubber tip: 2.5 ms pulses at 40 N ± 20 %, 24 hits, 0.5 s records; the hammer band ends near "
             "450 Hz; linear film",
             "PCB impact hammer tip charts (rubber/vinyl tips: bandwidth ≈ 0.5 kHz); Brandt (2011) §13.7",
             "A narrower hammer band and light hits on a linear film: only the band changes.", seed=703,
             pulse_ms=2.5, force_n=40.0, hits=24, record_s=0.5, must_not=everything,
             must_not_quality=control_quality),
        Case("control-dithered-16bit", "control",
             "recorded by a 16-bit logger on ±10 V (0.136 N and 0.030 m/s² per step) with triangular dither of "
             "±1 LSB before its quantiser: the quantisation error is white, 0.5 LSB RMS; linear film",
             "Wannamaker, Lipshitz & Vanderkooy, J. Audio Eng. Soc. 48 (2000) (subtractive and non-subtractive "
             "dither); Widrow & Kollár, Quantization Noise (2008) ch. 19",
             "Dither makes the quantiser's error white and independent of the signal: it is noise, not physics "
             "(a quantiser replayed as deterministic would be wrong here, but nothing is to be claimed).",
             seed=704, sampled=tpdf_dither, quant_steps=QUANT16, must_not=everything,
             must_not_quality=control_quality, physics={"bits": 16, "range_v": 10.0, "dither": "TPDF ±1 LSB"}),
        Case("control-impulse-normalised", "control",
             "the exporter divided both channels of every hit by that hit's force impulse ('unit-impulse "
             "records'): force peaks ≈ 1 570 'N', every hit scaled differently, the FRF of each hit unchanged; "
             "linear film",
             "Ewins (2000) §4.3 (FRF estimates are ratios: a common scale of both channels cancels); Brandt (2011) "
             "§13.7",
             "Both channels of a hit scaled alike: every hit's FRF and coherence are unchanged. Nothing to claim.",
             seed=705, export=impulse_normalised, must_not=everything, must_not_quality=control_quality),
        # ---------------------------------------------------------------------------------------------- rig
        Case("eddy-current-preload", "rig",
             "magnetically preloaded bearing: the magnets' negative stiffness −3e6 N/m (film 4.1e7, static "
             "3.8e7) and eddy currents in the mover's aluminium plate with skin effect, Z += c_e s/√(1 + sτ), "
             "c_e 800 N·s/m, τ 1 ms: added damping 770 N·s/m at 50 Hz, 570 at 196 Hz, 240 at 1 kHz, stiffness "
             "rising as √f (+3.4e5 N/m at 196 Hz, +1.3e6 at 1 kHz)",
             "Ro, Kim, Kwak & Park, Precision Engineering 34 (2010) 186 (air bearing stage with magnetic preload); "
             "Sodano & Bae, Shock Vib. Digest 36 (2004) 469 (eddy-current damping); Lammeraner & Štafl, Eddy "
             "Currents (1964) (field diffusion, skin depth)",
             "A linear frequency-dependent damper beside the film (a diffusion, √s, law): film-memory (fractional "
             "order) or squeeze-film (also a √s diffusion) are fair descriptions; a pneumatic lag has the opposite "
             "damping trend (false). Mass, mode, amplitude, time or chain terms are wrong.", seed=711,
             film=(4.1e7, C), extra_z=eddy_preload, physics={"film_k_n_per_m": 4.1e7} | EDDY,
             exact=[["eddy-current-preload"]], acceptable=[["film-memory"], ["squeeze-film"]],
             must_not=without(RIG, *MEMORY) + chain_but()),
        Case("pocket-thermal-relaxation", "rig",
             "the recess air (150 µm deep) is isothermal below and adiabatic above its thermal relaxation: its "
             "share of the film stiffness rises by γ − 1 = 40 %, Z += Δk sτ/(1 + sτ), Δk 1.2e6 N/m, τ 0.8 ms: "
             "+900 N·s/m at 50 Hz, +490 N·s/m and +5.9e5 N/m at 196 Hz, +36 N·s/m at 1 kHz",
             "Kornhauser & Smith, J. Heat Transfer 116 (1994) 536 (gas-spring heat transfer, complex Nusselt "
             "number); Powell, Design of Aerostatic Bearings (1970) ch. 2 (recess compressibility, polytropic "
             "exponent)",
             "A Maxwell (standard linear solid) branch beside the film: film-memory with α ≈ 1 is its exact law; "
             "squeeze-film has the same trends (stiffness up, damping down with frequency). A pneumatic lag "
             "(damping lowered) has the opposite trend: false. Mass, mode, amplitude, time, chain terms are wrong.",
             seed=712, extra_z=pocket_thermal, physics=dict(POCKET), exact=[["pocket-thermal-relaxation"]],
             acceptable=[["film-memory"], ["squeeze-film"]], must_not=without(RIG, *MEMORY) + chain_but()),
        Case("bellows-cover", "rig",
             "a rubber bellows way cover (1.0 kg) between the mover and the base: a distributed lossy spring "
             "(|k| 2e6 N/m at 100 Hz, loss factor 0.2, rising as f^0.126) with mass: below its surge resonance "
             "k + m s²/3 (+0.33 kg, +1130 N·s/m of hysteretic damping at 50 Hz, +350 at 196 Hz), the mover "
             "blocked near 800 Hz (its first surge mode)",
             "Slocum, Precision Machine Design (1992) §7 (way covers and bellows); Wahl, Mechanical Springs (1963) "
             "ch. 25 (surge); Nashif, Jones & Henderson, Vibration Damping (1985) ch. 3 (constant loss factor)",
             "A distributed lossy spring-mass beside the film: its hysteretic damping is a fractional film-memory "
             "(or squeeze-film) law, its moving third an added mass, its surge a mode riding on the mover (an "
             "extra mode near 800 Hz); any of these, alone or together, is a fair (partial) description. Chain, "
             "amplitude and time terms are wrong.", seed=713, extra_z=bellows, physics=dict(BELLOWS),
             exact=[["bellows-cover"]],
             acceptable=[["film-memory"], ["squeeze-film"], ["added-mass"], ["extra-mode"],
                         ["film-memory", "added-mass"], ["film-memory", "extra-mode"], ["squeeze-film", "added-mass"],
                         ["squeeze-film", "extra-mode"], ["added-mass", "extra-mode"],
                         ["film-memory", "added-mass", "extra-mode"], ["squeeze-film", "added-mass", "extra-mode"]],
             needs_alternative={"added-mass": "sensitivity-error"},
             must_not=list(AMPLITUDE) + list(TIME) + chain_but("sensitivity-error")),
        Case("coolant-filling", "rig",
             "the linear motor's cooling channels fill as the chiller purges their air during the session: the "
             "mover gains 0.35 kg × (1 − e^{−t/25 s}) from the first hit on (told 25.05 kg, the dry mass): "
             "+0.30 kg by the last hit (resonance −0.6 %, mass line −1.2 %); the film is unchanged",
             "Gieras, Piech & Tomczuk, Linear Synchronous Motors (2011) ch. 7 (water-cooled armatures); Ewins "
             "(2000) §2.3 (mass line)",
             "The moving mass drifts, not the film: the catalogue's drift (film × (1 + a t)) matches the resonance "
             "but not the mass line, an added mass matches the mean: both only partial. Not explained is honest. "
             "Memory, mode, amplitude or chain terms are wrong.", seed=714, per_hit_h=coolant_filling,
             physics=dict(COOLANT), exact=[["coolant-filling"]], partial_ok=["drift", "added-mass"],
             must_not=list(MEMORY) + ["extra-mode"] + list(AMPLITUDE) + chain_but("sensitivity-error")),
        Case("hand-on-mover", "rig",
             "the operator steadies the mover with the other hand during every hit: a hand-arm impedance beside "
             "the film (≈ 210 N·s/m at 196 Hz, +6 % damping, small mass), the grip ×0.7–1.3 per hit",
             "ISO 10068:2012 (mechanical impedance of the human hand-arm system at the driving point); Dong, Welcome "
             "& Wu, J. Biomech. 38 (2005) (hand-arm impedance)",
             "A damping, mostly, that differs per hit: parameters-only (the rig's damping recalibrated) is fair, "
             "an extra mode (the hand's masses ride on the contact) too; film-memory or squeeze-film only as partial "
             "descriptions. Amplitude, time (no trend: the grip is random), chain terms are wrong.", seed=715,
             per_hit_h=hand_on_mover, subtle=True, physics={k: v for k, v in HAND.items()},
             exact=[["hand-on-mover"]], acceptable=[[], ["extra-mode"]], partial_ok=["film-memory", "squeeze-film"],
             must_not=list(AMPLITUDE) + list(TIME) + chain_but()),
        # ------------------------------------------------------------------------------------- measurement
        Case("adc-midscale-dnl", "measurement",
             "both channels recorded by a 16-bit SAR logger (±10 V) whose mid-scale major-carry transition is "
             "10 LSB wide: inputs within ±5.5 LSB (±1.7 mV: 0.75 N, 0.16 m/s²) read 0, larger ones 5 LSB closer "
             "to zero: a dead band, so the ringing ends early and the quiet tails are exact zeros",
             "Kester (ed.), Data Conversion Handbook (Analog Devices 2005) §2.4 (DNL, missing codes at the major "
             "carry); IEEE Std 1241-2010 (ADC terminology and test methods)",
             "A static nonlinearity of the recorder: the ringing loses a constant amount, as Coulomb friction "
             "would make the rig do (friction is the lure, and wrong); nothing is physics. Not explained, a "
             "refusal, or parameters-only are right; every term is wrong.", seed=721, sampled=midscale_dnl,
             quant_steps=QUANT16, physics=dict(DNL) | {"bits": 16, "range_v": 10.0},
             exact=[["adc-midscale-dnl"]], acceptable=[[]], must_not=everything, refusal_ok=True),
        Case("hammer-head-ringing", "measurement",
             "the hammer's head sits loose on its handle and rings at 950 Hz after each contact (4 % of the peak, "
             "τ 3 ms): the gauge reads it, the mover never gets it; the force spectrum carries a ±25 % ripple "
             "around 950 Hz that the response lacks: the FRF reads +17 % at 900 Hz, −12 % at 1 kHz",
             "McConnell & Varoto, Vibration Testing (2nd ed. 2008) ch. 6 (impact hammer dynamics, what the gauge "
             "reads); PCB Piezotronics impact hammer manuals (hammer ringing, tip selection); Brandt (2011) §13.7",
             "A force-channel artefact: a peak/dip near 950 Hz in the FRF that is not the rig's. An extra mode is "
             "the lure (wrong). Not explained, parameters-only or a note are right; every term is wrong.",
             seed=722, chain=hammer_ringing, physics=dict(RING), exact=[["hammer-head-ringing"]],
             acceptable=[[]], must_not=everything),
        Case("force-gauge-nonlinearity", "measurement",
             "the hammer's preload stud worked loose: its quartz stack reads F(1 − 1.4e-4 F): −0.8 % at 60 N, "
             "−5.6 % at 400 N; hits 60–400 N (uniform), so the FRF reads +0.7 … +4.4 % high, growing with the "
             "hit level",
             "Gautschi, Piezoelectric Sensorics (2002) §5 (preload of quartz force sensors and linearity); Kistler, "
             "'Mounting of force sensors' (preload); ISO 376 (force-measuring instruments)",
             "A level-dependent gain of the force channel: the FRF moves with the hit level as a rig nonlinearity "
             "would (friction, quadratic damping, a cubic spring are the lures, wrong). A sensitivity error (or "
             "the equivalent added mass with it as alternative) describes the mean; not explained is honest.",
             seed=723, chain=gauge_compression, peaks_fn=level_spread_peaks, subtle=True,
             physics=dict(GAUGE) | {"force_range_n": [60.0, 400.0]}, exact=[["force-gauge-nonlinearity"]],
             acceptable=[[], ["sensitivity-error"], ["added-mass"]],
             needs_alternative={"added-mass": "sensitivity-error"},
             must_not=without(RIG, "added-mass") + chain_but("sensitivity-error")),
        Case("interpolated-response", "measurement",
             "the response came from a second module at 6.4 kS/s (51.2k/8, its own filter at 2.69 kHz); the "
             "logger removed the two filters' nominal delays and linearly interpolated it to 12.8 kS/s to merge "
             "the streams: |H| × (1 + cos ωT)/2, −1.5 % at 500 Hz, −5.8 % at 1 kHz, and the slower filter's "
             "phase left beyond its nominal delay (−0.5° at 500 Hz, −5.7° at 1 kHz)",
             "Crochiere & Rabiner, Multirate Digital Signal Processing (1983) §2.3, §4 (interpolation filters); "
             "NI, 'Synchronizing DSA devices: filter delay' (NI KB)",
             "A droop of the response rising as f² with a little phase: an extra mode above the band or an added "
             "mass are the lures (wrong); a channel delay describes the phase only (partial). Not explained or "
             "parameters-only are right; rig terms, AC coupling, cross-talk are wrong.", seed=724, resp_rate_div=2,
             physics={"response_rate_hz": 6400.0}, exact=[["interpolated-response"]], acceptable=[[]],
             partial_ok=["channel-delay"],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "polarity", "window-damping"]),
        Case("filter-delay-mismatch", "measurement",
             "force and response on two DSA modules of different types whose digital filters' delays differ by a "
             "fraction of a sample that the whole-sample alignment leaves: the response is 43 µs (0.55 sample) "
             "late, phase −15° at 1 kHz",
             "NI, 'Synchronizing DSA devices: filter delay' (NI KB); Brandt (2011) §11 (channel timing errors)",
             "A pure delay of the response: channel-delay (+43 µs on the response) is exact. Rig terms, AC "
             "coupling, cross-talk, sensitivity are wrong.", seed=725, response_advance_s=-43e-6,
             physics={"delay_s": 43e-6}, exact=[["channel-delay"]],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("charge-amp-short-tc", "measurement",
             "a charge-mode accelerometer through a charge amplifier whose time constant is on 'short': a "
             "first-order high-pass at 4 Hz on the response only (−2.0 % and +11° at 20 Hz, +4.6° at 50 Hz)",
             "Kistler charge amplifier 5015/5018 manuals (time constant short/medium/long); Serridge & Licht, "
             "Piezoelectric Accelerometer and Vibration Preamplifier Handbook (B&K 1987) §5 (lower limiting "
             "frequency)",
             "A first-order high-pass on the response: ac-coupling (f_c 4 Hz, response) is exact. Rig terms, "
             "delay, cross-talk, sensitivity are wrong.", seed=726, chain=charge_amp, physics=dict(CHARGE),
             exact=[["ac-coupling"]],
             must_not=list(RIG) + ["channel-delay", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("force-window-cut", "measurement",
             "the exporter's force window was set for a hard tip: open 0.3 ms before to 0.6 ms after the trigger "
             "plus a 0.15 ms taper; with this 1 ms tip it closes inside the pulse: 18–25 % of each impulse is "
             "missing from the force record (FRF ≈ +26 % at low frequency, frequency-dependent); response "
             "untouched",
             "Fladung & Rost, MSSP 11 (1997) 23 (force and exponential windows); Brandt (2011) §13.7 (force window "
             "length); Avitabile (2017) ch. 5",
             "The force record is not the force: a refusal or not explained is right; a sensitivity error only as "
             "a partial description; every rig term (a lighter mass included) is wrong.", seed=727,
             export=short_force_window, physics=dict(WINDOW), exact=[["force-window-cut"]],
             partial_ok=["sensitivity-error"], must_not=without(EVERYTHING, "sensitivity-error"), refusal_ok=True),
        Case("popcorn-noise", "measurement",
             "burst (popcorn) noise of the accelerometer's built-in amplifier: a random telegraph signal between 0 "
             "and +0.02 m/s², dwelling 60 ms low and 40 ms high on average, in every record and not locked to "
             "the hits: noise far above the white floor below ≈ 10 Hz (… ∝ 1/f² above)",
             "Kogan, Electronic Noise and Fluctuations in Solids (1996) ch. 8 (random telegraph noise); "
             "Motchenbacher & Connelly, Low-Noise Electronic System Design (1993) §1.7 (burst noise)",
             "Non-Gaussian, low-frequency noise, the same in the tails as during the hits: no physics. Parameters-"
             "only or not explained are right; every term is wrong.", seed=728, chain=popcorn,
             physics=dict(POPCORN), exact=[["popcorn-noise"]], acceptable=[[]], must_not=everything),
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


def write_uff(path: Path, records: np.ndarray, starts: np.ndarray, case: Case) -> None:
    sets = []
    dt = 1.0 / case.rate_hz
    for hit, (record, start) in enumerate(zip(records, starts)):
        start = float(start)
        for values, dtype, unit in ((record[0], 13, "N"), (record[1], 12, "m/s^2")):
            values = np.asarray(values, dtype=float)
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"{case.name} hit {hit + 1}", id2="redteam7 generator", id3="", id4="", id5="",
                func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, ord_data_type=4,
                abscissa_spacing=1, abscissa_min=start, abscissa_inc=dt, abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s", ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="NONE", data=values, x=start + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add", force_double=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam7"))
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
        write_uff(args.out / f"{case.name}.uff", records, starts, case)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(public(drawn), indent=1))
        print(f"{case.name:28s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak |a| "
              f"{np.abs(records[:, 1]).max():.3g}, peak |F| {np.abs(records[:, 0]).max():.0f}, acausal "
              f"{drawn['acausal_fraction']:.1e}")
    if not args.keys_only:
        print(f"total {time.perf_counter() - began_all:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
