"""What the Setup tab holds, turned into driver and analysis settings, and remembered between runs (QSettings)."""

from __future__ import annotations

import dataclasses
import enum
import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from PySide6.QtCore import QSettings

from gasfilm.analysis.capture import TriggerSettings, check_record_length
from gasfilm.analysis.settings import setting_label
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import ValidationSettings
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
logger = logging.getLogger(__name__)
#: The Setup state's groups of analysis settings and their dataclasses.
_SETTINGS_GROUPS = {"trigger": TriggerSettings, "window": WindowSettings, "validation": ValidationSettings}


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
    serial: str = ""  # the sensor's serial number (library, TEDS or typed in)
    calibration_date: str = ""  # its last calibration, YYYY-MM-DD ("" not known)
    teds: str = ""  # what its TEDS chip said, when it was read (Read TEDS)

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
    sim_speed: float = 1.0  # simulated rig: seconds of signal streamed per second (1: real time)
    live_view_s: float = 2.0
    target_averages: int = 10  # acquisition stops once this many hits are accepted (0: no target)
    min_coherence: float = 0.9  # auto-accept also needs the band's mean γ² to stay above this (0: no check)
    usable_drop_db: float = 20.0  # the FRF is trusted where the force spectrum is within this of its low-f level
    #: Operating conditions as typed (name with its unit → value text; empty values are not recorded)
    conditions: dict[str, str] = field(default_factory=dict)
    operator: str = ""  # who runs the test
    test_object: str = ""  # what is tested (bearing, mover, serial number …)

    def test_record(self) -> dict[str, Any]:
        """Who tested what, with which sensors: stored with the session ("test" and "sensors") and shown by the
        report."""
        sensors = [{"channel": c.physical_channel, "name": c.name, "kind": c.kind, "model": c.sensor_model or "typed in",
                    "serial": c.serial, "calibration_date": c.calibration_date, "teds": c.teds}
                   for c in self.enabled_channels()]
        return {"test": {"operator": self.operator, "test_object": self.test_object}, "sensors": sensors}

    def enabled_channels(self) -> list[ChannelSetup]:
        return [channel for channel in self.channels if channel.enabled]

    def daq_config(self) -> DaqConfig:
        """The validated acquisition setup (enabled channels in ai order)."""
        channels = tuple(channel.channel_config() for channel in self.enabled_channels())
        config = validate_config(DaqConfig(channels=channels, sample_rate_hz=float(self.sample_rate_hz)))
        config.channel_index(ChannelKind.FORCE)
        self.response_row(config)
        return config

    def trigger_settings(self) -> TriggerSettings:
        """The trigger of a live acquisition: refused, naming the Setup tab's field, where the command line's
        ``acquire`` refuses it too (one rule: :func:`gasfilm.analysis.capture.check_record_length`)."""
        trigger = settings_from_dict(TriggerSettings, self.trigger)
        check_record_length(trigger.record_s, setting_label("trigger", "record_s"))
        return trigger

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
        """Rebuild from stored JSON; unknown keys are dropped and missing ones take their defaults. Values of the
        wrong type raise :class:`SettingError` naming the key (a damaged settings file)."""
        try:
            data = json.loads(text)
        except (ValueError, RecursionError) as error:
            raise SettingError(f"not valid JSON ({error})") from None
        if not isinstance(data, dict):
            raise SettingError(f"expected a JSON object, found {type(data).__name__}")
        defaults = cls()
        values: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            if f.name not in data:
                continue
            value = data[f.name]
            if f.name == "channels":
                value = _channels_from_json(value)
            elif f.name in _SETTINGS_GROUPS:
                _check_group(f.name, value, _SETTINGS_GROUPS[f.name])
            elif f.name == "conditions":
                if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                                          for k, v in value.items()):
                    raise SettingError("'conditions': expected an object of condition names and value texts")
            else:
                _check_like(f.name, value, getattr(defaults, f.name))
            values[f.name] = value
        return cls(**values)


def _check_like(name: str, value: Any, default: Any) -> None:
    """``value`` has the type of ``default`` (an int passes for a float; numbers must be finite)."""
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, (int, float)):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        ok = ok and (isinstance(value, int) or not isinstance(default, int))
    elif isinstance(default, str):
        ok = isinstance(value, str)
    else:
        ok = value is None or (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value))
    if not ok:
        raise SettingError(f"'{name}': {value!r:.60} is not a {type(default).__name__}")


def _check_group(name: str, values: Any, settings_type: type) -> None:
    """A dict of a settings dataclass's fields with values of the right types (``None`` for optional ones)."""
    if not isinstance(values, dict):
        raise SettingError(f"'{name}': expected an object of settings, found {type(values).__name__}")
    defaults = settings_type()
    for key, value in values.items():
        if key in {f.name for f in dataclasses.fields(settings_type)}:
            default = getattr(defaults, key)
            if isinstance(default, enum.Enum):
                default = default.value
            if value is not None or default is not None:
                _check_like(f"{name}.{key}", value, default if value is not None else 0.0)


def _channels_from_json(rows: Any) -> list[ChannelSetup]:
    if not isinstance(rows, list) or not all(isinstance(row, dict) for row in rows):
        raise SettingError("'channels': expected a list of channel objects")
    defaults = ChannelSetup("ai0")
    channel_keys = {f.name: getattr(defaults, f.name) for f in dataclasses.fields(ChannelSetup)}
    channels = []
    for number, row in enumerate(rows):
        for key, value in row.items():
            if key in channel_keys:
                _check_like(f"channels[{number}].{key}", value, channel_keys[key])
        if "physical_channel" not in row:
            raise SettingError(f"'channels[{number}]': no physical_channel")
        if row.get("kind", defaults.kind) not in {kind.value for kind in ChannelKind}:
            raise SettingError(f"'channels[{number}].kind': {row['kind']!r} is not a channel type")
        if row.get("coupling", defaults.coupling) not in {coupling.value for coupling in Coupling}:
            raise SettingError(f"'channels[{number}].coupling': {row['coupling']!r} is not a coupling")
        channels.append(ChannelSetup(**{k: v for k, v in row.items() if k in channel_keys}))
    by_name = {row.physical_channel: row for row in channels}
    return [by_name.get(row.physical_channel, row) for row in default_channels()]


def load_setup(settings: QSettings) -> tuple[SetupState, str]:
    """The state stored by the last run and '' — or the defaults and one line saying why, when the stored value
    is damaged (the GUI shows it in its banner and starts anyway)."""
    text = settings.value(SETTINGS_KEY, "")
    if text is None or text == "":
        return SetupState(), ""
    try:
        if not isinstance(text, str):
            raise SettingError(f"expected text, found {type(text).__name__}")
        return SetupState.from_json(text), ""
    except SettingError as error:
        problem = f"stored GUI settings in {settings.fileName()} are damaged ({error}); using the defaults"
        logger.warning(problem)
        return SetupState(), problem


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
