"""``gasfilm report SESSION --out report.html``: a self-contained HTML (or PDF) report of a session for the test log."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "report", help="write an HTML or PDF report of a session (setup, hits, FRF, force spectrum, fits, diagnosis)"
    )
    parser.add_argument("session", type=Path, help="session file (.h5)")
    parser.add_argument("--out", type=Path, required=True, help="report file to write: .html (self-contained) or .pdf")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    parser.add_argument("--frf", metavar="NAME", help="which stored FRF (default: 'frf' or the only one, e.g. "
                                                      "'replay' for what gasfilm replay stored)")
    parser.add_argument("--paper", choices=("a4", "letter"),
                        help="the PDF's page size (default: as this machine prints: PAPERSIZE, /etc/papersize or "
                             "the locale, e.g. en_US → letter; A4 otherwise)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.report import check_report_path, write_report
    from gasfilm.app.commands.common import check_inputs

    check_inputs([args.session], (), "a session (HDF5)")  # the input first, then the output, then the work
    check_report_path(args.out, args.overwrite)  # before reading the session: a bad --out answers at once
    written = write_report(args.session, args.out, overwrite=args.overwrite, paper=args.paper, frf_name=args.frf)
    print(f"wrote {written}")
    return 0
