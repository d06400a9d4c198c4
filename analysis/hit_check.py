"""The hit check before a test: a few trial taps, recorded nowhere, and the settings they call for.

A technician taps the structure a few times before recording. From those taps :func:`propose_settings` reads what a
test engineer reads off them: the force noise and the smallest tap (→ trigger level), the largest tap against the
hammer channel's full scale (→ hit softer), the force spectrum's roll-off against the wanted band (→ a harder or
softer tip), the pulse width (→ force window) and the response's decay (→ record length, or an exponential window
when the response outlasts the longest record). :class:`TapRecorder` is the trigger and the hit checks of a recording
without a session: it stores nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from gasfilm.analysis.capture import MAX_RECORD_S, HitRecord, ImpactCapture
from gasfilm.analysis.recording import HitEvent
from gasfilm.analysis.spectra import USABLE_DROP_DB, force_level_db, usable_band_hz
from gasfilm.analysis.validation import ValidationSettings, validate_hit

#: A tap whose peak reaches this fraction of the hammer channel's full scale is too hard: the next one may clip.
HARD_TAP_FRACTION = 0.8
#: The trigger level proposed: this fraction of the smallest tap's peak ...
TRIGGER_FRACTION_OF_SMALLEST = 0.1
#: ... and at least this many times the force noise (RMS) before the taps, so that noise never triggers.
TRIGGER_NOISE_FACTOR = 8.0
#: The response has decayed when its envelope stays below this fraction of its peak (−40 dB).
DECAYED_FRACTION = 0.01
#: The envelope of a sensor's noise reaches this many times its RMS: below that the response has died away.
NOISE_ENVELOPE_FACTOR = 4.0
#: The record lengths offered, in s (a power-of-two ladder up to the live maximum).
RECORD_LENGTHS_S = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, MAX_RECORD_S)
#: A tip puts enough force into the band when its force spectrum stays within the usable drop up to this many times
#: the band's upper edge (margin for the scatter between taps).
TIP_MARGIN = 1.2
#: A tip is needlessly hard when its usable band reaches beyond this many times the band's upper edge: a softer one
#: puts more of the same impulse into the band.
TIP_TOO_HARD = 4.0


@dataclass(frozen=True)
class Tap:
    """What one trial tap shows (SI units)."""

    peak_force_n: float
    pulse_width_s: float  # the half-sine's width, from the time the pulse stays above 5 % of its peak
    force_noise_n: float  # RMS of the force before the pulse
    usable_to_hz: float  # where its force spectrum first falls ``drop_db`` below its low-frequency level
    decay_s: float | None  # from the trigger until the response stays below 1 % of its peak (None: beyond the record)
    envelope_decay_1_s: float  # the rate its envelope falls at (a log-linear fit from its peak; 0 if it does not)
    clipped: bool  # the validation found overload or clipping


@dataclass(frozen=True)
class HitCheckProposal:
    """The settings the taps call for, each with the reason in words."""

    taps: int
    trigger_level_n: float
    record_s: float
    force_window_ms: float
    exponential_end_fraction: float | None
    tip: str | None  # a tip to change to (a name the caller offered), None: keep the one in use
    lines: list[str] = field(default_factory=list)  # one sentence per setting and finding

    def text(self) -> str:
        return "\n".join(self.lines)


def _nice_ceiling(value: float, step: float) -> float:
    return step * math.ceil(value / step - 1e-9)


def _two_digits(value: float) -> float:
    """``value`` rounded to two significant digits."""
    if value <= 0 or not math.isfinite(value):
        return value
    return float(f"{value:.2g}")


def _pulse_width_s(force: np.ndarray, peak_index: int, sample_rate_hz: float) -> float:
    """Width of the half-sine pulse around ``peak_index``: the run above 5 % of the peak, scaled by the fraction of a
    half-sine's width spent above 5 % of its peak (1 − 2·asin(0.05)/π)."""
    level = 0.05 * force[peak_index]
    start = peak_index
    while start > 0 and force[start - 1] > level:
        start -= 1
    end = peak_index
    while end < force.size - 1 and force[end + 1] > level:
        end += 1
    above_s = (end - start + 1) / sample_rate_hz
    return above_s / (1.0 - 2.0 * math.asin(0.05) / math.pi)


