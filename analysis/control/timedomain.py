"""The time-domain truth check: the identified fractional model and its rational approximation, each driven by every
recorded hit's force, against the recorded acceleration.

* fractional: :func:`gasfilm.analysis.physics.response.simulate_response` — the fractional model's exact response
  to the sampled force (its transfer function applied to the zero-padded force spectrum, long enough for the
  response to decay: no wrap-around, no truncation of the fractional memory);
* rational: the state-space plant discretised with a first-order hold at 8× the sample rate, driven by the force
  up-sampled band-limited (:func:`scipy.signal.resample_poly`), run as second-order sections (:func:`scipy.signal.sosfilt`);
* all three signals pass through the same zero-phase brick-wall band before they are compared: the band the model
  was fitted in (the FRF fit's band, where its relative error is defined and the model is claimed), and, stated
  beside it, the whole band the recordings are alias-free in (0.45·fs, the NI 9234's pass band), where the sensor's
  broadband noise dominates the error.

Errors are relative RMS per hit: ``RMS(a_recorded − a_model) / RMS(a_recorded)`` over the record.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.fft
import scipy.signal

from gasfilm.analysis.control.rational import RationalModel
from gasfilm.analysis.physics.response import simulate_response
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.interface import NI9234_ALIAS_FREE_FRACTION as ALIAS_FREE_FRACTION

logger = logging.getLogger(__name__)

UPSAMPLING = 8
#: the noise floor is measured from here to the end of each record (fraction of its length)
TAIL_START_FRACTION = 0.8


@dataclass(frozen=True)
class TimeDomainCheck:
    """Per-hit relative RMS errors (fractions) in ``band_hz`` and the signals behind them (band-passed, m/s²)."""

    sample_rate_hz: float
    band_hz: tuple[float, float]  # the comparison band (Hz)
    hit_indices: tuple[int, ...]  # the hits' indices in the session, from 0 (shown to the user from 1)
    error_fractional: np.ndarray  # (hits,) RMS(recorded − fractional)/RMS(recorded)
    error_rational: np.ndarray  # (hits,) RMS(recorded − rational)/RMS(recorded)
    rational_vs_fractional: np.ndarray  # (hits,) RMS(rational − fractional)/RMS(fractional)
    recorded: np.ndarray  # (hits, samples)
    fractional: np.ndarray
    rational: np.ndarray
    trigger_index: np.ndarray  # (hits,)
    noise_floor: np.ndarray  # (hits,) RMS of the recording's quiet tail / RMS(recorded); NaN when the tail is not quiet
    frf_relative_error: float | None = None  # the FRF fit's RMS / RMS(|H_d|) in its band
    alias_free_error_fractional: np.ndarray | None = None  # (hits,) the same error over 0–0.45·fs

    @property
    def excess_fractional(self) -> np.ndarray:
        """The fractional model's error beyond the sensor noise, ``sqrt(error² − floor²)`` (NaN without a floor)."""
        return np.sqrt(np.maximum(self.error_fractional**2 - self.noise_floor**2, 0.0))

    @property
    def excess_rational(self) -> np.ndarray:
        """The rational model's error beyond the sensor noise (NaN without a floor)."""
        return np.sqrt(np.maximum(self.error_rational**2 - self.noise_floor**2, 0.0))

    def summary_lines(self) -> list[str]:
        def noise(value: float) -> str:
            return "not measurable (the response has not decayed by the record's end)" if np.isnan(value) else f"{100 * value:.3g} %"

        lines = [f"hit {index + 1:3d}: RMS error fractional {100 * f:.3g} % (beyond the noise {noise(xf)}), rational "
                 f"{100 * r:.3g} % (beyond the noise {noise(xr)}), noise floor {noise(n)}; rational vs "
                 f"fractional {100 * a:.3g} %"
                 for index, f, xf, r, xr, n, a in zip(self.hit_indices, self.error_fractional, self.excess_fractional,
                                                      self.error_rational, self.excess_rational, self.noise_floor,
                                                      self.rational_vs_fractional)]
        lines.insert(0, f"in {self.band_hz[0]:g}–{self.band_hz[1]:g} Hz:")
        lines.append(f"mean RMS error: fractional {100 * self.error_fractional.mean():.3g} %, rational "
                     f"{100 * self.error_rational.mean():.3g} %"
                     + ("" if np.all(np.isnan(self.noise_floor)) else
                        f", noise floor {100 * np.nanmean(self.noise_floor):.3g} %")
                     + f"; rational vs fractional at most {100 * self.rational_vs_fractional.max():.3g} %"
                     + ("" if self.frf_relative_error is None else
                        f"; the FRF fit's relative RMS error {100 * self.frf_relative_error:.3g} %"))
        if self.alias_free_error_fractional is not None:
            lines.append(f"over the whole alias-free band 0–{ALIAS_FREE_FRACTION * self.sample_rate_hz:g} Hz, where "
                         f"the sensor's broadband noise dominates: fractional "
                         f"{100 * self.alias_free_error_fractional.mean():.3g} % (mean)")
        return lines

    def to_dict(self) -> dict:
        """Per-hit figures as plain data (fractions); hits numbered from 1, as everywhere the user sees them."""
        return {"hits": [index + 1 for index in self.hit_indices], "hits_numbered_from": 1,
                "error_fractional": self.error_fractional.tolist(),
                "error_rational": self.error_rational.tolist(), "noise_floor": self.noise_floor.tolist(),
                "excess_fractional": self.excess_fractional.tolist(), "excess_rational": self.excess_rational.tolist(),
                "rational_vs_fractional": self.rational_vs_fractional.tolist(),
                "frf_relative_error": self.frf_relative_error, "band_hz": list(self.band_hz),
                "alias_free_error_fractional": (None if self.alias_free_error_fractional is None
                                                else self.alias_free_error_fractional.tolist())}


