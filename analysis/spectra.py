"""Windows, per-hit spectra and the averaged FRF of an impact test (formulas and references: docs/processing.md).

For each hit ``i`` the force ``f`` and the response ``x`` (rows of a record) are windowed, transformed with real FFTs
batched over blocks of hits and scaled as one-sided spectral densities (Bendat & Piersol, *Random Data*, 4th ed., ch. 11)::

    F_i = rfft(f · w_force · w_exp),   X_i = rfft(x · w_exp)
    G_ff = 2/(fs·N) · mean_i |F_i|²,   G_xx = 2/(fs·N) · mean_i |X_i|²,   G_fx = 2/(fs·N) · mean_i conj(F_i)·X_i

(DC and, for even N, Nyquist not doubled: the same scaling as ``scipy.signal.csd`` and pyFRF for a rectangular
window). The spectra are averaged over the hits, never the FRF ratios: ``H1 = G_fx/G_ff``, ``H2 = G_xx/G_xf``,
``γ² = |G_fx|²/(G_ff·G_xx)``. Uncertainty of |H1|: the random error from coherence,
``|H1|·sqrt(1-γ²)/(|γ|·sqrt(2·n))`` (Bendat & Piersol, ch. 9), and the hit-to-hit scatter, the standard deviation
of the per-hit FRFs ``X_i/F_i`` over ``sqrt(n)``.

Windows: the force window is 1 from the record start to ``force_window_ms`` after the force peak, then falls to 0
with a half-cosine taper of ``force_taper_ms``; the exponential window ``exp(-σ t)`` reaches
``exponential_end_fraction`` at the last sample and multiplies force and response alike. The FRF of the windowed
signals is then the Laplace accelerance at ``s = σ + jω``; σ is stored as ``FrfResult.decay_rate_1_s`` so a fit can
use ``gasfilm.analysis.physics.elements.accelerance(..., decay_rate_1_s=σ)`` or remove the damping the window adds
(``Δζ = σ/ω_n``, :func:`remove_window_damping`). No window-amplitude correction is applied (the same weighting is on
force and response, so it cancels in the FRF; this is where pyFRF and OpenModal go wrong).
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2

FRF_UNIT_SI = "(m/s^2)/N"
#: Complex values per block of hits transformed at once (about 4 MB per array, so a block stays in cache).
_BLOCK_VALUES = 1 << 18
#: Frequency lines per strip of a block whose spectra are combined at once (each pass over a strip stays in cache).
_STRIP_LINES = 8192
#: Blocks of at least this many complex values per channel are transformed on a second thread while the previous
#: block is combined (numpy releases the GIL in its FFTs); smaller ones in one thread, where the hand-over would cost
#: more than it saves.
_OVERLAPPED_VALUES = 1 << 17
_fft_thread: tuple[int, ThreadPoolExecutor] | None = None  # (the process it belongs to, the thread)
FRF_UNIT_G = "g/N"


@dataclass(frozen=True)
class WindowSettings:
    """Force and exponential windows; ``None`` switches a window off (rectangular)."""

    force_window_ms: float | None = None
    force_taper_ms: float = 0.5
    exponential_end_fraction: float | None = None

    def __post_init__(self) -> None:
        if self.force_window_ms is not None and not (np.isfinite(self.force_window_ms) and self.force_window_ms > 0):
            raise SettingError(f"force_window_ms: {self.force_window_ms} ms must be positive (or None for no window)")
        if not (np.isfinite(self.force_taper_ms) and self.force_taper_ms >= 0):
            raise SettingError(f"force_taper_ms: {self.force_taper_ms} ms must be 0 or more")
        if self.exponential_end_fraction is not None and not 0 < self.exponential_end_fraction <= 1:
            raise SettingError(
                f"exponential_end_fraction: {self.exponential_end_fraction} must be in (0, 1] (or None for no window)"
            )

    def decay_rate_1_s(self, n_samples: int, sample_rate_hz: float) -> float:
        """σ in 1/s of the exponential window over a record of ``n_samples`` (0 without one)."""
        if self.exponential_end_fraction is None:
            return 0.0
        return -np.log(self.exponential_end_fraction) * sample_rate_hz / (n_samples - 1)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def exponential_window(n_samples: int, end_fraction: float) -> np.ndarray:
    """``exp(-σ t)`` sampled over a record: 1 at the first sample, ``end_fraction`` at the last."""
    return np.exp(np.log(end_fraction) * np.arange(n_samples) / (n_samples - 1))


def force_window(force_n: np.ndarray, sample_rate_hz: float, settings: WindowSettings) -> np.ndarray:
    """Force windows for force rows of shape (hits, samples): 1 up to ``force_window_ms`` after each row's peak, a
    half-cosine taper of ``force_taper_ms``, 0 after (all ones when ``force_window_ms`` is None)."""
    force_n = np.atleast_2d(force_n)
    if settings.force_window_ms is None:
        return np.ones_like(force_n)
    peak = np.argmax(np.abs(force_n), axis=-1)
    flat_end = peak + int(round(settings.force_window_ms * 1e-3 * sample_rate_hz))
    taper = int(round(settings.force_taper_ms * 1e-3 * sample_rate_hz))
    after = np.arange(force_n.shape[-1])[np.newaxis, :] - flat_end[:, np.newaxis]
    if taper == 0:
        return (after <= 0).astype(float)
    ramp = 0.5 * (1.0 + np.cos(np.pi * np.clip(after, 0, taper) / taper))
    return np.where(after <= 0, 1.0, np.where(after < taper, ramp, 0.0))


def remove_window_damping(
    damping_ratio: float, natural_freq_hz: float, decay_rate_1_s: float
) -> tuple[float, float]:
    """Damping ratio and natural frequency of the structure from those fitted to an exponentially windowed FRF.

    The window moves every pole by -σ along the real axis: the fitted pole ``-ζ'ω' ± jω_d`` comes from the true pole
    ``-(ζ'ω' - σ) ± jω_d``. To first order this is ``ζ = ζ' - σ/ω_n`` (Δζ = 1/(ω_n τ), τ = 1/σ)."""
    omega_fit = 2 * np.pi * natural_freq_hz
    real = damping_ratio * omega_fit - decay_rate_1_s
    damped = omega_fit * np.sqrt(max(0.0, 1.0 - damping_ratio**2))
    omega = float(np.hypot(real, damped))
    return real / omega, omega / (2 * np.pi)


