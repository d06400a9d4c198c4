"""Software trigger: records independent of chunking, one per hit, level/slope/hysteresis/hold-off, overload flags."""

import numpy as np
import pytest

from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.drivers.errors import SettingError

FS_HZ = 5120.0
SETTINGS = TriggerSettings(level_n=20.0, hysteresis_n=5.0, pretrigger_s=0.01, record_s=0.2, holdoff_s=0.05)


def half_sine(n_samples: int, start: int, width: int, peak_n: float) -> np.ndarray:
    pulse = np.zeros(n_samples)
    pulse[start : start + width] = peak_n * np.sin(np.pi * (np.arange(width) + 0.5) / width)
    return pulse


def stream_with_hits(hit_samples, peaks_n=None, n_samples=20_000, seed=0, width=8):
    """Force (row 0) with half-sine pulses, response (row 1) ringing after each, and a third row of noise."""
    rng = np.random.default_rng(seed)
    force = rng.normal(0.0, 0.05, n_samples)
    response = rng.normal(0.0, 0.01, n_samples)
    t = np.arange(n_samples) / FS_HZ
    for i, start in enumerate(hit_samples):
        peak = 200.0 if peaks_n is None else peaks_n[i]
        force += half_sine(n_samples, start, width, peak)
        after = t - start / FS_HZ
        response += np.where(after >= 0, peak / 25 * np.exp(-60 * after) * np.sin(2 * np.pi * 195 * after), 0.0)
    return np.stack((force, response, rng.normal(0.0, 1.0, n_samples)))


def expected_triggers(force: np.ndarray, settings: TriggerSettings = SETTINGS) -> list[int]:
    """The trigger rule written out sample by sample, as an independent reference."""
    armed, next_allowed, triggers = False, 0, []
    for i, value in enumerate(force):
        if i < next_allowed:
            continue
        if not armed:
            armed = value < settings.level_n - min(settings.hysteresis_n, 0.5 * settings.level_n)
            if not armed:
                continue
        if value >= settings.level_n:
            triggers.append(i)
            armed = False
            next_allowed = i + settings.holdoff_samples(FS_HZ)
    return triggers


def capture_all(stream: np.ndarray, chunk_sizes, settings: TriggerSettings = SETTINGS, overload=None):
    capture = ImpactCapture(settings, FS_HZ, channel_count=stream.shape[0], force_channel=0, response_channel=1)
    records: list[HitRecord] = []
    position, k = 0, 0
    while position < stream.shape[1]:
        size = chunk_sizes[k % len(chunk_sizes)]
        chunk = stream[:, position : position + size]
        flags = None if overload is None else overload(position, chunk.shape[1])
        records.extend(capture.feed(chunk, flags))
        position += size
        k += 1
    return records, capture


@pytest.mark.parametrize("chunk_sizes", [[1], [7, 13, 1], [512], [1023, 1, 1024], [5000], [20_000]])
def test_records_do_not_depend_on_chunking(chunk_sizes):
    hits = [600, 3000, 3900, 9000, 15_000]
    stream = stream_with_hits(hits)
    records, _ = capture_all(stream, chunk_sizes)
    triggers = expected_triggers(stream[0])
    assert len(triggers) == len(hits)
    assert [r.index for r in records] == list(range(len(hits)))
    pre = SETTINGS.pretrigger_samples(FS_HZ)
    n = SETTINGS.record_samples(FS_HZ)
    for record, trigger in zip(records, triggers):
        start = trigger - pre
        assert record.trigger_index == pre
        assert record.data.shape == (3, n) and record.data.dtype == np.float64
        np.testing.assert_array_equal(record.data, stream[:, start : start + n])
        assert record.start_time_s == pytest.approx(start / FS_HZ)
        assert record.trigger_time_s == pytest.approx(trigger / FS_HZ)
        assert record.force_n[record.trigger_index] >= SETTINGS.level_n > record.force_n[record.trigger_index - 1]
        assert not record.overload.any()


def test_hits_closer_than_a_record_give_overlapping_records_and_none_is_missed():
    # 0.2 s records; hits 0.06 s apart arrive while the previous record is still being filled
    hits = [1000 + 310 * i for i in range(8)]
    stream = stream_with_hits(hits, n_samples=6000)
    records, _ = capture_all(stream, [97])
    assert len(records) == len(hits)
    pulse_peaks = [r.trigger_time_s for r in records]
    assert np.all(np.diff(pulse_peaks) > SETTINGS.holdoff_s)
    for record, hit in zip(records, hits):
        assert abs(record.trigger_time_s - hit / FS_HZ) < 4 / FS_HZ


def test_holdoff_suppresses_a_second_trigger_on_a_double_hit():
    stream = stream_with_hits([1000, 1000 + 40], peaks_n=[200.0, 100.0], n_samples=4000)
    records, _ = capture_all(stream, [64])
    assert len(records) == 1
    short = TriggerSettings(level_n=20.0, hysteresis_n=5.0, pretrigger_s=0.01, record_s=0.2, holdoff_s=0.002)
    records, _ = capture_all(stream, [64], settings=short)
    assert len(records) == 2


