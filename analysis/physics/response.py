"""The response of a rig spec: the linear accelerance at ``s = σ + jω`` and the time-domain response to a force.

Physics (SI units throughout). With ``M = m + Σ added mass``, the mover obeys
``(Z_film(s, t) + Σ Z_effect(s) + M s²)·X(s) = F(s)``, plus the force ``k3·x³`` with ``cubic-stiffness``.
``Z_film(s, t)`` is the film network at the hit's session time (drift and step changes scale it). The channels see
``(s² / (Z_film + Σ Z_effect + M s²) + Σ A_r s²/(s² + 2ζ_r ω_r s + ω_r²) + leak) · T_a(s) / T_f(s)``: ``T_a``,
``T_f`` the per-channel transfers (delays, AC coupling, sensitivity errors, polarity), the sum the structure modes in
modal superposition beside the mover (``structure-mode``), ``leak`` the force cross-talk into the acceleration
channel.
The simulated device (through its plant), the replay, identification and the diagnosis all evaluate a spec here.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.fft

from gasfilm.analysis.physics.elements import FilmModel, laplace_variable
from gasfilm.drivers.errors import GasfilmError

from gasfilm.analysis.physics import rigid_body
from gasfilm.analysis.physics.effects import CUBIC_EQUIVALENT, DECAY_TOLERANCE, MAX_RESPONSE_DURATION_S, Effect, TermChange
from gasfilm.analysis.physics.spec import RigSpec
# --- physics -------------------------------------------------------------------------------------------------------


#: How closely two discretisations of the nonlinear response agree (fraction of the peak, in the module's pass band):
#: the simulator's periodic ×2 grid and the replay's zero-padded grid, each solved to a residual of 1e-12.
NONLINEAR_TOLERANCE = 1e-5


@dataclass(frozen=True)
class HitConditions:
    """What differs between the hits of a session: each hit's session time (s), force impulse (N·s) and blow number
    (the hit's number among the session's blows, 0 for the first; None: the hits in order, 0, 1, 2 …)."""

    time_s: np.ndarray
    impulse_ns: np.ndarray
    blow: np.ndarray | None = None

    @property
    def blows(self) -> np.ndarray:
        """Each hit's blow number."""
        return np.arange(len(self.time_s), dtype=float) if self.blow is None else np.asarray(self.blow, dtype=float)

    def subset(self, hits: np.ndarray) -> "HitConditions":
        return HitConditions(self.time_s[hits], self.impulse_ns[hits], self.blows[hits])


