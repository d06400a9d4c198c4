"""``gasfilm export``: a session's averaged FRF and coherence as UFF 58 or CSV.

The FRF stored in the session is exported (``--frf NAME``; by default "frf", or the only one stored). A session
without a stored FRF is averaged from its accepted hits with the session's window settings first.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


from gasfilm.analysis.session import Session, SessionError
from gasfilm.analysis.spectra import FrfResult, WindowSettings, compute_frf, write_frf_csv
from gasfilm.analysis.uff import export_frf_uff
from gasfilm.drivers.errors import SettingError



def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("export", help="export a session's averaged FRF and coherence (UFF 58 or CSV)")
    parser.add_argument("session", type=Path, metavar="SESSION.h5", help="session file")
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--uff", type=Path, metavar="OUT.uff", help="write H1 (accelerance) and coherence as UFF 58")
    target.add_argument("--csv", type=Path, metavar="OUT.csv", help="write the FRF, coherence and uncertainty as CSV")
    parser.add_argument("--frf", metavar="NAME", help="which stored FRF (default: 'frf' or the only one)")
    parser.add_argument("--response-dof", type=int, nargs=2, default=(1, 3), metavar=("NODE", "DIR"),
                        help="UFF: response node and direction (default 1 3)")
    parser.add_argument("--reference-dof", type=int, nargs=2, default=(1, 3), metavar=("NODE", "DIR"),
                        help="UFF: reference (hammer) node and direction (default 1 3)")
    parser.set_defaults(func=run)


def load_frf(session: Session, name: str | None) -> tuple[FrfResult, str]:
    """The stored FRF named ``name`` (or the default one), else one averaged from the accepted hits."""
    stored = session.result_names("frf")
    if name is not None:
        return session.read_frf(name), f"FRF '{name}'"
    if "frf" in stored:
        return session.read_frf("frf"), "FRF 'frf'"
    if len(stored) == 1:
        return session.read_frf(stored[0]), f"FRF '{stored[0]}'"
    if len(stored) > 1:
        raise SettingError(f"--frf: {session.path} holds several FRFs ({', '.join(stored)}); choose one")
    records = session.accepted_records()
    if len(records) == 0:
        raise SessionError(f"{session.path}: no stored FRF and no accepted hits to average")
    window = session.settings_as("window", WindowSettings)
    hit = session.hits()[int(session.accepted_indices()[0])]
    frf = compute_frf(records, session.sample_rate_hz, window, hit.force_channel, hit.response_channel)
    return frf, f"FRF averaged now from {len(records)} accepted hits"


def run(args: argparse.Namespace) -> int:
    with Session.open(args.session, "r") as session:
        frf, what = load_frf(session, args.frf)
    if args.uff is not None:
        export_frf_uff(frf, args.uff, tuple(args.response_dof), tuple(args.reference_dof),
                       description=f"gasfilm {args.session.name}")
        target = args.uff
    else:
        write_frf_csv(frf, args.csv)
        target = args.csv
    print(f"{what} of {args.session} ({len(frf.freq_hz)} lines, {frf.n_averages} averages) written to {target}",
          file=sys.stdout)
    return 0
