"""Software trigger on the force channel: a stream of chunks in, one :class:`HitRecord` per hammer hit out.

:class:`ImpactCapture` is a pure consumer of chunks. It keeps the last record's worth of samples in a ring buffer,
scans the force channel with an armed/fired state machine (level in newtons, slope, hysteresis, hold-off) and emits a
record as soon as its last sample has arrived. The trigger never waits for a record to be filled or validated: the
next trigger is searched from the hold-off after the previous one, so records of hits closer together than a record
length overlap and no hit is missed. Chunk boundaries do not matter: a chunk of one sample and a chunk of several
records give the same records.

Trigger rule (rising slope): the trigger is *armed* when the force is below ``level_n - hysteresis_n`` and *fires* at
the first armed sample at or above ``level_n``; after firing it disarms and looks again only from ``holdoff_s``
after the trigger. Falling slope mirrors it: armed above ``level_n + hysteresis_n``, fires at or below ``level_n``.
A record holds ``record_s`` of samples in total, of which ``pretrigger_s`` precede the trigger sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gasfilm.drivers.errors import SettingError

SLOPES = ("rising", "falling")
#: Longest record per hit in s for a live acquisition (GUI and CLI alike): a hammer test's response has decayed long
#: before, and a 100 s record at 51.2 kS/s is 80 MB per hit (a session of rejected hits fills the disk).
MAX_RECORD_S = 20.0


def check_record_length(record_s: float, setting: str = "record length") -> None:
    """Refuse a live record length beyond :data:`MAX_RECORD_S`; ``setting`` is the name the user typed or sees (the
    CLI's ``--record-s``, the GUI's "Record (s)"). Stored recordings of any length can still be read and replayed."""
    if record_s > MAX_RECORD_S:
        raise SettingError(
            f"{setting}: {record_s:g} s is longer than a hammer test needs (at most {MAX_RECORD_S:g} s per hit)"
        )


@dataclass(frozen=True)
class TriggerSettings:
    """Where a hit starts and how much of it is kept."""

    level_n: float = 20.0
    slope: str = "rising"
    hysteresis_n: float = 5.0
    pretrigger_s: float = 0.01
    record_s: float = 1.0
    holdoff_s: float = 0.05

    def __post_init__(self) -> None:
        if self.slope not in SLOPES:
            raise SettingError(f"slope: '{self.slope}' is not one of {', '.join(SLOPES)}")
        for name in ("level_n", "hysteresis_n", "pretrigger_s", "record_s", "holdoff_s"):
            if not np.isfinite(getattr(self, name)):
                raise SettingError(f"{name}: {getattr(self, name)} is not a finite number")
        if self.hysteresis_n < 0:
            raise SettingError(f"hysteresis_n: {self.hysteresis_n} N is negative; use 0 or more")
        if self.record_s <= 0:
            raise SettingError(f"record_s: {self.record_s} s must be positive")
        if not 0 <= self.pretrigger_s < self.record_s:
            raise SettingError(
                f"pretrigger_s: {self.pretrigger_s} s must be at least 0 and shorter than record_s ({self.record_s} s)"
            )
        if self.holdoff_s < 0:
            raise SettingError(f"holdoff_s: {self.holdoff_s} s is negative; use 0 or more")

    def record_samples(self, sample_rate_hz: float) -> int:
        """Samples per record (at least 2)."""
        return max(2, int(round(self.record_s * sample_rate_hz)))

    def pretrigger_samples(self, sample_rate_hz: float) -> int:
        """Samples before the trigger sample in a record."""
        return min(int(round(self.pretrigger_s * sample_rate_hz)), self.record_samples(sample_rate_hz) - 1)

    def holdoff_samples(self, sample_rate_hz: float) -> int:
        """Samples after a trigger during which no new trigger is searched (at least 1)."""
        return max(1, int(round(self.holdoff_s * sample_rate_hz)))


@dataclass
class HitRecord:
    """One captured hit: all channels around a trigger, in N and m/s²."""

    index: int
    data: np.ndarray  # (channels, samples) float64
    sample_rate_hz: float
    trigger_index: int  # sample of the trigger inside ``data``
    start_time_s: float  # time of data[:, 0] since the start of the stream
    overload: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # (channels,) hardware overload flag
    force_channel: int = 0
    response_channel: int = 1

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[1])

    @property
    def force_n(self) -> np.ndarray:
        return self.data[self.force_channel]

    @property
    def response(self) -> np.ndarray:
        return self.data[self.response_channel]

    @property
    def trigger_time_s(self) -> float:
        return self.start_time_s + self.trigger_index / self.sample_rate_hz

    def time_s(self) -> np.ndarray:
        """Time of every sample since the start of the stream."""
        return self.start_time_s + np.arange(self.n_samples) / self.sample_rate_hz


class ImpactCapture:
    """Stream consumer: ``feed`` chunks of (channels, n) samples, get the completed :class:`HitRecord`\\ s back."""

    def __init__(
        self,
        settings: TriggerSettings,
        sample_rate_hz: float,
        channel_count: int,
        force_channel: int = 0,
        response_channel: int = 1,
        stream_start_s: float = 0.0,
    ) -> None:
        """``stream_start_s``: the session time of the stream's first sample (a run appended to a session continues
        its clock)."""
        if not sample_rate_hz > 0:
            raise SettingError(f"sample_rate_hz: {sample_rate_hz} must be positive")
        if channel_count < 1:
            raise SettingError(f"channel_count: {channel_count} must be at least 1")
        for name, channel in (("force_channel", force_channel), ("response_channel", response_channel)):
            if not 0 <= channel < channel_count:
                raise SettingError(f"{name}: {channel} is not a channel index below channel_count {channel_count}")
        self.settings = settings
        self.sample_rate_hz = float(sample_rate_hz)
        self.stream_start_s = float(stream_start_s)
        self.channel_count = channel_count
        self.force_channel = force_channel
        self.response_channel = response_channel
        self.record_samples = settings.record_samples(sample_rate_hz)
        self.pretrigger_samples = settings.pretrigger_samples(sample_rate_hz)
        self.holdoff_samples = settings.holdoff_samples(sample_rate_hz)
        if settings.slope == "rising":
            self._sign = 1.0
        else:
            self._sign = -1.0
        # In sign-normalised force (rising: f, falling: -f) the trigger fires at >= fire and arms at < arm.
        self._fire_level = self._sign * settings.level_n
        # re-armed below the level less the hysteresis, never less than half the level: a level under the hysteresis
        # (2 N against 5 N) would otherwise wait for a force of -3 N, which an AC-coupled quiet hammer never reaches
        self._arm_level = self._fire_level - min(settings.hysteresis_n, 0.5 * abs(settings.level_n))
        self._capacity = 2 * self.record_samples
        self.incomplete_at_end = 0
        self._reset_stream()

    def _reset_stream(self) -> None:
        self._samples = np.zeros((self.channel_count, self._capacity))
        self._overload = np.zeros((self.channel_count, self._capacity), bool)
        self._total = 0  # samples consumed since the start of the stream
        self._search_from = 0  # first sample the trigger may look at
        self._armed = False
        self._pending: list[int] = []  # absolute trigger samples whose records are not complete
        self._next_index = 0

    @property
    def samples_seen(self) -> int:
        return self._total

    def feed(self, chunk: np.ndarray, overload: np.ndarray | None = None) -> list[HitRecord]:
        """Consume a chunk (channels, n); ``overload`` is the device's per-channel flag for it, (channels,) or
        (channels, n). Returns the records completed by this chunk, oldest first."""
        chunk = np.asarray(chunk, dtype=float)
        if chunk.ndim != 2 or chunk.shape[0] != self.channel_count:
            raise SettingError(
                f"capture: chunk of shape {chunk.shape} does not have {self.channel_count} channel rows"
            )
        if overload is None:
            flags = np.zeros((self.channel_count, 1), bool)
        else:
            flags = np.asarray(overload, dtype=bool)
            if flags.ndim == 1:
                flags = flags[:, np.newaxis]
            if flags.shape[0] != self.channel_count or flags.shape[1] not in (1, chunk.shape[1]):
                raise SettingError(
                    f"capture: overload flags of shape {np.shape(overload)} do not match the chunk {chunk.shape}"
                )
        records: list[HitRecord] = []
        step = self.record_samples
        for start in range(0, chunk.shape[1], step):
            piece = chunk[:, start : start + step]
            piece_flags = flags if flags.shape[1] == 1 else flags[:, start : start + step]
            records.extend(self._consume(piece, piece_flags))
        return records

    def flush(self) -> list[HitRecord]:
        """End of stream: records still being filled are dropped (counted in ``incomplete_at_end``), never returned
        partial; the capture is ready for a new stream. Every complete record has already been returned by ``feed``,
        so the list is empty."""
        self.incomplete_at_end += len(self._pending)
        self._reset_stream()
        return []

    def _consume(self, piece: np.ndarray, flags: np.ndarray) -> list[HitRecord]:
        n = piece.shape[1]
        positions = (self._total + np.arange(n)) % self._capacity
        self._samples[:, positions] = piece
        self._overload[:, positions] = flags
        self._scan(self._sign * piece[self.force_channel])
        self._total += n
        return self._complete_records()

    def _scan(self, force: np.ndarray) -> None:
        """Run the armed/fired state machine over the sign-normalised force of the newest piece."""
        first = self._total
        end = first + force.size
        position = max(self._search_from, first)
        while position < end:
            local = force[position - first :]
            if not self._armed:
                below = np.flatnonzero(local < self._arm_level)
                if below.size == 0:
                    return
                self._armed = True
                position += int(below[0])
                local = force[position - first :]
            above = np.flatnonzero(local >= self._fire_level)
            if above.size == 0:
                return
            trigger = position + int(above[0])
            self._pending.append(trigger)
            self._armed = False
            position = trigger + self.holdoff_samples
            self._search_from = position

    def _complete_records(self) -> list[HitRecord]:
        records = []
        while self._pending:
            trigger = self._pending[0]
            record_start = max(0, trigger - self.pretrigger_samples)
            record_end = record_start + self.record_samples
            if record_end > self._total:
                break
            self._pending.pop(0)
            positions = np.arange(record_start, record_end) % self._capacity
            records.append(
                HitRecord(
                    index=self._next_index,
                    data=self._samples[:, positions],
                    sample_rate_hz=self.sample_rate_hz,
                    trigger_index=trigger - record_start,
                    start_time_s=self.stream_start_s + record_start / self.sample_rate_hz,
                    overload=self._overload[:, positions].any(axis=1),
                    force_channel=self.force_channel,
                    response_channel=self.response_channel,
                )
            )
            self._next_index += 1
        return records
