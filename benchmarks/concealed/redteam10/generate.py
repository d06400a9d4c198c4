"""Red-team world, round 10: seventeen cases of hidden physics and measurement faults (several at once, some varying
over the session) plus five controls, for ``gasfilm diagnose`` scored as *right*, *modelled* and *named*.

Written by a helper that has read neither ``analysis/``, ``app/``, ``drivers/`` nor ``tests/`` (only README.md, docs/,
the CLI's ``--help``, the paper with its ERRATA, the v2 JSON contract in the project's notes and the earlier rounds'
READMEs, keys, generators and scorers). Imports nothing from gasfilm: numpy, scipy and pyuff only. The synthesis frame
is round 9's (itself round 8's), re-written here with this round's hooks.

Per session:

1. an *analog* grid 8x the true sample rate with a 4 ms lead-in; the contact force of every hit (a half-sine of random
   peak and width starting at a random sub-sample instant);
2. the mover's acceleration at the accelerometer: the exact product of the zero-padded force spectrum with the case's
   accelerance (per hit where the rig changes between hits) -- the film's dynamic stiffness with what the case adds to
   it (attached oscillators, branches, a support in series), modes beside the rigid body (signed modal constants);
   where the case is not linear and time-invariant, the part that is not (a joint's microslip, a film modulated by the
   supply's pulsation) is integrated in time (RK4 on the analog grid);
3. the sensors: the accelerometer's own transfer (a seismic element's resonance, a mount, a missing charge amplifier)
   and the hammer's (a tip extender's resonance in front of the gauge) applied to the analog signals; white sensor
   noise on both channels; the NI 9234's 0.5 Hz first-order AC coupling on both channels;
4. the SAME anti-aliasing low-pass on both channels (elliptic, 0.02 dB to 0.42 fs, 110 dB from 0.5 fs, causal), every
   8th analog point taken, quantisation (24 bit on +-5 V with the sensitivities the software used);
5. UFF 58 (per hit a force record, data type 13 "N", and an acceleration record, 12 "m/s^2"; each record's absolute
   session start in ``abscissa_min``; binary doubles).

Every answer key ``<case>.key.json`` is written BEFORE its data (the scorer refuses a key newer than its UFF file);
the keys as committed before any diagnosis ran are in ``keys/``.

    python benchmarks/concealed/redteam10/generate.py [--out out/redteam10] [--only CASE ...] [--keys-only]
                                                      [--seed-offset N]
"""

from __future__ import annotations

import argparse
import itertools
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
RANGE_V = 5.0
HAMMER_V_PER_N = 2.25e-3
ACCEL_V_PER_M_S2 = 10.2e-3
MASS, K, C = 25.05, 3.8e7, 3.5e3  # true mover and film unless a case says otherwise
NOMINAL = {"mass_kg": 25.05, "k": 3.78e7, "eta": 3450.0}  # what the user knows (the paper's SD film)

# ----------------------------------------------------------------------------------------- names used in the keys
RIG = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
       "step-change", "friction", "quadratic-damping")
CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error", "polarity")
AMPLITUDE = ("cubic-stiffness", "friction", "quadratic-damping")
TIME = ("drift", "step-change")
MEMORY = ("film-memory", "squeeze-film", "pneumatic-lag")
#: A v2 generic description (an effect name that is no catalog term) is classified by its place (score.py):
G_BESIDE, G_FILM, G_MOVER, G_CHAIN, G_HITS = ("generic:beside", "generic:film", "generic:mover", "generic:chain",
                                              "generic:between-hits")
GENERIC = (G_BESIDE, G_FILM, G_MOVER, G_CHAIN, G_HITS)
EVERYTHING = RIG + CHAIN + ("window-damping",) + GENERIC
#: Places of the v2 contract.
FORCE_CH, RESP_CH, CHAIN_PL, MOVER_PL, FILM_PL, BESIDE_PL, HITS_PL = (
    "force channel", "response channel", "measurement chain", "mover", "film", "beside the mover", "between hits")
ANY_CHAIN_PLACE = [FORCE_CH, RESP_CH, CHAIN_PL]
MASS_KEYWORDS = ["mass", "weight", "heavier", "lighter"]


def without(names, *dropped):
    return [n for n in names if n not in dropped]


@dataclass
class Case:
    name: str
    category: str  # control | rig | measurement | several
    summary: str
    source: str
    reasoning: str
    seed: int
    right_means: str = ""
    rate_hz: float = 12800.0
    record_s: float = 1.0
    pretrigger_s: float = 0.010
    hits: int = 16
    pulse_ms: float = 1.0
    width_spread: float = 0.05
    force_n: float = 200.0
    spread: float = 0.2
    force_range: tuple | None = None  # (lo, hi): peaks log-uniform instead of normal
    gap_s: tuple = (1.0, 3.0)  # pause between one record's end and the next hit
    extra_gap: dict = field(default_factory=dict)  # hit index (from 0) -> extra pause before it (s)
    mass: float = MASS
    film: tuple = (K, C)
    model: Callable | None = None  # (case, s, drawn, on) -> dict(h=(h|1, nf), resp_tf=..., force_tf=...)
    time_domain: Callable | None = None  # (case, rng, t, drawn, on) -> analog response to add (h, n)
    accel_v: float = ACCEL_V_PER_M_S2  # the sensitivity the software divides by (quantisation step)
    accel_noise: float = ACCEL_NOISE
    force_noise: float = FORCE_NOISE
    physics: dict = field(default_factory=dict)
    kinds: list = field(default_factory=list)  # one dict per effect (see answer_key)
    partial_ok: list = field(default_factory=list)
    must_not: list = field(default_factory=list)
    must_not_quality: list = field(default_factory=lambda: ["mains", "clip"])
    expected_quality: list = field(default_factory=list)
    needs_alternative: dict = field(default_factory=dict)
    extra_exact: list = field(default_factory=list)  # further sets of names that describe the case
    refusal_ok: bool = False
    mass_told: float = NOMINAL["mass_kg"]


# ------------------------------------------------------------------------------------------------------ helpers

def nextpow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(n)))


def half_sine(t: np.ndarray, start: np.ndarray, width: np.ndarray, peak: np.ndarray) -> np.ndarray:
    u = (t[None, :] - start[:, None]) / width[:, None]
    return np.where((u >= 0) & (u <= 1), peak[:, None] * np.sin(np.pi * np.clip(u, 0, 1)), 0.0)


def w_of(f_hz: float) -> float:
    return 2 * np.pi * f_hz


def accelerance(s, z, m):
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.nan_to_num(s**2 / (z + m * s**2))


def sd_accelerance(s, k: float = K, c: float = C, m: float = MASS):
    return accelerance(s, k + c * s, m)


def extra_mode_z(s, m_e, f_e, zeta_e):
    """A mass on a spring-damper riding on the mover (the catalogue's extra-mode form)."""
    w = w_of(f_e)
    k_e, c_e = m_e * w**2, 2 * zeta_e * m_e * w
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.nan_to_num(m_e * s**2 * (k_e + c_e * s) / (m_e * s**2 + c_e * s + k_e))


def mode_beside(s, r, f, zeta):
    """A mode of the structure seen beside the rigid body: modal constant r (1/kg, signed) in the accelerance."""
    w = w_of(f)
    return r * s**2 / (s**2 + 2 * zeta * w * s + w**2)


def lag_z(s, k, tau):
    return k / (1 + s * tau)


def memory_z(s, k_m, eta, alpha):
    """Fractional Maxwell branch k_m eta s^a / (k_m + eta s^a) (the catalogue's film-memory form)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sa = np.where(s == 0, 0, s) ** alpha
        return np.nan_to_num(k_m * eta * sa / (k_m + eta * sa))


def second_order(s, f, zeta, zero=False):
    """w^2/(s^2 + 2 zeta w s + w^2) (a seismic element), or with the numerator w^2 + 2 zeta w s (a mount)."""
    w = w_of(f)
    num = w**2 + (2 * zeta * w * s if zero else 0)
    return num / (s**2 + 2 * zeta * w * s + w**2)


def poles_of(poly) -> list[tuple[float, float]]:
    """(natural frequency Hz, damping ratio) of the oscillatory roots of a polynomial, ascending."""
    roots = np.roots(poly)
    out = sorted({(round(float(abs(r) / (2 * np.pi)), 4), round(float(-r.real / abs(r)), 6)) for r in roots
                  if r.imag > 1e-6})
    return out


def attached_poles(m_e, f_e, zeta_e, mass=MASS, k=K, c=C):
    """Poles (Hz, zeta) of the mover on its film with a mass on a spring-damper riding on it."""
    w = w_of(f_e)
    k_e, c_e = m_e * w**2, 2 * zeta_e * m_e * w
    poly = np.polyadd(np.polymul([mass, c, k], [m_e, c_e, k_e]), np.polymul([m_e, 0, 0], [c_e, k_e]))
    return poles_of(poly)


def anti_aliasing(rate_hz: float):
    fine = OVERSAMPLE * rate_hz
    order, wn = signal.ellipord(0.42 * rate_hz, 0.5 * rate_hz, 0.02, 110, fs=fine)
    return signal.ellip(order, 0.02, 110, wn, btype="low", output="sos", fs=fine)


def draw_hits(case: Case, rng: np.random.Generator):
    h = case.hits
    gaps = rng.uniform(*case.gap_s, h)
    for index, extra in case.extra_gap.items():
        gaps[index] += extra
    hit_times = 1.5 + np.cumsum(case.record_s + gaps)
    if case.force_range is not None:
        lo, hi = case.force_range
        peaks = np.exp(rng.uniform(np.log(lo), np.log(hi), h))
    else:
        peaks = np.clip(case.force_n * (1 + case.spread * rng.standard_normal(h)), 0.5 * case.force_n,
                        1.5 * case.force_n)
    widths = case.pulse_ms * 1e-3 * rng.uniform(1 - case.width_spread, 1 + case.width_spread, h)
    t0 = case.pretrigger_s - 0.05e-3 + rng.uniform(0, 1 / case.rate_hz, h)
    return hit_times, peaks, widths, t0


# -------------------------------------------------------------------------------------------------- synthesis

def synthesise(case: Case, noise: bool = True, on: set | None = None):
    """Records (hits, 2, samples) as written (after quantisation), session starts, and what was drawn.

    ``on``: the ids of the case's effects to include (default all) -- check.py leaves one out at a time."""
    on = {k["id"] for k in case.kinds} if on is None else set(on)
    rng = np.random.default_rng(case.seed)
    fs = case.rate_hz
    fine = OVERSAMPLE * fs
    samples = int(round(case.record_s * fs))
    lead = int(round(LEAD_IN_S * fine))
    n = samples * OVERSAMPLE + lead
    t = (np.arange(n) - lead) / fine
    h = case.hits
    hit_times, peaks, widths, t0 = draw_hits(case, rng)
    drawn = {"hit_times_s": np.round(hit_times, 4).tolist(), "peak_force_n": np.round(peaks, 1).tolist(),
             "pulse_width_ms": np.round(widths * 1e3, 4).tolist(),
             "_t0": t0, "_widths": widths, "_peaks": peaks, "_hit_times": hit_times,
             "_session_times": hit_times - hit_times[0]}
    force = half_sine(t, t0, widths, peaks)
    starts = hit_times - case.pretrigger_s
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    parts = case.model(case, s, drawn, on) if case.model is not None else {}
    hh = parts.get("h")
    if hh is None:
        hh = sd_accelerance(s, *case.film, m=case.mass)[None, :]
    spectrum = np.fft.rfft(force, nfft, axis=1)
    resp_spec = spectrum * hh
    if case.time_domain is not None:
        extra = case.time_domain(case, rng, t, drawn, on)
        if extra is not None:
            resp_spec = resp_spec + np.fft.rfft(extra, nfft, axis=1)
    if parts.get("resp_tf") is not None:
        resp_spec = resp_spec * parts["resp_tf"]
    read_force_spec = spectrum * parts["force_tf"] if parts.get("force_tf") is not None else spectrum
    resp = np.fft.irfft(resp_spec, nfft, axis=1)[:, :n]
    read_force = np.fft.irfft(read_force_spec, nfft, axis=1)[:, :n] if parts.get("force_tf") is not None else force
    before = t < t0.min() - 2e-4
    drawn["acausal_fraction"] = float(np.abs(resp[:, before]).max() / max(np.abs(resp).max(), 1e-300))
    level = 1.0 if noise else 0.0
    read_force = read_force + level * case.force_noise * np.sqrt(fine / 2) * rng.standard_normal(force.shape)
    resp = resp + level * case.accel_noise * np.sqrt(fine / 2) * rng.standard_normal(resp.shape)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    read_force = signal.sosfilt(hp, read_force, axis=1)
    resp = signal.sosfilt(hp, resp, axis=1)
    records = np.empty((h, 2, samples))
    sos = anti_aliasing(fs)
    records[:, 0, :] = signal.sosfilt(sos, read_force, axis=1)[:, lead::OVERSAMPLE][:, :samples]
    records[:, 1, :] = signal.sosfilt(sos, resp, axis=1)[:, lead::OVERSAMPLE][:, :samples]
    drawn["peak_volts"] = [round(float(np.abs(records[:, 0]).max() * HAMMER_V_PER_N), 3),
                           round(float(np.abs(records[:, 1]).max() * case.accel_v), 3)]
    steps = (LSB_V / HAMMER_V_PER_N, LSB_V / case.accel_v)
    for row, step in enumerate(steps):
        records[:, row, :] = np.clip(np.round(records[:, row, :] / step), -2**23, 2**23 - 1) * step
    return list(records), starts, drawn


