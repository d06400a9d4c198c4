"""Files a control engineer loads without gasfilm: ``.json`` (state space, transfer function, zeros/poles/gain, the
film, units, band, errors, the source fit), ``.mat`` (A, B, C, D for MATLAB/Octave ``ss``) and ``.npz``.

The plant's input is the force on the mover (N), its output the mover's acceleration (m/s²), time in s; poles and
zeros in rad/s. The state-space form is the numerically sound one; the polynomial transfer function of a high order
model spans many decades of coefficients (it is given for convenience).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io

from gasfilm.analysis.control.rational import Passivity, RationalModel, film_transfer_function
from gasfilm.analysis.jsontext import dumps
from gasfilm.drivers.errors import SettingError

FORMAT = "gasfilm rational plant 1"
SUFFIXES = (".json", ".mat", ".npz")
UNITS = {"input": "force on the mover, N", "output": "mover acceleration, m/s²", "time": "s",
         "poles_zeros": "rad/s", "band": "Hz", "film_stiffness": "N/m", "film_impedance": "N·s/m"}


def _complex_pairs(values: np.ndarray) -> list[list[float]]:
    return [[float(v.real), float(v.imag)] for v in np.asarray(values, dtype=complex)]


def _passivity(check: Passivity) -> dict[str, Any]:
    return {"passed": check.passed, "grid_minimum_relative": check.grid_minimum,
            "crossings_hz": list(check.crossings_hz), "note": check.note}


def state_names(model: RationalModel) -> list[str]:
    names = ["x: mover displacement (m)"] if model.static_stiffness_n_per_m != 0.0 else []
    return names + ["v: mover velocity (m/s)"] + [f"film state {i + 1}" for i in range(model.film_order)]


def model_to_dict(model: RationalModel) -> dict[str, Any]:
    """The whole model as plain JSON-compatible data."""
    num, den = model.transfer_function()
    zeros, poles, gain = model.zpk()
    film_num, film_den = film_transfer_function(model.static_stiffness_n_per_m, model.impedance)
    return {
        "format": FORMAT,
        "description": f"force → acceleration of {model.source.description}, rational approximation by "
                       f"{model.method}",
        "units": UNITS,
        "band_hz": list(model.band_hz),
        "order": model.order,
        "film_order": model.film_order,
        "method": model.method,
        "target_error": model.target_error,
        "max_error_band": model.max_error_band,
        "max_error_plant_band": model.max_error_plant_band,
        "max_error_film_band": model.max_error_film_band,
        "max_error_outside_band": model.max_error_outside,
        "error_definition": "max |G_rational(jω)/G_fractional(jω) − 1| (complex: magnitude and phase) of the "
                            "plant's accelerance and of the film's stiffness; outside = a decade beyond each side",
        "error_grid": model.error_grid,
        "stable": model.stable,
        "film_passive": _passivity(model.passive),
        "film_storage_positive": _passivity(model.storage),
        "state_space": {"A": model.a.tolist(), "B": model.b[:, None].tolist(), "C": [model.c.tolist()],
                        "D": [[model.d]], "states": state_names(model)},
        "transfer_function": {"num": num.tolist(), "den": den.tolist()},
        "zpk": {"zeros": _complex_pairs(zeros), "poles": _complex_pairs(poles), "gain": gain},
        "film": {
            "static_stiffness_n_per_m": model.static_stiffness_n_per_m,
            "stiffness_tf": {"num": film_num.tolist(), "den": film_den.tolist()},
            "impedance_poles": _complex_pairs(model.impedance.poles),
            "impedance_residues": _complex_pairs(model.impedance.residues),
            "impedance_constant_ns_per_m": model.impedance.constant,
            "mass_kg": model.source.mass_kg,
        },
        "source": model.source.description,
        "excluded": list(model.source.excluded),
        "origin": model.source.origin,
    }


def write_model(model: RationalModel, path: str | Path) -> Path:
    """Write the model in the format named by ``path``'s suffix (.json, .mat or .npz)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise SettingError(f"--out {path}: name a .json, .mat or .npz file")
    data = model_to_dict(model)
    if suffix == ".json":
        path.write_text(dumps(data, indent=1) + "\n", encoding="utf-8")
        return path
    arrays = {
        "A": model.a, "B": model.b[:, None], "C": model.c[None, :], "D": np.array([[model.d]]),
        "num": np.asarray(data["transfer_function"]["num"]), "den": np.asarray(data["transfer_function"]["den"]),
        "band_hz": np.asarray(model.band_hz), "order": np.array(model.order),
        "max_error_band": np.array(model.max_error_band), "max_error_outside_band": np.array(model.max_error_outside),
        "mass_kg": np.array(model.source.mass_kg),
    }
    metadata = {key: value for key, value in data.items() if key not in ("state_space", "origin")}
    if suffix == ".mat":
        scipy.io.savemat(path, dict(arrays, description=data["description"], units=json.dumps(UNITS),
                                    metadata=json.dumps(metadata)), do_compression=True)
    else:
        with path.open("wb") as file:
            np.savez(file, **arrays, metadata=np.array(json.dumps(metadata)))
    return path
