"""Red-team generator (issue 14): impact-hammer sessions with rig physics and measurement faults no issue has named.

Written without reading ``analysis/`` or ``app/``; imports nothing from gasfilm (numpy, scipy, pyuff only). The file
format, the measurement chain and the scoring conventions follow ``benchmarks/concealed/independent/``: an analog grid
8× the sample rate, the same elliptic anti-aliasing filter on force and response, decimation by 8, sensor noise on both
channels, UFF 58 time records (one force record, data type 13 "N", and one acceleration record, 12 "m/s^2", per hit;
each record's absolute session start time in ``abscissa_min``).

Linear cases are synthesised exactly in the frequency domain (zero-padded FFT of the analog force times the measured
accelerance, sensor and channel effects included); nonlinear and time-varying cases by fixed-step RK4 on the analog
grid, all hits at once. Each case's answer key ``<case>.key.json`` is written BEFORE its UFF file.

    python benchmarks/concealed/redteam/generate.py [--out out/redteam] [--only CASE ...]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pyuff
from scipy import signal

logger = logging.getLogger(__name__)

OVERSAMPLE = 8  # analog grid = 8 × the sample rate
LEAD_IN_S = 0.004  # simulated before each record so that the anti-aliasing filter has settled
FORCE_NOISE_N_PER_RTHZ = 1e-4
ACCEL_NOISE_M_S2_PER_RTHZ = 3e-5
TOLD_MASS_KG = 25.05
AIR_MEAN_FREE_PATH_M = 68e-9  # at 20 °C, 1 atm
UFF_NODE, UFF_DIR = 1, 3
DATA_TYPE_ACCELERATION, DATA_TYPE_FORCE, DATA_TYPE_TIME = 12, 13, 17

#: Effect names of the diagnosis's catalogue, as the independent benchmark names them (answer keys use these).
RIG = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
       "step-change", "friction", "quadratic-damping")
MEASUREMENT = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error")
PROCESSING = ("window-damping",)


@dataclass
class Case:
    """One session: the rig, the hammer, the chain, and the answer (what is right, what must not be claimed)."""

    name: str
    category: str  # control | rig | measurement
    summary: str
    source: str  # literature the physics comes from
    physics: dict = field(default_factory=dict)  # parameters, for the key (SI)
    mass_kg: float = 25.05
    told_mass_kg: float = TOLD_MASS_KG
    film_k: float = 3.8e7
    film_c: float = 3.5e3
    sample_rate_hz: float = 12800.0
    record_s: float = 1.0
    pretrigger_s: float = 0.010
    hits: int = 20
    pulse_ms: float = 1.0
    force_n: float = 200.0
    force_spread: float = 0.2
    force_clip: tuple[float, float] = (100.0, 300.0)
    # linear pieces: extra dynamic stiffness Z(s) beside the film, a factor on the measured acceleration
    extra_stiffness: Callable[[np.ndarray], np.ndarray] | None = None
    sensor_factor: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None  # (s, displacement-over-accel) → ×
    added_response: Callable[[np.ndarray], np.ndarray] | None = None  # s → extra accelerance added (m/s²/N)
    # nonlinear/time-varying pieces: RK4 restoring force with extra states
    nonlinear: dict | None = None
    per_hit_film: Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray]] | None = None  # (t_s, span) → k, c
    per_hit_delay_s: Callable[[np.random.Generator, int], np.ndarray] | None = None
    pulse_shape: str = "half-sine"  # or "hertz" (sin^1.5, width ∝ F^-1/6)
    double_hit: dict | None = None
    force_full_scale_n: float | None = None  # the channel clips here (analog, before the anti-aliasing filter)
    tribo: dict | None = None
    dropout: dict | None = None
    accel_noise_pink_corner_hz: float = 0.0
    accel_noise_factor: float = 1.0
    # second red-team round (redteam2): more linear support physics, more measurement properties
    support: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None  # (s, film Z) → Z of film + its mounting
    session_s: float | None = None  # spread the hits over this long a session (s) instead of the default
    floor: dict | None = None  # narrowband floor acceleration lines, transmitted to the mover through the film
    trigger_level_n: float | None = None  # late trigger: no pre-trigger, the record starts when F crosses this
    adc: dict | None = None  # a coarse recorder: bits, range (V), sensitivities, ADC noise (LSB RMS)
    export_window: dict | None = None  # records exported already windowed (exponential on both, force window)
    # the answer
    exact: list[list[str]] = field(default_factory=lambda: [[]])
    acceptable: list[list[str]] = field(default_factory=list)
    must_not: list[str] = field(default_factory=list)
    must_not_quality: list[str] = field(default_factory=list)
    honest_ok: bool = True
    expected_quality: list[str] = field(default_factory=list)  # quality keywords a good report would carry (info)
    partial_ok: list[str] = field(default_factory=list)  # names allowed only beside a non-empty `unexplained`
    needs_alternative: dict = field(default_factory=dict)  # finding name → alternative it must carry to count
    empty_needs_recalibrated: list[str] = field(default_factory=list)  # nothing found: a recalibrated parameter
    #   whose name holds one of these must have moved by > 2 % (else the empty set does not count)
    reasoning: str = ""  # why the key says what it says (written into the key)
    seed: int = 0


# ------------------------------------------------------------------------------------------------------------ force

def pulse(case: Case, t: np.ndarray, start: np.ndarray, width: np.ndarray, peak: np.ndarray,
          second: np.ndarray) -> np.ndarray:
    """Contact force (N) of every hit (hits, len(t)); ``second`` (hits, 3) = (delay s, relative amplitude, width s)."""
    t = np.asarray(t)[None, :] if np.ndim(t) else np.full((len(start), 1), float(t))
    phase = (t - start[:, None]) / width[:, None]
    inside = (phase >= 0) & (phase <= 1)
    shape = np.sin(np.pi * np.clip(phase, 0, 1))
    if case.pulse_shape == "hertz":
        shape = shape ** 1.5
    force = np.where(inside, peak[:, None] * shape, 0.0)
    if case.double_hit:
        phase2 = (t - start[:, None] - second[:, 0:1]) / second[:, 2:3]
        inside2 = (phase2 >= 0) & (phase2 <= 1)
        force = force + np.where(inside2, (peak * second[:, 1])[:, None] * np.sin(np.pi * np.clip(phase2, 0, 1)),
                                 0.0)
    return force


# --------------------------------------------------------------------------------------------------- linear response

def accelerance(case: Case, freq_hz: np.ndarray, k: float, c: float, decay_rate_1_s: float = 0.0) -> np.ndarray:
    """Measured acceleration over contact force (m/s²/N) of a linear case, sensor and chain included
    (at s = σ + jω with ``decay_rate_1_s`` = σ > 0: what an exponential window e^{−σt} on both channels measures)."""
    s = 2j * np.pi * freq_hz + decay_rate_1_s
    z = k + s * c
    with np.errstate(invalid="ignore", divide="ignore"):
        if case.support is not None:
            z = case.support(s, z)
        if case.extra_stiffness is not None:
            z = z + np.nan_to_num(case.extra_stiffness(s))
        mobility_x = 1.0 / (z + case.mass_kg * s**2)  # displacement / force
        h = np.nan_to_num(s**2 * mobility_x)
        if case.sensor_factor is not None:
            h = h * np.nan_to_num(case.sensor_factor(s, z))
    if case.added_response is not None:
        h = h + np.nan_to_num(case.added_response(s))
    return h


# ------------------------------------------------------------------------------------------------- nonlinear: RK4

def integrate(case: Case, t_s: np.ndarray, force_at: Callable[[float], np.ndarray], films: np.ndarray,
              rng: np.random.Generator) -> np.ndarray:
    """Fixed-step RK4 of M·a = F − restoring(x, v, z) with extra states z; acceleration (hits, samples) on ``t_s``."""
    nl = case.nonlinear
    kind = nl["kind"]
    dt = float(t_s[1] - t_s[0])
    hits = films.shape[0]
    k, c, m = films[:, 0], films[:, 1], case.mass_kg

    def restoring(x: np.ndarray, v: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(force N, dz/dt)."""
        if kind == "gap":  # film force from the gap law: quadratic stiffness, h^-3 squeeze damping with slip
            h0, a2, kn0 = nl["gap_m"], nl["quadratic_factor"], AIR_MEAN_FREE_PATH_M / nl["gap_m"]
            ratio = h0 / np.maximum(h0 - x, 0.2 * h0)
            slip = (1 + 6 * kn0) / (1 + 6 * kn0 * ratio)
            return k * x * (1 + a2 * x / h0) + c * ratio**3 * slip * v, z
        if kind == "dahl":  # Dahl pre-sliding hysteresis: dF/dt = σ0 v (1 − F/Fc sgn v)
            sigma0, fc, vs = nl["sigma0_n_per_m"], nl["fc_n"], nl["sign_smoothing_m_s"]
            dz = sigma0 * v * (1 - z / fc * np.tanh(v / vs))
            return k * x + c * v + z, dz
        if kind == "touchdown":  # contact with the bearing land beyond the clearance (compressive only)
            xc, kc, cc = nl["clearance_m"], nl["contact_k_n_per_m"], nl["contact_c_ns_per_m"]
            pen = x - xc
            contact = np.where(pen > 0, np.maximum(kc * pen + cc * v, 0.0), 0.0)
            return k * x + c * v + contact, z
        if kind == "quintic":  # opposed-pad film: softening near the working gap, hardening further out
            u = x / nl["scale_m"]
            return k * x * (1 + nl["a3"] * u**2 + nl["a5"] * u**4) + c * v, z
        if kind == "hammer":  # negative damping at small amplitude, saturating (pneumatic hammer past threshold)
            cn, vs = nl["negative_c_ns_per_m"], nl["saturation_m_s"]
            return k * x + c * v - cn * vs * np.tanh(v / vs), z
        raise ValueError(kind)

    lead_s = nl.get("settle_s", 0.0)
    x = np.zeros(hits)
    v = np.zeros(hits)
    z = np.zeros(hits)
    if kind == "hammer":  # start on (about) the limit cycle at a random phase, settle before the record
        amp_v = nl["limit_cycle_m_s"]
        omega = np.sqrt(k / m)
        phase = rng.uniform(0, 2 * np.pi, hits)
        x, v = amp_v / omega * np.cos(phase), -amp_v * np.sin(phase)
        settle = int(round(lead_s / dt))
        zero = np.zeros(hits)
        for _ in range(settle):
            def d(xx, vv):
                f, _ = restoring(xx, vv, zero)
                return -f / m
            a1 = d(x, v)
            x2, v2 = x + 0.5 * dt * v, v + 0.5 * dt * a1
            a2 = d(x2, v2)
            x3, v3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2
            a3 = d(x3, v3)
            x4, v4 = x + dt * v3, v + dt * a3
            a4 = d(x4, v4)
            x, v = x + dt / 6 * (v + 2 * v2 + 2 * v3 + v4), v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    steps = len(t_s) if kind == "hammer" else min(len(t_s), int(round((nl.get("span_s", 0.2) + 0.004) / dt)))
    out = np.zeros((hits, len(t_s)))

    def deriv(t: float, x: np.ndarray, v: np.ndarray, z: np.ndarray):
        f, dz = restoring(x, v, z)
        return (force_at(t) - f) / m, dz

    for i in range(steps):
        t = t_s[i]
        a1, dz1 = deriv(t, x, v, z)
        out[:, i] = a1
        x2, v2, z2 = x + 0.5 * dt * v, v + 0.5 * dt * a1, z + 0.5 * dt * dz1
        a2, dz2 = deriv(t + 0.5 * dt, x2, v2, z2)
        x3, v3, z3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2, z + 0.5 * dt * dz2
        a3, dz3 = deriv(t + 0.5 * dt, x3, v3, z3)
        x4, v4, z4 = x + dt * v3, v + dt * a3, z + dt * dz3
        a4, dz4 = deriv(t + dt, x4, v4, z4)
        x = x + dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        z = z + dt / 6 * (dz1 + 2 * dz2 + 2 * dz3 + dz4)
    return out