def public(drawn: dict) -> dict:
    return {k: v for k, v in drawn.items() if not k.startswith("_")}


def integrate(deriv, y0: np.ndarray, t: np.ndarray, forcing, stride: int = 4):
    """Classical RK4 with a step of ``stride`` analog samples, the state (displacement, velocity) brought back onto
    the analog grid by cubic Hermite interpolation (its derivative known at every step): (q, v) on ``t``.
    ``deriv(tj, y, f)`` gets the forcing's value at tj; ``forcing(times)`` returns (hits, len(times))."""
    from scipy.interpolate import CubicHermiteSpline
    tc = t[::stride]
    if tc[-1] < t[-1]:
        tc = np.append(tc, t[-1])
    dt = np.diff(tc)
    f_c = forcing(tc)
    f_h = forcing(tc[:-1] + dt / 2)
    y = y0.copy()
    ys = np.empty((2, y0.shape[1], tc.size))
    dys = np.empty_like(ys)
    for j in range(tc.size):
        k1 = deriv(tc[j], y, f_c[:, j])
        ys[:, :, j], dys[:, :, j] = y, k1
        if j == tc.size - 1:
            break
        d = dt[j]
        k2 = deriv(tc[j] + d / 2, y + d / 2 * k1, f_h[:, j])
        k3 = deriv(tc[j] + d / 2, y + d / 2 * k2, f_h[:, j])
        k4 = deriv(tc[j] + d, y + d * k3, f_c[:, j + 1])
        y = y + d / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    q = CubicHermiteSpline(tc, ys[0], dys[0], axis=-1)(t)
    v = CubicHermiteSpline(tc, ys[1], dys[1], axis=-1)(t)
    return q, v


def forcing_of(drawn: dict):
    """The contact force of every hit at any times (hits, len(times))."""
    return lambda times: half_sine(np.asarray(times), drawn["_t0"], drawn["_widths"], drawn["_peaks"])


# ------------------------------------------------------------------------------------------------ case physics

PLATE = {"modes": [{"freq_hz": 610.0, "damping_ratio": 0.006, "modal_constant_1_per_kg": -3.0e-3},
                   {"freq_hz": 880.0, "damping_ratio": 0.008, "modal_constant_1_per_kg": 2.0e-3}]}


def plate_modes(case, s, drawn, on):
    """The mover's 20 mm top plate: its first two elastic modes (a twisting one at 610 Hz and a bending one at
    880 Hz), hit at the plate's centre and read by an accelerometer near a corner: the twisting mode's shape has
    opposite signs at the hit and at the sensor (negative modal constant), the bending one the same sign."""
    h = sd_accelerance(s)
    for i, mode in enumerate(PLATE["modes"]):
        if f"mode{i + 1}" in on:
            h = h + mode_beside(s, mode["modal_constant_1_per_kg"], mode["freq_hz"], mode["damping_ratio"])
    return {"h": h[None, :]}


SEISMIC = {"sensitivity_v_per_m_s2": 1.02, "sensor_mass_kg": 0.74, "housing_kg": 0.54, "seismic_element_kg": 0.20,
           "resonance_hz": 750.0, "damping_ratio": 0.03}


def seismic_sensor(case, s, drawn, on):
    """A 10 V/g seismic accelerometer (0.74 kg with its mounting block) screwed onto the mover; the told 25.05 kg
    does not include it. Its seismic element (0.2 kg on the crystal stack, 750 Hz, zeta 0.03) rides on the mover
    and the output is the element's deflection: the reading is a * w^2/(s^2 + 2 zeta w s + w^2)."""
    z = K + C * s
    m = MASS
    if "mass" in on:
        m += SEISMIC["housing_kg"]
    if "element" in on:  # the element riding on its crystal stack
        z = z + extra_mode_z(s, SEISMIC["seismic_element_kg"], SEISMIC["resonance_hz"], SEISMIC["damping_ratio"])
    elif "mass" in on:  # the element as a rigid part of the sensor's mass
        m += SEISMIC["seismic_element_kg"]
    out = {"h": accelerance(s, z, m)[None, :]}
    if "resonance" in on:
        out["resp_tf"] = second_order(s, SEISMIC["resonance_hz"], SEISMIC["damping_ratio"])[None, :]
    return out


EXTENDER = {"resonance_hz": 1450.0, "damping_ratio": 0.04, "tip_and_extender_g": 14.0, "head_g": 160.0}


def tip_extender(case, s, drawn, on):
    """A 150 mm Delrin extender with a nylon tip (14 g) in front of the hammer's quartz gauge (head 160 g), used to
    reach the mover through its guard: the gauge reads the contact force through the extender's compliance,
    F_gauge = F (w^2 + 2 zeta w s)/(s^2 + 2 zeta w s + w^2) (calibrated with the extender on: 1 at low frequency)."""
    out = {"h": sd_accelerance(s)[None, :]}
    if "extender" in on:
        out["force_tf"] = second_order(s, EXTENDER["resonance_hz"], EXTENDER["damping_ratio"], zero=True)[None, :]
    return out


STUD = {"first_hz": 8000.0, "last_hz": 1500.0, "zeta_first": 0.03, "zeta_last": 0.05}


def stud_frequencies(hits: int):
    i = np.arange(hits)
    f = STUD["first_hz"] * (STUD["last_hz"] / STUD["first_hz"]) ** (i / (hits - 1))
    z = STUD["zeta_first"] + (STUD["zeta_last"] - STUD["zeta_first"]) * i / (hits - 1)
    return f, z


def stud_backing_off(case, s, drawn, on):
    """The accelerometer's stud, mounted without thread-locker, backs off under the blows: the mount's resonance
    falls from 8 kHz (tight) to 1.5 kHz (loose) geometrically with the hit number, its damping rises: the reading
    is a * (w^2 + 2 zeta w s)/(s^2 + 2 zeta w s + w^2) with w and zeta per hit."""
    out = {"h": sd_accelerance(s)[None, :]}
    if "mount" in on:
        f, z = stud_frequencies(case.hits)
        if "loosening" not in on:  # the same mount in every hit (the middle of the session's)
            f, z = np.full_like(f, np.sqrt(f[0] * f[-1])), np.full_like(z, z.mean())
        drawn["mount_resonance_hz"] = np.round(f, 1).tolist()
        out["resp_tf"] = np.stack([second_order(s, fi, zi, zero=True) for fi, zi in zip(f, z)])
    return out


JOINT = {"freq_hz": 520.0, "zeta_small": 0.004, "phi_hit": 0.05, "phi_sensor": 0.05,
         "quadratic_damping_1_per_m": 3.0e4, "softening_1_per_m": 1.0e5}


def joint_microslip(case, rng, t, drawn, on):
    """The mover's top plate is bolted to the carriage; the joint's rocking mode (520 Hz) is seen beside the rigid
    body (phi_hit phi_sensor = +2.5e-3 1/kg). Microslip in the bolted interface (Iwan/Masing behaviour) dissipates
    in proportion to the cube of the amplitude and softens the joint: in modal form
    q'' + 2 zeta w q' + mu |q'| q' + w^2 (q - kappa |q| q) = phi_hit F, the sensor reading phi_sensor q''."""
    if "mode" not in on:
        return None
    w = w_of(JOINT["freq_hz"])
    zeta, mu, kappa = JOINT["zeta_small"], JOINT["quadratic_damping_1_per_m"], JOINT["softening_1_per_m"]
    if "microslip" not in on:
        mu = kappa = 0.0
    ph = JOINT["phi_hit"]

    def modal_acceleration(q, v, f):
        return ph * f - 2 * zeta * w * v - mu * np.abs(v) * v - w**2 * (q - kappa * np.abs(q) * q)

    def deriv(tj, y, f):
        return np.stack([y[1], modal_acceleration(y[0], y[1], f)])

    forcing = forcing_of(drawn)
    q, v = integrate(deriv, np.zeros((2, case.hits)), t, forcing)
    return JOINT["phi_sensor"] * modal_acceleration(q, v, forcing(t))


