"""Live recording: chunks in, every hit captured, validated and on disk before anyone is told about it.

:class:`HitRecorder` joins the software trigger (:class:`gasfilm.analysis.capture.ImpactCapture`), the hit checks
(:func:`gasfilm.analysis.validation.validate_hit`) and a :class:`gasfilm.analysis.session.Session`. Each hit, accepted or rejected,
is appended to the session (flushed) as soon as its record is complete; only then is it reported, through the
return value of :meth:`HitRecorder.feed` and the optional callback. No printing, no Qt: the command line and the GUI
present the events.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from gasfilm.analysis.capture import HitRecord, ImpactCapture
from gasfilm.analysis.session import Session
from gasfilm.analysis.validation import ValidationSettings, Verdict, validate_hit


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
    ) -> None:
        self.session = session
        self.capture = capture
        self.validation = validation
        self.full_scale_si = None if full_scale_si is None else tuple(float(v) for v in full_scale_si)
        self.window = window
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
            verdict = validate_hit(hit, self.validation, self.full_scale_si, window=self.window)
            index = self.session.append_hit(hit, verdict)
            if verdict.accepted:
                self.accepted_count += 1
            else:
                self.rejected_count += 1
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
        return events
