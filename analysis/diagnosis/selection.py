"""Weighted fits of the augmented model and forward selection of effects on held-out hits.

The misfit of a model is ``χ² = Σ_i Σ_f |H_i(f) − M_i(f)|² / v_i(f)`` over hits i and analysis frequencies f, with
``v_i`` the measured noise variance of hit i's FRF. When no effect varies from hit to hit it equals
``Σ_f W(f) |H̄(f) − M(f)|²`` plus a constant (H̄ the weighted mean = H1, W the summed weight), which is what is fitted
then: twenty times fewer numbers. A term enters the model only when it lowers χ² by more than its BIC cost on all
hits *and* lowers it on hits that were not used to fit it (odd hits predict even hits and the reverse).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from gasfilm.analysis.diagnosis.catalog import (
    CATALOG,
    AugmentedModel,
    HitConditions,
    ParameterSlot,
    effect_slots,
    film_slots,
    read_slots,
    write_slots,
)
from gasfilm.analysis.diagnosis.measurement import HitSpectra

#: Held-out improvement (χ² units, both folds together) a new term must reach.
HELD_OUT_THRESHOLD = 25.0
#: Extra χ² margin on top of the BIC penalty p·ln(N).
BIC_MARGIN = 10.0


@dataclass
class FitOutcome:
    model: AugmentedModel
    chi2: float
    slots: list[ParameterSlot]
    covariance: np.ndarray  # in search space
    evaluations: int

    def uncertainty(self, slot_index: int) -> float:
        """One standard deviation of a slot in its natural unit."""
        slot = self.slots[slot_index]
        sigma = float(np.sqrt(max(self.covariance[slot_index, slot_index], 0.0)))
        value = read_slots(self.model, [slot])[0]
        return float(slot.from_search(value) * sigma) if slot.scale == "log" else sigma


class Evidence:
    """The measured per-hit FRFs and weights on the analysis grid, with the sums needed for fast χ²."""

    def __init__(self, spectra: HitSpectra) -> None:
        self.spectra = spectra
        self.freq_hz = spectra.freq_hz
        self.decay_rate_1_s = spectra.decay_rate_1_s
        self.hit_count = spectra.h.shape[0]
        self.point_count = 2 * spectra.h.size

    def _subset(self, hits: np.ndarray | None) -> np.ndarray:
        return np.arange(self.hit_count) if hits is None else hits

    def conditions(self, hits: np.ndarray) -> HitConditions:
        c = self.spectra.conditions
        return HitConditions(c.time_s[hits], c.impulse_ns[hits]) if len(hits) != len(c.time_s) else c

    def per_hit(self, model: AugmentedModel) -> bool:
        return any(CATALOG[e].per_hit for e in model.effects)

    def residual(self, model: AugmentedModel, hits: np.ndarray | None = None) -> np.ndarray:
        """Weighted residual vector (real and imaginary parts) whose squared norm is χ² up to a constant."""
        hits = self._subset(hits)
        if self.per_hit(model):
            predicted = model.accelerance(self.freq_hz, self.decay_rate_1_s, self.spectra.conditions)[hits]
            difference = (self.spectra.h[hits] - predicted) * np.sqrt(self.spectra.weight[hits])
        else:
            mean, total = self.spectra.mean(hits)
            difference = (mean - model.accelerance(self.freq_hz, self.decay_rate_1_s)) * np.sqrt(total)
        return np.concatenate((difference.real.ravel(), difference.imag.ravel()))

    def scatter_constant(self, hits: np.ndarray | None = None) -> float:
        """``Σ_i w_i |H_i − H̄|²``: the part of χ² no hit-independent model can remove."""
        hits = self._subset(hits)
        mean, _ = self.spectra.mean(hits)
        return float(np.sum(self.spectra.weight[hits] * np.abs(self.spectra.h[hits] - mean) ** 2))

    def chi2(self, model: AugmentedModel, hits: np.ndarray | None = None) -> float:
        value = float(np.sum(self.residual(model, hits) ** 2))
        return value if self.per_hit(model) else value + self.scatter_constant(hits)

    def chi2_per_frequency(self, model: AugmentedModel) -> np.ndarray:
        """χ² contribution of every analysis frequency (summed over hits)."""
        predicted = model.accelerance(self.freq_hz, self.decay_rate_1_s, self.spectra.conditions)
        if predicted.ndim == 1:
            predicted = predicted[np.newaxis, :]
        return np.sum(self.spectra.weight * np.abs(self.spectra.h - predicted) ** 2, axis=0)

    def mean_prediction(self, model: AugmentedModel) -> np.ndarray:
        """The model's FRF averaged over hits the way H1 averages the measurement."""
        predicted = model.accelerance(self.freq_hz, self.decay_rate_1_s, self.spectra.conditions)
        if predicted.ndim == 1:
            return predicted
        weight = self.spectra.weight
        return (weight * predicted).sum(axis=0) / weight.sum(axis=0)


