"""The report in words (issue 15, items 7 and 21): quality notes as sentences, no "nan", flags once per model, the
settings in words with units, the device recorded for a simulated session, each fit's own band."""

from __future__ import annotations

import re

import pytest

from gasfilm.analysis.identification import FitResult
from gasfilm.analysis.report import read_report_data, report_html
from gasfilm.analysis.session import Session
from gasfilm.app.cli import main


@pytest.fixture(scope="module")
def demo_session(tmp_path_factory):
    path = tmp_path_factory.mktemp("report-words") / "demo.h5"
    assert main(["demo", "--hits", "2", "--out", str(path), "--seed", "4", "--no-fit"]) == 0
    assert main(["fit", str(path), "--models", "SD,FOMGF", "--out", str(path.parent)]) == 0
    return path


def text_of(html: str) -> str:
    body = html[html.find("<body>") + 1:]
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", re.sub(r"src='data:[^']*'", "", body)))


def test_the_setup_names_the_device_and_the_settings_in_words_with_units(demo_session):
    text = text_of(report_html(read_report_data(demo_session)))
    assert "Device sim " in text and "not recorded" not in text  # before: "Device not recorded" for a demo
    for internal in ("level_n", "exponential_end_fraction", "double_hit_fraction", "pretrigger_s"):
        assert internal not in text
    assert "Trigger level (N) 20" in text and "Record length (s) 0.5" in text
    assert "Exponential window, value at record end (fraction) off" in text
    assert "Double hit above (fraction of 1st peak) 0.1" in text


def test_parameters_show_a_reason_for_a_missing_sigma_and_flags_once_per_model(demo_session, tmp_path):
    path = tmp_path / "flagged.h5"
    path.write_bytes(demo_session.read_bytes())
    with Session.open(path, "a") as session:
        fit = session.read_fit("FOMGF")
        fit["std_errors"] = {name: float("nan") for name in fit["params"]}
        fit["flags"] = ["alpha at its bound", "ill-conditioned"]
        fit["at_bound"] = ["alpha"]
        session.write_fit("FOMGF", fit)
    html = report_html(read_report_data(path))
    text = text_of(html)
    fits = text[text.index("Identified models"):].lower()
    assert "nan" not in fits, fits[max(0, fits.find("nan") - 200):fits.find("nan") + 40]
    assert "— (at its search bound: not a measurement)" in text and "— (not estimated" in text
    assert text.count("alpha at its bound; ill-conditioned") == 1  # before: on every parameter row


def test_each_fit_is_shown_with_its_own_band(demo_session, tmp_path):
    path = tmp_path / "bands.h5"
    path.write_bytes(demo_session.read_bytes())
    assert main(["fit", str(path), "--models", "SD", "--band", "50:600", "--overwrite", "--out", str(tmp_path)]) == 0
    data = read_report_data(path)
    bands = {tuple(band) for band, _rows in data.comparison}
    assert len(bands) == 2
    text = text_of(report_html(data))
    sd = FitResult.from_dict(Session.open(path).read_fit("SD"))
    assert f"Band {sd.band_hz[0]:g}–{sd.band_hz[1]:g} Hz (1 model)" in text
    assert "Band 20–1000 Hz (1 model)" in text  # FOMGF keeps its own band, not SD's


def test_diagnosis_quality_notes_read_as_sentences_without_nan():
    from gasfilm.analysis.report import _diagnosis_html

    stored = {"verdict": "explained", "rms_before_g_per_n": 1e-3, "rms_after_g_per_n": 5e-4,
              "findings": [{"effect": "extra-mode", "band_hz": [215.0, 680.0],
                            "parameters": {"f_hz": {"value": 640.0, "uncertainty": float("nan"), "unit": "Hz"}},
                            "evidence": "χ² down 40"}],
              "recalibration": {"k": {"spec": 1.0, "fitted": 2.0, "uncertainty": float("nan")}},
              "quality": [{"kind": "double hit", "message": "1 hit(s) with a second impact were left out",
                           "band_hz": None, "hits": [2]}]}
    text = text_of(_diagnosis_html(stored))
    assert "{" not in text and "'kind'" not in text  # before: a raw Python dict
    assert "Double hit: 1 hit(s) with a second impact were left out; hit 3" in text
    assert "nan" not in text.lower()


def test_the_reports_diagnosis_leads_with_the_chi2_per_point_the_command_prints():
    from gasfilm.analysis.diagnosis.report import chi2_headline
    from gasfilm.analysis.report import _diagnosis_html

    stored = {"verdict": "missing physics", "chi2_per_point_before": 1652.172, "chi2_per_point_after": 1.383,
              "rms_before_g_per_n": 3.3e-4, "rms_after_g_per_n": 5.9e-6}
    text = text_of(_diagnosis_html(stored))
    assert chi2_headline(1652.172, 1.383) in text  # "χ²/point 1652.172 → 1.383 (1 = noise)", as gasfilm diagnose says
    assert "χ²/point" not in text_of(_diagnosis_html({"verdict": "consistent"}))  # (an old diagnosis without them)
