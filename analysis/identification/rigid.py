"""Identification of a rigid mover's films: the nine models per direction, the 3×3 stiffness and damping, coupling.

From :class:`gasfilm.analysis.rigid_frf.RigidFrf`:

* per direction (heave, roll, pitch) the models are fitted with :func:`~.fitter.fit_model` to the direction's
  accelerance with the other two held still, ``s²/D_jj`` — a mass ``M_jj`` (the mover's mass, or its moment of
  inertia about the centre of mass) on the direction's film ``D_jj − M_jj s²``; Table 2 per direction
  (:func:`~.comparison.compare_models`). A tilt direction's values are in N·m/rad, N·m·s/rad, kg·m².
* with the full 3×3 matrix (a roving hammer), the film matrix ``Z(s) = D(s) − M s²`` is fitted term by term with a
  stiffness and a damping, ``Z_ab ≈ K_ab + C_ab·s``, by linear least squares over the band, with standard errors
  from the residual: the coupling terms with their uncertainties. A coupling is *found* when it stands above 3
  standard errors and above 1 % of ``√(K_aa K_bb)`` (a normalised coupling); the elastic centre's offset from the
  centre of mass follows from the heave–tilt terms, ``Δy = K_zθx/K_zz``, ``Δx = −K_zθy/K_zz``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from gasfilm.analysis.identification.comparison import ComparisonRow, best_by_bic, compare_models, format_table2
from gasfilm.analysis.identification.fitter import DEFAULT_FIT_BAND_HZ, fit_model
from gasfilm.analysis.identification.result import FitResult
from gasfilm.analysis.physics.rigid_body import (ACCELERATION_UNITS, COUPLING_UNITS, COUPLINGS, DAMPING_UNITS,
                                                 DIRECTIONS, INERTIA_UNITS, LOAD_UNITS, STIFFNESS_UNITS)
from gasfilm.analysis.rigid_frf import RigidFrf
from gasfilm.drivers.errors import SettingError

#: A coupling counts as found above this many standard errors and this fraction of √(K_aa K_bb).
COUPLING_SIGMAS = 3.0
COUPLING_FRACTION = 0.01
DAMPING_COUPLING_UNITS = {("heave", "roll"): "N·s/rad", ("heave", "pitch"): "N·s/rad",
                          ("roll", "pitch"): "N·m·s/rad"}


def direction_unit(unit: str, direction: str) -> str:
    """A film parameter's unit for a direction: N/m → N·m/rad (and N·s/m, N·s^α/m alike) for roll and pitch."""
    if direction == "heave" or not unit.endswith("/m"):
        return unit
    return unit[: -len("/m")].replace("N", "N·m", 1) + "/rad"


@dataclass(frozen=True)
class MatrixTerm:
    """One term of the fitted 3×3 stiffness and damping at the centre of mass, ``Z_ab ≈ K_ab + C_ab·s``."""

    directions: tuple[str, str]
    stiffness: float
    stiffness_std: float
    damping: float
    damping_std: float
    #: ``K_ab / √(K_aa K_bb)`` (off-diagonal terms; 1 on the diagonal)
    normalised: float = 1.0

    @property
    def diagonal(self) -> bool:
        return self.directions[0] == self.directions[1]

    @property
    def units(self) -> tuple[str, str]:
        if self.diagonal:
            return STIFFNESS_UNITS[self.directions[0]], DAMPING_UNITS[self.directions[0]]
        return COUPLING_UNITS[self.directions], DAMPING_COUPLING_UNITS[self.directions]

    @property
    def found(self) -> bool:
        """An off-diagonal term beyond its noise and beyond 1 % of the directions' own stiffness."""
        return (abs(self.stiffness) > COUPLING_SIGMAS * self.stiffness_std
                and abs(self.normalised) > COUPLING_FRACTION)

    def line(self) -> str:
        k_unit, c_unit = self.units
        name = self.directions[0] if self.diagonal else f"{self.directions[0]}–{self.directions[1]}"
        text = (f"{name:<12} K = {self.stiffness:12.6g} ± {self.stiffness_std:<7.2g} {k_unit:<8}  "
                f"C = {self.damping:10.5g} ± {self.damping_std:.2g} {c_unit}")
        if not self.diagonal:
            text += (f"  (K/√(K_aa·K_bb) = {100 * self.normalised:+.2f} %: "
                     f"{'coupled' if self.found else 'no coupling beyond the noise'})")
        return text

    def to_dict(self) -> dict[str, Any]:
        k_unit, c_unit = self.units
        return {"directions": list(self.directions), "stiffness": self.stiffness, "stiffness_std": self.stiffness_std,
                "damping": self.damping, "damping_std": self.damping_std, "normalised": self.normalised,
                "found": self.found, "stiffness_unit": k_unit, "damping_unit": c_unit}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "MatrixTerm":
        return cls(tuple(data["directions"]), float(data["stiffness"]), float(data["stiffness_std"]),
                   float(data["damping"]), float(data["damping_std"]), float(data.get("normalised", 1.0)))


