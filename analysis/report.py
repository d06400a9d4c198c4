"""A session report an engineer can attach to a test log: setup, hits and verdicts, FRF with coherence and force
spectrum, fits (Table 2 style), stored diagnosis — as one self-contained HTML file (figures embedded as PNG) or a PDF.
Matplotlib is drawn without pyplot (no Qt, no global state).
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gasfilm.analysis.conditions import decode_conditions, format_value
from gasfilm.analysis.diagnosis.report import VERDICT_LINES, chi2_headline
from gasfilm.analysis.diagnosis.structure import mode_row_notes
from gasfilm.analysis.fit_warnings import fit_warnings
from gasfilm.analysis.paths import link_target, missing_folder, written_whole
from gasfilm.analysis.quantities import band_range, band_text, is_number, unit_suffix, unit_word, with_uncertainty
from gasfilm.analysis.session import Session
from gasfilm.analysis.session.api import LATEST_DIAGNOSIS
from gasfilm.analysis.spectra import (
    CAUTION_DROP_DB,
    USABLE_DROP_DB,
    FrfResult,
    WindowSettings,
    force_level_db,
    session_frf,
    usable_band_hz,
)
from gasfilm.drivers.errors import GasfilmError, SettingError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

logger = logging.getLogger(__name__)

REPORT_FORMATS = (".html", ".htm", ".pdf")


# --- the report's content -----------------------------------------------------------------------------------------


@dataclass
class ReportData:
    """What a report shows, read from a session file."""

    path: Path
    device_name: str
    status: str
    sample_rate_hz: float
    channels: list[dict[str, str]]
    settings: dict[str, Any]
    rig_spec_toml: str | None
    conditions: dict[str, Any]  # operating conditions (analysis/conditions.py)
    hits: list[dict[str, Any]]
    records: list[Any]  # HitRecord of every hit, in order
    frf: FrfResult | None
    frf_source: str
    fits: list[Any]  # FitResult
    comparison: list[tuple[tuple[float, float], list[Any]]]  # (fit band in Hz, ComparisonRow of its fits)
    diagnosis: dict[str, Any] | None  # the newest stored one
    diagnosis_name: str | None = None  # its name in the session (diagnoses/run-NNN)
    diagnosis_runs: int = 0  # how many diagnoses the session keeps
    fit_hits: dict[str, int | None] = field(default_factory=dict)  # hits each fit was made on
    stale: dict[str, str] = field(default_factory=dict)  # model → why its fit no longer describes the hits
    rigid_body: dict[str, Any] | None = None  # a rigid-body test's identification (gasfilm rigid), when stored


def stale_warning(data: ReportData, names: Sequence[str]) -> str | None:
    """One line for the fits among ``names`` made on fewer (or other) hits than the session accepts now."""
    stale = {name: data.stale[name] for name in names if name in data.stale}
    if not stale:
        return None
    by_note: dict[str, list[str]] = {}
    for name, note in stale.items():
        by_note.setdefault(note, []).append(name)
    which = "; ".join(f"{', '.join(models)} {note}" for note, models in by_note.items())
    return (f"stale fits: {which} — their parameters predate the hits since, while their RMS, E, AIC and BIC here are "
            f"computed on the FRF of the hits accepted now (gasfilm fit {data.path.name} --refit fits them again)")


def _rigid_lines(data: ReportData) -> list[str]:
    """The stored rigid-body identification as ``gasfilm rigid`` prints it (its fits, 3×3 terms, coupling)."""
    from gasfilm.analysis.identification.rigid import RigidIdentification

    return RigidIdentification.from_dict(data.rigid_body).summary_lines()


def fits_by_band(fits: Sequence[Any]) -> list[tuple[tuple[float, float], list[Any]]]:
    """Fits grouped by their own fit band (Hz), in the order first seen: a Table 2 compares fits of one band only."""
    groups: dict[tuple[float, float], list[Any]] = {}
    for fit in fits:
        key = (round(float(fit.band_hz[0]), 6), round(float(fit.band_hz[1]), 6))
        groups.setdefault(key, []).append(fit)
    return list(groups.items())


def band_lines(freq_hz: np.ndarray, band_hz: tuple[float, float]) -> np.ndarray:
    """The lines of a fit band as :func:`fits_by_band` keys it (its edges rounded): the lines the fit was made on."""
    slack = 1e-6 * max(1.0, abs(band_hz[1]))
    return (freq_hz >= band_hz[0] - slack) & (freq_hz <= band_hz[1] + slack)


def _device_from_settings(settings: Any) -> str:
    """The device a session was recorded on when its header has no name (older sessions): the simulator leaves its
    traces in the settings; an import names its file."""
    source = settings.get("source") if isinstance(settings, dict) else None
    if isinstance(source, dict):
        named = source.get("uff_file") or source.get("npy_files")
        if named:
            return f"none (imported from {named if isinstance(named, str) else ', '.join(map(str, named[:3]))})"
    return ""


def read_report_data(path: str | Path, frf_name: str | None = None) -> ReportData:
    """Everything the report needs from ``path`` (read only); ``frf_name``: which stored FRF (default "frf", or the
    only one)."""
    from gasfilm.analysis.fit_settings import FitHits, stale_note
    from gasfilm.analysis.identification import FitResult, compare_models

    path = Path(path)
    with Session.open(path, "r") as session:
        config = session.daq_config
        stored_sensors = session.settings.get("sensors")
        sensors = {entry.get("channel"): entry for entry in stored_sensors if isinstance(entry, dict)} \
            if isinstance(stored_sensors, list) else {}
        channels = [
            {
                "channel": channel.physical_channel,
                "name": channel.name,
                "kind": channel.kind.value,
                "sensor": str(sensors.get(channel.physical_channel, {}).get("model") or "—"),
                "serial": str(sensors.get(channel.physical_channel, {}).get("serial") or "—"),
                "calibrated": str(sensors.get(channel.physical_channel, {}).get("calibration_date") or "—"),
                "sensitivity": f"{channel.sensitivity:g} {channel.sensitivity_units}",
                "iepe": f"{channel.iepe_current_a * 1e3:g} mA" if channel.iepe_current_a else "off",
                "coupling": channel.coupling.value,
                "teds": str(sensors.get(channel.physical_channel, {}).get("teds") or "—"),
            }
            for channel in config.channels
        ]
        stored = session.hits()
        records = [hit.as_hit_record() for hit in stored]
        hits = [
            {
                "number": hit.index + 1,
                "time_s": record.trigger_time_s,
                "peak_force_n": float(np.max(np.abs(record.force_n))),
                "accepted": hit.verdict.accepted,
                "overridden": hit.verdict.overridden,
                "reasons": ", ".join(hit.verdict.reasons),
            }
            for hit, record in zip(stored, records)
        ]
        stored_frfs = session.result_names("frf")
        chosen = frf_name or ("frf" if "frf" in stored_frfs else stored_frfs[0] if len(stored_frfs) == 1 else None)
        if frf_name is not None and frf_name not in stored_frfs:
            raise SettingError(f"--frf {frf_name}: {path} holds no such FRF (it holds "
                               f"{', '.join(stored_frfs) or 'none'})")
        if chosen is not None:
            others = [name for name in stored_frfs if name != chosen]
            frf = session.read_frf(chosen)
            source = f"FRF '{chosen}' stored in the session" + (
                f" (it also holds {', '.join(repr(name) for name in others)}: gasfilm report --frf NAME shows another)"
                if others else "")
        else:
            accepted = [record for hit, record in zip(stored, records) if hit.verdict.accepted]
            window = session.settings_as("window", WindowSettings)
            frf = session_frf(accepted, window) if accepted else None
            source = "computed from the accepted hits with the session's window settings"
        stored_fits = {name: session.read_fit(name) for name in session.result_names("fits")}
        fits = [FitResult.from_dict(values) for values in stored_fits.values()]
        accepted_indices = session.accepted_indices()
        fit_hits = {fit.model_name: FitHits.of_stored(values) for fit, values in zip(fits, stored_fits.values())}
        stale = {name: note for name, hits in fit_hits.items()
                 if (note := stale_note(hits, accepted_indices)) is not None}
        comparison: list[tuple[tuple[float, float], list[Any]]] = []
        if fits and frf is not None:
            for band_hz, group in fits_by_band(fits):
                band = band_lines(frf.freq_hz, band_hz)
                comparison.append((band_hz, compare_models(group, frf.freq_hz[band], frf.h1[band])))
        newest = session.newest_diagnosis_name()
        diagnosis = None if newest is None else session.read_diagnosis(newest)
        diagnosis_runs = len([name for name in session.result_names("diagnoses") if name != LATEST_DIAGNOSIS])
        return ReportData(
            path=path,
            device_name=session.device_name or _device_from_settings(session.settings),
            status=session.status,
            sample_rate_hz=session.sample_rate_hz,
            channels=channels,
            settings=session.settings,
            rig_spec_toml=session.rig_spec_toml,
            conditions=decode_conditions(session.settings, str(path)),
            hits=hits,
            records=records,
            frf=frf,
            frf_source=source,
            fits=fits,
            comparison=comparison,
            diagnosis=diagnosis,
            diagnosis_name=newest,
            diagnosis_runs=diagnosis_runs,
            fit_hits={name: None if hits is None else hits.count for name, hits in fit_hits.items()},
            stale=stale,
            rigid_body=session.read_rigid_body(),
        )


# --- figures ------------------------------------------------------------------------------------------------------


def _new_figure(height_in: float, rows: int = 1, gap_in: float = 0.0) -> Any:
    """A 10-inch wide figure for ``rows`` panels stacked ``gap_in`` apart (room for a title, and an x label where the
    panels do not share one): fixed margins (a constrained layout took a third of the report's drawing time)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(10, height_in))
    bottom_in, top_in = 0.5, 0.35
    panels_in = height_in - bottom_in - top_in - (rows - 1) * gap_in
    figure.subplots_adjust(left=0.08, right=0.98, bottom=bottom_in / height_in, top=1.0 - top_in / height_in,
                           hspace=gap_in * rows / panels_in)
    return figure


def frf_figure(frf: FrfResult, drop_db: float = USABLE_DROP_DB) -> Any:
    """|H1| (grey outside the usable band), coherence and the force spectrum with its roll-off."""
    from gasfilm.analysis.figures import plain_log_labels

    figure = _new_figure(9, 3, gap_in=0.35)
    magnitude_axis, coherence_axis, force_axis = figure.subplots(3, 1, sharex=True)
    keep = frf.freq_hz > 0
    freq = frf.freq_hz[keep]
    low, high = usable_band_hz(frf.freq_hz, frf.gff, drop_db)
    inside = freq <= high
    magnitude = np.abs(frf.h1[keep]) / STANDARD_GRAVITY_M_S2
    magnitude_axis.semilogy(freq, np.where(inside, np.nan, magnitude), color="#bbbbbb", lw=1.0,
                            label="outside the usable band")
    magnitude_axis.semilogy(freq, np.where(inside, magnitude, np.nan), color="black", lw=1.2, label="H1")
    magnitude_axis.set_ylabel("|H1| (g/N)")
    plain_log_labels(magnitude_axis.yaxis)
    magnitude_axis.set_title(f"Accelerance H1, {frf.n_averages} averages")
    coherence_axis.plot(freq, frf.coherence[keep], color="#009E73", lw=1.0)
    coherence_axis.set_ylim(0, 1.05)
    coherence_axis.set_ylabel("coherence γ² (1)")
    level = force_level_db(frf.freq_hz, frf.gff)[keep]
    force_axis.plot(freq, level, color="#0072B2", lw=1.0, label="force autospectrum")
    for drop, style in ((CAUTION_DROP_DB, ":"), (drop_db, "--")):
        force_axis.axhline(-drop, color="#b3261e", ls=style, lw=0.8, label=f"−{drop:g} dB")
    force_axis.set_ylim(max(-60.0, float(np.nanmin(level)) - 3.0) if np.isfinite(np.nanmin(level)) else -60.0, 6.0)
    force_axis.set_ylabel("force level (dB re low f)")
    force_axis.set_xlabel("frequency (Hz)")
    for axis in (magnitude_axis, coherence_axis, force_axis):
        axis.axvspan(low, high, color="#0072B2", alpha=0.06, lw=0)
        axis.grid(True, alpha=0.3)
    magnitude_axis.legend(fontsize=8, loc="lower right")
    force_axis.legend(fontsize=8, loc="lower left")
    force_axis.set_title(f"Force spectrum: usable band {low:.3g}–{high:.4g} Hz (within {drop_db:g} dB)")
    return figure


def hits_figure(records: Sequence[Any], accepted: Sequence[bool]) -> Any:
    """Every hit's force pulse and response overlaid (accepted in colour, rejected in grey), aligned at the trigger."""
    figure = _new_figure(6, 2, gap_in=0.75)
    force_axis, response_axis = figure.subplots(2, 1)
    for record, ok in zip(records, accepted):
        t_ms = (np.arange(record.n_samples) - record.trigger_index) / record.sample_rate_hz * 1e3
        style = {"lw": 0.8, "alpha": 0.8} if ok else {"lw": 0.6, "color": "#bbbbbb", "zorder": 0}
        pulse = (t_ms >= -2.0) & (t_ms <= 10.0)
        force_axis.plot(t_ms[pulse], record.force_n[pulse], **style)
        response_axis.plot(t_ms / 1e3, record.response, **style)
    force_axis.set_xlabel("time from trigger (ms)")
    force_axis.set_ylabel("force (N)")
    force_axis.set_title("Force pulses (accepted in colour, rejected grey)")
    response_axis.set_xlabel("time from trigger (s)")
    response_axis.set_ylabel("acceleration (m/s²)")
    response_axis.set_title("Responses")
    for axis in (force_axis, response_axis):
        axis.grid(True, alpha=0.3)
    return figure


def fits_figure(frf: FrfResult, fits: Sequence[Any]) -> Any:
    """Measured |H1| and every fitted model over the fit band, in g/N."""
    from gasfilm.analysis.figures import plain_log_labels

    figure = _new_figure(4.5)
    axis = figure.subplots()
    low = min(fit.band_hz[0] for fit in fits)
    high = max(fit.band_hz[1] for fit in fits)
    band = (frf.freq_hz >= low) & (frf.freq_hz <= high) & (frf.freq_hz > 0)
    freq = frf.freq_hz[band]
    axis.semilogy(freq, np.abs(frf.h1[band]) / STANDARD_GRAVITY_M_S2, color="black", lw=2.0, label="measured")
    several = len(fits_by_band(fits)) > 1
    for fit in fits:
        own = freq[(freq >= fit.band_hz[0]) & (freq <= fit.band_hz[1])]
        label = fit.model_name + (f" ({fit.band_hz[0]:g}–{fit.band_hz[1]:g} Hz)" if several else "")
        axis.semilogy(own, np.abs(fit.accelerance(own)) / STANDARD_GRAVITY_M_S2, lw=1.0, label=label)
    axis.set_xlabel("frequency (Hz)")
    axis.set_ylabel("|H| (g/N)")
    plain_log_labels(axis.yaxis)
    axis.set_title(f"Fitted models, each over its own band ({low:g}–{high:g} Hz)" if several
                   else f"Fitted models, band {low:g}–{high:g} Hz")
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=8, ncol=3)
    return figure


