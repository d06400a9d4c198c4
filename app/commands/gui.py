"""``gasfilm gui``: the technician's window (Setup → Measure → FRF → Identify → Diagnose)."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("gui", help="open the GUI (simulated rig or an NI 9234)")
    parser.add_argument("--device", help="'sim' for the simulated rig or an NI-DAQmx device name (default: last used)")
    parser.add_argument("--session", type=Path, help="session file to open at start")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from gasfilm.app.gui.main_window import run_gui

    return run_gui(device=args.device, session=args.session)