@dataclass
class DirectionFits:
    """The models fitted to one direction, with their Table 2 on the same data."""

    direction: str
    inertia: float  # kg or kg·m²
    fits: list[FitResult]
    table: list[ComparisonRow]

    def best(self) -> FitResult | None:
        row = best_by_bic(self.table)
        return None if row is None else next(fit for fit in self.fits if fit.model_name == row.model_name)

    def fit(self, model: str) -> FitResult | None:
        return next((fit for fit in self.fits if fit.model_name == model), None)


@dataclass
class RigidIdentification:
    """Per-direction fits and Table 2, the 3×3 stiffness and damping with the couplings, and what the FRFs said."""

    band_hz: tuple[float, float]
    directions: dict[str, DirectionFits]
    matrix_terms: list[MatrixTerm] = field(default_factory=list)
    elastic_centre_offset_m: tuple[float, float, float, float] | None = None  # Δx, σx, Δy, σy
    coupling_seen: bool | None = None  # the one-column test's verdict (points on an axis)
    frf_lines: list[str] = field(default_factory=list)

    def term(self, a: str, b: str) -> MatrixTerm | None:
        return next((term for term in self.matrix_terms if set(term.directions) == {a, b} and
                     (a != b or term.diagonal)), None)

    def couplings(self) -> list[MatrixTerm]:
        return [term for term in self.matrix_terms if not term.diagonal]

    def coupling_found(self) -> bool | None:
        """Whether the film couples the directions: a coupling term found (full matrix), a point on an axis that
        moved its direction (one column per point), or None when the test cannot tell."""
        if self.matrix_terms:
            return any(term.found for term in self.couplings())
        return self.coupling_seen

    def summary_lines(self, units: str = "SI") -> list[str]:
        lines = list(self.frf_lines)
        for direction, fits in self.directions.items():
            lines.append(f"{direction} ({fits.inertia:.6g} {INERTIA_UNITS[direction]} on its film, the other "
                         f"directions held still), {self.band_hz[0]:g}–{self.band_hz[1]:g} Hz:")
            if fits.table:  # (recomputed from the FRFs; a stored identification read alone has none)
                table = format_table2(fits.table, units="SI" if direction != "heave" else units)
                if direction != "heave":
                    table = table.replace("(m/s²)/N", f"({ACCELERATION_UNITS[direction]})/(N·m)")
                lines.extend("  " + line for line in table.splitlines())
            for fit in fits.fits:
                units_of = {p.name: p.unit for p in fit.model().parameters}
                values = ", ".join(
                    f"{name} = {value:.6g}" + (f" ± {fit.std_errors[name]:.2g}" if name in fit.std_errors else
                                               " (at bound)")
                    + f" {direction_unit(units_of.get(name, ''), direction)}".rstrip()
                    for name, value in fit.params.items())
                lines.append(f"  {fit.model_name}: {values}")
        if self.matrix_terms:
            lines.append(f"stiffness and damping at the centre of mass, Z_ab ≈ K_ab + C_ab·s "
                         f"({self.band_hz[0]:g}–{self.band_hz[1]:g} Hz):")
            lines.extend("  " + term.line() for term in self.matrix_terms)
        if self.elastic_centre_offset_m is not None:
            dx, sx, dy, sy = self.elastic_centre_offset_m
            lines.append(f"elastic centre − centre of mass: Δx = {1e3 * dx:+.3f} ± {1e3 * sx:.2g} mm, "
                         f"Δy = {1e3 * dy:+.3f} ± {1e3 * sy:.2g} mm")
        found = self.coupling_found()
        lines.append("coupling: " + ("found — heave, roll and pitch do not move independently" if found else
                                     "none beyond the noise" if found is False else
                                     "not measured (rove the hammer over three points not in line)"))
        return lines

    def to_dict(self) -> dict[str, Any]:
        return {
            "band_hz": list(self.band_hz),
            "directions": {direction: {"inertia": fits.inertia, "fits": [fit.to_dict() for fit in fits.fits]}
                           for direction, fits in self.directions.items()},
            "matrix_terms": [term.to_dict() for term in self.matrix_terms],
            "elastic_centre_offset_m": None if self.elastic_centre_offset_m is None else list(
                self.elastic_centre_offset_m),
            "coupling_seen": self.coupling_seen,
            "coupling_found": self.coupling_found(),
            "frf_lines": list(self.frf_lines),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], rigid: RigidFrf | None = None) -> "RigidIdentification":
        """Back from :meth:`to_dict`; Table 2 is recomputed when the FRFs (``rigid``) are given, else empty."""
        band = tuple(float(v) for v in data["band_hz"])
        directions = {}
        for direction, entry in data["directions"].items():
            fits = [FitResult.from_dict(fit) for fit in entry["fits"]]
            table: list[ComparisonRow] = []
            if rigid is not None and fits:
                lines = _band_lines(rigid, band)
                table = compare_models(fits, rigid.freq_hz[lines], rigid.direction_accelerance(direction)[lines])
            directions[direction] = DirectionFits(direction, float(entry["inertia"]), fits, table)
        offset = data.get("elastic_centre_offset_m")
        return cls(band, directions, [MatrixTerm.from_dict(term) for term in data.get("matrix_terms", [])],
                   None if offset is None else tuple(float(v) for v in offset), data.get("coupling_seen"),
                   list(data.get("frf_lines", [])))


