"""Score ``gasfilm diagnose`` on the independent benchmark (run generate.py first).

For every case: refuse it when its answer key is missing or newer than its UFF file; run
``gasfilm diagnose <uff> --mass <M> --json --out <dir>`` (the ``gasfilm`` of this Python's environment) and read the
JSON contract; classify the reported effect set against the key (exact / acceptable / honest "not explained" /
wrong / false claim / error); check that χ²/point after > 3 comes with a non-empty ``unexplained``; close the loop
(diagnose again with ``--rig <improved_spec>``: nothing may be found). Fields the diagnosis does not (yet) write are
reported as "contract field missing", never a crash. Prints the per-case table and the confusion table, writes
``scores.json`` into the data folder.

    python benchmarks/concealed/independent/score.py [--data out/independent] [--only CASE ...] [--no-loop]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from effect_names import PARAMETER_TO_KEY, key_name  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import three_figures  # noqa: E402

OUTCOMES = ("exact", "acceptable", "honest not-explained", "wrong", "false claim", "error")
RIGHT = OUTCOMES[:3]
CATEGORIES = ("control", "catalog", "outside", "trap")
EXPLAINED_VERDICTS = ("consistent", "parameters-only")
HONEST_VERDICTS = ("not explained", "partly explained", "modelled")  # "modelled": described, nothing claimed
CHI2_LIMIT = 3.0
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
        done = subprocess.run([gasfilm_command(), "diagnose", *arguments, "--json"], capture_output=True, text=True,
                              timeout=TIMEOUT_S)
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


def reported(findings: list[dict], missing: set[str]) -> tuple[set[str], set[str]]:
    """(effect names, names among the findings' alternatives), both mapped to the key's names."""
    effects, alternatives = set(), set()
    for finding in findings:
        effects.add(key_name(str(finding.get("effect", "?"))))
        if "alternatives" not in finding:
            missing.add("findings[].alternatives")
        for name in finding.get("alternatives") or []:
            alternatives.add(key_name(str(name.get("effect", name) if isinstance(name, dict) else name)))
        if "gain_over_recalibrated" not in finding:
            missing.add("findings[].gain_over_recalibrated")
    return effects, alternatives


def classify(key: dict, result: dict, missing: set[str]) -> tuple[str, str]:
    """(outcome, reason) of one diagnosis against its answer key."""
    verdict = result.get("verdict")
    # a description the diagnosis only modelled (status "modelled") claims no mechanism: judged like an honest "not
    # explained", except on a control
    described = [f for f in result.get("findings") or [] if f.get("status") == "modelled"]
    findings = [f for f in result.get("findings") or [] if f.get("status") != "modelled"]
    effects, alternatives = reported(findings, missing)
    exact = [set(names) for names in key["exact"]]
    acceptable = [set(names) for names in key["acceptable"]]
    allowed = set().union(*exact, *acceptable)
    if key["control"]:
        if findings or described:
            names = effects | {f"modelled {f.get('effect')}" for f in described}
            return "false claim", f"finding(s) on a control: {', '.join(sorted(names))}"
        if verdict in EXPLAINED_VERDICTS:
            return "exact", ""
        return "wrong", f"control, no finding, but verdict '{verdict}'"
    false = effects & set(key["must_not_claim"])
    if false:
        return "false claim", f"claimed {', '.join(sorted(false))}"
    required = set(key.get("alternatives_required") or [])
    for outcome, sets in (("exact", exact), ("acceptable", acceptable)):
        if effects in sets:
            if not effects and verdict not in EXPLAINED_VERDICTS:
                return "wrong", f"no finding, verdict '{verdict}'"
            lacking = required - effects - alternatives
            if effects and lacking:
                return "wrong", f"right effect, but {', '.join(sorted(lacking))} not named as an alternative"
            return outcome, ""
    if key["outside_catalog"] and verdict in HONEST_VERDICTS and effects <= allowed:
        unexplained = result.get("unexplained")
        if unexplained is None:
            missing.add("unexplained")
        elif not unexplained and not described:
            return "wrong", f"verdict '{verdict}' with an empty unexplained list"
        return "honest not-explained", ""
    if not effects:
        return "wrong", f"nothing found (verdict '{verdict}')"
    return "wrong", f"reported {', '.join(sorted(effects))}"


def _values(finding: dict) -> dict[str, tuple[float, float | None]]:
    """A finding's numeric parameters as name → (value, uncertainty or None)."""
    out = {}
    for name, entry in (finding.get("parameters") or {}).items():
        value = entry.get("value") if isinstance(entry, dict) else entry
        spread = entry.get("uncertainty") if isinstance(entry, dict) else None
        if isinstance(value, (int, float)):
            out[name] = (float(value), float(spread) if isinstance(spread, (int, float)) else None)
    return out


def parameter_errors(key: dict, findings: list[dict]) -> dict[str, float]:
    """Relative error of every reported parameter the key knows the true value of ('effect.quantity' → error)."""
    expected = key.get("expected_parameters") or {}
    errors = {}
    for finding in findings:
        effect = key_name(str(finding.get("effect", "?")))
        for name, (value, _) in _values(finding).items():
            true = expected.get(effect, {}).get(PARAMETER_TO_KEY.get(name, name))
            if true:
                errors[f"{effect}.{PARAMETER_TO_KEY.get(name, name)}"] = value / true - 1
    return errors


def implausible(finding: dict, mass_kg: float, band_hz: Any) -> list[str]:
    """Physical-sense checks of one finding's parameters, independent of the diagnosis's own bounds: an uncertainty
    that vanishes (a parameter pinned at a bound), ζ ≥ 0.3, a mass over a quarter of the mover's, a mode outside the
    analysis band."""
    reasons = []
    for name, (value, spread) in _values(finding).items():
        if spread is not None and value and abs(spread) < 1e-6 * abs(value):
            reasons.append(f"{name} {value:.3g} ± {spread:.1g} (pinned?)")
        if name == "damping_ratio" and value >= 0.3:
            reasons.append(f"ζ {value:.2g}")
        if "mass" in name and abs(value) > 0.25 * mass_kg:
            reasons.append(f"{name} {value:.3g} kg against a {mass_kg:g} kg mover")
        in_band = not isinstance(band_hz, list) or len(band_hz) != 2 or band_hz[0] <= value <= band_hz[1]
        if name == "freq_hz" and not in_band:
            reasons.append(f"mode at {value:.3g} Hz outside the band {band_hz[0]:g}–{band_hz[1]:g} Hz")
    return reasons


def chi2_check(result: dict, missing: set[str]) -> str:
    """'ok', or what is wrong with a χ²/point after > 3."""
    if "chi2_per_point_after" not in result:
        missing.add("chi2_per_point_after")
        return "field missing"
    chi2 = float(result["chi2_per_point_after"])
    if chi2 <= CHI2_LIMIT:
        return "ok"
    if "unexplained" not in result:
        missing.add("unexplained")
        return f"χ²/pt {chi2:.3g}, unexplained missing"
    return "ok" if result["unexplained"] else f"χ²/pt {chi2:.3g} with empty unexplained"


def score_case(key_path: Path, data: Path, loop: bool) -> dict:
    key = json.loads(key_path.read_text())
    uff_path = data / key["uff"]
    row: dict[str, Any] = {"case": key["case"], "category": key["category"], "summary": key["summary"],
                           "outside_catalog": key["outside_catalog"], "missing_fields": []}
    problem = key_problem(key_path, uff_path)
    if problem:
        return row | {"outcome": "error", "reason": problem}
    out_dir = data / "diagnoses" / key["case"]
    result, error, wall = run_diagnosis([str(uff_path), "--mass", f"{key['mass_kg']:g}", "--out", str(out_dir)])
    row["wall_time_s"] = round(wall, 2)
    if result is None:
        return row | {"outcome": "error", "reason": error} | three_figures.figures(key, None, "error")
    missing: set[str] = set()
    for name in ("verdict", "findings", "unexplained", "chi2_per_point_after", "rms_recalibrated", "improved_spec"):
        if name not in result:
            missing.add(name)
    outcome, reason = classify(key, result, missing)
    chi2 = chi2_check(result, missing)
    if outcome in RIGHT and chi2 != "ok":
        reason = f"(right names, but {chi2})"
    findings = result.get("findings") or []
    row |= {
        "outcome": outcome,
        "reason": reason,
        "verdict": result.get("verdict"),
        "reported": sorted({key_name(str(f.get("effect", "?"))) for f in findings}),
        "findings": [{name: f.get(name) for name in ("effect", "alternatives", "parameters", "gain_over_recalibrated",
                                                       "band_hz") if name in f} for f in findings],
        "parameter_errors": {name: round(error, 5) for name, error in parameter_errors(key, findings).items()},
        "implausible": {str(f.get("effect")): reasons for f in findings
                        if (reasons := implausible(f, key["mass_kg"], result.get("band_hz")))},
        "unexplained": result.get("unexplained"),
        "chi2_per_point_after": result.get("chi2_per_point_after"),
        "rms_recalibrated": result.get("rms_recalibrated"),
        "rms_after": result.get("rms_after"),
        "chi2_check": chi2,
        "quality": [note.get("kind") if isinstance(note, dict) else str(note) for note in result.get("quality") or []],
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
    row["missing_fields"] = sorted(missing)
    looped = result | {"loop": {"verdict_on_written_spec": row.get("loop_verdict")}}
    return row | three_figures.figures(key, looped, outcome)


def parameter_text(parameters: Any) -> str:
    """A finding's parameters as 'name value ± uncertainty', tolerant of the shape the diagnosis writes."""
    if not isinstance(parameters, dict):
        return "(no parameters)"
    parts = []
    for name, entry in parameters.items():
        if isinstance(entry, dict):
            value, spread = entry.get("value"), entry.get("uncertainty")
            parts.append(f"{name} {value:.4g}" + (f" ± {spread:.2g}" if isinstance(spread, (int, float)) else ""))
        else:
            parts.append(f"{name} {entry}")
    return ", ".join(parts)


def print_tables(rows: list[dict]) -> None:
    print(f"\n{'case':22s} {'cat':8s} {'verdict':17s} {'reported':34s} {'outcome':21s} {'χ²/pt':>7s} "
          f"{'unexpl':>6s} {'loop':14s} {'time s':>7s}  reason")
    for row in rows:
        unexplained = row.get("unexplained")
        chi2 = row.get("chi2_per_point_after")
        print(f"{row['case']:22s} {row['category']:8s} {str(row.get('verdict', '-')):17s} "
              f"{', '.join(row.get('reported', [])) or '-':34s} {row['outcome']:21s} "
              f"{(f'{chi2:.3g}' if isinstance(chi2, (int, float)) else '-'):>7s} "
              f"{(str(len(unexplained)) if isinstance(unexplained, list) else 'n/a'):>6s} "
              f"{str(row.get('loop', '-'))[:14]:14s} "
              f"{row.get('wall_time_s', 0) + row.get('loop_wall_time_s', 0):7.1f}  {row.get('reason', '')}")
        for finding in row.get("findings", []):
            effect = str(finding.get("effect"))
            print(f"{'':31s}{effect}: {parameter_text(finding.get('parameters'))}")
            if effect in row.get("implausible", {}):
                print(f"{'':33s}implausible: {'; '.join(row['implausible'][effect])}")
        if row.get("parameter_errors"):
            print(f"{'':31s}parameter error vs truth: " + ", ".join(
                f"{name} {100 * error:+.1f} %" for name, error in row["parameter_errors"].items()))
        if str(row.get("loop", "clean")) != "clean":
            print(f"{'':31s}closed loop: {row['loop']}")
    print("\nConfusion table (rows: truth category; columns: outcome)\n")
    print("| truth \\ outcome | " + " | ".join(OUTCOMES) + " | right |")
    print("| --- " * (len(OUTCOMES) + 2) + "|")
    for category in CATEGORIES:
        counts = Counter(row["outcome"] for row in rows if row["category"] == category)
        total = sum(counts.values())
        if total:
            right = sum(counts[o] for o in RIGHT)
            print(f"| {category} ({total}) | " + " | ".join(str(counts[o]) for o in OUTCOMES)
                  + f" | {right}/{total} |")
    right = sum(row["outcome"] in RIGHT for row in rows)
    print(f"\nright (exact, acceptable or honest not-explained): {right}/{len(rows)} "
          f"= {100 * right / max(len(rows), 1):.0f} %")
    controls = [row for row in rows if row["category"] == "control"]
    print(f"controls with physics claimed: {sum(row['outcome'] == 'false claim' for row in controls)}/{len(controls)}")
    print(f"false claims in all: {sum(row['outcome'] == 'false claim' for row in rows)}")
    chi2_bad = [row["case"] for row in rows if row.get("chi2_check") not in (None, "ok")]
    print(f"χ²/pt > {CHI2_LIMIT:g} without an unexplained list: {len(chi2_bad)} ({', '.join(chi2_bad) or '-'})")
    flagged = [row["case"] for row in rows if row.get("implausible")]
    print(f"sessions with implausible finding parameters: {len(flagged)} ({', '.join(flagged) or '-'})")
    looped = [row for row in rows if "loop" in row]
    print(f"closed loop clean: {sum(row['loop'] == 'clean' for row in looped)}/{len(looped)}")
    missing = sorted({name for row in rows for name in row.get("missing_fields", [])})
    print(f"contract field missing: {', '.join(missing) or 'none'}")
    times = [row["wall_time_s"] for row in rows if "wall_time_s" in row]
    if times:
        print(f"diagnosis wall time per case: median {sorted(times)[len(times) // 2]:.1f} s, max {max(times):.1f} s")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/independent"), help="folder written by generate.py")
    parser.add_argument("--only", nargs="+", metavar="CASE", help="score these cases only")
    parser.add_argument("--no-loop", action="store_true", help="skip the closed-loop diagnosis")
    args = parser.parse_args(argv)
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
        print(f"  {row['case']:22s} {row['outcome']:21s} {row.get('reason', '')}", file=sys.stderr, flush=True)
        rows.append(row)
    rows.sort(key=lambda row: (order.get(row["category"], 9), row["case"]))
    print_tables(rows)
    counts = Counter(row["outcome"] for row in rows)
    print(three_figures.summary_line(rows))
    summary = {"cases": len(rows), "right": sum(counts[o] for o in RIGHT), "outcomes": dict(counts),
               **three_figures.summary_counts(rows),
               "measured_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    (args.data / "scores.json").write_text(json.dumps({"summary": summary, "cases": rows}, indent=1, default=str))
    print(f"\nwrote {args.data / 'scores.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
