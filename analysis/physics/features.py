"""Where a film's response has features, and what they are: the frequencies a grid must resolve, and the resonances,
antiresonances and negative stiffness of a film and of the accelerance of a mass on it.

A network of springs, dashpots and spring-pots has no poles of its own, but it can come arbitrarily close to one:
two branches in series (or in parallel) whose stiffnesses have equal magnitude and nearly opposite phase — a spring
and a spring-pot of order near 2 (an inertance) — make a resonance (an antiresonance) as narrow as ``2 − α`` is
small. Such a feature sits where the two magnitudes cross, so :func:`singular_frequencies_hz` finds every crossing of
two sibling branches' magnitudes (and of the film's with the mass line ``m ω²``, the mover's resonance), and
:func:`resolving_grid_hz` puts points around each crossing down to 1e-7 relative: a peak of any width is then
sampled on both flanks and at its top. A rational model's poles and zeros are given to the same grid as centres.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from gasfilm.analysis.physics.elements import FilmModel, Node, Parallel, Series, accelerance_from_stiffness
from gasfilm.analysis.spectra import peak_half_widths, prominent_peaks

#: lines per decade of the coarse grid on which magnitude crossings are looked for, and of the resolving grid's base
COARSE_LINES_PER_DECADE = 100
BASE_LINES_PER_DECADE = 200
#: relative offsets placed on either side of every centre of a resolving grid: from far below any feature's width
#: (a spring-pot of order 2 − 1e-6 resonates over about 1e-6 of its frequency) to a wide neighbourhood
LOCAL_OFFSETS = np.geomspace(1e-8, 0.3, 64)
#: least relative prominence (of the magnitude) a local extremum needs to count as a feature: rounding aside, any
#: bump the fit can make
FEATURE_PROMINENCE = 1e-4
#: a series branch whose stiffness peaks at this many times the magnitude where its elements cross resonates
BRANCH_RESONANCE_GAIN = 2.0


@dataclass(frozen=True)
class Feature:
    """One feature of a film's or a mover's response on the jω axis.

    ``kind``: "resonance" (a peak of the accelerance |H|), "film resonance" (a peak of |Z|, or of a series branch's
    |Z| where the film's has none), "film antiresonance" (a dip of |Z|) or "negative stiffness" (Re Z < 0). ``freq_hz`` its centre; ``low_hz``–``high_hz`` its width (half
    the prominence of the log magnitude on either side; the interval itself for negative stiffness); ``size`` its
    relative prominence (|Z| or |H| at the extremum over the higher of its surroundings' levels, minus 1) or, for
    negative stiffness, min Re Z / |Z| there (a negative number)."""

    kind: str
    freq_hz: float
    low_hz: float
    high_hz: float
    size: float
    main: bool = False  # the mover's own resonance (the strongest accelerance peak): every mass on a film has one

    def describe(self) -> str:
        width = self.high_hz - self.low_hz
        if self.kind == "negative stiffness":
            return (f"negative stiffness (Re Z < 0, down to {self.size:.2g}·|Z|) over "
                    f"{self.low_hz:.4g}–{self.high_hz:.4g} Hz")
        return f"a {self.kind} at {self.freq_hz:.4g} Hz ({width:.2g} Hz wide, {100 * self.size:.2g} % high)"


def _values(model: FilmModel, params: Mapping[str, float] | np.ndarray) -> dict[str, np.ndarray]:
    vector = model.vector(params) if isinstance(params, Mapping) else np.asarray(params, dtype=float)
    return {name: np.array([value]) for name, value in zip(model.parameter_names, vector)}


def _crossings(log_a: np.ndarray, log_b: np.ndarray, log_f: np.ndarray) -> list[float]:
    """Frequencies (Hz) where two log magnitudes on the grid ``log_f`` (ln Hz) cross, interpolated linearly."""
    difference = log_a - log_b
    finite = np.isfinite(difference)
    found = []
    for i in np.flatnonzero(finite[:-1] & finite[1:] & (np.sign(difference[:-1]) * np.sign(difference[1:]) < 0)):
        t = difference[i] / (difference[i] - difference[i + 1])
        found.append(math.exp(log_f[i] + t * (log_f[i + 1] - log_f[i])))
    return found


def _node_crossings(node: Node, values: Mapping[str, np.ndarray], s: np.ndarray, log_f: np.ndarray,
                    found: list[float], series: list[tuple[Node, Node, float]] | None = None) -> np.ndarray:
    """Log |Z| of ``node`` on the grid; the crossings of every pair of its children's magnitudes (and theirs, below)
    are appended to ``found``, and those of a series combination, with its node and one of the two children, to
    ``series``."""
    if isinstance(node, (Parallel, Series)):
        logs = [_node_crossings(child, values, s, log_f, found, series) for child in node.children]
        for (i, a), (_, b) in itertools.combinations(enumerate(logs), 2):
            crossings = _crossings(a, b, log_f)
            found.extend(crossings)
            if series is not None and isinstance(node, Series):
                series.extend((node, node.children[i], f) for f in crossings)
    with np.errstate(all="ignore"):
        return np.log(np.abs(node.stiffness(s, values)))


def _branch_resonances(model: FilmModel, values: Mapping[str, np.ndarray], span_hz: tuple[float, float]
                       ) -> list[Feature]:
    """Resonances of the film's series branches: where two elements in series have magnitudes that cross with
    nearly opposite phases (a spring and a spring-pot of order near 2, an inertance) their compliances cancel and
    the branch's stiffness peaks, however narrowly, even where the film's |Z| shows no extremum (the peak sits on a
    slope). Each peak at least :data:`BRANCH_RESONANCE_GAIN` times the crossing magnitude is one; its size is the
    peak over the film's |Z| there."""
    low, high = span_hz
    freq = np.geomspace(low, high, max(3, int(COARSE_LINES_PER_DECADE * math.log10(high / low)) + 1))
    series: list[tuple[Node, Node, float]] = []
    _node_crossings(model.network, values, 2j * np.pi * freq, np.log(freq), [], series)
    found = []
    relative = np.concatenate([-LOCAL_OFFSETS[::-1], [0.0], LOCAL_OFFSETS])
    for node, child, centre in series:
        local = centre * (1.0 + relative)
        with np.errstate(all="ignore"):
            magnitude = np.abs(node.stiffness(2j * np.pi * local, values))
            base = float(np.abs(child.stiffness(np.array([2j * np.pi * centre]), values))[0])
        top = int(np.nanargmax(magnitude))
        if not (np.isfinite(base) and base > 0 and magnitude[top] >= BRANCH_RESONANCE_GAIN * base):
            continue
        f_peak, peak = refine_maxima(lambda f: np.abs(node.stiffness(2j * np.pi * f, values)), local, [top])[0]
        edges = np.flatnonzero(magnitude >= peak / math.sqrt(2.0))
        # (an undamped branch, a spring-pot at order 2 exactly: the peak between two samples is above √2 × every
        # sample, narrower than any grid — of zero width here)
        width_low, width_high = (float(local[edges[0]]), float(local[edges[-1]])) if edges.size else (f_peak, f_peak)
        with np.errstate(all="ignore"):
            total = abs(complex(model.network.stiffness(np.array([2j * np.pi * f_peak]), values)[0]))
        if low <= f_peak <= high:
            found.append(Feature("film resonance", f_peak, min(width_low, f_peak), max(width_high, f_peak),
                                 peak / total if total > 0 else math.inf))
    return found


def singular_frequencies_hz(model: FilmModel, params: Mapping[str, float] | np.ndarray, span_hz: tuple[float, float],
                            mass_kg: float | None = None) -> np.ndarray:
    """Frequencies in ``span_hz`` where the film (under ``mass_kg``, when given) can have a narrow feature: where the
    magnitudes of two sibling branches cross, at every level of the network, and where the film's magnitude (or a
    top-level parallel branch's) crosses the mass line ``m ω²``."""
    low, high = span_hz
    freq = np.geomspace(low, high, max(3, int(COARSE_LINES_PER_DECADE * math.log10(high / low)) + 1))
    log_f, s = np.log(freq), 2j * np.pi * freq
    values = _values(model, params)
    found: list[float] = []
    total = _node_crossings(model.network, values, s, log_f, found)
    if mass_kg is not None:
        mass_line = np.log(mass_kg * (2 * np.pi * freq) ** 2)
        branches = model.network.children if isinstance(model.network, Parallel) else ()
        with np.errstate(all="ignore"):
            logs = [total] + [np.log(np.abs(branch.stiffness(s, values))) for branch in branches]
        for log_z in logs:
            found.extend(_crossings(log_z, mass_line, log_f))
    return np.unique(np.array([f for f in found if low <= f <= high]))


def resolving_grid_hz(span_hz: tuple[float, float], centres_hz: np.ndarray | list[float] = (),
                      widths_hz: np.ndarray | list[float] | None = None,
                      lines_per_decade: int = BASE_LINES_PER_DECADE) -> np.ndarray:
    """A log grid over ``span_hz`` with points clustered around each centre: at relative offsets
    :data:`LOCAL_OFFSETS` on both sides, and (for a centre given a width, e.g. a pole's ``|Re p|/2π``) at offsets
    from a tenth of that width to ten widths. Sorted, unique, inside the span."""
    low, high = span_hz
    parts = [np.geomspace(low, high, max(3, int(lines_per_decade * math.log10(high / low)) + 1))]
    centres = np.asarray(centres_hz, dtype=float)
    if centres.size:
        relative = np.concatenate([-LOCAL_OFFSETS[::-1], [0.0], LOCAL_OFFSETS])
        parts.append((centres[:, np.newaxis] * (1.0 + relative)).ravel())
        if widths_hz is not None:
            widths = np.asarray(widths_hz, dtype=float)
            steps = np.geomspace(0.1, 10.0, 21)
            offsets = np.concatenate([-steps[::-1], steps])
            parts.append((centres[:, np.newaxis] + widths[:, np.newaxis] * offsets).ravel())
    grid = np.concatenate(parts)
    return np.unique(grid[(grid >= low) & (grid <= high) & np.isfinite(grid)])


def refine_maxima(function, freq_hz: np.ndarray, indices: list[int] | np.ndarray, rounds: int = 8,
                  points: int = 17) -> list[tuple[float, float]]:
    """The local maxima of the real function ``function(freq_hz)`` (vectorised) whose grid maxima are at
    ``indices``: each searched between its neighbouring grid points by ``rounds`` zooms of ``points`` log-spaced
    samples (all maxima in one call per zoom; each zoom narrows the interval ``(points − 1)/2`` times). Returns
    (frequency, value) per index, never below the grid's value."""
    indices = [int(i) for i in indices]
    if not indices:
        return []
    last = len(freq_hz) - 1
    low = np.log(np.array([freq_hz[max(i - 1, 0)] for i in indices]))
    high = np.log(np.array([freq_hz[min(i + 1, last)] for i in indices]))
    best_f = np.array([freq_hz[i] for i in indices], dtype=float)
    with np.errstate(all="ignore"):
        best_v = np.asarray(function(best_f), dtype=float)
    best_v = np.where(np.isfinite(best_v), best_v, -np.inf)
    steps = np.linspace(0.0, 1.0, points)
    for _ in range(rounds):
        log_f = low[:, np.newaxis] + (high - low)[:, np.newaxis] * steps
        with np.errstate(all="ignore"):
            values = np.asarray(function(np.exp(log_f).ravel()), dtype=float).reshape(log_f.shape)
        values = np.where(np.isfinite(values), values, -np.inf)
        top = np.argmax(values, axis=1)
        rows = np.arange(len(indices))
        better = values[rows, top] > best_v
        best_v = np.where(better, values[rows, top], best_v)
        best_f = np.where(better, np.exp(log_f[rows, top]), best_f)
        low = log_f[rows, np.maximum(top - 1, 0)]
        high = log_f[rows, np.minimum(top + 1, points - 1)]
    return [(float(f), float(v)) for f, v in zip(best_f, best_v)]


def _extrema(freq: np.ndarray, log_magnitude: np.ndarray, kind: str, sign: float, function) -> list[Feature]:
    """Local maxima of ``sign · log_magnitude`` with a prominence of at least :data:`FEATURE_PROMINENCE`, each
    refined between its grid neighbours."""
    series = sign * log_magnitude
    peaks = prominent_peaks(series, math.log1p(FEATURE_PROMINENCE))
    if not len(peaks):
        return []
    prominences, left, right = peak_half_widths(series, peaks)
    index = np.arange(len(freq))
    features = []
    refined = refine_maxima(lambda f: sign * function(f), freq, peaks)
    for (f_peak, _), prominence, l, r in zip(refined, prominences, left, right):
        features.append(Feature(kind, f_peak, float(np.exp(np.interp(l, index, np.log(freq)))),
                                float(np.exp(np.interp(r, index, np.log(freq)))), math.expm1(float(prominence))))
    return features


def film_features(model: FilmModel, params: Mapping[str, float] | np.ndarray, mass_kg: float,
                  span_hz: tuple[float, float]) -> list[Feature]:
    """Every feature of the film ``model`` with ``params`` under ``mass_kg`` within ``span_hz`` on the jω axis, on a
    grid that resolves them (:func:`resolving_grid_hz` around :func:`singular_frequencies_hz`): accelerance peaks
    (the strongest marked ``main``: the mover's own resonance), peaks and dips of |Z|, and intervals of negative
    storage stiffness. Sorted by frequency."""
    values = model.vector(params) if isinstance(params, Mapping) else np.asarray(params, dtype=float)
    freq = resolving_grid_hz(span_hz, singular_frequencies_hz(model, values, span_hz, mass_kg))

    def stiffness(f: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):  # (a film at a bound can be infinitely stiff somewhere: dropped below)
            return model.stiffness(2j * np.pi * f, values)

    def log_h(f: np.ndarray) -> np.ndarray:
        s = 2j * np.pi * f
        with np.errstate(all="ignore"):
            return np.log(np.abs(accelerance_from_stiffness(s, stiffness(f), mass_kg)))

    def log_z(f: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.log(np.abs(stiffness(f)))

    z = stiffness(freq)
    with np.errstate(all="ignore"):
        lz = np.log(np.abs(z))
        lh = log_h(freq)
        negative = z.real < 0
    finite = np.isfinite(lz) & np.isfinite(lh)
    freq, z, lz, lh = freq[finite], z[finite], lz[finite], lh[finite]
    found = _extrema(freq, lh, "resonance", 1.0, log_h)
    if found:
        strongest = max(range(len(found)), key=lambda i: log_h(np.array([found[i].freq_hz]))[0])
        found[strongest] = Feature(**{**found[strongest].__dict__, "main": True})
    found += _extrema(freq, lz, "film resonance", 1.0, log_z)
    found += _extrema(freq, lz, "film antiresonance", -1.0, log_z)
    # a branch's resonance on a slope of |Z| (no extremum of the film's |Z| within its width: else it is that one)
    for branch in _branch_resonances(model, _values(model, values), span_hz):
        if not any(f.kind.startswith("film") and branch.low_hz <= f.freq_hz <= branch.high_hz for f in found):
            found.append(branch)
    negative = negative[finite]
    if negative.any():
        edges = np.flatnonzero(np.diff(np.concatenate([[0], negative.astype(int), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            part = slice(start, stop)
            ratio = z.real[part] / np.abs(z[part])
            worst = int(np.argmin(ratio))
            found.append(Feature("negative stiffness", float(freq[part][worst]), float(freq[start]),
                                 float(freq[stop - 1]), float(ratio[worst])))
    return sorted(found, key=lambda feature: feature.freq_hz)
