"""Weighted fits of rig specs to the recordings and the statistics that decide whether a term earns its place.

The misfit of a spec is ``χ² = Σ_i Σ_f |H_i(f) − M_i(f)|² / v_i(f)`` over hits i and analysis frequencies f, with
``v_i`` the measured noise variance of hit i's FRF and ``M_i`` the spec's accelerance for that hit
(:func:`gasfilm.analysis.physics.response.rig_accelerance`). When the spec is the same for every hit it equals
``Σ_f W(f) |H̄(f) − M(f)|²`` plus a constant (H̄ the weighted mean = H1, W the summed weight), which is what is fitted
then: twenty times fewer numbers. A term enters only when it lowers χ² by more than its BIC cost on all hits *and*
lowers it on hits that were not used to fit it (odd hits predict even hits and the reverse).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import leastsq

from gasfilm.analysis.diagnosis.fitspace import Slot, read_vector, spec_slots, with_effect, with_slot, write_vector
from gasfilm.analysis.diagnosis.measurement import HitSpectra
from gasfilm.analysis.diagnosis.parallel import shared_map
from gasfilm.analysis.physics.effects import (
    AIR_PRESSURE_PA,
    AIR_VISCOSITY_PA_S,
    CUBIC_EQUIVALENT,
    DRIFT_CLOCKS,
    AcCoupling,
    AddedMass,
    ChannelDelay,
    ChannelPoleZero,
    ChannelPowerLaw,
    ChannelResonance,
    CrossTalk,
    CubicStiffness,
    Drift,
    Effect,
    ExtraMode,
    FilmBranch,
    FilmMemory,
    FitContext,
    Friction,
    PneumaticLag,
    QuadraticDamping,
    SensitivityError,
    SideMode,
    StepChange,
    SqueezeFilm,
    SupportMode,
    TermChange,
    TermDrift,
    TermLevel,
    TermOnset,
)
from gasfilm.analysis.physics.response import (
    AcceleranceParts,
    GridPieces,
    HitConditions,
    accelerance_parts,
    rig_accelerance,
)
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import GasfilmError


#: Held-out improvement (χ² units, both folds together, in units of the noise scale) a new term must reach.
HELD_OUT_THRESHOLD = 25.0
#: Extra χ² margin on top of the BIC penalty p·ln(N).
BIC_MARGIN = 10.0


def _hits_key(hits: np.ndarray | None) -> tuple[int, ...] | None:
    """A subset of hits as a dictionary key (None: every hit)."""
    return None if hits is None else tuple(int(i) for i in hits)


def _weighted_parts(values: np.ndarray, factor: np.ndarray, out: np.ndarray) -> None:
    """The real parts, then the imaginary parts of ``values`` (hits, G), each times ``factor``, written into the
    first ``2·values.size`` entries of ``out``."""
    size = values.size
    np.multiply(values.real, factor, out=out[:size].reshape(values.shape))
    np.multiply(values.imag, factor, out=out[size:2 * size].reshape(values.shape))


def model_function(spec: RigSpec, conditions: HitConditions) -> Callable[[np.ndarray, float], np.ndarray]:
    """``(freq_hz, σ) → accelerance`` of the spec: per hit when the spec differs between hits, else one curve."""
    if spec.is_per_hit:
        return lambda freq_hz, decay_rate_1_s: rig_accelerance(spec, freq_hz, decay_rate_1_s, conditions=conditions)
    return lambda freq_hz, decay_rate_1_s: rig_accelerance(spec, freq_hz, decay_rate_1_s)


@dataclass
class FitOutcome:
    spec: RigSpec
    chi2: float
    slots: list[Slot]
    covariance: np.ndarray  # in search space
    evaluations: int

    def uncertainty(self, slot_index: int) -> float:
        """One standard deviation of a slot in its natural unit."""
        slot = self.slots[slot_index]
        sigma = float(np.sqrt(max(self.covariance[slot_index, slot_index], 0.0)))
        return float(slot.value(self.spec) * sigma) if slot.range.scale == "log" else sigma


class Evidence:
    """The measured per-hit FRFs and weights on the analysis grid, with the sums needed for fast χ².

    Late-triggered records (``spectra.missing_fronts``) each have their missing front profiled out of every comparison
    (variable projection: two real least-squares coefficients per such hit, the front's impulse and its timing within
    its prior, their degrees of freedom taken from ``point_count``); χ² is then summed hit by hit."""

    def __init__(self, spectra: HitSpectra) -> None:
        self.spectra = spectra
        self.freq_hz = spectra.freq_hz
        self.decay_rate_1_s = spectra.decay_rate_1_s
        self.hit_count = spectra.h.shape[0]
        fronts = spectra.missing_fronts
        self.point_count = 2 * spectra.h.size - (0 if fronts is None else fronts.parameter_count)
        self._means: dict[tuple[int, ...] | None, tuple[np.ndarray, np.ndarray]] = {}
        self._rows: dict[tuple[int, ...] | None, tuple[np.ndarray, np.ndarray]] = {}
        self._negative_rows: dict[tuple[int, ...] | None, np.ndarray] = {}
        self._pieces = GridPieces(self.freq_hz, self.decay_rate_1_s)

    def _subset(self, hits: np.ndarray | None) -> np.ndarray:
        return np.arange(self.hit_count) if hits is None else hits

    def _mean(self, hits: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean FRF and total weight of a subset of hits (remembered: a fit asks for it at every step)."""
        key = _hits_key(hits)
        if key not in self._means:
            self._means[key] = self.spectra.mean(hits)
        return self._means[key]

    def _hit_rows(self, hits: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The per-hit FRFs of a subset of hits and the square roots of their weights (remembered likewise)."""
        key = _hits_key(hits)
        if key not in self._rows:
            rows = self._subset(hits)
            self._rows[key] = (self.spectra.h[rows], np.sqrt(self.spectra.weight[rows]))
        return self._rows[key]

    def of_hits(self, hits: np.ndarray) -> "Evidence":
        """The same evidence for a subset of the hits (indices into the hits)."""
        fronts = self.spectra.missing_fronts
        spectra = dataclasses.replace(self.spectra, h=self.spectra.h[hits], variance=self.spectra.variance[hits],
                                      conditions=self.spectra.conditions.subset(hits),
                                      hit_numbers=self.spectra.hit_numbers[hits], replay=None,
                                      missing_fronts=None if fronts is None else fronts.subset(hits=hits))
        return Evidence(spectra)

    def restricted(self, lines: np.ndarray) -> "Evidence":
        """The same evidence on a subset of the analysis frequencies (indices into ``freq_hz``)."""
        fronts = self.spectra.missing_fronts
        spectra = dataclasses.replace(self.spectra, freq_hz=self.freq_hz[lines], h=self.spectra.h[:, lines],
                                      variance=self.spectra.variance[:, lines], replay=None,
                                      missing_fronts=None if fronts is None else fronts.subset(lines=lines))
        return Evidence(spectra)

    def predicted(self, spec: RigSpec, hits: np.ndarray | None = None) -> np.ndarray:
        """The spec's accelerance on the grid: (hits, G) when it differs between hits, else (G,)."""
        if not spec.is_per_hit:
            return rig_accelerance(spec, self.freq_hz, self.decay_rate_1_s, pieces=self._pieces)
        conditions = self.spectra.conditions
        if hits is not None:
            conditions = conditions.subset(hits)
        return rig_accelerance(spec, self.freq_hz, self.decay_rate_1_s, conditions=conditions, pieces=self._pieces)

    def predicted_parts(self, spec: RigSpec, hits: np.ndarray | None = None) -> AcceleranceParts | None:
        """:meth:`predicted` with its parts (for first-order changes, :meth:`AcceleranceParts.change`); None with
        late-triggered records (their profiled residual is not linear in the prediction)."""
        if self.spectra.missing_fronts is not None or spec.has_term_changes:
            return None
        if not spec.is_per_hit:
            return accelerance_parts(spec, self._pieces)
        conditions = self.spectra.conditions
        return accelerance_parts(spec, self._pieces, conditions=conditions if hits is None else conditions.subset(hits))

    def residual_change(
        self, change: np.ndarray, spec: RigSpec, hits: np.ndarray | None = None, out: np.ndarray | None = None
    ) -> np.ndarray:
        """The change of :meth:`residual` for a change of the prediction (late-triggered records excepted), written
        into ``out`` when given."""
        if spec.is_per_hit:
            negative_sqrt_weight = self._negative_sqrt_weights(hits)
        else:
            negative_sqrt_weight = -np.sqrt(self._mean(hits)[1])
        vector = np.empty(2 * change.size) if out is None else out
        _weighted_parts(change, negative_sqrt_weight, vector)
        return vector

    def _negative_sqrt_weights(self, hits: np.ndarray | None) -> np.ndarray:
        """−√weight of a subset of hits (remembered): the residual falls as the prediction rises."""
        key = _hits_key(hits)
        if key not in self._negative_rows:
            self._negative_rows[key] = -self._hit_rows(hits)[1]
        return self._negative_rows[key]

    def _hit_by_hit(self, spec: RigSpec) -> bool:
        """Whether χ² is summed hit by hit (a spec that differs between hits, or a missing front per late hit)."""
        return spec.is_per_hit or self.spectra.missing_fronts is not None

    def residual_per_hit(self, spec: RigSpec, hits: np.ndarray | None = None) -> np.ndarray:
        """``H_i − M_i`` (hits, G) of a subset of hits, each late hit's missing front fitted out of it."""
        return self._profiled(spec, hits)[0]

    def _profiled(
        self, spec: RigSpec, hits: np.ndarray | None, predicted: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`residual_per_hit` and the missing fronts' prior residuals (hits,; empty without late hits)."""
        rows = slice(None) if hits is None else hits
        difference = self.spectra.h[rows] - (self.predicted(spec, hits) if predicted is None else predicted)
        fronts = self.spectra.missing_fronts
        if fronts is None:
            return difference, np.zeros(0)
        fitted, prior = fronts.subset(hits).fitted(difference, self.spectra.weight[rows])
        return difference - fitted, prior

    def residual(
        self, spec: RigSpec, hits: np.ndarray | None = None, predicted: np.ndarray | None = None
    ) -> np.ndarray:
        """Weighted residual vector (real and imaginary parts, and the missing fronts' prior) whose squared norm is χ²
        up to a constant (``predicted``: :meth:`predicted` of the spec, when the caller has it)."""
        if self._hit_by_hit(spec):
            _, sqrt_weight = self._hit_rows(hits)
            difference, prior = self._profiled(spec, hits, predicted)
            size = difference.size
            vector = np.empty(2 * size + prior.size)  # real parts, imaginary parts, prior: each weighted in place
            _weighted_parts(difference, sqrt_weight, vector)
            vector[2 * size:] = prior
            return vector
        mean, total = self._mean(hits)
        difference = mean - (self.predicted(spec) if predicted is None else predicted)
        difference *= np.sqrt(total)
        parts = np.empty((2,) + difference.shape)
        parts[0], parts[1] = difference.real, difference.imag
        return parts.ravel()

    def scatter_constant(self, hits: np.ndarray | None = None) -> float:
        """``Σ_i w_i |H_i − H̄|²``: the part of χ² no hit-independent model can remove."""
        rows = self._subset(hits)
        mean, _ = self._mean(hits)
        return float(np.sum(self.spectra.weight[rows] * np.abs(self.spectra.h[rows] - mean) ** 2))

    def chi2(self, spec: RigSpec, hits: np.ndarray | None = None) -> float:
        value = float(np.sum(self.residual(spec, hits) ** 2))
        return value if self._hit_by_hit(spec) else value + self.scatter_constant(hits)

    def chi2_per_hit_and_frequency(self, spec: RigSpec) -> np.ndarray:
        """χ² contribution of every hit at every analysis frequency (hits, G)."""
        return self.spectra.weight * np.abs(self.residual_per_hit(spec)) ** 2

    def chi2_per_frequency(self, spec: RigSpec) -> np.ndarray:
        """χ² contribution of every analysis frequency (summed over hits)."""
        return self.chi2_per_hit_and_frequency(spec).sum(axis=0)

    def mean_prediction(self, spec: RigSpec) -> np.ndarray:
        """The spec's FRF averaged over hits the way H1 averages the measurement."""
        predicted = self.predicted(spec)
        if predicted.ndim == 1:
            return predicted
        weight = self.spectra.weight
        return (weight * predicted).sum(axis=0) / weight.sum(axis=0)


#: Relative tolerance of a final fit, and of a screening fit (the starting values of a candidate: the best start is
#: finished to the full tolerance). (1e-4 stops some starts in their first flat steps, 30 % of χ² above where they
#: end: the wrong starts are then finished.)
FIT_TOLERANCE = 1e-7
SCREENING_TOLERANCE = 1e-6
FINISHED_STARTS = 2


def fit(
    evidence: Evidence,
    spec: RigSpec,
    slots: list[Slot],
    hits: np.ndarray | None = None,
    tolerance: float = FIT_TOLERANCE,
    covariance: bool = True,
    worth_below: float | None = None,
) -> FitOutcome:
    """Weighted least squares of the slots (scaled search space) from the spec's current values. Without
    ``covariance`` (a screening fit, of which only the spec and χ² are used) the outcome's covariance is empty.

    ``worth_below``: the χ² below which the outcome matters to the caller (a candidate term's fit: below it the term
    would count). A fit still descending, after :data:`PACE_STEPS` steps, too slowly to get there within its
    evaluations even at :data:`PACE_MARGIN` times its recent pace (a term shrinking to nothing, a parameter crawling
    to its bound) stops where it is: its outcome then only says that it does not matter."""
    if not slots:
        return FitOutcome(spec, evidence.chi2(spec, hits), [], np.zeros((0, 0)), 1)
    budget = 40 * (len(slots) + 1)
    problem = _LeastSquares(evidence, spec, slots, hits)
    if worth_below is not None:
        problem.stop_unless_below(worth_below, budget)
    # MINPACK's Levenberg-Marquardt (bounds by clipping inside the residual): several times faster than a
    # bounded trust-region solver on these tall problems. Called as scipy.optimize.least_squares(method="lm",
    # x_scale="jac") calls it, with its forward differences (:meth:`_LeastSquares.jacobian_rows`), bit for bit; the
    # Jacobian is handed over by rows of parameters (no transposed copy of a tall matrix at every step).
    try:
        x, _, info, _, _ = leastsq(problem.residual_for_minpack, read_vector(spec, slots),
                                   Dfun=problem.jacobian_rows, full_output=True, col_deriv=True,
                                   ftol=tolerance, xtol=tolerance, gtol=GRADIENT_TOLERANCE, maxfev=budget)
        evaluations = int(info["nfev"])
    except _NotWorthFinishing as stopped:
        x, evaluations = stopped.vector, problem.calls
    problem.stop_unless_below(None, 0)
    fitted = problem.spec_at(x)
    matrix = _covariance(problem.jacobian_rows(x).T) if covariance else np.zeros((0, 0))
    return FitOutcome(fitted, evidence.chi2(fitted, hits), slots, matrix, evaluations)


#: A fit given ``worth_below`` is judged after this many steps, on its descent over the last this many steps, ...
PACE_STEPS = 10
#: ... allowed to speed up this many times over what is left of its evaluations.
PACE_MARGIN = 3.0


class _NotWorthFinishing(Exception):
    """Raised inside a fit that cannot reach the χ² that would make it matter (see :func:`fit`)."""

    def __init__(self, vector: np.ndarray) -> None:
        super().__init__("not worth finishing")
        self.vector = vector


#: Every element of the residual at values no rig can have (a film scale through zero within the session): its χ²
#: is beyond any rig's, so Levenberg-Marquardt refuses the step and shortens it; its square, summed, stays finite.
INFEASIBLE_RESIDUAL = 1e100
#: MINPACK's gradient tolerance (scipy.optimize.least_squares's default).
GRADIENT_TOLERANCE = 1e-8
#: Relative forward-difference step in search space (scipy's for two-point differences: √ε).
DIFFERENCE_STEP = float(np.finfo(float).eps ** 0.5)


class _LeastSquares:
    """A fit's residual in search space (values clipped into the slots' bounds) and its forward-difference Jacobian.
    A Jacobian column changes one slot of the spec at the point, not all of them (the same spec, built faster)."""

    def __init__(self, evidence: Evidence, spec: RigSpec, slots: list[Slot], hits: np.ndarray | None) -> None:
        self.evidence, self.spec, self.slots, self.hits = evidence, spec, slots, hits
        self.low, self.high = np.array([slot.search_bounds() for slot in slots]).T
        self._last: tuple[bytes, np.ndarray] | None = None
        self._last_rows: tuple[bytes, np.ndarray] | None = None
        self._last_parts: tuple[RigSpec, AcceleranceParts | None] | None = None  # of the residual in _last
        self.calls = 0  # residuals MINPACK asked for (the Jacobian's own not counted)
        self._worth_below: float | None = None
        self._budget = 0
        self._offset = 0.0
        self._path: list[float] = []  # χ² at every point a Jacobian was asked for: MINPACK's accepted steps

    def stop_unless_below(self, chi2: float | None, budget: int) -> None:
        """Stop the fit (:class:`_NotWorthFinishing`) once it cannot get below ``chi2`` within ``budget`` residuals
        (None: never)."""
        self._worth_below, self._budget = chi2, budget
        if chi2 is not None:  # the residual's squared norm is χ² less what no hit-independent model removes
            self._offset = 0.0 if self.evidence._hit_by_hit(self.spec) else self.evidence.scatter_constant(self.hits)

    def spec_at(self, vector: np.ndarray) -> RigSpec:
        return write_vector(self.spec, self.slots, np.clip(vector, self.low, self.high))

    def residual(self, vector: np.ndarray) -> np.ndarray:
        """The weighted residual at a search vector (the last one remembered: the Jacobian starts from it)."""
        key = vector.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        self.calls += 1
        spec = self.spec_at(vector)
        try:
            parts = self.evidence.predicted_parts(spec, self.hits)
            value = self.evidence.residual(spec, self.hits, None if parts is None else parts.accelerance)
        except GasfilmError:  # no rig has these values (a film scale through zero): a step there is refused
            if self._last is None:
                raise
            return np.full_like(self._last[1], INFEASIBLE_RESIDUAL)
        self._last = (key, value)
        self._last_parts = (spec, parts)
        return value

    def residual_for_minpack(self, vector: np.ndarray) -> np.ndarray:
        """:meth:`residual` as a copy: SciPy's MINPACK keeps the first residual it is handed as its own workspace and
        writes into it, which must never be the remembered residual the Jacobian's differences start from (the
        Jacobian it copies)."""
        return self.residual(vector).copy()

    def jacobian_rows(self, vector: np.ndarray) -> np.ndarray:
        """∂residual/∂vector by forward differences, one row per slot (scipy's two-point scheme: step
        √ε·max(1, |x|) away from zero, divided by the step as represented). The last one is remembered: scipy's
        leastsq asks for the first twice."""
        vector = np.array(vector, dtype=float)
        key = vector.tobytes()
        if self._last_rows is not None and self._last_rows[0] == key:
            return self._last_rows[1]
        base = self.residual(vector)
        if self._worth_below is not None:
            self._judge_pace(vector, float(base @ base) + self._offset)
        at, parts = self._last_parts  # the residual just evaluated there
        step = DIFFERENCE_STEP * ((vector >= 0).astype(float) * 2 - 1) * np.maximum(1.0, np.abs(vector))
        rows = np.empty((len(self.slots), base.size))
        for index, slot in enumerate(self.slots):
            moved = vector[index] + step[index]
            changed = with_slot(at, slot, slot.from_search(min(max(moved, self.low[index]), self.high[index])))
            change = None if parts is None else parts.change(at, changed, slot.effect)
            if change is None:
                rows[index] = (self.evidence.residual(changed, self.hits) - base) / (moved - vector[index])
            else:
                row = self.evidence.residual_change(change, at, self.hits, out=rows[index])
                row /= moved - vector[index]
        self._last_rows = (key, rows)  # MINPACK copies the Jacobian it is handed
        return rows

    def _judge_pace(self, vector: np.ndarray, chi2: float) -> None:
        """Raise :class:`_NotWorthFinishing` when the descent so far cannot reach :attr:`_worth_below` in time."""
        self._path.append(chi2)
        if len(self._path) <= PACE_STEPS or chi2 < self._worth_below:
            return
        pace = (self._path[-1 - PACE_STEPS] - chi2) / PACE_STEPS
        if chi2 - PACE_MARGIN * pace * max(self._budget - self.calls, 0) > self._worth_below:
            raise _NotWorthFinishing(vector)


def _covariance(jacobian: np.ndarray) -> np.ndarray:
    """``(JᵀJ)⁻¹`` with the columns equilibrated first (parameters of very different sensitivity)."""
    norms = np.linalg.norm(jacobian, axis=0)
    norms[norms == 0] = 1.0
    scaled = jacobian / norms
    inverse = np.linalg.pinv(scaled.T @ scaled, rcond=1e-12)
    return inverse / np.outer(norms, norms)


def bic(chi2: float, parameter_count: int, point_count: int) -> float:
    return chi2 + parameter_count * np.log(point_count)


@dataclass
class HeldOut:
    """A term judged on data left out of its fit: the χ² gain of the augmented spec over the base spec on the left-out
    part (both folds summed) and the augmented spec's fits on each fold (to compare their parameters)."""

    gain: float
    fold_fits: tuple[FitOutcome, FitOutcome]


def held_out_gain(
    base_evidence: Evidence, base: RigSpec, augmented_evidence: Evidence, augmented: RigSpec, context: FitContext
) -> HeldOut:
    """χ² improvement of ``augmented`` over ``base`` on hits not used to fit either (odd hits fitted, even hits
    predicted, and the reverse); each spec is judged on the evidence replayed with it."""
    hits = np.arange(base_evidence.hit_count)
    folds = (hits[0::2], hits[1::2])
    pairs = ((base_evidence, base), (augmented_evidence, augmented))
    fitted = shared_fits([(evidence, spec, spec_slots(spec, context), train)
                         for train in folds for evidence, spec in pairs])
    gain = 0.0
    for (base_fit, augmented_fit), test in zip((fitted[0:2], fitted[2:4]), folds[::-1]):
        gain += base_evidence.chi2(base_fit.spec, test) - augmented_evidence.chi2(augmented_fit.spec, test)
    return HeldOut(gain, (fitted[1], fitted[3]))


def shared_fits(problems: list[tuple]) -> list[FitOutcome]:
    """:func:`fit` of each argument tuple ((evidence, spec, slots) or (evidence, spec, slots, hits)), shared by two
    processes (:func:`shared_map`), in order; the first exception raised is raised here."""
    fitted = shared_map(lambda problem: fit(*problem), problems)
    failed = [outcome for outcome in fitted if isinstance(outcome, Exception)]
    if failed:
        raise failed[0]
    return fitted


#: Width, in analysis lines, of the interleaved sub-bands of :func:`held_out_band_gain`.
SUB_BAND_LINES = 3


def held_out_band_gain(
    base_evidence: Evidence, base: RigSpec, augmented_evidence: Evidence, augmented: RigSpec, context: FitContext
) -> HeldOut:
    """χ² improvement of ``augmented`` over ``base`` on frequencies left out of the fit: the band is cut into
    interleaved sub-bands of :data:`SUB_BAND_LINES` lines, the specs are fitted on every other sub-band and predict
    the rest, and the reverse."""
    lines = np.arange(len(base_evidence.freq_hz))
    folds = (lines[(lines // SUB_BAND_LINES) % 2 == 0], lines[(lines // SUB_BAND_LINES) % 2 == 1])
    pairs = ((base_evidence, base), (augmented_evidence, augmented))
    fitted = shared_fits([(evidence.restricted(train), spec, spec_slots(spec, context), None)
                         for train in folds for evidence, spec in pairs])
    gain = 0.0
    for (base_fit, augmented_fit), test in zip((fitted[0:2], fitted[2:4]), folds[::-1]):
        gain += (base_evidence.restricted(test).chi2(base_fit.spec)
                 - augmented_evidence.restricted(test).chi2(augmented_fit.spec))
    return HeldOut(gain, (fitted[1], fitted[3]))


#: Two fits of a term on disjoint data disagree when one of its parameters differs by more than this many standard
#: deviations (both fits' uncertainties combined, each scaled by its own noise scale, and a floor of
#: MODEL_UNCERTAINTY — 5 % of the value — for what no fit's covariance shows: the spec is a model).
AGREEMENT_SIGMA = 4.0
MODEL_UNCERTAINTY = 0.05


def disagreement(first: FitOutcome, second: FitOutcome, effect_index: int, points: tuple[int, int]) -> str | None:
    """Which parameter of effect ``effect_index`` differs between two fits on disjoint data beyond their
    uncertainties (in search space: logarithms of log-scaled values), or None when they agree."""
    worst: tuple[float, str] | None = None
    for index, slot in enumerate(first.slots):
        if slot.effect != effect_index:
            continue
        if slot.at_bound(first.spec) or slot.at_bound(second.spec):
            continue  # a value at a bound (the term degenerate there) has no uncertainty to compare with
        if min(first.covariance[index, index], second.covariance[index, index]) <= 0:
            continue
        variances = []
        for outcome, count in zip((first, second), points):
            scale = max(1.0, outcome.chi2 / max(count - len(outcome.slots), 1))
            variances.append(max(float(outcome.covariance[index, index]), 0.0) * scale)
        a, b = (slot.to_search(slot.value(outcome.spec)) if slot.range.scale != "log" or slot.value(outcome.spec) > 0
                else slot.search_bounds()[0] for outcome in (first, second))
        floor = MODEL_UNCERTAINTY * (1.0 if slot.range.scale == "log" else max(abs(a), abs(b)))
        z = abs(a - b) / max(np.sqrt(sum(variances) + 2 * floor**2), 1e-300)
        if z > AGREEMENT_SIGMA and (worst is None or z > worst[0]):
            worst = (z, f"{slot.name} {slot.value(first.spec):.4g} vs {slot.value(second.spec):.4g} ({z:.0f} σ apart)")
    return None if worst is None else worst[1]


def candidate_starts(evidence: Evidence, spec: RigSpec, identifier: str, context: FitContext) -> list[RigSpec]:
    """The spec plus the candidate term at each of its starting values (:func:`starting_effects`). A candidate's
    best fit: every start fitted to the screening tolerance (:func:`screening_fit`), the best :data:`FINISHED_STARTS`
    (:func:`to_finish`) finished to the full tolerance (:func:`finishing_fit`), the best of those
    (:func:`best_finished`). A changing description (``type+term-drift``, :func:`changing_description`) is started
    by :func:`changing_starts`."""
    term, change = changing_description(identifier)
    if change is not None:
        return changing_starts(term, spec, evidence, context)
    return [with_effect(spec, effect) for effect in starting_effects(identifier, spec, evidence, context)]


def changing_description(identifier: str) -> tuple[str, str | None]:
    """``(type, change)`` of a candidate: a new description that changes between hits is named ``type+change`` (a
    mode beside the mover whose modal constant moves over the session: ``side-mode+term-drift``); a plain one is
    ``(type, None)``."""
    term, _, change = identifier.partition("+")
    return term, change or None


def changing_starts(identifier: str, spec: RigSpec, evidence: Evidence, context: FitContext) -> list[RigSpec]:
    """Starts of a new description ``identifier`` whose values move steadily over the session, for hits that differ
    in a way no term of ``spec`` changing between them describes (a mode whose constant the H1 average cancels, a
    resonance that falls hit by hit): the description fitted to the early half of the hits and to the late half (in
    blow order, :func:`_halves`), its values the halves' mean, and, for each value that differs between the
    halves by :data:`AGREEMENT_SIGMA` or more, a ``term-drift`` of it on each clock through the two halves' values
    (:func:`_drifting_starts`). None when the halves agree (nothing that changes to describe)."""
    halves = _halves(evidence)
    if halves is None:
        return []
    fitted = []
    for half in halves:
        part = evidence.of_hits(half)
        outcomes = [fit(part, start, spec_slots(start, context), tolerance=SCREENING_TOLERANCE)
                    for start in candidate_starts(part, spec, identifier, context)]
        if not outcomes:
            return []
        fitted.append(min(outcomes, key=lambda outcome: outcome.chi2))
    index = len(spec.effects)
    early_term, late_term = (outcome.spec.effects[index] for outcome in fitted)
    held = {slot.name for slot in fitted[0].slots if slot.effect == index}
    if any(getattr(early_term, item.name) != getattr(late_term, item.name) for item in dataclasses.fields(early_term)
           if item.name not in held):  # not one description (a resonance of the force channel, then of the response)
        return []
    differences = _half_differences(fitted, index)
    values = {slot.name: slot.from_search(0.5 * (first + second)) for _, slot, first, second in differences}
    with_term = with_effect(spec, dataclasses.replace(early_term, **values))
    return [start for size, moving, early, late in differences if size >= AGREEMENT_SIGMA
            for start in _drifting_starts(with_term, index, moving, early, late, halves, context, evidence)]


def _halves(evidence: Evidence) -> tuple[np.ndarray, np.ndarray] | None:
    """The early and the late half of the hits, in blow order (None with fewer than two hits in each)."""
    order = np.argsort(evidence.spectra.conditions.blows, kind="stable")
    halves = (order[: order.size // 2], order[order.size // 2:])
    return None if min(half.size for half in halves) < 2 else halves


def _half_differences(fitted: list[FitOutcome], index: int) -> list[tuple[float, Slot, float, float]]:
    """For each fitted value of effect ``index`` in two fits (the early and the late half of the hits): how far apart
    the two are in units of their combined uncertainty (with :data:`MODEL_UNCERTAINTY`'s floor), the slot, and the
    two values in its search coordinate; largest difference first."""
    differences = []
    for position, slot in enumerate(fitted[0].slots):
        if slot.effect != index:
            continue
        early, late = (slot.to_search(slot.value(outcome.spec)) for outcome in fitted)
        spread = np.hypot(*(np.sqrt(max(outcome.covariance[position, position], 0.0)) for outcome in fitted))
        floor = MODEL_UNCERTAINTY if slot.range.scale == "log" else MODEL_UNCERTAINTY * max(abs(early), abs(late))
        differences.append((abs(late - early) / max(float(np.hypot(spread, floor)), 1e-300), slot, early, late))
    return sorted(differences, key=lambda item: -item[0])


def _drifting_starts(spec: RigSpec, index: int, moving: Slot, early: float, late: float,
                     halves: tuple[np.ndarray, np.ndarray], context: FitContext, evidence: Evidence) -> list[RigSpec]:
    """``spec`` with its term ``index``'s value ``moving`` drifting, on each clock, through ``early`` and ``late``
    (its search coordinate fitted to each half of the hits) at the halves' mean clock readings."""
    conditions = evidence.spectra.conditions
    signed = moving.range.scale != "log"
    starts = []
    for clock, positions in (("session time", conditions.time_s / 3600.0), ("blows", conditions.blows)):
        at_early, at_late = (float(np.mean(positions[half])) for half in halves)
        if at_late <= at_early:
            continue
        slope = (late - early) / (at_late - at_early)  # in the value's search coordinate, per unit of the clock
        at_zero = early - slope * at_early
        if signed:  # the first hit's value, and the slope as a fraction of it
            smallest = 1e-3 * max(abs(early), abs(late))
            first = moving.from_search(at_zero if abs(at_zero) > smallest else np.copysign(smallest, early))
            rate = slope / first
        else:  # the first hit's value, and the slope of its logarithm
            first, rate = moving.from_search(at_zero), slope
        rate_name = "fraction_per_blow" if clock == "blows" else "fraction_per_hour"
        term = dataclasses.replace(spec.effects[index], **{moving.name: first})
        drift = TermDrift(term=index, parameter=moving.name, clock=clock)
        limit = drift.fit_ranges_on(term, context)[rate_name].upper
        drift = dataclasses.replace(drift, **{rate_name: float(np.clip(rate, -limit, limit))})
        effects = list(spec.effects)
        effects[index] = term
        starts.append(spec.with_values(effects=[*effects, drift]))
    return starts


def screening_fit(
    evidence: Evidence, start: RigSpec, context: FitContext, worth_below: float | None = None
) -> FitOutcome:
    """A candidate's start fitted to the screening tolerance (``worth_below``: see :func:`fit`)."""
    return fit(evidence, start, spec_slots(start, context), tolerance=SCREENING_TOLERANCE, covariance=False,
               worth_below=worth_below)


def to_finish(screened: list[FitOutcome]) -> list[FitOutcome]:
    """The best :data:`FINISHED_STARTS` screened starts: the screening order of two close starts is not the final
    one's, so both are finished."""
    return sorted(screened, key=lambda outcome: outcome.chi2)[:FINISHED_STARTS]


def finishing_fit(evidence: Evidence, screened: FitOutcome, worth_below: float | None = None) -> FitOutcome:
    """A screened start refitted to the full tolerance (``worth_below``: see :func:`fit`)."""
    return fit(evidence, screened.spec, screened.slots, worth_below=worth_below)


def best_finished(finished: list[FitOutcome]) -> FitOutcome:
    return min(finished, key=lambda outcome: outcome.chi2)


def starting_effects(identifier: str, spec: RigSpec, evidence: Evidence, context: FitContext) -> list[Effect]:
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
    if identifier in ("friction", "quadratic-damping"):
        if np.ptp(evidence.spectra.conditions.impulse_ns) <= 0.05 * np.median(evidence.spectra.conditions.impulse_ns):
            return []  # all hits at one level: an amplitude-dependent damper cannot be told from the film's damping
        cls = Friction if identifier == "friction" else QuadraticDamping
        name, fit_range = next(iter(cls(1.0).fit_ranges(context).items()))
        return [cls(**{name: float(np.sqrt(fit_range.lower * fit_range.upper)) * factor}) for factor in (1e-2, 1.0)]
    if identifier == "ac-coupling":
        return [AcCoupling(channel="acceleration", corner_hz=factor * context.band_hz[0]) for factor in (0.05, 0.3)]
    if identifier == "cross-talk":
        return [CrossTalk(leak_m_s2_per_n=sign * 1e-3 / context.mass_kg) for sign in (1.0, -1.0)]
    if identifier == "film-memory":
        omega = 2 * np.pi * resonance_hz
        return [FilmMemory(k_memory=k_factor * film, eta_memory=0.01 * film / omega**alpha, alpha_memory=alpha)
                for alpha, k_factor in ((0.3, 0.1), (0.8, 1.0), (1.5, 100.0))]
    if identifier == "squeeze-film":
        # the air spring a tenth of the film's, squeeze numbers around 1, 10 and 100 at the resonance
        omega = 2 * np.pi * resonance_hz
        starts = []
        for squeeze_number in (1.0, 10.0, 100.0):
            gap_m = float(np.sqrt(12 * AIR_VISCOSITY_PA_S * 0.1**2 * omega / (AIR_PRESSURE_PA * squeeze_number)))
            starts.append(SqueezeFilm(gap_m=gap_m, length_m=0.1 * film * gap_m / (0.1 * AIR_PRESSURE_PA)))
        return starts
    if identifier == "pneumatic-lag":
        return [PneumaticLag(k_lag=0.01 * film, tau_lag=factor / (2 * np.pi * resonance_hz)) for factor in (0.3, 1, 3)]
    if identifier == "extra-mode":
        return [ExtraMode(freq_hz=f, damping_ratio=0.02, mass_kg=0.002 * context.mass_kg)
                for f in _excess_peaks(spec, evidence, resonance_hz)]
    if identifier == "support-mode":
        # the resonance a support in series adds lies beyond the support's own frequency; its modal mass is of the
        # order of the mover's or larger (a start at each of the two largest excess peaks)
        return [SupportMode(freq_hz=0.9 * f, damping_ratio=0.03, mass_kg=2.0 * context.mass_kg)
                for f in _excess_peaks(spec, evidence, resonance_hz)[:2]]
    if identifier == "sensitivity-error":
        return [SensitivityError(channel="acceleration", fraction=sign * 0.01) for sign in (1.0, -1.0)]
    if identifier == "side-mode":
        # a mode's contribution at its own resonance is A/(2ζ)·j: its modal constant's sign and size are read off the
        # residual's imaginary part there
        residual = evidence.spectra.mean()[0] - evidence.mean_prediction(spec)
        starts = []
        for freq in _excess_peaks(spec, evidence, None):
            line = int(np.argmin(np.abs(evidence.freq_hz - freq)))
            constant = 2 * 0.02 * float(residual[line].imag)
            limit = 0.5 * SideMode(freq_hz=freq, damping_ratio=0.02, modal_constant_per_kg=1.0).fit_ranges(
                context)["modal_constant_per_kg"].upper
            constant = float(np.clip(constant, -limit, limit)) or 1e-3 / context.mass_kg
            starts.append(SideMode(freq_hz=freq, damping_ratio=0.02, modal_constant_per_kg=constant))
        return starts
    if identifier == "film-branch":
        return [FilmBranch(stiffness_n_per_m=0.01 * film, order=order, reference_hz=resonance_hz)
                for order in (0.3, 1.0, 1.7)]
    if identifier == "channel-resonance":
        peaks = _excess_peaks(spec, evidence, None)[:1]
        return [ChannelResonance(channel=channel, freq_hz=freq, damping_ratio=0.05, form=form)
                for form in ("seismic", "transmitted") for channel in ("acceleration", "force")
                for freq in (*peaks, 2.0 * context.band_hz[1])]
    if identifier == "channel-power-law":
        return [ChannelPowerLaw(exponent=0.0, reference_hz=resonance_hz)]
    if identifier == "channel-pole-zero":
        # a lag and a lead above the band, and a high-pass at the resonance (its zero far below the band); the gain is
        # the magnitude at the resonance, 1 at the start
        low, high = context.band_hz
        near, far = 2.0 * high, 50.0 * high
        return [ChannelPoleZero(pole_hz=pole_hz, zero_hz=zero_hz, reference_hz=resonance_hz)
                for pole_hz, zero_hz in ((near, far), (far, near), (resonance_hz, 1e-2 * low))]
    if identifier in ("term-drift", "term-level", "term-onset"):
        return _term_change_starts(identifier, spec, evidence, context)
    raise KeyError(identifier)


#: Units of the fields a term-onset scales: its size (a mass, a stiffness, a modal constant, a force …), so that the
#: term is absent before the onset.
_AMPLITUDE_UNITS = frozenset({"kg", "N/m", "1/kg", "(m/s²)/N", "N", "N·s²/m²", "N/m³", "N·s^α/m"})


def _term_change_starts(identifier: str, spec: RigSpec, evidence: Evidence, context: FitContext) -> list[Effect]:
    """Starts of a change between hits of each changeable term of ``spec``: every fitted value of it (with session
    time, with the hit level), or, for an onset, its size from each likely moment on. Terms held after the
    recalibration (a measured structure's modes) and changes themselves are not changed."""
    conditions = evidence.spectra.conditions
    starts: list[Effect] = []
    for index, effect in enumerate(spec.effects):
        if isinstance(effect, TermChange) or type(effect).held_after_recalibration:
            continue
        names = list(effect.fit_ranges(context))
        if identifier == "term-drift":  # with session time, and with the blows
            starts += [TermDrift(term=index, parameter=name, clock=clock) for clock in DRIFT_CLOCKS for name in names
                       if clock == "session time" or context.blow_span > 0]
        elif identifier == "term-level":
            reference = float(np.median(np.abs(conditions.impulse_ns)))
            if np.ptp(conditions.impulse_ns) > 0.05 * reference:
                starts += [TermLevel(term=index, parameter=name, exponent=0.0, reference_impulse_ns=reference)
                           for name in names]
        else:
            units = {item.name: item.metadata.get("unit") for item in dataclasses.fields(effect)}
            sizes = [name for name in names if units.get(name) in _AMPLITUDE_UNITS][:1]
            starts += [TermOnset(term=index, parameter=name, at_time_s=at_time_s)
                       for name in sizes for at_time_s in _likely_step_times(spec, evidence, count=2)]
    return starts


def _excess_peaks(spec: RigSpec, evidence: Evidence, resonance_hz: float | None, count: int = 3) -> list[float]:
    """The frequencies of the ``count`` largest peaks of the spec's χ² per frequency (5-line smoothed), 5 % apart,
    away from the film's resonance when ``resonance_hz`` is given."""
    freq_hz = evidence.freq_hz
    excess = evidence.chi2_per_frequency(spec)
    smooth = np.convolve(excess, np.ones(5) / 5, mode="same")
    picks: list[float] = []
    for index in np.argsort(smooth)[::-1]:
        candidate = float(freq_hz[index])
        if all(abs(candidate - p) > 0.05 * p for p in picks) and (
                resonance_hz is None or abs(candidate - resonance_hz) > 0.1 * resonance_hz):
            picks.append(candidate)
        if len(picks) == count:
            break
    return picks



def _likely_step_times(spec: RigSpec, evidence: Evidence, count: int = 3) -> list[float]:
    """Moments between hits where a step best explains how the hits' residuals differ (a least-squares two-level fit
    of each hit's mean residual, in time order), best first; at least two hits on each side."""
    conditions = evidence.spectra.conditions
    order = np.argsort(conditions.time_s, kind="stable")
    times = conditions.time_s[order]
    if times.size < 4:
        return []
    weight = evidence.spectra.weight[order]
    residual = evidence.residual_per_hit(spec)[order] * np.sqrt(weight)
    costs = []
    for split in range(2, times.size - 1):
        if times[split] == times[split - 1]:
            continue
        before, after = residual[:split], residual[split:]
        cost = float(np.sum(np.abs(before - before.mean(axis=0)) ** 2)
                     + np.sum(np.abs(after - after.mean(axis=0)) ** 2))
        costs.append((cost, float(0.5 * (times[split - 1] + times[split]))))
    return [at_time_s for _, at_time_s in sorted(costs)[:count]]
