"""A second synthesis of rigid-body hammer tests, by another method than gasfilm's simulator, for
benchmarks/rigid/independent/score.py.

It imports nothing of gasfilm (numpy, scipy and pyuff only) and follows only the documented formats: the rig spec
(docs/rig-spec.md, ``[rigid_body]``) and the rigid-body UFF convention (accelerometer k is node k, hammer point p
node 100 + p, responses referenced to the point struck). Its method: the mover's equations of motion
``M q̈ + C q̇ + K q = g_p F(t)`` (q = [heave, roll, pitch] at the centre of mass) as a continuous state-space system
integrated in the time domain (scipy.signal.lsim, exact for a piecewise-linear force) at 16× the sample rate, a
half-sine hammer pulse, then one linear-phase FIR low-pass on every channel and decimation, then white noise per
channel — where gasfilm's simulator works in the frequency domain. The answers (``keys.json``: the K and C matrices
at the centre of mass the pads imply, per direction and per coupling) are written BEFORE any record is made.

Run: ``.venv/bin/python benchmarks/rigid/independent/generate.py OUT_FOLDER``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pyuff
import scipy.signal

FS_HZ = 6400.0
OVERSAMPLING = 16
RECORD_S = 1.0
PRETRIGGER_S = 0.02
PULSE_S = 0.8e-3
HITS_PER_POINT = 8
FORCE_NOISE_N = 0.02  # rms per sample
ACCELERATION_NOISE_M_S2 = 0.005

CASES = {
    "ring3-centred": {
        "mass_kg": 18.0, "inertia_kg_m2": [0.12, 0.15], "centre_of_mass_m": [0.0, 0.0],
        "pads": [([0.15 * np.cos(a), 0.15 * np.sin(a)], 8.0e6, 1200.0) for a in np.radians([90.0, 210.0, 330.0])],
    },
    "ring3-payload-off": {
        "mass_kg": 18.0, "inertia_kg_m2": [0.12, 0.15], "centre_of_mass_m": [0.015, -0.02],
        "pads": [([0.15 * np.cos(a), 0.15 * np.sin(a)], 8.0e6, 1200.0) for a in np.radians([90.0, 210.0, 330.0])],
    },
    "rect4-centred": {
        "mass_kg": 30.0, "inertia_kg_m2": [0.25, 0.35], "centre_of_mass_m": [0.0, 0.0],
        "pads": [([x, y], 6.0e6, 900.0) for x, y in ((0.12, 0.09), (-0.12, 0.09), (-0.12, -0.09), (0.12, -0.09))],
    },
    "rect4-unequal": {
        "mass_kg": 30.0, "inertia_kg_m2": [0.25, 0.35], "centre_of_mass_m": [0.0, 0.0],
        "pads": [([0.12, 0.09], 7.0e6, 1000.0), ([-0.12, 0.09], 6.0e6, 900.0), ([-0.12, -0.09], 5.0e6, 800.0),
                 ([0.12, -0.09], 6.0e6, 900.0)],
    },
}
SENSORS = [("S1", [0.16, 0.02], 1.0), ("S2", [-0.09, 0.13], -1.0), ("S3", [-0.08, -0.12], 1.0)]
OFF_CENTRE_POINTS = [("P1", [0.10, 0.0]), ("P2", [0.0, 0.08]), ("P3", [-0.07, -0.07])]


def lever_row(x: float, y: float, centre: list[float]) -> np.ndarray:
    """How a vertical displacement at (x, y) follows heave, roll (about x) and pitch (about y) at the centre."""
    return np.array([1.0, y - centre[1], -(x - centre[0])])


def matrices(case: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    centre = case["centre_of_mass_m"]
    stiffness = np.zeros((3, 3))
    damping = np.zeros((3, 3))
    for position, k, c in case["pads"]:
        row = lever_row(*position, centre)
        stiffness += k * np.outer(row, row)
        damping += c * np.outer(row, row)
    mass = np.diag([case["mass_kg"], *case["inertia_kg_m2"]])
    return mass, stiffness, damping


def keys(case: dict) -> dict:
    _, stiffness, damping = matrices(case)
    names = ("heave", "roll", "pitch")
    out = {"directions": {names[i]: {"k": stiffness[i, i], "eta": damping[i, i]} for i in range(3)},
           "couplings": {f"{names[a]}-{names[b]}": {"k": stiffness[a, b], "eta": damping[a, b]}
                         for a, b in ((0, 1), (0, 2), (1, 2))}}
    out["coupled"] = bool(any(abs(v["k"]) > 1e-6 * stiffness[0, 0] for v in out["couplings"].values()))
    return out


def system(case: dict, load: np.ndarray) -> scipy.signal.StateSpace:
    """States [q, q̇]; input F; outputs the three accelerometers' readings."""
    mass, stiffness, damping = matrices(case)
    inverse = np.linalg.inv(mass)
    a = np.block([[np.zeros((3, 3)), np.eye(3)], [-inverse @ stiffness, -inverse @ damping]])
    b = np.concatenate([np.zeros(3), inverse @ load])[:, np.newaxis]
    sensors = np.array([direction * lever_row(*position, case["centre_of_mass_m"])
                        for _, position, direction in SENSORS])
    c = sensors @ np.hstack([-inverse @ stiffness, -inverse @ damping])
    d = (sensors @ inverse @ load)[:, np.newaxis]
    return scipy.signal.StateSpace(a, b, c, d)


