"""The diagnosis's words as a test engineer reads them (the terminal report of `gasfilm diagnose`, the session report,
the GUI), after a user's reading of the shared real recording (fixtures/real-data/pyfrf-5-hits): a band printed with
no width ("where: 3111–3111 Hz"), dimensionless values with the unit "1" ("damping_ratio 0.000222621 ± 0.00011 1"),
"± 0" for a value held at its bound ("alpha_memory 1.9 ± 0 1"), modes at the fitter's damping floor listed without a
flag, and "gain over the recalibrated spec: 0.0 % RMS …; its own band at χ²/point 1.07 (beyond the noise above
5.25)", which nobody could read. Every number keeps its unit; only the words changed, never a number."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest

from gasfilm.analysis.diagnosis.report import report_text
from gasfilm.analysis.diagnosis.structure import AT_DAMPING_FLOOR, at_damping_floor, mode_row_notes
from gasfilm.analysis.physics.effects import MIN_DAMPING_RATIO
from gasfilm.analysis.quantities import (band_text, bands_text, in_band, rounded_band, unit_word,
                                         with_uncertainty)

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"
#: A band whose two ends print alike ("3111–3111 Hz", "50–50 Hz").
ZERO_WIDTH = re.compile(r"(?<![\d.])(\d+(?:\.\d+)?)–\1(?![\d.])")
#: A value with its uncertainty followed by the unit "1" ("± 0.00011 1", "± 0 1").
UNIT_ONE = re.compile(r"± [\d.e+-]+ 1(?![\d./])")
#: An uncertainty printed as zero ("± 0", "± 0.0 Hz").
PLUS_MINUS_ZERO = re.compile(r"± 0(?:\.0*)?(?![\d.e])")


# --- the words themselves ---------------------------------------------------------------------------------------


def test_a_band_whose_ends_round_alike_is_printed_with_its_width_or_as_one_frequency():
    assert band_text(4065.0, 4155.0) == "4065–4155 Hz"  # as before where whole hertz show the width
    assert band_text(3110.6, 3111.4) == "3110.6–3111.4 Hz"  # before: "3111–3111 Hz"
    assert band_text(3111.02, 3111.04) == "3111.02–3111.04 Hz"
    assert band_text(3111.0, 3111.0) == "at 3111 Hz"  # one line
    assert in_band(3111.0, 3111.0) == "at 3111 Hz" and in_band(10.0, 87.0) == "in 10–87 Hz"
    assert bands_text([(4497.0, 4515.0), (4587.0, 4587.0)]) == "4497–4515, 4587 Hz"
    # the JSON keeps 0.1 Hz, and as many decimals more as a band needs not to lose its width
    assert rounded_band(4065.04, 4155.04) == [4065.0, 4155.0]
    assert rounded_band(3111.02, 3111.04) == [3111.02, 3111.04]


def test_a_dimensionless_value_has_no_unit_and_a_value_with_a_unit_keeps_it():
    assert with_uncertainty(0.000222621, 0.00011, "1") == "0.000222621 ± 0.00011"  # before: "… ± 0.00011 1"
    assert with_uncertainty(3109.98, 0.25, "Hz") == "3109.98 ± 0.25 Hz"
    assert with_uncertainty(0.0396, 0.0041, "N·s^α/m", ".4g") == "0.0396 ± 0.0041 N·s^α/m"
    assert unit_word("1") == "(dimensionless)" and unit_word("") == "(dimensionless)" and unit_word("1/kg") == "1/kg"


def test_a_zero_uncertainty_is_said_to_be_a_value_at_its_bound_and_none_rounds_to_zero():
    assert with_uncertainty(1.9, 0.0, "1") == "1.9 (at its bound)"  # before: "1.9 ± 0 1"
    assert with_uncertainty(0.0001, 0.0, "1", ".4g") == "0.0001 (at its bound)"
    assert with_uncertainty(3110.0, 0.0, "Hz", ".1f", ".1f") == "3110.0 Hz (at its bound)"  # not "± 0.0 Hz"
    assert with_uncertainty(1.9, 0.1, "1", at_bound=True) == "1.9 (at its bound)"
    # a small uncertainty gets the decimals it needs, the value with it
    assert with_uncertainty(3110.0123, 0.02, "Hz", ".1f", ".1f") == "3110.01 ± 0.02 Hz"
    assert with_uncertainty(12.3, float("nan"), "N") == "12.3 N (± not estimated)"
    assert with_uncertainty(12.3, None, "N") == "12.3 N (± not estimated)"


def test_a_mode_at_the_fitters_damping_floor_is_flagged_from_the_fitters_own_constant():
    assert at_damping_floor(MIN_DAMPING_RATIO) and at_damping_floor(MIN_DAMPING_RATIO * (1 + 1e-5))
    assert not at_damping_floor(1.036 * MIN_DAMPING_RATIO) and not at_damping_floor(0.002)
    assert mode_row_notes({"damping_ratio": MIN_DAMPING_RATIO, "above_band": False}) == AT_DAMPING_FLOOR
    assert mode_row_notes({"damping_ratio": MIN_DAMPING_RATIO, "above_band": True}) == (
        f"{AT_DAMPING_FLOOR}; above the band: upper residual")
    assert mode_row_notes({"damping_ratio": 0.002, "above_band": False}) == ""
    assert mode_row_notes({"damping_ratio": None}) == ""  # a row stored by another version


def test_a_findings_gain_is_said_in_its_own_band_before_and_after_and_its_rms_only_where_it_shows():
    from gasfilm.analysis.diagnosis.pipeline import ADEQUATE_CHI2_PER_POINT
    from gasfilm.analysis.diagnosis.report import gain_sentences
    from gasfilm.analysis.diagnosis.result import Finding

    def finding(gain_percent: float, without: float | None, limit: float) -> Finding:
        return Finding(effect="side-mode", kind="rig", band_hz=(3111.0, 3111.0), where="at 3111 Hz", parameters={},
                       evidence="", explanation="", hits="all 5 hits", chi2_gain=944.0, held_out_gain=514.0,
                       gain_over_recalibrated=gain_percent, own_band_chi2_per_point=1.074,
                       own_band_chi2_per_point_without=without, own_band_limit=limit)

    # a narrow resonance: its RMS gain over the whole band rounds to 0.0 % and is not printed (before: "0.0 % RMS")
    (own,) = gain_sentences(finding(0.004, 94.084, 5.253))
    assert own == ("in its own band (at 3111 Hz): χ²/point 94.08 without it → 1.07 with it (1 = the measured noise; "
                   "up to 5.25 counts as noise there, a level an F test says the noise alone exceeds only once in "
                   "1000)")
    # a gain that shows is said, with what it is a percentage of; a limit at the floor is said to be that margin
    own, rms = gain_sentences(finding(0.84, 94.084, ADEQUATE_CHI2_PER_POINT))
    assert own.endswith(f"up to {ADEQUATE_CHI2_PER_POINT:.2f} counts as noise there, the margin the whole comparison "
                        f"is held to)")
    assert rms == ("over the whole band: RMS 0.8 % lower with it than the written spec refitted without it (in % of "
                   "the recalibrated spec's RMS)")
    # a finding stored before the value without the term was kept: the value with it alone
    (own,) = gain_sentences(finding(0.0, None, 5.253))
    assert "χ²/point 1.07 with it (1 = the measured noise;" in own and "without it →" not in own


def test_the_session_report_says_the_same_words_of_a_stored_diagnosis():
    from gasfilm.analysis.report import _diagnosis_html
    from test_report_words import text_of

    stored = {"verdict": "partly explained", "rms_before_g_per_n": 0.41, "rms_after_g_per_n": 0.41,
              "findings": [{"effect": "side-mode", "band_hz": [3111.0, 3111.0], "place": "beside the mover",
                            "parameters": {"freq_hz": {"value": 3109.98, "uncertainty": 0.25, "unit": "Hz"},
                                           "damping_ratio": {"value": 0.000222621, "uncertainty": 0.00011,
                                                             "unit": "1"}},
                            "evidence": "a resonance"}],
              "unexplained": [{"band_hz": [3111.0, 3111.0], "hits": [1, 2], "chi2_share": 0.2,
                               "character": "a peak", "candidates": []}],
              "recalibration": {"alpha": {"spec": 0.5, "fitted": 0.6, "uncertainty": 0.1, "at_bound": False,
                                          "unit": "1"},
                                "k": {"spec": 1e5, "fitted": 1.1e5, "uncertainty": 1e3, "at_bound": False,
                                      "unit": "N/m"}},
              "structure": {"modes": [{"freq_hz": 835.04, "damping_ratio": MIN_DAMPING_RATIO,
                                       "modal_constant_per_kg": 0.02, "quadrature_per_kg": 0.03,
                                       "above_band": False}]},
              "quality": [{"kind": "interference", "message": "mains at 50 Hz", "band_hz": [50.0, 50.0],
                           "hits": None}], "hits_numbered_from": 1}
    text = html.unescape(text_of(_diagnosis_html(stored)))
    assert not ZERO_WIDTH.search(text), ZERO_WIDTH.search(text)  # before: "3111–3111 Hz", "(50–50 Hz)"
    assert "beside the mover: at 3111 Hz" in text and "(at 50 Hz)" in text
    assert "damping_ratio = 0.0002226 ± 0.00011" in text and "freq_hz = 3109.98 ± 0.25 Hz" in text  # (never coarser than its ±)
    assert not UNIT_ONE.search(text), UNIT_ONE.search(text)
    assert "(dimensionless)" in text and "N/m" in text  # the recalibration's unit column
    assert AT_DAMPING_FLOOR in text


# --- the real recording a user read -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def real():
    """The shared real recording diagnosed as `gasfilm diagnose measurements_*.npy` does it (≈ 6 s)."""
    from gasfilm.analysis.diagnosis import diagnose

    diagnosis = diagnose(sorted(FIXTURE.glob("measurements_*.npy")))
    return diagnosis, report_text(diagnosis)


@pytest.mark.slow
def test_the_real_recordings_report_prints_no_band_without_width(real):
    diagnosis, text = real
    assert not ZERO_WIDTH.search(text), ZERO_WIDTH.search(text)
    single = [finding for finding in diagnosis.findings if finding.band_hz[0] == finding.band_hz[1]]
    assert single, "the recording no longer has a finding whose band is one line: the test needs another case"
    for finding in single:
        at = band_text(*finding.band_hz)
        assert at.startswith("at ") and f"(where: {at};" in text  # before: "(where: 3111–3111 Hz; …)"
        assert f"), {at};" in finding.evidence  # the sentence: "… mass line), at 3111 Hz; χ² falls …"


@pytest.mark.slow
def test_the_real_recordings_report_gives_no_unit_to_a_dimensionless_value(real):
    diagnosis, text = real
    assert not UNIT_ONE.search(text), UNIT_ONE.search(text)  # before: "damping_ratio 0.000222621 ± 0.00011 1"
    line = next(line for line in text.splitlines() if line.strip().startswith("damping_ratio"))
    assert re.fullmatch(r"\s*damping_ratio\s+[\d.e+-]+ ± [\d.e+-]+", line), line
    assert re.search(r"freq_hz\s+[\d.]+ ± [\d.]+ Hz", text) and " 1/kg" in text  # what has a unit keeps it


@pytest.mark.slow
def test_the_real_recordings_report_says_at_its_bound_not_plus_minus_zero(real):
    diagnosis, text = real
    assert not PLUS_MINUS_ZERO.search(text), PLUS_MINUS_ZERO.search(text)  # before: "alpha_memory 1.9 ± 0 1"
    held = [(name, row) for candidate in diagnosis.candidates for name, row in candidate.parameters.items()
            if row["uncertainty"] == 0]
    assert held, "no candidate parameter at its bound any more: the test needs another case"
    for name, row in held:
        assert f"{name} {row['value']:.4g} (at its bound)" in text


@pytest.mark.slow
def test_the_real_recordings_mode_table_flags_the_modes_at_the_damping_floor(real):
    diagnosis, text = real
    rows = json.loads(json.dumps(diagnosis.to_dict()))["structure"]["modes"]
    floor = [number for number, row in enumerate(rows, start=1) if at_damping_floor(row["damping_ratio"])]
    assert len(floor) >= 5  # 2, 10, 18, 20, 29, 36 on this recording
    table = text[text.index("modes of the improved spec"):].splitlines()[2:2 + len(rows)]
    flagged = [int(line.split()[0]) for line in table if AT_DAMPING_FLOOR in line]
    assert flagged == floor


@pytest.mark.slow
def test_the_real_recordings_gain_line_says_how_far_chi2_falls_in_the_terms_own_band(real):
    diagnosis, text = real
    assert "gain over the recalibrated spec" not in text and "0.0 % RMS" not in text
    assert "beyond the noise above" not in text  # what the threshold is, said
    for finding in diagnosis.findings:
        assert finding.own_band_chi2_per_point_without is not None
        said = (f"in its own band ({band_text(*finding.band_hz)}): χ²/point "
                f"{finding.own_band_chi2_per_point_without:.2f} without it → {finding.own_band_chi2_per_point:.2f} "
                f"with it (1 = the measured noise; up to {finding.own_band_limit:.2f} counts as noise there")
        assert said in text
        rms = f"RMS {finding.gain_over_recalibrated:.1f} % lower with it"
        assert (rms in text) == (f"{finding.gain_over_recalibrated:.1f}" != "0.0")
    # the value before is kept in the JSON beside the value after (what the session report and the GUI read)
    stored = json.loads(json.dumps(diagnosis.to_dict()))["findings"]
    assert [item["own_band_chi2_per_point_without"] for item in stored] == [
        round(finding.own_band_chi2_per_point_without, 3) for finding in diagnosis.findings]


@pytest.mark.slow
def test_the_diagnose_tab_shows_the_same_words_for_a_stored_diagnosis(qtbot, tmp_path, real):
    from gui_driving import open_window

    diagnosis, _ = real
    stored = json.loads(json.dumps(diagnosis.to_dict()))
    window = open_window(qtbot, tmp_path)
    try:
        tab = window.diagnose_tab
        window.tabs.setCurrentWidget(tab)
        tab.show_stored_diagnosis(stored)
        tab.findings.setCurrentRow(0)
        details = tab.details.toPlainText()
        assert "RMS 0.0 % below" not in details and "χ²/point" in details and "without it →" in details
        assert "(dimensionless)" in details and not ZERO_WIDTH.search(details)
        items = [tab.findings.item(i).text() for i in range(tab.findings.count())]
        structure_row = next(i for i, item in enumerate(items) if item.startswith("Measured structure"))
        tab.findings.setCurrentRow(structure_row)
        assert AT_DAMPING_FLOOR in tab.details.toPlainText()
    finally:
        window.controller.shutdown()


def test_a_value_is_never_printed_coarser_than_its_uncertainty():
    from gasfilm.analysis.quantities import with_uncertainty

    assert with_uncertainty(3109.98, 0.25, "Hz", ".4g") == "3109.98 ± 0.25 Hz"  # not "3110 ± 0.25 Hz"
    assert with_uncertainty(0.5, 0.25, "Hz", ".4g") == "0.5 ± 0.25 Hz"  # enough digits already: unchanged
    assert with_uncertainty(1.9, 0.0, "1") == "1.9 (at its bound)"


def test_gasfilm_fit_prints_no_unit_one_and_says_at_its_bound():
    from types import SimpleNamespace

    from gasfilm.app.commands.fit import format_parameters

    class Model:
        parameters = [SimpleNamespace(name="k", unit="N/m"), SimpleNamespace(name="alpha", unit="1")]

    fit = SimpleNamespace(model=Model, mass_fitted=False, model_name="FOKV", params={"k": 3.8e7, "alpha": 1.95},
                          std_errors={"k": 1.2e3, "alpha": 0.0}, at_bound=("alpha",), mass_kg=25.05, reduced_from="")
    text = format_parameters([fit])
    assert "N/m" in text and "(dimensionless)" in text and " 1\n" not in text + "\n"
    assert "alpha" in text and "(at its bound)" in text
