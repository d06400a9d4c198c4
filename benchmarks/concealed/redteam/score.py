"""Score ``gasfilm diagnose`` on the red-team world (run generate.py first).

Per case: refuse it when its answer key is missing or newer than its UFF file; run
``gasfilm diagnose <uff> --mass <M> --json --out <dir>`` (the ``gasfilm`` beside this Python: the worktree's .venv),
classify the outcome against the key, then close the loop (``--rig <improved_spec>``: nothing may be found).

Outcomes (first that applies):
- **error**: the command failed, or the key was refused;
- **must-not claimed**: a finding (or a quality note listed in ``must_not_quality``) names what the key forbids;
- **false claim**: any finding on a control, or a finding outside the key's allowed names;
- **exact** / **acceptable**: the set of findings is one of the key's sets (an empty set needs the verdict
  ``consistent`` or ``parameters-only``);
- **honest not-explained**: not a control, verdict ``not explained`` / ``partly explained``, ``unexplained`` not empty,
  every finding allowed (an honest not-explained names no physics that isn't there);
- **wrong**: anything else (e.g. a control ending ``not explained``, or nothing found and a verdict of missing physics).

Right = exact, acceptable or honest not-explained.

    python benchmarks/concealed/redteam/score.py [--data out/redteam] [--only CASE ...] [--no-loop]
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


_names = _load("independent_effect_names", HERE.parent / "independent" / "effect_names.py")
key_name = _names.key_name
three_figures = _load("three_figures", HERE.parent / "three_figures.py")

OUTCOMES = ("exact", "acceptable", "honest not-explained", "wrong", "false claim", "must-not claimed", "error")
RIGHT = OUTCOMES[:3]
CATEGORIES = ("control", "rig", "measurement")
EXPLAINED_VERDICTS = ("consistent", "parameters-only")
HONEST_VERDICTS = ("not explained", "partly explained", "modelled")  # "modelled": described, nothing claimed
TIMEOUT_S = 600


def gasfilm_command() -> str:
    """The ``gasfilm`` next to this Python (the current venv), else the one on PATH."""
    beside = Path(sys.executable).parent / "gasfilm"
    if beside.exists():
        return str(beside)
    found = shutil.which("gasfilm")
    if found is None:
        raise SystemExit("gasfilm: command not found in this environment (run from the worktree's .venv)")
    return found


def run_diagnosis(arguments: list[str]) -> tuple[dict | None, str, float]:
    """(parsed JSON or None, the error line when it failed, wall time s)."""
    started = time.perf_counter()
    try:
        done = subprocess.run([gasfilm_command(), "diagnose", *arguments, "--json", "--overwrite"],
                              capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {TIMEOUT_S} s", time.perf_counter() - started
    elapsed = time.perf_counter() - started
    if done.returncode != 0:
        lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
        return None, f"exit {done.returncode}: {lines[-1] if lines else '(no message)'}", elapsed
    try:
        return json.loads(done.stdout), "", elapsed
    except json.JSONDecodeError as error:
        return None, f"output is not JSON ({error})", elapsed


def key_problem(key_path: Path, uff_path: Path) -> str:
    """Why a case may not be scored ('' when it may)."""
    if not key_path.exists():
        return f"answer key {key_path.name} missing"
    if not uff_path.exists():
        return f"UFF file {uff_path.name} missing"
    if key_path.stat().st_mtime > uff_path.stat().st_mtime:
        return f"answer key {key_path.name} is newer than {uff_path.name}: written after the data, not scored"
    return ""


def quality_kinds(result: dict) -> list[str]:
    out = []
    for note in result.get("quality") or []:
        if isinstance(note, dict):
            out.append(f"{note.get('kind', '?')}: {note.get('message', '')}")
        else:
            out.append(str(note))
    return out


def condition_problem(key: dict, result: dict, findings: list[dict]) -> str:
    """What keeps a matching set from counting ('' when nothing): a finding without the alternative the key
    requires (``needs_alternative``), or an empty set whose recalibration did not move the parameter the key names
    (``empty_needs_recalibrated``: a name holding one of the strings, moved by more than 2 %)."""
    for finding in findings:
        needed = key.get("needs_alternative", {}).get(key_name(str(finding.get("effect", "?"))))
        if needed:
            named = {key_name(str(a.get("effect") if isinstance(a, dict) else a))
                     for a in finding.get("alternatives") or []}
            if needed not in named:
                return f"{finding.get('effect')} without the alternative {needed}"
    wanted = key.get("empty_needs_recalibrated", [])
    if wanted and not findings:
        moved = []
        for name, entry in (result.get("recalibration") or {}).items():
            if not any(word in name.lower() for word in wanted) or not isinstance(entry, dict):
                continue
            spec, fitted = entry.get("spec"), entry.get("fitted")
            if isinstance(spec, (int, float)) and isinstance(fitted, (int, float)) and spec and \
                    abs(fitted / spec - 1) > 0.02:
                moved.append(name)
        if not moved:
            return f"nothing found and no recalibrated parameter named {' or '.join(wanted)} moved by > 2 %"
    return ""


def classify(key: dict, result: dict) -> tuple[str, str]:
    """(outcome, reason) of one diagnosis against its answer key."""
    verdict = result.get("verdict")
    # a description the diagnosis only modelled (status "modelled") claims no mechanism: judged like an honest "not
    # explained", except on a control
    described = [f for f in result.get("findings") or [] if f.get("status") == "modelled"]
    findings = [f for f in result.get("findings") or [] if f.get("status") != "modelled"]
    effects = {key_name(str(f.get("effect", "?"))) for f in findings}
    allowed = set(key["allowed"]) | set(key.get("partial_ok", []))  # partial: only beside an unexplained rest
    forbidden = effects & set(key["must_not_claim"])
    notes = [kind.lower() for kind in quality_kinds(result)]
    bad_notes = [word for word in key.get("must_not_quality", []) if any(word in note for note in notes)]
    if forbidden or bad_notes:
        return "must-not claimed", "claimed " + ", ".join(sorted(forbidden) + [f"quality '{w}'" for w in bad_notes])
    if key["control"] and (findings or described):
        names = effects | {f"modelled {f.get('effect')}" for f in described}
        return "false claim", f"finding(s) on a control: {', '.join(sorted(names))}"
    outside = effects - allowed
    if outside:
        return "false claim", f"claimed {', '.join(sorted(outside))} (not there)"
    for outcome, sets in (("exact", key["exact"]), ("acceptable", key["acceptable"])):
        if effects in [set(names) for names in sets]:
            if not effects and verdict not in EXPLAINED_VERDICTS:
                break  # nothing found: judged below by its verdict
            problem = condition_problem(key, result, findings)
            if problem:
                return "wrong", problem
            return outcome, ""
    if key.get("honest_not_explained_ok") and verdict in HONEST_VERDICTS:
        if not result.get("unexplained") and not described:
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
                                                           else ""))
        else:
            parts.append(f"{name} {entry}")
    return ", ".join(parts)


def score_case(key_path: Path, data: Path, loop: bool) -> dict:
    key = json.loads(key_path.read_text())
    uff_path = data / key["uff"]
    row: dict[str, Any] = {"case": key["case"], "category": key["category"], "summary": key["summary"]}
    problem = key_problem(key_path, uff_path)
    if problem:
        return row | {"outcome": "error", "reason": problem}
    out_dir = data / "diagnoses" / key["case"]
    result, error, wall = run_diagnosis([str(uff_path), "--mass", f"{key['mass_kg']:g}", "--out", str(out_dir)])
    row["wall_time_s"] = round(wall, 2)
    if result is None:
        return row | {"outcome": "error", "reason": error} | three_figures.figures(key, None, "error")
    (out_dir / "diagnosis.json").write_text(json.dumps(result, indent=1, default=str))
    outcome, reason = classify(key, result)
    findings = result.get("findings") or []
    row |= {
        "outcome": outcome,
        "reason": reason,
        "verdict": result.get("verdict"),
        "reported": sorted({key_name(str(f.get("effect", "?"))) for f in findings}),
        "findings": [{"effect": f.get("effect"), "parameters": parameter_text(f.get("parameters")),
                      "gain_over_recalibrated": f.get("gain_over_recalibrated"),
                      "alternatives": [a.get("effect") if isinstance(a, dict) else a
                                       for a in f.get("alternatives") or []]} for f in findings],
        "unexplained": [{"band_hz": u.get("band_hz"), "chi2_share": u.get("chi2_share"),
                         "character": u.get("character")} if isinstance(u, dict) else u
                        for u in result.get("unexplained") or []],
        "quality": quality_kinds(result),
        "expected_quality_seen": [word for word in key.get("expected_quality", [])
                                  if any(word in note.lower() for note in quality_kinds(result))],
        "chi2_per_point_before": result.get("chi2_per_point_before"),
        "chi2_per_point_after": result.get("chi2_per_point_after"),
    }
    spec = result.get("improved_spec")
    if loop:
        if spec and Path(spec).exists():
            again, error, loop_wall = run_diagnosis([str(uff_path), "--rig", spec, "--out", str(out_dir / "loop")])
            row["loop_wall_time_s"] = round(loop_wall, 2)
            if again is None:
                row["loop"] = f"error: {error}"
            else:
                left = sorted({key_name(str(f.get("effect", "?"))) for f in again.get("findings") or []})
                row["loop"] = "clean" if not left else "found " + ", ".join(left)
                row["loop_verdict"] = again.get("verdict")
        else:
            row["loop"] = "no improved spec"
    looped = result | {"loop": {"verdict_on_written_spec": row.get("loop_verdict")}}
    return row | three_figures.figures(key, looped, outcome)


def confusion(rows: list[dict]) -> str:
    lines = ["| truth \\ outcome | " + " | ".join(OUTCOMES) + " | right |", "| --- " * (len(OUTCOMES) + 2) + "|"]
    for category in CATEGORIES:
        counts = Counter(row["outcome"] for row in rows if row["category"] == category)
        total = sum(counts.values())
        if total:
            right = sum(counts[o] for o in RIGHT)
            lines.append(f"| {category} ({total}) | " + " | ".join(str(counts[o]) for o in OUTCOMES)
                         + f" | {right}/{total} |")
    counts = Counter(row["outcome"] for row in rows)
    right = sum(counts[o] for o in RIGHT)
    lines.append(f"| all ({len(rows)}) | " + " | ".join(str(counts[o]) for o in OUTCOMES)
                 + f" | {right}/{len(rows)} |")
    return "\n".join(lines)


def print_tables(rows: list[dict]) -> None:
    print(f"\n{'case':24s} {'cat':11s} {'verdict':17s} {'reported':30s} {'outcome':20s} {'χ²/pt':>7s} "
          f"{'loop':12s} {'s':>5s}  reason")
    for row in rows:
        chi2 = row.get("chi2_per_point_after")
        print(f"{row['case']:24s} {row['category']:11s} {str(row.get('verdict', '-')):17s} "
              f"{', '.join(row.get('reported', [])) or '-':30s} {row['outcome']:20s} "
              f"{(f'{chi2:.3g}' if isinstance(chi2, (int, float)) else '-'):>7s} "
              f"{str(row.get('loop', '-'))[:12]:12s} "
              f"{row.get('wall_time_s', 0) + row.get('loop_wall_time_s', 0):5.1f}  {row.get('reason', '')}")
        for finding in row.get("findings", []):
            gain = finding.get("gain_over_recalibrated")
            print(f"{'':36s}{finding['effect']}: {finding['parameters']}"
                  + (f"  gain {gain:+.3g} %" if isinstance(gain, (int, float)) else "")
                  + (f"  alt {', '.join(map(str, finding['alternatives']))}" if finding.get("alternatives") else ""))
        for entry in row.get("unexplained", []):
            if isinstance(entry, dict):
                share = entry.get("chi2_share")
                print(f"{'':36s}unexplained {entry.get('band_hz')} "
                      + (f"share {share:.2f} " if isinstance(share, (int, float)) else "")
                      + f"{str(entry.get('character'))[:90]}")
        for note in row.get("quality", []):
            print(f"{'':36s}quality: {note[:110]}")
        if str(row.get("loop", "clean")) != "clean":
            print(f"{'':36s}closed loop: {row.get('loop')}")
    print("\nConfusion table (rows: truth category; columns: outcome)\n")
    print(confusion(rows))
    right = sum(row["outcome"] in RIGHT for row in rows)
    print(f"\nright (exact, acceptable or honest not-explained): {right}/{len(rows)} "
          f"= {100 * right / max(len(rows), 1):.0f} %")
    controls = [row for row in rows if row["category"] == "control"]
    print(f"controls with physics claimed: "
          f"{sum(row['outcome'] in ('false claim', 'must-not claimed') for row in controls)}/{len(controls)}")
    print(f"must-not claimed: {sum(row['outcome'] == 'must-not claimed' for row in rows)}; "
          f"false claims: {sum(row['outcome'] == 'false claim' for row in rows)}")
    looped = [row for row in rows if "loop" in row]
    print(f"closed loop clean: {sum(row['loop'] == 'clean' for row in looped)}/{len(looped)}")
    times = [row["wall_time_s"] for row in rows if "wall_time_s" in row]
    if times:
        print(f"diagnosis wall time per case: median {sorted(times)[len(times) // 2]:.1f} s, max {max(times):.1f} s")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/redteam"), help="folder written by generate.py")
    parser.add_argument("--only", nargs="+", metavar="CASE", help="score these cases only")
    parser.add_argument("--no-loop", action="store_true", help="skip the closed-loop diagnosis")
    parser.add_argument("--label", default="", help="name of this run, stored in scores-<label>.json")
    parser.add_argument("--tables-from", type=Path, nargs="+", metavar="SCORES_JSON",
                        help="print the tables of stored scores-*.json files (several: combined) instead of diagnosing")
    args = parser.parse_args(argv)
    if args.tables_from:
        order = {category: index for index, category in enumerate(CATEGORIES)}
        rows = [row for path in args.tables_from for row in json.loads(path.read_text())["cases"]]
        print_tables(sorted(rows, key=lambda row: (order.get(row["category"], 9), row["case"])))
        return 0
    keys = sorted(args.data.glob("*.key.json"))
    if not keys:
        print(f"--data: no answer keys (*.key.json) in {args.data}; run generate.py first", file=sys.stderr)
        return 2
    if args.only:
        names = {path.name.removesuffix(".key.json") for path in keys}
        unknown = set(args.only) - names
        if unknown:
            print(f"--only: no answer key for {', '.join(sorted(unknown))} in {args.data}", file=sys.stderr)
            return 2
        keys = [path for path in keys if path.name.removesuffix(".key.json") in args.only]
    order = {category: index for index, category in enumerate(CATEGORIES)}
    rows = []
    for key_path in keys:
        row = score_case(key_path, args.data, not args.no_loop)
        print(f"  {row['case']:24s} {row['outcome']:20s} {row.get('reason', '')}", file=sys.stderr, flush=True)
        rows.append(row)
    rows.sort(key=lambda row: (order.get(row["category"], 9), row["case"]))
    print_tables(rows)
    counts = Counter(row["outcome"] for row in rows)
    print(three_figures.summary_line(rows))
    summary = {"cases": len(rows), "right": sum(counts[o] for o in RIGHT), "outcomes": dict(counts),
               **three_figures.summary_counts(rows),
               "measured_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    name = f"scores-{args.label}.json" if args.label else "scores.json"
    (args.data / name).write_text(json.dumps({"summary": summary, "cases": rows}, indent=1, default=str))
    print(f"\nwrote {args.data / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
