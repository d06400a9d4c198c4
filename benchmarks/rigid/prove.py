"""The rigid-body proof (issue 34): simulated sessions of a mover on 3 and on 4 pads, the films' elastic centre on
and off the centre of mass, the hammer roving (at the centre and off it), at the centre only and off it only:
identified heave, roll and pitch stiffness and damping against what the pad layout implies, and the coupling.

Every session is recorded by ``gasfilm acquire`` on the simulated module (a run per hammer point, ``--append
--hammer-point``) and analysed as ``gasfilm rigid`` does (:func:`session_rigid_frf`, :func:`identify_rigid`); the
centre-only and off-centre-only cases are the hits of one point of the same session. Prints one line per figure and
writes ``results.json``. Run: ``.venv/bin/python benchmarks/rigid/prove.py [--out FOLDER] [--hits 8]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from gasfilm.analysis.identification.rigid import identify_rigid
from gasfilm.analysis.physics import rigid_body
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_frf import rigid_frf
from gasfilm.analysis.rigid_session import accelerometer_rows, hits_by_point, session_rigid_frf
from gasfilm.analysis.session import Session
from gasfilm.app.cli import main as gasfilm

RIGS = Path(__file__).resolve().parents[2] / "fixtures" / "rigs"
#: What the proof asks: identified stiffness and damping within this of the layout's.
TOLERANCE = 0.02


def layouts() -> dict[str, RigSpec]:
    """3 and 4 pads, the elastic centre on the centre of mass and off it (3 pads: a payload moving the centre of
    mass by (20, 10) mm; 4 pads: unequal pads moving the elastic centre)."""
    three = RigSpec.load(RIGS / "three-pads.toml")
    four = RigSpec.load(RIGS / "four-pads.toml")
    centre_of_mass = (0.02, 0.01)
    body = three.rigid_body
    points = tuple(point if point.name != "centre" else dataclasses.replace(point, position_m=centre_of_mass)
                   for point in body.hammer_points)
    three_off = dataclasses.replace(three, name="mover on three pads, centre of mass off the elastic centre",
                                    rigid_body=dataclasses.replace(body, centre_of_mass_m=centre_of_mass,
                                                                   hammer_points=points))
    parameters = dict(four.film_parameters)
    for index, (k, eta) in enumerate(((9.0e6, 1300.0), (7.5e6, 1100.0), (6.0e6, 900.0), (7.5e6, 1100.0)), start=1):
        parameters[f"k_pad{index}"], parameters[f"eta_pad{index}"] = k, eta
    four_off = dataclasses.replace(four, name="mover on four unequal pads", film_parameters=parameters)
    return {"3 pads, elastic centre on the centre of mass": three,
            "3 pads, elastic centre off (centre of mass moved 20, 10 mm)": three_off,
            "4 pads, elastic centre on the centre of mass": four,
            "4 pads, elastic centre off (unequal pads)": four_off}


def record(spec: RigSpec, folder: Path, hits: int, seed: int) -> Path:
    """A roving session: ``hits`` accepted hits at every hammer point, one ``gasfilm acquire`` run per point."""
    rig = folder / "rig.toml"
    spec.save(rig)
    session = folder / "session.h5"
    for run, point in enumerate(spec.rigid_body.point_names):
        argv = ["acquire", "--rig", str(rig), "--out", str(session), "--hits", str(hits), "--pacing", "fast",
                "--hit-interval", "1.2", "1.5", "--seed", str(seed), "--hammer-point", point]
        if run:
            argv.insert(1, "--append")
        with contextlib.redirect_stdout(io.StringIO()):
            status = gasfilm(argv)
        if status:
            raise SystemExit(f"gasfilm {' '.join(argv)} failed ({status})")
    return session


def implied(spec: RigSpec) -> dict:
    """What the pad layout implies at the centre of mass: each direction's SD film and the coupling terms."""
    films = rigid_body.layout_direction_films(spec)
    couplings = rigid_body.layout_coupling_sd(spec)
    return {"directions": {direction: films[direction][1] for direction in rigid_body.DIRECTIONS},
            "couplings": {f"{a}-{b}": {"k": k, "eta": eta} for (a, b), (k, eta) in couplings.items()}}


def error(identified: float, expected: float) -> float:
    return identified / expected - 1.0


def analyse(label: str, spec: RigSpec, rigid, claims: str) -> dict:
    """One case: fit SD per identified direction, compare with the layout; ``claims``: 'all' (stiffness, damping
    and coupling claimed), 'coupling' (only the coupling verdict: a one-column test of a coupled film is biased)."""
    identification = identify_rigid(rigid, ("SD",))
    expected = implied(spec)
    row = {"case": label, "points": list(rigid.point_names), "full_matrix": rigid.full,
           "identified_directions": list(identification.directions), "directions": {}, "couplings": {},
           "coupling_found": identification.coupling_found(), "claims": claims}
    for direction, fits in identification.directions.items():
        fit = fits.fit("SD")
        truth = expected["directions"][direction]
        row["directions"][direction] = {
            "k": fit.params["k"], "k_std": fit.std_errors.get("k"), "k_implied": truth["k"],
            "k_error": error(fit.params["k"], truth["k"]),
            "eta": fit.params["eta"], "eta_std": fit.std_errors.get("eta"), "eta_implied": truth["eta"],
            "eta_error": error(fit.params["eta"], truth["eta"])}
    for term in identification.couplings():
        key = f"{term.directions[0]}-{term.directions[1]}"
        row["couplings"][key] = {"k": term.stiffness, "k_std": term.stiffness_std, "eta": term.damping,
                                 "eta_std": term.damping_std, "found": term.found,
                                 "k_implied": expected["couplings"][key]["k"],
                                 "eta_implied": expected["couplings"][key]["eta"]}
    if identification.elastic_centre_offset_m is not None:
        row["elastic_centre_offset_m"] = list(identification.elastic_centre_offset_m)
    heave = expected["directions"]["heave"]["k"]
    row["elastic_centre_offset_implied_m"] = [-expected["couplings"]["heave-pitch"]["k"] / heave,
                                              expected["couplings"]["heave-roll"]["k"] / heave]
    row["coupled_layout"] = any(abs(c["k"]) > 1e-6 * heave for c in expected["couplings"].values())
    row["axis_checks"] = [list(check[:3]) for check in rigid.axis_checks()]
    return row


