"""Stop signals (SIGINT, SIGTERM, SIGHUP): what stops gasfilm like Ctrl-C, and the blocks a signal must not cut short.

A stop signal becomes :class:`StopSignal` (a ``KeyboardInterrupt``) where gasfilm handles it (the command line from
its first instruction, a recording between hits); inside :func:`signals_deferred` it waits until the block is done
(a commit of the session, files given their names, a session created and handed to its caller) and is then
delivered as it would have been. Light: the command line imports it before anything else."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Any, Callable, Iterator

#: The signals that stop gasfilm like Ctrl-C, where the platform has them.
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class StopSignal(KeyboardInterrupt):
    """A signal (SIGINT, SIGTERM, SIGHUP) asked gasfilm to stop."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(signal.Signals(signum).name)


#: The stop signals :func:`raise_stop_signal` raised in this process, in order.
_RAISED: list[int] = []


def raise_stop_signal(signum: int, frame: Any) -> None:
    """The signal handler that turns a stop signal into :class:`StopSignal` (and notes it). A signal that comes while a
    module is being imported is delivered again once the import is done: an extension module importing others turns
    the exception into an ImportError of its own ("initialization failed"), which a library may catch as an optional
    dependency that is missing, and the stop would be lost."""
    if _importing(frame):
        # sent to the main thread (where handlers run): a blocking call there (a sleep, a wait) then returns at once
        redelivery = threading.Timer(IMPORT_RETRY_S, signal.pthread_kill, (threading.main_thread().ident, signum))
        redelivery.daemon = True
        redelivery.start()
        return
    _RAISED.append(int(signum))
    raise StopSignal(signum)


#: How long a stop signal that came during an import waits before it is delivered again, s.
IMPORT_RETRY_S = 0.02

#: The code of Python's import machinery (frozen modules: these are the names their frames carry).
_IMPORT_MACHINERY = frozenset({"<frozen importlib._bootstrap>", "<frozen importlib._bootstrap_external>"})


def _importing(frame: Any) -> bool:
    """Whether ``frame`` (the one a signal handler is given) runs inside an import."""
    while frame is not None:
        if frame.f_code.co_filename in _IMPORT_MACHINERY:
            return True
        frame = frame.f_back
    return False


def stop_signal_raised() -> int | None:
    """The last stop signal :func:`raise_stop_signal` raised in this process (None: none)."""
    return _RAISED[-1] if _RAISED else None


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """While the block runs, a stop signal is noted instead of handled; when it ends, the first one noted is delivered
    to the handler that was in place (so it is raised right after the block). Only in the main thread (where Python
    runs signal handlers); elsewhere a no-op."""
    noted: list[int] = []

    def note(signum: int, frame: Any) -> None:  # noqa: ARG001
        noted.append(signum)

    with stop_signals_handled_by(note):
        yield
    if noted:
        signal.raise_signal(noted[0])


@contextlib.contextmanager
def stop_signals_handled_by(handler: Callable[[int, Any], None]) -> Iterator[None]:
    """While the block runs, ``handler`` handles every stop signal the process does not ignore (one it was started
    ignoring, nohup's SIGHUP or a background job's SIGINT, stays ignored); the handlers before are put back after
    it. The swap is whole either way: the kernel holds the signals back meanwhile, and a handler that raises during it
    (a signal that had come just before) does not leave part of the handlers swapped. Only in the main thread;
    elsewhere a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous: dict[int, Any] = {}
    try:
        with _held_back():  # (a signal that came before is handled when the kernel lets it through: still swapped)
            _install({signum: handler for signum in STOP_SIGNALS if signal.getsignal(signum) != signal.SIG_IGN},
                     previous)
        yield
    finally:  # also when a signal that came before the block was raised as it started: the block never ran
        with _held_back():
            _install(previous, {})


def _install(handlers: dict[int, Any], replaced: dict[int, Any]) -> None:
    """Install every handler of ``handlers`` (signal → handler), noting in ``replaced`` the handlers they replace,
    whatever a handler raises meanwhile (it is raised once all are in place)."""
    raised: BaseException | None = None
    for signum, handler in handlers.items():
        while signum not in replaced:
            try:
                replaced[signum] = signal.signal(signum, handler)
            except BaseException as error:  # (signal.signal runs the handlers of signals already come)
                raised = raised or error
    if raised is not None:
        raise raised


@contextlib.contextmanager
def _held_back() -> Iterator[None]:
    """Stop signals blocked by the kernel while the block runs (delivered after it), where the platform can."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def die_with_parent(parent_pid: int) -> None:
    """In a forked child: be killed when the parent dies, killed or not (Linux's PR_SET_PDEATHSIG; elsewhere only the
    check below), and end now if it died already."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:
        os._exit(1)
