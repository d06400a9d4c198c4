"""Score ``gasfilm rigid`` on the independent generator's UFF files against the keys committed before it ran.

Per case, as docs/rigid-body.md documents the command for UFF time records with a layout:

    gasfilm rigid DATA/<case>.uff --rig keys/<case>.toml --models SD --json --no-figures
    (the fractional case: --models SD,FOZGF)

The rig spec given to gasfilm holds the mover's mass, inertia, centre of mass, the sensors and the hammer points, and
a *nominal* film (docs: films per direction) that is not the truth, so that every figure must come from the data.

Compared with the key:

* per direction (the nine-model fit of each direction's accelerance, Table 2 per direction): the SD fit's k and eta
  against the layout's K_jj and C_jj (spring-damper pads); for fractional pads, the FOZGF fit's Re Z and Im Z / w at
  the direction's resonance against the layout's (and its four parameters, for information);
* the 3x3 terms (K_ab + C_ab s): the diagonal against K_jj and C_jj (spring-damper pads; fractional: information), the
  couplings' values, and each pair's *found* against the key's *exists*;
* the overall coupling verdict (found or seen) against the key; the elastic centre's offset (mm).

PASS for a case: every scored K and C within 2 % (per direction and, where the full matrix exists, its diagonal) and
every coupling verdict (per pair and overall) equal to the key's. Coupling values and the elastic centre are printed
with their error but not part of the pass (the issue asks for the verdict).

    python score.py [--data DIR] [--label NAME] [--only CASE ...] [--gasfilm PATH] [--nominal-check]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
TOL = 0.02
DIRS = ("heave", "roll", "pitch")
PAIRS = ("heave-roll", "heave-pitch", "roll-pitch")


def fozgf_z(p: dict, s: complex) -> complex:
    sa = s ** p["alpha"]
    return p["k2"] + p["k1"] * p["eta1"] * sa / (p["k1"] + p["eta1"] * sa)


def run_gasfilm(gasfilm: str, uff: Path, spec: Path, models: str, band: str | None = None
                ) -> tuple[dict | None, str, float]:
    cmd = [gasfilm, "rigid", str(uff), "--rig", str(spec), "--models", models, "--json", "--no-figures"]
    if band:
        cmd += ["--band", band]
    began = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - began
    if proc.returncode != 0:
        return None, (proc.stderr or proc.stdout).strip().splitlines()[-1:][0] if (proc.stderr or proc.stdout) \
            else f"exit {proc.returncode}", wall
    return json.loads(proc.stdout), "", wall


def gasfilm_version(gasfilm: str) -> str:
    """`gasfilm --version` and, when it runs from a git checkout, that checkout's commit."""
    version = subprocess.run([gasfilm, "--version"], capture_output=True, text=True).stdout.strip()
    tree = Path(gasfilm).resolve().parents[2]
    commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    return f"{version}, {tree} at {commit}" if commit else version


def rel(a: float, b: float) -> float:
    return (a - b) / b