def _png_base64(figure: Any) -> str:
    from gasfilm.analysis.figures import FAST_PNG

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100, pil_kwargs=FAST_PNG)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


# --- HTML ---------------------------------------------------------------------------------------------------------


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    head = "".join(f"<th>{html.escape(str(cell))}</th>" for cell in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(cell))}</td>" for cell in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _settings_rows(settings: dict[str, Any]) -> list[tuple[str, str, str]]:
    """The trigger, window and validation settings in words, each value with its unit."""
    from gasfilm.analysis.settings import describe_setting

    rows = []
    for group in ("trigger", "window", "validation"):
        values = settings.get(group)
        if isinstance(values, dict):
            for key, value in values.items():
                label, text = describe_setting(group, key, value)
                rows.append((group, label, text))
    return rows


def _percent(value: float | None) -> str:
    return "—" if value is None else f"{value:.2f} %"


def _sigma_text(fit: Any, name: str) -> str:
    """A parameter's 1-σ uncertainty, or "—" with the reason there is none."""
    std = fit.std_errors.get(name)
    if name in fit.at_bound:
        return "— (at its search bound: not a measurement)"
    if std is None or not np.isfinite(std):
        return "— (not estimated: the fit's Jacobian does not determine it)"
    return f"{std:.2g}"


