"""Film parameters as laws of the operating conditions (``[film.conditions]`` and ``[film.laws.*]`` of a rig spec).

A rig spec's ``film.parameters`` hold at its reference conditions ``film.conditions`` (e.g. supply pressure 0.4 MPa,
gap 10 µm). A law makes one coefficient follow the conditions as a power law,

    value(c) = value_ref · Π_key (c_key / c_key,ref) ^ exponent_key,

the scaling of an orifice-compensated aerostatic bearing: its static stiffness grows about in proportion to the
supply pressure and falls as 1/h with the gap, and its squeeze-film damping grows about as 1/h³ (Reynolds equation)
and falls with the supply pressure as the film stiffens (the paper's Figures 3–4, after Zhu [41]: supply pressure
and film thickness change the stiffness and, strongly, the low- and mid-frequency damping). ``docs/rig-spec.md``
gives the law, its source and the shipped example ``fixtures/rigs/fomgf-laws.toml``.

Re-basing a power law onto new reference conditions does not change it, so :func:`film_at_conditions` returns the
values at the given conditions *as* the new reference: a spec played at an operating point still carries its laws.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from gasfilm.drivers.errors import SettingError

#: Largest exponent magnitude of a law (beyond it a small change of a condition moves the film out of range).
MAX_EXPONENT = 10.0


def law_value(reference_value: float, reference: Mapping[str, float], exponents: Mapping[str, float],
              conditions: Mapping[str, float]) -> float:
    """One coefficient at ``conditions`` by its power law (keys of ``exponents`` must be in both tables)."""
    value = float(reference_value)
    for key, exponent in exponents.items():
        value *= (float(conditions[key]) / float(reference[key])) ** float(exponent)
    return value


def law_keys(laws: Mapping[str, Mapping[str, float]]) -> list[str]:
    """Every condition some law depends on, in first-use order."""
    keys: list[str] = []
    for exponents in laws.values():
        keys.extend(key for key in exponents if key not in keys)
    return keys


def played_at(spec: Any, conditions: Mapping[str, Any]) -> tuple[Any, dict[str, Any], dict[str, float]]:
    """How the simulator plays a rig spec at an operating point: the spec at ``conditions``, the conditions to store
    with the session, and those of them taken from the spec's reference because the film laws need them and
    ``conditions`` lacks them (they are stored too, so the session says where its film was)."""
    missing = {key: spec.film_conditions[key] for key in law_keys(spec.film_laws) if key not in conditions}
    conditions = {**conditions, **missing}
    return spec.at_conditions(conditions), conditions, missing


def film_at_conditions(parameters: Mapping[str, float], reference: Mapping[str, float],
                       laws: Mapping[str, Mapping[str, float]], conditions: Mapping[str, object],
                       source: str = "rig spec") -> tuple[dict[str, float], dict[str, float]]:
    """The film parameters at ``conditions`` and the reference conditions they now hold at.

    A condition the laws need and ``conditions`` lack stays at its reference value. A condition that is not a
    positive number is refused with one line naming it and ``source``."""
    values = dict(parameters)
    new_reference = dict(reference)
    for key in law_keys(laws):
        if key not in conditions:
            continue
        value = conditions[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise SettingError(f"{source}: operating condition {key} = {value!r}: the film's laws need a positive "
                               f"number")
        new_reference[key] = float(value)
    for name, exponents in laws.items():
        values[name] = law_value(parameters[name], reference, exponents, new_reference)
    return values, new_reference
