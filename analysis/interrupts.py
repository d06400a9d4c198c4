"""Stop signals (SIGINT, SIGTERM, SIGHUP): what stops gasfilm like Ctrl-C, and the blocks a signal must not cut short.

A stop signal becomes :class:`StopSignal` (a ``KeyboardInterrupt``) where gasfilm handles it (the command line from
its first instruction, a recording between hits); inside :func:`signals_deferred` it waits until the block is done
(a commit of the session, files given their names, a session created and handed to its caller) and is then
delivered as it would have been. Light: the command line imports it before anything else."""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Any, Iterator

#: The signals that stop gasfilm like Ctrl-C, where the platform has them.
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class StopSignal(KeyboardInterrupt):
    """A signal (SIGINT, SIGTERM, SIGHUP) asked gasfilm to stop."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(signal.Signals(signum).name)


def raise_stop_signal(signum: int, frame: Any) -> None:  # noqa: ARG001 - a signal handler's signature
    """The signal handler that turns a stop signal into :class:`StopSignal`."""
    raise StopSignal(signum)


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """While the block runs, a stop signal is noted instead of handled; when it ends, the first one noted is delivered
    to the handler that was in place (so it is raised right after the block). Only in the main thread (where Python
    runs signal handlers); elsewhere a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []

    def note(signum: int, frame: Any) -> None:  # noqa: ARG001
        noted.append(signum)

    previous = {signum: signal.signal(signum, note) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, action in previous.items():
            signal.signal(signum, action)
        if noted:
            signal.raise_signal(noted[0])
