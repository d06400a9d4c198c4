"""Checks that decide whether a hit may enter the average, each with the reason it stores with the hit.

Reasons (exact strings, several may apply to one hit):

* ``"double hit"``: after the first force pulse has ended (its smoothed force fell below half the threshold), the
  smoothed force rises again above ``double_hit_fraction`` of the first peak; a pulse in the pre-trigger counts too.
  The force is smoothed over half the first pulse's width at half maximum, so hammer-tip ringing and noise far above
  the pulse's bandwidth do not count as impacts.
* ``"overload"``: the device flagged an overload on the force or response channel during the record, a channel
  reaches ``full_scale_fraction`` of its full scale, or the signal is flat at its extreme for ``clip_run_samples``
  consecutive samples (clipping).
* ``"force too low"``: peak force over the RMS noise of the force before the pulse is below ``min_force_snr``.
* ``"response not decayed"``: the response (windowed, if a window is given) still rings at the end of the record:
  its RMS over the last ``tail_fraction`` of the record exceeds ``noise_margin`` times the RMS noise before the pulse,
  and the exponential decay of its envelope, fitted over the last ``decay_fit_fraction`` of the record, ends above
  ``decay_fraction`` of where it started at the trigger: truncation, hence leakage (a tail at the noise floor is
  decayed). The verdict's note says how much leakage to expect and which exponential window would cure it.
* ``"pre-trigger not quiet"``: the RMS of the response before the pulse exceeds ``pretrigger_quiet_fraction`` of its
  peak: the structure still rings from an earlier hit.

A rejected hit is kept with its verdict; the user may override it with :meth:`Verdict.overridden_to`. A recording
from elsewhere cannot be hit again: there a hit whose only fault is that it still rings at the record end enters the
average with its truncation flagged (:func:`keep_truncated`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from gasfilm.analysis.capture import HitRecord
from gasfilm.analysis.spectra import WindowSettings, exponential_window
from gasfilm.drivers.errors import SettingError

DOUBLE_HIT = "double hit"
OVERLOAD = "overload"
FORCE_TOO_LOW = "force too low"
NOT_DECAYED = "response not decayed"
PRETRIGGER_NOT_QUIET = "pre-trigger not quiet"
REASONS = (DOUBLE_HIT, OVERLOAD, FORCE_TOO_LOW, NOT_DECAYED, PRETRIGGER_NOT_QUIET)

#: An envelope that ends above this fraction of its start does not decay (a window would only hide it).
BARELY_DECAYING = 0.5
#: Samples just before the trigger that belong to the rising edge of the pulse, not to the pre-trigger noise.
_EDGE_GUARD_S = 0.5e-3


@dataclass(frozen=True)
class ValidationSettings:
    """Thresholds of the hit checks (all relative, so they hold for any force level and sensor)."""

    double_hit_fraction: float = 0.1
    min_force_snr: float = 20.0
    decay_fraction: float = 0.005
    tail_fraction: float = 0.05
    decay_fit_fraction: float = 0.3
    pretrigger_quiet_fraction: float = 0.02
    full_scale_fraction: float = 0.98
    clip_run_samples: int = 4
    noise_margin: float = 3.0

    def __post_init__(self) -> None:
        for name in ("double_hit_fraction", "decay_fraction", "tail_fraction", "decay_fit_fraction",
                     "pretrigger_quiet_fraction"):
            value = getattr(self, name)
            if not 0 < value < 1:
                raise SettingError(f"{name}: {value} must be between 0 and 1")
        if not 0 < self.full_scale_fraction <= 1:
            raise SettingError(f"full_scale_fraction: {self.full_scale_fraction} must be in (0, 1]")
        if not self.min_force_snr >= 0:
            raise SettingError(f"min_force_snr: {self.min_force_snr} must be 0 or more")
        if not self.noise_margin >= 1:
            raise SettingError(f"noise_margin: {self.noise_margin} must be 1 or more")
        if self.clip_run_samples < 2:
            raise SettingError(f"clip_run_samples: {self.clip_run_samples} must be at least 2")


@dataclass(frozen=True)
class Verdict:
    """Whether a hit enters the average, why not, and whether a person decided it."""

    accepted: bool
    reasons: tuple[str, ...] = ()
    overridden: bool = False
    #: Explanations for the operator (e.g. the leakage a truncated response causes); not stored with the hit.
    notes: tuple[str, ...] = field(default=(), compare=False)

    @classmethod
    def from_reasons(cls, reasons: tuple[str, ...], notes: tuple[str, ...] = ()) -> "Verdict":
        return cls(accepted=not reasons, reasons=tuple(reasons), notes=tuple(notes))

    def overridden_to(self, accepted: bool) -> "Verdict":
        """The user's decision; the automatic reasons are kept for the record."""
        return replace(self, accepted=bool(accepted), overridden=True)

    def to_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "reasons": list(self.reasons), "overridden": self.overridden}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> "Verdict":
        return cls(bool(values["accepted"]), tuple(str(r) for r in values["reasons"]), bool(values["overridden"]))