@dataclass
class FrfResult:
    """The averaged FRF of a set of hits with its spectra, coherence and uncertainty (plain arrays and scalars)."""

    freq_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    gff: np.ndarray
    gxx: np.ndarray
    gfx: np.ndarray
    h1_per_hit: np.ndarray  # (hits, frequencies)
    n_averages: int
    sample_rate_hz: float
    n_samples: int
    decay_rate_1_s: float
    h1_std_coherence: np.ndarray
    h1_std_scatter: np.ndarray
    window: dict
    frf_unit: str = FRF_UNIT_SI

    @property
    def hv(self) -> np.ndarray:
        """Hv, the total-least-squares estimator: noise on the force and the response weighed alike (in N and m/s²,
        whatever unit this result is in), between H1 (noise on the response only) and H2 (on the force only):
        ``Hv = 2·G_fx / (G_ff − G_xx + √((G_ff − G_xx)² + 4|G_fx|²))``, the eigenvector of the smallest eigenvalue
        of [[G_ff, G_fx], [G_xf, G_xx]] (Rocklin et al.; Shin & Hammond, *Fundamentals of Signal Processing*,
        ch. 9). |H1| ≤ |Hv| ≤ |H2| at every line; all three agree where the coherence is 1."""
        g = STANDARD_GRAVITY_M_S2 if self.frf_unit == FRF_UNIT_G else 1.0
        gff, gxx, gfx = self.gff, self.gxx * g**2, self.gfx * g
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt((gff - gxx) ** 2 + 4.0 * _squared_magnitude(gfx))
            # the form without cancellation on each line: the two are equal since their denominators' product is
            # root² − (G_ff − G_xx)² = 4|G_fx|²
            hv = np.where(gff >= gxx, 2.0 * gfx / (gff - gxx + root), (gxx - gff + root) / (2.0 * np.conj(gfx)))
        return hv / g

    def to_dict(self) -> dict[str, Any]:
        """Field name → value, arrays as they are (for HDF5 datasets and attributes)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> "FrfResult":
        kwargs: dict[str, Any] = {}
        for f in fields(cls):
            if f.name not in values:
                if f.name == "frf_unit":
                    continue
                raise SettingError(f"FRF: the stored result has no '{f.name}'")
            kwargs[f.name] = values[f.name]
        for name in ("n_averages", "n_samples"):
            kwargs[name] = int(kwargs[name])
        for name in ("sample_rate_hz", "decay_rate_1_s"):
            kwargs[name] = float(kwargs[name])
        kwargs["window"] = dict(kwargs["window"])
        if "frf_unit" in kwargs:
            kwargs["frf_unit"] = str(kwargs["frf_unit"])
        return cls(**kwargs)

    def in_g_per_n(self) -> "FrfResult":
        """The same result with the response in g (FRFs in g/N, G_xx in g²/Hz)."""
        if self.frf_unit == FRF_UNIT_G:
            return self
        g = STANDARD_GRAVITY_M_S2
        return replace(
            self,
            h1=self.h1 / g,
            h2=self.h2 / g,
            h1_per_hit=self.h1_per_hit / g,
            gxx=self.gxx / g**2,
            gfx=self.gfx / g,
            h1_std_coherence=self.h1_std_coherence / g,
            h1_std_scatter=self.h1_std_scatter / g,
            frf_unit=FRF_UNIT_G,
        )

    def band(self, lo_hz: float, hi_hz: float) -> "FrfResult":
        """The frequency lines with ``lo_hz <= f <= hi_hz``."""
        keep = (self.freq_hz >= lo_hz) & (self.freq_hz <= hi_hz)
        return replace(
            self,
            freq_hz=self.freq_hz[keep],
            h1=self.h1[keep],
            h2=self.h2[keep],
            coherence=self.coherence[keep],
            gff=self.gff[keep],
            gxx=self.gxx[keep],
            gfx=self.gfx[keep],
            h1_per_hit=self.h1_per_hit[:, keep],
            h1_std_coherence=self.h1_std_coherence[keep],
            h1_std_scatter=self.h1_std_scatter[keep],
        )


def _squared_magnitude(
    spectra: np.ndarray, out: np.ndarray | None = None, parts: np.ndarray | None = None
) -> np.ndarray:
    """|z|² of a complex array, without complex temporaries (into ``out``; ``parts`` is scratch for the squared real
    and imaginary parts side by side, shape (..., 2·lines), used when the lines of ``spectra`` are adjacent in
    memory)."""
    if parts is None or spectra.strides[-1] != spectra.itemsize:
        power = np.square(spectra.real, out=out)
        power += np.square(spectra.imag)
        return power
    squares = np.square(spectra.view(np.float64), out=parts)  # one pass over the real and imaginary parts
    return np.add(squares[..., 0::2], squares[..., 1::2], out=out)


def _summed_squared_magnitude(spectra: np.ndarray) -> np.ndarray:
    """Σ_i |z_i|² over the rows of a complex array (hits, lines) whose lines are adjacent in memory, in one pass over
    their real and imaginary parts side by side."""
    parts = spectra.view(np.float64)
    summed = np.einsum("ij,ij->j", parts, parts)
    return summed[0::2] + summed[1::2]


def _as_hits_array(records: Sequence[np.ndarray] | np.ndarray) -> np.ndarray:
    if isinstance(records, np.ndarray):
        data = np.asarray(records, dtype=np.float64)
    else:
        if len(records) == 0:
            raise SettingError("records: no hits to average")
        lengths = {np.shape(r)[-1] for r in records}
        if len(lengths) != 1:
            raise SettingError(f"records: hits of different lengths ({', '.join(map(str, sorted(lengths)))} samples)")
        data = np.stack([np.asarray(r, dtype=float) for r in records])
    if data.ndim == 2:
        data = data[np.newaxis]
    if data.ndim != 3:
        raise SettingError(f"records: expected (hits, channels, samples), got shape {data.shape}")
    if data.shape[0] == 0:
        raise SettingError("records: no hits to average")
    if data.shape[2] < 2:
        raise SettingError(f"records: {data.shape[2]} sample(s) per hit is too short")
    return data


# --- the force spectrum's roll-off: an FRF is meaningful only where the hammer put energy in, where the force
# autospectrum is within ~10–20 dB of its low-frequency level (a half-sine pulse has spectral nulls above that)

#: The force spectrum may fall this far below its low-frequency level before the FRF is no longer trusted.
USABLE_DROP_DB = 20.0
#: Where the roll-off becomes noticeable (the band is still usable, with care).
CAUTION_DROP_DB = 10.0
#: Fraction of the Nyquist band whose force level counts as "low-frequency".
_LOW_FREQUENCY_FRACTION = 0.02
_MIN_LOW_LINES = 3


def force_level_db(freq_hz: np.ndarray, gff: np.ndarray) -> np.ndarray:
    """The force autospectrum in dB relative to its low-frequency level (the mean of the lowest lines above 0 Hz,
    up to 2 % of the band); NaN at 0 Hz."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    gff = np.asarray(gff, dtype=float)
    positive = np.flatnonzero(freq_hz > 0)
    if positive.size == 0:
        return np.full(gff.shape, np.nan)
    low_count = max(_MIN_LOW_LINES, int(_LOW_FREQUENCY_FRACTION * positive.size))
    reference = float(np.mean(gff[positive[:low_count]]))
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 10.0 * np.log10(gff / reference) if reference > 0 else np.full(gff.shape, -np.inf)
    level = np.where(freq_hz > 0, level, np.nan)
    return level


