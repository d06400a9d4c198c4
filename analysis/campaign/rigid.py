"""A campaign of rigid-body tests: each session's heave, roll and pitch films (SD per direction, with σ), its
couplings and elastic centre as columns of its row, and the report's plots of them against the conditions."""

from __future__ import annotations

import html
import math
from typing import Any, Mapping, Sequence

import numpy as np

from gasfilm.analysis.physics.rigid_body import DAMPING_UNITS, DIRECTIONS, STIFFNESS_UNITS

#: The model fitted per direction in a campaign (its stiffness and damping are what the report plots).
RIGID_MODEL = "SD"


def direction_column(direction: str, name: str, sigma: bool = False) -> str:
    unit = STIFFNESS_UNITS[direction] if name == "k" else DAMPING_UNITS[direction]
    return f"rigid.{direction}.{name}{' sigma' if sigma else ''} [{unit}]"


def rigid_columns(spec: Any, settings: Mapping[str, Any], daq_config: Any, hits: Sequence[Any], window: Any,
                  band_hz: tuple[float, float], method: str, seed: int, sample_rate_hz: float) -> dict[str, Any]:
    """The rigid-body columns of a session's row (``rigid.error`` holds one line when they cannot be made)."""
    from gasfilm.analysis.identification.rigid import identify_rigid
    from gasfilm.analysis.rigid_frf import rigid_frf
    from gasfilm.analysis.rigid_session import accelerometer_rows, hits_by_point
    from gasfilm.drivers.errors import GasfilmError

    try:
        grouped = hits_by_point(spec, settings, hits)
        records = {point: np.stack([hit.data for hit in members]) for point, members in grouped.items()}
        rigid = rigid_frf(spec, records, sample_rate_hz, window, hits[0].force_channel,
                          accelerometer_rows(spec, daq_config))
        result = identify_rigid(rigid, (RIGID_MODEL,), band_hz, method, seed=seed)
    except GasfilmError as error:
        return {"rigid.error": str(error).splitlines()[0]}
    row: dict[str, Any] = {"rigid.points": ", ".join(rigid.point_names), "rigid.full_matrix": rigid.full,
                           "rigid.coupling_found": result.coupling_found()}
    for direction in DIRECTIONS:
        fit = result.directions[direction].fit(RIGID_MODEL) if direction in result.directions else None
        for name in ("k", "eta"):
            value = None if fit is None else fit.params[name]
            sigma = None if fit is None else fit.std_errors.get(name)
            row[direction_column(direction, name)] = value
            row[direction_column(direction, name, sigma=True)] = (sigma if sigma is not None and math.isfinite(sigma)
                                                                  else None)
    if result.elastic_centre_offset_m is not None:
        dx, sx, dy, sy = result.elastic_centre_offset_m
        row.update({"rigid.elastic_centre_dx [m]": dx, "rigid.elastic_centre_dx sigma [m]": sx,
                    "rigid.elastic_centre_dy [m]": dy, "rigid.elastic_centre_dy sigma [m]": sy})
    return row


def rigid_figure(rows: Sequence[dict[str, Any]], by: Sequence[str]) -> Any | None:
    """Heave, roll and pitch stiffness and damping against the first condition of ``by`` (1-σ error bars)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x_key = f"condition.{by[0]}"
    usable = [row for row in rows if isinstance(row.get(x_key), (int, float))
              and row.get(direction_column("heave", "k")) is not None]
    if not usable:
        return None
    figure, axes = plt.subplots(2, 3, figsize=(12, 6), squeeze=False)
    x = np.array([row[x_key] for row in usable], float)
    for column, direction in enumerate(DIRECTIONS):
        for line, name in enumerate(("k", "eta")):
            axis = axes[line, column]
            y = np.array([np.nan if row.get(direction_column(direction, name)) is None else
                          row[direction_column(direction, name)] for row in usable])
            sigma = np.array([row.get(direction_column(direction, name, sigma=True)) or 0.0 for row in usable])
            axis.errorbar(x, y, yerr=sigma, fmt="o", ms=4, capsize=3)
            unit = STIFFNESS_UNITS[direction] if name == "k" else DAMPING_UNITS[direction]
            axis.set(xlabel=by[0], ylabel=f"{'K' if name == 'k' else 'C'} ({unit})",
                     title=f"{direction}: {'stiffness' if name == 'k' else 'damping'}")
            axis.grid(True, alpha=0.3)
    figure.tight_layout()
    return figure


def rigid_section(rows: Sequence[dict[str, Any]], by: Sequence[str], png: Any) -> str:
    """The report's rigid-body section ('' when no session is a rigid-body test); ``png`` embeds a figure."""
    if not any(row.get(direction_column("heave", "k")) is not None for row in rows):
        return ""
    figure = rigid_figure(rows, by)
    coupled = sum(1 for row in rows if row.get("rigid.coupling_found"))
    tested = sum(1 for row in rows if row.get("rigid.coupling_found") is not None)
    parts = [f"<h2>Rigid body: heave, roll and pitch against {html.escape(by[0])}</h2>",
             f"<p>{RIGID_MODEL} fitted to each direction's accelerance with the other directions held still "
             f"(gasfilm rigid); error bars 1 σ. Coupling found in {coupled} of {tested} sessions that could tell.</p>"]
    if figure is not None:
        parts.append(png(figure))
    return "".join(parts)
