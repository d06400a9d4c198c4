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
#: The effects each variant's diagnosis may name (the gain error: a mass or a sensitivity error, or nothing).
NAMES = {"delay 10 µs": {"channel-delay"}, "cross-talk 0.05 (m/s²)/N": {"cross-talk"},
         "gain +3 %": {"added-mass", "sensitivity-error"}, "mains 50 Hz": set()}




def _diagnosed():
    """The untouched recording diagnosed from its start, then the loop and every variant against its written spec."""
    records = np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]
    records = records[:, :, : int(round(RECORD_S * RATE_HZ))]
    cases = variants(records)
    first = diagnose(Recordings(cases["untouched"], RATE_HZ, np.arange(5.0), None, None, None, "untouched"))
    results = {name: diagnose(Recordings(data, RATE_HZ, np.arange(5.0), None, None, None, name), first.improved)
               for name, data in cases.items()}
    return first, results


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
    # recording, the structure 3.35 (0.25 s records); nothing claimed beside a description still beyond the noise
    assert first.spectra.noise.source == "hit scatter"
    assert any(e.type_name == "polarity" for e in first.improved.effects)
    assert first.chi2_per_point_after < 5.0
    assert first.chi2_per_point_after < 0.5 * first.chi2_per_point_before
    assert not first.findings
    assert first.verdict == "not explained"

    # a parameter at its bound is said not to be measured
    rows = first.recalibration
    assert rows and all("at_bound" in row for row in rows.values())
    assert sum(row["at_bound"] for row in rows.values()) >= 1  # modes' dampings at 1e-4, the suspension below band
    text = report_text(first)
    for name, row in rows.items():
        if row["at_bound"]:
            assert math.isnan(row["uncertainty"])
            assert f"{name}" in text
    assert "not a measurement" in text

    # the untouched recording closes the loop
    loop = results["untouched"]
    assert not loop.findings
    assert loop.chi2_per_point_after <= 1.02 * first.chi2_per_point_after

    # no variant is given rig physics (naming the delay and the cross-talk is not reached yet: the written spec
    # leaves χ²/point ≈ 3.4 over the noise and the recalibrated modes absorb them — benchmarks/real_variants.md)
    for name, allowed in NAMES.items():
        found = {finding.effect for finding in results[name].findings}
        assert found <= allowed, (name, found)