def recorded_full_scale_si(config: Any, settings: Mapping[str, Any]) -> tuple[float, ...] | None:
    """Each channel's full scale (N or m/s²) for the overload check of a stored session's hits, or None when the
    recording does not know its input ranges: an import (``settings["source"]`` names the file it came from, and a
    UFF file carries units but no range) is never given limits from the default channel setup it is stored with."""
    source = settings.get("source") if isinstance(settings, Mapping) else None
    if isinstance(source, Mapping) and (source.get("uff_file") or source.get("full_scale_known") is False):
        return None
    return tuple(float(channel.full_scale_si) for channel in config.channels)


def _pretrigger_end(hit: HitRecord) -> int:
    """Last sample (exclusive) of the quiet part before the pulse's rising edge."""
    guard = int(np.ceil(_EDGE_GUARD_S * hit.sample_rate_hz)) + 1
    return max(0, hit.trigger_index - guard)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else 0.0


def _first_pulse(force: np.ndarray, quiet_end: int, trigger_index: int) -> tuple[np.ndarray, int, float]:
    """Force minus its pre-trigger baseline, turned so that the triggering pulse is positive; the index and value of
    that pulse's peak. The triggering pulse runs from the trigger until the force falls below half its trigger value,
    so a later, larger impact is never taken for it."""
    baseline = float(np.median(force[:quiet_end])) if quiet_end > 0 else 0.0
    f = force - baseline
    start = min(trigger_index, f.size - 1)
    if f[start] == 0:
        start = int(np.argmax(np.abs(f)))
    if f[start] < 0:
        f = -f
    if f[start] <= 0:
        return f, start, 0.0
    ended = np.flatnonzero(f[start:] < 0.5 * f[start])
    stop = f.size if ended.size == 0 else start + int(ended[0])
    peak_at = start + int(np.argmax(f[start:stop]))
    return f, peak_at, float(f[peak_at])