def joint_rigid(case, s, drawn, on):
    return {"h": sd_accelerance(s)[None, :]}


SEAL = {"k_relaxed_to_unrelaxed_n_per_m": 6.0e6, "tau_s": 6.0e-4, "beta": 0.4}


def wiper_seal_z(s):
    """A nitrile lip seal (dust wiper) round the mover's skirt, pressed on the base: a rubber near its glass
    transition, its relaxation of Cole-Davidson form: Z = dk [1 - (1 + s tau)^-beta] (0 at rest, dk at high
    frequency, an asymmetric spectrum of relaxation times)."""
    return SEAL["k_relaxed_to_unrelaxed_n_per_m"] * (1 - (1 + s * SEAL["tau_s"]) ** (-SEAL["beta"]))


def wiper_seal(case, s, drawn, on):
    z = case.film[0] + case.film[1] * s
    if "seal" in on:
        z = z + wiper_seal_z(s)
    return {"h": accelerance(s, z, MASS)[None, :]}


LAGS = {"film_k_n_per_m": 3.4e7, "film_c_ns_per_m": 4200.0,
        "pockets": {"k_n_per_m": 3.0e6, "tau_s": 2.0e-4}, "plenum": {"k_n_per_m": 1.0e6, "tau_s": 2.5e-3}}


def pocket_plenum(case, s, drawn, on):
    """Two pneumatic lags beside the film: the orifice pockets (small volume, tau 0.2 ms) and the distribution
    plenum behind the inlet restrictor (large volume, tau 2.5 ms): Z = k + c s + sum k_i/(1 + s tau_i)."""
    z = LAGS["film_k_n_per_m"] + LAGS["film_c_ns_per_m"] * s
    for name in ("pockets", "plenum"):
        if name in on:
            z = z + lag_z(s, LAGS[name]["k_n_per_m"], LAGS[name]["tau_s"])
        else:
            z = z + LAGS[name]["k_n_per_m"]  # the same static stiffness without its lag
    return {"h": accelerance(s, z, MASS)[None, :]}


STAND = {"from_hit": 9, "base_kg": 1.05, "arm_kg": 0.35, "arm_hz": 80.0, "arm_zeta": 0.02}


def indicator_stand(case, s, drawn, on):
    """Before hit 9 the technician set a magnetic-base dial-indicator stand on the mover: its base (1.05 kg) is held
    rigidly by the magnet, its articulated arm with the indicator (0.35 kg effective) rings on the arm's joints
    (80 Hz, zeta 0.02). Hits 1-8 see the plain rig, hits 9-16 the rig with the stand."""
    plain = sd_accelerance(s)
    z = K + C * s
    m = MASS
    if "mass" in on:
        m += STAND["base_kg"]
    if "arm" in on:
        z = z + extra_mode_z(s, STAND["arm_kg"], STAND["arm_hz"], STAND["arm_zeta"])
    loaded = accelerance(s, z, m)
    idx = np.arange(case.hits) + 1
    first = STAND["from_hit"] if "step" in on else 1  # without the step: the stand there from the start
    return {"h": np.where((idx >= first)[:, None], loaded[None, :], plain[None, :])}


BEAM = {"effective_mass_kg": 30.0, "freq_hz": 430.0, "damping_ratio": 0.02, "offset_mm": 120.0}


def beam_z(s):
    """The guide face's dynamic stiffness where the bearing sits: the gantry beam's first torsion mode seen 120 mm
    off the shear centre (effective mass J/e^2 = 30 kg; 430 Hz with the film removed; zeta 0.02)."""
    w = w_of(BEAM["freq_hz"])
    mb = BEAM["effective_mass_kg"]
    return mb * s**2 + 2 * BEAM["damping_ratio"] * mb * w * s + mb * w**2


def gantry_beam(case, s, drawn, on):
    zf = K + C * s
    if "support" in on:
        zb = beam_z(s)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.nan_to_num(zf * zb / (zf + zb))
    else:
        z = zf
    return {"h": accelerance(s, z, MASS)[None, :]}


def gantry_poles():
    w = w_of(BEAM["freq_hz"])
    mb = BEAM["effective_mass_kg"]
    zb = np.array([mb, 2 * BEAM["damping_ratio"] * mb * w, mb * w**2])
    zf = np.array([C, K])
    ms2 = np.array([MASS, 0, 0])
    return poles_of(np.polyadd(np.polymul(ms2, np.polyadd(zf, zb)), np.polymul(zf, zb)))


ISOLATOR = {"mass_kg": 0.5, "cold_hz": 310.0, "warm_hz": 262.0, "zeta_cold": 0.05, "zeta_warm": 0.07,
            "time_constant_s": 150.0}


def isolator_state(times):
    x = 1 - np.exp(-np.asarray(times) / ISOLATOR["time_constant_s"])
    f = ISOLATOR["cold_hz"] + (ISOLATOR["warm_hz"] - ISOLATOR["cold_hz"]) * x
    z = ISOLATOR["zeta_cold"] + (ISOLATOR["zeta_warm"] - ISOLATOR["zeta_cold"]) * x
    return f, z


def warming_isolator(case, s, drawn, on):
    """A pneumatic valve terminal (0.5 kg) on rubber grommets bolted to the mover; its coils were switched on at the
    start of the session and warm the grommets: the rubber softens (-2 %/K) and its mode falls from 310 Hz to 262 Hz
    with a 150 s time constant (its damping 0.05 -> 0.07)."""
    times = drawn["_session_times"]
    f, z = isolator_state(times)
    if "drift" not in on:
        f, z = np.full_like(f, f.mean()), np.full_like(z, z.mean())
    drawn["isolator_hz"] = np.round(f, 2).tolist()
    zf = K + C * s
    if "mode" not in on:
        return {"h": accelerance(s, zf, MASS)[None, :]}
    return {"h": np.stack([accelerance(s, zf + extra_mode_z(s, ISOLATOR["mass_kg"], fi, zi), MASS)
                           for fi, zi in zip(f, z)])}


SHAKER = {"armature_kg": 0.35, "suspension_n_per_m": 3.0e4, "stinger_n_per_m": 6.0e6, "bl_n_per_a": 18.0,
          "r_ohm": 1.2, "l_h": 8.0e-4, "stinger_c_ns_per_m": 5.0}


def shaker_z(s):
    """A modal shaker left attached through its stinger (steel rod, 6e6 N/m axially) with its amplifier on (voltage
    mode): the armature (0.35 kg, suspension 3e4 N/m) is damped by its back-EMF through the coil, Bl^2 s/(R + s L).
    Z = (k_st + c_st s) Z_arm/(k_st + c_st s + Z_arm), Z_arm = m_a s^2 + k_sus + Bl^2 s/(R + s L)."""
    sh = SHAKER
    z_arm = sh["armature_kg"] * s**2 + sh["suspension_n_per_m"] + sh["bl_n_per_a"] ** 2 * s / (sh["r_ohm"] + s * sh["l_h"])
    z_st = sh["stinger_n_per_m"] + sh["stinger_c_ns_per_m"] * s
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.nan_to_num(z_st * z_arm / (z_st + z_arm))


def shaker_attached(case, s, drawn, on):
    z = K + C * s
    if "shaker" in on:
        z = z + shaker_z(s)
    return {"h": accelerance(s, z, MASS)[None, :]}


def shaker_poles():
    sh = SHAKER
    r, l, bl2 = sh["r_ohm"], sh["l_h"], sh["bl_n_per_a"] ** 2
    n_arm = np.polyadd(np.polymul([sh["armature_kg"], 0, sh["suspension_n_per_m"]], [l, r]), [bl2, 0])
    d_arm = np.array([l, r])
    z_st = np.array([sh["stinger_c_ns_per_m"], sh["stinger_n_per_m"]])
    mover = np.array([MASS, C, K])
    # M s^2 + Zf + z_st N/(z_st D + N) = 0  ->  (M s^2 + Zf)(z_st D + N) + z_st N = 0
    den = np.polyadd(np.polymul(z_st, d_arm), n_arm)
    return poles_of(np.polyadd(np.polymul(mover, den), np.polymul(z_st, n_arm)))


CLOG = {"film_k_start": 3.4e7, "film_k_end": 3.28e7, "lag_k_n_per_m": 4.0e6, "tau_start_s": 3.5e-4,
        "tau_end_s": 7.0e-4, "film_c_ns_per_m": 3.5e3}


def clogging(case, s, drawn, on):
    """Oil mist from the compressor (no coalescing filter) clogs the orifices during the session: their conductance
    falls, so the pockets' pneumatic lag slows (tau 0.35 -> 0.70 ms, linearly with time) and the static stiffness
    falls (k 3.40e7 -> 3.28e7 N/m): Z_i = k_i + c s + k_p/(1 + s tau_i)."""
    x = drawn["_session_times"] / drawn["_session_times"][-1]
    if "clogging" not in on:
        x = np.full_like(x, 0.5)
    k = CLOG["film_k_start"] + (CLOG["film_k_end"] - CLOG["film_k_start"]) * x
    tau = CLOG["tau_start_s"] + (CLOG["tau_end_s"] - CLOG["tau_start_s"]) * x
    drawn["pocket_tau_ms"] = np.round(tau * 1e3, 4).tolist()
    drawn["film_k_n_per_m"] = np.round(k, -2).tolist()
    if "lag" not in on:
        return {"h": np.stack([accelerance(s, ki + CLOG["lag_k_n_per_m"] + CLOG["film_c_ns_per_m"] * s, MASS)
                               for ki in k])}
    return {"h": np.stack([accelerance(s, ki + CLOG["film_c_ns_per_m"] * s + lag_z(s, CLOG["lag_k_n_per_m"], ti), MASS)
                           for ki, ti in zip(k, tau)])}


PULSE = {"freq_hz": 24.6, "stiffness_depth": 0.025, "damping_depth": 0.010, "force_amplitude_n": 2.5}


