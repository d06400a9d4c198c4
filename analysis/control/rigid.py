"""The rigid mover as a MIMO plant for control design: force and moments at the centre of mass → heave, roll and
pitch accelerations, from a rigid-body identification (``gasfilm rigid``), as a rational state-space model with its
stated error.

Each direction's identified film (its best model by BIC, or the one named) is approximated as a rational film
``Z_r,j(s) = Z_j(0) + s·Y_j(s)`` exactly as a one-direction film is (:func:`~.rational.approximate`); the couplings
found (``K_ab + C_ab·s``, :mod:`gasfilm.analysis.identification.rigid`) join them in the film matrix
``Z(s) = diag Z_j(s) + K_c + C_c·s``. The plant, with states ``[q (3), q̇ (3), ξ_j …]``::

    M q̈ = Q − (diag Z_j(0) + K_c) q − (diag e_j + C_c) q̇ − Σ_j u_j c_j ξ_j,   ξ_j' = A_j ξ_j + B_j q̇_j

(``Y_j(s) = e_j + c_j (sI − A_j)⁻¹ B_j``), outputs ``q̈``: ``D = M⁻¹``. Its stated errors: the rational plant
against the identified (fractional) plant ``s²(Z(s) + M s²)⁻¹`` over the band (largest relative matrix error,
spectral norm), and the identified plant against the measured 3×3 FRF matrix where the test measured one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io

from gasfilm.analysis.control.rational import DEFAULT_MAX_ERROR, PlantSource, RationalModel, _grid_hz, approximate
from gasfilm.analysis.identification.result import FitResult
from gasfilm.analysis.identification.rigid import RigidIdentification
from gasfilm.analysis.physics.rigid_body import DIRECTIONS
from gasfilm.drivers.errors import SettingError

FORMAT = "gasfilm rigid-body plant 1"
INPUTS = ("F_z: force at the centre of mass along z (N)", "M_x: moment about x, roll (N·m)",
          "M_y: moment about y, pitch (N·m)")
OUTPUTS = ("heave acceleration (m/s²)", "roll acceleration (rad/s²)", "pitch acceleration (rad/s²)")


@dataclass
class RigidPlantModel:
    """The rational MIMO plant and what it was made from."""

    directions: dict[str, RationalModel]
    fits: dict[str, FitResult]
    coupling_stiffness: np.ndarray  # (3, 3), zero diagonal
    coupling_damping: np.ndarray
    mass_matrix: np.ndarray
    band_hz: tuple[float, float]
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    max_error_band: float  # rational against identified plant (matrix relative error, spectral norm)
    stable: bool
    measured_error: tuple[float, float] | None = None  # identified plant against the measured matrix: median, max
    rational_measured_error: tuple[float, float] | None = None
    couplings_used: list[str] = field(default_factory=list)

    @property
    def order(self) -> int:
        return int(self.a.shape[0])

    def film_matrix(self, s: np.ndarray) -> np.ndarray:
        """The identified film matrix ``diag Z_j(s) + K_c + C_c s`` (lines, 3, 3)."""
        s = np.asarray(s, dtype=complex)
        z = np.zeros(s.shape + (3, 3), dtype=complex)
        for index, direction in enumerate(DIRECTIONS):
            fit = self.fits[direction]
            z[..., index, index] = fit.model().stiffness(s, fit.params)
        return z + self.coupling_stiffness + self.coupling_damping * s[..., np.newaxis, np.newaxis]

    def identified_accelerance(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=complex)
        square = (s**2)[..., np.newaxis, np.newaxis]
        return np.linalg.inv(self.film_matrix(s) + self.mass_matrix * square) * square

    def accelerance(self, s: np.ndarray) -> np.ndarray:
        """The state-space plant's 3×3 accelerance at ``s``."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        eye = np.eye(self.order)
        solved = np.linalg.solve(s[:, None, None] * eye - self.a, np.broadcast_to(self.b, (s.size, *self.b.shape)))
        return self.c @ solved + self.d

    def summary_lines(self) -> list[str]:
        lines = [f"MIMO plant F_z, M_x, M_y → heave, roll, pitch accelerations: order {self.order}, "
                 f"{'stable' if self.stable else 'UNSTABLE'}; max error {100 * self.max_error_band:.3g} % in "
                 f"{self.band_hz[0]:g}–{self.band_hz[1]:g} Hz against the identified plant"]
        for direction, model in self.directions.items():
            lines.append(f"  {direction}: {self.fits[direction].model_name} film, {model.summary()}")
        lines.append("  couplings: " + (", ".join(self.couplings_used) or "none found (uncoupled plant)"))
        if self.measured_error is not None:
            lines.append(f"  identified plant against the measured 3×3 FRF matrix: median "
                         f"{100 * self.measured_error[0]:.3g} %, max {100 * self.measured_error[1]:.3g} % "
                         f"(readable band); rational plant: median {100 * self.rational_measured_error[0]:.3g} %, "
                         f"max {100 * self.rational_measured_error[1]:.3g} %")
        return lines

    def to_dict(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "inputs": list(INPUTS), "outputs": list(OUTPUTS), "time": "s",
            "band_hz": list(self.band_hz), "order": self.order, "stable": self.stable,
            "max_error_band": self.max_error_band,
            "error_definition": "max over the band of ‖G_rational(jω) − G_identified(jω)‖₂ / ‖G_identified(jω)‖₂ "
                                "(3×3 accelerance matrices, spectral norm)",
            "measured_error_median_max": None if self.measured_error is None else list(self.measured_error),
            "rational_measured_error_median_max": (None if self.rational_measured_error is None
                                                   else list(self.rational_measured_error)),
            "state_space": {"A": self.a.tolist(), "B": self.b.tolist(), "C": self.c.tolist(), "D": self.d.tolist(),
                            "states": state_names(self)},
            "mass_matrix": self.mass_matrix.tolist(),
            "coupling_stiffness": self.coupling_stiffness.tolist(),
            "coupling_damping": self.coupling_damping.tolist(),
            "couplings_used": self.couplings_used,
            "directions": {direction: {"fit": self.fits[direction].to_dict(), "order": model.order,
                                       "film_order": model.film_order, "max_error_band": model.max_error_band,
                                       "static_stiffness": model.static_stiffness_n_per_m}
                           for direction, model in self.directions.items()},
        }


