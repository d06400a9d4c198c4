"""``gasfilm rigid SOURCE``: a rigid-body test (one hammer, three accelerometers) turned into heave, roll and pitch:
the accelerometers' FRFs per hammer point, the rigid-body FRFs (the full 3×3 matrix with a roving hammer, its
reciprocity and rigidity checks), the nine models fitted per direction with Table 2 each, the 3×3 stiffness and
damping with the couplings and the elastic centre; stored in the session (``/rigid_body``) with figures.

SOURCE is a session recorded with a ``[rigid_body]`` rig spec (``gasfilm acquire --rig``, a run per hammer point),
or a UFF file of a rigid-body test's time records (nodes: accelerometer k is node k, hammer point p node 100 + p)
with ``--rig`` giving its geometry (docs/rig-spec.md).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from gasfilm.app.commands.common import check_inputs, check_output_folder
from gasfilm.drivers.errors import SettingError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "rigid", help="heave, roll and pitch of a rigid-body test: FRFs, fits per direction, 3×3 stiffness, coupling")
    parser.add_argument("source", type=Path, metavar="SESSION.h5|FILE.uff",
                        help="a session recorded with a [rigid_body] rig spec, or UFF time records with --rig")
    parser.add_argument("--rig", type=Path, help="rig spec TOML with [rigid_body] (default: the session's own)")
    parser.add_argument("--points", help="comma-separated hammer points to use (default: every point struck)")
    parser.add_argument("--models", default="SD", help="comma-separated model names or 'all' (default SD)")
    parser.add_argument("--method", default="default", help="fitter: 'default' (the fast one) or 'gapso'")
    parser.add_argument("--band", help="frequency band LO:HI in Hz (default 20:1000, capped at 0.45·fs)")
    parser.add_argument("--fit-mass", action="store_true", help="identify each direction's mass or inertia too")
    parser.add_argument("--exp-end", type=float,
                        help="exponential window's value at the record end for UFF time records (default: none; a "
                             "session uses its own window)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fitters' random starts")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    parser.add_argument("--out", type=Path, help="folder for the figures (default: next to the input)")
    parser.add_argument("--no-figures", action="store_true", help="write no figures")
    parser.add_argument("--overwrite", action="store_true", help="replace figures that exist already")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.identification import METHODS
    from gasfilm.analysis.identification.rigid import identify_rigid
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.rigid_figures import channel_figure, direction_figure
    from gasfilm.analysis.rigid_session import session_rigid_frf
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import is_time_record_file
    from gasfilm.app.commands.fit import parse_band, parse_models

    if args.method not in METHODS:
        raise SettingError(f"--method '{args.method}': choose one of {', '.join(METHODS)}")
    models = [model.name for model in parse_models(args.models)]
    points = None if args.points is None else [point.strip() for point in args.points.split(",") if point.strip()]
    check_inputs([args.source], (".uff", ".unv"), "a session or UFF time records")
    spec = RigSpec.load(args.rig) if args.rig is not None else None
    if spec is not None and spec.rigid_body is None:
        raise SettingError(f"--rig {args.rig}: the rig spec has no [rigid_body] (docs/rig-spec.md)")
    out = args.out if args.out is not None else args.source.parent
    stem = args.source.stem
    figure_paths = [] if args.no_figures else check_output_folder(
        out, "--out" if args.out is not None else "", (f"{stem}-rigid-directions.png", f"{stem}-rigid-channels.png"),
        args.overwrite)
    uff = is_time_record_file(args.source)
    if uff:
        from gasfilm.analysis.rigid_uff import read_rigid_uff

        if spec is None:
            raise SettingError(f"--rig: {args.source} is a UFF file; give the rig spec of its geometry "
                               f"(docs/rig-spec.md, [rigid_body])")
        from gasfilm.analysis.spectra import WindowSettings

        rigid = read_rigid_uff(args.source, spec, WindowSettings(exponential_end_fraction=args.exp_end), points)
    else:
        with Session.open(args.source) as session:
            rigid = session_rigid_frf(session, spec=spec, points=points)
    band = parse_band(args.band, rigid.sample_rate_hz)
    identification = identify_rigid(rigid, models, band, args.method, args.fit_mass, args.seed)
    if not uff:
        with Session.open(args.source, "a") as session:
            session.write_rigid_body(identification.to_dict())
    figures = [] if args.no_figures else [direction_figure(figure_paths[0], rigid, identification),
                                          channel_figure(figure_paths[1], rigid)]
    if args.json:
        print(json.dumps({"source": str(args.source), **identification.to_dict(),
                          "figures": [str(path) for path in figures]}))
        return 0
    print(f"{args.source}: rigid-body test, {identification.band_hz[0]:g}–{identification.band_hz[1]:g} Hz, "
          f"method {args.method}")
    for line in identification.summary_lines():
        print(line)
    if not uff:
        print(f"stored in {args.source} (/rigid_body)")
    if figures:
        print("figures: " + ", ".join(str(path) for path in figures))
    return 0
