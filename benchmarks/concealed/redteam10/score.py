"""Score ``gasfilm diagnose`` on the round-10 red-team world (run generate.py first): *right*, *modelled*, *named*.

Per case, as a user would (the ``gasfilm`` beside the Python that runs this file):

    gasfilm diagnose out/redteam10/<case>.uff --mass 25.05 --json --out out/redteam10/diagnoses/<case> --overwrite

Three figures per case (docs in README.md beside this file):

- **right** — round 3's classification, imported from ``../redteam3/score.py`` unchanged (exact / acceptable / honest
  not-explained are right; wrong, false claim, must-not claimed, error are not). Before it classifies, a finding whose
  effect is no catalogue term (a v2 generic description such as ``side-mode``) is renamed by its ``place``:
  beside the mover → ``generic:beside``, film → ``generic:film``, mover → ``generic:mover``, force/response channel or
  measurement chain → ``generic:chain``, between hits → ``generic:between-hits`` (the keys list these names).
- **modelled** — not a control; the verdict is not "not explained"; ``chi2_per_point_after`` ≤ 1.5 or
  ``loop.verdict_on_written_spec`` is "consistent"; and for every required effect of the key some finding has a
  ``place`` in the effect's list (or in one of its alternatives') and shows every one of its features within tolerance.
- **named** — modelled, and for every required effect a finding that matched it has, as the name of its first
  mechanism or of one marked ``tied``, a word of the effect's ``mechanism_keywords``.

Controls: right as round 3 says; "no physics" = no finding placed in the mover, film, beside the mover or between hits
(a finding without ``place`` counts as physics when its ``kind`` is "rig").

Every field of the v2 contract may be missing (today's diagnosis is being rewritten): a missing field is "not met",
never an error.

    python benchmarks/concealed/redteam10/score.py [--data out/redteam10] [--only CASE ...] [--label NAME]
                                                   [--tables-from results/scores-NAME.json ...]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("redteam3_score", HERE.parent / "redteam3" / "score.py")
round3 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(round3)
_names = importlib.util.spec_from_file_location("independent_effect_names", HERE.parent / "independent"
                                                / "effect_names.py")
effect_names = importlib.util.module_from_spec(_names)
_names.loader.exec_module(effect_names)

CATALOG = set(effect_names.ALL_EFFECTS) | {"structure-mode", "polarity", "mains"}
PHYSICS_PLACES = {"mover", "film", "beside the mover", "between hits"}
CHAIN_PLACES = {"force channel", "response channel", "measurement chain"}
GENERIC_BY_PLACE = {"beside the mover": "generic:beside", "film": "generic:film", "mover": "generic:mover",
                    "force channel": "generic:chain", "response channel": "generic:chain",
                    "measurement chain": "generic:chain", "between hits": "generic:between-hits"}
CATEGORIES = ("control", "rig", "measurement", "several")
#: For information only (not a headline figure): where a catalogue term sits, for a diagnosis that gives no ``place``.
CATALOG_PLACE = {"extra-mode": "beside the mover", "structure-mode": "beside the mover", "film-memory": "film",
                 "squeeze-film": "film", "pneumatic-lag": "film", "cubic-stiffness": "film", "friction": "film",
                 "quadratic-damping": "film", "added-mass": "mover", "drift": "between hits",
                 "step-change": "between hits", "channel-delay": "measurement chain",
                 "ac-coupling": "measurement chain", "cross-talk": "measurement chain",
                 "sensitivity-error": "measurement chain", "polarity": "measurement chain"}
TOLERANCE_KEYS = {"tol_rel", "tol_abs", "tol_factor", "range", "note"}
FIT_LIMIT = 1.5
FROM_SAVED = False  # --from-saved: classify the diagnoses saved by an earlier run instead of running gasfilm


# ------------------------------------------------------------------------------------------- reading a finding

def _number(x: Any) -> float | None:
    if isinstance(x, bool):
        return None
    if isinstance(x, (int, float)) and math.isfinite(x):
        return float(x)
    if isinstance(x, dict):
        return _number(x.get("value"))
    return None


def _numbers(x: Any) -> list[float]:
    if isinstance(x, (list, tuple)):
        return [v for v in (_number(e) for e in x) if v is not None]
    v = _number(x)
    return [] if v is None else [v]


def family(name: str, unit: str = "") -> str | None:
    """The quantity a parameter or feature name stands for (documented in README.md, 'How the scorer reads a
    finding')."""
    n = name.lower()
    u = (unit or "").replace(" ", "")
    if "delay" in n or "latency" in n:
        return "delay_s"
    if "damping_ratio" in n or "zeta" in n:
        return "damping_ratio"
    if n.endswith("_hz") or "freq" in n or u == "Hz":
        return "frequency_hz"
    if "tau" in n or "time_constant" in n:
        return "time_constant_s"
    if "modal_constant" in n or "residue" in n:
        return "modal_constant"
    if n == "sign" or n.startswith("sign_") or n.endswith("_sign"):
        return "sign"
    if "mass" in n or n.endswith("_kg") or u == "kg":
        return "mass_kg"
    if "gain" in n or "factor" in n:
        return "gain"
    if "alpha" in n or "order" in n:
        return "order"
    if "stiff" in n or u == "N/m" or n.endswith("_n_per_m"):
        return "stiffness_n_per_m"
    return None


def _sign_values(x: Any) -> list[int]:
    out = []
    for e in (x if isinstance(x, (list, tuple)) else [x]):
        if isinstance(e, str):
            t = e.strip().lower()
            if t in ("+", "+1", "positive", "pos"):
                out.append(1)
            elif t in ("-", "−", "-1", "negative", "neg"):
                out.append(-1)
        else:
            v = _number(e)
            if v:
                out.append(1 if v > 0 else -1)
    return out


def finding_values(finding: dict) -> dict[str, list[float]]:
    """Every number a finding shows, by quantity, from its ``parameters`` and ``features`` (plus what follows from
    them: a time constant as a frequency 1/(2πτ) and back, a film memory's corner (k_m/η)^(1/α)/(2π), a sensitivity
    error δ as the gain 1 + δ, a modal constant's sign)."""
    out: dict[str, list[float]] = {}

    def add(fam, values):
        if fam and values:
            out.setdefault(fam, []).extend(values)

    params = finding.get("parameters") if isinstance(finding.get("parameters"), dict) else {}
    by_name = {}
    for name, entry in params.items():
        unit = entry.get("unit", "") if isinstance(entry, dict) else ""
        values = _numbers(entry)
        by_name[name.lower()] = values
        add(family(name, unit), values)
    features = finding.get("features") if isinstance(finding.get("features"), dict) else {}
    for name, value in features.items():
        fam = family(name)
        if fam == "sign":
            add("sign", _sign_values(value))
        else:
            add(fam, _numbers(value))
    add("sign", [1 if v > 0 else -1 for v in out.get("modal_constant", []) if v])
    add("frequency_hz", [1 / (2 * math.pi * t) for t in out.get("time_constant_s", []) if t > 0])
    add("time_constant_s", [1 / (2 * math.pi * f) for f in out.get("frequency_hz", []) if f > 0])
    k_m = next((v for n, v in by_name.items() if n in ("k_m", "km", "k_memory") or n.startswith("k_m")), None)
    eta = next((v for n, v in by_name.items() if n.startswith("eta")), None)
    alpha = next((v for n, v in by_name.items() if "alpha" in n or n == "order"), None)
    if k_m and eta and alpha and k_m[0] > 0 and eta[0] > 0 and alpha[0] > 0:
        out.setdefault("frequency_hz", []).append((k_m[0] / eta[0]) ** (1 / alpha[0]) / (2 * math.pi))
    if str(finding.get("effect")) == "sensitivity-error":
        for n, v in by_name.items():
            if n.startswith("delta") or n in ("error", "relative_error"):
                out.setdefault("gain", []).extend(1 + x for x in v)
    return out


def _within(value: float, target: float, spec: dict, quantity: str) -> bool:
    if quantity == "delay_s":
        value, target = abs(value), abs(target)
    if "range" in spec:
        lo, hi = spec["range"]
        return lo <= value <= hi
    if "tol_factor" in spec:
        return target > 0 and value > 0 and target / spec["tol_factor"] <= value <= target * spec["tol_factor"]
    if "tol_abs" in spec:
        return abs(value - target) <= spec["tol_abs"]
    return abs(value - target) <= spec.get("tol_rel", 0.05) * abs(target)


def feature_met(spec: dict, values: dict[str, list[float]]) -> bool:
    quantity = next(k for k in spec if k not in TOLERANCE_KEYS)
    targets = spec[quantity] if isinstance(spec[quantity], list) else [spec[quantity]]
    have = values.get(quantity, [])
    if quantity == "sign":
        return all(t in have for t in targets)
    return all(any(_within(v, t, spec, quantity) for v in have) for t in targets if t is not None)


def place_of(finding: dict) -> str | None:
    place = finding.get("place")
    return place.strip().lower() if isinstance(place, str) else None


def match_effect(places: list[str], features: list[dict], findings: list[dict], may_split: bool = False) -> list[dict]:
    """The findings that show this effect: one finding in one of ``places`` with every feature; failing that, when a
    feature lists several values (several modes) or the key says its features may be split over several terms
    (``features_may_split``), the findings in those places that together show them all."""
    candidates = [f for f in findings if place_of(f) in {p.lower() for p in places}]
    if not candidates:
        return []
    if not features:
        return candidates
    for f in candidates:
        if all(feature_met(spec, finding_values(f)) for spec in features):
            return [f]
    if may_split or any(isinstance(spec.get(next(k for k in spec if k not in TOLERANCE_KEYS)), list)
                        for spec in features):
        merged: dict[str, list[float]] = {}
        for f in candidates:
            for k, v in finding_values(f).items():
                merged.setdefault(k, []).extend(v)
        if all(feature_met(spec, merged) for spec in features):
            return candidates
    return []


def mechanism_names(finding: dict) -> list[str]:
    """The first mechanism's name and those marked ``tied``."""
    mechanisms = finding.get("mechanisms")
    if not isinstance(mechanisms, list) or not mechanisms:
        return []
    names = []
    for i, m in enumerate(mechanisms):
        if not isinstance(m, dict):
            if i == 0 and isinstance(m, str):
                names.append(m)
            continue
        if i == 0 or m.get("tied") is True:
            if isinstance(m.get("name"), str):
                names.append(m["name"])
    return names


def effect_status(effect: dict, findings: list[dict]) -> dict:
    """For one effect of the key: which findings model it, whether one of them names it, and what was reported."""
    readings = [(effect["place"], effect["features"])] + [(a["place"], a["features"])
                                                          for a in effect.get("alternatives", [])]
    matched: list[dict] = []
    for places, features in readings:
        matched = match_effect(places, features, findings, bool(effect.get("features_may_split")))
        if matched:
            break
    keywords = [k.lower() for k in effect.get("mechanism_keywords", [])]
    named = any(any(k in n.lower() for k in keywords for n in mechanism_names(f)) for f in matched)
    in_place = [f for places, _ in readings for f in findings if place_of(f) in {p.lower() for p in places}]
    return {"modelled": bool(matched), "named": bool(matched) and named,
            "matched": [str(f.get("effect")) for f in matched],
            "in_place": sorted({str(f.get("effect")) for f in in_place})}


# ------------------------------------------------------------------------------------------------ per case

def normalised(result: dict) -> dict:
    """The result with each v2 generic description renamed by its place (for round 3's classifier)."""
    findings = []
    for f in result.get("findings") or []:
        if not isinstance(f, dict):
            continue
        name = round3.key_name(str(f.get("effect", "?")))
        place = place_of(f)
        if name not in CATALOG and place in GENERIC_BY_PLACE:
            f = dict(f, effect=GENERIC_BY_PLACE[place])
        findings.append(f)
    out = dict(result)
    out["findings"] = findings
    return out


def loop_verdict(result: dict) -> str | None:
    loop = result.get("loop")
    return loop.get("verdict_on_written_spec") if isinstance(loop, dict) else None


def fit_ok(result: dict) -> bool:
    chi2 = _number(result.get("chi2_per_point_after"))
    return (chi2 is not None and chi2 <= FIT_LIMIT) or loop_verdict(result) == "consistent"


def physics_claimed(result: dict) -> bool:
    for f in result.get("findings") or []:
        if not isinstance(f, dict):
            continue
        place = place_of(f)
        if place in PHYSICS_PLACES or (place is None and f.get("kind") != "measurement"):
            return True
    return False


def with_catalog_places(result: dict) -> dict:
    """The result with a place given to every catalogue finding that has none (information only)."""
    findings = []
    for f in result.get("findings") or []:
        if isinstance(f, dict) and place_of(f) is None:
            place = CATALOG_PLACE.get(round3.key_name(str(f.get("effect"))))
            f = dict(f, place=place) if place else f
        findings.append(f)
    return dict(result, findings=findings)


def three_figures(key: dict, result: dict) -> dict:
    findings = [f for f in result.get("findings") or [] if isinstance(f, dict)]
    required = [e for e in key.get("kinds", []) if e.get("required", True) and e.get("place")]
    effects = {e["id"]: effect_status(e, findings) for e in key.get("kinds", []) if e.get("place")}
    verdict = result.get("verdict")
    if key["control"]:
        return {"effects": effects, "modelled": None, "named": None, "no_physics": not physics_claimed(result),
                "fit_ok": fit_ok(result)}
    modelled = (verdict != "not explained" and fit_ok(result)
                and all(effects[e["id"]]["modelled"] for e in required))
    named = modelled and all(effects[e["id"]]["named"] for e in required)
    return {"effects": effects, "modelled": modelled, "named": named, "fit_ok": fit_ok(result)}


def committed_key_problem(key_path: Path) -> str:
    committed = HERE / "keys" / key_path.name
    if committed.exists() and committed.read_bytes() != key_path.read_bytes():
        return "answer key differs from the committed one in keys/: not scored"
    return ""


def score_case(key_path: Path, data: Path) -> dict:
    key = json.loads(key_path.read_text())
    uff = data / key["uff"]
    out_dir = data / "diagnoses" / key["case"]
    arguments = list(key["cli_arguments"])
    command = ["gasfilm", "diagnose", str(uff), *arguments, "--json", "--out", str(out_dir), "--overwrite"]
    row: dict[str, Any] = {"case": key["case"], "category": key["category"], "summary": key["summary"],
                           "command": " ".join(command), "control": key["control"],
                           "kinds": [{"id": e["id"], "kind": e["kind"], "place": e["place"],
                                      "required": e.get("required", True)} for e in key.get("kinds", [])]}
    problem = committed_key_problem(key_path)
    if not uff.exists():
        problem = problem or "UFF file missing"
    elif key_path.stat().st_mtime > uff.stat().st_mtime:
        problem = problem or "answer key newer than its data: not scored"
    if problem:
        return row | {"outcome": "error", "reason": problem, "modelled": False, "named": False}
    saved = out_dir / "diagnosis.json"
    if FROM_SAVED:
        if not saved.exists():
            return row | {"outcome": "error", "reason": f"{saved} missing (--from-saved)", "modelled": False,
                          "named": False}
        result, error, stderr, wall = json.loads(saved.read_text()), "", "", float("nan")
    else:
        result, error, stderr, wall = round3.run([str(uff), *arguments, "--out", str(out_dir)])
    if not FROM_SAVED:
        row["wall_time_s"] = round(wall, 1)
    if "Traceback" in stderr:
        row["traceback"] = stderr.strip().splitlines()[-1]
    if result is None:
        if key.get("refusal_ok") and "traceback" not in row and error.startswith("exit "):
            return row | {"outcome": "honest not-explained", "reason": f"refused: {error}", "modelled": False,
                          "named": False}
        return row | {"outcome": "error", "reason": error, "modelled": False, "named": False}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "diagnosis.json").write_text(json.dumps(result, indent=1, default=str))
    renamed = normalised(result)
    outcome, reason = round3.classify(key, renamed)
    figures = three_figures(key, result)
    inferred = three_figures(key, with_catalog_places(result))
    findings = [f for f in result.get("findings") or [] if isinstance(f, dict)]
    return row | figures | {
        "modelled_catalog_places": inferred["modelled"],
        "outcome": outcome, "reason": reason, "verdict": result.get("verdict"),
        "reported": sorted({str(f.get("effect")) for f in renamed["findings"]}),
        "findings": [{"effect": f.get("effect"), "place": f.get("place"), "status": f.get("status"),
                      "parameters": round3.parameter_text(f.get("parameters")),
                      "features": f.get("features") if isinstance(f.get("features"), dict) else None,
                      "mechanisms": mechanism_names(f)} for f in findings],
        "unexplained": [{"band_hz": u.get("band_hz"), "hits": u.get("hits"), "character": u.get("character"),
                         "reason": u.get("reason"),
                         "candidates": [c.get("effect") for c in u.get("candidates") or [] if isinstance(c, dict)]}
                        if isinstance(u, dict) else u for u in result.get("unexplained") or []],
        "quality": round3.notes(result),
        "chi2_per_point_before": result.get("chi2_per_point_before"),
        "chi2_per_point_after": result.get("chi2_per_point_after"),
        "loop_verdict": loop_verdict(result),
        "first_note": (result.get("notes") or [""])[0] if isinstance(result.get("notes"), list) else "",
    }


