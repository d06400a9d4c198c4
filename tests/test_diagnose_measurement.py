"""Measurement properties are never physics (issue 14, item 5): a short simulated session of the paper's SD film,
changed in software the way recorders and exports change records (benchmarks/measurement_controls.py, which prints
the same table at full size), diagnosed from a start read off the FRF with only the mass, as a user with UFF time
records would: each property is recognised and noted under ``quality``, taken into the noise model or the replay, and
the verdict stays ``consistent`` or ``parameters-only``."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.diagnosis.measurement import QualityNote, hit_spectra
from gasfilm.analysis.diagnosis.recordings import Recordings, load_recordings
from gasfilm.analysis.diagnosis.result import Unexplained
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.uff import export_frf_uff
from gasfilm.app.cli import main as gasfilm

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("measurement_controls", ROOT / "benchmarks" / "measurement_controls.py")
controls = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(controls)

MASS_KG = 25.05


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Recordings, RigSpec]:
    """4 hits of 0.5 s of the SD rig on the simulator, as UFF time records carry them (no spec, no windows)."""
    path = tmp_path_factory.mktemp("measurement") / "sd.h5"
    assert gasfilm(["acquire", "--device", "sim", "--out", str(path), "--hits", "4", "--pacing", "fast",
                    "--record-s", "0.5", "--seed", "5", "--rig", str(controls.SD_RIG)]) == 0
    recordings = load_recordings(path)
    spec = RigSpec.from_toml(recordings.rig_spec_toml, str(path))
    return dataclasses.replace(recordings, rig_spec_toml=None, window=None), spec


def _diagnosed(recorded, change):
    recordings, spec = recorded
    changed = dataclasses.replace(recordings, records=change(recordings.records, recordings.sample_rate_hz, spec))
    diagnosis = diagnose(changed, mass_kg=MASS_KG)
    assert diagnosis.verdict in ("consistent", "parameters-only"), (
        [f.effect for f in diagnosis.findings], [u.band_hz for u in diagnosis.unexplained])
    assert not diagnosis.findings and not diagnosis.unexplained
    return diagnosis, {note.kind: note.message for note in diagnosis.quality}


def test_records_quantised_to_8_bits_of_the_input_range(recorded):
    diagnosis, notes = _diagnosed(recorded, controls.quantised_8_bit)
    assert "quantisation" in notes and "replayed response is quantised" in notes["quantisation"]
    assert "overload" not in notes  # a quantiser's plateau at the peak is not clipping
    assert list(diagnosis.spectra.hit_numbers) == [0, 1, 2, 3]


def test_floor_vibration_on_the_response_only(recorded):
    _, notes = _diagnosed(recorded, controls.floor_vibration)
    found_hz = [float(f) for f in re.search(r"near ([\d, ]+) Hz", notes["floor vibration"]).group(1).split(",")]
    assert any(abs(f - 30) < 5 for f in found_hz) and any(abs(f - 87) < 5 for f in found_hz)


def test_late_trigger_that_misses_the_pulse_start(recorded):
    diagnosis, notes = _diagnosed(recorded, controls.late_trigger)
    assert "late trigger" in notes and "4 record(s)" in notes["late trigger"]
    assert diagnosis.spectra.noise.source == "record tails"  # the responses decayed: no need for the hit scatter


def test_records_triggered_on_the_force_at_a_tenth_of_its_peak(recorded):
    """A recorder without pre-trigger: each record starts at its first force sample ≥ 10 % of the peak, so the front
    of every pulse (its impulse, the first acceleration samples) is lost. Each late record's missing front — its
    impulse and timing — is a nuisance parameter of the replay, fitted in every comparison and counted off the
    degrees of freedom; nothing is claimed (with the mirrored front alone: ac-coupling and film-memory)."""
    diagnosis, notes = _diagnosed(recorded, lambda records, rate_hz, spec: controls.triggered_late(records))
    assert "4 record(s) start inside their force pulse" in notes["late trigger"]
    assert diagnosis.evidence.point_count == 2 * diagnosis.evidence.spectra.h.size - 2 * 4
    recordings, _ = recorded
    assert hit_spectra(recordings.records, recordings.sample_rate_hz).replay.front_padded is None


@pytest.fixture(scope="module")
def recorded_with_mode(tmp_path_factory) -> Recordings:
    """4 hits of 0.5 s of the SD rig with a 20 g extra mode at 600 Hz (ζ 0.02), as UFF time records carry them."""
    folder = tmp_path_factory.mktemp("late-mode")
    rig = folder / "sd-mode.toml"
    rig.write_text(controls.SD_RIG.read_text() + '\n[[effects]]\ntype = "extra-mode"\nfreq_hz = 600.0\n'
                                                 'damping_ratio = 0.02\nmass_kg = 0.02\n')
    path = folder / "sd-mode.h5"
    assert gasfilm(["acquire", "--device", "sim", "--out", str(path), "--hits", "4", "--pacing", "fast",
                    "--record-s", "0.5", "--seed", "5", "--rig", str(rig)]) == 0
    return dataclasses.replace(load_recordings(path), rig_spec_toml=None, window=None)


def test_a_late_trigger_does_not_hide_physics(recorded_with_mode):
    """The same recorder on a rig with an extra mode: the mode is found, and nothing else (the missing fronts are
    not physics, nor do they take the mode up)."""
    late = dataclasses.replace(recorded_with_mode, records=controls.triggered_late(recorded_with_mode.records))
    diagnosis = diagnose(late, mass_kg=MASS_KG)
    assert [finding.effect for finding in diagnosis.findings] == ["extra-mode"]
    assert abs(diagnosis.findings[0].parameters["freq_hz"]["value"] - 600.0) < 10.0
    assert "late trigger" in {note.kind for note in diagnosis.quality}


def test_records_exported_with_force_and_exponential_windows(recorded, tmp_path, capsys):
    """The user's path: UFF time records exported after a force window and a 1 % exponential window, ``gasfilm
    diagnose FILE --mass M``: both windows recognised, the exponential's rate measured."""
    recordings, spec = recorded
    records = controls.exported_windowed(recordings.records, recordings.sample_rate_hz, spec)
    hits = [SimpleNamespace(data=record, force_channel=0, response_channel=1, sample_rate_hz=recordings.sample_rate_hz,
                            start_time_s=float(start)) for record, start in zip(records, recordings.hit_times_s)]
    frf = compute_frf(records, recordings.sample_rate_hz, WindowSettings(force_window_ms=None,
                                                                         exponential_end_fraction=None))
    path = export_frf_uff(frf, tmp_path / "windowed.uff", hits=hits)
    capsys.readouterr()
    assert gasfilm(["diagnose", str(path), "--mass", str(MASS_KG), "--json", "--no-figures",
                    "--out", str(tmp_path / "d")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["verdict"] in ("consistent", "parameters-only") and not result["findings"]
    notes = {note["kind"]: note["message"] for note in result["quality"]}
    assert "AC coupling" in notes["force window"] and "inside the pulse" not in notes["force window"]
    true_1_s = np.log(100) * recordings.sample_rate_hz / (records.shape[-1] - 1)  # 1 % at the end
    found_1_s, error_1_s = map(float, re.search(r"σ = ([\d.]+) ± ([\d.e-]+) 1/s", notes["exponential window"]).groups())
    assert abs(found_1_s - true_1_s) < max(4 * error_1_s, 0.02 * true_1_s)


def test_a_force_window_that_closes_inside_the_pulse_is_said_to_cut_the_impulse(recorded):
    """Red team round 7's force-window-cut: an exporter's force window set for a shorter tip closes while the pulse
    is still near its peak. The force-window note says so (part of every impulse missing, the FRF too large by that
    share), as it does not for a window closing after the pulse (the test above)."""
    recordings, _ = recorded
    records = np.array(recordings.records)
    for record in records:
        record[0, int(np.argmax(np.abs(record[0]))) + 1:] = 0.0
    notes = {note.kind: note.message for note in hit_spectra(records, recordings.sample_rate_hz).quality}
    assert "the window closes inside the pulse (the force falls from 100 % of its peak" in notes["force window"]


def test_two_hits_are_said_to_be_too_few_for_a_verdict(recorded):
    """Two hits cannot check the noise model against their scatter: a quality note says the verdict is provisional;
    with three hits there is no such note."""
    recordings, _ = recorded
    notes = {note.kind: note.message for note in hit_spectra(recordings.records[:2], recordings.sample_rate_hz).quality}
    assert "only 2 usable hits" in notes["few hits"] and "provisional" in notes["few hits"]
    assert "few hits" not in {note.kind for note in hit_spectra(recordings.records[:3],
                                                                recordings.sample_rate_hz).quality}


def test_response_clipped_before_the_adc_filter_is_an_overload(recorded):
    """A sensor overloaded before the ADC's filter leaves no flat run of samples, but a ceiling: the hits whose
    response would have passed the level all peak at it, whatever their force. They are left out as overloads; the same
    hits unclipped, and hits whose forces are all alike, are not."""
    recordings, _ = recorded
    from scipy import signal

    levels = np.array([0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5])
    hits = np.array([recordings.records[index % 4] * level for index, level in enumerate(levels)])
    peaks = np.max(hits[:, 1], axis=1)
    ceiling = 1.05 * np.median(peaks)
    filter_taps = signal.firwin(63, 0.9)  # a steep low-pass near 0.45 fs, as the ADC's
    clipped = hits.copy()
    clipped[:, 1] = signal.lfilter(filter_taps, 1.0, np.minimum(hits[:, 1], ceiling), axis=-1)
    filtered = hits.copy()
    filtered[:, 1] = signal.lfilter(filter_taps, 1.0, hits[:, 1], axis=-1)

    spectra = hit_spectra(clipped, recordings.sample_rate_hz)
    notes = {note.kind: note for note in spectra.quality}
    over = [int(i) for i in np.flatnonzero(peaks > ceiling)]
    assert list(notes["overload"].hits) == over and "whatever their force" in notes["overload"].message
    assert list(spectra.hit_numbers) == [i for i in range(levels.size) if i not in over]
    assert "overload" not in {note.kind for note in hit_spectra(filtered, recordings.sample_rate_hz).quality}


def test_slow_motion_and_a_settling_offset_are_neither_truncation_nor_floor_vibration(recorded):
    """Hits on a mover scanning slowly (0.7 Hz, through the AC coupling) and records starting with the IEPE bias still
    settling (an offset decaying over 0.32 s): the responses have decayed all the same, and a decaying offset is not a
    narrowband line."""
    recordings, _ = recorded
    time_s = np.arange(recordings.records.shape[-1]) / recordings.sample_rate_hz
    phases = np.random.default_rng(3).uniform(0, 2 * np.pi, recordings.records.shape[0])
    scanning = recordings.records.copy()
    scanning[:, 1] += 0.1 * np.sin(2 * np.pi * 0.7 * time_s + phases[:, np.newaxis])
    settling = recordings.records.copy()
    settling[:, 1] += 0.05 * np.exp(-time_s / 0.32)
    for records in (scanning, settling):
        kinds = {note.kind for note in hit_spectra(records, recordings.sample_rate_hz).quality}
        assert not kinds & {"truncation", "floor vibration"}, kinds


def test_a_level_off_by_g_is_said_and_a_per_hit_gain_is_told_from_a_change_of_shape(recorded):
    """An acceleration read in g as m/s² leaves the FRF 9.81× low: a quality note says so against the given spec. Hits
    that differ by a gain alone (a per-hit sensitivity) are told from hits that differ in shape."""
    from gasfilm.analysis.diagnosis.pipeline import _level_note, _per_hit_gain_spread, evidence_for

    recordings, spec = recorded
    in_g = recordings.records.copy()
    in_g[:, 1] /= 9.80665
    notes = _level_note(evidence_for(hit_spectra(in_g, recordings.sample_rate_hz), spec), spec)
    assert notes and "ratio of g to m/s²" in notes[0].message
    assert not _level_note(evidence_for(hit_spectra(recordings.records, recordings.sample_rate_hz), spec), spec)
    in_lbf = recordings.records.copy()  # a force recorded in lbf and read as N (red team round 9): 4.45× high
    in_lbf[:, 0] /= 4.4482216
    notes = _level_note(evidence_for(hit_spectra(in_lbf, recordings.sample_rate_hz), spec), spec)
    assert notes and "ratio of a pound-force to a newton" in notes[0].message
    velocity = recordings.records.copy()  # a vibrometer's velocity (m/s) recorded as m/s²: the FRF goes as 1/f
    velocity[:, 1] = np.cumsum(velocity[:, 1], axis=-1) / recordings.sample_rate_hz
    velocity[:, 1] -= velocity[:, 1, :1]
    notes = _level_note(evidence_for(hit_spectra(velocity, recordings.sample_rate_hz), spec), spec)
    assert notes and "a velocity recorded as an acceleration" in notes[0].message

    gains = np.array([1.0, 0.96, 1.03, 0.93])
    scaled = recordings.records.copy()
    scaled[:, 1] *= gains[:, np.newaxis]
    spread = _per_hit_gain_spread(hit_spectra(scaled, recordings.sample_rate_hz))
    assert spread is not None and abs(spread - np.std(gains / gains.mean())) < 0.01
    assert _per_hit_gain_spread(hit_spectra(recordings.records, recordings.sample_rate_hz)) is None
    delayed = recordings.records.copy()  # a per-hit delay changes the shape (phase growing with frequency)
    for hit, samples in zip(delayed, (0, 1, 2, 3)):
        hit[1] = np.roll(hit[1], samples)
    assert _per_hit_gain_spread(hit_spectra(delayed, recordings.sample_rate_hz)) is None


def test_a_start_is_read_past_a_spliced_hit_that_spoils_the_coherence(recorded):
    """A buffer overrun drops 2.5 ms of one hit's response 4 ms after the pulse, spliced: that hit alone pulls the
    coherence below 0.9 around the resonance. The start is read from the other hits, and the text names the one left out."""
    from gasfilm.analysis.diagnosis.recordings import read_start

    recordings, spec = recorded
    records = recordings.records.copy()
    rate_hz = recordings.sample_rate_hz
    start = int(np.argmax(np.abs(records[1, 0]))) + int(0.004 * rate_hz)
    dropped = int(0.0025 * rate_hz)
    records[1, 1, start:-dropped] = records[1, 1, start + dropped:].copy()
    spliced = dataclasses.replace(recordings, records=records)
    read, text = read_start(spliced, MASS_KG)
    assert "read from 3 of 4 hits: hits 2 differ from the others" in text
    film_k = spec.film_parameters["k"]
    assert abs(read.film_parameters["k"] / film_k - 1) < 0.05


def test_an_interference_spike_away_from_the_impact_leaves_its_hit_out(recorded):
    """A solenoid's kick in the accelerometer cable, 0.2 s after one hit's impact (through a steep low-pass like the
    ADC's): that hit is left out with a note; the untouched hits have none."""
    from scipy import signal

    recordings, _ = recorded
    records = recordings.records.copy()
    at = int(0.2 * recordings.sample_rate_hz)
    kick = np.zeros(records.shape[-1])
    kick[at] = 4.0
    records[2, 1] += signal.lfilter(signal.firwin(63, 0.9), 1.0, kick)
    spectra = hit_spectra(records, recordings.sample_rate_hz)
    notes = {note.kind: note for note in spectra.quality}
    assert notes["spikes"].hits == (2,) and list(spectra.hit_numbers) == [0, 1, 3]
    assert "spikes" not in {note.kind for note in hit_spectra(recordings.records, recordings.sample_rate_hz).quality}


def test_no_mains_line_is_sought_where_the_quiet_stretch_cannot_resolve_one():
    """Red-team round 5's control-few-short: 0.06 s records at 25.6 kS/s, the force after each pulse only the AC
    coupling's slow decay. 30 ms after the pulse cannot tell 60 Hz from 50 Hz, nor a line from that decay: no mains is
    found there; with 0.25 s of the same decay beside a true 50 Hz line, the line is found."""
    from gasfilm.analysis.diagnosis.measurement import _remove_mains_seen_on_force

    rate_hz, rng = 25_600.0, np.random.default_rng(3)

    def records(duration_s: float, mains_n: float) -> tuple[np.ndarray, list[tuple[int, int, int]]]:
        time_s = np.arange(int(duration_s * rate_hz)) / rate_hz
        pulse = (time_s > 0.5e-3) & (time_s < 1.5e-3)
        rows = []
        for hit in range(4):
            force = 200 * np.sin(np.pi * (time_s - 0.5e-3) / 1e-3) * pulse  # 0.2 N·s
            force -= 0.2 * np.pi * np.exp(-np.pi * time_s) * (time_s > 1.5e-3)  # the 0.5 Hz coupling's decay
            force += mains_n * np.sin(2 * np.pi * 50 * time_s + hit) + 2e-3 * rng.standard_normal(time_s.size)
            rows.append([force, np.zeros_like(force)])
        return np.array(rows), [(12, 13, 39)] * 4

    for duration_s in (0.06, 0.08):
        data, extents = records(duration_s, 0.0)
        assert _remove_mains_seen_on_force(data, extents, rate_hz)[1] is None, duration_s
    data, extents = records(0.25, 0.05)
    assert _remove_mains_seen_on_force(data, extents, rate_hz)[1] == 50.0


def test_records_zero_padded_by_an_exporter_are_said_so(recorded):
    """Red-team round 5's zero-padded-export: both channels exact zeros after 0.3 s of each 0.5 s record. Said in
    words (it was "inf× lower" with a divide-by-zero warning), the noise measured before the hits."""
    import warnings

    def zero_padded(records, sample_rate_hz, spec):
        padded = records.copy()
        padded[:, :, int(0.3 * sample_rate_hz):] = 0.0
        return padded

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        diagnosis, notes = _diagnosed(recorded, zero_padded)
    assert "exact zeros" in notes["noise"] and "inf" not in notes["noise"]
    assert diagnosis.spectra.noise.source == "pre-trigger"


def test_a_response_on_a_dc_offset_is_said_and_subtracted(recorded):
    """Red-team round 5's gravity-dc: a DC-coupled accelerometer reads 1 g before every hit. Said and subtracted (it
    was read as a film twice as stiff with six extra modes, "the film depends on the amplitude" and a level 2×)."""
    def on_gravity(records, sample_rate_hz, spec):
        return records + np.array([0.0, 9.81])[np.newaxis, :, np.newaxis]

    diagnosis, notes = _diagnosed(recorded, on_gravity)
    assert "response records sit on +9.81 m/s²" in notes["offset"]
    assert "level" not in notes
    assert abs(diagnosis.improved.film_parameters["k"] / 3.78e7 - 1) < 0.05  # the SD rig's own film, not 2×


def test_a_sensitivity_that_jumps_mid_session_is_worded_as_a_gain(recorded):
    """Red-team round 5's sensor-swap: the accelerometer swapped after hit 8 for one 4.4 % less sensitive. The jump
    scales every frequency alike: it is worded as a sensor's gain, not "the rig changed"."""
    from gasfilm.analysis.diagnosis.pipeline import _character, evidence_for

    recordings, spec = recorded
    records = np.concatenate((recordings.records, recordings.records))
    records[4:, 1] *= 0.956
    spectra = hit_spectra(records, recordings.sample_rate_hz, hit_times_s=np.arange(8.0))
    evidence = evidence_for(spectra, spec)
    words = _character(spectra, evidence, spec, 0, evidence.freq_hz.size - 1)
    assert words.startswith("a jump between hits 4 and 5 that scales the whole FRF alike"), words
    assert "sensor" in words and "rig changed" not in words


def test_a_broad_excess_spanning_harmonics_is_not_called_distortion():
    """Red-team round 5's sampling-jitter left a broad excess over 520–1300 Hz, which spans harmonics of the 196 Hz
    resonance without sitting at them: not "distorted by a nonlinearity". A round 1–2 pneumatic hammer's lines at 3×
    and 5× the resonance still are."""
    from gasfilm.analysis.diagnosis.pipeline import _at_harmonics

    freq_hz = np.arange(520.0, 1300.0, 5.0)
    flat = np.full((16, freq_hz.size), 3.0)
    assert not _at_harmonics(freq_hz, flat, 196.0, 5.0)
    peaked = np.ones((16, freq_hz.size)) + 40.0 * (np.abs(freq_hz - 588.0) < 10)
    assert _at_harmonics(freq_hz, peaked, 196.0, 5.0)
    narrow = np.arange(560.0, 611.0, 10.0)
    assert _at_harmonics(narrow, np.full((16, narrow.size), 3.0), 200.0, 10.0)


def test_an_excess_at_a_harmonic_is_called_distortion_only_when_it_grows_with_the_hit_level(recorded, monkeypatch):
    """Red-team round 6's linear twin carriage and differentiated displacement left small excesses at 5× the
    resonance, which were called "distorted by a nonlinearity": now only an excess that also follows the hits' levels
    is; one that does not is said to sit there without growing as distortion would."""
    from gasfilm.analysis.diagnosis import pipeline

    recordings, spec = recorded
    spectra = hit_spectra(recordings.records, recordings.sample_rate_hz, hit_times_s=np.arange(4.0))
    evidence = pipeline.evidence_for(spectra, spec)
    top = evidence.freq_hz.size - 1
    low = int(np.searchsorted(evidence.freq_hz, 2.0 * 200.0))
    monkeypatch.setattr(pipeline, "_at_harmonics", lambda *arguments: True)
    for trend, expected in ((True, "growing with the hit level: the response is distorted by a nonlinearity"),
                            (False, "does not follow the hits' levels as a nonlinearity's distortion would")):
        monkeypatch.setattr(pipeline, "_level_trend", lambda values, impulse_ns, trend=trend: trend)
        words = pipeline._character(spectra, pipeline.evidence_for(spectra, spec), spec, low, top)
        assert expected in words, words


def test_records_with_no_usable_hit_say_which_checks_removed_them(recorded):
    """Red-team round 6's swapped cables: every record's 'force' rings on after the impact, so every hit was left out
    as a double hit; the refusal says so, and asks whether the channels are swapped."""
    from gasfilm.drivers.errors import SettingError

    recordings, _ = recorded
    with pytest.raises(SettingError) as refused:
        hit_spectra(recordings.records[:, ::-1], recordings.sample_rate_hz)
    message = str(refused.value)
    assert "only 0 usable hit(s) of 4" in message and "4 with a second impact" in message, message
    assert "channels swapped" in message


def _two_significant_digits(records: np.ndarray) -> np.ndarray:
    """Every sample kept to two significant digits, as a CSV written with '%.1e' holds it."""
    magnitude = np.abs(records)
    unit = 10.0 ** (np.floor(np.log10(np.where(magnitude > 0, magnitude, 1.0))) - 1)
    return np.round(records / unit) * unit


def test_records_stored_with_two_significant_digits_are_rounded_not_clipped(recorded):
    """Red team round 8: a text export with two significant digits leaves flat tops at every peak (10 N steps on a
    200 N pulse), which are not clipping; the rounding is said, the response's part is in the noise model and the
    force's, which falls on the few samples of each pulse, is said to scale each hit by about its size."""
    recordings, _ = recorded
    rounded = dataclasses.replace(recordings, records=_two_significant_digits(recordings.records))
    diagnosis = diagnose(rounded, mass_kg=MASS_KG)
    notes = {note.kind: note.message for note in diagnosis.quality}
    assert "overload" not in notes and len(diagnosis.spectra.hit_numbers) == 4
    assert "few significant decimal digits" in notes["quantisation"], notes
    assert re.search(r"changes each hit's gain by about [\d.]+ % \(RMS\)", notes["quantisation"])
    assert not diagnosis.findings
    # a plain record's float values, and a uniform quantiser's integers, are not decimal rounding
    assert "significant decimal" not in _notes_of(recordings.records)
    assert "significant decimal" not in _notes_of(np.round(recordings.records * 1000.0))


def _notes_of(records: np.ndarray) -> str:
    return " ".join(note.message for note in hit_spectra(records, 12800.0).quality)


def test_the_json_numbers_hits_from_1(recorded):
    """Hits are numbered from 1 everywhere a user reads them, the JSON included (red team round 8 found the JSON's
    ``unexplained[].hits``, ``quality[].hits`` and ``hit_numbers_used`` counted from 0 beside a text counting from 1)."""
    recordings, _ = recorded
    diagnosis = diagnose(recordings, mass_kg=MASS_KG)
    values = json.loads(json.dumps(diagnosis.to_dict(), default=str))
    assert values["hit_numbers_used"] == [1, 2, 3, 4] and values["hits_numbered_from"] == 1
    assert QualityNote("overload", "two hits", hits=(0, 2)).to_dict()["hits"] == [1, 3]
    assert Unexplained((100.0, 200.0), [0, 3], 1.0, "a peak").to_dict()["hits"] == [1, 4]


def test_integer_counts_that_wrapped_around_on_export_leave_their_hits_out(recorded):
    """Red team round 8: an exporter's int16 counts that overflowed wrap from one extreme to the other: the hits are
    left out as overloaded, not read as modes of the structure."""
    recordings, _ = recorded
    records = recordings.records.copy()
    peaks = np.max(np.abs(records[:, 1]), axis=1)
    step = 1.02 * np.sort(peaks)[-2] / 32767  # only the largest hit overflows 16 bits
    counts = np.round(records[:, 1] / step).astype(np.int64)
    records[:, 1] = (((counts + 32768) % 65536) - 32768) * step
    diagnosis = diagnose(dataclasses.replace(recordings, records=records), mass_kg=MASS_KG)
    wrapped = int(np.argmax(peaks))
    (note,) = [note for note in diagnosis.quality if "wrap around" in note.message]
    assert note.kind == "overload" and note.hits == (wrapped,) and f"hits {wrapped + 1})" in note.message
    assert wrapped not in diagnosis.spectra.hit_numbers and not diagnosis.findings and not diagnosis.unexplained


def test_a_force_pulse_without_a_response_leaves_its_hit_out(recorded):
    """Red team round 8: a trigger on the hammer tapping the bench records a force pulse and only noise in the
    response; such a record is left out with a note, not read as the rig changing during the session."""
    recordings, _ = recorded
    records = recordings.records.copy()
    records[2, 1] = np.random.default_rng(3).normal(0.0, 0.01, records.shape[-1])
    records[2, 0] *= 0.2
    diagnosis = diagnose(dataclasses.replace(recordings, records=records), mass_kg=MASS_KG)
    notes = {note.kind: note for note in diagnosis.quality}
    assert notes["no response"].hits == (2,) and "hits 3:" in notes["no response"].message
    assert list(diagnosis.spectra.hit_numbers) == [0, 1, 3]
    assert not diagnosis.findings and not diagnosis.unexplained
    # every plain hit responds
    assert "no response" not in {note.kind for note in hit_spectra(recordings.records, recordings.sample_rate_hz).quality}


def test_narrowband_lines_in_the_quiet_records_are_read_between_the_bins():
    """Round 9 of the red team: a fan at 46.3 Hz (and its 2×) in 0.25 s quiet tails (4 Hz bins) was reported 'near 48,
    92 Hz'. The vertex of the log-power parabola puts each line within a fraction of a bin."""
    from gasfilm.analysis.diagnosis.measurement import _narrowband_lines_hz

    rate_hz, samples = 12_800.0, 3200
    time_s = np.arange(samples) / rate_hz
    rng = np.random.default_rng(4)
    quiet = np.array([0.3 * np.sin(2 * np.pi * 46.3 * time_s + phase) + 0.1 * np.sin(2 * np.pi * 92.6 * time_s + phase)
                      + 1e-3 * rng.standard_normal(samples) for phase in rng.uniform(0, 2 * np.pi, 8)])
    lines = _narrowband_lines_hz(quiet, rate_hz, [])
    assert len(lines) == 2 and abs(lines[0] - 46.3) < 0.6 and abs(lines[1] - 92.6) < 0.6, lines


def test_a_stuck_converter_bit_is_named_and_whole_codes_without_one_are_not():
    """Round 9 of the red team: bit 8 of the response's 24-bit codes stuck at 1 was 'a localised peak/dip near
    198 Hz' and, in another draw, 'changing with the hit level' — with no word of the converter."""
    from gasfilm.analysis.diagnosis.measurement import stuck_bits

    step = 5.0 / 2**23 / 0.0102  # 24 bits on ±5 V at 10.2 mV/(m/s²)
    rng = np.random.default_rng(2)
    response = np.sin(np.linspace(0, 60, 20_000)) * np.exp(-np.linspace(0, 5, 20_000)) * 40.0
    codes = np.round((response + 1e-3 * rng.standard_normal(response.size)) / step).astype(np.int64)
    assert stuck_bits(codes * step, step) == []
    assert stuck_bits((codes | (1 << 8)) * step, step) == [(8, 1)]
    assert stuck_bits((codes & ~(1 << 3)) * step, step) == [(3, 0)]
    assert stuck_bits(np.round(response, 3), step) == []  # not whole codes of that step: nothing said


def test_records_ringing_to_their_end_with_a_noisy_hammer_channel_carry_the_replays_force_noise():
    """Full-length records still ringing at their end, 0.5 ms of pre-trigger (the noise from the hits' scatter) and a
    hammer channel with 0.3 N of noise after the pulse: the replay plays that noise through the spec over the whole
    record, which the recorded FRFs (force window) do not carry; measured on the force after the impacts, it is part
    of the noise model, and the true spec is consistent (without it: χ²/point 6.3, 'not explained' 12–1252 Hz)."""
    import sys

    sys.path.insert(0, str(ROOT / "tests"))
    from synthesis import synthesised_hits

    from gasfilm.analysis.physics.effects import StructureMode
    from gasfilm.analysis.physics.response import rig_accelerance

    omega = 2 * np.pi * 20.0
    spec = RigSpec.nominal("SD", mass_kg=1.7, parameters={"k": 1.7 * omega**2, "eta": 2 * 0.03 * 1.7 * omega},
                           effects=[StructureMode(freq_hz=380.0, damping_ratio=0.002, modal_constant_per_kg=0.5),
                                    StructureMode(freq_hz=905.0, damping_ratio=0.002, modal_constant_per_kg=-0.6)])
    synthetic = synthesised_hits(lambda freq_hz: rig_accelerance(spec, freq_hz, 0.0, 0.0), 25_600.0, 5, 7, "rings")
    start = int(0.0095 * 25_600.0)  # 0.5 ms before the pulse
    records = synthetic.records[:, :, start : start + int(0.25 * 25_600.0)].copy()
    records[:, 0] += np.random.default_rng(1).normal(0.0, 0.3, records[:, 0].shape)
    diagnosis = diagnose(Recordings(records, 25_600.0, synthetic.hit_times_s, None, None, None, "rings"), spec)
    assert diagnosis.spectra.noise.source == "hit scatter"
    assert diagnosis.verdict == "consistent" and diagnosis.chi2_per_point_before < 1.3
