"""Continuous acquisition: a reader thread that never waits for the people it feeds.

The reader pulls about ten chunks per second from a :class:`gasfilm.drivers.interface.DaqDevice` into a ring buffer and
hands each chunk to every consumer through that consumer's own bounded queue. A consumer that cannot keep up loses
chunks from *its* queue (counted in :attr:`Consumer.dropped_chunks`); the reader itself never blocks on a consumer,
so the device buffer never overflows because of a slow plot. A device that falls behind raises in the reader;
the error is kept in :attr:`AcquisitionLoop.error` and delivered to every consumer as a final item.
"""

from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from gasfilm.drivers.errors import DeviceError, GasfilmError
from gasfilm.drivers.interface import ChannelStatus, DaqDevice


@dataclass(frozen=True)
class Chunk:
    """One block of samples as read from the device."""

    data: np.ndarray  # (channels, samples), N and m/s²
    first_sample: int  # index of data[:, 0] since start
    sample_rate_hz: float
    status: ChannelStatus

    @property
    def start_time_s(self) -> float:
        return self.first_sample / self.sample_rate_hz


@dataclass
class Consumer:
    """A subscriber's mailbox: chunks in order, then ``None`` at the end of the stream."""

    name: str
    capacity: int
    items: "queue.Queue[Chunk | None]" = field(init=False)
    dropped_chunks: int = 0

    def __post_init__(self) -> None:
        self.items = queue.Queue(maxsize=self.capacity)

    def get(self, timeout_s: float | None = None) -> Chunk | None:
        """The next chunk, ``None`` once the stream has ended; raises ``queue.Empty`` on timeout."""
        return self.items.get(timeout=timeout_s)

    def _offer(self, chunk: Chunk | None) -> None:
        try:
            self.items.put_nowait(chunk)
        except queue.Full:
            self.dropped_chunks += 1

    def _close(self) -> None:
        """Deliver the end-of-stream mark even to a full mailbox (by dropping its oldest chunk)."""
        while True:
            try:
                self.items.put_nowait(None)
                return
            except queue.Full:
                try:
                    self.items.get_nowait()
                    self.dropped_chunks += 1
                except queue.Empty:
                    pass


class RingBuffer:
    """The most recent ``capacity`` samples of every channel, for live views."""

    def __init__(self, channel_count: int, capacity: int) -> None:
        self._data = np.zeros((channel_count, capacity))
        self._written = 0
        self._lock = threading.Lock()

    def write(self, block: np.ndarray) -> None:
        with self._lock:
            capacity = self._data.shape[1]
            total = block.shape[1]
            self._written += total - min(total, capacity)
            block = block[:, -capacity:]
            n = block.shape[1]
            start = self._written % capacity
            first = min(n, capacity - start)
            self._data[:, start : start + first] = block[:, :first]
            self._data[:, : n - first] = block[:, first:]
            self._written += block.shape[1]

    @property
    def samples_written(self) -> int:
        return self._written

    def latest(self, samples: int | None = None) -> np.ndarray:
        """A copy of the newest ``samples`` (default: all held) in time order."""
        with self._lock:
            capacity = self._data.shape[1]
            held = min(self._written, capacity)
            samples = held if samples is None else min(samples, held)
            end = self._written % capacity
            indices = (np.arange(end - samples, end)) % capacity
            return self._data[:, indices]


class AcquisitionLoop:
    """Run ``device`` on a reader thread; hand chunks to consumers without ever blocking on them."""

    def __init__(self, device: DaqDevice, ring_seconds: float = 10.0, read_timeout_s: float = 10.0) -> None:
        self.device = device
        self.sample_rate_hz = device.sample_rate_hz
        self.chunk_samples = device.config.chunk_samples
        self.channel_count = len(device.config.channels)
        self.ring = RingBuffer(self.channel_count, max(self.chunk_samples, int(ring_seconds * self.sample_rate_hz)))
        self.read_timeout_s = read_timeout_s
        self.error: GasfilmError | None = None
        self.chunks_read = 0
        self.max_read_gap_s = 0.0
        self._consumers: list[Consumer] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def subscribe(self, name: str, capacity_chunks: int = 600) -> Consumer:
        """A new mailbox receiving every chunk from now on; subscribe before :meth:`start` to get the first sample."""
        consumer = Consumer(name, capacity_chunks)
        self._consumers.append(consumer)
        return consumer

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def samples_read(self) -> int:
        return self.ring.samples_written

    def start(self) -> None:
        self._stop.clear()
        self.device.start()
        self._thread = threading.Thread(target=self._run, name="gasfilm-reader", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        """Ask the reader to stop after its current chunk, wait for it, and stop the device."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
        try:
            self.device.stop()
        except DeviceError:
            pass  # a removed device cannot be stopped; the reader already reported why

    def wait(self, timeout_s: float | None = None) -> bool:
        """Wait for the reader to end by itself (device error); True when it has ended."""
        if self._thread is None:
            return True
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def __enter__(self) -> "AcquisitionLoop":
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def _run(self) -> None:
        last_read = time.monotonic()
        try:
            while not self._stop.is_set():
                block = np.empty((self.channel_count, self.chunk_samples))
                self.device.read(block, timeout_s=self.read_timeout_s)
                now = time.monotonic()
                self.max_read_gap_s = max(self.max_read_gap_s, now - last_read)
                last_read = now
                chunk = Chunk(block, self.ring.samples_written, self.sample_rate_hz, self.device.status())
                self.ring.write(block)
                self.chunks_read += 1
                for consumer in list(self._consumers):
                    consumer._offer(chunk)
        except GasfilmError as error:
            self.error = error
        finally:
            for consumer in list(self._consumers):
                consumer._close()
