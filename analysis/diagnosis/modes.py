"""Resonances of the recordings that a spec does not have: how a multi-mode structure's unmodelled modes are named
at their frequencies in the diagnosis's ``unexplained`` entries."""

from __future__ import annotations

import numpy as np

from gasfilm.analysis.diagnosis.selection import Evidence
from gasfilm.analysis.physics.spec import RigSpec

#: A resonance stands this many times above the lowest |H| on either side (as :func:`spectra.resonance_lines`).
PROMINENCE = 1.5
#: A resonance of the spec accounts for the nearest measured one within this fraction of its frequency (its
#: parameters may be off: a shifted resonance is the recalibration's, not a missing mode).
SAME_MODE = 0.15


def unmodelled_resonances_hz(evidence: Evidence, spec: RigSpec, band_hz: tuple[float, float]) -> list[float]:
    """Frequencies (Hz) of the resonances of the recordings' averaged FRF inside ``band_hz`` that no resonance of
    ``spec`` (replayed the same way) accounts for: each of the spec's resonances takes the nearest measured one within
    :data:`SAME_MODE`; those left are unmodelled, lowest first."""
    freq_hz = evidence.freq_hz
    measured = np.abs(evidence.spectra.mean()[0])
    model = np.abs(evidence.mean_prediction(spec))
    import scipy.signal  # (on first use: reading a stored diagnosis does not wait for it)
    measured_peaks, _ = scipy.signal.find_peaks(np.log(measured + 1e-300), prominence=np.log(PROMINENCE))
    model_peaks, _ = scipy.signal.find_peaks(np.log(model + 1e-300), prominence=np.log(PROMINENCE))
    left = [float(freq_hz[p]) for p in measured_peaks]
    for model_hz in sorted(freq_hz[model_peaks], key=lambda f: -model[np.searchsorted(freq_hz, f)]):
        if left:
            nearest = min(left, key=lambda f: abs(f - model_hz))
            if abs(nearest - model_hz) <= SAME_MODE * model_hz:
                left.remove(nearest)
    return [f for f in left if band_hz[0] <= f <= band_hz[1]]
