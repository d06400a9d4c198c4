"""*Modelled* and *named* for the concealed sets whose answer keys predate round 10 (simulator, independent, rounds
1–9), beside each scorer's own *right*.

Those keys list the catalogue names a right diagnosis may report (``exact``, ``acceptable``, ``allowed``,
``partial_ok``) but not where in the chain the truth sits nor its features with tolerances, as round 10's do. The
place of each listed name is read off this file's table, the same for every set:

- **modelled** — not a control; the key names at least one effect; the diagnosis described something (a finding or
  a generic description) or its outcome is exact/acceptable; every finding and description sits in a place of the
  key's names; and the written spec is within the noise: ``chi2_per_point_after`` ≤ 1.5 (or, where the loop was run,
  the written spec diagnosed again is ``consistent``).
- **named** — modelled, and the outcome is exact or acceptable (the key's names reported, with the alternatives the
  key requires).

Cases whose key names no effect (a clipped record, a dropout, double hits: the right answer is a measurement note)
and controls count for *right* only; the denominators of modelled and named are the cases whose key names an effect.
This scorer imports nothing of gasfilm.
"""

from __future__ import annotations

from typing import Any, Iterable

FIT_LIMIT = 1.5
CHAIN = frozenset({"force channel", "response channel", "measurement chain"})
#: Where each catalogue name of the keys sits in the chain (a channel term anywhere in the chain).
PLACES_OF_NAME: dict[str, frozenset[str]] = {
    "extra-mode": frozenset({"mover", "beside the mover"}),
    "structure-mode": frozenset({"mover", "beside the mover"}),
    "added-mass": frozenset({"mover"}),
    "film-memory": frozenset({"film"}),
    "squeeze-film": frozenset({"film"}),
    "pneumatic-lag": frozenset({"film"}),
    "cubic-stiffness": frozenset({"film"}),
    "friction": frozenset({"film"}),
    "quadratic-damping": frozenset({"film"}),
    "drift": frozenset({"between hits"}),
    "step-change": frozenset({"between hits"}),
    "channel-delay": CHAIN,
    "ac-coupling": CHAIN,
    "cross-talk": CHAIN,
    "sensitivity-error": CHAIN,
    "polarity": CHAIN,
    "window-damping": CHAIN,
}
NAMED_OUTCOMES = ("exact", "acceptable")


def key_names(key: dict) -> set[str]:
    """Every effect name the key lets a right diagnosis report."""
    names: set[str] = set()
    for field in ("exact", "acceptable", "allowed", "partial_ok"):
        for entry in key.get(field) or []:
            names |= set(entry) if isinstance(entry, (list, tuple, set)) else {entry}
    return {str(n) for n in names}


def key_places(key: dict) -> set[str]:
    """The places in the chain of the key's names."""
    return set().union(*(PLACES_OF_NAME.get(n, frozenset()) for n in key_names(key)))


def _within_noise(result: dict) -> bool:
    chi2 = result.get("chi2_per_point_after")
    loop = result.get("loop") if isinstance(result.get("loop"), dict) else {}
    return ((isinstance(chi2, (int, float)) and chi2 <= FIT_LIMIT)
            or loop.get("verdict_on_written_spec") == "consistent")


def figures(key: dict, result: dict | None, outcome: str) -> dict[str, Any]:
    """``{"scored": bool, "modelled": bool, "named": bool, "places": [...]}`` of one case (``scored``: the key names an
    effect and is not a control, so the case counts towards modelled and named)."""
    scored = not key.get("control") and bool(key_names(key))
    if not scored or not isinstance(result, dict):
        return {"scored": scored, "modelled": False, "named": False, "places": []}
    findings = [f for f in result.get("findings") or [] if isinstance(f, dict)]
    places = sorted({str(f.get("place")) for f in findings})
    in_place = all(f.get("place") in key_places(key) for f in findings)
    described = bool(findings) or outcome in NAMED_OUTCOMES
    modelled = described and in_place and _within_noise(result)
    return {"scored": True, "modelled": modelled, "named": modelled and outcome in NAMED_OUTCOMES,
            "places": places}


def summary_line(rows: Iterable[dict]) -> str:
    """"modelled a/n, named b/n" over the rows that carry :func:`figures`' fields and count."""
    scored = [r for r in rows if r.get("scored")]
    return (f"modelled {sum(bool(r.get('modelled')) for r in scored)}/{len(scored)}, "
            f"named {sum(bool(r.get('named')) for r in scored)}/{len(scored)} "
            f"(of the non-controls whose key names an effect; written spec within the noise, every description in "
            f"a place of the key's names)")
