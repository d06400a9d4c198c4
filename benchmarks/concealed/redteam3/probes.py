"""Bad-input probes of ``gasfilm diagnose`` (not scored): files made with pyuff from ``control-clean.uff`` (run
generate.py first), each diagnosed as a user would; prints exit code, traceback count, the last stderr line and the
verdict line.

    python benchmarks/concealed/redteam3/probes.py [--data out/redteam3]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyuff


def write(path: Path, sets: list[dict]) -> Path:
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/redteam3"))
    args = parser.parse_args(argv)
    probe = args.data / "probes"
    probe.mkdir(parents=True, exist_ok=True)
    clean = args.data / "control-clean.uff"
    sets = pyuff.UFF(str(clean)).read_sets()
    with_nan = [dict(s) for s in sets[:10]]
    values = with_nan[3]["data"].copy()
    values[500:510] = np.nan  # 10 samples of hit 1's response
    with_nan[3]["data"] = values
    ragged = [dict(s) for s in sets[:10]]
    for s in ragged[4:6]:
        s["data"], s["x"] = s["data"][:6000], s["x"][:6000]
    (probe / "empty.uff").write_text("")
    files = {
        "nan": write(probe / "nan.uff", with_nan),
        "two-hits": write(probe / "two-hits.uff", sets[:4]),
        "force-only": write(probe / "force-only.uff", [s for s in sets if s["ordinate_spec_data_type"] == 13]),
        "ragged": write(probe / "ragged.uff", ragged),
    }
    gasfilm = str(Path(sys.executable).parent / "gasfilm")
    runs = [[str(files["nan"]), "--mass", "25.05"], [str(files["two-hits"]), "--mass", "25.05"],
            [str(files["force-only"]), "--mass", "25.05"], [str(files["ragged"]), "--mass", "25.05"],
            [str(probe / "empty.uff"), "--mass", "25.05"],
            [str(args.data / "rate-mislabel.uff"), str(clean), "--mass", "25.05"],
            [str(clean), "--band", "2000:100"], [str(clean), "--band", "abc"],
            [str(clean), "--rig", str(probe / "missing.toml")], [str(clean), "--mass", "-3"]]
    for arguments in runs:
        command = ["gasfilm", "diagnose", *arguments, "--out", str(probe / "out"), "--overwrite"]
        done = subprocess.run([gasfilm, *command[1:]], capture_output=True, text=True, timeout=600)
        stderr = [line for line in done.stderr.splitlines() if line.strip()]
        verdict = next((line for line in done.stdout.splitlines() if "verdict" in line), "")
        print(f"$ {' '.join(command)}\n  exit {done.returncode}, tracebacks {done.stderr.count('Traceback')}, "
              f"stderr: {stderr[-1] if stderr else '-'}\n  {verdict.strip()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
