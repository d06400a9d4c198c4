"""The sensor library: a small TOML file of sensor models the Setup tab offers for each channel.

Format (``fixtures/sensors.toml``)::

    [[sensor]]
    model = "PCB 086C02"
    type = "force"            # or "acceleration"
    sensitivity = 11.2
    units = "mV/N"            # see drivers.interface.SENSITIVITY_UNITS
    description = "modally tuned impact hammer"
    serial = "LW12345"        # optional: one calibrated sensor (its sheet's sensitivity); listed as "model s/n …",
    calibration_date = 2026-03-02   # with its last calibration (a TOML date or "YYYY-MM-DD")
"""

from __future__ import annotations

import datetime
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import SENSITIVITY_UNITS, ChannelKind

DEFAULT_SENSOR_LIBRARY = Path(__file__).resolve().parents[2] / "fixtures" / "sensors.toml"


@dataclass(frozen=True)
class Sensor:
    """One library entry: a sensor model with its nominal sensitivity, or one sensor of it (serial number, calibrated
    sensitivity and calibration date)."""

    model: str
    kind: ChannelKind
    sensitivity: float
    units: str
    description: str = ""
    serial: str = ""
    calibration_date: str = ""  # ISO date of the last calibration, "" when not known

    @property
    def key(self) -> str:
        """How the Setup tab names the entry (and a channel row stores it): the model, and the serial number of a
        calibrated sensor."""
        return f"{self.model} s/n {self.serial}" if self.serial else self.model

    @property
    def label(self) -> str:
        return f"{self.key} ({self.sensitivity:g} {self.units})"


def load_sensor_library(path: str | Path = DEFAULT_SENSOR_LIBRARY) -> list[Sensor]:
    """Read a sensor library file; raise :class:`SettingError` naming the file and the bad entry."""
    path = Path(path)
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SettingError(f"sensor library {path}: file not found") from None
    except UnicodeDecodeError:
        raise SettingError(f"sensor library {path}: not UTF-8 text") from None
    except OSError as error:
        raise SettingError(f"sensor library {path}: cannot be read ({error.strerror or error})") from None
    except (tomllib.TOMLDecodeError, RecursionError) as error:
        raise SettingError(f"sensor library {path}: not valid TOML ({error})") from None
    entries = document.get("sensor", [])
    if not isinstance(entries, list):
        raise SettingError(f"sensor library {path}: 'sensor' must be an array of tables ([[sensor]])")
    sensors = []
    for number, entry in enumerate(entries, start=1):
        where = f"sensor library {path}: sensor #{number}"
        if not isinstance(entry, dict):
            raise SettingError(f"{where}: must be a table ([[sensor]] with model, type, sensitivity, units)")
        missing = [key for key in ("model", "type", "sensitivity", "units") if key not in entry]
        if missing:
            raise SettingError(f"{where}: missing {', '.join(missing)}")
        kinds = {kind.value: kind for kind in ChannelKind}
        if not isinstance(entry["type"], str) or entry["type"] not in kinds:
            raise SettingError(f"{where} type: {entry['type']!r} is not one of {', '.join(kinds)}")
        kind = kinds[entry["type"]]
        if not isinstance(entry["units"], str) or entry["units"] not in SENSITIVITY_UNITS[kind]:
            raise SettingError(
                f"{where} units: {entry['units']!r} is not valid for a {kind.value} sensor; "
                f"allowed: {', '.join(SENSITIVITY_UNITS[kind])}"
            )
        sensitivity = entry["sensitivity"]
        if isinstance(sensitivity, bool) or not isinstance(sensitivity, (int, float)) or not 0 < sensitivity < math.inf:
            raise SettingError(f"{where} sensitivity: {sensitivity!r} must be a positive finite number")
        if not isinstance(entry["model"], str) or not entry["model"].strip():
            raise SettingError(f"{where} model: {entry['model']!r} must be a non-empty text")
        serial = entry.get("serial", "")
        if not isinstance(serial, (str, int)) or isinstance(serial, bool):
            raise SettingError(f"{where} serial: {serial!r} must be a text")
        sensors.append(Sensor(entry["model"], kind, float(sensitivity), entry["units"],
                              str(entry.get("description", "")), str(serial).strip(),
                              _calibration_date(entry.get("calibration_date", ""), where)))
    return sensors


def _calibration_date(value: object, where: str) -> str:
    """A calibration date as ISO text: a TOML date, or text in the form YYYY-MM-DD ("" when not given)."""
    if isinstance(value, datetime.datetime):
        return value.date().isoformat()
    if isinstance(value, datetime.date):
        return value.isoformat()
    if value == "":
        return ""
    try:
        return datetime.date.fromisoformat(str(value)).isoformat()
    except ValueError:
        raise SettingError(f"{where} calibration_date: {value!r} is not a date (YYYY-MM-DD)") from None
