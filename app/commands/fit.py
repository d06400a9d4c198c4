"""``gasfilm fit SOURCE``: identify gas-film models from an FRF, compare them like Table 2, list the identified
parameters with units and uncertainties, draw Figures 18 and 19, and store the fits in a session.

The FRF is a session's stored one (``--frf NAME``; by default "frf" or the only one), or one averaged from its accepted
hits when none is stored yet, or the average of UFF / .npy time records. The mass is ``--mass``, else the rig spec's mover mass stored in the session,
else the paper's 25.05 kg. A structure that is not a mass on a film (its accelerance far above the resonance does
not approach 1/m) is warned about: its fits mean little.

Each stored fit names the hits it was made on: an FRF that averages fewer hits than the session now accepts is said
to be stale, and ``--refit`` fits the stored models again, with their settings, on all the accepted hits. A session
that cannot be written (a read-only file or folder) is fitted all the same: what could not be stored is said.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any, Callable

from gasfilm.analysis.jsontext import dumps
from gasfilm.analysis.paths import results_folder
from gasfilm.app.commands.common import (UNITS, accelerance_text, add_units_flag, check_inputs,
                                         check_output_folder, is_terminal,
                                         load_frf_and_hits, source_conditions)
from gasfilm.drivers.errors import GasfilmError, SettingError

logger = logging.getLogger(__name__)

MIN_BAND_LINES = 10


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit", help="fit the paper's gas-film models to an FRF (Table 2, Figures 18/19)"
    )
    parser.add_argument("source", type=Path, nargs="+", metavar="SESSION.h5|FILE.uff|HIT.npy",
                        help="a session, a UFF 58 file (its FRF, else its time records), or .npy hit records")
    parser.add_argument("--frf", metavar="NAME", help="which stored FRF of a session (default: 'frf' or the only one)")
    parser.add_argument("--models", default="all", help="comma-separated model names (SD, FOMGF, ...) or 'all'")
    parser.add_argument("--method", default="default", help="fitter: 'default' (the fast one) or 'gapso'")
    parser.add_argument("--band", help="frequency band LO:HI in Hz (default 20:1000, capped at 0.45·fs)")
    parser.add_argument("--mass", type=float, help="mover mass in kg (default: the session's rig spec, else 25.05)")
    parser.add_argument("--fit-mass", action="store_true", help="identify the mass too, starting from --mass")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fitters' random starts")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    add_units_flag(parser)
    parser.add_argument("--figures", action="store_true",
                        help="draw Figures 18 and 19 (PNG) into NAME-fit/ beside the input, NAME its file name without "
                             "the suffix (drawing them takes longer than the fits)")
    parser.add_argument("--out", type=Path, help="folder for Figures 18 and 19 (implies --figures)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace figures that exist already, and a session's stored fit made with other "
                             "settings (band, mass, --fit-mass, method, FRF)")
    parser.add_argument("--refit", action="store_true",
                        help="fit the session's stored models again, with their settings, on the FRF of all its "
                             "accepted hits (stored as its FRF 'frf'): after more hits, its fits are current again")
    parser.set_defaults(func=run)


def parse_band(text: str | None, sample_rate_hz: float) -> tuple[float, float]:
    """``LO:HI`` in Hz; the default band is 20–1000 Hz. Either is capped at ``ALIAS_FREE_FRACTION``·fs (the module's
    alias-free band), said in one warning when a given band reaches above it."""
    import math

    from gasfilm.analysis.identification import default_fit_band_hz
    from gasfilm.analysis.identification.fitter import ALIAS_FREE_FRACTION

    top_hz = ALIAS_FREE_FRACTION * sample_rate_hz
    if text is None:
        return default_fit_band_hz(sample_rate_hz)
    parts = text.split(":")
    try:
        low, high = (float(part) for part in parts)
    except ValueError:
        raise SettingError(f"--band '{text}': write LO:HI in Hz, e.g. 20:800") from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise SettingError(f"--band '{text}': needs 0 ≤ LO < HI")
    if low >= top_hz:
        raise SettingError(f"--band '{text}': starts above {ALIAS_FREE_FRACTION:g}·fs = {top_hz:g} Hz, the top of "
                           f"the alias-free band")
    if high > top_hz:
        logger.warning("--band %s: the top is capped at %g·fs = %g Hz (the alias-free band)", text,
                       ALIAS_FREE_FRACTION, top_hz)
        high = top_hz
    return low, high


def check_stored_fits(session: Any, settings: dict[str, Any], overwrite: bool) -> None:
    """Refuse (before any fitting) to replace a session's stored fit of a model by one made with other settings (band,
    mass, fitted mass, fitter, FRF), unless ``--overwrite``: a report must never show a fit beside figures or other
    fits of settings it was not made with. ``settings``: model name → its new fit's
    :class:`~gasfilm.analysis.fit_settings.FitSettings`."""
    from gasfilm.analysis.fit_settings import conflicting_fits, refusal

    if overwrite:
        return
    conflicts = conflicting_fits(session, settings)
    if conflicts:
        raise SettingError(refusal(session.path, conflicts))


def parse_models(text: str) -> list:
    from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER, get_model

    names = PAPER_MODEL_ORDER if text.strip().lower() == "all" else [n for n in text.split(",") if n.strip()]
    if not names:
        raise SettingError("--models: give at least one model name or 'all'")
    models = []
    for name in names:
        if any(operator in name for operator in ("||", "--", "(")):
            raise SettingError(f"--models '{name}': give model names, not network text")
        models.append(get_model(name))
    return models


def _mass_kg(args: argparse.Namespace, rig_spec_toml: str | None) -> float:
    from gasfilm.analysis.physics.elements import PAPER_MASS_KG
    from gasfilm.analysis.physics.spec import RigSpec

    if args.mass is not None:
        return args.mass
    return RigSpec.from_toml(rig_spec_toml, f"{args.source[0]} rig spec").mass_kg if rig_spec_toml else PAPER_MASS_KG


def format_parameters(fits: list) -> str:
    """Each fit's identified parameters with units and 1-σ uncertainties, and those its reduced form leaves out."""
    from gasfilm.analysis.identification.reduction import reduced_parameters
    from gasfilm.analysis.quantities import uncertainty_text, unit_word

    lines = []
    for fit in fits:
        units = {parameter.name: parameter.unit for parameter in fit.model().parameters}
        if fit.mass_fitted:
            units["mass"] = "kg"
        lines.append(f"{fit.model_name}:")
        values = dict(fit.params, **({"mass": fit.mass_kg} if fit.mass_fitted else {}))
        for name, value in values.items():
            error = fit.std_errors.get(name)
            spread = "± —" if error is None else uncertainty_text(error, at_bound=name in fit.at_bound)
            lines.append(f"  {name:<14} {value:>12.5g} {spread:<10} {unit_word(units.get(name, ''))}")
        missing = reduced_parameters(fit)
        if missing:
            lines.append(f"  {', '.join(missing)}: not determined by the data (the model's reduced form, below)")
    return "\n".join(lines)


