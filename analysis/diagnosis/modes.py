"""Resonances of the recordings that a spec does not have: how a multi-mode structure's unmodelled modes are named
at their frequencies in the diagnosis's ``unexplained`` entries."""

from __future__ import annotations

import numpy as np
import scipy.signal

from gasfilm.analysis.diagnosis.selection import Evidence
from gasfilm.analysis.physics.spec import RigSpec

#: A resonance stands this many times above the lowest |H| on either side (as :func:`spectra.resonance_lines`).
PROMINENCE = 1.5
#: A measured resonance is the spec's when the spec has one within this fraction of its frequency.
SAME_MODE = 0.03


def unmodelled_resonances_hz(evidence: Evidence, spec: RigSpec, band_hz: tuple[float, float]) -> list[float]:
    """Frequencies (Hz) of the resonances of the recordings' averaged FRF inside ``band_hz`` that ``spec`` replayed
    the same way has no resonance near (within :data:`SAME_MODE`), lowest first."""
    freq_hz = evidence.freq_hz
    measured = np.abs(evidence.spectra.mean()[0])
    model = np.abs(evidence.mean_prediction(spec))
    measured_peaks, _ = scipy.signal.find_peaks(np.log(measured + 1e-300), prominence=np.log(PROMINENCE))
    model_peaks, _ = scipy.signal.find_peaks(np.log(model + 1e-300), prominence=np.log(PROMINENCE))
    model_hz = freq_hz[model_peaks]
    return [float(freq_hz[p]) for p in measured_peaks if band_hz[0] <= freq_hz[p] <= band_hz[1]
            and not np.any(np.abs(model_hz - freq_hz[p]) <= SAME_MODE * freq_hz[p])]
