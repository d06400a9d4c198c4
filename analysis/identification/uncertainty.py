"""What an identified parameter is worth: which parameters ended at a bound, standard errors and correlations from
the Jacobian of the residual at the optimum, and the flags a reader should see."""

from __future__ import annotations

import logging
import math

import numpy as np

from gasfilm.analysis.identification.problem import Problem, stack

logger = logging.getLogger(__name__)

#: relative distance to a bound within which a parameter counts as at the bound (not a measurement)
AT_BOUND_RELATIVE = 1e-6
#: relative standard error above which a parameter is flagged as not identifiable
NOT_IDENTIFIABLE_RELATIVE_STD = 1.0
#: |correlation| above which a pair of parameters is flagged
CORRELATION_FLAG = 0.999


def parameters_at_bounds(problem: Problem, theta: np.ndarray, params: np.ndarray) -> tuple[str, ...]:
    """Names of the parameters (and ``mass_kg``) that ended within :data:`AT_BOUND_RELATIVE` of a bound.

    Bounds are each parameter's own (relative to the value for coefficients, to the range for orders), the mass
    box, and the box of the search coordinates (both fitters search it).
    """
    coords = problem.coords
    at_bound = []
    for i, parameter in enumerate(problem.model.parameters):
        value = float(params[i])
        if parameter.scale == "log":
            distance = min(math.log(value / parameter.lower), math.log(parameter.upper / value))
        else:
            distance = min(value - parameter.lower, parameter.upper - value) / (parameter.upper - parameter.lower)
        if not coords.is_order[i]:
            distance = min(distance, theta[i] - coords.lower[i], coords.upper[i] - theta[i])
        if distance <= AT_BOUND_RELATIVE:
            at_bound.append(parameter.name)
    if coords.fit_mass and min(theta[-1] - coords.lower[-1], coords.upper[-1] - theta[-1]) <= AT_BOUND_RELATIVE:
        at_bound.append("mass_kg")
    return tuple(at_bound)


def covariance(problem: Problem, theta: np.ndarray) -> np.ndarray:
    """Linearised covariance of (parameters, mass) from the weighted residual's Jacobian at the optimum."""
    evaluations = problem.evaluations
    jac = problem.acc_jacobian(theta)
    residual = stack(problem.acc_complex_residual(theta) * problem.sqrt_w)
    problem.evaluations = evaluations
    dof = max(len(residual) - jac.shape[1], 1)
    variance = float(residual @ residual) / dof
    # (JᵀJ)⁻¹ from the small normal matrix; directions it cannot resolve get a huge (not a dropped) variance.
    eigenvalues, vectors = np.linalg.eigh(jac.T @ jac)
    floor = max(float(eigenvalues[-1]), 1e-300) * 1e-30
    inverse = (vectors / np.maximum(eigenvalues, floor)) @ vectors.T
    to_params = problem.coords.params_jacobian(theta)
    return variance * to_params @ inverse @ to_params.T


def flags(
    problem: Problem,
    names: list[str],
    values: np.ndarray,
    std: np.ndarray,
    correlation: np.ndarray,
    at_bound: tuple[str, ...],
) -> list[str]:
    """One line per finding: parameters at a bound, not identifiable ones, strongly correlated pairs."""
    found = [f"{name} at a bound of its search range: not a measurement" for name in at_bound]
    parameters = {p.name: p for p in problem.model.parameters}
    for name, value, sigma in zip(names, values, std):
        if name in at_bound:
            continue
        parameter = parameters.get(name)
        if parameter is not None and parameter.scale == "linear":
            relative = sigma / (parameter.upper - parameter.lower)
        else:
            relative = sigma / abs(value)
        if not np.isfinite(relative) or relative > NOT_IDENTIFIABLE_RELATIVE_STD:
            found.append(f"{name} not identifiable (std error {sigma:.3g})")
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(correlation[i, j]) > CORRELATION_FLAG:
                found.append(f"{names[i]} and {names[j]} correlated ({correlation[i, j]:+.4f})")
    return found