def _envelope(signal: np.ndarray, block: int) -> np.ndarray:
    """The amplitude envelope of ``signal`` (the magnitude of its analytic signal, whatever the frequency of its
    ringing), its largest value in each block of ``block`` samples."""
    if signal.size < 2:
        return np.abs(signal) if signal.size else np.zeros(1)
    # zero-padded to twice its length: the transform's wrap-around would otherwise lift the record's end
    import scipy.signal  # (on first use: the GUI's start does not wait for it)

    amplitude = np.abs(scipy.signal.hilbert(signal - np.mean(signal), 2 * signal.size)[: signal.size])
    usable = amplitude.size - amplitude.size % block
    if usable == 0:
        return np.array([float(np.max(amplitude))])
    return np.max(amplitude[:usable].reshape(-1, block), axis=1)


def summarise_tap(record: HitRecord, full_scale_si: Sequence[float] | None = None,
                  drop_db: float = USABLE_DROP_DB) -> Tap:
    """One tap's peak force, pulse width, force noise, usable band and the response's decay."""
    rate = record.sample_rate_hz
    force = record.force_n - float(np.median(record.force_n[: max(1, record.trigger_index)]))
    response = record.response
    quiet = max(1, record.trigger_index - int(round(1e-3 * rate)))
    noise = float(np.std(force[:quiet])) if quiet > 1 else 0.0
    peak_index = int(np.argmax(force))
    peak = float(force[peak_index])
    width = _pulse_width_s(force, peak_index, rate)
    spectrum = np.abs(np.fft.rfft(force)) ** 2
    freq = np.fft.rfftfreq(force.size, 1.0 / rate)
    usable_to = usable_band_hz(freq, spectrum, drop_db)[1]
    block = max(1, min(int(round(10e-3 * rate)), (record.n_samples - record.trigger_index) // 40))
    envelope = _envelope(response[record.trigger_index:], block)
    top = int(np.argmax(envelope))
    peak_envelope = float(envelope[top]) or 1.0
    after = envelope[top:] / peak_envelope
    # decayed: below 1 % of the peak, or down in the sensor's noise (its envelope's peaks reach ~4× its RMS)
    response_noise = float(np.std(response[:quiet])) if quiet > 1 else 0.0
    floor = max(DECAYED_FRACTION, NOISE_ENVELOPE_FACTOR * response_noise / peak_envelope)
    loud = np.flatnonzero(after >= floor)
    decay_rate = _decay_rate_1_s(after, block / rate)
    decay_s: float | None = None
    if loud.size and loud[-1] < after.size - 1:
        decay_s = (top + loud[-1] + 1) * block / rate
    elif not loud.size:
        decay_s = top * block / rate
    verdict = validate_hit(record, ValidationSettings(), full_scale_si)
    clipped = any(reason.startswith(("overload", "clipp")) for reason in verdict.reasons)
    return Tap(peak, width, noise, usable_to, decay_s, decay_rate, clipped)


def half_sine_usable_to_hz(pulse_width_s: float, drop_db: float = USABLE_DROP_DB) -> float:
    """Where a half-sine pulse of ``pulse_width_s`` first falls ``drop_db`` below its low-frequency level:
    |F(f)| ∝ |cos(π f T)| / |1 − (2 f T)²|."""
    x = np.linspace(1e-6, 3.0, 30_000)  # f·T
    with np.errstate(divide="ignore", invalid="ignore"):
        level = np.abs(np.cos(np.pi * x) / (1.0 - (2.0 * x) ** 2))
    level = np.where(np.isfinite(level), level, np.pi / 4)  # the removable singularity at f·T = 1/2
    below = np.flatnonzero(20.0 * np.log10(level) < -abs(drop_db))
    return float(x[below[0]] / pulse_width_s) if below.size else float("inf")


def _decay_rate_1_s(envelope: np.ndarray, block_s: float) -> float:
    """The rate (1/s) at which an envelope that starts at its peak falls: the slope of a straight line through its
    logarithm, its first and last 5 % left out (the onset and the record's end); 0 when it does not fall."""
    if envelope.size < 8:
        return 0.0
    edge = max(1, envelope.size // 20)
    kept = envelope[edge:-edge]
    time_s = (np.arange(kept.size) + edge) * block_s
    slope = np.polyfit(time_s, np.log(np.maximum(kept, 1e-300)), 1)[0]
    return float(max(0.0, -slope))


def _decay_time_s(tap: Tap) -> float:
    """The response's time to decay to 1 %: as measured, or from the rate its envelope falls at when it outlasts
    the record (infinite when it does not fall)."""
    if tap.decay_s is not None:
        return tap.decay_s
    return math.log(1.0 / DECAYED_FRACTION) / tap.envelope_decay_1_s if tap.envelope_decay_1_s > 0 else math.inf


def propose_settings(
    records: Sequence[HitRecord],
    band_hz: tuple[float, float],
    full_scale_n: float,
    pretrigger_s: float,
    tips_pulse_width_s: Mapping[str, float] | None = None,
    full_scale_si: Sequence[float] | None = None,
    drop_db: float = USABLE_DROP_DB,
) -> HitCheckProposal:
    """Trigger level, record length, windows and tip from trial taps; ``band_hz`` is the band wanted (the fit band),
    ``full_scale_n`` the hammer channel's full scale, ``tips_pulse_width_s`` the tips the hammer has (name → pulse
    width in s; the simulated hammer's), else the tip is advised in words only."""
    if not records:
        raise ValueError("propose_settings: no taps")
    taps = [summarise_tap(record, full_scale_si, drop_db) for record in records]
    peaks = [tap.peak_force_n for tap in taps]
    widths = sorted({f"{1e3 * tap.pulse_width_s:.2g}" for tap in taps}, key=float)
    lines = [f"{len(taps)} tap{'s' if len(taps) != 1 else ''}: peaks {min(peaks):.0f}–{max(peaks):.0f} N, "
             f"pulses {widths[0] if len(widths) == 1 else widths[0] + '–' + widths[-1]} ms."]

    noise = max(tap.force_noise_n for tap in taps)
    level = max(TRIGGER_FRACTION_OF_SMALLEST * min(peaks), TRIGGER_NOISE_FACTOR * noise)
    level = _two_digits(min(level, 0.5 * min(peaks)))
    lines.append(f"Trigger level {level:g} N: {100 * TRIGGER_FRACTION_OF_SMALLEST:.0f} % of the lightest tap, "
                 + (f"{level / noise:.0f}× the force noise ({noise:.2g} N RMS)." if noise > 0
                    else "far above the force noise (none before the taps)."))

    hardest = max(peaks)
    if any(tap.clipped for tap in taps) or hardest >= HARD_TAP_FRACTION * full_scale_n:
        lines.append(f"Force range: hit softer — the hardest tap ({hardest:.0f} N) reaches "
                     f"{100 * hardest / full_scale_n:.0f} % of the hammer channel's full scale ({full_scale_n:.0f} N)"
                     + (" and clipped" if any(tap.clipped for tap in taps) else "") + ".")
    else:
        lines.append(f"Force range: fine — the hardest tap uses {100 * hardest / full_scale_n:.0f} % of the hammer "
                     f"channel's full scale ({full_scale_n:.0f} N).")

    usable_to = float(np.median([tap.usable_to_hz for tap in taps]))
    band_top = band_hz[1]
    reach = f"the force stays within {drop_db:g} dB of its low-frequency level up to {usable_to:.0f} Hz"
    tip: str | None = None
    if tips_pulse_width_s:  # the hammer's tips are known: the softest that still covers the band
        measured = float(np.median([tap.pulse_width_s for tap in taps]))
        in_use = min(tips_pulse_width_s, key=lambda name: abs(math.log(tips_pulse_width_s[name] / measured)))
        covering = [name for name, width in tips_pulse_width_s.items()
                    if half_sine_usable_to_hz(width, drop_db) >= TIP_MARGIN * band_top]
        best = (max(covering, key=lambda name: tips_pulse_width_s[name]) if covering
                else min(tips_pulse_width_s, key=lambda name: tips_pulse_width_s[name]))
        if best == in_use:
            advice = f"Tip: keep the {in_use} tip — {reach}, the band reaches {band_top:g} Hz."
        else:
            tip = best
            harder = tips_pulse_width_s[best] < tips_pulse_width_s[in_use]
            why = ("short of the band's" if harder else "beyond what the band needs,")
            advice = (f"Tip: change to the {best} tip ({'harder' if harder else 'softer'}, "
                      f"{1e3 * tips_pulse_width_s[best]:g} ms pulses) — with the {in_use} tip {reach}, {why} "
                      f"{band_top:g} Hz" + ("" if covering else "; no tip covers the band, the hardest comes closest")
                      + ("." if harder else "; a softer tip puts more of each tap into the band."))
    elif usable_to < TIP_MARGIN * band_top:
        advice = f"Tip: harder — {reach}, short of the band's {band_top:g} Hz (above it the FRF is not trusted)."
    elif usable_to > TIP_TOO_HARD * band_top:
        advice = (f"Tip: a softer one would do — {reach}, far beyond the band's {band_top:g} Hz; a softer tip puts "
                  f"more of each tap into the band.")
    else:
        advice = f"Tip: keep it — {reach}, the band reaches {band_top:g} Hz."
    lines.append(advice)

    width_ms = 1e3 * float(np.median([tap.pulse_width_s for tap in taps]))
    force_window_ms = max(1.0, _nice_ceiling(2.0 * width_ms, 0.5))
    lines.append(f"Force window {force_window_ms:g} ms after the peak: twice the pulse width ({width_ms:.2g} ms), "
                 f"the noise after the pulse left out.")

    decay_s = max(_decay_time_s(tap) for tap in taps)
    wanted_s = pretrigger_s + 1.2 * decay_s
    record_s = next((length for length in RECORD_LENGTHS_S if length >= wanted_s), MAX_RECORD_S)
    exponential: float | None = None
    end_level = DECAYED_FRACTION ** ((record_s - pretrigger_s) / decay_s)  # the envelope at the record's end
    if end_level > DECAYED_FRACTION:
        # the window brings the envelope, exp(-t/τ) with τ from the decay to 1 %, down to 1 % at the record end
        exponential = _two_digits(DECAYED_FRACTION / end_level)
        needs = (f"needs about {decay_s:.3g} s to decay to 1 %" if math.isfinite(decay_s)
                 else "does not decay within the record")
        lines.append(f"Record {record_s:g} s, the longest: the response {needs}; an exponential window ending at {exponential:g} makes it decay within the record "
                     f"(it adds damping the fit takes back).")
    else:
        lines.append(f"Record {record_s:g} s: the response decays to 1 % of its peak {decay_s:.3g} s after the tap "
                     f"(no exponential window needed).")
    return HitCheckProposal(len(taps), level, record_s, force_window_ms, exponential, tip, lines)


class TapRecorder:
    """The trigger and hit checks of a recording, storing nothing: :meth:`feed` returns each tap as a
    :class:`gasfilm.analysis.recording.HitEvent` (numbered in the order the taps came)."""

    def __init__(self, capture: ImpactCapture, validation: ValidationSettings = ValidationSettings(),
                 full_scale_si: Sequence[float] | None = None, window: object = None) -> None:
        self.capture = capture
        self.validation = validation
        self.full_scale_si = full_scale_si
        self.window = window
        self.accepted_count = 0
        self.rejected_count = 0

    def feed(self, chunk: np.ndarray, overload: np.ndarray | None = None) -> list[HitEvent]:
        events = []
        for record in self.capture.feed(chunk, overload):
            verdict = validate_hit(record, self.validation, self.full_scale_si, window=self.window)
            self.accepted_count += verdict.accepted
            self.rejected_count += not verdict.accepted
            events.append(HitEvent(
                index=self.accepted_count + self.rejected_count - 1, verdict=verdict,
                start_time_s=record.start_time_s, trigger_time_s=record.trigger_time_s,
                peak_force_n=float(np.max(np.abs(record.force_n))), accepted_count=self.accepted_count,
                rejected_count=self.rejected_count, record=record))
        return events


#: Force pulses whose widths differ by more than this factor come from different tips (or a hit on another spot).
MIXED_TIPS_RATIO = 1.5


def pulse_width_s(record: HitRecord) -> float:
    """The width of a hit's force pulse (its half-sine's, as :func:`summarise_tap` measures it)."""
    force = record.force_n - float(np.median(record.force_n[: max(1, record.trigger_index)]))
    peak_index = int(np.argmax(force))
    return _pulse_width_s(force, peak_index, record.sample_rate_hz)


def mixed_tips(records: Sequence[HitRecord]) -> str:
    """A warning when the hits' force pulses are of different widths (a 2 ms soft-tip pulse averaged with 0.5 ms
    pulses: their force spectra roll off at different frequencies), else ''."""
    if len(records) < 2:
        return ""
    widths = [pulse_width_s(record) for record in records]
    if max(widths) <= MIXED_TIPS_RATIO * min(widths):
        return ""
    return (f"mixed tips: force pulses of {1e3 * min(widths):.2g} to {1e3 * max(widths):.2g} ms are averaged "
            f"(their spectra roll off at different frequencies); keep to one tip or reject the odd hits")


def force_spectrum_db(record: HitRecord) -> tuple[np.ndarray, np.ndarray]:
    """A tap's force autospectrum in dB re its low-frequency level, above 0 Hz: (frequency in Hz, level in dB)."""
    freq = np.fft.rfftfreq(record.n_samples, 1.0 / record.sample_rate_hz)
    level = force_level_db(freq, np.abs(np.fft.rfft(record.force_n)) ** 2)
    return freq[1:], level[1:]