# ------------------------------------------------------------------------------------------------- tables

def _mark(value) -> str:
    return "—" if value is None else ("yes" if value else "no")


def outcome_table(rows: list[dict]) -> str:
    outcomes = round3.OUTCOMES
    lines = ["| truth \\ outcome | " + " | ".join(outcomes) + " | right | modelled | named |",
             "| --- " * (len(outcomes) + 4) + "|"]
    for category in CATEGORIES + ("all",):
        sub = rows if category == "all" else [r for r in rows if r["category"] == category]
        if not sub:
            continue
        counts = Counter(r["outcome"] for r in sub)
        right = sum(counts[o] for o in round3.RIGHT)
        if category == "control":
            modelled = named = "—"
        else:
            eff = [r for r in sub if not r["control"]]
            modelled = f"{sum(bool(r.get('modelled')) for r in eff)}/{len(eff)}"
            named = f"{sum(bool(r.get('named')) for r in eff)}/{len(eff)}"
        lines.append(f"| {category} ({len(sub)}) | " + " | ".join(str(counts[o]) for o in outcomes)
                     + f" | {right}/{len(sub)} | {modelled} | {named} |")
    return "\n".join(lines)


def reported_label(row: dict, effect_id: str) -> str:
    status = (row.get("effects") or {}).get(effect_id)
    if "verdict" not in row:
        return "(error)"
    if status and status["modelled"]:
        return " + ".join(sorted(set(status["matched"]))) + (" ✓named" if status["named"] else " ✓")
    if status and status["in_place"]:
        return " + ".join(status["in_place"]) + " (off)"
    unplaced = sorted({str(f.get("effect")) for f in row.get("findings", []) if not f.get("place")})
    if unplaced:
        return "no place: " + " + ".join(unplaced)
    if row.get("verdict") in ("not explained", "partly explained") and row.get("unexplained"):
        return "(not explained)"
    return "(missed)"