def band_passed(signal: np.ndarray, sample_rate_hz: float, band_hz: tuple[float, float]) -> np.ndarray:
    """``signal`` (last axis time) with everything outside ``band_hz`` removed, zero-phase (zero-padded FFT)."""
    n = signal.shape[-1]
    n_fft = scipy.fft.next_fast_len(2 * n, real=True)
    spectrum = scipy.fft.rfft(signal, n_fft, axis=-1)
    freq_hz = scipy.fft.rfftfreq(n_fft, 1.0 / sample_rate_hz)
    spectrum[..., (freq_hz < band_hz[0]) | (freq_hz > band_hz[1])] = 0.0
    return scipy.fft.irfft(spectrum, n_fft, axis=-1)[..., :n]


#: Above this condition number of A_d's eigenvectors (a nearly defective system) the simulation goes through
#: second-order sections instead of modes.
MAX_MODAL_CONDITION = 1e8


def simulate_rational(model: RationalModel, force_n: np.ndarray, sample_rate_hz: float,
                      upsampling: int = UPSAMPLING) -> np.ndarray:
    """Acceleration (m/s²) of the rational plant for sampled forces (last axis time), from rest."""
    dt = 1.0 / (upsampling * sample_rate_hz)
    a_d, b_d, c_d, d_d, _ = scipy.signal.cont2discrete(
        (model.a, model.b[:, None], model.c[None, :], np.array([[model.d]])), dt, method="foh")
    fine = scipy.signal.resample_poly(np.asarray(force_n, dtype=float), upsampling, 1, axis=-1)
    poles, modes = np.linalg.eig(a_d)
    if np.linalg.cond(modes) < MAX_MODAL_CONDITION:
        # one first-order filter per mode of the discrete system: its poles are A_d's eigenvalues as they are; the
        # transfer-function route (ss2zpk, the roots of a polynomial) put a pole of a 9-state model outside the unit
        # circle (|p| 1.004 for 0.9988) and the simulation overflowed to NaN
        b_modal = np.linalg.solve(modes, b_d[:, 0])
        c_modal = c_d[0] @ modes
        response = np.real(sum(c_i * scipy.signal.lfilter([0.0, b_i], [1.0, -pole], fine, axis=-1)
                               for pole, b_i, c_i in zip(poles, b_modal, c_modal)))
        return (response + d_d[0, 0] * fine)[..., ::upsampling]
    zeros, zpk_poles, gain = scipy.signal.ss2zpk(a_d, b_d, c_d, d_d)
    sos = scipy.signal.zpk2sos(zeros, zpk_poles, gain)
    return scipy.signal.sosfilt(sos, fine, axis=-1)[..., ::upsampling]