def _hits_cell(data: ReportData, name: str) -> str:
    """The hits a fit was made on, for Table 2: "10", or "4 (stale)" (the warning above the table says more)."""
    count = data.fit_hits.get(name)
    text = "not recorded" if count is None else str(count)
    return f"{text} (stale)" if name in data.stale else text


def band_warnings(data: ReportData, band_hz: tuple[float, float]) -> list[str]:
    """The warnings ``gasfilm fit`` gives for the fits over ``band_hz`` (a structure that is not a mass on a film,
    resonances no film model explains), judged on the report's FRF."""
    if data.frf is None:
        return []
    masses = [fit.mass_kg for fit in data.fits
              if (round(fit.band_hz[0], 6), round(fit.band_hz[1], 6)) == band_hz]
    return fit_warnings(data.frf, band_lines(data.frf.freq_hz, band_hz), masses)


def _fits_html(data: ReportData) -> str:
    from gasfilm.analysis.identification import best_by_bic

    if not data.fits:
        return "<p>No fits stored in the session (run <code>gasfilm fit</code> or the GUI's Identify tab).</p>"
    g = STANDARD_GRAVITY_M_S2
    parts = []
    for (low, high), rows in data.comparison:
        band_fits = [fit for fit in data.fits if (round(fit.band_hz[0], 6), round(fit.band_hz[1], 6)) == (low, high)]
        masses = sorted({(fit.mass_kg, fit.mass_fitted) for fit in band_fits})
        mass_text = ", ".join(f"{mass:g} kg{' (fitted)' if fitted else ''}" for mass, fitted in masses)
        parts.append(f"<p>Band {low:g}–{high:g} Hz ({len(rows)} model{'s' if len(rows) != 1 else ''}), mover mass "
                     f"{mass_text}. E and E_m: improvement over SD (eq. 35) fitted over the same band.</p>")
        given = sorted({mass for mass, fitted in masses if not fitted})
        if len(given) > 1:  # (new-user trial: SD at 25.05 kg beside eight models at 25 050 kg, E = −471 %)
            by_mass = {mass: sorted(fit.model_name for fit in band_fits if fit.mass_kg == mass and not fit.mass_fitted)
                       for mass in given}
            parts.append("<p class='warning'>Warning: these fits were made with different mover masses ("
                         + "; ".join(f"{mass:g} kg: {', '.join(names)}" for mass, names in by_mass.items())
                         + "): their RMS, E and E_m compare unlike fits; refit them with one mass (gasfilm fit "
                           "--mass M --overwrite)</p>")
        parts.extend(f"<p class='warning'>Warning: {html.escape(warning)}</p>"
                     for warning in band_warnings(data, (low, high)))
        stale = stale_warning(data, [row.model_name for row in rows])
        if stale:
            parts.append(f"<p class='warning'>Warning: {html.escape(stale)}</p>")
        best = best_by_bic(rows)
        parts.append(_table(
            ("#", "Model", "Parameters (count)", "RMS (g/N)", "E (%)", "Peak error (g/N)", "E_m (%)", "AIC (1)",
             "BIC (1)", "Hits (count)"),
            [
                (row.rank, row.model_name, row.n_parameters, f"{row.rms / g:.4g}", _percent(row.e_percent),
                 f"{row.peak_error / g:.4g}", _percent(row.e_m_percent), f"{row.aic:.1f}",
                 f"{row.bic:.1f}{' *' if row is best and len(rows) > 1 else ''}", _hits_cell(data, row.model_name))
                for row in rows
            ],
        ))
        if best is not None and len(rows) > 1:
            parts.append(f"<p>Ranked by RMS; * lowest BIC: {html.escape(best.model_name)}, the model the data "
                         f"support best.</p>")
    parameter_rows = []
    units_of = {}
    for fit in data.fits:
        try:
            units_of = {parameter.name: parameter.unit for parameter in fit.model().parameters}
        except GasfilmError:
            units_of = {}
        for name, value in fit.params.items():
            parameter_rows.append((fit.model_name, f"{fit.band_hz[0]:g}–{fit.band_hz[1]:g}", name,
                                   f"{value:.5g}{unit_suffix(units_of.get(name, ''))}", _sigma_text(fit, name)))
    flags = [f"<li><b>{html.escape(fit.model_name)}</b> ({fit.band_hz[0]:g}–{fit.band_hz[1]:g} Hz): "
             f"{html.escape('; '.join(fit.notes + fit.flags))}</li>" for fit in data.fits if fit.flags or fit.notes]
    return (
        "".join(parts)
        + "<h3>Identified parameters (each with its unit; ±1σ in the same unit)</h3>"
        + _table(("Model", "Fit band (Hz)", "Parameter", "Value", "±1σ"), parameter_rows)
        + (f"<p>Notes and flags (once per model):</p><ul>{''.join(flags)}</ul>" if flags else "")
    )


