"""What the Setup tab holds, turned into driver and analysis settings, and remembered between runs (QSettings)."""

from __future__ import annotations

import dataclasses
import enum
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from PySide6.QtCore import QSettings

from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import (
    NI9234_IEPE_CURRENT_A,
    ChannelConfig,
    ChannelKind,
    Coupling,
    DaqConfig,
    validate_config,
)
from gasfilm.drivers.plant import TIPS_PULSE_WIDTH_S

SETTINGS_KEY = "setup/state"
SETTINGS_ORGANIZATION = "gasfilm"
SETTINGS_APPLICATION = "gasfilm-gui"
SIM_TIPS = tuple(TIPS_PULSE_WIDTH_S)  # the simulated hammer's tips

T = TypeVar("T")


@dataclass
class ChannelSetup:
    """One row of the channel table."""

    physical_channel: str
    kind: str = ChannelKind.ACCELERATION.value
    enabled: bool = False
    name: str = ""
    sensor_model: str = ""  # "" → typed in by hand
    sensitivity: float = 10.2
    units: str = "mV/(m/s^2)"
    iepe: bool = True
    coupling: str = Coupling.AC.value

    def channel_config(self) -> ChannelConfig:
        return ChannelConfig(
            physical_channel=self.physical_channel,
            kind=ChannelKind(self.kind),
            sensitivity=float(self.sensitivity),
            sensitivity_units=self.units,
            iepe_current_a=NI9234_IEPE_CURRENT_A if self.iepe else 0.0,
            coupling=Coupling(self.coupling),
            name=self.name,
        )


def default_channels() -> list[ChannelSetup]:
    """The paper's setup: PCB 086C02 hammer on ai0, PCB 352B accelerometer on ai1, ai2/ai3 off."""
    return [
        ChannelSetup("ai0", ChannelKind.FORCE.value, True, "hammer", "PCB 086C02", 11.2, "mV/N"),
        ChannelSetup("ai1", ChannelKind.ACCELERATION.value, True, "accelerometer", "PCB 352B", 10.2, "mV/(m/s^2)"),
        ChannelSetup("ai2", name="response 2"),
        ChannelSetup("ai3", name="response 3"),
    ]


@dataclass
class SetupState:
    """Everything the technician sets before arming; plain data so it can be stored as JSON."""

    device: str = "sim"
    channels: list[ChannelSetup] = field(default_factory=default_channels)
    response_channel: str = "ai1"  # the acceleration channel the FRF is computed from
    sample_rate_hz: float = 51200.0 / 4
    trigger: dict[str, Any] = field(default_factory=lambda: {"level_n": 20.0, "pretrigger_s": 0.01, "record_s": 1.0})
    window: dict[str, Any] = field(default_factory=dict)
    validation: dict[str, Any] = field(default_factory=dict)
    rig_spec_path: str = ""  # "" → the paper's FOMGF film on 25.05 kg
    auto_accept: bool = True  # hits passing every check are accepted without a click
    auto_reject: bool = True  # hits failing a check are rejected without a click
    sim_auto_hammer: bool = False  # simulated rig: the hammer also hits by itself every 1.5–3 s
    sim_tip: str = "medium"
    sim_seed: int = 1
    live_view_s: float = 2.0

    def enabled_channels(self) -> list[ChannelSetup]:
        return [channel for channel in self.channels if channel.enabled]

    def daq_config(self) -> DaqConfig:
        """The validated acquisition setup (enabled channels in ai order)."""
        channels = tuple(channel.channel_config() for channel in self.enabled_channels())
        config = validate_config(DaqConfig(channels=channels, sample_rate_hz=float(self.sample_rate_hz)))
        config.channel_index(ChannelKind.FORCE)
        self.response_row(config)
        return config

    def response_row(self, config: DaqConfig) -> int:
        """Row of the FRF's response channel in ``config``'s read order."""
        for row, channel in enumerate(config.channels):
            if channel.physical_channel == self.response_channel and channel.kind is ChannelKind.ACCELERATION:
                return row
        raise SettingError(
            f"response channel: '{self.response_channel}' is not an enabled acceleration channel; enable it or pick "
            f"one of {', '.join(c.physical_channel for c in config.channels if c.kind is ChannelKind.ACCELERATION)}"
        )

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self))

    @classmethod
    def from_json(cls, text: str) -> "SetupState":
        """Rebuild from stored JSON; unknown keys are dropped and missing ones take their defaults."""
        data = json.loads(text)
        known = {f.name for f in dataclasses.fields(cls)}
        values = {key: value for key, value in data.items() if key in known}
        channel_keys = {f.name for f in dataclasses.fields(ChannelSetup)}
        if "channels" in values:
            rows = [ChannelSetup(**{k: v for k, v in row.items() if k in channel_keys}) for row in values["channels"]]
            by_name = {row.physical_channel: row for row in rows}
            values["channels"] = [by_name.get(row.physical_channel, row) for row in default_channels()]
        return cls(**values)


def load_setup(settings: QSettings) -> SetupState:
    """The state stored by the last run, or the defaults (also when the stored value is unreadable)."""
    text = settings.value(SETTINGS_KEY, "")
    if not text:
        return SetupState()
    try:
        return SetupState.from_json(str(text))
    except (ValueError, TypeError):
        return SetupState()


def save_setup(settings: QSettings, state: SetupState) -> None:
    settings.setValue(SETTINGS_KEY, state.to_json())
    settings.sync()


def settings_from_dict(cls: type[T], values: dict[str, Any]) -> T:
    """An instance of the settings dataclass ``cls`` with the stored ``values`` that still fit its fields."""
    instance = cls()
    changes = {}
    for f in dataclasses.fields(cls):
        if f.name not in values or not f.init:
            continue
        default = getattr(instance, f.name)
        value = values[f.name]
        if isinstance(default, enum.Enum):
            value = type(default)(value)
        elif isinstance(default, tuple):
            value = tuple(value)
        changes[f.name] = value
    return dataclasses.replace(instance, **changes) if changes else instance


def rig_spec_label(path: str) -> str:
    return Path(path).name if path else "nominal FOMGF film, 25.05 kg (paper)"
