"""The mover as a rigid body: heave, roll and pitch on its films, seen by several accelerometers (``[rigid_body]``).

Coordinates (``docs/rig-spec.md``): x and y span the mover's plane, z is the hammer's axis (the force and a ``+z``
accelerometer are positive in the direction the hammer strikes). The generalised coordinates at the centre of mass
(x_c, y_c) are ``q = [z, θx, θy]``: heave (m), roll about the x axis and pitch about the y axis (rad). A point (x, y)
of the mover moves along z by ``w = gᵀq`` with ``g = [1, y − y_c, −(x − x_c)]``, so a force F at that point is the
generalised force ``Q = g·F`` (N, N·m, N·m), and an accelerometer there reads ``d·gᵀq̈`` (d = ±1, its direction).

The film is either pads at positions, each with its own film ``Z_i(s)``, whose 3×3 dynamic stiffness is
``Z(s) = Σ_i Z_i(s) g_i g_iᵀ``; or one film per direction about the elastic centre (x_e, y_e),
``Z(s) = Tᵀ diag(Z_heave, Z_roll, Z_pitch) T`` with ``T = [[1, y_e − y_c, −(x_e − x_c)], [0, 1, 0], [0, 0, 1]]``.
The mover obeys ``D(s)·q = Q`` with ``D = Z(s) + M s²``, ``M = [[m, 0, 0], [0, I_xx, −I_xy], [0, −I_xy, I_yy]]``
(``I_xy = ∫ x y dm`` about the centre of mass), so its generalised accelerance is ``A(s) = s² D(s)⁻¹`` and the
accelerometers see ``H = d·G A g_p`` for a hammer at point p.

Effects of a rigid spec act as on a one-direction spec: drift and step changes scale every film; mechanical effects
(added mass, an extra mode, pneumatic lag, ...) load the heave direction at the centre of mass; channel effects,
cross-talk, structure modes and interference act on every accelerometer alike. A cubic spring and film laws are not
supported on a rigid body (the spec is refused).

In a spec with pads, the pads' parameters are the spec's film parameters under the names ``<name>_pad<i>`` (i from
1), and the spec's film is their parallel network — the heave film at the centre of mass: a tool that sees one
direction (one accelerometer, a fit, a diagnosis's recalibration) sees and changes exactly the pads' values.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from gasfilm.analysis.physics.elements import FilmModel, get_model
from gasfilm.drivers.errors import SettingError

#: A :class:`gasfilm.analysis.physics.spec.RigSpec` (whose ``rigid_body`` this module defines: spec.py imports it).
RigSpec = Any

#: The rigid-body directions in the order of q, with the units of their stiffness, inertia, motion and load.
DIRECTIONS = ("heave", "roll", "pitch")
DIRECTION_AXES = {"heave": "z", "roll": "θx", "pitch": "θy"}
STIFFNESS_UNITS = {"heave": "N/m", "roll": "N·m/rad", "pitch": "N·m/rad"}
DAMPING_UNITS = {"heave": "N·s/m", "roll": "N·m·s/rad", "pitch": "N·m·s/rad"}
INERTIA_UNITS = {"heave": "kg", "roll": "kg·m²", "pitch": "kg·m²"}
ACCELERATION_UNITS = {"heave": "m/s²", "roll": "rad/s²", "pitch": "rad/s²"}
LOAD_UNITS = {"heave": "N", "roll": "N·m", "pitch": "N·m"}
#: The coupling terms of the 3×3 matrices (upper triangle), by name.
COUPLINGS = (("heave", "roll"), ("heave", "pitch"), ("roll", "pitch"))
COUPLING_UNITS = {("heave", "roll"): "N/rad", ("heave", "pitch"): "N/rad", ("roll", "pitch"): "N·m/rad"}

MAX_ACCELEROMETERS = 8
MAX_HAMMER_POINTS = 16
MAX_PADS = 8
MAX_POSITION_M = 10.0
INERTIA_RANGE_KG_M2 = (1e-6, 1e4)
DIRECTION_SIGNS = {"+z": 1.0, "-z": -1.0}
_PAD_SUFFIX = "_pad"
_NAME = re.compile(r"\b([A-Za-z_][A-Za-z_0-9]*)\b(?!\s*\()")


@dataclass(frozen=True)
class Accelerometer:
    """An accelerometer on the mover: where (m), which way along z (+1 or −1), and optionally its own true
    sensitivity (mV/(m/s²)), noise density ((m/s²)/√Hz) and serial number (else ``[sensors.acceleration]``'s)."""

    name: str
    position_m: tuple[float, float]
    direction: float = 1.0
    sensitivity_mv_per_m_s2: float | None = None
    noise_m_s2_per_sqrt_hz: float | None = None
    serial: str = ""


@dataclass(frozen=True)
class HammerPoint:
    """A point the hammer strikes (along z), in m."""

    name: str
    position_m: tuple[float, float]


@dataclass(frozen=True)
class Pad:
    """An air pad at ``position_m`` (m) with its own film ``model`` (its parameters are the spec's film parameters
    ``<name>_pad<index>``)."""

    name: str
    position_m: tuple[float, float]
    model: str


@dataclass(frozen=True)
class DirectionFilm:
    """A film of one tilt direction about the elastic centre: model and parameters (N·m/rad, N·m·s/rad, ...)."""

    model: str
    parameters: Mapping[str, float]

    @property
    def film(self) -> FilmModel:
        return get_model(self.model)


@dataclass(frozen=True)
class RigidBody:
    """The mover as a rigid body: inertia about the centre of mass, sensors, hammer points and the film's layout
    (pads, or roll and pitch films about an elastic centre with the spec's ``[film]`` as the heave film)."""

    inertia_kg_m2: tuple[float, float]
    accelerometers: tuple[Accelerometer, ...]
    hammer_points: tuple[HammerPoint, ...]
    centre_of_mass_m: tuple[float, float] = (0.0, 0.0)
    product_of_inertia_kg_m2: float = 0.0
    #: The point the hammer strikes now (the simulator's, and the one a single FRF of the spec is for).
    hammer_point: str = ""
    pads: tuple[Pad, ...] = ()
    elastic_centre_m: tuple[float, float] | None = None
    roll: DirectionFilm | None = None
    pitch: DirectionFilm | None = None

    def __post_init__(self) -> None:
        if not self.hammer_point and self.hammer_points:
            object.__setattr__(self, "hammer_point", self.hammer_points[0].name)

    @property
    def has_pads(self) -> bool:
        return bool(self.pads)

    @property
    def sensor_names(self) -> tuple[str, ...]:
        return tuple(sensor.name for sensor in self.accelerometers)

    @property
    def point_names(self) -> tuple[str, ...]:
        return tuple(point.name for point in self.hammer_points)

    def point(self, name: str) -> HammerPoint:
        for point in self.hammer_points:
            if point.name == name:
                return point
        raise SettingError(f"hammer point '{name}': not in the rig spec (points: {', '.join(self.point_names)})")

    def rows(self, positions_m: np.ndarray) -> np.ndarray:
        """``g = [1, y − y_c, −(x − x_c)]`` for each position (n, 2) → (n, 3)."""
        positions = np.atleast_2d(np.asarray(positions_m, dtype=float))
        x_c, y_c = self.centre_of_mass_m
        return np.column_stack((np.ones(len(positions)), positions[:, 1] - y_c, -(positions[:, 0] - x_c)))

    def sensor_matrix(self) -> np.ndarray:
        """(accelerometers, 3): what each accelerometer reads of q̈ (its direction included)."""
        rows = self.rows(np.array([sensor.position_m for sensor in self.accelerometers]))
        return rows * np.array([sensor.direction for sensor in self.accelerometers])[:, np.newaxis]

    def load_vector(self, point: str | None = None) -> np.ndarray:
        """(3,): the generalised force (N, N·m, N·m) of 1 N at hammer point ``point`` (default: the struck one)."""
        return self.rows(np.array([self.point(point or self.hammer_point).position_m]))[0]

    def mass_matrix(self, mass_kg: float) -> np.ndarray:
        i_xx, i_yy = self.inertia_kg_m2
        i_xy = self.product_of_inertia_kg_m2
        return np.array([[mass_kg, 0.0, 0.0], [0.0, i_xx, -i_xy], [0.0, -i_xy, i_yy]])

    def elastic_transform(self) -> np.ndarray:
        """T of the direction form: heave at the elastic centre, roll and pitch as they are."""
        x_c, y_c = self.centre_of_mass_m
        x_e, y_e = self.elastic_centre_m if self.elastic_centre_m is not None else self.centre_of_mass_m
        return np.array([[1.0, y_e - y_c, -(x_e - x_c)], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])

    def pad_parameter_names(self, index: int) -> dict[str, str]:
        """Pad ``index``'s own parameter names → the spec's film parameter names."""
        return {name: f"{name}{_PAD_SUFFIX}{index + 1}" for name in get_model(self.pads[index].model).parameter_names}

    def pad_parameters(self, index: int, film_parameters: Mapping[str, float]) -> dict[str, float]:
        """Pad ``index``'s parameters under its own model's names."""
        return {own: float(film_parameters[spec_name]) for own, spec_name in self.pad_parameter_names(index).items()}

    def struck_at(self, point: str) -> "RigidBody":
        self.point(point)
        return replace(self, hammer_point=point)


# --- the spec's film for pads ---------------------------------------------------------------------------------------


def renamed_network(model_text: str, suffix: str) -> str:
    """A network's text with every parameter name given ``suffix`` (element keywords kept)."""
    return _NAME.sub(lambda match: match.group(1) + suffix, get_model(model_text).text)


def pads_film(pads: Sequence[Pad], pad_parameters: Sequence[Mapping[str, float]]) -> tuple[str, dict[str, float]]:
    """The heave film of pads (their parallel network) and its parameters (``<name>_pad<i>``)."""
    texts, values = [], {}
    for index, (pad, parameters) in enumerate(zip(pads, pad_parameters)):
        suffix = f"{_PAD_SUFFIX}{index + 1}"
        texts.append(f"({renamed_network(pad.model, suffix)})")
        values.update({f"{name}{suffix}": float(value) for name, value in parameters.items()})
    return " || ".join(texts), values


# --- physics ----------------------------------------------------------------------------------------------------------


def _scaled(model: FilmModel, parameters: Mapping[str, float], viscous: np.ndarray) -> np.ndarray:
    """The model's parameter vector, its viscous coefficients (N·s…) scaled by ``viscous`` (one, or one per hit)."""
    vector = model.vector(parameters)
    if np.all(viscous == 1.0):
        return vector
    columns = [i for i, parameter in enumerate(model.parameters) if parameter.unit.startswith("N·s")]
    vector = np.broadcast_to(vector, viscous.shape + vector.shape).copy()
    vector[..., columns] *= viscous[..., np.newaxis]
    return vector


def _film_of(model: FilmModel, parameters: Mapping[str, float], s: np.ndarray, viscous: np.ndarray,
             whole: np.ndarray) -> np.ndarray:
    stiffness = model.stiffness(s, _scaled(model, parameters, viscous))
    return stiffness * whole[..., np.newaxis] if whole.ndim else stiffness * float(whole)


def _scales(spec: RigSpec, time_s: np.ndarray | float, film_scale: float | None) -> tuple[np.ndarray, np.ndarray]:
    if film_scale is not None:
        return np.asarray(1.0), np.asarray(float(film_scale))
    return (np.asarray(spec.viscous_scale(time_s), dtype=float), np.asarray(spec.film_scale(time_s), dtype=float))


def film_matrix(spec: RigSpec, s: np.ndarray, time_s: np.ndarray | float = 0.0,
                film_scale: float | None = None) -> np.ndarray:
    """The films' 3×3 dynamic stiffness at the centre of mass, (G, 3, 3) or (hits, G, 3, 3) for an array of times
    (drift and step changes scale every film as they scale a one-direction film; ``film_scale`` overrides them)."""
    body = _body(spec)
    s = np.asarray(s, dtype=complex)
    viscous, whole = _scales(spec, time_s, film_scale)
    if body.has_pads:
        rows = body.rows(np.array([pad.position_m for pad in body.pads]))
        stiffness = np.stack(np.broadcast_arrays(*[
            _film_of(get_model(pad.model), body.pad_parameters(index, spec.film_parameters), s, viscous, whole)
            for index, pad in enumerate(body.pads)]))
        return np.einsum("p...,pa,pb->...ab", stiffness, rows, rows)
    heave = _film_of(spec.film, spec.film_parameters, s, viscous, whole)
    roll = _film_of(body.roll.film, body.roll.parameters, s, viscous, whole)
    pitch = _film_of(body.pitch.film, body.pitch.parameters, s, viscous, whole)
    diagonal = np.zeros(np.broadcast_shapes(heave.shape, roll.shape, pitch.shape) + (3, 3), dtype=complex)
    diagonal[..., 0, 0], diagonal[..., 1, 1], diagonal[..., 2, 2] = heave, roll, pitch
    transform = body.elastic_transform()
    return transform.T @ diagonal @ transform


def mass_matrix(spec: RigSpec) -> np.ndarray:
    """M (3×3): the moving mass (with added masses) and the inertia about the centre of mass."""
    return _body(spec).mass_matrix(spec.moving_mass_kg)


def dynamic_stiffness_matrix(spec: RigSpec, s: np.ndarray, time_s: np.ndarray | float = 0.0, *,
                             film_scale: float | None = None,
                             impulse_ns: np.ndarray | float | None = None) -> np.ndarray:
    """``D(s) = Z(s) + M s²`` plus the mechanical effects on heave (added stiffness, amplitude-dependent damping at
    the hit's level ``impulse_ns``), (G, 3, 3) or (hits, G, 3, 3)."""
    s = np.asarray(s, dtype=complex)
    total = film_matrix(spec, s, time_s, film_scale) + mass_matrix(spec) * (s**2)[..., np.newaxis, np.newaxis]
    heave: np.ndarray | float = 0.0
    for effect in spec.effects:
        heave = heave + effect.added_stiffness(s)
    if impulse_ns is not None:
        velocity_m_s = np.abs(np.asarray(impulse_ns, dtype=float)) / spec.moving_mass_kg
        damping = sum(effect.level_damping_ns_per_m(velocity_m_s) for effect in spec.effects)
        heave = heave + (np.asarray(damping)[..., np.newaxis] if np.ndim(damping) else damping) * s
    if np.any(np.asarray(heave) != 0.0):
        lines = np.broadcast_shapes(total.shape[:-2], np.shape(heave))
        if lines != total.shape[:-2]:  # (a damper per hit on a film the same for every hit)
            total = np.broadcast_to(total, lines + (3, 3)).copy()
        total[..., 0, 0] += heave
    return total


def diagonal_accelerances(spec: RigSpec, s: np.ndarray, **options: Any) -> np.ndarray:
    """The diagonal of :func:`accelerance_matrix`, (3, G): each direction's accelerance to its own load (every mode
    shows in at least one of them)."""
    s = np.asarray(s, dtype=complex)
    a = dynamic_stiffness_matrix(spec, s, **options)
    determinant = (a[..., 0, 0] * (a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1])
                   - a[..., 0, 1] * (a[..., 1, 0] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 0])
                   + a[..., 0, 2] * (a[..., 1, 0] * a[..., 2, 1] - a[..., 1, 1] * a[..., 2, 0]))
    minors = np.stack([a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1],
                       a[..., 0, 0] * a[..., 2, 2] - a[..., 0, 2] * a[..., 2, 0],
                       a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]])
    return minors / determinant * s**2


