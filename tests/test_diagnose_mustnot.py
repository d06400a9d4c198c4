"""Claims the diagnosis must not make (issue 14): measurement notes that mislabel the data (a line near a mains
harmonic that is not mains). Fast checks on records synthesised exactly from a rig spec."""

from __future__ import annotations

import numpy as np

from gasfilm.analysis.diagnosis.measurement import hit_spectra
from gasfilm.analysis.physics.response import simulate_response

from test_diagnose import NOMINAL

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

