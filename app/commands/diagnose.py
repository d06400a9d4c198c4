"""``gasfilm diagnose``: where the rig spec and the recordings differ, which physics is missing, and the fix.

Reads a session (HDF5) or UFF 58 time records, compares them with the rig spec played under identical conditions,
recalibrates the spec's own parameters, then names and fits the missing physics (:mod:`gasfilm.analysis.diagnosis`). Writes
the improved rig spec and before/after figures into ``--out``; ``--json`` prints one JSON object instead of text.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gasfilm.app.commands.common import check_output_folder
from gasfilm.drivers.errors import GasfilmError, SettingError

def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "diagnose",
        help="find where the rig spec and the recordings differ, name the missing physics, write an improved spec",
    )
    parser.add_argument("source", type=Path, help="session file (.h5) or UFF 58 time records (.uff/.unv)")
    parser.add_argument("--rig", type=Path, help="rig spec TOML (default: a spring-damper film on --mass)")
    parser.add_argument("--mass", type=float, help="moving mass in kg (default: the spec's, else 25.05 kg)")
    parser.add_argument("--band", help="analysis band LO:HI in Hz (default: where the hammer excites, ≤ 0.4 fs)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the report")
    parser.add_argument("--out", type=Path, default=Path("out/diagnosis"),
                        help="folder for the improved spec and the figures (default out/diagnosis)")
    parser.add_argument("--overwrite", action="store_true", help="replace an improved spec or figures in --out")
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
    from gasfilm.analysis.diagnosis.plots import OUTPUT_FILES, write_outputs
    from gasfilm.analysis.diagnosis.report import report_text
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.session import Session

    if args.mass is not None and not args.mass > 0:
        raise SettingError(f"--mass: {args.mass} kg must be positive")
    band = _band(args.band)
    check_output_folder(args.out, "--out", OUTPUT_FILES, args.overwrite)
    spec = RigSpec.load(args.rig) if args.rig else None

    def progress(message: str) -> None:
        print(f"  {message}", file=sys.stderr)

    from gasfilm.analysis.conditions import format_conditions
    from gasfilm.app.commands.common import source_conditions

    conditions = source_conditions([args.source])
    progress(f"{args.source}: conditions {format_conditions(conditions)}")
    diagnosis = diagnose(args.source, spec, args.mass, band, progress)
    write_outputs(diagnosis, args.out)
    if args.source.suffix.lower() not in (".uff", ".unv"):
        try:
            with Session.open(args.source, "a") as session:
                session.write_diagnosis("latest", diagnosis.to_dict())
            progress(f"diagnosis stored in {args.source} (diagnoses/latest)")
        except GasfilmError as error:
            progress(f"diagnosis not stored in the session: {error}")
    if args.json:
        print(json.dumps({**diagnosis.to_dict(), "conditions": conditions}, indent=2))
    else:
        print(f"conditions: {format_conditions(conditions)}")
        print(report_text(diagnosis))
    return 0
