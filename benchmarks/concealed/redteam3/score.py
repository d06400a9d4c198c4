"""Score ``gasfilm diagnose`` on the round-3 red-team world (run generate.py first).

Per case, exactly as an engineer would run it (the ``gasfilm`` beside this Python, i.e. the worktree's .venv):

    gasfilm diagnose <case>.uff --mass 25.05 --json --out <dir> --overwrite            (key "cli": "mass")
    gasfilm diagnose <case>.uff --rig nominal-rig.toml --json --out <dir> --overwrite   (key "cli": "rig")

The scoring rules are those of ``benchmarks/concealed/redteam/score.py`` (first that applies):
- **error**: the command failed or timed out, or the key is missing or newer than its UFF file;
- **must-not claimed**: a finding, or a quality note, that the key forbids;
- **false claim**: any finding on a control, or a finding outside the key's allowed names (``partial_ok`` names only
  beside a non-empty ``unexplained`` and a verdict "partly explained"/"not explained");
- **exact** / **acceptable**: the set of findings is one of the key's sets (an empty set needs the verdict
  ``consistent`` or ``parameters-only``; ``needs_alternative`` and ``empty_needs_recalibrated`` must hold);
- **honest not-explained**: not a control, the key allows it, verdict ``not explained``/``partly explained``,
  ``unexplained`` not empty, every finding allowed;
- **wrong**: anything else.
Right = exact, acceptable or honest not-explained. A traceback on stderr is reported whatever the outcome.

    python benchmarks/concealed/redteam3/score.py [--data out/redteam3] [--only CASE ...] [--label NAME]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import shutil
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_key_name = _load("independent_effect_names", HERE.parent / "independent" / "effect_names.py").key_name
three_figures = _load("three_figures", HERE.parent / "three_figures.py")


def key_name(name: str) -> str:
    """The key's name of a diagnosis effect (a measured structure's ``structure-mode`` is an extra mode)."""
    return "extra-mode" if name == "structure-mode" else _key_name(name)

OUTCOMES = ("exact", "acceptable", "honest not-explained", "wrong", "false claim", "must-not claimed", "error")
RIGHT = OUTCOMES[:3]
CATEGORIES = ("control", "rig", "measurement")
EXPLAINED = ("consistent", "parameters-only")
HONEST = ("not explained", "partly explained", "modelled")  # "modelled": described, no mechanism claimed
TIMEOUT_S = 420


def gasfilm() -> str:
    beside = Path(sys.executable).parent / "gasfilm"
    if beside.exists():
        return str(beside)
    found = shutil.which("gasfilm")
    if not found:
        raise SystemExit("gasfilm: not found (run with the worktree's .venv/bin/python)")
    return found


def run(arguments: list[str]) -> tuple[dict | None, str, str, float]:
    """(JSON or None, error line, stderr, wall s)."""
    began = time.perf_counter()
    try:
        done = subprocess.run([gasfilm(), "diagnose", *arguments, "--json", "--overwrite"], capture_output=True,
                              text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {TIMEOUT_S} s", "", time.perf_counter() - began
    wall = time.perf_counter() - began
    if done.returncode != 0:
        lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
        return None, f"exit {done.returncode}: {lines[-1] if lines else '(no message)'}", done.stderr, wall
    try:
        return json.loads(done.stdout), "", done.stderr, wall
    except json.JSONDecodeError as error:
        return None, f"output is not JSON ({error})", done.stderr, wall


def notes(result: dict) -> list[str]:
    return [f"{n.get('kind', '?')}: {n.get('message', '')}" if isinstance(n, dict) else str(n)
            for n in result.get("quality") or []]


def condition_problem(key: dict, result: dict, findings: list[dict]) -> str:
    for finding in findings:
        needed = key.get("needs_alternative", {}).get(key_name(str(finding.get("effect", "?"))))
        if needed:
            named = {key_name(str(a.get("effect") if isinstance(a, dict) else a))
                     for a in finding.get("alternatives") or []}
            if needed not in named:
                return f"{finding.get('effect')} without the alternative {needed}"
    wanted = key.get("empty_needs_recalibrated") or {}
    if wanted and not findings:
        recal = result.get("recalibration") or {}
        for name, fraction in wanted.items():
            entry = recal.get(name)
            if not isinstance(entry, dict) or not entry.get("spec") or not isinstance(entry.get("fitted"), (int, float)):
                return f"nothing found and '{name}' not recalibrated"
            moved = entry["fitted"] / entry["spec"] - 1
            if abs(moved) <= fraction:
                return f"nothing found and '{name}' moved only {moved:+.2%} (key: > {fraction:.0%})"
    return ""


def claimed(result: dict) -> list[dict]:
    """The findings that claim a mechanism: a description the diagnosis only modelled (``status`` "modelled", its
    mechanisms candidates) claims none — it is judged like an honest "not explained", except on a control."""
    return [f for f in result.get("findings") or [] if f.get("status") != "modelled"]


def modelled(result: dict) -> list[dict]:
    return [f for f in result.get("findings") or [] if f.get("status") == "modelled"]


def classify(key: dict, result: dict) -> tuple[str, str]:
    verdict = result.get("verdict")
    findings = claimed(result)
    effects = {key_name(str(f.get("effect", "?"))) for f in findings}
    forbidden = effects & set(key["must_not_claim"])
    lowered = [n.lower() for n in notes(result)]
    bad_notes = [w for w in key.get("must_not_quality", []) if any(w in n for n in lowered)]
    if forbidden or bad_notes:
        return "must-not claimed", "claimed " + ", ".join(sorted(forbidden) + [f"quality '{w}'" for w in bad_notes])
    if key["control"] and (findings or modelled(result)):
        described = effects | {f"modelled {f.get('effect')}" for f in modelled(result)}
        return "false claim", f"finding(s) on a control: {', '.join(sorted(described))}"
    partial = set(key.get("partial_ok", []))
    honest_context = verdict in HONEST and (bool(result.get("unexplained")) or bool(modelled(result)))
    outside = effects - set(key["allowed"]) - (partial if honest_context else set())
    if outside:
        return "false claim", f"claimed {', '.join(sorted(outside))} (not there)"
    for outcome, sets in (("exact", key["exact"]), ("acceptable", key["acceptable"])):
        if effects in [set(s) for s in sets]:
            if not effects and verdict not in EXPLAINED:
                break
            problem = condition_problem(key, result, findings)
            if problem:
                return "wrong", problem
            return outcome, ""
    if key.get("honest_not_explained_ok") and verdict in HONEST:
        if not result.get("unexplained") and not modelled(result):
            return "wrong", f"verdict '{verdict}' with an empty unexplained list"
        return "honest not-explained", ""
    if not effects:
        return "wrong", f"nothing found, verdict '{verdict}'"
    return "wrong", f"reported {', '.join(sorted(effects))}, verdict '{verdict}'"


def parameter_text(parameters: Any) -> str:
    if not isinstance(parameters, dict):
        return ""
    parts = []
    for name, entry in parameters.items():
        if isinstance(entry, dict) and isinstance(entry.get("value"), (int, float)):
            spread = entry.get("uncertainty")
            parts.append(f"{name} {entry['value']:.4g}" + (f" ± {spread:.2g}" if isinstance(spread, (int, float))
                                                           else "") + (f" {entry['unit']}" if entry.get("unit") else ""))
    return ", ".join(parts)


def score_case(key_path: Path, data: Path) -> dict:
    key = json.loads(key_path.read_text())
    uff = data / key["uff"]
    arguments = [str(data / a) if a.endswith(".toml") else a for a in key["cli_arguments"]]
    out_dir = data / "diagnoses" / key["case"]
    command = ["gasfilm", "diagnose", str(uff), *arguments, "--json", "--out", str(out_dir), "--overwrite"]
    row: dict[str, Any] = {"case": key["case"], "category": key["category"], "summary": key["summary"],
                           "command": " ".join(command)}
    if not key_path.exists() or not uff.exists():
        return row | {"outcome": "error", "reason": "key or UFF file missing"}
    if key_path.stat().st_mtime > uff.stat().st_mtime:
        return row | {"outcome": "error", "reason": "answer key newer than its data: not scored"}
    result, error, stderr, wall = run([str(uff), *arguments, "--out", str(out_dir)])
    row |= three_figures.figures(key, result, "error")
    row["wall_time_s"] = round(wall, 1)
    if "Traceback" in stderr:
        row["traceback"] = stderr.strip().splitlines()[-1]
    if result is None:
        if key.get("refusal_ok") and "traceback" not in row and error.startswith("exit "):
            return row | {"outcome": "honest not-explained", "reason": f"refused: {error}"}
        return row | {"outcome": "error", "reason": error}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "diagnosis.json").write_text(json.dumps(result, indent=1, default=str))
    outcome, reason = classify(key, result)
    row |= three_figures.figures(key, result, outcome)
    findings = result.get("findings") or []
    return row | {
        "outcome": outcome, "reason": reason, "verdict": result.get("verdict"),
        "reported": sorted({key_name(str(f.get("effect", "?"))) for f in findings}),
        "findings": [{"effect": f.get("effect"), "parameters": parameter_text(f.get("parameters")),
                      "gain_over_recalibrated": f.get("gain_over_recalibrated"),
                      "alternatives": [a.get("effect") if isinstance(a, dict) else a
                                       for a in f.get("alternatives") or []]} for f in findings],
        "unexplained": [{"band_hz": u.get("band_hz"), "chi2_share": u.get("chi2_share"),
                         "character": u.get("character"),
                         "candidates": [c.get("effect") for c in u.get("candidates") or [] if isinstance(c, dict)]}
                        if isinstance(u, dict) else u for u in result.get("unexplained") or []],
        "quality": notes(result),
        "noise": (result.get("noise") or {}).get("source") if isinstance(result.get("noise"), dict) else None,
        "recalibration": {name: f"{e.get('spec'):.4g} → {e.get('fitted'):.4g}"
                          for name, e in (result.get("recalibration") or {}).items()
                          if isinstance(e, dict) and isinstance(e.get("spec"), (int, float))
                          and isinstance(e.get("fitted"), (int, float))},
        "chi2_per_point_after": result.get("chi2_per_point_after"),
        "first_note": (result.get("notes") or [""])[0] if isinstance(result.get("notes"), list) else "",
    }


def confusion(rows: list[dict]) -> str:
    lines = ["| truth \\ outcome | " + " | ".join(OUTCOMES) + " | right |", "| --- " * (len(OUTCOMES) + 2) + "|"]
    for category in CATEGORIES:
        counts = Counter(r["outcome"] for r in rows if r["category"] == category)
        total = sum(counts.values())
        if total:
            lines.append(f"| {category} ({total}) | " + " | ".join(str(counts[o]) for o in OUTCOMES)
                         + f" | {sum(counts[o] for o in RIGHT)}/{total} |")
    counts = Counter(r["outcome"] for r in rows)
    lines.append(f"| all ({len(rows)}) | " + " | ".join(str(counts[o]) for o in OUTCOMES)
                 + f" | {sum(counts[o] for o in RIGHT)}/{len(rows)} |")
    return "\n".join(lines)


def reported_text(row: dict) -> str:
    if "verdict" not in row:
        return f"error: {row.get('reason', '')}"
    parts = [f"`{row['verdict']}`"]
    for f in row.get("findings", []):
        gain = f.get("gain_over_recalibrated")
        parts.append(f"{f['effect']} ({f['parameters']}"
                     + (f"; gain {gain:+.3g} %" if isinstance(gain, (int, float)) else "")
                     + (f"; alt {', '.join(map(str, f['alternatives']))}" if f.get("alternatives") else "") + ")")
    for u in row.get("unexplained", []):
        if isinstance(u, dict):
            band = u.get("band_hz")
            parts.append(f"unexplained {band[0]:.0f}–{band[1]:.0f} Hz" if isinstance(band, list) and len(band) == 2
                         else "unexplained")
    for n in row.get("quality", []):
        parts.append(f"quality: {n[:70]}")
    chi2 = row.get("chi2_per_point_after")
    if isinstance(chi2, (int, float)):
        parts.append(f"χ²/pt {chi2:.3g}")
    return "; ".join(parts).replace("|", "/")


def per_case_table(rows: list[dict]) -> str:
    lines = ["| case | category | truth | reported | outcome |", "| --- | --- | --- | --- | --- |"]
    for r in rows:
        outcome = r["outcome"] + (f" ({r['reason']})" if r.get("reason") else "")
        lines.append(f"| {r['case']} | {r['category']} | {r['summary'][:150]} | {reported_text(r)} | {outcome} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None, default_data: Path = Path("out/redteam3")) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=default_data)
    parser.add_argument("--only", nargs="+", metavar="CASE")
    parser.add_argument("--label", default="")
    parser.add_argument("--tables-from", type=Path, nargs="+", metavar="SCORES_JSON",
                        help="print the tables of stored scores (several: combined) instead of diagnosing")
    args = parser.parse_args(argv)
    order = {c: i for i, c in enumerate(CATEGORIES)}
    if args.tables_from:
        rows = [r for p in args.tables_from for r in json.loads(p.read_text())["cases"]]
        rows.sort(key=lambda r: (order.get(r["category"], 9), r["case"]))
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
            print(f"  {row['case']:24s} {row['outcome']:20s} {row.get('wall_time_s', 0):6.1f} s  "
                  f"{row.get('reason', '')}", file=sys.stderr, flush=True)
            rows.append(row)
        rows.sort(key=lambda r: (order.get(r["category"], 9), r["case"]))
    print("\n" + confusion(rows) + "\n")
    print(per_case_table(rows) + "\n")
    controls = [r for r in rows if r["category"] == "control"]
    print(f"right: {sum(r['outcome'] in RIGHT for r in rows)}/{len(rows)} (exact or acceptable: "
          f"{sum(r['outcome'] in RIGHT[:2] for r in rows)}/{len(rows)}); controls with physics claimed: "
          f"{sum(r['outcome'] in ('false claim', 'must-not claimed') for r in controls)}/{len(controls)}; must-not "
          f"claimed: {sum(r['outcome'] == 'must-not claimed' for r in rows)}; false claims: "
          f"{sum(r['outcome'] == 'false claim' for r in rows)}; errors: {sum(r['outcome'] == 'error' for r in rows)}; "
          f"tracebacks: {sum('traceback' in r for r in rows)}")
    print(three_figures.summary_line(rows))
    times = sorted(r["wall_time_s"] for r in rows if "wall_time_s" in r)
    if times:
        print(f"diagnosis wall time per case: median {times[len(times) // 2]:.1f} s, max {times[-1]:.1f} s")
    if not args.tables_from:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=HERE).stdout.strip()
        summary = {"cases": len(rows), "right": sum(r["outcome"] in RIGHT for r in rows),
                   **three_figures.summary_counts(rows), "outcomes": dict(Counter(r["outcome"] for r in rows)),
                   "worktree_commit": commit,
                   "measured_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        name = f"scores-{args.label}.json" if args.label else "scores.json"
        (args.data / name).write_text(json.dumps({"summary": summary, "cases": rows}, indent=1, default=str))
        print(f"wrote {args.data / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
