"""Numbers in words, as every report of gasfilm prints them (the terminal's, the session report's, the GUI's): a
value with its one-σ uncertainty and its unit, and a frequency band.

- A dimensionless value has no unit after it (the JSON's unit "1"); a table column that needs a word says
  "(dimensionless)". Everything with a unit keeps it.
- An uncertainty of exactly zero is a value the fit could not move — held at the edge of its fit range — never an
  exact measurement: it reads "(at its bound)", not "± 0". An uncertainty is never rounded to zero either: it gets
  the decimals it needs.
- A band shows its width: "3110.6–3111.4 Hz" where whole hertz would print "3111–3111 Hz"; a band of one frequency
  is "at 3111 Hz".
"""

from __future__ import annotations

import math
import re
from typing import Any

#: The units of a dimensionless value: "1" in the JSON and the effects' fields, "" where none was given.
DIMENSIONLESS_UNITS = frozenset({"", "1"})
#: What a table column of units says for a dimensionless value.
DIMENSIONLESS_WORD = "(dimensionless)"
#: Said instead of "± 0": the value is held at the edge of its fit range, its uncertainty not measured.
AT_BOUND = "(at its bound)"
#: Said when no uncertainty could be estimated (NaN, or null in a stored diagnosis).
NOT_ESTIMATED = "(± not estimated)"
#: The finest resolution (decimals of a hertz) a band is printed at to show its width; ends equal at this
#: resolution are one frequency.
BAND_DECIMALS = 3
#: A band's ends in the JSON: to this many decimals, finer when that would hide its width.
JSON_BAND_DECIMALS = 1


def is_number(value: Any) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def unit_suffix(unit: Any) -> str:
    """What follows a number: " Hz", " N/m", … and nothing for a dimensionless value."""
    unit = "" if unit is None else str(unit)
    return "" if unit.strip() in DIMENSIONLESS_UNITS else f" {unit}"


def unit_word(unit: Any) -> str:
    """A unit for a column of units: the unit itself, or "(dimensionless)"."""
    return unit_suffix(unit).strip() or DIMENSIONLESS_WORD


def held_at_bound(uncertainty: Any, at_bound: bool = False) -> bool:
    """Whether a value is held at its bound: said so (``at_bound``), or its uncertainty is exactly zero (the fit could
    not move it: a bound's doing, never an exact measurement)."""
    return at_bound or (is_number(uncertainty) and uncertainty == 0)


def uncertainty_text(uncertainty: Any, uncertainty_format: str = ".2g", at_bound: bool = False) -> str:
    """An uncertainty for a column of its own: "± 0.25", "(at its bound)" or "(± not estimated)"."""
    if held_at_bound(uncertainty, at_bound):
        return AT_BOUND
    return f"± {uncertainty:{uncertainty_format}}" if is_number(uncertainty) else NOT_ESTIMATED


def with_uncertainty(value: float, uncertainty: Any, unit: Any = "", value_format: str = ".6g",
                     uncertainty_format: str = ".2g", at_bound: bool = False) -> str:
    """``value ± uncertainty unit`` ("3109.98 ± 0.25 Hz", "0.000223 ± 0.00011" for a dimensionless value); "1.9 (at its
    bound)" when the value is held at its bound (``at_bound``, or an uncertainty of exactly zero: the fit could not
    move it); "… (± not estimated)" when the uncertainty is unknown (None, NaN). A fixed-point ``uncertainty_format``
    that would round a non-zero uncertainty to zero ("± 0.0 Hz") is widened to its first significant digit, the
    value with it; a value in significant digits ("g") is never rounded coarser than its uncertainty's last digit
    ("3109.98 ± 0.25 Hz", not "3110 ± 0.25 Hz")."""
    suffix = unit_suffix(unit)
    if held_at_bound(uncertainty, at_bound) or not is_number(uncertainty):
        return f"{value:{value_format}}{suffix} {uncertainty_text(uncertainty, at_bound=at_bound)}"
    value_format = _digits_to_uncertainty(value, uncertainty, value_format, uncertainty_format)
    fixed = re.fullmatch(r"(.*)\.(\d+)f", uncertainty_format)
    if fixed and float(f"{abs(uncertainty):{uncertainty_format}}") == 0:
        decimals = max(int(fixed.group(2)), -math.floor(math.log10(abs(uncertainty))))
        uncertainty_format = f"{fixed.group(1)}.{decimals}f"
        value_fixed = re.fullmatch(r"(.*)\.(\d+)f", value_format)
        if value_fixed:
            value_format = f"{value_fixed.group(1)}.{max(int(value_fixed.group(2)), decimals)}f"
    return f"{value:{value_format}} {uncertainty_text(uncertainty, uncertainty_format)}{suffix}"


