"""Identification of gas-film models from a measured accelerance, and their comparison like the paper's Table 2.

Objective (paper eq. 33): ``RMS = sqrt(mean |H_d(k) - H(k)|²)`` on the complex accelerance in (m/s²)/N, with
``H = s² / (Z(s) + m s²)`` at ``s = jω`` (or ``s = σ + jω`` when the FRF was measured through an exponential window
of decay rate σ). Two fitters:

* ``method="default"``: variable projection and Levenberg–Marquardt in decorrelated coordinates. Every
  coefficient becomes the element's stiffness at the reference frequency ω_r (the peak of |H|) relative to the
  measured dynamic stiffness there, in log scale; orders stay linear. The search starts on the *dynamic stiffness*
  ``Z_d = s²/H_d - m s²`` in log space (smooth, no resonance to hit): the scale of each top-level branch is linear
  there and is solved by least squares for given branch shapes, so a small Latin hypercube, a few local searches
  and branch splits run over the shapes only. The results, and the samples that best fit the accelerance, are
  then polished on the accelerance residual itself with an analytic Jacobian.
* ``method="gapso"``: the paper's GA-PSO (section 4): a genetic algorithm finds several "global optimal"
  candidates, particle swarms (eq. 32, scalar c1 per ERRATA item 6) refine around them; converged when the best
  RMS is unchanged for 50 iterations. Searches each parameter's unit interval (log or linear per its scale).

Standard errors and correlations come from the Jacobian of the residual at the optimum.
"""

from __future__ import annotations

import itertools
import math
import re
import time
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.stats import qmc

from gasfilm.analysis.physics.elements import (
    Dashpot,
    FilmModel,
    Node,
    Parallel,
    Series,
    Spring,
    SpringPot,
    accelerance,
    get_model,
    laplace_variable,
    parse_network,
)
from gasfilm.drivers.errors import GasfilmError, SettingError
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2

G_M_S2 = STANDARD_GRAVITY_M_S2
METHODS = ("default", "gapso")

#: relative standard error above which a parameter is flagged as not identifiable
NOT_IDENTIFIABLE_RELATIVE_STD = 1.0
#: |correlation| above which a pair of parameters is flagged
CORRELATION_FLAG = 0.999
#: search box of the default fitter for log coordinates, as a factor around the reference stiffness
_LOG_BOX = math.log(1e8)
#: where the Latin-hypercube shapes are drawn: coefficient ratios within this factor squared, and orders
_LOG_START = math.log(1e3)
_ORDER_START = (0.05, 1.95)
_MASS_BOX = (0.2, 5.0)
#: local searches of the default fitter from the best distinct Latin-hypercube starts
_LOCAL_SEARCHES = 8
#: best local-search results polished on the accelerance
_POLISHED = 2
#: projected Latin-hypercube samples with the lowest accelerance residual that are polished as they are
_ACCELERANCE_STARTS = 6
#: iterations of the brief polish every local result gets
_BRIEF_POLISH = 15
#: Latin-hypercube shapes scored per shape coordinate
_SAMPLES_PER_SHAPE = 32
#: least distance between two starts of local searches, in the unit cube of the shapes
_START_SPACING = 0.1
#: mean squared log-stiffness residual at which the data are matched to round-off and the search stops
_EXACT_LOG_COST = 1e-20


class FitCancelledError(GasfilmError):
    """The caller cancelled a running fit."""


@dataclass
class FitResult:
    """One identified model: parameters with uncertainties, quality (eq. 33) and how the fit went."""

    model_name: str
    network: str
    params: dict[str, float]
    std_errors: dict[str, float]
    correlation: np.ndarray  # (P, P) in the order of correlation_names
    correlation_names: tuple[str, ...]
    rms: float  # eq. 33 in (m/s²)/N
    peak_error: float  # max |H_d - H| in (m/s²)/N
    evaluations: int
    wall_time_s: float
    method: str
    flags: tuple[str, ...]
    band_hz: tuple[float, float]
    mass_kg: float
    mass_fitted: bool
    decay_rate_1_s: float
    n_points: int

    def model(self) -> FilmModel:
        """The fitted network as a model."""
        return parse_network(self.network, self.model_name)

    def accelerance(self, freq_hz: ArrayLike, decay_rate_1_s: float | None = None) -> np.ndarray:
        """The fitted accelerance in (m/s²)/N; by default with the decay rate the fit used."""
        sigma = self.decay_rate_1_s if decay_rate_1_s is None else decay_rate_1_s
        return accelerance(self.model(), self.params, freq_hz, self.mass_kg, sigma)

    def to_dict(self) -> dict:
        """Plain JSON-compatible form for storage."""
        return {
            "model_name": self.model_name,
            "network": self.network,
            "params": dict(self.params),
            "std_errors": dict(self.std_errors),
            "correlation": np.asarray(self.correlation, dtype=float).tolist(),
            "correlation_names": list(self.correlation_names),
            "rms": self.rms,
            "peak_error": self.peak_error,
            "evaluations": self.evaluations,
            "wall_time_s": self.wall_time_s,
            "method": self.method,
            "flags": list(self.flags),
            "band_hz": list(self.band_hz),
            "mass_kg": self.mass_kg,
            "mass_fitted": self.mass_fitted,
            "decay_rate_1_s": self.decay_rate_1_s,
            "n_points": self.n_points,
        }

    @classmethod
    def from_dict(cls, data: Mapping) -> "FitResult":
        """Inverse of :meth:`to_dict`."""
        return cls(
            model_name=str(data["model_name"]),
            network=str(data["network"]),
            params={k: float(v) for k, v in data["params"].items()},
            std_errors={k: float(v) for k, v in data["std_errors"].items()},
            correlation=np.asarray(data["correlation"], dtype=float),
            correlation_names=tuple(data["correlation_names"]),
            rms=float(data["rms"]),
            peak_error=float(data["peak_error"]),
            evaluations=int(data["evaluations"]),
            wall_time_s=float(data["wall_time_s"]),
            method=str(data["method"]),
            flags=tuple(data["flags"]),
            band_hz=(float(data["band_hz"][0]), float(data["band_hz"][1])),
            mass_kg=float(data["mass_kg"]),
            mass_fitted=bool(data["mass_fitted"]),
            decay_rate_1_s=float(data["decay_rate_1_s"]),
            n_points=int(data["n_points"]),
        )