def control_models(data: ReportData) -> list[tuple[Any, Any]]:
    """Each stored fit with its rational model for control design within 0.5 % (or the reason there is none)."""
    from gasfilm.analysis.control import DEFAULT_MAX_ERROR, PlantSource, approximate

    ranked = [row.model_name for _band, rows in data.comparison for row in rows]
    order = ranked or [fit.model_name for fit in data.fits]
    fits = {fit.model_name: fit for fit in data.fits}
    models = []
    for name in order:
        try:
            models.append((fits[name], approximate(PlantSource.from_fit(fits[name]), max_error=DEFAULT_MAX_ERROR)))
        except GasfilmError as error:
            models.append((fits[name], str(error)))
    return models


def _control_html(models: list[tuple[Any, Any]]) -> str:
    if not models:
        return "<p>No fits stored: nothing to approximate.</p>"
    from gasfilm.analysis.control.timedomain import error_figure

    rows = []
    for fit, model in models:
        if isinstance(model, str):
            rows.append((fit.model_name, "—", "—", "—", "—", "—", html.escape(model)))
            continue
        rows.append((fit.model_name, model.order, f"{100 * model.max_error_band:.3g}",
                     f"{100 * model.max_error_outside:.3g}", "yes" if model.stable else "NO",
                     "yes" if model.passive.passed else "NO",
                     "" if model.storage.passed else "storage stiffness Re Z < 0 somewhere"
                     + (" (as in the fractional film)" if model.source_storage_minimum < 0 else "")))
    best = next((model for _fit, model in models if not isinstance(model, str)), None)
    figure = "" if best is None else (
        f"<img alt='rational model error' src='data:image/png;base64,{_png_base64(error_figure(best))}'>")
    band = next((m.band_hz for _f, m in models if not isinstance(m, str)), None)
    where = f" over {band[0]:g}–{band[1]:g} Hz (a decade beyond the fitted band)" if band else ""
    return (
        f"<p>Each fit as a rational state-space plant (force → acceleration) for control design: the lowest order "
        f"within 0.5 % complex relative error of the fractional model{where}, by vector fitting; exported with "
        f"<code>gasfilm model SESSION --model NAME --out plant.json|.mat|.npz</code> (docs/control.md).</p>"
        + _table(("Model", "States (1)", "Max error in band (%)", "Max error outside (%)", "Stable", "Film passive",
                  "Note"), rows)
        + figure
    )


