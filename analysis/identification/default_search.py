"""The default fitter: variable projection on the log dynamic stiffness, then Levenberg–Marquardt on the accelerance.

Every coefficient is searched as the element's stiffness at the reference frequency ω_r relative to the measured
dynamic stiffness there, in log scale (:class:`~gasfilm.analysis.identification.problem.Coordinates`); orders stay
linear. The search starts on the *dynamic stiffness* ``Z_d = s²/H_d - m s²`` in log space (smooth, no resonance to
hit): the scale of each top-level branch is linear there and is solved by least squares for given branch shapes, so
a small Latin hypercube, a few local searches and branch splits run over the shapes only. The results, and the
samples that best fit the accelerance, are then polished on the accelerance residual itself with the model's
analytic Jacobian.
"""

from __future__ import annotations

import functools
import itertools
import logging
import math
import re
from typing import Callable

import numpy as np

from gasfilm.analysis.identification.problem import LOG_BOX, Problem
from gasfilm.analysis.physics.elements import Parallel, Series

logger = logging.getLogger(__name__)

#: where the Latin-hypercube shapes are drawn: coefficient ratios within this factor squared, and orders
_LOG_START = math.log(1e3)
_ORDER_START = (0.05, 1.95)
#: local searches of the default fitter from the best distinct Latin-hypercube starts
_LOCAL_SEARCHES = 8
#: search rounds at most; a round whose best cost is within :data:`_ROUND_AGREEMENT` (relative: RMS 0.005 %) of the
#: best so far agrees with the rounds before and ends the search
_MAX_ROUNDS = 3
_ROUND_AGREEMENT = 1e-4
#: relative decrease of the weighted sum of squares that a Gauss–Newton step from a round's best point may still
#: promise for that point to be the minimum of its basin (RMS 5e-7 relative): a round that reaches one ends the search
_MINIMUM_PROMISE = 1e-6
#: best local-search results polished on the accelerance
_POLISHED = 4
#: projected Latin-hypercube samples with the lowest accelerance residual that are polished as they are
_ACCELERANCE_STARTS = 6
#: least difference of two candidates in some coordinate (log coefficient or order) for both to be polished
_DISTINCT = 0.01
#: iterations of the brief polish every local result gets (on the lines of the log-stiffness stage)
_BRIEF_POLISH = 10
#: Latin-hypercube shapes scored per shape coordinate
_SAMPLES_PER_SHAPE = 32
#: lines (of the searches' lines) on which the Latin-hypercube shapes are scored: a score only ranks a start, and the
#: film's stiffness is smooth across the band
_SCORING_LINES = 100
#: least distance between two starts of local searches, in the unit cube of the shapes
_START_SPACING = 0.1
#: relative cost decrease at which a local search over the shapes, or the brief polish, stops: their results are
#: polished on the accelerance anyway
_SEARCH_TOLERANCE = 1e-6
#: relative cost decrease at which the final polish on the accelerance stops
_POLISH_TOLERANCE = 1e-10
#: relative excess of cost over the best of the final polish at which a start is given up after
#: :data:`_BEHIND_AFTER` iterations (its RMS then is 0.05 % above the best, half the accuracy asked of the fitter)
_POLISH_BEHIND = 1e-3
_BEHIND_AFTER = 20
#: relative cost decrease over :data:`_STALL_AFTER` iterations at which a start of the final polish is stopped: it
#: crawls along a flat valley (an order running to its bound, a branch fitting noise), where another 2000
#: iterations lower its RMS by less than 1e-6 (relative) on bench_fit's FRFs, while each costs as much as any other
_POLISH_STALL = 1e-7
_STALL_AFTER = 10
#: relative excess of log cost over the best of a group of shape searches at which a search is given up after
#: :data:`_SEARCH_BEHIND_AFTER` iterations (its point so far is still polished)
_SEARCH_BEHIND = 9.0
_SEARCH_BEHIND_AFTER = 10
#: iterations of a local search over the shapes, per shape coordinate
_SEARCH_ITERATIONS = 25
#: mean squared log-stiffness residual at which the data are matched to round-off and the search stops
_EXACT_LOG_COST = 1e-20


@functools.cache
def _subsample(n: int, count: int) -> np.ndarray:
    """``count`` lines spread evenly over ``n`` (all when fewer), made once per size (read-only)."""
    index = np.arange(n) if n <= count else np.unique(np.linspace(0, n - 1, count).round().astype(int))
    index.flags.writeable = False
    return index


