"""What the recordings say, with their own uncertainty: per-hit windowed spectra, measured noise, quality checks.

Each accepted hit is windowed the way the session's FRF is (:mod:`gasfilm.analysis.spectra`: a force window after the
peak with a short taper, and an exponential window on both channels), so that ``X_i / F_i`` is the hit's FRF at
``s = σ + jω``. The model is compared under the same conditions: it is *played with the hit's own recorded force*
(the whole record, as the DAQ delivered it, AC coupling and anti-aliasing included) and the replayed response goes
through the same windows (:class:`Replay`). Window truncation, the module's high-pass tail that the force window cuts,
and leakage thus appear in the replay exactly as in the recording instead of passing for physics.

The noise of each hit's FRF is measured, not assumed: the noise spectra of both channels come from the quiet
pre-trigger samples, and the variance of hit i's FRF at f is ``(P_x(f) + |H|² P_f(f)) Σw² / |F_i(f)|²`` (the
replayed response carries the recorded force's noise through the same window). With these weights the weighted mean
of the per-hit FRFs is exactly H1 (averaged cross- over auto-spectrum).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
import scipy.fft

from gasfilm.analysis.physics.response import HitConditions
from gasfilm.analysis.quantities import in_band as in_band_words
from gasfilm.analysis.spectra import WindowSettings, exponential_window, force_window
from gasfilm.drivers.errors import SettingError

MAINS_BASES_HZ = (50.0, 60.0)
QUIET_MARGIN_S = 0.001
TAIL_FRACTION = 0.25
#: Quiet samples a hit needs before its impact for its noise to be measured.
MIN_QUIET_SAMPLES = 16
#: An exponential window already in the records is divided out when it lowers the noise by more than this over the
#: record and the noise follows one exponential (log-level residual below PREWINDOW_FIT).
PREWINDOW_MIN_DECAY = 0.1
PREWINDOW_FIT = 0.05
MAINS_HARMONICS = 20
#: A mains line lies within this fraction of its harmonic's nominal frequency (grids hold 50/60 Hz within ±1 %; a
#: self-excited line near a harmonic is not mains).
MAINS_FREQUENCY_TOLERANCE = 0.01
#: Mains is stationary: the lines fitted on the tails, carried back to the pre-trigger, must be found there with the
#: same phase (one-sided z score of their correlation) and at least this fraction of their power.
MAINS_COHERENCE_Z = 3.0
MAINS_COHERENCE_SHARE = 0.5
#: Shortest quiet stretch (s) in which a mains line is sought: one over the spacing of the mains frequencies, the
#: length that resolves 50 Hz from 60 Hz. A shorter stretch cannot tell a line from its neighbour, nor from the slow
#: decay the AC coupling leaves after a pulse.
MIN_MAINS_WINDOW_S = 1.0 / (max(MAINS_BASES_HZ) - min(MAINS_BASES_HZ))
#: Hits needed to measure the noise from their scatter when no quiet pre-trigger is recorded.
MIN_SCATTER_HITS = 3
#: Lines (at least) over which the scatter of the hits' FRFs is smoothed into a noise spectrum.
SCATTER_SMOOTH_LINES = 41
#: The NI 9234's AC-coupling corner (Hz): a hit's force record decays this way after the pulse; an exported force
#: window cuts that decay, and the replay continues it (its corner uncertain by this fraction).
AC_COUPLING_HZ = 0.5
AC_COUPLING_UNCERTAINTY = 0.5
#: The anti-aliasing filter rings this long (s) after a pulse ends.
FILTER_SETTLE_S = 0.5e-3
#: Tails whose response levels (thirds) differ by less than this fraction of their mean hold steady noise.
STEADY_TAIL_SPREAD = 0.15
#: A channel with fewer quantisation steps than this to its peak is coarsely quantised: a plateau at its peak is
#: not by itself a sign of clipping.
COARSE_LEVELS = 2**12


@dataclass
class QualityNote:
    """A measurement-quality observation (never physics)."""

    kind: str  # "interference", "double hit", "overload", "low coherence", "truncation", "noise", "rejected hits",
    # "few hits", …
    message: str
    band_hz: tuple[float, float] | None = None
    hits: tuple[int, ...] = ()

    def to_dict(self) -> dict:
        return {"kind": self.kind, "message": self.message, "band_hz": self.band_hz,
                "hits": [int(hit) + 1 for hit in self.hits]}  # numbered from 1, as everywhere the user sees


@dataclass
class NoiseSource:
    """Where the noise of the FRFs was measured: ``source`` is "record tails", "pre-trigger" or "hit scatter";
    ``degrees_of_freedom`` of the noise estimate (real numbers, over the band a line's estimate draws on)."""

    source: str
    degrees_of_freedom: float
    detail: str

    def to_dict(self) -> dict:
        return {"source": self.source, "degrees_of_freedom": round(self.degrees_of_freedom, 1),
                "detail": self.detail}


@dataclass
class HitSpectra:
    """Per-hit FRFs on the analysis grid with their measured noise variance, and what is needed to replay them.

    ``h`` is what the diagnosis compares with the model. It starts as the measured ``X_i/F_i``; after
    :meth:`correct_for_replay` it is the measured FRF divided by the replay ratio ``C_i = H_replay,i / H_model,i``
    (the spec played with the hit's own recorded force through the same windows, over the model's plain Laplace
    accelerance), so that comparing ``h`` with the plain model is comparing recording and replay hit by hit.
    """

    freq_hz: np.ndarray  # (G,)
    decay_rate_1_s: float
    h: np.ndarray  # (hits, G) complex per-hit FRF
    variance: np.ndarray  # (hits, G) E|H_i − true|²: each of the real and imaginary parts carries half
    conditions: HitConditions
    hit_numbers: np.ndarray  # index of each used hit in the input
    sample_rate_hz: float
    n_samples: int
    quality: list[QualityNote] = field(default_factory=list)
    replay: "Replay | None" = None
    noise: "NoiseSource | None" = None
    #: What late-triggered records' missing pulse fronts add to their replayed FRFs, for the spec ``h`` was corrected
    #: with (:meth:`Replay.front_responses`); None without late hits. Profiled out of every comparison
    #: (:class:`~gasfilm.analysis.diagnosis.selection.Evidence`).
    missing_fronts: "MissingFronts | None" = None

    @property
    def weight(self) -> np.ndarray:
        """Weight per real number: the real and imaginary parts each have variance ``variance / 2``."""
        return 2.0 / self.variance

    def mean(self, subset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean FRF (H1) over a subset of hits and its total weight per frequency."""
        rows = slice(None) if subset is None else subset
        return weighted_mean(self.h[rows], self.weight[rows])

    def correct_for_replay(
        self, model_accelerance: Callable[[np.ndarray, float], np.ndarray], replayed: np.ndarray | None = None
    ) -> "HitSpectra":
        """A copy whose ``h`` and ``variance`` are divided by the replay ratio of ``model_accelerance``.

        ``model_accelerance(freq_hz, decay_rate_1_s)`` returns (hits, frequencies) or (frequencies,); ``replayed``
        gives the replayed per-hit FRFs when they come from an exact nonlinear simulation."""
        if self.replay is None:
            return self
        if self.replay.additive:
            if replayed is None:
                replayed = self.replay.replayed(model_accelerance)
            return replace(self, h=self.replay.measured_h - (replayed - self.replay.laplace(model_accelerance)),
                           variance=self.replay.measured_variance,
                           missing_fronts=self.replay.front_responses(model_accelerance,
                                                                      self.replay.measured_h - replayed))
        ratio = self.replay.ratio(model_accelerance, replayed)
        return replace(self, h=self.replay.measured_h / ratio,
                       variance=self.replay.measured_variance / np.abs(ratio) ** 2)


#: The replay's circular convolution is damped so that what wraps round after ``n_fft`` samples is attenuated by
#: e^(−WRAP_DECAY) (see :meth:`Replay.replayed`); the undamping amplifies round-off by at most e^(WRAP_DECAY/2).
WRAP_DECAY = 20.0


#: The timing of a late record's missing front is known to about this many samples (the Gaussian prior scale of its
#: timing coefficient, in units of the front's impulse: :class:`MissingFronts`).
FRONT_TIMING_SAMPLES = 0.5


@dataclass
class MissingFronts:
    """What each late-triggered record's missing pulse front adds to its hit's replayed FRF, per unit of its two
    nuisance parameters: the front's impulse (N·s) and that impulse moved one sample earlier (N·s·samples, its timing).

    A record that starts inside its pulse misses the front's impulse ΔI_i: the mover keeps the velocity it gave (in
    the record), the first acceleration samples are lost (before it), so the recording holds
    ``H·F_rec + ΔI_i·(H − 1/m)·e^{sτ_i}`` through the windows — linear in ΔI_i and, to first order, in ΔI_i·δτ_i about
    the mirrored front's timing; the mirror only estimates both. Both are fitted by weighted least squares in every
    comparison, the timing within a Gaussian prior ``timing_sigma`` of :data:`FRONT_TIMING_SAMPLES` times the front's
    impulse (the mirrored one with what the recording adds to it at the spec replayed, which the mass line's offset
    below the resonance measures): a timing free of the impulse it moves would turn the resonance's phase as a small
    shift of the resonance does, hit by hit, and take up a small added mass or a change of the film."""

    columns: np.ndarray  # (2, hits, G) complex; zero for records whose pulse start is recorded
    timing_sigma: np.ndarray  # (hits,) prior scale of the timing coefficient (N·s·samples)

    @property
    def parameter_count(self) -> int:
        """Nuisance parameters fitted: two per late record."""
        return int(np.sum(np.any(self.columns != 0, axis=2)))

    def subset(self, hits: np.ndarray | None = None, lines: np.ndarray | None = None) -> "MissingFronts":
        """The fronts of some hits on some analysis lines."""
        columns = self.columns if hits is None else self.columns[:, hits]
        return MissingFronts(columns if lines is None else columns[:, :, lines],
                             self.timing_sigma if hits is None else self.timing_sigma[hits])

    def fitted(self, difference: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What the fronts contribute to ``difference`` (hits, G; recording − replay) by weighted least squares
        (``weight`` per complex value) with the timing prior, and the prior's residual (hits,) in noise units."""
        columns = self.columns
        gram = np.einsum("ahg,bhg->hab", np.conj(columns) * weight, columns).real
        projection = np.einsum("ahg,hg->ha", np.conj(columns) * weight, difference).real
        late = np.any(gram != 0, axis=(1, 2))
        gram[:, 1, 1] += np.where(late, self.timing_sigma ** -2.0, 0.0)
        gram[~late] = np.eye(columns.shape[0])
        coefficients = np.linalg.solve(gram, projection[..., np.newaxis])[..., 0]
        return np.einsum("ha,ahg->hg", coefficients, columns), coefficients[:, 1] / self.timing_sigma


@dataclass
class Replay:
    """The recorded forces and windows, to play a model with them exactly as the recordings were processed."""

    force_padded: np.ndarray  # (hits, n_fft//2+1) spectrum of each raw recorded force record, zero-padded
    n_fft: int
    exponential: np.ndarray  # (hits, samples)
    force_windowed_grid: np.ndarray  # (hits, G) windowed force spectrum on the analysis grid
    grid: np.ndarray  # (G,) rfft bins of the analysis grid
    measured_h: np.ndarray
    measured_variance: np.ndarray
    n_samples: int
    sample_rate_hz: float
    decay_rate_1_s: float
    nonlinear_cache: dict = field(default_factory=dict)  # model key → replayed FRFs of the exact nonlinear rig
    damped_force_padded: np.ndarray | None = None  # spectrum of the forces × e^(−σ₀t), see :meth:`replayed`
    #: A coarsely quantised response (step and offset, m/s²): the replayed response is quantised the same way.
    response_step: float = 0.0
    response_offset: float = 0.0
    #: Correct the measured FRFs by the replay's difference from the model, not its ratio: records that start inside
    #: the pulse miss part of their response (the mass line's, not the model's shape), which a ratio would scale.
    additive: bool = False
    #: Records that start inside their force pulse (a late trigger): spectrum of each one's missing front scaled to
    #: one N·s of impulse, at negative times, zero-padded to ``n_fft`` (hits × n_fft//2+1, zero rows for records
    #: whose pulse start is recorded), and the mirrored front's impulse (N·s, hits); None without late records. See
    #: :meth:`front_responses`.
    front_padded: np.ndarray | None = None
    front_impulse_ns: np.ndarray | None = None
    damped_front_padded: np.ndarray | None = None

    def quantised(self, responses: np.ndarray) -> np.ndarray:
        """Replayed response records as the recording's quantiser stores them (unchanged for a fine one)."""
        if self.response_step <= 0:
            return responses
        step, offset = self.response_step, self.response_offset
        return np.round((responses - offset) / step) * step + offset

    def replayed(self, model_accelerance: Callable[[np.ndarray, float], np.ndarray]) -> np.ndarray:
        """Per-hit FRFs (hits, G) of the model played with each hit's recorded force, windowed like the recording.

        The convolution is circular over ``n_fft`` samples: a lightly damped mode still ringing after ``n_fft``
        would wrap round into the record (5 % of a ζ = 0.0024 mode at 609 Hz with 0.16 s records). It is computed
        damped — force × e^(−σ₀t), the model at s + σ₀, the response × e^(σ₀t) — which attenuates the wrapped part
        by e^(−σ₀·n_fft/fs) = e^(−:data:`WRAP_DECAY`) and is otherwise exact."""
        if self.damped_force_padded is None:
            self.damped_force_padded = self._damped(self.force_padded)
        return self._played(self.damped_force_padded, model_accelerance, self.quantised)

    def front_responses(
        self, model_accelerance: Callable[[np.ndarray, float], np.ndarray], difference: np.ndarray
    ) -> MissingFronts | None:
        """The model played with each late record's missing front alone, windowed like the recording: per N·s of its
        impulse and per N·s of it moved one sample earlier, the timing's prior from the front's impulse with what
        ``difference`` (recording − replay, hits × G) adds to it (:class:`MissingFronts`; None without late
        records)."""
        if self.front_padded is None:
            return None
        if self.damped_front_padded is None:
            earlier = np.exp(2j * np.pi * np.arange(self.front_padded.shape[-1]) / self.n_fft)  # one sample earlier
            self.damped_front_padded = np.stack([self._damped(self.front_padded),
                                                 self._damped(self.front_padded * (earlier - 1.0))])
        played = self._played(self.damped_front_padded.reshape(-1, self.damped_front_padded.shape[-1]),
                              model_accelerance, lambda responses: responses, stacked=2)
        columns = played.reshape(2, *self.measured_h.shape)
        weight = 1.0 / self.measured_variance
        norm = np.sum(weight * np.abs(columns[0]) ** 2, axis=1)
        added_ns = np.divide(np.sum(weight * (np.conj(columns[0]) * difference).real, axis=1), norm,
                             out=np.zeros_like(norm), where=norm > 0)
        impulse_ns = np.abs(self.front_impulse_ns + added_ns)
        return MissingFronts(columns, FRONT_TIMING_SAMPLES * np.maximum(impulse_ns, 1e-9 * impulse_ns.max() + 1e-300))

    def with_missing_fronts(
        self, replayed: np.ndarray, model_accelerance: Callable[[np.ndarray, float], np.ndarray]
    ) -> np.ndarray:
        """Replayed per-hit FRFs with each late record's missing front fitted to the recording
        (:meth:`MissingFronts.fitted`); unchanged without late records."""
        fronts = self.front_responses(model_accelerance, self.measured_h - replayed)
        if fronts is None:
            return replayed
        return replayed + fronts.fitted(self.measured_h - replayed, 1.0 / self.measured_variance)[0]

    def _played(
        self, damped_force: np.ndarray, model_accelerance: Callable[[np.ndarray, float], np.ndarray],
        quantised: Callable[[np.ndarray], np.ndarray], stacked: int = 1,
    ) -> np.ndarray:
        """The damped circular convolution of :meth:`replayed` for force spectra × e^(−σ₀t) (:meth:`_damped`);
        ``stacked`` sets of the hits' rows one after the other."""
        decay_1_s = WRAP_DECAY * self.sample_rate_hz / self.n_fft
        padded_freq_hz = np.fft.rfftfreq(self.n_fft, 1.0 / self.sample_rate_hz)
        plain = model_accelerance(padded_freq_hz, decay_1_s)
        plain = np.broadcast_to(np.concatenate([plain] * stacked) if plain.ndim == 2 and stacked > 1 else plain,
                                damped_force.shape)
        response = scipy.fft.irfft(damped_force * plain, self.n_fft, axis=1)[:, : self.n_samples]
        response = quantised(response * np.exp(decay_1_s * np.arange(self.n_samples) / self.sample_rate_hz))
        exponential = np.concatenate([self.exponential] * stacked) if stacked > 1 else self.exponential
        force_windowed_grid = (np.concatenate([self.force_windowed_grid] * stacked) if stacked > 1
                               else self.force_windowed_grid)
        return scipy.fft.rfft(response * exponential, axis=1)[:, self.grid] / force_windowed_grid

    def _damped(self, padded: np.ndarray) -> np.ndarray:
        """Spectrum of each zero-padded force × e^(−σ₀t) (σ₀ of :meth:`replayed`). The buffer beyond the record is
        negative time: a late trigger's reconstructed pulse front sits at its end (:func:`_with_fronts`)."""
        decay_1_s = WRAP_DECAY * self.sample_rate_hz / self.n_fft
        time_samples = np.arange(self.n_fft, dtype=float)
        time_samples[self.n_samples :] -= self.n_fft
        damping = np.exp(-decay_1_s * time_samples / self.sample_rate_hz)
        return np.fft.rfft(scipy.fft.irfft(padded, self.n_fft, axis=1) * damping, axis=1)

    def single(self, hit: int) -> "Replay":
        """The replay of one hit only."""
        rows = slice(hit, hit + 1)
        return replace(self, force_padded=self.force_padded[rows], exponential=self.exponential[rows],
                       force_windowed_grid=self.force_windowed_grid[rows], measured_h=self.measured_h[rows],
                       measured_variance=self.measured_variance[rows], nonlinear_cache={}, damped_force_padded=None,
                       front_padded=None if self.front_padded is None else self.front_padded[rows],
                       front_impulse_ns=None if self.front_padded is None else self.front_impulse_ns[rows],
                       damped_front_padded=None)

    def windowed_frf(self, responses: np.ndarray) -> np.ndarray:
        """Per-hit FRFs on the grid of replayed response records (hits, samples), windowed like the recording."""
        return (scipy.fft.rfft(self.quantised(responses) * self.exponential, axis=1)[:, self.grid]
                / self.force_windowed_grid)

    @property
    def forces_n(self) -> np.ndarray:
        """The recorded force records (hits, samples) as the DAQ delivered them."""
        return scipy.fft.irfft(self.force_padded, self.n_fft, axis=1)[:, : self.n_samples]

    def ratio(
        self, model_accelerance: Callable[[np.ndarray, float], np.ndarray], replayed: np.ndarray | None = None
    ) -> np.ndarray:
        """``H_replay,i / H_model,i`` on the grid: the replayed FRF (linear replay of ``model_accelerance`` unless
        given) over the model's windowed Laplace accelerance."""
        if replayed is None:
            replayed = self.replayed(model_accelerance)
        return replayed / self.laplace(model_accelerance)

    def laplace(self, model_accelerance: Callable[[np.ndarray, float], np.ndarray]) -> np.ndarray:
        """The model's windowed Laplace accelerance on the grid (what the corrected FRFs are compared with)."""
        return model_accelerance(np.fft.rfftfreq(self.n_samples, 1.0 / self.sample_rate_hz)[self.grid],
                                 self.decay_rate_1_s)


def _pulse_extent(force_n: np.ndarray) -> tuple[int, int, int]:
    """Start, peak and end sample of the main force pulse (where |F| exceeds 2 % of its peak)."""
    magnitude = np.abs(force_n)
    peak = int(np.argmax(magnitude))
    threshold = 0.02 * magnitude[peak]
    start = peak
    while start > 0 and magnitude[start - 1] > threshold:
        start -= 1
    end = peak
    while end < len(magnitude) - 1 and magnitude[end + 1] > threshold:
        end += 1
    return start, peak, end


#: The impulse sums the pulse with this many of its own lengths (at least IMPULSE_MARGIN_MIN samples) on either side:
#: the anti-aliasing filter spreads a short pulse beyond where |F| > 2 % of its peak, and summing only that part misses
#: 0.3–0.8 % of the impulse depending on where the samples fall on the pulse (enough to leave an amplitude-dependent
#: damping's resonance at χ²/point ~2–4). The whole band-limited pulse sums to its integral.
IMPULSE_MARGIN_PULSES = 1.0
IMPULSE_MARGIN_MIN = 4


def hit_impulse_ns(force_n: np.ndarray, extent: tuple[int, int, int], sample_rate_hz: float) -> float:
    """A hit's force impulse (N·s): the sum of the band-limited pulse with its filter ringing on either side."""
    start, _, end = extent
    margin = max(IMPULSE_MARGIN_MIN, int(round(IMPULSE_MARGIN_PULSES * (end - start + 1))))
    return float(np.sum(force_n[max(start - margin, 0) : end + 1 + margin]) / sample_rate_hz)


def _clipped(signal: np.ndarray, run: int = 3, step: float = 0.0) -> bool:
    """True when the signal sits at its own extreme for ``run`` consecutive samples (a clipped ADC).

    A coarsely quantised signal (``step``, fewer than :data:`COARSE_LEVELS` steps to its peak) sits on its top level
    for several samples near any smooth peak: there a plateau counts as clipping only when the samples on either side
    of it, extrapolated by a parabola, rise more than two steps above it (a clipped peak is cut, a quantised one is
    not)."""
    magnitude = np.abs(signal)
    peak = magnitude.max()
    if peak == 0:
        return False
    at_peak = magnitude >= peak * (1 - 1e-9)
    if at_peak.sum() < run:
        return False
    edges = np.flatnonzero(np.diff(np.concatenate(([0], at_peak.astype(int), [0]))))
    starts, stops = edges[::2], edges[1::2]
    long_runs = [(a, b) for a, b in zip(starts, stops) if b - a >= run]
    if not long_runs:
        return False
    if step <= 0 or peak / step >= COARSE_LEVELS:
        return True
    for a, b in long_runs:
        flank = np.r_[max(a - 3, 0):a, b:min(b + 3, signal.size)]
        if flank.size < 4:
            return True
        coefficients = np.polyfit(flank - 0.5 * (a + b - 1), magnitude[flank], 2)
        if coefficients[0] < 0 and coefficients[2] > peak + 2 * step:
            return True
    return False


def _wrapped(signal: np.ndarray) -> bool:
    """True when the signal jumps between consecutive samples from near one extreme to near the other (beyond 80 % of
    its largest magnitude on both sides, opposite signs): integer counts that overflowed their type wrap so; a
    band-limited signal cannot swing its whole range in one sample unless it is at full amplitude near 0.5 fs."""
    largest = float(np.max(np.abs(signal)))
    if largest == 0:
        return False
    first, second = signal[:-1], signal[1:]
    return bool(np.any((first * second < 0) & (np.abs(first) > 0.8 * largest) & (np.abs(second) > 0.8 * largest)))


#: A record whose response per unit impulse is below this share of the hits' median holds no response to its pulse.
SILENT_RESPONSE_SHARE = 0.05
#: The response is measured over this long (s) from the pulse.
SILENT_RESPONSE_S = 0.1


def _hits_without_response(records: np.ndarray, extents: list[tuple[int, int, int]], sample_rate_hz: float
                           ) -> list[int]:
    """Hits whose response (RMS over :data:`SILENT_RESPONSE_S` from the pulse) per unit impulse is below
    :data:`SILENT_RESPONSE_SHARE` of the median hit's: a force pulse the structure did not feel."""
    length = max(int(SILENT_RESPONSE_S * sample_rate_hz), 1)
    ratios = []
    for record, extent in zip(records, extents):
        start = extent[0]
        response = record[1, start : start + length]
        impulse = abs(hit_impulse_ns(record[0], extent, sample_rate_hz))
        ratios.append(float(np.sqrt(np.mean(response**2))) / impulse if impulse > 0 else np.inf)
    ratios = np.array(ratios)
    return [int(i) for i in np.flatnonzero(ratios < SILENT_RESPONSE_SHARE * np.median(ratios))]


#: A response "ceiling": hits whose peak response lies within this fraction of the session's largest peak ...
CEILING_CLUSTER = 0.04
#: ... while their peak forces span at least this ratio (a linear chain's peak response follows the peak force)
CEILING_FORCE_SPAN = 1.1
#: floor of the relative scatter of peak response over peak force between the hits below the ceiling
CEILING_MIN_SPREAD = 0.01


def response_ceiling_hits(records: np.ndarray, extents: list[tuple[int, int, int]]) -> tuple[list[int], float]:
    """Hits whose response was clipped before the anti-aliasing filter, and the ceiling (m/s², signed).

    A sensor or conditioner overloaded before the ADC's filter leaves no flat run of samples (the filter rounds the
    cut peak), but it leaves a ceiling: several hits reach the same peak response whatever their force. In a linear
    chain each hit's peak response over its peak force scatters only a little (``spread``, measured on the hits below
    the ceiling); a hit is clipped when that ratio predicts a peak at or above the ceiling. Found only when at least
    three hits sit at the ceiling with forces spanning ``CEILING_FORCE_SPAN`` and two of them would have reached
    beyond it by more than three spreads.
    """
    force_peak = np.array([abs(record[0, peak]) for record, (_, peak, _) in zip(records, extents)])
    for sign in (1.0, -1.0):
        response_peak = np.max(sign * records[:, 1], axis=1)
        top = float(response_peak.max())
        if top <= 0:
            continue
        at_top = response_peak >= (1 - CEILING_CLUSTER) * top
        below = ~at_top
        if at_top.sum() < 3 or below.sum() < 3:
            continue
        if force_peak[at_top].max() < CEILING_FORCE_SPAN * force_peak[at_top].min():
            continue
        ratio = response_peak[below] / force_peak[below]
        gain = float(np.median(ratio))
        spread = max(1.4826 * float(np.median(np.abs(ratio / gain - 1))), CEILING_MIN_SPREAD)
        predicted = gain * force_peak
        if np.sum(predicted[at_top] > top * (1 + 3 * spread)) < 2:
            continue
        clipped = np.flatnonzero(at_top | (predicted >= top * (1 - 2 * spread)))
        return [int(i) for i in clipped], sign * top
    return [], 0.0


def _rms_about_trend(segments: np.ndarray) -> np.ndarray:
    """RMS of each row about its own least-squares parabola (motion slower than about one cycle per segment is not
    counted)."""
    length = segments.shape[-1]
    if length < 4:
        return np.sqrt(np.mean(segments**2, axis=-1))
    basis = np.vander(np.linspace(-1.0, 1.0, length), 3)
    coefficients, *_ = np.linalg.lstsq(basis, segments.T, rcond=None)
    return np.sqrt(np.mean((segments - (basis @ coefficients).T) ** 2, axis=-1))


#: The default analysis band starts here (Hz) and ends where the hammer's force spectrum has fallen 20 dB, at most
#: at this fraction of the sample rate (a margin below the NI 9234's alias-free 0.45·fs).
DEFAULT_LOW_HZ = 10.0
DIAGNOSIS_TOP_FRACTION = 0.4
#: A given band needs at least this many analysis lines.
MIN_BAND_LINES = 8


def _given_band(
    band_hz: tuple[float, float], hammer_top_hz: float, sample_rate_hz: float, n_samples: int
) -> tuple[float, float, QualityNote | None]:
    """The band the user gave (``--band``), checked against the records: above DC, capped at the alias-free top, and
    where the hammer excites; a band the records cannot support is refused in one line."""
    given = f"--band {band_hz[0]:g}:{band_hz[1]:g}"
    resolution_hz = sample_rate_hz / n_samples
    top_hz = DIAGNOSIS_TOP_FRACTION * sample_rate_hz
    low, high = max(band_hz[0], resolution_hz), min(band_hz[1], top_hz)
    if low >= hammer_top_hz:
        raise SettingError(f"{given}: the hammer excites only up to {hammer_top_hz:.0f} Hz in these records (its force "
                           f"spectrum is 20 dB down there); an FRF above it is noise — choose a band below")
    if (high - low) / resolution_hz < MIN_BAND_LINES:
        raise SettingError(f"{given}: fewer than {MIN_BAND_LINES} frequency lines of these records "
                           f"({resolution_hz:.3g} Hz apart) in the band; give a wider band")
    notes = []
    if high < band_hz[1]:
        notes.append(f"its top is capped at {DIAGNOSIS_TOP_FRACTION:g}·fs = {top_hz:.0f} Hz (a margin below the ADC "
                     f"filter's alias-free band)")
    if high > hammer_top_hz:
        notes.append(f"above {hammer_top_hz:.0f} Hz the hammer's force is 20 dB down: the FRF there is noisy and weighs "
                     f"little")
    note = QualityNote("band", f"{given}: " + "; ".join(notes), band_hz=(low, high)) if notes else None
    return low, high, note


#: Spikes: the response above this fraction of the sample rate (above any hammer band), outside the pulse, standing
#: this many robust noise deviations above the hit's own level and above the hits' common (hit-locked) level.
SPIKE_BAND_FRACTION = 0.3
SPIKE_NOISE_FACTOR = 20.0
SPIKE_LOCKED_FACTOR = 10.0
SPIKE_BLOCK = 128


def spiked_hits(records: np.ndarray, extents: list[tuple[int, int, int]], sample_rate_hz: float) -> list[int]:
    """Hits whose response carries an impulsive spike not locked to the impact (electrical interference: a relay, a
    solenoid, a loose connector): a burst above the hammer's band, away from the pulse, that the other hits do not
    have at that time (a structure's own ringing after the pulse is in every hit)."""
    if len(records) < 3:
        return []
    import scipy.signal  # (on first use, as the next two: a command that only reads a diagnosis does not wait for them)
    sos = scipy.signal.butter(4, SPIKE_BAND_FRACTION * sample_rate_hz, "highpass", fs=sample_rate_hz, output="sos")
    high = np.abs(scipy.signal.sosfiltfilt(sos, records[:, 1], axis=-1))
    # the noise level where each sample is (blocks of SPIKE_BLOCK samples: records may come windowed, the noise
    # falling along them), robust to the spike itself
    blocks = -(-high.shape[1] // SPIKE_BLOCK)
    padded = np.pad(high, ((0, 0), (0, blocks * SPIKE_BLOCK - high.shape[1])), mode="edge")
    block_level = np.median(padded.reshape(len(high), blocks, SPIKE_BLOCK), axis=2)
    noise = 1.4826 * np.repeat(block_level, SPIKE_BLOCK, axis=1)[:, : high.shape[1]] + 1e-300
    locked = np.median(high, axis=0, keepdims=True)
    spiky = (high > SPIKE_NOISE_FACTOR * noise) & (high > SPIKE_LOCKED_FACTOR * locked)
    guard = int(0.005 * sample_rate_hz)
    for row, (start, _, end) in zip(spiky, extents):
        row[max(start - guard, 0) : end + guard] = False
    return [int(i) for i in np.flatnonzero(spiky.any(axis=1))]


def _decimal_share(values: np.ndarray, digits: int) -> float:
    """The share of the (positive) values that are multiples of the ``digits``-th significant decimal digit."""
    quotient = values / 10.0 ** (np.floor(np.log10(values)) - digits + 1)
    return float(np.mean(np.abs(quotient - np.round(quotient)) <= 1e-6 * quotient))


def _rounding_variance(step: np.ndarray, window: np.ndarray, force_power: np.ndarray) -> np.ndarray:
    """The per-hit FRF variance (hits, lines) that a response's decimal rounding adds: each sample's error is uniform
    within its own step (variance step²/12, independent between samples: white), weighted by the window."""
    return (np.sum((window * step) ** 2, axis=1) / 12.0)[:, np.newaxis] / force_power


def _rounding_note(rounding: list[np.ndarray | None], force_w: np.ndarray, force_n: np.ndarray) -> QualityNote:
    """What decimal rounding does: on the response, noise the noise model takes in; on the force, whose error falls
    on the few samples of the pulse, each hit's own gain error (its RMS estimated), which no noise model that is
    independent between frequencies holds."""
    channels = [f"the {name} (steps up to {step.max():.3g} {unit})"
                for name, unit, step in zip(("force", "response"), ("N", "m/s²"), rounding) if step is not None]
    message = (f"{' and '.join(channels)} stored with few significant decimal digits (a text export): the rounding "
               f"error grows with each sample's value, up to 5 % of it, near the peaks where the quiet parts show none; "
               f"the flat tops it leaves at the peaks are the rounding's, not an overload's")
    if rounding[1] is not None:
        message += "; the response's rounding is part of the noise model (step²/12 at each sample's own step)"
    if rounding[0] is not None:
        gain = np.sqrt(np.sum((force_w * rounding[0]) ** 2, axis=1) / 12.0) / np.abs(np.sum(force_w * force_n, axis=1))
        message += (f"; the force's falls on the few samples of each pulse, so it changes each hit's gain by about "
                    f"{100 * float(np.sqrt(np.mean(gain**2))):.2g} % (RMS), alike at every frequency: expect the hits "
                    f"to differ by a scale factor that far")
    return QualityNote("quantisation", message + " — a property of the recording, not physics")


def weighted_mean(per_hit: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean over hits (axis 0) and the total weight per frequency: with the noise weights, H1."""
    total = weight.sum(axis=0)
    return (weight * per_hit).sum(axis=0) / total, total


def contiguous_bands(mask: np.ndarray, min_bins: int) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in ``mask`` at least ``min_bins`` long."""
    edges = np.diff(np.concatenate(([0], mask.astype(int), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(a, b - 1) for a, b in zip(starts, stops) if b - a >= min_bins]


def default_window(records: np.ndarray, sample_rate_hz: float) -> WindowSettings:
    """Windows for records that come without any: force window 1 ms past three pulse widths, 1 % exponential."""
    widths = [end - start + 1 for start, _, end in (_pulse_extent(r[0]) for r in records)]
    return WindowSettings(force_window_ms=1.0 + 3e3 * float(np.median(widths)) / sample_rate_hz,
                          force_taper_ms=0.5, exponential_end_fraction=0.01)


def hit_spectra(
    records: np.ndarray,
    sample_rate_hz: float,
    window: WindowSettings | None = None,
    *,
    hit_times_s: np.ndarray | None = None,
    overload: np.ndarray | None = None,
    band_hz: tuple[float, float] | None = None,
    max_points: int = 400,
) -> HitSpectra:
    """Window, transform and weigh the accepted hits; checks for double hits, clipping, mains lines, truncation.

    ``records``: (hits, 2, samples) with row 0 the force in N and row 1 the response in m/s², all hits aligned the
    same way (pre-trigger then pulse). ``window``: the session's windows (None → :func:`default_window`). Hits
    failing a check are left out and named in ``quality``.
    """
    records = np.asarray(records, dtype=float)
    if records.ndim != 3 or records.shape[1] != 2 or records.shape[0] < 2:
        raise SettingError(
            f"diagnosis records: expected (hits ≥ 2, 2 channels, samples), got shape {records.shape}"
        )
    if not np.all(np.isfinite(records)):
        raise SettingError("diagnosis records: the hit records contain NaN or infinite samples")
    hit_count, _, n_samples = records.shape
    quality: list[QualityNote] = []
    extents = [_pulse_extent(record[0]) for record in records]
    pulse_samples = int(np.median([end - start + 1 for start, _, end in extents]))

    steps = [_quantisation_step(records[:, channel]) for channel in (0, 1)]
    rounding = [decimal_rounding_step(records[:, channel]) for channel in (0, 1)]
    coarse_response = coarsely_quantised_response(records, steps[1])
    response_step = steps[1] if coarse_response else 0.0
    response_offset = (steps[1] * float(np.angle(np.mean(np.exp(2j * np.pi * records[:, 1] / steps[1])))) / (2 * np.pi)
                       if coarse_response else 0.0)
    for channel, (name, unit) in enumerate((("force", "N"), ("response", "m/s²"))):
        stuck = stuck_bits(records[:, channel], steps[channel]) if rounding[channel] is None else []
        if stuck:
            bits = ", ".join(f"bit {bit} always {value}" for bit, value in stuck)
            worst = max(2**bit for bit, _ in stuck)
            quality.append(QualityNote(
                "stuck bit",
                f"the {name} records' converter codes (steps of {steps[channel]:.3g} {unit}) have {bits} while the "
                f"codes around them change: a stuck bit of the converter or the exporter, which moves samples by up "
                f"to {worst} steps ({worst * steps[channel]:.3g} {unit}) — a fault of the measurement chain, not "
                f"physics; what it distorts is left unexplained"))
    double_hits, clipped_hits, wrapped_hits = [], [], []
    for index, (record, (start, peak, end)) in enumerate(zip(records, extents)):
        after = record[0, end + 1 + pulse_samples :]
        if after.size and np.max(np.abs(after)) > 0.1 * abs(record[0, peak]):
            double_hits.append(index)
        if _wrapped(record[0]) or _wrapped(record[1]):
            wrapped_hits.append(index)
            continue
        peak_steps = [steps[c] if rounding[c] is None else float(rounding[c][index].max()) for c in (0, 1)]
        if (_clipped(record[0], step=peak_steps[0]) or _clipped(record[1], step=peak_steps[1])
                or (overload is not None and np.any(overload[index]))):
            clipped_hits.append(index)
    if double_hits:
        quality.append(QualityNote("double hit", f"{len(double_hits)} hit(s) with a second impact were left out",
                                   hits=tuple(double_hits)))
    if wrapped_hits:
        quality.append(QualityNote(
            "overload", f"{len(wrapped_hits)} hit(s) wrap around (hits {', '.join(str(i + 1) for i in wrapped_hits)}): "
            f"a sample jumps from near one extreme of the record to near the other, as integer counts do that "
            f"overflowed their type on export; they were left out — a property of the recording, not physics",
            hits=tuple(wrapped_hits)))
    silent = [index for index in _hits_without_response(records, extents, sample_rate_hz)
              if index not in double_hits + clipped_hits + wrapped_hits]
    if silent and hit_count - len(silent) >= 2:
        quality.append(QualityNote(
            "no response", f"{len(silent)} record(s) hold a force pulse but almost no response (hits "
            f"{', '.join(str(i + 1) for i in silent)}: under {100 * SILENT_RESPONSE_SHARE:.0f} % of the response per "
            f"unit impulse the other hits have): the hammer struck something else (the bench, a cable) or the "
            f"response channel was off; they were left out — a property of the recording, not physics",
            hits=tuple(silent)))
    else:
        silent = []
    if clipped_hits:
        quality.append(QualityNote("overload", f"{len(clipped_hits)} clipped hit(s) were left out (hits "
                                   f"{', '.join(str(i + 1) for i in clipped_hits)}): a record sits at its extreme for "
                                   f"several samples", hits=tuple(clipped_hits)))
    clipped_hits = sorted(clipped_hits + wrapped_hits)
    unclipped = [index for index in range(hit_count) if index not in clipped_hits]
    ceiling_hits, ceiling = response_ceiling_hits(records[unclipped], [extents[i] for i in unclipped])
    if ceiling_hits:
        ceiling_hits = [unclipped[i] for i in ceiling_hits]
        clipped_hits = sorted(clipped_hits + ceiling_hits)
        quality.append(QualityNote(
            "overload",
            f"{len(ceiling_hits)} hit(s) reach the same peak response ({ceiling:.3g} m/s²) whatever their force: the "
            f"response was clipped before the ADC's filter (a sensor or conditioner overload); they were left out — "
            f"a property of the recording, not physics",
            hits=tuple(ceiling_hits)))
    clean = [index for index in range(hit_count) if index not in double_hits + clipped_hits + silent]
    spiked = [] if coarse_response else [clean[i] for i in spiked_hits(records[clean], [extents[i] for i in clean],
                                                                        sample_rate_hz)]
    if spiked and len(clean) - len(spiked) >= MIN_SCATTER_HITS:
        quality.append(QualityNote(
            "spikes", f"{len(spiked)} hit(s) carry impulsive spikes in the response away from the impact, not in the "
            f"other hits at that time (electrical interference: a relay, a valve, a loose connector, or a record "
            f"spliced after lost samples); they were left out — a property of the recording, not physics",
            hits=tuple(spiked)))
    else:
        spiked = []
    keep = np.ones(hit_count, bool)
    keep[double_hits + clipped_hits + silent + spiked] = False
    used = np.flatnonzero(keep)
    if used.size < 2:
        removed = [f"{len(hits)} {why}" for hits, why in ((double_hits, "with a second impact"),
                                                          (clipped_hits, "clipped or overloaded"),
                                                          (silent, "without a response"),
                                                          (spiked, "with spikes away from the impact")) if hits]
        hint = ("; every force record swings on after its impact: are the force and response channels swapped, or "
                "the records windowed?" if len(double_hits) == hit_count else "")
        raise SettingError(f"diagnosis records: only {used.size} usable hit(s) of {hit_count} after quality checks "
                           f"({', '.join(removed)}); at least 2 needed{hint}")
    if used.size < MIN_SCATTER_HITS:
        quality.append(QualityNote(
            "few hits", f"only {used.size} usable hits: too few to check the noise model against the scatter between "
            f"hits, so any verdict is provisional; record at least {MIN_SCATTER_HITS}", hits=tuple(int(i) for i in used)))
    records = records[used]
    rounding = [None if step is None else step[used] for step in rounding]
    extents = [extents[i] for i in used]
    trigger = np.array([start for start, _, _ in extents])
    margin = int(QUIET_MARGIN_S * sample_rate_hz)
    short = np.flatnonzero(trigger - margin < MIN_QUIET_SAMPLES)
    from_scatter = short.size > used.size - 2 and used.size >= MIN_SCATTER_HITS
    if short.size and not from_scatter:
        quality.append(QualityNote(
            "pre-trigger", f"{short.size} hit(s) with fewer than {MIN_QUIET_SAMPLES} quiet samples before the impact "
            f"were left out: their noise cannot be measured", hits=tuple(int(used[i]) for i in short)))
        keep_quiet = np.setdiff1d(np.arange(used.size), short)
        if keep_quiet.size < 2:
            raise SettingError(
                f"diagnosis records: only {keep_quiet.size} hit(s) have a quiet pre-trigger and {used.size} hit(s) are "
                f"too few to measure the noise from their scatter (at least {MIN_SCATTER_HITS}); record at least "
                f"{MIN_QUIET_SAMPLES / sample_rate_hz * 1e3 + QUIET_MARGIN_S * 1e3:.1f} ms before the hit, or more hits")
        used, records, trigger = used[keep_quiet], records[keep_quiet], trigger[keep_quiet]
        rounding = [None if step is None else step[keep_quiet] for step in rounding]
        extents = [extents[i] for i in keep_quiet]
    late, fronts = _missing_pulse_fronts(records[:, 0], extents)
    if late:
        mirrored = [fronts[i].size for i in late if fronts[i].size]
        started = (f"{1e3 * np.median(mirrored) / sample_rate_hz:.2g} ms (median of {len(mirrored)})" if mirrored
                   else "less than a sample")
        quality.append(QualityNote(
            "late trigger",
            f"{len(late)} record(s) start inside their force pulse, {started} after it began (a late trigger, the "
            f"pre-trigger misses the pulse start): the replay plays each pulse with its missing front mirrored from "
            f"its fall about the peak, and fits each such front's impulse and timing in every comparison (two nuisance "
            f"parameters per record, their degrees of freedom taken from the χ² count) — a property of the recording, "
            f"not physics",
            hits=tuple(int(used[i]) for i in late)))

    mains_base: float | None = None
    mains_harmonics: list[float] = []
    force_zero_from: int | None = None
    force_tail: ForceTail | None = None
    coarse_force = steps[0] > 0 and np.abs(records[:, 0]).max() / steps[0] < COARSE_LEVELS
    if coarse_force:
        # the AC coupling's decay after the pulse is below one step: the replay continues it from the impulse
        records, force_tail = _continue_force_from_impulse(records, extents, sample_rate_hz)
    prewindow_error_1_s = 0.0
    tail_start = int((1 - TAIL_FRACTION) * n_samples)
    tails_only = from_scatter and _steady_tails(records, tail_start)
    if tails_only:
        from_scatter = False
        quality.append(QualityNote(
            "pre-trigger", f"{short.size} hit(s) with fewer than {MIN_QUIET_SAMPLES} quiet samples before the impact: "
            f"the responses have decayed to a steady noise by the end of the records, so the noise is measured on "
            f"the record tails", hits=tuple(int(used[i]) for i in short)))
    if from_scatter:
        quiet_slice = None
        noise_source = "hit scatter"
        records, mains_base, mains_harmonics = _remove_mains_seen_on_force(records, extents, sample_rate_hz)
        if mains_base is not None:
            quality.append(_mains_note(mains_base, mains_harmonics, "found on the quiet force records after the "
                                                                      "impacts"))
    else:
        quiet_samples = int(np.min(trigger)) - margin
        # quiet samples to measure the noise: the record tails when every response has decayed, else the pre-trigger
        # the tails about their slow trend: a slow motion of the mover (a scan, a drift, a settling offset) over the
        # long tail is not a response still ringing
        tail_rms = _rms_about_trend(records[:, 1, tail_start:])
        pretrigger_rms = np.sqrt(np.mean(records[:, 1, : max(quiet_samples, 1)] ** 2, axis=1)) + 1e-30
        truncated = np.flatnonzero(tail_rms > 3 * pretrigger_rms) if not tails_only else np.zeros(0, int)
        if tails_only:
            records, mains_base, mains_harmonics = _remove_mains(records, tail_start, sample_rate_hz,
                                                                 MAINS_HARMONICS * max(MAINS_BASES_HZ))
            if mains_base is not None:
                quality.append(_mains_note(mains_base, mains_harmonics, "found on the quiet record tails"))
            quiet_slice = slice(tail_start, n_samples)
        elif truncated.size:
            quality.append(
                QualityNote(
                    "truncation",
                    f"the response has not decayed by the end of the record in {truncated.size} hit(s): leakage is "
                    f"controlled only by the exponential window (the replay goes through the same window); the noise is "
                    f"measured before the hits",
                    hits=tuple(int(used[i]) for i in truncated),
                )
            )
            quiet_slice = slice(0, quiet_samples)
        else:
            records, mains_base, mains_harmonics = _remove_mains(records, tail_start, sample_rate_hz,
                                                                 MAINS_HARMONICS * max(MAINS_BASES_HZ), quiet_samples)
            if mains_base is not None:
                quality.append(_mains_note(mains_base, mains_harmonics, "found on the quiet record tails"))
            quiet_slice = slice(tail_start, n_samples)
            force_zero_from = None if coarse_force else _force_windowed_from(records[:, 0], extents)
            prewindow = _exponential_prewindow_1_s(records, quiet_samples, tail_start, sample_rate_hz,
                                                   (0, 1) if force_zero_from is None else (1,))
            if prewindow is not None:
                prewindow_1_s, prewindow_error_1_s = prewindow
                records = records * np.exp(prewindow_1_s * np.arange(n_samples) / sample_rate_hz)
                quality.append(QualityNote(
                    "exponential window",
                    f"the records carry an exponential window already (the noise falls as exp(−σt), σ = "
                    f"{prewindow_1_s:.3g} ± {prewindow_error_1_s:.2g} 1/s, as in records exported windowed): divided "
                    f"out of both channels before the comparison, and its uncertainty (which shifts every decay rate "
                    f"alike) is part of the noise model — a processing property, not physics"))
            if force_zero_from is not None:
                cut_share = _window_cut_share(records[:, 0], extents)
                records, force_tail = _continue_windowed_force(records, extents, sample_rate_hz)
                cut = ("" if cut_share is None else
                       f"; but the window closes inside the pulse (the force falls from {100 * cut_share:.0f} % of its "
                       f"peak to zero within {WINDOW_CUT_SAMPLES} samples): part of every impulse is missing, so the "
                       f"FRF is too large by that share and a recalibrated film is not the rig's")
                quality.append(QualityNote(
                    "force window",
                    f"the force records are zero from {1e3 * force_zero_from / sample_rate_hz:.1f} ms on (records "
                    f"exported with a force window already): the replay continues each force after its window as the "
                    f"AC coupling's decay ({AC_COUPLING_HZ:g} Hz, from the level just after the pulse, median "
                    f"{np.median(force_tail.level_n):.3g} N) and that decay's uncertainty is part of the noise model; "
                    f"the force noise is measured before the hits — a processing property, not physics" + cut))
            tail_noise = np.median(np.std(records[:, 1, tail_start:], axis=1))
            before_noise = np.median(np.std(records[:, 1, :quiet_samples], axis=1))
            if tail_noise < 0.8 * before_noise:
                lower = (f"the noise at the end of the records is {before_noise / tail_noise:.1f}× lower than before "
                         f"the hits: the records look windowed already (or the noise is not steady)" if tail_noise > 0 else
                         "the response records end in exact zeros: zero-padded by the program that exported them (or "
                         "windowed to zero)")
                quality.append(QualityNote(
                    "noise", f"{lower}; the noise is measured before the hits, which makes the comparison conservative"))
                quiet_slice = slice(0, quiet_samples)
        noise_source = "record tails" if quiet_slice.start == tail_start else "pre-trigger"
    window = window or default_window(records, sample_rate_hz)
    if window.force_window_ms is None or window.exponential_end_fraction is None:
        fallback = default_window(records, sample_rate_hz)
        window = WindowSettings(
            force_window_ms=window.force_window_ms or fallback.force_window_ms,
            force_taper_ms=window.force_taper_ms,
            exponential_end_fraction=window.exponential_end_fraction or fallback.exponential_end_fraction,
        )
    decay_rate_1_s = window.decay_rate_1_s(n_samples, sample_rate_hz)
    exponential = np.broadcast_to(exponential_window(n_samples, window.exponential_end_fraction),
                                  (len(used), n_samples))
    force_w = force_window(records[:, 0], sample_rate_hz, window) * exponential
    force_spectra = np.fft.rfft(records[:, 0] * force_w, axis=1)
    response_spectra = np.fft.rfft(records[:, 1] * exponential, axis=1)
    full_freq_hz = np.fft.rfftfreq(n_samples, 1.0 / sample_rate_hz)

    floor = 1e-30
    force_power = np.abs(force_spectra) ** 2 + floor
    h_full = response_spectra / (force_spectra + floor)
    cross = (response_spectra * np.conj(force_spectra)).sum(axis=0)
    h1_full = cross / force_power.sum(axis=0)
    correlation_step = int(np.ceil(decay_rate_1_s * n_samples / sample_rate_hz))
    if quiet_slice is None:
        output_noise, dof = _scatter_noise(h_full, h1_full, force_power, max(SCATTER_SMOOTH_LINES, 8 * correlation_step))
        noise = NoiseSource(
            "hit scatter", dof,
            f"measured from the scatter of the {len(used)} hits' FRFs about their mean ({2 * (len(used) - 1)} degrees "
            f"of freedom per line, about {dof:.0f} over the smoothing band): the pre-trigger is too short to measure "
            f"it; hit-to-hit changes count as noise, which makes the comparison conservative")
        # the replay plays each whole force record, its noise after the pulse too, which the recorded FRFs (force
        # window) do not carry: that noise, measured on the quiet force after the impacts, is the replay's own
        quiet_force = records[:, 0, _quiet_force_from(extents, n_samples, sample_rate_hz):]
        replayed_force_noise = _through_window(_noise_spectrum(quiet_force, full_freq_hz, sample_rate_hz, steps[0]),
                                               exponential[0])
        variance_full = (output_noise[np.newaxis, :] + np.abs(h1_full[np.newaxis, :]) ** 2 * replayed_force_noise
                         ) / force_power
    else:
        quiet = records[:, :, quiet_slice]
        # a force exported with a force window is zero in the tails: its noise is measured before the hits
        quiet_force = records[:, 0, :quiet_samples] if force_zero_from is not None else quiet[:, 0]
        noise_force = _noise_spectrum(quiet_force, full_freq_hz, sample_rate_hz, steps[0])
        noise_response = _noise_spectrum(quiet[:, 1], full_freq_hz, sample_rate_hz, steps[1])
        coarse = [name for name, step, segment in zip(("force", "response"), steps, (quiet_force, quiet[:, 1]))
                  if step > 0.5 * np.median(np.std(segment, axis=1))]
        if coarse:
            quality.append(QualityNote(
                "quantisation",
                f"the {' and '.join(coarse)} records are coarsely quantised (steps of "
                + ", ".join(f"{steps[i]:.3g} {('N', 'm/s²')[i]}" for i in (0, 1) if ("force", "response")[i] in coarse)
                + "): the quantisation noise (step²/12 per sample) is part of the noise model"
                + ("; the force's AC-coupling decay after each pulse, below one step, is continued from the pulse's "
                   "impulse for the replay" if coarse_force else "")
                + ("; the replayed response is quantised with the same step, so the quantiser's distortion (the same "
                   "in every hit) is not mistaken for physics" if coarse_response else "")
                + " — a property of the recording, not physics"))
        dof = float(2 * len(used) * max(quiet.shape[-1] // 2, 1))
        where = ("the quiet record tails (last 25 %)" if noise_source == "record tails"
                 else f"the quiet pre-trigger ({quiet.shape[-1]} samples per hit)")
        noise = NoiseSource(noise_source, dof, f"measured on {where} of {len(used)} hits, both channels")
        # the replayed response carries the recorded force's noise through the whole record: same window as the
        # response
        vibration = _narrowband_lines_hz(quiet[:, 1], sample_rate_hz, mains_harmonics)
        if vibration:
            quality.append(QualityNote(
                "floor vibration",
                f"narrowband vibration or interference near {', '.join(f'{f:.0f}' for f in vibration)} Hz in the "
                f"quiet records, uncorrelated with the hammer (floor vibration, a machine running on or near the rig, "
                f"or electrical pick-up): its leakage through the windows is part of the noise model — not physics",
                band_hz=(min(vibration), max(vibration))))
        # the replayed response carries the recorded force's noise through the whole record: same window as the
        # response; a line in the noise leaks through that window beyond its own frequency
        window_row = exponential[0]
        variance_full = (
            (_through_window(noise_response, window_row)[np.newaxis, :]
             + np.abs(h1_full[np.newaxis, :]) ** 2 * _through_window(noise_force, window_row)[np.newaxis, :])
            / force_power
        )
    if rounding[1] is not None:
        variance_full = variance_full + _rounding_variance(rounding[1], exponential, force_power)
    if rounding[0] is not None or rounding[1] is not None:
        quality.append(_rounding_note(rounding, force_w, records[:, 0]))
    if force_tail is not None:
        variance_full = variance_full + force_tail.variance(h_full, force_spectra, exponential[0], sample_rate_hz)
    if prewindow_error_1_s > 0:
        variance_full = variance_full + _prewindow_variance(
            records, force_w, exponential[0], response_spectra, force_spectra, sample_rate_hz, prewindow_error_1_s)
    variance_full = np.maximum(variance_full, (1e-7 * np.abs(h1_full)) ** 2 + 1e-30)

    # analysis band: where the hammer puts energy in (within 20 dB of its low-frequency level), below 0.4 fs
    mean_force_power = force_power.mean(axis=0)
    if late:  # the band the hammer excites is the whole pulse's, not the recorded part's (wider: it is shorter)
        mean_force_power = np.mean(np.abs(np.fft.rfft(_with_fronts(records[:, 0] * force_w, fronts, n_samples),
                                                      axis=1)) ** 2, axis=0)
    low, high = DEFAULT_LOW_HZ, DIAGNOSIS_TOP_FRACTION * sample_rate_hz
    reference = np.median(mean_force_power[(full_freq_hz >= low) & (full_freq_hz <= low + 50)])
    beyond = np.flatnonzero((full_freq_hz > low) & (mean_force_power < 0.01 * reference))
    hammer_top_hz = min(high, float(full_freq_hz[beyond[0]])) if beyond.size else high
    if band_hz is None:
        high = hammer_top_hz
    else:
        low, high, note = _given_band(band_hz, hammer_top_hz, sample_rate_hz, n_samples)
        if note:
            quality.append(note)
    in_band = (full_freq_hz >= low) & (full_freq_hz <= high)

    coherence = np.abs(cross) ** 2 / (force_power.sum(axis=0) * (np.abs(response_spectra) ** 2).sum(axis=0) + floor)
    mask = in_band.copy()
    for harmonic in mains_harmonics:
        centre = int(round(harmonic * n_samples / sample_rate_hz))
        mask[max(0, centre - 2) : centre + 3] = False
    low_coherence = mask & (coherence < 0.9)
    for a, b in contiguous_bands(low_coherence, 3):
        quality.append(
            QualityNote(
                "low coherence",
                f"coherence below 0.9 {in_band_words(full_freq_hz[a], full_freq_hz[b])} "
                f"(minimum {coherence[a:b + 1].min():.2f}): the measurement is noisy there, weighted accordingly",
                band_hz=(float(full_freq_hz[a]), float(full_freq_hz[b])),
            )
        )
    selected = np.flatnonzero(mask)
    step = max(1, correlation_step, int(np.ceil(selected.size / max_points)))
    grid = selected[::step]
    if grid.size < MIN_BAND_LINES:  # fewer compared lines than a spec has parameters to fit: refuse, in one line
        spacing_hz = step * sample_rate_hz / n_samples
        where = f"--band {band_hz[0]:g}:{band_hz[1]:g}" if band_hz is not None else "the hammer's band"
        raise SettingError(f"{where}: only {grid.size} analysis line(s) in {low:.0f}–{high:.0f} Hz (lines "
                           f"{spacing_hz:.3g} Hz apart, every {step}th of the records' so that the exponential "
                           f"window's neighbours are independent); the diagnosis needs at least {MIN_BAND_LINES}: give "
                           f"a band at least {MIN_BAND_LINES * spacing_hz:.0f} Hz wide" + (", or longer records"
                                                                                           if band_hz is None else ""))
    impulses = np.array([hit_impulse_ns(record[0], extent, sample_rate_hz) for record, extent in zip(records, extents)])
    times = np.arange(hit_count, dtype=float)[used] if hit_times_s is None else np.asarray(hit_times_s, float)[used]
    n_fft = int(scipy.fft.next_fast_len(2 * n_samples, real=True))
    replay = Replay(
        force_padded=np.fft.rfft(_with_fronts(records[:, 0], fronts, n_fft), axis=1),
        n_fft=n_fft,
        exponential=np.ascontiguousarray(exponential),
        force_windowed_grid=force_spectra[:, grid],
        grid=grid,
        measured_h=h_full[:, grid],
        measured_variance=variance_full[:, grid],
        n_samples=int(n_samples),
        sample_rate_hz=float(sample_rate_hz),
        decay_rate_1_s=float(decay_rate_1_s),
        response_step=response_step,
        response_offset=response_offset,
        additive=bool(late),
        front_padded=(np.fft.rfft(_with_fronts(np.zeros_like(records[:, 0]), _unit_fronts(fronts, late, sample_rate_hz),
                                               n_fft), axis=1) if late else None),
        front_impulse_ns=np.array([np.sum(front) / sample_rate_hz for front in fronts]) if late else None,
    )
    return HitSpectra(
        freq_hz=full_freq_hz[grid],
        decay_rate_1_s=float(decay_rate_1_s),
        h=h_full[:, grid],
        variance=variance_full[:, grid],
        conditions=HitConditions(time_s=times, impulse_ns=np.abs(impulses), blow=used.astype(float)),
        hit_numbers=used,
        sample_rate_hz=float(sample_rate_hz),
        n_samples=int(n_samples),
        quality=quality,
        replay=replay,
        noise=noise,
    )


def _scatter_noise(
    h: np.ndarray, h1: np.ndarray, force_power: np.ndarray, width_lines: int
) -> tuple[np.ndarray, float]:
    """Output noise power S(f) with ``Var(H_i) = S/|F_i|²``, from the scatter of the per-hit FRFs ``h`` (hits, lines)
    about their weighted mean ``h1``, and its degrees of freedom.

    ``Σ_i |F_i|² |H_i − H1|²`` has expectation ``(n − 1)·S`` (2(n − 1) real degrees of freedom per line). A line's
    estimate is a local least-squares fit ``S ≈ a + b·|H1|²`` over ``width_lines`` lines (response noise, and force
    noise carried by the FRF), so a resonance does not smear its noise onto its neighbours."""
    hits = h.shape[0]
    raw = (force_power * np.abs(h - h1[np.newaxis, :]) ** 2).sum(axis=0) / (hits - 1)
    level = np.abs(h1) ** 2
    kernel = np.ones(width_lines)

    def local(values: np.ndarray) -> np.ndarray:
        return np.convolve(values, kernel, mode="same")

    n, sx, sxx, sy, sxy = local(np.ones_like(raw)), local(level), local(level**2), local(raw), local(level * raw)
    determinant = n * sxx - sx**2
    safe = np.where(np.abs(determinant) > 1e-12 * np.maximum(n * sxx, 1e-300), determinant, np.inf)
    a = (sxx * sy - sx * sxy) / safe
    b = (n * sxy - sx * sy) / safe
    mean_only = sy / n
    through_level = sxy / np.maximum(sxx, 1e-300)
    noise = np.where((a >= 0) & (b >= 0), a + b * level, np.where(b < 0, mean_only, through_level * level))
    noise = np.where(np.isfinite(determinant) & (np.abs(safe) < np.inf), noise, mean_only)
    dof = 2.0 * (hits - 1) * width_lines / max(1.0, width_lines / 8.0)
    return np.maximum(noise, 1e-3 * mean_only + 1e-300), dof


def _mains_note(base_hz: float, harmonics_hz: list[float], where: str) -> QualityNote:
    return QualityNote(
        "interference",
        f"mains interference at {base_hz:.0f} Hz"
        + (f" and harmonics ({', '.join(f'{h:.0f}' for h in harmonics_hz[1:])} Hz)" if len(harmonics_hz) > 1 else "")
        + f" ({where}): removed from every record, and the lines left out of the comparison",
        band_hz=(min(harmonics_hz), max(harmonics_hz)),
    )


def _quiet_force_from(extents: list[tuple[int, int, int]], n_samples: int, sample_rate_hz: float) -> int:
    """The first sample from which every force record is quiet after its impact (10 ms after the latest pulse's end,
    at most half the record)."""
    last_end = max(end for _, _, end in extents)
    return min(n_samples // 2, last_end + int(0.01 * sample_rate_hz))


def _remove_mains_seen_on_force(
    records: np.ndarray, extents: list[tuple[int, int, int]], sample_rate_hz: float
) -> tuple[np.ndarray, float | None, list[float]]:
    """Mains lines when the responses ring to the end of the records: found on the force records after the impacts
    (quiet there), then fitted and removed on both channels at those lines only."""
    start = _quiet_force_from(extents, records.shape[-1], sample_rate_hz)
    _, base, found = _remove_mains(records[:, :1], start, sample_rate_hz, MAINS_HARMONICS * max(MAINS_BASES_HZ))
    if base is None:
        return records, None, []
    return _subtract_lines(records, start, sample_rate_hz, np.array(found)), base, found


def _exponential_prewindow_1_s(
    records: np.ndarray, quiet_samples: int, tail_start: int, sample_rate_hz: float, channels: tuple[int, ...] = (0, 1)
) -> tuple[float, float] | None:
    """Decay rate σ (1/s) of an exponential window the records already carry and its standard error, from the noise
    level of the quiet pre-trigger and three parts of the quiet tail (the given channels, pooled over hits), or None
    when the noise is steady or does not fall as one exponential."""
    n_samples = records.shape[-1]
    edges = np.linspace(tail_start, n_samples, 4).astype(int)
    segments = [(0, quiet_samples)] + list(zip(edges[:-1], edges[1:]))
    centres_s = np.array([(a + b) / 2 / sample_rate_hz for a, b in segments])
    # first differences: a slow drift (the AC coupling's decay after a hit) is not noise; white noise doubles
    levels = np.array([[np.sqrt(np.mean(np.var(np.diff(records[:, channel, a:b], axis=1), axis=1))) for a, b in segments]
                       for channel in channels])
    if np.any(levels <= 0):
        return None
    # a noise level from N samples is uncertain by 1/√(2N) in its logarithm (white noise)
    log_sigma = 1.0 / np.sqrt(2.0 * records.shape[0] * np.array([b - a for a, b in segments]))
    slopes, errors = [], []
    for row in np.log(levels):
        (slope, intercept), covariance = np.polyfit(centres_s, row, 1, w=1.0 / log_sigma, cov="unscaled")
        misfit = row - (slope * centres_s + intercept)
        if np.max(np.abs(misfit)) > PREWINDOW_FIT:
            return None
        reduced_chi2 = float(np.sum((misfit / log_sigma) ** 2)) / max(len(segments) - 2, 1)
        slopes.append(-slope)
        errors.append(np.sqrt(covariance[0, 0] * max(1.0, reduced_chi2)))
    decay_1_s = float(np.mean(slopes))
    if decay_1_s * n_samples / sample_rate_hz < PREWINDOW_MIN_DECAY or np.ptp(slopes) > 0.2 * decay_1_s:
        return None
    return decay_1_s, float(np.sqrt(np.mean(np.square(errors)) / len(errors)))


def _prewindow_variance(
    records: np.ndarray,
    force_w: np.ndarray,
    exponential: np.ndarray,
    response_spectra: np.ndarray,
    force_spectra: np.ndarray,
    sample_rate_hz: float,
    error_1_s: float,
) -> np.ndarray:
    """Variance (hits, lines) each hit's FRF gets from an exported exponential window divided out with a decay rate
    uncertain by ``error_1_s``: to first order a rate error Δ multiplies both records by ``1 − Δt``, so
    ``δH = Δ·(T[t·x] − H·T[t·f])/F``. The error is the same in every hit, so it does not average out: each hit carries
    it ``hits`` times over, and their mean carries it once."""
    time_s = np.arange(records.shape[-1]) / sample_rate_hz
    d_response = np.fft.rfft(records[:, 1] * exponential * time_s, axis=1)
    d_force = np.fft.rfft(records[:, 0] * force_w * time_s, axis=1)
    h = response_spectra / (force_spectra + 1e-30)
    sensitivity = (d_response - h * d_force) / (force_spectra + 1e-30)
    return records.shape[0] * error_1_s**2 * np.abs(sensitivity) ** 2


@dataclass
class ForceTail:
    """The AC-coupling decay a force window cut off each force record: ``level_n`` (hits,) at ``start`` (hits,)."""

    level_n: np.ndarray
    level_error_n: np.ndarray
    start: np.ndarray

    def variance(self, h: np.ndarray, force_spectra: np.ndarray, exponential: np.ndarray,
                 sample_rate_hz: float) -> np.ndarray:
        """Variance (hits, lines) of each hit's replayed FRF from the continued tail's uncertainty: its level (per
        hit) and its corner (±:data:`AC_COUPLING_UNCERTAINTY`, alike in every hit, so carried ``hits`` times)."""
        hits, n_samples = h.shape[0], exponential.size
        time_s = np.arange(n_samples) / sample_rate_hz
        omega_c = 2 * np.pi * AC_COUPLING_HZ
        variance = np.zeros(h.shape)
        for hit in range(hits):
            after_s = np.clip(time_s - self.start[hit] / sample_rate_hz, 0.0, None)
            shape = np.where(time_s >= self.start[hit] / sample_rate_hz, np.exp(-omega_c * after_s), 0.0)
            d_level = np.fft.rfft(shape * exponential)
            d_corner = np.fft.rfft(-after_s * shape * exponential) * self.level_n[hit]
            variance[hit] = (np.abs(h[hit] / (force_spectra[hit] + 1e-30)) ** 2
                             * (self.level_error_n[hit] ** 2 * np.abs(d_level) ** 2
                                + hits * (AC_COUPLING_UNCERTAINTY * omega_c) ** 2 * np.abs(d_corner) ** 2))
        return variance


def _continue_windowed_force(
    records: np.ndarray, extents: list[tuple[int, int, int]], sample_rate_hz: float
) -> tuple[np.ndarray, ForceTail]:
    """Force records exported with a force window, continued after the pulse as the AC coupling's decay: from the
    level averaged over the first half of the samples between the pulse's end (plus the anti-aliasing filter's
    ringing) and the window's zeros, ``level·exp(−ω_c (t − t_0))`` replaces the record from that half's middle on."""
    records = records.copy()
    settle = int(round(FILTER_SETTLE_S * sample_rate_hz))
    levels, errors, starts = [], [], []
    for record, (_, _, end) in zip(records, extents):
        nonzero = np.flatnonzero(record[0])
        first = min(end + settle, int(nonzero[-1]))
        stop = max(first + 2, first + (int(nonzero[-1]) + 1 - first) // 2)
        segment = record[0, first:stop]
        start = (first + stop) // 2
        level = float(segment.mean())
        levels.append(level)
        errors.append(float(segment.std() / np.sqrt(max(segment.size - 1, 1))) + 1e-12)
        starts.append(start)
        after_s = (np.arange(record.shape[-1] - start)) / sample_rate_hz
        record[0, start:] = level * np.exp(-2 * np.pi * AC_COUPLING_HZ * after_s)
    return records, ForceTail(np.array(levels), np.array(errors), np.array(starts))


def _continue_force_from_impulse(
    records: np.ndarray, extents: list[tuple[int, int, int]], sample_rate_hz: float
) -> tuple[np.ndarray, ForceTail]:
    """Coarsely quantised force records, continued after the pulse as the AC coupling's decay predicted from the
    pulse's impulse J (a first-order high-pass leaves ``−ω_c·J·exp(−ω_c t)`` after a short pulse), in place of the
    zeros and single steps the quantiser made of it; the level is uncertain as the corner is."""
    records = records.copy()
    omega_c = 2 * np.pi * AC_COUPLING_HZ
    levels, starts = [], []
    for record, (start, _, end) in zip(records, extents):
        impulse_ns = float(record[0, start : end + 1].sum()) / sample_rate_hz
        levels.append(-omega_c * impulse_ns)
        starts.append(end + 1)
        after_s = np.arange(record.shape[-1] - end - 1) / sample_rate_hz
        record[0, end + 1 :] = levels[-1] * np.exp(-omega_c * after_s)
    levels_n = np.array(levels)
    return records, ForceTail(levels_n, AC_COUPLING_UNCERTAINTY * np.abs(levels_n), np.array(starts))


def _steady_tails(records: np.ndarray, tail_start: int) -> bool:
    """Whether every response has decayed to steady noise in the record tails: the response level (RMS about the
    mean, median over hits) of the tail's three thirds agrees within :data:`STEADY_TAIL_SPREAD`, with no line
    standing out (a ringing mode decays across the tail, or stands 30× above the local level)."""
    edges = np.linspace(tail_start, records.shape[-1], 4).astype(int)
    levels = np.array([np.median(np.std(records[:, 1, a:b], axis=1)) for a, b in zip(edges[:-1], edges[1:])])
    if np.any(levels <= 0) or np.ptp(levels) > STEADY_TAIL_SPREAD * levels.mean():
        return False
    tail = records[:, 1, tail_start:]
    periodogram = np.mean(np.abs(np.fft.rfft((tail - tail.mean(axis=1, keepdims=True)) * np.hanning(tail.shape[1]),
                                             axis=1)) ** 2, axis=0)[1:]
    return bool(periodogram.size > 64 and periodogram.max() < 30.0 * np.median(periodogram))


def _missing_pulse_fronts(
    force_n: np.ndarray, extents: list[tuple[int, int, int]]
) -> tuple[list[int], list[np.ndarray]]:
    """The records that start inside their force pulse (a late trigger: above 2 % of the peak at the first sample, the
    peak recorded) and, for each record, the samples before its start mirrored from the pulse's fall about the peak
    (time order, the peak located between samples by a parabola, the fall interpolated by a cubic spline): empty for
    a record whose pulse start is recorded, and for a late one whose mirror reaches no sample before it (less than a
    sample missing). What the mirror misses is fitted in every comparison (:class:`MissingFronts`)."""
    late, fronts = [], []
    for index, (row, (start, peak, end)) in enumerate(zip(force_n, extents)):
        fronts.append(np.zeros(0))
        if start > 0 or peak >= row.size - 1 or abs(row[0]) <= 0.02 * abs(row[peak]):
            continue
        late.append(index)
        centre = float(peak)  # a record that starts at its peak is mirrored about its first sample
        if peak > 0:
            before, at, after = row[peak - 1 : peak + 2]
            curvature = before - 2 * at + after
            centre += 0.5 * (before - after) / curvature if curvature != 0 else 0.0
        last = min(end + 1, row.size - 1)  # the foot below 2 % belongs to the pulse too
        import scipy.interpolate
        fall = scipy.interpolate.CubicSpline(np.arange(peak, last + 1), row[peak : last + 1])
        missing = int(np.floor(last - 2 * centre))
        if missing > 0:
            fronts[-1] = fall(np.clip(2 * centre - np.arange(-missing, 0), peak, last))
    return late, fronts


def _unit_fronts(fronts: list[np.ndarray], late: list[int], sample_rate_hz: float) -> list[np.ndarray]:
    """Each late record's missing front scaled to one N·s of impulse (where its impulse lies in time); a single
    sample just before the record when the mirror reaches none; empty for the other records."""
    unit = [np.zeros(0) for _ in fronts]
    for index in late:
        front = fronts[index]
        total_ns = float(np.sum(front)) / sample_rate_hz
        unit[index] = front / total_ns if front.size and total_ns > 0 else np.array([sample_rate_hz])
    return unit


def _with_fronts(force_n: np.ndarray, fronts: list[np.ndarray], length: int) -> np.ndarray:
    """Force records zero-padded to ``length`` samples with each hit's reconstructed front at the end of its buffer:
    at negative times for a circular convolution of ``length`` ≥ twice the record."""
    padded = np.zeros((force_n.shape[0], length))
    padded[:, : force_n.shape[1]] = force_n
    for row, front in zip(padded, fronts):
        if front.size:
            row[length - front.size :] = front
    return padded


def _force_windowed_from(force_n: np.ndarray, extents: list[tuple[int, int, int]]) -> int | None:
    """First sample from which every hit's force record is exactly zero to its end, after the pulse (records exported
    with a force window already), or None when the force is recorded to the end of any record."""
    first = []
    for row, (_, _, end) in zip(force_n, extents):
        last = _last_nonzero(row) + 1
        if last <= end or last > row.size - MIN_QUIET_SAMPLES:
            return None
        first.append(last)
    return max(first)


def _last_nonzero(row: np.ndarray) -> int:
    """Index of a record's last sample that is not exactly zero (to 1e-12 of its largest), −1 for an all-zero one."""
    nonzero = np.flatnonzero(np.abs(row) > 1e-12 * np.abs(row).max())
    return int(nonzero[-1]) if nonzero.size else -1


#: A force window "closes inside the pulse" when a record falls from at least WINDOW_CUT_LEVEL of its peak to exact
#: zero within WINDOW_CUT_SAMPLES samples, in at least half the hits (a window that closes after the pulse meets a
#: force near zero; the anti-aliasing filter alone never drops a pulse that fast).
WINDOW_CUT_LEVEL = 0.5
WINDOW_CUT_SAMPLES = 3


def _window_cut_share(force_n: np.ndarray, extents: list[tuple[int, int, int]]) -> float | None:
    """The median level (a fraction of the peak) from which windowed force records drop to zero, when the window
    closes inside the pulse (see WINDOW_CUT_LEVEL); None otherwise."""
    levels = []
    for row, (_, peak, _) in zip(force_n, extents):
        last = max(_last_nonzero(row), 0)
        levels.append(float(np.max(np.abs(row[max(last - WINDOW_CUT_SAMPLES + 1, 0): last + 1]))) / abs(row[peak]))
    cut = [level for level in levels if level >= WINDOW_CUT_LEVEL]
    return float(np.median(cut)) if 2 * len(cut) >= len(levels) else None


def _through_window(power_per_sample: np.ndarray, window: np.ndarray) -> np.ndarray:
    """Variance of a windowed record's spectrum at each rfft line for noise of ``power_per_sample`` (on the rfft
    grid of the record): the noise spectrum convolved with the window's |W|² (white noise gives ``P·Σw²``; a
    narrowband disturbance also leaks where the window's spectrum carries it)."""
    n_samples = window.size
    two_sided = np.concatenate((power_per_sample, power_per_sample[1 : (n_samples + 1) // 2][::-1]))
    kernel = np.abs(np.fft.fft(window)) ** 2
    convolved = np.fft.ifft(np.fft.fft(two_sided) * np.fft.fft(kernel)).real / n_samples
    return np.maximum(convolved[: power_per_sample.size], 0.0)


#: the lowest periodogram bin (of the quiet records) a narrowband line may sit in
MIN_LINE_BIN = 3


def _narrowband_lines_hz(quiet: np.ndarray, sample_rate_hz: float, mains_hz: list[float]) -> list[float]:
    """Frequencies of narrowband lines in quiet records (hits, samples) standing 30× above the noise level
    (mains lines already removed are not counted), against the local median level."""
    length = quiet.shape[1]
    if length < 64:
        return []
    hann = np.hanning(length)
    centred = quiet - quiet.mean(axis=1, keepdims=True)
    periodogram = np.mean(np.abs(np.fft.rfft(centred * hann, axis=1)) ** 2, axis=0)
    freq_hz = np.fft.rfftfreq(length, 1.0 / sample_rate_hz)
    import scipy.signal
    floor = scipy.signal.medfilt(periodogram, 41)  # the local noise level around each line
    if not np.all(floor[1:] > 0):
        return []
    resolution_hz = 4 * sample_rate_hz / length
    peaks, _ = scipy.signal.find_peaks(periodogram / np.maximum(floor, 1e-300), height=30.0)
    # a line must stand clear of DC: within the first bins a slow settling or drift (an offset decaying through the AC
    # coupling) looks like a peak against the median filter's zero-padded edge
    kept = [p for p in peaks if p >= MIN_LINE_BIN and p + 1 < len(periodogram)
            and all(abs(freq_hz[p] - m) > resolution_hz for m in mains_hz)]
    # between the bins: the vertex of a parabola through the log-power of the peak bin and its neighbours (a short
    # quiet tail has bins of several Hz; a 46 Hz line read 48 Hz)
    log_power = np.log(periodogram + 1e-300)
    lines = []
    for p in kept:
        below, at, above = log_power[p - 1], log_power[p], log_power[p + 1]
        curvature = below - 2 * at + above
        offset = 0.5 * (below - above) / curvature if curvature < 0 else 0.0
        lines.append(float((p + np.clip(offset, -0.5, 0.5)) * (freq_hz[1] - freq_hz[0])))
    return lines


def coarsely_quantised_response(records: np.ndarray, step: float | None = None) -> bool:
    """Whether the response records (hits, 2, samples) are stored with steps coarse against their peak (fewer than
    :data:`COARSE_LEVELS`) and against their noise (the records end within one step): then the quantiser's error is
    deterministic, not noise, and a replay must be quantised the same way. ``step``: the response's step if known."""
    step = _quantisation_step(records[:, 1]) if step is None else step
    ending = records[:, 1, -max(records.shape[-1] // 10, 2):]
    return bool(step > 0 and np.abs(records[:, 1]).max() / step < COARSE_LEVELS
                and float(np.median(np.std(np.diff(ending, axis=1), axis=1))) / np.sqrt(2) < step)


def stuck_bits(records: np.ndarray, step: float) -> list[tuple[int, int]]:
    """Bits of a channel's converter codes (``records`` / ``step``, when they are whole numbers) that never change
    although the codes span far more than that bit: (bit, its value) pairs, lowest first; [] for data that are not
    whole codes (floating-point or decimal exports)."""
    if not step > 0:
        return []
    scaled = records.ravel() / step
    codes = np.round(scaled)
    if np.max(np.abs(scaled - codes)) > 0.05 or not np.all(np.abs(codes) < 2**40):
        return []
    codes = codes.astype(np.int64)
    span = int(codes.max() - codes.min())
    stuck = []
    for bit in range(0, max(span.bit_length() - 3, 0)):  # a bit the codes cross at least 4 times over their span
        share = float(np.mean((codes >> bit) & 1))
        if share in (0.0, 1.0):
            stuck.append((bit, int(share)))
    return stuck


def _quantisation_step(records: np.ndarray) -> float:
    """The smallest step between the distinct values of a channel's records (its quantisation step when it was
    stored quantised; negligible for floating-point data)."""
    steps = np.diff(np.unique(records))
    steps = steps[steps > 0]
    return float(steps.min()) if steps.size else 0.0


#: At most this many significant decimal digits are looked for in a channel's samples (a text export with %.1e …)
MAX_ROUNDED_DIGITS = 4


def decimal_rounding_step(records: np.ndarray) -> np.ndarray | None:
    """The rounding step at every sample (same shape) of a channel stored with few significant decimal digits — a
    text export such as ``%.1e``: every nonzero sample is a multiple of 10^(e − d + 1), e its decimal exponent, for
    d ≤ :data:`MAX_ROUNDED_DIGITS` — where that step at the channel's peak is ten times its finest step between
    values (a uniform quantiser's integers pass the digit test, but their step is the same everywhere); else None.
    The rounding error then grows with each value, up to 5 % of it, where the quiet parts show none."""
    magnitude = np.abs(records)
    nonzero = magnitude[magnitude > 0]
    if nonzero.size < 100:
        return None
    probe = nonzero[:: max(1, nonzero.size // 1000)]  # a thousand samples tell floating-point data at once
    for digits in range(1, MAX_ROUNDED_DIGITS + 1):
        if not all(_decimal_share(values, digits) >= 0.999 for values in (probe, nonzero)):
            continue
        with np.errstate(divide="ignore"):
            step = np.where(magnitude > 0, 10.0 ** (np.floor(np.log10(magnitude)) - digits + 1), 0.0)
        return step if step.max() >= 10 * _quantisation_step(records) else None
    return None


def _noise_spectrum(
    segments: np.ndarray, freq_hz: np.ndarray, sample_rate_hz: float, step: float = 0.0
) -> np.ndarray:
    """Noise power per sample at each frequency (white noise of variance σ² gives σ²) from quiet segments
    (hits, samples): Hann-windowed periodograms averaged over hits, lightly smoothed, interpolated onto ``freq_hz``."""
    length = segments.shape[1]
    quiet = segments - segments.mean(axis=1, keepdims=True)
    hann = np.hanning(length)
    periodogram = np.mean(np.abs(np.fft.rfft(quiet * hann, axis=1)) ** 2, axis=0) / np.sum(hann**2)
    coarse_freq_hz = np.fft.rfftfreq(length, 1.0 / sample_rate_hz)
    if periodogram.size > 2:
        periodogram[0] = periodogram[1]  # the mean removal empties the 0 Hz bin
    if periodogram.size > 4:
        smooth = np.convolve(periodogram, np.ones(3) / 3, mode="same")
        smooth[0], smooth[-1] = periodogram[0], periodogram[-1]
        periodogram = smooth
    # a quiet signal that quantises to a few levels (or to one) still carries at least the quantisation noise
    # step²/12 of the whole record
    steps = np.diff(np.unique(segments))
    steps = steps[steps > 0]
    step = max(step, float(steps.min()) if steps.size else 0.0)
    periodogram = np.maximum(periodogram, step**2 / 12.0)
    return np.interp(freq_hz, coarse_freq_hz, periodogram)


def _remove_mains(
    records: np.ndarray, tail_start: int, sample_rate_hz: float, top_hz: float, before: int = 0
) -> tuple[np.ndarray, float | None, list[float]]:
    """Find mains lines (50 or 60 Hz and harmonics) in the quiet record tails and subtract them from every record.

    Each hit and channel gets its own amplitudes and phases, fitted by least squares on the tail where nothing else
    happens; a harmonic counts when its power over all hits stands 25 times above what noise alone gives, and when
    the line's own frequency is the harmonic's (:data:`MAINS_FREQUENCY_TOLERANCE`). Lines at harmonics only, without
    the mains frequency itself, need two harmonics; tails shorter than :data:`MIN_MAINS_WINDOW_S` are not searched.
    With ``before`` samples of pre-trigger, the lines carried back there must be found with their phase
    (:func:`_coherent_before`): mains is there before the hit too, a line the hit excites (a self-excited limit
    cycle, a ringing mode) is not mains."""
    n_samples = records.shape[-1]
    if (n_samples - tail_start) / sample_rate_hz < MIN_MAINS_WINDOW_S:
        return records, None, []
    time_s = np.arange(n_samples) / sample_rate_hz
    tail_time_s = time_s[tail_start:]
    best: tuple[float, list[float], np.ndarray] | None = None
    for base in MAINS_BASES_HZ:
        harmonics = np.arange(base, min(top_hz, 0.45 * sample_rate_hz) + 1e-9, base)[:MAINS_HARMONICS]
        if harmonics.size == 0 or tail_time_s.size < 4 * harmonics.size + 8:
            continue
        phase = 2 * np.pi * np.outer(tail_time_s, harmonics)
        design = np.hstack((np.cos(phase), np.sin(phase), np.ones((tail_time_s.size, 1))))
        tails = records[:, :, tail_start:].reshape(-1, tail_time_s.size).T
        coefficients, *_ = np.linalg.lstsq(design, tails, rcond=None)
        residual_variance = np.mean((tails - design @ coefficients) ** 2, axis=0)
        count = harmonics.size
        power = coefficients[:count] ** 2 + coefficients[count : 2 * count] ** 2
        noise_power = 4.0 * residual_variance / tail_time_s.size  # E(a² + b²) for noise alone
        ratio = np.mean(power / np.maximum(noise_power, 1e-300)[np.newaxis, :], axis=1)  # all-zero tails: 0
        found = [float(h) for h, r in zip(harmonics, ratio)
                 if r > 25.0 and _line_at(tails, tail_time_s, float(h))]
        if found and found[0] != base and len(found) < 2:
            found = []
        if found and (best is None or len(found) > len(best[1])):
            best = (base, found, coefficients)
    if best is None:
        return records, None, []
    base, found, coefficients = best
    harmonics = np.arange(base, min(top_hz, 0.45 * sample_rate_hz) + 1e-9, base)[:MAINS_HARMONICS]
    keep = np.isin(harmonics, found)
    count = harmonics.size
    phase = 2 * np.pi * np.outer(time_s, harmonics[keep])
    lines = np.cos(phase) @ coefficients[:count][keep] + np.sin(phase) @ coefficients[count : 2 * count][keep]
    if not _coherent_before(records.reshape(-1, n_samples).T[:before], lines[:before]):
        return records, None, []
    cleaned = records - lines.T.reshape(records.shape)
    return cleaned, base, found


def _line_at(tails: np.ndarray, time_s: np.ndarray, nominal_hz: float) -> bool:
    """Whether the line near ``nominal_hz`` in the tails (samples × records) peaks within the mains tolerance of it:
    the power summed over records, scanned ±3 % around the nominal frequency on a grid finer than the resolution."""
    centred = tails - tails.mean(axis=0)
    trial_hz = nominal_hz * np.linspace(0.97, 1.03, 121)
    phase = 2 * np.pi * np.outer(trial_hz, time_s)
    power = (np.cos(phase) @ centred) ** 2 + (np.sin(phase) @ centred) ** 2
    peak_hz = float(trial_hz[np.argmax(power.sum(axis=1))])
    return abs(peak_hz - nominal_hz) <= MAINS_FREQUENCY_TOLERANCE * nominal_hz


def _coherent_before(before: np.ndarray, lines: np.ndarray) -> bool:
    """Whether mains lines fitted on the tails and carried back (``lines``: samples × records) are in the pre-trigger
    (``before``, same shape) with their phase and most of their power; True when the pre-trigger is too short or too
    noisy to tell (then the frequency alone decides)."""
    if before.shape[0] < 16:
        return True
    before = before - before.mean(axis=0)
    lines = lines - lines.mean(axis=0)
    energy = float(np.sum(lines**2))
    sigma = float(np.sqrt(np.mean((before - lines) ** 2)))
    if energy <= 0 or np.sqrt(energy) / max(sigma, 1e-300) < 2 * MAINS_COHERENCE_Z:
        return True  # even a coherent line would not stand out of the pre-trigger's noise
    correlation = float(np.sum(before * lines))
    return correlation / (sigma * np.sqrt(energy)) > MAINS_COHERENCE_Z and correlation > MAINS_COHERENCE_SHARE * energy


def _subtract_lines(records: np.ndarray, start: int, sample_rate_hz: float, lines_hz: np.ndarray) -> np.ndarray:
    """Records with sinusoids at ``lines_hz`` removed: amplitudes and phases fitted per hit and channel by least
    squares on the samples from ``start`` on, subtracted from the whole record."""
    time_s = np.arange(records.shape[-1]) / sample_rate_hz
    phase = 2 * np.pi * np.outer(time_s, lines_hz)
    basis = np.hstack((np.cos(phase), np.sin(phase)))
    design = np.hstack((basis[start:], np.ones((time_s.size - start, 1))))
    flat = records.reshape(-1, time_s.size).T
    coefficients, *_ = np.linalg.lstsq(design, flat[start:], rcond=None)
    return (flat - basis @ coefficients[:-1]).T.reshape(records.shape)


#: A channel sits on a DC offset when its mean before the impacts stands this many times its own noise (RMS) from
#: zero in every hit: an AC-coupled channel's pre-trigger mean is within its noise.
DC_OFFSET_NOISE_RATIO = 10.0


def without_dc_offsets(records: np.ndarray, sample_rate_hz: float) -> tuple[np.ndarray, QualityNote | None, bool]:
    """Records (hits, 2, samples) with each channel's pre-trigger mean subtracted where that channel sits on a DC
    offset in every hit (a DC-coupled channel: gravity on a MEMS or servo accelerometer, a zero offset), the note
    saying so, and whether the response alone is DC-coupled (then the force's AC coupling is not matched on it);
    unchanged, with None, where the pre-trigger is too short to tell or no channel has an offset."""
    margin = int(QUIET_MARGIN_S * sample_rate_hz)
    quiet = [_pulse_extent(record[0])[0] - margin for record in records]
    if min(quiet) < MIN_QUIET_SAMPLES:
        return records, None, False
    means = np.array([[np.mean(record[channel, :n]) for channel in (0, 1)] for record, n in zip(records, quiet)])
    noise = np.array([[np.std(record[channel, :n]) for channel in (0, 1)] for record, n in zip(records, quiet)])
    offset = np.all(np.abs(means) > DC_OFFSET_NOISE_RATIO * noise, axis=0) & np.all(
        np.sign(means) == np.sign(means[0]), axis=0)
    if not np.any(offset):
        return records, None, False
    cleaned = records - (means * offset)[:, :, np.newaxis]
    said = [f"the {name} records sit on {np.median(means[:, channel]):+.3g} {unit}"
            for channel, (name, unit) in enumerate((("force", "N"), ("response", "m/s²"))) if offset[channel]]
    response_only = bool(offset[1] and not offset[0])
    unmatched = (f"; the force's {AC_COUPLING_HZ:g} Hz AC coupling is then not on the response, and the replay "
                 f"takes it on the force channel" if response_only else "")
    return cleaned, QualityNote(
        "offset", f"{' and '.join(said)} before every hit (a DC-coupled channel: gravity on a MEMS or servo "
        f"accelerometer, a zero offset, or records detrended on export; the NI 9234's IEPE inputs are AC-coupled): "
        f"each record's mean before its impact is subtracted{unmatched} — a property of the recording, not physics"
    ), response_only
