"""Red-team world, round 6: twelve further rig-physics and measurement faults plus five controls.

Written by a helper that has read neither ``analysis/``, ``app/``, ``drivers/`` nor ``tests/`` (only README.md, docs/,
the CLI's ``--help``, the paper and the earlier rounds' READMEs, keys, generators and scorers). Imports nothing from
gasfilm: numpy, scipy and pyuff only; the synthesis below is this round's own code (its frame follows round 5's).

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the measured contact force of every hit (a half-sine
   of random peak and width starting at a random sub-sample instant; in ``overlapping-records`` the record also holds
   the NEXT hit's pulse);
2. the mover's acceleration: the exact product of the zero-padded force spectrum with the case's accelerance (per
   hit where it differs per hit); the displacement instead where the response sensor is a displacement probe;
3. the sensor's and the wiring's additions on the analog signals (capacitive cross-talk, multiplexer ghosting),
   white sensor noise on both channels, the NI 9234's 0.5 Hz first-order AC coupling on both channels;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal),
   every 8th analog point taken (the response 14 us later in ``multiplexed-daq``), what the module's cabling did to
   the sampled values (swapped cables), quantisation (24 bit on +-5 V with the sensitivities the software used;
   16 bit on the multiplexed card's ranges);
5. what the exporter did (differentiation, zero-phase high-pass, wavelet denoising, Hann window), then UFF 58 (per
   hit a force record, data type 13 "N", and an acceleration record, 12 "m/s^2"; each record's absolute start in
   ``abscissa_min`` unless the case says; double precision unless the case says).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file).

    python benchmarks/concealed/redteam6/generate.py [--out out/redteam6] [--only CASE ...] [--keys-only]
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
CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error", "polarity")
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
    film: tuple = (K, C)  # the true film (k, c)
    extra_z: Callable | None = None  # s -> dynamic stiffness added to the SD film (N/m)
    accelerance: Callable | None = None  # (case, s) -> the whole accelerance (replaces the film's)
    per_hit_h: Callable | None = None  # (case, rng, s, drawn) -> (hits, nf) accelerance per hit
    peaks_fn: Callable | None = None  # (case, rng) -> (hits,) peak forces
    overlap: bool = False  # each record also holds the next hit (continuous hitting)
    displacement: bool = False  # the response sensor measures displacement (the accelerance / s^2)
    chain: Callable | None = None  # (case, rng, force, resp, t, drawn) -> (force, resp), analog, before noise
    sampled: Callable | None = None  # (case, rng, records, drawn) -> records, after sampling, before quantisation
    response_advance_s: float = 0.0  # the response sampled this much after the force (multiplexer skew)
    accel_noise: float = ACCEL_NOISE
    quant_steps: tuple | None = None  # (force N, response unit) per LSB; default 24 bit +-5 V
    resp_v_per_unit: float = ACCEL_V_PER_M_S2
    export: Callable | None = None  # (case, records, starts, drawn) -> records, starts
    abscissa: str = "session"  # session | trigger (-pretrigger in every record)
    ord_data_type: int = 4  # 4 double, 2 single
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
    if case.accelerance is not None:
        return case.accelerance(case, s)
    k, c = case.film
    z = k + c * s
    if case.extra_z is not None:
        z = z + case.extra_z(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (z + MASS * s**2))


def ac_coupling(s: np.ndarray) -> np.ndarray:
    return s / (s + 2 * np.pi * AC_CORNER_HZ)


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
    drawn_hits = case.hits + 1 if case.overlap else case.hits
    if case.overlap:
        gaps = rng.uniform(0.90, 0.95, drawn_hits - 1)
        hit_times = 3.0 + np.concatenate(([0.0], np.cumsum(gaps)))
    else:
        hit_times = 1.5 + np.cumsum(case.record_s + 1.0 + rng.uniform(0, 2.0, drawn_hits))
    if case.peaks_fn is not None:
        peaks = case.peaks_fn(case, rng)
    else:
        peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(drawn_hits)),
                        0.5 * case.force_n, 1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, drawn_hits)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, drawn_hits)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist()}
    h = case.hits
    force = half_sine(t, t0[:h], widths[:h], peaks[:h])
    if case.overlap:
        # the next hit lands inside this record, gap_i after this one (sub-sample start of its own)
        second = t0[:h] + (hit_times[1:] - hit_times[:-1])
        force = force + half_sine(t, second, widths[1:], peaks[1:])
        drawn["next_hit_in_record_at_s"] = np.round(second, 4).tolist()
    starts = hit_times[:h] - case.pretrigger_s
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    hh = case.per_hit_h(case, rng, s, drawn) if case.per_hit_h is not None else case_accelerance(case, s)[None, :]
    if case.response_advance_s:
        hh = hh * np.exp(s * case.response_advance_s)[None, :]
    if case.displacement:
        with np.errstate(divide="ignore", invalid="ignore"):
            hh = hh / np.where(s == 0, 1.0, s**2)[None, :]
        hh[:, 0] = hh[:, 1].real  # the receptance's static value (1/k), not the accelerance's 0
    resp = np.fft.irfft(np.fft.rfft(force, nfft, axis=1) * hh, nfft, axis=1)[:, :n]
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(resp[:, before]).max() / np.abs(resp).max())
    if case.chain is not None:
        force, resp = case.chain(case, rng, force, resp, t, drawn)
    level = 1.0 if noise else 0.0
    force = force + level * FORCE_NOISE * np.sqrt(fine / 2) * rng.standard_normal(force.shape)
    resp = resp + level * case.accel_noise * np.sqrt(fine / 2) * rng.standard_normal(resp.shape)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    force = signal.sosfilt(hp, force, axis=1)
    resp = signal.sosfilt(hp, resp, axis=1)
    records = np.empty((case.hits, 2, samples))
    sos = anti_aliasing(fs)
    for row, channel in enumerate((force, resp)):
        filtered = signal.sosfilt(sos, channel, axis=1)
        records[:, row, :] = filtered[:, lead::OVERSAMPLE][:, :samples]
    if case.sampled is not None:
        records = case.sampled(case, rng, records, drawn)
    steps = case.quant_steps or (LSB_V / HAMMER_V_PER_N, LSB_V / case.resp_v_per_unit)
    for row, step in enumerate(steps):
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    if case.export is not None:
        records, starts = case.export(case, records, starts, drawn)
    return records, starts, drawn


# ------------------------------------------------------------------------------------------------ case hooks

def transport_delay(s):
    """Orifice-to-film transport delay: part of the film's pressure force follows the gap T late, Z += k_d e^{-sT}
    (k_d 4e5 N/m, T 1.0 ms): negative damping -k_d sin(wT)/w below 500 Hz (-8.7 % of c at 196 Hz), positive above."""
    return 4.0e5 * np.exp(-s * 1.0e-3)


def soft_payload_accelerance(case, s):
    """A 2.0 kg electronics box on elastomer feet (11 Hz, zeta 0.1) on the mover; the told 25.05 kg includes it."""
    mp, fp, zp = 2.0, 11.0, 0.1
    wp = 2 * np.pi * fp
    kp = mp * wp**2 + 2 * zp * mp * wp * s
    z_payload = mp * s**2 * kp / (mp * s**2 + kp)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (K + C * s + (MASS - mp) * s**2 + z_payload))


def twin_carriage_accelerance(case, s):
    """Gantry: the hit carriage A (25.05 kg, the film) is tied by the bridge's axial flexure (2e6 N/m, 60 N.s/m) to
    carriage B on the parallel rail (25.0 kg on its own film 4.15e7 N/m, 3.5e3 N.s/m: 205 Hz alone)."""
    kc = 2.0e6 + 60.0 * s
    zb = 4.15e7 + 3.5e3 * s + 25.0 * s**2
    z = K + C * s + kc - kc**2 / (kc + zb)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(s**2 / (z + MASS * s**2))


def two_sided(case, rng, s, drawn):
    """Hits 11-16 from the mover's other face: the gauge still reads compression (+), the mover goes the other way."""
    sign = np.where(np.arange(case.hits) >= 10, -1.0, 1.0)
    drawn["response_sign"] = sign.tolist()
    return sign[:, None] * sd_accelerance(s)[None, :]


