"""``gasfilm diagnose``: where the rig spec and the recordings differ, which physics is missing, and the fix.

Reads a session (HDF5) or UFF 58 time records, compares them with the rig spec played under identical conditions,
recalibrates the spec's own parameters, then names and fits the missing physics (:mod:`gasfilm.analysis.diagnose`). Writes
the improved rig spec and before/after figures into ``--out``; ``--json`` prints one JSON object instead of text.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from gasfilm.app.commands.common import check_output_folder
from gasfilm.drivers.errors import GasfilmError, SettingError
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2 as G_M_S2

#: The files the diagnosis writes into ``--out`` (names chosen by gasfilm.analysis.diagnose and its plots).
DIAGNOSIS_FILES = ("improved-rig.toml", "diagnosis-overlay.png", "diagnosis-residual.png")


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


def _report(diagnosis: Any) -> str:
    lines = [f"gasfilm diagnose — verdict: {diagnosis.verdict}"]
    evidence = diagnosis.evidence
    lines.append(f"  compared {evidence.hit_count} hits, {evidence.freq_hz[0]:.0f}–{evidence.freq_hz[-1]:.0f} Hz, "
                 f"replayed with the recorded forces through the same windows")
    if diagnosis.recalibration:
        lines.append("  recalibrated spec parameters:")
        for name, row in diagnosis.recalibration.items():
            lines.append(f"    {name:28s} {row['spec']:.6g} → {row['fitted']:.6g} ± {row['uncertainty']:.2g}")
    if diagnosis.findings:
        lines.append("  missing physics:")
        for finding in diagnosis.findings:
            lines.append(f"    {finding.effect}  ({finding.band_hz[0]:.0f}–{finding.band_hz[1]:.0f} Hz, {finding.hits})")
            for name, row in finding.parameters.items():
                lines.append(f"      {name:28s} {row['value']:.6g} ± {row['uncertainty']:.2g} {row['unit']}")
            lines.append(f"      why:  {finding.evidence}")
            lines.append(f"      what: {finding.explanation}")
    elif diagnosis.verdict == "parameters-only":
        lines.append("  no missing physics: the recalibrated parameters explain the recordings within the noise")
    else:
        lines.append("  no missing physics: the spec explains the recordings within the noise")
    if diagnosis.quality:
        lines.append("  measurement quality (not physics):")
        lines.extend(f"    {note.kind}: {note.message}" for note in diagnosis.quality)
    lines.append(f"  RMS {diagnosis.rms_before / G_M_S2:.4g} → {diagnosis.rms_after / G_M_S2:.4g} g/N "
                 f"(E = {diagnosis.improvement_e:.1f} %), χ²/point {diagnosis.chi2_per_point_before:.3f} → "
                 f"{diagnosis.chi2_per_point_after:.3f}, BIC {diagnosis.bic_before:.0f} → {diagnosis.bic_after:.0f}")
    lines.extend(f"  note: {note}" for note in diagnosis.spec_notes)
    if diagnosis.improved_spec:
        lines.append(f"  improved spec: {diagnosis.improved_spec}")
    lines.extend(f"  figure: {figure}" for figure in diagnosis.figures)
    lines.append(f"  time: {diagnosis.wall_time_s:.1f} s")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.diagnose import diagnose
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.session import Session

    if args.mass is not None and not args.mass > 0:
        raise SettingError(f"--mass: {args.mass} kg must be positive")
    band = _band(args.band)
    check_output_folder(args.out, "--out", DIAGNOSIS_FILES, args.overwrite)
    spec = RigSpec.load(args.rig) if args.rig else None

    def progress(message: str) -> None:
        print(f"  {message}", file=sys.stderr)

    diagnosis = diagnose(args.source, spec, args.mass, args.out, band, progress)
    if args.source.suffix.lower() not in (".uff", ".unv"):
        try:
            with Session.open(args.source, "a") as session:
                session.write_diagnosis("latest", diagnosis.to_dict())
            progress(f"diagnosis stored in {args.source} (diagnoses/latest)")
        except GasfilmError as error:
            progress(f"diagnosis not stored in the session: {error}")
    if args.json:
        print(json.dumps(diagnosis.to_dict(), indent=2))
    else:
        print(_report(diagnosis))
    return 0
