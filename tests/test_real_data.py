"""A recording nobody here made: pyFRF's 5 hammer hits (fixtures/real-data/pyfrf-5-hits, MIT licence).

Capture, validation, windows, averaging and coherence on real hits: 25.6 kHz, 1 s records, rows time/force/
acceleration; a lightly damped structure with modes near 900, 2640, 3669/3690 and 4128 Hz.
"""

from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from pyFRF import FRF

from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.spectra import WindowSettings, compute_frf, session_frf
from gasfilm.analysis.validation import ValidationSettings, validate_hit

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"
FS_HZ = 25_600.0
MODES_HZ = (900.0, 2640.0, 3669.0, 3690.0, 4128.0)
WINDOW = WindowSettings(force_window_ms=2.0, force_taper_ms=0.5, exponential_end_fraction=0.01)


@pytest.fixture(scope="module")
def measured() -> np.ndarray:
    """(5 hits, 2 rows force/acceleration, 25600 samples)."""
    data = np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])
    assert data.shape == (5, 3, 25_600)
    assert np.allclose(np.diff(data[0, 0]), 1 / FS_HZ)
    return data[:, 1:]


def as_hits(records: np.ndarray) -> list[HitRecord]:
    trigger = int(np.flatnonzero(records[0, 0] >= 20.0)[0])
    return [HitRecord(i, r, FS_HZ, trigger, float(i), np.zeros(2, bool)) for i, r in enumerate(records)]


def stream_of(records: np.ndarray, gap_s: float = 0.3, seed: int = 4) -> np.ndarray:
    """The 5 records one after another, each after a quiet gap of sensor-level noise."""
    rng = np.random.default_rng(seed)
    gap = int(gap_s * FS_HZ)
    pieces = []
    for record in records:
        pieces.append(np.stack((rng.normal(0, 0.02, gap), rng.normal(0, 0.3, gap))))
        pieces.append(record)
    return np.concatenate(pieces, axis=1)


@pytest.mark.parametrize("chunk_sizes", [[997], [1, 13, 4099], [30_011]])
def test_capture_finds_exactly_the_five_hits(measured, chunk_sizes):
    stream = stream_of(measured)
    first_trigger = int(np.flatnonzero(measured[0, 0] >= 20.0)[0])
    settings = TriggerSettings(level_n=20.0, hysteresis_n=5.0, pretrigger_s=first_trigger / FS_HZ, record_s=1.0)
    capture = ImpactCapture(settings, FS_HZ, channel_count=2)
    records = []
    position, k = 0, 0
    while position < stream.shape[1]:
        size = chunk_sizes[k % len(chunk_sizes)]
        records.extend(capture.feed(stream[:, position : position + size]))
        position += size
        k += 1
    assert capture.flush() == [] and capture.incomplete_at_end == 0
    assert len(records) == 5
    for record, original in zip(records, measured):
        # every hit triggers at the same sample of its recording, so the capture gives back the recording itself
        np.testing.assert_array_equal(record.data, original)
    np.testing.assert_array_equal(session_frf(records).h1, compute_frf(measured, FS_HZ).h1)


def test_validation_accepts_the_real_hits_and_flags_truncated_ones_honestly(measured):
    hits = as_hits(measured)
    for hit in hits:
        # the structure still rings at 1-2 % of its start after 1 s: flagged, with the leakage and the window to use
        verdict = validate_hit(hit, ValidationSettings())
        assert verdict.reasons == ("response not decayed",)
        (note,) = verdict.notes
        end_percent = float(note.split(" of its start")[0].rsplit(" ", 1)[1].rstrip("%"))
        assert 0.5 < end_percent < 2.5
        assert "leakage" in note and "--exp-end" in note
        suggested = float(note.split("--exp-end ")[1].split(")")[0])
        assert validate_hit(hit, window=WindowSettings(exponential_end_fraction=suggested)).accepted
        assert validate_hit(hit, window=WINDOW).accepted
    # cut to 0.25 s the lightly damped structure still rings at the end: leakage, flagged; the window cures it
    for hit in as_hits(measured[:, :, : int(0.25 * FS_HZ)]):
        assert validate_hit(hit).reasons == ("response not decayed",)
        assert validate_hit(hit, window=WINDOW).accepted


def test_rectangular_frf_equals_pyfrf_on_the_real_hits(measured):
    result = compute_frf(measured, FS_HZ)
    reference = FRF(int(FS_HZ), exc=measured[:, 0], resp=measured[:, 1], exc_type="f", resp_type="a")
    lines = slice(1, None)
    for ours, theirs in (
        (result.h1, reference.get_FRF("H1", frf_form="accelerance")[0, 0]),
        (result.h2, reference.get_FRF("H2", frf_form="accelerance")[0, 0]),
        (result.coherence, reference.get_coherence()[0]),
    ):
        assert np.max(np.abs(ours[lines] - theirs[lines]) / np.abs(theirs[lines])) < 1e-9


