"""The ``gasfilm`` command line: a thin shell over :mod:`drivers` and :mod:`analysis`.

Each sub-command lives in :mod:`gasfilm.app.commands` as a module with ``register(subparsers)``, which adds its parser and
sets ``func`` (called with the parsed arguments, returning the exit status). Registering imports no heavy library
(numpy, scipy, h5py, matplotlib, Qt): each command imports those when it runs, so ``gasfilm --help`` answers at once.

Errors that gasfilm raises on purpose are printed as one line and exit with status 2; nothing ever prints a traceback
unless ``GASFILM_DEBUG=1`` (an internal error raised with its traceback) or ``GASFILM_DEBUG=2`` (also the traceback
of an error raised on purpose: where deep in a long computation it came from). Python warnings (ADC overload, numpy
floating-point warnings) become one clean ``warning:`` line each; a closed output pipe (``gasfilm ... --json |
head``) ends the command quietly.
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import importlib
import logging
import os
import re
import sys
import warnings
from typing import Iterator, NoReturn, Sequence

from gasfilm.drivers.errors import GasfilmError

COMMAND_MODULES = ("demo", "acquire", "replay", "export", "fit", "rigid", "model", "diagnose", "gui", "report",
                   "campaign")
#: Exit status of a command whose output pipe was closed by the reader (128 + SIGPIPE, as a shell reports it).
BROKEN_PIPE_STATUS = 141

logger = logging.getLogger(__name__)


def installed_version() -> str:
    """gasfilm's version as installed (pyproject.toml's), or "unknown" when it is run from an uninstalled tree."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("gasfilm")
    except PackageNotFoundError:
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``: print gasfilm's version and exit (looked up only when asked)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:  # noqa: A002 — argparse's name
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(f"gasfilm {installed_version()}")
        parser.exit()


