"""Score gasfilm on the second synthesis (generate.py): ``gasfilm rigid FILE.uff --rig FILE.toml`` for every case,
its heave, roll and pitch stiffness and damping and its couplings against ``keys.json`` (written before the
records), the roving hammer (all four points) and the hammer at the centre alone.

Run: ``.venv/bin/python benchmarks/rigid/independent/score.py FOLDER`` (the folder generate.py wrote).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

TOLERANCE = 0.02
GASFILM = Path(sys.executable).with_name("gasfilm")


def rigid(folder: Path, case: str, *options: str) -> dict:
    command = [str(GASFILM), "rigid", str(folder / f"{case}.uff"), "--rig", str(folder / f"{case}.toml"), "--json",
               "--no-figures", *options]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode:
        raise SystemExit(f"{' '.join(command)}: {done.stderr.strip()}")
    return json.loads(done.stdout)


def main() -> int:
    folder = Path(sys.argv[1])
    keys = json.loads((folder / "keys.json").read_text(encoding="utf-8"))
    failures = total = 0
    for case, key in keys.items():
        result = rigid(folder, case)
        print(f"{case} (layout {'coupled' if key['coupled'] else 'uncoupled'}):")
        for direction, truth in key["directions"].items():
            fit = next(f for f in result["directions"][direction]["fits"] if f["model_name"] == "SD")
            for name in ("k", "eta"):
                total += 1
                error = fit["params"][name] / truth[name] - 1
                failures += abs(error) > TOLERANCE
                print(f"  {direction:<6} {name:<3} {fit['params'][name]:12.6g} (key {truth[name]:12.6g}) "
                      f"{100 * error:+7.3f} %{'' if abs(error) <= TOLERANCE else '  FAIL'}")
        for term in result["matrix_terms"]:
            a, b = term["directions"]
            if a == b:
                continue
            truth = key["couplings"][f"{a}-{b}"]
            print(f"  {a}–{b:<6} K {term['stiffness']:12.6g} ± {term['stiffness_std']:.2g} (key {truth['k']:12.6g})"
                  f"  C {term['damping']:9.4g} ± {term['damping_std']:.2g} (key {truth['eta']:9.4g})  "
                  f"{'coupled' if term['found'] else 'not coupled'}")
        total += 1
        agrees = bool(result["coupling_found"]) == key["coupled"]
        failures += not agrees
        print(f"  coupling {'found' if result['coupling_found'] else 'none'}{'' if agrees else '  FAIL'}")
        centre = rigid(folder, case, "--points", "C")  # the hammer at the centre of mass alone
        total += 1
        agrees = bool(centre["coupling_found"]) == key["coupled"]
        failures += not agrees
        heave = next(f for f in centre["directions"]["heave"]["fits"] if f["model_name"] == "SD")["params"]
        line = f"  hammer at the centre only: coupling {'found' if centre['coupling_found'] else 'none'}"
        if not key["coupled"]:  # an uncoupled film's heave from the centre alone
            for name in ("k", "eta"):
                total += 1
                error = heave[name] / key["directions"]["heave"][name] - 1
                failures += abs(error) > TOLERANCE
                line += f", heave {name} {heave[name]:.6g} ({100 * error:+.3f} %)"
        print(line + ("" if agrees else "  FAIL"))
    print(f"{total - failures}/{total} figures within {100 * TOLERANCE:g} % (and coupling verdicts) of the keys")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
