"""Independent generator of rigid-body hammer tests: a mover on 3 or 4 air pads, one hammer (roving over named
points) and three or four accelerometers, recorded as an NI 9234 records them, written as UFF for ``gasfilm rigid``.

Written by a helper that has not read gasfilm's ``analysis/``, ``app/``, ``drivers/``, ``tests/`` nor
``benchmarks/rigid/independent/`` (only README.md, docs/, the command line's ``--help``, the paper, and the red-team
generators under ``benchmarks/concealed/`` for how a hammer test is synthesised). Imports nothing from gasfilm: numpy,
scipy and pyuff only.

Physics (derived here, see README.md):

* the mover is built from boxes (a plate and payloads): mass m, centre of mass (x_c, y_c, z_c), moments of inertia
  about axes through the centre of mass I_xx = sum m_j (l_y^2 + l_z^2)/12 + m_j ((y_j - y_c)^2 + (z_j - z_c)^2), I_yy
  likewise, and the product I_xy = sum m_j (x_j - x_c)(y_j - y_c);
* generalised coordinates q = [z, theta_x, theta_y] at the centre of mass: a point (x, y) moves vertically by
  w = z + (y - y_c) theta_x - (x - x_c) theta_y = g(x, y)^T q (a right-handed rotation about y lifts points at
  negative x);
* kinetic energy 1/2 (m zdot^2 + omega^T J omega) with J = [[I_xx, -I_xy], [-I_xy, I_yy]]: M = diag(m, J);
* each pad a vertical film Z_i(s) at (x_i, y_i): potential 1/2 sum Z_i w_i^2, so Z(s) = sum Z_i(s) g_i g_i^T;
* a vertical hammer force F at p does virtual work F dw_p = F g_p^T dq: the generalised load is g_p F;
* an accelerometer at k, mounted along d_k z (d_k = +1 or -1), reads d_k g_k^T qddot;
* so H_kp(s) = d_k g_k^T s^2 (Z(s) + M s^2)^-1 g_p, evaluated on the analog grid's FFT lines.

Measurement chain per hit (the red-team rounds' frame, re-written): a half-sine contact force of random peak, width and
sub-sample start on an analog grid 8x the sample rate (with a lead-in), the struck point scattered by 0.5 mm; each
accelerometer's response the exact product of the zero-padded force spectrum with H_kp; white sensor noise per
channel (sensor + the module's 3.1e-7 V/sqrt(Hz) referred to the input); the NI 9234's 0.5 Hz first-order AC
coupling on every channel; the SAME causal elliptic anti-aliasing low-pass (0.02 dB to 0.42 fs, 110 dB from 0.5 fs)
on every channel; every 8th point taken; 24-bit quantisation of +-5 V with each channel's sensitivity.

Output per case (written in this order): ``<case>.key.json`` (the answer key: BEFORE any data), ``<case>.toml`` (the
rig spec a user would give gasfilm: mass, inertia, centre of mass, sensors, hammer points and a *nominal* film that
is deliberately not the truth), ``<case>.uff`` (dataset 164 units, 15 geometry: accelerometer k is node k, hammer
point p node 100 + p; 58 time records per hit: the force at node 100+p, each accelerometer at its node referenced to
100+p, direction 3 or -3 as mounted), ``<case>.drawn.json`` (what was drawn per hit).

    python generate.py [--out OUT] [--only CASE ...] [--keys-only] [--check]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyuff
from scipy import optimize, signal

OVERSAMPLE = 8
LEAD_IN_S = 0.02
PRETRIGGER_S = 0.010
AC_CORNER_HZ = 0.5
LSB_V = 10.0 / 2**24
RANGE_V = 5.0
MODULE_NOISE_V = 3.1e-7  # V/sqrt(Hz), NI 9234 input noise
HAMMER_V_PER_N = 2.25e-3  # PCB 086C03-like
HAMMER_NOISE = 9e-5  # N/sqrt(Hz)
ACCEL_NOISE = 3e-5  # (m/s^2)/sqrt(Hz)
POINT_SCATTER_M = 0.5e-3  # rms of where the hammer really lands about the named point (each axis)
BAND_HZ = (20.0, 1000.0)
DIRECTIONS = ("heave", "roll", "pitch")
PAIRS = (("heave", "roll"), ("heave", "pitch"), ("roll", "pitch"))
#: What the user gives gasfilm as the film: a nominal guess, not the truth (identification must read the data).
NOMINAL_FILM = {"heave": {"k": 2.0e7, "eta": 3000.0}, "roll": {"k": 2.0e5, "eta": 30.0},
                "pitch": {"k": 3.0e5, "eta": 40.0}}
ALU = 2700.0


# ------------------------------------------------------------------------------------------------------- the mover

@dataclass
class Box:
    name: str
    mass_kg: float
    centre_m: tuple  # (x, y, z)
    size_m: tuple  # (lx, ly, lz)


def plate(lx, ly, lz, density=ALU) -> Box:
    return Box("plate", density * lx * ly * lz, (0.0, 0.0, 0.0), (lx, ly, lz))


def rigid_body(boxes: list[Box]) -> dict:
    m = sum(b.mass_kg for b in boxes)
    c = np.sum([b.mass_kg * np.asarray(b.centre_m) for b in boxes], axis=0) / m
    ixx = iyy = ixy = 0.0
    for b in boxes:
        lx, ly, lz = b.size_m
        dx, dy, dz = np.asarray(b.centre_m) - c
        ixx += b.mass_kg * (ly**2 + lz**2) / 12 + b.mass_kg * (dy**2 + dz**2)
        iyy += b.mass_kg * (lx**2 + lz**2) / 12 + b.mass_kg * (dx**2 + dz**2)
        ixy += b.mass_kg * dx * dy
    return {"mass_kg": float(m), "centre_of_mass_m": [float(c[0]), float(c[1]), float(c[2])],
            "inertia_kg_m2": [float(ixx), float(iyy)], "product_of_inertia_kg_m2": float(ixy)}


def mass_matrix(body: dict) -> np.ndarray:
    ixx, iyy = body["inertia_kg_m2"]
    ixy = body["product_of_inertia_kg_m2"]
    return np.array([[body["mass_kg"], 0, 0], [0, ixx, -ixy], [0, -ixy, iyy]], dtype=float)


def g_vec(xy, body: dict) -> np.ndarray:
    xc, yc = body["centre_of_mass_m"][:2]
    return np.array([1.0, xy[1] - yc, -(xy[0] - xc)])


# --------------------------------------------------------------------------------------------------------- films

def film_z(model: str, p: dict, s: np.ndarray) -> np.ndarray:
    """A pad's complex stiffness (N/m) at the Laplace variable s."""
    if model == "SD":
        return p["k"] + p["eta"] * s
    if model == "FOZGF":  # k2 || (k1 -- pot(eta1, alpha))
        with np.errstate(divide="ignore", invalid="ignore"):
            sa = np.where(s == 0, 0.0, s) ** p["alpha"]
            arm = np.where(s == 0, 0.0, p["k1"] * p["eta1"] * sa / (p["k1"] + p["eta1"] * sa))
        return p["k2"] + arm
    raise ValueError(model)


