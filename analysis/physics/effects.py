"""Effects: the ways a real rig departs from the ideal mass on a film (extra mode, hardening, delays, added mass,
drift, mains, pneumatic lag, AC coupling). Each effect is one small class registered with :func:`register_effect`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar

import numpy as np

from gasfilm.drivers.errors import GasfilmError

CHANNELS = ("force", "acceleration")
TIPS_PULSE_WIDTH_S: dict[str, float] = {"soft": 2.0e-3, "medium": 0.8e-3, "hard": 0.25e-3}

#: PCB 086C02 hammer and PCB 352B accelerometer as in the paper; noise densities from their broadband resolution.
DEFAULT_FORCE_SENSITIVITY_MV_PER_N = 11.2
DEFAULT_FORCE_NOISE_N_PER_SQRT_HZ = 9.0e-5
DEFAULT_ACCELERATION_SENSITIVITY_MV_PER_M_S2 = 10.2
DEFAULT_ACCELERATION_NOISE_M_S2_PER_SQRT_HZ = 3.0e-5

#: Relative level below which a response counts as decayed, and the longest response the synthesis will pad for.
DECAY_TOLERANCE = 1e-7
MAX_RESPONSE_DURATION_S = 16.0


class EffectValueError(ValueError):
    """Raised by an effect's ``validate`` with the key at fault; the loader turns it into a SettingError."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


# --- value rules shared by the spec and the effects ---------------------------------------------------------------


def _positive(value: float) -> str | None:
    return None if value > 0 else "must be > 0"


def _non_negative(value: float) -> str | None:
    return None if value >= 0 else "must be ≥ 0"


def _fraction(value: float) -> str | None:
    return None if 0 <= value <= 1 else "must be between 0 and 1"


def _any_number(value: float) -> str | None:
    return None


def _number(unit: str, rule: Callable[[float], str | None] = _any_number, default: Any = dataclasses.MISSING) -> Any:
    """A float field of an effect with its unit and rule (metadata read by the loader and the docs)."""
    return field(default=default, metadata={"unit": unit, "rule": rule})


def _channel_field(default: Any = dataclasses.MISSING) -> Any:
    return field(default=default, metadata={"unit": "", "choices": CHANNELS})


# --- effects -------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Effect:
    """One departure from the ideal mass on a film. Subclasses set ``type_name`` and override the hooks they need."""

    type_name: ClassVar[str] = ""

    def validate(self) -> None:
        """Cross-field checks; raise :class:`EffectValueError` naming the key."""

    def added_mass_kg(self) -> float:
        return 0.0

    def film_scale(self, time_s: float) -> float:
        """Factor on the film's complex stiffness at session time ``time_s``."""
        return 1.0

    def added_stiffness(self, s: np.ndarray) -> np.ndarray | float:
        """Dynamic stiffness (N/m) this effect adds to the mover's, at the Laplace variable ``s``."""
        return 0.0

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        """Multiplicative transfer applied to a channel's signal (``channel`` is "force" or "acceleration")."""
        return 1.0

    def cubic_stiffness_n_per_m3(self) -> float:
        return 0.0

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        """An additive signal in the channel's SI unit at the given times, or ``None``."""
        return None

    def to_table(self) -> dict[str, Any]:
        table: dict[str, Any] = {"type": self.type_name}
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            table[item.name] = list(value) if isinstance(value, tuple) else value
        return table


EFFECT_TYPES: dict[str, type[Effect]] = {}


def register_effect(type_name: str) -> Callable[[type[Effect]], type[Effect]]:
    """Class decorator: make an :class:`Effect` subclass available under ``type = "<type_name>"`` in rig specs."""

    def register(cls: type[Effect]) -> type[Effect]:
        cls.type_name = type_name
        EFFECT_TYPES[type_name] = cls
        return cls

    return register


@register_effect("extra-mode")
@dataclass(frozen=True)
class ExtraMode(Effect):
    """A mass–spring–damper attached to the mover (natural frequency measured with the mover held still)."""

    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    mass_kg: float = _number("kg", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        omega = 2 * np.pi * self.freq_hz
        spring_damper = self.mass_kg * omega**2 + 2 * self.damping_ratio * self.mass_kg * omega * s
        return self.mass_kg * s**2 * spring_damper / (self.mass_kg * s**2 + spring_damper)


@register_effect("cubic-stiffness")
@dataclass(frozen=True)
class CubicStiffness(Effect):
    """Hardening of the film: the restoring force gains ``k3·x³`` (nonlinear)."""

    k3_n_per_m3: float = _number("N/m³", _positive)

    def cubic_stiffness_n_per_m3(self) -> float:
        return self.k3_n_per_m3


@register_effect("channel-delay")
@dataclass(frozen=True)
class ChannelDelay(Effect):
    """One channel's signal arrives ``delay_s`` late (cable, conditioning, a mismatched module)."""

    channel: str = _channel_field()
    delay_s: float = _number("s", _positive)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return np.exp(-s * self.delay_s) if channel == self.channel else 1.0


@register_effect("added-mass")
@dataclass(frozen=True)
class AddedMass(Effect):
    """Mass moving with the mover that the nominal mass leaves out (sensor, fixture, cable)."""

    mass_kg: float = _number("kg", _positive)

    def added_mass_kg(self) -> float:
        return self.mass_kg


@register_effect("drift")
@dataclass(frozen=True)
class Drift(Effect):
    """The film's stiffness changes linearly over the session: ``Z·(1 + fraction_per_hour·t/3600 s)``."""

    fraction_per_hour: float = _number("1/h", _any_number)

    def film_scale(self, time_s: float) -> float:
        scale = 1.0 + self.fraction_per_hour * time_s / 3600.0
        if scale <= 0:
            raise GasfilmError(f"drift: the film stiffness scale reaches {scale:.3g} at t = {time_s:.0f} s")
        return scale


@register_effect("mains")
@dataclass(frozen=True)
class Mains(Effect):
    """Mains interference on one channel: ``amplitude·Σ h_n·sin(2π n f t)`` with ``harmonics = [h_1, h_2, …]``."""

    channel: str = _channel_field()
    amplitude: float = _number("N or m/s²", _positive)
    frequency_hz: float = _number("Hz", _positive, 50.0)
    harmonics: tuple[float, ...] = field(default=(1.0,), metadata={"unit": "1", "list": True})

    def validate(self) -> None:
        if not self.harmonics or not all(math.isfinite(h) and h >= 0 for h in self.harmonics):
            raise EffectValueError("harmonics", "must be a non-empty list of relative amplitudes ≥ 0")

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        if channel != self.channel:
            return None
        phase = 2 * np.pi * self.frequency_hz * np.asarray(time_s, dtype=float)
        return self.amplitude * sum(h * np.sin((n + 1) * phase) for n, h in enumerate(self.harmonics))


@register_effect("pneumatic-lag")
@dataclass(frozen=True)
class PneumaticLag(Effect):
    """Part of the film force lags the motion by a first-order time constant: ``k_lag / (1 + s·tau_lag)``."""

    k_lag: float = _number("N/m", _positive)
    tau_lag: float = _number("s", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        return self.k_lag / (1.0 + s * self.tau_lag)


@register_effect("ac-coupling")
@dataclass(frozen=True)
class AcCoupling(Effect):
    """A first-order high-pass ``s / (s + 2π corner_hz)`` on one channel (beyond the module's own, equal on all)."""

    channel: str = _channel_field()
    corner_hz: float = _number("Hz", _positive)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return s / (s + 2 * np.pi * self.corner_hz) if channel == self.channel else 1.0