# --- the network with its gradient in decorrelated coordinates ----------------------------------------------------


class _Coordinates:
    """Search coordinates of the default fitter.

    Each coefficient is written as ``g = K0·exp(θ)``, the element's stiffness magnitude at the reference angular
    frequency ω_r (spring ``k = g``, dashpot ``η = g/ω_r``, spring-pot ``η = g/ω_r^α``), so an element reads
    ``Z = g·(s/ω_r)^α`` and a coefficient no longer trades off against its order. Orders are searched as they are.
    With ``fit_mass`` a last coordinate ``θ_m = ln(m/m0)`` is appended.
    """

    def __init__(self, model: FilmModel, omega_ref: float, stiffness_ref: float, mass_kg: float, fit_mass: bool):
        self.model = model
        self.omega_ref = omega_ref
        self.stiffness_ref = stiffness_ref
        self.mass_ref = mass_kg
        self.fit_mass = fit_mass
        self.names = model.parameter_names
        self.order_of: dict[str, str] = {}
        self.dashpots: set[str] = set()
        self.orders: set[str] = set()
        self._collect(model.network)
        self.size = len(self.names) + int(fit_mass)
        lower, upper = [], []
        for parameter in model.parameters:
            if parameter.name in self.orders:
                lower.append(parameter.lower)
                upper.append(parameter.upper)
                continue
            low, high = -_LOG_BOX, _LOG_BOX
            if parameter.name not in self.order_of:
                scale = stiffness_ref / omega_ref if parameter.name in self.dashpots else stiffness_ref
                low = max(low, math.log(parameter.lower / scale))
                high = min(high, math.log(parameter.upper / scale))
            lower.append(low)
            upper.append(high)
        if fit_mass:
            lower.append(math.log(_MASS_BOX[0]))
            upper.append(math.log(_MASS_BOX[1]))
        self.lower = np.array(lower)
        self.upper = np.array(upper)
        self.is_order = np.array([n in self.orders for n in self.names] + [False] * int(fit_mass))

    def _collect(self, node: Node) -> None:
        if isinstance(node, (Parallel, Series)):
            for child in node.children:
                self._collect(child)
        elif isinstance(node, SpringPot):
            self.order_of[node.coefficient] = node.order
            self.orders.add(node.order)
        elif isinstance(node, Dashpot):
            self.dashpots.add(node.name)
        elif not isinstance(node, Spring):
            raise SettingError(f"model {self.model.name}: element {type(node).__name__} is not supported by the fitter")

    def to_params(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model parameter vectors (..., P) and masses (...) from coordinates (..., size)."""
        theta = np.asarray(theta, dtype=float)
        params = np.empty(theta.shape[:-1] + (len(self.names),))
        for i, name in enumerate(self.names):
            if name in self.orders:
                params[..., i] = theta[..., i]
            else:
                params[..., i] = self.stiffness_ref * np.exp(theta[..., i])
        for i, name in enumerate(self.names):
            if name in self.dashpots:
                params[..., i] /= self.omega_ref
            elif name in self.order_of:
                params[..., i] /= self.omega_ref ** params[..., self.names.index(self.order_of[name])]
        mass = self.mass_ref * np.exp(theta[..., -1]) if self.fit_mass else np.full(theta.shape[:-1], self.mass_ref)
        return params, mass

    def from_params(self, params: np.ndarray, mass_kg: float) -> np.ndarray:
        """Coordinates of one parameter vector (inverse of :meth:`to_params`)."""
        theta = np.empty(self.size)
        for i, name in enumerate(self.names):
            value = params[i]
            if name in self.orders:
                theta[i] = value
                continue
            if name in self.dashpots:
                value = value * self.omega_ref
            elif name in self.order_of:
                value = value * self.omega_ref ** params[self.names.index(self.order_of[name])]
            theta[i] = math.log(value / self.stiffness_ref)
        if self.fit_mass:
            theta[-1] = math.log(mass_kg / self.mass_ref)
        return theta

    def params_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """d(model parameters, mass)/dθ at one point, shape (P [+1], size)."""
        params, mass = self.to_params(theta)
        n = len(self.names)
        jac = np.zeros((self.size, self.size))
        for i, name in enumerate(self.names):
            if name in self.orders:
                jac[i, i] = 1.0
            else:
                jac[i, i] = params[i]
            if name in self.order_of:
                jac[i, self.names.index(self.order_of[name])] = -params[i] * math.log(self.omega_ref)
        if self.fit_mass:
            jac[n, n] = mass
        return jac

    def stiffness(
        self, theta: np.ndarray, s_rel: np.ndarray, log_s_rel: np.ndarray, gradient: bool
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Z(s) in N/m for coordinates (..., size), with dZ/dθ per parameter name when ``gradient``."""
        values = {name: np.asarray(theta)[..., i, np.newaxis] for i, name in enumerate(self.names)}
        return self._node(self.model.network, values, s_rel, log_s_rel, gradient)

    def _node(self, node, values, s_rel, log_s_rel, gradient):
        if isinstance(node, Spring):
            z = self.stiffness_ref * np.exp(values[node.name]) * np.ones_like(s_rel)
            return z, {node.name: z} if gradient else {}
        if isinstance(node, Dashpot):
            z = self.stiffness_ref * np.exp(values[node.name]) * s_rel
            return z, {node.name: z} if gradient else {}
        if isinstance(node, SpringPot):
            power = np.exp(values[node.order] * log_s_rel)
            z = self.stiffness_ref * np.exp(values[node.coefficient]) * power
            return z, {node.coefficient: z, node.order: z * log_s_rel} if gradient else {}
        parts = [self._node(child, values, s_rel, log_s_rel, gradient) for child in node.children]
        if isinstance(node, Parallel):
            z = sum(part[0] for part in parts)
            grads = {name: g for part in parts for name, g in part[1].items()}
            return z, grads
        z = 1.0 / sum(1.0 / part[0] for part in parts)
        grads = {}
        if gradient:
            for part_z, part_grads in parts:
                factor = (z / part_z) ** 2
                for name, g in part_grads.items():
                    grads[name] = factor * g
        return z, grads


# --- the default fitter -------------------------------------------------------------------------------------------


class _Problem:
    """Data, weights, coordinates and evaluation counting of one fit."""

    def __init__(self, model, freq_hz, h_measured, mass_kg, decay_rate_1_s, fit_mass, weights, cancel):
        self.model = model
        self.freq_hz = np.asarray(freq_hz, dtype=float)
        self.h = np.asarray(h_measured, dtype=complex)
        self.s = laplace_variable(self.freq_hz, decay_rate_1_s)
        self.weights = np.ones(len(self.freq_hz)) if weights is None else np.asarray(weights, dtype=float)
        self.sqrt_w = np.sqrt(self.weights / np.mean(self.weights))
        self.cancel = cancel
        self.evaluations = 0
        self.z_measured = self.s**2 / self.h - mass_kg * self.s**2
        peak = int(np.argmax(np.abs(self.h) * self.weights))
        omega_ref = abs(self.s[peak].imag)
        stiffness_ref = abs(self.z_measured[peak])
        if not (omega_ref > 0 and np.isfinite(stiffness_ref) and stiffness_ref > 0):
            omega_ref = float(np.exp(np.mean(np.log(np.abs(self.s)))))
            stiffness_ref = float(np.median(np.abs(self.z_measured)))
        self.coords = _Coordinates(model, omega_ref, stiffness_ref, mass_kg, fit_mass)
        self.s_rel = self.s / omega_ref
        self.log_s_rel = np.log(self.s_rel)
        sensitivity = np.abs(self.h) ** 2 * np.abs(self.z_measured) / np.abs(self.s) ** 2
        self.sensitivity = sensitivity / np.max(sensitivity)

    def log_weights(self, power: float) -> np.ndarray:
        """Weights of the log-stiffness residual: the accelerance sensitivity ``|dH/dlnZ| = |H|²|Z|/|s|²`` to a
        power. Power 2 makes the log-stiffness residual the linearised accelerance residual (the RMS objective);
        power 1 still lets points where Z_d is buried in the mass line count less, without reducing the fit to the
        resonance, and finds the solution more often on data a model can fit."""
        weights = self.sqrt_w * self.sensitivity ** (power / 2)
        return weights / np.sqrt(np.mean(weights**2))

    def check_cancel(self) -> None:
        if self.cancel is not None and self.cancel():
            raise FitCancelledError(f"fit of {self.model.name} cancelled")

    def _z(self, theta, index, gradient):
        return self.coords.stiffness(theta, self.s_rel[index], self.log_s_rel[index], gradient)

    def log_cost(self, thetas: np.ndarray, index: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Mean squared weighted log-stiffness residual for many coordinate sets at once."""
        self.evaluations += len(thetas)
        z, _ = self._z(thetas, index, False)
        with np.errstate(all="ignore"):
            r = np.log(z / self.z_measured[index]) * weights[index]
        cost = np.mean(np.abs(r) ** 2, axis=-1)
        return np.where(np.isfinite(cost), cost, np.inf)

    def acc_cost(self, thetas: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Mean squared weighted accelerance residual for many coordinate sets at once."""
        self.evaluations += len(thetas)
        z, _ = self._z(thetas, index, False)
        _, mass = self.coords.to_params(thetas)
        s = self.s[index]
        with np.errstate(all="ignore"):
            h_model = s**2 / (z + mass[..., np.newaxis] * s**2)
            cost = np.mean(np.abs((h_model - self.h[index]) * self.sqrt_w[index]) ** 2, axis=-1)
        return np.where(np.isfinite(cost), cost, np.inf)

    def acc_residual(self, theta):
        self.check_cancel()
        self.evaluations += 1
        return _stack(self.acc_complex_residual(theta) * self.sqrt_w)

    def acc_complex_residual(self, theta) -> np.ndarray:
        z, _ = self.coords.stiffness(theta, self.s_rel, self.log_s_rel, False)
        _, mass = self.coords.to_params(theta)
        h_model = self.s**2 / (z + mass * self.s**2)
        return np.nan_to_num(h_model - self.h, nan=1e6, posinf=1e6, neginf=-1e6)

    def acc_jacobian(self, theta):
        self.evaluations += self.coords.size
        z, grads = self.coords.stiffness(theta, self.s_rel, self.log_s_rel, True)
        _, mass = self.coords.to_params(theta)
        h_model = self.s**2 / (z + mass * self.s**2)
        factor = -(h_model**2) / self.s**2
        columns = [factor * grads[name] for name in self.coords.names]
        if self.coords.fit_mass:
            columns.append(-(h_model**2) * mass)
        return _stack_columns([c * self.sqrt_w for c in columns])


def _stack(r: np.ndarray) -> np.ndarray:
    return np.concatenate([r.real, r.imag])


def _stack_columns(columns: Sequence[np.ndarray]) -> np.ndarray:
    j = np.stack(columns, axis=-1)
    return np.concatenate([j.real, j.imag], axis=0)


def _subsample(n: int, count: int) -> np.ndarray:
    return np.arange(n) if n <= count else np.unique(np.linspace(0, n - 1, count).round().astype(int))


class _Projection:
    """Variable projection of the log-stiffness problem onto the branch shapes.

    The top of a network is a parallel (``Z = Σ c_b φ_b``) or series (``1/Z = Σ φ_b⁻¹ / c_b``) combination of
    branches, and a branch is homogeneous of degree one in its coefficients: scaling them all by ``c_b`` scales its
    stiffness by ``c_b``. With the branch *shapes* ψ fixed (each coefficient relative to the branch's first one, and
    the orders) the scales solve a small linear least-squares problem weighted like the relative stiffness
    residual, so the search runs over ψ only.
    """

    def __init__(self, problem: _Problem, index: np.ndarray, weights: np.ndarray):
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
        is_order = coords.is_order[self.free]
        self.lower = np.where(is_order, coords.lower[self.free], -2 * _LOG_BOX)
        self.upper = np.where(is_order, coords.upper[self.free], 2 * _LOG_BOX)
        self.start_lower = np.where(is_order, _ORDER_START[0], -2 * _LOG_START)
        self.start_upper = np.where(is_order, _ORDER_START[1], 2 * _LOG_START)
        z = problem.z_measured[index]
        self.weights = weights
        weight = weights[index]
        self.row_weight = weight * np.abs(z) if self.compliance else weight / np.abs(z)
        target = (1.0 / z if self.compliance else z) * self.row_weight
        self.target = np.concatenate([target.real, target.imag])

    def project(self, psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates (..., size) from shapes (..., free), the branch scales solved by least squares, and the
        weighted relative stiffness residual (..., 2n) those coordinates leave."""
        self.problem.check_cancel()
        self.problem.evaluations += int(np.prod(psi.shape[:-1]))
        coords, problem = self.problem.coords, self.problem
        theta = np.zeros(psi.shape[:-1] + (coords.size,))
        theta[..., self.free] = psi
        values = {name: theta[..., i, np.newaxis] for i, name in enumerate(coords.names)}
        s_rel, log_s_rel = problem.s_rel[self.index], problem.log_s_rel[self.index]
        with np.errstate(all="ignore"):
            basis = [coords._node(branch, values, s_rel, log_s_rel, False)[0] for branch in self.branches]
            basis = np.stack([1.0 / b if self.compliance else b for b in basis], axis=-1)
            basis = basis * self.row_weight[:, np.newaxis]
            a = np.concatenate([basis.real, basis.imag], axis=-2)
            a = np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0)
            coefficients = self._solve(a)
            # A branch whose best coefficient is negative is dropped and the others solved again.
            a = a * (coefficients > 0)[..., np.newaxis, :]
            coefficients = self._solve(a)
            valid = np.isfinite(coefficients) & (coefficients > 0)
            residual = (a @ np.where(valid, coefficients, 0.0)[..., np.newaxis])[..., 0] - self.target
            log_coefficients = np.log(np.where(valid, coefficients, 1.0))
            # Series: the branch scale is 1/coefficient and a dropped branch becomes infinitely stiff;
            # parallel: the scale is the coefficient and a dropped branch becomes infinitely soft.
            if self.compliance:
                log_scales = np.where(valid, -log_coefficients, _LOG_BOX)
            else:
                log_scales = np.where(valid, log_coefficients, -_LOG_BOX)
        for b, anchor in enumerate(self.anchors):
            theta[..., anchor] = log_scales[..., b]
            for member in self.members[b]:
                theta[..., member] += log_scales[..., b]
        return np.clip(theta, coords.lower, coords.upper), residual

    def _solve(self, a: np.ndarray) -> np.ndarray:
        normal = np.swapaxes(a, -1, -2) @ a
        ridge = 1e-12 * np.trace(normal, axis1=-2, axis2=-1)[..., np.newaxis, np.newaxis] + 1e-300
        right = (np.swapaxes(a, -1, -2) @ self.target)[..., np.newaxis]
        return np.linalg.solve(normal + ridge * np.eye(len(self.branches)), right)[..., 0]

    def residual(self, psi: np.ndarray) -> np.ndarray:
        return self.project(psi)[1]

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

    def jacobian(self, psi: np.ndarray) -> np.ndarray:
        """Forward differences of :meth:`residual`, all shifted shapes projected in one call."""
        step = 1e-7 * np.maximum(1.0, np.abs(psi))
        step = np.where(psi + step > self.upper, -step, step)
        points = np.vstack([psi, psi + np.diag(step)])
        residuals = self.project(points)[1]
        return ((residuals[1:] - residuals[0]) / step[:, np.newaxis]).T


def _levenberg_marquardt(
    residual: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    max_iterations: int,
    tolerance: float,
) -> tuple[np.ndarray, float]:
    """Box-constrained Levenberg–Marquardt (Nielsen's damping update, steps projected onto the box).

    Solves the small scaled normal equations instead of factorising the tall Jacobian: with a few parameters and
    thousands of residuals this is an order of magnitude faster than a QR/SVD per step, and the damping keeps it
    stable where the normal equations are ill-conditioned. Stops when a successful step lowers the cost by less
    than ``tolerance`` (relative) and the local model predicted no more (MINPACK's ftol test), after
    ``max_iterations``, or when no damping gives a lower cost. Returns (x, sum of squared residuals).
    """
    x = np.clip(np.asarray(x0, dtype=float), lower, upper)
    r = residual(x)
    cost = float(r @ r)
    jac = jacobian(x)
    damping, growth = 1e-3, 2.0
    for _ in range(max_iterations):
        normal = jac.T @ jac
        gradient = jac.T @ r
        scale = np.sqrt(np.diag(normal))
        scale[~(scale > 0)] = 1.0
        scaled = normal / np.outer(scale, scale)
        try:
            step = -np.linalg.solve(scaled + damping * np.eye(len(x)), gradient / scale) / scale
        except np.linalg.LinAlgError:
            damping *= growth
            growth *= 2.0
            continue
        trial = np.clip(x + step, lower, upper)
        r_trial = residual(trial)
        cost_trial = float(r_trial @ r_trial)
        linear = r + jac @ (trial - x)
        predicted = cost - float(linear @ linear)
        if np.isfinite(cost_trial) and cost_trial < cost:
            gain = (cost - cost_trial) / predicted if predicted > 0 else 0.0
            converged = cost - cost_trial <= tolerance * cost and predicted <= tolerance * cost
            x, r, cost = trial, r_trial, cost_trial
            if converged or cost == 0.0:
                break
            jac = jacobian(x)
            damping *= max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
            growth = 2.0
        else:
            damping *= growth
            growth *= 2.0
            if damping > 1e16:
                break
    return x, cost


def _projected_searches(
    projection: _Projection, searches: int, rng: np.random.Generator
) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Local searches over the branch shapes from the best-scored distinct Latin-hypercube shapes, then from
    split branches; (log cost, coordinates, shape) of each, stopping early on an exact fit."""
    problem, index = projection.problem, projection.index
    found: list[tuple[float, np.ndarray, np.ndarray]] = []

    def local_search(start: np.ndarray) -> float:
        shape, _ = _levenberg_marquardt(
            projection.residual,
            projection.jacobian,
            start,
            projection.lower,
            projection.upper,
            max_iterations=50 * projection.size,
            tolerance=1e-10,
        )
        theta = projection.project(shape)[0]
        cost = float(problem.log_cost(theta[np.newaxis], index, projection.weights)[0])
        found.append((cost, theta, shape))
        return cost

    if projection.size == 0:
        local_search(np.zeros(0))
        return found
    unit = qmc.LatinHypercube(d=projection.size, seed=rng).random(_SAMPLES_PER_SHAPE * projection.size)
    shapes = projection.start_lower + unit * (projection.start_upper - projection.start_lower)
    thetas, residuals = projection.project(shapes)
    scores = np.mean(residuals**2, axis=-1)
    scores = np.where(np.isfinite(scores), scores, np.inf)
    # The projected samples that best fit the accelerance itself join the polish: where the model cannot fit
    # the data, the RMS optimum can lie in another basin than the log-stiffness optimum.
    for start in np.argsort(problem.acc_cost(thetas, index))[:_ACCELERANCE_STARTS]:
        found.append((np.inf, thetas[start], shapes[start]))
    chosen: list[int] = []
    for start in np.argsort(scores):
        if len(chosen) == searches or not np.isfinite(scores[start]):
            break
        if all(np.linalg.norm(unit[start] - unit[other]) > _START_SPACING for other in chosen):
            chosen.append(int(start))
    for start in chosen:
        if local_search(shapes[start]) <= _EXACT_LOG_COST:
            return found
    best = min(found, key=lambda item: item[0])
    for start in projection.split_starts(best[2]):
        if local_search(start) <= _EXACT_LOG_COST:
            break
    return found


def _default_search(problem: _Problem, seed: int, progress: Callable[[float], None] | None) -> np.ndarray:
    """Latin-hypercube shapes → projected local searches (two weightings) → branch splits → polish on the
    accelerance."""
    coords = problem.coords
    rng = np.random.default_rng(seed)
    index = _subsample(len(problem.freq_hz), 200)
    candidates: list[tuple[float, np.ndarray]] = []
    stages = ((1.0, _LOCAL_SEARCHES), (2.0, _LOCAL_SEARCHES // 2))
    for stage, (power, searches) in enumerate(stages):
        projection = _Projection(problem, index, problem.log_weights(power))
        found = _projected_searches(projection, searches, rng)
        candidates += [(cost, theta) for cost, theta, _ in found]
        if progress is not None:
            progress(0.6 * (stage + 1) / len(stages))
        if min(cost for cost, _, _ in found) <= _EXACT_LOG_COST:
            break
    # Every local result is polished briefly on the accelerance (the log-stiffness optimum is not the RMS
    # optimum when the model cannot fit the data), the best ones to convergence.
    def brief_polish(theta: np.ndarray) -> tuple[float, np.ndarray]:
        theta, cost = _levenberg_marquardt(
            problem.acc_residual, problem.acc_jacobian, theta, coords.lower, coords.upper, _BRIEF_POLISH, 1e-10
        )
        return cost, theta

    polished = []
    for count, (_, theta) in enumerate(candidates):
        if progress is not None:
            progress(0.6 + 0.3 * count / len(candidates))
        polished.append(brief_polish(theta))
    polished.sort(key=lambda item: item[0])
    final = []
    for _, theta in polished[:_POLISHED]:
        theta, cost = _levenberg_marquardt(
            problem.acc_residual, problem.acc_jacobian, theta, coords.lower, coords.upper, 200, 1e-10
        )
        final.append((cost, theta))
    return min(final, key=lambda item: item[0])[1]


# --- the paper's GA-PSO -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GapsoSettings:
    """Settings of the GA-PSO search (paper section 4, Figure 14)."""

    population: int = 60
    crossover_rate: float = 0.8
    mutation_sigma: float = 0.1
    elite: int = 2
    candidates: int = 4
    swarm_size: int = 15
    inertia: float = 0.729
    c1: float = 1.49445
    c2: float = 1.49445
    max_velocity: float = 0.2
    stall_iterations: int = 50
    relative_tolerance: float = 1e-9
    max_generations: int = 1000
    max_iterations: int = 3000


class _UnitObjective:
    """Weighted RMS (eq. 33) of whole populations in the parameters' unit intervals, in one model call."""

    def __init__(self, problem: _Problem, mass_kg: float, fit_mass: bool):
        self.problem = problem
        self.mass_kg = mass_kg
        self.fit_mass = fit_mass
        self.dimension = len(problem.model.parameters) + int(fit_mass)

    def to_params(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        model = self.problem.model
        params = np.stack([p.from_unit_interval(u[..., i]) for i, p in enumerate(model.parameters)], axis=-1)
        if self.fit_mass:
            low, high = np.log(_MASS_BOX[0]), np.log(_MASS_BOX[1])
            mass = self.mass_kg * np.exp(low + u[..., -1] * (high - low))
        else:
            mass = np.full(u.shape[:-1], self.mass_kg)
        return params, mass

    def __call__(self, u: np.ndarray) -> np.ndarray:
        problem = self.problem
        problem.check_cancel()
        params, mass = self.to_params(u)
        problem.evaluations += int(np.prod(u.shape[:-1]))
        z = problem.model.stiffness(problem.s, params)
        with np.errstate(all="ignore"):
            h_model = problem.s**2 / (z + mass[..., np.newaxis] * problem.s**2)
            rms = np.sqrt(np.mean(np.abs((h_model - problem.h) * problem.sqrt_w) ** 2, axis=-1))
        return np.where(np.isfinite(rms), rms, np.inf)


def _unchanged(previous: float, current: float, tolerance: float) -> bool:
    return previous - current <= tolerance * abs(previous)


def gapso_search(
    objective: Callable[[np.ndarray], np.ndarray],
    dimension: int,
    seed: int = 0,
    settings: GapsoSettings = GapsoSettings(),
    progress: Callable[[float], None] | None = None,
) -> tuple[np.ndarray, float]:
    """Minimise ``objective`` (vectorised over rows) on the unit cube by GA then PSO; returns (best point, value).

    GA: tournament selection, extended intermediate crossover, Gaussian mutation, elitism, until the best value
    is unchanged for ``stall_iterations`` generations. The best distinct individuals become the "global optimal"
    candidates; a swarm per candidate then follows eq. 32 ``v = w v + c1 r1 (p - x) + c2 r2 (g - x)`` until the best
    value is unchanged for ``stall_iterations`` iterations.
    """
    rng = np.random.default_rng(seed)
    n = settings.population
    population = rng.random((n, dimension))
    values = objective(population)
    best = float(values.min())
    stall = 0
    for generation in range(settings.max_generations):
        first, second = rng.integers(n, size=(2, n))
        parents = population[np.where(values[first] <= values[second], first, second)]
        mates = parents[rng.permutation(n)]
        blend = rng.uniform(-0.25, 1.25, size=(n, dimension))
        cross = rng.random(n) < settings.crossover_rate
        children = np.where(cross[:, np.newaxis], parents + blend * (mates - parents), parents)
        mutate = rng.random((n, dimension)) < 1.0 / dimension
        children = np.clip(children + mutate * rng.normal(0.0, settings.mutation_sigma, (n, dimension)), 0.0, 1.0)
        elite = np.argsort(values)[: settings.elite]
        children[: settings.elite] = population[elite]
        child_values = objective(children[settings.elite :])
        population = children
        values = np.concatenate([values[elite], child_values])
        current = float(values.min())
        stall = stall + 1 if _unchanged(best, current, settings.relative_tolerance) else 0
        best = min(best, current)
        if progress is not None:
            progress(0.5 * max(generation / settings.max_generations, stall / settings.stall_iterations))
        if stall >= settings.stall_iterations:
            break

    candidates: list[np.ndarray] = []
    for index in np.argsort(values):
        if all(np.linalg.norm(population[index] - c) > 0.05 for c in candidates):
            candidates.append(population[index])
        if len(candidates) == settings.candidates:
            break
    k, m = len(candidates), settings.swarm_size
    centres = np.array(candidates)
    positions = np.clip(centres[:, np.newaxis, :] + rng.normal(0.0, 0.05, (k, m, dimension)), 0.0, 1.0)
    positions[:, 0] = centres
    velocities = np.zeros_like(positions)
    personal = positions.copy()
    personal_values = objective(positions)
    best = float(personal_values.min())
    stall = 0
    for iteration in range(settings.max_iterations):
        leader = personal[np.arange(k), np.argmin(personal_values, axis=1)]
        r1 = rng.random(positions.shape)
        r2 = rng.random(positions.shape)
        velocities = (
            settings.inertia * velocities
            + settings.c1 * r1 * (personal - positions)
            + settings.c2 * r2 * (leader[:, np.newaxis, :] - positions)
        )
        velocities = np.clip(velocities, -settings.max_velocity, settings.max_velocity)
        positions = np.clip(positions + velocities, 0.0, 1.0)
        values_now = objective(positions)
        better = values_now < personal_values
        personal[better] = positions[better]
        personal_values[better] = values_now[better]
        current = float(personal_values.min())
        stall = stall + 1 if _unchanged(best, current, settings.relative_tolerance) else 0
        best = min(best, current)
        if progress is not None:
            progress(0.5 + 0.5 * max(iteration / settings.max_iterations, stall / settings.stall_iterations))
        if stall >= settings.stall_iterations:
            break
    flat = np.unravel_index(np.argmin(personal_values), personal_values.shape)
    return personal[flat], float(personal_values[flat])


# --- fit, uncertainties, flags ------------------------------------------------------------------------------------


def fit_model(
    model: FilmModel | str,
    freq_hz: ArrayLike,
    h_measured: ArrayLike,
    mass_kg: float,
    method: str = "default",
    decay_rate_1_s: float = 0.0,
    fit_mass: bool = False,
    weights: ArrayLike | None = None,
    seed: int = 0,
    progress: Callable[[float], None] | None = None,
    cancel: Callable[[], bool] | None = None,
    gapso_settings: GapsoSettings = GapsoSettings(),
) -> FitResult:
    """Fit ``model`` to the measured accelerance ``h_measured`` ((m/s²)/N at ``freq_hz``) of ``mass_kg`` on the film.

    ``decay_rate_1_s`` > 0 fits the exponentially windowed model; ``fit_mass`` also identifies the mass (starting
    at ``mass_kg``); ``weights`` (e.g. the coherence) weight the frequency points. ``progress`` receives fractions in
    [0, 1]; ``cancel`` returning True stops the fit with :class:`FitCancelledError`.
    """
    started = time.perf_counter()
    film = get_model(model) if isinstance(model, str) else model
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex)
    _check_inputs(film, freq, h, mass_kg, method, weights)
    problem = _Problem(film, freq, h, float(mass_kg), float(decay_rate_1_s), fit_mass, weights, cancel)
    coords = problem.coords
    if method == "default":
        theta = _default_search(problem, seed, progress)
        params, mass = coords.to_params(theta)
        mass = float(mass)
        at_search_bound = [
            name
            for name, value, low, high in zip(coords.names, theta, coords.lower, coords.upper)
            if name not in coords.orders and min(value - low, high - value) < 1e-6
        ]
    else:
        objective = _UnitObjective(problem, float(mass_kg), fit_mass)
        best_unit, _ = gapso_search(objective, objective.dimension, seed, gapso_settings, progress)
        params_2d, mass_1d = objective.to_params(best_unit[np.newaxis, :])
        params, mass = params_2d[0], float(mass_1d[0])
        theta = coords.from_params(params, mass)
        at_search_bound = []
    if progress is not None:
        progress(1.0)
    return _result(problem, method, theta, params, mass, at_search_bound, started)


def _check_inputs(model: FilmModel, freq: np.ndarray, h: np.ndarray, mass_kg: float, method: str, weights) -> None:
    if method not in METHODS:
        raise SettingError(f"fit method '{method}': unknown; choose one of {', '.join(METHODS)}")
    if freq.ndim != 1 or freq.shape != h.shape:
        raise SettingError(f"fit {model.name}: freq_hz {freq.shape} and accelerance {h.shape} must be equal 1-D arrays")
    if len(freq) <= len(model.parameters) + 1:
        raise SettingError(
            f"fit {model.name}: {len(freq)} frequency points are too few for {len(model.parameters)} parameters"
        )
    if not (np.all(np.isfinite(freq)) and np.all(np.isfinite(h)) and np.all(h != 0)):
        raise SettingError(f"fit {model.name}: the accelerance has non-finite or zero values")
    if np.any(freq <= 0):
        raise SettingError(f"fit {model.name}: the band must exclude 0 Hz")
    if not mass_kg > 0:
        raise SettingError(f"fit {model.name}: mass_kg must be positive, got {mass_kg}")
    if weights is not None:
        w = np.asarray(weights, dtype=float)
        if w.shape != freq.shape or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
            raise SettingError(f"fit {model.name}: weights must be finite, non-negative, one per frequency point")


def _result(problem: _Problem, method: str, theta, params, mass, at_search_bound, started) -> FitResult:
    model, coords = problem.model, problem.coords
    residual = problem.acc_complex_residual(theta)
    names = list(coords.names) + (["mass_kg"] if coords.fit_mass else [])
    values = np.append(params, mass) if coords.fit_mass else np.asarray(params)
    covariance = _covariance(problem, theta)
    std = np.sqrt(np.abs(np.diag(covariance)))
    with np.errstate(all="ignore"):
        correlation = covariance / np.outer(std, std)
    correlation = np.where(np.isfinite(correlation), correlation, 0.0)
    np.fill_diagonal(correlation, 1.0)
    flags = _flags(model, names, values, std, correlation, at_search_bound)
    return FitResult(
        model_name=model.name,
        network=model.text,
        params=model.mapping(params),
        std_errors={n: float(s) for n, s in zip(names, std)},
        correlation=correlation,
        correlation_names=tuple(names),
        rms=float(np.sqrt(np.mean(np.abs(residual) ** 2))),
        peak_error=float(np.max(np.abs(residual))),
        evaluations=problem.evaluations,
        wall_time_s=time.perf_counter() - started,
        method=method,
        flags=tuple(flags),
        band_hz=(float(problem.freq_hz.min()), float(problem.freq_hz.max())),
        mass_kg=float(mass),
        mass_fitted=coords.fit_mass,
        decay_rate_1_s=float(problem.s[0].real),
        n_points=len(problem.freq_hz),
    )


def _covariance(problem: _Problem, theta: np.ndarray) -> np.ndarray:
    """Linearised covariance of (parameters, mass) from the weighted residual's Jacobian at the optimum."""
    evaluations = problem.evaluations
    jac = problem.acc_jacobian(theta)
    residual = _stack(problem.acc_complex_residual(theta) * problem.sqrt_w)
    problem.evaluations = evaluations
    dof = max(len(residual) - jac.shape[1], 1)
    variance = float(residual @ residual) / dof
    # (JᵀJ)⁻¹ from the small normal matrix; directions it cannot resolve get a huge (not a dropped) variance.
    eigenvalues, vectors = np.linalg.eigh(jac.T @ jac)
    floor = max(float(eigenvalues[-1]), 1e-300) * 1e-30
    inverse = (vectors / np.maximum(eigenvalues, floor)) @ vectors.T
    to_params = problem.coords.params_jacobian(theta)
    return variance * to_params @ inverse @ to_params.T


def _flags(model: FilmModel, names, values, std, correlation, at_search_bound) -> list[str]:
    flags = []
    parameters = {p.name: p for p in model.parameters}
    for name, value, sigma in zip(names, values, std):
        parameter = parameters.get(name)
        if parameter is not None:
            linear = parameter.scale == "linear"
            u = float(parameter.to_unit_interval(np.asarray(value))) if value > 0 or linear else 0.0
            if u <= 1e-6 or u >= 1 - 1e-6:
                flags.append(f"{name} at its {'lower' if u <= 0.5 else 'upper'} bound")
            relative = sigma / (parameter.upper - parameter.lower) if linear else sigma / abs(value)
        else:
            relative = sigma / abs(value)
        if not np.isfinite(relative) or relative > NOT_IDENTIFIABLE_RELATIVE_STD:
            flags.append(f"{name} not identifiable (std error {sigma:.3g})")
    flags.extend(f"{name} at the search bound" for name in at_search_bound)
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(correlation[i, j]) > CORRELATION_FLAG:
                flags.append(f"{names[i]} and {names[j]} correlated ({correlation[i, j]:+.4f})")
    return flags


# --- comparison like Table 2 --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ComparisonRow:
    """One row of the Table-2 comparison; errors in (m/s²)/N, E and E_m in % against SD (eq. 35)."""

    rank: int
    model_name: str
    n_parameters: int
    rms: float
    e_percent: float | None
    peak_error: float
    e_m_percent: float | None
    aic: float
    bic: float


def compare_models(fits: Sequence[FitResult], freq_hz: ArrayLike, h: ArrayLike) -> list[ComparisonRow]:
    """Rank fits by RMS (eq. 33) on the given data; E and E_m (eq. 35) against the SD fit when one is present."""
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    n_real = 2 * len(freq)
    measured = []
    for fit in fits:
        residual = fit.accelerance(freq) - h
        rss = float(np.sum(np.abs(residual) ** 2))
        k = len(fit.params) + int(fit.mass_fitted)
        log_likelihood_term = n_real * math.log(max(rss, 1e-300) / n_real)
        measured.append(
            (fit, math.sqrt(rss / len(freq)), float(np.max(np.abs(residual))), k, log_likelihood_term)
        )
    reference = next((m for m in measured if m[0].model_name == "SD"), None)
    rows = []
    for rank, (fit, rms, peak, k, term) in enumerate(sorted(measured, key=lambda m: m[1]), start=1):
        e = e_m = None
        if reference is not None:
            e = 100.0 * (reference[1] - rms) / reference[1]
            e_m = 100.0 * (reference[2] - peak) / reference[2]
        aic, bic = term + 2 * k, term + k * math.log(n_real)
        rows.append(ComparisonRow(rank, fit.model_name, k, rms, e, peak, e_m, aic, bic))
    return rows


def format_table2(rows: Sequence[ComparisonRow], units: str = "g/N") -> str:
    """The comparison as a text table in g/N (like the paper's Table 2, ERRATA item 5) or SI ((m/s²)/N)."""
    if units not in ("g/N", "SI"):
        raise SettingError(f"table units '{units}': choose 'g/N' or 'SI'")
    scale, label = (1.0 / G_M_S2, "g/N") if units == "g/N" else (1.0, "(m/s²)/N")

    def percent(value: float | None) -> str:
        return "—" if value is None else f"{value:.2f}%"

    header = (
        f"{'#':>2}  {'Model':<10}{'k':>3}  {'RMS ' + label:>16}  {'E':>9}  {'Peak error ' + label:>22}  "
        f"{'E_m':>9}  {'AIC':>10}  {'BIC':>10}"
    )
    lines = [header, "-" * len(header)]
    for row in rows:
        lines.append(
            f"{row.rank:>2}  {row.model_name:<10}{row.n_parameters:>3}  {row.rms * scale:>16.6g}  "
            f"{percent(row.e_percent):>9}  "
            f"{row.peak_error * scale:>22.6g}  {percent(row.e_m_percent):>9}  {row.aic:>10.1f}  {row.bic:>10.1f}"
        )
    return "\n".join(lines)