def accelerance_matrix(spec: RigSpec, s: np.ndarray, time_s: np.ndarray | float = 0.0, **options: Any
                       ) -> np.ndarray:
    """The generalised accelerance ``A(s) = s² D(s)⁻¹`` ((m/s²)/N, (rad/s²)/(N·m), ...), (G, 3, 3)."""
    s = np.asarray(s, dtype=complex)
    return np.linalg.inv(dynamic_stiffness_matrix(spec, s, time_s, **options)) * (s**2)[..., np.newaxis, np.newaxis]


def sensor_accelerances(spec: RigSpec, s: np.ndarray, point: str | None = None, time_s: float = 0.0,
                        impulse_ns: float | None = None) -> np.ndarray:
    """What each accelerometer reads of the mover's motion per N at hammer point ``point`` (default: the struck
    one), (accelerometers, G) in (m/s²)/N; without the effects beside the mover (cross-talk, structure modes)."""
    body = _body(spec)
    s = np.asarray(s, dtype=complex)
    motion = solve3(dynamic_stiffness_matrix(spec, s, time_s, impulse_ns=impulse_ns), body.load_vector(point))
    return np.moveaxis(motion @ body.sensor_matrix().T, -1, 0) * s**2


def effective_dynamic_stiffness(spec: RigSpec, s: np.ndarray, time_s: np.ndarray | float = 0.0, *,
                                film_scale: float | None = None,
                                impulse_ns: np.ndarray | float | None = None) -> np.ndarray:
    """``1 / (t_1ᵀ D(s)⁻¹ g_p)``: the scalar dynamic stiffness whose ``s²/·`` is the accelerance of the first
    accelerometer for the struck hammer point — what a tool that reads one FRF sees of the rigid body (G,) or
    (hits, G). For one accelerometer at the centre of mass, a hammer there and an uncoupled film it is ``D_zz``."""
    body = _body(spec)
    motion = solve3(dynamic_stiffness_matrix(spec, s, time_s, film_scale=film_scale, impulse_ns=impulse_ns),
                    body.load_vector())
    return 1.0 / (motion @ body.sensor_matrix()[0])


