"""``gasfilm gui``: the technician's window (Setup → Measure → FRF → Identify → Diagnose)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path
from typing import Mapping

from gasfilm.app.commands.common import device_name
from gasfilm.drivers.errors import SettingError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("gui", help="open the GUI (simulated rig or an NI 9234)")
    parser.add_argument("--device", type=device_name, help="'sim' for the simulated rig or an NI-DAQmx device name (default: last used)")
    parser.add_argument("--session", type=Path, help="session file to open at start")
    parser.set_defaults(func=run)


def missing_display(environ: Mapping[str, str], platform: str) -> str | None:
    """Why Qt could not open a window here, before it tries (Qt aborts the process when its X11 platform finds no
    display); None when it can, or when Qt was told another platform (``QT_QPA_PLATFORM=offscreen``)."""
    qt_platform = environ.get("QT_QPA_PLATFORM", "")
    if qt_platform and not qt_platform.startswith("xcb") or not platform.startswith("linux"):
        return None
    if environ.get("DISPLAY") or (not qt_platform and environ.get("WAYLAND_DISPLAY")):
        return None
    return ("no display: neither DISPLAY nor WAYLAND_DISPLAY is set, so no window can open here. Run `./run gui` on "
            "a machine with a display (or over ssh -X); to render without one, e.g. for screenshots, set "
            "QT_QPA_PLATFORM=offscreen (python -m gasfilm.app.gui.screenshots)")


#: The signals that end the GUI as its Quit does.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)


def run(args: argparse.Namespace) -> int:
    if args.session is not None:  # a mistyped session is said here, in one line, not in a window after it opens
        from gasfilm.app.commands.common import check_inputs

        check_inputs([args.session], suffixes=(), what="a session (HDF5); a UFF file becomes one with "
                                                      "`gasfilm replay FILE.uff --out S.h5`")
    problem = missing_display(os.environ, sys.platform)
    if problem:
        raise SettingError(problem)
    # SIGTERM, SIGHUP and Ctrl-C while the GUI loads are kept, not raised inside the imports (where one could be lost
    # or leave a half-imported module): before the window stands they end the start as "interrupted", the job
    # processes and their fork server shut down by multiprocessing's exit; afterwards the window quits cleanly.
    received: list[int] = []
    for number in STOP_SIGNALS:
        signal.signal(number, lambda number_received, _frame: received.append(number_received))
    from gasfilm.app.gui.main_window import run_gui

    if received:
        raise KeyboardInterrupt(signal.Signals(received[0]).name)
    return run_gui(device=args.device, session=args.session, received=received)