def frf_relative_error(fit: object, freq_hz: np.ndarray, h: np.ndarray) -> float:
    """The FRF fit's relative RMS error in its band: ``RMS(H_d − H) / RMS(|H_d|)``."""
    low, high = fit.band_hz
    keep = (freq_hz >= low) & (freq_hz <= high)
    measured = h[keep]
    residual = measured - fit.accelerance(freq_hz[keep])
    return float(np.sqrt(np.mean(np.abs(residual) ** 2) / np.mean(np.abs(measured) ** 2)))


def _relative_rms(error: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(error**2, axis=-1) / np.mean(reference**2, axis=-1))


def noise_floor(recorded: np.ndarray, simulated: np.ndarray) -> np.ndarray:
    """The sensor noise relative to each record's RMS: the RMS of the residual ``recorded − simulated`` over the
    record's last fifth, where the hit's response has decayed (so the model's own error, proportional to the
    response, is small there), divided by the RMS of the whole recording. NaN when the response has not decayed
    there (the simulated tail's RMS over a tenth of the recording's)."""
    start = int(TAIL_START_FRACTION * recorded.shape[-1])
    recorded_power = np.mean(recorded**2, axis=-1)
    residual_power = np.mean((recorded[..., start:] - simulated[..., start:]) ** 2, axis=-1)
    response_power = np.mean(simulated[..., start:] ** 2, axis=-1)
    floor = np.sqrt(residual_power / recorded_power)
    return np.where(response_power < recorded_power / 100.0, floor, np.nan)


def time_domain_check(
    spec: RigSpec,
    model: RationalModel,
    records: np.ndarray,
    sample_rate_hz: float,
    force_channel: int = 0,
    response_channel: int = 1,
    hit_indices: tuple[int, ...] | None = None,
    trigger_index: np.ndarray | None = None,
    frf_error: float | None = None,
    band_hz: tuple[float, float] | None = None,
) -> TimeDomainCheck:
    """Drive the fractional ``spec`` (a mass on the identified film) and the rational ``model`` with each record's
    force; ``records`` is (hits, channels, samples) in N and m/s². Errors in ``band_hz`` (the FRF fit's band; default
    the whole alias-free band 0–0.45·fs), and over the whole alias-free band beside them."""
    records = np.asarray(records, dtype=float)
    force = records[:, force_channel]
    alias_free_hz = (0.0, ALIAS_FREE_FRACTION * sample_rate_hz)
    band_hz = alias_free_hz if band_hz is None else (float(band_hz[0]), min(float(band_hz[1]), alias_free_hz[1]))
    raw_recorded = band_passed(records[:, response_channel], sample_rate_hz, alias_free_hz)
    raw_fractional = band_passed(simulate_response(spec, force, sample_rate_hz), sample_rate_hz, alias_free_hz)
    # one hit at a time: the 8× up-sampled force of a long session would not fit in memory at once
    rational = band_passed(np.stack([simulate_rational(model, hit, sample_rate_hz) for hit in force]),
                           sample_rate_hz, band_hz)
    recorded = band_passed(raw_recorded, sample_rate_hz, band_hz)
    fractional = band_passed(raw_fractional, sample_rate_hz, band_hz)
    check = TimeDomainCheck(
        sample_rate_hz=float(sample_rate_hz),
        band_hz=band_hz,
        hit_indices=tuple(hit_indices) if hit_indices is not None else tuple(range(len(records))),
        error_fractional=_relative_rms(recorded - fractional, recorded),
        error_rational=_relative_rms(recorded - rational, recorded),
        rational_vs_fractional=_relative_rms(rational - fractional, fractional),
        recorded=recorded, fractional=fractional, rational=rational,
        trigger_index=np.zeros(len(records), int) if trigger_index is None else np.asarray(trigger_index),
        noise_floor=noise_floor(recorded, fractional),
        frf_relative_error=frf_error,
        alias_free_error_fractional=_relative_rms(raw_recorded - raw_fractional, raw_recorded),
    )
    logger.info("time-domain check of %s on %d hits: %s", model.source.description, len(records),
                check.summary_lines()[-1])
    return check


