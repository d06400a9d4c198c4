"""A measured structure read off its FRF the way experimental modal analysis reads it, for a start when the FRF is
not a mover on a film (below its first resonance a mass line, or a transfer FRF: modal constants of both signs).

Over the usable band (force within 20 dB, coherence ≥ 0.9):

- **poles** by the least-squares complex-frequency estimator (LSCF) of sdypy-EMA at every model order up to
  :data:`LSCF_ORDER`, each pole's damping less the exponential window's decay rate;
- a **stabilization diagram**: a pole is stable in frequency, in damping and in participation (its complex modal
  constant, from the constants fitted at that order) when the next lower order has one within
  :data:`STABLE_FREQUENCY`, :data:`STABLE_DAMPING` and :data:`STABLE_PARTICIPATION`; a mode is a cluster of poles
  stable in all three at :data:`MIN_STABLE_ORDERS` orders or more. Poles at an antiresonance of |H1| or on a line of
  low coherence are never modes; a peak of |H1| no stable pole accounts for becomes a pole of its own;
- **constants** by least squares in the frequency domain (LSFD) at ``s = σ + jω`` (the exponential window's FRF):
  a complex modal constant per mode, the lower residual (the mass line 1/M, whose sign is the response polarity) and
  the upper residual (the modes above the band, as one mode above it); the poles refined with the constants solved
  at every step (variable projection);
- the **polarity** and whether the FRF is a **driving point** (every modal constant of the mass line's sign);
- a mode far below the others whose constant is the mass line's (a rigid body on a soft support) is the
  **suspension**: the mover on its film in the rig spec.

sdypy-EMA's own LSFD and stabilization chart work at ``s = jω`` (and its chart through a GUI): the constants, the
stability classes and the refinement are computed here, on the window's ``s``.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from gasfilm.analysis.diagnosis.fitspace import at_range_bounds
from gasfilm.analysis.physics.effects import (MAX_MODAL_CONSTANT_PER_KG, MIN_DAMPING_RATIO, MODE_DAMPING_RANGE,
                                              StructureMode)
from gasfilm.analysis.quantities import is_number
from gasfilm.analysis.threads import one_blas_thread

logger = logging.getLogger(__name__)

#: Highest LSCF polynomial order over two (sdypy's ``pol_order_high``): poles at model orders 2, 4, … 2·LSCF_ORDER.
LSCF_ORDER = 60
#: Stability of a pole against the nearest pole of the next lower order: relative frequency distance, damping
#: distance (relative, at least :data:`STABLE_DAMPING_FLOOR` absolute) and change of its complex modal constant.
STABLE_FREQUENCY = 0.005
STABLE_DAMPING = 0.2
STABLE_DAMPING_FLOOR = 2e-4
STABLE_PARTICIPATION = 0.2
#: A mode: poles stable in frequency, damping and participation at this many model orders, within
#: :data:`CLUSTER_WIDTH` of each other in frequency (at least :data:`CLUSTER_LINES` lines).
MIN_STABLE_ORDERS = 8
CLUSTER_WIDTH = 0.002
CLUSTER_LINES = 2
#: A pole where |H1| is below this fraction of its median over a few bandwidths around it sits at an antiresonance.
ANTIRESONANCE_DEPTH = 0.7
#: Coherence below which a line is not read (as :data:`gasfilm.analysis.spectra.READ_MIN_COHERENCE`).
MIN_COHERENCE = 0.9
#: Damping ratio of a pole placed at a peak of |H1| that no stable pole accounts for.
PEAK_DAMPING_RATIO = 2e-3
#: The refined poles' frequencies stay within this fraction of their start, their damping ratios below
#: :data:`MAX_DAMPING_RATIO`; the refinement takes at most this many Jacobians.
POLE_FREEDOM = 0.03
MAX_DAMPING_RATIO = 0.2
REFINE_STEPS = 10
#: Lines of the refinement away from the poles (every n-th readable line), and the half-width of the band kept whole
#: around each pole, in its bandwidths (at least :data:`POLE_LINES` lines).
MAX_FIT_LINES = 900
POLE_BANDWIDTHS = 6.0
POLE_LINES = 4
#: The fit's weights are 1/√(|H|² + floor²), the floor this fraction of the band's median |H|: relative at the peaks,
#: absolute at the antiresonances (where a relative weight would fit the noise).
WEIGHT_FLOOR = 0.05
#: H1's random error (from the coherence) is taken at least this fraction of |H1| and of the band's median |H1|.
RELATIVE_FLOOR = 1e-4
ABSOLUTE_FLOOR = 1e-5
#: The upper residual is a mode above the band: it starts at this multiple of the band's top, damping ratio
#: :data:`UPPER_DAMPING`, and stays between :data:`UPPER_RANGE` times the top.
UPPER_START = 1.2
UPPER_DAMPING = 0.1
UPPER_RANGE = (1.02, 1.5)
#: A lowest mode this far below the next, with a constant of the mass line's sign at least this share of the whole
#: high-frequency level, is a rigid body on a soft support: the suspension.
SUSPENSION_RATIO = 0.3
SUSPENSION_SHARE = 0.3
#: A driving point's constants all have the mass line's sign; constants whose peak contributes less than this share
#: of |H1| at their own frequency are not counted.
SIGN_SHARE = 0.1

#: Poles added where the refined description leaves a misfit this many times its median, away from its poles (at
#: most RESIDUAL_POLES): weak modes LSCF left unstable.
RESIDUAL_POLES = 8
RESIDUAL_PEAK = 30.0
#: A mode is kept when the description's misfit without it grows by more than this many times ln(points) times its
#: misfit per point (four parameters at a BIC's price).
MODE_COST = 4.0
#: Residual poles are sought above this fraction of the lowest mode read.
RESIDUAL_FROM = 0.5

#: The stability classes of a pole in the diagram, in order.
STABILITY = ("new", "frequency", "frequency and damping", "frequency, damping and participation")


@dataclass(frozen=True)
class StabilizationDiagram:
    """Every pole LSCF returned in the band, per model order, with its stability against the next lower order
    (:data:`STABILITY` index) — what a modal engineer reads the modes off — and the FRF it was read from."""

    order: np.ndarray  # (P,) model order
    freq_hz: np.ndarray  # (P,)
    damping_ratio: np.ndarray  # (P,) less the window's decay
    stability: np.ndarray  # (P,) index into STABILITY
    frf_freq_hz: np.ndarray  # the readable lines
    frf_magnitude: np.ndarray  # |H1| there, (m/s²)/N

    def counts(self) -> dict[str, int]:
        """Poles per stability class."""
        return {name: int(np.count_nonzero(self.stability == index)) for index, name in enumerate(STABILITY)}


@dataclass(frozen=True)
class RejectedPole:
    """A stable pole that is not a mode, and why (an antiresonance, a line of low coherence)."""

    freq_hz: float
    reason: str


@dataclass(frozen=True)
class Structure:
    """What the reading found: the modes in the band (by frequency), the mass line's mass (kg) and its sign (the
    response polarity, ±1), whether the FRF is a driving point, the suspension (Hz, damping ratio) when a soft support
    was read in the band, the upper residual (a mode above the band), the stable poles that are not modes, the
    stabilization diagram and the band read (Hz)."""

    modes: list[StructureMode]
    mass_kg: float
    polarity: float
    driving_point: bool
    suspension: tuple[float, float] | None
    upper_residual: StructureMode | None
    rejected: list[RejectedPole]
    diagram: StabilizationDiagram
    band_hz: tuple[float, float]
    stable_orders: list[int] = field(default_factory=list)  # orders each mode was stable at (0: a peak's pole)

    def to_dict(self) -> dict:
        """The reading for the JSON (``structure.read_off_frf``)."""
        return {
            "band_hz": [round(self.band_hz[0], 1), round(self.band_hz[1], 1)],
            "lscf_orders": int(self.diagram.order.max()) if self.diagram.order.size else 0,
            "poles": self.diagram.counts(),
            "mass_line_kg": self.mass_kg,
            "polarity": int(self.polarity),
            "driving_point": self.driving_point,
            "suspension_hz": None if self.suspension is None else round(self.suspension[0], 3),
            "upper_residual_hz": None if self.upper_residual is None else round(self.upper_residual.freq_hz, 1),
            "stable_orders": [int(n) for n in self.stable_orders],
            "rejected_poles": [{"freq_hz": round(p.freq_hz, 1), "reason": p.reason} for p in self.rejected],
            "modes_read": [{"freq_hz": m.freq_hz, "damping_ratio": m.damping_ratio} for m in self.modes],
            "stabilization": {"order": self.diagram.order.tolist(),
                              "freq_hz": [float(f"{f:.6g}") for f in self.diagram.freq_hz],
                              "damping_ratio": [float(f"{z:.3g}") for z in self.diagram.damping_ratio],
                              "stability": self.diagram.stability.tolist(), "classes": list(STABILITY)},
        }


def mode_rows(modes: list[StructureMode]) -> list[dict]:
    """The mode table, by frequency: frequency (Hz), damping ratio, modal constant (real and quadrature parts and its
    size, 1/kg)."""
    return [{"freq_hz": mode.freq_hz, "damping_ratio": mode.damping_ratio,
             "modal_constant_per_kg": mode.modal_constant_per_kg, "quadrature_per_kg": mode.quadrature_per_kg,
             "modal_constant_size_per_kg": float(np.hypot(mode.modal_constant_per_kg, mode.quadrature_per_kg))}
            for mode in sorted(modes, key=lambda mode: mode.freq_hz)]


#: What the mode table says of a mode whose damping ratio is the fitter's floor (:func:`at_damping_floor`).
AT_DAMPING_FLOOR = "damping ratio at the fitter's floor: not determined"
#: What it says of the mode that stands for the modes above the band.
UPPER_RESIDUAL = "above the band: upper residual"


def at_damping_floor(damping_ratio: float) -> bool:
    """Whether a mode's damping ratio is the fitter's floor (:data:`MIN_DAMPING_RATIO`, the bottom of
    :data:`MODE_DAMPING_RANGE`), judged as a fitted value at its bound is (:func:`at_range_bounds`): held there by the
    fit, not determined by the data."""
    return at_range_bounds(MODE_DAMPING_RANGE, damping_ratio)[0]


def mode_row_notes(row: dict) -> str:
    """What the mode table says of one row of :func:`mode_rows` (as stored in a diagnosis), beside its numbers: a
    damping ratio at the fitter's floor, the mode above the band; "" for neither."""
    damping = row.get("damping_ratio")
    floor = is_number(damping) and at_damping_floor(damping)
    return "; ".join(([AT_DAMPING_FLOOR] if floor else []) + ([UPPER_RESIDUAL] if row.get("above_band") else []))


