"""A measured structure read off its FRF the way experimental modal analysis does it, for a start when the FRF is
not a mover on a film (below its first resonance a mass line, not a rise as ω²).

Poles: the least-squares complex-frequency estimator (LSCF) of sdypy-EMA, keeping the poles that are stable between
its two highest model orders, their damping less the exponential window's decay rate. Modal constants: real
(proportional damping, as the rig spec's ``structure-mode`` has them) with a constant residual term, by linear least
squares on the FRF (least-squares frequency-domain constants, LSFD), the poles then refined with the constants solved
at every step (variable projection). The constant term is the mass line 1/M; its sign is the response polarity.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from gasfilm.analysis.physics.effects import MAX_MODAL_CONSTANT_PER_KG, MIN_DAMPING_RATIO, StructureMode

logger = logging.getLogger(__name__)

#: Model order of the LSCF estimator (poles per order: half of it in the band at most).
LSCF_ORDER = 60
#: A pole is stable when the next lower order has one within these relative frequency and damping distances.
STABLE_FREQUENCY = 0.005
STABLE_DAMPING = 0.1
#: Damping ratio of a pole placed at a peak of |H1| that LSCF did not return.
PEAK_DAMPING_RATIO = 2e-3
#: The refined poles' frequencies stay within this fraction of their start; the refinement takes about this many
#: Jacobians.
POLE_FREEDOM = 0.03
#: At most this many lines in the fit of the constants and poles (every n-th readable line).
MAX_FIT_LINES = 900
REFINE_STEPS = 6


@dataclass(frozen=True)
class Structure:
    """Modes, the mass line's mass (kg) and the response polarity (+1 or −1) read off an FRF."""

    modes: list[StructureMode]
    mass_kg: float
    polarity: float


def read_structure(freq_hz: np.ndarray, h1: np.ndarray, decay_rate_1_s: float, lines: np.ndarray,
                   resonances_hz: list[float]) -> Structure:
    """The structure of an accelerance ``h1`` measured through an exponential window of ``decay_rate_1_s`` (1/s), read
    on the readable ``lines`` (indices of ``freq_hz``, ascending); ``resonances_hz`` (the peaks of |H1|) that no
    stable pole accounts for become poles of their own (damping ratio :data:`PEAK_DAMPING_RATIO`)."""
    from sdypy import EMA  # imported here: only a structure read off an FRF needs it

    low_hz, high_hz = float(freq_hz[lines[0]]), float(freq_hz[lines[-1]])
    upto = int(lines[-1]) + 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        model = EMA.Model(frf=h1[None, :upto], freq=freq_hz[:upto], lower=low_hz, upper=high_hz,
                          pol_order_high=LSCF_ORDER, frf_form="accelerance")
        model.get_poles(method="lscf", show_progress=False)
    poles = _stable_poles(model.all_poles[-1], model.all_poles[-2], low_hz, high_hz)
    lines = lines[:: int(np.ceil(lines.size / MAX_FIT_LINES))]  # the fit's lines: enough to hold every pole
    s = decay_rate_1_s + 2j * np.pi * freq_hz[lines]
    measured = h1[lines]
    weight = 1.0 / np.abs(measured)  # relative misfit: the mass line counts as much as the peaks
    start_hz = np.abs(poles) / (2 * np.pi)
    start_zeta = np.maximum((-poles.real - decay_rate_1_s) / np.abs(poles), 2 * MIN_DAMPING_RATIO)
    missed = [f for f in resonances_hz if not np.any(np.abs(start_hz - f) < STABLE_FREQUENCY * 2 * f)]
    start_hz = np.concatenate((start_hz, missed))
    start_zeta = np.concatenate((start_zeta, np.full(len(missed), PEAK_DAMPING_RATIO)))

    def basis(vector: np.ndarray) -> np.ndarray:
        count = vector.size // 2
        omega = 2 * np.pi * np.exp(vector[:count])
        zeta = np.exp(vector[count:])
        modes = s[:, None] ** 2 / (s[:, None] ** 2 + 2 * zeta * omega * s[:, None] + omega**2)
        return np.column_stack((np.ones_like(s), modes, modes * s[:, None] / omega))

    def constants(columns: np.ndarray) -> np.ndarray:
        weighted = columns * weight[:, None]
        stacked = np.vstack((weighted.real, weighted.imag))
        normal = stacked.T @ stacked
        normal[np.diag_indices_from(normal)] *= 1.0 + 1e-12
        target = measured * weight
        return np.linalg.solve(normal, stacked.T @ np.concatenate((target.real, target.imag)))

    vector = np.log(np.concatenate((start_hz, start_zeta)))
    count = vector.size // 2
    lower = np.concatenate((vector[:count] + np.log(1 - POLE_FREEDOM), np.full(count, np.log(MIN_DAMPING_RATIO))))
    upper = np.concatenate((vector[:count] + np.log(1 + POLE_FREEDOM), np.full(count, np.log(0.2))))

    def residual(trial: np.ndarray) -> np.ndarray:
        columns = basis(np.clip(trial, lower, upper))
        misfit = (columns @ constants(columns) - measured) * weight
        return np.concatenate((misfit.real, misfit.imag))

    # the poles refined with the constants solved at every step (variable projection), a few steps: the diagnosis's
    # recalibration finishes them against the measured noise
    refined = np.clip(scipy.optimize.least_squares(residual, np.clip(vector, lower, upper), method="lm",
                                                   max_nfev=REFINE_STEPS * (vector.size + 1)).x, lower, upper)
    if np.sum(residual(refined) ** 2) < np.sum(residual(vector) ** 2):
        vector = refined
    values = constants(basis(vector))
    count = vector.size // 2
    polarity = -1.0 if values[0] < 0 else 1.0
    limit = MAX_MODAL_CONSTANT_PER_KG
    modes = [StructureMode(freq_hz=float(np.exp(vector[i])), damping_ratio=float(np.exp(vector[count + i])),
                           modal_constant_per_kg=float(np.clip(polarity * values[1 + i], -limit, limit)),
                           quadrature_per_kg=float(np.clip(polarity * values[1 + count + i], -limit, limit)))
             for i in range(count) if values[1 + i] != 0]
    logger.info("structure read off the FRF: %d modes, mass line %.4g kg, polarity %+d", len(modes),
                1.0 / abs(values[0]), polarity)
    return Structure(modes, float(1.0 / max(abs(values[0]), 1e-12)), polarity)


def _stable_poles(last: np.ndarray, previous: np.ndarray, low_hz: float, high_hz: float) -> np.ndarray:
    """Poles of the highest order inside the band, decaying, with a pole of the next lower order close to them."""
    kept = []
    for pole in last:
        omega = abs(pole)
        zeta = -pole.real / omega if omega > 0 else -1.0
        if pole.imag <= 0 or zeta <= 0 or not low_hz < omega / (2 * np.pi) < high_hz:
            continue
        other = previous[np.argmin(np.abs(previous - pole))]
        if (abs(abs(other) - omega) < STABLE_FREQUENCY * omega
                and abs(-other.real / abs(other) - zeta) < STABLE_DAMPING * zeta):
            kept.append(pole)
    return np.array(sorted(kept, key=abs))