def diagnosis_options_text(options: Any) -> str:
    """How a stored diagnosis was run, in words: its rig spec, mass and band (the flags of ``gasfilm diagnose``)."""
    if not isinstance(options, dict):
        return "options not recorded (stored by an older gasfilm)"
    by = "the GUI's Diagnose tab" if options.get("command") == "GUI" else "gasfilm diagnose"
    rig = options.get("rig")
    mass = options.get("mass_kg")
    band = options.get("band_hz")
    band_flag = (f"--band {band[0]:g}:{band[1]:g} Hz" if isinstance(band, (list, tuple)) and len(band) == 2
                 and all(is_number(edge) for edge in band) else "the default band (where the hammer excites)")
    return (f"{by}, " + (f"--rig {rig}" if rig else "the session's own rig spec (else one read off the FRF)")
            + ", " + (f"--mass {mass:g} kg" if is_number(mass) else "the spec's mass") + f", {band_flag}")


def _diagnosis_html(diagnosis: dict[str, Any] | None, name: str | None = None, runs: int = 0, frf: Any = None) -> str:
    if diagnosis is None:
        return "<p>No diagnosis stored in the session (run <code>gasfilm diagnose</code> or the GUI's Diagnose tab).</p>"
    kept = f" ({runs} stored; earlier runs are kept in the session)" if runs > 1 else ""
    verdict = str(diagnosis.get("verdict", "?"))
    parts = [f"<p>The newest diagnosis, <code>diagnoses/{html.escape(str(name))}</code>{kept}: run by "
             f"{html.escape(diagnosis_options_text(diagnosis.get('options')))}.</p>" if name else "",
             f"<p>Verdict: <b>{html.escape(verdict)}</b>"]
    if verdict in VERDICT_LINES:
        parts.append(f" — {html.escape(VERDICT_LINES[verdict])}.")
    if is_number(diagnosis.get("chi2_per_point_before")) and is_number(diagnosis.get("chi2_per_point_after")):
        headline = chi2_headline(diagnosis["chi2_per_point_before"], diagnosis["chi2_per_point_after"])
        parts.append(f" <b>{html.escape(headline)}</b>.")
    if "rms_before_g_per_n" in diagnosis and "rms_after_g_per_n" in diagnosis:
        parts.append(
            f" RMS {diagnosis['rms_before_g_per_n']:.4g} g/N with the given spec, "
            f"{diagnosis['rms_after_g_per_n']:.4g} g/N with the improved spec "
            + (f"(E {diagnosis['e_percent']:.1f} %)" if is_number(diagnosis.get("e_percent")) else "")
        )
    parts.append("</p>")
    noise = diagnosis.get("noise")
    if isinstance(noise, dict) and noise.get("source"):
        parts.append(f"<p>Noise: {html.escape(str(noise['source']))}"
                     + (f" — {html.escape(str(noise['detail']))}" if noise.get("detail") else "") + "</p>")
    findings = diagnosis.get("findings") or []
    if findings:
        rows = []
        for finding in findings:
            band = finding.get("band_hz")
            where = finding.get("where") or (band_text(*band) if _is_band(band) else "?")
            values = "; ".join(_parameter_text(name, entry)
                               for name, entry in (finding.get("parameters") or {}).items())
            mechanisms = [m.get("name", "") for m in finding.get("mechanisms") or [] if isinstance(m, dict)]
            status = finding.get("status", "named")
            named = (f"{'named' if status == 'named' else 'modelled; likely'}: {mechanisms[0]}"
                     + (f" (also consistent: {'; '.join(mechanisms[1:])})" if mechanisms[1:] else "")
                     if mechanisms else status)
            place = finding.get("place") or ""
            rows.append((finding.get("effect", "?"), f"{place}: {where}" if place else where, values, named,
                         finding.get("evidence", "")))
        parts.append(_table(("Effect", "Where", "Parameters", "Mechanism", "Evidence"), rows))
    elif verdict in NOTHING_MISSING:
        parts.append("<p>No missing physics found.</p>")
    unexplained = [item for item in diagnosis.get("unexplained") or [] if isinstance(item, dict)]
    if unexplained:
        first_hit = diagnosis.get("hits_numbered_from", 0)
        parts.append("<h3>NOT explained</h3>")
        parts.append(_table(
            ("Band (Hz)", "Hits (from 1)", "Share of the excess χ² (%)", "Character",
             "Resonances the spec lacks (Hz)", "Partial descriptions (not findings)"),
            [(_band_text(item.get("band_hz")), _hits_text(item.get("hits"), first_hit),
              _number_text(100 * item["chi2_share"] if is_number(item.get("chi2_share")) else None, ".1f"),
              item.get("character", ""),
              ", ".join(f"{f:.0f}" for f in item.get("unmodelled_resonances_hz") or [] if is_number(f)) or "—",
              ", ".join(str(c.get("effect", "?")) for c in item.get("candidates") or [] if isinstance(c, dict))
              or "—")
             for item in unexplained],
        ))
    recalibration = diagnosis.get("recalibration") or {}
    if recalibration:
        parts.append("<h3>Recalibrated spec parameters (SI)</h3>")
        parts.append(_table(
            ("Parameter", "Spec", "Fitted", "±1σ", "Unit"),
            [(name, _number_text(v.get("spec"), ".5g"), _number_text(v.get("fitted"), ".5g"),
              "at its bound: not a measurement" if v.get("at_bound") else _number_text(v.get("uncertainty"), ".2g",
                                                                                        NO_SIGMA),
              unit_word(v.get("unit")))
             for name, v in recalibration.items()
             if isinstance(v, dict)],
        ))
    structure = diagnosis.get("structure")
    if isinstance(structure, dict) and structure.get("modes"):
        parts.append(_structure_html(structure, frf))
    notes = [quality_note_text(note, diagnosis.get("hits_numbered_from", 0)) for note in diagnosis.get("quality") or []]
    if notes:
        parts.append("<h3>Measurement quality</h3><ul>"
                     + "".join(f"<li class='note'>{html.escape(note)}</li>" for note in notes) + "</ul>")
    return "".join(parts)


