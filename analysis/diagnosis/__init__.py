"""The parts of the mismatch diagnosis (:mod:`analysis.diagnose` is the entry point).

Importing this package registers the rig effect types the diagnosis adds (``pneumatic-lag``, ``ac-coupling``).
"""

from analysis.diagnosis import rigspec as _rigspec  # noqa: F401  (registers the effect types)