def capacitive_crosstalk(case, rng, force, resp, t, drawn):
    """8 pF between the hammer's and the accelerometer's unshielded adapter leads into the module's 305 kOhm input: the response
    channel carries R C dV_F/dt, i.e. l dF/dt with l = R C (2.25/10.2) = 5.4e-7 (m/s^2)/(N/s)."""
    leak = 305e3 * 8e-12 * HAMMER_V_PER_N / ACCEL_V_PER_M_S2
    drawn["leak_m_s2_per_n_per_s"] = leak
    return force, resp + leak * np.gradient(force, t, axis=1)


def multiplexer_ghost(case, rng, force, resp, t, drawn):
    """Multiplexed card: the response sample still holds 0.5 % of the force channel's voltage (ghosting after the
    channel switch and range change)."""
    ghost = 0.005 * HAMMER_V_PER_N / ACCEL_V_PER_M_S2
    drawn["ghost_m_s2_per_n"] = ghost
    return force, resp + ghost * force


def swap_cables(case, rng, records, drawn):
    """The two BNC cables swapped at the module: the force channel (2.25 mV/N in the software) holds the
    accelerometer's voltage, the acceleration channel (10.2 mV/(m/s^2)) the hammer's."""
    out = np.empty_like(records)
    out[:, 0] = records[:, 1] * ACCEL_V_PER_M_S2 / HAMMER_V_PER_N
    out[:, 1] = records[:, 0] * HAMMER_V_PER_N / ACCEL_V_PER_M_S2
    return out


