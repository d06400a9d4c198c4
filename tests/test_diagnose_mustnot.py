"""Claims the diagnosis must not make (issue 14): measurement notes that mislabel the data (a line near a mains
harmonic that is not mains), an added mass that is a response reading the film's force, a term within a larger
term's form error, a rig term a measurement term fits as well. Mostly fast checks on records synthesised exactly
from a rig spec."""

from __future__ import annotations

import numpy as np

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.diagnosis.measurement import hit_spectra
from gasfilm.analysis.diagnosis.pipeline import Claim, Step, _beside_a_larger_term, _measurement_alternative
from gasfilm.analysis.physics.effects import CrossTalk, SensitivityError
from gasfilm.analysis.physics.response import simulate_response

from test_diagnose import NOMINAL, record

RATE_HZ = 12800.0


def _records(hits: int = 8, seconds: float = 0.5, pretrigger_s: float = 0.01, seed: int = 0,
             line=None) -> np.ndarray:
    """Records (hits, 2, samples) of the nominal spring-damper rig hit by 1 ms half-sine pulses of 150–250 N after
    ``pretrigger_s``, sensor noise added, and ``line(hit, time_s)`` (m/s²) added to the response."""
    rng = np.random.default_rng(seed)
    time_s = np.arange(int(seconds * RATE_HZ)) / RATE_HZ
    pulse = np.where((time_s >= pretrigger_s) & (time_s < pretrigger_s + 1e-3),
                     np.sin(np.pi * (time_s - pretrigger_s) / 1e-3), 0.0)
    force = rng.uniform(150.0, 250.0, (hits, 1)) * pulse
    response = np.stack([simulate_response(NOMINAL, hit, RATE_HZ) for hit in force])
    if line is not None:
        response = response + np.stack([line(hit, time_s) for hit in range(hits)])
    return np.stack((force + rng.normal(0.0, 0.02, force.shape), response + rng.normal(0.0, 0.005, force.shape)),
                    axis=1)


def _notes(records: np.ndarray) -> dict[str, str]:
    return {note.kind: note.message for note in hit_spectra(records, RATE_HZ).quality}


def _mains(hit: int, time_s: np.ndarray, start_s: float = -np.inf) -> np.ndarray:
    phase = np.random.default_rng(100 + hit).uniform(0, 2 * np.pi)  # each record at its own time of the mains cycle
    on = time_s >= start_s
    return on * (0.03 * np.sin(2 * np.pi * 50.0 * time_s + phase) + 0.01 * np.sin(2 * np.pi * 150.0 * time_s + 3 * phase))


def test_mains_lines_are_found_and_removed():
    notes = _notes(_records(line=_mains))
    assert "interference" in notes and "mains interference at 50 Hz" in notes["interference"], notes


def test_a_self_excited_line_near_a_mains_harmonic_is_not_mains():
    # a limit cycle at 196 Hz in every record, before and after the hit: not at 200 Hz, no 50 Hz line beside it
    def limit_cycle(hit: int, time_s: np.ndarray) -> np.ndarray:
        return 0.03 * np.sin(2 * np.pi * 196.0 * time_s + hit)

    notes = _notes(_records(line=limit_cycle))
    assert "interference" not in notes, notes


def test_lines_whose_phase_the_hit_resets_are_not_mains():
    # lines at the mains frequencies before and after the hit, but the hit sets their phase (a response to it, not a
    # stationary interference): carried back from the tails they do not match the pre-trigger
    def reset(hit: int, time_s: np.ndarray) -> np.ndarray:
        after = time_s >= 0.0105
        return np.where(after, _mains(hit, time_s - 0.0105 + 0.005), _mains(hit, time_s))

    notes = _notes(_records(line=reset))
    assert "interference" not in notes, notes



def test_a_response_that_reads_the_film_force_is_no_added_mass(tmp_path):
    # accelerometer base strain: the response reads a + g·(F − m·a), exactly a cross-talk g with a sensitivity error
    # −g·m, which an added mass g·m² beside the cross-talk describes as well; the pair leaves the mass line where it
    # is, which a mass on the mover would move: no added mass is claimed
    leak = 6.5e-5
    truth = NOMINAL.with_effects(CrossTalk(leak_m_s2_per_n=leak),
                                 SensitivityError(channel="acceleration", fraction=-leak * NOMINAL.moving_mass_kg))
    diagnosis = diagnose(record(truth, tmp_path / "strain.h5", hits=6, seed=5), NOMINAL)
    assert "added-mass" not in [finding.effect for finding in diagnosis.findings], diagnosis.findings
    assert any(c.effect == "added-mass" and "mass line does not move" in c.reason for c in diagnosis.candidates)


def _step(identifier: str, gain: float, alternatives: tuple[str, ...] = ()) -> Step:
    return Step(identifier, 1e7, 1e7 - gain, gain, gain, list(alternatives))


def test_a_term_within_a_larger_terms_form_error_is_no_finding():
    memory, lag = _step("film-memory", 7.2e5), _step("pneumatic-lag", 46.0)
    quiet_without = Claim(0.994, 1.5, 0.06, None, own_band_without=0.998, own_band_chance=1.05)
    assert "form error" in _beside_a_larger_term(lag, [memory, lag], quiet_without)
    assert _beside_a_larger_term(memory, [memory, lag], quiet_without) is None
    # small beside a large term, but its own band is beyond the noise without it: a second effect, kept
    needed = Claim(1.0, 1.5, 0.5, None, own_band_without=1.44, own_band_chance=1.2)
    assert _beside_a_larger_term(_step("film-memory", 287.0), [_step("added-mass", 4.7e5), lag], needed) is None
    mass = _step("added-mass", 480.0)  # 7 % of a channel delay's gain: a second effect, not a correction
    assert _beside_a_larger_term(mass, [_step("channel-delay", 7.2e3), mass], quiet_without) is None


def test_a_rig_term_that_a_measurement_term_fits_as_well_is_no_finding():
    assert "cannot tell whether the rig or the measurement" in _measurement_alternative(
        _step("added-mass", 37.0, ("channel-delay",)))
    assert _measurement_alternative(_step("added-mass", 47.0, ("pneumatic-lag",))) is None
    assert _measurement_alternative(_step("channel-delay", 47.0, ("added-mass",))) is None