def state_names(model: RigidPlantModel) -> list[str]:
    names = ["z (m)", "θx (rad)", "θy (rad)", "ż (m/s)", "θx' (rad/s)", "θy' (rad/s)"]
    for direction, rational in model.directions.items():
        names += [f"{direction} film state {i + 1}" for i in range(rational.film_order)]
    return names


def _choose_fit(identification: RigidIdentification, direction: str, model: str | None) -> FitResult:
    fits = identification.directions.get(direction)
    if fits is None:
        raise SettingError(f"{direction}: not identified (the test loaded no hammer point on it); a MIMO plant "
                           f"needs heave, roll and pitch")
    if model is not None:
        fit = fits.fit(model)
        if fit is None:
            raise SettingError(f"--model {model}: no {direction} fit of it (fitted: "
                               f"{', '.join(f.model_name for f in fits.fits)}; run gasfilm rigid --models {model})")
        return fit
    best = fits.best() if fits.table else None
    return best or min(fits.fits, key=lambda fit: fit.rms)


def rigid_plant(identification: RigidIdentification, mass_matrix: np.ndarray, model: str | None = None,
                band_hz: tuple[float, float] | None = None, max_error: float = DEFAULT_MAX_ERROR,
                measured: Any = None) -> RigidPlantModel:
    """The MIMO plant of an identification (``measured``: its :class:`~gasfilm.analysis.rigid_frf.RigidFrf`, for
    the error against the measured matrix)."""
    fits = {direction: _choose_fit(identification, direction, model) for direction in DIRECTIONS}
    band = band_hz or (identification.band_hz[0] / 10, identification.band_hz[1] * 10)
    directions = {direction: approximate(PlantSource.from_fit(fit, direction), band, max_error=max_error)
                  for direction, fit in fits.items()}
    k_c, c_c = np.zeros((3, 3)), np.zeros((3, 3))
    used = []
    for term in identification.couplings():
        if term.found:
            a, b = (DIRECTIONS.index(name) for name in term.directions)
            k_c[a, b] = k_c[b, a] = term.stiffness
            c_c[a, b] = c_c[b, a] = term.damping
            used.append(f"{term.directions[0]}–{term.directions[1]}")
    a, b, c, d = _state_space(directions, k_c, c_c, mass_matrix)
    poles = np.linalg.eigvals(a)
    plant = RigidPlantModel(directions, fits, k_c, c_c, mass_matrix, band, a, b, c, d, 0.0,
                            bool(np.all(poles.real < 0)), couplings_used=used)
    grid = _grid_hz(band)
    s = 2j * np.pi * grid
    plant.max_error_band = float(np.max(_relative(plant.accelerance(s), plant.identified_accelerance(s))))
    if measured is not None and measured.full:
        lines = measured.readable() & (measured.freq_hz >= identification.band_hz[0]) & (
            measured.freq_hz <= identification.band_hz[1])
        s_measured = measured.s[lines]
        reference = measured.matrix[lines]
        identified = _relative(plant.identified_accelerance(s_measured), reference)
        rational = _relative(plant.accelerance(s_measured), reference)
        plant.measured_error = (float(np.median(identified)), float(np.max(identified)))
        plant.rational_measured_error = (float(np.median(rational)), float(np.max(rational)))
    return plant


