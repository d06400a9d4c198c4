"""The ``gasfilm`` command line: a thin shell over :mod:`drivers` and :mod:`analysis`.

Each sub-command lives in :mod:`gasfilm.app.commands` as a module with ``register(subparsers)``, which adds its parser and
sets ``func`` (called with the parsed arguments, returning the exit status). Errors that gasfilm raises on purpose
are printed as one line and exit with status 2; nothing ever prints a traceback unless ``GASFILM_DEBUG=1``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import Sequence

from gasfilm.drivers.errors import GasfilmError

COMMAND_MODULES = ("demo", "acquire", "replay", "export", "fit", "diagnose", "gui", "report")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gasfilm",
        description="Impact-hammer testing of air-bearing gas films: acquire, FRF, identify, diagnose.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"gasfilm.app.commands.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"gasfilm.app.commands.{name}":
                raise
            continue
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except GasfilmError as error:
        print(f"gasfilm {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"gasfilm {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # a bug: still one line for the user, the traceback on request
        if os.environ.get("GASFILM_DEBUG") == "1":
            raise
        print(
            f"gasfilm {args.command}: internal error: {type(error).__name__}: {error} "
            f"(set GASFILM_DEBUG=1 for details)",
            file=sys.stderr,
        )
        return 3


if __name__ == "__main__":
    sys.exit(main())
