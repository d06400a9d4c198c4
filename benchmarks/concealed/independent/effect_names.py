"""Effect names of the independent benchmark, and how the diagnosis's own names map onto them.

Edit ``DIAGNOSIS_TO_KEY`` when the diagnosis renames an effect: the answer keys use the names of ``RIG_PHYSICS`` and
``MEASUREMENT_CHAIN`` only.
"""

from __future__ import annotations

#: Names the answer keys use for rig physics (what the mover, film and frame do).
RIG_PHYSICS = ("added-mass", "extra-mode", "film-memory", "squeeze-film", "pneumatic-lag", "cubic-stiffness", "drift",
               "step-change", "friction", "quadratic-damping")
#: Names for the measurement chain: reported as measurement, never as rig physics.
MEASUREMENT_CHAIN = ("channel-delay", "ac-coupling", "cross-talk", "sensitivity-error")
#: Processing properties, never physics (an exponential window already applied by an exporting program).
PROCESSING = ("window-damping",)
ALL_EFFECTS = RIG_PHYSICS + MEASUREMENT_CHAIN + PROCESSING

#: The diagnosis's effect name → the key's name (names not listed map to themselves).
DIAGNOSIS_TO_KEY = {
    "amplitude-nonlinearity": "cubic-stiffness",
    "cubic": "cubic-stiffness",
    "hardening": "cubic-stiffness",
    "softening": "cubic-stiffness",
    "stiffness-drift": "drift",
    "damping-drift": "drift",
    "step": "step-change",
    "coulomb-friction": "friction",
    "crosstalk": "cross-talk",
    "sensitivity": "sensitivity-error",
    "delay": "channel-delay",
    "squeeze": "squeeze-film",
}


#: The diagnosis's parameter name → the key's quantity (``expected_parameters``); unlisted names map to themselves.
PARAMETER_TO_KEY = {
    "delta_mass_kg": "mass_kg",
    "k_lag": "k_n_per_m",
    "tau_lag": "tau_s",
    "sensitivity_factor": "factor",
}


def key_name(diagnosis_name: str) -> str:
    """The answer-key name of an effect named by the diagnosis."""
    return DIAGNOSIS_TO_KEY.get(diagnosis_name, diagnosis_name)
