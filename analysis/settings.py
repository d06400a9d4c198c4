"""The processing settings stored with a session — trigger, validation and window — decoded in one place.

A session (or any recording) stores its settings as plain JSON tables keyed ``"trigger"``, ``"validation"`` and
``"window"`` (see :meth:`gasfilm.analysis.session.Session.settings`). :func:`decode_settings` turns that dict back into
the settings dataclasses: a missing table gives the defaults, unknown fields are ignored (older or newer files), and
a damaged table raises one :class:`SettingError` naming the file and the table.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping, TypeVar

from gasfilm.analysis.capture import TriggerSettings
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import ValidationSettings
from gasfilm.drivers.errors import SettingError

T = TypeVar("T")

#: Stored settings table name → the dataclass it decodes to.
SETTINGS_TABLES: dict[str, type] = {
    "trigger": TriggerSettings,
    "validation": ValidationSettings,
    "window": WindowSettings,
}


#: Each setting in words with its unit, and a sentence saying what it does: what the GUI's forms and the report show
#: instead of the field names. Table name → field name → (label, help).
SETTING_LABELS: dict[str, dict[str, tuple[str, str]]] = {
    "trigger": {
        "level_n": ("Trigger level (N)", "A hit starts where the force crosses this level"),
        "slope": ("Slope", "Trigger on the force rising through the level, or falling"),
        "hysteresis_n": ("Hysteresis (N)", "The force must fall this far below the level before the trigger re-arms"),
        "pretrigger_s": ("Pre-trigger (s)", "Time kept before the trigger: the quiet part that measures the noise"),
        "record_s": ("Record length (s)", "Time kept per hit, pre-trigger included"),
        "holdoff_s": ("Hold-off (s)", "After a trigger, no new trigger is searched for this long"),
    },
    "window": {
        "force_window_ms": ("Force window (ms after the peak)", "The force is kept this long after its peak"),
        "force_taper_ms": ("Force window taper (ms)", "Cosine taper at the end of the force window"),
        "exponential_end_fraction": (
            "Exponential window, value at record end (fraction)",
            "The response is multiplied by an exponential falling to this fraction at the record's end",
        ),
    },
    "validation": {
        "double_hit_fraction": (
            "Double hit above (fraction of 1st peak)",
            "A second impact above this fraction of the first peak rejects the hit (double hit)",
        ),
        "min_force_snr": (
            "Least force peak / noise (ratio)",
            "The force peak must be at least this many times the RMS noise before the pulse (force too low)",
        ),
        "decay_fraction": (
            "Decayed below (fraction of start)",
            "The response's envelope must end below this fraction of its start (response not decayed)",
        ),
        "tail_fraction": (
            "Tail length (fraction of record)", "The end of the record whose RMS is compared with the noise"
        ),
        "decay_fit_fraction": (
            "Decay fit length (fraction of record)", "The end of the record where the envelope's decay is fitted"
        ),
        "pretrigger_quiet_fraction": (
            "Quiet pre-trigger below (fraction of peak)",
            "The response's RMS before the pulse must stay below this fraction of its peak (pre-trigger not quiet)",
        ),
        "full_scale_fraction": (
            "Overload above (fraction of full scale)",
            "A channel reaching this fraction of its input range rejects the hit (overload)",
        ),
        "clip_run_samples": (
            "Clipping: flat run of (samples)",
            "This many consecutive samples flat at the signal's extreme count as clipping (overload)",
        ),
        "noise_margin": (
            "Tail above noise by (× noise RMS)",
            "A record tail louder than this many times the pre-trigger noise still rings (response not decayed)",
        ),
    },
}


def setting_label(table: str, name: str) -> str:
    """The setting ``name`` of the settings table ``table`` in words with its unit (the name itself if unknown)."""
    return SETTING_LABELS.get(table, {}).get(name, (name, ""))[0]


@dataclass(frozen=True)
class ProcessingSettings:
    """How hits were (or are to be) triggered, validated and windowed."""

    trigger: TriggerSettings = TriggerSettings()
    validation: ValidationSettings = ValidationSettings()
    window: WindowSettings = WindowSettings()

    def to_dict(self) -> dict[str, Any]:
        """The tables as stored in a session (dataclasses; the session writes them as JSON)."""
        return {name: getattr(self, name) for name in SETTINGS_TABLES}


def decode_setting(stored: Mapping[str, Any] | None, table: str, cls: type[T], source: str = "settings") -> T:
    """The settings table ``table`` of ``stored`` as a ``cls`` dataclass (``cls()`` when absent); ``source`` (a
    file name) starts the error message of a damaged table."""
    values = (stored or {}).get(table)
    if values is None:
        return cls()
    if not isinstance(values, Mapping):
        raise SettingError(f"{source}: the stored '{table}' settings are not a table ({type(values).__name__})")
    known = {field.name for field in dataclasses.fields(cls)}
    try:
        return cls(**{name: value for name, value in values.items() if name in known})
    except (SettingError, TypeError, ValueError) as error:
        raise SettingError(f"{source}: the stored '{table}' settings are unusable: {error}") from None


def decode_settings(stored: Mapping[str, Any] | None, source: str = "settings") -> ProcessingSettings:
    """All processing settings of a stored settings dict (defaults for missing tables)."""
    return ProcessingSettings(
        **{table: decode_setting(stored, table, cls, source) for table, cls in SETTINGS_TABLES.items()}
    )
