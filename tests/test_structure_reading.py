"""A structure read off its FRF as modal analysis reads it (issue 30, items 1 and 6): poles stable over model orders in
frequency, damping and participation, antiresonances and lines of low coherence never modes, a soft support read as
the suspension, the polarity and whether the FRF is a driving point; the stabilization diagram and the mode table
(by frequency) in the files, the JSON, the text, the session report and the GUI; the GUI's FRF tab opening on the
whole usable band with the peak `replay` reports."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from synthesis import synthesised_hits

from gasfilm.analysis.diagnosis.measurement import default_window
from gasfilm.analysis.diagnosis.plots import STABILIZATION_FILE, write_outputs
from gasfilm.analysis.diagnosis.recordings import Recordings, diagnose, read_start_with_structure
from gasfilm.analysis.diagnosis.report import report_text
from gasfilm.analysis.diagnosis.structure import SCAN_STEP, STABILITY, _not_a_mode, beside_transfer, reread_mode
from gasfilm.analysis.physics.effects import Polarity, StructureMode
from gasfilm.analysis.physics.response import rig_accelerance
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import compute_frf, peak_line, readable_lines

RATE_HZ = 25_600.0
#: A rigid body of 1.7 kg on a soft support (20 Hz, ζ 0.03), measured at a transfer point (modal constants of both
#: signs) with the accelerometer mounted the other way round: what issue 30's second recording looked like.
MASS_KG, SUPPORT_HZ, SUPPORT_ZETA = 1.7, 20.0, 0.03
MODES = (StructureMode(freq_hz=380.0, damping_ratio=0.004, modal_constant_per_kg=0.5),
         StructureMode(freq_hz=610.0, damping_ratio=0.006, modal_constant_per_kg=-0.35),
         StructureMode(freq_hz=905.0, damping_ratio=0.003, modal_constant_per_kg=0.6))
REAL = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"


def _structure() -> RigSpec:
    omega = 2 * np.pi * SUPPORT_HZ
    return RigSpec.nominal("SD", mass_kg=MASS_KG, parameters={"k": MASS_KG * omega**2,
                                                              "eta": 2 * SUPPORT_ZETA * MASS_KG * omega},
                           effects=[Polarity(channel="acceleration"), *MODES])


@pytest.fixture(scope="module")
def recordings() -> Recordings:
    spec = _structure()
    return synthesised_hits(lambda freq_hz: rig_accelerance(spec, freq_hz, 0.0, 0.0), RATE_HZ, 4, 3,
                            "soft-support.npy")


@pytest.fixture(scope="module")
def diagnosis(recordings, tmp_path_factory):
    result = diagnose(recordings)
    write_outputs(result, tmp_path_factory.mktemp("diagnosis"))
    return result


def test_a_transfer_frf_on_a_soft_support_is_read_as_modal_analysis_reads_it(recordings):
    spec, text, structure = read_start_with_structure(recordings)
    assert "not a driving point" in text and "soft support" in text and "polarity −1" in text
    assert not structure.driving_point and structure.polarity == -1
    assert structure.suspension[0] == pytest.approx(SUPPORT_HZ, rel=0.01)
    assert structure.suspension[1] == pytest.approx(SUPPORT_ZETA, rel=0.05)
    assert structure.mass_kg == pytest.approx(MASS_KG, rel=0.01)
    # the modes, and nothing else in the band (a stable pole whose constant is nothing is not kept)
    assert len(structure.modes) == len(MODES)
    for read, true in zip(sorted(structure.modes, key=lambda mode: mode.freq_hz), MODES):
        assert read.freq_hz == pytest.approx(true.freq_hz, rel=1e-3)
        assert read.damping_ratio == pytest.approx(true.damping_ratio, rel=0.05)
        assert read.modal_constant_per_kg == pytest.approx(true.modal_constant_per_kg, rel=0.02)
    # the spec: the suspension is the film, the modes beside the mover, the polarity a measurement effect
    assert np.sqrt(spec.film_parameters["k"] / spec.mass_kg) / (2 * np.pi) == pytest.approx(SUPPORT_HZ, rel=0.01)
    assert [e.type_name for e in spec.effects].count("polarity") == 1
    # the stabilization diagram holds poles of every class, over the model orders of LSCF
    counts = structure.diagram.counts()
    assert set(counts) == set(STABILITY) and all(count > 0 for count in counts.values())
    assert structure.diagram.order.max() == 120


def test_antiresonances_and_lines_of_low_coherence_are_never_modes(recordings):
    frf = compute_frf(recordings.records, RATE_HZ, default_window(recordings.records, RATE_HZ))
    magnitude = np.abs(frf.h1)
    lines = np.flatnonzero(readable_lines(frf))
    # the antiresonance between the soft support and the mode at 380 Hz (constants of the same sign: a zero)
    between = lines[(frf.freq_hz[lines] > 40) & (frf.freq_hz[lines] < 370)]
    dip_hz = float(frf.freq_hz[between[np.argmin(magnitude[between])]])
    assert "antiresonance" in _not_a_mode(dip_hz, 0.004, frf.freq_hz, magnitude, frf.coherence, frf.decay_rate_1_s)
    assert _not_a_mode(380.0, 0.004, frf.freq_hz, magnitude, frf.coherence, frf.decay_rate_1_s) == ""
    low = frf.coherence.copy()
    low[np.argmin(np.abs(frf.freq_hz - 380.0))] = 0.36
    assert "low coherence (0.36)" in _not_a_mode(380.0, 0.004, frf.freq_hz, magnitude, low, frf.decay_rate_1_s)
    _, _, structure = read_start_with_structure(recordings)
    assert all(abs(mode.freq_hz - dip_hz) > 5.0 for mode in structure.modes)


def test_the_stabilization_diagram_and_the_mode_table_are_in_the_files_the_json_and_the_text(diagnosis):
    assert Path(diagnosis.figures[-1]).name == STABILIZATION_FILE and Path(diagnosis.figures[-1]).stat().st_size
    structure = json.loads(json.dumps(diagnosis.to_dict()))["structure"]
    frequencies = [row["freq_hz"] for row in structure["modes"]]
    assert frequencies == sorted(frequencies)
    assert {"freq_hz", "damping_ratio", "modal_constant_per_kg", "quadrature_per_kg"} <= set(structure["modes"][0])
    read = structure["read_off_frf"]
    assert read["driving_point"] is False and read["polarity"] == -1
    assert read["suspension_hz"] == pytest.approx(SUPPORT_HZ, rel=0.01)
    assert len(read["stabilization"]["order"]) == len(read["stabilization"]["freq_hz"]) > 100
    text = report_text(diagnosis)
    assert "structure read off the FRF" in text and "diagnosis-stabilization.png" in text
    table = text[text.index("modes of the improved spec"):].splitlines()[2:]
    shown = [float(line.split()[1]) for line in table if line.split()[0].isdigit()]
    assert shown == sorted(shown) and len(shown) == len(structure["modes"])


def test_the_session_report_shows_the_stabilization_diagram_and_the_modes(diagnosis):
    from gasfilm.analysis.report import _diagnosis_html

    stored = json.loads(json.dumps(diagnosis.to_dict()))
    page = _diagnosis_html(stored, "run-001", 1)
    assert "Measured structure: modes" in page and "alt='stabilization diagram'" in page
    assert page.count("<tr>") >= len(stored["structure"]["modes"])


def test_the_diagnose_tab_shows_the_stabilization_diagram_and_the_mode_table(qtbot, tmp_path, diagnosis):
    from gui_driving import open_window

    window = open_window(qtbot, tmp_path)
    try:
        tab = window.diagnose_tab
        window.tabs.setCurrentWidget(tab)
        tab.show_diagnosis(diagnosis)
        items = [tab.findings.item(i).text() for i in range(tab.findings.count())]
        assert any(text.startswith("Measured structure: ") and "stabilization diagram" in text for text in items)
        assert tab.stabilization_plot.isVisible()
        assert len(tab.stabilization_plot.getPlotItem().listDataItems()) == len(STABILITY)
        structure_row = next(i for i, text in enumerate(items) if text.startswith("Measured structure"))
        tab.findings.setCurrentRow(structure_row)
        assert "modal constant" in tab.details.toHtml() and "380.00" in tab.details.toHtml()
    finally:
        window.controller.shutdown()


def test_the_shared_recording_is_read_with_its_known_modes():
    """0.25 s of the shared recording: a transfer FRF (a negative mass line, constants of both signs) whose known
    modes are read, by frequency."""
    records = np.stack([np.load(REAL / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:, : int(0.25 * RATE_HZ)]
    spec, text, structure = read_start_with_structure(Recordings(records, RATE_HZ, np.arange(5.0), None, None, None,
                                                                 "shared"))
    assert structure.polarity == -1 and not structure.driving_point and structure.suspension is None
    found = sorted(mode.freq_hz for mode in structure.modes)
    for mode_hz in (900.0, 2640.0, 3669.0, 3689.0, 4128.0):
        assert min(abs(f - mode_hz) for f in found) < 0.002 * mode_hz, mode_hz
    assert structure.upper_residual is None or structure.upper_residual.freq_hz > structure.band_hz[1]
    assert "3172 Hz" not in text  # the line of low coherence (0.3) in the antiresonance near 3.2 kHz is no mode
    assert all(abs(f - 3172.0) > 20.0 for f in found)


def test_the_frf_tab_opens_on_the_usable_band_with_the_peak_replay_reports(qtbot, tmp_path):
    from gui_driving import open_window

    records = np.stack([np.load(REAL / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]
    frf = compute_frf(records, RATE_HZ, default_window(records, RATE_HZ))
    window = open_window(qtbot, tmp_path)
    try:
        window.tabs.setCurrentWidget(window.frf_tab)
        window.frf_tab.set_frf(frf)
        shown_low, shown_high = window.frf_tab.magnitude_plot.getPlotItem().viewRange()[0]
        assert shown_high >= 7000.0  # the usable band ends near 7 kHz; its strongest modes are at 2.6–4.1 kHz
        peak_hz = float(frf.freq_hz[peak_line(frf)])
        assert abs(peak_hz - 4128.0) < 2.0
        assert f"peak {peak_hz:.1f} Hz" in window.frf_tab.summary.text()
    finally:
        window.controller.shutdown()


@pytest.mark.parametrize("field, factor", [("freq_hz", 1.015), ("freq_hz", 0.997), ("damping_ratio", 2.0)])
def test_a_sharp_mode_that_moved_by_many_bandwidths_is_re_read_where_it_now_is(field, factor):
    # a mode of ζ 0.001 at 905 Hz (half-power bandwidth 1.8 Hz) moved 1.5 % (7.5 bandwidths) or 0.3 %, or its damping
    # doubled, seen on a coarse grid (5 Hz lines) beside the other modes: a local fit from the spec's pole has no
    # gradient to follow there; the scan finds the new pole within a step and the constant near the mode's (the fit
    # that follows in the diagnosis finishes both)
    mode = StructureMode(freq_hz=905.0, damping_ratio=0.001, modal_constant_per_kg=0.6, quadrature_per_kg=0.02)
    spec = _structure().with_values(effects=[*_structure().effects[:-1], mode])
    changed = spec.with_values(effects=[*spec.effects[:-1],
                                        dataclasses.replace(mode, **{field: getattr(mode, field) * factor})])
    freq_hz, decay_1_s = np.arange(100.0, 2000.0, 5.0), 3.0
    s = decay_1_s + 2j * np.pi * freq_hz
    measured = rig_accelerance(changed, freq_hz, decay_1_s)
    transfer = beside_transfer(spec, freq_hz, decay_1_s)
    target = measured - rig_accelerance(spec, freq_hz, decay_1_s) + transfer * mode.added_accelerance(s)
    reread, gain = reread_mode(mode, freq_hz, decay_1_s, target, np.full(freq_hz.size, 1e6), transfer)
    assert gain > 0
    new_hz = mode.freq_hz * (factor if field == "freq_hz" else 1.0)
    assert abs(reread.freq_hz - new_hz) <= SCAN_STEP * 2 * mode.damping_ratio * mode.freq_hz
    new_zeta = mode.damping_ratio * (factor if field == "damping_ratio" else 1.0)
    assert abs(reread.damping_ratio / new_zeta - 1) < 0.45  # the scan's damping steps are √2 apart; the fit finishes
    assert abs(reread.modal_constant_per_kg / mode.modal_constant_per_kg - 1) < 0.5
