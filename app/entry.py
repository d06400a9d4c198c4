"""The ``gasfilm`` command's first instructions: stop signals (Ctrl-C, SIGTERM, SIGHUP) are handled from here on, so
that one arriving at any moment of the start-up (the imports take a second or two) ends the command with one line and
nothing left behind, as one arriving later does; a signal that arrives as the process exits is ignored.

Only the interpreter's own start comes before this module: a signal then meets Python's defaults. Signals blocked
when the process starts (by its parent) are delivered once the handlers are in place."""

import signal

from gasfilm.analysis.interrupts import STOP_SIGNALS, raise_stop_signal

for _signum in STOP_SIGNALS:
    if signal.getsignal(_signum) is not signal.SIG_IGN:  # (nohup's SIGHUP stays ignored)
        signal.signal(_signum, raise_stop_signal)
if hasattr(signal, "pthread_sigmask"):
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def run() -> int:
    """``gasfilm`` with the arguments of this process: its exit status (128 + the signal's number when stopped by
    one)."""
    import sys

    try:
        from gasfilm.app.cli import main, stopped

        try:
            return main()
        except KeyboardInterrupt as stop:  # before the command runs (reading its flags)
            return stopped(stop, None)
    except KeyboardInterrupt as stop:  # during the first imports
        signum = getattr(stop, "signum", signal.SIGINT)
        print(f"gasfilm: {'interrupted' if signum == signal.SIGINT else f'stopped by {signal.Signals(signum).name}'}",
              file=sys.stderr)
        return 128 + signum
    finally:
        for signum in STOP_SIGNALS:  # the process is ending: a late signal changes nothing
            signal.signal(signum, signal.SIG_IGN)


if __name__ == "__main__":
    raise SystemExit(run())