def usable_band_hz(freq_hz: np.ndarray, gff: np.ndarray, drop_db: float = USABLE_DROP_DB) -> tuple[float, float]:
    """(lowest line above 0 Hz, frequency where the force spectrum first falls ``drop_db`` below its low-frequency
    level) in Hz; the upper end is the last line when it never falls that far, or when there is no force spectrum
    (NaN: an FRF read from UFF)."""
    freq_hz = np.asarray(freq_hz, dtype=float)
    level = force_level_db(freq_hz, gff)
    positive = np.flatnonzero(freq_hz > 0)
    if positive.size == 0:
        return 0.0, 0.0
    if not np.any(np.isfinite(np.asarray(gff, dtype=float)[positive])):
        # an FRF read from a file without its force spectrum (UFF 58 H1): the band is not known to be limited
        return float(freq_hz[positive[0]]), float(freq_hz[positive[-1]])
    below = positive[level[positive] < -abs(drop_db)]
    upper = freq_hz[below[0]] if below.size else freq_hz[positive[-1]]
    return float(freq_hz[positive[0]]), float(upper)


#: Lines below this frequency are never read as a resonance (the DC line and the rigid-body rise).
RESONANCE_SEARCH_FROM_HZ = 5.0
#: Lines whose coherence is below this are not read (zeros of the hammer spectrum give noisy spikes in |H1|).
READ_MIN_COHERENCE = 0.9
#: A local maximum of |H1| is a resonance when it stands this many times above the lowest |H1| on each side of it
#: (down to the neighbouring higher maximum): a noise wiggle never does, a lightly damped mode by far.
RESONANCE_PROMINENCE = 1.5


