"""The small interface every acquisition backend implements, and the NI 9234's rules.

A backend is opened by name with :func:`gasfilm.drivers.open_device`; the rest of gasfilm sees only :class:`DaqDevice`.
Samples are delivered in physical units: newtons for force channels, m/s² for acceleration channels.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2

#: Base clock of the NI 9234's delta-sigma ADC, divided by n = 1…31 to give the valid sample rates.
NI9234_BASE_RATE_HZ = 51_200.0
NI9234_RATE_DIVISORS = tuple(range(1, 32))
NI9234_VALID_RATES_HZ = tuple(NI9234_BASE_RATE_HZ / n for n in NI9234_RATE_DIVISORS)
NI9234_CHANNELS = ("ai0", "ai1", "ai2", "ai3")
#: The NI 9234's anti-aliasing filter is flat, and the band alias-free, up to this fraction of the sample rate.
NI9234_ALIAS_FREE_FRACTION = 0.45
NI9234_INPUT_RANGE_V = 5.0
NI9234_IEPE_CURRENT_A = 0.002
NI9234_ADC_BITS = 24


class ChannelKind(str, enum.Enum):
    """What a channel measures."""

    FORCE = "force"
    ACCELERATION = "acceleration"

    @property
    def unit(self) -> str:
        return "N" if self is ChannelKind.FORCE else "m/s^2"


class Coupling(str, enum.Enum):
    AC = "AC"
    DC = "DC"


#: Sensitivity units accepted for each channel kind, with the factor that turns them into V per SI unit.
SENSITIVITY_UNITS: dict[ChannelKind, dict[str, float]] = {
    ChannelKind.FORCE: {"mV/N": 1e-3, "V/N": 1.0},
    ChannelKind.ACCELERATION: {
        "mV/(m/s^2)": 1e-3,
        "mV/g": 1e-3 / STANDARD_GRAVITY_M_S2,
        "V/g": 1.0 / STANDARD_GRAVITY_M_S2,
    },
}


@dataclass(frozen=True)
class ChannelConfig:
    """One input of the module: where it is, what sensor is on it and how it is powered."""

    physical_channel: str
    kind: ChannelKind
    sensitivity: float
    sensitivity_units: str
    iepe_current_a: float = NI9234_IEPE_CURRENT_A
    coupling: Coupling = Coupling.AC
    name: str = ""

    @property
    def label(self) -> str:
        return self.name or f"{self.kind.value} ({self.physical_channel})"

    @property
    def sensitivity_v_per_si(self) -> float:
        """Sensitivity in volts per newton (force) or volts per m/s² (acceleration)."""
        return self.sensitivity * SENSITIVITY_UNITS[self.kind][self.sensitivity_units]

    @property
    def full_scale_si(self) -> float:
        """The physical value (N or m/s²) that drives the input to ±5 V."""
        return NI9234_INPUT_RANGE_V / self.sensitivity_v_per_si


@dataclass(frozen=True)
class DaqConfig:
    """A complete acquisition setup: channels in read order, sample rate and chunk size."""

    channels: tuple[ChannelConfig, ...]
    sample_rate_hz: float = NI9234_BASE_RATE_HZ / 4
    samples_per_chunk: int = 0  # 0 → about ten chunks per second

    @property
    def chunk_samples(self) -> int:
        if self.samples_per_chunk > 0:
            return self.samples_per_chunk
        return max(1, int(round(self.sample_rate_hz / 10)))

    def channel_index(self, kind: ChannelKind) -> int:
        """Index of the first channel of a kind in read order."""
        for index, channel in enumerate(self.channels):
            if channel.kind is kind:
                return index
        raise SettingError(f"channels: no {kind.value} channel is configured")


@dataclass
class ChannelStatus:
    """Per-channel condition flags, refreshed after every read."""

    overload: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    open_sensor: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))

    @classmethod
    def clear(cls, channel_count: int) -> "ChannelStatus":
        return cls(np.zeros(channel_count, bool), np.zeros(channel_count, bool))


def nearest_valid_rates(rate_hz: float, count: int = 2) -> list[float]:
    """The valid NI 9234 rates closest to ``rate_hz``."""
    return sorted(NI9234_VALID_RATES_HZ, key=lambda valid: abs(valid - rate_hz))[:count]


def _format_rate(rate_hz: float) -> str:
    return f"{rate_hz:.6g} S/s"


def validate_config(config: DaqConfig) -> DaqConfig:
    """Check a setup against the NI 9234's rules; raise :class:`SettingError` naming the first bad setting."""
    if not any(abs(config.sample_rate_hz - valid) < 1e-6 for valid in NI9234_VALID_RATES_HZ):
        nearest = ", ".join(_format_rate(r) for r in nearest_valid_rates(config.sample_rate_hz))
        raise SettingError(
            f"sample_rate_hz: {_format_rate(config.sample_rate_hz)} is not a NI 9234 rate; it runs at 51200/n S/s "
            f"for n = 1…31 (nearest: {nearest})"
        )
    if not config.channels:
        raise SettingError("channels: at least one channel is needed")
    if len(config.channels) > len(NI9234_CHANNELS):
        raise SettingError(f"channels: the NI 9234 has {len(NI9234_CHANNELS)} channels, {len(config.channels)} given")
    seen: set[str] = set()
    for channel in config.channels:
        where = f"channel {channel.physical_channel}"
        if channel.physical_channel not in NI9234_CHANNELS:
            raise SettingError(
                f"physical_channel: '{channel.physical_channel}' does not exist on the NI 9234; "
                f"allowed: {', '.join(NI9234_CHANNELS)}"
            )
        if channel.physical_channel in seen:
            raise SettingError(f"physical_channel: '{channel.physical_channel}' is configured twice")
        seen.add(channel.physical_channel)
        units = SENSITIVITY_UNITS[ChannelKind(channel.kind)]
        if channel.sensitivity_units not in units:
            raise SettingError(
                f"{where} sensitivity_units: '{channel.sensitivity_units}' is not valid for a {channel.kind.value} "
                f"sensor; allowed: {', '.join(units)}"
            )
        if not np.isfinite(channel.sensitivity) or channel.sensitivity <= 0:
            raise SettingError(
                f"{where} sensitivity: {channel.sensitivity} {channel.sensitivity_units} must be a positive number"
            )
        if channel.iepe_current_a not in (0.0, NI9234_IEPE_CURRENT_A):
            raise SettingError(
                f"{where} iepe_current_a: {channel.iepe_current_a} A is not available; the NI 9234 supplies "
                f"0 A (IEPE off) or 0.002 A"
            )
        if channel.iepe_current_a > 0 and Coupling(channel.coupling) is not Coupling.AC:
            raise SettingError(
                f"{where} coupling: DC coupling is not allowed with IEPE excitation on; allowed: AC "
                f"(or set iepe_current_a to 0)"
            )
    if config.samples_per_chunk < 0:
        raise SettingError(f"samples_per_chunk: {config.samples_per_chunk} must be ≥ 0 (0 = about 10 chunks/s)")
    return config


