"""The rig behind the NI 9234: a TOML rig spec and its physics.

A rig spec (``docs/rig-spec.md``) describes the mover (mass), the gas film (a model of :mod:`gasfilm.analysis.models` with
its parameters), the sensors, optional hammer defaults and a list of **effects** that make a real rig differ from
the ideal mass-on-a-film: an extra mode, cubic hardening, a channel delay, added mass, drift, mains interference.
The simulated module plays a spec; the mismatch diagnosis reads one and writes an improved one.

Physics (SI units throughout). With ``s = σ + j2πf`` and ``M = m + Σ added mass``, the mover obeys
``(Z_film(s)·drift(t) + Σ Z_effect(s) + M s²)·X(s) = F(s)`` plus, with ``cubic-stiffness``, the force ``k3·x³``.
The linear accelerance the channels see is ``s² / (Z_film·drift + Σ Z_effect + M s²) · T_a(s) / T_f(s)`` where
``T_a``, ``T_f`` are the per-channel transfers (``channel-delay`` gives ``exp(-sτ)`` on the delayed channel).

Adding an effect type is one small class registered with :func:`register_effect`; it overrides the hooks of
:class:`Effect` it needs (added mass, film scale, added dynamic stiffness, channel transfer, cubic stiffness,
interference).
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.fft
from scipy.sparse.linalg import LinearOperator, bicgstab

from gasfilm.analysis.physics.elements import laplace_variable
from gasfilm.drivers.errors import GasfilmError

from gasfilm.analysis.physics.effects import DECAY_TOLERANCE, MAX_RESPONSE_DURATION_S
from gasfilm.analysis.physics.spec import RigSpec
# --- physics -------------------------------------------------------------------------------------------------------


def rig_dynamic_stiffness(
    spec: RigSpec, s: np.ndarray, time_s: float = 0.0, *, film_scale: float | None = None
) -> np.ndarray:
    """Linear dynamic stiffness of the mover on its film, ``Z_film·drift + Σ Z_effect + M s²`` (N/m).

    The film's scale is the spec's at ``time_s`` unless ``film_scale`` gives it.
    """
    s = np.asarray(s, dtype=complex)
    scale = spec.film_scale(time_s) if film_scale is None else film_scale
    total = spec.film.stiffness(s, spec.film_parameters) * scale + spec.moving_mass_kg * s**2
    for effect in spec.effects:
        total = total + effect.added_stiffness(s)
    return total


def channel_transfer(spec: RigSpec, channel: str, s: np.ndarray) -> np.ndarray:
    """Product of the effects' transfers on one channel ("force" or "acceleration")."""
    s = np.asarray(s, dtype=complex)
    transfer = np.ones_like(s)
    for effect in spec.effects:
        transfer = transfer * effect.channel_transfer(channel, s)
    return transfer


def rig_accelerance(
    spec: RigSpec, freq_hz: np.ndarray, decay_rate_1_s: float = 0.0, time_s: float = 0.0
) -> np.ndarray:
    """Linear accelerance (m/s²)/N the channels of ``spec`` show at ``s = σ + j2πf`` (cubic stiffness left out)."""
    s = laplace_variable(freq_hz, decay_rate_1_s)
    accelerance = s**2 / rig_dynamic_stiffness(spec, s, time_s)
    return accelerance * channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s)


def _grid_laplace(n_samples: int, sample_rate_hz: float) -> np.ndarray:
    """``s = j2πf`` on the rfft grid of ``n_samples``; the DC bin is nudged off zero so every film is finite."""
    freq_hz = scipy.fft.rfftfreq(n_samples, 1.0 / sample_rate_hz)
    freq_hz[0] = 1e-9 * sample_rate_hz / n_samples
    return 2j * np.pi * freq_hz


def response_duration_s(spec: RigSpec, sample_rate_hz: float, time_s: float = 0.0) -> float:
    """Time after which the rig's impulse response stays below ``DECAY_TOLERANCE`` of its peak (capped).

    Cached per spec, sample rate and film scale (to 0.1 %), so replaying many records costs one evaluation.
    """
    return _cached_response_duration_s(spec.to_toml(), float(sample_rate_hz), round(spec.film_scale(time_s), 3))


