"""One fit's data and search coordinates: the weighted accelerance residual, its Jacobian and evaluation counting.

The model is evaluated only through the element algebra's one evaluator (:meth:`FilmModel.stiffness`,
:meth:`FilmModel.stiffness_and_gradient`), at ``s/ω_r`` with the coordinates' reference values; this module maps the
search coordinates onto those values and the physical parameters, and chains the derivative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike

from gasfilm.analysis.physics.elements import (
    Dashpot,
    FilmModel,
    LogLaplace,
    Node,
    Parallel,
    Series,
    Spring,
    SpringPot,
    laplace_variable,
    log_laplace,
)
from gasfilm.drivers.errors import GasfilmError, SettingError

#: search box of the default fitter for log coordinates, as a factor around the reference stiffness
LOG_BOX = math.log(1e8)
#: search box of a fitted mass, as factors of the starting mass
MASS_BOX = (0.2, 5.0)


class FitCancelledError(GasfilmError):
    """The caller cancelled a running fit."""


class Coordinates:
    """Search coordinates of the default fitter.

    Each coefficient is written as ``g = K0·exp(θ)``, the element's stiffness magnitude at the reference angular
    frequency ω_r (spring ``k = g``, dashpot ``η = g/ω_r``, spring-pot ``η = g/ω_r^α``), so an element reads
    ``Z = g·(s/ω_r)^α`` and a coefficient no longer trades off against its order. Orders are searched as they are.
    With ``fit_mass`` a last coordinate ``θ_m = ln(m/m0)`` is appended.

    The network evaluated at ``s/ω_r`` with the *reference values* (every coefficient replaced by its g) is the
    network at ``s`` with the physical parameters, so the fitter evaluates the model there
    (:meth:`reference_values`) and converts to physical parameters only for the result (:meth:`to_params`).
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
            low, high = -LOG_BOX, LOG_BOX
            if parameter.name not in self.order_of:
                scale = stiffness_ref / omega_ref if parameter.name in self.dashpots else stiffness_ref
                low = max(low, math.log(parameter.lower / scale))
                high = min(high, math.log(parameter.upper / scale))
            lower.append(low)
            upper.append(high)
        if fit_mass:
            lower.append(math.log(MASS_BOX[0]))
            upper.append(math.log(MASS_BOX[1]))
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

    def reference_values(self, theta: np.ndarray, masses: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Parameter vectors (..., P) for the network at ``s/ω_r`` (coefficients g in N/m, orders) and masses (...)
        in kg (None without ``masses``) from coordinates (..., size)."""
        theta = np.asarray(theta, dtype=float)
        values = theta[..., : len(self.names)]
        values = np.where(self.is_order[: len(self.names)], values, self.stiffness_ref * np.exp(values))
        if not masses:
            return values, None
        mass = self.mass_ref * np.exp(theta[..., -1]) if self.fit_mass else np.full(theta.shape[:-1], self.mass_ref)
        return values, mass

    def to_params(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model parameter vectors (..., P) and masses (...) in kg from coordinates (..., size)."""
        params, mass = self.reference_values(theta)
        for i, name in enumerate(self.names):
            if name in self.dashpots:
                params[..., i] /= self.omega_ref
            elif name in self.order_of:
                params[..., i] /= self.omega_ref ** params[..., self.names.index(self.order_of[name])]
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


@dataclass(frozen=True)
class Lines:
    """A fit's data on some of its lines, gathered once: the searches evaluate the model thousands of times on the
    same lines (``index``, an index array or a slice of the problem's lines)."""

    index: np.ndarray | slice
    s_rel: np.ndarray
    log_s_rel: LogLaplace
    s2: np.ndarray
    sqrt_w: np.ndarray
    h: np.ndarray


class Problem:
    """Data, weights, coordinates and evaluation counting of one fit."""

    def __init__(
        self,
        model: FilmModel,
        freq_hz: ArrayLike,
        h_measured: ArrayLike,
        mass_kg: float,
        decay_rate_1_s: float,
        fit_mass: bool,
        weights: ArrayLike | None,
        cancel: Callable[[], bool] | None,
    ):
        self.model = model
        self.freq_hz = np.asarray(freq_hz, dtype=float)
        self.h = np.asarray(h_measured, dtype=complex)
        self.s = laplace_variable(self.freq_hz, decay_rate_1_s)
        self.s2 = self.s**2
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
        self.coords = Coordinates(model, omega_ref, stiffness_ref, mass_kg, fit_mass)
        self.s_rel = self.s / omega_ref  # where the network is evaluated with the coordinates' reference values
        self.all_lines = self.lines(slice(None))
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

    def lines(self, index: np.ndarray | slice) -> Lines:
        """The data on the lines ``index``, for the evaluations below."""
        return Lines(index, self.s_rel[index], log_laplace(self.s_rel[index]), self.s2[index], self.sqrt_w[index],
                     self.h[index])

    def stiffness(self, values: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """Film stiffness Z in N/m on ``lines`` (all by default) for reference-value sets (..., P) at once."""
        lines = self.all_lines if lines is None else lines
        return self.model.stiffness(lines.s_rel, values, lines.log_s_rel)

    def log_cost(self, thetas: np.ndarray, lines: Lines, weights: np.ndarray) -> np.ndarray:
        """Mean squared weighted log-stiffness residual for many coordinate sets at once (``weights`` on all lines)."""
        self.evaluations += len(thetas)
        values, _ = self.coords.reference_values(thetas)
        with np.errstate(all="ignore"):
            r = np.log(self.stiffness(values, lines) / self.z_measured[lines.index]) * weights[lines.index]
        cost = np.mean(np.abs(r) ** 2, axis=-1)
        return np.where(np.isfinite(cost), cost, np.inf)

    def acc_cost(self, thetas: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """Mean squared weighted accelerance residual for many coordinate sets at once."""
        values, mass = self.coords.reference_values(thetas)
        with np.errstate(all="ignore"):
            return self.accelerance_cost(self.stiffness(values, lines), mass, lines)

    def accelerance_cost(self, stiffness: np.ndarray, mass_kg: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """Mean squared weighted accelerance residual ((m/s²)/N)² of film stiffnesses (..., lines) in N/m with
        masses (...) in kg, on ``lines`` (all by default); one evaluation per stiffness set."""
        lines = self.all_lines if lines is None else lines
        self.evaluations += math.prod(stiffness.shape[:-1])
        with np.errstate(all="ignore"):
            h_model = lines.s2 / (stiffness + mass_kg[..., np.newaxis] * lines.s2)
            cost = np.mean(np.abs((h_model - lines.h) * lines.sqrt_w) ** 2, axis=-1)
        return np.where(np.isfinite(cost), cost, np.inf)

    def acc_residual(self, theta: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """Weighted accelerance residual at coordinates (..., size) on ``lines`` (all by default), real and
        imaginary parts stacked (..., 2·lines); one evaluation per point."""
        lines = self.all_lines if lines is None else lines
        self.check_cancel()
        self.evaluations += math.prod(np.shape(theta)[:-1])
        return stack(self.acc_complex_residual(theta, lines) * lines.sqrt_w)

    def acc_complex_residual(self, theta: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """``H(θ) - H_d`` in (m/s²)/N at coordinates (..., size) on ``lines`` (all by default), unweighted, shape
        (..., lines); non-finite values become large finite ones."""
        lines = self.all_lines if lines is None else lines
        values, mass = self.coords.reference_values(theta)
        with np.errstate(all="ignore"):
            residual = lines.s2 / (self.stiffness(values, lines) + mass[..., np.newaxis] * lines.s2) - lines.h
        if np.all(np.isfinite(residual)):  # the usual case, without nan_to_num's cost
            return residual
        return np.nan_to_num(residual, nan=1e6, posinf=1e6, neginf=-1e6)

    def acc_jacobian(self, theta: np.ndarray, lines: Lines | None = None) -> np.ndarray:
        """Jacobian of :meth:`acc_residual` on ``lines`` (all by default) with respect to the coordinates
        (..., size), shape (..., 2·lines, size)."""
        return self.acc_residual_and_jacobian(theta, lines)[1]

    def acc_residual_and_jacobian(
        self, theta: np.ndarray, lines: Lines | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`acc_residual` and its Jacobian at coordinates (..., size), shapes (..., 2·lines) and
        (..., 2·lines, size), from one model evaluation: the model's analytic dZ/d(reference values) times ``g`` for
        a coefficient ``g = K0·e^θ`` (1 for an order), and ``H = s²/(Z + m s²)`` gives ``dH = -H²/s² · dZ`` and
        ``dH/dθ_m = -H² m``. The Jacobian is a view of one contiguous array of its columns."""
        lines = self.all_lines if lines is None else lines
        self.check_cancel()
        self.evaluations += (1 + self.coords.size) * math.prod(np.shape(theta)[:-1])
        values, mass = self.coords.reference_values(theta)
        z, columns = self.model.stiffness_and_gradient(lines.s_rel, values, lines.log_s_rel, parameters_first=True)
        s2, sqrt_w = lines.s2, lines.sqrt_w
        with np.errstate(all="ignore"):
            h_model = s2 / (z + mass[..., np.newaxis] * s2)
        residual = h_model - lines.h
        if not np.isfinite(residual).all():
            residual = np.nan_to_num(residual, nan=1e6, posinf=1e6, neginf=-1e6)
        # one complex factor per line and one real factor per parameter, applied in place
        weighted_h2 = h_model**2 * sqrt_w
        columns *= (-weighted_h2 / s2)[..., np.newaxis, :]
        columns *= np.where(self.coords.is_order[: values.shape[-1]], 1.0, values)[..., np.newaxis]
        if self.coords.fit_mass:
            columns = np.concatenate([columns, (-weighted_h2 * mass[..., np.newaxis])[..., np.newaxis, :]], axis=-2)
        return stack(residual * sqrt_w), stack(columns).swapaxes(-1, -2)


def stack(r: np.ndarray) -> np.ndarray:
    """Real and imaginary parts of complex residuals (..., n) as real vectors (..., 2n), each line's two parts side by
    side (a view of a contiguous array)."""
    return np.ascontiguousarray(r, dtype=complex).view(np.float64)