def pulsating_supply(case, rng, t, drawn, on):
    """A single-cylinder compressor (1476 rpm) feeds the bearings through a small receiver: the supply pressure
    pulsates at 24.6 Hz, +-2.5 % of the film's stiffness and +-1 % of its damping follow it within every hit, and the
    pulsating load capacity pushes the mover (+-2.5 N, a steady line). Integrated in time from the hit:
    M x'' + c(t) x' + k(t) x = F(t); the steady line added in closed form. Returns the response minus the LTI
    response (the frequency-domain part of the synthesis is the plain film)."""
    w = w_of(PULSE["freq_hz"])
    phase = rng.uniform(0, 2 * np.pi, case.hits)
    drawn["pulsation_phase_rad"] = np.round(phase, 4).tolist()
    out = np.zeros((case.hits, t.size))
    if "modulation" in on:
        eps_k, eps_c = PULSE["stiffness_depth"], PULSE["damping_depth"]
        forcing = forcing_of(drawn)

        def film_acceleration(tt, x, v, f, depth_k, depth_c):
            cs = np.cos(w * tt + phase[:, None]) if np.ndim(x) == 2 else np.cos(w * tt + phase)
            return (f - C * (1 + depth_c * cs) * v - K * (1 + depth_k * cs) * x) / MASS

        for depth_k, depth_c, sign in ((eps_k, eps_c, 1.0), (0.0, 0.0, -1.0)):
            def deriv(tj, y, f, dk=depth_k, dc=depth_c):
                return np.stack([y[1], film_acceleration(tj, y[0], y[1], f, dk, dc)])
            x, v = integrate(deriv, np.zeros((2, case.hits)), t, forcing)
            out += sign * film_acceleration(t[None, :], x, v, forcing(t), depth_k, depth_c)
    if "line" in on:
        h_line = sd_accelerance(np.array([1j * w]))[0]
        out += np.real(PULSE["force_amplitude_n"] * h_line * np.exp(1j * (w * t[None, :] + phase[:, None] + 0.7)))
    return out


def pulsating_rigid(case, s, drawn, on):
    return {"h": sd_accelerance(s)[None, :]}


CHARGE = {"charge_pc_per_m_s2": 1.0, "sensor_nf": 1.1, "cable_nf": 0.3, "input_kohm": 305.0}
CHARGE["typed_mv_per_m_s2"] = CHARGE["charge_pc_per_m_s2"] / CHARGE["sensor_nf"]  # the data sheet's open-circuit value
CHARGE["corner_hz"] = 1 / (2 * np.pi * CHARGE["input_kohm"] * 1e3 * (CHARGE["sensor_nf"] + CHARGE["cable_nf"]) * 1e-9)
CHARGE["gain"] = (CHARGE["charge_pc_per_m_s2"] / (CHARGE["sensor_nf"] + CHARGE["cable_nf"])) / CHARGE["typed_mv_per_m_s2"]


def charge_on_voltage(case, s, drawn, on):
    """A charge-output accelerometer (1 pC/(m/s^2), 1.1 nF) plugged straight into the module with IEPE off (no
    charge amplifier): its charge divides over the sensor's and the cable's capacitance (1.4 nF) and leaks through
    the 305 kOhm input: the module reads q/C_total * s/(s + 1/(R C_total)); the technician typed the data sheet's
    open-circuit voltage sensitivity q/C_sensor = 0.909 mV/(m/s^2), which ignores the cable:
    reading = a * C_sensor/C_total * s/(s + w_c) = 0.786 a s/(s + w_c), f_c = 373 Hz."""
    out = {"h": sd_accelerance(s)[None, :]}
    if "input" in on:
        wc = w_of(CHARGE["corner_hz"])
        out["resp_tf"] = (CHARGE["gain"] * s / (s + wc))[None, :]
    return out


CLAMP = {"mode": {"mass_kg": 0.28, "freq_hz": 360.0, "damping_ratio": 0.04},
         "memory": {"k_m_n_per_m": 8.0e6, "alpha": 0.55, "corner_hz": 300.0}, "film": (3.8e7, 3.0e3)}
CLAMP["memory"]["eta"] = CLAMP["memory"]["k_m_n_per_m"] / w_of(CLAMP["memory"]["corner_hz"]) ** CLAMP["memory"]["alpha"]


def clamp_and_graphite(case, s, drawn, on):
    """The sensor cables' strain-relief clamp with its connector block (0.28 kg) on a cable-tie mount (360 Hz,
    zeta 0.04), and porous graphite pads whose gas exchange with the porous layer gives the film a fractional memory
    (k_m 8e6 N/m, alpha 0.55, corner 300 Hz): the catalogue's extra-mode and film-memory forms together."""
    k, c = CLAMP["film"]
    z = k + c * s
    if "mode" in on:
        z = z + extra_mode_z(s, CLAMP["mode"]["mass_kg"], CLAMP["mode"]["freq_hz"], CLAMP["mode"]["damping_ratio"])
    if "memory" in on:
        m = CLAMP["memory"]
        z = z + memory_z(s, m["k_m_n_per_m"], m["eta"], m["alpha"])
    return {"h": accelerance(s, z, MASS)[None, :]}


THREE = {"delay_s": 3.125e-5, "added_mass_kg": 0.6, "k_change_over_session": -0.04, "c_change_over_session": 0.03}


def three_at_once(case, s, drawn, on):
    """Three unrelated things in one session: the accelerometer on a second module whose filter delay the merge
    did not remove (the response 31.25 us late), a 0.6 kg clamp left on the mover (the told mass is without it), and
    the supply air warming up (film k -4 %, c +3 %, linearly over the session)."""
    x = drawn["_session_times"] / drawn["_session_times"][-1]
    m = MASS + (THREE["added_mass_kg"] if "mass" in on else 0.0)
    if "drift" not in on:
        x = np.zeros_like(x)
    k = K * (1 + THREE["k_change_over_session"] * x)
    c = C * (1 + THREE["c_change_over_session"] * x)
    h = np.stack([accelerance(s, ki + ci * s, m) for ki, ci in zip(k, c)])
    out = {"h": h}
    if "delay" in on:
        out["resp_tf"] = np.exp(-s * THREE["delay_s"])[None, :]
    return out


WALK = {"freq_hz": 640.0, "damping_ratio": 0.006, "first_constant_1_per_kg": -2.5e-3,
        "last_constant_1_per_kg": 2.5e-3, "walk_mm": 15.0}


def walking_constants(hits: int) -> np.ndarray:
    return np.linspace(WALK["first_constant_1_per_kg"], WALK["last_constant_1_per_kg"], hits)


def walking_sensor(case, s, drawn, on):
    """The accelerometer sits on a magnet base that walks 15 mm across the top plate under the blows, over the
    twisting mode's nodal line: the plate's 640 Hz mode (zeta 0.006) is seen with a modal constant going linearly from
    -2.5e-3 1/kg (hit 1) to +2.5e-3 1/kg (hit 16); the rigid body and the film do not change."""
    h = sd_accelerance(s)
    if "mode" not in on:
        return {"h": h[None, :]}
    r = walking_constants(case.hits)
    if "walk" not in on:
        r = np.full_like(r, -2.5e-3)  # the sensor where it was put
    drawn["modal_constant_per_hit_1_per_kg"] = np.round(r, 6).tolist()
    shape = mode_beside(s, 1.0, WALK["freq_hz"], WALK["damping_ratio"])
    return {"h": h[None, :] + r[:, None] * shape[None, :]}


def control_film(k, c):
    def model(case, s, drawn, on):
        return {"h": sd_accelerance(s, k, c)[None, :]}
    return model


# ------------------------------------------------------------------------------------------------- the kinds

def kind(id_, short, place, features, mechanism, keywords, names, *, truth=None, required=True, alternatives=None,
         note=""):
    """One effect of a key: where a correct reading may put it, the numbers it must show, its mechanism."""
    return {"id": id_, "kind": short, "place": list(place), "features": features, "mechanism": mechanism,
            "mechanism_keywords": keywords, "names": names, "required": required,
            "alternatives": alternatives or [], "truth": truth or {}, "note": note}


def mass_alternatives(mass_kg: float, gain: float, tol_abs: float) -> list:
    """A mass the told one lacks reads exactly as a sensitivity error of the response (docs: always listed
    together): the alternative reading, on the chain, with the equivalent gain."""
    return [{"place": ANY_CHAIN_PLACE, "features": [{"gain": round(gain, 5), "tol_abs": tol_abs}],
             "names": ["sensitivity-error", G_CHAIN], "note": f"equivalent to {mass_kg} kg on the mover"}]


BESIDE_OR_ON = [BESIDE_PL, FILM_PL, MOVER_PL]  # an attached oscillator changes K* and is a mode beside alike
ON_MOVER_NAMES = ["extra-mode", G_BESIDE, G_FILM, G_MOVER]