def _band_lines(rigid: RigidFrf, band_hz: tuple[float, float]) -> np.ndarray:
    lines = rigid.readable() & (rigid.freq_hz >= band_hz[0]) & (rigid.freq_hz <= band_hz[1])
    return lines


def default_band_hz(rigid: RigidFrf) -> tuple[float, float]:
    return DEFAULT_FIT_BAND_HZ[0], min(DEFAULT_FIT_BAND_HZ[1], 0.45 * rigid.sample_rate_hz)


def fit_matrix_terms(rigid: RigidFrf, band_hz: tuple[float, float]) -> list[MatrixTerm]:
    """``Z = D − M s²`` term by term as ``K + C·s`` with standard errors (the full matrix only)."""
    lines = _band_lines(rigid, band_hz)
    if lines.sum() < 4:
        raise SettingError(f"band {band_hz[0]:g}–{band_hz[1]:g} Hz: too few readable lines for the 3×3 matrix")
    s = rigid.s[lines]
    film = rigid.dynamic_stiffness()[lines] - rigid.mass_matrix * (s**2)[:, np.newaxis, np.newaxis]
    design = np.block([[np.ones((s.size, 1)), s.real[:, np.newaxis]], [np.zeros((s.size, 1)), s.imag[:, np.newaxis]]])
    inverse = np.linalg.inv(design.T @ design)
    fitted: dict[tuple[int, int], tuple[float, float, float, float]] = {}
    for a in range(3):
        for b in range(a, 3):
            z = film[:, a, b]
            data = np.concatenate([z.real, z.imag])
            coefficients = inverse @ design.T @ data
            residual = data - design @ coefficients
            variance = float(residual @ residual) / max(1, data.size - 2)
            std = np.sqrt(np.diag(inverse) * variance)
            fitted[(a, b)] = (float(coefficients[0]), float(std[0]), float(coefficients[1]), float(std[1]))
    terms = []
    for a in range(3):
        terms.append(MatrixTerm((DIRECTIONS[a], DIRECTIONS[a]), *fitted[(a, a)]))
    for a_name, b_name in COUPLINGS:
        a, b = DIRECTIONS.index(a_name), DIRECTIONS.index(b_name)
        scale = math.sqrt(abs(fitted[(a, a)][0] * fitted[(b, b)][0])) or 1.0
        terms.append(MatrixTerm((a_name, b_name), *fitted[(a, b)], normalised=fitted[(a, b)][0] / scale))
    return terms


