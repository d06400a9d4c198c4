"""Live recording: chunks in, every hit captured, validated and on disk before anyone is told about it.

:class:`HitRecorder` joins the software trigger (:class:`gasfilm.analysis.capture.ImpactCapture`), the hit checks
(:func:`gasfilm.analysis.validation.validate_hit`) and a :class:`gasfilm.analysis.session.Session`. Each hit, accepted or rejected,
is appended to the session (flushed) as soon as its record is complete; only then is it reported, through the
return value of :meth:`HitRecorder.feed` and the optional callback. No printing, no Qt: the command line and the GUI
present the events.

A recorder stops itself (:class:`RecordingStopped`) after a run of consecutive rejected hits, and
:meth:`HitRecorder.stop_on_signals` turns SIGINT, SIGTERM and SIGHUP into :class:`StopSignal` between hits, never
while one is being stored; :func:`stop_signals_raised` does the same at once for the setup before it.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from gasfilm.analysis.capture import HitRecord, ImpactCapture
from gasfilm.analysis.session import Session
from gasfilm.analysis.validation import ValidationSettings, Verdict, validate_hit
from gasfilm.drivers.errors import GasfilmError, SettingError

logger = logging.getLogger(__name__)

#: Consecutive rejected hits after which a recorder stops: settings that cannot give a valid hit, not bad luck.
DEFAULT_MAX_CONSECUTIVE_REJECTIONS = 20
#: The signals that stop a recording like Ctrl-C, where the platform has them.
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class RecordingStopped(GasfilmError):
    """The recorder stopped itself: too many consecutive hits were rejected (every hit stays in the session)."""


class StopSignal(KeyboardInterrupt):
    """A signal (SIGINT, SIGTERM, SIGHUP) asked the recording to stop; raised between hits."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(signal.Signals(signum).name)


@dataclass(frozen=True)
class HitEvent:
    """A hit that is now stored in the session, with the running counts after it."""

    index: int  # row in the session
    verdict: Verdict
    start_time_s: float  # time of the record's first sample since the start of the stream
    trigger_time_s: float
    peak_force_n: float
    accepted_count: int
    rejected_count: int
    record: HitRecord  # the samples as captured (also in the session)


class HitRecorder:
    """Feed it the device's chunks; it stores every hit in ``session`` and reports each one."""

    def __init__(
        self,
        session: Session,
        capture: ImpactCapture,
        validation: ValidationSettings = ValidationSettings(),
        full_scale_si: Sequence[float] | None = None,
        window: Any = None,
        on_hit: Callable[[HitEvent], None] | None = None,
        max_consecutive_rejections: int = DEFAULT_MAX_CONSECUTIVE_REJECTIONS,
        other_responses: tuple[int, ...] = (),
    ) -> None:
        if max_consecutive_rejections < 1:
            raise SettingError(f"max_consecutive_rejections: {max_consecutive_rejections} must be at least 1")
        self.max_consecutive_rejections = max_consecutive_rejections
        self.consecutive_rejections = 0
        self._storing = False  # a hit is being written: a stop signal waits until it is stored
        self._pending_signal: int | None = None
        self.session = session
        self.capture = capture
        self.validation = validation
        self.full_scale_si = None if full_scale_si is None else tuple(float(v) for v in full_scale_si)
        self.window = window
        self.other_responses = tuple(other_responses)  # a rigid body's further accelerometers, checked alike
        self.on_hit = on_hit
        verdicts = session.verdicts()
        self.accepted_count = sum(1 for verdict in verdicts if verdict.accepted)
        self.rejected_count = len(verdicts) - self.accepted_count
        self.reason_counts: dict[str, int] = {}
        for verdict in verdicts:
            self._count_reasons(verdict)

    def _count_reasons(self, verdict: Verdict) -> None:
        for reason in verdict.reasons:
            self.reason_counts[reason] = self.reason_counts.get(reason, 0) + 1

    @property
    def hit_count(self) -> int:
        return self.accepted_count + self.rejected_count

    def feed(self, chunk: np.ndarray, overload: np.ndarray | None = None) -> list[HitEvent]:
        """Consume one chunk (channels, samples) with the device's overload flags; return the hits it completed,
        each already stored and flushed."""
        events = []
        for hit in self.capture.feed(chunk, overload):
            verdict = validate_hit(hit, self.validation, self.full_scale_si, window=self.window,
                                   other_responses=self.other_responses)
            self._storing = True
            try:
                index = self.session.append_hit(hit, verdict)
            finally:
                self._storing = False
            if verdict.accepted:
                self.accepted_count += 1
                self.consecutive_rejections = 0
            else:
                self.rejected_count += 1
                self.consecutive_rejections += 1
            self._count_reasons(verdict)
            event = HitEvent(
                index=index,
                verdict=verdict,
                start_time_s=hit.start_time_s,
                trigger_time_s=hit.trigger_time_s,
                peak_force_n=float(np.max(np.abs(hit.data[hit.force_channel]))),
                accepted_count=self.accepted_count,
                rejected_count=self.rejected_count,
                record=hit,
            )
            events.append(event)
            if self.on_hit is not None:
                self.on_hit(event)
            self._raise_pending_signal()
            if self.consecutive_rejections >= self.max_consecutive_rejections:
                reasons = ", ".join(f"{reason}: {count}" for reason, count in sorted(self.reason_counts.items()))
                logger.error("%s: stopped after %d consecutive rejected hits (%s)", self.session.path,
                             self.consecutive_rejections, reasons)
                raise RecordingStopped(
                    f"{self.session.path}: stopped after {self.consecutive_rejections} consecutive rejected hits "
                    f"(last: {', '.join(verdict.reasons) or 'rejected'}); check the trigger level, ranges and record "
                    f"length"
                )
        return events

    def _raise_pending_signal(self) -> None:
        if self._pending_signal is not None:
            signum, self._pending_signal = self._pending_signal, None
            raise StopSignal(signum)

    @contextlib.contextmanager
    def stop_on_signals(self) -> Iterator[None]:
        """While the block runs, SIGINT, SIGTERM and SIGHUP raise :class:`StopSignal` (a ``KeyboardInterrupt``) so the
        caller closes the session as on Ctrl-C; a signal that arrives while a hit is being stored is raised once the
        hit is stored and reported. Only in the main thread (where Python runs signal handlers); elsewhere a no-op."""

        def handler(signum: int, frame: Any) -> None:
            if self._storing:
                self._pending_signal = signum
            else:
                raise StopSignal(signum)

        with _stop_signals_handled_by(handler):
            yield
            self._raise_pending_signal()


@contextlib.contextmanager
def stop_signals_raised() -> Iterator[None]:
    """While the block runs, SIGINT, SIGTERM and SIGHUP raise :class:`StopSignal` at once: for the setup before a
    recording (opening the device and the session), so that a signal arriving then ends the process through the
    caller's cleanup, not by the default handler. Only in the main thread; elsewhere a no-op."""

    def handler(signum: int, frame: Any) -> None:
        raise StopSignal(signum)

    with _stop_signals_handled_by(handler):
        yield


@contextlib.contextmanager
def _stop_signals_handled_by(handler: Callable[[int, Any], None]) -> Iterator[None]:
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, handler) for signum in STOP_SIGNALS}
    try:
        yield
    finally:
        for signum, action in previous.items():
            signal.signal(signum, action)