def test_windowed_frf_agrees_with_pyfrf_rectangular_away_from_the_peaks(measured):
    windowed = compute_frf(measured, FS_HZ, WINDOW)
    reference = FRF(int(FS_HZ), exc=measured[:, 0], resp=measured[:, 1], exc_type="f", resp_type="a")
    h1_rectangular = reference.get_FRF("H1", frf_form="accelerance")[0, 0]
    band = (windowed.freq_hz > 100) & (windowed.freq_hz < 5000)
    difference = np.abs(np.abs(windowed.h1[band]) / np.abs(h1_rectangular[band]) - 1)
    assert np.median(difference) < 0.02
    assert windowed.decay_rate_1_s == pytest.approx(np.log(100) * FS_HZ / (25_600 - 1))


@pytest.mark.parametrize("window", [WindowSettings(), WINDOW], ids=["rectangular", "force+exponential"])
def test_modes_are_found_with_coherence_near_one(measured, window):
    result = compute_frf(measured, FS_HZ, window)
    magnitude = np.abs(result.h1)
    peaks, _ = scipy.signal.find_peaks(magnitude, prominence=0.02 * magnitude.max())
    peak_hz = result.freq_hz[peaks]
    for mode_hz in MODES_HZ:
        assert np.min(np.abs(peak_hz - mode_hz)) <= 2.0, mode_hz
        around = np.abs(result.freq_hz - mode_hz) <= 20.0
        assert result.coherence[around].min() > 0.99
        assert np.all(result.h1_std_coherence[around] < 0.05 * magnitude[around])  # γ² > 0.99, 5 hits
    assert result.n_averages == 5


def test_real_hits_are_stored_replayed_and_exported_like_our_own(measured, tmp_path, capsys):
    """The real recording goes through the same path as a live session: hit recorder → HDF5 session → `gasfilm
    replay` with windows → `gasfilm export` as UFF 58, read back with pyuff."""
    import json

    import pyuff

    from gasfilm.analysis.recording import HitRecorder
    from gasfilm.analysis.session import Session
    from gasfilm.app.cli import main as gasfilm
    from gasfilm.drivers.interface import ChannelConfig, ChannelKind, DaqConfig

    # 25.6 kS/s is an NI 9234 rate (51 200 / 2); sensitivities chosen so that ±5 V holds the recorded peaks
    config = DaqConfig(
        (ChannelConfig("ai0", ChannelKind.FORCE, 2.25, "mV/N"), ChannelConfig("ai1", ChannelKind.ACCELERATION, 1.0, "mV/g")),
        FS_HZ,
    )
    trigger = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=0.9)
    session_path = tmp_path / "real.h5"
    stream = stream_of(measured)
    # recorded with the exponential window its ringing tail needs (without one the hits are "response not decayed")
    with Session.create(session_path, config, None, {"trigger": trigger, "window": WINDOW},
                        sync_each_hit=False) as session:
        recorder = HitRecorder(session, ImpactCapture(trigger, FS_HZ, 2, 0, 1), ValidationSettings(),
                               full_scale_si=tuple(c.full_scale_si for c in config.channels), window=WINDOW)
        for start in range(0, stream.shape[1], 2560):
            recorder.feed(np.ascontiguousarray(stream[:, start : start + 2560]))
    assert recorder.accepted_count == 5 and recorder.rejected_count == 0

    assert gasfilm(["replay", str(session_path), "--json", "--exp-end", "0.01", "--force-window-ms", "2"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["hits"] == 5 and summary["accepted"] == 5
    assert min(abs(summary["peak_frequency_hz"] - mode) for mode in MODES_HZ) < 5.0
    assert all(band["mean_coherence"] > 0.98 for band in summary["coherence_bands"] if band["high_hz"] <= 5000)

    uff_path = tmp_path / "real-frf.uff"
    assert gasfilm(["export", str(session_path), "--uff", str(uff_path), "--frf", "replay"]) == 0
    with Session.open(session_path) as session:
        frf = session.read_frf("replay")
    exported = [s for s in pyuff.UFF(str(uff_path)).read_sets() if s.get("type") == 58 and s["func_type"] == 4]
    assert len(exported) == 1
    np.testing.assert_allclose(exported[0]["data"], frf.h1, rtol=1e-9)