def hammer_band_lines(frf: FrfResult, drop_db: float = USABLE_DROP_DB) -> np.ndarray:
    """Mask of the lines above 5 Hz inside the usable band (the force spectrum within ``drop_db`` of its
    low-frequency level): where the hammer excites."""
    _, upper_hz = usable_band_hz(frf.freq_hz, frf.gff, drop_db)
    return (frf.freq_hz >= RESONANCE_SEARCH_FROM_HZ) & (frf.freq_hz <= upper_hz)


def readable_lines(frf: FrfResult, drop_db: float = USABLE_DROP_DB) -> np.ndarray:
    """Mask of the lines where an FRF can be read: inside the hammer's band (:func:`hammer_band_lines`) and with
    coherence ≥ 0.9 (a single hit's coherence is 1 everywhere, so the usable band is what keeps it off the hammer's
    spectral nulls)."""
    return (hammer_band_lines(frf, drop_db) & np.isfinite(np.abs(frf.h1))
            & (np.nan_to_num(frf.coherence) >= READ_MIN_COHERENCE))


def prominent_peaks(values: np.ndarray, min_prominence: float) -> np.ndarray:
    """Indices of the local maxima of ``values`` whose topographic prominence is at least ``min_prominence``: what
    ``scipy.signal.find_peaks(values, prominence=min_prominence)[0]`` returns (a flat top counts once, at its middle;
    a maximum's prominence is its height above the higher of the lowest points on each side before a higher sample
    or the edge), without importing ``scipy.signal`` and the ``scipy.stats`` it loads (a second of a command's
    start-up)."""
    x = np.asarray(values, dtype=float)
    if x.size < 3:
        return np.empty(0, dtype=np.intp)
    # runs of equal samples; a run higher than both neighbouring runs, not at an edge, is a maximum (at its middle)
    starts = np.concatenate(([0], np.flatnonzero(np.diff(x) != 0) + 1))
    ends = np.concatenate((starts[1:] - 1, [x.size - 1]))
    level = x[starts]
    top = np.zeros(starts.size, bool)
    top[1:-1] = (level[1:-1] > level[:-2]) & (level[1:-1] > level[2:])
    peaks = (starts[top] + ends[top]) // 2
    if peaks.size == 0:
        return peaks.astype(np.intp)
    # each sample's nearest strictly higher sample on the left and on the right (-1 and n where none)
    higher_left = _nearest_higher(x, peaks)
    higher_right = x.size - 1 - _nearest_higher(x[::-1], x.size - 1 - peaks)
    extended = np.append(x, np.inf)
    left_low = np.minimum.reduceat(extended, np.ravel(np.column_stack((higher_left + 1, peaks + 1))))[0::2]
    right_low = np.minimum.reduceat(extended, np.ravel(np.column_stack((peaks, higher_right))))[0::2]
    prominence = x[peaks] - np.maximum(left_low, right_low)
    return peaks[prominence >= min_prominence].astype(np.intp)


