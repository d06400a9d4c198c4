"""The free parameters of a rig spec as a fit sees them: one slot per film parameter or effect field.

A fit varies a vector in search space (logarithm of log-scaled values) and every evaluation is a real
:class:`~gasfilm.analysis.physics.spec.RigSpec` built from it (:meth:`RigSpec.with_values`), so the spec a fit
returns is the spec that is written and replayed: there is no second model of the rig.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from gasfilm.analysis.physics.effects import Effect, FitContext, FitRange, TermChange
from gasfilm.analysis.physics.response import HitConditions, hit_displacement_m, resonance_omega_rad_s
from gasfilm.analysis.physics.spec import RigSpec, film_parameter_range, within_readable_range

#: Relative distance (in the search space's span) within which a fitted value counts as sitting at its bound.
AT_BOUND_FRACTION = 1e-3


@dataclass(frozen=True)
class Slot:
    """One free parameter: ``effect`` None for a film parameter, else the index of the effect in the spec."""

    effect: int | None
    name: str
    range: FitRange

    def label(self, spec: RigSpec) -> str:
        """``name`` for a film parameter, ``type.name`` for an effect's, ``type#n.name`` (n from 1) when the spec has
        several effects of that type (several extra modes)."""
        if self.effect is None:
            return self.name
        type_name = spec.effects[self.effect].type_name
        same = [i for i, effect in enumerate(spec.effects) if effect.type_name == type_name]
        return (f"{type_name}.{self.name}" if len(same) == 1
                else f"{type_name}#{same.index(self.effect) + 1}.{self.name}")

    def unit(self, spec: RigSpec) -> str:
        """The parameter's unit: the film element's, or the effect field's (as the rig spec's reference gives it)."""
        if self.effect is None:
            return next((p.unit for p in spec.film.parameters if p.name == self.name), "")
        fields = {item.name: item for item in dataclasses.fields(spec.effects[self.effect])}
        return str(fields[self.name].metadata.get("unit", "")) if self.name in fields else ""

    def to_search(self, value: float) -> float:
        return float(np.log(value)) if self.range.scale == "log" else float(value)

    def from_search(self, value: float) -> float:
        """The parameter value of a search coordinate, inside its range: exp(log(1e10)) is 1.0000000000000004e10,
        which a spec written with it could not be read back with (the range's bound is the effect's rule)."""
        result = float(np.exp(value)) if self.range.scale == "log" else float(value)
        return min(max(result, self.range.lower), self.range.upper)

    def search_bounds(self) -> tuple[float, float]:
        return self.to_search(self.range.lower), self.to_search(self.range.upper)

    def value(self, spec: RigSpec) -> float:
        if self.effect is None:
            return float(spec.film_parameters[self.name])
        return float(getattr(spec.effects[self.effect], self.name))

    def at_bound(self, spec: RigSpec) -> bool:
        """Whether the fitted value sits at a bound of its range that is not a valid limit of its effect."""
        at_lower, at_upper = at_range_bounds(self.range, self.value(spec))
        effect = None if self.effect is None else type(spec.effects[self.effect])
        open_lower = effect is not None and self.name in effect.open_lower
        open_upper = effect is not None and self.name in effect.open_upper
        return (at_lower and not open_lower) or (at_upper and not open_upper)


def at_range_bounds(fit_range: FitRange, value: float) -> tuple[bool, bool]:
    """Whether ``value`` sits at the lower and at the upper bound of ``fit_range``: within :data:`AT_BOUND_FRACTION`
    of the range's span in its search space (the logarithm's for a "log" range, where a value ≤ 0 is at the lower)."""
    log = fit_range.scale == "log"
    low, high = (float(np.log(fit_range.lower)), float(np.log(fit_range.upper))) if log else (fit_range.lower,
                                                                                              fit_range.upper)
    position = (float(np.log(value)) if value > 0 else low) if log else float(value)
    margin = AT_BOUND_FRACTION * (high - low)
    return position - low <= margin, high - position <= margin


def fit_context(spec: RigSpec, conditions: HitConditions, band_hz: tuple[float, float]) -> FitContext:
    """The physical scales that bound every term in this session (from the spec as given and the hits)."""
    omega = resonance_omega_rad_s(spec)
    stiffness = spec.film.stiffness(np.array([1j * omega]), spec.film_parameters)[0]
    return FitContext(
        mass_kg=spec.moving_mass_kg,
        film_stiffness_n_per_m=float(abs(stiffness)),
        resonance_hz=omega / (2 * np.pi),
        band_hz=(float(band_hz[0]), float(band_hz[1])),
        session_span_s=float(np.ptp(conditions.time_s)) if len(conditions.time_s) else 0.0,
        max_displacement_m=float(np.max(hit_displacement_m(spec, conditions.impulse_ns))),
        film_damping_ratio=float(stiffness.imag / (2 * stiffness.real)) if stiffness.real > 0 else 0.0,
        blow_span=float(np.ptp(conditions.blows)) if len(conditions.time_s) else 0.0,
    )


def film_slots(spec: RigSpec) -> list[Slot]:
    """The film model's own parameters in the ranges the spec reader takes (:func:`film_parameter_range`: the
    element's bounds, and the film resonating with the mass in the supported range; orders linear, everything else
    log-scaled)."""
    slots = []
    for p in spec.film.parameters:
        low, high = film_parameter_range(spec.film, p.name, spec.mass_kg, spec.film_parameters)
        slots.append(Slot(None, p.name, FitRange(p.scale, max(low, 1e-12) if p.scale == "log" else low, high)))
    return slots


def effect_slots(spec: RigSpec, index: int, context: FitContext) -> list[Slot]:
    """The continuously fitted fields of effect ``index`` with their physical ranges in this session, cut to what the
    spec reader takes (:func:`within_readable_range`)."""
    effect = spec.effects[index]
    units = {item.name: str(item.metadata.get("unit", "")) for item in dataclasses.fields(effect)}
    ranges = (effect.fit_ranges_on(spec.effects[effect.term], context) if isinstance(effect, TermChange)
              else effect.fit_ranges(context))
    return [Slot(index, name, within_readable_range(fit_range, units.get(name, "")))
            for name, fit_range in ranges.items()]


def spec_slots(spec: RigSpec, context: FitContext, recalibration: bool = False) -> list[Slot]:
    """Every free parameter of a spec: the film's, then each effect's (ranges widened to hold the current values, so
    a spec a diagnosis wrote is recalibrated from exactly where it is). Effects held after the recalibration (a
    structure's modes: many parameters no candidate term competes with) only with ``recalibration``; film parameters
    the recordings do not determine (``context.held_film``) never."""
    slots = [slot for slot in film_slots(spec) if slot.name not in context.held_film]
    for index, effect in enumerate(spec.effects):
        if recalibration or not type(effect).held_after_recalibration:
            slots.extend(effect_slots(spec, index, context))
    return [_holding_value(slot, slot.value(spec)) for slot in slots]


def _holding_value(slot: Slot, value: float) -> Slot:
    fit_range = slot.range
    if fit_range.scale == "log" and value <= 0:
        return slot
    if fit_range.lower <= value <= fit_range.upper:
        return slot
    return Slot(slot.effect, slot.name, FitRange(fit_range.scale, min(fit_range.lower, value),
                                                  max(fit_range.upper, value)))


def read_vector(spec: RigSpec, slots: list[Slot]) -> np.ndarray:
    """The search-space vector of the slots' current values, clipped into their bounds."""
    values = []
    for slot in slots:
        low, high = slot.search_bounds()
        value = slot.value(spec)
        search = low if slot.range.scale == "log" and value <= 0 else slot.to_search(value)
        values.append(float(np.clip(search, low, high)))
    return np.array(values)


def write_vector(spec: RigSpec, slots: list[Slot], vector: np.ndarray) -> RigSpec:
    """The spec with the slots set from a search-space vector (not re-validated: the ranges keep it physical)."""
    film = dict(spec.film_parameters)
    changes: dict[int, dict[str, float]] = {}
    for slot, value in zip(slots, vector):
        if slot.effect is None:
            film[slot.name] = slot.from_search(value)
        else:
            changes.setdefault(slot.effect, {})[slot.name] = slot.from_search(value)
    effects = [dataclasses.replace(effect, **changes[index]) if index in changes else effect
               for index, effect in enumerate(spec.effects)]
    return spec.with_values(film_parameters=film, effects=effects)


def with_slot(spec: RigSpec, slot: Slot, value: float) -> RigSpec:
    """The spec with one slot set to a value (as :func:`write_vector` sets it)."""
    if slot.effect is None:
        return spec.with_values(film_parameters={**spec.film_parameters, slot.name: value})
    effects = list(spec.effects)
    effects[slot.effect] = dataclasses.replace(effects[slot.effect], **{slot.name: value})
    return spec.with_values(effects=effects)


def with_effect(spec: RigSpec, effect: Effect) -> RigSpec:
    return spec.with_values(effects=(*spec.effects, effect))


def removed_with(spec: RigSpec, index: int) -> set[int]:
    """The indices :func:`without_effect` takes out with effect ``index``: it and the changes that act on it."""
    return {index} | {i for i, effect in enumerate(spec.effects) if isinstance(effect, TermChange) and effect.term == index}


def kept_positions(spec: RigSpec, index: int) -> dict[int, int]:
    """Where each effect :func:`without_effect` keeps stands in the spec it returns: index in ``spec`` → index there
    (the effects it takes out, :func:`removed_with`, are not keys)."""
    gone = removed_with(spec, index)
    return {old: new for new, old in enumerate(i for i in range(len(spec.effects)) if i not in gone)}


def without_effect(spec: RigSpec, index: int) -> RigSpec:
    """The spec less effect ``index`` and less the changes between hits that act on it; the other changes keep
    pointing at their terms."""
    position = kept_positions(spec, index)
    return spec.with_values(effects=[
        dataclasses.replace(effect, term=position[effect.term]) if isinstance(effect, TermChange) else effect
        for i, effect in enumerate(spec.effects) if i in position])
