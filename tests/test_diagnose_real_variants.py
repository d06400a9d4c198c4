"""The shared real recording (fixtures/real-data/pyfrf-5-hits, 0.25 s records) and variants of it made in software
with concealed measurement effects (benchmarks/real_variants.py: a 10 µs response delay, cross-talk of the force, a
3 % gain error, 50 Hz mains). The untouched recording is diagnosed from a start read off its FRF (a measured structure,
modal superposition); its written spec is what every variant is diagnosed against, and the untouched recording once
more (the loop). Figures: benchmarks/real_variants.md."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.diagnosis.recordings import Recordings, diagnose
from gasfilm.analysis.diagnosis.report import report_text

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from real_variants import FIXTURE, RATE_HZ, variants  # noqa: E402

RECORD_S = 0.25
#: The effects each variant's diagnosis must name (the gain error: a sensitivity error, a mass, or nothing).
NAMES = {"delay 10 µs": {"channel-delay"}, "cross-talk 0.05 (m/s²)/N": {"cross-talk"},
         "gain +3 %": {"added-mass", "sensitivity-error"}, "mains 50 Hz": set()}


def _diagnosed():
    """The untouched recording diagnosed from its start, then the loop and every variant against its written spec."""
    records = np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]
    cases = variants(records, RECORD_S)
    first = diagnose(Recordings(cases["untouched"], RATE_HZ, np.arange(5.0), None, None, None, "untouched"))
    results = {name: diagnose(Recordings(data, RATE_HZ, np.arange(5.0), None, None, None, name), first.improved)
               for name, data in cases.items()}
    return first, results


def _value(diagnosis, effect: str, name: str) -> float:
    return next(f.parameters[name]["value"] for f in diagnosis.findings if f.effect == effect)


@pytest.mark.slow  # six diagnoses in one test, so that test workers do not compute them twice (real_variants.md)
def test_the_real_recording_and_its_variants():
    first, results = _diagnosed()

    # Below its first resonance the recording is a negative mass line, not a mover on a film rising as ω²: the start
    # is a measured structure (modal superposition) with the response polarity −1 and its modes.
    spec = first.given
    assert "mass line" in first.notes[0] and "polarity −1" in first.notes[0]
    assert [e.type_name for e in spec.effects if e.type_name == "polarity"] == ["polarity"]
    assert 0.75 < spec.mass_kg < 1.0  # |H1| ≈ 1.2 (m/s²)/N below 800 Hz
    modes = [e for e in spec.effects if e.type_name == "structure-mode"]
    for mode_hz in (900.0, 2640.0, 3669.0, 4128.0):
        assert any(abs(mode.freq_hz - mode_hz) < 0.01 * mode_hz for mode in modes), mode_hz
    suspension_hz = np.sqrt(spec.film_parameters["k"] / spec.mass_kg) / (2 * np.pi)
    assert suspension_hz < 5.0  # below the band: in band the mover is its mass line

    # described far closer than by a film: a mover on a film with extra modes left χ²/point ≈ 3600 on this
    # recording; the structure read as modal analysis reads it (stable poles, LSFD with residuals, finished on the
    # diagnosis's own comparison) starts at χ²/point ≈ 2.3 (0.25 s records) and the recalibration can only gain
    # little; nothing claimed beside a description still beyond the noise
    assert first.spectra.noise.source == "hit scatter"
    assert any(e.type_name == "polarity" for e in first.improved.effects)
    assert first.chi2_per_point_before < 3.0
    assert first.chi2_per_point_after <= first.chi2_per_point_before
    assert not first.findings
    assert first.verdict == "not explained"

    # the written spec records how far it is from this recording, in the bands it leaves unexplained
    error = first.improved.description_error
    assert error is not None and error.recording == "untouched"
    assert abs(error.chi2_per_point - first.chi2_per_point_after) < 0.05 * first.chi2_per_point_after
    for item in first.unexplained:
        inside = [f for f in error.freq_hz if item.band_hz[0] <= f <= item.band_hz[1]]
        assert inside, item.band_hz
    assert type(first.improved).from_toml(first.improved.to_toml()) == first.improved

    # a parameter at its bound is said not to be measured
    rows = first.recalibration
    assert all("at_bound" in row for row in rows.values())
    text = report_text(first)
    for name, row in rows.items():
        if row["at_bound"]:
            assert math.isnan(row["uncertainty"])
            assert f"{name}" in text or name.startswith("structure-mode")  # modes: counted, listed in --json
            assert "not a measurement" in text

    # the untouched recording closes the loop: within its recorded description error, nothing found or unexplained
    loop = results["untouched"]
    assert not loop.findings and not loop.unexplained
    assert loop.verdict == "consistent"
    assert loop.chi2_per_point_after < 1.5
    assert any(note.kind == "description error" for note in loop.quality)

    # each variant names its own effect, with its size, and no rig physics; the modes are held (not recalibrated)
    for name, allowed in NAMES.items():
        found = {finding.effect for finding in results[name].findings}
        assert found <= allowed, (name, found)
        assert results[name].improved.effects[: len(first.improved.effects)] == first.improved.effects[
            : len(first.improved.effects)] or name == "untouched"
    assert abs(_value(results["delay 10 µs"], "channel-delay", "delay_s") - 10e-6) < 1e-6
    assert abs(abs(_value(results["cross-talk 0.05 (m/s²)/N"], "cross-talk", "leak_m_s2_per_n")) - 0.05) < 0.005
    gain = results["gain +3 %"]
    assert gain.findings or gain.verdict == "parameters-only"
    if any(f.effect == "sensitivity-error" for f in gain.findings):
        assert abs(_value(gain, "sensitivity-error", "fraction") - 0.03) < 0.005
    for name in ("delay 10 µs", "cross-talk 0.05 (m/s²)/N"):
        assert {finding.effect for finding in results[name].findings} == NAMES[name], name
    for name, result in results.items():
        assert not result.unexplained, name
    mains = results["mains 50 Hz"]
    assert any(note.kind == "interference" for note in mains.quality)
    assert mains.verdict == "consistent" and not mains.findings