def test_hysteresis_stops_ringing_around_the_level_from_retriggering():
    n = 4000
    force = np.zeros(n)
    force[1000:1100] = 20.0 + 3.0 * np.sin(np.arange(100))  # hovers around the level, never below level - 5 N
    force[1100:] = 0.0
    stream = np.stack((force, np.zeros(n)))
    tiny_holdoff = dict(pretrigger_s=0.01, record_s=0.1, holdoff_s=0.0)
    with_hysteresis, _ = capture_all(stream, [33], TriggerSettings(level_n=20.0, hysteresis_n=5.0, **tiny_holdoff))
    without, _ = capture_all(stream, [33], TriggerSettings(level_n=20.0, hysteresis_n=0.0, **tiny_holdoff))
    assert len(with_hysteresis) == 1
    assert len(without) > 10
    assert len(without) == len(expected_triggers(force, TriggerSettings(level_n=20.0, hysteresis_n=0.0, **tiny_holdoff)))


def test_stream_starting_above_the_level_does_not_trigger_until_armed():
    force = np.concatenate((np.full(50, 100.0), np.zeros(500), half_sine(3000, 0, 8, 150.0)))
    stream = np.stack((force, np.zeros_like(force)))
    records, _ = capture_all(stream, [10])
    assert len(records) == 1
    assert records[0].trigger_time_s == pytest.approx(550 / FS_HZ)  # the pulse, not the stream start


def test_falling_slope_triggers_on_negative_pulses():
    stream = stream_with_hits([1500, 6000], n_samples=9000)
    stream[0] *= -1
    settings = TriggerSettings(level_n=-20.0, slope="falling", hysteresis_n=5.0, pretrigger_s=0.01, record_s=0.2)
    records, _ = capture_all(stream, [100], settings)
    assert len(records) == 2
    for record in records:
        assert record.force_n[record.trigger_index] <= -20.0 < record.force_n[record.trigger_index - 1]
    rising, _ = capture_all(stream, [100])
    assert rising == []


def test_trigger_near_stream_start_keeps_the_full_record_with_a_shorter_pretrigger():
    stream = stream_with_hits([10], n_samples=3000)
    records, _ = capture_all(stream, [5])
    assert len(records) == 1
    record = records[0]
    assert record.start_time_s == 0.0
    assert record.trigger_index == expected_triggers(stream[0])[0] < SETTINGS.pretrigger_samples(FS_HZ)
    assert record.n_samples == SETTINGS.record_samples(FS_HZ)


def test_overload_flags_mark_only_the_records_that_contain_them():
    hits = [1000, 5000, 9000]
    stream = stream_with_hits(hits, n_samples=12_000)

    def overload(position, size):
        flags = np.zeros((3, size), bool)
        flags[1, (np.arange(position, position + size) >= 5050) & (np.arange(position, position + size) < 5060)] = True
        return flags

    records, _ = capture_all(stream, [256], overload=overload)
    assert [bool(r.overload[1]) for r in records] == [False, True, False]
    assert not any(r.overload[0] for r in records)

    def chunk_flag(position, size):  # a per-chunk flag (channels,) as the driver's status() gives it
        return np.array([position <= 9005 < position + size, False, False])

    records, _ = capture_all(stream, [256], overload=chunk_flag)
    assert [bool(r.overload[0]) for r in records] == [False, False, True]


def test_flush_never_returns_a_partial_record():
    stream = stream_with_hits([1000, 2500], n_samples=2700)
    records, capture = capture_all(stream, [100])
    assert len(records) == 1
    assert capture.flush() == []
    assert capture.incomplete_at_end == 1
    again, _ = capture_all(stream, [100])
    assert len(again) == 1 and again[0].index == 0


@pytest.mark.parametrize(
    "field, value",
    [("slope", "up"), ("hysteresis_n", -1.0), ("record_s", 0.0), ("pretrigger_s", 2.0), ("holdoff_s", -0.1),
     ("level_n", float("nan"))],
)
def test_bad_trigger_settings_name_the_field(field, value):
    with pytest.raises(SettingError, match=field):
        TriggerSettings(**{field: value})


def test_bad_chunk_shape_and_channel_are_one_line_errors():
    capture = ImpactCapture(SETTINGS, FS_HZ, channel_count=2)
    with pytest.raises(SettingError, match="2 channel rows"):
        capture.feed(np.zeros((3, 10)))
    with pytest.raises(SettingError, match="overload"):
        capture.feed(np.zeros((2, 10)), np.zeros((2, 3), bool))
    with pytest.raises(SettingError, match="response_channel"):
        ImpactCapture(SETTINGS, FS_HZ, channel_count=2, response_channel=2)


def test_a_level_below_the_hysteresis_still_triggers():
    """New-user trial: `acquire --trigger-n 2` never fired (hits of 200 N): with the 5 N hysteresis the trigger waited
    for the force to fall below -3 N before arming. The hysteresis used is at most half the level."""
    stream = stream_with_hits([2000, 9000])
    low = TriggerSettings(level_n=2.0, hysteresis_n=5.0, pretrigger_s=0.001, record_s=0.05)
    records, _ = capture_all(stream, [500], low)
    assert [record.start_time_s + record.trigger_index / FS_HZ for record in records] == pytest.approx(
        [trigger / FS_HZ for trigger in expected_triggers(stream[0], low)])
    assert len(records) == 2
