"""*Modelled* and *named* for the concealed sets whose answer keys predate round 10 (simulator, independent, rounds
1–9), beside each scorer's own *right*.

Those keys list the names a right diagnosis may report (``exact``, ``acceptable``, ``allowed``, ``partial_ok``: the
catalogue's, and the key's own name of a mechanism outside it) but not where in the chain the truth sits nor its
features with tolerances, as round 10's do. The place of each listed name is read off this file's table (written
after the keys, from their summaries alone, the same for every set):

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
    "cubic-stiffness": frozenset({"film", "between hits"}),  # amplitude-dependent: per hit, with its level
    "friction": frozenset({"film", "between hits"}),  # amplitude-dependent: per hit, with its level
    "quadratic-damping": frozenset({"film", "between hits"}),  # amplitude-dependent: per hit, with its level
    "drift": frozenset({"between hits"}),
    "step-change": frozenset({"between hits"}),
    "channel-delay": CHAIN,
    "ac-coupling": CHAIN,
    "cross-talk": CHAIN,
    "sensitivity-error": CHAIN,
    "polarity": CHAIN,
    "window-damping": CHAIN,
}
FILM, BESIDE, MOVER, BETWEEN = frozenset({"film"}), frozenset({"beside the mover"}), frozenset({"mover"}), frozenset(
    {"between hits"})
FORCE, RESPONSE = frozenset({"force channel", "measurement chain"}), frozenset({"response channel",
                                                                               "measurement chain"})
#: The keys' own names of mechanisms outside the catalogue, placed from each key's summary (what the key says the
#: mechanism does): the film's place for anything acting between the mover and the ground (between hits as well when
#: it depends on the amplitude: the diagnosis describes that per hit, with its level), beside the mover for a body
#: riding on it or a motion the sensor sees beside the mover's own, a channel for the sensor, the hammer and what
#: the recorder or an exporter did; between hits as well for what changes over the session.
PLACES_OF_NAME |= {
    # between the mover and the ground: the film's dynamic stiffness
    **{name: FILM for name in (
        "transport-delay", "viscoelastic-mount", "pocket-resonance", "servo", "dynamic-brake",
        "cross-coupled-stiffness", "vacuum-preload", "eddy-current-preload", "pocket-thermal-relaxation",
        "supply-line-resonance", "porous-restrictor", "hand-on-mover", "bellows-cover")},
    # the same, amplitude-dependent: described per hit, with its level (as the catalogue's cubic spring is)
    **{name: FILM | BETWEEN for name in (
        "gap-nonlinearity", "pneumatic-hammer", "softening-hardening", "touchdown", "hysteresis", "orifice-choking",
        "freeplay", "pneumatic-hammer-onset")},
    # a support or second body in series or beside: either description is in its place
    **{name: FILM | BESIDE | MOVER for name in ("soft-foundation", "twin-carriage", "reaction-impactor",
                                                "soft-payload", "loose-part", "viscous-absorber", "fan-unbalance",
                                                "drive-point-pad")},
    # the film changing over the session
    **{name: FILM | BETWEEN for name in ("thermal-cycling", "supply-ripple", "compressor-cycling", "pad-creep",
                                         "thermal-settling", "stiffness-fluctuation", "coolant-filling")},
    # what the sensor sees beside the mover's axial motion
    **{name: BESIDE | RESPONSE | BETWEEN for name in ("transverse-sensitivity", "wrong-axis",
                                                      "hit-location-scatter")},
    # the hammer and the force channel
    **{name: FORCE | BETWEEN for name in ("hit-angle", "two-sided-hits", "iepe-slew-limit", "force-units",
                                          "force-gauge-nonlinearity", "force-window-cut", "hammer-head-ringing")},
    # the accelerometer, its mounting and the response channel
    **{name: RESPONSE for name in ("base-strain", "filter-mismatch", "mount-resonance", "dielectric-slope",
                                   "velocity-labelled-acceleration", "differentiated-displacement",
                                   "sensor-nonlinearity", "zero-shift", "boxcar-smoothing", "mains-notch",
                                   "sensor-liftoff", "interpolated-response", "zero-phase-highpass",
                                   "dc-coupled-response", "pyroelectric", "popcorn-noise")},
    **{name: RESPONSE | BETWEEN for name in ("sensor-swap", "autorange-gain", "sensor-thermal-drift")},
    # the recorder and the export: both channels
    **{name: CHAIN for name in ("capacitive-crosstalk", "hann-windowed", "overlapping-records", "swapped-cables",
                                "wavelet-denoised", "aliasing", "record-pairing", "detrended-export", "zero-padded",
                                "sampling-jitter", "gsm-buzz", "floor-shocks", "stuck-adc-bit", "int16-wrap",
                                "bench-tap-triggers", "two-digit-export", "adc-midscale-dnl", "clock-drift")},
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


def summary_counts(rows: Iterable[dict]) -> dict[str, int]:
    """``{"modelled": a, "named": b, "scored_for_modelled": n}`` over the rows that carry :func:`figures`' fields
    and count (a scores file's summary)."""
    scored = [r for r in rows if r.get("scored")]
    return {"modelled": sum(bool(r.get("modelled")) for r in scored),
            "named": sum(bool(r.get("named")) for r in scored), "scored_for_modelled": len(scored)}


def summary_line(rows: Iterable[dict]) -> str:
    """"modelled a/n, named b/n" over the rows that carry :func:`figures`' fields and count."""
    counts = summary_counts(rows)
    return (f"modelled {counts['modelled']}/{counts['scored_for_modelled']}, "
            f"named {counts['named']}/{counts['scored_for_modelled']} "
            f"(of the non-controls whose key names an effect; written spec within the noise, every description in "
            f"a place of the key's names)")


def main(argv: list[str] | None = None) -> int:
    """Recompute modelled and named of a scored folder from its saved diagnoses (``diagnoses/<case>/diagnosis.json``),
    its keys and the outcomes of its scores file."""
    import argparse
    import json
    from pathlib import Path

    parser = argparse.ArgumentParser(description=main.__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, required=True, help="a folder a round's scorer ran on")
    parser.add_argument("--scores", default="scores.json", help="its scores file (default scores.json)")
    args = parser.parse_args(argv)
    rows = json.loads((args.data / args.scores).read_text())["cases"]
    for row in rows:
        key = json.loads((args.data / f"{row['case']}.key.json").read_text())
        saved = args.data / "diagnoses" / row["case"] / "diagnosis.json"
        if row["outcome"] == "error":
            result = None
        elif saved.exists():
            result = json.loads(saved.read_text())
        else:  # a scorer that keeps no diagnosis: what its row kept of it
            result = {"findings": [{"place": place} for place in row.get("places") or []],
                      "chi2_per_point_after": row.get("chi2_per_point_after")}
        if result is not None and row.get("loop_verdict"):
            result["loop"] = {"verdict_on_written_spec": row["loop_verdict"]}
        row |= figures(key, result, row["outcome"])
        if row["scored"]:
            print(f"  {row['case']:28s} {row['outcome']:22s} modelled {'yes' if row['modelled'] else 'no ':3s} "
                  f"named {'yes' if row['named'] else 'no ':3s} places {', '.join(row['places']) or '—'}; key: "
                  f"{', '.join(sorted(key_places(key)))}")
    print(summary_line(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