@one_blas_thread
def read_structure(freq_hz: np.ndarray, h1: np.ndarray, coherence: np.ndarray, decay_rate_1_s: float,
                   lines: np.ndarray, resonances_hz: list[float], averages: int = 1) -> Structure:
    """The structure of an accelerance ``h1`` ((m/s²)/N at ``freq_hz``, with its ``coherence``) measured through an
    exponential window of ``decay_rate_1_s`` (1/s), read on the readable ``lines`` (indices, ascending), averaged over
    ``averages`` hits; ``resonances_hz`` (the peaks of |H1|) that no mode accounts for become poles of their own."""
    low_hz, high_hz = float(freq_hz[lines[0]]), float(freq_hz[lines[-1]])
    spacing_hz = float(freq_hz[1] - freq_hz[0])
    magnitude = np.abs(h1)
    orders, poles = _lscf_poles(freq_hz, h1, lines, decay_rate_1_s)
    fit_lines = _fit_lines(freq_hz, lines, [abs(p) / (2 * np.pi) for p in poles[-1]] + list(resonances_hz),
                           decay_rate_1_s)
    s = decay_rate_1_s + 2j * np.pi * freq_hz[fit_lines]
    measured = h1[fit_lines]
    weight = _weights(magnitude[fit_lines], coherence[fit_lines], averages, float(np.median(magnitude[lines])))
    diagram = _diagram(orders, poles, s, measured, weight, freq_hz[lines], magnitude[lines])

    start_hz, start_zeta, stable_orders, rejected = [], [], [], []
    for cluster_hz, cluster_zeta, count in _stable_clusters(diagram, spacing_hz):
        reason = _not_a_mode(cluster_hz, cluster_zeta, freq_hz, magnitude, coherence, decay_rate_1_s)
        if reason:
            rejected.append(RejectedPole(cluster_hz, reason))
            continue
        start_hz.append(cluster_hz)
        start_zeta.append(max(cluster_zeta, 2 * MIN_DAMPING_RATIO))
        stable_orders.append(count)
    for peak_hz in resonances_hz:
        if not any(abs(f - peak_hz) <= max(STABLE_FREQUENCY * peak_hz, CLUSTER_LINES * spacing_hz) for f in start_hz):
            start_hz.append(float(peak_hz))
            start_zeta.append(PEAK_DAMPING_RATIO)
            stable_orders.append(0)
    order = np.argsort(start_hz)
    start_hz = np.array(start_hz)[order]
    start_zeta = np.array(start_zeta)[order]
    stable_orders = [stable_orders[i] for i in order]

    fitted_hz, fitted_zeta, upper, _ = _refined(s, measured, weight, start_hz, start_zeta, high_hz)
    keep = _significant(s, measured, weight, fitted_hz, fitted_zeta, upper)[:-1]
    fitted_hz, fitted_zeta = fitted_hz[keep], fitted_zeta[keep]
    stable_orders = [count for count, kept in zip(stable_orders, keep) if kept]
    added = _residual_poles(s, measured, weight, fitted_hz, fitted_zeta, upper, spacing_hz,
                            RESIDUAL_FROM * float(fitted_hz.min()) if fitted_hz.size else low_hz)
    if added:
        start_hz = np.concatenate((fitted_hz, added))
        start_zeta = np.concatenate((fitted_zeta, np.full(len(added), PEAK_DAMPING_RATIO)))
        stable_orders = stable_orders + [0] * len(added)
        order = np.argsort(start_hz)
        start_hz, start_zeta = start_hz[order], start_zeta[order]
        stable_orders = [stable_orders[i] for i in order]
        fitted_hz, fitted_zeta, upper, _ = _refined(s, measured, weight, start_hz, start_zeta, high_hz)
        keep = _significant(s, measured, weight, fitted_hz, fitted_zeta, upper)[:-1]
        fitted_hz, fitted_zeta = fitted_hz[keep], fitted_zeta[keep]
        stable_orders = [count for count, kept in zip(stable_orders, keep) if kept]
    if not _significant(s, measured, weight, fitted_hz, fitted_zeta, upper)[-1]:
        upper = None
    values = _pole_constants(s, measured, weight, fitted_hz, fitted_zeta, upper)
    count = fitted_hz.size
    real, quadrature = values[1 : 1 + count].real, values[1 + count : 1 + 2 * count].real
    level = float(values[0].real)  # the mass line, with its sign
    suspension = None
    if count and (count == 1 or fitted_hz[0] < SUSPENSION_RATIO * fitted_hz[1]):
        total = level + real[0]  # a rigid body on a soft support: its mode is the mass line's own
        if real[0] * total > 0 and abs(real[0]) >= SUSPENSION_SHARE * abs(total):
            suspension = (float(fitted_hz[0]), float(fitted_zeta[0]))
            level = total
    polarity = -1.0 if level < 0 else 1.0
    limit = MAX_MODAL_CONSTANT_PER_KG
    first = 0 if suspension is None else 1
    modes = [StructureMode(freq_hz=float(fitted_hz[i]), damping_ratio=float(fitted_zeta[i]),
                           modal_constant_per_kg=float(np.clip(polarity * real[i], -limit, limit)),
                           quadrature_per_kg=float(np.clip(polarity * quadrature[i], -limit, limit)))
             for i in range(first, count) if real[i] != 0 or quadrature[i] != 0]
    stable_orders = [stable_orders[i] for i in range(first, count) if real[i] != 0 or quadrature[i] != 0]
    upper_mode = None
    if upper is not None and (values[-2].real != 0 or values[-1].real != 0):
        upper_mode = StructureMode(freq_hz=float(upper[0]), damping_ratio=float(upper[1]),
                                   modal_constant_per_kg=float(np.clip(polarity * values[-2].real, -limit, limit)),
                                   quadrature_per_kg=float(np.clip(polarity * values[-1].real, -limit, limit)))
    driving = _driving_point(modes, freq_hz, magnitude)
    mass_kg = float(1.0 / max(abs(level), 1e-12))
    logger.info("structure read off the FRF: %d modes, mass line %.4g kg, polarity %+d, %s", len(modes), mass_kg,
                polarity, "driving point" if driving else "transfer FRF")
    return Structure(modes, mass_kg, polarity, driving, suspension, upper_mode, rejected, diagram,
                     (low_hz, high_hz), stable_orders)


