"""The ``gasfilm`` command's first instructions: stop signals (Ctrl-C, SIGTERM, SIGHUP) are handled from here on, so
that one arriving at any moment of the start-up (the imports take a second or two) ends the command with one line and
nothing left behind, as one arriving later does; a signal that arrives as the process exits is ignored.

Only the interpreter's own start comes before this module: a signal then meets Python's defaults. Signals blocked
when the process starts (by its parent) are delivered once the handlers are in place."""

import signal
import sys

from gasfilm.analysis.interrupts import STOP_SIGNALS, raise_stop_signal, stop_signal_raised
from gasfilm.app.memory import MIN_ADDRESS_SPACE_BYTES, address_space_limit

if hasattr(signal, "pthread_sigmask"):  # held back until run() is in place to answer them
    signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
for _signum in STOP_SIGNALS:
    if signal.getsignal(_signum) is not signal.SIG_IGN:  # (nohup's SIGHUP stays ignored)
        signal.signal(_signum, raise_stop_signal)


def _silent_once_stopped(kind: type[BaseException], value: BaseException, traceback) -> None:
    """``sys.excepthook`` for the start-up: an extension module interrupted while it imports numpy prints its own
    ImportError through this hook (numpy's ``import_array``, "_multiarray_umath failed to import"); once a stop signal
    has come, the one line :func:`run` prints says all there is."""
    if stop_signal_raised() is None:
        sys.__excepthook__(kind, value, traceback)


sys.excepthook = _silent_once_stopped


def run() -> int:
    """``gasfilm`` with the arguments of this process: its exit status (128 + the signal's number when stopped by
    one)."""
    import os

    try:
        if hasattr(signal, "pthread_sigmask"):  # (one that came while they were blocked is raised here)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
        limit = address_space_limit()
        if limit is not None:  # each BLAS thread reserves 32 MB when its library is loaded: one will do
            os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
            if limit < MIN_ADDRESS_SPACE_BYTES:
                print(f"gasfilm: error: out of memory before starting: this process may use {limit / 2**20:.0f} MB "
                      f"(ulimit -v), gasfilm's numerical libraries need about {MIN_ADDRESS_SPACE_BYTES >> 20} MB",
                      file=sys.stderr)
                return 2
        from gasfilm.app.cli import main, stopped

        try:
            return main()
        except KeyboardInterrupt as stop:  # before the command runs (reading its flags)
            return stopped(stop, None)
    except (KeyboardInterrupt, ImportError, MemoryError) as stop:  # during the first imports (an interrupted one:
        signum = getattr(stop, "signum", None) or stop_signal_raised()        # ImportError)
        if signum is None:
            if isinstance(stop, KeyboardInterrupt):
                raise
            print(f"gasfilm: error: out of memory while starting ({stop})", file=sys.stderr)
            return 2
        print(f"gasfilm: {'interrupted' if signum == signal.SIGINT else f'stopped by {signal.Signals(signum).name}'}",
              file=sys.stderr)
        return 128 + signum
    finally:
        for signum in STOP_SIGNALS:  # the process is ending: a late signal changes nothing
            signal.signal(signum, signal.SIG_IGN)


if __name__ == "__main__":
    raise SystemExit(run())
