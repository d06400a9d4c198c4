"""The diagnosis's measurement on a recording nobody here made (fixtures/real-data/pyfrf-5-hits): 0.8 ms of
pre-trigger, still ringing at the end of its 1 s records, 5 hits. The noise is measured from what the recording has
— here the scatter of the hits' FRFs — and said; cut to a 0.5 ms pre-trigger, to shorter records or to 3 hits it is
still normal input. It is read as a measured structure (modal superposition, response polarity −1); its diagnosis
and variants with concealed measurement effects are in tests/test_diagnose_real_variants.py and
benchmarks/real_variants.py."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gasfilm.app.cli import main as gasfilm

from gasfilm.analysis.diagnosis.measurement import hit_spectra
from gasfilm.drivers.errors import SettingError

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"
FS_HZ = 25_600.0


@pytest.fixture(scope="module")
def measured() -> np.ndarray:
    """(5 hits, force/acceleration, 25600 samples)."""
    return np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]


def cut(records: np.ndarray, pretrigger_s: float, record_s: float) -> np.ndarray:
    """The records re-cut in software: ``pretrigger_s`` before the first sample above 2 % of the force peak."""
    start = np.flatnonzero(np.abs(records[0, 0]) > 0.02 * np.abs(records[0, 0]).max())[0]
    first = start - int(round(pretrigger_s * FS_HZ))
    assert first >= 0
    return records[:, :, first : first + int(round(record_s * FS_HZ))]


@pytest.mark.parametrize("pretrigger_s, record_s, hits", [(None, None, 5), (0.5e-3, 1.0, 5), (0.5e-3, 0.25, 5),
                                                         (0.5e-3, 0.125, 3)])
def test_real_recording_noise_comes_from_the_hit_scatter_and_is_said(measured, pretrigger_s, record_s, hits):
    records = measured if pretrigger_s is None else cut(measured, pretrigger_s, record_s - 0.6e-3)
    spectra = hit_spectra(records[:hits], FS_HZ)
    assert spectra.noise.source == "hit scatter"
    assert spectra.noise.degrees_of_freedom >= 2 * (hits - 1)
    assert f"{hits} hits" in spectra.noise.detail
    assert list(spectra.hit_numbers) == list(range(hits))  # no hit left out for its short pre-trigger
    # the measured noise describes the scatter: the hits about their weighted mean give χ² ≈ dof
    mean, _ = spectra.mean()
    chi2 = float(np.sum(np.abs(spectra.h - mean) ** 2 * spectra.weight))
    dof = 2 * (hits - 1) * spectra.h.shape[1]
    assert 0.5 < chi2 / dof < 2.0


def test_two_hits_without_a_pre_trigger_are_one_line(measured):
    with pytest.raises(SettingError, match="too few to measure the noise from their scatter"):
        hit_spectra(cut(measured, 0.5e-3, 0.25)[:2], FS_HZ)


def test_fit_says_which_resonances_no_film_model_explains(tmp_path, capsys):
    files = [str(FIXTURE / f"measurements_{i}.npy") for i in range(1, 4)]
    assert gasfilm(["fit", *files, "--models", "SD", "--mass", "0.8", "--band", "20:3000", "--json",
                    "--out", str(tmp_path)]) == 0
    result = json.loads(capsys.readouterr().out)
    assert any(abs(f - 2640.0) < 10.0 for f in result["not_explained_resonances_hz"])
    assert all(20.0 <= f <= 3000.0 for f in result["not_explained_resonances_hz"])
