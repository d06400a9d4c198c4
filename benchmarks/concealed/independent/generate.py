"""Independent generator of impact-hammer sessions with answer keys (issue 11).

Imports nothing from gasfilm: its own mechanics (frequency domain for linear cases, fixed-step RK4 for nonlinear
ones) on an analog grid 8× the sample rate, its own anti-aliasing filter applied to force and response alike,
decimation, sensor noise on both channels, UFF 58 time records written with pyuff (one force and one acceleration
record per hit, each record's absolute session start time in ``abscissa_min``). Each case's answer key
``<case>.key.json`` is written BEFORE its UFF file, so the scorer can check that no key was written after a diagnosis
could have been seen.

    python benchmarks/concealed/independent/generate.py [--out out/independent] [--only CASE ...]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import pyuff
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from effect_names import ALL_EFFECTS  # noqa: E402

logger = logging.getLogger(__name__)

OVERSAMPLE = 8  # analog grid = 8 × the sample rate
PRETRIGGER_S = 0.010
LEAD_IN_S = 0.004  # simulated before each record so the anti-aliasing filter has settled
FORCE_NOISE_N_PER_RTHZ = 1e-4
ACCEL_NOISE_M_S2_PER_RTHZ = 3e-5
FORCE_SENSITIVITY_V_PER_N = 2.25e-3  # a PCB 086C03-class hammer
ACCEL_SENSITIVITY_V_PER_M_S2 = 10.2e-3  # 100 mV/g
TOLD_MASS_KG = 25.05  # what the diagnosis is told (--mass) unless a case says otherwise
FRICTION_SMOOTHING_M_S = 1e-5  # Coulomb friction as F_c·tanh(v/v_s): no chatter in the fixed-step integration
NONLINEAR_SPAN_S = 0.30  # nonlinear responses are integrated this long after the record start, zero afterwards
AIR_VISCOSITY_PA_S = 1.81e-5
AMBIENT_PRESSURE_PA = 101325.0
UFF_NODE, UFF_DIR = 1, 3  # driving point, +Z
DATA_TYPE_ACCELERATION, DATA_TYPE_FORCE, DATA_TYPE_TIME = 12, 13, 17


@dataclass(frozen=True)
class Truth:
    """What is simulated. Film parameters are at session start; every optional effect is off at its default."""

    mass_kg: float = 25.05
    film_k_n_per_m: float = 3.8e7
    film_c_ns_per_m: float = 3.5e3
    # time dependence over the session (session time t_s of each hit)
    stiffness_drift_fraction: float = 0.0  # k changes linearly by this fraction from the first to the last hit
    damping_drift_fraction: float = 0.0
    step_fraction: float | None = None  # film k, c multiplied by the step factors from this fraction of the session
    step_stiffness_factor: float = 1.0
    step_damping_factor: float = 1.0
    # linear rig physics
    extra_mass_kg: float = 0.0  # mass on a spring on the mover
    extra_freq_hz: float = 0.0  # its own natural frequency (on a rigid base)
    extra_damping_ratio: float = 0.0
    lag_k_n_per_m: float = 0.0  # k/(1+sτ)^order in parallel with the film
    lag_tau_s: float = 0.0
    lag_order: int = 1
    squeeze_length_m: float = 0.0  # compressible squeeze film of the paper's eq. 10-11 in parallel with the spring
    squeeze_width_m: float = 0.0
    squeeze_gap_m: float = 0.0
    rocking: dict | None = None  # {inertia_kg_m2, lever_arm_m, stiffness_asymmetry, hammer_offset_m, sensor_offset_m}
    # nonlinear rig physics
    coulomb_n: float = 0.0
    quadratic_ns2_per_m2: float = 0.0
    cubic_n_per_m3: float = 0.0
    # measurement chain
    sensitivity_factor: float = 1.0  # response channel scaled by this
    delay_s: float = 0.0  # response channel delayed against the force
    crosstalk_m_s2_per_n: float = 0.0  # force signal leaking into the response channel
    floor_rms_m_s2: float = 0.0  # narrowband random floor vibration on the response
    floor_band_hz: tuple[float, float] = (30.0, 40.0)
    mains_m_s2: tuple[float, ...] = ()  # amplitudes of 50, 100, 150, ... Hz on the response
    # hammer
    pulse_ms: float = 1.0
    pulse_ms_after_change: float | None = None  # a tip change halfway through the session
    force_n: float = 200.0
    force_spread: float = 0.2

    @property
    def nonlinear(self) -> bool:
        return bool(self.coulomb_n or self.quadratic_ns2_per_m2 or self.cubic_n_per_m3)

    def described(self) -> dict:
        """The fields that differ from a clean rig (film and mass always), for the answer key."""
        clean = Truth()
        table = {name: value for name, value in asdict(self).items()
                 if value != getattr(clean, name) or name in ("mass_kg", "film_k_n_per_m", "film_c_ns_per_m")}
        return {name: list(value) if isinstance(value, tuple) else value for name, value in table.items()}


@dataclass(frozen=True)
class Case:
    name: str
    category: str  # control | catalog | outside | trap
    summary: str
    truth: Truth
    sample_rate_hz: float = 12800.0
    record_s: float = 1.0
    hits: int = 20
    told_mass_kg: float = TOLD_MASS_KG
    exact: tuple[frozenset, ...] = (frozenset(),)
    acceptable: tuple[frozenset, ...] = ()
    alternatives_required: tuple[str, ...] = ()
    notes: dict = field(default_factory=dict)
    seed: int = 0

    @property
    def control(self) -> bool:
        return self.category == "control"

    @property
    def outside_catalog(self) -> bool:
        return self.category == "outside"


# ---------------------------------------------------------------------------------------------------------- physics

def squeeze_film(freq_hz: np.ndarray, length_m: float, width_m: float, gap_m: float,
                 pressure_pa: float = AMBIENT_PRESSURE_PA, viscosity_pa_s: float = AIR_VISCOSITY_PA_S) -> np.ndarray:
    """Complex stiffness K + jωC (N/m) of the compressible squeeze film, paper eq. 9-11 (infinitely long plate)."""
    omega = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    sigma = 12 * viscosity_pa_s * width_m**2 * omega / (pressure_pa * gap_m**2)
    root = np.sqrt(sigma) * np.exp(1j * np.pi / 4)
    with np.errstate(invalid="ignore", divide="ignore"):
        shape = np.where(sigma > 0, 1 - 2 * np.tanh(root / 2) / np.where(sigma > 0, root, 1), 0)
    return length_m * width_m * pressure_pa / gap_m * shape


def film_at(truth: Truth, t_s: float, session_s: float) -> tuple[float, float]:
    """Film (k N/m, c N·s/m) for a hit at session time ``t_s``."""
    ramp = t_s / session_s if session_s > 0 else 0.0
    k = truth.film_k_n_per_m * (1 + truth.stiffness_drift_fraction * ramp)
    c = truth.film_c_ns_per_m * (1 + truth.damping_drift_fraction * ramp)
    if truth.step_fraction is not None and ramp >= truth.step_fraction:
        k, c = k * truth.step_stiffness_factor, c * truth.step_damping_factor
    return k, c


def dynamic_stiffness(truth: Truth, freq_hz: np.ndarray, k: float, c: float) -> np.ndarray:
    """Everything between the mover and ground plus the attached oscillator, as seen by the mover (N/m, complex)."""
    omega = 2 * np.pi * freq_hz
    s = 1j * omega
    z = k + s * c
    if truth.lag_k_n_per_m:
        z = z + truth.lag_k_n_per_m / (1 + s * truth.lag_tau_s) ** truth.lag_order
    if truth.squeeze_gap_m:
        z = z + squeeze_film(freq_hz, truth.squeeze_length_m, truth.squeeze_width_m, truth.squeeze_gap_m)
    if truth.extra_mass_kg:
        omega_e = 2 * np.pi * truth.extra_freq_hz
        k_e = truth.extra_mass_kg * omega_e**2
        c_e = 2 * truth.extra_damping_ratio * truth.extra_mass_kg * omega_e
        spring = k_e + s * c_e
        z = z + spring * (-truth.extra_mass_kg * omega**2) / (spring - truth.extra_mass_kg * omega**2)
    return z


def accelerance(truth: Truth, freq_hz: np.ndarray, k: float, c: float) -> np.ndarray:
    """Mechanical acceleration at the sensor over the hammer force (m/s²/N), linear cases."""
    omega = 2 * np.pi * freq_hz
    if truth.rocking is None:
        with np.errstate(invalid="ignore", divide="ignore"):
            h = -omega**2 / (dynamic_stiffness(truth, freq_hz, k, c) - truth.mass_kg * omega**2)
        return np.nan_to_num(h)
    # Translation x and rocking θ: the film as two spring-dampers at ±a sharing k, c unevenly (asymmetry ε),
    # the hammer at offset e, the accelerometer at offset d.
    r = truth.rocking
    a, eps, e, d, inertia = (r["lever_arm_m"], r["stiffness_asymmetry"], r["hammer_offset_m"],
                             r["sensor_offset_m"], r["inertia_kg_m2"])
    z = k + 1j * omega * c  # total film, split (1-ε)/2 at -a and (1+ε)/2 at +a
    zxx = z - truth.mass_kg * omega**2
    zxt = eps * a * z
    ztt = a**2 * z - inertia * omega**2
    det = zxx * ztt - zxt**2
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (ztt * 1.0 - zxt * e) / det
        theta = (zxx * e - zxt * 1.0) / det
    return np.nan_to_num(-omega**2 * (x + d * theta))


def half_sine(t_s: np.ndarray, start_s: float, width_s: float, peak_n: float) -> np.ndarray:
    phase = (t_s - start_s) / width_s
    return np.where((phase >= 0) & (phase <= 1), peak_n * np.sin(np.pi * np.clip(phase, 0, 1)), 0.0)


def integrate_nonlinear(truth: Truth, t_s: np.ndarray, starts_s: np.ndarray, widths_s: np.ndarray,
                        peaks_n: np.ndarray, films: np.ndarray) -> np.ndarray:
    """Fixed-step RK4 of m·a = F − k x − c v − F_c tanh(v/v_s) − c_q |v| v − k3 x³ for all hits at once;
    returns the acceleration (hits, samples) on the grid ``t_s``."""
    dt = float(t_s[1] - t_s[0])
    k, c = films[:, 0], films[:, 1]
    m = truth.mass_kg

    def accel(time_s: float, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        phase = np.clip((time_s - starts_s) / widths_s, 0.0, 1.0)
        force = peaks_n * np.sin(np.pi * phase)
        restoring = k * x + c * v + truth.cubic_n_per_m3 * x**3 + truth.quadratic_ns2_per_m2 * np.abs(v) * v
        if truth.coulomb_n:
            restoring = restoring + truth.coulomb_n * np.tanh(v / FRICTION_SMOOTHING_M_S)
        return (force - restoring) / m

    steps = min(len(t_s), int(round(NONLINEAR_SPAN_S / dt)))
    out = np.zeros((len(starts_s), len(t_s)))
    x = np.zeros(len(starts_s))
    v = np.zeros(len(starts_s))
    for i in range(steps):
        t = t_s[i]
        a1 = accel(t, x, v)
        out[:, i] = a1
        x2, v2 = x + 0.5 * dt * v, v + 0.5 * dt * a1
        a2 = accel(t + 0.5 * dt, x2, v2)
        x3, v3 = x + 0.5 * dt * v2, v + 0.5 * dt * a2
        a3 = accel(t + 0.5 * dt, x3, v3)
        x4, v4 = x + dt * v3, v + dt * a3
        a4 = accel(t + dt, x4, v4)
        x = x + dt / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return out


# ------------------------------------------------------------------------------------------------ measurement chain

def anti_aliasing_filter(sample_rate_hz: float) -> tuple[np.ndarray, int]:
    """Elliptic low-pass (SOS, order) on the analog grid: flat to 0.45 fs (0.01 dB), ≥ 100 dB down from 0.55 fs."""
    fine_hz = OVERSAMPLE * sample_rate_hz
    order, natural = signal.ellipord(0.45 * sample_rate_hz, 0.55 * sample_rate_hz, 0.01, 100, fs=fine_hz)
    return signal.ellip(order, 0.01, 100, natural, btype="low", output="sos", fs=fine_hz), int(order)


def band_noise(rng: np.random.Generator, n: int, fine_hz: float, band_hz: tuple[float, float],
               rms: float) -> np.ndarray:
    """Gaussian random signal with a flat spectrum in ``band_hz`` and the given RMS."""
    spectrum = rng.standard_normal(n // 2 + 1) + 1j * rng.standard_normal(n // 2 + 1)
    freq = np.fft.rfftfreq(n, 1 / fine_hz)
    spectrum[(freq < band_hz[0]) | (freq > band_hz[1])] = 0
    out = np.fft.irfft(spectrum, n)
    return out * rms / max(np.std(out), 1e-30)


def hit_schedule(case: Case, rng: np.random.Generator) -> np.ndarray:
    """Sorted random hit times (s) over a session, at least one record plus 0.8 s apart."""
    gap_s = case.record_s + 0.8
    session_s = case.hits * gap_s * 1.8
    free = session_s - (case.hits - 1) * gap_s
    offsets = np.sort(rng.uniform(0, free, case.hits))
    return 1.0 + offsets + np.arange(case.hits) * gap_s


def synthesise(case: Case) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Records (hits, 2, samples) in N and m/s², record start times (s), and what was drawn (for the key)."""
    rng = np.random.default_rng(case.seed)
    truth = case.truth
    fs = case.sample_rate_hz
    fine_hz = OVERSAMPLE * fs
    samples = int(round(case.record_s * fs))
    lead = int(round(LEAD_IN_S * fine_hz))
    fine_n = samples * OVERSAMPLE + lead
    t_fine = (np.arange(fine_n) - lead) / fine_hz  # 0 = record start
    hit_times = hit_schedule(case, rng)
    starts = hit_times - PRETRIGGER_S
    session_s = float(hit_times[-1] - hit_times[0])
    first = hit_times[0]
    change_s = first + 0.5 * session_s
    widths = np.array([(truth.pulse_ms_after_change if truth.pulse_ms_after_change and t >= change_s
                        else truth.pulse_ms) * 1e-3 for t in hit_times])
    widths *= rng.uniform(0.95, 1.05, case.hits)
    peaks = np.clip(truth.force_n * (1 + truth.force_spread * rng.standard_normal(case.hits)), 100, 300)
    pulse_starts = PRETRIGGER_S - 0.05e-3 + rng.uniform(0, 1 / fs, case.hits)
    films = np.array([film_at(truth, t - first, session_s) for t in hit_times])
    forces = np.array([half_sine(t_fine, s0, w, p) for s0, w, p in zip(pulse_starts, widths, peaks)])

    if truth.nonlinear:
        mechanical = integrate_nonlinear(truth, t_fine, pulse_starts, widths, peaks, films)
    else:
        n_fft = 1 << int(np.ceil(np.log2(2 * fine_n)))
        freq = np.fft.rfftfreq(n_fft, 1 / fine_hz)
        mechanical = np.empty_like(forces)
        for hit, (force, (k, c)) in enumerate(zip(forces, films)):
            response = np.fft.irfft(np.fft.rfft(force, n_fft) * accelerance(truth, freq, k, c), n_fft)
            mechanical[hit] = response[:fine_n]

    n_fft = 1 << int(np.ceil(np.log2(fine_n)))
    freq = np.fft.rfftfreq(n_fft, 1 / fine_hz)
    response = truth.sensitivity_factor * mechanical
    if truth.delay_s:
        shifted = np.fft.irfft(np.fft.rfft(response, n_fft, axis=1) * np.exp(-2j * np.pi * freq * truth.delay_s),
                               n_fft, axis=1)
        response = shifted[:, :fine_n]
    response = response + truth.crosstalk_m_s2_per_n * forces
    for hit, start in enumerate(starts):
        absolute = start + t_fine
        for order, amplitude in enumerate(truth.mains_m_s2, start=1):
            response[hit] += amplitude * np.sin(2 * np.pi * 50.0 * order * absolute + 0.7 * order)
        if truth.floor_rms_m_s2:
            response[hit] += band_noise(rng, fine_n, fine_hz, truth.floor_band_hz, truth.floor_rms_m_s2)
    # sensor noise, white over the analog band, the stated density after the anti-aliasing filter
    forces = forces + FORCE_NOISE_N_PER_RTHZ * np.sqrt(fine_hz / 2) * rng.standard_normal(forces.shape)
    response = response + ACCEL_NOISE_M_S2_PER_RTHZ * np.sqrt(fine_hz / 2) * rng.standard_normal(response.shape)

    sos, order = anti_aliasing_filter(fs)
    records = np.empty((case.hits, 2, samples))
    for row, channel in enumerate((forces, response)):
        filtered = signal.sosfilt(sos, channel, axis=1)
        records[:, row, :] = filtered[:, lead::OVERSAMPLE][:, :samples]
    drawn = {
        "session_span_s": round(session_s, 3),  # first to last hit: drift per hour = fraction × 3600 / span
        "hit_times_s": np.round(hit_times, 4).tolist(),
        "peak_force_n": np.round(peaks, 1).tolist(),
        "pulse_width_ms": np.round(widths * 1e3, 3).tolist(),
        "film_k_per_hit_n_per_m": [float(f"{k:.5g}") for k in films[:, 0]],
        "film_c_per_hit_ns_per_m": [float(f"{c:.5g}") for c in films[:, 1]],
        "anti_aliasing": f"elliptic order {order}, 0.01 dB to 0.45 fs, 100 dB from 0.55 fs, on {fine_hz:.0f} Hz",
    }
    return records, starts, hit_times, drawn