def _has_double_hit(f: np.ndarray, peak_at: int, quiet_end: int, fraction: float) -> bool:
    peak = f[peak_at]
    below_half = f < 0.5 * peak
    # width at half maximum of the first pulse: from the last sample below half before the peak to the first after
    before_peak = np.flatnonzero(below_half[:peak_at])
    after_peak = np.flatnonzero(below_half[peak_at:])
    left = before_peak[-1] + 1 if before_peak.size else 0
    right = peak_at + after_peak[0] if after_peak.size else f.size
    smoothing = max(1, int(right - left) // 2)
    smooth = np.convolve(f, np.ones(smoothing) / smoothing, mode="same")
    threshold = fraction * peak
    before = max(0, quiet_end - smoothing)
    if before > 0 and np.max(smooth[:before]) > threshold:
        return True
    below = np.flatnonzero(smooth[peak_at:] < 0.5 * threshold)
    if below.size == 0:
        return False
    pulse_end = peak_at + int(below[0])
    return bool(np.any(smooth[pulse_end:] > threshold))


def _is_clipped(x: np.ndarray, run_samples: int) -> bool:
    magnitude = np.abs(x)
    top = magnitude.max()
    if top == 0:
        return False
    at_top = np.concatenate(([0], (magnitude >= top * (1 - 1e-12)).astype(np.int8), [0]))
    edges = np.flatnonzero(np.diff(at_top))
    runs = edges[1::2] - edges[::2]
    return bool(runs.size and runs.max() >= run_samples)  # no runs when the record holds NaN


def validate_hit(
    hit: HitRecord,
    settings: ValidationSettings = ValidationSettings(),
    full_scale_si: tuple[float, ...] | None = None,
    *,
    window: WindowSettings | None = None,
    other_responses: tuple[int, ...] = (),
) -> Verdict:
    """Run every check on a hit; ``full_scale_si`` gives each channel's full scale in N or m/s² (channel order),
    ``window`` the processing window, whose exponential counts when judging whether the response has decayed.
    ``other_responses``: further response channels (a rigid body's other accelerometers) that get the response's
    checks too (overload, decay, a quiet pre-trigger); a note names the channel that failed one."""
    data = np.asarray(hit.data, dtype=float)
    force = data[hit.force_channel]
    quiet_end = _pretrigger_end(hit)
    reasons: list[str] = []

    f, peak_at, peak = _first_pulse(force, quiet_end, hit.trigger_index)
    if peak > 0 and _has_double_hit(f, peak_at, quiet_end, settings.double_hit_fraction):
        reasons.append(DOUBLE_HIT)

    channels = (hit.force_channel, hit.response_channel, *other_responses)
    flagged = np.asarray(hit.overload, dtype=bool)
    overload = bool(flagged.size and flagged[list(channels)].any())
    if full_scale_si is not None:
        overload |= any(
            np.max(np.abs(data[c])) >= settings.full_scale_fraction * full_scale_si[c] for c in channels
        )
    overload |= any(_is_clipped(data[c], settings.clip_run_samples) for c in channels)
    if overload:
        reasons.append(OVERLOAD)

    noise_force = _rms(f[:quiet_end] - np.mean(f[:quiet_end])) if quiet_end > 1 else 0.0
    if peak == 0 or (noise_force > 0 and peak / noise_force < settings.min_force_snr):
        reasons.append(FORCE_TOO_LOW)

    notes: list[str] = []
    for row in (hit.response_channel, *other_responses):
        response = data[row]
        named = "" if row == hit.response_channel else f"channel {row}: "
        pre = response[:quiet_end]
        noise_response = _rms(pre - np.mean(pre)) if quiet_end > 1 else 0.0
        decay = response_decay(response, hit.trigger_index, hit.sample_rate_hz, noise_response, settings, window)
        if decay is not None and decay.end_ratio > settings.decay_fraction:
            if NOT_DECAYED not in reasons:
                reasons.append(NOT_DECAYED)
            notes.append(named + decay.advice(settings.decay_fraction))
        if noise_response > settings.pretrigger_quiet_fraction * float(np.max(np.abs(response))):
            if PRETRIGGER_NOT_QUIET not in reasons:
                reasons.append(PRETRIGGER_NOT_QUIET)
            if named:
                notes.append(f"{named}the response before the hit is not quiet")
    return Verdict.from_reasons(tuple(reasons), tuple(notes))


def keep_truncated(verdict: Verdict) -> Verdict:
    """For a recording from elsewhere (no technician can hit again): a hit rejected ONLY because its response still
    rings at the record end is accepted, its reason kept as a flag and its note saying the leakage and the advised
    window. Any other verdict is returned as it is."""
    if verdict.accepted or verdict.overridden or verdict.reasons != (NOT_DECAYED,):
        return verdict
    notes = tuple(f"kept although truncated (a recording from elsewhere): {note}" for note in verdict.notes)
    return Verdict(True, verdict.reasons, False, notes=notes)


def is_flagged(verdict: Verdict) -> bool:
    """An accepted hit that still carries a reason (a truncation kept by :func:`keep_truncated`)."""
    return verdict.accepted and not verdict.overridden and bool(verdict.reasons)


@dataclass(frozen=True)
class ResponseDecay:
    """How far the response's envelope has decayed at the end of the record: ``end_ratio`` = envelope at the last
    sample over envelope at the trigger (the exponential fitted to the end of the record, extrapolated back),
    ``decay_rate_1_s`` its rate σ (0 when it does not decay), ``tail_over_noise`` the tail RMS over the pre-trigger
    noise RMS (inf without pre-trigger noise), ``record_after_trigger_s`` the time from the trigger to the end,
    ``window_end_fraction`` the exponential window already applied (1 for none)."""

    end_ratio: float
    decay_rate_1_s: float
    tail_over_noise: float
    record_after_trigger_s: float
    window_end_fraction: float = 1.0

    def suggested_end_fraction(self, decay_fraction: float) -> float:
        """An exponential window end value (one significant digit, total with any window already applied) that brings
        the envelope at the record end to half of ``decay_fraction`` of its start."""
        wanted = self.window_end_fraction * 0.5 * decay_fraction / max(self.end_ratio, 1e-300)
        wanted = min(0.5, max(1e-4, wanted))
        exponent = math.floor(math.log10(wanted))
        return math.floor(wanted / 10**exponent) * 10**exponent

    def advice(self, decay_fraction: float) -> str:
        """One sentence: how much is left, the leakage it causes, and the exponential window that cures it."""
        end = self.suggested_end_fraction(decay_fraction)
        window = "" if self.window_end_fraction == 1.0 else f" with the exponential window ending at " \
                                                              f"{self.window_end_fraction:g}"
        if self.end_ratio > BARELY_DECAYING:
            state = f"the response{window} does not decay: at the end of the record it still rings at " \
                    f"{self.end_ratio:.0%} of its start, {self.tail_over_noise:.3g}× the pre-trigger noise"
            return f"{state}; the FRF is dominated by leakage; lengthen the record or check for a steady signal"
        state = (f"the response{window} still rings at the end of the record at {self.end_ratio:.2%} of its start "
                 f"(decay {self.decay_rate_1_s:.3g} 1/s, {self.tail_over_noise:.3g}× the pre-trigger noise)")
        leakage = f"leakage: each such mode's FRF peak about {min(self.end_ratio, 1):.2%} low and rippled by " \
                  f"±{min(self.end_ratio, 1):.2%} around it"
        return f"{state}; {leakage}; an exponential window ending at {end:g} (--exp-end {end:g}) would help " \
               f"(it adds {-math.log(end) / self.record_after_trigger_s:.3g} 1/s of damping, which the fit removes)"


def response_decay(
    response: np.ndarray,
    trigger_index: int,
    sample_rate_hz: float,
    noise_rms: float,
    settings: ValidationSettings = ValidationSettings(),
    window: WindowSettings | None = None,
) -> ResponseDecay | None:
    """The decay of the response's envelope at the end of the record, or None when the tail has reached the noise
    floor (``noise_margin`` × ``noise_rms``) or the record is too short to tell.

    The envelope is the RMS in ten blocks over the last ``decay_fit_fraction`` of the record, less the noise power;
    the blocks above the noise floor are fitted with an exponential (a line through log RMS)."""
    response = np.asarray(response, dtype=float)
    end_fraction = 1.0
    if window is not None and window.exponential_end_fraction is not None:
        end_fraction = float(window.exponential_end_fraction)
        weight = exponential_window(response.size, end_fraction)
    else:
        weight = np.ones(response.size)
    start = min(max(int(trigger_index), 0), response.size)
    tail = max(2, int(round(settings.tail_fraction * response.size)))
    if response.size - start < 2 * tail:
        return None
    noise_at = noise_rms * weight  # the window scales the noise as much as the signal
    tail_rms = _rms(response[-tail:] * weight[-tail:])
    tail_noise = float(np.mean(noise_at[-tail:]))
    if not tail_rms > settings.noise_margin * tail_noise:
        return None
    span = max(2 * tail, int(round(settings.decay_fit_fraction * (response.size - start))))
    block = max(2, span // 10)
    first = response.size - 10 * block
    mean_square = np.mean(np.square(response[first:] * weight[first:]).reshape(10, block), axis=1)
    noise_square = np.square(noise_at[first:].reshape(10, block).mean(axis=1))
    above = mean_square > settings.noise_margin**2 * noise_square
    power = mean_square - noise_square
    # fitted against time in samples (well conditioned at any sample rate), converted to seconds afterwards
    times_samples = first + block * (np.arange(10) + 0.5) - start
    record_samples = response.size - 1 - start
    over_noise = math.inf if tail_noise == 0 else tail_rms / tail_noise
    if np.count_nonzero(above) < 3:
        return None
    log_amplitude = 0.5 * np.log(power[above])
    if not np.all(np.isfinite(log_amplitude)):
        return None
    slope_per_sample, _ = np.polyfit(times_samples[above], log_amplitude, 1)
    decay_per_sample = max(0.0, -float(slope_per_sample))
    return ResponseDecay(math.exp(-decay_per_sample * record_samples), decay_per_sample * sample_rate_hz,
                         over_noise, record_samples / sample_rate_hz, end_fraction)