def solve3(matrices: np.ndarray, load: np.ndarray) -> np.ndarray:
    """``D⁻¹ g`` for a stack of 3×3 matrices (…, 3, 3) and one vector g (3,), by Cramer's rule (a stack of small
    systems, evaluated at once: many times faster than a LAPACK call per matrix)."""
    a = matrices
    cofactors = np.stack([
        a[..., 1, 1] * a[..., 2, 2] - a[..., 1, 2] * a[..., 2, 1],
        a[..., 0, 2] * a[..., 2, 1] - a[..., 0, 1] * a[..., 2, 2],
        a[..., 0, 1] * a[..., 1, 2] - a[..., 0, 2] * a[..., 1, 1],
        a[..., 1, 2] * a[..., 2, 0] - a[..., 1, 0] * a[..., 2, 2],
        a[..., 0, 0] * a[..., 2, 2] - a[..., 0, 2] * a[..., 2, 0],
        a[..., 0, 2] * a[..., 1, 0] - a[..., 0, 0] * a[..., 1, 2],
        a[..., 1, 0] * a[..., 2, 1] - a[..., 1, 1] * a[..., 2, 0],
        a[..., 0, 1] * a[..., 2, 0] - a[..., 0, 0] * a[..., 2, 1],
        a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0],
    ], axis=-1).reshape(a.shape)  # the adjugate, row by row
    determinant = a[..., 0, 0] * cofactors[..., 0, 0] + a[..., 0, 1] * cofactors[..., 1, 0] \
        + a[..., 0, 2] * cofactors[..., 2, 0]
    return (cofactors @ np.asarray(load, dtype=float)) / determinant[..., np.newaxis]


