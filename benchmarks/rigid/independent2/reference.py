"""The generator's own reading of its UFF files (no gasfilm): what a plain textbook processing of the records gives,
so that a figure of ``gasfilm rigid`` that misses its key can be put on the data or on gasfilm.

Per hammer point and accelerometer H1 = sum X F* / sum |F|^2 over the hits (rectangular window: the records have
decayed), the generalised accelerations per newton by least squares over the accelerometers, the 3x3 FRF matrix
A = U B^+ over the points (B the points' load vectors g_p, or the single column when one point), its symmetric part,
D = s^2 A^-1, Z = D - M s^2 and K_ab + C_ab s by unweighted linear least squares on the lines of 20-1000 Hz; and the
direction's K and C from Z_jj alone. For a fractional film only the diagonal at the direction's resonance is
compared.

    python reference.py [--data DIR] [--only CASE ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pyuff

HERE = Path(__file__).resolve().parent
BAND_HZ = (20.0, 1000.0)
DIRS = ("heave", "roll", "pitch")


def g_vec(xy, com):
    return np.array([1.0, xy[1] - com[1], -(xy[0] - com[0])])


def read_hits(path: Path):
    """{point node: [(force, {acc node: signed record})]}, dt."""
    sets = pyuff.UFF(str(path)).read_sets()
    by_hit: dict = {}
    dt = None
    for s in sets:
        if s["type"] != 58 or s["func_type"] != 1:
            continue
        dt = s["abscissa_inc"]
        entry = by_hit.setdefault(s["ver_num"], {"ref": s["ref_node"], "acc": {}})
        if s["ordinate_spec_data_type"] == 13:
            entry["force"] = np.asarray(s["data"])
        else:
            entry["acc"][s["rsp_node"]] = np.asarray(s["data"])
    out: dict = {}
    for hit in by_hit.values():
        out.setdefault(hit["ref"], []).append((hit["force"], hit["acc"]))
    return out, dt


def landed_points(drawn: list, key: dict) -> dict:
    """Where each point's hits really landed on average, weighted as H1 weights them (|F|^2 at low frequency is
    proportional to (peak x width)^2 for a half-sine)."""
    out = {}
    for p, point in enumerate(key["hammer_points"]):
        rows = [d for d in drawn if d["point"] == point["name"]]
        if rows:
            w = np.array([(d["peak_force_n"] * d["pulse_width_ms"]) ** 2 for d in rows])
            xy = np.array([d["landed_at_m"] for d in rows])
            out[101 + p] = (w[:, None] * xy).sum(axis=0) / w.sum()
    return out


def analyse(key: dict, uff: Path, landed: dict | None = None) -> dict:
    """``landed``: the load vectors from where the hits really landed (drawn.json) instead of the named points."""
    hits, dt = read_hits(uff)
    body = key["body"]
    com = body["centre_of_mass_m"]
    m = np.array(key["mass_matrix"])
    accs = key["accelerometers"]
    # the sensor reads d g^T qdd: its row of G is d g^T
    gmat = np.array([a["direction"] * g_vec(a["position_m"], com) for a in accs])
    n = len(next(iter(hits.values()))[0][0])
    f = np.fft.rfftfreq(n, dt)
    band = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
    cols, loads = [], []
    for node in sorted(hits):
        sff = 0.0
        sxf = np.zeros((len(accs), len(f)), dtype=complex)
        for force, acc in hits[node]:
            fs_ = np.fft.rfft(force)
            sff = sff + np.abs(fs_) ** 2
            for k in range(len(accs)):
                sxf[k] += np.fft.rfft(acc[k + 1]) * np.conj(fs_)
        h1 = sxf / sff  # (K, f)
        u = np.linalg.lstsq(gmat, h1, rcond=None)[0]  # (3, f): generalised accelerations per newton
        cols.append(u)
        xy = landed[node] if landed else key["hammer_points"][node - 101]["position_m"]
        loads.append(g_vec(xy, com))
    s = 2j * np.pi * f[band]
    res: dict = {"points": len(cols)}
    if len(cols) >= 3:
        u = np.stack(cols, axis=1)[:, :, band]  # (3, P, f)
        b = np.array(loads).T  # (3, P)
        a = np.einsum("ipf,pj->fij", u, np.linalg.pinv(b))  # (f, 3, 3)
        res["reciprocity_median"] = float(np.median(np.linalg.norm(a - np.transpose(a, (0, 2, 1)), axis=(1, 2))
                                                    / np.linalg.norm(a, axis=(1, 2))))
        a = 0.5 * (a + np.transpose(a, (0, 2, 1)))
        d = np.linalg.inv(a) * (s**2)[:, None, None]
        z = d - m[None] * (s**2)[:, None, None]
        basis = np.stack([np.ones_like(s), s], axis=1)
        kc = {}
        for i in range(3):
            for j in range(i, 3):
                sol = np.linalg.lstsq(np.vstack([basis.real, basis.imag]),
                                      np.concatenate([z[:, i, j].real, z[:, i, j].imag]), rcond=None)[0]
                kc[(i, j)] = sol
        res["K"] = {f"{DIRS[i]}" if i == j else f"{DIRS[i]}-{DIRS[j]}": float(v[0]) for (i, j), v in kc.items()}
        res["C"] = {f"{DIRS[i]}" if i == j else f"{DIRS[i]}-{DIRS[j]}": float(v[1]) for (i, j), v in kc.items()}
        kz = kc[(0, 0)][0]
        res["elastic_centre_offset_m"] = [float(-kc[(0, 2)][0] / kz), float(kc[(0, 1)][0] / kz)]
        # the direction's resonance: Re Z_jj and Im Z_jj / w there
        fb = f[band]
        res["at_resonance"] = {}
        for dname in DIRS:
            j = DIRS.index(dname)
            fr = key["directions"][dname]["resonance_hz"]
            sel = np.abs(fb - fr) <= 10.0
            zz = z[sel, j, j]
            w = 2 * np.pi * fb[sel]
            c1 = np.polyfit(fb[sel] - fr, zz.real, 1)[1]
            c2 = np.polyfit(fb[sel] - fr, zz.imag / w, 1)[1]
            res["at_resonance"][dname] = [float(c1), float(c2)]
    else:
        # one column: heave from the struck point, the film taken as uncoupled
        u = cols[0][:, band]
        zz = s**2 / u[0] - m[0, 0] * s**2
        sol = np.linalg.lstsq(np.vstack([np.stack([np.ones_like(s), s], 1).real, np.stack([np.ones_like(s), s], 1).imag]),
                              np.concatenate([zz.real, zz.imag]), rcond=None)[0]
        res["K"] = {"heave": float(sol[0])}
        res["C"] = {"heave": float(sol[1])}
        res["tilt_over_heave_response"] = float(np.abs(u[1:]).max() * 0.1 / np.abs(u[0]).max())
    return res


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=HERE.parents[2] / "out" / "rigid-independent2")
    parser.add_argument("--only", nargs="+")
    parser.add_argument("--landed", action="store_true",
                        help="load vectors from where the hits landed (drawn.json), not the named points")
    args = parser.parse_args(argv)
    out = {}
    for keyfile in sorted((HERE / "keys").glob("*.key.json")):
        key = json.loads(keyfile.read_text())
        name = key["case"]
        if args.only and name not in args.only:
            continue
        landed = landed_points(json.loads((args.data / f"{name}.drawn.json").read_text()), key) \
            if args.landed else None
        res = analyse(key, args.data / f"{name}.uff", landed)
        out[name] = res
        print(name)
        for what in ("K", "C"):
            for term, v in res[what].items():
                if "-" in term:
                    kv = key["couplings"][term][what]
                else:
                    kv = key["directions"][term][what] if key["pad_model"] == "SD" else float("nan")
                print(f"   {what} {term:12s} ref {v:12.6g}  key {kv:12.6g}  {100 * (v / kv - 1) if kv else 0:+7.3f} %")
        if "at_resonance" in res:
            for d, (kr, cr) in res["at_resonance"].items():
                e = key["directions"][d]
                print(f"   at resonance {d:6s} K {kr:12.6g} key {e['K_at_resonance']:12.6g} "
                      f"({100 * (kr / e['K_at_resonance'] - 1):+.3f} %)  C {cr:10.6g} key {e['C_at_resonance']:10.6g} "
                      f"({100 * (cr / e['C_at_resonance'] - 1):+.3f} %)")
        if "elastic_centre_offset_m" in res:
            print("   elastic centre", [round(v * 1e3, 3) for v in res["elastic_centre_offset_m"]], "mm; key",
                  [round(v * 1e3, 3) for v in key["elastic_centre_offset_m"]])
    (args.data / f"reference{'-landed' if args.landed else ''}.json").write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