def fit(
    evidence: Evidence,
    model: AugmentedModel,
    slots: list[ParameterSlot],
    hits: np.ndarray | None = None,
) -> FitOutcome:
    """Weighted least squares of the slots (scaled search space) from the model's current values."""
    if not slots:
        return FitOutcome(model, evidence.chi2(model, hits), [], np.zeros((0, 0)), 1)
    start = read_slots(model, slots)
    bounds = np.array([slot.search_bounds() for slot in slots]).T

    def residual(vector: np.ndarray) -> np.ndarray:
        return evidence.residual(write_slots(model, slots, np.clip(vector, bounds[0], bounds[1])), hits)

    # MINPACK's Levenberg-Marquardt (bounds by clipping inside the residual): several times faster than a
    # bounded trust-region solver on these tall problems
    result = least_squares(residual, start, x_scale="jac", method="lm", max_nfev=40 * (len(slots) + 1),
                           xtol=1e-9, ftol=1e-9)
    fitted = write_slots(model, slots, np.clip(result.x, bounds[0], bounds[1]))
    covariance = _covariance(result.jac)
    return FitOutcome(fitted, evidence.chi2(fitted, hits), slots, covariance, int(result.nfev))


def _covariance(jacobian: np.ndarray) -> np.ndarray:
    """``(JᵀJ)⁻¹`` with the columns equilibrated first (parameters of very different sensitivity)."""
    norms = np.linalg.norm(jacobian, axis=0)
    norms[norms == 0] = 1.0
    scaled = jacobian / norms
    inverse = np.linalg.pinv(scaled.T @ scaled, rcond=1e-12)
    return inverse / np.outer(norms, norms)


def model_slots(model: AugmentedModel, free_film: bool = True) -> list[ParameterSlot]:
    slots = film_slots(model) if free_film else []
    for identifier in model.effects:
        slots.extend(effect_slots(identifier))
    return slots


def initial_guesses(identifier: str, evidence: Evidence, model: AugmentedModel) -> list[dict[str, float]]:
    """Starting values for a candidate term, chosen from the current model and the shape of the residual."""
    freq_hz = evidence.freq_hz
    resonance_hz = float(freq_hz[np.argmax(np.abs(evidence.mean_prediction(model)))])
    s0 = 2j * np.pi * resonance_hz
    film_stiffness = float(np.abs(model.film.stiffness(np.array([s0]), model.film_parameters))[0])
    if identifier == "film-memory":
        omega = 2 * np.pi * resonance_hz
        return [
            {"k_memory": k_factor * film_stiffness, "eta_memory": 0.01 * film_stiffness / omega**alpha,
             "alpha_memory": alpha}
            for alpha in (0.3, 0.8, 1.5) for k_factor in (0.1, 100.0)
        ]
    if identifier == "pneumatic-lag":
        return [
            {"k_lag": 0.01 * film_stiffness, "tau_lag": factor / (2 * np.pi * resonance_hz)}
            for factor in (0.3, 1.0, 3.0)
        ]
    if identifier == "extra-mode":
        excess = evidence.chi2_per_frequency(model)
        smooth = np.convolve(excess, np.ones(5) / 5, mode="same")
        order = np.argsort(smooth)[::-1]
        picks: list[float] = []
        for index in order:
            if all(abs(freq_hz[index] - p) > 0.05 * p for p in picks) and abs(freq_hz[index] - resonance_hz) > 0.1 * resonance_hz:
                picks.append(float(freq_hz[index]))
            if len(picks) == 3:
                break
        return [{"freq_hz": f, "damping_ratio": 0.02, "mass_kg": 0.002 * model.mass_kg} for f in picks]
    if identifier == "ac-coupling":
        return [{"corner_hz": factor * float(freq_hz[0])} for factor in (0.05, 0.3)]
    return [{parameter.name: 0.0 for parameter in CATALOG[identifier].parameters}]


@dataclass
class Step:
    """One accepted term of the forward selection: χ² before and after it, and its gain on held-out hits."""

    identifier: str
    chi2_before: float
    chi2_after: float
    held_out_gain: float


def bic(chi2: float, parameter_count: int, point_count: int) -> float:
    return chi2 + parameter_count * np.log(point_count)


def _with_candidate(model: AugmentedModel, identifier: str, guess: dict[str, float]) -> AugmentedModel:
    candidate = model.copy()
    candidate.effects[identifier] = dict(guess)
    return candidate


def held_out_gain(
    base_evidence: Evidence, base: AugmentedModel, augmented_evidence: Evidence, augmented: AugmentedModel
) -> float:
    """χ² improvement of ``augmented`` over ``base`` on hits not used to fit either (two folds, summed); each model
    is judged on the evidence replayed with it."""
    hits = np.arange(base_evidence.hit_count)
    folds = (hits[0::2], hits[1::2])
    gain = 0.0
    for train, test in (folds, folds[::-1]):
        base_fit = fit(base_evidence, base, model_slots(base), train)
        augmented_fit = fit(augmented_evidence, augmented, model_slots(augmented), train)
        gain += base_evidence.chi2(base_fit.model, test) - augmented_evidence.chi2(augmented_fit.model, test)
    return gain


def best_candidate_fit(
    evidence: Evidence, model: AugmentedModel, identifier: str
) -> FitOutcome:
    """The best full-data fit of the current model plus one candidate term over its starting values."""
    outcomes = []
    for guess in initial_guesses(identifier, evidence, model):
        candidate = _with_candidate(model, identifier, guess)
        outcomes.append(fit(evidence, candidate, model_slots(candidate)))
    return min(outcomes, key=lambda outcome: outcome.chi2)