def _structure_html(structure: dict[str, Any], frf: Any = None) -> str:
    """The measured structure of a stored diagnosis: its stabilization diagram (when it was read off the FRF, drawn
    over the session's H1) and the mode table of the improved spec, by frequency."""
    parts = ["<h3>Measured structure: modes</h3>"]
    read = structure.get("read_off_frf")
    if isinstance(read, dict) and isinstance(read.get("stabilization"), dict):
        from gasfilm.analysis.diagnosis.plots import stabilization_figure

        kind = "a driving point" if read.get("driving_point") else "a transfer FRF (modal constants of both signs)"
        parts.append(f"<p>Read off the FRF as modal analysis reads it: LSCF over {read.get('lscf_orders')} model orders, "
                     f"modes where poles are stable in frequency, damping and participation; {kind}, polarity "
                     f"{read.get('polarity', 1):+d}, mass line {_number_text(read.get('mass_line_kg'), '.4g')} kg.</p>")
        try:
            figure = stabilization_figure(read, None if frf is None else np.asarray(frf.freq_hz),
                                          None if frf is None else np.abs(np.asarray(frf.h1)))
            parts.append(f"<img alt='stabilization diagram' src='data:image/png;base64,{_png_base64(figure)}'>")
        except (KeyError, TypeError, ValueError):  # a reading stored by another version: the table still shows
            pass
    rows = [row for row in structure["modes"] if isinstance(row, dict)]
    parts.append(_table(
        ("#", "Frequency (Hz)", "Damping ratio", "Modal constant (1/kg)", "Quadrature (1/kg)", ""),
        [(str(number), _number_text(row.get("freq_hz"), ".2f"), _number_text(row.get("damping_ratio"), ".3g"),
          _number_text(row.get("modal_constant_per_kg"), "+.4g"), _number_text(row.get("quadrature_per_kg"), "+.3g"),
          mode_row_notes(row))
         for number, row in enumerate(sorted(rows, key=lambda row: row.get("freq_hz", 0.0)), start=1)]))
    return "".join(parts)


#: The verdicts under which nothing is missing from the spec.
NOTHING_MISSING = ("consistent", "parameters-only")


def _band_text(band: Any) -> str:
    """A stored band's ends for a column headed "(Hz)", its width shown (:func:`band_range`); "?" when not stored."""
    return band_range(*band) if _is_band(band) else "?"


def _is_band(band: Any) -> bool:
    """Whether a stored band is one: two finite numbers."""
    return isinstance(band, (list, tuple)) and len(band) == 2 and all(is_number(edge) for edge in band)


def _hits_text(hits: Any, first_hit: int = 1) -> str:
    """Stored hit numbers as the user sees them, from 1 (``first_hit``: what the stored numbers start from)."""
    if not isinstance(hits, (list, tuple)) or not hits:
        return "—"
    shown = [str(int(hit) + 1 - first_hit) for hit in hits if is_number(hit)]
    return ", ".join(shown[:12]) + (" …" if len(shown) > 12 else "")


#: Shown for an uncertainty the diagnosis could not estimate.
NO_SIGMA = "— (not estimated)"