def peak_half_widths(values: np.ndarray, peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each of the ``peaks``' prominence, and where its flanks cross half of it (fractional sample indices, left and
    right): what ``scipy.signal.peak_prominences(values, peaks)[0]`` and ``scipy.signal.peak_widths(values, peaks,
    rel_height=0.5)[2:]`` return, without importing ``scipy.signal`` (see :func:`prominent_peaks`)."""
    x = np.asarray(values, dtype=float)
    prominences, left_ips, right_ips = (np.empty(len(peaks)) for _ in range(3))
    for number, peak in enumerate(peaks):
        bases = []
        for step, end in ((-1, -1), (1, x.size)):  # the lowest point on each side before a higher sample or the edge
            lowest, base, i = x[peak], peak, peak
            while i != end and x[i] <= x[peak]:
                if x[i] < lowest:
                    lowest, base = x[i], i
                i += step
            bases.append((lowest, base))
        (left_low, left_base), (right_low, right_base) = bases
        prominences[number] = x[peak] - max(left_low, right_low)
        height = x[peak] - 0.5 * prominences[number]
        i = peak
        while left_base < i and height < x[i]:
            i -= 1
        left_ips[number] = i + ((height - x[i]) / (x[i + 1] - x[i]) if x[i] < height else 0.0)
        i = peak
        while i < right_base and height < x[i]:
            i += 1
        right_ips[number] = i - ((height - x[i]) / (x[i - 1] - x[i]) if x[i] < height else 0.0)
    return prominences, left_ips, right_ips


def _nearest_higher(x: np.ndarray, points: np.ndarray) -> np.ndarray:
    """For each sample index of ``points``, the index of the nearest sample on its left that is strictly higher (-1
    where none); in blocks of points of at most about 4 million comparisons."""
    found = np.full(len(points), -1, dtype=np.intp)
    block = max(1, 2**22 // max(x.size, 1))
    position = np.arange(x.size)
    for start in range(0, len(points), block):
        chunk = np.asarray(points[start:start + block])
        higher = (x > x[chunk, np.newaxis]) & (position < chunk[:, np.newaxis])
        last = x.size - 1 - np.argmax(higher[:, ::-1], axis=1)
        found[start:start + block] = np.where(higher.any(axis=1), last, -1)
    return found


def resonance_lines(frf: FrfResult, drop_db: float = USABLE_DROP_DB) -> list[int]:
    """Line indices of the resonances of |H1| inside the readable band (:func:`readable_lines`), strongest first:
    local maxima standing :data:`RESONANCE_PROMINENCE` times above the lowest |H1| on either side down to the next
    higher maximum or the band's edge. A maximum on the band's edge is not a resonance."""
    readable = readable_lines(frf, drop_db)
    lines = np.flatnonzero(readable)
    if lines.size < 3:
        return []
    magnitude = np.abs(frf.h1[lines])
    peaks = prominent_peaks(np.log(magnitude), np.log(RESONANCE_PROMINENCE))
    # a peak must be one of the band's own: neighbours read on both sides (no gap of unreadable lines)
    peaks = [p for p in peaks if lines[p + 1] - lines[p] == 1 and lines[p] - lines[p - 1] == 1]
    return [int(lines[p]) for p in sorted(peaks, key=lambda p: -magnitude[p])]


def peak_line(frf: FrfResult, drop_db: float = USABLE_DROP_DB) -> int:
    """The line a summary calls the FRF's peak: its strongest resonance (:func:`resonance_lines`), else the largest
    readable line, else the largest line above :data:`RESONANCE_SEARCH_FROM_HZ` — what ``replay`` reports and the
    GUI's FRF tab shows."""
    magnitude = np.abs(frf.h1)
    resonances = resonance_lines(frf, drop_db)
    if resonances:
        return resonances[0]
    search = readable_lines(frf, drop_db)
    if not np.any(search):
        search = (frf.freq_hz >= RESONANCE_SEARCH_FROM_HZ) & np.isfinite(magnitude)
    return int(np.flatnonzero(search)[np.argmax(magnitude[search])])