def differentiate_export(case, records, starts, drawn):
    """The exporter turned the probe's displacement into an acceleration by two backward differences:
    a[n] = (x[n] - 2 x[n-1] + x[n-2]) / T^2 (the first two samples repeat the third)."""
    dt = 1.0 / case.rate_hz
    x = records[:, 1]
    a = np.empty_like(x)
    a[:, 2:] = (x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]) / dt**2
    a[:, :2] = a[:, 2:3]
    out = records.copy()
    out[:, 1] = a
    return out, starts


def zero_phase_highpass_export(case, records, starts, drawn):
    """The exporting script 'removed the drift' from the response: scipy.signal.filtfilt with a 2nd-order 10 Hz
    Butterworth high-pass (zero phase: |T|^2, no phase, non-causal), response channel only."""
    sos = signal.butter(2, 10.0, btype="high", output="sos", fs=case.rate_hz)
    out = records.copy()
    out[:, 1] = signal.sosfiltfilt(sos, records[:, 1], axis=1)
    return out, starts


def haar_denoise(x: np.ndarray) -> np.ndarray:
    """Haar wavelet soft-threshold denoising (Donoho's universal threshold sigma sqrt(2 ln N), sigma from the MAD of
    the finest details), as far as the length halves evenly."""
    n = x.size
    approx, details = x.copy(), []
    while approx.size % 2 == 0 and approx.size >= 8:
        a = (approx[0::2] + approx[1::2]) / np.sqrt(2)
        d = (approx[0::2] - approx[1::2]) / np.sqrt(2)
        details.append(d)
        approx = a
    sigma = np.median(np.abs(details[0])) / 0.6745
    thr = sigma * np.sqrt(2 * np.log(n))
    details = [np.sign(d) * np.maximum(np.abs(d) - thr, 0.0) for d in details]
    for d in reversed(details):
        up = np.empty(2 * approx.size)
        up[0::2] = (approx + d) / np.sqrt(2)
        up[1::2] = (approx - d) / np.sqrt(2)
        approx = up
    return approx