# ------------------------------------------------------------------------------------------------------------ files

def write_uff(path: Path, records: np.ndarray, starts_s: np.ndarray, sample_rate_hz: float, name: str) -> None:
    """One force (type 13, N) and one acceleration (type 12, m/s²) time record per hit, start time in abscissa_min."""
    datasets = []
    dt = 1.0 / sample_rate_hz
    for hit, (record, start) in enumerate(zip(records, starts_s)):
        for values, data_type, unit in ((record[0], DATA_TYPE_FORCE, "N"),
                                        (record[1], DATA_TYPE_ACCELERATION, "m/s^2")):
            datasets.append(pyuff.prepare_58(
                binary=1, id1=f"{name} hit {hit}", id2="independent generator", id3="", id4="", id5="",
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


def expected_parameters(case: Case, session_span_s: float) -> dict[str, dict[str, float]]:
    """The true value of each allowed effect's main quantities (key names, SI units), for the parameter errors."""
    truth, told = case.truth, case.told_mass_kg
    per_hour = 3600.0 / session_span_s
    table: dict[str, dict[str, float]] = {}
    if truth.mass_kg != told or truth.sensitivity_factor != 1.0:
        # a sensitivity factor s on the response ≡ a mass told/s with the film scaled by 1/s
        apparent_mass = truth.mass_kg / truth.sensitivity_factor
        table["added-mass"] = {"mass_kg": apparent_mass - told}
        table["sensitivity-error"] = {"factor": told / apparent_mass}
    if truth.extra_mass_kg:
        table["extra-mode"] = {"freq_hz": truth.extra_freq_hz, "mass_kg": truth.extra_mass_kg,
                               "damping_ratio": truth.extra_damping_ratio}
    if truth.lag_k_n_per_m:
        table["pneumatic-lag"] = {"k_n_per_m": truth.lag_k_n_per_m, "tau_s": truth.lag_tau_s}
    if truth.delay_s:
        table["channel-delay"] = {"delay_s": truth.delay_s}
    if truth.stiffness_drift_fraction or truth.damping_drift_fraction:
        table["drift"] = {name: value for name, value in (
            ("fraction_per_hour", truth.stiffness_drift_fraction * per_hour),
            ("damping_fraction_per_hour", truth.damping_drift_fraction * per_hour)) if value}
    if truth.step_fraction is not None:
        table["step-change"] = {"stiffness_factor": truth.step_stiffness_factor,
                                "damping_factor": truth.step_damping_factor,
                                "after_s": truth.step_fraction * session_span_s}
    if truth.cubic_n_per_m3:
        table["cubic-stiffness"] = {"k3_n_per_m3": truth.cubic_n_per_m3}
    if truth.coulomb_n:
        table["friction"] = {"force_n": truth.coulomb_n}
    if truth.quadratic_ns2_per_m2:
        table["quadratic-damping"] = {"c2_ns2_per_m2": truth.quadratic_ns2_per_m2}
    if truth.crosstalk_m_s2_per_n:
        table["cross-talk"] = {"gain_m_s2_per_n": truth.crosstalk_m_s2_per_n}
    if truth.squeeze_gap_m:
        table["squeeze-film"] = {"length_m": truth.squeeze_length_m, "width_m": truth.squeeze_width_m,
                                 "gap_m": truth.squeeze_gap_m}
    allowed = set().union(*case.exact, *case.acceptable)
    return {effect: values for effect, values in table.items() if effect in allowed}


def answer_key(case: Case, uff_name: str) -> dict:
    allowed = set().union(*case.exact, *case.acceptable)
    return {
        "case": case.name,
        "uff": uff_name,
        "mass_kg": case.told_mass_kg,
        "category": case.category,
        "summary": case.summary,
        "truth": case.truth.described() | case.notes,
        "sample_rate_hz": case.sample_rate_hz,
        "record_s": case.record_s,
        "hits": case.hits,
        "control": case.control,
        "outside_catalog": case.outside_catalog,
        "exact": [sorted(names) for names in case.exact],
        "acceptable": [sorted(names) for names in case.acceptable],
        "must_not_claim": sorted(set(ALL_EFFECTS) - allowed - set(case.alternatives_required)),
        "alternatives_required": list(case.alternatives_required),
    }


# ------------------------------------------------------------------------------------------------------------ cases

def squeeze_notes(length_m: float, width_m: float, gap_m: float, static_k: float) -> dict:
    freq = np.array([50.0, 100.0, 200.0, 400.0, 1000.0])
    z = squeeze_film(freq, length_m, width_m, gap_m)
    sigma = 12 * AIR_VISCOSITY_PA_S * width_m**2 * 2 * np.pi * freq / (AMBIENT_PRESSURE_PA * gap_m**2)
    return {"squeeze_film": {
        "model": "paper eq. 9-11: K + jωC = (L B Pa / h0)·[1 − 2 th(√σ e^{jπ/4}/2)/(√σ e^{jπ/4})], "
                 "σ = 12 μ B² ω/(Pa h0²), in parallel with a static spring (no other dashpot)",
        "L_m": length_m, "B_m": width_m, "h0_m": gap_m, "Pa_pa": AMBIENT_PRESSURE_PA, "mu_pa_s": AIR_VISCOSITY_PA_S,
        "static_spring_n_per_m": static_k,
        "table": [{"freq_hz": f, "sigma": round(float(s), 3), "K_n_per_m": float(f"{v.real:.4g}"),
                   "C_ns_per_m": float(f"{v.imag / (2 * np.pi * f):.4g}")} for f, s, v in zip(freq, sigma, z)],
    }}


def cases() -> list[Case]:
    """The benchmark: controls, catalog-form positives, physics outside the catalog, identifiability traps."""
    s = frozenset
    base = Truth()
    sq_static = 3.8e7 - float(squeeze_film(np.array([200.0]), 0.20, 0.15, 150e-6).real[0])
    film = lambda k, c: replace(base, film_k_n_per_m=k, film_c_ns_per_m=c)  # noqa: E731
    listed = [
        # ---- controls: no physics may be claimed
        Case("clean", "control", "spring-damper film, nothing else", film(3.79e7, 3.47e3), seed=1),
        Case("clean-25k6", "control", "clean at 25.6 kS/s, 0.5 s records", film(3.84e7, 3.52e3),
             sample_rate_hz=25600.0, record_s=0.5, hits=16, seed=2),
        Case("parameters-only", "control", "film k +5 %, c −6 % against the usual nominal",
             film(3.78e7 * 1.05, 3.45e3 * 0.94), seed=3),
        Case("floor-vibration", "control",
             "narrowband random floor vibration 30-40 Hz, 2e-3 m/s² RMS, on the response",
             replace(film(3.8e7, 3.5e3), floor_rms_m_s2=2e-3), seed=4, hits=24),
        Case("tip-change", "control", "hammer tip 0.4 ms (hard) for the first half, 1.6 ms after",
             replace(film(3.77e7, 3.44e3), pulse_ms=0.4, pulse_ms_after_change=1.6, force_n=150.0), seed=5),
        Case("mains", "control",
             "mains 50 Hz 3e-3, 100 Hz 3e-4, 150 Hz 1e-3, 200 Hz 1e-4, 250 Hz 5e-4 m/s² on the response",
             replace(film(3.81e7, 3.49e3), mains_m_s2=(3e-3, 3e-4, 1e-3, 1e-4, 5e-4)), seed=6, record_s=0.5),
        Case("clean-many-light", "control", "30 light hits (120 N), 25.6 kS/s, 0.25 s records",
             replace(film(3.75e7, 3.6e3), force_n=120.0, force_spread=0.1), sample_rate_hz=25600.0, record_s=0.25,
             hits=30, seed=7),
        # ---- catalog forms
        Case("added-mass", "catalog", "mover 2.0 kg heavier than told", replace(base, mass_kg=27.05),
             exact=(s({"added-mass"}),), acceptable=(s({"sensitivity-error"}),), seed=11),
        Case("extra-mode", "catalog", "1.2 kg on a spring on the mover, 480 Hz, ζ 0.01",
             replace(base, extra_mass_kg=1.2, extra_freq_hz=480.0, extra_damping_ratio=0.01),
             exact=(s({"extra-mode"}),), seed=12),
        Case("extra-mode-truncated", "catalog",
             "0.8 kg at 610 Hz, ζ 0.002: rings past the 0.16 s records (response deliberately not decayed)",
             replace(base, extra_mass_kg=0.8, extra_freq_hz=610.0, extra_damping_ratio=0.002),
             sample_rate_hz=25600.0, record_s=0.16, exact=(s({"extra-mode"}),), seed=13),
        Case("pneumatic-lag", "catalog", "k/(1+sτ) in parallel: k 2e6 N/m, τ 0.6 ms (−0.76e3 N·s/m at 200 Hz)",
             replace(base, lag_k_n_per_m=2e6, lag_tau_s=0.6e-3), exact=(s({"pneumatic-lag"}),),
             acceptable=(s({"film-memory"}),), seed=14),
        Case("channel-delay", "catalog", "response delayed 60 µs against the force", replace(base, delay_s=60e-6),
             exact=(s({"channel-delay"}),), sample_rate_hz=25600.0, record_s=0.5, seed=15),
        Case("stiffness-drift", "catalog", "film k −4 % linearly over the session",
             replace(base, stiffness_drift_fraction=-0.04), exact=(s({"drift"}),), hits=24, seed=16),
        Case("hardening-film", "catalog", "cubic spring k3 = +1.5e17 N/m³ (≈ +6 % of k·x at 200 N)",
             replace(base, cubic_n_per_m3=1.5e17), exact=(s({"cubic-stiffness"}),), record_s=0.5, seed=17),
        # ---- outside the catalog's exact forms
        Case("friction", "outside", "Coulomb friction 2.5 N on the mover (tanh-smoothed at 1e-5 m/s)",
             replace(base, coulomb_n=2.5), exact=(s({"friction"}),), record_s=0.5, seed=21),
        Case("quadratic-damping", "outside", "velocity² damping 1.5e5 N·s²/m² (≈ +20 % of c·v at peak)",
             replace(base, quadratic_ns2_per_m2=1.5e5), exact=(s({"quadratic-damping"}),), record_s=0.5, seed=22),
        Case("rocking", "outside",
             "rocking mode ≈ 330 Hz coupled to translation: J 0.09 kg·m², film at ±0.1 m sharing k 40/60, "
             "hammer +0.03 m, accelerometer −0.05 m from the centre",
             replace(base, rocking={"inertia_kg_m2": 0.09, "lever_arm_m": 0.1, "stiffness_asymmetry": 0.2,
                                    "hammer_offset_m": 0.03, "sensor_offset_m": -0.05}),
             exact=(s({"extra-mode"}),), seed=23),
        Case("step-change", "outside", "film k −6 %, c +15 % from halfway through the session on",
             replace(base, step_fraction=0.5, step_stiffness_factor=0.94, step_damping_factor=1.15),
             exact=(s({"step-change"}),),
             hits=24, seed=24),
        Case("softening-film", "outside", "cubic spring k3 = −1.5e17 N/m³ (softening)",
             replace(base, cubic_n_per_m3=-1.5e17), exact=(s({"cubic-stiffness"}),), record_s=0.5, seed=25),
        Case("squeeze-film", "outside",
             "compressible squeeze film (eq. 10-11), L 0.20 m, B 0.15 m, h0 150 µm, air at 101 325 Pa, "
             "in parallel with a static spring",
             replace(base, film_k_n_per_m=sq_static, film_c_ns_per_m=0.0, squeeze_length_m=0.20,
                     squeeze_width_m=0.15, squeeze_gap_m=150e-6),
             exact=(s({"squeeze-film"}),), acceptable=(s({"film-memory"}),),
             notes=squeeze_notes(0.20, 0.15, 150e-6, sq_static), seed=26),
        Case("two-pole-lag", "outside", "k/(1+sτ)² in parallel: k 2e6 N/m, τ 0.4 ms (−1.0e3 N·s/m at 200 Hz)",
             replace(base, lag_k_n_per_m=2e6, lag_tau_s=0.4e-3, lag_order=2), exact=(s({"pneumatic-lag"}),),
             acceptable=(s({"film-memory"}),), seed=27),
        Case("cross-talk", "outside",
             "0.5 % of the force channel's voltage in the response channel (2.25 mV/N, 10.2 mV/(m/s²)): "
             "1.10e-3 (m/s²)/N",
             replace(base, crosstalk_m_s2_per_n=0.005 * FORCE_SENSITIVITY_V_PER_N / ACCEL_SENSITIVITY_V_PER_M_S2),
             exact=(s({"cross-talk"}),), seed=28),
        Case("damping-drift", "outside", "film c +25 % linearly over the session",
             replace(base, damping_drift_fraction=0.25),
             exact=(s({"drift"}),), hits=24, seed=29),
        # ---- identifiability traps
        Case("sensitivity-error", "trap", "accelerometer sensitivity +4 % (uniform), mass as told",
             replace(base, sensitivity_factor=1.04), exact=(s({"sensitivity-error"}), s({"added-mass"})),
             alternatives_required=("added-mass", "sensitivity-error"), seed=31),
        Case("equivalent-mass", "trap", "mover 1.0 kg heavier than told (≡ a −3.8 % sensitivity error)",
             replace(base, mass_kg=26.05), exact=(s({"added-mass"}), s({"sensitivity-error"})),
             alternatives_required=("added-mass", "sensitivity-error"), seed=32),
        Case("faint-mode", "trap", "1.6 g at 700 Hz, ζ 0.02: an extra mode below the noise of one hit",
             replace(base, extra_mass_kg=0.0016, extra_freq_hz=700.0, extra_damping_ratio=0.02),
             exact=(s({"extra-mode"}),), acceptable=(s(),),
             notes={"signature": "for a 200 N, 1 ms hit on a 1 s record at 12.8 kS/s, 10-1300 Hz: the mode adds "
                                 "Δχ² ≈ 63 per hit against a 1σ χ² fluctuation of ≈ 72 (2580 real points, "
                                 "accelerometer noise alone); about 4σ over the 20 hits"},
             seed=33),
    ]
    return listed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/independent"), help="output folder")
    parser.add_argument("--only", nargs="+", metavar="CASE", help="generate these cases only")
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
        records, starts, _, drawn = synthesise(case)
        key["truth"]["drawn"] = drawn
        key["expected_parameters"] = expected_parameters(case, drawn["session_span_s"])
        key["generated_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        (args.out / f"{case.name}.key.json").write_text(json.dumps(key, indent=1, ensure_ascii=False))
        write_uff(uff_path, records, starts, case.sample_rate_hz, case.name)
        logger.info("%-22s %-8s %5.1f kS/s %4.2f s × %2d hits  %.1f s", case.name, case.category,
                    case.sample_rate_hz / 1e3, case.record_s, case.hits, time.perf_counter() - started)
    logger.info("%d cases in %.1f s → %s", len(chosen), time.perf_counter() - begin, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
