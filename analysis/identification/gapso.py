"""The paper's GA-PSO search (section 4): a genetic algorithm finds several "global optimal" candidates, particle
swarms (eq. 32, scalar c1 per ERRATA item 6) refine around them; converged when the best RMS is unchanged for 50
iterations. Searches each parameter's unit interval (log or linear per its scale).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable

import numpy as np

from gasfilm.analysis.identification.default_search import Projection
from gasfilm.analysis.identification.problem import Problem

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class GapsoSettings:
    """Settings of the GA-PSO search (paper section 4, Figure 14)."""

    population: int = 60
    #: random individuals drawn for the first generation per member of the population (each also with one order
    #: at 0, see :func:`gapso_search`); the best ``population`` of them start the GA
    first_draws: int = 4
    #: share of each end of an order's unit interval that maps onto the bound itself (see :class:`UnitObjective`)
    order_margin: float = 0.05
    crossover_rate: float = 0.8
    mutation_sigma: float = 0.1
    elite: int = 2
    candidates: int = 4
    swarm_size: int = 15
    inertia: float = 0.729
    c1: float = 1.49445
    c2: float = 1.49445
    max_velocity: float = 0.2
    #: spread (standard deviation in the unit cube) of each swarm around its GA candidate: 0.005 is 0.08 decades
    #: of a coefficient and 0.01 of an order, so the swarm refines its candidate's basin instead of searching anew
    swarm_spread: float = 0.005
    stall_iterations: int = 50
    relative_tolerance: float = 1e-9
    max_generations: int = 1000
    max_iterations: int = 3000


class UnitObjective:
    """Weighted RMS (eq. 33) of whole populations in the unit cube of the fitter's search coordinates, in one
    model call.

    The cube spans :class:`~gasfilm.analysis.identification.problem.Coordinates`' box: each coefficient as the
    element's stiffness at the reference frequency relative to the measured dynamic stiffness there (log scale,
    ± 8 decades, inside the physical bounds), orders linear. A spring-pot's coefficient then no longer trades off
    against its order (in the raw parameters, η·ω^α: a change of 0.01 in α moves the element by a factor ω^0.01,
    and the optimum lies in a narrow diagonal valley across 17 decades that a swarm cannot follow).

    With ``order_margin`` > 0 the first and last ``order_margin`` of an order's interval map onto its bounds: an order
    at 0 (a spring-pot that is a spring) or 2 is a network of its own whose optimum can lie on the bound in a
    valley a few thousandths wide (on the paper's FOMGF rig FOTGF's RMS is 10× its optimum at β = 0.01); a swarm
    or a GA child comes to rest there only if the bound has volume.
    """

    def __init__(self, problem: Problem, order_margin: float = 0.0):
        self.problem = problem
        self.lower = problem.coords.lower
        self.span = problem.coords.upper - problem.coords.lower
        self.dimension = problem.coords.size
        self.orders = np.flatnonzero(problem.coords.is_order)
        self.order_margin = order_margin
        self.projection = None
        if not problem.coords.fit_mass:
            index = np.arange(len(problem.freq_hz))[:: max(1, len(problem.freq_hz) // 200)]
            self.projection = Projection(problem, index, problem.log_weights(2.0))

    def to_coordinates(self, u: np.ndarray) -> np.ndarray:
        """Search coordinates (..., dimension) of unit-cube points (..., dimension)."""
        fraction = np.array(u, dtype=float)
        if self.order_margin:
            margin = self.order_margin
            fraction[..., self.orders] = np.clip((fraction[..., self.orders] - margin) / (1.0 - 2.0 * margin), 0.0, 1.0)
        return self.lower + fraction * self.span

    def to_unit(self, theta: np.ndarray) -> np.ndarray:
        """Unit-cube points of search coordinates (inverse of :meth:`to_coordinates`), clipped to the cube."""
        u = np.clip((theta - self.lower) / self.span, 0.0, 1.0)
        if self.order_margin:
            u[..., self.orders] = self.order_margin + u[..., self.orders] * (1.0 - 2.0 * self.order_margin)
        return u

    def to_params(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model parameter vectors (..., P) and masses (...) in kg from unit-cube points (..., dimension)."""
        return self.problem.coords.to_params(self.to_coordinates(u))

    def repair(self, u: np.ndarray) -> np.ndarray:
        """Each individual with its branch scales replaced by the best ones for its branch shapes (a Lamarckian
        step of the GA: the scales enter the log dynamic stiffness linearly and are solved by least squares,
        weighted as the linearised accelerance residual), so the GA searches over the shapes; unchanged when the
        mass is fitted."""
        if self.projection is None:
            return u
        theta = self.to_coordinates(u)
        repaired, _ = self.projection.project(self.projection.shape_of(theta))
        return self.to_unit(repaired)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        self.problem.check_cancel()
        return np.sqrt(self.problem.acc_cost(self.to_coordinates(u)))


def _unchanged(previous: float, current: float, tolerance: float) -> bool:
    return previous - current <= tolerance * abs(previous)


def gapso_search(
    objective: Callable[[np.ndarray], np.ndarray],
    dimension: int,
    seed: int = 0,
    settings: GapsoSettings = GapsoSettings(),
    progress: Callable[[float], None] | None = None,
    repair: Callable[[np.ndarray], np.ndarray] | None = None,
    edges: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """Minimise ``objective`` (vectorised over rows) on the unit cube by GA then PSO; returns (best point, value).

    First generation: the best ``population`` of ``first_draws × population`` random individuals, each also with
    one of the coordinates ``edges`` at 0 (the orders: a network whose best fit degenerates into a spring there
    lies on the cube's face, which random individuals almost never reach). GA: tournament selection, extended
    intermediate crossover, Gaussian mutation, elitism, until the best value is unchanged for ``stall_iterations``
    generations. The best distinct individuals become the "global optimal" candidates; a swarm per candidate then
    follows eq. 32 ``v = w v + c1 r1 (p - x) + c2 r2 (g - x)`` until the best value is unchanged for
    ``stall_iterations`` iterations.
    """
    rng = np.random.default_rng(seed)
    repair = repair or (lambda u: u)
    n = settings.population
    drawn = rng.random((settings.first_draws * n, dimension))
    copies = [drawn]
    for coordinate in [] if edges is None else edges:
        copy = drawn.copy()
        copy[:, coordinate] = 0.0
        copies.append(copy)
    drawn = repair(np.concatenate(copies))
    drawn_values = objective(drawn)
    first = np.argsort(drawn_values, kind="stable")[:n]
    population, values = drawn[first], drawn_values[first]
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
        children[settings.elite :] = repair(children[settings.elite :])
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
    positions = np.clip(centres[:, np.newaxis, :] + rng.normal(0.0, settings.swarm_spread, (k, m, dimension)), 0.0, 1.0)
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