def elastic_centre_offset(terms: Sequence[MatrixTerm]) -> tuple[float, float, float, float]:
    """(Δx, σx, Δy, σy) of the elastic centre from the centre of mass: ``Δy = K_zθx/K_zz``, ``Δx = −K_zθy/K_zz``,
    standard errors to first order."""
    by_name = {term.directions: term for term in terms}
    heave = by_name[("heave", "heave")]

    def ratio(term: MatrixTerm) -> tuple[float, float]:
        value = term.stiffness / heave.stiffness
        return value, math.hypot(term.stiffness_std, value * heave.stiffness_std) / abs(heave.stiffness)

    dy, sy = ratio(by_name[("heave", "roll")])
    dx, sx = ratio(by_name[("heave", "pitch")])
    return -dx, sx, dy, sy


def identify_rigid(
    rigid: RigidFrf,
    models: Sequence[str] = ("SD",),
    band_hz: tuple[float, float] | None = None,
    method: str = "default",
    fit_mass: bool = False,
    seed: int = 0,
    progress: Callable[[float], None] | None = None,
) -> RigidIdentification:
    """Fit ``models`` to every identified direction, Table 2 per direction, and (full matrix) the 3×3 stiffness and
    damping with the couplings; ``band_hz`` defaults to 20–1000 Hz capped at 0.45·fs."""
    band = band_hz or default_band_hz(rigid)
    lines = _band_lines(rigid, band)
    if lines.sum() < 10:
        raise SettingError(f"band {band[0]:g}–{band[1]:g} Hz: {lines.sum()} readable lines; at least 10 are needed")
    directions = {}
    identified = rigid.identified()
    total = max(1, len(identified) * len(models))
    done = 0
    for direction in identified:
        index = DIRECTIONS.index(direction)
        h = rigid.direction_accelerance(direction)[lines]
        inertia = float(rigid.mass_matrix[index, index])
        fits = []
        for model in models:
            fits.append(fit_model(model, rigid.freq_hz[lines], h, inertia, method=method,
                                  decay_rate_1_s=rigid.decay_rate_1_s, fit_mass=fit_mass, seed=seed))
            done += 1
            if progress is not None:
                progress(done / total)
        directions[direction] = DirectionFits(direction, inertia, fits,
                                              compare_models(fits, rigid.freq_hz[lines], h))
    result = RigidIdentification(band, directions, frf_lines=rigid.summary_lines())
    if rigid.full:
        result.matrix_terms = fit_matrix_terms(rigid, band)
        result.elastic_centre_offset_m = elastic_centre_offset(result.matrix_terms)
    else:
        result.coupling_seen = rigid.coupling_seen()
    return result