def spec_of_fit(fit: object) -> RigSpec:
    """A rig spec of the fit alone (its film under its mass, no effects): the fractional model to simulate."""
    bounds = {parameter.name: parameter for parameter in fit.model().parameters}
    # a fitted value at its bound may sit a rounding error outside it (1e-16 relative): a spec holds it at the bound
    inside = {name: min(max(value, bounds[name].lower), bounds[name].upper) for name, value in fit.params.items()}
    return RigSpec(name=f"{fit.model_name} fit", mass_kg=fit.mass_kg, film_model=fit.network,
                   film_parameters=inside, source=f"{fit.model_name} fit")


def figure_hits(path: str | Path, check: TimeDomainCheck, max_hits: int = 4, window_s: float = 0.08) -> Path:
    """Overlay of recorded, fractional and rational acceleration for the first hits (from 5 ms before the trigger)."""
    from matplotlib.figure import Figure

    from gasfilm.analysis.figures import FAST_PNG

    count = min(max_hits, len(check.hit_indices))
    height_in = 2.6 * count + 0.6
    figure = Figure(figsize=(11, height_in))
    axes = np.atleast_1d(figure.subplots(count, 1, sharex=True))
    # fixed margins, in inches whatever the number of hits (a "tight" layout draws the figure twice)
    figure.subplots_adjust(left=0.06, right=0.985, bottom=0.5 / height_in, top=1 - 0.3 / height_in,
                           hspace=0.16)
    fs = check.sample_rate_hz
    for row, axis in enumerate(axes):
        start = max(0, int(check.trigger_index[row] - 0.005 * fs))
        stop = min(check.recorded.shape[-1], start + int(window_s * fs))
        time_ms = 1e3 * (np.arange(start, stop) - check.trigger_index[row]) / fs
        axis.plot(time_ms, check.recorded[row, start:stop], color="black", linewidth=2.0, label="recorded")
        axis.plot(time_ms, check.fractional[row, start:stop], color="tab:blue", linewidth=1.2,
                  label="fractional model")
        axis.plot(time_ms, check.rational[row, start:stop], color="tab:orange", linewidth=1.0, linestyle="--",
                  label="rational model")
        axis.set_ylabel("acceleration (m/s²)")
        floor = "" if np.isnan(check.noise_floor[row]) else f" (noise floor {100 * check.noise_floor[row]:.3g} %)"
        axis.set_title(f"hit {check.hit_indices[row] + 1}, {check.band_hz[0]:g}–{check.band_hz[1]:g} Hz: RMS error "
                       f"fractional {100 * check.error_fractional[row]:.3g} %, rational "
                       f"{100 * check.error_rational[row]:.3g} %{floor}, rational vs fractional "
                       f"{100 * check.rational_vs_fractional[row]:.3g} %", fontsize=9)
        axis.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time after the trigger (ms)")
    path = Path(path)
    figure.savefig(path, dpi=110, format="png", pil_kwargs=FAST_PNG)
    return path


def error_figure(model: RationalModel) -> Any:
    """The approximation's complex relative error of the plant and the film against frequency, band shaded."""
    from matplotlib.figure import Figure

    from gasfilm.analysis.figures import plain_log_labels

    figure = Figure(figsize=(9, 4.5))
    axis = figure.subplots()
    figure.subplots_adjust(left=0.09, right=0.975, bottom=0.11, top=0.9)  # fixed: a "tight" layout draws twice
    floor = 1e-12
    axis.loglog(model.curve_freq_hz, np.maximum(100 * model.curve_plant_error, floor), label="plant (accelerance)")
    axis.loglog(model.curve_freq_hz, np.maximum(100 * model.curve_film_error, floor), label="film (stiffness)",
                linestyle="--")
    axis.axvspan(*model.band_hz, color="tab:green", alpha=0.08, label="approximation band")
    if model.target_error:
        axis.axhline(100 * model.target_error, color="tab:red", linewidth=1.0, label="target")
    plain_log_labels(axis.xaxis)
    plain_log_labels(axis.yaxis)
    axis.set_xlabel("frequency (Hz)")
    axis.set_ylabel("|G_rational / G_fractional − 1| (%)")
    axis.set_title(f"{model.source.description}: {model.summary()}", fontsize=8, wrap=True)
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=8)
    return figure


def figure_error(path: str | Path, model: RationalModel) -> Path:
    """:func:`error_figure` written as PNG."""
    from gasfilm.analysis.figures import FAST_PNG

    path = Path(path)
    error_figure(model).savefig(path, dpi=110, format="png", pil_kwargs=FAST_PNG)
    return path