def hit_records(case: dict, load: np.ndarray, rng: np.random.Generator, hits: int) -> np.ndarray:
    """(hits, 4, samples): force and the three accelerometers, band-limited, decimated, with noise."""
    fine_hz = FS_HZ * OVERSAMPLING
    samples = int(RECORD_S * FS_HZ)
    extra = 256  # filter settling at both ends, cut away
    time_s = np.arange((samples + 2 * extra) * OVERSAMPLING) / fine_hz
    lowpass = scipy.signal.firwin(16 * OVERSAMPLING + 1, 0.45 * FS_HZ, fs=fine_hz, window=("kaiser", 10.0))
    model = system(case, load)
    out = np.empty((hits, 4, samples))
    for hit in range(hits):
        peak = rng.uniform(150.0, 250.0)
        start = (extra / FS_HZ) + PRETRIGGER_S + rng.uniform(0.0, 1.0 / FS_HZ)
        force = np.where((time_s >= start) & (time_s <= start + PULSE_S),
                         peak * np.sin(np.pi * np.clip(time_s - start, 0.0, PULSE_S) / PULSE_S), 0.0)
        _, response, _ = scipy.signal.lsim(model, force, time_s, interp=True)
        channels = np.vstack([force, response.T])
        filtered = scipy.signal.filtfilt(lowpass, [1.0], channels, axis=1)  # zero phase, the same on every channel
        decimated = filtered[:, ::OVERSAMPLING][:, extra: extra + samples]
        noise = rng.standard_normal(decimated.shape) * np.array(
            [FORCE_NOISE_N, ACCELERATION_NOISE_M_S2, ACCELERATION_NOISE_M_S2, ACCELERATION_NOISE_M_S2])[:, np.newaxis]
        out[hit] = decimated + noise
    return out


def write_uff(path: Path, case: dict, points: list, records: dict) -> None:
    nodes = [(k + 1, position) for k, (_, position, _) in enumerate(SENSORS)]
    nodes += [(101 + p, position) for p, (_, position) in enumerate(points)]
    sets = [pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0,
                              temp_offset=273.15),
            pyuff.prepare_15(node_nums=[n for n, _ in nodes], def_cs=[0] * len(nodes), disp_cs=[0] * len(nodes),
                             color=[1] * len(nodes), x=[p[0] for _, p in nodes], y=[p[1] for _, p in nodes],
                             z=[0.0] * len(nodes))]
    number = 0
    for p, (name, _) in enumerate(points):
        reference = 101 + p
        for hit in records[name]:
            number += 1
            for row in range(4):
                node, direction = (reference, 3) if row == 0 else (row, 3 if SENSORS[row - 1][2] > 0 else -3)
                sets.append(pyuff.prepare_58(
                    binary=0, id1=f"independent {name} hit {number} {'force' if row == 0 else SENSORS[row - 1][0]}",
                    func_type=1, ver_num=number, rsp_node=node, rsp_dir=direction, ref_node=reference, ref_dir=3,
                    abscissa_spacing=1, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
                    ordinate_spec_data_type=13 if row == 0 else 12,
                    ordinate_axis_units_lab="N" if row == 0 else "m/s^2", orddenom_spec_data_type=0,
                    data=hit[row], x=number * 2 * RECORD_S + np.arange(hit.shape[1]) / FS_HZ))
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


def spec_toml(name: str, case: dict, points: list) -> str:
    """The rig spec gasfilm reads the geometry from: mass, inertia, sensors, hammer points, and the pads at their
    positions with a NOMINAL film (equal spring-dampers, not the answer)."""
    lines = [f'name = "independent {name}"', f"mass_kg = {case['mass_kg']}", "", "[rigid_body]",
             f"inertia_kg_m2 = {case['inertia_kg_m2']}", f"centre_of_mass_m = {list(case['centre_of_mass_m'])}",
             f'hammer_point = "{points[0][0]}"', ""]
    for index, (position, _, _) in enumerate(case["pads"], start=1):
        lines += ["[[rigid_body.pads]]", f'name = "pad {index}"', f"position_m = {[float(v) for v in position]}",
                  'model = "SD"', "parameters = { k = 1.0e7, eta = 1000.0 }", ""]
    for name_, position, direction in SENSORS:
        lines += ["[[rigid_body.accelerometers]]", f'name = "{name_}"', f"position_m = {position}",
                  f'direction = "{"+z" if direction > 0 else "-z"}"', ""]
    for name_, position in points:
        lines += ["[[rigid_body.hammer_points]]", f'name = "{name_}"', f"position_m = {list(position)}", ""]
    return "\n".join(lines)


def main() -> None:
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    all_keys = {name: keys(case) for name, case in CASES.items()}
    (out / "keys.json").write_text(json.dumps(all_keys, indent=1), encoding="utf-8")  # the answers first
    rng = np.random.default_rng(20260534)
    for name, case in CASES.items():
        points = [("C", list(case["centre_of_mass_m"]))] + OFF_CENTRE_POINTS
        records = {point: hit_records(case, lever_row(*position, case["centre_of_mass_m"]), rng, HITS_PER_POINT)
                   for point, position in points}
        write_uff(out / f"{name}.uff", case, points, records)
        (out / f"{name}.toml").write_text(spec_toml(name, case, points), encoding="utf-8")
        print(f"{name}: {sum(len(r) for r in records.values())} hits at {len(points)} points -> {out / name}.uff")


if __name__ == "__main__":
    main()