class Projection:
    """Variable projection of the log-stiffness problem onto the branch shapes.

    The top of a network is a parallel (``Z = Σ c_b φ_b``) or series (``1/Z = Σ φ_b⁻¹ / c_b``) combination of
    branches, and a branch is homogeneous of degree one in its coefficients: scaling them all by ``c_b`` scales its
    stiffness by ``c_b``. With the branch *shapes* ψ fixed (each coefficient relative to the branch's first one, and
    the orders) the scales solve a small linear least-squares problem weighted like the relative stiffness
    residual, so the search runs over ψ only. ``weights`` (lines,) or several weightings (weightings, lines) of the
    problem's lines; with several, each point names its weighting (searches of both weightings run in one batch).
    """

    def __init__(self, problem: Problem, index: np.ndarray, weights: np.ndarray):
        coords = problem.coords
        self.problem = problem
        self.index = index
        top = coords.model.network
        self.compliance = isinstance(top, Series)
        self.branches = top.children if isinstance(top, (Parallel, Series)) else (top,)
        position = {name: i for i, name in enumerate(coords.names)}
        self.anchors: list[int] = []
        self.members: list[list[int]] = []
        for branch in self.branches:
            names = [p.name for p in branch.parameters() if p.name not in coords.orders]
            self.anchors.append(position[names[0]])
            self.members.append([position[name] for name in names[1:]])
        self.free = np.array([i for i in range(len(coords.names)) if i not in self.anchors], dtype=int)
        free_position = {int(index): k for k, index in enumerate(self.free)}
        self.branch_free = [
            [free_position[position[p.name]] for p in branch.parameters() if position[p.name] in free_position]
            for branch in self.branches
        ]
        self.signatures = [re.sub(r"\b[A-Za-z_]\w*\b(?!\()", "x", branch.text()) for branch in self.branches]
        self.size = len(self.free)
        # per branch, for :meth:`residual_and_jacobian`: which of its evaluations each point (the shapes, then each
        # shape coordinate shifted) takes: the shapes' own (0) but where one of its own coordinates is shifted
        self._which = []
        for own in self.branch_free:
            which = np.zeros(1 + self.size, dtype=int)
            which[1 + np.array(own, dtype=int)] = 1 + np.arange(len(own))
            self._which.append(which)
        # per branch: its parameters (names, coordinates) and, for each of its shape coordinates, the point shifting
        # it, which of its parameters it is and its coordinate
        self._branch_names = [[p.name for p in branch.parameters()] for branch in self.branches]
        self._branch_coordinates = [np.array([position[name] for name in names], dtype=int)
                                    for names in self._branch_names]
        self._shift_points = [1 + np.arange(len(own)) for own in self.branch_free]
        self._shifted_coordinates = [self.free[own] for own in self.branch_free]
        self._shifted_parameter = [
            np.array([list(coordinates).index(self.free[i]) for i in own], dtype=int)
            for own, coordinates in zip(self.branch_free, self._branch_coordinates)
        ]
        is_order = coords.is_order[self.free]
        self.lower = np.where(is_order, coords.lower[self.free], -2 * LOG_BOX)
        self.upper = np.where(is_order, coords.upper[self.free], 2 * LOG_BOX)
        self.start_lower = np.where(is_order, _ORDER_START[0], -2 * _LOG_START)
        self.start_upper = np.where(is_order, _ORDER_START[1], 2 * _LOG_START)
        self.lines = problem.lines(index)
        z = problem.z_measured[index]
        self.weights = weights
        weight = weights[..., index]
        self.row_weight = weight * np.abs(z) if self.compliance else weight / np.abs(z)
        target = (1.0 / z if self.compliance else z) * self.row_weight
        self.target = np.concatenate([target.real, target.imag], axis=-1)

    def project(self, psi: np.ndarray, weighting: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates (..., size) from shapes (..., free), the branch scales solved by least squares, and the
        weighted relative stiffness residual (..., 2n) those coordinates leave; ``weighting`` (k,): the weighting
        of each leading row of ``psi`` (k, ..., free) when the projection has several."""
        row_weight, target = self._weighting(psi.ndim, weighting)
        self.problem.check_cancel()
        self.problem.evaluations += math.prod(psi.shape[:-1])
        theta = self._theta(psi)
        values = self._values(theta)
        with np.errstate(all="ignore"):
            rows = [self._weighted_row(branch, values, row_weight) for branch in self.branches]
            # the least-squares matrix, transposed: one row per branch, its weighted stiffness (compliance) with the
            # real parts before the imaginary parts
            n_lines = len(self.index)
            a_t = np.empty(np.broadcast_shapes(*(row.shape for row in rows))[:-1] + (len(rows), 2 * n_lines))
            for b, row in enumerate(rows):
                a_t[..., b, :n_lines] = row.real
                a_t[..., b, n_lines:] = row.imag
            log_scales, residual = self._solve(a_t, target)
        for b, anchor in enumerate(self.anchors):
            theta[..., anchor] = log_scales[..., b]
            for member in self.members[b]:
                theta[..., member] += log_scales[..., b]
        return np.clip(theta, self.problem.coords.lower, self.problem.coords.upper), residual

    def _weighting(self, ndim: int, weighting: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Row weights and target of the points (k, ..., free) of ``ndim`` dimensions in their weightings."""
        row_weight, target = self.row_weight, self.target
        if weighting is not None:
            leading = (slice(None),) + (np.newaxis,) * (ndim - 2)
            row_weight, target = row_weight[weighting][leading], target[weighting][leading]
        return row_weight, target

    def _theta(self, psi: np.ndarray) -> np.ndarray:
        theta = np.zeros(psi.shape[:-1] + (self.problem.coords.size,))
        theta[..., self.free] = psi
        return theta

    def _values(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """The network's name → reference value (..., 1) mapping at coordinates (..., size)."""
        coords = self.problem.coords
        reference_values, _ = coords.reference_values(theta, masses=False)
        return {name: reference_values[..., i, np.newaxis] for i, name in enumerate(coords.names)}

    def _weighted_row(self, branch, values: dict[str, np.ndarray], row_weight: np.ndarray) -> np.ndarray:
        """A branch's weighted stiffness (parallel) or compliance (series) at the points of ``values``."""
        z = branch.stiffness(self.lines.s_rel, values, self.lines.log_s_rel)
        return (1.0 / z if self.compliance else z) * row_weight

    def _solve(
        self, a_t: np.ndarray, target: np.ndarray, finite: bool | None = None, scales: bool = True
    ) -> tuple[np.ndarray | None, np.ndarray]:
        """Log branch scales (..., branches) (None without ``scales``) and the residual (..., 2n) of the least-squares
        matrices ``a_t`` (..., branches, 2n), transposed; ``finite``: whether all of ``a_t`` is finite, when the
        caller knows."""
        if not (np.all(np.isfinite(a_t)) if finite is None else finite):
            a_t = np.nan_to_num(a_t, nan=0.0, posinf=0.0, neginf=0.0)
        normal = _gram(a_t)
        right = a_t @ target if target.ndim == 1 else (a_t @ target[..., np.newaxis])[..., 0]
        coefficients = _solve_normal(normal, right)
        # A branch whose best coefficient is negative is dropped (its row and column of the normal equations
        # zeroed) and the others solved again, only for the points that have one
        positive = coefficients > 0
        again = ~positive.all(axis=-1)
        if again.any():
            kept = positive[again]
            coefficients[again] = _solve_normal(
                normal[again] * kept[..., :, np.newaxis] * kept[..., np.newaxis, :], right[again] * kept
            )
        valid = np.isfinite(coefficients) & (coefficients > 0)
        residual = (np.where(valid, coefficients, 0.0)[..., np.newaxis, :] @ a_t)[..., 0, :] - target
        if not scales:
            return None, residual
        log_coefficients = np.log(np.where(valid, coefficients, 1.0))
        # Series: the branch scale is 1/coefficient and a dropped branch becomes infinitely stiff;
        # parallel: the scale is the coefficient and a dropped branch becomes infinitely soft.
        if self.compliance:
            return np.where(valid, -log_coefficients, LOG_BOX), residual
        return np.where(valid, log_coefficients, -LOG_BOX), residual

    def residual_and_jacobian(
        self, psi: np.ndarray, weighting: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The weighted relative stiffness residual (k, 2n) at shapes (k, free) and its Jacobian (k, 2n, free) by
        forward differences, each row in its ``weighting`` (see :meth:`project`): the shapes and all their shifts
        projected in one call. A shift of a shape coordinate changes only its own branch's row of the least-squares
        matrix, so each branch is evaluated at the shapes and at the shifts of its own coordinates only (the
        projection of every shifted point is the one :meth:`project` gives, bit for bit). (The exact
        variable-projection Jacobian from the branches' analytic gradients was tried: no faster, since a gradient
        evaluation costs about as much as the shifted projections.)"""
        step = 1e-7 * np.maximum(1.0, np.abs(psi))
        step = np.where(psi + step > self.upper, -step, step)
        count, size = psi.shape
        row_weight, target = self._weighting(3, weighting)
        self.problem.check_cancel()
        self.problem.evaluations += count * (1 + size)
        n_lines = len(self.index)
        a_t = np.empty((count, 1 + size, len(self.branches), 2 * n_lines))
        finite = True
        coords = self.problem.coords
        # the reference values at the shapes, and each coordinate's at its shift (a value depends on its coordinate)
        at_shapes, at_shifts = coords.reference_values(self._theta(np.stack([psi, psi + step])), masses=False)[0]
        with np.errstate(all="ignore"):
            for b, branch in enumerate(self.branches):
                # the branch's parameters at the shapes (point 0) and at the shift of each of its shape coordinates
                shifted = self._shifted_parameter[b]
                columns = self._branch_coordinates[b]
                values = np.empty((count, 1 + len(shifted), len(columns)))
                values[...] = at_shapes[:, np.newaxis, columns]
                values[:, self._shift_points[b], shifted] = at_shifts[:, self._shifted_coordinates[b]]
                row = self._weighted_row(
                    branch, {name: values[..., i, np.newaxis] for i, name in enumerate(self._branch_names[b])},
                    row_weight)
                finite = finite and bool(np.isfinite(row).all())
                which = self._which[b]
                a_t[:, :, b, :n_lines] = row.real[:, which]
                a_t[:, :, b, n_lines:] = row.imag[:, which]
            residuals = self._solve(a_t, target, finite, scales=False)[1]
        jacobian = ((residuals[:, 1:] - residuals[:, :1]) / step[:, :, np.newaxis]).swapaxes(-1, -2)
        return residuals[:, 0], jacobian

    def shape_of(self, theta: np.ndarray) -> np.ndarray:
        """Shapes (..., free) of coordinates (..., size): the inverse of :meth:`project` for its own output."""
        psi = np.array(theta[..., self.free], dtype=float)
        position = {int(index): k for k, index in enumerate(self.free)}
        for anchor, members in zip(self.anchors, self.members):
            for member in members:
                psi[..., position[member]] -= theta[..., anchor]
        return psi

    def split_starts(self, psi: np.ndarray) -> list[np.ndarray]:
        """Starts that copy one branch's shape onto another branch of the same structure, orders pulled apart.

        Two similar relaxations in parallel are fitted well by one of them: a local search then parks the second
        branch where it does nothing, and no gradient brings it back. Splitting the fitted branch in two does.
        """
        starts = []
        for a, b in itertools.combinations(range(len(self.branches)), 2):
            if self.signatures[a] != self.signatures[b] or not self.branch_free[a]:
                continue
            for source, target in ((a, b), (b, a)):
                start = psi.copy()
                for i, j in zip(self.branch_free[source], self.branch_free[target]):
                    shift = 0.1 if self.problem.coords.is_order[self.free[i]] else 0.5
                    start[i] = psi[i] - shift
                    start[j] = psi[i] + shift
                starts.append(np.clip(start, self.lower, self.upper))
        return starts


def _gram(rows: np.ndarray) -> np.ndarray:
    """``rows @ rowsᵀ`` for stacked matrices (..., m, n) with rows contiguous: numpy hands ``a @ aᵀ`` to BLAS's syrk
    (another rounding than gemm's) and ``a @ bᵀ`` to gemm without copying ``bᵀ``, so the second operand is a
    transposed view of a copy (plain memory copy, 5–10× cheaper than a transposed one). For up to 4 rows this gives
    gemm's result on a transposed copy bit for bit (OpenBLAS, x86-64); with more, the last bits differ."""
    return rows @ rows.copy().swapaxes(-1, -2)


def _row_major(matrices: np.ndarray) -> np.ndarray:
    """``matrices`` (..., m, n) with rows contiguous: numpy's matmul hands stacked matrices to BLAS only in that
    layout and multiplies a transposed view in its own loop, 3–9× slower for these tall, narrow matrices."""
    return np.ascontiguousarray(matrices)


def _solve_normal(normal: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Solutions (..., b) of the normal equations (..., b, b) with right-hand sides (..., b), with a ridge of 1e-12 of
    the trace (a dropped branch's zero row then gives it a zero coefficient)."""
    ridge = 1e-12 * normal.trace(axis1=-2, axis2=-1)[..., np.newaxis] + 1e-300
    system = normal + ridge[..., np.newaxis] * _identity(normal.shape[-1])
    return np.linalg.solve(system, right[..., np.newaxis])[..., 0]


@functools.cache
def _identity(size: int) -> np.ndarray:
    """The identity matrix of ``size`` (read-only, made once)."""
    identity = np.eye(size)
    identity.flags.writeable = False
    return identity


def _levenberg_marquardt(
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    max_iterations: int,
    tolerance: float,
    good_enough: float = 0.0,
    behind: float = np.inf,
    behind_after: int = _BEHIND_AFTER,
    groups: np.ndarray | None = None,
    stall: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Box-constrained Levenberg–Marquardt (Nielsen's damping update) from many starts at once.

    ``x0`` (starts, p); ``evaluate`` maps points (k, p) to residuals (k, m) and their Jacobians (k, m, p), so
    every iteration makes one call for all starts still running (each start keeps its own damping and stops on
    its own; the Jacobian comes with every trial point, which costs little next to a second call per iteration). A coordinate at a bound whose gradient points out of the box is held there for the step (the
    other coordinates' step is solved without it) instead of being clipped after the step, which would spoil
    the step of the others and make the search crawl along the bound. Solves the small scaled normal equations
    instead of factorising the tall Jacobian. A start stops when a successful step lowers its cost by less than
    ``tolerance`` (relative) and the local model predicted no more (MINPACK's ftol test), after
    ``max_iterations``, when no damping gives a lower cost, when it comes within :data:`_DISTINCT` of a start with a
    lower cost (the same point: one search goes on), or, after ``behind_after`` iterations, when its cost is more
    than a factor ``1 + behind`` above the lowest cost of all starts, or, with ``stall`` > 0, when its cost fell by
    at most ``stall`` (relative) in its last :data:`_STALL_AFTER` iterations; all stop as soon as one start's cost
    is at most ``good_enough``. With ``groups`` (one label per start) starts are only compared with the starts of
    their own group (searches of differently weighted problems run in one batch), and ``evaluate`` is called with
    the running points and their labels. Returns (x (starts, p), sums of squared residuals (starts,)).
    """
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    rows = np.arange(len(x))  # the working arrays hold the starts still running: rows of the output
    labels = np.zeros(len(x), dtype=int) if groups is None else np.asarray(groups)

    def evaluate_running(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return evaluate(points) if groups is None else evaluate(points, labels[rows])

    r, jac = evaluate_running(x)
    cost = np.einsum("km,km->k", r, r)
    x_out, cost_out = x.copy(), cost.copy()
    damping, growth = np.full(len(x), 1e-3), np.full(len(x), 2.0)
    identity = _identity(x.shape[1])
    # each start's cost after every iteration, for the stall test
    history = np.empty((len(x), max_iterations + 1)) if stall > 0 else None
    if history is not None:
        history[:, 0] = cost
    for iteration in range(max_iterations):
        if rows.size == 0 or cost_out.min() <= good_enough:
            break
        jac_t = _row_major(jac.swapaxes(-1, -2))
        normal = _gram(jac_t)
        gradient = (jac_t @ r[..., np.newaxis])[..., 0]
        scale = np.sqrt(normal.diagonal(axis1=1, axis2=2))
        at_lower, at_upper = x <= lower, x >= upper
        held = None
        if at_lower.any() or at_upper.any():
            held = (at_lower & (gradient > 0)) | (at_upper & (gradient < 0))
            unit = ~(scale > 0) | held
            if unit.any():
                scale[unit] = 1.0
            if not held.any():
                held = None
        elif not scale.min() > 0:  # a zero (or NaN) column
            scale[~(scale > 0)] = 1.0
        scaled = normal / (scale[:, :, np.newaxis] * scale[:, np.newaxis, :])
        if held is not None:
            free = ~held
            scaled = scaled * (free[:, :, np.newaxis] & free[:, np.newaxis, :]) + identity * held[:, np.newaxis, :]
            right = np.where(held, 0.0, gradient / scale)
        else:
            right = gradient / scale
        system = scaled + damping[:, np.newaxis, np.newaxis] * identity
        trial = (x - _solve_each(system, right) / scale).clip(lower, upper)
        step = trial - x
        r_trial, jac_trial = evaluate_running(trial)
        cost_trial = np.einsum("km,km->k", r_trial, r_trial)
        # cost − |r + J·step|², from the normal equations
        predicted = -2.0 * np.einsum("ki,ki->k", gradient, step) - np.einsum("ki,kij,kj->k", step, normal, step)
        decrease = cost - cost_trial
        better = decrease > 0  # False for a non-finite trial cost
        # MINPACK's ftol test: the decrease and the predicted one both at most the tolerance
        converged = better & ((np.maximum(decrease, predicted) <= tolerance * cost) | (cost_trial == 0.0))
        if better.all():
            x, r, cost, jac = trial, r_trial, cost_trial, jac_trial
            cost_out[rows] = cost
            gain = np.divide(decrease, predicted, out=np.zeros(len(cost)), where=predicted > 0)
            damping *= np.maximum(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
            growth[:] = 2.0
        elif better.any():
            x[better], r[better], cost[better], jac[better] = (
                trial[better], r_trial[better], cost_trial[better], jac_trial[better])
            cost_out[rows[better]] = cost[better]
            gain = np.divide(decrease, predicted, out=np.zeros(len(cost)), where=predicted > 0)
            damping = np.where(better, damping * np.maximum(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3),
                               damping * growth)
            growth = np.where(better, 2.0, growth * 2.0)
        else:
            damping *= growth
            growth *= 2.0
        stopped = converged | (damping > 1e16)
        if history is not None:
            history[rows, iteration + 1] = cost
            if iteration + 1 >= _STALL_AFTER:
                stopped |= history[rows, iteration + 1 - _STALL_AFTER] - cost <= stall * cost
        if iteration >= behind_after:
            best_of_group = np.full(labels.max() + 1, np.inf)
            np.minimum.at(best_of_group, labels, cost_out)
            stopped |= cost > (1.0 + behind) * best_of_group[labels[rows]]
        if len(rows) > 1:
            stopped |= _follows_another(x, cost, None if groups is None else labels[rows])
        if stopped.any():
            x_out[rows[stopped]] = x[stopped]
            going = ~stopped
            rows, x, r, cost, jac, damping, growth = (
                rows[going], x[going], r[going], cost[going], jac[going], damping[going], growth[going])
    x_out[rows] = x
    return x_out, cost_out


def _follows_another(x: np.ndarray, cost: np.ndarray, labels: np.ndarray | None) -> np.ndarray:
    """Which of the points (k, p) are within :data:`_DISTINCT` in every coordinate of another point of the same
    group label (all one group when None) with a lower cost (or the same cost and a lower row): the same point
    reached from two starts, which is searched on once."""
    close = (np.abs(x[:, np.newaxis, :] - x) <= _DISTINCT).all(axis=-1)
    if labels is not None:
        close &= labels[:, np.newaxis] == labels
    rank = np.empty(len(cost), dtype=int)
    rank[cost.argsort(kind="stable")] = np.arange(len(cost))
    close &= rank[:, np.newaxis] > rank
    return close.any(axis=1)


def _solve_each(system: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Solutions (k, p) of the systems (k, p, p) with right-hand sides (k, p); a singular system gives a zero step
    (its start then counts the iteration as failed and raises its damping)."""
    try:
        return np.linalg.solve(system, right[..., np.newaxis])[..., 0]
    except np.linalg.LinAlgError:
        solutions = np.zeros_like(right)
        for k in range(len(system)):
            try:
                solutions[k] = np.linalg.solve(system[k], right[k])
            except np.linalg.LinAlgError:
                pass
        return solutions


def _projected_searches(
    projection: Projection, searches: list[int], rng: np.random.Generator
) -> list[list[tuple[float, np.ndarray, np.ndarray]]]:
    """For each weighting of ``projection``: local searches over the branch shapes from its ``searches`` best-scored
    distinct Latin-hypercube shapes (scored on :data:`_SCORING_LINES` of its lines), then from split branches; the
    searches of all weightings in one batch per
    step. Per weighting, (log cost, coordinates, shape) of each result, after the projected samples that best fit
    the accelerance (log cost ∞); without the splits when a search fits exactly."""
    problem, weightings = projection.problem, len(searches)
    found: list[list[tuple[float, np.ndarray, np.ndarray]]] = [[] for _ in range(weightings)]

    def local_searches(starts: list[np.ndarray]) -> float:
        labels = np.repeat(np.arange(weightings), [len(group) for group in starts])
        shapes, _ = _levenberg_marquardt(
            projection.residual_and_jacobian,
            np.concatenate(starts),
            projection.lower,
            projection.upper,
            max_iterations=_SEARCH_ITERATIONS * projection.size,
            tolerance=_SEARCH_TOLERANCE,
            good_enough=_EXACT_LOG_COST * len(projection.index),
            behind=_SEARCH_BEHIND,
            behind_after=_SEARCH_BEHIND_AFTER,
            groups=labels,
        )
        thetas = projection.project(shapes, labels)[0]
        best = np.inf
        for label in range(weightings):
            mine = labels == label
            costs = problem.log_cost(thetas[mine], projection.lines, projection.weights[label])
            found[label].extend((float(c), theta, shape) for c, theta, shape in zip(costs, thetas[mine], shapes[mine]))
            best = min(best, float(np.min(costs)))
        return best

    if projection.size == 0:
        local_searches([np.zeros((1, 0))] * weightings)
        return found
    scoring = Projection(problem, projection.index[_subsample(len(projection.index), _SCORING_LINES)], projection.weights)
    starts = [_chosen_shapes(scoring, label, searches[label], rng, found[label]) for label in range(weightings)]
    if local_searches(starts) <= _EXACT_LOG_COST:
        return found
    splits = [np.array(projection.split_starts(min(group, key=lambda item: item[0])[2])) for group in found]
    if len(splits[0]):
        local_searches(splits)
    return found


def latin_hypercube(dimensions: int, samples: int, rng: np.random.Generator) -> np.ndarray:
    """``samples`` points of a Latin hypercube in [0, 1)^``dimensions``: the same points, bit for bit, as
    ``scipy.stats.qmc.LatinHypercube(d=dimensions, seed=rng).random(samples)`` (a generator spawned from ``rng``,
    one uniform draw per point and coordinate, then a shuffled stratum per coordinate), without importing
    ``scipy.stats`` (half of a command's start-up)."""
    bit_generator = rng.bit_generator
    own = np.random.Generator(type(bit_generator)(bit_generator.seed_seq.spawn(1)[0]))
    jitter = own.uniform(size=(samples, dimensions))
    strata = np.tile(np.arange(1, samples + 1), (dimensions, 1))
    for row in strata:
        own.shuffle(row)
    return (strata.T - jitter) / samples


def _chosen_shapes(
    projection: Projection,
    weighting: int,
    searches: int,
    rng: np.random.Generator,
    found: list[tuple[float, np.ndarray, np.ndarray]],
) -> np.ndarray:
    """The ``searches`` Latin-hypercube shapes best scored in ``weighting`` at least :data:`_START_SPACING` apart;
    the projected samples that best fit the accelerance itself are appended to ``found`` (they join the polish:
    where the model cannot fit the data, the RMS optimum can lie in another basin than the log-stiffness one)."""
    problem = projection.problem
    unit = latin_hypercube(projection.size, _SAMPLES_PER_SHAPE * projection.size, rng)
    # Each sample also with one order at 0: a spring-pot of order 0 is a spring, and a network whose best fit
    # degenerates that way lies on the edge of the box, where a search started inside rarely ends.
    span = projection.start_upper - projection.start_lower
    edges = [unit]
    for i in np.flatnonzero(problem.coords.is_order[projection.free]):
        edge = unit.copy()
        edge[:, i] = (projection.lower[i] - projection.start_lower[i]) / span[i]
        edges.append(edge)
    unit = np.vstack(edges)
    shapes = projection.start_lower + unit * span
    thetas, residuals = projection.project(shapes, np.full(len(shapes), weighting))
    scores = np.mean(residuals**2, axis=-1)
    scores = np.where(np.isfinite(scores), scores, np.inf)
    for start in np.argsort(problem.acc_cost(thetas, projection.lines))[:_ACCELERANCE_STARTS]:
        found.append((np.inf, thetas[start], shapes[start]))
    chosen: list[int] = []
    for start in np.argsort(scores):
        if len(chosen) == searches or not np.isfinite(scores[start]):
            break
        if all(np.linalg.norm(unit[start] - unit[other]) > _START_SPACING for other in chosen):
            chosen.append(int(start))
    return shapes[chosen]


def _distinct(thetas: np.ndarray, count: int) -> list[int]:
    """Indices of the first ``count`` rows of ``thetas`` that differ from every earlier chosen row by more than
    :data:`_DISTINCT` in some coordinate: the same point reached from several starts is polished once."""
    differs = (np.max(np.abs(thetas[:, np.newaxis, :] - thetas[np.newaxis, :, :]), axis=-1) > _DISTINCT).tolist()
    chosen: list[int] = []
    for row in range(len(thetas)):
        if len(chosen) == count:
            break
        if all(differs[row][other] for other in chosen):
            chosen.append(row)
    return chosen


def default_search(
    problem: Problem,
    seed: int,
    progress: Callable[[float], None] | None,
    start: np.ndarray | None = None,
    reachable_cost: float = 0.0,
) -> np.ndarray:
    """Rounds of :func:`_search_round`, each from a fresh Latin hypercube, until the best point so far is the minimum
    of its basin (:func:`_promised_decrease`), two rounds reach the same optimum (their costs agree) or the data are
    fitted to round-off; the best point of all rounds.

    One round finds the global optimum of a fractional network in about 19 cases out of 20; which ones it misses
    depends on the last bits of the arithmetic (another BLAS kernel, another CPU), because the searches that reach the
    narrow basins of nearly degenerate networks (a spring-pot of order near 0 beside a spring, a small series arm)
    start from points whose ranking differs in those bits. A second round misses in other cases, so agreeing rounds
    make the result the same on every machine. A round that missed ended where a Gauss–Newton step still promises a
    decrease (its polish stalled in a valley; on 540 noise-free fits with three BLAS kernels every miss did): a round
    whose point promises none is at a minimum and is not repeated.

    ``start``: coordinates near the optimum (a fit of a network this one is a reduction of), polished first; when that
    reaches ``reachable_cost`` (that fit's weighted sum of squares, which this network, a limit of that one, cannot
    go below) within :data:`_ROUND_AGREEMENT`, it is the optimum and no search round is run; else a round that agrees
    with it ends the search as a second round would."""
    rng = np.random.default_rng(seed)
    exact = _EXACT_LOG_COST * float(np.sum(np.abs(problem.h) ** 2 * problem.sqrt_w**2))
    best_theta, best_cost, minimum = None, np.inf, False
    if start is not None:
        thetas, costs = _polish(problem, start[np.newaxis])
        best_theta, best_cost = thetas[0], float(costs[0])
        if best_cost <= max(exact, (1.0 + _ROUND_AGREEMENT) * reachable_cost):
            logger.debug("%s: polished from the start given, weighted sum of squares %.4g (reachable %.4g)",
                         problem.model.name, best_cost, reachable_cost)
            return best_theta
    for round_index in range(_MAX_ROUNDS):
        theta, cost = _search_round(problem, rng, progress if round_index == 0 else None)
        agrees = (round_index > 0 or start is not None) and abs(cost - best_cost) <= _ROUND_AGREEMENT * best_cost
        if cost < best_cost:
            best_theta, best_cost = theta, cost
            minimum = best_cost > exact and _promised_decrease(problem, theta) <= _MINIMUM_PROMISE
        if best_cost <= exact or agrees or minimum:
            break
    logger.debug("%s: %d search round(s), best weighted sum of squares %.4g", problem.model.name, round_index + 1,
                 best_cost)
    return best_theta


def _promised_decrease(problem: Problem, theta: np.ndarray) -> float:
    """The relative decrease of the weighted sum of squares that a full Gauss–Newton step from ``theta`` promises,
    coordinates at a bound whose gradient points out of the box held there: 0 at the minimum of a basin, near 1 on a
    slope or in the flat valley of a nearly degenerate network (where the polish stalls, and the searches' ranking
    depends on the last bits of the arithmetic). One Jacobian evaluation."""
    residual, jacobian = problem.acc_residual_and_jacobian(theta[np.newaxis])
    residual, jacobian = residual[0], jacobian[0]
    gradient = jacobian.T @ residual
    coords = problem.coords
    held = ((theta <= coords.lower) & (gradient > 0)) | ((theta >= coords.upper) & (gradient < 0))
    free = jacobian[:, ~held]
    cost = float(residual @ residual)
    if free.shape[1] == 0 or not cost > 0:
        return 0.0
    step = np.linalg.lstsq(free, residual, rcond=None)[0]
    promised = free @ step
    return float(promised @ promised) / cost


def _polish(problem: Problem, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The final polish on the accelerance from ``starts`` (k, size): their points and weighted sums of squares."""
    return _levenberg_marquardt(
        problem.acc_residual_and_jacobian, starts, problem.coords.lower, problem.coords.upper, 200, _POLISH_TOLERANCE,
        behind=_POLISH_BEHIND,
        stall=_POLISH_STALL,
    )


def _search_round(
    problem: Problem, rng: np.random.Generator, progress: Callable[[float], None] | None
) -> tuple[np.ndarray, float]:
    """Latin-hypercube shapes → projected local searches (two weightings, in one batch) → branch splits → polish
    on the accelerance; the best point and its weighted sum of squares."""
    coords = problem.coords
    index = _subsample(len(problem.freq_hz), 200)
    powers, searches = (1.0, 2.0), [_LOCAL_SEARCHES, _LOCAL_SEARCHES // 2]
    projection = Projection(problem, index, np.array([problem.log_weights(power) for power in powers]))
    found = _projected_searches(projection, searches, rng)
    candidates = [(cost, theta) for group in found for cost, theta, _ in group]
    if progress is not None:
        progress(0.6)
    for power, group in zip(powers, found):
        logger.debug(
            "%s: log-stiffness search (weight power %g): %d candidates, best log cost %.3g",
            problem.model.name, power, len(group), min(cost for cost, _, _ in group),
        )
    # Every local result is polished briefly on the accelerance (the log-stiffness optimum is not the RMS
    # optimum when the model cannot fit the data), the best ones to convergence; each group in one batch.
    exact = _EXACT_LOG_COST * float(np.sum(np.abs(problem.h[index]) ** 2 * problem.sqrt_w[index] ** 2))
    starts = np.array([theta for _, theta in candidates])
    thetas, costs = _levenberg_marquardt(
        lambda theta: problem.acc_residual_and_jacobian(theta, projection.lines),
        starts[_distinct(starts, len(starts))],
        coords.lower,
        coords.upper,
        _BRIEF_POLISH,
        _SEARCH_TOLERANCE,
        good_enough=exact,
    )
    if progress is not None:
        progress(0.9)
    best = np.argsort(costs, kind="stable")
    thetas, costs = _polish(problem, thetas[best[_distinct(thetas[best], _POLISHED)]])
    best_theta, best_cost = thetas[np.argmin(costs)], float(np.min(costs))
    logger.debug(
        "%s: %d candidates polished on the accelerance, best weighted sum of squares %.4g",
        problem.model.name, len(candidates), best_cost,
    )
    return best_theta, best_cost
