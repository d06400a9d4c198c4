"""The result of one identification: parameters, which of them are measurements, uncertainties and fit quality."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike

from gasfilm.analysis.physics.elements import FilmModel, accelerance, parse_network
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2


@dataclass
class FitResult:
    """One identified model: parameters with uncertainties, quality (eq. 33) and how the fit went.

    A parameter (or ``mass_kg``) named in ``at_bound`` ended at, or within 1e-6 relative of, a bound of its search
    range: its value is where the search stopped, not a measurement, and it has no entry in ``std_errors``.

    A fit in its identifiable form (:mod:`~gasfilm.analysis.identification.reduction`) keeps the model's name but
    holds the reduced ``network`` and its parameters only; ``reduced_from`` is then the network asked for, and
    ``notes`` say what was taken out and what an order at a bound means.
    """

    model_name: str
    network: str
    params: dict[str, float]
    std_errors: dict[str, float]  # standard errors in the parameters' units, for the parameters not at a bound
    correlation: np.ndarray  # (P, P) in the order of correlation_names
    correlation_names: tuple[str, ...]
    rms: float  # eq. 33 in (m/s²)/N
    peak_error: float  # max |H_d - H| in (m/s²)/N
    evaluations: int
    wall_time_s: float
    method: str
    flags: tuple[str, ...]
    band_hz: tuple[float, float]
    mass_kg: float
    mass_fitted: bool
    decay_rate_1_s: float
    n_points: int
    at_bound: tuple[str, ...]
    reduced_from: str = ""  # the network asked for, when the data determine only the reduced ``network``
    notes: tuple[str, ...] = ()  # what the reduction took out, orders at 0 or 2: sentences for the reader

    def model(self) -> FilmModel:
        """The fitted network as a model."""
        return parse_network(self.network, self.model_name)

    def accelerance(self, freq_hz: ArrayLike, decay_rate_1_s: float | None = None) -> np.ndarray:
        """The fitted accelerance in (m/s²)/N; by default with the decay rate the fit used."""
        sigma = self.decay_rate_1_s if decay_rate_1_s is None else decay_rate_1_s
        return accelerance(self.model(), self.params, freq_hz, self.mass_kg, sigma)

    def to_dict(self) -> dict:
        """Plain JSON-compatible form for storage."""
        return {
            "model_name": self.model_name,
            "network": self.network,
            "params": dict(self.params),
            "std_errors": dict(self.std_errors),
            "correlation": np.asarray(self.correlation, dtype=float).tolist(),
            "correlation_names": list(self.correlation_names),
            "rms": self.rms,
            "peak_error": self.peak_error,
            "rms_unit": "(m/s^2)/N",  # rms and peak_error; as the diagnosis's JSON, with their g/N twins
            "rms_g_per_n": self.rms / STANDARD_GRAVITY_M_S2,
            "peak_error_g_per_n": self.peak_error / STANDARD_GRAVITY_M_S2,
            "evaluations": self.evaluations,
            "wall_time_s": self.wall_time_s,
            "method": self.method,
            "flags": list(self.flags),
            "band_hz": list(self.band_hz),
            "mass_kg": self.mass_kg,
            "mass_fitted": self.mass_fitted,
            "decay_rate_1_s": self.decay_rate_1_s,
            "n_points": self.n_points,
            "at_bound": list(self.at_bound),
            "reduced_from": self.reduced_from,
            "notes": list(self.notes),
        }

    @classmethod
    def from_dict(cls, data: Mapping) -> "FitResult":
        """Inverse of :meth:`to_dict`."""
        return cls(
            model_name=str(data["model_name"]),
            network=str(data["network"]),
            params={k: float(v) for k, v in data["params"].items()},
            std_errors={k: float(v) for k, v in data["std_errors"].items()},
            correlation=np.asarray(data["correlation"], dtype=float),
            correlation_names=tuple(data["correlation_names"]),
            rms=float(data["rms"]),
            peak_error=float(data["peak_error"]),
            evaluations=int(data["evaluations"]),
            wall_time_s=float(data["wall_time_s"]),
            method=str(data["method"]),
            flags=tuple(data["flags"]),
            band_hz=(float(data["band_hz"][0]), float(data["band_hz"][1])),
            mass_kg=float(data["mass_kg"]),
            mass_fitted=bool(data["mass_fitted"]),
            decay_rate_1_s=float(data["decay_rate_1_s"]),
            n_points=int(data["n_points"]),
            at_bound=tuple(data.get("at_bound", ())),  # absent from fits stored before it was recorded
            reduced_from=str(data.get("reduced_from", "")),  # (likewise)
            notes=tuple(str(note) for note in data.get("notes", ())),
        )
