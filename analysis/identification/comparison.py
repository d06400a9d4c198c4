"""Comparison of identified models like the paper's Table 2: RMS (eq. 33), peak error, E and E_m against the
spring-damper (eq. 35), AIC and BIC; parameters that ended at a bound are named, since they are not measurements."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from gasfilm.analysis.identification.result import FitResult
from gasfilm.analysis.threads import one_blas_thread
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2


@dataclass(frozen=True)
class ComparisonRow:
    """One row of the Table-2 comparison; errors in (m/s²)/N, E and E_m in % against SD (eq. 35)."""

    rank: int
    model_name: str
    n_parameters: int
    rms: float
    e_percent: float | None
    peak_error: float
    e_m_percent: float | None
    aic: float
    bic: float
    at_bound: tuple[str, ...]  # parameters that ended at a bound: not measurements


@one_blas_thread
def compare_models(fits: Sequence[FitResult], freq_hz: ArrayLike, h: ArrayLike) -> list[ComparisonRow]:
    """Rank fits by RMS (eq. 33) on the given data; E and E_m (eq. 35) against the SD fit when one is present."""
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h, dtype=complex)
    n_real = 2 * len(freq)
    measured = []
    for fit in fits:
        residual = fit.accelerance(freq) - h
        rss = float(np.sum(np.abs(residual) ** 2))
        k = len(fit.params) + int(fit.mass_fitted)
        log_likelihood_term = n_real * math.log(max(rss, 1e-300) / n_real)
        measured.append(
            (fit, math.sqrt(rss / len(freq)), float(np.max(np.abs(residual))), k, log_likelihood_term)
        )
    reference = next((m for m in measured if m[0].model_name == "SD"), None)
    rows = []
    for rank, (fit, rms, peak, k, term) in enumerate(sorted(measured, key=lambda m: m[1]), start=1):
        e = e_m = None
        if reference is not None:
            e = 100.0 * (reference[1] - rms) / reference[1]
            e_m = 100.0 * (reference[2] - peak) / reference[2]
        aic, bic = term + 2 * k, term + k * math.log(n_real)
        rows.append(ComparisonRow(rank, fit.model_name, k, rms, e, peak, e_m, aic, bic, fit.at_bound))
    return rows


def best_by_bic(rows: Sequence[ComparisonRow]) -> ComparisonRow | None:
    """The model the data support best: the lowest BIC (the table itself is ranked by RMS, as the paper's Table 2;
    a model with more parameters may fit a little closer without being worth them)."""
    return min(rows, key=lambda row: row.bic) if rows else None


def format_table2(rows: Sequence[ComparisonRow], units: str = "g/N") -> str:
    """The comparison as a text table in g/N (like the paper's Table 2, ERRATA item 5) or SI ((m/s²)/N), ranked by
    RMS; the lowest BIC is marked and named below. "Params" is the number of identified parameters (the BIC's k)."""
    if units not in ("g/N", "SI"):
        raise SettingError(f"table units '{units}': choose 'g/N' or 'SI'")
    scale, label = (1.0 / STANDARD_GRAVITY_M_S2, "g/N") if units == "g/N" else (1.0, "(m/s²)/N")

    def percent(value: float | None) -> str:
        return "—" if value is None else f"{value:.2f}%"

    header = (
        f"{'#':>2}  {'Model':<10}{'Params':>6}  {'RMS ' + label:>16}  {'E':>9}  {'Peak error ' + label:>22}  "
        f"{'E_m':>9}  {'AIC':>10}  {'BIC':>10}  At bound (not measured)"
    )
    lines = [header, "-" * len(header)]
    best = best_by_bic(rows)
    for row in rows:
        mark = "*" if row is best and len(rows) > 1 else " "
        lines.append(
            f"{row.rank:>2}  {row.model_name:<10}{row.n_parameters:>6}  {row.rms * scale:>16.6g}  "
            f"{percent(row.e_percent):>9}  "
            f"{row.peak_error * scale:>22.6g}  {percent(row.e_m_percent):>9}  {row.aic:>10.1f}  {row.bic:>9.1f}{mark}  "
            f"{', '.join(row.at_bound)}".rstrip()
        )
    if best is not None and len(rows) > 1:
        lines.append(f"ranked by RMS; * lowest BIC: {best.model_name}, the model the data support best "
                     f"(the campaign's best model)")
    return "\n".join(lines)
