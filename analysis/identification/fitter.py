"""Identification of a gas-film model from a measured accelerance: :func:`fit_model`.

Objective (paper eq. 33): ``RMS = sqrt(mean |H_d(k) - H(k)|²)`` on the complex accelerance in (m/s²)/N, with
``H = s² / (Z(s) + m s²)`` at ``s = jω`` (or ``s = σ + jω`` when the FRF was measured through an exponential window
of decay rate σ). Two searches: ``method="default"`` (variable projection and Levenberg–Marquardt with the model's
analytic gradient, :mod:`~gasfilm.analysis.identification.default_search`) and ``method="gapso"`` (the paper's
GA-PSO, :mod:`~gasfilm.analysis.identification.gapso`). Standard errors and correlations come from the Jacobian of
the residual at the optimum (:mod:`~gasfilm.analysis.identification.uncertainty`).
"""

from __future__ import annotations

import logging
import time
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike

from gasfilm.analysis.identification import reduction, uncertainty
from gasfilm.analysis.identification.default_search import default_search
from gasfilm.analysis.identification.gapso import GapsoSettings, UnitObjective, gapso_search
from gasfilm.analysis.identification.problem import Problem
from gasfilm.analysis.identification.result import FitResult
from gasfilm.analysis.physics.elements import FilmModel, get_model
from gasfilm.analysis.threads import one_blas_thread
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import NI9234_ALIAS_FREE_FRACTION as ALIAS_FREE_FRACTION

logger = logging.getLogger(__name__)

METHODS = ("default", "gapso")
#: The band models are fitted in unless the user says otherwise (GUI and CLI alike), in Hz; it is capped at
#: :data:`ALIAS_FREE_FRACTION` of the sample rate.
DEFAULT_FIT_BAND_HZ = (20.0, 1000.0)
#: the share of a fit's progress its first search takes (the rest: the searches of its reduced forms)
REDUCTION_PROGRESS = 0.8


def default_fit_band_hz(sample_rate_hz: float) -> tuple[float, float]:
    """The default fit band for a recording at ``sample_rate_hz``: 20–1000 Hz, capped at 0.45·fs."""
    return DEFAULT_FIT_BAND_HZ[0], min(DEFAULT_FIT_BAND_HZ[1], ALIAS_FREE_FRACTION * sample_rate_hz)


@one_blas_thread
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
    reduce: bool = True,
) -> FitResult:
    """Fit ``model`` to the measured accelerance ``h_measured`` ((m/s²)/N at ``freq_hz``) of ``mass_kg`` on the film.

    ``decay_rate_1_s`` > 0 fits the exponentially windowed model; ``fit_mass`` also identifies the mass (starting
    at ``mass_kg``); ``weights`` (e.g. the coherence) weight the frequency points. ``progress`` receives fractions in
    [0, 1]; ``cancel`` returning True stops the fit with
    :class:`~gasfilm.analysis.identification.problem.FitCancelledError`. With ``reduce`` (the default) the result is
    the model's identifiable form (:func:`~gasfilm.analysis.identification.reduction.identifiable_form`): what the
    data cannot determine is taken out and said, features they do not support are flagged.
    """
    film = get_model(model) if isinstance(model, str) else model
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex)
    _check_inputs(film, freq, h, mass_kg, method, weights)

    def fit_network(network: FilmModel, report: Callable[[float], None] | None,
                    near: FitResult | None = None) -> FitResult:
        return _fit_once(network, freq, h, float(mass_kg), method, float(decay_rate_1_s), fit_mass, weights, seed,
                         report, cancel, gapso_settings, near)

    share = REDUCTION_PROGRESS if reduce else 1.0
    result = fit_network(film, None if progress is None else (lambda fraction: progress(share * fraction)))
    if reduce:
        result = reduction.identifiable_form(
            result, lambda network, near=None: fit_network(network, None, near), freq, h,
            None if progress is None else (lambda fraction: progress(share + (1 - share) * fraction)))
        for note in result.notes:
            logger.info("fit %s: %s", film.name, note)
    if progress is not None:
        progress(1.0)
    return result