def direction_modes_hz(spec: RigSpec) -> list[tuple[float, str]]:
    """The rigid-body resonances (Hz) on the films' real stiffness near them, each named by the direction that
    dominates its mode shape — what a spec with a rigid body says of the resonances an accelerometer sees."""
    mass = mass_matrix(spec)
    omega = np.full(3, 2 * np.pi * 100.0)
    for _ in range(30):  # fixed point: the films' real stiffness at the modes' own frequencies
        stiffness = np.array([film_matrix(spec, np.array([1j * w]))[0].real for w in omega])
        shapes = []
        new = np.empty(3)
        for index in range(3):
            values, vectors = _generalised_eigen(stiffness[index], mass)
            new[index] = math.sqrt(max(values[index], 0.0))
            shapes.append(vectors[:, index])
        if np.allclose(new, omega, rtol=1e-10):
            break
        omega = new
    return [(float(w / (2 * np.pi)), DIRECTIONS[int(np.argmax(np.abs(shape) * np.sqrt(np.diag(mass))))])
            for w, shape in zip(omega, shapes)]


def _generalised_eigen(stiffness: np.ndarray, mass: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and vectors of K v = λ M v for symmetric K and positive definite M."""
    chol = np.linalg.cholesky(mass)
    inverse = np.linalg.inv(chol)
    values, vectors = np.linalg.eigh(inverse @ stiffness @ inverse.T)
    return values, inverse.T @ vectors


def layout_direction_films(spec: RigSpec) -> dict[str, tuple[str, dict[str, float]] | None]:
    """What the film layout implies for each diagonal term of the 3×3 film stiffness at the centre of mass (heave,
    roll, pitch) as one model with parameters, when it is one: pads of the same model and orders whose coefficients
    are proportional, or whose model only adds its elements (SD); the direction form's films about the elastic centre
    moved to the centre of mass when the elastic centre is on it. None where the layout gives no single model."""
    body = _body(spec)
    if not body.has_pads:
        if body.elastic_centre_m is not None and tuple(body.elastic_centre_m) != tuple(body.centre_of_mass_m):
            return {"heave": (spec.film_model, dict(spec.film_parameters)), "roll": None, "pitch": None}
        return {"heave": (spec.film_model, dict(spec.film_parameters)),
                "roll": (body.roll.model, dict(body.roll.parameters)),
                "pitch": (body.pitch.model, dict(body.pitch.parameters))}
    rows = body.rows(np.array([pad.position_m for pad in body.pads]))
    return {direction: _weighted_pads(spec, rows[:, index] ** 2) for index, direction in enumerate(DIRECTIONS)}


def layout_coupling_sd(spec: RigSpec) -> dict[tuple[str, str], tuple[float, float]] | None:
    """For pads with a spring-damper (SD) film: the coupling stiffness and damping each pair of directions has at
    the centre of mass, ``Σ k_i g_ia g_ib`` and ``Σ η_i g_ia g_ib``; None for another layout."""
    body = _body(spec)
    if not body.has_pads or any(get_model(pad.model).name != "SD" for pad in body.pads):
        return None
    rows = body.rows(np.array([pad.position_m for pad in body.pads]))
    out = {}
    for a, b in COUPLINGS:
        weights = rows[:, DIRECTIONS.index(a)] * rows[:, DIRECTIONS.index(b)]
        k = sum(w * body.pad_parameters(i, spec.film_parameters)["k"] for i, w in enumerate(weights))
        eta = sum(w * body.pad_parameters(i, spec.film_parameters)["eta"] for i, w in enumerate(weights))
        out[(a, b)] = (float(k), float(eta))
    return out


def _weighted_pads(spec: RigSpec, weights: np.ndarray) -> tuple[str, dict[str, float]] | None:
    body = _body(spec)
    models = {get_model(pad.model).text for pad in body.pads}
    if len(models) != 1:
        return None
    model = get_model(body.pads[0].model)
    vectors = np.array([model.vector(body.pad_parameters(i, spec.film_parameters)) for i in range(len(body.pads))])
    orders = [i for i, parameter in enumerate(model.parameters) if parameter.scale != "log"]
    coefficients = [i for i, parameter in enumerate(model.parameters) if parameter.scale == "log"]
    if orders and not np.allclose(vectors[:, orders], vectors[0, orders], rtol=1e-12, atol=0.0):
        return None
    additive = model.text.replace(" ", "").count("--") == 0  # a parallel network of elements: Z linear in them
    if not additive:
        ratios = vectors[:, coefficients] / vectors[0, coefficients]
        if not np.allclose(ratios, ratios[:, :1], rtol=1e-9, atol=0.0):
            return None
    summed = vectors[0].copy()
    summed[coefficients] = weights @ vectors[:, coefficients]
    name = model.name if model.name != "custom" else model.text
    return name, model.mapping(summed)


def _body(spec: RigSpec) -> RigidBody:
    if spec.rigid_body is None:
        raise SettingError(f"{spec.source}: the rig spec has no [rigid_body]")
    return spec.rigid_body


def struck_at(spec: RigSpec, point: str) -> RigSpec:
    """The spec with the hammer at ``point`` (a name of ``[[rigid_body.hammer_points]]``)."""
    return replace(spec, rigid_body=_body(spec).struck_at(point))


# --- TOML -------------------------------------------------------------------------------------------------------------


def _where(source: str, key: str) -> str:
    return f"{source} key 'rigid_body.{key}'"


def _pair(value: Any, where: str, limit: float = MAX_POSITION_M) -> tuple[float, float]:
    if (not isinstance(value, list) or len(value) != 2
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value)):
        raise SettingError(f"{where} = {value!r}: must be two finite numbers [x, y] (m)")
    if any(abs(v) > limit for v in value):
        raise SettingError(f"{where} = {value!r}: each within ±{limit:g} m")
    return float(value[0]), float(value[1])


def _text(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > 80:
        raise SettingError(f"{where} = {value!r}: must be a name (1 to 80 characters)")
    return value


def _keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise SettingError(f"{where}: unknown key '{key}'; allowed: {', '.join(allowed)}")


def _tables(table: Mapping[str, Any], key: str, source: str, limit: int) -> list[Mapping[str, Any]]:
    items = table.get(key, [])
    if not isinstance(items, list) or not all(isinstance(item, Mapping) for item in items):
        raise SettingError(f"{_where(source, key)}: must be an array of tables ([[rigid_body.{key}]])")
    if len(items) > limit:
        raise SettingError(f"{_where(source, key)}: {len(items)} given; at most {limit}")
    return items


def _unique(names: Sequence[str], where: str) -> None:
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise SettingError(f"{where}: names used twice: {', '.join(twice)}")


def _number(value: Any, where: str, low: float, high: float, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SettingError(f"{where} = {value!r}: must be a finite number ({unit})")
    if not low <= value <= high:
        raise SettingError(f"{where} = {value!r}: must be ≥ {low:g} and ≤ {high:g} ({unit})")
    return float(value)


def _direction_film(table: Any, where: str) -> DirectionFilm:
    if not isinstance(table, Mapping):
        raise SettingError(f"{where}: must be a table with 'model' and 'parameters'")
    _keys(table, ("model", "parameters"), where)
    model = table.get("model")
    if not isinstance(model, str):
        raise SettingError(f"{where} key 'model': missing; a paper model name or a network")
    parameters = table.get("parameters", {})
    if not isinstance(parameters, Mapping):
        raise SettingError(f"{where} key 'parameters': must be a table")
    return DirectionFilm(model, {key: parameters[key] for key in parameters})


RIGID_BODY_KEYS = ("inertia_kg_m2", "product_of_inertia_kg_m2", "centre_of_mass_m", "hammer_point",
                   "elastic_centre_m", "roll", "pitch", "accelerometers", "hammer_points", "pads")


def rigid_body_from_table(table: Any, source: str) -> tuple[RigidBody, list[Mapping[str, Any]]]:
    """``[rigid_body]`` of a spec: the body and, for pads, each pad's parameter table (under its model's names)."""
    if not isinstance(table, Mapping):
        raise SettingError(f"{source} key 'rigid_body': must be a table")
    _keys(table, RIGID_BODY_KEYS, f"{source} [rigid_body]")
    inertia = table.get("inertia_kg_m2")
    if not isinstance(inertia, list) or len(inertia) != 2:
        raise SettingError(f"{_where(source, 'inertia_kg_m2')}: missing or not [I_xx, I_yy] (kg·m², about the "
                           f"centre of mass)")
    inertia = tuple(_number(value, _where(source, "inertia_kg_m2"), *INERTIA_RANGE_KG_M2, "kg·m²")
                    for value in inertia)
    accelerometers = []
    for index, item in enumerate(_tables(table, "accelerometers", source, MAX_ACCELEROMETERS)):
        where = f"{source} [[rigid_body.accelerometers]][{index}]"
        _keys(item, ("name", "position_m", "direction", "serial", "sensitivity_mv_per_m_s2",
                     "noise_m_s2_per_sqrt_hz"), where)
        direction = item.get("direction", "+z")
        if direction not in DIRECTION_SIGNS:
            raise SettingError(f"{where} key 'direction' = {direction!r}: allowed: {', '.join(DIRECTION_SIGNS)}")
        serial = item.get("serial", "")
        if not isinstance(serial, str):
            raise SettingError(f"{where} key 'serial': must be a string")
        accelerometers.append(Accelerometer(
            _text(item.get("name", f"A{index + 1}"), f"{where} key 'name'"),
            _pair(item.get("position_m"), f"{where} key 'position_m'"), DIRECTION_SIGNS[direction],
            None if "sensitivity_mv_per_m_s2" not in item else _number(
                item["sensitivity_mv_per_m_s2"], f"{where} key 'sensitivity_mv_per_m_s2'", 1e-3, 1e5, "mV/(m/s²)"),
            None if "noise_m_s2_per_sqrt_hz" not in item else _number(
                item["noise_m_s2_per_sqrt_hz"], f"{where} key 'noise_m_s2_per_sqrt_hz'", 0.0, 1e3, "(m/s²)/√Hz"),
            serial))
    points = []
    for index, item in enumerate(_tables(table, "hammer_points", source, MAX_HAMMER_POINTS)):
        where = f"{source} [[rigid_body.hammer_points]][{index}]"
        _keys(item, ("name", "position_m"), where)
        points.append(HammerPoint(_text(item.get("name", f"H{index + 1}"), f"{where} key 'name'"),
                                  _pair(item.get("position_m"), f"{where} key 'position_m'")))
    pads, pad_tables = [], []
    for index, item in enumerate(_tables(table, "pads", source, MAX_PADS)):
        where = f"{source} [[rigid_body.pads]][{index}]"
        _keys(item, ("name", "position_m", "model", "parameters"), where)
        model = item.get("model")
        if not isinstance(model, str):
            raise SettingError(f"{where} key 'model': missing; a paper model name or a network")
        try:
            get_model(model)
        except SettingError as error:
            raise SettingError(f"{where} key 'model': {error}") from None
        parameters = item.get("parameters", {})
        if not isinstance(parameters, Mapping):
            raise SettingError(f"{where} key 'parameters': must be a table")
        pads.append(Pad(_text(item.get("name", f"P{index + 1}"), f"{where} key 'name'"),
                        _pair(item.get("position_m"), f"{where} key 'position_m'"), model))
        pad_tables.append(parameters)
    hammer_point = table.get("hammer_point", "")
    if not isinstance(hammer_point, str):
        raise SettingError(f"{_where(source, 'hammer_point')}: must be the name of a hammer point")
    body = RigidBody(
        inertia_kg_m2=inertia,  # type: ignore[arg-type]
        accelerometers=tuple(accelerometers),
        hammer_points=tuple(points),
        centre_of_mass_m=_pair(table.get("centre_of_mass_m", [0.0, 0.0]), _where(source, "centre_of_mass_m")),
        product_of_inertia_kg_m2=_number(table.get("product_of_inertia_kg_m2", 0.0),
                                         _where(source, "product_of_inertia_kg_m2"), -INERTIA_RANGE_KG_M2[1],
                                         INERTIA_RANGE_KG_M2[1], "kg·m²"),
        hammer_point=hammer_point,
        pads=tuple(pads),
        elastic_centre_m=(None if "elastic_centre_m" not in table
                          else _pair(table["elastic_centre_m"], _where(source, "elastic_centre_m"))),
        roll=None if "roll" not in table else _direction_film(table["roll"], f"{source} [rigid_body.roll]"),
        pitch=None if "pitch" not in table else _direction_film(table["pitch"], f"{source} [rigid_body.pitch]"),
    )
    return body, pad_tables


def rigid_body_to_table(body: RigidBody, film_parameters: Mapping[str, float]) -> dict[str, Any]:
    """``[rigid_body]`` as TOML values (pads with their parameters under their own models' names)."""
    table: dict[str, Any] = {"inertia_kg_m2": list(body.inertia_kg_m2)}
    if body.product_of_inertia_kg_m2:
        table["product_of_inertia_kg_m2"] = body.product_of_inertia_kg_m2
    table["centre_of_mass_m"] = list(body.centre_of_mass_m)
    table["hammer_point"] = body.hammer_point
    if body.elastic_centre_m is not None:
        table["elastic_centre_m"] = list(body.elastic_centre_m)
    for direction in ("roll", "pitch"):
        film = getattr(body, direction)
        if film is not None:
            table[direction] = {"model": film.model, "parameters": dict(film.parameters)}
    accelerometers = []
    for sensor in body.accelerometers:
        item: dict[str, Any] = {"name": sensor.name, "position_m": list(sensor.position_m),
                                "direction": "+z" if sensor.direction > 0 else "-z"}
        if sensor.serial:
            item["serial"] = sensor.serial
        if sensor.sensitivity_mv_per_m_s2 is not None:
            item["sensitivity_mv_per_m_s2"] = sensor.sensitivity_mv_per_m_s2
        if sensor.noise_m_s2_per_sqrt_hz is not None:
            item["noise_m_s2_per_sqrt_hz"] = sensor.noise_m_s2_per_sqrt_hz
        accelerometers.append(item)
    table["accelerometers"] = accelerometers
    table["hammer_points"] = [{"name": point.name, "position_m": list(point.position_m)}
                              for point in body.hammer_points]
    if body.pads:
        table["pads"] = [{"name": pad.name, "position_m": list(pad.position_m), "model": pad.model,
                          "parameters": body.pad_parameters(index, film_parameters)}
                         for index, pad in enumerate(body.pads)]
    return table


def validate_rigid_body(spec: RigSpec) -> None:
    """Cross-checks of a spec's rigid body; one line naming the key at fault."""
    body = _body(spec)
    source = spec.source
    if not body.accelerometers:
        raise SettingError(f"{_where(source, 'accelerometers')}: at least one accelerometer is needed")
    if not body.hammer_points:
        raise SettingError(f"{_where(source, 'hammer_points')}: at least one hammer point is needed")
    _unique(body.sensor_names, _where(source, "accelerometers"))
    _unique(body.point_names, _where(source, "hammer_points"))
    if body.hammer_point not in body.point_names:
        raise SettingError(f"{_where(source, 'hammer_point')} = {body.hammer_point!r}: not a hammer point "
                           f"({', '.join(body.point_names)})")
    if len(body.accelerometers) >= 3 and np.linalg.matrix_rank(body.sensor_matrix(), tol=1e-9) < 3:
        raise SettingError(f"{_where(source, 'accelerometers')}: the accelerometers lie on one line; heave, roll "
                           f"and pitch need three not in line")
    mass = body.mass_matrix(spec.moving_mass_kg)
    if np.any(np.linalg.eigvalsh(mass) <= 0):
        raise SettingError(f"{_where(source, 'product_of_inertia_kg_m2')} = {body.product_of_inertia_kg_m2!r}: the "
                           f"inertia is not positive definite (|I_xy| must be below √(I_xx·I_yy))")
    if spec.cubic_stiffness_n_per_m3:
        raise SettingError(f"{source}: a cubic-stiffness effect is not supported on a rigid body")
    if spec.film_laws:
        raise SettingError(f"{source} [film.laws]: film laws are not supported on a rigid body")
    if body.has_pads:
        if body.roll is not None or body.pitch is not None or body.elastic_centre_m is not None:
            raise SettingError(f"{source} [rigid_body]: give pads, or roll and pitch films with an elastic centre, "
                               f"not both")
        _unique([pad.name for pad in body.pads], _where(source, "pads"))
        if len(body.pads) < 3 or np.linalg.matrix_rank(body.rows(np.array([p.position_m for p in body.pads])),
                                                       tol=1e-9) < 3:
            raise SettingError(f"{_where(source, 'pads')}: the mover needs at least three pads not in line")
    else:
        for direction in ("roll", "pitch"):
            film = getattr(body, direction)
            if film is None:
                raise SettingError(f"{source} [rigid_body]: pads, or a [rigid_body.{direction}] film, are needed")
            where = f"{source} [rigid_body.{direction}]"
            try:
                model = film.film
            except SettingError as error:
                raise SettingError(f"{where} key 'model': {error}") from None
            for parameter in model.parameters:
                if parameter.name not in film.parameters:
                    raise SettingError(f"{where} key 'parameters.{parameter.name}': missing; {model.name} needs "
                                       f"{', '.join(model.parameter_names)}")
                _number(film.parameters[parameter.name], f"{where} key 'parameters.{parameter.name}'",
                        parameter.lower, parameter.upper, parameter.unit)
            for name in film.parameters:
                if name not in model.parameter_names:
                    raise SettingError(f"{where} key 'parameters.{name}': not a parameter of {model.name} "
                                       f"({', '.join(model.parameter_names)})")
    static = film_matrix(spec, np.array([2j * np.pi * 0.1]))[0].real
    if np.any(np.linalg.eigvalsh(0.5 * (static + static.T)) <= 0):
        raise SettingError(f"{source} [rigid_body]: the films do not hold the mover in every direction (their "
                           f"stiffness matrix is not positive at 0.1 Hz)")


def pad_spec_parts(pads: Sequence[Pad], pad_tables: Sequence[Mapping[str, Any]], source: str
                   ) -> tuple[str, dict[str, float]]:
    """The spec's film (heave network) and film parameters of pads read from TOML, each pad's parameters checked
    against its model (names, bounds) with a line naming the pad."""
    checked = []
    for index, (pad, parameters) in enumerate(zip(pads, pad_tables)):
        where = f"{source} [[rigid_body.pads]][{index}]"
        model = get_model(pad.model)
        values = {}
        for parameter in model.parameters:
            if parameter.name not in parameters:
                raise SettingError(f"{where} key 'parameters.{parameter.name}': missing; {model.name} needs "
                                   f"{', '.join(model.parameter_names)}")
            values[parameter.name] = _number(parameters[parameter.name], f"{where} key 'parameters.{parameter.name}'",
                                             parameter.lower, parameter.upper, parameter.unit)
        for name in parameters:
            if name not in model.parameter_names:
                raise SettingError(f"{where} key 'parameters.{name}': not a parameter of {model.name} "
                                   f"({', '.join(model.parameter_names)})")
        checked.append(values)
    return pads_film(pads, checked)


def channel_names(spec: RigSpec) -> list[str]:
    """Names of the accelerometers in channel order (ai1, ai2, ... after the hammer on ai0)."""
    return list(_body(spec).sensor_names)


@dataclass(frozen=True)
class HammerRun:
    """The hits of a roving test struck at one point: from session hit ``first_hit`` on (until the next run)."""

    point: str
    first_hit: int


@dataclass
class RovingPlan:
    """The hammer points of a session's runs (the session setting ``hammer_points``), oldest first."""

    runs: list[HammerRun] = field(default_factory=list)

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any]) -> "RovingPlan":
        runs = settings.get("hammer_points") or []
        plan = cls()
        if isinstance(runs, list):
            for run in runs:
                if isinstance(run, Mapping) and isinstance(run.get("point"), str) and isinstance(
                        run.get("first_hit"), int):
                    plan.runs.append(HammerRun(run["point"], int(run["first_hit"])))
        return plan

    def to_setting(self) -> list[dict[str, Any]]:
        return [{"point": run.point, "first_hit": run.first_hit} for run in self.runs]

    def with_run(self, point: str, first_hit: int) -> "RovingPlan":
        """The plan with a run at ``point`` starting at hit ``first_hit`` (a run of the same point goes on)."""
        if self.runs and self.runs[-1].point == point:
            return RovingPlan(list(self.runs))
        return RovingPlan([*self.runs, HammerRun(point, first_hit)])

    def point_of_hit(self, index: int, default: str) -> str:
        point = default
        for run in self.runs:
            if index >= run.first_hit:
                point = run.point
        return point

    def points(self) -> list[str]:
        """The points struck, each once, in the order first struck."""
        seen: list[str] = []
        for run in self.runs:
            if run.point not in seen:
                seen.append(run.point)
        return seen