class FrfAccumulator:
    """Running sums of an averaged FRF: add hits one at a time (or a block at a time) and read the averaged
    result whenever wanted, without transforming the earlier hits again.

    All hits share the sample rate, the record length and the window; force in N, response in m/s²."""

    def __init__(
        self, sample_rate_hz: float, n_samples: int, window: WindowSettings = WindowSettings(), capacity_hits: int = 8
    ) -> None:
        if not sample_rate_hz > 0:
            raise SettingError(f"sample_rate_hz: {sample_rate_hz} must be positive")
        if n_samples < 2:
            raise SettingError(f"records: {n_samples} sample(s) per hit is too short")
        self.sample_rate_hz = float(sample_rate_hz)
        self.n_samples = int(n_samples)
        self.window = window
        n_lines = self.n_samples // 2 + 1
        self._decay = None
        if window.exponential_end_fraction is not None:
            self._decay = exponential_window(self.n_samples, window.exponential_end_fraction)
        self._sum_ff = np.zeros(n_lines)
        self._sum_xx = np.zeros(n_lines)
        self._sum_fx = np.zeros(n_lines, complex)
        # the hit-to-hit scatter in one pass, from sums of the per-hit FRFs' deviations from the first hit's FRF:
        # Σ|H_i - m|² = Σ|H_i - H_0|² - |Σ(H_i - H_0)|²/n loses at most a factor n to cancellation, since
        # n|m - H_0|² ≤ n·Σ|H_i - m|² (the per-hit FRFs are then never read again to average them)
        self._h1_reference: np.ndarray | None = None
        self._sum_deviation = np.zeros(n_lines, complex)
        self._sum_deviation_sq = np.zeros(n_lines)
        self._h1_per_hit = np.empty((max(1, capacity_hits), n_lines), complex)
        self._spectra: list[tuple[np.ndarray, np.ndarray] | None] = [None, None]
        self._scratch: tuple[np.ndarray, ...] | None = None
        # strips of about _STRIP_LINES, of equal width (no strip of a few lines that costs its calls for nothing)
        self._strip_lines = -(-n_lines // max(1, round(n_lines / _STRIP_LINES)))
        self.n_averages = 0

    def add(self, force_n: np.ndarray, response: np.ndarray) -> None:
        """Add one hit (rows of ``n_samples``) or a block of hits (arrays of shape (hits, ``n_samples``))."""
        self.add_blocks([(force_n, response)])

    def add_blocks(self, blocks: Iterable[tuple[np.ndarray, np.ndarray]]) -> None:
        """Add blocks of hits, each a pair of force and response arrays (hits, ``n_samples``), in order. Large blocks
        are transformed on a second thread while the block before is combined (the sums are formed by this thread
        alone, block after block: the same result as adding them one by one)."""
        pending: Future | tuple | None = None
        for number, (force_n, response) in enumerate(blocks):
            force, response = self._windowed(force_n, response)
            spectra = self._spectra_buffers(number % 2, force.shape[0])
            if force.size >= 2 * _OVERLAPPED_VALUES:  # counted in samples: two per complex line
                transformed: Future | tuple = _second_thread().submit(_transform, force, response, spectra)
            else:
                transformed = _transform(force, response, spectra)
            if pending is not None:
                self._combine(*(pending.result() if isinstance(pending, Future) else pending))
            pending = transformed
        if pending is not None:
            self._combine(*(pending.result() if isinstance(pending, Future) else pending))

    def _windowed(self, force_n: np.ndarray, response: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A block's force and response rows, checked and windowed."""
        force = np.atleast_2d(np.asarray(force_n, dtype=np.float64))
        response = np.atleast_2d(np.asarray(response, dtype=np.float64))
        if force.shape != response.shape or force.shape[-1] != self.n_samples:
            raise SettingError(
                f"records: force {force.shape} and response {response.shape} do not match {self.n_samples} samples"
            )
        if self.window.force_window_ms is not None:
            force = force * force_window(force, self.sample_rate_hz, self.window)
        if self._decay is not None:
            force = force * self._decay
            response = response * self._decay
        return force, response

    def _combine(self, force_fft: np.ndarray, response_fft: np.ndarray) -> None:
        """Add a block's spectra to the sums and its per-hit FRFs to the kept ones (``force_fft`` is overwritten)."""
        first, count = self.n_averages, force_fft.shape[0]
        if first + count > len(self._h1_per_hit):
            grown = np.empty((max(first + count, 2 * len(self._h1_per_hit)), self._h1_per_hit.shape[1]), complex)
            grown[:first] = self._h1_per_hit[:first]
            self._h1_per_hit = grown
        scratch = self._scratch_buffers(count)
        h1 = self._h1_per_hit[first : first + count]
        with np.errstate(divide="ignore", invalid="ignore"):
            if self._h1_reference is None:
                self._h1_reference = response_fft[0] / force_fft[0]
            # the sums line by line in strips of a few thousand lines, so that every pass over a strip stays in cache
            for start in range(0, force_fft.shape[1], self._strip_lines):
                lines = slice(start, start + self._strip_lines)
                self._add_strip(lines, force_fft[:, lines], response_fft[:, lines], h1[:, lines], scratch)
        self.n_averages += count

    def _add_strip(self, lines: slice, force_fft: np.ndarray, response_fft: np.ndarray, h1: np.ndarray,
                   scratch: tuple[np.ndarray, ...]) -> None:
        """Add a block of hits' spectra on the frequency ``lines`` to the sums, and their per-hit FRFs into ``h1``
        (``force_fft`` is overwritten)."""
        width = force_fft.shape[1]
        force_power, power, deviation = (buffer[:, :width] for buffer in (scratch[0], scratch[1], scratch[3]))
        parts = scratch[2][:, : 2 * width]
        _squared_magnitude(force_fft, out=force_power, parts=parts)
        self._sum_ff[lines] += force_power.sum(axis=0)
        self._sum_xx[lines] += _squared_magnitude(response_fft, out=power, parts=parts).sum(axis=0)
        cross = np.conj(force_fft, out=force_fft)
        cross *= response_fft  # conj(F_i)·X_i
        self._sum_fx[lines] += cross.sum(axis=0)
        # X_i/F_i = conj(F_i)·X_i/|F_i|², on the real and imaginary parts: a complex array divided by a real one
        # would be promoted to a complex division (three times slower)
        np.divide(cross.real, force_power, out=h1.real)
        np.divide(cross.imag, force_power, out=h1.imag)
        np.subtract(h1, self._h1_reference[lines], out=deviation)
        self._sum_deviation[lines] += deviation.sum(axis=0)
        self._sum_deviation_sq[lines] += _summed_squared_magnitude(deviation)

    def _spectra_buffers(self, which: int, count: int) -> tuple[np.ndarray, np.ndarray]:
        """Force and response spectra of a block of ``count`` hits in one of two pairs of buffers kept between blocks
        (one is filled while the other is read): fresh arrays of this size would be mapped from the operating
        system, and zero-filled, on every block."""
        kept = self._spectra[which]
        if kept is None or kept[0].shape[0] < count:
            n_lines = len(self._sum_ff)
            kept = self._spectra[which] = (np.empty((count, n_lines), complex), np.empty((count, n_lines), complex))
        return kept[0][:count], kept[1][:count]

    def _scratch_buffers(self, count: int) -> tuple[np.ndarray, ...]:
        """Scratch strips for a block of ``count`` hits (powers, squared parts, deviations), kept between blocks."""
        if self._scratch is None or self._scratch[0].shape[0] < count:
            strip = self._strip_lines
            self._scratch = (np.empty((count, strip)), np.empty((count, strip)), np.empty((count, 2 * strip)),
                             np.empty((count, strip), complex))
        return tuple(buffer[:count] for buffer in self._scratch)

    def add_hit(self, hit: Any) -> None:
        """Add a :class:`gasfilm.analysis.capture.HitRecord` (or stored hit) through its OWN force and response
        channels."""
        if abs(hit.sample_rate_hz - self.sample_rate_hz) > 1e-9 * self.sample_rate_hz:
            raise SettingError(f"hits: recorded at {hit.sample_rate_hz:g} and {self.sample_rate_hz:g} S/s")
        self.add(hit.data[hit.force_channel], hit.data[hit.response_channel])

    def result(self) -> FrfResult:
        """H1, H2, coherence and the two uncertainties of |H1| averaged over the hits added so far."""
        n_hits, n_samples = self.n_averages, self.n_samples
        if n_hits == 0:
            raise SettingError("records: no hits to average")
        n_lines = len(self._sum_ff)
        h1_per_hit = self._h1_per_hit[:n_hits]
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.full(n_lines, 2.0 / (self.sample_rate_hz * n_samples * n_hits))
            scale[0] /= 2.0
            if n_samples % 2 == 0:
                scale[-1] /= 2.0
            gff = self._sum_ff * scale
            gxx = self._sum_xx * scale
            gfx = self._sum_fx * scale
            if not (np.all(np.isfinite(gff)) and np.all(np.isfinite(gxx))):
                raise SettingError("records: the hits contain NaN or infinite samples")
            h1 = gfx / gff
            h2 = gxx / np.conj(gfx)
            coherence = _squared_magnitude(gfx) / (gff * gxx)
            gamma_sq = np.clip(coherence, 0.0, 1.0)
            h1_std_coherence = np.abs(h1) * np.sqrt(1.0 - gamma_sq) / (np.sqrt(gamma_sq) * np.sqrt(2.0 * n_hits))
            if n_hits > 1:
                spread = self._sum_deviation_sq - _squared_magnitude(self._sum_deviation) / n_hits
                h1_std_scatter = np.sqrt(np.maximum(spread, 0.0) / (n_hits - 1) / n_hits)
            else:
                h1_std_scatter = np.full(n_lines, np.nan)
        decay_rate = self.window.decay_rate_1_s(n_samples, self.sample_rate_hz)
        return FrfResult(
            freq_hz=np.fft.rfftfreq(n_samples, 1.0 / self.sample_rate_hz),
            h1=h1,
            h2=h2,
            coherence=coherence,
            gff=gff,
            gxx=gxx,
            gfx=gfx,
            h1_per_hit=h1_per_hit.copy() if len(self._h1_per_hit) > n_hits else h1_per_hit,
            n_averages=n_hits,
            sample_rate_hz=self.sample_rate_hz,
            n_samples=n_samples,
            decay_rate_1_s=float(decay_rate),
            h1_std_coherence=h1_std_coherence,
            h1_std_scatter=h1_std_scatter,
            window={**self.window.to_dict(), "decay_rate_1_s": float(decay_rate)},
        )


def _second_thread() -> ThreadPoolExecutor:
    """The thread that transforms blocks, started once per process (a forked child has none of its parent's
    threads: it starts its own)."""
    global _fft_thread
    if _fft_thread is None or _fft_thread[0] != os.getpid():
        _fft_thread = (os.getpid(), ThreadPoolExecutor(max_workers=1, thread_name_prefix="gasfilm-fft"))
    return _fft_thread[1]


def _transform(force: np.ndarray, response: np.ndarray, spectra: tuple[np.ndarray, np.ndarray]
               ) -> tuple[np.ndarray, np.ndarray]:
    """The real FFTs of a block's force and response rows into ``spectra``; returns ``spectra``."""
    np.fft.rfft(force, axis=-1, out=spectra[0])
    np.fft.rfft(response, axis=-1, out=spectra[1])
    return spectra


def _block_hits(n_samples: int) -> int:
    """Hits transformed at once: about :data:`_BLOCK_VALUES` complex values per channel, so that a block stays in
    cache, and an even number (numpy's FFT transforms rows two at a time, an odd one out alone at 1.4× the cost)."""
    return 2 * max(1, round(_BLOCK_VALUES / (n_samples // 2 + 1) / 2))


def compute_frf(
    records: Sequence[np.ndarray] | np.ndarray,
    sample_rate_hz: float,
    window: WindowSettings = WindowSettings(),
    force_row: int = 0,
    response_row: int = 1,
) -> FrfResult:
    """Averaged H1, H2, coherence and uncertainty of hits given as (channels, samples) arrays or one
    (hits, channels, samples) array; force in N, response in m/s²."""
    if not sample_rate_hz > 0:
        raise SettingError(f"sample_rate_hz: {sample_rate_hz} must be positive")
    data = _as_hits_array(records)
    n_hits, n_rows, n_samples = data.shape
    for name, row in (("force_row", force_row), ("response_row", response_row)):
        if not 0 <= row < n_rows:
            raise SettingError(f"{name}: {row} is not a row of records with {n_rows} rows")
    accumulator = FrfAccumulator(sample_rate_hz, n_samples, window, capacity_hits=n_hits)
    block = _block_hits(n_samples)
    accumulator.add_blocks((data[first : first + block, force_row, :], data[first : first + block, response_row, :])
                           for first in range(0, n_hits, block))
    return accumulator.result()


def session_frf(hits: Sequence[Any], window: WindowSettings = WindowSettings()) -> FrfResult:
    """The averaged FRF of a session's hits (:class:`gasfilm.analysis.capture.HitRecord` or stored hits), each
    taken from its OWN force and response channels (a session whose response is on ai2 is averaged on ai2). ``hits``
    is sliced a block at a time: :meth:`Session.stored_hits <gasfilm.analysis.session.Session.stored_hits>` reads a
    session's records block by block, never all at once."""
    if len(hits) == 0:
        raise SettingError("hits: no accepted hits to average")
    first_hit = hits[0]
    accumulator = FrfAccumulator(float(first_hit.sample_rate_hz), first_hit.data.shape[-1], window,
                                 capacity_hits=len(hits))
    block = _block_hits(accumulator.n_samples)

    def blocks() -> Iterable[tuple[np.ndarray, np.ndarray]]:
        """The hits a block at a time (a session's stored hits are read from the file block by block)."""
        for first in range(0, len(hits), block):
            chunk = hits[first : first + block]
            rates = {accumulator.sample_rate_hz, *(float(hit.sample_rate_hz) for hit in chunk)}
            if len(rates) != 1:
                raise SettingError(f"hits: recorded at different sample rates ({', '.join(map(str, sorted(rates)))} "
                                   f"Hz)")
            lengths = {accumulator.n_samples, *(hit.data.shape[-1] for hit in chunk)}
            if len(lengths) != 1:
                raise SettingError(f"hits: records of different lengths ({', '.join(map(str, sorted(lengths)))} "
                                   f"samples)")
            yield (np.stack([hit.data[hit.force_channel] for hit in chunk]),
                   np.stack([hit.data[hit.response_channel] for hit in chunk]))

    accumulator.add_blocks(blocks())
    return accumulator.result()




FRF_CSV_COLUMNS = (
    "freq_hz",
    "h1_real_m_s2_per_n",
    "h1_imag_m_s2_per_n",
    "h1_abs_m_s2_per_n",
    "h1_abs_g_per_n",
    "h1_phase_deg",
    "h2_real_m_s2_per_n",
    "h2_imag_m_s2_per_n",
    "coherence",
    "h1_std_coherence_m_s2_per_n",
    "h1_std_scatter_m_s2_per_n",
    "hv_real_m_s2_per_n",
    "hv_imag_m_s2_per_n",
)


def write_frf_csv(frf: FrfResult, path: str | Path, conditions: Mapping[str, Any] | None = None) -> Path:
    """The FRF as CSV with a header row (:data:`FRF_CSV_COLUMNS`): H1 in (m/s²)/N and g/N, H2, coherence, the
    two uncertainties and Hv. The session's operating ``conditions``, if any, come first as ``# condition KEY = VALUE``
    comment lines."""
    path = Path(path)
    if not path.parent.is_dir():
        from gasfilm.analysis.paths import missing_folder

        raise SettingError(f"{path}: {missing_folder(path.parent)}")
    columns = np.column_stack(
        (
            frf.freq_hz,
            frf.h1.real,
            frf.h1.imag,
            np.abs(frf.h1),
            np.abs(frf.h1) / STANDARD_GRAVITY_M_S2,
            np.degrees(np.angle(frf.h1)),
            frf.h2.real,
            frf.h2.imag,
            frf.coherence,
            frf.h1_std_coherence,
            frf.h1_std_scatter,
            frf.hv.real,
            frf.hv.imag,
        )
    )
    from gasfilm.analysis.paths import written_whole

    header = "".join(f"# condition {key} = {value}\n" for key, value in (conditions or {}).items())
    with written_whole(path, what="the CSV") as (building,):  # a full disk leaves no partial file
        np.savetxt(building, columns, delimiter=",", header=header + ",".join(FRF_CSV_COLUMNS), comments="",
                   fmt="%.12g")
    return path