def _fit_once(
    film: FilmModel,
    freq: np.ndarray,
    h: np.ndarray,
    mass_kg: float,
    method: str,
    decay_rate_1_s: float,
    fit_mass: bool,
    weights: ArrayLike | None,
    seed: int,
    progress: Callable[[float], None] | None,
    cancel: Callable[[], bool] | None,
    gapso_settings: GapsoSettings,
    near: FitResult | None = None,
) -> FitResult:
    """One search of ``film``'s parameters, as it is (see :func:`fit_model`); ``near``: a fit of a network ``film``
    is a reduction of, whose values (those of ``film``'s parameters it has) start the default fitter's search."""
    started = time.perf_counter()
    logger.info(
        "fit %s (%s, %s fitter): %d lines %.6g–%.6g Hz, mass %.6g kg%s, decay rate %.6g 1/s",
        film.name, film.text, method, len(freq), freq.min(), freq.max(), mass_kg, " (fitted)" if fit_mass else "",
        decay_rate_1_s,
    )
    problem = Problem(film, freq, h, mass_kg, decay_rate_1_s, fit_mass, weights, cancel)
    if method == "default":
        start, reachable_cost = _start_near(problem, near)
        theta = default_search(problem, seed, progress, start, reachable_cost)
    else:
        objective = UnitObjective(problem, gapso_settings.order_margin)
        best_unit, _ = gapso_search(
            objective, objective.dimension, seed, gapso_settings, progress, objective.repair, objective.orders
        )
        theta = objective.to_coordinates(best_unit)
    params, mass = problem.coords.to_params(theta)
    mass = float(mass)
    canonical = film.canonical(params, 1j * problem.coords.omega_ref)
    if not np.array_equal(canonical, params):  # interchangeable arms named in one order (the same film)
        params, theta = canonical, problem.coords.from_params(canonical, mass)
    at_bound = uncertainty.parameters_at_bounds(problem, theta, params)
    result = _result(problem, method, theta, params, mass, at_bound, started)
    logger.info(
        "fit %s done: RMS %.6g (m/s²)/N, peak error %.6g (m/s²)/N, %d evaluations, %.3f s",
        film.name, result.rms, result.peak_error, result.evaluations, result.wall_time_s,
    )
    if at_bound:
        logger.info("fit %s: %s ended at a bound (not measured)", film.name, ", ".join(at_bound))
    return result


def _start_near(problem: Problem, near: FitResult | None) -> tuple[np.ndarray | None, float]:
    """Coordinates of ``problem`` at ``near``'s values of its parameters (None when ``near`` lacks one of them, or
    with a fitted mass), and ``near``'s weighted sum of squares on ``problem``'s lines."""
    names = problem.coords.names
    if near is None or problem.coords.fit_mass or any(name not in near.params for name in names):
        return None, 0.0
    params = np.array([near.params[name] for name in names])
    if not (np.all(np.isfinite(params)) and np.all((params > 0) | problem.coords.is_order[: len(names)])):
        return None, 0.0
    start = np.clip(problem.coords.from_params(params, near.mass_kg), problem.coords.lower, problem.coords.upper)
    with np.errstate(all="ignore"):
        residual = (near.accelerance(problem.freq_hz) - problem.h) * problem.sqrt_w
    reachable_cost = float(np.sum(np.abs(residual) ** 2))
    return start, reachable_cost if np.isfinite(reachable_cost) else 0.0


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


def _result(
    problem: Problem,
    method: str,
    theta: np.ndarray,
    params: np.ndarray,
    mass: float,
    at_bound: tuple[str, ...],
    started: float,
) -> FitResult:
    model, coords = problem.model, problem.coords
    residual = problem.acc_complex_residual(theta)
    names = list(coords.names) + (["mass_kg"] if coords.fit_mass else [])
    values = np.append(params, mass) if coords.fit_mass else np.asarray(params)
    covariance = uncertainty.covariance(problem, theta)
    std = np.sqrt(np.abs(np.diag(covariance)))
    with np.errstate(all="ignore"):
        correlation = covariance / np.outer(std, std)
    correlation = np.where(np.isfinite(correlation), correlation, 0.0)
    np.fill_diagonal(correlation, 1.0)
    return FitResult(
        model_name=model.name,
        network=model.text,
        params=model.mapping(params),
        std_errors={n: float(s) for n, s in zip(names, std) if n not in at_bound},
        correlation=correlation,
        correlation_names=tuple(names),
        rms=float(np.sqrt(np.mean(np.abs(residual) ** 2))),
        peak_error=float(np.max(np.abs(residual))),
        evaluations=problem.evaluations,
        wall_time_s=time.perf_counter() - started,
        method=method,
        flags=tuple(uncertainty.flags(problem, names, values, std, correlation, at_bound)),
        band_hz=(float(problem.freq_hz.min()), float(problem.freq_hz.max())),
        mass_kg=float(mass),
        mass_fitted=coords.fit_mass,
        decay_rate_1_s=float(problem.s[0].real),
        n_points=len(problem.freq_hz),
        at_bound=at_bound,
    )
