"""What a stored fit means beyond its model: the band it was fitted over, the mover mass (given, or fitted from a
start), the fitter, and the FRF it was fitted to with that FRF's exponential-window decay rate. A session's stored
fit is replaced only by one made with the same settings unless the user says so (``gasfilm fit --overwrite``, or the
GUI's question): a report must never compare a fit with others made under settings it does not show.

A stored fit also names the hits its FRF averaged (:class:`FitHits`): a fit made on fewer (or other) hits than the
session now accepts is stale (:func:`stale_note`), which the GUI, ``gasfilm fit``, the report and campaigns say.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from gasfilm.drivers.errors import GasfilmError

#: Relative difference below which two settings are the same (rounding of the stored values).
SAME_RELATIVE = 1e-6


@dataclass(frozen=True)
class FitSettings:
    """The settings a fit was made with. ``frf_name`` is the session's stored FRF it was fitted to ("" when not
    known: fits stored before it was recorded, or an FRF averaged from the hits at the time)."""

    band_hz: tuple[float, float]
    mass_kg: float  # the mass given (the start of the search when the mass is fitted), kg
    mass_fitted: bool
    method: str
    decay_rate_1_s: float
    frf_name: str = ""

    #: The keys :meth:`stored_keys` adds to a stored fit.
    STORED_KEYS = ("frf_name", "mass_given_kg")

    def stored_keys(self) -> dict[str, Any]:
        """What a stored fit holds beyond :meth:`FitResult.to_dict` so that its settings can be read back."""
        return {"frf_name": self.frf_name, "mass_given_kg": float(self.mass_kg)}

    @classmethod
    def of_fit(cls, fit: Any, frf_name: str = "") -> "FitSettings":
        """The settings of a fit made with the mass fixed (a :class:`FitResult`) to the FRF ``frf_name``."""
        return cls(tuple(fit.band_hz), fit.mass_kg, fit.mass_fitted, fit.method, fit.decay_rate_1_s, frf_name)

    @classmethod
    def of_stored(cls, values: Mapping[str, Any]) -> "FitSettings | None":
        """The settings of a stored fit (None when it is damaged: then a new fit may replace it)."""
        try:
            band = (float(values["band_hz"][0]), float(values["band_hz"][1]))
            fitted = bool(values.get("mass_fitted", False))
            given = values.get("mass_given_kg")
            mass = float(given) if given is not None else (math.nan if fitted else float(values["mass_kg"]))
            return cls(band, mass, fitted, str(values.get("method", "")), float(values.get("decay_rate_1_s", 0.0)),
                       str(values.get("frf_name", "")))
        except (KeyError, TypeError, ValueError, IndexError):
            return None


@dataclass(frozen=True)
class Difference:
    """One setting in which a new fit differs from a stored one: the flag that sets it on the command line, the
    stored and the new value in words, and the flag that would repeat the stored value."""

    setting: str
    flag: str
    stored: str
    new: str
    again: str


def _differ(a: float, b: float) -> bool:
    if not (math.isfinite(a) and math.isfinite(b)):
        return False  # not known for one of them: not a difference that can be shown
    return abs(a - b) > SAME_RELATIVE * max(abs(a), abs(b), 1e-12)


def _method_text(method: str) -> str:
    return f"the {method} fitter"


def differences(stored: FitSettings, new: FitSettings) -> list[Difference]:
    """The settings in which ``new`` differs from ``stored`` (empty: the new fit means what the stored one meant)."""
    found = []
    (old_low, old_high), (low, high) = stored.band_hz, new.band_hz
    top = max(1.0, high, old_high)
    if abs(old_low - low) > SAME_RELATIVE * top or abs(old_high - high) > SAME_RELATIVE * top:
        found.append(Difference("band", "--band", f"over {old_low:g}–{old_high:g} Hz", f"over {low:g}–{high:g} Hz",
                                f"--band {old_low:g}:{old_high:g}"))
    if stored.mass_fitted != new.mass_fitted:
        found.append(Difference("fitted mass", "--fit-mass",
                                "with the mass fitted" if stored.mass_fitted else "with the mass fixed",
                                "with the mass fitted" if new.mass_fitted else "with the mass fixed",
                                "--fit-mass" if stored.mass_fitted else "without --fit-mass"))
    if _differ(stored.mass_kg, new.mass_kg):
        found.append(Difference("mass", "--mass", f"with m = {stored.mass_kg:g} kg", f"with m = {new.mass_kg:g} kg",
                                f"--mass {stored.mass_kg:g}"))
    if stored.method and stored.method != new.method:
        found.append(Difference("method", "--method", f"by {_method_text(stored.method)}",
                                f"by {_method_text(new.method)}", f"--method {stored.method}"))
    named = stored.frf_name and new.frf_name and stored.frf_name != new.frf_name
    if named or _differ(stored.decay_rate_1_s, new.decay_rate_1_s):
        def frf_text(settings: FitSettings) -> str:
            name = f"FRF '{settings.frf_name}'" if settings.frf_name else "an FRF"
            return f"of {name} with an exponential-window decay rate of {settings.decay_rate_1_s:g} 1/s"

        found.append(Difference("FRF", "--frf", frf_text(stored), frf_text(new),
                                f"--frf {stored.frf_name}" if stored.frf_name else "the FRF it was fitted to"))
    return found


def conflicting_fits(session: Any, settings: Mapping[str, FitSettings]) -> list[tuple[str, list[Difference]]]:
    """The models among ``settings`` (model name → the new fit's settings) whose fit stored in ``session`` was made
    with other settings, each with how they differ."""
    stored_names = set(session.result_names("fits"))
    conflicts = []
    for name, new in settings.items():
        if name not in stored_names:
            continue
        try:
            stored = FitSettings.of_stored(session.read_fit(name))
        except GasfilmError:  # a damaged stored fit: the new one replaces it
            stored = None
        found = differences(stored, new) if stored is not None else []
        if found:
            conflicts.append((name, found))
    return conflicts


def refusal(path: Any, conflicts: list[tuple[str, list[Difference]]]) -> str:
    """One line refusing to replace stored fits: the differing settings by the flag that sets them, and --overwrite."""
    name, found = conflicts[0]
    others = [other for other, _ in conflicts[1:]]
    also = f" (and its {', '.join(others)} fit{'s' if len(others) > 1 else ''} likewise)" if others else ""
    flags = ", ".join(dict.fromkeys(difference.flag for difference in found))
    return (f"{flags}: {path} holds a {name} fit {', '.join(d.stored for d in found)}{also}; this one would be "
            f"{', '.join(d.new for d in found)}. Add --overwrite to replace it, or fit with the stored settings "
            f"({', '.join(d.again for d in found)})")


@dataclass(frozen=True)
class FitHits:
    """The hits a fit's FRF averaged: how many, and which (the session's hit indices, from 0; None when the FRF did
    not record them)."""

    count: int
    indices: tuple[int, ...] | None = None

    #: The keys :meth:`stored_keys` adds to a stored fit.
    STORED_KEYS = ("hit_count", "hit_indices")

    def stored_keys(self) -> dict[str, Any]:
        """What a stored fit holds of its hits."""
        return {"hit_count": int(self.count),
                **({"hit_indices": [int(i) for i in self.indices]} if self.indices is not None else {})}

    @classmethod
    def of_stored(cls, values: Mapping[str, Any]) -> "FitHits | None":
        """The hits of a stored fit (None when it does not say: fits stored before it was recorded)."""
        try:
            indices = values.get("hit_indices")
            count = values.get("hit_count")
            if indices is not None:
                indices = tuple(int(i) for i in indices)
                return cls(len(indices) if count is None else int(count), indices)
            return None if count is None else cls(int(count))
        except (TypeError, ValueError):
            return None


def stale_note(hits: FitHits | None, accepted_indices: Any) -> str | None:
    """Why a fit made on ``hits`` no longer describes a session whose accepted hits are ``accepted_indices`` (None
    when it does, or when the fit does not say which hits it used): "made on 4 of the 10 accepted hits"."""
    if hits is None:
        return None
    accepted = {int(i) for i in accepted_indices}
    if hits.indices is not None:
        used = set(hits.indices)
        if used == accepted:
            return None
        if used < accepted:
            return f"made on {len(used)} of the {len(accepted)} accepted hits"
        return (f"made on {len(used)} hits, {len(used - accepted)} of them no longer accepted (the session accepts "
                f"{len(accepted)})")
    if hits.count < len(accepted):
        return f"made on {hits.count} of the {len(accepted)} accepted hits"
    return None
