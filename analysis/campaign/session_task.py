"""One session of a campaign, as one task: read it, average its FRF, fit the nine models, diagnose it — one row.

:func:`analyse_session` runs on a dask worker with the session's *path* (the file is read there, inside the task,
never shipped through the scheduler). It never raises: a session that cannot be analysed gives a row whose
``error`` is one line saying why, so the campaign goes on. Everything it computes goes through the project's own
entry points: :func:`gasfilm.analysis.spectra.session_frf`, :func:`gasfilm.analysis.identification.fit_model` /
``compare_models`` and :func:`gasfilm.analysis.diagnosis.diagnose`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import re
import resource
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

logger = logging.getLogger(__name__)

#: Bumped when the content or meaning of a row changes: cached rows of another version are computed again.
ROW_VERSION = 2
#: The default identification band in Hz (capped at 0.45·fs, the module's alias-free band), as ``gasfilm fit``'s.
DEFAULT_BAND_HZ = (20.0, 1000.0)
#: Columns that depend on where and how fast a task ran, not on the session (left out when comparing runs).
RUN_COLUMNS = ("seconds", "cpu_seconds", "worker_peak_rss_mb", "worker", "cached")


@dataclass(frozen=True)
class CampaignOptions:
    """What is computed for every session (part of the cache key): fitted models, fitter, band, diagnosis."""

    models: tuple[str, ...] = ("SD", "FOZGF", "Zener", "FOMGF", "Maxwell", "FOTGF", "FOBGF", "TGF", "BGF")
    method: str = "default"
    band_hz: tuple[float, float] | None = None  # None: DEFAULT_BAND_HZ capped at 0.45·fs
    diagnose: bool = True
    rig_spec_toml: str | None = None  # diagnose against this spec (at each session's conditions), else the session's
    seed: int = 0

    def fingerprint(self) -> str:
        """A text that changes whenever a row would (the cache key's options part)."""
        return repr((ROW_VERSION, dataclasses.astuple(self)))


def condition_column(key: str) -> str:
    return f"condition.{key}"


def parameter_column(model: str, name: str, unit: str) -> str:
    return f"{model}.{name} [{unit}]"


def sigma_column(model: str, name: str, unit: str) -> str:
    return f"{model}.{name} sigma [{unit}]"


def spec_column(name: str, unit: str) -> str:
    """The rig spec's film parameter at the session's conditions (the law's value when the spec has laws)."""
    return f"spec.{name} [{unit}]"


def _one_line(error: BaseException, limit: int = 300) -> str:
    text = re.sub(r"\s+", " ", str(error)).strip() or type(error).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _peak_rss_mb() -> float:
    """This process's peak resident memory in MB (Linux reports kB, macOS bytes)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 1e6 if sys.platform == "darwin" else peak / 1e3


def analyse_session(path: str, options: CampaignOptions = CampaignOptions()) -> dict[str, Any]:
    """The campaign row of the session at ``path`` (``error`` holds one line when it could not be analysed)."""
    from gasfilm.drivers.errors import GasfilmError

    started, started_cpu = time.perf_counter(), time.process_time()
    row: dict[str, Any] = {"session": str(path), "error": None}
    try:
        row.update(_analyse(Path(path), options))
    except GasfilmError as error:
        row["error"] = _one_line(error)
    except MemoryError:
        row["error"] = f"{path}: out of memory while analysing the session"
    except Exception as error:  # a bug or an unforeseen damage: still one row with one line, the campaign goes on
        logger.exception("%s: internal error", path)
        row["error"] = f"{path}: internal error: {type(error).__name__}: {_one_line(error)}"
    row["seconds"] = time.perf_counter() - started
    row["cpu_seconds"] = time.process_time() - started_cpu
    row["worker_peak_rss_mb"] = _peak_rss_mb()
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def _analyse(path: Path, options: CampaignOptions) -> dict[str, Any]:
    import numpy as np

    from gasfilm.analysis.conditions import condition_unit, decode_conditions
    from gasfilm.analysis.diagnosis import diagnose, load_recordings
    from gasfilm.analysis.fit_settings import FitHits, stale_note
    from gasfilm.analysis.diagnosis.parallel import worker_processes
    from gasfilm.analysis.fit_warnings import fit_warnings
    from gasfilm.analysis.identification import best_by_bic, compare_models, fit_model
    from gasfilm.analysis.physics.elements import PAPER_MASS_KG, get_model
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.quantities import band_text
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings, session_frf
    from gasfilm.drivers.errors import SettingError

    if path.suffix.lower() in (".uff", ".unv", ".npy"):
        raise SettingError(f"{path}: a campaign reads sessions (.h5); import time records first with "
                           f"gasfilm replay ... --out SESSION.h5 --condition KEY=VALUE")
    with Session.open(path, "r") as session:
        conditions = decode_conditions(session.settings, str(path))
        hits = session.hits()
        window = session.settings_as("window", WindowSettings)
        rig_spec_toml = session.rig_spec_toml
        settings = session.settings
        daq_config = session.daq_config
        status = session.status
        sample_rate_hz = session.sample_rate_hz
        stored_hits = {name: FitHits.of_stored(session.read_fit(name)) for name in session.result_names("fits")}
    accepted = [hit for hit in hits if hit.verdict.accepted]
    every_point = accepted
    rigid_spec = None
    if rig_spec_toml:
        from gasfilm.analysis.rigid_session import hits_at_spec_point

        rigid_spec = RigSpec.from_toml(rig_spec_toml, f"{path} rig spec")
        if rigid_spec.rigid_body is not None:  # the one-FRF view of a rigid-body test: its spec's point
            accepted = hits_at_spec_point(rigid_spec, settings, accepted)
        else:
            rigid_spec = None
    # (as gasfilm fit and the report judge the session's stored fits: against all its accepted hits)
    stale = {name: note for name, used in stored_hits.items()
             if (note := stale_note(used, [hit.index for hit in every_point])) is not None}
    row: dict[str, Any] = {
        "status": status,
        "hits": len(hits),
        "accepted_hits": len(accepted),
        "sample_rate_hz": sample_rate_hz,
        # the campaign fits all accepted hits; the fits the session stores may predate some (its report shows them)
        "fit_hits": len(accepted),
        "stored_fits_stale": "; ".join(f"{name} {note}" for name, note in stale.items()),
    }
    for key, value in conditions.items():  # labels as text, so one column keeps one type across sessions
        row[condition_column(key)] = value if condition_unit(key) else str(value)
    if not accepted:
        raise SettingError(f"{path}: no accepted hits to analyse")
    spec_toml = options.rig_spec_toml or rig_spec_toml
    spec = RigSpec.from_toml(spec_toml, f"{path} rig spec").at_conditions(conditions) if spec_toml else None
    if spec is not None:
        # (a network that is no paper model by its text, which names it again: a mover's pads, say)
        row["spec.film_model"] = spec.film.name if spec.film.name != "custom" else spec.film_model
        for parameter in spec.film.parameters:
            row[spec_column(parameter.name, parameter.unit)] = spec.film_parameters[parameter.name]
    mass_kg = spec.mass_kg if spec is not None else PAPER_MASS_KG
    row["mass_kg"] = mass_kg

    frf = session_frf(accepted, window)
    low, high = options.band_hz or (DEFAULT_BAND_HZ[0], min(DEFAULT_BAND_HZ[1], 0.45 * frf.sample_rate_hz))
    keep = (frf.freq_hz >= max(low, 1e-9)) & (frf.freq_hz <= high)
    if np.count_nonzero(keep) < 10:
        raise SettingError(f"{path}: only {np.count_nonzero(keep)} FRF lines between {low:g} and {high:g} Hz")
    freq_hz, h1 = frf.freq_hz[keep], frf.h1[keep]
    row["band_low_hz"], row["band_high_hz"] = float(freq_hz[0]), float(freq_hz[-1])
    row["coherence_mean"] = float(np.mean(frf.coherence[keep]))

    fits = [fit_model(get_model(name), freq_hz, h1, mass_kg, method=options.method,
                      decay_rate_1_s=frf.decay_rate_1_s, seed=options.seed) for name in options.models]
    rows = compare_models(fits, freq_hz, h1)
    comparison = {entry.model_name: entry for entry in rows}
    best = best_by_bic(rows)
    row["best_model"] = best.model_name
    row["best_model_rms_m_s2_per_n"] = best.rms
    # what `gasfilm fit` warns of (not a mass on a film, resonances no film explains): a "best model" means little then
    row["fit_warnings"] = "; ".join(fit_warnings(frf, keep, [mass_kg])) or None
    for fit in fits:
        entry = comparison[fit.model_name]
        row[f"{fit.model_name}.rms [(m/s²)/N]"] = entry.rms
        row[f"{fit.model_name}.E [%]"] = entry.e_percent
        row[f"{fit.model_name}.BIC"] = entry.bic
        row[f"{fit.model_name}.at_bound"] = ", ".join(fit.at_bound)
        # the network the data determine (a reduced form's lacks the parameters they cannot: those stay empty)
        row[f"{fit.model_name}.network"] = fit.network
        row[f"{fit.model_name}.notes"] = "; ".join(fit.notes)
        for parameter in fit.model().parameters:
            row[parameter_column(fit.model_name, parameter.name, parameter.unit)] = fit.params[parameter.name]
            sigma = fit.std_errors.get(parameter.name)
            row[sigma_column(fit.model_name, parameter.name, parameter.unit)] = (
                sigma if sigma is not None and math.isfinite(sigma) else None)

    if rigid_spec is not None and every_point:
        from gasfilm.analysis.campaign.rigid import rigid_columns

        row.update(rigid_columns(rigid_spec, settings, daq_config, every_point, window, (low, high),
                                 options.method, options.seed, sample_rate_hz))
    if options.diagnose:
        recordings = load_recordings(path)
        with worker_processes(1):  # the campaign runs one task per core already
            diagnosis = diagnose(recordings, spec)
        result = diagnosis.to_dict()
        findings = result.get("findings", [])
        row["diagnosis_verdict"] = str(result.get("verdict", ""))
        row["diagnosis_findings"] = "; ".join(str(finding.get("effect", "?")) for finding in findings)
        row["diagnosis_unexplained"] = "; ".join(band_text(*item["band_hz"]) for item in result.get("unexplained", []))
        row["diagnosis_rms_before_m_s2_per_n"] = diagnosis.rms_before
        row["diagnosis_rms_after_m_s2_per_n"] = diagnosis.rms_after
    return row