def film_matrix(pads: list[dict], body: dict, s: np.ndarray) -> np.ndarray:
    """Z(s) = sum_i Z_i(s) g_i g_i^T, shape (len(s), 3, 3)."""
    out = np.zeros((len(s), 3, 3), dtype=complex)
    for pad in pads:
        g = g_vec(pad["position_m"], body)
        out += film_z(pad["model"], pad["parameters"], s)[:, None, None] * np.outer(g, g)[None]
    return out


def weighted_sum(pads, body, weight, key):
    """sum_i w(g_i) * parameter_i."""
    return float(sum(weight(g_vec(p["position_m"], body)) * p["parameters"][key] for p in pads))


WEIGHTS = {  # the entry (a, b) of g g^T
    ("heave", "heave"): lambda g: g[0] * g[0], ("roll", "roll"): lambda g: g[1] * g[1],
    ("pitch", "pitch"): lambda g: g[2] * g[2], ("heave", "roll"): lambda g: g[0] * g[1],
    ("heave", "pitch"): lambda g: g[0] * g[2], ("roll", "pitch"): lambda g: g[1] * g[2]}
INDEX = {"heave": 0, "roll": 1, "pitch": 2}


# ---------------------------------------------------------------------------------------------------------- cases

@dataclass
class Case:
    name: str
    summary: str
    boxes: list
    pads: list
    accelerometers: list  # dicts: name, position_m, direction (+1/-1), serial, sensitivity_mv_per_m_s2
    hammer_points: list  # dicts: name, position_m  (all the layout's points, in the spec's order)
    struck: list  # names of the points struck, in order
    seed: int
    rate_hz: float = 12800.0
    record_s: float = 0.5
    hits_per_point: int = 6
    pulse_ms: float = 0.7
    force_n: float = 180.0
    score_heave_only: bool = False  # one point at the centre: roll and pitch are not identified
    heave_biased: bool = False  # one point and a coupled film: heave is documented as biased, not scored
    notes: str = ""