@functools.lru_cache(maxsize=64)
def _cached_response_duration_s(spec_toml: str, sample_rate_hz: float, film_scale: float) -> float:
    spec = RigSpec.from_toml(spec_toml)
    n_samples = scipy.fft.next_fast_len(int(MAX_RESPONSE_DURATION_S * sample_rate_hz), real=True)
    s = _grid_laplace(n_samples, sample_rate_hz)
    # a smooth band limit (raised cosine 0.2–0.4·fs) keeps the truncation at Nyquist from ringing on for ever
    ramp = np.clip((s.imag / (2 * np.pi * sample_rate_hz) - 0.2) / 0.2, 0.0, 1.0)
    accelerance = 0.5 * (1.0 + np.cos(np.pi * ramp)) * s**2 / rig_dynamic_stiffness(spec, s, film_scale=film_scale)
    impulse = np.abs(scipy.fft.irfft(accelerance, n_samples))
    causal = impulse[: n_samples // 2]  # the second half holds the band limit's (zero-phase) ringing before t = 0
    envelope_from_end = np.maximum.accumulate(causal[::-1])[::-1]
    decayed = np.flatnonzero(envelope_from_end < DECAY_TOLERANCE * impulse.max())
    if not decayed.size:
        return MAX_RESPONSE_DURATION_S
    return min(MAX_RESPONSE_DURATION_S, 1.25 * decayed[0] / sample_rate_hz + 0.01)


def mover_displacement_spectrum(
    spec: RigSpec, force_spectrum: np.ndarray, s: np.ndarray, n_samples: int, time_s: float = 0.0
) -> np.ndarray:
    """The mover's displacement spectrum (rfft grid of ``n_samples``) for a force spectrum on the same grid.

    Linear films: ``X = F / Z_total``. With cubic stiffness, the periodic problem ``x + R*(k3·x³) = R*f``
    (``R = 1/Z_total``, ``*`` a circular convolution done by FFT) is solved by damped Newton steps with BiCGSTAB on
    matrix-free Jacobian products ``J v = v + R*(3·k3·x²·v)``, continued from the linear response in steps of k3
    when the full hardening is too strong to reach at once. The grid must be long enough for the response to decay.
    """
    receptance = 1.0 / rig_dynamic_stiffness(spec, s, time_s)
    linear = force_spectrum * receptance
    k3 = spec.cubic_stiffness_n_per_m3
    if k3 == 0.0:
        return linear
    x_linear = scipy.fft.irfft(linear, n_samples)
    scale = float(np.max(np.abs(x_linear))) or 1.0

    def apply_receptance(signal: np.ndarray) -> np.ndarray:
        return scipy.fft.irfft(receptance * scipy.fft.rfft(signal), n_samples)

    def residual_norm(displacement: np.ndarray, k3_now: float) -> tuple[np.ndarray, float]:
        residual = displacement - x_linear + apply_receptance(k3_now * displacement**3)
        return residual, float(np.max(np.abs(residual))) / scale

    def newton(k3_now: float, displacement: np.ndarray) -> np.ndarray | None:
        residual, norm = residual_norm(displacement, k3_now)
        for _ in range(12):  # a good continuation step converges fast; a slow one is better halved
            if norm <= 1e-12:
                return displacement
            local_stiffness = 3.0 * k3_now * displacement**2
            jacobian = LinearOperator(
                (n_samples, n_samples), matvec=lambda v: v + apply_receptance(local_stiffness * v), dtype=float
            )
            with np.errstate(all="ignore"):
                step, _ = bicgstab(jacobian, -residual / scale, rtol=min(0.1, norm), atol=0.0, maxiter=200)
            if not np.all(np.isfinite(step)):
                return None
            damping = 1.0
            while damping >= 1 / 64:
                trial = displacement + damping * scale * step
                trial_residual, trial_norm = residual_norm(trial, k3_now)
                if trial_norm < norm:
                    break
                damping /= 2
            else:
                return None
            displacement, residual, norm = trial, trial_residual, trial_norm
        return None

    solved, fraction, increment = x_linear, 0.0, 1.0
    while fraction < 1.0:
        target = min(1.0, fraction + increment)
        result = newton(target * k3, solved)
        if result is None:
            increment /= 2
            if increment < 1 / 256:
                raise GasfilmError(
                    f"{spec.source}: cubic-stiffness k3 = {k3:.3g} N/m³ is too strong for this force; the nonlinear "
                    f"response does not converge"
                )
            continue
        solved, fraction, increment = result, target, 2 * increment
    return scipy.fft.rfft(solved)


def simulate_response(
    spec: RigSpec, force_n: np.ndarray, sample_rate_hz: float, time_s: float = 0.0
) -> np.ndarray:
    """Acceleration (m/s²) the rig's accelerometer channel records for a sampled force record (last axis = time).

    The force is the *recorded* force (band-limited, as measured); channel delays are applied relative to it.
    Linear specs: exact, by a zero-padded FFT long enough for the response to decay (no wrap-around).
    Cubic stiffness: the nonlinear equation of motion solved on a ×2 band-limited-interpolated grid
    (:func:`mover_displacement_spectrum`), the acceleration returned band-limited to the sample rate.
    """
    force = np.asarray(force_n, dtype=float)
    n_record = force.shape[-1]
    pad = int(np.ceil(response_duration_s(spec, sample_rate_hz, time_s) * sample_rate_hz))
    n_fft = scipy.fft.next_fast_len(n_record + pad)
    force_spectrum = scipy.fft.rfft(force, n_fft)
    s = _grid_laplace(n_fft, sample_rate_hz)
    delays = channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s)
    if spec.is_linear:
        response = force_spectrum * (s**2 / rig_dynamic_stiffness(spec, s, time_s)) * delays
        return scipy.fft.irfft(response, n_fft)[..., :n_record]
    oversampling = 2
    n_fine = oversampling * n_fft
    s_fine = _grid_laplace(n_fine, oversampling * sample_rate_hz)
    records = force_spectrum.reshape(-1, force_spectrum.shape[-1])
    out = np.empty((records.shape[0], n_record))
    for row, spectrum in enumerate(records):
        fine_force = np.zeros(s_fine.size, dtype=complex)
        fine_force[: spectrum.size] = spectrum * oversampling
        fine_force[spectrum.size - 1] *= 0.5 if n_fft % 2 == 0 else 1.0
        displacement = mover_displacement_spectrum(spec, fine_force, s_fine, n_fine, time_s)
        acceleration = (s_fine**2 * displacement)[: spectrum.size] / oversampling * delays
        out[row] = scipy.fft.irfft(acceleration, n_fft)[:n_record]
    return out.reshape(force.shape)
