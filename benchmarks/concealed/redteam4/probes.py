"""Bad-input probes as a new user would type them (not scored; round 3's probes are not repeated): numbers that are
not finite, bands outside the data, a folder or a broken TOML as --rig, --out naming a file, .npy hits in the wrong
orientation or with one hit, an .h5 that is not HDF5, infinite samples, a pound-force UFF, all-zero force records.

    python benchmarks/concealed/redteam4/probes.py [--data out/redteam4]
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyuff


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path("out/redteam4"))
    args = parser.parse_args()
    gasfilm = str(Path(sys.executable).parent / "gasfilm")
    clean = args.data / "control-clean.uff"
    probe = args.data / "probes"
    probe.mkdir(parents=True, exist_ok=True)
    sets = pyuff.UFF(str(clean)).read_sets()
    sets = sets[:8]  # 4 hits

    def write(path: Path, chosen: list[dict]) -> str:
        if path.exists():
            path.unlink()
        pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(**{k: v for k, v in s.items() if k in PREPARE})
                                         for s in chosen], mode="add")
        return str(path)

    import inspect
    PREPARE = set(inspect.signature(pyuff.prepare_58).parameters)
    four = write(probe / "four-hits.uff", sets)
    with_inf = [dict(s) for s in sets]
    with_inf[3]["data"] = np.array(with_inf[3]["data"], dtype=float)
    with_inf[3]["data"][500:505] = np.inf
    inf_file = write(probe / "inf.uff", with_inf)
    lbf = [dict(s) for s in sets]
    for s in lbf:
        if s["ordinate_spec_data_type"] == 13:
            s["ordinate_axis_units_lab"] = "lbf"
            s["data"] = np.asarray(s["data"]) / 4.448
    lbf_file = write(probe / "lbf.uff", lbf)
    zero = [dict(s) for s in sets]
    for s in zero:
        if s["ordinate_spec_data_type"] == 13:
            s["data"] = np.zeros_like(np.asarray(s["data"], dtype=float))
    zero_file = write(probe / "zero-force.uff", zero)
    rows = [np.vstack([np.asarray(sets[2 * i]["x"]), sets[2 * i]["data"], sets[2 * i + 1]["data"]]) for i in range(4)]
    for i, r in enumerate(rows):
        np.save(probe / f"hit{i + 1}.npy", r)
        np.save(probe / f"hitT{i + 1}.npy", r.T)
        np.save(probe / f"hit2row{i + 1}.npy", r[1:])
    (probe / "not-hdf5.h5").write_text("this is not an HDF5 file\n")
    (probe / "broken.toml").write_text("mass_kg = 25.05\n[film\nmodel = 'SD'\n")
    (probe / "a-file.txt").write_text("x")
    (probe / "rigdir").mkdir(exist_ok=True)
    out = str(probe / "out")
    npy = [str(probe / f"hit{i + 1}.npy") for i in range(4)]
    cases = [
        ["diagnose", four, "--mass", "nan"],
        ["diagnose", four, "--mass", "inf"],
        ["diagnose", four, "--mass", "25.05kg"],
        ["diagnose", four, "--mass", "1e30"],
        ["diagnose", four, "--mass", "25.05", "--band", "0:100"],
        ["diagnose", four, "--mass", "25.05", "--band", "5000:6000"],
        ["diagnose", four, "--mass", "25.05", "--band", "20:1e9"],
        ["diagnose", four, "--mass", "25.05", "--band", "nan:500"],
        ["diagnose", four, "--rig", str(probe / "rigdir")],
        ["diagnose", four, "--rig", str(probe / "broken.toml")],
        ["diagnose", four, "--mass", "25.05", "--out", str(probe / "a-file.txt")],
        ["diagnose", *[str(probe / f"hitT{i + 1}.npy") for i in range(4)], "--mass", "25.05"],
        ["diagnose", *[str(probe / f"hit2row{i + 1}.npy") for i in range(4)], "--mass", "25.05"],
        ["diagnose", npy[0], "--mass", "25.05"],
        ["diagnose", str(probe / "not-hdf5.h5")],
        ["diagnose", inf_file, "--mass", "25.05"],
        ["diagnose", lbf_file, "--mass", "25.05"],
        ["diagnose", zero_file, "--mass", "25.05"],
        ["fit", inf_file, "--mass", "25.05"],
        ["fit", four, "--band", "5000:6000"],
        ["replay", four, "--exp-end", "0"],
        ["replay", four, "--exp-end", "-1"],
        ["replay", four, "--force-window-ms", "nan"],
        ["export", four, "--csv", str(probe / "rigdir")],
    ]
    for arguments in cases:
        if arguments[0] in ("diagnose",) and "--out" not in arguments:
            arguments = [*arguments, "--out", out, "--overwrite"]
        done = subprocess.run([gasfilm, *arguments], capture_output=True, text=True, timeout=300)
        err = [line for line in done.stderr.strip().splitlines() if line.strip()]
        shown = " ".join(a.replace(str(probe) + "/", "") for a in arguments)
        tb = " TRACEBACK" if "Traceback" in done.stderr else ""
        last = err[-1] if err else ""
        head = done.stdout.strip().splitlines()[:1]
        print(f"$ gasfilm {shown}\n  exit {done.returncode}{tb}; stderr: {last[:300]}"
              + (f"\n  stdout: {head[0][:200]}" if head and done.returncode == 0 else "")
              + (f"\n  stderr lines: {len(err)}; first: {err[0][:200]}" if len(err) > 1 else ""), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
