"""What ``gasfilm model`` approximates, read from what the user names: a session's stored fit, a fit written by
``gasfilm fit --json`` (or one fit's own JSON), or a rig spec (a whole plant, e.g. the spec ``gasfilm diagnose``
writes). Every failure is one line naming the file or the flag."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gasfilm.analysis.control.rational import PlantSource
from gasfilm.analysis.identification import FitResult
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import GasfilmError, SettingError

MAX_JSON_BYTES = 50_000_000


@dataclass
class LoadedSource:
    """The plant to approximate and, for a session, what the time-domain check needs."""

    plant: PlantSource
    fit: FitResult | None = None
    records: np.ndarray | None = None  # (hits, channels, samples) accepted hits, N and m/s²
    hit_indices: tuple[int, ...] = ()
    trigger_index: np.ndarray | None = None
    force_channel: int = 0
    response_channel: int = 1
    sample_rate_hz: float = 0.0
    frf: Any = None
    note: str = ""  # how the fit was chosen when --model was not given


def _choose(fits: dict[str, dict], model: str | None, path: Path,
            bic: dict[str, float] | None = None) -> tuple[dict, str]:
    """The fit ``model`` names, and a note ('' when named): without a name, the only fit, else the one of lowest
    BIC (``bic``: model name → BIC, when the fits share one band; otherwise a name is asked for)."""
    if not fits:
        raise SettingError(f"{path}: holds no fitted model (run gasfilm fit first)")
    if model is None:
        if len(fits) == 1:
            return next(iter(fits.values())), ""
        if bic and set(bic) >= set(fits):
            best = min(fits, key=lambda name: bic[name])
            return fits[best], (f"--model not given: {best}, the lowest BIC of the {len(fits)} fits "
                                f"({', '.join(fits)}); --model NAME takes another")
        raise SettingError(f"--model: {path} holds several fits ({', '.join(fits)}) that no one BIC ranks (made over "
                           f"other bands or FRFs, or stored without Table 2); name one")
    for name, fit in fits.items():
        if name.lower() == model.strip().lower():
            return fit, ""
    raise SettingError(f"--model {model}: {path} holds no fit of it (it holds {', '.join(fits)}; run gasfilm fit "
                       f"with --models {model})")


def _bic_of_session_fits(session: Any, fits: dict[str, dict]) -> dict[str, float] | None:
    """Each stored fit's BIC on the session's FRF, when they were all made over one band of one FRF."""
    from gasfilm.analysis.identification import compare_models

    made = {(tuple(np.round(np.asarray(fit.get("band_hz", (0, 0)), float), 6)), fit.get("frf_name", "frf"))
            for fit in fits.values()}
    if len(made) != 1:
        return None
    (band, frf_name), = made
    if frf_name not in session.result_names("frf"):
        return None
    frf = session.read_frf(frf_name)
    lines = (frf.freq_hz >= band[0] - 1e-6) & (frf.freq_hz <= band[1] + 1e-6)
    results = [_fit_from_dict(fit, session.path) for fit in fits.values()]
    return {row.model_name: row.bic for row in compare_models(results, frf.freq_hz[lines], frf.h1[lines])}


#: The widest band a fit is taken over (a fit gasfilm made lies far inside: the NI 9234 samples at most 51.2 kS/s).
MAX_BAND_HZ = 1e6
MAX_BAND_RATIO = 1e9


def _fit_from_dict(data: Any, path: Path) -> FitResult:
    try:
        fit = FitResult.from_dict(data)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError) as error:
        raise SettingError(f"{path}: not a gasfilm fit ({type(error).__name__}: {error})") from None
    bad = [name for name, value in fit.params.items() if not np.isfinite(value)]
    if bad or not (np.isfinite(fit.mass_kg) and fit.mass_kg > 0):
        what = f"parameter(s) {', '.join(bad)} not finite" if bad else f"mass {fit.mass_kg} kg is not positive"
        raise SettingError(f"{path}: fit {fit.model_name}: {what}")
    low_hz, high_hz = fit.band_hz
    if not (np.isfinite(low_hz) and np.isfinite(high_hz) and 0 <= low_hz < high_hz <= MAX_BAND_HZ
            and (low_hz == 0 or high_hz / low_hz <= MAX_BAND_RATIO)):
        raise SettingError(f"{path}: fit {fit.model_name}: band {fit.band_hz} Hz is not 0 ≤ LO < HI ≤ {MAX_BAND_HZ:g} "
                           f"over at most {np.log10(MAX_BAND_RATIO):.0f} decades")
    try:
        parameters = {parameter.name: parameter for parameter in fit.model().parameters}
    except (GasfilmError, KeyError, ValueError) as error:
        raise SettingError(f"{path}: fit {fit.model_name}: not a model gasfilm knows ({error})") from None
    for name, value in fit.params.items():  # a fit gasfilm made lies within its search bounds (at worst on one)
        parameter = parameters.get(name)
        if parameter is None:
            raise SettingError(f"{path}: fit {fit.model_name}: '{name}' is not one of its parameters "
                               f"({', '.join(parameters)})")
        if not parameter.lower - 1e-9 * abs(parameter.lower) <= value <= parameter.upper + 1e-9 * abs(parameter.upper):
            raise SettingError(f"{path}: fit {fit.model_name}: {name} = {value:g} {parameter.unit} is outside what a "
                               f"fit can give ({parameter.lower:g} to {parameter.upper:g})")
    return fit


def load_source(path: Path, model: str | None) -> LoadedSource:
    """The plant in ``path`` (.h5 session, .json fit, .toml rig spec); ``model`` names the fit to use."""
    suffix = path.suffix.lower()
    if not path.is_file():
        raise SettingError(f"{path}: no such file")
    if suffix == ".toml":
        if model is not None:
            raise SettingError(f"--model {model}: {path} is a rig spec; its film is the spec's own (leave --model out)")
        return LoadedSource(PlantSource.from_spec(RigSpec.load(path), str(path)))
    if suffix == ".json":
        if path.stat().st_size > MAX_JSON_BYTES:
            raise SettingError(f"{path}: too large for a fit ({path.stat().st_size} bytes)")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise SettingError(f"{path}: not a readable JSON fit ({type(error).__name__}: {error})") from None
        except RecursionError:
            raise SettingError(f"{path}: not a gasfilm fit (its JSON is nested too deeply)") from None
        if isinstance(data, dict) and isinstance(data.get("fits"), list):
            fits = {str(fit.get("model_name")): fit for fit in data["fits"] if isinstance(fit, dict)}
        elif isinstance(data, dict) and "model_name" in data:
            fits = {str(data["model_name"]): data}
        else:
            raise SettingError(f"{path}: not a gasfilm fit (expected the output of gasfilm fit --json)")
        table = data.get("table") if isinstance(data, dict) else None
        bic = {str(row.get("model_name")): float(row["bic"]) for row in table
               if isinstance(row, dict) and isinstance(row.get("bic"), (int, float))} if isinstance(table, list) else None
        chosen, note = _choose(fits, model, path, bic)
        fit = _fit_from_dict(chosen, path)
        return LoadedSource(PlantSource.from_fit(fit, str(path)), fit=fit, note=note)
    return _from_session(path, model)


def _from_session(path: Path, model: str | None) -> LoadedSource:
    from gasfilm.analysis.session import Session

    try:
        with Session.open(path, "r") as session:
            fits = {name: session.read_fit(name) for name in session.result_names("fits")}
            bic = _bic_of_session_fits(session, fits) if model is None and len(fits) > 1 else None
            chosen, note = _choose(fits, model, path, bic)
            fit = _fit_from_dict(chosen, path)
            hits = [hit for hit in session.hits() if hit.verdict.accepted]
            sample_rate_hz = session.sample_rate_hz
    except GasfilmError:
        raise
    except OSError as error:
        raise SettingError(f"{path}: not a session, a .json fit or a .toml rig spec ({error})") from None
    loaded = LoadedSource(PlantSource.from_fit(fit, str(path)), fit=fit, sample_rate_hz=sample_rate_hz, note=note)
    if hits:
        loaded.records = np.stack([hit.data for hit in hits])
        loaded.hit_indices = tuple(hit.index for hit in hits)
        loaded.trigger_index = np.array([hit.trigger_index for hit in hits])
        loaded.force_channel, loaded.response_channel = hits[0].force_channel, hits[0].response_channel
    return loaded
