"""Red-team world, round 3 (issue 14): rig physics and measurement faults that no issue and no earlier round names.

Written without reading ``analysis/`` or ``app/`` (only README.md, docs/, ``gasfilm diagnose --help`` and the earlier
red-team/independent benchmarks' READMEs, keys and scorers). Imports nothing from gasfilm: numpy, scipy, pyuff.

Synthesis per session (all hits at once):

1. an *analog* grid 8× the true sample rate with a 4 ms lead-in; contact force of every hit (half-sine, or the
   case's pulse), its random sub-sample start ≈ 10 ms into the record;
2. the mover's acceleration: exact frequency-domain product of the force spectrum (zero-padded FFT, no wrap) with the
   accelerance s²/(Z(s) + m s²) of the case's dynamic stiffness Z(s); the nonlinear case by fixed-step RK4 on the
   analog grid;
3. the chain on the analog grid: per-hit response delay (exact phase), sensor noise on both channels (white,
   1e-4 N/√Hz and 3e-5 m/s²/√Hz), the NI 9234's 0.5 Hz AC coupling (first order, both channels alike), additive
   disturbances (already through the AC coupling), range clipping (after the coupling, before the ADC's filter);
4. the SAME anti-aliasing low-pass on force and response (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, on
   the analog grid, causal), decimation by 8;
5. digital faults (lost samples, a wrong scale factor), 24-bit quantisation on ±5 V, UFF 58 (one force record,
   data type 13 "N", and one acceleration record, 12 "m/s^2", per hit; absolute start time in ``abscissa_min``).

Each case's answer key ``<case>.key.json`` is written BEFORE its UFF file; ``nominal-rig.toml`` is what a user knows.

    python benchmarks/concealed/redteam3/generate.py [--out out/redteam3] [--only CASE ...] [--keys-only]
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
FORCE_NOISE_N_PER_RTHZ = 1e-4
ACCEL_NOISE_M_S2_PER_RTHZ = 3e-5
AC_COUPLING_HZ = 0.5
ADC_BITS, ADC_RANGE_V = 24, 5.0
HAMMER_V_PER_N = 2.25e-3  # PCB 086C03
ACCEL_V_PER_M_S2 = 10.2e-3  # PCB 352B-class, 100 mV/g
NOMINAL = {"mass_kg": 25.05, "k": 3.78e7, "eta": 3450.0}  # what the user knows (the paper's SD film)
TRUE_MASS_KG, TRUE_K, TRUE_C = 25.05, 3.8e7, 3.5e3
DATA_TYPE_ACCELERATION, DATA_TYPE_FORCE, DATA_TYPE_TIME = 12, 13, 17

#: The catalogue's names as the earlier keys spell them (benchmarks/concealed/independent/effect_names.py).
RIG = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
       "step-change", "friction", "quadratic-damping")
CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error")
EVERYTHING = RIG + CHAIN + ("window-damping",)


def but(names: tuple[str, ...] | list[str], *allowed: str) -> list[str]:
    return [name for name in names if name not in allowed]


@dataclass
class Case:
    """One session and its answer."""

    name: str
    category: str  # control | rig | measurement
    summary: str
    source: str
    reasoning: str
    cli: str = "mass"  # "mass": --mass told; "rig": --rig nominal-rig.toml (the user's nominal spec)
    physics: dict = field(default_factory=dict)
    mass_kg: float = TRUE_MASS_KG
    film_k: float = TRUE_K
    film_c: float = TRUE_C
    sample_rate_hz: float = 12800.0  # true rate
    labelled_rate_hz: float | None = None  # the rate written into the file (None: the true one)
    record_s: float = 1.0
    pretrigger_s: float = 0.010
    hits: int = 20
    pulse_ms: float = 1.0
    force_n: float = 200.0
    force_spread: float = 0.2
    force_clip: tuple[float, float] = (100.0, 300.0)
    seed: int = 0
    # physics and chain hooks
    extra_z: Callable[[np.ndarray], np.ndarray] | None = None  # s → dynamic stiffness beside the film (N/m)
    series_z: Callable[[np.ndarray], np.ndarray] | None = None  # s → Z of what the film sits on (series)
    nonlinear: dict | None = None
    pulse_modulation: dict | None = None  # handle resonance: depth, freq_hz
    axial_gain: Callable[[np.random.Generator, int], np.ndarray] | None = None  # per hit: structure gets F × g
    response_delay_s: Callable[[np.ndarray], np.ndarray] | None = None  # hit times (s, from the first) → delay
    disturbance: Callable[["Case", np.random.Generator, np.ndarray, np.ndarray, dict], tuple[np.ndarray, np.ndarray]] \
        | None = None  # (case, rng, record starts s, t from record start s, drawn) → (force N, accel m/s²) added
    accel_v_per_m_s2: float = ACCEL_V_PER_M_S2
    response_clip: bool = False  # the response channel clips at the ±5 V range
    dropped: dict | None = None  # lost response samples: count (hits), samples, after_s range
    response_scale: float = 1.0  # a wrong scale factor in software (digital)
    pulse_growth: float = 0.0  # the pulse width grows by this fraction from the first to the last hit (tip wear)
    response_gain_drift: float = 0.0  # the accelerometer's sensitivity changes by this fraction over the session,
    #   as an exponential warm-up with a time constant of half the session (sensor heating)
    # the answer
    exact: list[list[str]] = field(default_factory=lambda: [[]])
    acceptable: list[list[str]] = field(default_factory=list)
    must_not: list[str] = field(default_factory=list)
    must_not_quality: list[str] = field(default_factory=list)
    partial_ok: list[str] = field(default_factory=list)
    needs_alternative: dict = field(default_factory=dict)
    empty_needs_recalibrated: dict = field(default_factory=dict)  # name → minimum relative move (exact name)
    honest_ok: bool = True
    expected_quality: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------------------------------- force

def contact_force(case: Case, t: np.ndarray, start: np.ndarray, width: np.ndarray, peak: np.ndarray,
                  phase: np.ndarray) -> np.ndarray:
    """Contact force (N), (hits, len(t)) for an array t, (hits,) for a scalar t."""
    scalar = np.ndim(t) == 0
    tt = np.full((len(start), 1), float(t)) if scalar else np.asarray(t)[None, :]
    u = (tt - start[:, None]) / width[:, None]
    inside = (u >= 0) & (u <= 1)
    shape = np.sin(np.pi * np.clip(u, 0, 1))
    if case.pulse_modulation:  # handle flexure: the head's velocity, hence the contact force, oscillates
        pm = case.pulse_modulation
        shape = shape * (1 + pm["depth"] * np.sin(2 * np.pi * pm["freq_hz"] * (tt - start[:, None]) + phase[:, None]))
    force = np.where(inside, peak[:, None] * np.maximum(shape, 0.0), 0.0)
    return force[:, 0] if scalar else force


# ------------------------------------------------------------------------------------------------------ linear

def dynamic_stiffness(case: Case, s: np.ndarray) -> np.ndarray:
    z = case.film_k + case.film_c * s
    if case.extra_z is not None:
        z = z + case.extra_z(s)
    if case.series_z is not None:
        zb = case.series_z(s)
        z = z * zb / (z + zb)
    return z


def accelerance(case: Case, freq_hz: np.ndarray) -> np.ndarray:
    s = 2j * np.pi * freq_hz
    with np.errstate(invalid="ignore", divide="ignore"):
        h = s**2 / (dynamic_stiffness(case, s) + case.mass_kg * s**2)
    h = np.nan_to_num(h)
    h[freq_hz == 0] = 0.0
    return h


# ------------------------------------------------------------------------------------------------- nonlinear

def integrate(case: Case, force_full: np.ndarray, force_half: np.ndarray, dt: float) -> np.ndarray:
    """RK4 of m a = F − k x − c v + c_n v_s tanh(v/v_s) (a saturating negative damping: pneumatic hammer below
    its threshold) on the analog grid; ``force_full``/``force_half`` (hits, n) are F at t_i and t_i + dt/2;
    acceleration (hits, n)."""
    nl = case.nonlinear
    k, c, m = case.film_k, case.film_c, case.mass_kg
    cn, vs = nl["negative_c_ns_per_m"], nl["saturation_m_s"]
    hits, n = force_full.shape

    def accel(f: np.ndarray, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return (f - k * x - c * v + cn * vs * np.tanh(v / vs)) / m

    x = np.zeros(hits)
    v = np.zeros(hits)
    out = np.zeros((hits, n))
    ff, fh = np.ascontiguousarray(force_full.T), np.ascontiguousarray(force_half.T)
    for i in range(n):
        a1 = accel(ff[i], x, v)
        out[:, i] = a1
        v2 = v + dt / 2 * a1
        a2 = accel(fh[i], x + dt / 2 * v, v2)
        v3 = v + dt / 2 * a2
        a3 = accel(fh[i], x + dt / 2 * v2, v3)
        v4 = v + dt * a3
        a4 = accel(ff[i + 1] if i + 1 < n else ff[i], x + dt * v3, v4)
        x = x + dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return out


# --------------------------------------------------------------------------------------------------- chain

def anti_aliasing(sample_rate_hz: float) -> np.ndarray:
    fine = OVERSAMPLE * sample_rate_hz
    order, wn = signal.ellipord(0.42 * sample_rate_hz, 0.5 * sample_rate_hz, 0.02, 110, fs=fine)
    return signal.ellip(order, 0.02, 110, wn, btype="low", output="sos", fs=fine)


def ac_coupling(rate_hz: float) -> np.ndarray:
    return signal.butter(1, AC_COUPLING_HZ, btype="high", output="sos", fs=rate_hz)


def hit_schedule(case: Case, rng: np.random.Generator) -> np.ndarray:
    gap = case.record_s + 0.8
    session = case.hits * gap * 1.8
    free = session - (case.hits - 1) * gap
    return 2.0 + np.sort(rng.uniform(0, free, case.hits)) + np.arange(case.hits) * gap


def next_pow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(n)))


def synthesise(case: Case, noise: bool = True) -> tuple[np.ndarray, np.ndarray, dict]:
    """Records (hits, 2, samples) in N and m/s² as the file holds them, record start times (s), what was drawn."""
    rng = np.random.default_rng(case.seed)
    fs = case.sample_rate_hz
    fine_hz = OVERSAMPLE * fs
    extra = case.dropped["samples"] if case.dropped else 0
    samples = int(round(case.record_s * fs))
    lead = int(round(LEAD_IN_S * fine_hz))
    n_fine = (samples + extra) * OVERSAMPLE + lead
    t = (np.arange(n_fine) - lead) / fine_hz  # from the record start
    hit_times = hit_schedule(case, rng)
    starts = hit_times - case.pretrigger_s
    peaks = np.clip(case.force_n * (1 + case.force_spread * rng.standard_normal(case.hits)), *case.force_clip)
    widths = case.pulse_ms * 1e-3 * rng.uniform(0.95, 1.05, case.hits)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / fs, case.hits)
    progress = (hit_times - hit_times[0]) / (hit_times[-1] - hit_times[0])
    widths = widths * (1 + case.pulse_growth * progress)  # (no further draws: other cases stay bit-identical)
    mod_phase = rng.uniform(0, 2 * np.pi, case.hits)
    force = contact_force(case, t, t0, widths, peaks, mod_phase)
    gain = case.axial_gain(rng, case.hits) if case.axial_gain else np.ones(case.hits)
    drawn: dict = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
                   "pulse_width_ms": np.round(widths * 1e3, 3).tolist(),
                   "session_span_s": round(float(hit_times[-1] - hit_times[0]), 3)}
    if case.axial_gain:
        drawn["axial_gain"] = np.round(gain, 5).tolist()
    n_fft = next_pow2(2 * n_fine)
    freq = np.fft.rfftfreq(n_fft, 1 / fine_hz)
    if case.nonlinear:
        half = contact_force(case, t + 0.5 / fine_hz, t0, widths, peaks, mod_phase)
        accel = integrate(case, force * gain[:, None], half * gain[:, None], 1 / fine_hz)
    else:
        spectra = np.fft.rfft(force * gain[:, None], n_fft, axis=1)
        accel = np.fft.irfft(spectra * accelerance(case, freq), n_fft, axis=1)[:, :n_fine]
    if case.response_delay_s is not None:
        delays = case.response_delay_s(hit_times - hit_times[0])
        accel = np.fft.irfft(np.fft.rfft(accel, n_fft, axis=1) * np.exp(-2j * np.pi * freq * delays[:, None]),
                             n_fft, axis=1)[:, :n_fine]
        drawn["response_delay_us"] = np.round(delays * 1e6, 3).tolist()
    # sanity: causal (nothing before the earliest pulse)
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(accel[:, before]).max() / np.abs(accel).max())
    level = 1.0 if noise else 0.0
    force_meas = force + level * FORCE_NOISE_N_PER_RTHZ * np.sqrt(fine_hz / 2) * rng.standard_normal(force.shape)
    accel_meas = accel + level * ACCEL_NOISE_M_S2_PER_RTHZ * np.sqrt(fine_hz / 2) * rng.standard_normal(accel.shape)
    hp = ac_coupling(fine_hz)
    force_meas = signal.sosfilt(hp, force_meas, axis=1)
    accel_meas = signal.sosfilt(hp, accel_meas, axis=1)
    if case.disturbance is not None:
        df, da = case.disturbance(case, rng, starts, t, drawn)
        force_meas = force_meas + level * df
        accel_meas = accel_meas + level * da
    if case.response_clip:
        limit = ADC_RANGE_V / case.accel_v_per_m_s2
        drawn["response_clip_m_s2"] = limit
        drawn["clipped_hits"] = np.flatnonzero(np.abs(accel_meas).max(axis=1) > limit).tolist()
        drawn["peak_accel_m_s2"] = np.round(np.abs(accel_meas).max(axis=1), 2).tolist()
        accel_meas = np.clip(accel_meas, -limit, limit)
    aaf = anti_aliasing(fs)
    records = np.empty((case.hits, 2, samples + extra))
    for row, channel in enumerate((force_meas, accel_meas)):
        records[:, row, :] = signal.sosfilt(aaf, channel, axis=1)[:, lead::OVERSAMPLE][:, :samples + extra]
    if case.dropped:  # a block of response samples lost in the stream: the rest of the record comes early
        dr = case.dropped
        which = np.sort(rng.permutation(case.hits)[:dr["count"]])
        info = []
        out = records[:, :, :samples].copy()
        for hit in which:
            at = int(round((t0[hit] + rng.uniform(*dr["after_s"])) * fs))
            out[hit, 1, at:] = records[hit, 1, at + dr["samples"]:at + dr["samples"] + samples - at]
            info.append({"hit": int(hit), "at_sample": at, "at_ms_after_pulse": round(1e3 * (at / fs - t0[hit]), 2)})
        records = out
        drawn["dropped_blocks"] = info
    records[:, 1, :] *= case.response_scale
    if case.response_gain_drift:
        warm = (1 - np.exp(-2 * progress)) / (1 - np.exp(-2.0))
        gains = 1 + case.response_gain_drift * warm
        records[:, 1, :] *= gains[:, None]
        drawn["response_gain_per_hit"] = np.round(gains, 5).tolist()
    lsb_v = 2 * ADC_RANGE_V / 2**ADC_BITS
    for row, volts_per_unit in ((0, HAMMER_V_PER_N), (1, case.accel_v_per_m_s2 / case.response_scale)):  # V per unit the software used
        step = lsb_v / volts_per_unit
        records[:, row, :] = np.round(records[:, row, :] / step) * step
    drawn["anti_aliasing"] = "elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, on the 8x grid; AC coupling 0.5 Hz"
    return records, starts, drawn


# ---------------------------------------------------------------------------------------------------- files

def write_uff(path: Path, records: np.ndarray, starts: np.ndarray, rate_hz: float, name: str) -> None:
    datasets = []
    dt = 1.0 / rate_hz
    for hit, (record, start) in enumerate(zip(records, starts)):
        for values, data_type, unit in ((record[0], DATA_TYPE_FORCE, "N"), (record[1], DATA_TYPE_ACCELERATION,
                                                                                 "m/s^2")):
            datasets.append(pyuff.prepare_58(
                binary=1, id1=f"{name} hit {hit}", id2="redteam3 generator", id3="", id4="", id5="",
                func_type=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3,
                ord_data_type=4, abscissa_spacing=1, abscissa_min=float(start), abscissa_inc=dt,
                abscissa_spec_data_type=DATA_TYPE_TIME, abscissa_axis_units_lab="s",
                ordinate_spec_data_type=data_type, ordinate_axis_units_lab=unit,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE",
                z_axis_spec_data_type=0, z_axis_axis_units_lab="NONE",
                data=np.asarray(values, dtype=float), x=float(start) + np.arange(len(values)) * dt))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(datasets, mode="add")


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
    truth = {"mass_kg": case.mass_kg, "film_k_n_per_m": case.film_k, "film_c_ns_per_m": case.film_c,
             "sample_rate_hz": case.sample_rate_hz, "labelled_rate_hz": case.labelled_rate_hz or case.sample_rate_hz,
             "record_s": case.record_s, "hits": case.hits, "pretrigger_s": case.pretrigger_s,
             "pulse_ms": case.pulse_ms, "force_n": case.force_n, "force_spread": case.force_spread} | case.physics
    return {
        "case": case.name, "uff": f"{case.name}.uff", "category": case.category, "summary": case.summary,
        "source": case.source, "reasoning": case.reasoning,
        "cli": case.cli, "mass_kg": NOMINAL["mass_kg"],
        "cli_arguments": (["--rig", "nominal-rig.toml"] if case.cli == "rig"
                          else ["--mass", f"{NOMINAL['mass_kg']:g}"]),
        "truth": truth, "control": case.category == "control",
        "exact": [sorted(n) for n in case.exact], "acceptable": [sorted(n) for n in case.acceptable],
        "allowed": allowed, "partial_ok": sorted(case.partial_ok), "must_not_claim": sorted(case.must_not),
        "must_not_quality": sorted(case.must_not_quality), "needs_alternative": case.needs_alternative,
        "empty_needs_recalibrated": case.empty_needs_recalibrated,
        "honest_not_explained_ok": case.honest_ok and case.category != "control",
        "expected_quality": case.expected_quality,
    }


# ---------------------------------------------------------------------------------------------------- cases

def supply_line_z(s: np.ndarray, kappa: float, transit_s: float, loss: float) -> np.ndarray:
    """Supply hose as a lossy acoustic line seen through the orifice: κ·tanh(Γ L), Γ L = sT + β√(sT)."""
    gl = s * transit_s + loss * np.sqrt(s * transit_s)
    return kappa * np.tanh(gl)


def porous_z(s: np.ndarray, delta_k: float, tau_s: float) -> np.ndarray:
    """Pressure diffusion through a porous restrictor (closed-end RC line): Δk·(1 − tanh(q)/q), q = √(sτ)."""
    q = np.sqrt(s * tau_s)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = 1 - np.tanh(q) / q
    return delta_k * np.where(np.abs(q) < 1e-6, q**2 / 3, g)


def iepe_settling(case: Case, rng: np.random.Generator, starts: np.ndarray, t: np.ndarray, drawn: dict):
    """A recorder that creates its task per hit: the IEPE bias step (12 V) settles through the 0.5 Hz AC coupling
    from the task start, ``wait`` s before the record — on both IEPE channels (hammer and accelerometer)."""
    tau = 1 / (2 * np.pi * AC_COUPLING_HZ)
    wait = rng.uniform(*case.physics["settle_wait_s"], case.hits)
    decay = np.exp(-(t[None, :] + wait[:, None]) / tau)
    bias_v = case.physics["iepe_bias_v"]
    drawn["settle_wait_s"] = np.round(wait, 3).tolist()
    drawn["accel_offset_at_record_start_m_s2"] = np.round(bias_v * np.exp(-wait / tau) / ACCEL_V_PER_M_S2, 5).tolist()
    return bias_v / HAMMER_V_PER_N * decay, bias_v / ACCEL_V_PER_M_S2 * decay


def scan_motion(case: Case, rng: np.random.Generator, starts: np.ndarray, t: np.ndarray, drawn: dict):
    """The mover is scanned sinusoidally by its linear motor during the test (x = X sin ω t from the session start),
    with the motor's cogging force (two periods per magnet pitch); its acceleration, through the 0.5 Hz AC
    coupling (computed on a 2 kHz grid from 8 s before each record, interpolated)."""
    ph = case.physics
    x_amp, f_scan, pitch, f_cog = ph["scan_amplitude_m"], ph["scan_hz"], ph["magnet_pitch_m"], ph["cogging_n"]
    coarse_hz = 2000.0
    hp = ac_coupling(coarse_hz)
    pre = 8.0
    tc = np.arange(-pre, t[-1] + 1 / coarse_hz, 1 / coarse_hz)
    out = np.empty((case.hits, len(t)))
    w = 2 * np.pi * f_scan
    for hit, start in enumerate(starts):
        ta = start + tc
        x = x_amp * np.sin(w * ta)
        a = -x_amp * w**2 * np.sin(w * ta) + f_cog / case.mass_kg * np.sin(4 * np.pi * x / pitch)
        a = signal.sosfilt(hp, a - a[0])
        out[hit] = np.interp(t, tc, a)
    drawn["scan_accel_rms_in_records_m_s2"] = round(float(np.sqrt(np.mean(out[:, t >= 0] ** 2))), 5)
    return np.zeros_like(out), out


def cases() -> list[Case]:
    tp = 2 * np.pi
    everything = list(EVERYTHING)
    rig_but = lambda *a: but(RIG, *a)  # noqa: E731
    listed: list[Case] = []

    # ------------------------------------------------------------------ controls
    listed.append(Case(
        "control-clean", "control", "spring-damper film only (k 3.8e7, c 3.5e3, 25.05 kg), 20 hits 200 N ± 20 %",
        "—", "Nothing but the nominal physics: any finding is false.", seed=301, must_not=everything,
        must_not_quality=["mains"]))
    kn = 68e-9 / 6e-6
    listed.append(Case(
        "control-rarefaction", "control",
        f"parameters only: a 6 µm film in slip flow (Kn {kn:.4f}): squeeze damping ÷ (1 + 6 Kn) → c 3229 N·s/m "
        "(nominal 3450, −6.4 %), k 3.84e7 (nominal 3.78e7, +1.6 %); scored against the nominal spec",
        "Burgdorfer, J. Basic Eng. 81 (1959) 94 (first-order slip, μ_eff = μ/(1 + 6Kn)); Fukui & Kaneko, "
        "J. Tribol. 110 (1988) 253 (rarefied gas film lubrication)",
        "Rarefaction at this gap changes only the film's coefficients (the slip factor is constant in frequency at "
        "these squeeze numbers), so the right answer is parameters-only with eta moved down (> 2 %).",
        cli="rig", film_k=3.84e7, film_c=3450 / (1 + 6 * kn), seed=302, physics={"knudsen": kn},
        must_not=everything, empty_needs_recalibrated={"eta": 0.02}))
    listed.append(Case(
        "control-handle-ripple", "control",
        "hammer handle flexure at 1.35 kHz modulates the contact force ±30 % within a 1.2 ms pulse (the force gauge "
        "measures it: H unbiased; the force spectrum has shifted nulls and a bump)",
        "Halvorsen & Brown, Sound and Vibration 11 (1977) 8; Brandt, Noise and Vibration Analysis (2011) §13.7 "
        "(hammer dynamics, tip/handle resonances)",
        "A property of the excitation only; the gauge measures the true contact force, so the FRF is exact where the "
        "force spectrum is usable. No physics, no double hit (the force never returns to zero inside the pulse).",
        pulse_ms=1.2, pulse_modulation={"depth": 0.3, "freq_hz": 1350.0}, seed=303, must_not=everything,
        must_not_quality=["double", "mains"], physics={"handle_hz": 1350.0, "modulation_depth": 0.3}))

    listed.append(Case(
        "control-tip-wear", "control",
        "the hammer's plastic tip wears and softens during the session: the pulse grows from 0.8 ms to 1.5 ms, "
        "linearly with the hit's time (force level unchanged); the gauge measures it: H unbiased",
        "Brandt (2011) §13.7 (tip hardness sets the excited band); PCB impulse hammer manuals (tip wear, replace "
        "worn tips)",
        "A property of the excitation that changes over the session (the usable band shrinks from ≈ 1.9 to ≈ 1 kHz); "
        "the structure does not change, so drift or step-change would be false.",
        pulse_ms=0.8, pulse_growth=0.875, seed=304, physics={"pulse_ms_first_last": [0.8, 1.5]},
        must_not=everything, must_not_quality=["mains"]))

    # ------------------------------------------------------------------ rig physics
    kappa, transit, loss = 1.0e5, 2.4 / 343.0, 0.05
    listed.append(Case(
        "supply-line-resonance", "rig",
        "2.4 m supply hose as a lossy acoustic line behind the orifice: Z += κ tanh(sT + β√(sT)), κ 1e5 N/m, "
        "T 7.0 ms, β 0.05 — a comb of quarter-wave resonances at 35.7, 107, 179, 250, 322 … Hz in the film's "
        "dynamic stiffness (≈ ±1e6 N/m at each tooth), nothing at DC",
        "Nichols, ISA Trans. 1 (1962) 5 (linear pneumatic transmission lines); Krus, Weddfelt & Palmberg, "
        "J. Dyn. Syst. Meas. Control 116 (1994) 756; Belforte et al., Tribol. Lett. 2007 (supply/feed dynamics "
        "of aerostatic pads)",
        "A linear, frequency-dependent film stiffness with several narrow teeth; no catalogue term has a comb. "
        "One extra mode can describe one tooth only beside an unexplained rest.",
        extra_z=lambda s: supply_line_z(s, kappa, transit, loss), seed=311,
        physics={"kappa_n_per_m": kappa, "transit_s": transit, "loss_beta": loss,
                 "teeth_hz": [round((2 * n + 1) / (4 * transit), 1) for n in range(6)]},
        exact=[["supply-line-resonance"]], partial_ok=["extra-mode"],
        must_not=["added-mass", "channel-delay", "cross-talk", "cubic-stiffness", "drift", "step-change",
                  "friction", "quadratic-damping", "ac-coupling", "sensitivity-error"],
        must_not_quality=["mains"]))
    cn = 0.85 * TRUE_C
    listed.append(Case(
        "hammer-onset", "rig",
        "pneumatic hammer just below its threshold: negative damping from the orifice/pocket lag, "
        "F = k x + c v − c_n v_s tanh(v/v_s), c_n 2975 N·s/m (0.85 c), v_s 0.8 mm/s: small motions damped at "
        "ζ 0.0085, large ones at ≈ ζ 0.057 (the hit's first swing, 5 mm/s) — stable, no limit cycle",
        "Licht, Fuller & Sternlicht, Trans. ASME 80 (1958) 411; Stowell, J. Lubr. Technol. 93 (1971) 441; "
        "Chen, Lin et al., Tribol. Int. 2010 (pneumatic hammer in aerostatic bearings, threshold by supply "
        "pressure and pocket volume)",
        "The damping depends on the amplitude (rises with it): a saturating negative viscous term, i.e. a negative "
        "Coulomb force at large velocity. No catalogue term has that shape; quadratic damping, friction or a "
        "pneumatic lag describe parts of it only beside an unexplained rest. The stiffness does not depend on "
        "the amplitude (cubic is wrong).",
        nonlinear={"negative_c_ns_per_m": cn, "saturation_m_s": 0.8e-3}, seed=312,
        physics={"negative_c_ns_per_m": cn, "saturation_m_s": 0.8e-3},
        exact=[["pneumatic-hammer-onset"]], partial_ok=["pneumatic-lag", "quadratic-damping", "friction"],
        must_not=["added-mass", "extra-mode", "channel-delay", "cross-talk", "drift", "step-change",
                  "ac-coupling", "cubic-stiffness", "sensitivity-error"],
        must_not_quality=["mains"], expected_quality=["truncat"]))
    dk, tau_p = 1.2e7, 1 / (tp * 250.0)
    listed.append(Case(
        "porous-restrictor", "rig",
        "porous (graphite) restrictor: gap pressure diffuses into the porous layer, Z += Δk (1 − tanh q / q), "
        "q = √(sτ), Δk 1.2e7 N/m, τ 0.64 ms (|sτ| = 1 at 250 Hz); film's own c 2.2e3 so that the total damping "
        "at the resonance is ≈ 3.9e3; static stiffness 3.8e7 unchanged",
        "Majumdar, Wear 36 (1976) 269 (externally pressurised porous gas bearings); Plante, Vogan, El-Aguizy & "
        "Slocum, Precis. Eng. 29 (2005) 336 (porous air bearing dynamics); Stout & El-Ashkar, Tribol. Int. 1979",
        "A diffusion (√s) transition of the film's stiffness and damping. The catalogue's squeeze-film term has the "
        "same 1 − tanh(q)/q law (q ∝ √s), so squeeze-film is an acceptable name; a fractional film-memory term "
        "approximates it.",
        film_c=2.2e3, extra_z=lambda s: porous_z(s, dk, tau_p), seed=313,
        physics={"delta_k_n_per_m": dk, "tau_s": tau_p},
        exact=[["porous-restrictor"]], acceptable=[["squeeze-film"], ["film-memory"]],
        must_not=["added-mass", "extra-mode", "channel-delay", "cross-talk", "cubic-stiffness", "drift",
                  "step-change", "friction", "quadratic-damping", "ac-coupling", "sensitivity-error"]))
    mb, fb, zb = 380.0, 14.0, 0.10
    kb = (TRUE_MASS_KG + mb) * (tp * fb) ** 2
    cb = 2 * zb * np.sqrt(kb * (TRUE_MASS_KG + mb))
    listed.append(Case(
        "soft-foundation", "rig",
        f"the bearing's granite base (380 kg) stands on soft isolators (k {kb:.3g} N/m, c {cb:.3g} N·s/m): the film "
        "acts in series with the base, Z_mover = Z_f Z_b/(Z_f + Z_b), Z_b = M_b s² + c_b s + k_b: a bounce mode "
        "at ≈ 14 Hz, the film mode moves to ≈ 202 Hz",
        "Rivin, Stiffness and Damping in Mechanical Design (1999) ch. 8 (machine foundations and isolators); "
        "Ewins, Modal Testing (2000) §3.2 (test-structure supports)",
        "A second degree of freedom below the mover, in series (not a mass riding on the mover): an extra mode "
        "near 14 Hz is the catalogue's closest description and acceptable; the mover is not heavier.",
        series_z=lambda s: mb * s**2 + cb * s + kb, seed=314,
        physics={"base_mass_kg": mb, "isolator_k_n_per_m": kb, "isolator_c_ns_per_m": cb},
        exact=[["soft-foundation"]], acceptable=[["extra-mode"]],
        must_not=["added-mass", "channel-delay", "cross-talk", "cubic-stiffness", "drift", "step-change",
                  "friction", "quadratic-damping", "ac-coupling", "sensitivity-error"]))

    # ------------------------------------------------------------------ measurement faults
    listed.append(Case(
        "iepe-settling", "measurement",
        "a recorder that creates its DAQ task per hit: IEPE excitation switches on 3.0–3.6 s before each record and "
        "the 12 V bias step is still settling through the 0.5 Hz AC coupling (τ 0.32 s): every record starts with "
        "a positive offset decaying with τ (accelerometer 0.015–0.1 m/s², hammer 0.07–0.45 N)",
        "NI 9234 user manual (AC coupling settling after IEPE excitation is enabled); PCB 'Introduction to ICP "
        "sensors' (bias turn-on settling); Brandt (2011) §4",
        "Additive, hit-independent transients at low frequency on both channels; no rig property. A note (not quiet "
        "before the hit, low coherence, baseline) and nothing claimed is right; an honest not-explained at low "
        "frequency is acceptable.",
        disturbance=iepe_settling, seed=321, physics={"iepe_bias_v": 12.0, "settle_wait_s": [3.0, 3.6]},
        must_not=list(RIG) + ["cross-talk", "sensitivity-error"], must_not_quality=["mains"]))
    listed.append(Case(
        "response-clipping", "measurement",
        "a 10 V/g seismic accelerometer (1.02 V/(m/s²)) on the ±5 V range: the response clips at ±4.9 m/s² "
        "(after the AC coupling, before the ADC's filter); hits 135 N ± 25 % (60–200 N), 13 of the 20 clip (peaks up to 7.1 m/s² before clipping)",
        "NI 9234 datasheet (±5 V input range, overload); PCB 393B12 data sheet (10 V/g, ±0.5 g); Avitabile, Modal "
        "Testing: A Practitioner's Guide (2017) (overloads)",
        "Clipped responses are not the structure: the right answer notes clipped hits, leaves them out and claims "
        "nothing. An amplitude-dependent term (cubic, friction, quadratic damping) would be a must-not.",
        accel_v_per_m_s2=1.02, response_clip=True, force_n=135.0, force_spread=0.25, force_clip=(60.0, 200.0),
        seed=322, physics={"accel_v_per_m_s2": 1.02, "clip_m_s2": 5.0 / 1.02},
        must_not=list(RIG) + ["cross-talk", "sensitivity-error"], expected_quality=["clip"]))
    ppm = 1.2e-6
    listed.append(Case(
        "clock-drift", "measurement",
        "force and response on two chassis with their own clocks (1.2 ppm apart), continuous acquisition, records "
        "cut by the force trigger: the response lags by 1.2e-6 × (time since the first hit), 0 → ≈ 75 µs over "
        "the session (≈ 1 sample at 12.8 kS/s at the end)",
        "NI-DAQmx help, 'Synchronizing multiple devices' (shared timebase/reference clock); Brandt (2011) §11 "
        "(channel timing errors); IEEE 1588 clock-drift literature",
        "A channel delay that grows linearly with the hit's time. A single mean channel delay is the closest "
        "catalogue description (acceptable); the rig does not drift (drift/step-change are must-not).",
        response_delay_s=lambda elapsed: ppm * elapsed, seed=323, physics={"clock_offset_ppm": 1.2},
        exact=[["clock-drift"]], acceptable=[["channel-delay"]],
        must_not=list(RIG) + ["cross-talk", "sensitivity-error"]))
    listed.append(Case(
        "dropped-samples", "measurement",
        "buffer overruns on the response channel's stream: in 5 of 20 hits a block of 32 samples (2.5 ms) is lost "
        "3–40 ms after the pulse; the record is spliced (the rest of the response comes 2.5 ms early)",
        "NI-DAQmx error −200279 (samples no longer available, buffer overwrite); Brandt (2011) §11 (data "
        "acquisition errors)",
        "A per-hit splice, not physics and not a steady delay: the hits should be found and left out, or the "
        "rest reported honestly as not explained.",
        dropped={"count": 5, "samples": 32, "after_s": (0.003, 0.040)}, seed=324,
        physics={"dropped_hits": 5, "samples": 32},
        must_not=list(RIG) + ["cross-talk", "sensitivity-error"], expected_quality=["hit"]))
    listed.append(Case(
        "teds-units", "measurement",
        "TEDS gives the accelerometer as 100 mV/g; the recorder took 100 as mV/(m/s²): every acceleration reads "
        "÷ 9.807 (×0.102); scored with the nominal spec (mass 25.05 kg as it really is)",
        "IEEE 1451.4 (TEDS templates, sensitivity units); ISO 16063-21:2003 (calibration by comparison)",
        "The FRF is 9.81× too small at every frequency: a sensitivity (units) error. An added mass is acceptable only "
        "with the sensitivity-error alternative (and a + 221 kg mass on a 25 kg mover is absurd on its face).",
        cli="rig", response_scale=1 / 9.80665, seed=325, physics={"response_factor": 1 / 9.80665},
        exact=[["sensitivity-error"]], acceptable=[["added-mass"]],
        needs_alternative={"added-mass": "sensitivity-error"},
        must_not=but(RIG, "added-mass") + ["channel-delay", "cross-talk", "ac-coupling"]))
    listed.append(Case(
        "rate-mislabel", "measurement",
        "NI 9234 coerced a requested 10 kS/s to 10.24 kS/s (51.2k/5) silently; the recorder wrote 10 000 S/s into "
        "the file: every frequency reads 2.4 % low (H_file(f) = H(1.024 f)); scored with the nominal spec",
        "NI 9234 datasheet (data rates f_M/(256 n), coercion); NI-DAQmx help 'Sample clock rate coercion'",
        "Exactly a spring-damper with k/1.024² (−4.6 %) and c/1.024 on the same mass: undetectable from the data, so "
        "parameters-only with k moved down (> 2 %) is right; nothing else.",
        cli="rig", sample_rate_hz=10240.0, labelled_rate_hz=10000.0, seed=326,
        physics={"true_rate_hz": 10240.0, "labelled_rate_hz": 10000.0},
        must_not=everything, empty_needs_recalibrated={"k": 0.02}, honest_ok=False))
    listed.append(Case(
        "hit-angle-scatter", "measurement",
        "hand-held hits on a bevelled face, 5–28° off the bearing axis at random: the gauge measures the full force, "
        "the mover's axis gets F cos θ (0.88–0.996, mean 0.95): the FRF reads ≈ 5 % low and scatters ±4 % "
        "between hits; scored with the nominal spec",
        "Ewins, Modal Testing (2000) §3.7 (excitation direction); Avitabile (2017) (hammer technique, "
        "perpendicular hits)",
        "A per-hit force-direction error: sensitivity-error (the force reads high) is acceptable, an added mass only "
        "with that alternative; the between-hit scatter is not physics.",
        cli="rig", axial_gain=lambda rng, n: np.cos(np.deg2rad(rng.uniform(5, 28, n))), seed=327,
        physics={"angle_deg_range": [5, 28]},
        exact=[["hit-angle"]], acceptable=[["sensitivity-error"], ["added-mass"]],
        needs_alternative={"added-mass": "sensitivity-error"},
        must_not=but(RIG, "added-mass") + ["channel-delay", "cross-talk", "ac-coupling"]))
    listed.append(Case(
        "scan-motion", "measurement",
        "hits on a moving mover: the stage scans x = 6 mm sin(2π 0.7 t) during the test (0.116 m/s² at 0.7 Hz) "
        "with its linear motor's cogging (0.8 N, two periods per 24 mm pitch, up to 2.2 Hz), through the 0.5 Hz AC "
        "coupling; the hammer hits at whatever phase",
        "Altintas et al., CIRP Annals 60 (2011) 779 (feed drives, force ripple); Avitabile (2017) (testing "
        "operating structures)",
        "A large, slow motion uncorrelated with the hammer, mostly below the band, whose leakage reaches the "
        "band's bottom. Nothing is claimed; a low-frequency honest not-explained is acceptable.",
        disturbance=scan_motion, seed=328,
        physics={"scan_amplitude_m": 6e-3, "scan_hz": 0.7, "magnet_pitch_m": 24e-3, "cogging_n": 0.8},
        must_not=list(RIG) + ["cross-talk", "sensitivity-error", "ac-coupling"], must_not_quality=["mains"]))
    listed.append(Case(
        "sensor-thermal-drift", "measurement",
        "the accelerometer warms on the mover (linear-motor coil heat, ≈ 25 K): its sensitivity falls by 3 % over "
        "the session, an exponential warm-up with a time constant of half the session; the film and mass do not "
        "change",
        "PCB/Endevco data sheets (sensitivity temperature coefficient of shear-mode PZT, ≈ −0.1 %/K); "
        "Serridge & Licht (B&K 1987) §3.4 (temperature sensitivity); Bryan, CIRP Annals 39 (1990) 645",
        "A measurement gain that drifts: the whole FRF (mass line included) falls with time. A film drift or step "
        "would send the user to the bearing (must-not); a (mean) sensitivity error, or an added mass with that "
        "alternative, is acceptable.",
        response_gain_drift=-0.03, seed=329, physics={"sensitivity_change": -0.03, "time_constant": "span/2"},
        exact=[["sensor-thermal-drift"]], acceptable=[["sensitivity-error"], ["added-mass"]],
        needs_alternative={"added-mass": "sensitivity-error"},
        must_not=but(RIG, "added-mass") + ["channel-delay", "cross-talk", "ac-coupling"]))
    return listed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/redteam3"))
    parser.add_argument("--only", nargs="+", metavar="CASE")
    parser.add_argument("--keys-only", action="store_true", help="write the answer keys only")
    parser.add_argument("--seed-offset", type=int, default=0,
                        help="another draw of the same world (noise, hits); the keys' drawn figures are of draw 0")
    args = parser.parse_args(argv)
    listed = cases()
    for case in listed:
        case.seed += args.seed_offset
    if args.only:
        unknown = set(args.only) - {c.name for c in listed}
        if unknown:
            print(f"--only: unknown case(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        listed = [c for c in listed if c.name in args.only]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "nominal-rig.toml").write_text(NOMINAL_TOML)
    for case in listed:
        began = time.perf_counter()
        key_path = args.out / f"{case.name}.key.json"
        key_path.write_text(json.dumps(answer_key(case), indent=1))
        if args.keys_only:
            continue
        records, starts, drawn = synthesise(case)
        time.sleep(0.01)  # the key is older than its data
        write_uff(args.out / f"{case.name}.uff", records, starts, case.labelled_rate_hz or case.sample_rate_hz,
                  case.name)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1))
        print(f"{case.name:24s} {case.category:11s} {time.perf_counter() - began:5.1f} s  "
              f"peak |a| {np.abs(records[:, 1]).max():.3g} m/s², acausal {drawn['acausal_fraction']:.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