def sd(k, c):
    return {"model": "SD", "parameters": {"k": k, "eta": c}}


def pad(name, x, y, film):
    return {"name": name, "position_m": [x, y], **film}


def accel(name, x, y, serial, sens, direction=+1):
    return {"name": name, "position_m": [x, y], "direction": direction, "serial": serial,
            "sensitivity_mv_per_m_s2": sens}


def fozgf(k1, k2, alpha, corner_hz):
    """A FOZGF pad whose Maxwell arm turns over at corner_hz (eta1 = k1 / omega_c^alpha)."""
    return {"model": "FOZGF", "parameters": {"k1": k1, "k2": k2, "alpha": alpha,
                                             "eta1": k1 / (2 * np.pi * corner_hz) ** alpha}}


def cases() -> list[Case]:
    # body A: aluminium plate 0.36 x 0.32 x 0.04 m and a 12 kg block on its middle
    body_a = [plate(0.36, 0.32, 0.04), Box("payload", 12.0, (0.0, 0.0, 0.045), (0.15, 0.15, 0.05))]
    # body B: aluminium plate 0.40 x 0.30 x 0.05 m and a 10 kg block on its middle
    body_b = [plate(0.40, 0.30, 0.05), Box("payload", 10.0, (0.0, 0.0, 0.05), (0.16, 0.12, 0.05))]
    # body C: body B's plate with a 12 kg block off its middle (centre of mass off the pads' centre, I_xy != 0)
    body_c = [plate(0.40, 0.30, 0.05), Box("payload", 12.0, (0.09, -0.07, 0.05), (0.14, 0.10, 0.05))]
    r = 0.13
    ring3 = [(r * np.cos(a), r * np.sin(a)) for a in np.deg2rad([90.0, 210.0, 330.0])]
    tri_acc = [accel("A1", 0.15, 0.0, "IX3001", 10.31), accel("A2", -0.12, 0.12, "IX3002", 10.14),
               accel("A3", -0.12, -0.13, "IX3003", 10.22)]
    tri_points = [{"name": "centre", "position_m": [0.0, 0.0]}, {"name": "east", "position_m": [0.12, 0.02]},
                  {"name": "north", "position_m": [-0.03, 0.12]}, {"name": "south-east", "position_m": [0.09, -0.10]}]
    tri_offset_pads = [pad("pad 1", 0.14, 0.02, sd(1.5e7, 2200.0)), pad("pad 2", -0.09, 0.12, sd(1.0e7, 1400.0)),
                       pad("pad 3", -0.05, -0.12, sd(0.8e7, 1300.0))]
    tri_offset_acc = [accel("A1", 0.15, 0.0, "IX3001", 10.31), accel("A2", -0.12, 0.12, "IX3002", 10.14, -1),
                      accel("A3", -0.12, -0.13, "IX3003", 10.22)]
    quad_pads = [pad(n, x, y, sd(8.0e6, 1200.0)) for n, x, y in
                 (("front left", -0.16, 0.11), ("front right", 0.16, 0.11), ("rear right", 0.16, -0.11),
                  ("rear left", -0.16, -0.11))]
    quad_acc4 = [accel("A1", 0.18, 0.13, "IX3001", 10.31), accel("A2", -0.18, 0.13, "IX3002", 10.14),
                 accel("A3", -0.18, -0.13, "IX3003", 10.22), accel("A4", 0.18, -0.13, "IX3004", 9.87)]
    quad_points = [{"name": "centre", "position_m": [0.0, 0.0]}, {"name": "east", "position_m": [0.14, 0.0]},
                   {"name": "north", "position_m": [0.0, 0.11]}, {"name": "north-west", "position_m": [-0.10, 0.09]}]
    offset_points = [{"name": "east", "position_m": [0.15, -0.02]}, {"name": "north", "position_m": [0.02, 0.12]},
                     {"name": "south-west", "position_m": [-0.12, -0.10]}]
    frac_pads = [pad(n, x, y, fozgf(9.0e6, 6.0e6, 0.55, 300.0)) for n, x, y in
                 (("front left", -0.15, 0.12), ("front right", 0.15, 0.12), ("rear right", 0.15, -0.12),
                  ("rear left", -0.15, -0.12))]
    return [
        Case("tri-centred", "3 equal SD pads on a ring of 0.13 m about the centre of mass (elastic centre on it); "
             "roving hammer at the centre and three points off it", body_a,
             [pad(f"pad {i + 1}", x, y, sd(1.2e7, 1700.0)) for i, (x, y) in enumerate(ring3)],
             tri_acc, tri_points, [p["name"] for p in tri_points], seed=3401),
        Case("tri-offset", "3 unequal SD pads placed unevenly (elastic centre 19/20 mm off the centre of mass): "
             "heave-roll, heave-pitch and roll-pitch coupled; A2 mounted upside down (-z); roving hammer",
             body_a, tri_offset_pads, tri_offset_acc, tri_points, [p["name"] for p in tri_points], seed=3402),
        Case("quad-centred-4acc", "4 equal SD pads on a 0.32 x 0.22 m rectangle centred on the centre of mass, "
             "four accelerometers (rigidity check), 25.6 kS/s, roving hammer", body_b, quad_pads, quad_acc4,
             quad_points, [p["name"] for p in quad_points], seed=3403, rate_hz=25600.0),
        Case("quad-com-offset", "4 equal SD pads centred on the plate, a payload moving the centre of mass by "
             "(38, -30) mm and giving a product of inertia: every pair coupled; hammer at three points, none at "
             "the centre", body_c, quad_pads, quad_acc4[:3], offset_points, [p["name"] for p in offset_points],
             seed=3404),
        Case("quad-fractional", "4 equal fractional (FOZGF, alpha 0.55) pads on a 0.30 x 0.24 m rectangle centred "
             "on the centre of mass; roving hammer", body_b, frac_pads, quad_acc4[:3], quad_points,
             [p["name"] for p in quad_points], seed=3405),
        Case("tri-offset-centre-only", "tri-offset's coupled rig struck at the centre of mass only (one column): "
             "the coupling must be seen from roll/pitch responses to a heave load; heave is biased by the "
             "coupling (docs), so only the verdict is scored", body_a, tri_offset_pads, tri_offset_acc,
             tri_points, ["centre"], seed=3406, hits_per_point=10, score_heave_only=True, heave_biased=True),
        Case("quad-centred-centre-only", "quad-centred's uncoupled rig (3 accelerometers) struck at the centre of "
             "mass only: heave K and C, no coupling", body_b, quad_pads, quad_acc4[:3], quad_points, ["centre"],
             seed=3407, hits_per_point=10, score_heave_only=True),
    ]