def _number_text(value: Any, spec: str, missing: str = "—") -> str:
    return format(value, spec) if is_number(value) else missing


def _parameter_text(name: str, entry: Any) -> str:
    if not (isinstance(entry, dict) and is_number(entry.get("value"))):
        return f"{name} = {entry}"
    return f"{name} = {with_uncertainty(entry['value'], entry.get('uncertainty'), entry.get('unit'), '.4g')}"


def quality_note_text(note: Any, first_hit: int = 1) -> str:
    """A stored measurement-quality note (kind, message, band, hits) as one readable sentence; ``first_hit``: the
    number the stored hits start from (diagnoses stored before they were numbered from 1 counted from 0)."""
    if not isinstance(note, dict):
        return str(note)
    text = f"{str(note.get('kind') or 'note').capitalize()}: {note.get('message') or note.get('text') or ''}".rstrip()
    band = note.get("band_hz")
    if _is_band(band):
        text += f" ({band_text(*band)})"
    hits = note.get("hits")
    if isinstance(hits, (list, tuple)) and hits:
        shown = ", ".join(str(int(hit) + 1 - first_hit) for hit in hits[:12]) + (" …" if len(hits) > 12 else "")
        text += f"; hit{'s' if len(hits) > 1 else ''} {shown}"
    return text


_STYLE = """
body { font-family: sans-serif; max-width: 1050px; margin: 2em auto; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 2px 8px; text-align: left; }
th { background: #f0f0f0; } img { max-width: 100%; } .rejected { color: #b3261e; } .note { color: #a66300; }
.warning { color: #b3261e; font-weight: bold; }
pre { background: #f7f7f7; padding: 6px; font-size: 0.85em; overflow-x: auto; }
"""


def _test_html(test: Any) -> str:
    """Who tested what (``settings["test"]``), or that the session does not say."""
    test = test if isinstance(test, dict) else {}
    operator, test_object = str(test.get("operator") or ""), str(test.get("test_object") or "")
    if not operator and not test_object:
        return ("<p>Operator and test object: not given (the GUI's Setup tab, or gasfilm acquire --operator NAME "
                "--test-object TEXT).</p>")
    return (f"<p>Operator <b>{html.escape(operator or '—')}</b>; test object "
            f"<b>{html.escape(test_object or '—')}</b>.</p>")


#: The paper sizes a report is laid out on: ``--paper`` value → CSS page size.
PAPER_SIZES = {"a4": "A4", "letter": "letter"}
#: Territories whose locales print on US Letter (glibc's LC_PAPER); everywhere else A4.
LETTER_TERRITORIES = frozenset({"US", "CA", "MX", "PR", "CL", "CO", "CR", "GT", "NI", "PA", "PH", "SV", "VE", "DO",
                                "BZ"})


def default_paper() -> str:
    """"letter" or "a4" as this machine prints: the PAPERSIZE variable, else /etc/papersize (libpaper), else the
    locale's territory (LC_ALL, LC_PAPER, LANG: en_US → letter, de_DE → A4); A4 when none says."""
    named = os.environ.get("PAPERSIZE", "").strip().lower()
    if not named:
        try:
            named = Path("/etc/papersize").read_text(encoding="utf-8").split("#")[0].strip().lower()
        except (OSError, UnicodeDecodeError):
            named = ""
    if named in PAPER_SIZES:
        return named
    for variable in ("LC_ALL", "LC_PAPER", "LANG"):
        value = os.environ.get(variable, "")
        if value:
            territory = value.split(".")[0].split("@")[0].partition("_")[2].upper()
            return "letter" if territory in LETTER_TERRITORIES else "a4"
    return "a4"


#: Print layout: the page, its margins and number, figures and tables to the page's width, no row split over pages.
_PRINT_STYLE = """
@page { size: PAPER; margin: 14mm 12mm 16mm 12mm;
        @bottom-right { content: "page " counter(page) " of " counter(pages); font-size: 8pt; color: #666; } }
@media print {
  body { max-width: none; margin: 0; font-size: 9pt; }
  h1 { font-size: 15pt; } h2 { font-size: 12pt; break-after: avoid; } h3 { font-size: 10pt; break-after: avoid; }
  table { font-size: 7.5pt; max-width: 100%; } th, td { overflow-wrap: anywhere; padding: 1px 4px; }
  tr, img { break-inside: avoid; } img { width: 100%; }
  pre { white-space: pre-wrap; overflow-wrap: anywhere; font-size: 7pt; }
}
"""


