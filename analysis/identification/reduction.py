"""A fit in its identifiable form: what the data cannot determine is taken out and said, never filled in.

A network can hold more than an FRF determines: FOMGF's second arm beside a stiff film, an order at 0 (the
spring-pot is a spring) or at 2 (an inertance). A search then parks the spare part wherever it harms least — often
where it makes a narrow resonance between the FRF's lines — and its values mean nothing.

Every network one step simpler is a candidate (:func:`candidate_reductions`: a parallel branch removed, a series
element shorted, a spring-pot made a spring; inside interchangeable arms always in the last one, so the arm kept has
the first arm's names). A candidate the fit's own values already support (the element taken out as it is, the BIC
no higher) is fitted again first; the others are fitted when the fit says the data do not determine it
(:func:`troubles`: a parameter at a bound or not identifiable, an order at 0 or 2 within its uncertainty, a feature
inside the band the data do not support), each started from the fit's own values (a search of its own only when
that start does not reach the fit's RMS), and not at all when even the fit's RMS would not give it a BIC below the
best candidate's so far. The candidate with the lowest BIC (Table 2's) is taken if that is not
above the fit's own — or, when the fit has a feature the FRF cannot show, the best candidate without one, whatever
its BIC. This repeats until nothing is left to take out; the form reached is then named as the removals from the
requested network name it (the same names in every session). The result keeps the model's name, holds the reduced
network and its parameters only, and says what was taken out and why (:attr:`FitResult.notes`).

Features (:mod:`gasfilm.analysis.physics.features`) inside and near the band are checked against the FRF: a
resonance, antiresonance or negative stiffness of the fitted model counts as supported only inside the band, across
at least :data:`MIN_LINES_ACROSS` lines and above the FRF's noise there; any other is flagged as invented.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from gasfilm.analysis.identification.result import FitResult
from gasfilm.analysis.physics.elements import (
    PAPER_MODEL_ORDER,
    PAPER_MODELS,
    Dashpot,
    FilmModel,
    Node,
    Parallel,
    Series,
    Spring,
    SpringPot,
    _shape,
    accelerance_from_stiffness,
    laplace_variable,
    network_shape,
    parse_network,
)
from gasfilm.analysis.physics.features import Feature, film_features

#: an order within this distance of 0 or 2, or within two standard errors and :data:`ORDER_NEAR_BOUND`, is at that
#: bound
ORDER_AT_BOUND = 1e-3
ORDER_NEAR_BOUND = 0.02
#: features are looked for this factor beyond each edge of the band ("near the band")
NEAR_BAND_FACTOR = 2.0
#: lines of the FRF a feature must span (its half-prominence width) for the FRF to show it
MIN_LINES_ACROSS = 3
#: a feature must change the accelerance by this many times the FRF's relative noise there to be seen
NOISE_FACTOR = 2.0
#: how a feature outside the band is said
OUTSIDE = "outside the fitted band"
#: two fits of one film family whose BIC differ by at most this much reach the same optimum (rounding, the search)
SAME_BIC = 1.0
#: at most this many reduction steps (each removes at least one parameter)
MAX_STEPS = 8


# --- networks one step simpler -------------------------------------------------------------------------------------


def _simplified(node: Node) -> Node:
    """The same family of films written without redundancy: nested combinations of one kind flattened, springs (or
    dashpots) side by side merged into the first one, a combination of one element replaced by that element."""
    if not isinstance(node, (Parallel, Series)):
        return node
    children: list[Node] = []
    for child in (_simplified(c) for c in node.children):
        children.extend(child.children if type(child) is type(node) else (child,))
    kept: list[Node] = []
    for child in children:
        if isinstance(child, (Spring, Dashpot)) and any(type(other) is type(child) for other in kept):
            continue
        kept.append(child)
    return kept[0] if len(kept) == 1 else type(node)(tuple(kept))


def _one_step(node: Node, every: bool = False) -> list[tuple[Node, str]]:
    """Networks one step simpler than ``node`` (unsimplified) with what the step took out, in words. Of
    interchangeable children only the last is removed (the arm kept has the first arm's names), unless ``every``."""
    found: list[tuple[Node, str]] = []
    if isinstance(node, SpringPot):
        return [(Spring(node.coefficient), f"{node.text()} acts as a spring (order 0)")]
    if not isinstance(node, (Parallel, Series)):
        return found
    children = list(node.children)
    last_of_shape = {_shape(child): i for i, child in enumerate(children)}
    if len(children) > 1:
        for i in range(len(children)) if every else sorted(last_of_shape.values()):
            rest = tuple(children[:i] + children[i + 1:])
            what = (f"the branch {children[i].text()} contributes below the noise"
                    if isinstance(node, Parallel) else
                    f"{children[i].text()} is too stiff to matter in its series branch")
            found.append((rest[0] if len(rest) == 1 else type(node)(rest), what))
    for i, child in enumerate(children):
        if not every and last_of_shape[_shape(child)] != i:
            continue  # (a step inside interchangeable arms is taken in the last: the first keeps its names whole)
        for reduced, what in _one_step(child, every):
            found.append((type(node)(tuple(children[:i] + [reduced] + children[i + 1:])), what))
    return found


def _dissipates(node: Node) -> bool:
    """Whether a network holds a dashpot or a spring-pot: springs alone are no film (an undamped resonance)."""
    if isinstance(node, (Parallel, Series)):
        return any(_dissipates(child) for child in node.children)
    return isinstance(node, (Dashpot, SpringPot))


def candidate_reductions(network: Node) -> list[tuple[Node, str]]:
    """Distinct networks one step simpler than ``network`` (fewer parameters, simplified, still dissipating), each
    with what was taken out; of several of one shape (names aside) the first is kept."""
    size = len(network.parameters())
    seen: set = set()
    found = []
    for reduced, what in _one_step(network):
        reduced = _simplified(reduced)
        shape = network_shape(reduced)
        if shape in seen or len(reduced.parameters()) >= size or not _dissipates(reduced):
            continue
        seen.add(shape)
        found.append((reduced, what))
    return found


def _screened_shapes(fit: FitResult, freq_hz: np.ndarray, h_measured: np.ndarray) -> list[tuple]:
    """The shapes of the reductions the fit's own values already support: the fit with an element taken out as it
    is (not fitted again) has a BIC no higher than the fit's, best first. A spare part the data cannot see passes
    this; a part that holds some of the film (which the others take over only when fitted again) does not."""
    model, own = fit.model(), bic(fit)
    s = laplace_variable(freq_hz, fit.decay_rate_1_s)
    found = []
    for reduced, _ in _one_step(model.network, every=True):
        simplified = _simplified(reduced)
        if not _dissipates(simplified) or len(simplified.parameters()) >= len(model.parameters):
            continue
        with np.errstate(all="ignore"):
            z = FilmModel("screen", reduced).stiffness(s, {p.name: fit.params[p.name] for p in reduced.parameters()})
            residual = accelerance_from_stiffness(s, z, fit.mass_kg) - h_measured
        rms = float(np.sqrt(np.mean(np.abs(residual) ** 2)))
        if not math.isfinite(rms):
            continue
        without = bic(fit, rms, len(simplified.parameters()))
        if without <= own:
            found.append((without, network_shape(simplified)))
    return [shape for _, shape in sorted(found, key=lambda item: item[0])]


def _removal_forms(network: Node) -> dict[tuple, tuple[Node, list[str]]]:
    """Shape → the first network of that shape reached from ``network`` by removals alone (parallel branches
    removed, series elements shorted; breadth first, in :func:`candidate_reductions`'s order) and what the removals
    took out: the names a reduced form is given whichever way it was reached — a session that reached FOZGF's shape
    through FOMGF's spring-pot at order 0 names its parts as one that dropped the arm."""
    forms: dict[tuple, tuple[Node, list[str]]] = {}
    frontier: list[tuple[Node, list[str]]] = [(network, [])]
    while frontier:
        following = []
        for node, path in frontier:
            for reduced, what in _one_step(node):
                if "acts as a spring" in what:
                    continue
                reduced = _simplified(reduced)
                shape = network_shape(reduced)
                if shape not in forms:
                    forms[shape] = (reduced, path + [what])
                    following.append(forms[shape])
        frontier = following
    return forms


def paper_name_of(network: Node) -> str | None:
    """The paper model of the same shape as ``network`` (names aside), or None."""
    shape = network_shape(network)
    return next((name for name in PAPER_MODEL_ORDER if network_shape(PAPER_MODELS[name].network) == shape), None)


# --- what a fit says about itself ----------------------------------------------------------------------------------


def bic(fit: FitResult, rms: float | None = None, parameters: int | None = None) -> float:
    """Table 2's BIC of a fit on its own lines: ``2n ln(RSS/2n) + k ln 2n`` with 2n real residuals (with ``rms``
    and ``parameters`` given: of those instead of the fit's own)."""
    n_real = 2 * fit.n_points
    rss = fit.n_points * (fit.rms if rms is None else rms) ** 2
    k = (len(fit.params) if parameters is None else parameters) + int(fit.mass_fitted)
    return n_real * math.log(max(rss, 1e-300) / n_real) + k * math.log(n_real)


def _orders(model: FilmModel) -> dict[str, str]:
    """Order parameter name → its spring-pot's coefficient name."""
    found: dict[str, str] = {}

    def walk(node: Node) -> None:
        if isinstance(node, SpringPot):
            found[node.order] = node.coefficient
        elif isinstance(node, (Parallel, Series)):
            for child in node.children:
                walk(child)

    walk(model.network)
    return found


def order_bound_notes(fit: FitResult) -> list[str]:
    """One sentence per order at 0 or 2 (within :data:`ORDER_AT_BOUND`, or within two standard errors up to
    :data:`ORDER_NEAR_BOUND`): what its spring-pot is there."""
    notes = []
    for order, coefficient in _orders(fit.model()).items():
        value = fit.params[order]
        sigma = fit.std_errors.get(order, 0.0)
        if not math.isfinite(sigma) or sigma > 0.5:
            continue  # not identifiable: flagged as such
        reach = max(ORDER_AT_BOUND, min(2 * sigma, ORDER_NEAR_BOUND))
        pot = f"pot({coefficient}, {order})"
        eta = fit.params[coefficient]
        if value <= reach:
            notes.append(f"{order} = {value:.4g} is at its bound 0: {pot} is a spring of {eta:.4g} N/m there, "
                         f"not a damper")
        elif 2.0 - value <= reach:
            notes.append(f"{order} = {value:.4g} is at its bound 2: {pot} is an inertance (a mass of {eta:.4g} kg) "
                         f"there, not a damper")
    return notes


def invented_features(fit: FitResult, freq_hz: np.ndarray, h_measured: np.ndarray) -> list[str]:
    """The features of the fitted model inside and near its band (:data:`NEAR_BAND_FACTOR`) the FRF does not
    support, one sentence each. The mover's own resonance is every model's and is not examined."""
    low, high = float(freq_hz[0]), float(freq_hz[-1])
    spacing = float(np.median(np.diff(freq_hz))) if len(freq_hz) > 1 else high - low
    model = fit.model()
    features = film_features(model, fit.params, fit.mass_kg, (low / NEAR_BAND_FACTOR, high * NEAR_BAND_FACTOR))
    if not features:
        return []
    h_fit = fit.accelerance(freq_hz)
    relative_noise = np.abs(h_fit - h_measured) / np.abs(h_fit)
    s = laplace_variable(freq_hz, fit.decay_rate_1_s)
    with np.errstate(all="ignore"):
        z_measured = s**2 / h_measured - fit.mass_kg * s**2
    found = []
    for feature in features:
        if feature.main:
            continue
        why = _unsupported(feature, model, fit, freq_hz, spacing, relative_noise, z_measured, (low, high))
        if why:
            found.append(f"invented feature: {feature.describe()} {why}")
    return found


def _unsupported(feature: Feature, model: FilmModel, fit: FitResult, freq_hz: np.ndarray, spacing: float,
                 relative_noise: np.ndarray, z_measured: np.ndarray, band: tuple[float, float]) -> str:
    """Why the FRF does not support ``feature`` ("" when it does)."""
    if not band[0] <= feature.freq_hz <= band[1]:
        return f"{OUTSIDE} ({band[0]:.4g}–{band[1]:.4g} Hz), where the data cannot confirm it"
    across = (freq_hz >= feature.low_hz) & (freq_hz <= feature.high_hz)
    if np.count_nonzero(across) < MIN_LINES_ACROSS:
        return f"narrower than {MIN_LINES_ACROSS} of the FRF's lines ({spacing:.3g} Hz apart), which cannot show it"
    if feature.kind == "negative stiffness":
        if np.nanmedian(z_measured[across].real) >= 0:
            return "where the measured stiffness is positive"
        return ""
    centre = int(np.argmin(np.abs(freq_hz - feature.freq_hz)))
    near = slice(max(0, centre - 5), centre + 6)
    noise = float(np.sqrt(np.mean(relative_noise[near] ** 2)))
    effect = feature.size
    if feature.kind != "resonance":  # a relative change of Z changes H by that much times |Z|/|Z + m s²|
        s = 2j * np.pi * feature.freq_hz
        z = model.stiffness(np.array([s]), fit.params)[0]
        effect *= abs(z) / abs(z + fit.mass_kg * s**2)
    if effect < NOISE_FACTOR * noise:
        return f"smaller than the FRF's noise there ({100 * noise:.2g} % of |H|)"
    return ""


def _least_bic(fit: FitResult, network: Node) -> float:
    """The least BIC ``network``, a reduction of ``fit``'s, can reach on the same data: a limit of ``fit``'s network
    fits no closer than ``fit``."""
    return bic(fit, fit.rms, len(network.parameters()))


def troubles(fit: FitResult, invented: list[str], notes: list[str]) -> bool:
    """Whether the fit says the data do not determine all of it: a parameter at a bound or not identifiable, an
    order at 0 or 2, a feature inside the band the data do not support. (Strong correlations alone are not: well
    determined parameters of a film can be, and a feature outside the band is flagged but no reduction can be
    supported by data that do not reach it.)"""
    inside = [sentence for sentence in invented if OUTSIDE not in sentence]
    return bool(fit.at_bound or inside or notes or any("not identifiable" in flag for flag in fit.flags))


# --- the identifiable form -----------------------------------------------------------------------------------------


def _inside(invented: list[str]) -> list[str]:
    """The invented features inside the band (those outside no data can settle)."""
    return [sentence for sentence in invented if OUTSIDE not in sentence]


def identifiable_form(
    fit: FitResult,
    refit: Callable[..., FitResult],
    freq_hz: np.ndarray,
    h_measured: np.ndarray,
    progress: Callable[[float], None] | None = None,
) -> FitResult:
    """``fit`` reduced to what the FRF ``h_measured`` at ``freq_hz`` determines, with its notes and flags:
    ``refit(model)`` fits a reduced network to the same data (without reducing it), ``refit(model, near)`` starting
    from the values of ``near``, the fit it is a reduction of.

    A reduction is taken when its BIC is not above the fit's; and when the fit has a feature inside the band the
    FRF does not support (a resonance narrower than its lines, or below its noise), the best reduction without one
    is taken even at a higher BIC — the data cannot show such a feature, so it is never reported as measured."""
    requested = fit.network
    current = fit
    taken_out: list[str] = []
    evaluations, wall_time_s = fit.evaluations, fit.wall_time_s
    for step in range(MAX_STEPS):
        invented = invented_features(current, freq_hz, h_measured)
        notes = order_bound_notes(current)
        # a reduction the fit's own values support (an element taken out as it is) is fitted again first, whatever
        # the flags say; the others only when the fit says the data do not determine it
        screened = _screened_shapes(current, freq_hz, h_measured)
        trouble = troubles(current, invented, notes)
        if not screened and not trouble:
            break
        candidates = candidate_reductions(current.model().network)
        # the screened reduction first, then those with fewer parameters (which may leave the others no chance)
        candidates.sort(key=lambda candidate: (network_shape(candidate[0]) not in screened[:1],
                                               len(candidate[0].parameters())))
        tried: list[tuple[FitResult, str, bool]] = []  # (fit, what was taken out, it invents nothing in the band)
        for number, (network, what) in enumerate(candidates):
            if number == 1 and screened and bic(tried[0][0]) <= bic(current) and tried[0][2]:
                break  # the screened reduction holds: the others need not be fitted
            if number >= 1 and screened and not trouble:
                break
            supported = [bic(item[0]) for item in tried if bic(item[0]) <= bic(current)]
            if supported and _least_bic(current, network) - SAME_BIC >= min(supported):
                continue  # even fitting as closely as the fit itself it would not be chosen
            if progress is not None:
                progress(min(1.0, (step + number / max(len(candidates), 1)) / 3))
            reduced = refit(FilmModel(fit.model_name, network, fit.model().description), current)
            evaluations += reduced.evaluations
            wall_time_s += reduced.wall_time_s
            tried.append((reduced, what, not _inside(invented_features(reduced, freq_hz, h_measured))))
        supported = [item for item in tried if bic(item[0]) <= bic(current)]
        forced = [item for item in tried if item[2]] if _inside(invented) else []
        chosen = min(supported or forced, key=lambda item: bic(item[0]), default=None)
        if chosen is None:
            break
        best, best_what, _ = chosen
        rise = 100 * (best.rms / current.rms - 1) if current.rms > 0 else 0.0
        if not supported:  # taken out for what it invents, not for its size
            element = best_what.split(" contributes")[0].split(" is too stiff")[0].split(" acts as")[0]
            best_what = f"{element} made " + "; ".join(
                sentence.removeprefix("invented feature: ") for sentence in _inside(invented))
        taken_out.append(f"{best_what} (without it the RMS changes by {rise:+.3g} %, the BIC by "
                         f"{bic(best) - bic(current):+.1f})")
        current = best
    if taken_out:  # the reduced form named as every session names it (by removals from the requested network)
        named = _removal_forms(fit.model().network).get(network_shape(current.model().network))
        if named is not None and named[0].text() != current.network:
            renamed = refit(FilmModel(fit.model_name, named[0], fit.model().description))
            evaluations += renamed.evaluations
            wall_time_s += renamed.wall_time_s
            if bic(renamed) <= bic(current) + SAME_BIC:
                current = renamed
                if bic(current) <= bic(fit):  # said as the removals that name it, against the fit as found
                    rise = 100 * (current.rms / fit.rms - 1) if fit.rms > 0 else 0.0
                    taken_out = ["; ".join(named[1]) + f" (without {'them' if len(named[1]) > 1 else 'it'} the RMS "
                                 f"changes by {rise:+.3g} %, the BIC by {bic(current) - bic(fit):+.1f})"]
    invented = invented_features(current, freq_hz, h_measured)
    notes = order_bound_notes(current)
    if taken_out:
        form = paper_name_of(current.model().network)
        name = f"{form} ({current.network})" if form else current.network
        notes.insert(0, f"{fit.model_name} reduces to {name} here: " + "; ".join(taken_out))
    return dataclasses.replace(
        current,
        reduced_from=requested if current.network != requested else "",
        notes=tuple(notes),
        flags=tuple(current.flags) + tuple(invented),
        evaluations=evaluations,
        wall_time_s=wall_time_s,
    )


def reduced_parameters(fit: FitResult) -> list[str]:
    """The requested model's parameters the reduced fit does not have (not determined by the data)."""
    if not fit.reduced_from:
        return []
    return [name for name in parse_network(fit.reduced_from).parameter_names if name not in fit.params]