def cases() -> list[Case]:
    everything = list(EVERYTHING)
    control_quality = ["mains", "clip", "double"]
    listed = [
        # ---------------------------------------------------------------------------------------- controls
        Case("control-7k314-rate", "control",
             "the module at 51.2 kS/s / 7 = 7 314.29 S/s (a rate no earlier round used), 1.5 s records, 15 ms "
             "pre-trigger, 20 hits; linear film",
             "NI 9234 data sheet (f_s = 51.2 kS/s / n, n = 1…31); Brandt, Noise and Vibration Analysis (2011) §13.7",
             "A legal, odd sample rate: nothing to claim.", seed=1001, rate_hz=51200.0 / 7, record_s=1.5,
             pretrigger_s=0.015, hits=20, must_not=everything, must_not_quality=control_quality,
             right_means="consistent or parameters-only with no finding; no physics"),
        Case("control-soft-film", "control",
             "a soft bearing: the 25.05 kg mover on k 6.0e6 N/m, c 1.3e3 N·s/m (78.3 Hz, ζ 0.053); 16 hits; linear",
             "Powell, Design of Aerostatic Bearings (1970) ch. 3 (low supply pressure, large gap: a soft film); "
             "Ewins, Modal Testing (2000) §2",
             "The plain rig, resonance at 78 Hz instead of 197 Hz: read off the FRF, nothing to claim.", seed=1002,
             film=(6.0e6, 1.3e3), model=control_film(6.0e6, 1.3e3), physics={"film_k_n_per_m": 6.0e6,
                                                                             "film_c_ns_per_m": 1.3e3},
             must_not=everything, must_not_quality=control_quality,
             right_means="consistent or parameters-only with no finding; no physics"),
        Case("control-lightly-damped", "control",
             "a lightly damped film: k 3.8e7 N/m, c 480 N·s/m (ζ 0.0078, Q 64), 2 s records (the ringing decays to "
             "e⁻¹⁹), 16 hits; linear",
             "Ewins (2000) §4.3 (lightly damped modes, record length); Brandt (2011) §13.7",
             "The plain rig with little damping and records long enough: nothing to claim.", seed=1003,
             film=(3.8e7, 480.0), model=control_film(3.8e7, 480.0), record_s=2.0,
             physics={"film_k_n_per_m": 3.8e7, "film_c_ns_per_m": 480.0}, must_not=everything,
             must_not_quality=control_quality, right_means="consistent or parameters-only with no finding"),
        Case("control-slow-session", "control",
             "16 hits spread over ≈ 45 min (2–3.5 min between hits, as in a campaign's spot checks); linear film "
             "that does not change",
             "ISO 7626-5 (impact excitation, averaging); Brandt (2011) §13.7",
             "Long pauses between hits are legal; a trend or step claimed over them is false.", seed=1004,
             gap_s=(120.0, 210.0), must_not=everything, must_not_quality=control_quality,
             right_means="consistent or parameters-only with no finding; no drift or step"),
        Case("control-wide-force-range", "control",
             "24 hits whose peaks span 25–500 N (log-uniform, a factor 20); linear film",
             "ISO 7626-5 §7 (linearity check by varying the excitation level); Ewins (2000) §3.11",
             "A linear rig hit at very different levels: no amplitude term, no change between hits.", seed=1005,
             hits=24, force_range=(25.0, 500.0), must_not=everything, must_not_quality=control_quality,
             right_means="consistent or parameters-only with no finding; no amplitude physics"),
        # --------------------------------------------------------------------------------------------- rig
        Case("mover-plate-modes", "rig",
             "the mover's 20 mm top plate has two elastic modes in band, hit at the centre and read near a corner: a "
             "twisting mode at 610 Hz (ζ 0.006, modal constant −3.0e-3 1/kg: the sensor is across its nodal line) and "
             "a bending mode at 880 Hz (ζ 0.008, +2.0e-3 1/kg), beside the rigid body on the film",
             "Blevins, Formulas for Natural Frequency and Mode Shape (1979) ch. 11 (free plates); Ewins (2000) §2.8 "
             "(modal constants, point and transfer FRFs); Avitabile, Modal Testing (2017) ch. 3",
             "Two modes beside the mover, one with a negative modal constant (its anti-resonance lies above its "
             "resonance, which no mass riding on the mover gives). Two side modes with their signs are right; an "
             "extra mode is at best a partial description (it cannot have the negative sign).", seed=1011,
             model=plate_modes, physics=dict(PLATE),
             kinds=[kind("mode1", "elastic mode, negative (beside)", [BESIDE_PL],
                         [{"frequency_hz": 610.0, "tol_rel": 0.02}, {"damping_ratio": 0.006, "tol_rel": 0.5},
                          {"sign": -1}],
                         "an elastic (twisting) mode of the mover's plate, sensor across its nodal line",
                         ["elastic", "bending", "twist", "torsion", "plate", "flexible", "structural", "local mode",
                          "mode of the mover", "mover's own", "nodal"], [G_BESIDE],
                         truth=PLATE["modes"][0]),
                    kind("mode2", "elastic mode, positive (beside)", [BESIDE_PL],
                         [{"frequency_hz": 880.0, "tol_rel": 0.02}, {"damping_ratio": 0.008, "tol_rel": 0.5},
                          {"sign": 1}],
                         "an elastic (bending) mode of the mover's plate",
                         ["elastic", "bending", "twist", "torsion", "plate", "flexible", "structural", "local mode",
                          "mode of the mover", "mover's own"], [G_BESIDE, "extra-mode"],
                         truth=PLATE["modes"][1])],
             partial_ok=["extra-mode", "added-mass"],
             must_not=list(AMPLITUDE) + list(TIME) + list(MEMORY) + list(CHAIN) + ["window-damping", G_HITS],
             right_means="side modes at 610 Hz (negative) and 880 Hz (positive) beside the mover; or honest not "
                         "explained"),
        Case("joint-microslip-mode", "rig",
             "the mover's top plate is bolted to the carriage; the joint's rocking mode (520 Hz at small amplitude, "
             "ζ 0.004, modal constant +2.5e-3 1/kg) softens and gains damping with the hit level through microslip "
             "(Iwan/Masing): hits 50–400 N (log-uniform); per hit ≈ 518 Hz, ζ 0.007 at 67 N … 505 Hz, ζ 0.030 at "
             "350 N",
             "Segalman, 'A four-parameter Iwan model for lap-type joints', J. Appl. Mech. 72 (2005) 752; Brake (ed.), "
             "The Mechanics of Jointed Structures (2018) ch. 1–3; Ewins (2000) §4.8",
             "A mode beside the mover whose frequency and damping follow the hit level: not the film's amplitude "
             "laws (cubic, friction, quadratic damping act on the film's resonance). A side mode with a level "
             "dependence is right; an extra mode alone is partial; not explained is right.", seed=1012,
             force_range=(50.0, 400.0), model=joint_rigid, time_domain=joint_microslip, physics=dict(JOINT),
             kinds=[kind("mode", "joint mode (beside, level-dependent)", BESIDE_OR_ON,
                         [{"frequency_hz": 510.0, "tol_rel": 0.04}],
                         "a bolted joint's mode of the mover, softening and damped by microslip",
                         ["joint", "bolt", "microslip", "micro-slip", "slip", "iwan", "interface", "fastener",
                          "loose"], ON_MOVER_NAMES, truth={"freq_hz_small_amplitude": 520.0}),
                    kind("microslip", "level dependence of a mode", [HITS_PL], [],
                         "the mode's frequency and damping change with the hit level",
                         ["joint", "microslip", "micro-slip", "slip", "level", "amplitude", "iwan", "friction"],
                         [G_HITS],
                         truth={"quadratic_damping_1_per_m": 3.0e4, "softening_1_per_m": 1.0e5})],
             partial_ok=["extra-mode", "added-mass"] + list(AMPLITUDE),
             must_not=list(TIME) + list(MEMORY) + list(CHAIN) + ["window-damping", G_CHAIN],
             right_means="a side mode near 515 Hz whose damping/frequency follow the hit level; or honest not "
                         "explained"),
        Case("wiper-seal-relaxation", "rig",
             "a nitrile lip seal (dust wiper) round the mover's skirt pressed on the base: rubber near its glass "
             "transition, Cole–Davidson relaxation Z = Δk [1 − (1 + sτ)^−β], Δk 6e6 N/m, τ 0.6 ms, β 0.4, beside the "
             "film (k 3.8e7, c 3.0e3): +1 410 N·s/m at 50 Hz, +6.8e5 N/m and +1 120 N·s/m at 197 Hz, +3.0e6 N/m and "
             "+280 N·s/m at 1 kHz",
             "Davidson & Cole, J. Chem. Phys. 19 (1951) 1484; Havriliak & Negami, Polymer 8 (1967) 161; Ferry, "
             "Viscoelastic Properties of Polymers (1980) ch. 3; Müller & Nau, Fluid Sealing Technology (1998) ch. 3",
             "A film branch whose spectrum of relaxation times is asymmetric, which no catalogue term has exactly "
             "(film memory is a symmetric one). A film branch (generic) or a film memory that brings the recordings "
             "within the noise is right; chain, time, amplitude terms are wrong.", seed=1013,
             film=(3.8e7, 3.0e3), model=wiper_seal, physics=dict(SEAL),
             kinds=[kind("seal", "film relaxation (Cole–Davidson)", [FILM_PL],
                         [{"frequency_hz": 380.0, "tol_factor": 2.0}],
                         "a viscoelastic (rubber) seal or contact beside the film",
                         ["seal", "wiper", "elastomer", "rubber", "viscoelastic", "polymer"],
                         [G_FILM, "film-memory"],
                         note="frequency: the branch's characteristic frequency (1/2πτ = 265 Hz, loss peak 549 Hz)")],
             partial_ok=["pneumatic-lag", "squeeze-film", "film-memory"],
             must_not=list(AMPLITUDE) + list(TIME) + list(CHAIN) + ["added-mass", "window-damping", G_CHAIN, G_HITS],
             right_means="a film branch (or film memory) within the noise; or honest not explained"),
        Case("pocket-and-plenum-lags", "rig",
             "two pneumatic lags beside the film: the orifice pockets (3e6 N/m, τ 0.2 ms) and the distribution "
             "plenum behind the inlet restrictor (1e6 N/m, τ 2.5 ms); film k 3.4e7, c 4.2e3 (static total 3.8e7)",
             "Powell (1970) ch. 4 (pocket volume and pneumatic lag); Blondeel, Snoeys & Devrieze, 'Dynamic stability "
             "of externally pressurized gas bearings', J. Lubr. Technol. 102 (1980) 511; Slocum, Precision Machine "
             "Design (1992) §8.7",
             "Two of one catalogue form with time constants a decade apart: two pneumatic lags (or two film "
             "branches) are right; one lag or one memory is only partial.", seed=1014, model=pocket_plenum,
             physics=dict(LAGS),
             kinds=[kind("pockets", "pneumatic lag, fast (pockets)", [FILM_PL],
                         [{"time_constant_s": 2.0e-4, "tol_rel": 0.35}, {"stiffness_n_per_m": 3.0e6, "tol_rel": 0.5}],
                         "the orifice pockets' pneumatic lag",
                         ["pneumatic", "pocket", "recess", "orifice", "lag", "compressib"],
                         ["pneumatic-lag", G_FILM], truth=LAGS["pockets"]),
                    kind("plenum", "pneumatic lag, slow (plenum)", [FILM_PL],
                         [{"time_constant_s": 2.5e-3, "tol_rel": 0.35}, {"stiffness_n_per_m": 1.0e6, "tol_rel": 0.5}],
                         "the supply plenum's pneumatic lag behind the inlet restrictor",
                         ["pneumatic", "plenum", "supply", "restrictor", "lag", "compressib", "volume"],
                         ["pneumatic-lag", G_FILM], truth=LAGS["plenum"])],
             partial_ok=["pneumatic-lag", "film-memory", "squeeze-film", "extra-mode"],
             must_not=list(AMPLITUDE) + list(TIME) + list(CHAIN) + ["added-mass", "window-damping", G_CHAIN, G_HITS],
             right_means="two lags (τ ≈ 0.2 ms and 2.5 ms) on the film; or honest not explained"),
        Case("gantry-beam-torsion", "rig",
             "the guide is the top of a gantry cross-beam; the bearing sits 120 mm off the beam's shear centre, so "
             "the beam's first torsion mode (effective mass 30 kg there, 430 Hz alone, ζ 0.02) is in series with the "
             "film: Z = Z_f Z_b/(Z_f + Z_b): the film's resonance falls to ≈ 179 Hz and a second one appears",
             "Altintas (2012) ch. 3 (machine-tool structures, frame modes); Young & Budynas, Roark's Formulas (2002) "
             "ch. 10 (torsion of beams, shear centre); Ewins (2000) §2.3",
             "What the mover stands on has a mode in band, seen through the film: the film's dynamic stiffness "
             "becomes resonant (or, read as modes, a mode beside with its own constant). A description in the film "
             "or beside the mover at the second pole is right; chain, time, amplitude terms are wrong.", seed=1015,
             model=gantry_beam, physics=dict(BEAM),
             kinds=[kind("support", "support mode in series", [FILM_PL, BESIDE_PL],
                         [{"frequency_hz": None, "tol_rel": 0.02}, {"damping_ratio": None, "tol_rel": 0.5}],
                         "a mode of the support (the beam/base under the bearing) in series with the film",
                         ["base", "foundation", "support", "beam", "guide", "stands on", "ground", "frame",
                          "gantry", "series", "structure under"], [G_FILM, G_BESIDE, "extra-mode"])],
             partial_ok=["extra-mode", "added-mass", "film-memory", "pneumatic-lag", "squeeze-film"],
             must_not=list(AMPLITUDE) + list(TIME) + list(CHAIN) + ["window-damping", G_CHAIN, G_HITS],
             right_means="a resonant film branch or a side mode at the second system pole; or honest not explained"),
        Case("shaker-left-attached", "rig",
             "a modal shaker left attached through its stinger (6e6 N/m) with its amplifier on: the armature "
             "(0.35 kg, suspension 3e4 N/m) rings on the stinger at 685 Hz (ζ 0.012), damped by its back-EMF through the coil "
             "(Bl 18 N/A, R 1.2 Ω, L 0.8 mH): Bl² s/(R + sL): 270 N·s/m at low frequency, a spring 4e5 N/m at high",
             "Varoto & McConnell, 'Single point vs multi point acceleration transfer function measurements', and "
             "McConnell & Varoto, Vibration Testing (2008) ch. 8 (shaker–structure interaction); Lang, "
             "'Electrodynamic shaker fundamentals', Sound & Vibration 31 (1997)",
             "A mass coupled to the mover through a spring, damped electrically with a frequency-dependent damping: "
             "nearly the catalogue's extra mode. An extra mode or a side mode at the armature's pole is right.",
             seed=1016, model=shaker_attached, physics=dict(SHAKER),
             kinds=[kind("shaker", "attached armature (mode on the mover)", BESIDE_OR_ON,
                         [{"frequency_hz": None, "tol_rel": 0.03}, {"damping_ratio": None, "tol_rel": 0.5}],
                         "an attached exciter (shaker armature on its stinger)",
                         ["shaker", "exciter", "stinger", "armature", "push rod", "drive rod", "attached"],
                         ON_MOVER_NAMES)],
             partial_ok=["added-mass", "film-memory", "pneumatic-lag"],
             must_not=list(AMPLITUDE) + list(TIME) + list(CHAIN) + ["window-damping", G_CHAIN, G_HITS],
             right_means="an extra/side mode at the armature's pole (≈ 685 Hz); or honest not explained"),
        Case("cable-clamp-and-graphite", "several",
             "two catalogue forms at once: the sensor cables' strain-relief clamp and connector block (0.28 kg) on "
             "a cable-tie mount (360 Hz, ζ 0.04), and porous graphite pads that give the film a fractional memory "
             "(k_m 8e6 N/m, α 0.55, corner 300 Hz); film k 3.8e7, c 3.0e3",
             "Kwan & Corbett, 'Porous aerostatic bearings — an updated review', Wear 222 (1998) 69; the paper's "
             "fractional film model; Ewins (2000) §2.3",
             "An extra mode and a film memory, each a catalogue term: both together are right (the issue's own "
             "example of two effects at once).", seed=1017, film=CLAMP["film"], model=clamp_and_graphite,
             physics={"mode": CLAMP["mode"], "memory": CLAMP["memory"]},
             kinds=[kind("mode", "attached mass on a spring (catalogue)", BESIDE_OR_ON,
                         [{"frequency_hz": 360.0, "range": None}, {"damping_ratio": 0.04, "tol_rel": 0.5}],
                         "a part riding on the mover on its own spring (clamp, cable, connector)",
                         ["cable", "clamp", "connector", "attached", "part riding", "riding", "mass on a spring",
                          "absorber", "payload", "fixture", "bracket", "component"], ON_MOVER_NAMES,
                         truth=CLAMP["mode"]),
                    kind("memory", "fractional film memory (catalogue)", [FILM_PL],
                         [{"frequency_hz": 300.0, "tol_factor": 2.0}],
                         "a fractional (porous, viscoelastic) memory of the film",
                         ["porous", "graphite", "memory", "fractional", "viscoelastic", "relaxation", "spring-pot"],
                         ["film-memory", G_FILM], truth=CLAMP["memory"])],
             partial_ok=["extra-mode", "film-memory", "pneumatic-lag", "squeeze-film", "added-mass"],
             must_not=list(AMPLITUDE) + list(TIME) + list(CHAIN) + ["window-damping", G_CHAIN, G_HITS],
             right_means="extra-mode (360 Hz) and film-memory (corner ≈ 300 Hz); or honest not explained"),
        # ------------------------------------------------------------------------------------- measurement
        Case("tip-extender-resonance", "measurement",
             "a 150 mm Delrin extender with a nylon tip (14 g) in front of the hammer's gauge (head 160 g), used to "
             "reach the mover through its guard: the gauge reads the contact force × (ω² + 2ζωs)/(s² + 2ζωs + ω²), "
             "1450 Hz, ζ 0.04 (calibrated with it: 1 at low frequency); hard tip, 0.5 ms pulses: the FRF falls "
             "towards a notch at 1450 Hz (−14 % at 500 Hz, −52 % at 1 kHz)",
             "McConnell & Varoto, Vibration Testing (2008) ch. 6 (force transducer dynamics, mass in front of the "
             "gauge); PCB Piezotronics impact hammer manuals (extenders, tips); Brandt (2011) §13.7",
             "A resonance in front of the force gauge: a factor on the force channel (the FRF divided by it); a rig "
             "term (an extra mode's anti-resonance) would put the hammer's tip into the rig.", seed=1021,
             pulse_ms=0.5, model=tip_extender, physics=dict(EXTENDER),
             kinds=[kind("extender", "resonance in front of the force gauge", [FORCE_CH, CHAIN_PL],
                         [{"frequency_hz": 1450.0, "tol_rel": 0.03}, {"damping_ratio": 0.04, "tol_rel": 0.5}],
                         "a resonance of the hammer's tip/extender in front of its force gauge",
                         ["hammer", "tip", "extender", "impact cap", "force gauge", "force sensor", "load cell",
                          "force transducer"], [G_CHAIN])],
             partial_ok=["channel-delay", "sensitivity-error"],
             must_not=list(RIG) + ["ac-coupling", "cross-talk", "polarity", "window-damping", G_BESIDE, G_FILM,
                                   G_MOVER, G_HITS],
             right_means="a force-channel (or chain) factor with a resonance at 1450 Hz; or honest not explained"),
        Case("charge-sensor-on-voltage-input", "measurement",
             "a charge-output accelerometer (1 pC/(m/s²), 1.1 nF) plugged straight into the module with IEPE off (no "
             "charge amplifier): 3 m of cable (0.3 nF) and the 305 kΩ input make a first-order high-pass at 373 Hz, "
             "and the typed open-circuit sensitivity (0.909 mV/(m/s²), the sensor alone) ignores the cable: reading = "
             "0.786 a · s/(s + ω_c)",
             "Serridge & Licht, Piezoelectric Accelerometer and Vibration Preamplifier Handbook (Brüel & Kjær 1987) "
             "ch. 5 (voltage amplification: cable capacitance, low-frequency limit RC); NI 9234 data sheet (input "
             "impedance 305 kΩ); Brüel & Kjær 4371 data sheet",
             "One fault of the response channel with two faces (a high-pass far inside the band and a gain): a "
             "channel factor (first-order high-pass 373 Hz, gain 0.79) is right; the catalogue's AC coupling cannot "
             "reach 373 Hz. Any rig term is wrong.", seed=1022, model=charge_on_voltage,
             accel_v=CHARGE["typed_mv_per_m_s2"] * 1e-3, accel_noise=4.0e-4,
             physics={k: (round(v, 4) if isinstance(v, float) else v) for k, v in CHARGE.items()},
             kinds=[kind("input", "missing charge amplifier (high-pass + gain)", [RESP_CH, CHAIN_PL],
                         [{"frequency_hz": round(CHARGE["corner_hz"], 1), "tol_rel": 0.05},
                          {"gain": round(CHARGE["gain"], 4), "tol_abs": 0.02}],
                         "a charge sensor read by a voltage input (no charge amplifier): a high-pass and a gain",
                         ["charge", "capacitance", "input impedance", "input resistance", "high-pass", "highpass",
                          "ac coupling", "ac-coupling", "coupling", "amplifier", "cable"],
                         [G_CHAIN])
                    | {"features_may_split": True, "note": "the high-pass and the gain may be two terms"}],
             extra_exact=[["ac-coupling", "sensitivity-error"], ["ac-coupling", G_CHAIN], ["sensitivity-error", G_CHAIN]],
             partial_ok=["ac-coupling", "sensitivity-error", "channel-delay"],
             must_not=list(RIG) + ["cross-talk", "polarity", "window-damping", G_BESIDE, G_FILM, G_MOVER, G_HITS],
             right_means="a response-channel factor: high-pass 373 Hz with gain 0.79; or honest not explained"),
        Case("heavy-seismic-accelerometer", "several",
             "a 10 V/g seismic accelerometer (0.74 kg with its block, not in the told mass) on the mover: its "
             "seismic element (0.2 kg, 750 Hz, ζ 0.03) rides on the mover and the output is its deflection, a × ω²/"
             "(s² + 2ζωs + ω²); light hits (35 N ± 20 %) to stay in range",
             "Serridge & Licht (1987) ch. 2 and 4 (seismic accelerometers, mounted resonance, mass loading); Wilcoxon "
             "731A-class data sheets (10 V/g, resonance ≈ 750 Hz); McConnell & Varoto (2008) ch. 4",
             "Two effects of one object: a resonance of the response channel (the sensor's own) and a mass on the "
             "mover (its housing; the seismic element's reaction near 750 Hz is a small third part, not required). "
             "A response-channel resonance at 750 Hz with +0.74 kg (or the equivalent sensitivity) is right.",
             seed=1023, force_n=35.0, model=seismic_sensor, accel_v=SEISMIC["sensitivity_v_per_m_s2"],
             accel_noise=3e-6, physics=dict(SEISMIC),
             kinds=[kind("resonance", "sensor's own resonance (response channel)", [RESP_CH, CHAIN_PL],
                         [{"frequency_hz": 750.0, "tol_rel": 0.03}, {"damping_ratio": 0.03, "tol_rel": 0.5}],
                         "the accelerometer's own (seismic element or mounting) resonance",
                         ["accelerometer", "sensor", "transducer", "seismic", "mount", "pickup"], [G_CHAIN]),
                    kind("mass", "mass not in the told mass", [MOVER_PL, FILM_PL],
                         [{"mass_kg": 0.74, "tol_rel": 0.15}], "a mass the told mass lacks (the sensor's)",
                         MASS_KEYWORDS + ["sensor", "accelerometer"], ["added-mass", G_MOVER, G_FILM],
                         alternatives=mass_alternatives(0.74, MASS / (MASS + 0.74), 0.006)),
                    kind("element", "the seismic element's reaction (mode on the mover)", BESIDE_OR_ON,
                         [{"frequency_hz": 750.0, "tol_rel": 0.03}], "the seismic element riding on the mover",
                         ["seismic", "sensor", "accelerometer", "element"], ON_MOVER_NAMES, required=False)],
             partial_ok=["added-mass", "sensitivity-error", "channel-delay", "extra-mode"],
             must_not=list(AMPLITUDE) + list(TIME) + ["film-memory", "squeeze-film", "pneumatic-lag", "cross-talk",
                                                     "polarity", "window-damping", G_HITS],
             right_means="a response-channel resonance at 750 Hz and +0.74 kg on the mover (or the sensitivity "
                         "0.971); or honest not explained"),
        Case("three-at-once", "several",
             "three unrelated things: the response on a second module whose filter delay the merge left (response "
             "31.25 µs late), a 0.6 kg clamp left on the mover (told mass without it), and the supply air warming "
             "(film k −4 %, c +3 %, linearly over the ≈ 1.5 min session)",
             "NI 9232/9234 data sheets (input delays of the modules' filters); Avitabile (2017) ch. 5 (leave nothing "
             "on the test article); Slocum (1992) §8.7 (supply temperature and film stiffness)",
             "Three catalogue forms in three places: channel-delay, added-mass (or its sensitivity twin) and drift. "
             "All three are right; any two with an honest rest are honest.", seed=1024, gap_s=(3.0, 6.0),
             model=three_at_once, physics=dict(THREE),
             kinds=[kind("delay", "delay between the channels (catalogue)", ANY_CHAIN_PLACE,
                         [{"delay_s": THREE["delay_s"], "tol_rel": 0.2}],
                         "a delay between the channels (a module's filter, sampling skew)",
                         ["delay", "filter", "module", "skew", "align", "sampl", "time shift", "latency"],
                         ["channel-delay", G_CHAIN], truth={"delay_s": THREE["delay_s"], "channel": "response late"}),
                    kind("mass", "mass not in the told mass (catalogue)", [MOVER_PL, FILM_PL],
                         [{"mass_kg": 0.6, "tol_rel": 0.2}], "a mass the told mass lacks", MASS_KEYWORDS,
                         ["added-mass", G_MOVER, G_FILM], alternatives=mass_alternatives(0.6, MASS / (MASS + 0.6),
                                                                                         0.006)),
                    kind("drift", "film trend over the session (catalogue)", [HITS_PL, FILM_PL], [],
                         "the film changing steadily over the session (supply temperature)",
                         ["drift", "trend", "warm", "temperature", "thermal", "supply", "steady change",
                          "over the session"], ["drift", G_HITS])],
             partial_ok=["channel-delay", "added-mass", "sensitivity-error", "drift", "step-change"],
             must_not=list(AMPLITUDE) + ["film-memory", "squeeze-film", "pneumatic-lag", "cross-talk", "polarity",
                                         "ac-coupling", "window-damping"],
             right_means="channel-delay 31 µs, added-mass 0.6 kg (or sensitivity 0.977) and drift; or honest not "
                         "explained"),
        # ------------------------------------------------------------------------- varying over the session
        Case("stud-backing-off", "measurement",
             "the accelerometer's stud, mounted without thread-locker, backs off under the blows: the mount's "
             "resonance falls from 8 kHz at hit 1 to 1.5 kHz at hit 16 (geometrically), ζ 0.03 → 0.05; 0.6 ms "
             "pulses: the FRF at 1 kHz reads +1.6 % at the first hit, +79 % at the last",
             "ISO 5348:2021 (mechanical mounting of accelerometers: stud, torque, mounted resonance); Serridge & "
             "Licht (1987) §4.3; McConnell & Varoto (2008) ch. 4",
             "A response-channel resonance that moves over the session: a channel factor changing between hits is "
             "right; a rig term (film, mass, drift of the film) is wrong.", seed=1031, pulse_ms=0.6,
             model=stud_backing_off, physics=dict(STUD),
             kinds=[kind("mount", "mount resonance of the response channel", [RESP_CH, CHAIN_PL],
                         [{"frequency_hz": 2000.0, "range": [1400.0, 3000.0]}],
                         "the accelerometer's mounting resonance (a loosening stud)",
                         ["mount", "stud", "loose", "sensor", "accelerometer", "transducer", "attachment"],
                         [G_CHAIN], note="frequency: where the late hits' mount resonance lies (1.5–2.6 kHz for "
                                         "hits 12–16)"),
                    kind("loosening", "the channel changing over the session", [HITS_PL], [],
                         "the mount loosening hit by hit", ["loos", "mount", "stud", "sensor", "trend", "worsen"],
                         [G_HITS])],
             partial_ok=["channel-delay", "sensitivity-error", "drift", "step-change"],
             must_not=list(AMPLITUDE) + ["added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag",
                                         "cross-talk", "polarity", "ac-coupling", "window-damping", G_BESIDE, G_FILM,
                                         G_MOVER],
             right_means="a response-channel resonance (≈ 1.5–3 kHz late in the session) changing between hits; or "
                         "honest not explained"),
        Case("indicator-stand-set-down", "several",
             "before hit 9 the technician set a magnetic-base dial-indicator stand on the mover (25 s pause): its "
             "base (1.05 kg) held rigidly, its arm with the indicator (0.35 kg effective) ringing at 80 Hz (ζ 0.02); "
             "hits 1–8 see the plain rig, hits 9–16 the rig with the stand",
             "Avitabile (2017) ch. 5 (mass loading, 'nothing left on the test article'); Ewins (2000) §3.3; "
             "Mitutoyo/Noga magnetic stand data (arm masses, stiffness)",
             "A step between two groups of hits in the mover's mass and a new mode: a change at hit 9 with +1.05 kg "
             "and an 80 Hz mode on the mover is right; the catalogue's step change (film × (1 + f)) only partly.",
             seed=1032, gap_s=(2.0, 5.0), extra_gap={8: 25.0}, model=indicator_stand, physics=dict(STAND),
             kinds=[kind("mass", "mass added from hit 9", [MOVER_PL, FILM_PL, HITS_PL],
                         [{"mass_kg": 1.05, "tol_rel": 0.2}], "a mass set on the mover during the session",
                         MASS_KEYWORDS + ["stand", "set down", "placed", "added"],
                         ["added-mass", G_MOVER, G_FILM, G_HITS],
                         alternatives=mass_alternatives(1.05, MASS / (MASS + 1.05), 0.008)),
                    kind("arm", "mode on the mover from hit 9", BESIDE_OR_ON + [HITS_PL],
                         [{"frequency_hz": None, "range": None}], "a part riding on the mover on its own spring",
                         ["stand", "arm", "indicator", "attached", "riding", "part", "mass on a spring", "fixture"],
                         ON_MOVER_NAMES + [G_HITS], truth={k: STAND[k] for k in ("arm_kg", "arm_hz", "arm_zeta")}),
                    kind("step", "change at hit 9", [HITS_PL], [], "something set on the mover between hits 8 and 9",
                         ["step", "jump", "between hits", "two groups", "change", "set", "placed", "added"],
                         [G_HITS])],
             partial_ok=["added-mass", "extra-mode", "step-change", "sensitivity-error", "drift"],
             must_not=list(AMPLITUDE) + ["film-memory", "squeeze-film", "pneumatic-lag", "channel-delay",
                                         "cross-talk", "polarity", "ac-coupling", "window-damping"],
             right_means="from hit 9: +1.05 kg and an 80 Hz mode on the mover; or honest not explained naming the "
                         "two groups"),
        Case("warming-isolator-mode", "rig",
             "a pneumatic valve terminal (0.5 kg) on rubber grommets on the mover; its coils, switched on at the "
             "start, warm the rubber: the mode falls from 310 Hz to 262 Hz (time constant 150 s; ζ 0.05 → 0.07) "
             "over a ≈ 9 min session (hits 20–40 s apart)",
             "Harris' Shock and Vibration Handbook (6th ed. 2010) ch. 32 and 33 (elastomeric isolators, temperature); "
             "Nashif, Jones & Henderson, Vibration Damping (1985) ch. 3 (temperature dependence of elastomers)",
             "A mode riding on the mover whose frequency drifts over the session: an extra/side mode that changes "
             "between hits is right; the film's drift (a film scale) is wrong in form, a fixed extra mode partial.",
             seed=1033, gap_s=(20.0, 40.0), model=warming_isolator, physics=dict(ISOLATOR),
             kinds=[kind("mode", "mode riding on the mover (rubber-mounted part)", BESIDE_OR_ON,
                         [{"frequency_hz": 280.0, "range": None}],
                         "a part riding on the mover on rubber mounts",
                         ["rubber", "isolator", "grommet", "elastomer", "mount", "attached", "riding", "part",
                          "mass on a spring", "payload", "component"], ON_MOVER_NAMES,
                         truth={"mass_kg": 0.5}),
                    kind("drift", "the mode's frequency drifting over the session", [HITS_PL], [],
                         "the rubber warming (temperature)",
                         ["warm", "temperature", "thermal", "drift", "trend", "soften"], [G_HITS])],
             partial_ok=["extra-mode", "drift", "step-change", "added-mass"],
             must_not=list(AMPLITUDE) + ["film-memory", "squeeze-film", "pneumatic-lag"] + list(CHAIN)
             + ["window-damping", G_CHAIN],
             right_means="a mode on the mover falling 310 → 262 Hz over the session; or honest not explained"),
        Case("clogging-orifice", "rig",
             "oil mist (no coalescing filter) clogs the orifices during the session: the pockets' pneumatic lag "
             "slows (τ 0.35 → 0.70 ms) and the static stiffness falls (k 3.40e7 → 3.28e7 N/m, + the lag's 4e6), "
             "linearly with time over ≈ 9 min (hits 20–40 s apart)",
             "ISO 8573-1:2010 (compressed-air purity classes: oil); Powell (1970) ch. 3 (restrictor conductance and "
             "pocket time constant); Slocum (1992) §8.7",
             "The film's frequency dependence itself changes over the session: a lag whose time constant drifts. A "
             "film lag with a change between hits is right; a drift alone (a film scale) partial.", seed=1034,
             gap_s=(20.0, 40.0), model=clogging, physics=dict(CLOG),
             kinds=[kind("lag", "pneumatic lag of the pockets", [FILM_PL],
                         [{"time_constant_s": 5.0e-4, "range": [3.0e-4, 8.0e-4]},
                          {"stiffness_n_per_m": 4.0e6, "tol_rel": 0.5}],
                         "the pockets' pneumatic lag", ["pneumatic", "pocket", "recess", "orifice", "lag",
                                                        "compressib", "restrict"],
                         ["pneumatic-lag", G_FILM]),
                    kind("clogging", "the lag slowing over the session", [HITS_PL], [],
                         "the orifices clogging (restrictor conductance falling)",
                         ["clog", "orifice", "restrict", "contamina", "oil", "drift", "trend", "supply"],
                         [G_HITS])],
             partial_ok=["pneumatic-lag", "drift", "step-change", "film-memory", "squeeze-film"],
             must_not=list(AMPLITUDE) + ["added-mass", "extra-mode"] + list(CHAIN) + ["window-damping", G_CHAIN],
             right_means="a film lag (τ ≈ 0.35–0.7 ms) changing between hits; or honest not explained"),
        Case("pulsating-supply", "rig",
             "a single-cylinder compressor (1476 rpm) feeds the bearings through a small receiver: the supply "
             "pulsates at 24.6 Hz; within every hit the film's stiffness follows ±2.5 % (damping ±1 %), and the "
             "pulsating load pushes the mover (±2.5 N: a steady 24.6 Hz line)",
             "API 618 (pulsation of reciprocating compressors); Nayfeh & Mook, Nonlinear Oscillations (1979) ch. 5 "
             "(parametric excitation); Powell (1970) ch. 3 (film stiffness against supply pressure)",
             "A film modulated within each hit (a linear time-periodic system: sidebands ±24.6 Hz about the "
             "response), different in every hit by the pulsation's phase: no time-invariant term describes it. A "
             "description between hits (per-hit film) is the nearest; not explained is right. The line is a note.",
             seed=1035, model=pulsating_rigid, time_domain=pulsating_supply, physics=dict(PULSE),
             kinds=[kind("modulation", "film modulated within each hit (parametric)", [HITS_PL, FILM_PL],
                         [{"frequency_hz": 24.6, "tol_rel": 0.05}],
                         "the supply pressure pulsating (compressor) and the film following it",
                         ["pulsat", "compressor", "supply", "modulat", "parametric", "periodic"],
                         [G_HITS]),
                    kind("line", "steady line at 24.6 Hz", [], [], "the pulsating load on the mover (a line)",
                         ["pulsat", "compressor", "vibration", "line"], [], required=False)],
             partial_ok=["drift", "step-change", "film-memory", "pneumatic-lag", G_FILM],
             must_not=["added-mass", "extra-mode", "squeeze-film"] + list(AMPLITUDE) + list(CHAIN)
             + ["window-damping", G_CHAIN],
             must_not_quality=["mains", "clip"],
             expected_quality=["a narrowband line at 24.6 Hz (floor-vibration kind), not mains"],
             right_means="not explained (a change between hits within the hits) or a per-hit film description; a "
                         "line note at 24.6 Hz"),
        Case("walking-magnet-sensor", "rig",
             "the accelerometer's magnet base walks 15 mm across the top plate under the blows, over the nodal line of "
             "the plate's twisting mode (640 Hz, ζ 0.006): the mode is seen with a modal constant going linearly from "
             "−2.5e-3 1/kg at hit 1 to +2.5e-3 1/kg at hit 16 (through 0 between hits 8 and 9); rigid body and film "
             "unchanged",
             "ISO 5348:2021 (magnet mounting); Avitabile (2017) ch. 3 (mode shapes, nodal lines, modal constants); "
             "Ewins (2000) §2.8",
             "A mode beside the mover whose modal constant changes sign over the session because the measuring point "
             "moves: a side mode at 640 Hz with a change between hits is right; an extra mode, a film or a chain term "
             "is not.", seed=1036, model=walking_sensor, physics=dict(WALK),
             kinds=[kind("mode", "elastic mode seen from a moving point (beside)", [BESIDE_PL],
                         [{"frequency_hz": 640.0, "tol_rel": 0.02}, {"damping_ratio": 0.006, "tol_rel": 0.5}],
                         "an elastic mode of the mover's plate, seen from a sensor that moved",
                         ["elastic", "bending", "twist", "torsion", "plate", "flexible", "structural", "local mode",
                          "mode of the mover", "mover's own", "nodal"], [G_BESIDE]),
                    kind("walk", "the sensor moving over the session", [HITS_PL], [],
                         "the accelerometer's position changing (a magnet base walking)",
                         ["sensor", "accelerometer", "moved", "walk", "position", "location", "magnet", "mount",
                          "nodal"], [G_HITS])],
             partial_ok=["extra-mode", "added-mass", "drift", "step-change"],
             must_not=list(AMPLITUDE) + list(MEMORY) + list(CHAIN) + ["window-damping", G_CHAIN],
             right_means="a side mode at 640 Hz whose modal constant changes (sign) between hits; or honest not "
                         "explained"),
    ]
    # keys with poles computed from the model
    by = {c.name: c for c in listed}
    gp = gantry_poles()
    second = max(gp, key=lambda p: p[0])
    by["gantry-beam-torsion"].kinds[0]["features"] = [{"frequency_hz": second[0], "tol_rel": 0.02},
                                                      {"damping_ratio": second[1], "tol_rel": 0.5}]
    by["gantry-beam-torsion"].physics["system_poles_hz_zeta"] = gp
    sp = shaker_poles()
    armature = min(sp, key=lambda p: abs(p[0] - 680.0))
    by["shaker-left-attached"].kinds[0]["features"] = [{"frequency_hz": armature[0], "tol_rel": 0.03},
                                                       {"damping_ratio": armature[1], "tol_rel": 0.5}]
    by["shaker-left-attached"].physics["system_poles_hz_zeta"] = sp
    # an oscillator riding on the mover: from its own frequency (what an extra-mode reports) to the system's pole
    # near it (what a side mode beside the accelerance reports), 2 % either side
    def span(m_e, f_e, zeta_e, mass=MASS, near=None):
        pole = min((p for p in attached_poles(m_e, f_e, zeta_e, mass)), key=lambda p: abs(p[0] - (near or f_e)))
        lo, hi = sorted((f_e, pole[0]))
        return [round(0.98 * lo, 1), round(1.02 * hi, 1)], pole
    clamp = by["cable-clamp-and-graphite"]
    clamp.kinds[0]["features"][0]["range"], pole = span(CLAMP["mode"]["mass_kg"], CLAMP["mode"]["freq_hz"],
                                                        CLAMP["mode"]["damping_ratio"])
    clamp.physics["system_pole_without_memory_hz_zeta"] = pole
    f = np.linspace(340.0, 420.0, 8001)
    h = np.abs(clamp_and_graphite(clamp, 2j * np.pi * f, {}, {"mode", "memory"})["h"][0])
    peak = float(f[np.argmax(h)])
    clamp.physics["accelerance_peak_with_memory_hz"] = peak
    clamp.kinds[0]["features"][0]["range"][1] = round(1.02 * max(pole[0], peak), 1)
    stand = by["indicator-stand-set-down"]
    rng_, pole = span(STAND["arm_kg"], STAND["arm_hz"], STAND["arm_zeta"], MASS + STAND["base_kg"])
    stand.kinds[1]["features"] = [{"frequency_hz": STAND["arm_hz"], "range": rng_}]
    stand.physics["system_pole_arm_hz_zeta"] = pole
    iso = by["warming-isolator-mode"]
    (lo, _), cold = span(ISOLATOR["mass_kg"], ISOLATOR["cold_hz"], ISOLATOR["zeta_cold"])
    (lo2, _), warm = span(ISOLATOR["mass_kg"], ISOLATOR["warm_hz"], ISOLATOR["zeta_warm"])
    iso.kinds[0]["features"][0]["range"] = [round(0.98 * ISOLATOR["warm_hz"], 1), round(1.02 * max(cold[0], 310.0), 1)]
    iso.physics["system_poles_cold_warm_hz_zeta"] = [cold, warm]
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


