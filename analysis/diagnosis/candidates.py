"""Which effects the diagnosis may add to a spec, and where a fit of each starts.

The effects themselves (parameters, physical ranges, physics, explanation, evidence) are defined once in
:mod:`gasfilm.analysis.physics.effects`; this module only lists the candidates in order of preference (fewest
parameters first, for ties) and proposes starting values from the current spec and the shape of the residual.
Effects that cannot be told apart from the data are listed in :data:`EQUIVALENT`, with the measurement that would.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from gasfilm.analysis.physics.effects import (
    CUBIC_EQUIVALENT,
    AcCoupling,
    AddedMass,
    ChannelDelay,
    CrossTalk,
    CubicStiffness,
    Drift,
    Effect,
    ExtraMode,
    FilmMemory,
    FitContext,
    PneumaticLag,
    StepChange,
)
from gasfilm.analysis.physics.spec import RigSpec

if TYPE_CHECKING:
    from gasfilm.analysis.diagnosis.selection import Evidence

#: Forward-selection candidates in order of preference when they explain the data equally well.
CANDIDATES: tuple[str, ...] = (
    "added-mass",
    "channel-delay",
    "drift",
    "step-change",
    "cubic-stiffness",
    "ac-coupling",
    "cross-talk",
    "film-memory",
    "pneumatic-lag",
    "extra-mode",
)

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
    frozenset({"film-memory", "pneumatic-lag"}): "a wider analysis band (a softer or harder hammer tip)",
    frozenset({"extra-mode", "film-memory"}): "a second accelerometer elsewhere on the mover",
    frozenset({"cross-talk", "added-mass"}): "a recording with the hammer resting on the mover (no impact)",
}


def separating_measurement(first: str, second: str) -> str:
    return SEPARATING_MEASUREMENT.get(frozenset({first, second}),
                                      "a repeat with a different hammer tip and force level")


def starting_effects(identifier: str, spec: RigSpec, evidence: "Evidence", context: FitContext) -> list[Effect]:
    """Starting values for a candidate term, from the current spec and the shape of the residual."""
    resonance_hz = context.resonance_hz
    film = context.film_stiffness_n_per_m
    if identifier == "added-mass":
        return [AddedMass(mass_kg=0.01 * context.mass_kg), AddedMass(mass_kg=-0.01 * context.mass_kg)]
    if identifier == "channel-delay":
        return [ChannelDelay(channel="acceleration", delay_s=1e-6)]
    if identifier == "drift":
        return [Drift(fraction_per_hour=0.0, damping_fraction_per_hour=0.0)]
    if identifier == "step-change":
        return [StepChange(at_time_s=at_time_s, fraction=0.0, damping_fraction=0.0)
                for at_time_s in _likely_step_times(spec, evidence)]
    if identifier == "cubic-stiffness":
        limit = film / (CUBIC_EQUIVALENT * context.max_displacement_m**2)
        return [CubicStiffness(k3_n_per_m3=sign * 1e-3 * limit) for sign in (1.0, -1.0)]
    if identifier == "ac-coupling":
        return [AcCoupling(channel="acceleration", corner_hz=factor * context.band_hz[0]) for factor in (0.05, 0.3)]
    if identifier == "cross-talk":
        return [CrossTalk(leak_m_s2_per_n=sign * 1e-3 / context.mass_kg) for sign in (1.0, -1.0)]
    if identifier == "film-memory":
        omega = 2 * np.pi * resonance_hz
        return [FilmMemory(k_memory=k_factor * film, eta_memory=0.01 * film / omega**alpha, alpha_memory=alpha)
                for alpha, k_factor in ((0.3, 0.1), (0.8, 1.0), (1.5, 100.0))]
    if identifier == "pneumatic-lag":
        return [PneumaticLag(k_lag=0.01 * film, tau_lag=factor / (2 * np.pi * resonance_hz)) for factor in (0.3, 1, 3)]
    if identifier == "extra-mode":
        freq_hz = evidence.freq_hz
        excess = evidence.chi2_per_frequency(spec)
        smooth = np.convolve(excess, np.ones(5) / 5, mode="same")
        picks: list[float] = []
        for index in np.argsort(smooth)[::-1]:
            candidate = float(freq_hz[index])
            if all(abs(candidate - p) > 0.05 * p for p in picks) and abs(candidate - resonance_hz) > 0.1 * resonance_hz:
                picks.append(candidate)
            if len(picks) == 3:
                break
        return [ExtraMode(freq_hz=f, damping_ratio=0.02, mass_kg=0.002 * context.mass_kg) for f in picks]
    raise KeyError(identifier)



def _likely_step_times(spec: RigSpec, evidence: "Evidence", count: int = 3) -> list[float]:
    """Moments between hits where a step best explains how the hits' residuals differ (a least-squares two-level fit
    of each hit's mean residual, in time order), best first; at least two hits on each side."""
    conditions = evidence.spectra.conditions
    order = np.argsort(conditions.time_s, kind="stable")
    times = conditions.time_s[order]
    if times.size < 4:
        return []
    predicted = evidence.predicted(spec)
    weight = evidence.spectra.weight[order]
    residual = (evidence.spectra.h[order] - (predicted[order] if predicted.ndim == 2 else predicted)) * np.sqrt(weight)
    costs = []
    for split in range(2, times.size - 1):
        if times[split] == times[split - 1]:
            continue
        before, after = residual[:split], residual[split:]
        cost = float(np.sum(np.abs(before - before.mean(axis=0)) ** 2) + np.sum(np.abs(after - after.mean(axis=0)) ** 2))
        costs.append((cost, float(0.5 * (times[split - 1] + times[split]))))
    return [at_time_s for _, at_time_s in sorted(costs)[:count]]
