"""The paper's GA-PSO search (section 4): a genetic algorithm finds several "global optimal" candidates, particle
swarms (eq. 32, scalar c1 per ERRATA item 6) refine around them; converged when the best RMS is unchanged for 50
iterations. Searches each parameter's unit interval (log or linear per its scale).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable

import numpy as np

from gasfilm.analysis.identification.problem import MASS_BOX, Problem

logger = logging.getLogger(__name__)


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


class UnitObjective:
    """Weighted RMS (eq. 33) of whole populations in the parameters' unit intervals, in one model call."""

    def __init__(self, problem: Problem, mass_kg: float, fit_mass: bool):
        self.problem = problem
        self.mass_kg = mass_kg
        self.fit_mass = fit_mass
        self.dimension = len(problem.model.parameters) + int(fit_mass)

    def to_params(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model parameter vectors (..., P) and masses (...) in kg from unit-cube points (..., dimension)."""
        model = self.problem.model
        params = np.stack([p.from_unit_interval(u[..., i]) for i, p in enumerate(model.parameters)], axis=-1)
        if self.fit_mass:
            low, high = np.log(MASS_BOX[0]), np.log(MASS_BOX[1])
            mass = self.mass_kg * np.exp(low + u[..., -1] * (high - low))
        else:
            mass = np.full(u.shape[:-1], self.mass_kg)
        return params, mass

    def __call__(self, u: np.ndarray) -> np.ndarray:
        problem = self.problem
        problem.check_cancel()
        params, mass = self.to_params(u)
        return np.sqrt(problem.accelerance_cost(problem.model.stiffness(problem.s, params), mass))


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
    logger.debug("GA: %d generations, best objective %.6g", generation + 1, best)

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
    logger.debug("PSO: %d swarms, %d iterations, best objective %.6g", k, iteration + 1, best)
    flat = np.unravel_index(np.argmin(personal_values), personal_values.shape)
    return personal[flat], float(personal_values[flat])