class _OneLineParser(argparse.ArgumentParser):
    """A parser whose usage errors are one line (bad input gets one line, as every other refusal): the message, the
    nearest flag for a mistyped one, and where the flags are listed. Its sub-commands' parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        hint = ""
        unknown = re.fullmatch(r"unrecognized arguments: (.*)", message)
        if unknown:
            typed = next((word.split("=")[0] for word in unknown.group(1).split() if word.startswith("--")), None)
            flags = [flag for flag in self._option_string_actions if flag.startswith("--")]
            close = difflib.get_close_matches(typed, flags, n=1, cutoff=0.6) if typed else []
            if close:
                hint = f"; did you mean {close[0]}?"
        choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if choice:
            close = difflib.get_close_matches(choice.group(1), re.findall(r"'([^']*)'", choice.group(2)), n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
        listed = "commands" if self.prog == "gasfilm" else "flags"
        self.exit(2, f"{self.prog}: error: {message}{hint} (`{self.prog} --help` lists the {listed})\n")


def _typed_flags(parser: argparse.ArgumentParser, argv: list[str]) -> set[str]:
    """The destinations of the flags the user typed (``--exp-end`` → ``exp_end``; abbreviations as argparse takes
    them), so a command can tell a value typed from its default."""
    options = {flag: action.dest for flag, action in parser._option_string_actions.items()}
    typed = set()
    for word in argv:
        if not word.startswith("--"):
            continue
        flag = word.split("=", 1)[0]
        matches = [flag] if flag in options else [option for option in options if option.startswith(flag)]
        if len(matches) == 1:
            typed.add(options[matches[0]])
    return typed


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineParser(
        prog="gasfilm",
        description="Impact-hammer testing of air-bearing gas films: acquire, FRF, identify, diagnose.",
    )
    parser.add_argument("--version", action=_VersionAction, help="print gasfilm's version and exit")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"gasfilm.app.commands.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"gasfilm.app.commands.{name}":
                raise
            continue
        module.register(subparsers)
    parser.set_defaults(subparsers=subparsers)
    return parser


@contextlib.contextmanager
def _user_messages(command: str) -> Iterator[None]:
    """While a command runs: gasfilm's warnings and Python warnings reach the user as one line each on stderr."""
    handler = logging.StreamHandler(sys.stderr)
    handler.addFilter(lambda record: record.levelno == logging.WARNING)  # errors reach the user as raised errors
    handler.setFormatter(logging.Formatter(f"gasfilm {command}: %(levelname)s: %(message)s"))
    package_logger = logging.getLogger("gasfilm")
    package_logger.addHandler(handler)
    if package_logger.level == logging.NOTSET:
        package_logger.setLevel(logging.INFO)  # INFO reaches file handlers (the acquire log); stderr shows WARNING+
    shown = set()

    def show_warning(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ANN001
        text = f"{category.__name__}: {message}"
        if text not in shown:  # once per distinct warning, not once per hit
            shown.add(text)
            logger.warning(text)

    previous = warnings.showwarning
    warnings.showwarning = show_warning
    try:
        yield
    finally:
        warnings.showwarning = previous
        package_logger.removeHandler(handler)


def _silence_stdout() -> None:
    """After the reader closed stdout: point it at /dev/null so the interpreter's final flush cannot fail."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass  # stdout is not a real file (e.g. captured by a test): nothing will be flushed to a pipe


def _interrupted_during(error: BaseException) -> bool:
    """Whether ``error`` was caused by a Ctrl-C (a KeyboardInterrupt in its chain of causes)."""
    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        # the usage of the command the user typed, not the top-level one
        command_parser = args.subparsers.choices.get(args.command, parser)
        command_parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    command_parser = args.subparsers.choices.get(args.command, parser)
    args.typed_flags = _typed_flags(command_parser, list(sys.argv[1:] if argv is None else argv))
    try:
        with _user_messages(args.command):
            return int(args.func(args) or 0)
    except BrokenPipeError:
        _silence_stdout()
        return BROKEN_PIPE_STATUS
    except GasfilmError as error:
        if os.environ.get("GASFILM_DEBUG") == "2":  # where a user-level error was raised, for a developer
            import traceback

            traceback.print_exc()
        print(f"gasfilm {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as stop:  # Ctrl-C, or SIGTERM/SIGHUP (gasfilm.analysis.interrupts)
        return stopped(stop, args.command)
    except MemoryError as error:
        print(f"gasfilm {args.command}: error: {out_of_memory(error)}", file=sys.stderr)
        return 2
    except Exception as error:  # a bug: still one line for the user, the traceback on request
        from gasfilm.analysis.interrupts import StopSignal, stop_signal_raised

        if stop_signal_raised() is not None:  # a stop signal that a library turned into an error of its own (an
            return stopped(StopSignal(stop_signal_raised()), args.command)  # import interrupted: ImportError)
        if _interrupted_during(error):  # a Ctrl-C inside an import (numpy says "failed to import")
            return stopped(KeyboardInterrupt(), args.command)
        if _memory_ran_out(error):  # a library that could not map itself, or wrapped a MemoryError
            print(f"gasfilm {args.command}: error: {out_of_memory(error)}", file=sys.stderr)
            return 2
        if os.environ.get("GASFILM_DEBUG") == "1":
            raise
        print(
            f"gasfilm {args.command}: internal error: {type(error).__name__}: {error} "
            f"(set GASFILM_DEBUG=1 for details)",
            file=sys.stderr,
        )
        return 3


def _memory_ran_out(error: BaseException) -> bool:
    """Whether ``error`` (or what caused it) is memory running out: a MemoryError, or a library that could not be
    mapped ("failed to map segment from shared object", "Cannot allocate memory")."""
    seen = set()
    while error is not None and id(error) not in seen:
        text = str(error).lower()
        if isinstance(error, MemoryError) or "failed to map segment" in text or "cannot allocate memory" in text:
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def out_of_memory(error: BaseException) -> str:
    """One line saying the memory ran out: the process's limit when it has one, else the machine's memory."""
    from gasfilm.app.memory import address_space_limit

    limit = address_space_limit()
    what = (f"this process may use {limit / 2**20:.0f} MB (ulimit -v); raise the limit" if limit is not None else
            "the machine's memory is used up; close other programs or analyse fewer hits at once")
    detail = " ".join(str(error).split())[:120]
    return f"out of memory ({what}){': ' + detail if detail else ''}"


def stopped(stop: KeyboardInterrupt, command: str | None) -> int:
    """Say in one line that a stop signal ended ``command``; the exit status, 128 + the signal's number."""
    import signal

    signum = getattr(stop, "signum", signal.SIGINT)
    how = "interrupted" if signum == signal.SIGINT else f"stopped by {signal.Signals(signum).name}"
    print(f"gasfilm{' ' + command if command else ''}: {how}", file=sys.stderr)
    return 128 + signum


if __name__ == "__main__":  # (the installed command starts at gasfilm.app.entry, which handles stop signals first)
    sys.exit(main())
