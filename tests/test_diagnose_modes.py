"""A structure with several modes in band (issue 14, item 2): a start read off the FRF describes them as extra modes;
against a spec without them, the diagnosis names them at their frequencies; ``fit`` lists the resonances no film
model explains, also for an FRF read from UFF (which carries no force spectrum)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.diagnosis.measurement import hit_spectra
from gasfilm.analysis.diagnosis.modes import unmodelled_resonances_hz
from gasfilm.analysis.diagnosis.pipeline import evidence_for
from gasfilm.analysis.diagnosis.recordings import load_recordings, read_start
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.app.cli import main as gasfilm

RIGS = Path(__file__).resolve().parents[1] / "fixtures" / "rigs"
#: fixtures/rigs/three-modes.toml: extra modes at 480, 820 and 1250 Hz (antiresonances), their peaks just above.
MODES_HZ = (480.0, 820.0, 1250.0)


@pytest.fixture(scope="module")
def three_modes(tmp_path_factory) -> Path:
    """4 hits of 0.5 s of an SD film with three structural modes, exported as UFF 58 (FRF and time records)."""
    folder = tmp_path_factory.mktemp("modes")
    session = folder / "three.h5"
    assert gasfilm(["acquire", "--device", "sim", "--out", str(session), "--hits", "4", "--pacing", "fast",
                    "--record-s", "0.5", "--seed", "2", "--rig", str(RIGS / "three-modes.toml")]) == 0
    assert gasfilm(["export", str(session), "--uff", str(folder / "three.uff")]) == 0
    return folder / "three.uff"


def _near_each(found_hz: list[float], wanted_hz: tuple[float, ...], tolerance: float) -> bool:
    return all(any(abs(f - w) <= tolerance * w for f in found_hz) for w in wanted_hz)


def test_start_read_off_the_frf_describes_each_mode(three_modes):
    spec, text = read_start(load_recordings(three_modes), mass_kg=25.05)
    assert len(spec.effects) == 3 and "multi-mode structure" in text
    assert _near_each([mode.freq_hz for mode in spec.effects], MODES_HZ, 0.03)


def test_modes_a_spec_lacks_are_named_at_their_frequencies(three_modes):
    recordings = load_recordings(three_modes)
    spectra = hit_spectra(recordings.records, recordings.sample_rate_hz)
    film_only = RigSpec.from_toml((RIGS / "sd.toml").read_text(), "sd.toml")
    evidence = evidence_for(spectra, film_only)
    found_hz = unmodelled_resonances_hz(evidence, film_only, (float(spectra.freq_hz[0]), float(spectra.freq_hz[-1])))
    assert len(found_hz) == 3 and _near_each(found_hz, MODES_HZ, 0.06)  # peaks lie a little above the modes
    full = RigSpec.from_toml((RIGS / "three-modes.toml").read_text(), "three-modes.toml")
    assert unmodelled_resonances_hz(evidence_for(spectra, full), full, (10.0, 1600.0)) == []


def test_fit_of_a_uff_frf_lists_the_resonances_no_film_model_explains(three_modes, tmp_path, capsys):
    capsys.readouterr()
    assert gasfilm(["fit", str(three_modes), "--models", "SD", "--mass", "25.05", "--json", "--out",
                    str(tmp_path)]) == 0
    result = json.loads(capsys.readouterr().out)
    inside = [f for f in MODES_HZ if result["band_hz"][0] <= f <= result["band_hz"][1]]
    assert inside and _near_each(result["not_explained_resonances_hz"], tuple(inside), 0.06)
    assert np.all(np.diff(result["not_explained_resonances_hz"]) > 0)
