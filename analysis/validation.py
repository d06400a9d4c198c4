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
* ``"response not decayed"``: the RMS of the (windowed, if a window is given) response over the last
  ``tail_fraction`` of the record exceeds ``decay_fraction`` of its peak and ``noise_margin`` times the RMS noise of
  the response before the pulse: truncation, hence leakage (a tail at the noise floor is decayed).
* ``"pre-trigger not quiet"``: the RMS of the response before the pulse exceeds ``pretrigger_quiet_fraction`` of its
  peak: the structure still rings from an earlier hit.

A rejected hit is kept with its verdict; the user may override it with :meth:`Verdict.overridden_to`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
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

#: Samples just before the trigger that belong to the rising edge of the pulse, not to the pre-trigger noise.
_EDGE_GUARD_S = 0.5e-3


@dataclass(frozen=True)
class ValidationSettings:
    """Thresholds of the hit checks (all relative, so they hold for any force level and sensor)."""

    double_hit_fraction: float = 0.1
    min_force_snr: float = 20.0
    decay_fraction: float = 0.01
    tail_fraction: float = 0.05
    pretrigger_quiet_fraction: float = 0.02
    full_scale_fraction: float = 0.98
    clip_run_samples: int = 4
    noise_margin: float = 3.0

    def __post_init__(self) -> None:
        for name in ("double_hit_fraction", "decay_fraction", "tail_fraction", "pretrigger_quiet_fraction"):
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

    @classmethod
    def from_reasons(cls, reasons: tuple[str, ...]) -> "Verdict":
        return cls(accepted=not reasons, reasons=tuple(reasons))

    def overridden_to(self, accepted: bool) -> "Verdict":
        """The user's decision; the automatic reasons are kept for the record."""
        return replace(self, accepted=bool(accepted), overridden=True)

    def to_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "reasons": list(self.reasons), "overridden": self.overridden}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> "Verdict":
        return cls(bool(values["accepted"]), tuple(str(r) for r in values["reasons"]), bool(values["overridden"]))


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
    return bool(runs.max() >= run_samples)


def validate_hit(
    hit: HitRecord,
    settings: ValidationSettings = ValidationSettings(),
    full_scale_si: tuple[float, ...] | None = None,
    *,
    window: WindowSettings | None = None,
) -> Verdict:
    """Run every check on a hit; ``full_scale_si`` gives each channel's full scale in N or m/s² (channel order),
    ``window`` the processing window, whose exponential counts when judging whether the response has decayed."""
    data = np.asarray(hit.data, dtype=float)
    force = data[hit.force_channel]
    response = data[hit.response_channel]
    quiet_end = _pretrigger_end(hit)
    reasons: list[str] = []

    f, peak_at, peak = _first_pulse(force, quiet_end, hit.trigger_index)
    if peak > 0 and _has_double_hit(f, peak_at, quiet_end, settings.double_hit_fraction):
        reasons.append(DOUBLE_HIT)

    channels = (hit.force_channel, hit.response_channel)
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

    weighted = response
    if window is not None and window.exponential_end_fraction is not None:
        weighted = response * exponential_window(response.size, window.exponential_end_fraction)
    tail = max(2, int(round(settings.tail_fraction * response.size)))
    response_peak = float(np.max(np.abs(weighted)))
    pre = response[:quiet_end]
    noise_response = _rms(pre - np.mean(pre)) if quiet_end > 1 else 0.0
    tail_rms = _rms(weighted[-tail:])
    if tail_rms > settings.decay_fraction * response_peak and tail_rms > settings.noise_margin * noise_response:
        reasons.append(NOT_DECAYED)

    if noise_response > settings.pretrigger_quiet_fraction * float(np.max(np.abs(response))):
        reasons.append(PRETRIGGER_NOT_QUIET)
    return Verdict.from_reasons(tuple(reasons))