def film_stiffness(
    spec: RigSpec, s: np.ndarray, time_s: np.ndarray | float = 0.0,
    scales: tuple[np.ndarray, np.ndarray] | None = None,
    network: Callable[[np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """The film's complex stiffness Z(s) in N/m at session time(s): (G,) for one time, (hits, G) for an array.

    The whole film scales with :meth:`RigSpec.film_scale` (drift, step changes); its viscous coefficients (dashpot and
    spring-pot coefficients) further with :meth:`RigSpec.viscous_scale`. ``scales``: those two at ``time_s``
    (:func:`film_scales`), when the caller has them; ``network``: :func:`viscous_network` of the spec for a viscous
    scale, when the caller remembers it.
    """
    s = np.asarray(s, dtype=complex)
    viscous, whole = film_scales(spec, time_s) if scales is None else scales
    stiffness = viscous_network(spec, s, viscous) if network is None else network(viscous)
    return stiffness * whole[..., np.newaxis] if whole.ndim else stiffness * float(whole)


def viscous_network(spec: RigSpec, s: np.ndarray, viscous: np.ndarray) -> np.ndarray:
    """The film network's stiffness (N/m) with its viscous coefficients scaled by ``viscous`` (one factor, or one
    per hit): :func:`film_stiffness` before the whole film's scale."""
    model = spec.film
    vector = model.vector(spec.film_parameters)
    if np.any(viscous != 1.0):
        columns = [i for i, parameter in enumerate(model.parameters) if parameter.unit.startswith("N·s")]
        vector = np.broadcast_to(vector, viscous.shape + vector.shape).copy()
        vector[..., columns] *= viscous[..., np.newaxis]
    return _network_stiffness(model, vector, s) if vector.ndim == 1 else model.stiffness(s, vector)


def film_scales(spec: RigSpec, time_s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`RigSpec.viscous_scale` and :meth:`RigSpec.film_scale` at ``time_s``, as arrays."""
    return (np.asarray(spec.viscous_scale(time_s), dtype=float), np.asarray(spec.film_scale(time_s), dtype=float))


class _LastNetwork:
    """``model.stiffness(s, vector)``, kept for the last model, single parameter vector and ``s``: the simulator asks
    for the same film on the same grid at every hit (a drifting film only scales it), and evaluating the spring-pots
    is most of a simulated hit's cost. The returned array must not be modified."""

    def __init__(self) -> None:
        self._kept: tuple[FilmModel, np.ndarray, np.ndarray, np.ndarray] | None = None

    def stiffness(self, model: FilmModel, vector: np.ndarray, s: np.ndarray) -> np.ndarray:
        kept = self._kept  # one read: another thread may replace it meanwhile
        if (kept is not None and kept[0] is model and kept[1].shape == vector.shape and np.array_equal(kept[1], vector)
                and kept[2].shape == s.shape and np.array_equal(kept[2], s)):
            return kept[3]
        stiffness = model.stiffness(s, vector)
        if vector.ndim == 1:
            self._kept = (model, vector.copy(), s.copy(), stiffness)
        return stiffness


_network_stiffness = _LastNetwork().stiffness


def rig_dynamic_stiffness(
    spec: RigSpec,
    s: np.ndarray,
    time_s: np.ndarray | float = 0.0,
    *,
    film_scale: float | None = None,
    impulse_ns: np.ndarray | float | None = None,
    pieces: "GridPieces | None" = None,
) -> np.ndarray:
    """Linear dynamic stiffness of the mover on its film, ``Z_film(t) + Σ Z_effect + c_eq(v)·s + M s²`` (N/m), the
    film in series with its support's ``Z_b`` when the spec has one (``Z_film Z_b/(Z_film + Z_b)``).

    The film is the spec's at ``time_s`` (one time or an array of hit times) unless ``film_scale`` gives its scale.
    With ``impulse_ns`` (one hit's or an array matching ``time_s``), amplitude-dependent dampers add their equivalent
    viscous damping at the hit's initial velocity ``J / M``. ``pieces`` (made for this ``s``) remembers the film's and
    the effects' parts between calls (the same numbers, computed once). A spec with a rigid body gives the scalar
    its first accelerometer sees for the struck hammer point
    (:func:`~gasfilm.analysis.physics.rigid_body.effective_dynamic_stiffness`).
    """
    s = np.asarray(s, dtype=complex)
    if spec.rigid_body is not None:  # what the first accelerometer sees of the rigid body struck where it is
        return rigid_body.effective_dynamic_stiffness(spec, s, time_s, film_scale=film_scale, impulse_ns=impulse_ns)
    if pieces is not None and film_scale is None:
        total = pieces.film(spec, time_s)
    elif film_scale is None:
        total = film_stiffness(spec, s, time_s)
    else:
        total = spec.film.stiffness(s, spec.film_parameters) * film_scale
    support = spec.support_stiffness(s) if pieces is None else pieces.support(spec)
    if support is not None:  # the film in series with what it stands on
        total = total * support / (total + support)
    total = total + spec.moving_mass_kg * (s**2 if pieces is None else pieces.s_squared)
    if pieces is None:
        for effect in spec.effects:
            total = total + effect.added_stiffness(s)
    else:  # (an effect that adds no stiffness adds 0.0: skipped; added in place to the new sum)
        for effect in spec.effects:
            if _overrides(type(effect), "added_stiffness"):
                total += pieces.added_stiffness(effect)
    if impulse_ns is not None and (pieces is None or any(_overrides(type(effect), "level_damping_ns_per_m")
                                                         for effect in spec.effects)):
        velocity_m_s = np.abs(np.asarray(impulse_ns, dtype=float)) / spec.moving_mass_kg
        damping = sum(effect.level_damping_ns_per_m(velocity_m_s) for effect in spec.effects)
        total = total + (np.asarray(damping)[..., np.newaxis] if np.ndim(damping) else damping) * s
    return total


def channel_transfer(spec: RigSpec, channel: str, s: np.ndarray) -> np.ndarray:
    """Product of the effects' transfers on one channel ("force" or "acceleration")."""
    s = np.asarray(s, dtype=complex)
    transfer = np.ones_like(s)
    for effect in spec.effects:
        transfer = transfer * effect.channel_transfer(channel, s)
    return transfer


def structure_accelerance(spec: RigSpec, s: np.ndarray) -> np.ndarray | float:
    """Accelerance ((m/s²)/N) of the structure modes beside the mover (modal superposition), 0 without any."""
    total: np.ndarray | float = 0.0
    for effect in spec.effects:
        total = total + effect.added_accelerance(s)
    return total


class GridPieces:
    """The parts of :func:`rig_accelerance` on one grid ``s = σ + j2πf`` that a fit evaluates again and again with
    one parameter changed: the film at the hits' times, each effect's added stiffness, the channel transfers, s².
    Each is remembered under the values it depends on (about :data:`KEPT` of each kind, the least recently used
    forgotten first) and computed exactly as without it, so results are bit-for-bit the same. Effects are frozen
    dataclasses: their values are their key."""

    KEPT = 16

    def __init__(self, freq_hz: np.ndarray, decay_rate_1_s: float) -> None:
        self.freq_hz = freq_hz
        self.decay_rate_1_s = decay_rate_1_s
        self.s = laplace_variable(freq_hz, decay_rate_1_s)
        self.s_squared = self.s**2
        self._kept: dict[tuple, np.ndarray | float] = {}

    def matches(self, freq_hz: np.ndarray, decay_rate_1_s: float) -> bool:
        return freq_hz is self.freq_hz and decay_rate_1_s == self.decay_rate_1_s

    def _remembered(self, key: tuple, compute: Callable[[], np.ndarray | float]) -> np.ndarray | float:
        try:
            value = self._kept.pop(key)
        except KeyError:
            pass
        except TypeError:  # an unhashable effect field: computed every time
            return compute()
        else:  # (kept as the most recently used)
            self._kept[key] = value
            return value
        value = compute()
        if len(self._kept) >= 4 * self.KEPT:
            self._kept.pop(next(iter(self._kept)))
        self._kept[key] = value
        return value

    def film(self, spec: RigSpec, time_s: np.ndarray | float) -> np.ndarray:
        """:func:`film_stiffness` of the spec at ``time_s``."""
        times = time_s.tobytes() if isinstance(time_s, np.ndarray) else float(time_s)
        scaling = tuple(effect for effect in spec.effects if _scales_film(effect))
        parameters = tuple(spec.film_parameters.items())
        key = ("film", spec.film_model, parameters, scaling, times)
        if not scaling:  # the network alone (film_stiffness's × 1.0 and its last-network check spared)
            model = spec.film
            return self._remembered(key, lambda: model.stiffness(self.s, model.vector(spec.film_parameters)))

        def network(viscous: np.ndarray) -> np.ndarray:  # (the same for a change of the whole film's scale alone)
            return self._remembered(("network", spec.film_model, parameters, viscous.tobytes()),
                                    lambda: viscous_network(spec, self.s, viscous))

        return self._remembered(key, lambda: film_stiffness(
            spec, self.s, time_s, self._remembered(("scales", scaling, times), lambda: film_scales(spec, time_s)),
            network))

    def added_stiffness(self, effect: Effect) -> np.ndarray | float:
        return self._remembered(("added", effect), lambda: effect.added_stiffness(self.s))

    def support(self, spec: RigSpec) -> np.ndarray | None:
        """:meth:`RigSpec.support_stiffness` of the spec (None without a support: effects that have none skipped)."""
        supports = tuple(effect for effect in spec.effects if _overrides(type(effect), "support_stiffness"))
        if not supports:
            return None
        return self._remembered(("support", supports), lambda: spec.support_stiffness(self.s))

    def structure(self, spec: RigSpec) -> np.ndarray | float:
        """:func:`structure_accelerance` of the spec (each mode remembered; effects that add none skipped)."""
        total: np.ndarray | float = 0.0
        for effect in spec.effects:
            if _overrides(type(effect), "added_accelerance"):
                total = total + self._remembered(("accelerance", effect), lambda: effect.added_accelerance(self.s))
        return total

    def channel_ratio(self, spec: RigSpec) -> np.ndarray | None:
        """``channel_transfer(acceleration) / channel_transfer(force)``, remembered under the effects that have a
        channel transfer (the others multiply by 1.0); None when none has (the ratio is 1)."""
        transfers = tuple(effect for effect in spec.effects if _overrides(type(effect), "channel_transfer"))
        if not transfers:
            return None
        return self._remembered(("ratio", transfers), lambda: channel_transfer(spec, "acceleration", self.s)
                                / channel_transfer(spec, "force", self.s))


@functools.cache
def _overrides(kind: type, method: str) -> bool:
    """Whether an effect type has its own ``method`` (else it adds nothing: 0.0 stiffness, 1.0 transfer, ...)."""
    return getattr(kind, method) is not getattr(Effect, method)


def _scales_film(effect: Effect) -> bool:
    """Whether the effect scales the film with session time (drift, step changes)."""
    kind = type(effect)
    return kind.film_scale is not Effect.film_scale or kind.viscous_scale is not Effect.viscous_scale


def resonance_omega_rad_s(spec: RigSpec) -> float:
    """Undamped natural frequency (rad/s) of the moving mass on the real part of the film stiffness
    (:meth:`FilmModel.resonance_omega_rad_s`), remembered per film and mass (a fit of a cubic term asks at every
    evaluation)."""
    key = (spec.film_model, tuple(spec.film_parameters.items()), spec.moving_mass_kg)
    omega = _RESONANCES.get(key)
    if omega is None:
        omega = spec.film.resonance_omega_rad_s(spec.film_parameters, spec.moving_mass_kg)
        if len(_RESONANCES) >= 256:
            _RESONANCES.clear()
        _RESONANCES[key] = omega
    return omega


_RESONANCES: dict[tuple, float] = {}


def hit_displacement_m(spec: RigSpec, impulse_ns: np.ndarray | float) -> np.ndarray | float:
    """Initial displacement amplitude ``J / (M ω0)`` of a hit of impulse J (N·s)."""
    return np.asarray(impulse_ns) / (spec.moving_mass_kg * resonance_omega_rad_s(spec))


def rig_accelerance(
    spec: RigSpec,
    freq_hz: np.ndarray,
    decay_rate_1_s: float = 0.0,
    time_s: float = 0.0,
    conditions: HitConditions | None = None,
    pieces: GridPieces | None = None,
) -> np.ndarray:
    """Accelerance (m/s²)/N the channels of ``spec`` show at ``s = σ + j2πf``: (G,), or (hits, G) with ``conditions``.

    Measurement-chain effects are included (channel transfers, force cross-talk). With ``conditions``, every hit sees
    the film at its own session time, and a cubic film spring enters by equivalent linearisation at the hit's level
    (``Δk = CUBIC_EQUIVALENT·k3·x0²``); the exact nonlinear response is :func:`simulate_response`'s. ``pieces``, made
    for this ``freq_hz`` (the same array) and decay rate, remembers parts between calls (a fit's many evaluations).
    """
    if spec.has_term_changes:
        return _changing_accelerance(spec, freq_hz, decay_rate_1_s, time_s, conditions, pieces)
    if pieces is not None and pieces.matches(freq_hz, decay_rate_1_s):
        return accelerance_parts(spec, pieces, time_s, conditions).accelerance
    s = laplace_variable(freq_hz, decay_rate_1_s)
    stiffness = _loaded_stiffness(spec, s, time_s, conditions, None)
    return (s**2 / stiffness + structure_accelerance(spec, s) + spec.force_leak_m_s2_per_n) * (
        channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s))


def _changing_accelerance(
    spec: RigSpec,
    freq_hz: np.ndarray,
    decay_rate_1_s: float,
    time_s: float,
    conditions: HitConditions | None,
    pieces: GridPieces | None,
) -> np.ndarray:
    """:func:`rig_accelerance` of a spec with terms that change between hits: hit by hit, each hit's spec
    (:meth:`RigSpec.at_hit`); without ``conditions``, the spec at ``time_s`` with each level change at its reference."""
    if conditions is None:
        fixed = spec.at_hit(time_s, _reference_impulse_ns(spec))
        return rig_accelerance(fixed, freq_hz, decay_rate_1_s, time_s, pieces=pieces)
    rows = []
    for time, impulse, blow in zip(conditions.time_s, conditions.impulse_ns, conditions.blows):
        hit = HitConditions(time_s=np.array([time]), impulse_ns=np.array([impulse]), blow=np.array([blow]))
        rows.append(rig_accelerance(spec.at_hit(float(time), float(impulse), float(blow)), freq_hz, decay_rate_1_s,
                                    conditions=hit, pieces=pieces)[0])
    return np.array(rows)


def _reference_impulse_ns(spec: RigSpec) -> float:
    """The impulse at which the spec's level changes are 1 (their reference; 1 N·s without any)."""
    return next((effect.reference_impulse_ns for effect in spec.effects if hasattr(effect, "reference_impulse_ns")),
                1.0)


def _loaded_stiffness(
    spec: RigSpec, s: np.ndarray, time_s: float, conditions: HitConditions | None, pieces: GridPieces | None
) -> np.ndarray:
    """The dynamic stiffness :func:`rig_accelerance` divides by: (G,), or (hits, G) with ``conditions`` (each hit's
    film time, amplitude-dependent damping and equivalent cubic spring)."""
    if conditions is None:
        return rig_dynamic_stiffness(spec, s, time_s, pieces=pieces)
    stiffness = rig_dynamic_stiffness(spec, s, conditions.time_s, impulse_ns=conditions.impulse_ns, pieces=pieces)
    k3 = spec.cubic_stiffness_n_per_m3
    if k3:
        stiffness = stiffness + (CUBIC_EQUIVALENT * k3 * hit_displacement_m(spec, conditions.impulse_ns) ** 2)[
            :, np.newaxis]
    if stiffness.shape != (len(conditions.time_s), s.size):
        stiffness = np.broadcast_to(stiffness, (len(conditions.time_s), s.size))
    return stiffness


@dataclass
class AcceleranceParts:
    """:func:`rig_accelerance` on a grid (:class:`GridPieces`) and its parts, ``A = (s²/D + S + L)·R``: the dynamic
    stiffness D, the structure modes' accelerance S, the force leak L and the channel ratio R (None: 1)."""

    accelerance: np.ndarray
    stiffness: np.ndarray
    structure: np.ndarray | float
    leak: float
    ratio: np.ndarray | None
    time_s: float
    conditions: HitConditions | None
    pieces: GridPieces
    _receptance_slope: np.ndarray | None = None
    _film: np.ndarray | None = None

    def change(self, spec: RigSpec, changed: RigSpec, effect_index: int | None) -> np.ndarray | None:
        """The first-order change of the accelerance from ``spec`` (whose parts these are) to ``changed``, a spec that
        differs from it in one film parameter (``effect_index`` None) or in fields of effect ``effect_index``:
        ``ΔA = R·(−s²ΔD/D² + ΔS + ΔL) + (A/R)·ΔR``, only the parts the effect's kind touches evaluated again (a
        fit's forward-difference Jacobian, its columns several times cheaper than whole accelerances). None for an
        effect that changes something else."""
        parts = {"film"} if effect_index is None else _touched_parts(type(spec.effects[effect_index]))
        if parts is None or spec.rigid_body is not None:  # (a rigid body's films do not add to D)
            return None
        if "film" in parts and self.pieces.support(spec) is not None:  # (a film in series does not add to D)
            return None
        pieces = self.pieces
        change: np.ndarray | float = 0.0
        if parts & {"film", "added", "stiffness"}:
            if "stiffness" in parts or ("film" in parts and spec.cubic_stiffness_n_per_m3):
                # (a cubic spring's equivalent stiffness moves with the film's resonance)
                stiffness_change = _loaded_stiffness(changed, pieces.s, self.time_s, self.conditions, pieces) \
                    - self.stiffness
            else:
                stiffness_change = 0.0
                if "film" in parts:
                    times = self.time_s if self.conditions is None else self.conditions.time_s
                    if self._film is None:
                        self._film = pieces.film(spec, times)
                    stiffness_change = pieces.film(changed, times) - self._film
                if "added" in parts:
                    stiffness_change = stiffness_change + (pieces.added_stiffness(changed.effects[effect_index])
                                                           - pieces.added_stiffness(spec.effects[effect_index]))
            if self._receptance_slope is None:  # −s²/D²
                self._receptance_slope = -pieces.s_squared / (self.stiffness * self.stiffness)
            change = self._receptance_slope * stiffness_change
        if "structure" in parts:
            change = change + (pieces.structure(changed) - self.structure)
        if "leak" in parts:
            change = change + (changed.force_leak_m_s2_per_n - self.leak)
        if self.ratio is not None:
            change = change * self.ratio
        if "ratio" in parts:
            ratio = 1.0 if self.ratio is None else self.ratio
            changed_ratio = pieces.channel_ratio(changed)
            change = change + self.accelerance / ratio * ((1.0 if changed_ratio is None else changed_ratio) - ratio)
        return change if np.shape(change) == self.accelerance.shape else np.broadcast_to(change, self.accelerance.shape)


def accelerance_parts(
    spec: RigSpec, pieces: GridPieces, time_s: float = 0.0, conditions: HitConditions | None = None
) -> AcceleranceParts:
    """:func:`rig_accelerance` on the grid of ``pieces``, with its parts (:class:`AcceleranceParts`)."""
    stiffness = _loaded_stiffness(spec, pieces.s, time_s, conditions, pieces)
    # the same sum as rig_accelerance's; terms that are 0.0 and a ratio of 1 skipped (x + 0.0 and x·1 are x, bit for
    # bit) (in place on the new quotient)
    accelerance = pieces.s_squared / stiffness
    structure = pieces.structure(spec)
    if not (isinstance(structure, float) and structure == 0.0):
        accelerance += structure
    leak = spec.force_leak_m_s2_per_n
    if leak != 0.0:
        accelerance += leak
    ratio = pieces.channel_ratio(spec)
    if ratio is not None:
        accelerance *= ratio
    return AcceleranceParts(accelerance, stiffness, structure, leak, ratio, time_s, conditions, pieces)


#: Which part of :class:`AcceleranceParts` each of an effect's physics methods changes: the film's scale, an added
#: stiffness the same for every hit, the rest of the dynamic stiffness, the structure, the leak, the channel ratio.
_PART_OF_METHOD = {
    "film_scale": "film", "viscous_scale": "film", "added_stiffness": "added",
    "added_mass_kg": "stiffness", "cubic_stiffness_n_per_m3": "stiffness", "level_damping_ns_per_m": "stiffness",
    "added_accelerance": "structure", "force_leak_m_s2_per_n": "leak", "channel_transfer": "ratio",
    "support_stiffness": "stiffness",
}
#: Methods that do not enter the accelerance.
_OUTSIDE_ACCELERANCE = ("validate", "interference", "fit_ranges", "implausible", "implausible_in", "evidence",
                        "to_table", "place", "features", "features_on")


@functools.cache
def _touched_parts(kind: type) -> frozenset[str] | None:
    """The parts of the accelerance an effect type's fields change; None when it overrides a method of unknown
    effect (its columns are then whole differences), and for a change between hits (it moves another term hit by
    hit: a spec holding one is evaluated whole)."""
    if issubclass(kind, TermChange):
        return None
    parts = set()
    for name, member in vars(Effect).items():
        if callable(member) and not name.startswith("_") and _overrides(kind, name):
            if name in _PART_OF_METHOD:
                parts.add(_PART_OF_METHOD[name])
            elif name not in _OUTSIDE_ACCELERANCE:
                return None
    return frozenset(parts)


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
    band_limit = 0.5 * (1.0 + np.cos(np.pi * ramp))
    if spec.rigid_body is None:
        accelerances = [s**2 / rig_dynamic_stiffness(spec, s, film_scale=film_scale) + structure_accelerance(spec, s)]
    else:  # every mode of a rigid body shows in a diagonal term of its accelerance matrix
        accelerances = list(rigid_body.diagonal_accelerances(spec, s, film_scale=film_scale)
                            + structure_accelerance(spec, s))
    durations = []
    for accelerance in accelerances:
        impulse = np.abs(scipy.fft.irfft(band_limit * accelerance, n_samples))
        causal = impulse[: n_samples // 2]  # the second half holds the band limit's (zero-phase) ringing before t = 0
        envelope_from_end = np.maximum.accumulate(causal[::-1])[::-1]
        decayed = np.flatnonzero(envelope_from_end < DECAY_TOLERANCE * impulse.max())
        if not decayed.size:
            return MAX_RESPONSE_DURATION_S
        durations.append(min(MAX_RESPONSE_DURATION_S, 1.25 * decayed[0] / sample_rate_hz + 0.01))
    return max(durations)


def mover_displacement_spectrum(
    spec: RigSpec,
    force_spectrum: np.ndarray,
    s: np.ndarray,
    n_samples: int,
    time_s: float = 0.0,
    impulse_ns: float | None = None,
) -> np.ndarray:
    """The mover's displacement spectrum (rfft grid of ``n_samples``) for a force spectrum on the same grid.

    Linear films: ``X = F / Z_total``. With cubic stiffness, the periodic problem ``x + R*(k3·x³) = R*f``
    (``R = 1/Z_total``, ``*`` a circular convolution done by FFT) is solved by damped Newton steps with BiCGSTAB on
    matrix-free Jacobian products ``J v = v + R*(3·k3·x²·v)``, continued from the linear response in steps of k3
    when the full hardening is too strong to reach at once. The grid must be long enough for the response to decay.
    """
    receptance = 1.0 / rig_dynamic_stiffness(spec, s, time_s, impulse_ns=impulse_ns)
    linear = force_spectrum * receptance
    k3 = spec.cubic_stiffness_n_per_m3
    if k3 == 0.0:
        return linear
    x_linear = scipy.fft.irfft(linear, n_samples)
    scale = float(np.max(np.abs(x_linear))) or 1.0

    def apply_receptance(signal: np.ndarray) -> np.ndarray:
        spectrum = scipy.fft.rfft(signal)  # multiplied and inverted in place: no temporary spectra
        spectrum *= receptance
        return scipy.fft.irfft(spectrum, n_samples, overwrite_x=True)

    def residual_norm(displacement: np.ndarray, k3_now: float) -> tuple[np.ndarray, float]:
        # x·x·x, not x**3: numpy raises to the power 3 with pow() per sample, 25× slower than two products
        residual = displacement - x_linear + apply_receptance(k3_now * (displacement * displacement * displacement))
        return residual, float(np.max(np.abs(residual))) / scale

    def newton(k3_now: float, displacement: np.ndarray) -> np.ndarray | None:
        from scipy.sparse.linalg import LinearOperator, bicgstab  # (imported here only: a tenth of a second)

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
    beside_mover = spec.force_leak_m_s2_per_n + structure_accelerance(spec, s)  # both beside the mover's motion
    impulse_ns = force.sum(axis=-1) / sample_rate_hz  # the hit's level, for amplitude-dependent dampers
    if spec.is_linear:
        stiffness = rig_dynamic_stiffness(spec, s, time_s, impulse_ns=impulse_ns)
        response = force_spectrum * (s**2 / stiffness + beside_mover) * delays
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
        displacement = mover_displacement_spectrum(spec, fine_force, s_fine, n_fine, time_s,
                                                   impulse_ns=float(np.ravel(impulse_ns)[row]))
        acceleration = ((s_fine**2 * displacement)[: spectrum.size] / oversampling + beside_mover * spectrum) * delays
        out[row] = scipy.fft.irfft(acceleration, n_fft)[:n_record]
    return out.reshape(force.shape)
