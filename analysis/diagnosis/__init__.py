"""The parts of the mismatch diagnosis (:mod:`analysis.diagnose` is the entry point)."""
