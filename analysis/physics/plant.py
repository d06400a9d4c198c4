"""A rig spec as the plant of the simulated NI 9234 (:class:`gasfilm.drivers.plant.Plant`).

:class:`RigPlant` answers the simulator's questions from a :class:`~gasfilm.analysis.physics.spec.RigSpec` with the
functions of :mod:`gasfilm.analysis.physics.response`; it satisfies the Protocol structurally, so the physics layer
imports nothing from drivers/ but its error types.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gasfilm.analysis.physics import response, rigid_body
from gasfilm.analysis.physics.spec import HammerSpec, RigSpec
from gasfilm.drivers.errors import SettingError


#: A rigid body's accelerances kept for this many hammer points (a roving test's).
KEPT_POINTS = 16


class RigPlant:
    """The rig of ``spec`` behind the simulated module: its hammer, sensors, mover, channel effects and interference.

    A spec with a rigid body and several accelerometers is a :class:`~gasfilm.drivers.plant.MultiResponsePlant`:
    each accelerometer reads the rigid body's motion at its point for the hammer at the struck point
    (:meth:`strike_at` moves the hammer, e.g. between the runs of a roving test)."""

    def __init__(self, spec: RigSpec) -> None:
        self.spec = spec
        self._kept_accelerances: list[tuple[RigSpec, np.ndarray, np.ndarray]] = []
        #: Blows the plant has taken (each impact it was asked to respond to): a change of the rig per blow
        #: (``term-drift`` on the blows' clock) sees each hit at its own blow number.
        self.blows = 0

    @classmethod
    def nominal(cls, film: str = "FOMGF") -> "RigPlant":
        """The paper's rig: the ``film`` model (Table 1 parameters) on the 25.05 kg mover."""
        return cls(RigSpec.nominal(film))

    @classmethod
    def from_spec(cls, spec: RigSpec | str | Path | None) -> "RigPlant":
        """The plant of a spec, of a rig spec TOML file, or (``None``) of the paper's FOMGF rig."""
        if spec is None:
            return cls.nominal()
        return cls(spec if isinstance(spec, RigSpec) else RigSpec.load(spec))

    def __repr__(self) -> str:
        return f"RigPlant({self.spec.name!r})"

    @property
    def hammer(self) -> HammerSpec:
        """The spec's ``[hammer]`` table, else medium tip, 200 N ± 20 %, no double hits."""
        return self.spec.hammer or HammerSpec()

    @property
    def is_linear(self) -> bool:
        """False when the spec has cubic stiffness."""
        return self.spec.is_linear

    def sensitivity_v_per_si(self, channel: str) -> float:
        return self.spec.sensor(channel).sensitivity_v_per_si

    def noise_per_sqrt_hz(self, channel: str) -> float:
        return self.spec.sensor(channel).noise_per_sqrt_hz

    def response_duration_s(self, sample_rate_hz: float) -> float:
        """The time the rig's response takes to decay. A spec with cubic stiffness whose response does not decay
        within :data:`~gasfilm.analysis.physics.response.MAX_RESPONSE_DURATION_S` is refused: its equation of motion
        would be solved on a grid that long for every hit (minutes a hit, and then it does not converge)."""
        duration_s = response.response_duration_s(self.spec, sample_rate_hz)
        if not self.spec.is_linear and duration_s >= response.MAX_RESPONSE_DURATION_S:
            raise SettingError(
                f"{self.spec.source}: the rig's response does not die away within "
                f"{response.MAX_RESPONSE_DURATION_S:g} s (its film or modes are damped too little or too much), which a "
                f"rig with cubic stiffness needs to be simulated"
            )
        return duration_s

    def acceleration_spectrum(
        self, force_spectrum: np.ndarray, s: np.ndarray, sample_rate_hz: float, time_s: float
    ) -> np.ndarray:
        """Linear specs: ``F·s²/Z(s, t)`` bin by bin (plus the force cross-talk and the structure modes). Cubic stiffness: the periodic equation of motion solved on the
        grid's samples (:func:`~gasfilm.analysis.physics.response.mover_displacement_spectrum`)."""
        impulse_ns = float(force_spectrum[0].real)  # the spectrum at s ≈ 0: the hit's level
        spec = self.spec.at_hit(time_s, impulse_ns, self.blows)  # terms that change between hits, at this hit
        self.blows += 1
        # electrical cross-talk of the force signal, and the structure modes beside the mover
        beside_mover = (spec.force_leak_m_s2_per_n + response.structure_accelerance(spec, s)) * force_spectrum
        if spec is not self.spec:  # a channel term that changes between hits: its change in the FRF, on this channel
            beside_mover = beside_mover * self._changed_channel_ratio(spec, s)
            force_spectrum = force_spectrum * self._changed_channel_ratio(spec, s)
        if spec.is_linear:
            stiffness = response.rig_dynamic_stiffness(spec, s, time_s, impulse_ns=impulse_ns)
            return force_spectrum * s**2 / stiffness + beside_mover
        n_samples = 2 * (len(s) - 1)
        # the solver works on sampled signals, whose DFT is the continuous spectrum × the sample rate
        displacement = response.mover_displacement_spectrum(
            spec, force_spectrum * sample_rate_hz, s, n_samples, time_s, impulse_ns=impulse_ns
        )
        return s**2 * displacement / sample_rate_hz + beside_mover

    def _changed_channel_ratio(self, spec: RigSpec, s: np.ndarray) -> np.ndarray:
        """How a hit's channel transfers (``spec``, the spec at the hit) change the FRF against the spec's own, which
        :meth:`channel_transfer` gives the module once: the response channel's change over the force channel's."""
        return (response.channel_transfer(spec, "acceleration", s) / self.channel_transfer("acceleration", s)
                * self.channel_transfer("force", s) / response.channel_transfer(spec, "force", s))

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray:
        return response.channel_transfer(self.spec, channel, s)

    # --- a rigid body's accelerometers ------------------------------------------------------------------------------

    @property
    def response_count(self) -> int:
        """The rigid body's accelerometers (1 for a mover in one direction)."""
        return len(self.spec.rigid_body.accelerometers) if self.spec.rigid_body is not None else 1

    def response_sensitivity_v_per_si(self, response_index: int) -> float:
        sensor = self.spec.rigid_body.accelerometers[response_index] if self.spec.rigid_body is not None else None
        if sensor is None or sensor.sensitivity_mv_per_m_s2 is None:
            return self.sensitivity_v_per_si("acceleration")
        return sensor.sensitivity_mv_per_m_s2 * 1e-3

    def response_noise_per_sqrt_hz(self, response_index: int) -> float:
        sensor = self.spec.rigid_body.accelerometers[response_index] if self.spec.rigid_body is not None else None
        if sensor is None or sensor.noise_m_s2_per_sqrt_hz is None:
            return self.noise_per_sqrt_hz("acceleration")
        return sensor.noise_m_s2_per_sqrt_hz

    def acceleration_spectra(
        self, force_spectrum: np.ndarray, s: np.ndarray, sample_rate_hz: float, time_s: float
    ) -> np.ndarray:
        """Each accelerometer's ``F·H_k(s)`` for the hammer at the struck point (plus the force cross-talk and the
        structure modes), accelerometers × bins."""
        if self.spec.rigid_body is None:
            return self.acceleration_spectrum(force_spectrum, s, sample_rate_hz, time_s)[np.newaxis]
        for spec, grid, accelerances in self._kept_accelerances:
            if (spec is self.spec or spec == self.spec) and grid.shape == s.shape and np.array_equal(grid, s):
                return accelerances * force_spectrum
        impulse_ns = float(force_spectrum[0].real)
        beside_mover = self.spec.force_leak_m_s2_per_n + response.structure_accelerance(self.spec, s)
        accelerances = rigid_body.sensor_accelerances(self.spec, s, None, time_s, impulse_ns=impulse_ns) + beside_mover
        if not self.spec.is_per_hit:  # the same for every hit at this point: kept for the next ones (the simulator
            # asks on one grid; a roving hammer comes back to its points)
            self._kept_accelerances = [*self._kept_accelerances[-(KEPT_POINTS - 1):],
                                       (self.spec, s.copy(), accelerances)]
        return accelerances * force_spectrum

    def strike_at(self, point: str) -> None:
        """Hits from now on strike hammer point ``point`` of the rigid body (a name of its hammer points)."""
        self.spec = rigid_body.struck_at(self.spec, point)

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        """Sum of the spec's effects' interference on the channel, or ``None`` if none has any."""
        total = None
        for effect in self.spec.effects:
            signal = effect.interference(channel, time_s)
            if signal is not None:
                total = signal if total is None else total + signal
        return total