# ------------------------------------------------------------------------------------------------------ the keys

def direction_resonance_hz(case: Case, body: dict, direction: str) -> float:
    """Where Re Z_jj(j w) = M_jj w^2 (the direction's resonance with the other two held still)."""
    j = INDEX[direction]
    mjj = mass_matrix(body)[j, j]

    def f(fhz):
        s = np.array([2j * np.pi * fhz])
        return film_matrix(case.pads, body, s)[0, j, j].real - mjj * (2 * np.pi * fhz) ** 2
    return float(optimize.brentq(f, 1.0, 20000.0))


def band_projection(case: Case, body: dict) -> tuple[np.ndarray, np.ndarray]:
    """K_ab + C_ab s fitted to Z_ab(j w) by unweighted least squares on 1 Hz lines of BAND_HZ (only meaningful as
    an approximation for a fractional film; exact for spring-dampers)."""
    f = np.arange(BAND_HZ[0], BAND_HZ[1] + 0.5, 1.0)
    s = 2j * np.pi * f
    z = film_matrix(case.pads, body, s)
    k = z.real.mean(axis=0)
    c = (z.imag * (2 * np.pi * f)[:, None, None]).sum(axis=0) / ((2 * np.pi * f) ** 2).sum()
    return k, c


def answer_key(case: Case) -> dict:
    body = rigid_body(case.boxes)
    mm = mass_matrix(body)
    models = {p["model"] for p in case.pads}
    assert len(models) == 1
    model = models.pop()
    key = {"case": case.name, "summary": case.summary, "notes": case.notes,
           "coordinates": "q = [heave z (m), roll theta_x (rad), pitch theta_y (rad)] at the centre of mass; "
                          "g(x, y) = [1, y - y_c, -(x - x_c)]",
           "body": {**body, "boxes": [vars(b) for b in case.boxes]},
           "mass_matrix": mm.tolist(), "pad_model": model, "pads": case.pads,
           "accelerometers": case.accelerometers, "hammer_points": case.hammer_points, "struck": case.struck,
           "rate_hz": case.rate_hz, "record_s": case.record_s, "hits_per_point": case.hits_per_point,
           "scored": {"heave": not case.heave_biased, "roll": not case.score_heave_only,
                      "pitch": not case.score_heave_only, "coupling_verdict": True}}
    if model == "SD":
        kmat = np.zeros((3, 3))
        cmat = np.zeros((3, 3))
        for (a, b), w in WEIGHTS.items():
            for mat, par in ((kmat, "k"), (cmat, "eta")):
                mat[INDEX[a], INDEX[b]] = mat[INDEX[b], INDEX[a]] = weighted_sum(case.pads, body, w, par)
    else:  # exact FOZGF per direction when every pad has the same alpha and the same eta1/k1
        kmat, cmat = band_projection(case, body)
        alphas = {p["parameters"]["alpha"] for p in case.pads}
        taus = {round(p["parameters"]["eta1"] / p["parameters"]["k1"], 15) for p in case.pads}
        assert len(alphas) == 1 and len(taus) == 1
        fo = {}
        for d in DIRECTIONS:
            w = WEIGHTS[(d, d)]
            fo[d] = {"k1": weighted_sum(case.pads, body, w, "k1"), "k2": weighted_sum(case.pads, body, w, "k2"),
                     "eta1": weighted_sum(case.pads, body, w, "eta1"),
                     "alpha": case.pads[0]["parameters"]["alpha"]}
        key["fozgf_per_direction"] = fo
    key["stiffness_matrix"] = kmat.tolist()
    key["damping_matrix"] = cmat.tolist()
    units = {"heave": ("N/m", "N*s/m"), "roll": ("N*m/rad", "N*m*s/rad"), "pitch": ("N*m/rad", "N*m*s/rad")}
    directions = {}
    for d in DIRECTIONS:
        j = INDEX[d]
        f_ref = direction_resonance_hz(case, body, d)
        s_ref = np.array([2j * np.pi * f_ref])
        z_ref = film_matrix(case.pads, body, s_ref)[0, j, j]
        entry = {"K": float(kmat[j, j]), "C": float(cmat[j, j]), "units": units[d], "inertia": float(mm[j, j]),
                 "resonance_hz": f_ref, "K_at_resonance": float(z_ref.real),
                 "C_at_resonance": float(z_ref.imag / (2 * np.pi * f_ref))}
        if model != "SD":
            entry["K"] = entry["K_at_resonance"]  # a fractional film: its storage stiffness and its damping
            entry["C"] = entry["C_at_resonance"]  # (Im Z / w) at the direction's resonance
            entry["K_C_meaning"] = "Re Z_jj and Im Z_jj / w at the direction's resonance (fractional film)"
        else:
            entry["K_C_meaning"] = "K_jj and C_jj of the layout (exact: spring-damper pads)"
        directions[d] = entry
    key["directions"] = directions
    couplings = {}
    for a, b in PAIRS:
        ia, ib = INDEX[a], INDEX[b]
        rk = abs(kmat[ia, ib]) / np.sqrt(kmat[ia, ia] * kmat[ib, ib])
        rc = abs(cmat[ia, ib]) / np.sqrt(cmat[ia, ia] * cmat[ib, ib])
        exact_zero = abs(kmat[ia, ib]) < 1e-9 * np.sqrt(kmat[ia, ia] * kmat[ib, ib]) and \
            abs(cmat[ia, ib]) < 1e-9 * np.sqrt(cmat[ia, ia] * cmat[ib, ib])
        # designed so that every pair is either exactly uncoupled or clearly coupled (>= 4 % of sqrt(Kaa Kbb))
        assert exact_zero or rk >= 0.04, (case.name, a, b, rk)
        couplings[f"{a}-{b}"] = {"K": float(kmat[ia, ib]), "C": float(cmat[ia, ib]), "K_relative": float(rk),
                                 "C_relative": float(rc), "exists": not exact_zero}
    key["couplings"] = couplings
    key["coupling_exists"] = any(c["exists"] for c in couplings.values())
    kzz = kmat[0, 0]
    key["elastic_centre_offset_m"] = [float(-kmat[0, 2] / kzz), float(kmat[0, 1] / kzz)]  # (dx_e, dy_e)
    # undamped natural frequencies of the coupled body (information)
    lam = np.linalg.eigvals(np.linalg.solve(mm, kmat))
    key["undamped_natural_hz"] = sorted(float(np.sqrt(abs(v)) / (2 * np.pi)) for v in lam.real)
    key["nominal_film_given_to_gasfilm"] = NOMINAL_FILM
    return key