def kind_table(rows: list[dict]) -> str:
    """Hidden effect × what was reported for it: the finding(s) that model it (✓, ✓named), findings in its place
    whose features are off ('(off)'), an honest '(not explained)', or '(missed)'."""
    cells: dict[str, Counter] = {}
    columns: Counter = Counter()
    for r in rows:
        if r["control"]:
            label = "(no physics)" if r.get("no_physics") else "physics claimed: " + ", ".join(r.get("reported", []))
            if "verdict" not in r:
                label = "(error)"
            cells.setdefault("control (nothing)", Counter())[label] += 1
            columns[label] += 1
            continue
        for k in r.get("kinds", []):
            if not k.get("place") or not k.get("required", True):
                continue
            label = reported_label(r, k["id"])
            cells.setdefault(k["kind"], Counter())[label] += 1
            columns[label] += 1
    cols = [c for c, _ in columns.most_common()]
    lines = ["| hidden \\ reported | " + " | ".join(c.replace("|", "/") for c in cols) + " |",
             "| --- " * (len(cols) + 1) + "|"]
    for kind, counter in cells.items():
        lines.append(f"| {kind} | " + " | ".join(str(counter[c]) if counter[c] else "" for c in cols) + " |")
    return "\n".join(lines)


def place_table(rows: list[dict]) -> str:
    """Each hidden effect's place (the first the key lists) × the places the diagnosis reported in the case."""
    cells: dict[str, Counter] = {}
    columns: Counter = Counter()
    for r in rows:
        reported = sorted({str(f.get("place")) if f.get("place") else f"(no place: {f.get('effect')})"
                           for f in r.get("findings", [])}) or ["(no finding)"]
        truths = ["(control)"] if r["control"] else [k["place"][0] for k in r.get("kinds", [])
                                                      if k.get("place") and k.get("required", True)]
        for t in truths:
            for p in reported:
                cells.setdefault(t, Counter())[p] += 1
                columns[p] += 1
    cols = [c for c, _ in columns.most_common()]
    lines = ["| hidden place \\ reported place | " + " | ".join(cols) + " |", "| --- " * (len(cols) + 1) + "|"]
    for t, counter in cells.items():
        lines.append(f"| {t} | " + " | ".join(str(counter[c]) if counter[c] else "" for c in cols) + " |")
    return "\n".join(lines)


