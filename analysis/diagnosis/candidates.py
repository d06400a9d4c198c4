"""Which effects the diagnosis may add to a spec, and where a fit of each starts.

The effects themselves (parameters, physical ranges, physics, explanation, evidence) are defined once in
:mod:`gasfilm.analysis.physics.effects`; this module only lists the candidates in order of preference (fewest
parameters first, for ties) and proposes starting values from the current spec and the shape of the residual.
Effects that cannot be told apart from the data are listed in :data:`EQUIVALENT`, with the measurement that would.
"""

from __future__ import annotations

from gasfilm.analysis.physics.effects import Effect
from gasfilm.analysis.physics.spec import RigSpec

#: Forward-selection candidates in order of preference when they explain the data equally well.
CANDIDATES: tuple[str, ...] = (
    "added-mass",
    "channel-delay",
    "drift",
    "step-change",
    "cubic-stiffness",
    "friction",
    "quadratic-damping",
    "ac-coupling",
    "cross-talk",
    "film-memory",
    "squeeze-film",
    "pneumatic-lag",
    "extra-mode",
    "support-mode",
)


#: Generic descriptions of a place in the chain, tried for what the catalog's terms leave beyond the noise (fewest
#: parameters first): a power law or a first-order factor of the chain, a branch of the film, a resonance of a channel,
#: a mode beside the mover.
GENERIC_DESCRIPTIONS: tuple[str, ...] = ("channel-power-law", "channel-pole-zero", "film-branch", "channel-resonance",
                                         "side-mode")


#: Changes between hits of a term already in the spec (any of its fitted values, with session time or hit level, or
#: the term from one moment on): tried when the hits differ from each other beyond the noise about the spec.
TERM_CHANGES: tuple[str, ...] = ("term-drift", "term-level", "term-onset")


def candidates_for(spec: RigSpec) -> tuple[str, ...]:
    """The candidates for ``spec``: :data:`CANDIDATES`, and a sensitivity error when part of the spec's accelerance
    lies beside the mover (a measured structure's modes): a uniform gain then scales those parts too, which no mass
    change does, so it is a candidate of its own rather than the exact equivalent of an added mass
    (:data:`EQUIVALENT`)."""
    if gain_is_not_a_mass(spec):
        return (*CANDIDATES, "sensitivity-error")
    return CANDIDATES


def gain_is_not_a_mass(spec: RigSpec) -> bool:
    """Whether part of the spec's accelerance lies beside the mover (an ``added_accelerance``: structure modes)."""
    return any(type(effect).added_accelerance is not Effect.added_accelerance for effect in spec.effects)


#: Explanations the recordings cannot tell apart whatever their noise, and the measurement that would separate them:
#: a uniform sensitivity error ``δ`` scales the FRF exactly as a mass ``M/(1+δ)`` on a film ``Z/(1+δ)`` does.
EQUIVALENT: dict[str, tuple[str, str]] = {
    "added-mass": ("sensitivity-error",
                   "a calibration check of the accelerometer and hammer sensitivities, or a test with a known added "
                   "mass, would tell a mass change from a sensitivity error"),
}

#: What measurement tells close alternatives apart, by pair of effect types (order irrelevant).
SEPARATING_MEASUREMENT: dict[frozenset[str], str] = {
    frozenset({"drift", "step-change"}): "more hits spread evenly over the session (or a log of the supply pressure)",
    frozenset({"friction", "quadratic-damping"}): "hits over a wider range of force levels",
    frozenset({"friction", "cubic-stiffness"}): "hits over a wider range of force levels",
    frozenset({"quadratic-damping", "cubic-stiffness"}): "hits over a wider range of force levels",
    frozenset({"film-memory", "pneumatic-lag"}): "a wider analysis band (a softer or harder hammer tip)",
    frozenset({"film-memory", "squeeze-film"}): "a test at another gap or supply pressure (a squeeze film scales "
                                                "with the gap as h0⁻¹ and h0⁻²)",
    frozenset({"extra-mode", "film-memory"}): "a second accelerometer elsewhere on the mover",
    frozenset({"extra-mode", "support-mode"}): "an accelerometer on what the bearing stands on (a support mode moves "
                                               "it most; a part on the mover does not move it)",
    frozenset({"cross-talk", "added-mass"}): "a recording with the hammer resting on the mover (no impact)",
}


def separating_measurement(first: str, second: str) -> str:
    return SEPARATING_MEASUREMENT.get(frozenset({first, second}),
                                      "a repeat with a different hammer tip and force level")
