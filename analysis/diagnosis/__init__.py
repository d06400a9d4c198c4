"""Mismatch diagnosis: where a rig spec and the recordings differ, what physics (or measurement) is missing, what is
not explained. Entry point :func:`diagnose`; parts: ``measurement`` (per-hit spectra, noise, quality), ``fitspace``
(a spec's free parameters), ``candidates``, ``selection`` (weighted fits, statistics), ``pipeline``, ``result``,
``recordings``, ``report`` (text) and ``plots`` (figures, written by callers).
"""

from gasfilm.analysis.diagnosis.recordings import Recordings, diagnose, load_recordings, starting_spec
from gasfilm.analysis.diagnosis.result import Diagnosis, Finding, Unexplained

__all__ = ["Diagnosis", "Finding", "Recordings", "Unexplained", "diagnose", "load_recordings", "starting_spec"]
