"""The parts of the mismatch diagnosis (:mod:`gasfilm.analysis.diagnose` is the entry point)."""
