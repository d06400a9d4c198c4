"""Operating conditions of a session: supply pressure, gap, load, temperature and free labels.

A session is recorded at one operating point. Its conditions are a flat table ``{key: value}`` stored with the
session (as the JSON settings entry ``"conditions"``, ``docs/session-format.md``). A key names its unit at its end
(``supply_pressure_mpa``, ``gap_um``, ``load_n``, ``temperature_c``); a key with a unit suffix holds a number, any
other key is a free label (text or number), e.g. ``bearing=B-17``. Typed on the command line as
``--condition KEY=VALUE`` and in the GUI's setup tab.
"""

from __future__ import annotations

import math
import re
from typing import Any, Iterable, Mapping

from gasfilm.drivers.errors import SettingError

#: The settings entry of a session that holds its conditions.
SETTINGS_KEY = "conditions"

#: The conditions a bearing test usually reports, with their meaning (offered first by the GUI).
STANDARD_CONDITIONS: dict[str, str] = {
    "supply_pressure_mpa": "supply pressure (gauge), MPa",
    "gap_um": "film thickness or gap reading, µm",
    "load_n": "load on the bearing, N",
    "temperature_c": "temperature, °C",
}

#: Unit suffixes a condition key may end with → the unit shown (the value must then be a finite number).
UNIT_SUFFIXES: dict[str, str] = {
    "mpa": "MPa", "kpa": "kPa", "pa": "Pa", "bar": "bar",
    "um": "µm", "mm": "mm", "m": "m",
    "n": "N", "kg": "kg", "c": "°C", "k": "K",
    "hz": "Hz", "s": "s", "rpm": "rpm", "pct": "%",
    "l_min": "l/min", "nl_min": "Nl/min", "psi": "psi",
}
#: Quantities that always have a unit: typed with a number but without a unit suffix, they are refused (stored
#: sessions that hold one anyway still read, as a label).
_PHYSICAL_STEMS = ("supply_pressure", "pressure", "gap", "film_thickness", "clearance", "load", "force", "mass",
                   "temperature", "flow", "speed", "frequency")

#: Units of one quantity, as factors to a common base: a condition recorded in one converts to another.
_CONVERTIBLE: tuple[dict[str, float], ...] = (
    {"mpa": 1e6, "kpa": 1e3, "pa": 1.0, "bar": 1e5, "psi": 6894.757293168},
    {"um": 1e-6, "mm": 1e-3, "m": 1.0},
)

_KEY_PATTERN = re.compile(r"[a-z][a-z0-9_]{0,47}")
MAX_CONDITIONS = 32
MAX_LABEL_CHARACTERS = 200

Conditions = dict[str, float | str]


def condition_unit(key: str) -> str | None:
    """The unit a condition key names at its end (``gap_um`` → ``µm``), None for a free label."""
    parts = _stem_and_suffix(key)
    return UNIT_SUFFIXES[parts[1]] if parts else None


def check_condition_name(key: Any, where: str) -> str:
    """A condition name as typed (lower-case identifier, unit at its end) or one :class:`SettingError` line."""
    if not isinstance(key, str) or not _KEY_PATTERN.fullmatch(key):
        raise SettingError(f"{where}: condition name {key!r} must be lower-case letters, digits and _ (starting "
                           f"with a letter, ≤ 48 characters), its unit at the end, e.g. supply_pressure_mpa")
    return key


def check_condition(key: Any, value: Any, where: str) -> float | str:
    """A condition's value as stored (a float for a key with a unit, else a float or text); one
    :class:`SettingError` line starting with ``where`` when the key or value is not usable."""
    check_condition_name(key, where)
    unit = condition_unit(key)
    if isinstance(value, bool):
        value = str(value).lower()
    if isinstance(value, (int, float)):
        number = float(value)
    elif isinstance(value, str):
        text = value.strip()
        try:
            number = float(text)
        except ValueError:
            if unit is not None:
                raise SettingError(f"{where}: {key} = {value!r}: must be a number in {unit}") from None
            if not text or len(text) > MAX_LABEL_CHARACTERS or any(ord(c) < 32 for c in text):
                raise SettingError(f"{where}: {key} = {value!r}: a label must be 1–{MAX_LABEL_CHARACTERS} "
                                   f"printable characters")
            return text
    else:
        raise SettingError(f"{where}: {key} = {value!r}: must be a number or a text label")
    if not math.isfinite(number):
        raise SettingError(f"{where}: {key} = {value!r}: must be a finite number{' in ' + unit if unit else ''}")
    return number


