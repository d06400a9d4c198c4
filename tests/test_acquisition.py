"""The acquisition loop: chunks in order to every consumer, never blocked by a slow one, faults reported."""

import numpy as np
import pytest

from gasfilm.analysis.acquisition import AcquisitionLoop, RingBuffer
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.drivers import open_device
from gasfilm.drivers.errors import DeviceRemovedError
from gasfilm.drivers.interface import default_hammer_and_accelerometer

RATE_HZ = 51200.0 / 8


def _device(seed: int = 3):
    device = open_device("sim", plant=RigPlant.nominal(), seed=seed, pacing="fast", hit_interval_s=(0.5, 0.8))
    device.configure(default_hammer_and_accelerometer(RATE_HZ))
    return device


def _collect(consumer, chunks: int):
    received = []
    while len(received) < chunks:
        chunk = consumer.get(timeout_s=10.0)
        assert chunk is not None, "stream ended early"
        received.append(chunk)
    return received


def test_every_consumer_gets_contiguous_chunks_equal_to_direct_reads():
    device = _device()
    loop = AcquisitionLoop(device)
    first, second = loop.subscribe("first"), loop.subscribe("second")
    with device, loop:
        got_first, got_second = _collect(first, 30), _collect(second, 30)
    starts = [chunk.first_sample for chunk in got_first]
    assert starts == [i * loop.chunk_samples for i in range(30)]
    streamed = np.concatenate([chunk.data for chunk in got_first], axis=1)
    assert np.array_equal(streamed, np.concatenate([chunk.data for chunk in got_second], axis=1))
    assert got_first[0].data.shape == (2, int(RATE_HZ / 10))

    direct = _device()
    direct.start()
    block = np.empty_like(streamed)
    direct.read(block)
    assert np.array_equal(block, streamed)
    assert np.max(np.abs(streamed[0])) > 20.0  # hammer hits are in there


def test_a_slow_consumer_loses_its_own_chunks_but_never_blocks_the_reader():
    device = _device()
    loop = AcquisitionLoop(device)
    stalled = loop.subscribe("stalled plot", capacity_chunks=2)
    keeping_up = loop.subscribe("recorder", capacity_chunks=10_000)
    with device, loop:
        received = _collect(keeping_up, 200)
    assert stalled.dropped_chunks > 0
    assert keeping_up.dropped_chunks == 0
    assert [c.first_sample for c in received] == [i * loop.chunk_samples for i in range(200)]


def test_a_device_fault_is_reported_after_the_data_read_before_it():
    device = _device()
    loop = AcquisitionLoop(device)
    consumer = loop.subscribe("recorder", capacity_chunks=10_000)
    with device:
        loop.start()
        before = _collect(consumer, 5)
        device.sim_inject_fault("device_removed")
        assert loop.wait(timeout_s=10.0)
        rest = []
        while (chunk := consumer.get(timeout_s=5.0)) is not None:
            rest.append(chunk)
        loop.stop()
    assert isinstance(loop.error, DeviceRemovedError)
    assert len(before) == 5
    assert loop.chunks_read == len(before) + len(rest)


def test_ring_buffer_keeps_the_newest_samples_in_order():
    ring = RingBuffer(channel_count=2, capacity=10)
    for start in range(0, 37, 4):
        block = np.vstack([np.arange(start, start + 4), -np.arange(start, start + 4)]).astype(float)
        ring.write(block)
    latest = ring.latest()
    assert latest.shape == (2, 10)
    assert np.array_equal(latest[0], np.arange(30, 40))
    assert np.array_equal(ring.latest(3)[1], -np.arange(37, 40))
    big = np.ones((2, 25))
    ring.write(big)
    assert np.array_equal(ring.latest(), np.ones((2, 10)))
    assert ring.samples_written == 65


@pytest.mark.parametrize("capacity", [1, 3])
def test_end_of_stream_reaches_even_a_full_mailbox(capacity):
    device = _device()
    with device:
        loop = AcquisitionLoop(device)
        consumer = loop.subscribe("full", capacity_chunks=capacity)
        loop.start()
        device.sim_inject_fault("device_removed")
        assert loop.wait(timeout_s=10.0)
        items = []
        while True:
            item = consumer.get(timeout_s=5.0)
            items.append(item)
            if item is None:
                break
        loop.stop()
    assert items[-1] is None