# --------------------------------------------------------------------------------------------- the rig spec (TOML)

def fmt(v: float) -> str:
    return repr(float(v))


def rig_toml(case: Case) -> str:
    body = rigid_body(case.boxes)
    ixx, iyy = body["inertia_kg_m2"]
    lines = [f'name = "{case.name} (independent2): layout, sensors, hammer points; nominal film (not the truth)"',
             f"mass_kg = {fmt(body['mass_kg'])}", "",
             "[film]", 'model = "SD"', "[film.parameters]",
             f"k = {fmt(NOMINAL_FILM['heave']['k'])}", f"eta = {fmt(NOMINAL_FILM['heave']['eta'])}", "",
             "[rigid_body]", f"inertia_kg_m2 = [{fmt(ixx)}, {fmt(iyy)}]",
             f"product_of_inertia_kg_m2 = {fmt(body['product_of_inertia_kg_m2'])}",
             f"centre_of_mass_m = [{fmt(body['centre_of_mass_m'][0])}, {fmt(body['centre_of_mass_m'][1])}]",
             f'hammer_point = "{case.struck[0]}"', ""]
    for d in ("roll", "pitch"):
        lines += [f"[rigid_body.{d}]", 'model = "SD"',
                  f"parameters = {{ k = {fmt(NOMINAL_FILM[d]['k'])}, eta = {fmt(NOMINAL_FILM[d]['eta'])} }}", ""]
    for a in case.accelerometers:
        lines += ["[[rigid_body.accelerometers]]", f'name = "{a["name"]}"',
                  f"position_m = [{fmt(a['position_m'][0])}, {fmt(a['position_m'][1])}]",
                  f'direction = "{"+z" if a["direction"] > 0 else "-z"}"', f'serial = "{a["serial"]}"',
                  f"sensitivity_mv_per_m_s2 = {fmt(a['sensitivity_mv_per_m_s2'])}", ""]
    for p in case.hammer_points:
        lines += ["[[rigid_body.hammer_points]]", f'name = "{p["name"]}"',
                  f"position_m = [{fmt(p['position_m'][0])}, {fmt(p['position_m'][1])}]", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------- synthesis

def nextpow2(n: int) -> int:
    return 1 << int(np.ceil(np.log2(n)))


def anti_aliasing(rate_hz: float):
    fine = OVERSAMPLE * rate_hz
    order, wn = signal.ellipord(0.42 * rate_hz, 0.5 * rate_hz, 0.02, 110, fs=fine)
    return signal.ellip(order, 0.02, 110, wn, btype="low", output="sos", fs=fine)


def accelerance_matrix(case: Case, body: dict, s: np.ndarray) -> np.ndarray:
    """A(s) = s^2 (Z(s) + M s^2)^-1, shape (len(s), 3, 3); 0 at s = 0."""
    d = film_matrix(case.pads, body, s) + mass_matrix(body)[None] * (s**2)[:, None, None]
    a = np.zeros_like(d)
    nz = s != 0
    a[nz] = np.linalg.inv(d[nz]) * (s[nz] ** 2)[:, None, None]
    return a


def half_sine(t, start, width, peak):
    u = (t - start) / width
    return np.where((u >= 0) & (u <= 1), peak * np.sin(np.pi * np.clip(u, 0, 1)), 0.0)


def synthesise(case: Case, noise: bool = True, scatter_m: float = POINT_SCATTER_M):
    """Per hit: (point name, point index, record start s, force record, accelerometer records (k, n)); drawn."""
    body = rigid_body(case.boxes)
    rng = np.random.default_rng(case.seed)
    fs = case.rate_hz
    fine = OVERSAMPLE * fs
    samples = int(round(case.record_s * fs))
    lead = int(round(LEAD_IN_S * fine))
    n = lead + samples * OVERSAMPLE
    t = (np.arange(n) - lead) / fine
    nfft = nextpow2(2 * n)
    s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fine)
    amat = accelerance_matrix(case, body, s)
    gk = np.array([a["direction"] * g_vec(a["position_m"], body) for a in case.accelerometers])  # (K, 3)
    rows = np.einsum("kj,fjl->fkl", gk, amat)  # (f, K, 3): d_k g_k^T A(s)
    sos = anti_aliasing(fs)
    hp = signal.butter(1, AC_CORNER_HZ, btype="high", output="sos", fs=fine)
    f_noise = np.hypot(HAMMER_NOISE, MODULE_NOISE_V / HAMMER_V_PER_N) * np.sqrt(fine / 2)
    sens = np.array([a["sensitivity_mv_per_m_s2"] * 1e-3 for a in case.accelerometers])
    a_noise = np.hypot(ACCEL_NOISE, MODULE_NOISE_V / sens) * np.sqrt(fine / 2)
    index = {p["name"]: i for i, p in enumerate(case.hammer_points)}
    hits, drawn = [], []
    clock = 1.5
    for point in case.struck:
        xy0 = np.asarray(case.hammer_points[index[point]]["position_m"], dtype=float)
        clock += 20.0  # the technician moves to the point
        for _ in range(case.hits_per_point):
            peak = float(np.clip(case.force_n * (1 + 0.2 * rng.standard_normal()), 0.5 * case.force_n,
                                 1.5 * case.force_n))
            width = case.pulse_ms * 1e-3 * rng.uniform(0.9, 1.1)
            t0 = PRETRIGGER_S + rng.uniform(0, 1 / fs)
            xy = xy0 + scatter_m * rng.standard_normal(2)
            force = half_sine(t, t0, width, peak)
            spec = np.fft.rfft(force, nfft)
            gp = g_vec(xy, body)
            resp = np.fft.irfft(spec[:, None] * (rows @ gp), nfft, axis=0)[:n].T  # (K, n)
            level = 1.0 if noise else 0.0
            chans = np.vstack([force[None], resp])
            chans[0] += level * f_noise * rng.standard_normal(n)
            chans[1:] += level * a_noise[:, None] * rng.standard_normal(resp.shape)
            chans = signal.sosfilt(hp, chans, axis=1)
            chans = signal.sosfilt(sos, chans, axis=1)[:, lead::OVERSAMPLE][:, :samples]
            steps = np.concatenate([[LSB_V / HAMMER_V_PER_N], LSB_V / sens])
            volts = np.abs(chans).max(axis=1) * np.concatenate([[HAMMER_V_PER_N], sens])
            assert volts.max() < RANGE_V, (case.name, volts)
            chans = np.clip(np.round(chans / steps[:, None]), -2**23, 2**23 - 1) * steps[:, None]
            start = clock
            hits.append((point, index[point], start, chans[0], chans[1:]))
            drawn.append({"point": point, "start_s": round(start, 6), "peak_force_n": round(peak, 2),
                          "pulse_width_ms": round(width * 1e3, 4), "pulse_start_in_record_s": round(t0, 7),
                          "landed_at_m": [round(float(xy[0]), 5), round(float(xy[1]), 5)],
                          "peak_volts": [round(float(v), 3) for v in volts]})
            clock += case.record_s + rng.uniform(1.5, 3.0)
    return hits, drawn


