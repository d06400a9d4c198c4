"""``gasfilm model SOURCE``: a rational (state-space) model of an identified film or a whole rig for control design,
of a chosen order or the lowest order within a stated error, written as .json, .mat or .npz; with a session's hits,
the time-domain check of the fractional and the rational model against the recordings.

SOURCE is a session (its stored fit ``--model NAME``), a fit written by ``gasfilm fit --json``, or a rig spec
(.toml, e.g. the spec ``gasfilm diagnose`` writes: the film and its mechanical effects under the moving mass).
Next to ``--out`` go ``<name>-error.png`` (the approximation's error against frequency) and, with hits,
``<name>-hits.png`` (recorded, fractional and rational acceleration), ``<name>`` the whole file name with its format
(``plant.mat-error.png``): a second format of the same model does not meet the first one's figures. Without
``--model``, a session's or fit file's only fit, else the one of lowest BIC (said).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from gasfilm.analysis.jsontext import dumps
from gasfilm.analysis.paths import written_whole
from gasfilm.app.commands.common import check_inputs, check_output_file
from gasfilm.drivers.errors import SettingError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "model", help="rational state-space model of a fitted film or a rig spec for control design (.json/.mat/.npz)"
    )
    parser.add_argument("source", type=Path, metavar="SESSION.h5|FIT.json|RIG.toml",
                        help="a session with stored fits, the JSON of gasfilm fit --json, or a rig spec")
    parser.add_argument("--model", help="which fit (SD, FOMGF, ...); not for a rig spec")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--order", type=int, help="number of states of the plant")
    size.add_argument("--max-error", default="0.5",
                      help="the lowest order whose complex relative error is within this many percent "
                           "(default 0.5, i.e. 0.5%%; a trailing %% is accepted)")
    parser.add_argument("--band", help="LO:HI in Hz (default: a decade beyond the fitted band on each side)")
    parser.add_argument("--out", type=Path, required=True, help="the model file: .json, .mat or .npz")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the summary")
    parser.add_argument("--overwrite", action="store_true", help="replace the model file and figures if they exist")
    parser.add_argument("--rigid", action="store_true",
                        help="a rigid-body session (after gasfilm rigid): the MIMO plant, force and moments → heave, "
                             "roll and pitch accelerations (--model: the film model of every direction, default each "
                             "direction's lowest BIC)")
    parser.set_defaults(func=run)


def parse_percent(text: str) -> float:
    """``--max-error`` as a fraction: a percentage, with or without its ``%`` (``0.5`` and ``0.5%`` are 0.5 %)."""
    number = text.strip().removesuffix("%").strip()
    try:
        value = float(number) / 100
    except ValueError:
        raise SettingError(f"--max-error '{text}': write a percentage such as 0.5 (or 0.5%)") from None
    if not (math.isfinite(value) and 0 < value < 1):
        raise SettingError(f"--max-error '{text}': must be above 0 and below 100 (a percentage)")
    return value


def parse_band(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        low, high = (float(part) for part in text.split(":"))
    except ValueError:
        raise SettingError(f"--band '{text}': write LO:HI in Hz, e.g. 2:10000") from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low < high):
        raise SettingError(f"--band '{text}': needs 0 < LO < HI")
    return low, high


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.control.export import SUFFIXES, model_to_dict, write_model
    from gasfilm.analysis.control.inputs import load_source
    from gasfilm.analysis.control.rational import approximate, oustaloup_order
    from gasfilm.analysis.control.timedomain import (
        figure_error, figure_hits, frf_relative_error, spec_of_fit, time_domain_check)

    check_inputs([args.source], (".json", ".toml"),
                 "a session (HDF5), a fit's JSON (gasfilm fit --json) or a rig spec (.toml)")  # before the outputs
    if args.out.suffix.lower() not in SUFFIXES:
        raise SettingError(f"--out {args.out}: name a .json, .mat or .npz file")
    if args.order is not None and args.order < 1:
        raise SettingError(f"--order {args.order}: must be a positive number of states")
    max_error = parse_percent(args.max_error)
    band = parse_band(args.band)
    if args.rigid:
        return _rigid_plant(args, max_error, band)
    loaded = load_source(args.source, args.model)
    error_png = args.out.with_name(f"{args.out.name}-error.png")  # (each format its own figures)
    hits_png = args.out.with_name(f"{args.out.name}-hits.png") if loaded.records is not None else None
    for path, flag in ((args.out, "--out"), (error_png, ""), (hits_png, "")):
        if path is not None:
            check_output_file(path, flag, args.overwrite)

    if loaded.note:
        print(f"note: {loaded.note}", file=sys.stderr)
    model = approximate(loaded.plant, band, order=args.order, max_error=max_error)
    oustaloup = None
    if loaded.plant.network and "pot(" in loaded.plant.network and loaded.fit is not None:
        oustaloup = oustaloup_order(loaded.plant, model.band_hz, max_error)
    check = None
    if hits_png is not None and loaded.fit is not None:
        from gasfilm.app.commands.common import load_frf

        frf = load_frf([args.source])[0]
        check = time_domain_check(spec_of_fit(loaded.fit), model, loaded.records, loaded.sample_rate_hz,
                                  loaded.force_channel, loaded.response_channel, loaded.hit_indices,
                                  loaded.trigger_index, frf_relative_error(loaded.fit, frf.freq_hz, frf.h1),
                                  band_hz=loaded.fit.band_hz)
    outputs = [args.out, error_png] + ([hits_png] if check is not None else [])
    with written_whole(*outputs, what="the model and its figures") as building:  # all of them, or none
        write_model(model, building[0])
        figure_error(building[1], model)
        if check is not None:
            figure_hits(building[2], check)
    written, figures = args.out, outputs[1:]
    if args.json:
        data = model_to_dict(model)
        data.pop("origin")
        print(dumps({"out": str(written), "figures": [str(path) for path in figures], "model": data,
                          "oustaloup_order": None if oustaloup is None else oustaloup[0],
                          "time_domain": None if check is None else check.to_dict()}))
        return 0
    print(f"{loaded.plant.description}: m = {loaded.plant.mass_kg:g} kg")
    target = f"--order {args.order}" if args.order is not None else f"target: within {100 * max_error:g} %"
    print(f"rational model ({model.method}, {target}): {model.summary()}")
    print(f"  plant {100 * model.max_error_plant_band:.3g} %, film {100 * model.max_error_film_band:.3g} % "
          f"(max |G_rational/G_fractional − 1| in the band)")
    if not model.storage.passed:
        print("  note: the film's storage stiffness Re Z(jω) is negative somewhere"
              + (" — so is the fractional film's" if model.source_storage_minimum < 0 else ""))
    if model.target_error is not None and model.max_error_band > model.target_error:
        print(f"  note: no order reached {100 * model.target_error:.3g} %; this is the most accurate one found")
    for excluded in loaded.plant.excluded:
        print(f"  left out: {excluded}")
    if oustaloup is not None:
        needed = f"order {oustaloup[0]}" if oustaloup[0] is not None else f"more than any order tried " \
                                                                           f"(best {100 * oustaloup[1]:.3g} %)"
        print(f"  a plain Oustaloup approximation of each s^α needs {needed} for the same error")
    if check is not None:
        print("time-domain check against the recorded hits (relative RMS, in the fit's band):")
        for line in check.summary_lines():
            print("  " + line)
    print(f"written: {written}; figures: {', '.join(str(path) for path in figures)}")
    return 0


def _rigid_plant(args: argparse.Namespace, max_error: float, band: tuple[float, float] | None) -> int:
    """``--rigid``: the MIMO plant of a session's stored rigid-body identification."""
    from gasfilm.analysis.control.rigid import rigid_plant, write_rigid_plant
    from gasfilm.analysis.identification.rigid import RigidIdentification
    from gasfilm.analysis.physics.rigid_body import mass_matrix
    from gasfilm.analysis.rigid_session import session_rigid_frf, session_spec
    from gasfilm.analysis.session import Session

    if args.order is not None:
        raise SettingError("--order: a MIMO plant is made direction by direction within --max-error")
    check_output_file(args.out, "--out", args.overwrite)
    with Session.open(args.source) as session:
        spec = session_spec(session)
        stored = session.read_rigid_body()
        if spec is None or stored is None:
            raise SettingError(f"{args.source}: no rigid-body identification stored (a session recorded with a "
                               f"[rigid_body] rig spec, then gasfilm rigid)")
        measured = session_rigid_frf(session, spec=spec)
    identification = RigidIdentification.from_dict(stored, measured)
    plant = rigid_plant(identification, mass_matrix(spec), args.model, band, max_error, measured)
    written = write_rigid_plant(plant, args.out)
    if args.json:
        print(dumps({"out": str(written), "model": plant.to_dict()}))
        return 0
    for line in plant.summary_lines():
        print(line)
    print(f"written: {written}")
    return 0