def _digits_to_uncertainty(value: float, uncertainty: float, value_format: str, uncertainty_format: str) -> str:
    """``value_format`` ("…Ng") with as many significant digits as reach the last digit its uncertainty is printed
    with (in ``uncertainty_format``, "…Mg")."""
    significant = re.fullmatch(r"(.*)\.(\d+)g", value_format)
    shown = re.fullmatch(r".*\.(\d+)g", uncertainty_format)
    if not (significant and shown and is_number(value) and value != 0 and uncertainty != 0):
        return value_format
    last_digit = math.floor(math.log10(abs(uncertainty))) - int(shown.group(1)) + 1
    needed = math.floor(math.log10(abs(value))) - last_digit + 1
    return f"{significant.group(1)}.{min(needed, 15)}g" if needed > int(significant.group(2)) else value_format


def band_decimals(low_hz: float, high_hz: float) -> int | None:
    """The fewest decimals of a hertz (from 0, at most :data:`BAND_DECIMALS`) at which a band's ends differ; None for
    a band of one frequency."""
    for decimals in range(BAND_DECIMALS + 1):
        if f"{low_hz:.{decimals}f}" != f"{high_hz:.{decimals}f}":
            return decimals
    return None


def band_range(low_hz: float, high_hz: float) -> str:
    """A band's ends without the unit, at the resolution that shows its width ("4065–4155", "3110.6–3111.4"), or its
    one frequency ("3111"): for a column headed "(Hz)"."""
    decimals = band_decimals(low_hz, high_hz)
    if decimals is None:
        return f"{low_hz:.0f}"
    return f"{low_hz:.{decimals}f}–{high_hz:.{decimals}f}"


def band_text(low_hz: float, high_hz: float) -> str:
    """A band in words: "4065–4155 Hz", "3110.6–3111.4 Hz", or "at 3111 Hz" for a band of one frequency."""
    text = f"{band_range(low_hz, high_hz)} Hz"
    return text if band_decimals(low_hz, high_hz) is not None else f"at {text}"


def in_band(low_hz: float, high_hz: float) -> str:
    """Where in a sentence: "in 4065–4155 Hz", or "at 3111 Hz" for a band of one frequency."""
    text = band_text(low_hz, high_hz)
    return text if text.startswith("at ") else f"in {text}"


def bands_text(bands: list[tuple[float, float]]) -> str:
    """Several bands in one list, the unit once: "4497–4515, 4587–4605 Hz" ("…, 3111 Hz" for one frequency)."""
    return ", ".join(band_range(low, high) for low, high in bands) + " Hz"


def rounded_band(low_hz: float, high_hz: float) -> list[float]:
    """A band's ends for the JSON: to :data:`JSON_BAND_DECIMALS` decimals of a hertz, or as many more as keep its
    width (ends that differ never round equal)."""
    decimals = max(JSON_BAND_DECIMALS, band_decimals(low_hz, high_hz) or 0)
    return [round(float(low_hz), decimals), round(float(high_hz), decimals)]