def score_case(key: dict, out: dict) -> dict:
    """Rows (what, key, identified, error, scored, ok) and verdicts."""
    rows = []
    fractional = key["pad_model"] != "SD"
    for d in DIRS:
        if d not in out["directions"]:
            if key["scored"][d]:
                rows.append({"what": f"{d}: not identified", "key": None, "got": None, "err": None,
                             "scored": True, "ok": False})
            continue
        fits = {f["model_name"]: f for f in out["directions"][d]["fits"]}
        k = key["directions"][d]
        scored = key["scored"][d]
        if not fractional:
            p = fits["SD"]["params"]
            for what, kv, gv in (("K", k["K"], p["k"]), ("C", k["C"], p["eta"])):
                e = rel(gv, kv)
                rows.append({"what": f"{d} {what} (SD fit)", "key": kv, "got": gv, "err": e, "scored": scored,
                             "ok": abs(e) <= TOL})
        else:
            p = fits["FOZGF"]["params"]
            s = 2j * np.pi * k["resonance_hz"]
            z = fozgf_z(p, s)
            for what, kv, gv in (("K@res", k["K_at_resonance"], z.real),
                                 ("C@res", k["C_at_resonance"], z.imag / (2 * np.pi * k["resonance_hz"]))):
                e = rel(gv, kv)
                rows.append({"what": f"{d} {what} (FOZGF fit)", "key": kv, "got": gv, "err": e, "scored": scored,
                             "ok": abs(e) <= TOL})
            kp = key["fozgf_per_direction"][d]
            for name in ("k1", "k2", "eta1", "alpha"):
                e = rel(p[name], kp[name])
                rows.append({"what": f"{d} FOZGF {name}", "key": kp[name], "got": p[name], "err": e,
                             "scored": False, "ok": abs(e) <= TOL})
            sdp = fits["SD"]["params"]
            rows.append({"what": f"{d} K (SD fit, info)", "key": k["K_at_resonance"], "got": sdp["k"],
                         "err": rel(sdp["k"], k["K_at_resonance"]), "scored": False, "ok": None})
    terms = {tuple(t["directions"]): t for t in out.get("matrix_terms") or []}
    pair_verdicts = {}
    for (a, b), t in terms.items():
        if a == b:
            k = key["directions"][a]
            for what, kv, gv in (("K", key["stiffness_matrix"][DIRS.index(a)][DIRS.index(a)], t["stiffness"]),
                                 ("C", key["damping_matrix"][DIRS.index(a)][DIRS.index(a)], t["damping"])):
                e = rel(gv, kv)
                rows.append({"what": f"{a} {what} (3x3 term)", "key": kv, "got": gv, "err": e,
                             "scored": not fractional and key["scored"][a], "ok": abs(e) <= TOL})
        else:
            name = f"{a}-{b}"
            c = key["couplings"][name]
            ia, ib = DIRS.index(a), DIRS.index(b)
            scale_k = np.sqrt(key["stiffness_matrix"][ia][ia] * key["stiffness_matrix"][ib][ib])
            scale_c = np.sqrt(key["damping_matrix"][ia][ia] * key["damping_matrix"][ib][ib])
            for what, kv, gv, scale in (("K", c["K"], t["stiffness"], scale_k), ("C", c["C"], t["damping"], scale_c)):
                rows.append({"what": f"{name} {what} (3x3 term)", "key": kv, "got": gv,
                             "err": (gv - kv) / scale, "err_of": "sqrt(aa*bb)", "scored": False, "ok": None})
            pair_verdicts[name] = {"key": c["exists"], "found": bool(t["found"]),
                                   "normalised": t.get("normalised"), "ok": bool(t["found"]) == c["exists"]}
    overall_found = bool(out.get("coupling_found") or out.get("coupling_seen"))
    verdict_ok = overall_found == key["coupling_exists"] and all(v["ok"] for v in pair_verdicts.values())
    values_ok = all(r["ok"] for r in rows if r["scored"])
    ec = out.get("elastic_centre_offset_m")
    return {"rows": rows, "pairs": pair_verdicts, "coupling_found": overall_found,
            "coupling_key": key["coupling_exists"], "verdict_ok": verdict_ok, "values_ok": values_ok,
            "pass": verdict_ok and values_ok,
            "elastic_centre_mm": None if ec is None else [ec[0] * 1e3, ec[1] * 1e3 if len(ec) == 2 else ec[2] * 1e3],
            "elastic_centre_key_mm": [v * 1e3 for v in key["elastic_centre_offset_m"]],
            "frf_lines": out.get("frf_lines", [])}


def fmt(v):
    return "—" if v is None else f"{v:.6g}"


