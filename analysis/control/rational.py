"""A rational (state-space) model of an identified film or a whole rig, with its error, stability and passivity.

The support stiffness ``Z(s)`` (N/m: the film, plus a diagnosed spec's mechanical effects) is evaluated only
through the physics package (:meth:`FilmModel.stiffness`, :func:`rig_dynamic_stiffness`). It is approximated as

    ``Z_r(s) = Z(0) + s·Y_r(s)``,   ``Y_r(s) = e + Σ r_i / (s − p_i)``   (vector fitting of ``(Z − Z(0))/s``)

so the static stiffness ``Z(0)`` is exact and ``Y_r = (Z_r − Z(0))/s`` is the film's mechanical impedance (force per
velocity) less its static spring. The fit is weighted by ``|s| / min(|Z|, |Z + M s²|)``: the relative error of the
film and of the plant's accelerance ``H = s² / (Z + M s²)`` (which amplifies a film error by the resonance's
quality factor) are both bounded. The plant (force in N → mover acceleration in m/s²) is realised with states
``[x (only when Z(0) ≠ 0), v, ξ]``: ``M v' = F − Z(0)·x − e·v − C ξ``, ``ξ' = A ξ + B v``.

Passivity of the film is checked, not assumed: a film is passive when it never returns energy, i.e. its mechanical
impedance ``Z(s)/s`` is positive real — ``Re[Z(jω)/(jω)] = Im Z(jω)/ω ≥ 0`` at every frequency. (Every network of
springs, dashpots and spring-pots with orders in [0, 2] has it; a rational fit need not.) It is tested on a dense
log grid and by the Hamiltonian test of positive realness on the state-space realisation (no imaginary eigenvalue
⇔ no frequency where the real part crosses zero). The storage stiffness ``Re Z(jω) ≥ 0`` is tested the same way
and reported separately: a fractional film with an order above 1 may itself have ``Re Z < 0`` somewhere.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import scipy.signal

from gasfilm.analysis.control.fitting import PoleResidue, oustaloup_response, vector_fit
from gasfilm.analysis.physics.elements import (
    LogLaplace,
    Node,
    Parallel,
    Series,
    SpringPot,
    accelerance_from_stiffness,
    parse_network,
)
from gasfilm.analysis.physics.effects import Effect
from gasfilm.analysis.physics.features import refine_maxima, resolving_grid_hz, singular_frequencies_hz
from gasfilm.analysis.physics.response import rig_dynamic_stiffness
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import SettingError

logger = logging.getLogger(__name__)

DEFAULT_MAX_ERROR = 0.005
#: frequency lines per decade of the fitting and checking grids
LINES_PER_DECADE = 40
#: the passivity grid reaches this factor beyond the band on each side
PASSIVITY_GRID_FACTOR = 1e4
MAX_FILM_ORDER = 40
#: the order search gives up when this many more states in a row lower the error by less than this fraction
STALL_ORDERS = 8
STALL_GAIN = 0.1
#: the band a spec (which holds no measured band) is approximated over by default: a decade beyond 20–1000 Hz
DEFAULT_MEASURED_BAND_HZ = (20.0, 1000.0)
#: lines per decade of the base of the grid the errors are measured on (points cluster around every feature)
ERROR_LINES_PER_DECADE = 200
#: local maxima of an error within this fraction of the largest are refined between their grid neighbours; at most
#: this many of them
REFINE_WITHIN = 0.3
REFINED_MAXIMA = 8
#: the least error stated, and the relative margin a stated error carries: the rounding of evaluating both models
#: in double precision (stiffnesses of 1e9 N/m and more, sums that cancel)
ROUNDING_FLOOR = 1e-12
ROUNDING_MARGIN = 1e-6
#: a plain Oustaloup filter is designed over the band widened one of these many times on each side
OUSTALOUP_WIDENINGS = (10.0, 100.0, 1000.0)


@dataclass(frozen=True)
class PlantSource:
    """What is approximated: the support stiffness Z(s) in N/m (film, + a spec's mechanical effects) under a mass."""

    description: str
    mass_kg: float
    support_stiffness: Callable[[np.ndarray], np.ndarray]  # Z(s) in N/m at the Laplace variable s (rad/s)
    measured_band_hz: tuple[float, float] | None
    origin: dict[str, Any]  # JSON-compatible: the fit (FitResult.to_dict) or the rig spec TOML
    excluded: tuple[str, ...] = ()  # what the linear plant leaves out (measurement chain, nonlinear terms)
    film_parameters: dict[str, float] = field(default_factory=dict)
    network: str = ""
    #: where Z(s) (under the mass) can have narrow features in a span of Hz: centres (Hz) and widths (Hz, or None)
    features_hz: Callable[[tuple[float, float]], tuple[np.ndarray, np.ndarray | None]] = (
        lambda span: (np.zeros(0), None))

    def accelerance(self, s: np.ndarray) -> np.ndarray:
        """The exact accelerance (m/s²)/N at ``s``."""
        return accelerance_from_stiffness(s, self.support_stiffness(s), self.mass_kg)

    @classmethod
    def from_fit(cls, fit: Any, where: str = "") -> "PlantSource":
        """An identified film (a :class:`~gasfilm.analysis.identification.FitResult`) under its mass."""
        model = fit.model()
        params = dict(fit.params)
        band = tuple(fit.band_hz) if fit.band_hz and fit.band_hz[1] > 0 else None
        mass = float(fit.mass_kg)
        return cls(
            description=f"{fit.model_name} fit ({fit.method} fitter, {fit.band_hz[0]:g}–{fit.band_hz[1]:g} Hz)"
                        + (f" of {where}" if where else ""),
            mass_kg=float(fit.mass_kg),
            support_stiffness=lambda s: model.stiffness(s, params),
            measured_band_hz=band,
            origin={"fit": fit.to_dict(), "source": where},
            film_parameters=params,
            network=fit.network,
            features_hz=lambda span: (singular_frequencies_hz(model, params, span, mass), None),
        )

    @classmethod
    def from_spec(cls, spec: RigSpec, where: str = "") -> "PlantSource":
        """A whole rig: the spec's film and mechanical effects under its moving mass, at session time 0 and zero
        amplitude. Measurement-chain effects, interference and amplitude-dependent terms are left out (named)."""
        excluded = []
        for effect in spec.effects:
            nonlinear = effect.cubic_stiffness_n_per_m3() != 0.0 or (
                type(effect).level_damping_ns_per_m is not Effect.level_damping_ns_per_m)
            if effect.kind != "rig":
                excluded.append(f"{effect.type_name} ({effect.kind}: not part of the mechanical plant)")
            elif nonlinear:
                excluded.append(f"{effect.type_name} (amplitude-dependent: left out of the linear plant)")
            elif effect.per_hit:
                excluded.append(f"{effect.type_name} (changes over the session: taken at session time 0)")
        mass = spec.moving_mass_kg

        def support(s: np.ndarray) -> np.ndarray:
            s = np.asarray(s, dtype=complex)
            return rig_dynamic_stiffness(spec, s) - mass * s**2

        def features(span: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
            """The film's singular frequencies under the moving mass, and each mode an effect adds (its frequency and
            its half-power width ζ·f)."""
            film = singular_frequencies_hz(spec.film, spec.film_parameters, span, mass)
            modes = [(float(effect.freq_hz), float(effect.damping_ratio) * float(effect.freq_hz))
                     for effect in spec.effects if hasattr(effect, "freq_hz") and hasattr(effect, "damping_ratio")]
            centres = np.concatenate([film, [f for f, _ in modes]])
            return centres, np.concatenate([np.full(film.size, np.nan), [w for _, w in modes]])

        return cls(
            description=f"rig spec '{spec.name}'" + (f" ({where})" if where else ""),
            mass_kg=mass,
            support_stiffness=support,
            measured_band_hz=None,
            origin={"rig_spec_toml": spec.to_toml(), "source": where},
            excluded=tuple(excluded),
            film_parameters=dict(spec.film_parameters),
            network=spec.film.text,
            features_hz=features,
        )


@dataclass(frozen=True)
class Passivity:
    """A positive-real check of one function on the jω axis: grid minimum, crossings found by the Hamiltonian test."""

    passed: bool
    grid_minimum: float  # minimum of the real part on the grid (relative to its largest magnitude there)
    crossings_hz: tuple[float, ...]  # frequencies where the real part crosses zero (Hamiltonian test)
    note: str = ""


@dataclass
class RationalModel:
    """The rational approximation: film and plant, their errors, stability and passivity."""

    source: PlantSource
    band_hz: tuple[float, float]
    static_stiffness_n_per_m: float
    impedance: PoleResidue  # Y_r(s) = (Z_r(s) − Z(0))/s in N·s/m
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: float
    max_error_band: float  # max complex relative error of the plant or the film in the band
    max_error_plant_band: float
    max_error_film_band: float
    max_error_outside: float  # the same a decade beyond the band on each side
    stable: bool
    passive: Passivity  # dissipation: Re[Z_r(jω)/(jω)] ≥ 0
    storage: Passivity  # Re Z_r(jω) ≥ 0
    source_storage_minimum: float  # min Re Z/|Z| of the fractional film on the grid (negative: Re Z < 0 there)
    target_error: float | None
    method: str = "vector fitting"
    #: how the errors were found: the grid (its base density, the frequencies it resolves), where each is largest
    error_grid: dict[str, Any] = field(default_factory=dict)
    curve_freq_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    curve_plant_error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    curve_film_error: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def order(self) -> int:
        """Number of states of the plant."""
        return int(self.a.shape[0])

    @property
    def film_order(self) -> int:
        return self.impedance.order

    def support_stiffness(self, s: np.ndarray) -> np.ndarray:
        """The rational film's Z_r(s) in N/m."""
        s = np.asarray(s, dtype=complex)
        return self.static_stiffness_n_per_m + s * self.impedance(s)

    def accelerance(self, s: np.ndarray) -> np.ndarray:
        """The state-space plant's accelerance (m/s²)/N at ``s``, from (A, B, C, D)."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        eye = np.eye(self.order)
        solved = np.linalg.solve(s[:, None, None] * eye - self.a, np.broadcast_to(self.b, (s.size, self.order))[..., None])
        return (self.c @ solved)[..., 0] + self.d

    def zpk(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Zeros, poles (rad/s) and gain of the plant."""
        import scipy.signal

        zeros, poles, gain = scipy.signal.ss2zpk(self.a, self.b[:, None], self.c[None, :], np.array([[self.d]]))
        return zeros, poles, float(gain)

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and denominator coefficients of the plant (highest power of s first)."""
        import scipy.signal

        num, den = scipy.signal.ss2tf(self.a, self.b[:, None], self.c[None, :], np.array([[self.d]]))
        return np.asarray(num[0]), np.asarray(den)

    def summary(self) -> str:
        """One line: order, errors, stability and passivity."""
        storage = "" if self.storage.passed else (
            "; storage stiffness Re Z < 0 somewhere" + (" (so is the fractional film's)"
                                                       if self.source_storage_minimum < 0 else ""))
        worst = self.error_grid.get("worst_band_hz")
        at = f" (at {worst:.4g} Hz)" if worst else ""
        return (f"order {self.order} (film {self.film_order}), max error {100 * self.max_error_band:.3g} %{at} in "
                f"{self.band_hz[0]:g}–{self.band_hz[1]:g} Hz, {100 * self.max_error_outside:.3g} % in the decade "
                f"outside, {'stable' if self.stable else 'UNSTABLE'}, film "
                f"{'passive' if self.passive.passed else 'NOT passive'}{storage}")


# --- checks ------------------------------------------------------------------------------------------------------


def _hamiltonian_crossings(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: float) -> tuple[float, ...]:
    """Angular frequencies ω ≥ 0 where Re G(jω) = 0 for ``G = d + c (sI − A)⁻¹ b`` (d > 0): the imaginary-axis
    eigenvalues of the Hamiltonian ``[[A − b c/2d, −b bᵀ/2d], [cᵀ c/2d, −Aᵀ + cᵀ bᵀ/2d]]``."""
    if a.shape[0] == 0:
        return ()
    r = 2.0 * d
    top = np.hstack([a - np.outer(b, c) / r, -np.outer(b, b) / r])
    bottom = np.hstack([np.outer(c, c) / r, -a.T + np.outer(c, b) / r])
    eigenvalues = np.linalg.eigvals(np.vstack([top, bottom]))
    scale = max(1.0, float(np.max(np.abs(eigenvalues))))
    on_axis = eigenvalues[np.abs(eigenvalues.real) <= 1e-9 * scale]
    return tuple(sorted({round(float(abs(v.imag)), 6) for v in on_axis}))


def _positive_real(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: float, real_part: Callable[[np.ndarray], np.ndarray],
    omega_grid: np.ndarray, magnitude: float,
) -> Passivity:
    """Re G(jω) ≥ 0 for all ω: the grid, and the Hamiltonian test on ``G + δ`` with δ = 1e-9 of the largest
    magnitude (so a strictly proper G, whose real part only tends to 0, is certified to within δ)."""
    delta = 1e-9 * magnitude
    values = real_part(omega_grid)
    grid_minimum = float(np.min(values)) / magnitude
    every = _hamiltonian_crossings(a, b, c, d + delta)
    # a zero at DC (a film without static stiffness: Re Z(jω) ∝ ω²) touches the axis without crossing it
    crossings = tuple(w for w in every if w > 1e-6 * omega_grid[0])
    at_infinity = d + delta > 0
    passed = grid_minimum >= -1e-9 and not crossings and at_infinity
    note = "negative at infinite frequency" if not at_infinity else (
        "zero at DC (no static stiffness)" if len(every) > len(crossings) else "")
    return Passivity(passed, grid_minimum, tuple(w / (2 * np.pi) for w in crossings), note)


# --- the approximation -------------------------------------------------------------------------------------------


def default_band_hz(source: PlantSource) -> tuple[float, float]:
    """A decade beyond the measured band on each side (20–1000 Hz for a spec, which holds no measured band)."""
    low, high = source.measured_band_hz or DEFAULT_MEASURED_BAND_HZ
    if low <= 0:
        low = high / 100
    return low / 10, high * 10


def static_stiffness(source: PlantSource, band_hz: tuple[float, float]) -> float:
    """Z(0) in N/m: the support stiffness far below the band, or 0 when it still falls off there (a series
    dashpot or spring-pot: the mover then floats freely at DC)."""
    omega = 2 * np.pi * band_hz[0] * np.array([1e-6, 1e-5])
    low, higher = source.support_stiffness(1j * omega)
    if not (np.isfinite(low) and np.isfinite(higher)) or low == 0 or higher == 0:
        return 0.0
    slope = abs(np.log(abs(higher / low))) / np.log(10)
    return float(low.real) if slope < 0.01 else 0.0


def _grid_hz(band_hz: tuple[float, float], factor: float = 1.0) -> np.ndarray:
    low, high = band_hz[0] / factor, band_hz[1] * factor
    return np.geomspace(low, high, max(50, int(LINES_PER_DECADE * np.log10(high / low)) + 1))


def _plant_state_space(z0: float, impedance: PoleResidue, mass_kg: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """States [x (when z0 ≠ 0), v, ξ]: M v' = F − z0 x − e v − C ξ, ξ' = A ξ + B v; output the acceleration v'."""
    a_y, b_y, c_y, e = impedance.state_space()
    n = a_y.shape[0]
    with_x = z0 != 0.0
    offset = 1 if with_x else 0
    size = n + 1 + offset
    a = np.zeros((size, size))
    v = offset
    row = np.zeros(size)
    if with_x:
        a[0, v] = 1.0
        row[0] = -z0
    row[v] = -e
    row[v + 1:] = -c_y
    a[v] = row / mass_kg
    a[v + 1:, v] = b_y
    a[v + 1:, v + 1:] = a_y
    b = np.zeros(size)
    b[v] = 1.0 / mass_kg
    return a, b, row / mass_kg, 1.0 / mass_kg


def _relative_errors(source: PlantSource, z0: float, impedance: PoleResidue, freq_hz: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    s = 2j * np.pi * freq_hz
    z = source.support_stiffness(s)
    z_r = z0 + s * impedance(s)
    h = accelerance_from_stiffness(s, z, source.mass_kg)
    h_r = accelerance_from_stiffness(s, z_r, source.mass_kg)
    return np.abs(h_r / h - 1.0), np.abs(z_r / z - 1.0)


def film_transfer_function(z0: float, impedance: PoleResidue) -> tuple[np.ndarray, np.ndarray]:
    """The rational film stiffness ``Z_r(s) = Z(0) + s·Y_r(s)`` as numerator and denominator (N/m, highest power
    first); improper (numerator one degree higher) when the film has a parallel dashpot at high frequency."""
    a, b, c, e = impedance.state_space()
    if a.shape[0] == 0:
        num, den = np.array([e]), np.array([1.0])
    else:
        tf_num, den = scipy.signal.ss2tf(a, b[:, None], c[None, :], np.array([[e]]))
        num = np.asarray(tf_num[0])
    numerator = np.polyadd(z0 * den, np.polymul(num, [1.0, 0.0]))
    return np.trim_zeros(numerator, "f"), den


def _rational_features_hz(z0: float, impedance: PoleResidue, plant_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the rational model's responses have features: every pole of the plant and of the film, every zero of
    the film's stiffness — each at |p|/2π Hz with its half-power width |Re p|/2π."""
    roots = [np.linalg.eigvals(plant_a) if plant_a.size else np.zeros(0), impedance.poles]
    numerator, _ = film_transfer_function(z0, impedance)
    if numerator.size > 1 and np.all(np.isfinite(numerator)):
        roots.append(np.roots(numerator))
    every = np.concatenate(roots)
    every = every[(every.imag >= 0) & (np.abs(every) > 0) & np.isfinite(every)]
    return np.abs(every) / (2 * np.pi), np.abs(every.real) / (2 * np.pi)


def _largest_errors(source: PlantSource, z0: float, impedance: PoleResidue, grid_hz: np.ndarray,
                    refine_below: float = np.inf) -> tuple[np.ndarray, np.ndarray, float, float, float, float]:
    """The plant's and the film's relative errors on ``grid_hz`` and their largest values with where they are, each
    local maximum within :data:`REFINE_WITHIN` of the largest refined between its grid neighbours, stated with
    :data:`ROUNDING_MARGIN` for the rounding of evaluating both models there (a flat maximum's last digits vary
    between grids) and at least :data:`ROUNDING_FLOOR` (an exact model's error is rounding).
    An error already above ``refine_below`` on the grid is not refined (a model that misses its target does)."""
    plant, film = _relative_errors(source, z0, impedance, grid_hz)
    found = []
    for which, error in enumerate((plant, film)):
        best_hz, best = float(grid_hz[int(np.argmax(error))]), float(np.max(error))
        if max(plant.max(), film.max()) > refine_below:
            found += [max(best, ROUNDING_FLOOR), best_hz]  # (not refined: a model that misses its target)
            continue
        inner = np.flatnonzero((error[1:-1] >= error[:-2]) & (error[1:-1] >= error[2:])) + 1
        ends = [i for i in (0, len(error) - 1) if error[i] >= REFINE_WITHIN * best]
        candidates = [int(i) for i in inner if error[i] >= REFINE_WITHIN * best] + ends
        chosen = sorted(candidates, key=lambda i: -error[i])[:REFINED_MAXIMA]
        for f_hz, value in refine_maxima(lambda f: _relative_errors(source, z0, impedance, f)[which], grid_hz,
                                         chosen):
            if value > best:
                best_hz, best = f_hz, value
        found += [max(best * (1 + ROUNDING_MARGIN), ROUNDING_FLOOR), best_hz]
    return plant, film, found[0], found[1], found[2], found[3]


def _fit_impedance(source: PlantSource, z0: float, band_hz: tuple[float, float], film_order: int) -> PoleResidue:
    freq_hz = _grid_hz(band_hz)
    s = 2j * np.pi * freq_hz
    z = source.support_stiffness(s)
    weight = np.abs(s) / np.minimum(np.abs(z), np.abs(z + source.mass_kg * s**2))
    impedance = (z - z0) / s
    start = (2 * np.pi * band_hz[0], 2 * np.pi * band_hz[1])
    fit = vector_fit(s, impedance, film_order, weight=weight, start_band_rad_s=start)
    if fit.constant < 0:  # a negative dashpot at infinite frequency is not passive: fit a strictly proper one
        fit = vector_fit(s, impedance, film_order, weight=weight, constant=False, start_band_rad_s=start)
    return fit


def build_model(source: PlantSource, band_hz: tuple[float, float], film_order: int,
                target_error: float | None = None) -> RationalModel:
    """The rational model with ``film_order`` poles in the film's impedance, with every check done. With a
    ``target_error`` that the grid shows the model misses, its errors are the grid's (not refined: a lower bound)."""
    z0 = static_stiffness(source, band_hz)
    impedance = _fit_impedance(source, z0, band_hz, film_order)
    a, b, c, d = _plant_state_space(z0, impedance, source.mass_kg)
    # the errors where they are largest: a grid resolving every feature of both models, its maxima refined
    low_out, high_out = band_hz[0] / 10, band_hz[1] * 10
    source_centres, source_widths = source.features_hz((low_out, high_out))
    source_widths = np.full(source_centres.size, np.nan) if source_widths is None else source_widths
    rational_centres, rational_widths = _rational_features_hz(z0, impedance, a)
    centres = np.concatenate([source_centres, rational_centres])
    widths = np.concatenate([source_widths, rational_widths])
    band_grid = resolving_grid_hz(band_hz, centres, widths, ERROR_LINES_PER_DECADE)
    target = np.inf if target_error is None else target_error
    plant_error, film_error, plant_max, plant_at, film_max, film_at = _largest_errors(source, z0, impedance,
                                                                                      band_grid, target)
    # each side outside on its own (a maximum is refined between neighbours of its own side)
    sides = [resolving_grid_hz(span, centres, widths, ERROR_LINES_PER_DECADE)
             for span in ((low_out, band_hz[0]), (band_hz[1], high_out))]
    below, above = (_largest_errors(source, z0, impedance, grid) for grid in sides)
    outside = np.concatenate(sides)
    outside_plant, outside_film = np.concatenate([below[0], above[0]]), np.concatenate([below[1], above[1]])
    (out_plant_max, out_plant_at), (out_film_max, out_film_at) = (
        max(((side[2], side[3]) for side in (below, above)), key=lambda item: item[0]),
        max(((side[4], side[5]) for side in (below, above)), key=lambda item: item[0]))
    error_grid = {
        "method": "complex relative errors on a log grid of the band (and of the decade beyond each side) with "
                  "points clustered around every frequency where either model can have a narrow feature — the "
                  "fractional film's magnitude crossings of sibling branches and of the mass line, each mode of a "
                  "spec's effects, every pole and zero of the rational model, each from 1e-8 to 0.3 relative and "
                  "from 0.1 to 10 half-power widths away —, then every local maximum within "
                  f"{REFINE_WITHIN:g} of the largest refined by zooming in between its grid neighbours; "
                  f"stated with a margin of {ROUNDING_MARGIN:g} of itself and at least {ROUNDING_FLOOR:g} (rounding)",
        "base_lines_per_decade": ERROR_LINES_PER_DECADE,
        "points_band": int(band_grid.size),
        "points_outside": int(outside.size),
        "resolved_fractional_hz": sorted(float(f) for f in source_centres if low_out <= f <= high_out),
        "resolved_rational_hz": sorted(float(f) for f in rational_centres if low_out <= f <= high_out),
        "worst_band_hz": plant_at if plant_max >= film_max else film_at,
        "worst_plant_band_hz": plant_at,
        "worst_film_band_hz": film_at,
        "worst_outside_hz": out_plant_at if out_plant_max >= out_film_max else out_film_at,
    }
    poles = np.linalg.eigvals(a) if a.size else np.zeros(0)
    stable = bool(np.all(poles.real < 0))

    omega = 2 * np.pi * _grid_hz(band_hz, PASSIVITY_GRID_FACTOR)
    a_y, b_y, c_y, e = impedance.state_space()
    y_scale = float(np.max(np.abs(impedance(1j * omega)))) or 1.0
    passive = _positive_real(a_y, b_y, c_y, e, lambda w: impedance(1j * w).real, omega, y_scale)
    # Z_r(s) = z0 + s Y(s) = (z0 + C B) + e s + C A (sI − A)⁻¹ B: e s adds nothing to Re Z_r(jω)
    z_static_part = z0 + (float(c_y @ b_y) if b_y.size else 0.0)
    z_scale = float(np.max(np.abs(z0 + 1j * omega * impedance(1j * omega)))) or 1.0
    storage = _positive_real(a_y, b_y, c_y @ a_y if a_y.size else c_y, z_static_part,
                             lambda w: (z0 + 1j * w * impedance(1j * w)).real, omega, z_scale)
    source_z = source.support_stiffness(1j * omega)
    model = RationalModel(
        source=source, band_hz=(float(band_hz[0]), float(band_hz[1])), static_stiffness_n_per_m=z0,
        impedance=impedance, a=a, b=b, c=c, d=d,
        max_error_band=float(max(plant_max, film_max)),
        max_error_plant_band=float(plant_max), max_error_film_band=float(film_max),
        max_error_outside=float(max(out_plant_max, out_film_max)),
        stable=stable, passive=passive, storage=storage,
        source_storage_minimum=float(np.min(source_z.real / np.abs(source_z))),
        target_error=target_error,
        error_grid=error_grid,
    )
    order = np.argsort(np.concatenate([outside, band_grid]), kind="stable")
    model.curve_freq_hz = np.concatenate([outside, band_grid])[order]
    model.curve_plant_error = np.concatenate([outside_plant, plant_error])[order]
    model.curve_film_error = np.concatenate([outside_film, film_error])[order]
    return model


def _check_band(band_hz: tuple[float, float]) -> tuple[float, float]:
    low, high = (float(v) for v in band_hz)
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
        raise SettingError(f"--band {low:g}:{high:g}: needs 0 < LO < HI (Hz)")
    return low, high


def approximate(
    source: PlantSource,
    band_hz: tuple[float, float] | None = None,
    order: int | None = None,
    max_error: float = DEFAULT_MAX_ERROR,
) -> RationalModel:
    """The rational model of ``source`` over ``band_hz`` (default :func:`default_band_hz`): of ``order`` states,
    or the lowest order whose plant and film are within ``max_error`` (complex relative error) over the band,
    stable and passive. When no order up to the limit meets it (or :data:`STALL_ORDERS` more states in a row do not
    lower the error by :data:`STALL_GAIN`), the most accurate stable, passive one is returned (its error says by how
    much it misses)."""
    band = _check_band(band_hz) if band_hz is not None else default_band_hz(source)
    z0 = static_stiffness(source, band)
    states_without_film = 2 if z0 != 0.0 else 1
    if order is not None:
        film_order = order - states_without_film
        if film_order < 0:
            raise SettingError(f"--order {order}: this plant has at least {states_without_film} states "
                               f"(mover{' and static spring' if z0 else ''})")
        if film_order > MAX_FILM_ORDER:
            raise SettingError(f"--order {order}: at most {MAX_FILM_ORDER + states_without_film} states for this plant "
                               f"(a film of order {MAX_FILM_ORDER}); --max-error finds the lowest order accurate enough")
        return build_model(source, band, film_order)
    if not max_error > 0:
        raise SettingError(f"--max-error {max_error:g}: must be a positive fraction (e.g. 0.5%)")
    best: RationalModel | None = None
    since_better = 0
    for film_order in range(0, MAX_FILM_ORDER + 1):
        model = build_model(source, band, film_order, target_error=max_error)
        usable = model.stable and model.passive.passed
        if usable and model.max_error_band <= max_error:
            logger.info("%s: %s", source.description, model.summary())
            return model
        since_better += 1
        if usable and (best is None or model.max_error_band < (1 - STALL_GAIN) * best.max_error_band):
            best, since_better = model, 0
        if best is not None and since_better >= STALL_ORDERS:
            break  # more states no longer help: a feature no rational model of these orders follows
    if best is None:
        raise SettingError(f"{source.description}: no stable, passive rational model up to film order "
                           f"{MAX_FILM_ORDER} in {band[0]:g}–{band[1]:g} Hz")
    best = build_model(source, band, best.film_order)  # its errors refined (none was within the target)
    best.target_error = max_error
    logger.warning("%s: no order up to %d reaches %.3g %%; the best reaches %.3g %%", source.description,
                   film_order + states_without_film, 100 * max_error, 100 * best.max_error_band)
    return best


# --- the plain Oustaloup approximation (for comparison) ------------------------------------------------------------


@dataclass(frozen=True)
class _OustaloupPot(Node):
    """A spring-pot whose ``s^α`` is Oustaloup's rational approximation: composed by the same network algebra."""

    pot: SpringPot
    band_rad_s: tuple[float, float]
    n: int

    def parameters(self) -> list:
        return self.pot.parameters()

    def evaluate(self, s: np.ndarray, values: Any, gradient: bool, log_s: LogLaplace | None = None
                 ) -> tuple[np.ndarray, dict]:
        alpha = np.ravel(values[self.pot.order])[0]
        return values[self.pot.coefficient] * oustaloup_response(float(alpha), self.band_rad_s, self.n, s), {}

    def text(self) -> str:
        return self.pot.text()


def _with_oustaloup(node: Node, band_rad_s: tuple[float, float], n: int) -> Node:
    if isinstance(node, SpringPot):
        return _OustaloupPot(node, band_rad_s, n)
    if isinstance(node, (Parallel, Series)):
        return type(node)(tuple(_with_oustaloup(child, band_rad_s, n) for child in node.children))
    return node


def oustaloup_order(source: PlantSource, band_hz: tuple[float, float], max_error: float = DEFAULT_MAX_ERROR,
                    max_n: int = 40) -> tuple[int | None, float, float]:
    """The plant order a plain Oustaloup approximation needs to be within ``max_error`` of the film and the plant
    over the band: each spring-pot's ``s^α`` replaced by ``2N + 1`` real poles and zeros over the band widened
    10, 100 or 1000 times on each side (Oustaloup's filter is poor near its edges; the widening needing the fewest
    states wins), the network composed as it is. A pot of order α counts ``2N + 1 + ⌊α⌋`` states (``α`` when it is an integer). Returns
    (order or None when N up to ``max_n`` does not reach it, its error, the widening)."""
    model = parse_network(source.network)
    orders = [source.film_parameters[p.name] for p in model.parameters if p.unit == "1"]
    grid = _grid_hz(band_hz)
    s = 2j * np.pi * grid
    z = source.support_stiffness(s)
    h = accelerance_from_stiffness(s, z, source.mass_kg)
    values = {name: np.array([source.film_parameters[name]]) for name in model.parameter_names}
    states_without_film = 2 if static_stiffness(source, band_hz) != 0.0 else 1
    best: tuple[int | None, float, float] = (None, np.inf, OUSTALOUP_WIDENINGS[0])
    for widen in OUSTALOUP_WIDENINGS:
        band_rad_s = (2 * np.pi * band_hz[0] / widen, 2 * np.pi * band_hz[1] * widen)
        for n in range(0, max_n + 1):
            network = _with_oustaloup(model.network, band_rad_s, n)
            z_r = network.evaluate(s, values, False)[0]
            error = float(max(np.max(np.abs(z_r / z - 1)),
                              np.max(np.abs(accelerance_from_stiffness(s, z_r, source.mass_kg) / h - 1))))
            if error <= max_error:
                order = states_without_film + sum(
                    int(np.floor(alpha)) + (2 * n + 1 if alpha % 1 else 0) for alpha in orders)
                if best[0] is None or order < best[0]:
                    best = (order, error, widen)
                break
            if best[0] is None and error < best[1]:
                best = (None, error, widen)
    return best