def refit_settings(args: argparse.Namespace) -> None:
    """``--refit``: the models and settings of the session's stored fits, for the flags not typed (one line when the
    stored fits disagree on one, naming the flag that settles it)."""
    from gasfilm.analysis.fit_settings import FitSettings
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import is_time_record_file

    if len(args.source) != 1 or is_time_record_file(args.source[0]):
        raise SettingError("--refit: only for a session (it fits the session's stored models again)")
    if args.frf is not None:
        raise SettingError("--refit: fits on the FRF of all the session's accepted hits; leave --frf out")
    typed = getattr(args, "typed_flags", set())
    with Session.open(args.source[0], "r") as session:
        stored = {name: FitSettings.of_stored(session.read_fit(name)) for name in session.result_names("fits")}
    stored = {name: settings for name, settings in stored.items() if settings is not None}
    if "models" not in typed:
        if not stored:
            raise SettingError(f"--refit: {args.source[0]} holds no fits to fit again; name them with --models")
        args.models = ",".join(stored)
    chosen = [settings for name, settings in stored.items() if name in args.models.split(",")]
    for dest, flag, value in (("band", "--band", lambda f: f"{f.band_hz[0]!r}:{f.band_hz[1]!r}"),
                              ("mass", "--mass", lambda f: f.mass_kg),
                              ("fit_mass", "--fit-mass", lambda f: f.mass_fitted),
                              ("method", "--method", lambda f: f.method or "default")):
        values = list(dict.fromkeys(value(f) for f in chosen if not (dest == "mass" and f.mass_kg != f.mass_kg)))
        if dest in typed or not values:
            continue
        if len(values) > 1:
            raise SettingError(f"--refit: the stored fits differ in {flag} ({', '.join(map(str, values))}); give "
                               f"{flag} (and --overwrite for the fits it changes)")
        setattr(args, dest, values[0])


