"""Step 3 of the diagnosis, *name*: the mechanisms listed for a description, best first, and which of them the data
cannot tell apart (``tied``)."""

from __future__ import annotations

import numpy as np

from gasfilm.analysis.diagnosis.mechanisms import mechanisms_for
from gasfilm.analysis.physics.effects import EFFECT_TYPES, FitContext

#: a 25 kg mover on a film resonating at 200 Hz with a damping ratio of 0.05, seen over 20–1300 Hz
CONTEXT = FitContext(mass_kg=25.0, film_stiffness_n_per_m=4e7, resonance_hz=200.0, band_hz=(20.0, 1300.0),
                     session_span_s=60.0, max_displacement_m=1e-6, film_damping_ratio=0.05)


def side_mode(freq_hz: float, damping_ratio: float, modal_constant_per_kg: float = 2e-3):
    return EFFECT_TYPES["side-mode"](freq_hz=freq_hz, damping_ratio=damping_ratio,
                                     modal_constant_per_kg=modal_constant_per_kg)


def test_a_lightly_damped_mode_seen_across_a_nodal_line_is_an_elastic_mode_alone():
    """Damped far less than the film damps the mover, above its resonance, with a negative modal constant: no part
    riding on the mover in heave makes that, and no film carries it."""
    matches = mechanisms_for(side_mode(610.0, 0.006, -3e-3), CONTEXT)
    assert "elastic" in matches[0].name
    assert [match.tied for match in matches] == [True] + [False] * (len(matches) - 1)


def test_a_lightly_damped_positive_mode_is_an_elastic_mode_a_riding_part_or_an_attached_exciter():
    """One accelerometer cannot tell those apart (removing the part, disconnecting a stinger would)."""
    tied = {match.name for match in mechanisms_for(side_mode(685.0, 0.0116, 6e-4), CONTEXT) if match.tied}
    assert {"elastic", "riding", "exciter"} <= {word for name in tied for word in ("elastic", "riding", "exciter")
                                                if word in name}
    assert not any("tilt" in name for name in tied)


def test_mechanisms_the_features_point_at_equally_are_tied():
    """A film-damped mode below the film's resonance: tilt on the film and a mode of the base both fit its features
    (the data of one accelerometer cannot tell them apart), the plate's elastic mode does not (it needs a mode above
    the resonance)."""
    matches = mechanisms_for(side_mode(120.0, 0.06), CONTEXT)
    tied = {match.name for match in matches if match.tied}
    assert any("tilt" in name for name in tied) and any("base" in name for name in tied)
    assert not any("elastic" in match.name for match in matches)
    assert all(match.tied for match in matches[:len(tied)])  # the tied ones come first


def test_every_description_has_at_least_one_mechanism_marked_first_and_tied():
    matches = mechanisms_for(EFFECT_TYPES["channel-resonance"](channel="force", freq_hz=1450.0, damping_ratio=0.04),
                             CONTEXT)
    assert matches and matches[0].tied and "hammer" in matches[0].name


def test_a_squeeze_film_is_named_and_a_relaxation_it_cannot_be_told_from_is_tied_with_it():
    """A squeeze film has no spring-pot order, and its loss peaks at squeeze number ≈ 10 (its characteristic
    frequency); a film memory that fitted as well (an alternative) brings its mechanism, tied."""
    squeeze = EFFECT_TYPES["squeeze-film"](gap_m=7e-5, length_m=0.025)
    freq_hz = np.linspace(10.0, 3000.0, 30000)
    loss_peak_hz = freq_hz[np.argmax(squeeze.added_stiffness(2j * np.pi * freq_hz).imag)]
    assert abs(squeeze.features()["characteristic_frequency_hz"] / loss_peak_hz - 1) < 0.01
    alone = mechanisms_for(squeeze, CONTEXT)
    assert alone and "compressibility" in alone[0].name
    assert not any("viscoelastic" in match.name for match in alone)
    beside = mechanisms_for(squeeze, CONTEXT, alternatives=("film-memory",))
    assert beside[0].name == alone[0].name
    assert any("viscoelastic" in match.name and match.tied for match in beside)


def test_a_high_pass_inside_the_band_that_reads_low_is_a_charge_sensor_on_a_voltage_input():
    """A first-order factor with its zero at the origin and its pole inside the band, reading below 1 above it: the
    capacitance of a charge sensor and its cable on a voltage input's resistance (no charge amplifier). A coupling's
    corner below the band is a conditioner's, not that."""
    pole_zero = EFFECT_TYPES["channel-pole-zero"]
    matches = mechanisms_for(pole_zero(pole_hz=373.0, zero_hz=0.01, gain=0.37, reference_hz=200.0), CONTEXT)
    assert "voltage input" in matches[0].name and matches[0].tied and not matches[1].tied
    coupling = mechanisms_for(pole_zero(pole_hz=2.0, zero_hz=0.01, gain=0.9, reference_hz=200.0), CONTEXT)
    assert not any("voltage input" in match.name for match in coupling) and "high-pass" in coupling[0].name


def test_a_parameter_the_data_do_not_determine_is_said_and_read_back():
    """Red team round 9's journal-cross-coupling modelled a channel pole-zero at 63 ± 180 Hz / 376 ± 590 Hz: values
    the data do not determine are listed as such (JSON ``undetermined``), the ones they determine are not."""
    from gasfilm.analysis.diagnosis.result import Finding

    finding = Finding(
        effect="channel-pole-zero", kind="measurement", band_hz=(20.0, 900.0), where="20–900 Hz",
        parameters={"pole_hz": {"value": 63.5, "uncertainty": 177.0, "unit": "Hz"},
                    "zero_hz": {"value": 376.2, "uncertainty": 594.5, "unit": "Hz"},
                    "gain": {"value": 1.127, "uncertainty": 0.02, "unit": ""}},
        evidence="", explanation="", hits="all 12 hits", chi2_gain=1.0, held_out_gain=1.0,
        gain_over_recalibrated=1.0, status="modelled")
    assert finding.undetermined == ["pole_hz", "zero_hz"]
    stored = finding.to_dict()
    assert stored["undetermined"] == ["pole_hz", "zero_hz"]
    assert Finding.from_dict(stored).undetermined == ["pole_hz", "zero_hz"]
