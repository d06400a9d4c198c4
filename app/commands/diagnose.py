"""``gasfilm diagnose``: where the rig spec and the recordings differ, which physics is missing, and the fix.

Reads a session (HDF5) or UFF 58 time records, compares them with the rig spec played under identical conditions,
recalibrates the spec's own parameters, then names and fits the missing physics (:mod:`gasfilm.analysis.diagnosis`). Writes
the improved rig spec and before/after figures into ``--out``; ``--json`` prints one JSON object instead of text.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

from gasfilm.analysis.jsontext import dumps
from gasfilm.analysis.paths import results_folder
from gasfilm.app.commands.common import check_inputs, check_output_folder
from gasfilm.drivers.errors import GasfilmError, SettingError

def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "diagnose",
        help="find where the rig spec and the recordings differ, name the missing physics, write an improved spec",
    )
    parser.add_argument("source", type=Path, nargs="+", metavar="SESSION.h5|FILE.uff|HIT.npy",
                        help="a session (.h5), UFF 58 time records (.uff/.unv) or .npy hit records (one per hit)")
    parser.add_argument("--rig", type=Path, help="rig spec TOML (default: the one the session was recorded with, "
                                                 "else a start read off the FRF)")
    parser.add_argument("--mass", type=float, help="moving mass in kg (overrides the spec's; without a spec, default "
                                                   "the mass line read off the FRF)")
    parser.add_argument("--band", help="analysis band LO:HI in Hz (default: where the hammer excites, ≤ 0.4 fs)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the report")
    parser.add_argument("--out", type=Path,
                        help="folder for the improved spec and the figures (default NAME-diagnosis/ beside the "
                             "input, NAME its file name without the suffix)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an improved spec or figures in --out (and remove an earlier run's figure this "
                             "run does not draw)")
    parser.add_argument("--no-figures", action="store_true",
                        help="write the improved spec only, no figures (for scripts that read the JSON)")
    parser.add_argument("--verbose", "-v", action="store_true",
                        help="print the search's trace too (every candidate's scores), not only its steps and what "
                             "it has so far")
    parser.add_argument("--check-loop", action="store_true",
                        help="diagnose the written spec again on the same recordings: it must find nothing more "
                             "(the result under 'loop'; takes about as long again)")
    parser.set_defaults(func=run)


def _band(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        low, high = (float(part) for part in text.split(":"))
    except ValueError:
        raise SettingError(f"--band: '{text}' is not LO:HI in Hz (for example 20:1000)") from None
    if not 0 <= low < high:
        raise SettingError(f"--band: {text} must have 0 ≤ LO < HI")
    return low, high


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.diagnosis import diagnose
    from gasfilm.analysis.diagnosis.pipeline import is_trace
    from gasfilm.analysis.diagnosis.plots import OUTPUT_FILES, remove_stale_outputs, write_outputs
    from gasfilm.analysis.diagnosis.report import report_text
    from gasfilm.analysis.physics.spec import MASS_RANGE_KG, RigSpec
    from gasfilm.analysis.session import Session

    if args.mass is not None and not MASS_RANGE_KG[0] <= args.mass <= MASS_RANGE_KG[1]:
        raise SettingError(f"--mass {args.mass:g}: must be {MASS_RANGE_KG[0]:g} to {MASS_RANGE_KG[1]:g} kg")
    band = _band(args.band)
    check_inputs(args.source)  # the inputs before the outputs (and before any folder is made)
    spec = RigSpec.load(args.rig) if args.rig else None
    typed = args.out is not None
    if not typed:  # each recording's own folder: a second session's diagnosis never meets the first one's files
        args.out = results_folder(args.source[0], "diagnosis")
    made = not args.out.exists()
    try:
        check_output_folder(args.out, "--out" if typed else "", OUTPUT_FILES, args.overwrite)
    except SettingError as error:
        if typed or "exists already" not in str(error):
            raise
        raise SettingError(f"{args.out}: holds an earlier diagnosis of {args.source[0].name} (its default folder): "
                           f"give --overwrite to replace it, or --out FOLDER to keep both") from None
    started = time.monotonic()
    try:
        def progress(message: str) -> None:
            if args.verbose or not is_trace(message):
                print(f"  {message}", file=sys.stderr)

        from gasfilm.analysis.conditions import format_conditions
        from gasfilm.app.commands.common import source_conditions

        conditions = source_conditions(list(args.source))
        if conditions:  # files from elsewhere carry none: the report says "not recorded" once, at the end
            progress(f"{args.source[0]}: conditions {format_conditions(conditions)}")
        source = args.source[0] if len(args.source) == 1 else list(args.source)
        diagnosis = diagnose(source, spec, args.mass, band, progress, check_loop=args.check_loop)
        write_outputs(diagnosis, args.out, figures=not args.no_figures)
        if args.overwrite:
            for stale in remove_stale_outputs(diagnosis, args.out):
                progress(f"removed {stale}: an earlier run's, which this run does not write")
        computed_s = diagnosis.wall_time_s  # the diagnosis itself, without loading and figures
        diagnosis.wall_time_s = time.monotonic() - started  # what the user waited: loading to figures written
    except BaseException:
        if made:  # a failed run leaves no empty folder behind
            with contextlib.suppress(OSError):
                args.out.rmdir()
        raise
    options = {"command": "gasfilm diagnose", "rig": str(args.rig) if args.rig else None, "mass_kg": args.mass,
               "band_hz": list(band) if band else None}
    if len(args.source) == 1 and args.source[0].suffix.lower() not in (".uff", ".unv", ".npy"):
        try:
            with Session.updating(args.source[0]) as session:
                run_name = session.add_diagnosis({**diagnosis.to_dict(), "options": options})
            progress(f"diagnosis stored in {args.source[0]} as diagnoses/{run_name} (the newest: diagnoses/latest; "
                     f"earlier runs are kept)")
        except GasfilmError as error:
            progress(f"diagnosis not stored in the session: {error}")
    if args.json:
        print(dumps({**diagnosis.to_dict(), "options": options, "conditions": conditions, "diagnosis_s": computed_s},
                    indent=2))
    else:
        print(f"conditions: {format_conditions(conditions)}")
        print(report_text(diagnosis))
    return 0