def case_table(rows: list[dict]) -> str:
    lines = ["| case | category | reported (verdict; findings; χ²/point after; loop) | right | modelled | named |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        if "verdict" not in r:
            text = f"error: {r.get('reason', '')}"
        else:
            parts = [f"`{r['verdict']}`"]
            for f in r.get("findings", []):
                where = f" @{f['place']}" if f.get("place") else ""
                mech = f"; {f['mechanisms'][0]}" if f.get("mechanisms") else ""
                parts.append(f"{f['effect']}{where} ({f['parameters']}{mech})")
            for u in r.get("unexplained", []):
                if isinstance(u, dict) and isinstance(u.get("band_hz"), list) and len(u["band_hz"]) == 2:
                    parts.append(f"unexplained {u['band_hz'][0]:.0f}–{u['band_hz'][1]:.0f} Hz")
            chi2 = r.get("chi2_per_point_after")
            if isinstance(chi2, (int, float)):
                parts.append(f"χ²/pt {chi2:.3g}")
            if r.get("loop_verdict"):
                parts.append(f"loop {r['loop_verdict']}")
            text = "; ".join(parts).replace("|", "/")
        right = r["outcome"] + (f" ({r['reason']})" if r.get("reason") else "")
        if r["control"]:
            lines.append(f"| {r['case']} | control | {text} | {right} | no physics: {_mark(r.get('no_physics'))} | — |")
        else:
            lines.append(f"| {r['case']} | {r['category']} | {text} | {right} | {_mark(r.get('modelled'))} | "
                         f"{_mark(r.get('named'))} |")
    return "\n".join(lines)


def summary_line(rows: list[dict]) -> str:
    effects = [r for r in rows if not r["control"]]
    controls = [r for r in rows if r["control"]]
    right = sum(r["outcome"] in round3.RIGHT for r in rows)
    modelled = sum(bool(r.get("modelled")) for r in effects)
    named = sum(bool(r.get("named")) for r in effects)
    loops = [r for r in rows if r.get("loop_verdict") is not None]
    inferred = sum(bool(r.get("modelled_catalog_places")) for r in effects)
    return (f"right {right}/{len(rows)}; modelled {modelled}/{len(effects)} ({100 * modelled / max(len(effects), 1):.0f} %"
            f" of the non-controls); named {named}/{len(effects)} ({100 * named / max(len(effects), 1):.0f} %); "
            f"controls with physics claimed {sum(not r.get('no_physics', True) for r in controls)}/{len(controls)}; "
            f"must-not claimed {sum(r['outcome'] == 'must-not claimed' for r in rows)}; false claims "
            f"{sum(r['outcome'] == 'false claim' for r in rows)}; errors {sum(r['outcome'] == 'error' for r in rows)}; "
            f"tracebacks {sum('traceback' in r for r in rows)}; loop closed "
            f"{sum(r['loop_verdict'] == 'consistent' for r in loops)}/{len(rows)} "
            f"({len(rows) - len(loops)} without a loop field); for information, modelled if every catalogue term "
            f"had its place: {inferred}/{len(effects)}")


def report(rows: list[dict]) -> str:
    times = sorted(r["wall_time_s"] for r in rows if "wall_time_s" in r)
    return "\n\n".join([
        "Outcomes (round 3's classification) with modelled and named, by category:\n\n" + outcome_table(rows),
        "Hidden effect × what was reported for it:\n\n" + kind_table(rows),
        "Hidden place × reported place:\n\n" + place_table(rows),
        "Per case:\n\n" + case_table(rows),
        summary_line(rows) + (f"\ndiagnosis wall time per case: median {times[len(times) // 2]:.1f} s, max "
                              f"{times[-1]:.1f} s" if times else ""),
    ]) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/redteam10"))
    parser.add_argument("--only", nargs="+", metavar="CASE")
    parser.add_argument("--label", default="")
    parser.add_argument("--tables-from", type=Path, nargs="+", metavar="SCORES_JSON")
    parser.add_argument("--gasfilm", type=Path, metavar="PATH",
                        help="the gasfilm command to score (default: the one beside this Python)")
    parser.add_argument("--gasfilm-tree", type=Path, metavar="DIR",
                        help="a checkout of the project to score (run by gasfilm-at.sh with this Python's packages, "
                             "unless --gasfilm is given); its commit is recorded with the scores")
    parser.add_argument("--from-saved", action="store_true",
                        help="classify DATA/diagnoses/CASE/diagnosis.json of an earlier run (no gasfilm run)")
    args = parser.parse_args(argv)
    global FROM_SAVED
    FROM_SAVED = args.from_saved
    if args.gasfilm_tree and not args.gasfilm:  # a checkout, run with this environment's packages
        os.environ["GASFILM_TREE"] = str(args.gasfilm_tree.resolve())
        os.environ.setdefault("GASFILM_PYTHON", sys.executable)
        args.gasfilm = HERE / "gasfilm-at.sh"
    if args.gasfilm:
        command = str(args.gasfilm.resolve())
        round3.gasfilm = lambda: command  # round 3's run() calls it by name
    order = {c: i for i, c in enumerate(CATEGORIES)}
    if args.tables_from:
        rows = [r for p in args.tables_from for r in json.loads(p.read_text())["cases"]]
    else:
        keys = sorted(args.data.glob("*.key.json"))
        if not keys:
            print(f"--data: no answer keys (*.key.json) in {args.data}; run generate.py first", file=sys.stderr)
            return 2
        if args.only:
            keys = [k for k in keys if k.name.removesuffix(".key.json") in args.only]
        rows = []
        for key_path in keys:
            row = score_case(key_path, args.data)
            print(f"  {row['case']:34s} {row['outcome']:20s} modelled {_mark(row.get('modelled')):3s} named "
                  f"{_mark(row.get('named')):3s} {row.get('wall_time_s', 0):6.1f} s  {row.get('reason', '')}",
                  file=sys.stderr, flush=True)
            rows.append(row)
    rows.sort(key=lambda r: (order.get(r["category"], 9), r["case"]))
    text = report(rows)
    print("\n" + text)
    if not args.tables_from:
        main_commit = subprocess.run(["git", "-C", str(args.gasfilm_tree or Path(round3.gasfilm()).resolve().parents[2]),
                                      "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=HERE).stdout.strip()
        summary = {"cases": len(rows), "summary": summary_line(rows), "worktree_commit": commit,
                   "gasfilm": round3.gasfilm(), "gasfilm_tree_head": main_commit,
                   "measured_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        results = HERE / "results"
        results.mkdir(exist_ok=True)
        name = args.label or "latest"
        (results / f"scores-{name}.json").write_text(json.dumps({"summary": summary, "cases": rows}, indent=1,
                                                                default=str, ensure_ascii=False))
        (results / f"score-{name}.txt").write_text(f"{summary}\n\n{text}")
        print(f"wrote {results / f'scores-{name}.json'} and score-{name}.txt")
    return 0


if __name__ == "__main__":
    sys.exit(main())