def _progress_printer(name: str, index: int, count: int) -> Callable[[float], None] | None:
    if not is_terminal():
        return None

    def show(fraction: float) -> None:
        bar = "#" * int(20 * fraction)
        print(f"\r  [{index}/{count}] {name:<8} [{bar:<20}] {100 * fraction:3.0f}%", end="", file=sys.stderr)

    return show


def run(args: argparse.Namespace) -> int:
    import dataclasses

    import numpy as np

    from gasfilm.analysis.fit_settings import FitSettings, stale_note
    from gasfilm.analysis.fit_warnings import mass_line_warning, not_explained_warning, other_resonances_hz
    from gasfilm.analysis.identification import METHODS, compare_models, fit_model, format_table2
    from gasfilm.analysis.paths import written_whole
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import is_time_record_file
    from gasfilm.analysis.spectra import usable_band_hz

    check_inputs(args.source)  # the inputs before the outputs
    if args.refit:
        refit_settings(args)
    if args.method not in METHODS:
        raise SettingError(f"--method '{args.method}': choose one of {', '.join(METHODS)}")
    models = parse_models(args.models)
    if args.mass is not None and not args.mass > 0:
        raise SettingError(f"--mass {args.mass}: must be a positive mass in kg")
    draw = args.figures or args.out is not None  # figures when asked: matplotlib costs more than the fits
    out = args.out if args.out is not None else results_folder(args.source[0], "fit")
    stem = args.source[0].stem
    # (--refit replaces the figures of the fits it replaces)
    figure_paths = check_output_folder(out, "--out" if args.out is not None else "",
                                       (f"{stem}-figure18.png", f"{stem}-figure19.png"), args.overwrite or args.refit) if draw else []
    from gasfilm.analysis.conditions import format_conditions

    loaded = load_frf_and_hits(args.source, args.frf, fresh=args.refit)
    frf, what, rig_spec_toml = loaded.frf, loaded.what, loaded.rig_spec_toml
    hits = loaded.fit_hits()
    stale = None if loaded.accepted_indices is None else stale_note(hits, loaded.accepted_indices)
    if stale:
        stale = (f"the {what} is {stale}, and so are fits on it (--refit averages all "
                 f"{len(loaded.accepted_indices)} and fits again)")
    conditions = source_conditions(args.source)
    low, high = parse_band(args.band, frf.sample_rate_hz)
    band_note = None
    # the default band stays where the hammer excites: force within 20 dB of its low level (an FRF read from a UFF
    # file carries no force spectrum: its band is the default one)
    if args.band is None and np.all(np.isfinite(frf.gff)):
        _, usable_hz = usable_band_hz(frf.freq_hz, frf.gff)
        if usable_hz < high:
            band_note = (f"the band ends at {usable_hz:.0f} Hz, where the force spectrum falls 20 dB below its "
                         f"low-frequency level (above it the FRF is not measured)")
            high = usable_hz
    keep = (frf.freq_hz >= max(low, 1e-9)) & (frf.freq_hz <= high)
    if np.count_nonzero(keep) < MIN_BAND_LINES:
        raise SettingError(
            f"--band {low:g}:{high:g}: only {np.count_nonzero(keep)} FRF lines in it (the FRF spans "
            f"{frf.freq_hz[0]:g}–{frf.freq_hz[-1]:g} Hz every {frf.freq_hz[1] - frf.freq_hz[0]:g} Hz)"
        )
    freq_hz, h = frf.freq_hz[keep], frf.h1[keep]
    mass_kg = _mass_kg(args, rig_spec_toml)
    settings = FitSettings((float(freq_hz[0]), float(freq_hz[-1])), mass_kg, args.fit_mass, args.method,
                           frf.decay_rate_1_s, "frf" if args.refit else loaded.name)
    if not is_time_record_file(args.source[0]):
        with Session.open(args.source[0], "r") as session:
            check_stored_fits(session, {model.name: settings for model in models}, args.overwrite)
    if loaded.note:  # (after the refusals: a refused fit is one line)
        logger.warning(loaded.note)
    warning = mass_line_warning(freq_hz, h, mass_kg)
    if warning:
        logger.warning(warning)
    fits = []
    for index, model in enumerate(models, start=1):
        fit = fit_model(model, freq_hz, h, mass_kg, method=args.method, decay_rate_1_s=frf.decay_rate_1_s,
                        fit_mass=args.fit_mass, seed=args.seed,
                        progress=_progress_printer(model.name, index, len(models)))
        if is_terminal():
            print(f"\r\033[K  [{index}/{len(models)}] {model.name:<8} RMS {accelerance_text(fit.rms, args.units)} "
                  f"in {fit.wall_time_s:.2f} s", file=sys.stderr)
        fits.append(fit)
    unexplained_hz = other_resonances_hz(frf, (float(freq_hz[0]), float(freq_hz[-1])))
    not_explained = not_explained_warning(unexplained_hz)
    if not_explained:
        logger.warning(not_explained)
    rows = compare_models(fits, freq_hz, h)
    # the figures and the session's fits, all or nothing: the figures get their names once the fits are stored
    figures: list[Path] = []
    stored_note = None
    with written_whole(*figure_paths, what="the figures") as building:
        if draw:
            from gasfilm.analysis.figures import figure18, figure19

            figure18(building[0], freq_hz, h, fits)
            figure19(building[1], freq_hz, h, fits)
            figures = figure_paths
        if not is_time_record_file(args.source[0]):
            try:
                with Session.updating(args.source[0]) as session:
                    if args.refit:
                        session.write_frf(frf, hit_indices=np.array(hits.indices, dtype=np.int64))
                    for fit in fits:
                        session.write_fit(fit.model_name,
                                          {**fit.to_dict(), **settings.stored_keys(), **hits.stored_keys()})
            except GasfilmError as error:  # a read-only session (or folder): the fits are shown, not kept
                stored_note = (f"the fits{' and the FRF' if args.refit else ''} are not stored in the session: "
                               f"{error}")
                if args.json:  # (the text output says it in its notes)
                    logger.warning(stored_note)
    if args.json:
        print(dumps({
            "source": [str(path) for path in args.source],
            "frf": what,
            "conditions": conditions,
            "band_hz": [float(freq_hz[0]), float(freq_hz[-1])],
            "mass_kg": mass_kg,
            "method": args.method,
            "decay_rate_1_s": frf.decay_rate_1_s,
            "mass_line_warning": warning,
            "band_note": band_note,
            "hits": {"count": hits.count, "indices": None if hits.indices is None else list(hits.indices),
                     "accepted": None if loaded.accepted_indices is None else len(loaded.accepted_indices),
                     "stale": stale},
            "stored_note": stored_note,
            "not_explained_resonances_hz": unexplained_hz,
            "fits": [fit.to_dict() for fit in fits],
            "table": [dataclasses.asdict(row) for row in rows],
            "figures": [str(path) for path in figures],
        }))
        return 0
    print(f"{args.source[0]}: {what}, {len(freq_hz)} lines, {freq_hz[0]:g}–{freq_hz[-1]:g} Hz, m = {mass_kg:g} kg, "
          f"method {args.method}")
    print(f"conditions: {format_conditions(conditions)}")
    if loaded.accepted_indices is not None:
        accepted = len(loaded.accepted_indices)
        print(f"hits: the fits are made on {hits.count} of the session's {accepted} accepted hits (stale)" if stale
              else f"hits: the fits are made on all {accepted} accepted hits of the session")
    for line in (band_note, not_explained, stale, stored_note):
        if line:
            print(f"note: {line}")
    table_units = "g/N" if args.units == "g" else "SI"
    print(f"\nTable 2 ({UNITS[args.units]}; --units {'si' if args.units == 'g' else 'g'} for "
          f"{UNITS['si' if args.units == 'g' else 'g']})\n" + format_table2(rows, table_units))
    print("\nIdentified parameters (± 1σ)\n" + format_parameters(fits))
    for fit in fits:
        for note in fit.notes:
            print(f"{fit.model_name}: {note}")
        if fit.flags:
            print(f"{fit.model_name}: " + "; ".join(fit.flags))
    print("\nfigures: " + (", ".join(str(path) for path in figures) if figures else
                            f"not drawn (--figures draws Figures 18 and 19 into {out})"))
    return 0