def exact_sets(kinds: list) -> list[list[str]]:
    """Every set of effect names that describes the case: one name per required effect (its own names or its
    alternatives'), any name or none for an optional one."""
    choices = []
    for k in kinds:
        names = list(dict.fromkeys(k["names"] + [n for a in k["alternatives"] for n in a.get("names", [])]))
        if not names:
            continue
        choices.append(names if k["required"] else names + [None])
    sets = {tuple(sorted({n for n in combo if n})) for combo in itertools.product(*choices)} if choices else {()}
    return [list(s) for s in sorted(sets)]


def answer_key(case: Case) -> dict:
    exact = exact_sets(case.kinds) if case.kinds else [[]]
    exact += [sorted(x) for x in case.extra_exact if sorted(x) not in exact]
    allowed = sorted(set().union(*map(set, exact)))
    truth = {"mass_kg": case.mass, "film_k_n_per_m": case.film[0], "film_c_ns_per_m": case.film[1],
             "sample_rate_hz": case.rate_hz, "record_s": case.record_s, "hits": case.hits,
             "pretrigger_s": case.pretrigger_s, "pulse_ms": case.pulse_ms,
             "force_n": list(case.force_range) if case.force_range else case.force_n,
             "force_spread": None if case.force_range else case.spread} | case.physics
    must_not = sorted(set(case.must_not) - set(allowed))
    return {
        "case": case.name, "uff": f"{case.name}.uff", "category": case.category, "summary": case.summary,
        "source": case.source, "reasoning": case.reasoning, "right_means": case.right_means, "cli": "mass",
        "cli_arguments": ["--mass", f"{case.mass_told:g}"], "truth": truth,
        "control": case.category == "control", "subtle": False,
        "kinds": case.kinds,
        "must_not": must_not + [f"quality:{q}" for q in sorted(case.must_not_quality)],
        # round 3's fields (its classifier decides *right*)
        "exact": exact, "acceptable": [], "allowed": allowed, "partial_ok": sorted(set(case.partial_ok) - set(must_not)),
        "must_not_claim": must_not, "must_not_quality": sorted(case.must_not_quality),
        "needs_alternative": case.needs_alternative, "empty_needs_recalibrated": {},
        "honest_not_explained_ok": case.category != "control", "refusal_ok": case.refusal_ok,
        "expected_quality": case.expected_quality,
    }


def write_uff(path: Path, records: list, starts: np.ndarray, case: Case) -> None:
    sets = []
    dt = 1.0 / case.rate_hz
    for hit, record in enumerate(records):
        start = float(starts[hit])
        for row, dtype, unit in ((0, 13, "N"), (1, 12, "m/s^2")):
            values = np.asarray(record[row], dtype=float)
            sets.append(pyuff.prepare_58(
                binary=1, id1=f"{case.name} hit {hit + 1}", id2="redteam10 generator", id3="", id4="", id5="",
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
    parser.add_argument("--out", type=Path, default=Path("out/redteam10"))
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
        print(f"{case.name:32s} {case.category:11s} {time.perf_counter() - began:5.1f} s  peak V force/resp "
              f"{drawn['peak_volts'][0]:.2f}/{drawn['peak_volts'][1]:.2f}, acausal {drawn['acausal_fraction']:.1e}")
    if not args.keys_only:
        print(f"total {time.perf_counter() - began_all:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