def write_uff(path: Path, case: Case, hits: list) -> None:
    sets = [pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0,
                              temp_offset=273.15)]
    nodes = [k + 1 for k in range(len(case.accelerometers))] + [101 + p for p in range(len(case.hammer_points))]
    xy = [a["position_m"] for a in case.accelerometers] + [p["position_m"] for p in case.hammer_points]
    sets.append(pyuff.prepare_15(node_nums=nodes, def_cs=[0] * len(nodes),
                                 disp_cs=[0] * len(nodes), color=[1] * len(nodes),
                                 x=[float(v[0]) for v in xy], y=[float(v[1]) for v in xy], z=[0.0] * len(nodes)))
    dt = 1.0 / case.rate_hz

    def record(id1, number, rsp_node, rsp_dir, ref_node, dtype, unit, start, values):
        return pyuff.prepare_58(
            binary=1, id1=id1, id2="independent2 generator", id3="NONE", id4="NONE", id5="NONE", func_type=1,
            ver_num=number, load_case_id=0, rsp_ent_name="NONE", rsp_node=rsp_node, rsp_dir=rsp_dir,
            ref_ent_name="NONE", ref_node=ref_node, ref_dir=3, ord_data_type=4, abscissa_spacing=1,
            abscissa_min=start, abscissa_inc=dt, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=dtype, ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
            orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0, z_axis_axis_units_lab="NONE",
            data=np.asarray(values, dtype=float), x=start + np.arange(len(values)) * dt)

    for number, (point, p, start, force, resp) in enumerate(hits, start=1):
        ref = 101 + p
        sets.append(record(f"{case.name} {point} hit {number} force", number, ref, 3, ref, 13, "N", start, force))
        for k, a in enumerate(case.accelerometers):
            sets.append(record(f"{case.name} {point} {a['name']} hit {number} response", number, k + 1,
                               3 * a["direction"], ref, 12, "m/s^2", start, resp[k]))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add", force_double=True)


