"""Rigid-body FRFs: a hammer and several accelerometers on a rigid mover turned into heave, roll and pitch.

For each hammer point p (the hits struck there) every accelerometer's averaged FRF ``H_kp`` (H1, through
:func:`gasfilm.analysis.spectra.compute_frf`) is taken; the accelerometers read ``H_p = G ü_p`` of the generalised
acceleration per newton ``ü_p = A(s) g_p`` (``G`` the accelerometers' rows, ``A`` the 3×3 generalised accelerance,
``g_p`` the point's load vector: :mod:`gasfilm.analysis.physics.rigid_body`), so

* ``ü_p = G⁺ H_p`` by least squares; with a fourth accelerometer the residual ``|H_p − G ü_p| / |H_p|`` is the
  rigidity check (a mover that bends, or a sensor at the wrong place, does not fit three rigid-body motions);
* with three or more points whose load vectors span heave, roll and pitch (a roving hammer), ``A = Ü B⁺``
  (``B = [g_p]``) is the full 3×3 FRF matrix; a rigid body's is symmetric (Maxwell–Betti reciprocity), and
  ``|A − Aᵀ| / |A|`` is its check. The dynamic stiffness ``D = s² Ā⁻¹`` (``Ā`` the symmetric part) gives each
  direction's film (``D_jj − M_jj s²``) and the couplings (``D_ab − M_ab s²``);
* with fewer points the film is taken as uncoupled: a direction j is identified from the points that load it
  (``s²/D_jj = Σ_p ü_jp g_jp / Σ_p g_jp²``), and a point on a direction's axis (``g_jp = 0``) checks the coupling:
  an uncoupled film does not move that direction, so its response beyond the noise says the film is coupled.

Everything is at ``s = σ + jω`` (an exponential window's decay rate σ is the same on every channel).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from gasfilm.analysis.physics import rigid_body
from gasfilm.analysis.physics.elements import laplace_variable
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import FrfResult, WindowSettings, compute_frf
from gasfilm.drivers.errors import SettingError

DIRECTIONS = rigid_body.DIRECTIONS
#: A direction counts as loaded by a hammer point when its lever, over the direction's radius of gyration, is at
#: least this (1 for heave); below AXIS_LEVER it is on the direction's axis and checks the coupling.
LOADED_LEVER = 0.1
AXIS_LEVER = 0.02
#: The load vectors of a roving test must span the three directions this well (smallest over largest singular
#: value of B, each row scaled by its radius of gyration) for the full 3×3 matrix.
MIN_SPAN = 0.05
#: A direction's response to points on its axis beyond the noise by this χ² per line says the film is coupled.
COUPLED_CHI2 = 4.0


@dataclass
class RigidFrf:
    """The FRFs of a rigid-body hammer test and what follows from them (see the module's description)."""

    freq_hz: np.ndarray
    decay_rate_1_s: float
    sample_rate_hz: float
    sensor_names: tuple[str, ...]
    point_names: tuple[str, ...]
    loads: np.ndarray  # (points, 3) load vectors g_p
    sensor_matrix: np.ndarray  # (accelerometers, 3)
    mass_matrix: np.ndarray  # (3, 3)
    channel_frfs: list[list[FrfResult]]  # [point][accelerometer]
    motion: np.ndarray  # (points, 3, lines): ü_p per newton
    motion_std: np.ndarray  # (points, 3, lines): its standard error from the hits' scatter
    rigidity_error: np.ndarray | None  # (points, lines) with ≥ 4 accelerometers
    matrix: np.ndarray | None = None  # (lines, 3, 3): A, with a roving hammer spanning the directions
    reciprocity_error: np.ndarray | None = None  # (lines,)
    hit_counts: tuple[int, ...] = ()
    notes: list[str] = field(default_factory=list)

    @property
    def s(self) -> np.ndarray:
        return laplace_variable(self.freq_hz, self.decay_rate_1_s)

    @property
    def full(self) -> bool:
        """Whether the full 3×3 matrix was measured (a roving hammer spanning heave, roll and pitch)."""
        return self.matrix is not None

    def radii_of_gyration_m(self) -> np.ndarray:
        """``√(M_jj/m)`` per direction (1 for heave): the lever that loads a tilt as much as heave."""
        diagonal = np.diag(self.mass_matrix)
        return np.array([1.0, np.sqrt(diagonal[1] / diagonal[0]), np.sqrt(diagonal[2] / diagonal[0])])

    def levers(self) -> np.ndarray:
        """(points, 3): each point's load on each direction over the direction's radius of gyration."""
        return np.abs(self.loads) / self.radii_of_gyration_m()

    def identified(self) -> tuple[str, ...]:
        """The directions the test identifies: all three with the full matrix, else those some point loads."""
        if self.full:
            return DIRECTIONS
        loaded = (self.levers() >= LOADED_LEVER).any(axis=0)
        return tuple(direction for direction, on in zip(DIRECTIONS, loaded) if on)

    def dynamic_stiffness(self) -> np.ndarray:
        """(lines, 3, 3): ``s² Ā⁻¹`` of the full matrix's symmetric part."""
        if self.matrix is None:
            raise SettingError("the hammer points do not span heave, roll and pitch: no 3×3 dynamic stiffness")
        symmetric = 0.5 * (self.matrix + np.swapaxes(self.matrix, -1, -2))
        symmetric[self.freq_hz == 0] = np.eye(3)  # (A vanishes at 0 Hz: that line's D is not measured)
        return np.linalg.inv(symmetric) * (self.s**2)[:, np.newaxis, np.newaxis]

    def direction_accelerance(self, direction: str) -> np.ndarray:
        """``s²/D_jj``: direction j's accelerance with the other two held still ((m/s²)/N or (rad/s²)/(N·m)) — a
        mass ``M_jj`` on the direction's film, what the models are fitted to."""
        index = DIRECTIONS.index(direction)
        if direction not in self.identified():
            raise SettingError(f"{direction}: no hammer point loads it (hit off its axis, or rove the hammer)")
        if self.full:
            with np.errstate(divide="ignore", invalid="ignore"):  # (the 0 Hz line)
                return self.s**2 / self.dynamic_stiffness()[:, index, index]
        loads = self.loads[:, index]
        used = self.levers()[:, index] >= LOADED_LEVER
        return (np.sum(self.motion[used, index] * loads[used, np.newaxis], axis=0) / np.sum(loads[used] ** 2))

    def direction_accelerance_std(self, direction: str) -> np.ndarray:
        """A standard error of :meth:`direction_accelerance` (first order, from the hits' scatter)."""
        index = DIRECTIONS.index(direction)
        used = self.levers()[:, index] >= LOADED_LEVER
        if self.full:
            used = np.ones(len(self.point_names), bool)
        loads = self.loads[used, index]
        scale = np.sqrt(np.sum(loads**2)) if np.any(loads) else 1.0
        return np.sqrt(np.sum(self.motion_std[used, index] ** 2, axis=0)) / max(scale, 1e-12)

    def axis_checks(self) -> list[tuple[str, str, float, tuple[str, ...]]]:
        """(point, direction, χ² per line, directions the point loads) for every point on a direction's axis: that
        direction's response there in units of its noise over the readable lines — about 1 for an uncoupled film,
        far more when the film couples it to a direction the point loads."""
        out = []
        lines = self.readable()
        levers = self.levers()
        for p, point in enumerate(self.point_names):
            loaded = tuple(d for d, lever in zip(DIRECTIONS, levers[p]) if lever >= LOADED_LEVER)
            for j, direction in enumerate(DIRECTIONS):
                if levers[p, j] < AXIS_LEVER:
                    with np.errstate(divide="ignore", invalid="ignore"):
                        ratio = np.abs(self.motion[p, j, lines]) ** 2 / self.motion_std[p, j, lines] ** 2
                    ratio = ratio[np.isfinite(ratio)]
                    out.append((point, direction, float(np.mean(ratio)) if ratio.size else float("nan"), loaded))
        return out

    def coupling_seen(self) -> bool | None:
        """Whether a point on an axis moved that direction beyond its noise (None: no point on an axis)."""
        checks = self.axis_checks()
        if not checks:
            return None
        return any(chi2 > COUPLED_CHI2 for _, _, chi2, _ in checks)

    def readable(self) -> np.ndarray:
        """Lines where every accelerometer's FRF at every point can be read (the hammer's band, coherence)."""
        from gasfilm.analysis.spectra import readable_lines

        mask = np.ones(len(self.freq_hz), bool)
        for frfs in self.channel_frfs:
            for frf in frfs:
                mask &= readable_lines(frf)
        return mask

    def summary_lines(self) -> list[str]:
        lines = [f"rigid-body FRFs: {len(self.sensor_names)} accelerometers ({', '.join(self.sensor_names)}), "
                 f"hammer points {', '.join(f'{p} ({n} hits)' for p, n in zip(self.point_names, self.hit_counts))}"]
        if self.full:
            band = self.readable()
            lines.append(f"  full 3×3 FRF matrix (roving hammer); reciprocity |A − Aᵀ|/|A|: median "
                         f"{100 * np.median(self.reciprocity_error[band]):.2g} %, max "
                         f"{100 * np.max(self.reciprocity_error[band]):.2g} % in the readable band")
        else:
            lines.append(f"  one column per point: identified {', '.join(self.identified()) or 'nothing'} with the "
                         f"film taken as uncoupled")
            for point, direction, chi2, loaded in self.axis_checks():
                pairs = ", ".join(f"{other}–{direction}" for other in loaded)
                verdict = (f"coupled ({pairs}): the directions do not move independently" if chi2 > COUPLED_CHI2
                           else f"within the noise: no {pairs} coupling")
                lines.append(f"  hammer at {point} (loads {', '.join(loaded)}), on the {direction} axis: {direction} "
                             f"response χ²/line {chi2:.3g} (1 = noise) — {verdict}")
            if self.coupling_seen():
                lines.append("  the film is coupled: the directions above, fitted as uncoupled, are biased; rove the "
                             "hammer over three points not in line for the full matrix")
        if self.rigidity_error is not None:
            band = self.readable()
            lines.append(f"  rigidity check ({len(self.sensor_names)} accelerometers for 3 motions): residual median "
                         f"{100 * np.median(self.rigidity_error[:, band]):.2g} %, max "
                         f"{100 * np.max(self.rigidity_error[:, band]):.2g} %")
        lines.extend(f"  note: {note}" for note in self.notes)
        return lines


def rigid_frf(spec: RigSpec, point_records: Mapping[str, np.ndarray], sample_rate_hz: float,
              window: WindowSettings, force_row: int, accelerometer_rows: Sequence[int]) -> RigidFrf:
    """The rigid-body FRFs of records per hammer point (``{point: (hits, channels, samples)}``, force in N and the
    accelerometers in m/s², rows ``accelerometer_rows`` in the order of the spec's accelerometers)."""
    body = spec.rigid_body
    if body is None:
        raise SettingError(f"{spec.source}: the rig spec has no [rigid_body]; its FRF is the one accelerometer's")
    if len(accelerometer_rows) != len(body.accelerometers):
        raise SettingError(f"{spec.source}: {len(body.accelerometers)} accelerometers in the rig spec, "
                           f"{len(accelerometer_rows)} recorded")
    if len(body.accelerometers) < 3:
        raise SettingError(f"{spec.source}: heave, roll and pitch need three accelerometers; the spec has "
                           f"{len(body.accelerometers)}")
    points = [point for point in body.point_names if point in point_records and len(point_records[point])]
    if not points:
        raise SettingError("rigid-body FRFs: no accepted hits at any hammer point")
    sensors = body.sensor_matrix()
    pseudo_inverse = np.linalg.pinv(sensors)
    channel_frfs, motions, stds, rigidity, counts = [], [], [], [], []
    for point in points:
        records = np.asarray(point_records[point], dtype=float)
        frfs = [compute_frf(records, sample_rate_hz, window, force_row, row) for row in accelerometer_rows]
        h = np.array([frf.h1 for frf in frfs])
        sigma = np.array([frf.h1_std_scatter for frf in frfs])
        motion = pseudo_inverse @ h
        channel_frfs.append(frfs)
        motions.append(motion)
        stds.append(np.sqrt((pseudo_inverse**2) @ (sigma**2)))
        counts.append(len(records))
        if len(body.accelerometers) > 3:
            with np.errstate(divide="ignore", invalid="ignore"):
                rigidity.append(np.linalg.norm(h - sensors @ motion, axis=0) / np.linalg.norm(h, axis=0))
    first = channel_frfs[0][0]
    for frfs in channel_frfs:
        if frfs[0].n_samples != first.n_samples or frfs[0].decay_rate_1_s != first.decay_rate_1_s:
            raise SettingError("rigid-body FRFs: the hammer points' records differ in length or window")
    loads = np.array([body.load_vector(point) for point in points])
    result = RigidFrf(
        freq_hz=first.freq_hz, decay_rate_1_s=first.decay_rate_1_s, sample_rate_hz=sample_rate_hz,
        sensor_names=body.sensor_names, point_names=tuple(points), loads=loads, sensor_matrix=sensors,
        mass_matrix=rigid_body.mass_matrix(spec), channel_frfs=channel_frfs, motion=np.array(motions),
        motion_std=np.array(stds), rigidity_error=np.array(rigidity) if rigidity else None, hit_counts=tuple(counts))
    scaled = loads / result.radii_of_gyration_m()
    singular = np.linalg.svd(scaled, compute_uv=False) if len(points) >= 3 else np.zeros(1)
    if len(points) >= 3 and singular[-1] >= MIN_SPAN * singular[0]:
        moved = np.moveaxis(result.motion, -1, 0)  # (lines, points, 3)
        matrix = np.swapaxes(moved, -1, -2) @ np.linalg.pinv(loads).T  # A = Ü B⁺ with Ü (3, points)
        result.matrix = matrix
        with np.errstate(divide="ignore", invalid="ignore"):
            result.reciprocity_error = (np.linalg.norm(matrix - np.swapaxes(matrix, -1, -2), axis=(-2, -1))
                                        / np.linalg.norm(matrix, axis=(-2, -1)))
    elif len(points) >= 3:
        result.notes.append(f"the {len(points)} hammer points do not span heave, roll and pitch (points on one line):"
                            f" no full 3×3 matrix")
    return result