@dataclass(frozen=True)
class TedsSensor:
    """What an IEPE sensor's TEDS chip (IEEE 1451.4) says, read through the NI 9234: the basic TEDS and the
    sensitivity NI-DAQmx scales the channel with (in one of :data:`SENSITIVITY_UNITS`)."""

    manufacturer_id: int
    model_number: int
    serial_number: int
    version: str
    sensitivity: float
    sensitivity_units: str

    def description(self) -> str:
        return (f"TEDS: manufacturer {self.manufacturer_id}, model {self.model_number}, serial {self.serial_number}, "
                f"version {self.version}, {self.sensitivity:g} {self.sensitivity_units}")


@runtime_checkable
class DaqDevice(Protocol):
    """What gasfilm needs from an acquisition backend.

    Life cycle: ``configure`` → ``start`` → ``read`` … → ``stop`` → ``close`` (or use it as a context manager).
    ``read`` fills a preallocated ``(channels, samples)`` float64 array in physical units (N, m/s²), blocking until
    that many samples per channel have arrived, and returns the number of samples per channel written. Faults raise
    :class:`gasfilm.drivers.errors.DeviceError` subclasses; samples delivered before a fault stay delivered.
    """

    name: str

    def configure(self, config: DaqConfig) -> None: ...

    @property
    def config(self) -> DaqConfig: ...

    @property
    def sample_rate_hz(self) -> float: ...

    def start(self) -> None: ...

    def read(self, out: np.ndarray, timeout_s: float = 10.0) -> int: ...

    def status(self) -> ChannelStatus: ...

    def stop(self) -> None: ...

    def close(self) -> None: ...

    def __enter__(self) -> "DaqDevice": ...

    def __exit__(self, *exc_info: object) -> None: ...


def check_read_buffer(out: np.ndarray, channel_count: int) -> None:
    """Raise :class:`SettingError` unless ``out`` is a writable C-contiguous float64 (channels × samples) array."""
    if out.ndim != 2 or out.shape[0] != channel_count or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise SettingError(
            f"read buffer: expected a C-contiguous float64 array of shape ({channel_count}, samples), "
            f"got {out.dtype} {out.shape}"
        )


def default_hammer_and_accelerometer(sample_rate_hz: float = NI9234_BASE_RATE_HZ / 4) -> DaqConfig:
    """The paper's setup: PCB 086C02 hammer on ai0 (11.2 mV/N), PCB 352B accelerometer on ai1 (10.2 mV/(m/s²))."""
    return DaqConfig(
        channels=(
            ChannelConfig("ai0", ChannelKind.FORCE, 11.2, "mV/N", name="hammer"),
            ChannelConfig("ai1", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)", name="accelerometer"),
        ),
        sample_rate_hz=sample_rate_hz,
    )