def report(name: str, res: dict, wall: float) -> list[str]:
    lines = [f"{name}  ({wall:.1f} s)  {'PASS' if res['pass'] else 'FAIL'}"]
    lines += [f"    {ln.strip()}" for ln in res["frf_lines"] if "reciprocity" in ln or "rigidity" in ln]
    lines.append(f"    {'':34s}{'key':>14s}{'identified':>14s}{'error':>10s}")
    for r in res["rows"]:
        err = "—" if r["err"] is None else f"{100 * r['err']:+.3f} %"
        if r.get("err_of"):
            err += "*"
        mark = ("ok" if r["ok"] else "MISS") if r["scored"] else "info"
        lines.append(f"    {r['what']:34s}{fmt(r['key']):>14s}{fmt(r['got']):>14s}{err:>10s}  {mark}")
    for pname, v in res["pairs"].items():
        lines.append(f"    coupling {pname:12s} key {'yes' if v['key'] else 'no ':3s}  found "
                     f"{'yes' if v['found'] else 'no '}  ({100 * (v['normalised'] or 0):+.2f} % of sqrt(K_aa K_bb))"
                     f"  {'ok' if v['ok'] else 'WRONG'}")
    lines.append(f"    coupling overall: key {'yes' if res['coupling_key'] else 'no'}, gasfilm "
                 f"{'found' if res['coupling_found'] else 'none'}  {'ok' if res['verdict_ok'] else 'WRONG'}")
    if res["elastic_centre_mm"] is not None:
        ec, kc = res["elastic_centre_mm"], res["elastic_centre_key_mm"]
        lines.append(f"    elastic centre − centre of mass: dx {ec[0]:+.3f} mm (key {kc[0]:+.3f}), "
                     f"dy {ec[1]:+.3f} mm (key {kc[1]:+.3f})")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=ROOT / "out" / "rigid-independent2")
    parser.add_argument("--label", default="scatter")
    parser.add_argument("--only", nargs="+")
    parser.add_argument("--gasfilm", default="/work/main/.venv/bin/gasfilm")
    parser.add_argument("--band", help="gasfilm rigid --band LO:HI (default: gasfilm's own, 20:1000)")
    parser.add_argument("--nominal-check", action="store_true",
                        help="also run each case with a second, different nominal film in its spec and report the "
                             "largest change of any figure (it must not depend on the spec's film)")
    args = parser.parse_args(argv)
    keys = sorted((HERE / "keys").glob("*.key.json"))
    lines = [f"gasfilm rigid on independent2 data in {args.data} (label {args.label}"
             f"{', --band ' + args.band if args.band else ''})",
             f"gasfilm: {args.gasfilm} ({gasfilm_version(args.gasfilm)}); keys: {HERE / 'keys'}", ""]
    summary, results = [], {}
    for keyfile in keys:
        key = json.loads(keyfile.read_text())
        name = key["case"]
        if args.only and name not in args.only:
            continue
        uff = args.data / f"{name}.uff"
        data_key = args.data / f"{name}.key.json"
        if data_key.exists() and json.loads(data_key.read_text()) != key:
            print(f"{name}: the key next to the data differs from keys/ — regenerate", file=sys.stderr)
            return 2
        spec = HERE / "keys" / f"{name}.toml"
        models = "SD" if key["pad_model"] == "SD" else "SD,FOZGF"
        out, error, wall = run_gasfilm(args.gasfilm, uff, spec, models, args.band)
        if out is None:
            lines += [f"{name}: gasfilm failed: {error}", ""]
            summary.append((name, False, error))
            results[name] = {"error": error}
            print(lines[-2], flush=True)
            continue
        res = score_case(key, out)
        res["wall_s"] = wall
        if args.nominal_check:
            alt = spec.read_text().replace("k = 20000000.0", "k = 55000000.0").replace("eta = 3000.0", "eta = 900.0") \
                .replace("k = 200000.0, eta = 30.0", "k = 900000.0, eta = 5.0") \
                .replace("k = 300000.0, eta = 40.0", "k = 60000.0, eta = 200.0")
            alt_path = args.data / f"{name}.nominal-b.toml"
            alt_path.write_text(alt)
            out_b, error_b, _ = run_gasfilm(args.gasfilm, uff, alt_path, models, args.band)
            if out_b is None:
                res["nominal_check"] = f"failed: {error_b}"
            else:
                res_b = score_case(key, out_b)
                diffs = [abs(a["got"] - b["got"]) / abs(a["got"]) for a, b in zip(res["rows"], res_b["rows"])
                         if a["got"] not in (None, 0)]
                res["nominal_check"] = {"max_relative_change": max(diffs) if diffs else 0.0,
                                        "same_verdicts": res_b["pairs"] == res["pairs"]
                                        and res_b["coupling_found"] == res["coupling_found"]}
        block = report(name, res, wall)
        if "nominal_check" in res:
            block.append(f"    second nominal film in the spec: {res['nominal_check']}")
        lines += block + [""]
        print("\n".join(block), flush=True)
        results[name] = res
        scored = [abs(r["err"]) for r in res["rows"] if r["scored"] and r["err"] is not None]
        worst = f"worst scored K/C error {100 * max(scored):.3f} %" if scored else \
            "no K/C scored (one coupled column: biased, as documented)"
        summary.append((name, res["pass"], f"{worst}, coupling "
                        f"{'found' if res['coupling_found'] else 'none'} (key {'yes' if res['coupling_key'] else 'no'})"
                        + ("" if res["verdict_ok"] else ": WRONG VERDICT")))
    lines.append("summary")
    for name, ok, text in summary:
        lines.append(f"  {name:26s} {'PASS' if ok else 'FAIL'}  {text}")
    lines.append(f"  {sum(ok for _, ok, _ in summary)}/{len(summary)} cases pass")
    lines.append("  (* coupling value errors are relative to sqrt(K_aa K_bb), information only)")
    print("\n".join(lines[-len(summary) - 3:]))
    res_dir = HERE / "results"
    res_dir.mkdir(exist_ok=True)
    (res_dir / f"score-{args.label}.txt").write_text("\n".join(lines) + "\n")
    (res_dir / f"score-{args.label}.json").write_text(json.dumps(results, indent=1, default=float))
    return 0 if all(ok for _, ok, _ in summary) else 1


if __name__ == "__main__":
    sys.exit(main())