def _weights(magnitude: np.ndarray, coherence: np.ndarray, averages: int, median: float) -> np.ndarray:
    """Weights of the fits: one over H1's random error from the coherence, ``|H1|·√((1 − γ²)/(2·n·γ²))`` for n
    averages (Bendat and Piersol), floored at :data:`RELATIVE_FLOOR` of |H1| and :data:`ABSOLUTE_FLOOR` of the band's
    median |H1|; with a single hit (coherence 1 everywhere), 1/√(|H|² + (:data:`WEIGHT_FLOOR`·median)²): relative at
    the peaks, absolute at the antiresonances."""
    if averages < 2:
        return 1.0 / np.sqrt(magnitude**2 + (WEIGHT_FLOOR * median) ** 2)
    gamma2 = np.clip(np.nan_to_num(coherence), 1e-6, 1.0)
    error2 = magnitude**2 * (1.0 - gamma2) / (2 * averages * gamma2)
    return 1.0 / np.sqrt(error2 + (RELATIVE_FLOOR * magnitude) ** 2 + (ABSOLUTE_FLOOR * median) ** 2)


def _lscf_poles(freq_hz: np.ndarray, h1: np.ndarray, lines: np.ndarray,
                decay_rate_1_s: float) -> tuple[list[int], list[np.ndarray]]:
    """LSCF poles (sdypy-EMA) at every model order, as the structure's poles (the window's decay added back), those
    in the band with a positive frequency only."""
    from sdypy import EMA  # imported here: only a structure read off an FRF needs it

    low_hz, high_hz = float(freq_hz[lines[0]]), float(freq_hz[lines[-1]])
    upto = int(lines[-1]) + 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        model = EMA.Model(frf=h1[None, :upto], freq=freq_hz[:upto], lower=low_hz, upper=high_hz,
                          pol_order_high=LSCF_ORDER, frf_form="accelerance")
        model.get_poles(method="lscf", show_progress=False)
    orders, poles = [], []
    for index, found in enumerate(model.all_poles):
        found = np.asarray(found)
        found = found[np.isfinite(found) & (found.imag > 0) & (found.real < 0)] + decay_rate_1_s
        inside = (np.abs(found) > 2 * np.pi * low_hz) & (np.abs(found) < 2 * np.pi * high_hz)
        orders.append(2 * (index + 1))
        poles.append(np.sort_complex(found[inside]))
    return orders, poles