def _relative(matrices: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.linalg.norm(matrices - reference, ord=2, axis=(-2, -1)) / np.linalg.norm(reference, ord=2,
                                                                                         axis=(-2, -1))


def _state_space(directions: dict[str, RationalModel], k_c: np.ndarray, c_c: np.ndarray, mass: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    blocks = [model.impedance.state_space() for model in directions.values()]
    sizes = [block[0].shape[0] for block in blocks]
    n = 6 + sum(sizes)
    stiffness = np.diag([model.static_stiffness_n_per_m for model in directions.values()]) + k_c
    damping = np.diag([block[3] for block in blocks]) + c_c
    force_of_states = np.zeros((3, n))  # −(the film's force) in terms of the states
    force_of_states[:, :3] = -stiffness
    force_of_states[:, 3:6] = -damping
    a = np.zeros((n, n))
    a[:3, 3:6] = np.eye(3)
    offset = 6
    for index, ((a_y, b_y, c_y, _), size) in enumerate(zip(blocks, sizes)):
        force_of_states[index, offset:offset + size] = -c_y
        a[offset:offset + size, offset:offset + size] = a_y
        a[offset:offset + size, 3 + index] = b_y
        offset += size
    inverse = np.linalg.inv(mass)
    a[3:6] = inverse @ force_of_states
    b = np.zeros((n, 3))
    b[3:6] = inverse
    return a, b, inverse @ force_of_states, inverse


def write_rigid_plant(model: RigidPlantModel, path: str | Path) -> Path:
    """The MIMO plant as .json, .mat (A, B, C, D for MATLAB/Octave ``ss``) or .npz."""
    path = Path(path)
    data = model.to_dict()
    suffix = path.suffix.lower()
    if suffix == ".json":
        path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        return path
    arrays = {"A": model.a, "B": model.b, "C": model.c, "D": model.d, "M": model.mass_matrix,
              "band_hz": np.asarray(model.band_hz), "max_error_band": np.array(model.max_error_band)}
    metadata = {key: value for key, value in data.items() if key != "state_space"}
    if suffix == ".mat":
        scipy.io.savemat(path, dict(arrays, metadata=json.dumps(metadata)), do_compression=True)
    elif suffix == ".npz":
        with path.open("wb") as file:
            np.savez(file, **arrays, metadata=np.array(json.dumps(metadata)))
    else:
        raise SettingError(f"--out {path}: name a .json, .mat or .npz file")
    return path
