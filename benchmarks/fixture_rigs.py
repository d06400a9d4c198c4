"""The project's own fixture rigs with effects, as a user meets them: each recorded on the simulated module
(``gasfilm acquire --device sim --rig RIG.toml``), then diagnosed against the rig's film alone
(``gasfilm diagnose S.h5 --rig FILM-ALONE.toml --json --check-loop``). Prints, per rig, every effect of the rig and
whether the diagnosis *named* it (the same term) or *modelled* it in its place (a description at its frequency), the
verdict, χ²/point before → after and the loop; then the totals *right* (no rig physics claimed that the rig does not
have), *modelled* and *named*. The answer key is the rig file itself, read before the diagnosis runs.

    .venv/bin/python benchmarks/fixture_rigs.py [--rigs three-modes all-effects] [--hits 8] [--seed 5] [--out DIR]

``tests/test_diagnose_fixture_rigs.py`` holds the three-modes rig to the same scoring in the suite; all-effects
(six effects, one of them a drift over the session) takes minutes and is scored here.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RIGS = ROOT / "fixtures" / "rigs"
GASFILM = [sys.executable, "-m", "gasfilm.app.cli"]
#: A description covers an effect with a frequency when it is found within this fraction of it.
FREQUENCY_MATCH = 0.02


def film_alone(spec):
    """The rig as an engineer would first model it: its mass on its film, the sensors and hammer, no effect."""
    from gasfilm.analysis.physics.spec import RigSpec

    return RigSpec(name=f"{spec.name}: film alone", mass_kg=spec.mass_kg, film_model=spec.film_model,
                   film_parameters=spec.film_parameters, force_sensor=spec.force_sensor,
                   acceleration_sensor=spec.acceleration_sensor, hammer=spec.hammer)


def _frequency_hz(finding: dict) -> float | None:
    """The frequency a finding gives its term (a named term's parameter, a description's feature)."""
    named = (finding.get("parameters") or {}).get("freq_hz")
    if isinstance(named, dict) and named.get("value") is not None:
        return float(named["value"])
    return (finding.get("features") or {}).get("frequency_hz")


def covers(finding: dict, effect: dict, place: str) -> str | None:
    """"named" when a finding names the effect's term, "modelled" when it describes it in its place (``place``,
    the effect's place in the chain); at the effect's frequency (within :data:`FREQUENCY_MATCH`) where it has one;
    None otherwise."""
    frequency, found = effect.get("freq_hz"), _frequency_hz(finding)
    if frequency is not None and (found is None or abs(found / frequency - 1) > FREQUENCY_MATCH):
        return None
    if finding.get("effect") == effect["type"]:
        return "named"
    return "modelled" if finding.get("status") == "modelled" and finding.get("place") == place else None


def score(effects: list[dict], places: dict[str, str], findings: list[dict]) -> list[str]:
    """Each effect's answer ("named", "modelled" or "—"), every finding describing one effect at most."""
    unused = list(findings)
    answers = []
    for effect in effects:
        matches = [(covers(finding, effect, places[effect["type"]]), finding) for finding in unused]
        best = next((m for m in matches if m[0] == "named"), None) or next((m for m in matches if m[0]), None)
        answers.append(best[0] if best else "—")
        if best:
            unused.remove(best[1])
    return answers


def rig_effects(rig: Path) -> tuple[list[dict], dict[str, str]]:
    """The answer key of a rig file: its effects as written (mains and other interference left out: a disturbance,
    not physics to model) and each effect type's place in the chain."""
    import tomllib

    from gasfilm.analysis.physics.spec import RigSpec

    loaded = RigSpec.load(rig)
    places = {effect.type_name: effect.place() for effect in loaded.effects}
    kinds = {effect.type_name: effect.kind for effect in loaded.effects}
    effects = [effect for effect in tomllib.loads(rig.read_text(encoding="utf-8")).get("effects", [])
               if kinds[effect["type"]] != "interference"]
    return effects, places


def run_rig(rig: Path, hits: int, seed: int, work: Path, figures: bool = False) -> dict:
    """Record ``rig`` on the simulator, diagnose it against its film alone (its figures drawn if ``figures``), score
    the findings against its effects."""
    from gasfilm.analysis.physics.spec import RigSpec

    effects, places = rig_effects(rig)
    session, given, out = work / f"{rig.stem}.h5", work / f"{rig.stem}-film-alone.toml", work / f"{rig.stem}-diagnosis"
    film_alone(RigSpec.load(rig)).save(given)
    subprocess.run([*GASFILM, "acquire", "--device", "sim", "--rig", str(rig), "--out", str(session), "--hits",
                    str(hits), "--pacing", "fast", "--seed", str(seed), "--hit-interval", "7", "8"],
                   check=True, capture_output=True, cwd=ROOT)
    started = time.perf_counter()
    done = subprocess.run([*GASFILM, "diagnose", str(session), "--rig", str(given), "--json", "--check-loop",
                           "--out", str(out), *([] if figures else ["--no-figures"])],
                          capture_output=True, text=True, cwd=ROOT)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        return {"rig": rig.stem, "error": done.stderr.strip()[-300:], "effects": len(effects), "seconds": seconds}
    result = json.loads(done.stdout)
    findings = result.get("findings", [])
    scored = list(zip((effect["type"] for effect in effects), score(effects, places, findings)))
    known = {effect["type"] for effect in effects}
    false_claims = [finding["effect"] for finding in findings
                    if finding.get("status") != "modelled" and finding["effect"] not in known]
    loop = result.get("loop") or {}
    return {"rig": rig.stem, "effects": len(effects), "scored": scored, "false_claims": false_claims,
            "verdict": result["verdict"], "chi2_before": result["chi2_per_point_before"],
            "chi2_after": result["chi2_per_point_after"], "loop_verdict": loop.get("verdict_on_written_spec"),
            "loop_closed": loop.get("closed"), "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rigs", nargs="+", default=["three-modes", "all-effects"])
    parser.add_argument("--hits", type=int, default=8)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--out", type=Path, help="keep the sessions and diagnoses, with their figures, here (default: "
                                                 "a temporary folder, no figures)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as temporary:
        work = args.out or Path(temporary)
        work.mkdir(parents=True, exist_ok=True)
        rows = [run_rig(RIGS / f"{name}.toml", args.hits, args.seed, work, figures=args.out is not None)
                for name in args.rigs]
    effects = right = modelled = named = 0
    for row in rows:
        if "error" in row:
            print(f"{row['rig']}: error: {row['error']}")
            effects += row["effects"]
            continue
        print(f"{row['rig']}: verdict {row['verdict']}, χ²/point {row['chi2_before']:.4g} → {row['chi2_after']:.3g}, "
              f"loop {'closed' if row['loop_closed'] else 'open'} ({row['loop_verdict']}), diagnosis {row['seconds']:.0f} s wall")
        for effect, answer in row["scored"]:
            print(f"  {effect:<16} {answer}")
        if row["false_claims"]:
            print(f"  claimed, not in the rig: {', '.join(row['false_claims'])}")
        effects += row["effects"]
        right += not row["false_claims"]
        modelled += sum(answer != "—" for _, answer in row["scored"])
        named += sum(answer == "named" for _, answer in row["scored"])
    closed = sum(bool(row.get("loop_closed")) for row in rows)
    print(f"right {right}/{len(rows)} rigs, modelled {modelled}/{effects} effects, named {named}/{effects}, "
          f"loop closed {closed}/{len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