def _fit_lines(freq_hz: np.ndarray, lines: np.ndarray, poles_hz: list[float], decay_rate_1_s: float) -> np.ndarray:
    """The readable lines a fit uses: every one within a few bandwidths of a pole or peak, every n-th elsewhere."""
    keep = np.zeros(freq_hz.size, bool)
    keep[lines[:: int(np.ceil(lines.size / MAX_FIT_LINES))]] = True
    spacing_hz = freq_hz[1] - freq_hz[0]
    window_hz = max(POLE_LINES * spacing_hz, POLE_BANDWIDTHS * decay_rate_1_s / (2 * np.pi))
    for pole_hz in poles_hz:
        keep[(freq_hz >= pole_hz - window_hz) & (freq_hz <= pole_hz + window_hz)] = True
    readable = np.zeros(freq_hz.size, bool)
    readable[lines] = True
    return np.flatnonzero(keep & readable)


def _columns(s: np.ndarray, freq_hz: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """The LSFD basis at ``s``: the constant (mass line), each mode's real and quadrature columns."""
    omega = 2 * np.pi * freq_hz
    modes = s[:, None] ** 2 / (s[:, None] ** 2 + 2 * zeta * omega * s[:, None] + omega**2)
    return np.column_stack((np.ones_like(s), modes, modes * s[:, None] / omega))


def _constants(columns: np.ndarray, measured: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Real coefficients of ``columns`` fitting ``measured`` by weighted least squares (as complex numbers)."""
    weighted = columns * weight[:, None]
    stacked = np.vstack((weighted.real, weighted.imag))
    target = measured * weight
    normal = stacked.T @ stacked
    normal[np.diag_indices_from(normal)] *= 1.0 + 1e-12
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            solution = np.linalg.solve(normal, stacked.T @ np.concatenate((target.real, target.imag)))
        except np.linalg.LinAlgError:
            solution = np.linalg.lstsq(stacked, np.concatenate((target.real, target.imag)), rcond=None)[0]
    return solution.astype(complex)


def _diagram(orders: list[int], poles: list[np.ndarray], s: np.ndarray, measured: np.ndarray, weight: np.ndarray,
             frf_freq_hz: np.ndarray, frf_magnitude: np.ndarray) -> StabilizationDiagram:
    """Each order's poles with their stability against the next lower order's; the participation compared is the
    complex modal constant the order's own poles get by LSFD."""
    rows = []
    previous = None
    for order, found in zip(orders, poles):
        freq = np.abs(found) / (2 * np.pi)
        zeta = np.clip(-found.real / np.maximum(np.abs(found), 1e-300), 0.0, None)
        if found.size:
            values = _constants(_columns(s, freq, np.maximum(zeta, MIN_DAMPING_RATIO)), measured, weight)
            constant = values[1 : 1 + found.size].real + 1j * values[1 + found.size :].real
        else:
            constant = np.zeros(0, complex)
        for f, z, c in zip(freq, zeta, constant):
            stability = 0
            if previous is not None and previous[0].size:
                j = int(np.argmin(np.abs(previous[0] - f)))
                if abs(previous[0][j] - f) < STABLE_FREQUENCY * f:
                    stability = 1
                    if abs(previous[1][j] - z) < max(STABLE_DAMPING * z, STABLE_DAMPING_FLOOR):
                        stability = 2
                        if abs(previous[2][j] - c) < STABLE_PARTICIPATION * max(abs(c), 1e-300):
                            stability = 3
            rows.append((order, f, z, stability))
        previous = (freq, zeta, constant)
    table = np.array(rows, float).reshape(-1, 4)
    return StabilizationDiagram(table[:, 0].astype(int), table[:, 1], table[:, 2], table[:, 3].astype(int),
                                np.asarray(frf_freq_hz, float), np.asarray(frf_magnitude, float))


def _stable_clusters(diagram: StabilizationDiagram, spacing_hz: float) -> list[tuple[float, float, int]]:
    """(frequency Hz, damping ratio, orders) of each cluster of poles stable in frequency, damping and participation
    at :data:`MIN_STABLE_ORDERS` orders or more: the median pole of the cluster."""
    stable = diagram.stability == len(STABILITY) - 1
    freq, zeta, order = diagram.freq_hz[stable], diagram.damping_ratio[stable], diagram.order[stable]
    sort = np.argsort(freq)
    freq, zeta, order = freq[sort], zeta[sort], order[sort]
    if freq.size == 0:
        return []
    gaps = np.flatnonzero(np.diff(freq) > np.maximum(CLUSTER_WIDTH * freq[1:], CLUSTER_LINES * spacing_hz)) + 1
    clusters = []
    for members in np.split(np.arange(freq.size), gaps):
        count = np.unique(order[members]).size
        if count >= MIN_STABLE_ORDERS:
            clusters.append((float(np.median(freq[members])), float(np.median(zeta[members])), int(count)))
    return clusters


def _not_a_mode(pole_hz: float, zeta: float, freq_hz: np.ndarray, magnitude: np.ndarray, coherence: np.ndarray,
                decay_rate_1_s: float) -> str:
    """Why a stable pole is not a mode ("" when it is one): it sits on a line of low coherence, or at an antiresonance
    (|H1| there well below its median over a few bandwidths around it)."""
    line = int(np.argmin(np.abs(freq_hz - pole_hz)))
    spacing_hz = freq_hz[1] - freq_hz[0]
    if np.nan_to_num(coherence[line]) < MIN_COHERENCE:
        return f"a line of low coherence ({np.nan_to_num(coherence[line]):.2f})"
    half_width_hz = max(POLE_LINES * spacing_hz, 3 * (zeta * 2 * np.pi * pole_hz + decay_rate_1_s) / (2 * np.pi))
    around = (freq_hz >= pole_hz - half_width_hz) & (freq_hz <= pole_hz + half_width_hz)
    if magnitude[line] < ANTIRESONANCE_DEPTH * np.median(magnitude[around]):
        return "an antiresonance of |H1|"
    return ""


def _refined(s: np.ndarray, measured: np.ndarray, weight: np.ndarray, start_hz: np.ndarray, start_zeta: np.ndarray,
             high_hz: float) -> tuple[np.ndarray, np.ndarray, tuple[float, float] | None, np.ndarray]:
    """The poles (Hz, damping ratio) refined with the constants solved at every step (:func:`_projected`), with one
    mode above the band as the upper residual; its (Hz, damping ratio), and the constants: [mass line, each mode's
    real parts, each mode's quadrature parts, the upper residual's real and quadrature parts]."""
    count = start_hz.size
    freq = np.concatenate((start_hz, [UPPER_START * high_hz]))
    zeta = np.concatenate((start_zeta, [UPPER_DAMPING]))
    low = np.concatenate((start_hz * (1 - POLE_FREEDOM), [UPPER_RANGE[0] * high_hz],
                          np.full(count, MIN_DAMPING_RATIO), [1e-3]))
    high = np.concatenate((start_hz * (1 + POLE_FREEDOM), [UPPER_RANGE[1] * high_hz],
                           np.full(count, MAX_DAMPING_RATIO), [0.5]))
    freq, zeta, constants = _projected(s, measured, weight, freq, zeta, low, high, np.ones_like(s), np.ones_like(s))
    poles = count + 1
    values = np.concatenate((constants[:1], constants[1 : 1 + count], constants[1 + poles : 1 + poles + count],
                             constants[poles : poles + 1], constants[-1:])).astype(complex)
    return freq[:count], zeta[:count], (float(freq[count]), float(zeta[count])), values


def _projected(s: np.ndarray, measured: np.ndarray, weight: np.ndarray, freq_hz: np.ndarray, zeta: np.ndarray,
               low: np.ndarray, high: np.ndarray, base: np.ndarray, transfer: np.ndarray,
               steps: int = REFINE_STEPS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Variable projection of ``measured`` ≈ c₀·base + transfer·Σ_r (A_r + B_r·s/ω_r)·s²/(s² + 2ζ_rω_r s + ω_r²) at
    ``s`` by weighted least squares: the poles (Hz, damping ratios, within ``low``/``high`` = [frequencies…,
    damping ratios…]) by a bounded trust region with Kaufman's Jacobian, the real coefficients [c₀, A…, B…] solved at
    every step. Returns the poles and the coefficients."""
    poles = freq_hz.size
    lower, upper = np.log(low), np.log(high)
    start = np.clip(np.log(np.concatenate((freq_hz, zeta))), lower, upper)
    target = measured * weight
    stacked_target = np.concatenate((target.real, target.imag))
    s2 = s**2
    scale = (transfer * weight)[:, None]
    cache: dict[bytes, tuple] = {}

    def solve(trial: np.ndarray) -> tuple:
        key = trial.tobytes()
        if key not in cache:
            cache.clear()
            omega, damping = 2 * np.pi * np.exp(trial[:poles]), np.exp(trial[poles:])
            denominator = s2[:, None] + 2 * damping * omega * s[:, None] + omega**2
            mode = s2[:, None] / denominator
            basis = np.column_stack((base * weight, mode * scale, mode * s[:, None] / omega * scale))
            stacked = np.vstack((basis.real, basis.imag))
            q, r = np.linalg.qr(stacked)
            constants = np.linalg.lstsq(r, q.T @ stacked_target, rcond=None)[0]
            cache[key] = (omega, damping, denominator, mode, q, constants, stacked @ constants - stacked_target)
        return cache[key]

    def residual(trial: np.ndarray) -> np.ndarray:
        return solve(trial)[-1]

    def jacobian(trial: np.ndarray) -> np.ndarray:
        omega, damping, denominator, mode, q, constants, _ = solve(trial)
        real, quadrature = constants[1 : 1 + poles], constants[1 + poles :]
        # d(mode)/d(ln ω) and d(mode)/d(ln ζ); the quadrature column is mode·s/ω
        d_mode_omega = -s2[:, None] * (2 * damping * omega * s[:, None] + 2 * omega**2) / denominator**2
        d_mode_zeta = -s2[:, None] * (2 * damping * omega * s[:, None]) / denominator**2
        ratio = s[:, None] / omega
        by_omega = (d_mode_omega * (real + quadrature * ratio) - mode * quadrature * ratio) * scale
        by_zeta = d_mode_zeta * (real + quadrature * ratio) * scale
        change = np.vstack((np.column_stack((by_omega.real, by_zeta.real)),
                            np.column_stack((by_omega.imag, by_zeta.imag))))
        return change - q @ (q.T @ change)  # the part the constants cannot take up (Kaufman)

    try:
        refined = scipy.optimize.least_squares(residual, start, jac=jacobian, bounds=(lower, upper), method="trf",
                                               max_nfev=steps * 10, x_scale="jac").x
    except (ValueError, np.linalg.LinAlgError):
        refined = start
    if np.sum(residual(refined) ** 2) > np.sum(residual(start) ** 2):
        refined = start
    return np.exp(refined[:poles]), np.exp(refined[poles:]), solve(refined)[5]


def _pole_constants(s: np.ndarray, measured: np.ndarray, weight: np.ndarray, freq_hz: np.ndarray, zeta: np.ndarray,
                    upper: tuple[float, float] | None) -> np.ndarray:
    """The constants of these poles (and the upper residual's) by weighted least squares, in the order
    :func:`_refined` returns them."""
    count = freq_hz.size
    extra = [] if upper is None else [upper]
    basis = _columns(s, np.concatenate((freq_hz, [p[0] for p in extra])), np.concatenate((zeta, [p[1] for p in extra])))
    values = _constants(basis, measured, weight)
    poles = count + len(extra)
    tail = values[poles : poles + 1].tolist() + values[-1:].tolist() if extra else [0.0, 0.0]
    return np.concatenate((values[: 1 + count], values[1 + poles : 1 + poles + count], tail)).astype(complex)


def _significant(s: np.ndarray, measured: np.ndarray, weight: np.ndarray, freq_hz: np.ndarray, zeta: np.ndarray,
                 upper: tuple[float, float] | None) -> np.ndarray:
    """Which modes (and, last, the upper residual) the description needs: without a mode (the other constants solved
    again) the misfit must grow by more than its cost, :data:`MODE_COST` times ln(points) times the misfit per point
    of the whole description — a pole LSCF kept stable on a clean FRF, whose constant is nothing, is dropped."""
    extra = [] if upper is None else [upper]
    all_hz = np.concatenate((freq_hz, [p[0] for p in extra]))
    all_zeta = np.concatenate((zeta, [p[1] for p in extra]))
    basis = _columns(s, all_hz, all_zeta) * weight[:, None]
    stacked = np.vstack((basis.real, basis.imag))
    target = np.concatenate(((measured * weight).real, (measured * weight).imag))

    def residual(columns: np.ndarray) -> np.ndarray:
        solution = np.linalg.lstsq(stacked[:, columns], target, rcond=None)[0]
        return stacked[:, columns] @ solution - target

    poles = all_hz.size
    everything = np.ones(stacked.shape[1], bool)
    left = residual(everything)
    full = float(np.sum(left**2))
    points = target.size
    scale = full / max(points - stacked.shape[1], 1)
    cost = MODE_COST * np.log(points) * scale

    def misfit(columns: np.ndarray) -> float:
        return float(np.sum(residual(columns) ** 2))
    keep = np.ones(poles, bool)
    for mode in range(poles):
        without = everything.copy()
        without[[1 + mode, 1 + poles + mode]] = False
        keep[mode] = misfit(without) - full > cost
    return keep


def _residual_poles(s: np.ndarray, measured: np.ndarray, weight: np.ndarray, freq_hz: np.ndarray,
                    zeta: np.ndarray, upper: tuple[float, float] | None, spacing_hz: float,
                    from_hz: float) -> list[float]:
    """Frequencies (Hz) above ``from_hz`` where the refined description still leaves a misfit standing
    :data:`RESIDUAL_PEAK` times above the median misfit, away from its poles: a weak mode LSCF left unstable (what a
    modal engineer adds from the stabilization diagram where the synthesis misses). At most :data:`RESIDUAL_POLES`,
    the largest first. Below the modes read the FRF is the mass line and the suspension, not modes."""
    line_hz = s.imag / (2 * np.pi)
    poles_hz = np.concatenate((freq_hz, [] if upper is None else [upper[0]]))
    poles_zeta = np.concatenate((zeta, [] if upper is None else [upper[1]]))
    added: list[float] = []
    for _ in range(RESIDUAL_POLES):
        basis = _columns(s, poles_hz, poles_zeta)
        misfit = np.abs(basis @ _constants(basis, measured, weight).real - measured) * weight
        smoothed = np.convolve(misfit**2, np.ones(3) / 3, mode="same")
        level = np.median(smoothed)
        near = np.any(np.abs(line_hz[:, None] - poles_hz[None, :])
                      <= np.maximum(CLUSTER_LINES * spacing_hz, STABLE_FREQUENCY * poles_hz[None, :]), axis=1)
        smoothed[near | (line_hz < from_hz)] = 0.0
        best = int(np.argmax(smoothed))
        if smoothed[best] < RESIDUAL_PEAK * level:
            break
        added.append(float(line_hz[best]))
        poles_hz = np.append(poles_hz, line_hz[best])
        poles_zeta = np.append(poles_zeta, PEAK_DAMPING_RATIO)
    return added


def _driving_point(modes: list[StructureMode], freq_hz: np.ndarray, magnitude: np.ndarray) -> bool:
    """Whether every mode that stands out (its peak at least :data:`SIGN_SHARE` of |H1| there) has a modal constant
    of the mass line's sign (modes are written with the polarity taken out: positive)."""
    signs = []
    for mode in modes:
        line = int(np.argmin(np.abs(freq_hz - mode.freq_hz)))
        peak = abs(mode.modal_constant_per_kg) / (2 * mode.damping_ratio)
        if peak >= SIGN_SHARE * magnitude[line]:
            signs.append(mode.modal_constant_per_kg > 0)
    return all(signs)


def structure_summary(spec, reading: Structure | None, band_hz: tuple[float, float]) -> dict | None:
    """The measured structure of ``spec`` (a rig spec with structure modes) for the JSON and the report: the mode
    table by frequency (a mode above ``band_hz`` is the upper residual), the mass line, the polarity, and the reading
    off the FRF (:meth:`Structure.to_dict`) when the spec was read there; None for a spec without structure modes."""
    modes = [effect for effect in spec.effects if effect.type_name == "structure-mode"]
    if not modes:
        return None
    rows = mode_rows(modes)
    for row in rows:
        row["above_band"] = bool(row["freq_hz"] > band_hz[1])
    polarity = -1 if any(e.type_name == "polarity" and e.channel == "acceleration" for e in spec.effects) else 1
    return {"modes": rows, "mass_line_kg": spec.mass_kg, "polarity": polarity,
            "driving_point": all(row["modal_constant_per_kg"] > 0 for row in rows if not row["above_band"]),
            "read_off_frf": None if reading is None else reading.to_dict()}


#: A mode of a given structure re-read where the spec leaves the recordings beyond the noise: its pole scanned over
#: :data:`POLE_FREEDOM` of its frequency either side, in steps of :data:`SCAN_STEP` of its half-power bandwidth (at
#: least :data:`SCAN_MIN_STEP` of its frequency), at its damping ratio times :data:`SCAN_DAMPING_FACTORS`, judged on the
#: lines within :data:`SCAN_WINDOW` times that span (at least :data:`POLE_LINES` lines either side): the fit that
#: follows finishes the pole on every line.
SCAN_STEP = 0.25
SCAN_MIN_STEP = 2e-5
SCAN_DAMPING_FACTORS = (0.25, 0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0)
SCAN_WINDOW = 2.0


def beside_transfer(spec, freq_hz: np.ndarray, decay_rate_1_s: float) -> np.ndarray:
    """What the measurement chain of ``spec`` multiplies a mode beside the mover by on the grid (polarity, channel
    transfers): the response channel's transfer over the force channel's."""
    from gasfilm.analysis.physics.response import channel_transfer, laplace_variable

    s = laplace_variable(freq_hz, decay_rate_1_s)
    return channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s)


def reread_mode(mode: StructureMode, freq_hz: np.ndarray, decay_rate_1_s: float, target: np.ndarray,
                weight: np.ndarray, transfer: np.ndarray) -> tuple[StructureMode, float]:
    """The mode whose pole and complex constant best describe ``target`` (the recordings less the rest of the spec,
    (m/s²)/N on the grid, with real ``weight`` per line: χ² = Σ weight·|target − transfer·mode|²), its pole scanned
    within :data:`POLE_FREEDOM` of ``mode``'s (the constant solved at every trial pole: variable projection), and
    the χ² it gains over ``mode`` as it is, on the lines around it. What a modal engineer does when one peak of a known
    structure no longer fits: re-read that mode where it now is; the fit that follows finishes it."""
    spacing_hz = float(np.median(np.diff(freq_hz))) if freq_hz.size > 1 else 1.0
    span_hz = POLE_FREEDOM * mode.freq_hz
    near = np.abs(freq_hz - mode.freq_hz) <= max(SCAN_WINDOW * span_hz, POLE_LINES * spacing_hz)
    s = decay_rate_1_s + 2j * np.pi * freq_hz[near]
    transfer, root, target = transfer[near], np.sqrt(weight[near]), target[near]
    bandwidth_hz = 2 * mode.damping_ratio * mode.freq_hz
    step_hz = max(SCAN_STEP * bandwidth_hz, SCAN_MIN_STEP * mode.freq_hz)
    trial_hz = mode.freq_hz + np.arange(-span_hz, span_hz + step_hz / 2, step_hz)
    trial_zeta = np.clip(mode.damping_ratio * np.array(SCAN_DAMPING_FACTORS), MIN_DAMPING_RATIO, MAX_DAMPING_RATIO)
    hz, zeta = (grid.ravel() for grid in np.meshgrid(trial_hz, trial_zeta))
    omega = 2 * np.pi * hz[:, None]
    a = transfer * root * s**2 / (s**2 + 2 * zeta[:, None] * omega * s + omega**2)  # (trials, lines)
    t = target * root
    # the quadrature column is a·s/ω: its products follow from |a|² and conj(a)·t
    power = np.abs(a) ** 2
    aa = power.sum(axis=1)
    bb = power @ np.abs(s) ** 2 / omega[:, 0] ** 2
    ab = power @ s.real / omega[:, 0]
    at = (np.conj(a) @ t).real
    bt = (np.conj(a) @ (np.conj(s) * t)).real / omega[:, 0]
    determinant = aa * bb - ab**2
    ok = determinant > 1e-12 * aa * bb
    determinant = np.where(ok, determinant, 1.0)
    real = np.where(ok, (bb * at - ab * bt) / determinant, 0.0)
    quadrature = np.where(ok, (aa * bt - ab * at) / determinant, 0.0)
    total = float(np.sum(np.abs(t) ** 2))
    misfit = total - (real * at + quadrature * bt)
    best = int(np.argmin(misfit))
    as_it_is = float(np.sum(np.abs(t - transfer * root * mode.added_accelerance(s)) ** 2))
    limit = MAX_MODAL_CONSTANT_PER_KG
    return (StructureMode(freq_hz=float(hz[best]), damping_ratio=float(zeta[best]),
                          modal_constant_per_kg=float(np.clip(real[best], -limit, limit)) or mode.modal_constant_per_kg,
                          quadrature_per_kg=float(np.clip(quadrature[best], -limit, limit))),
            as_it_is - float(misfit[best]))


#: How a diagnosis's note on a re-read mode of its structure begins (the report lists it with the recalibration).
STRUCTURE_CHANGED = "the structure changed: "


def mode_change_text(before: StructureMode, after: StructureMode) -> str:
    """A mode's change in words: its frequency (Hz and %), its damping ratio (and factor) and the size of its modal
    constant (factor)."""
    size_before = np.hypot(before.modal_constant_per_kg, before.quadrature_per_kg)
    size_after = np.hypot(after.modal_constant_per_kg, after.quadrature_per_kg)
    return (f"the mode at {before.freq_hz:.1f} Hz: frequency → {after.freq_hz:.1f} Hz "
            f"({100 * (after.freq_hz / before.freq_hz - 1):+.2f} %), damping ratio {before.damping_ratio:.3g} → "
            f"{after.damping_ratio:.3g} (×{after.damping_ratio / before.damping_ratio:.2f}), modal constant "
            f"×{size_after / max(size_before, 1e-300):.2f} in size")


def side_modes_as_structure(spec):
    """``spec`` with its side modes (resonances beside the mover a diagnosis found) written as modes of its measured
    structure when it describes one (it has structure modes): the same physics (modal superposition, a real modal
    constant), then part of the structure a later diagnosis holds and re-reads mode by mode, rather than free terms a
    recalibration may move anywhere in the band (a side mode at 6.7 kHz moved above the band to take up a force leak).
    Unchanged for a spec without structure modes (a mover on a film: its side modes stay terms)."""
    if not any(effect.type_name == "structure-mode" for effect in spec.effects):
        return spec
    limit = MAX_MODAL_CONSTANT_PER_KG
    return spec.with_values(effects=[
        StructureMode(freq_hz=effect.freq_hz, damping_ratio=max(effect.damping_ratio, MIN_DAMPING_RATIO),
                      modal_constant_per_kg=float(np.clip(effect.modal_constant_per_kg, -limit, limit)),
                      quadrature_per_kg=float(np.clip(effect.quadrature_per_kg, -limit, limit)))
        if effect.type_name == "side-mode" else effect for effect in spec.effects])
