"""The sensor library: a small TOML file of sensor models the Setup tab offers for each channel.

Format (``fixtures/sensors.toml``)::

    [[sensor]]
    model = "PCB 086C02"
    type = "force"            # or "acceleration"
    sensitivity = 11.2
    units = "mV/N"            # see drivers.interface.SENSITIVITY_UNITS
    description = "modally tuned impact hammer"
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import SENSITIVITY_UNITS, ChannelKind

DEFAULT_SENSOR_LIBRARY = Path(__file__).resolve().parents[2] / "fixtures" / "sensors.toml"


@dataclass(frozen=True)
class Sensor:
    """One catalogue entry: what the sensor measures and its nominal sensitivity."""

    model: str
    kind: ChannelKind
    sensitivity: float
    units: str
    description: str = ""

    @property
    def label(self) -> str:
        return f"{self.model} ({self.sensitivity:g} {self.units})"


def load_sensor_library(path: str | Path = DEFAULT_SENSOR_LIBRARY) -> list[Sensor]:
    """Read a sensor library file; raise :class:`SettingError` naming the file and the bad entry."""
    path = Path(path)
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SettingError(f"sensor library {path}: file not found") from None
    except tomllib.TOMLDecodeError as error:
        raise SettingError(f"sensor library {path}: not valid TOML ({error})") from None
    entries = document.get("sensor", [])
    if not isinstance(entries, list):
        raise SettingError(f"sensor library {path}: 'sensor' must be an array of tables ([[sensor]])")
    sensors = []
    for number, entry in enumerate(entries, start=1):
        where = f"sensor library {path}: sensor #{number}"
        missing = [key for key in ("model", "type", "sensitivity", "units") if key not in entry]
        if missing:
            raise SettingError(f"{where}: missing {', '.join(missing)}")
        try:
            kind = ChannelKind(entry["type"])
        except ValueError:
            raise SettingError(f"{where} type: '{entry['type']}' is not one of force, acceleration") from None
        if entry["units"] not in SENSITIVITY_UNITS[kind]:
            raise SettingError(
                f"{where} units: '{entry['units']}' is not valid for a {kind.value} sensor; "
                f"allowed: {', '.join(SENSITIVITY_UNITS[kind])}"
            )
        sensitivity = entry["sensitivity"]
        if not isinstance(sensitivity, (int, float)) or sensitivity <= 0:
            raise SettingError(f"{where} sensitivity: {sensitivity!r} must be a positive number")
        sensors.append(
            Sensor(str(entry["model"]), kind, float(sensitivity), entry["units"], str(entry.get("description", "")))
        )
    return sensors