def verdict(row: dict) -> tuple[bool, str]:
    """Whether the case holds what it claims, and why not."""
    if row["coupling_found"] is not None and bool(row["coupling_found"]) != row["coupled_layout"]:
        return False, f"coupling {'found' if row['coupling_found'] else 'not found'}"
    if row["claims"] == "all":
        for direction, values in row["directions"].items():
            for key in ("k_error", "eta_error"):
                if abs(values[key]) > TOLERANCE:
                    return False, f"{direction} {key[:-6]} off by {100 * values[key]:+.2f} %"
    return True, ""


def print_row(row: dict) -> None:
    ok, why = verdict(row)
    print(f"  {row['case']}: points {', '.join(row['points'])}"
          f"{' (full 3×3 matrix)' if row['full_matrix'] else ''} — {'PASS' if ok else 'FAIL ' + why}")
    for direction, values in row["directions"].items():
        unit_k, unit_c = rigid_body.STIFFNESS_UNITS[direction], rigid_body.DAMPING_UNITS[direction]
        note = "" if row["claims"] == "all" else "  (not claimed: the film is coupled, one column is biased)"
        print(f"    {direction:<6} K {values['k']:12.6g} {unit_k:<8} (layout {values['k_implied']:.6g}, "
              f"{100 * values['k_error']:+.3f} %)   C {values['eta']:10.5g} {unit_c:<10} (layout "
              f"{values['eta_implied']:.5g}, {100 * values['eta_error']:+.3f} %){note}")
    for key, values in row["couplings"].items():
        print(f"    {key:<12} K {values['k']:12.6g} ± {values['k_std']:.2g} (layout {values['k_implied']:.6g})   "
              f"C {values['eta']:10.4g} ± {values['eta_std']:.2g} (layout {values['eta_implied']:.4g})   "
              f"{'coupled' if values['found'] else 'not coupled'}")
    if "elastic_centre_offset_m" in row:
        dx, sx, dy, sy = row["elastic_centre_offset_m"]
        ix, iy = row["elastic_centre_offset_implied_m"]
        print(f"    elastic centre − centre of mass: ({1e3 * dx:+.2f} ± {1e3 * sx:.2f}, {1e3 * dy:+.2f} ± "
              f"{1e3 * sy:.2f}) mm, layout ({1e3 * ix:+.2f}, {1e3 * iy:+.2f}) mm")
    for point, direction, chi2 in row["axis_checks"]:
        print(f"    hammer at {point} on the {direction} axis: {direction} response χ²/line {chi2:.3g} (1 = noise)")
    print(f"    coupling: {'found' if row['coupling_found'] else 'none' if row['coupling_found'] is False else '—'}"
          f" (layout: {'coupled' if row['coupled_layout'] else 'uncoupled'})")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="folder for the sessions and results.json (default: a temporary one)")
    parser.add_argument("--hits", type=int, default=8, help="accepted hits per hammer point (default 8)")
    parser.add_argument("--seed", type=int, default=34)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="gasfilm-rigid-proof-"))
    out.mkdir(parents=True, exist_ok=True)
    rows, failures = [], 0
    for number, (label, spec) in enumerate(layouts().items(), start=1):
        folder = out / f"layout-{number}"
        folder.mkdir(exist_ok=True)
        session_path = folder / "session.h5"
        if not session_path.exists():
            record(spec, folder, args.hits, args.seed + number)
        with Session.open(session_path) as session:
            roving = session_rigid_frf(session)
            accepted = [hit for hit in session.hits() if hit.verdict.accepted]
            grouped = hits_by_point(spec, session.settings, accepted)
            rows_of = accelerometer_rows(spec, session.daq_config)
            window = roving.channel_frfs[0][0].window
            single = {}
            for point in ("centre", "north-east"):
                from gasfilm.analysis.spectra import WindowSettings

                records = {point: np.stack([hit.data for hit in grouped[point]])}
                single[point] = rigid_frf(spec, records, session.sample_rate_hz,
                                          WindowSettings(window.get("force_window_ms"), window["force_taper_ms"],
                                                         window.get("exponential_end_fraction")),
                                          accepted[0].force_channel, rows_of)
        coupled = rigid_body.layout_coupling_sd(spec)
        coupled = any(abs(k) > 1e-6 * spec.moving_mass_kg for k, _ in coupled.values())
        print(f"{label} ({session_path}):")
        for case, rigid, claims in (("roving hammer", roving, "all"),
                                    ("hammer at the centre only", single["centre"], "coupling" if coupled else "all"),
                                    ("hammer off the centre only (north-east)", single["north-east"],
                                     "coupling" if coupled else "all")):
            row = analyse(f"{label} / {case}", spec, rigid, claims)
            print_row(row)
            failures += not verdict(row)[0]
            rows.append(row)
    (out / "results.json").write_text(json.dumps(rows, indent=1), encoding="utf-8")
    print(f"{len(rows) - failures}/{len(rows)} cases hold; results in {out / 'results.json'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
