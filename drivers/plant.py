"""The plant: what the simulated NI 9234 needs from the rig behind it (hammer defaults, sensors, the mover's
response, channel transfers and interference), as a small Protocol in SI units and plain numpy.

The simulated device is handed a plant by its caller; drivers/ knows no rig physics. The rig spec's implementation
is :class:`gasfilm.analysis.physics.plant.RigPlant`. Channels are named by their kind, ``"force"`` or
``"acceleration"``. Spectra are continuous Fourier transforms (N·s, m/s²·s) on a Laplace grid ``s = j2πf``.
A plant whose accelerometers see different motions (a rigid mover: heave, roll and pitch) is also a
:class:`MultiResponsePlant`: the k-th acceleration channel of the configuration carries its response k.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

#: The simulated hammer's tips and the width (s) of the half-sine force pulse each gives.
TIPS_PULSE_WIDTH_S: dict[str, float] = {"soft": 2.0e-3, "medium": 0.8e-3, "hard": 0.25e-3}


class HammerDefaults(Protocol):
    """How the simulated hammer hits unless told otherwise: tip (a key of :data:`TIPS_PULSE_WIDTH_S`), peak force
    (N), uniform spread of the peak force (± fraction) and the fraction of hits that bounce (double hits)."""

    tip: str
    force_n: float
    force_spread: float
    double_hit_rate: float


@runtime_checkable
class Plant(Protocol):
    """The rig behind the simulated NI 9234: hammer, sensors and the mover they measure."""

    @property
    def hammer(self) -> HammerDefaults:
        """The hammer's defaults."""
        ...

    @property
    def is_linear(self) -> bool:
        """True when the acceleration at a frequency depends on the force at that frequency only, so that
        :meth:`acceleration_spectrum` may be asked on the leading part of a grid."""
        ...

    def sensitivity_v_per_si(self, channel: str) -> float:
        """The sensor's true sensitivity on a ``channel`` kind (V per N or per m/s²)."""
        ...

    def noise_per_sqrt_hz(self, channel: str) -> float:
        """The sensor's white noise density on a ``channel`` kind (N/√Hz or (m/s²)/√Hz)."""
        ...

    def response_duration_s(self, sample_rate_hz: float) -> float:
        """Time after an impact by which the mover's response, sampled at ``sample_rate_hz``, has decayed."""
        ...

    def acceleration_spectrum(
        self, force_spectrum: np.ndarray, s: np.ndarray, sample_rate_hz: float, time_s: float
    ) -> np.ndarray:
        """The acceleration the accelerometer senses (m/s²·s: the mover's, plus anything the plant adds such as
        force cross-talk) for a force spectrum (N·s) on the same grid.

        ``s`` is the rfft grid of a periodic record of ``2·(len(s) − 1)`` samples at ``sample_rate_hz`` (its DC bin
        nudged just off zero), long enough for the response to decay, over which a nonlinear plant solves the motion;
        a linear plant (:attr:`is_linear`) may be given only the grid's first bins. ``time_s`` is the session time
        of the impact.
        """
        ...

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray:
        """The transfer (1) on a ``channel`` kind's signal between the rig and the module (a delay, an extra
        coupling, ...), at ``s``; the module's own filters are the simulator's."""
        ...

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        """Additive interference on a ``channel`` kind (N or m/s²) at the session times ``time_s``, or ``None``."""
        ...


@runtime_checkable
class MultiResponsePlant(Plant, Protocol):
    """A plant with several accelerometers that see different motions; with :attr:`response_count` 1 it is played
    as a :class:`Plant`. Responses are numbered from 0 in the order of the configuration's acceleration channels."""

    @property
    def response_count(self) -> int:
        """How many distinct accelerometer responses the plant has."""
        ...

    def response_sensitivity_v_per_si(self, response: int) -> float:
        """Accelerometer ``response``'s true sensitivity (V per m/s²)."""
        ...

    def response_noise_per_sqrt_hz(self, response: int) -> float:
        """Accelerometer ``response``'s white noise density ((m/s²)/√Hz)."""
        ...

    def acceleration_spectra(
        self, force_spectrum: np.ndarray, s: np.ndarray, sample_rate_hz: float, time_s: float
    ) -> np.ndarray:
        """Every accelerometer's acceleration (responses × bins, m/s²·s) for a force spectrum, as
        :meth:`Plant.acceleration_spectrum` gives one."""
        ...
