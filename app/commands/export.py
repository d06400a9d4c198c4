"""``gasfilm export``: the averaged FRF and coherence of a session or of time records, as UFF 58 or CSV.

The FRF stored in a session is exported (``--frf NAME``; by default "frf", or the only one stored). A session
without a stored FRF is averaged from its accepted hits with the session's window settings first; UFF or .npy time
records are averaged over the hits ``replay`` would accept. A UFF export also holds the time records of the hits the
FRF averages (unless ``--no-time-records``), so ``replay``, ``diagnose`` and ``fit`` read it back. An existing output
file is replaced only with ``--overwrite``. A session of a rigid-body test (a ``[rigid_body]`` rig spec) goes to UFF
whole: its geometry, every accelerometer's H1 and coherence at every hammer point and the time records
(:mod:`gasfilm.analysis.rigid_uff`; ``gasfilm rigid FILE.uff --rig SPEC`` reads it back).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gasfilm.app.commands.common import (ESTIMATOR_NAMES, add_estimator_flag, check_inputs, check_output_file,
                                         check_output_suffix, load_frf_and_hits, source_conditions)
from gasfilm.drivers.errors import SettingError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("export", help="export the averaged FRF and coherence of a session or of time "
                                   "records (UFF 58 or CSV)")
    parser.add_argument("source", type=Path, nargs="+", metavar="SESSION.h5|FILE.uff|HIT.npy",
                        help="a session, UFF 58 time records, or .npy hit records")
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--uff", type=Path, metavar="OUT.uff", help="write H1 (accelerance) and coherence as UFF 58")
    target.add_argument("--csv", type=Path, metavar="OUT.csv", help="write the FRF, coherence and uncertainty as CSV")
    parser.add_argument("--time-records", action=argparse.BooleanOptionalAction, default=None,
                        help="UFF: also write the averaged hits' force and response time records (dataset 58, "
                             "function type 1), which replay and diagnose need (default: yes)")
    parser.add_argument("--overwrite", action="store_true", help="replace the output file if it exists")
    add_estimator_flag(parser, "UFF: which FRF estimator is written (the CSV holds H1, H2 and Hv)")
    parser.add_argument("--frf", metavar="NAME", help="which stored FRF (default: 'frf' or the only one)")
    parser.add_argument("--response-dof", type=int, nargs=2, default=(1, 3), metavar=("NODE", "DIR"),
                        help="UFF: response node and direction (default 1 3)")
    parser.add_argument("--reference-dof", type=int, nargs=2, default=(1, 3), metavar=("NODE", "DIR"),
                        help="UFF: reference (hammer) node and direction (default 1 3)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.spectra import write_frf_csv
    from gasfilm.analysis.uff import export_frf_uff

    check_inputs(args.source)  # the inputs before the outputs
    flag, target = ("--uff", args.uff) if args.uff is not None else ("--csv", args.csv)
    check_output_suffix(target, flag, (".uff", ".unv") if args.uff is not None else (".csv",))
    if args.csv is not None and args.time_records:
        raise SettingError("--time-records: only a UFF export holds time records (use --uff OUT.uff)")
    check_output_file(target, flag, args.overwrite)
    if args.uff is not None and args.frf is None and _export_rigid_body(args):
        return 0
    with_hits = args.uff is not None and args.time_records is not False
    loaded = load_frf_and_hits(args.source, args.frf, with_hits=with_hits)
    frf = loaded.frf
    conditions = source_conditions(args.source)
    estimator = ESTIMATOR_NAMES[args.estimator]
    if args.uff is not None:
        import dataclasses

        import numpy as np

        chosen = getattr(frf, args.estimator)
        if not np.all(np.isfinite(chosen[frf.freq_hz > 0])):
            raise SettingError(f"--estimator {args.estimator}: {args.source[0]} holds no force and response spectra "
                               f"({estimator} needs them; an FRF read from a file has H1 only)")
        export_frf_uff(dataclasses.replace(frf, h1=np.nan_to_num(chosen)), args.uff, tuple(args.response_dof),
                       tuple(args.reference_dof), description=f"gasfilm {args.source[0].name}", hits=loaded.hits,
                       conditions=conditions, estimator=estimator)
    else:
        write_frf_csv(frf, args.csv, conditions)
    if loaded.note:  # (once written: a refused export is one line)
        print(f"note: {loaded.note}", file=sys.stderr)
    records = f", with the time records of {len(loaded.hits)} hits" if loaded.hits else ""
    if with_hits and not loaded.hits:
        records = ", no time records (the source holds none)"
    written = f"{estimator} of the " if args.uff is not None and args.estimator != "h1" else ""
    print(f"{written}{loaded.what} of {args.source[0]} ({len(frf.freq_hz)} lines, {frf.n_averages} averages{records}) "
          f"written to {target}")
    return 0


def _export_rigid_body(args: argparse.Namespace) -> bool:
    """A rigid-body session to UFF (geometry, every channel at every point, time records); False for another
    source, which is exported as one FRF."""
    from gasfilm.analysis.conditions import format_conditions
    from gasfilm.analysis.rigid_session import accelerometer_rows, hits_by_point, session_rigid_frf, session_spec
    from gasfilm.analysis.rigid_uff import export_rigid_uff
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import is_time_record_file

    if len(args.source) != 1 or is_time_record_file(args.source[0]):
        return False
    with Session.open(args.source[0]) as session:
        spec = session_spec(session)
        if spec is None:
            return False
        rigid = session_rigid_frf(session, spec=spec)
        hits = [hit for hit in session.hits() if hit.verdict.accepted] if args.time_records is not False else []
        conditions = source_conditions(args.source)
        export_rigid_uff(args.uff, spec, rigid, hits_by_point(spec, session.settings, hits),
                         accelerometer_rows(spec, session.daq_config), f"gasfilm {args.source[0].name}",
                         format_conditions(conditions) if conditions else "")
    print(f"rigid-body test {args.source[0]}: geometry, H1 and coherence of {len(rigid.sensor_names)} accelerometers "
          f"at {len(rigid.point_names)} hammer points ({len(rigid.freq_hz)} lines)"
          + (f", time records of {len(hits)} hits" if hits else "") + f" written to {args.uff}")
    return True