# ------------------------------------------------------------------------------------------------------- checks

def check(case: Case) -> dict:
    """The synthesis against a time-domain integration of M qdd + C qd + K q = g_p F (spring-damper pads only),
    the accelerance matrix's symmetry (Maxwell-Betti) and, for an equal-pad ring, K_theta = n k r^2 / 2."""
    body = rigid_body(case.boxes)
    out = {}
    if case.pads[0]["model"] == "SD":
        from scipy.integrate import solve_ivp
        key = answer_key(case)
        km, cm, mm = (np.array(key["stiffness_matrix"]), np.array(key["damping_matrix"]),
                      mass_matrix(body))
        fs = case.rate_hz * OVERSAMPLE
        n = int(0.25 * fs)
        t = np.arange(n) / fs
        width, peak, t0 = 0.7e-3, 150.0, 0.002
        gp = g_vec(case.hammer_points[1]["position_m"], body)
        force = half_sine(t, t0, width, peak)
        nfft = nextpow2(8 * n)
        s = 2j * np.pi * np.fft.rfftfreq(nfft, 1 / fs)
        rows = np.einsum("kj,fjl->fkl", np.array([a["direction"] * g_vec(a["position_m"], body)
                                                  for a in case.accelerometers]), accelerance_matrix(case, body, s))
        freq_dom = np.fft.irfft(np.fft.rfft(force, nfft)[:, None] * (rows @ gp), nfft, axis=0)[:n].T
        minv = np.linalg.inv(mm)

        def rhs(tt, y):
            q, v = y[:3], y[3:]
            f = half_sine(np.array([tt]), t0, width, peak)[0]
            return np.concatenate([v, minv @ (gp * f - km @ q - cm @ v)])
        sol = solve_ivp(rhs, (0, t[-1]), np.zeros(6), t_eval=t, rtol=1e-10, atol=1e-14, max_step=1 / fs * 4)
        qdd = np.array([rhs(tt, y)[3:] for tt, y in zip(sol.t, sol.y.T)]).T
        gk = np.array([a["direction"] * g_vec(a["position_m"], body) for a in case.accelerometers])
        time_dom = gk @ qdd
        out["fd_vs_td_rel_error"] = float(np.abs(freq_dom - time_dom).max() / np.abs(time_dom).max())
    s = 2j * np.pi * np.array([50.0, 200.0, 700.0])
    a = accelerance_matrix(case, body, s)
    out["reciprocity_rel"] = float(np.abs(a - np.transpose(a, (0, 2, 1))).max() / np.abs(a).max())
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parent
    parser.add_argument("--out", type=Path, default=here.parents[2] / "out" / "rigid-independent2")
    parser.add_argument("--only", nargs="+", metavar="CASE")
    parser.add_argument("--keys-only", action="store_true", help="write the keys (and rig specs) only")
    parser.add_argument("--keys-dir", type=Path, default=None, help="also copy the keys here (e.g. keys/)")
    parser.add_argument("--check", action="store_true", help="check the synthesis, write no data")
    parser.add_argument("--scatter-mm", type=float, default=POINT_SCATTER_M * 1e3,
                        help="rms scatter of where the hammer lands about its named point, each axis (mm; "
                             "default %(default)s)")
    args = parser.parse_args(argv)
    listed = cases()
    if args.only:
        unknown = set(args.only) - {c.name for c in listed}
        if unknown:
            print(f"--only: unknown case(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        listed = [c for c in listed if c.name in args.only]
    if args.check:
        for case in listed:
            print(case.name, check(case))
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    for case in listed:
        began = time.perf_counter()
        key_text = json.dumps(answer_key(case), indent=1)
        (args.out / f"{case.name}.key.json").write_text(key_text)
        (args.out / f"{case.name}.toml").write_text(rig_toml(case))
        if args.keys_dir is not None:
            args.keys_dir.mkdir(parents=True, exist_ok=True)
            (args.keys_dir / f"{case.name}.key.json").write_text(key_text)
            (args.keys_dir / f"{case.name}.toml").write_text(rig_toml(case))
        if args.keys_only:
            continue
        hits, drawn = synthesise(case, scatter_m=args.scatter_mm * 1e-3)
        time.sleep(0.01)
        write_uff(args.out / f"{case.name}.uff", case, hits)
        (args.out / f"{case.name}.drawn.json").write_text(json.dumps(drawn, indent=1))
        peak = np.max([d["peak_volts"] for d in drawn], axis=0)
        print(f"{case.name:26s} {len(hits):3d} hits {time.perf_counter() - began:5.1f} s, peak V "
              + " ".join(f"{v:.2f}" for v in peak))
    return 0


if __name__ == "__main__":
    sys.exit(main())