def parse_condition_flags(texts: Iterable[str], flag: str = "--condition") -> Conditions:
    """``KEY=VALUE`` texts (as typed after ``flag``) as a conditions table; a repeated key is refused."""
    conditions: Conditions = {}
    for text in texts:
        key, separator, value = text.partition("=")
        key = key.strip()
        if not separator:
            raise SettingError(f"{flag} {text!r}: write KEY=VALUE, the unit in the key, e.g. supply_pressure_mpa=0.4")
        if key in conditions:
            raise SettingError(f"{flag} {text!r}: {key} is given twice")
        conditions[key] = check_condition(key, value, f"{flag} {text!r}")
        if condition_unit(key) is None and isinstance(conditions[key], float) and key in _PHYSICAL_STEMS:
            example = next((k for k in STANDARD_CONDITIONS if k.startswith(key + "_")), f"{key}_<unit>")
            raise SettingError(f"{flag} {text!r}: {key} needs its unit at the end of the name, e.g. {example} "
                               f"(units: {', '.join(UNIT_SUFFIXES)})")
    if len(conditions) > MAX_CONDITIONS:
        raise SettingError(f"{flag}: {len(conditions)} conditions; at most {MAX_CONDITIONS}")
    return conditions


def parse_condition_table(table: Mapping[str, str], where: str = "operating condition") -> Conditions:
    """A table of typed texts (the GUI's editor: name → value as typed) as conditions; rows with an empty value
    are left out."""
    return parse_condition_flags([f"{key.strip()}={value}" for key, value in table.items()
                                  if str(value).strip() and key.strip()], where)


def decode_conditions(stored_settings: Mapping[str, Any] | None, source: str = "session") -> Conditions:
    """The conditions stored in a session's settings (``{}`` when none were recorded); ``source`` (the file name)
    starts the line of a damaged entry."""
    values = (stored_settings or {}).get(SETTINGS_KEY)
    if values is None:
        return {}
    if not isinstance(values, Mapping) or len(values) > MAX_CONDITIONS:
        raise SettingError(f"{source}: the stored operating conditions are not a table of at most "
                           f"{MAX_CONDITIONS} entries")
    return {key: check_condition(key, value, f"{source}: stored operating condition") for key, value in
            values.items()}


def format_value(key: str, value: float | str) -> str:
    """One condition for people: ``supply_pressure_mpa = 0.4 MPa``, ``bearing = B-17``."""
    unit = condition_unit(key)
    if isinstance(value, float):
        shown = f"{value:g}"
        return f"{key} = {shown} {unit}" if unit else f"{key} = {shown}"
    return f"{key} = {value}"


def format_conditions(conditions: Mapping[str, float | str]) -> str:
    """All conditions on one line (``not recorded`` when there are none)."""
    if not conditions:
        return "not recorded"
    return ", ".join(format_value(key, value) for key, value in conditions.items())


def _stem_and_suffix(key: str) -> tuple[str, str] | None:
    """A condition key as (its quantity, its unit suffix): ``gap_um`` → (``gap``, ``um``); None for a free label."""
    for suffix in sorted(UNIT_SUFFIXES, key=len, reverse=True):
        if key.endswith("_" + suffix):
            return key[: -len(suffix) - 1], suffix
    return None


def converted_condition(conditions: Mapping[str, Any], key: str) -> tuple[float | str | None, str | None]:
    """The value of condition ``key`` (``supply_pressure_mpa``) in its own unit, converted from the same quantity
    recorded in another unit (``supply_pressure_kpa = 600`` → 0.6), and the key it came from (None when not
    recorded either way)."""
    if key in conditions:
        return conditions[key], key
    parts = _stem_and_suffix(key)
    if parts is None:
        return None, None
    stem, suffix = parts
    units = next((group for group in _CONVERTIBLE if suffix in group), {})
    for other, value in conditions.items():
        other_parts = _stem_and_suffix(other)
        if other_parts and other_parts[0] == stem and other_parts[1] in units and isinstance(value, float):
            return value * units[other_parts[1]] / units[suffix], other
    return None, None