# ------------------------------------------------------------------------------------------------ measurement chain

def anti_aliasing_filter(sample_rate_hz: float) -> tuple[np.ndarray, int]:
    """Elliptic low-pass (SOS, order) on the analog grid: flat to 0.45 fs (0.01 dB), ≥ 100 dB down from 0.55 fs
    (the independent generator's filter)."""
    fine_hz = OVERSAMPLE * sample_rate_hz
    order, natural = signal.ellipord(0.45 * sample_rate_hz, 0.55 * sample_rate_hz, 0.01, 100, fs=fine_hz)
    return signal.ellip(order, 0.01, 100, natural, btype="low", output="sos", fs=fine_hz), int(order)


def band_noise(rng: np.random.Generator, shape: tuple[int, int], fine_hz: float, band_hz: tuple[float, float]
               ) -> np.ndarray:
    """Unit-RMS Gaussian noise, flat in ``band_hz``, per row."""
    n = shape[1]
    spectrum = rng.standard_normal((shape[0], n // 2 + 1)) + 1j * rng.standard_normal((shape[0], n // 2 + 1))
    freq = np.fft.rfftfreq(n, 1 / fine_hz)
    spectrum[:, (freq < band_hz[0]) | (freq > band_hz[1])] = 0
    out = np.fft.irfft(spectrum, n, axis=1)
    return out / np.std(out, axis=1, keepdims=True)


def white_noise(rng: np.random.Generator, shape: tuple[int, int], fine_hz: float, density: float,
                pink_corner_hz: float = 0.0) -> np.ndarray:
    """Noise of one-sided density ``density`` /√Hz (times √(1 + f_c/f) below the pink corner)."""
    noise = density * np.sqrt(fine_hz / 2) * rng.standard_normal(shape)
    if pink_corner_hz:
        n = shape[1]
        freq = np.fft.rfftfreq(n, 1 / fine_hz)
        shaping = np.sqrt(1 + pink_corner_hz / np.maximum(freq, freq[1]))
        shaping[0] = 0.0
        noise = np.fft.irfft(np.fft.rfft(noise, axis=1) * shaping, n, axis=1)
    return noise


def floor_vibration(case: Case, rng: np.random.Generator, fine_n: int, fine_hz: float) -> np.ndarray:
    """The mover's acceleration (hits, fine_n) from narrowband floor lines (centre Hz, bandwidth Hz, floor RMS
    m/s²), each a Gaussian process flat in its band, through the film's transmissibility Z/(Z + m s²): a random
    stretch of a record four times longer than needed, so that the band's ~1/bandwidth correlation is kept."""
    n_long = 1 << int(np.ceil(np.log2(4 * fine_n)))
    freq = np.fft.rfftfreq(n_long, 1 / fine_hz)
    spectrum = np.zeros((case.hits, len(freq)), dtype=complex)
    for centre_hz, bandwidth_hz, rms in case.floor["lines"]:
        band = np.abs(freq - centre_hz) <= bandwidth_hz / 2
        part = rng.standard_normal((case.hits, band.sum())) + 1j * rng.standard_normal((case.hits, band.sum()))
        part *= rms * n_long / np.sqrt(2 * np.sum(np.abs(part) ** 2, axis=1, keepdims=True))
        spectrum[:, band] += part
    s = 2j * np.pi * freq
    z = case.film_k + case.film_c * s
    with np.errstate(invalid="ignore", divide="ignore"):
        transmissibility = np.nan_to_num(z / (z + case.mass_kg * s**2))
    long = np.fft.irfft(spectrum * transmissibility, n_long, axis=1)
    begin = rng.integers(0, n_long - fine_n, case.hits)
    return np.stack([long[hit, b:b + fine_n] for hit, b in enumerate(begin)])


def hit_schedule(case: Case, rng: np.random.Generator) -> np.ndarray:
    """Sorted random hit times (s) over a session, at least one record plus 0.8 s apart."""
    gap_s = case.record_s + 0.8
    session_s = case.session_s or case.hits * gap_s * 1.8
    free = session_s - (case.hits - 1) * gap_s
    return 1.0 + np.sort(rng.uniform(0, free, case.hits)) + np.arange(case.hits) * gap_s


def synthesise(case: Case, noise: bool = True) -> tuple[np.ndarray, np.ndarray, dict]:
    """Records (hits, 2, samples) in N and m/s², record start times (s), what was drawn (for the key).
    ``noise=False`` leaves out the sensor noise (for the physics checks only)."""
    rng = np.random.default_rng(case.seed)
    fs = case.sample_rate_hz
    fine_hz = OVERSAMPLE * fs
    samples = int(round(case.record_s * fs))
    pretrigger_s, extra = case.pretrigger_s, 0
    if case.trigger_level_n:  # late trigger: synthesise 2 ms before the pulse, cut where the recorded F crosses
        pretrigger_s, extra = 0.002, int(round(0.004 * fs))
    lead = int(round(LEAD_IN_S * fine_hz))
    fine_n = (samples + extra) * OVERSAMPLE + lead
    t_fine = (np.arange(fine_n) - lead) / fine_hz
    hit_times = hit_schedule(case, rng)
    starts = hit_times - pretrigger_s
    span = float(hit_times[-1] - hit_times[0])
    peaks = np.clip(case.force_n * (1 + case.force_spread * rng.standard_normal(case.hits)), *case.force_clip)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    if case.pulse_shape == "hertz":  # Hertz contact: duration ∝ v^-1/5, peak ∝ v^6/5 → duration ∝ F^-1/6
        widths = widths * (peaks / 200.0) ** (-1 / 6)
    pulse_starts = pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, case.hits)
    second = np.zeros((case.hits, 3))
    second[:, 2] = 1.0
    if case.double_hit:
        dh = case.double_hit
        which = rng.permutation(case.hits)[:dh["count"]]
        second[which, 0] = rng.uniform(*dh["delay_s"], len(which))
        second[which, 1] = rng.uniform(*dh["relative"], len(which))
        second[:, 2] = widths * 1.2
    if case.per_hit_film is not None:
        ks, cs = case.per_hit_film(hit_times - hit_times[0], span)
        films = np.column_stack([ks, cs])
    else:
        films = np.tile([case.film_k, case.film_c], (case.hits, 1))
    forces = pulse(case, t_fine, pulse_starts, widths, peaks, second)

    if case.nonlinear:
        mechanical = integrate(case, t_fine, lambda t: pulse(case, t, pulse_starts, widths, peaks, second)[:, 0],
                               films, rng)
    else:
        n_fft = 1 << int(np.ceil(np.log2(2 * fine_n)))
        freq = np.fft.rfftfreq(n_fft, 1 / fine_hz)
        spectra = np.fft.rfft(forces, n_fft, axis=1)
        if case.per_hit_film is None:
            h = accelerance(case, freq, case.film_k, case.film_c)
            mechanical = np.fft.irfft(spectra * h, n_fft, axis=1)[:, :fine_n]
        else:
            mechanical = np.empty_like(forces)
            for hit, (k, c) in enumerate(films):
                mechanical[hit] = np.fft.irfft(spectra[hit] * accelerance(case, freq, k, c), n_fft)[:fine_n]
    response = mechanical
    delays = np.zeros(case.hits)
    if case.per_hit_delay_s is not None:
        delays = case.per_hit_delay_s(rng, case.hits)
        n_fft = 1 << int(np.ceil(np.log2(2 * fine_n)))
        freq = np.fft.rfftfreq(n_fft, 1 / fine_hz)
        response = np.fft.irfft(np.fft.rfft(response, n_fft, axis=1) * np.exp(-2j * np.pi * freq * delays[:, None]),
                                n_fft, axis=1)[:, :fine_n]
    drawn_extra: dict = {}
    if case.floor:  # floor vibration (not caused by the hammer), felt by the mover through the film
        floor = floor_vibration(case, rng, fine_n, fine_hz)
        response = response + (1.0 if noise else 0.0) * floor
        drawn_extra["floor_rms_on_mover_m_s2"] = float(np.round(np.sqrt(np.mean(floor**2)), 6))
    if case.tribo:  # hit-correlated random burst from cable motion (uncorrelated with the force waveform)
        tr = case.tribo
        burst = band_noise(rng, response.shape, fine_hz, tr["band_hz"])
        onset = pulse_starts[:, None]
        envelope = np.where(t_fine[None, :] >= onset, np.exp(-(t_fine[None, :] - onset) / tr["decay_s"]), 0.0)
        level = tr["rms_m_s2_at_200n"] * peaks / 200.0 * rng.uniform(0.5, 1.5, case.hits)
        response = response + level[:, None] * envelope * burst
        drawn_extra["burst_rms_m_s2"] = np.round(level, 5).tolist()
    if case.dropout:  # intermittent connector: the response signal is lost for a few ms in some hits
        dr = case.dropout
        which = np.sort(rng.permutation(case.hits)[:dr["count"]])
        info = []
        for hit in which:
            t0 = pulse_starts[hit] + rng.uniform(*dr["after_s"])
            length = rng.uniform(*dr["length_s"])
            cut = (t_fine >= t0) & (t_fine < t0 + length)
            response[hit, cut] = dr["level_m_s2"]
            info.append({"hit": int(hit), "from_s": round(float(t0), 5), "length_ms": round(1e3 * length, 2)})
        drawn_extra["dropouts"] = info
    scale = 1.0 if noise else 0.0
    forces_measured = forces + scale * FORCE_NOISE_N_PER_RTHZ * np.sqrt(fine_hz / 2) * rng.standard_normal(forces.shape)
    response = response + scale * white_noise(rng, response.shape, fine_hz,
                                              ACCEL_NOISE_M_S2_PER_RTHZ * case.accel_noise_factor,
                                              case.accel_noise_pink_corner_hz)
    if case.force_full_scale_n:
        clipped = np.max(forces_measured, axis=1) > case.force_full_scale_n
        forces_measured = np.clip(forces_measured, -case.force_full_scale_n, case.force_full_scale_n)
        drawn_extra["clipped_hits"] = np.flatnonzero(clipped).tolist()
    sos, order = anti_aliasing_filter(fs)
    records = np.empty((case.hits, 2, samples + extra))
    for row, channel in enumerate((forces_measured, response)):
        records[:, row, :] = signal.sosfilt(sos, channel, axis=1)[:, lead::OVERSAMPLE][:, :samples + extra]
    if case.trigger_level_n:  # the recorder keeps no pre-trigger: its record starts at the first sample ≥ level
        first = np.argmax(records[:, 0, :] >= case.trigger_level_n, axis=1)
        impulse = records[:, 0, :].sum(axis=1)
        before = np.array([records[hit, 0, :at].sum() for hit, at in enumerate(first)])
        records = np.stack([records[hit, :, at:at + samples] for hit, at in enumerate(first)])
        starts = starts + first / fs
        drawn_extra["force_at_first_sample_n"] = np.round(records[:, 0, 0], 2).tolist()
        drawn_extra["impulse_fraction_before_record"] = np.round(before / impulse, 6).tolist()
    if case.adc:  # a coarse recorder: its own input noise, then rounding to its LSB (after its anti-aliasing)
        adc = case.adc
        lsb_v = 2 * adc["range_v"] / 2 ** adc["bits"]
        top = 2 ** (adc["bits"] - 1)
        for row, volts_per_unit in ((0, adc["force_v_per_n"]), (1, adc["accel_v_per_m_s2"])):
            volts = records[:, row, :] * volts_per_unit
            volts = volts + (1.0 if noise else 0.0) * adc["noise_lsb_rms"] * lsb_v * rng.standard_normal(volts.shape)
            records[:, row, :] = np.clip(np.round(volts / lsb_v), -top, top - 1) * lsb_v / volts_per_unit
        drawn_extra["lsb"] = {"force_n": lsb_v / adc["force_v_per_n"], "accel_m_s2": lsb_v / adc["accel_v_per_m_s2"]}
    if case.export_window:  # exported processed: e^{-σt} on both channels from the record start, force window
        ew = case.export_window
        t_rec = np.arange(samples) / fs
        sigma = -np.log(ew["end_fraction"]) / case.record_s
        end_s = case.pretrigger_s + 1e-3 * ew["force_window_ms"]
        taper_s = 1e-3 * ew["taper_ms"]
        force_window = np.where(t_rec <= end_s, 1.0,
                                np.where(t_rec <= end_s + taper_s,
                                         0.5 * (1 + np.cos(np.pi * (t_rec - end_s) / taper_s)), 0.0))
        records[:, 0, :] *= force_window * np.exp(-sigma * t_rec)
        records[:, 1, :] *= np.exp(-sigma * t_rec)
        drawn_extra["export_decay_rate_1_s"] = float(sigma)
    drawn = {
        "session_span_s": round(span, 3),
        "hit_times_s": np.round(hit_times, 4).tolist(),
        "peak_force_n": np.round(peaks, 1).tolist(),
        "pulse_width_ms": np.round(widths * 1e3, 3).tolist(),
        "film_k_per_hit_n_per_m": [float(f"{k:.5g}") for k in films[:, 0]],
        "film_c_per_hit_ns_per_m": [float(f"{c:.5g}") for c in films[:, 1]],
        "anti_aliasing": f"elliptic order {order}, 0.01 dB to 0.45 fs, 100 dB from 0.55 fs, on {fine_hz:.0f} Hz",
    } | drawn_extra
    if case.double_hit:
        drawn["second_pulse"] = [{"hit": int(i), "delay_ms": round(1e3 * d, 3), "relative": round(r, 3)}
                                 for i, (d, r, _) in enumerate(second) if r > 0]
    if case.per_hit_delay_s is not None:
        drawn["response_delay_us"] = np.round(delays * 1e6, 2).tolist()
    return records, starts, drawn


# ------------------------------------------------------------------------------------------------------------ files

def write_uff(path: Path, records: np.ndarray, starts_s: np.ndarray, sample_rate_hz: float, name: str) -> None:
    """One force (type 13, N) and one acceleration (type 12, m/s²) time record per hit, start time in abscissa_min."""
    datasets = []
    dt = 1.0 / sample_rate_hz
    for hit, (record, start) in enumerate(zip(records, starts_s)):
        for values, data_type, unit in ((record[0], DATA_TYPE_FORCE, "N"),
                                        (record[1], DATA_TYPE_ACCELERATION, "m/s^2")):
            datasets.append(pyuff.prepare_58(
                binary=1, id1=f"{name} hit {hit}", id2="redteam generator", id3="", id4="", id5="",
                func_type=1, rsp_node=UFF_NODE, rsp_dir=UFF_DIR, ref_node=UFF_NODE, ref_dir=UFF_DIR,
                ord_data_type=4, abscissa_spacing=1, abscissa_min=float(start), abscissa_inc=dt,
                abscissa_spec_data_type=DATA_TYPE_TIME, abscissa_axis_units_lab="s",
                ordinate_spec_data_type=data_type, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE",
                z_axis_spec_data_type=0, z_axis_axis_units_lab="NONE",
                data=np.asarray(values, dtype=float), x=float(start) + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(datasets, mode="add")


def answer_key(case: Case, uff_name: str) -> dict:
    allowed = sorted(set().union(*map(set, case.exact), *map(set, case.acceptable)))
    return {
        "case": case.name,
        "uff": uff_name,
        "mass_kg": case.told_mass_kg,
        "category": case.category,
        "summary": case.summary,
        "source": case.source,
        "truth": {"mass_kg": case.mass_kg, "film_k_n_per_m": case.film_k, "film_c_ns_per_m": case.film_c,
                  "sample_rate_hz": case.sample_rate_hz, "record_s": case.record_s, "hits": case.hits,
                  "pretrigger_s": case.pretrigger_s, "pulse_ms": case.pulse_ms, "pulse_shape": case.pulse_shape,
                  "force_n": case.force_n, "force_spread": case.force_spread} | case.physics,
        "control": case.category == "control",
        "exact": [sorted(names) for names in case.exact],
        "acceptable": [sorted(names) for names in case.acceptable],
        "allowed": allowed,
        "must_not_claim": sorted(case.must_not),
        "must_not_quality": sorted(case.must_not_quality),
        "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "expected_quality": case.expected_quality,
    } | {name: value for name, value in (("partial_ok", sorted(case.partial_ok)),
                                         ("needs_alternative", case.needs_alternative),
                                         ("empty_needs_recalibrated", case.empty_needs_recalibrated),
                                         ("reasoning", case.reasoning)) if value}


# ------------------------------------------------------------------------------------------------------------ cases

def all_rig_but(*allowed: str) -> list[str]:
    return [name for name in RIG if name not in allowed]


def cases() -> list[Case]:
    """Controls, rig physics no issue named, and measurement faults no issue named."""
    two_pi = 2 * np.pi
    rig_all = list(RIG)
    listed: list[Case] = []

    # ---- controls: the nominal spring-damper film, realistic measurement variation, no physics may be claimed
    listed += [
        Case("control-nominal", "control", "spring-damper film only, 150 N ± 25 % hits, 16 hits",
             "—", film_k=3.83e7, film_c=3.42e3, hits=16, force_n=150.0, force_spread=0.25, seed=101,
             must_not=rig_all),
        Case("control-hertz-tip", "control",
             "Hertzian hammer tip: pulse sin^1.5, duration ∝ F^-1/6 (1.22 ms at 60 N, 0.91 ms at 350 N), hits 60–350 N",
             "Goldsmith, Impact (1960) ch. 4; Johnson, Contact Mechanics (1985) §11.4: Hertz impact duration ∝ v^-1/5",
             physics={"hertz": "F = F_max sin(πt/T)^1.5, T = 1 ms (F_max/200 N)^-1/6"},
             film_k=3.77e7, film_c=3.55e3, pulse_shape="hertz", force_n=200.0, force_spread=0.45,
             force_clip=(60.0, 350.0), seed=102, must_not=rig_all),
        Case("control-short-pretrigger", "control",
             "2 ms pre-trigger, 0.2 s records at 25.6 kS/s, lightly damped film (ζ 0.024, still ringing at 0.4 % at "
             "the record end), 12 hits",
             "issue 14: real recorders keep short pre-triggers; lightly damped structures ring to the record end",
             film_k=3.8e7, film_c=1.5e3, sample_rate_hz=25600.0, record_s=0.2, pretrigger_s=0.002, hits=12,
             pulse_ms=0.6, seed=103, must_not=rig_all),
        Case("control-few-hits-pink", "control",
             "5 hits on an 18.3 kg mover (told 18.3 kg), accelerometer noise 3× and pink below 80 Hz",
             "PCB/IEPE accelerometer noise spectra: density rising as 1/f below ~10-100 Hz (manufacturer data)",
             mass_kg=18.3, told_mass_kg=18.3, film_k=3.1e7, film_c=2.9e3, hits=5, accel_noise_factor=3.0,
             accel_noise_pink_corner_hz=80.0, seed=104, must_not=rig_all),
    ]

    # ---- rig physics outside every named catalogue
    kp, fp, zp = 3.0e6, 650.0, 0.08
    wp = two_pi * fp
    listed.append(Case(
        "pocket-resonance", "rig",
        "orifice/pocket air-volume resonance in the film's dynamic stiffness: Z_p = k_p ω_p²/(s² + 2ζ_p ω_p s + ω_p²), "
        "k_p 3e6 N/m, 650 Hz, ζ_p 0.08, beside a 3.5e7 N/m film (static total 3.8e7)",
        "Al-Bender, Precision Engineering 33 (2009) 117-126 (dynamic film model with pocket volume); Powell, Design "
        "of Aerostatic Bearings (1970); Belforte et al., Tribology Letters 2007 (feed-hole/pocket dynamics)",
        physics={"pocket_k_n_per_m": kp, "pocket_freq_hz": fp, "pocket_damping_ratio": zp,
                 "equivalent": "a static spring k_p minus an extra mode of NEGATIVE mass k_p/ω_p² = 0.18 kg"},
        film_k=3.5e7, film_c=3.5e3, pulse_ms=0.7,
        extra_stiffness=lambda s: kp * wp**2 / (s**2 + 2 * zp * wp * s + wp**2),
        exact=[["pocket-resonance"]], acceptable=[],
        must_not=["added-mass", "drift", "step-change", "cubic-stiffness", "friction", "quadratic-damping",
                  "channel-delay", "cross-talk", "ac-coupling"], seed=201))

    listed.append(Case(
        "pneumatic-hammer", "rig",
        "pneumatic hammer just past its threshold: negative damping c_n = 4200 N·s/m at small velocity, saturating "
        "above v_s = 30 µm/s (force −c_n v_s tanh(v/v_s)), beside the 3500 N·s/m film: a self-excited limit cycle "
        "≈ 0.05 m/s² at the film resonance (≈ 196 Hz) in every record, before and after the hit",
        "Licht, Fuller & Sternlicht, Trans. ASME 80 (1958) 411 (self-excited vibration of air thrust bearings); "
        "Stowell, J. Lubr. Technol. 93 (1971) 441; Talukder & Stowell, Tribology Int. 36 (2003) 585",
        physics={"negative_c_ns_per_m": 4200.0, "saturation_m_s": 3e-5,
                 "limit_cycle_accel_m_s2": "≈ 0.057 (V = 4 c_n v_s/(π c) = 4.6e-5 m/s)"},
        record_s=0.5,
        nonlinear={"kind": "hammer", "negative_c_ns_per_m": 4200.0, "saturation_m_s": 3e-5,
                   "limit_cycle_m_s": 4.6e-5, "settle_s": 0.1},
        exact=[["pneumatic-hammer"]], acceptable=[],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "channel-delay", "cross-talk"],
        must_not_quality=["mains"], seed=202))

    listed.append(Case(
        "gap-nonlinear-film", "rig",
        "the film force follows the gap h = h0 − x (h0 30 µm): stiffness k x (1 + 0.6 x/h0) (quadratic, asymmetric) "
        "and squeeze damping c (h0/h)³ with first-order slip (1 + 6Kn0)/(1 + 6Kn), Kn = λ/h; peak x ≈ 4 µm",
        "Blech, J. Lubr. Technol. 105 (1983) 615 (squeeze films, h^-3); Burgdorfer, J. Basic Eng. 81 (1959) 94 "
        "(slip, Kn); Gross, Gas Film Lubrication (1962)",
        physics={"gap_m": 30e-6, "quadratic_factor": 0.6, "mean_free_path_m": AIR_MEAN_FREE_PATH_M},
        record_s=0.5, force_spread=0.3,
        nonlinear={"kind": "gap", "gap_m": 30e-6, "quadratic_factor": 0.6},
        exact=[["gap-nonlinearity"]], acceptable=[],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "channel-delay", "cross-talk", "ac-coupling"],
        seed=203))

    listed.append(Case(
        "hose-hysteresis", "rig",
        "Dahl pre-sliding hysteresis from the supply hose and cables dragging on the mover: dF_h/dt = σ0 v "
        "(1 − F_h/F_c sgn v), σ0 4e6 N/m, F_c 3 N (pre-sliding range 0.75 µm against ≈ 4 µm motion)",
        "Dahl, AIAA J. 14 (1976) 1675 (solid friction damping); Bouc (1967), Wen, J. Eng. Mech. 102 (1976) 249; "
        "Al-Bender & Symens, IEEE Control Systems 2005 (pre-sliding friction in precision stages)",
        physics={"sigma0_n_per_m": 4e6, "fc_n": 3.0},
        record_s=0.5, force_spread=0.3,
        nonlinear={"kind": "dahl", "sigma0_n_per_m": 4e6, "fc_n": 3.0, "sign_smoothing_m_s": 1e-6},
        exact=[["hysteresis"]], acceptable=[["friction"]],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "channel-delay", "cross-talk", "ac-coupling"],
        seed=204))

    m_t = 25.05
    listed.append(Case(
        "touchdown", "rig",
        "the heaviest hits close the gap: contact with the bearing land beyond 4.6 µm (k_c 1.5e9 N/m, c_c 4e4 N·s/m, "
        "compressive only); hits 200 N ± 30 % (up to 300 N), about a third touch",
        "Shaw & Holmes, J. Sound Vib. 90 (1983) 129 (piecewise-linear impact oscillator); Gross (1962) on "
        "touchdown of gas bearings",
        physics={"clearance_m": 4.6e-6, "contact_k_n_per_m": 1.5e9, "contact_c_ns_per_m": 4e4},
        record_s=0.5, force_spread=0.3, mass_kg=m_t,
        nonlinear={"kind": "touchdown", "clearance_m": 4.6e-6, "contact_k_n_per_m": 1.5e9,
                   "contact_c_ns_per_m": 4e4},
        exact=[["touchdown"]], acceptable=[],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "channel-delay", "cross-talk", "ac-coupling",
                  "film-memory", "squeeze-film", "pneumatic-lag"], seed=205))

    f_r, ripple_k, ripple_c = 3.1, 0.025, 0.012
    ripple_phase = 0.9

    def ripple(t: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray]:
        mod = np.sin(two_pi * f_r * t + ripple_phase)
        return 3.8e7 * (1 + ripple_k * mod), 3.5e3 * (1 + ripple_c * mod)

    listed.append(Case(
        "supply-ripple", "rig",
        "regulator hunting at 3.1 Hz: supply pressure ±2.5 %, film k ±2.5 % and c ±1.2 % following it; each hit "
        "(≈ 40 ms of response) sees a different, random-looking film; no trend over the session",
        "Al-Bender (2009) (film stiffness ∝ supply pressure); Powell (1970); regulator hunting: pressure-regulator "
        "instability, e.g. Zafer & Luecke, Simulation Modelling Practice and Theory 16 (2008) 1488",
        physics={"ripple_freq_hz": f_r, "stiffness_fraction": ripple_k, "damping_fraction": ripple_c},
        per_hit_film=ripple, hits=24,
        exact=[["supply-ripple"]], acceptable=[],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "cubic-stiffness", "friction",
                  "quadratic-damping", "channel-delay", "cross-talk"], seed=206))

    kp_s, ki_s, kd_s, td_s, fa_s = 1.5e6, 1.5e8, 300.0, 150e-6, 1500.0
    listed.append(Case(
        "servo-left-on", "rig",
        "the stage's position servo left enabled: Z_s = (K_p + K_i/s + K_d s) e^{-sT}/(1 + s/ω_a), K_p 1.5e6 N/m, "
        "K_i 1.5e8 N/(m·s), K_d 300 N·s/m, T 150 µs, ω_a 2π·1500 rad/s (negative effective damping below ≈ 100 Hz)",
        "Altintas, Verl, Brecher, Uriarte & Pritschow, CIRP Annals 60 (2011) 779 (feed drives: dynamic stiffness of "
        "servo axes); Franklin, Powell & Emami-Naeini, Feedback Control of Dynamic Systems",
        physics={"kp_n_per_m": kp_s, "ki_n_per_m_s": ki_s, "kd_ns_per_m": kd_s, "delay_s": td_s,
                 "current_loop_hz": fa_s},
        extra_stiffness=lambda s: (kp_s + ki_s / s + kd_s * s) * np.exp(-s * td_s) / (1 + s / (two_pi * fa_s)),
        exact=[["servo"]], acceptable=[],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "cubic-stiffness", "friction",
                  "channel-delay", "cross-talk", "sensitivity-error"], seed=207))

    tau_frac, dk, dc = 0.3, -0.035, 0.07

    def settling(t: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray]:
        law = 1 - np.exp(-t / (tau_frac * span))
        return 3.8e7 * (1 + dk * law), 3.5e3 * (1 + dc * law)

    listed.append(Case(
        "thermal-settling", "rig",
        "the supply air and film warm up over the session with a first-order time constant of 0.3 × the session: "
        "k −3.5 % (gap opens) and c +7 % (air viscosity, Sutherland) approached exponentially, flat by the last third",
        "Sutherland's law for air viscosity; thermal effects in aerostatic bearings, e.g. Gao et al., Tribology "
        "Int. 2017; Stout & Barrans, Tribology Int. 33 (2000) 803",
        physics={"time_constant_of_session": tau_frac, "stiffness_fraction": dk, "damping_fraction": dc},
        per_hit_film=settling, hits=24,
        exact=[["thermal-settling"]], acceptable=[["drift"], ["step-change"]],
        must_not=["added-mass", "extra-mode", "cubic-stiffness", "friction", "quadratic-damping", "channel-delay",
                  "cross-talk"], seed=208))

    # ---- measurement faults
    fm, zm = 2200.0, 0.04
    wm = two_pi * fm
    listed.append(Case(
        "mount-resonance", "measurement",
        "loose magnet mount of the accelerometer: the sensor reads a·T(s), T = (ω_m² + 2ζω_m s)/(s² + 2ζω_m s + "
        "ω_m²), 2.2 kHz, ζ 0.04 (Q 12.5); 25.6 kS/s, 0.25 ms hard tip",
        "ISO 5348:2021 (mechanical mounting of accelerometers); Serridge & Licht, Piezoelectric Accelerometer and "
        "Vibration Preamplifier Handbook (B&K 1987) ch. 4",
        physics={"mount_freq_hz": fm, "mount_damping_ratio": zm},
        sample_rate_hz=25600.0, record_s=0.5, pulse_ms=0.25,
        sensor_factor=lambda s, z: (wm**2 + 2 * zm * wm * s) / (s**2 + 2 * zm * wm * s + wm**2),
        exact=[["mount-resonance"]], acceptable=[],
        must_not=rig_all, seed=301))

    fx, zx, theta, st = 310.0, 0.03, np.radians(6.0), 0.05
    mx = 25.05
    kx = mx * (two_pi * fx) ** 2
    cx = 2 * zx * mx * two_pi * fx
    listed.append(Case(
        "transverse-sensitivity", "measurement",
        "hits 6° off axis excite the mover's lateral film mode (310 Hz, ζ 0.03); the accelerometer's 5 % transverse "
        "sensitivity adds it: H = cos6°·H_z + 0.05·sin6°·H_x (and the axial force is cos 6° of the gauge's)",
        "ISO 16063-31:2009 (transverse sensitivity); Ewins, Modal Testing (2000) §3.7 (off-axis excitation)",
        physics={"lateral_freq_hz": fx, "lateral_damping_ratio": zx, "angle_deg": 6.0, "transverse_sensitivity": st},
        sensor_factor=lambda s, z: np.full(s.shape, np.cos(theta)),
        added_response=lambda s: st * np.sin(theta) * s**2 / (kx + cx * s + mx * s**2),
        exact=[["transverse-sensitivity"]], acceptable=[["extra-mode"]],
        must_not=all_rig_but("extra-mode"), seed=302))

    strain = 5e4 * 1.3e-9  # 0.05 (m/s²)/µε × 1.3 µε/kN
    listed.append(Case(
        "base-strain", "measurement",
        "the film pressure bends the mover's top plate under the accelerometer (1.3 µε/kN) and the sensor's base-strain "
        "sensitivity (0.05 (m/s²)/µε) adds 6.5e-5 (m/s²)/N × film force: a_meas = a + 6.5e-5 (k x + c v) "
        "(2.5 % of |a| at 50 Hz, 16 % at 20 Hz)",
        "Serridge & Licht (B&K 1987) §3.5 (base strain sensitivity); ISA-RP37.2 / ANSI S2.11 (base strain test)",
        physics={"strain_gain_m_s2_per_n": strain},
        sensor_factor=lambda s, z: 1 + strain * z / s**2,
        exact=[["base-strain"]], acceptable=[],
        must_not=rig_all, seed=303))

    listed.append(Case(
        "force-clipping", "measurement",
        "11.2 mV/N hammer on the ±5 V range: the force channel clips at 446 N (analog, before the anti-aliasing "
        "filter, so the recorded tops ring); hits 380 N ± 20 %, the heavier ones clip",
        "NI 9234 datasheet (±5 V input range); Avitabile, Modal Testing: A Practitioner's Guide (2017) (overloads)",
        physics={"force_full_scale_n": 446.0},
        force_n=380.0, force_spread=0.2, force_clip=(200.0, 600.0), force_full_scale_n=446.0, hits=20,
        exact=[[]], acceptable=[], expected_quality=["clip"],
        must_not=rig_all + ["sensitivity-error"], seed=304))

    listed.append(Case(
        "double-hits", "measurement",
        "hammer bounce: 7 of 20 hits have a second pulse 2–3.5 ms later at 15–35 % of the first (measured by the "
        "force gauge, so H is unbiased where the force spectrum is not in a notch)",
        "Halvorsen & Brown, Sound and Vibration 11 (1977) 8 (impulse technique); Ewins (2000) §3.6; Brandt, Noise "
        "and Vibration Analysis (2011) §13.7",
        physics={"double_hit_count": 7, "delay_ms": [2.0, 3.5], "relative": [0.15, 0.35]},
        double_hit={"count": 7, "delay_s": (2.0e-3, 3.5e-3), "relative": (0.15, 0.35)},
        exact=[[]], acceptable=[], expected_quality=["double"],
        must_not=rig_all, seed=305))

    listed.append(Case(
        "trigger-jitter", "measurement",
        "force and response on two unsynchronised modules: the response record starts a random 0–1 sample "
        "(0–39 µs at 25.6 kS/s) late, different in every hit (mean ≈ 20 µs)",
        "NI cDAQ/C-series synchronisation notes (shared timebase); Brandt (2011) §11 (channel timing errors)",
        physics={"delay_uniform_s": [0.0, 1 / 25600.0]},
        sample_rate_hz=25600.0, record_s=0.5, pulse_ms=0.5,
        per_hit_delay_s=lambda rng, n: rng.uniform(0.0, 1 / 25600.0, n),
        exact=[["channel-delay"]], acceptable=[],
        must_not=rig_all, seed=306))

    b, a = signal.butter(4, two_pi * 2500.0, analog=True)
    listed.append(Case(
        "conditioner-lowpass", "measurement",
        "a signal conditioner's 4-pole Butterworth low-pass at 2.5 kHz left on the response channel only (group "
        "delay 166 µs at DC, −0.7 dB at 2 kHz); 0.4 ms tip",
        "Brandt (2011) §11.3 (anti-aliasing filter mismatch between channels); PCB 482C / B&K NEXUS conditioner "
        "manuals (selectable low-pass)",
        physics={"butterworth_order": 4, "cutoff_hz": 2500.0},
        pulse_ms=0.4,
        sensor_factor=lambda s, z: np.polyval(b, s) / np.polyval(a, s),
        exact=[["filter-mismatch"]], acceptable=[["channel-delay"]],
        must_not=rig_all, seed=307))

    listed.append(Case(
        "cable-triboelectric", "measurement",
        "the accelerometer cable flexes with every hit: triboelectric bursts (10–120 Hz random, decaying with "
        "40 ms, 4e-3 m/s² RMS at onset for 200 N, ×0.5–1.5 at random) in the response, absent from the quiet tails",
        "Serridge & Licht (B&K 1987) §4.6 (triboelectric noise); PCB technical note on cable noise",
        physics={"band_hz": [10.0, 120.0], "decay_s": 0.04, "rms_m_s2_at_200n": 4e-3},
        tribo={"band_hz": (10.0, 120.0), "decay_s": 0.04, "rms_m_s2_at_200n": 4e-3},
        exact=[[]], acceptable=[],
        must_not=rig_all, seed=308))

    listed.append(Case(
        "connector-dropout", "measurement",
        "an intermittent accelerometer connector: in 4 of 20 hits the response reads −0.5 m/s² (contact open) for "
        "1.5–4 ms, 3–40 ms after the hit",
        "Avitabile (2017) (intermittent cables as a common measurement fault); IEPE open-circuit behaviour, e.g. "
        "PCB 'Introduction to ICP sensors'",
        physics={"count": 4, "after_s": [0.003, 0.040], "length_s": [0.0015, 0.004], "level_m_s2": -0.5},
        dropout={"count": 4, "after_s": (0.003, 0.040), "length_s": (0.0015, 0.004), "level_m_s2": -0.5},
        exact=[[]], acceptable=[],
        must_not=rig_all, seed=309))
    listed += second_round(rig_all)
    return listed