def report_html(data: ReportData, drop_db: float = USABLE_DROP_DB, paper: str | None = None) -> str:
    """The report as one self-contained HTML page; printed (or made a PDF) on ``paper`` ("a4" or "letter"; default
    :func:`default_paper`)."""
    accepted = [hit["accepted"] for hit in data.hits]
    sections = [
        f"<h1>gasfilm session report</h1><p>Session <code>{html.escape(str(data.path))}</code>; "
        f"written {datetime.datetime.now().astimezone().strftime('%Y-%m-%d %H:%M %Z')}.</p>",
        "<h2>Setup</h2>",
        f"<p>Device <b>{html.escape(data.device_name or 'not recorded')}</b>, {data.sample_rate_hz:g} S/s, session status "
        f"{html.escape(data.status)}.</p>",
        _test_html(data.settings.get("test")),
        _table(("Channel", "Name", "Type", "Sensor", "Serial", "Calibrated", "Sensitivity", "IEPE", "Coupling",
                "TEDS"), [tuple(c.values()) for c in data.channels]),
        _table(("Group", "Setting", "Value"), _settings_rows(data.settings)),
        "<h3>Operating conditions</h3>",
        _table(("Condition (unit in the name)", "Value"),
               [(key, format_value(key, value).split(" = ", 1)[1]) for key, value in data.conditions.items()])
        if data.conditions else "<p>No operating conditions recorded with this session.</p>",
    ]
    if data.rig_spec_toml:
        sections.append(f"<details><summary>Rig spec</summary><pre>{html.escape(data.rig_spec_toml)}</pre></details>")
    sections.append(f"<h2>Hits: {sum(accepted)} accepted of {len(data.hits)}</h2>")
    sections.append(_table(
        ("Hit", "Time (s)", "Peak force (N)", "Verdict", "Reasons"),
        [(h["number"], f"{h['time_s']:.2f}", f"{h['peak_force_n']:.0f}",
          ("accepted" if h["accepted"] else "rejected") + (" (by hand)" if h["overridden"] else "")
          + (", flagged (a recording from elsewhere, kept)" if h["accepted"] and h["reasons"] and not h["overridden"]
             else ""),
          h["reasons"] or "—") for h in data.hits],
    ))
    if data.records:
        sections.append(f"<img alt='hits' src='data:image/png;base64,{_png_base64(hits_figure(data.records, accepted))}'>")
    sections.append("<h2>FRF, coherence and force spectrum</h2>")
    if data.frf is None:
        sections.append("<p>No FRF: the session has no accepted hit.</p>")
    else:
        low, high = usable_band_hz(data.frf.freq_hz, data.frf.gff, drop_db)
        sections.append(
            f"<p>H1 of {data.frf.n_averages} averages, {data.frf_source}; Δf {data.frf.freq_hz[1]:.3g} Hz. "
            f"Usable band (force spectrum within {drop_db:g} dB of its low-frequency level): "
            f"{low:.3g}–{high:.4g} Hz; H1 outside it is drawn grey.</p>"
        )
        sections.append(f"<img alt='FRF' src='data:image/png;base64,{_png_base64(frf_figure(data.frf, drop_db))}'>")
    sections.append("<h2>Identified models (Table 2)</h2>")
    sections.append(_fits_html(data))
    if data.fits and data.frf is not None:
        sections.append(f"<img alt='fits' src='data:image/png;base64,{_png_base64(fits_figure(data.frf, data.fits))}'>")
    if data.rigid_body is not None:
        sections.append("<h2>Rigid body: heave, roll and pitch (gasfilm rigid)</h2>")
        sections.append(f"<pre>{html.escape(chr(10).join(_rigid_lines(data)))}</pre>")
    sections.append("<h2>Control design: rational models</h2>")
    sections.append(_control_html(control_models(data)))
    sections.append("<h2>Diagnosis</h2>")
    sections.append(_diagnosis_html(data.diagnosis, data.diagnosis_name, data.diagnosis_runs, data.frf))
    title = html.escape(f"gasfilm report — {data.path.name}")
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{title}</title><style>{_STYLE}"
        f"{_PRINT_STYLE.replace('PAPER', PAPER_SIZES[paper or default_paper()])}</style></head>"
        f"<body>{''.join(sections)}</body></html>\n"
    )


def _report_pdf(data: ReportData, drop_db: float, paper: str) -> bytes:
    """The HTML report laid out on ``paper`` pages by WeasyPrint: the same sections, tables and figures."""
    import weasyprint

    quiet = logging.getLogger("weasyprint"), logging.getLogger("fontTools")
    levels = [log.level for log in quiet]
    for log in quiet:  # its notes on CSS it skips are not the user's business
        log.setLevel(logging.ERROR)
    try:
        return weasyprint.HTML(string=report_html(data, drop_db, paper), base_url=str(data.path.parent)).write_pdf()
    finally:
        for log, level in zip(quiet, levels):
            log.setLevel(level)


def check_report_path(out: str | Path, overwrite: bool, flag: str = "--out") -> Path:
    """Refuse an unknown format, a missing folder, or an existing file unless ``overwrite``; one line naming it."""
    out = Path(out)
    if out.is_dir():
        raise SettingError(f"{flag} {out}: is a folder; name the report file in it, e.g. {out / 'report.html'}")
    if out.suffix.lower() not in REPORT_FORMATS:
        raise SettingError(f"{flag} {out}: the report is written as .html or .pdf")
    if not link_target(out).parent.is_dir():
        raise SettingError(f"{flag} {out}: {missing_folder(link_target(out).parent)}")
    if out.exists() and not overwrite:
        raise SettingError(f"{flag} {out}: the file exists; add --overwrite to replace it")
    if out.is_dir():
        raise SettingError(f"{flag} {out}: is a folder")
    return out


def write_report(
    session_path: str | Path, out: str | Path, overwrite: bool = False, drop_db: float = USABLE_DROP_DB,
    paper: str | None = None, frf_name: str | None = None,
) -> Path:
    """Write the report of ``session_path`` to ``out`` (.html or .pdf); never replace a file unless ``overwrite``
    (then whole or not at all; a symbolic link is followed: the file it points to is replaced, the link kept)."""
    out = check_report_path(out, overwrite)
    paper = paper or default_paper()
    data = read_report_data(session_path, frf_name)
    if out.suffix.lower() == ".pdf":
        content = _report_pdf(data, drop_db, paper)
    else:
        content = report_html(data, drop_db, paper).encode("utf-8")
    with written_whole(out, what="the report") as (building,):  # a full disk leaves no partial file
        building.write_bytes(content)
    logger.info("report of %s written to %s", session_path, out)
    return out