def denoise_export(case, records, starts, drawn):
    """The logger's export option 'denoise' (Haar wavelet soft thresholding, universal threshold) on both channels."""
    out = records.copy()
    for i in range(out.shape[0]):
        for ch in range(2):
            out[i, ch] = haar_denoise(records[i, ch])
    return out, starts


def hann_export(case, records, starts, drawn):
    """The exporting script multiplied both channels of every record by a Hann window (periodic, record length)."""
    w = signal.windows.hann(records.shape[2], sym=False)
    return records * w[None, None, :], starts


def two_level_peaks(case, rng):
    """Alternating light and heavy hits (ISO 7626-5 linearity check): 60 N and 350 N, +-5 %."""
    base = np.where(np.arange(case.hits) % 2 == 0, 60.0, 350.0)
    return base * rng.uniform(0.95, 1.05, case.hits)


def invert_both(case, rng, records, drawn):
    """Both sensors read with the opposite sign (hammer gauge wired in reverse, accelerometer upside down)."""
    return -records


# -------------------------------------------------------------------------------------------------------- cases

def cases() -> list[Case]:
    controls_mustnot = list(EVERYTHING)
    listed = [
        # ---------------------------------------------------------------------------------------- controls
        Case("control-float32", "control",
             "a plain film whose exporter wrote every record in single precision (UFF 58 ord_data_type 2, float32: "
             "≈ 7 significant digits; the 24-bit data had ≈ 7); linear film",
             "UFF dataset 58 specification (SDRC/I-DEAS: ordinate data type 2 = real single precision); IEEE 754",
             "Rounding to float32 is ≈ 6e-8 relative, far below the noise: nothing to claim.", seed=601,
             ord_data_type=2, must_not=controls_mustnot, must_not_quality=["mains", "clip", "double"]),
        Case("control-trigger-time", "control",
             "every record's abscissa_min is −0.010 s (the time axis relative to the trigger, as many recorders "
             "export), so the file holds no session times; plain film (`--rig` nominal)",
             "UFF 58 (abscissa minimum is whatever the writer chose); Brandt, Noise and Vibration Analysis (2011) §13.7",
             "Trigger-relative time axes are ordinary; no hit times means no drift can be read, not that there is "
             "any.", seed=602, cli="rig", abscissa="trigger", must_not=controls_mustnot,
             must_not_quality=["mains", "clip", "double"]),
        Case("control-stiff-film", "control",
             "a stiffer bearing: the same 25.05 kg mover on k 2.0e8 N/m, c 9.0e3 N·s/m (450 Hz, ζ 0.064); linear",
             "Slocum, Precision Machine Design (1992) ch. 9 (aerostatic bearing stiffness ranges)",
             "A plain spring-damper at another frequency: only the parameters differ.", seed=603,
             film=(2.0e8, 9.0e3), must_not=controls_mustnot, must_not_quality=["mains", "clip", "double"],
             physics={"film_k_n_per_m": 2.0e8, "film_c_ns_per_m": 9.0e3}),
        Case("control-two-level", "control",
             "a linearity check: hits alternate 60 N and 350 N (± 5 %), 16 hits; the film is linear",
             "ISO 7626-5 (excitation by impact: checks of linearity at two levels); Ewins, Modal Testing (2000) §4.2",
             "Two force levels on a linear rig: the FRF is the same at both; no amplitude term.", seed=604,
             peaks_fn=two_level_peaks, must_not=controls_mustnot, must_not_quality=["mains", "clip", "double"],
             physics={"force_levels_n": [60.0, 350.0]}),
        Case("control-both-inverted", "control",
             "both channels read with the opposite sign (hammer gauge wired reversed AND accelerometer mounted "
             "upside down): force pulses are negative, the FRF is unchanged; linear film",
             "ISO 7626-1 (sign conventions of mobility measurements); PCB hammer manual (output polarity)",
             "The two inversions cancel in every ratio: the FRF is the film's. A `polarity` on one channel alone "
             "would be false.", seed=605, sampled=invert_both, must_not=controls_mustnot,
             must_not_quality=["mains", "clip", "double"]),
        # ---------------------------------------------------------------------------------------------- rig
        Case("transport-delay", "rig",
             "orifice-to-film transport delay: part of the film's pressure force follows the gap 1.0 ms late, "
             "Z += k_d e^{−sT}, k_d 4e5 N/m (1 % of k), T 1.0 ms: −8.7 % damping at 196 Hz, damping added above "
             "500 Hz (a delayed spring: periodic in frequency, not a first-order lag)",
             "Licht & Elrod, J. Appl. Mech. 27 (1960) (stability of externally pressurised gas bearings, time lag "
             "of the pocket); Talukder & Stowell, Tribol. Int. 36 (2003) (pneumatic hammer, delay models)",
             "A linear lagging spring beside the film: pneumatic-lag is its first-order description (k/(1+sτ) ≈ "
             "k e^{−sτ}), film-memory and squeeze-film fit the same trend near resonance; parameters-only fair. "
             "Mass, mode, amplitude, time or chain terms are wrong.", seed=611, extra_z=transport_delay,
             subtle=True, physics={"k_delay_n_per_m": 4e5, "delay_s": 1e-3},
             exact=[["transport-delay"]], acceptable=[["pneumatic-lag"], ["film-memory"], ["squeeze-film"], []],
             must_not=without(RIG, "pneumatic-lag", "film-memory", "squeeze-film") + list(CHAIN)
             + ["window-damping"]),
        Case("soft-payload", "rig",
             "a 2.0 kg electronics box on elastomer feet (11 Hz, ζ 0.1) rides on the mover; the told 25.05 kg "
             "includes it, but above ≈ 30 Hz it no longer moves with the mover: the in-band mass is 23.05 kg "
             "(resonance +4.3 %)",
             "Harris & Piersol, Harris' Shock and Vibration Handbook (5th ed. 2002) ch. 30 (isolator "
             "transmissibility); Ewins (2000) §2.3 (effective mass)",
             "A real mode below the band: an extra mode at ≈ 11 Hz, or an added mass ≈ −2 kg (with the sensitivity "
             "alternative the docs promise) are fair. Memory, amplitude, time or chain terms are wrong.",
             seed=612, accelerance=soft_payload_accelerance,
             physics={"payload_kg": 2.0, "payload_hz": 11.0, "payload_zeta": 0.1},
             exact=[["soft-payload"]], acceptable=[["extra-mode"], ["added-mass"]],
             needs_alternative={"added-mass": "sensitivity-error"},
             must_not=without(RIG, "extra-mode", "added-mass") + list(CHAIN) + ["window-damping"]),
        Case("twin-carriage", "rig",
             "gantry: the hit carriage is tied through the bridge's axial flexure (2e6 N/m) to the second carriage "
             "on the parallel rail (25.0 kg on its own film, 205 Hz alone): two close coupled modes (≈ 199 and "
             "212 Hz) where the spec has one",
             "Slocum, Precision Machine Design (1992) §8 (gantry / dual-rail stages); Den Hartog, Mechanical "
             "Vibrations (1956) §3.2 (coupled oscillators)",
             "A second body on a spring beside the mover: an extra mode (mass on a spring riding on the mover) is a "
             "fair description (the grounding of carriage B goes into the film's k). Memory, amplitude, time, "
             "chain terms are wrong.", seed=613, accelerance=twin_carriage_accelerance,
             physics={"carriage_b_kg": 25.0, "carriage_b_k": 4.15e7, "bridge_k": 2e6},
             exact=[["twin-carriage"]], acceptable=[["extra-mode"], ["extra-mode", "added-mass"]],
             needs_alternative={"added-mass": "sensitivity-error"},
             must_not=without(RIG, "extra-mode", "added-mass") + list(CHAIN) + ["window-damping"]),
        # ------------------------------------------------------------------------------------- measurement
        Case("swapped-cables", "measurement",
             "the hammer's and the accelerometer's BNC cables swapped at the module: the 'force' records hold the "
             "accelerometer's voltage / 2.25 mV/N, the 'acceleration' records the hammer's / 10.2 mV/(m/s²): the "
             "file's FRF is 0.0487 / H (a dynamic stiffness, not an accelerance)",
             "Avitabile, Modal Testing: A Practitioner's Guide (2017) ch. 5 (channel set-up errors); ISO 7626-1",
             "Not the accelerance at all: a level/shape note, refusal or not explained is right; every term is false.",
             seed=621, sampled=swap_cables, exact=[["swapped-cables"]], must_not=list(EVERYTHING), refusal_ok=True),
        Case("capacitive-crosstalk", "measurement",
             "8 pF between the hammer's and the accelerometer's unshielded adapter leads (taped together at the "
             "module) into its 305 kΩ input: the response carries 5.4e-7 × dF/dt (m/s²)/(N/s): a leak rising with "
             "frequency, 8.4 % of |H| at 1 kHz in quadrature (phase +4.8°, |H| +0.4 %)",
             "Ott, Electromagnetic Compatibility Engineering (Wiley 2009) §2.3 (capacitive coupling ∝ dV/dt); NI 9234 "
             "data sheet (input impedance 305 kΩ)",
             "A derivative leak of the force into the response: a constant cross-talk is a partial description "
             "(same channel, wrong law); not explained is honest. Rig terms, delay, AC coupling, sensitivity are "
             "wrong.", seed=622, chain=capacitive_crosstalk, subtle=True,
             physics={"coupling_pf": 8.0, "input_ohm": 305e3},
             exact=[["capacitive-crosstalk"]], acceptable=[["cross-talk"], []],
             must_not=list(RIG) + ["channel-delay", "ac-coupling", "sensitivity-error", "polarity", "window-damping"]),
        Case("differentiated-displacement", "measurement",
             "the response is a capacitive displacement probe (1 V/µm, 3e-11 m/√Hz) on the module; the exporter "
             "turned it into m/s² by two backward differences: ×e^{−sT}(sin(ωT/2)/(ωT/2))², a one-sample delay "
             "(78 µs, 28° at 1 kHz) and −2 % at 1 kHz, noise rising as f²",
             "Lion Precision / Kaman capacitive sensor application notes (noise density, bandwidth); Hamming, "
             "Digital Filters (3rd ed. 1989) §6 (differentiators); Brandt (2011) §9 (integration/differentiation)",
             "The backward difference IS a one-sample delay on the response: channel-delay (−78 µs on the response) "
             "is a right partial description; rig terms, AC coupling, cross-talk, sensitivity are wrong.",
             seed=623, displacement=True, accel_noise=3e-11, resp_v_per_unit=1e6, export=differentiate_export,
             physics={"probe_v_per_m": 1e6, "probe_noise_m_per_sqrt_hz": 3e-11, "delay_s": 1 / 12800},
             exact=[["differentiated-displacement"]], acceptable=[["channel-delay"], []],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("multiplexed-daq", "measurement",
             "a multiplexed 16-bit card (one ADC scanning force then response; DAQmx's default convert clock: "
             "14 µs between them) behind the conditioners' filters: the response is sampled 14 µs after the force "
             "(phase +5° at 1 kHz) and holds 0.5 % of the force channel's voltage (ghosting: 1.1e-3 (m/s²)/N, "
             "2.7 % of |H| at 1 kHz); ranges ±1 V (force) and ±0.2 V (response)",
             "NI, 'Multiplexed vs. simultaneous sampling' and 'How do I eliminate ghosting from my measurements?' "
             "(NI KB); NI 622x specifications (convert clock, settling)",
             "Two chain terms the catalogue has: the response early by 14 µs (a channel delay of −14 µs) and a "
             "constant cross-talk of 1.1e-3 (m/s²)/N; either or both are right; rig terms are wrong.",
             seed=624, response_advance_s=14e-6, chain=multiplexer_ghost,
             quant_steps=(2.0 / 2**16 / HAMMER_V_PER_N, 0.4 / 2**16 / ACCEL_V_PER_M_S2),
             physics={"skew_s": 14e-6, "ghost_fraction": 0.005, "bits": 16},
             exact=[["channel-delay", "cross-talk"]], acceptable=[["cross-talk"], ["channel-delay"], []],
             must_not=list(RIG) + ["ac-coupling", "sensitivity-error", "polarity", "window-damping"]),
        Case("zero-phase-highpass", "measurement",
             "the exporting script 'removed the drift' from the response records only: filtfilt with a 2nd-order "
             "10 Hz Butterworth high-pass — |T|² with no phase (−6 % at 20 Hz, −0.4 % at 40 Hz, −50 % at 10 Hz) and a "
             "non-causal precursor before the pulse",
             "Smith, The Scientist and Engineer's Guide to DSP (1997) ch. 19 (bidirectional filtering); SciPy "
             "`filtfilt`; Bendat & Piersol (2010) §11.1",
             "A processing step on one channel: a magnitude loss at the band's low edge without the phase an "
             "AC coupling has. Not explained or parameters-only is right; rig terms, delay, cross-talk, sensitivity "
             "are wrong (an AC coupling is a false claim, not a must-not).",
             seed=625, export=zero_phase_highpass_export, subtle=True, physics={"corner_hz": 10.0, "order": 2},
             exact=[["zero-phase-highpass"]], acceptable=[[]],
             must_not=list(RIG) + ["channel-delay", "cross-talk", "sensitivity-error", "polarity", "window-damping"]),
        Case("overlapping-records", "measurement",
             "continuous hitting every 0.90–0.95 s with 1 s records: every record also holds the NEXT hit (force "
             "and response) 0.9 s in, its ringing cut 30–80 ms later at the record's end (≈ 1–10 % left); "
             "session times overlap",
             "ISO 7626-5 (time between impacts ≥ the response's decay); Brandt (2011) §13.7 (impact testing: "
             "record length, multiple impacts)",
             "Two full impacts per record, the second truncated: leakage, no physics. A note on the second pulse or "
             "the truncation, parameters-only or not explained; any term is false.", seed=626, overlap=True,
             exact=[["overlapping-records"]], acceptable=[[]], must_not=list(EVERYTHING)),
        Case("wavelet-denoised", "measurement",
             "the logger's export option 'denoise' was on: Haar wavelet soft thresholding (universal threshold "
             "σ√(2 ln N)) on every record of both channels — the quiet tails are nearly noise-free, small late "
             "ringing and the pulse's fine detail are shrunk",
             "Donoho, IEEE Trans. Inf. Theory 41 (1995) 'De-noising by soft-thresholding'; Donoho & Johnstone, "
             "Biometrika 81 (1994)",
             "A nonlinear processing step: noise measured from the tails is far too low, the ringing below the "
             "threshold is shrunk (decay looks faster late). No physics; friction or any amplitude term is false.",
             seed=627, export=denoise_export, exact=[["wavelet-denoised"]], acceptable=[[]],
             must_not=list(EVERYTHING)),
        Case("hann-windowed", "measurement",
             "the exporting script multiplied both channels of every record by a Hann window (the habit from "
             "random-noise FFTs): the pulse at 10 ms is scaled by 1e-3, the ringing by a window rising to 1 at 0.5 s",
             "Brandt (2011) §9.3 and §13.7 (never a Hann window on impact records); Gade & Herlufsen, B&K "
             "Technical Review 3/1987 (windows for transients)",
             "Not an FRF of the rig: the window grows through the response (the opposite of an exponential "
             "window). A refusal or not explained is right; every term is false.", seed=628, export=hann_export,
             exact=[["hann-windowed"]], must_not=list(EVERYTHING), refusal_ok=True),
        Case("two-sided-hits", "measurement",
             "the operator hit hits 11–16 on the mover's opposite face: the gauge reads compression (+) as always, "
             "the mover moves the other way: 6 of 16 responses have the opposite sign; the averaged FRF shrinks to "
             "≈ 0.3 H with coherence ≈ 0.1",
             "Ewins (2000) §3.9 (reciprocity and direction conventions); ISO 7626-5 (excitation direction)",
             "Records of opposite sign averaged: level and coherence collapse, no physics. A refusal or not "
             "explained is right; any term (a polarity included) is false.", seed=629, per_hit_h=two_sided,
             exact=[["two-sided-hits"]], must_not=list(EVERYTHING), refusal_ok=True),
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
        "allowed": allowed, "partial_ok": sorted(case.partial_ok), "must_not_claim": sorted(case.must_not),
        "must_not_quality": sorted(case.must_not_quality), "needs_alternative": case.needs_alternative,
        "empty_needs_recalibrated": {}, "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "refusal_ok": case.refusal_ok, "expected_quality": case.expected_quality,
    }


def write_uff(path: Path, records: np.ndarray, starts: np.ndarray, case: Case) -> None:
    sets = []
    dt = 1.0 / case.rate_hz
    for hit, (record, start) in enumerate(zip(records, starts)):
        start = -case.pretrigger_s if case.abscissa == "trigger" else float(start)
        for values, dtype, unit in ((record[0], 13, "N"), (record[1], 12, "m/s^2")):
            values = np.asarray(values, dtype=float)
            if case.ord_data_type == 2:  # pyuff wants float64 here; it writes 4-byte floats for type 2
                values = values.astype(np.float32).astype(float)
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"{case.name} hit {hit + 1}", id2="redteam6 generator", id3="", id4="", id5="",
                func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, ord_data_type=case.ord_data_type,
                abscissa_spacing=1, abscissa_min=start, abscissa_inc=dt, abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s", ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0,
                z_axis_axis_units_lab="NONE", data=values, x=start + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add", force_double=case.ord_data_type != 2)
    if case.ord_data_type == 2:
        to_single(path)


def to_single(path: Path) -> None:
    """pyuff writes 8-byte values even under ord_data_type 2: rewrite every binary 58 record with 4-byte floats and
    the byte count of its '58b' line accordingly (UFF 58b: the header's 11 lines, then the values, then -1)."""
    raw = path.read_bytes()
    out, pos = bytearray(), 0
    marker = b"    58b"
    while True:
        at = raw.find(marker, pos)
        if at < 0:
            out += raw[pos:]
            break
        line_end = raw.index(b"\n", at)
        fields = raw[at:line_end].split()
        head_end = line_end + 1
        header = []
        for _ in range(11):
            nxt = raw.index(b"\n", head_end) + 1
            header.append(raw[head_end:nxt])
            head_end = nxt
        n_bytes = 8 * int(header[6].split()[1])  # record 7: ord_data_type, number of values, ...; pyuff wrote doubles
        values = np.frombuffer(raw[head_end:head_end + n_bytes], dtype="<f8")
        fields[4] = str(values.size * 4).encode()
        line = b"%7s%6s%6s%12s%12s%6s%6s%12s%12s" % tuple(fields[:9])
        out += raw[pos:at] + line + b"\n" + raw[line_end + 1:head_end] + values.astype("<f4").tobytes()
        pos = head_end + n_bytes
    path.write_bytes(bytes(out))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam6"))
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
        write_uff(args.out / f"{case.name}.uff", records, starts, case)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1))
        print(f"{case.name:28s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak |a| "
              f"{np.abs(records[:, 1]).max():.3g}, peak |F| {np.abs(records[:, 0]).max():.0f}, acausal "
              f"{drawn['acausal_fraction']:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