def second_round(rig_all: list[str]) -> list[Case]:
    """Round 2 (redteam2): controls of measurement properties that must never be reported as physics, a gain error,
    and support physics from the air-bearing and precision-stage literature that no issue or earlier set names."""
    two_pi = 2 * np.pi
    chain = list(MEASUREMENT)
    listed: list[Case] = []

    # ---- measurement properties on an otherwise nominal rig (controls: nothing may be claimed)
    listed.append(Case(
        "control-exported-windowed", "control",
        "records exported already processed: e^{-σt} from the record start on both channels (0.5 % at the end of "
        "the 1 s record, σ = 5.30 1/s) and a force window (kept to 6 ms after the 10 ms pre-trigger, 1 ms "
        "half-cosine taper, zero after); the FRF of such records is exactly the accelerance at s = σ + jω",
        "Fladung & Rost, Mech. Syst. Signal Process. 11 (1997) 23 (application and correction of the exponential "
        "window for FRFs); Avitabile, Modal Testing: A Practitioner's Guide (2017) (force/exponential windows, "
        "the exponential applied to the force too); Brandt, Noise and Vibration Analysis (2011) §13.7",
        physics={"export_end_fraction": 0.005, "export_decay_rate_1_s": float(np.log(200.0)),
                 "force_window_ms_after_pretrigger": 6.0, "force_window_taper_ms": 1.0},
        film_k=3.79e7, film_c=3.48e3, export_window={"end_fraction": 0.005, "force_window_ms": 6.0, "taper_ms": 1.0},
        must_not=rig_all + chain, expected_quality=["window"],
        reasoning="A processing property of the file, not of the rig: the tool must recognise it (note under "
                  "quality) and compare at s = σ + jω or divide it out; a film damping raised by 2mσ = 266 N·s/m "
                  "(+7.6 %) would be what an unaware recalibration finds — parameters-only with that is still "
                  "counted right by the verdict, but the quality note is what a user needs.", seed=401))

    listed.append(Case(
        "control-coarse-adc", "control",
        "recorded on a 12-bit recorder set to ±5 V: 2.44 mV steps = 1.085 N on the 2.25 mV/N hammer and "
        "0.239 m/s² on the 10.2 mV/(m/s²) accelerometer (peaks ≈ 44 steps), recorder input noise 0.25 step RMS: "
        "95 % of the tail samples are exact zeros (tail RMS 0.052 m/s² against LSB/√12 = 0.069 m/s²) and the "
        "rounding of the ringing response is correlated with it (H1 error 1 % at 100–300 Hz, 8 % at 50–100 Hz)",
        "Widrow & Kollár, Quantization Noise (Cambridge 2008) (the LSB²/12 model needs a signal that spans many "
        "steps); 12-bit USB data loggers' data sheets (±5/±10 V ranges)",
        physics={"bits": 12, "range_v": 5.0, "force_lsb_n": 10.0 / 4096 / 2.25e-3,
                 "accel_lsb_m_s2": 10.0 / 4096 / 10.2e-3, "adc_noise_lsb_rms": 0.25},
        film_k=3.82e7, film_c=3.52e3,
        adc={"bits": 12, "range_v": 5.0, "force_v_per_n": 2.25e-3, "accel_v_per_m_s2": 10.2e-3,
             "noise_lsb_rms": 0.25},
        must_not=rig_all + chain, expected_quality=["quantis"],
        reasoning="Rounding is measurement noise that is larger while the response is large than in the tails; a "
                  "noise model from the tails alone makes every rounding step look significant. Right: nothing "
                  "claimed, verdict consistent/parameters-only, ideally a note naming the step size.", seed=402))

    listed.append(Case(
        "control-floor-compressor", "control",
        "a compressor in the next room: narrowband floor vibration at 37 Hz (0.6 Hz wide, 3e-3 m/s² RMS) and "
        "74 Hz (1.5e-3 m/s²), uncorrelated with the hammer, reaching the mover through the film "
        "(transmissibility 1.04 and 1.17): present in the pre-trigger, the response and the tails of every record",
        "Gordon, Proc. SPIE 3786 (1999) (generic vibration criteria, narrowband machinery lines in precision "
        "labs); Brandt (2011) §13 (uncorrelated output noise: H1 unbiased, coherence drops)",
        physics={"floor_lines_hz_bw_rms": [[37.0, 0.6, 3e-3], [74.0, 0.6, 1.5e-3]]},
        film_k=3.78e7, film_c=3.46e3, floor={"lines": [(37.0, 0.6, 3e-3), (74.0, 0.6, 1.5e-3)]},
        must_not=rig_all + chain, expected_quality=["coherence"],
        reasoning="Uncorrelated output noise leaves H1 unbiased and only widens its scatter where the lines are; "
                  "it is stationary, so the tails measure it. Right: nothing claimed, low coherence noted near "
                  "37/74 Hz. A 'mains' note would misname the source (informational, not scored).", seed=403))

    listed.append(Case(
        "control-late-trigger", "control",
        "a recorder without pre-trigger: every record starts at the first recorded sample ≥ 20 N (the trigger "
        "level), so the pulse's first samples are not in the record (0.14–2.5 % of its impulse; the force record "
        "starts at 21–73 N); the response keeps the velocity that impulse gave: the FRF reads high by ≈ 5 % at "
        "20–100 Hz and 0.4 % at 100–300 Hz (a constant −δ/m added, δ the missing impulse fraction, per hit)",
        "Halvorsen & Brown, Sound and Vibration 11 (1977) 8 (pre-trigger needed to capture the whole pulse); "
        "Brandt (2011) §13.7 (impact testing: trigger and pre-trigger)",
        physics={"trigger_level_n": 20.0, "pretrigger_s": 0.0},
        film_k=3.81e7, film_c=3.49e3, pretrigger_s=0.0, trigger_level_n=20.0,
        must_not=rig_all + chain, expected_quality=["trigger"],
        reasoning="The part of the pulse before the record is missing from the force but its effect (the "
                  "mover's initial velocity) is in the response: a constant −δ/m is added to each hit's FRF, "
                  "different per hit. Cross-talk (a constant added), an added mass, a level-dependent "
                  "'nonlinearity' or a film term would all be artefacts. Issue 14 item 5: recognised, noted, "
                  "taken into the noise model, verdict consistent or parameters-only.", seed=404))

    gain = 9.6 / 10.2
    listed.append(Case(
        "sensitivity-mismatch", "measurement",
        "the accelerometer was replaced by one of 9.6 mV/(m/s²) but the file was scaled with the old 10.2 "
        "mV/(m/s²): every acceleration reads 0.941 × the truth (−5.9 %); the mass told is right",
        "ISO 16063-21:2003 (calibration by comparison); Ewins, Modal Testing (2000) §3.9 (calibration of the "
        "measurement chain: the mass-line check)",
        physics={"acceleration_factor": gain, "equivalent_added_mass_kg": 25.05 / gain - 25.05},
        sensor_factor=lambda s, z: np.full(s.shape, gain),
        exact=[["sensitivity-error"]], acceptable=[["added-mass"], []],
        needs_alternative={"added-mass": "sensitivity-error"}, empty_needs_recalibrated=["mass", "sensitiv"],
        must_not=[name for name in rig_all if name != "added-mass"] + ["channel-delay", "ac-coupling", "cross-talk"],
        honest_ok=False,
        reasoning="A uniform gain δ is exactly a mass M/(1+δ) on a film Z/(1+δ): one FRF cannot tell them apart. "
                  "Exact: sensitivity-error. Acceptable: added-mass +1.56 kg only if it names sensitivity-error as "
                  "its alternative (the user told the right mass; a calibration check decides); or nothing found "
                  "with verdict parameters-only only if the recalibration moved a mass/sensitivity parameter by "
                  "> 2 %. Not explained is not honest here: the equivalence is exact and documented.", seed=405))

    # ---- support physics nobody has named
    kf_o, cf_o, ko, tau_o, alpha_o, mp_o = 5.09e7, 4.0e3, 1.5e8, 1.77e-4, 0.5, 0.1

    def oring(s: np.ndarray, z_film: np.ndarray) -> np.ndarray:
        z_base = ko * (1 + (s * tau_o) ** alpha_o) + mp_o * s**2  # the pad's O-ring mount (fractional) + pad mass
        return z_film * z_base / (z_film + z_base)

    listed.append(Case(
        "oring-mount", "rig",
        "the bearing pads sit on elastomer O-rings (for self-alignment): the film (5.09e7 N/m, 4.0e3 N·s/m) is in "
        "SERIES with a fractional Kelvin–Voigt mount k_o (1 + (sτ)^0.5), k_o 1.5e8 N/m, τ 0.177 ms (loss factor "
        "0.24 at 196 Hz) and a 0.1 kg pad: static 3.8e7 N/m; the effective stiffness rises 4.01e7 → 4.24e7 N/m and "
        "the damping falls 5.0e3 → 3.3e3 N·s/m from 100 Hz to 1 kHz",
        "Smalley, Darlow & Mehta, J. Mech. Des. 100 (1978) 132 (dynamic stiffness and damping of O-rings, frequency "
        "dependent); J. Lubr. Technol. 101 (1979) 451 (stability of externally pressurised gas bearings on rubber "
        "O-ring supports); Bagley & Torvik, AIAA J. 21 (1983) 741 (fractional-derivative viscoelastic model)",
        physics={"film_k_n_per_m": kf_o, "film_c_ns_per_m": cf_o, "mount_k_n_per_m": ko, "mount_tau_s": tau_o,
                 "mount_alpha": alpha_o, "pad_mass_kg": mp_o, "static_total_k_n_per_m": kf_o * ko / (kf_o + ko)},
        film_k=kf_o, film_c=cf_o, pulse_ms=0.7, support=oring,
        exact=[["viscoelastic-mount"]], acceptable=[["film-memory"]],
        must_not=["added-mass", "extra-mode", "cubic-stiffness", "drift", "step-change", "friction",
                  "quadratic-damping", "pneumatic-lag"] + chain,
        reasoning="A driving-point FRF of the mover sees only the total dynamic stiffness of its support; where the "
                  "viscoelastic element sits (film or mount) is not identifiable from it. A fractional Maxwell "
                  "branch (film-memory) that closes the loop is an equivalent description (acceptable; its words "
                  "'film memory' mis-locate it — noted, not scored). Pneumatic-lag makes the stiffness fall with "
                  "frequency, the opposite (must not). A squeeze film names a gap and a plate that are not there "
                  "(false claim).", seed=411))

    a3, a5, scale_m = -0.25, 1.2, 7e-6
    listed.append(Case(
        "softening-hardening", "rig",
        "opposed-pad film whose stiffness peaks at the working gap: F = k x (1 + a3 (x/h)² + a5 (x/h)⁴) + c v, "
        "a3 −0.25, a5 +1.2, h 7 µm (x ≈ 4 µm at 200 N): softening for moderate hits, hardening for heavy ones; the "
        "per-hit |H| peak (noiseless, one hit) is 196.56 Hz at 80 N (= the linear film), 196.31 Hz at 200 N, "
        "196.59 Hz at 280 N, 196.97 Hz at 320 N: not monotone in the hit level; hits 220 N ± 35 % (80–340 N)",
        "Powell, Design of Aerostatic Bearings (1970) and Belforte et al., Tribology Letters 2007 (orifice-fed film "
        "stiffness maximal at the design gap); Worden & Tomlinson, Nonlinearity in Structural Dynamics (IOP 2001) "
        "and Masri & Caughey, J. Appl. Mech. 46 (1979) 433 (restoring-force surfaces: softening–hardening shapes)",
        physics={"a3": a3, "a5": a5, "scale_m": scale_m},
        record_s=0.5, force_n=220.0, force_spread=0.35, force_clip=(80.0, 340.0),
        nonlinear={"kind": "quintic", "a3": a3, "a5": a5, "scale_m": scale_m},
        exact=[["softening-hardening"]], partial_ok=["cubic-stiffness"],
        must_not=["added-mass", "extra-mode", "drift", "step-change", "film-memory", "squeeze-film",
                  "pneumatic-lag"] + chain,
        reasoning="Amplitude-dependent and non-monotone: a cubic spring fits one branch only. Cubic-stiffness is "
                  "allowed as a partial description beside a non-empty 'unexplained' (honest not-explained), not "
                  "as the explanation (verdict missing physics = wrong). Linear frequency-dependent terms and "
                  "chain terms stand in for it (must not).", seed=417))

    period_s, dk_o, dc_o, phase_o = 480.0, -0.009, -0.0038, 1.3

    def hvac(t: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray]:
        cycle = np.sin(two_pi * t / period_s + phase_o)
        return 3.8e7 * (1 + dk_o * cycle), 3.5e3 * (1 + dc_o * cycle)

    listed.append(Case(
        "hvac-cycling", "rig",
        "the lab's air conditioning hunts ±0.6 K with an 8 min period; the film follows (gap opening 0.3 %/K: k "
        "−1.5 %/K, c −0.63 %/K, viscosity +0.27 %/K included): k ±0.9 %, c ±0.38 %, 24 hits over a 24 min "
        "session (three periods: no net trend, no step)",
        "Bryan, CIRP Annals 39 (1990) 645 (thermal errors in precision machines; room-temperature cycling); "
        "Sutherland, Phil. Mag. 36 (1893) 507 (air viscosity vs temperature)",
        physics={"period_s": period_s, "stiffness_fraction": dk_o, "damping_fraction": dc_o, "phase_rad": phase_o},
        per_hit_film=hvac, hits=24, session_s=1440.0,
        exact=[["thermal-cycling"]], partial_ok=["drift"],
        must_not=["step-change", "added-mass", "extra-mode", "cubic-stiffness", "friction", "quadratic-damping",
                  "film-memory", "squeeze-film", "pneumatic-lag"] + chain,
        reasoning="The film changes between hits, periodically: a steady drift is at best a partial description "
                  "(allowed only beside a non-empty 'unexplained'), a step is wrong (must not), and every "
                  "frequency-dependent or amplitude-dependent term stands in for it.", seed=413))
    return listed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam"), help="output folder")
    parser.add_argument("--only", nargs="+", metavar="CASE", help="generate these cases only")
    parser.add_argument("--keys-only", action="store_true", help="write the answer keys only (no data)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    chosen = cases()
    if args.only:
        unknown = set(args.only) - {case.name for case in chosen}
        if unknown:
            print(f"--only: unknown case(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        chosen = [case for case in chosen if case.name in args.only]
    args.out.mkdir(parents=True, exist_ok=True)
    begin = time.perf_counter()
    for case in chosen:
        started = time.perf_counter()
        uff_path = args.out / f"{case.name}.uff"
        key = answer_key(case, uff_path.name)
        key["generated_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        key_path = args.out / f"{case.name}.key.json"
        key_path.write_text(json.dumps(key, indent=1, ensure_ascii=False))  # the key first
        if args.keys_only:
            continue
        records, starts, drawn = synthesise(case)
        key["drawn"] = drawn
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1, ensure_ascii=False))
        write_uff(uff_path, records, starts, case.sample_rate_hz, case.name)
        logger.info("%-24s %-11s %5.1f kS/s %4.2f s × %2d hits  %.1f s", case.name, case.category,
                    case.sample_rate_hz / 1e3, case.record_s, case.hits, time.perf_counter() - started)
    logger.info("%d cases in %.1f s → %s", len(chosen), time.perf_counter() - begin, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
