"""Before/after figures of a diagnosis (matplotlib, PNG, headless)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from gasfilm.analysis.diagnose import Diagnosis

G_M_S2 = 9.80665


def write_figures(diagnosis: "Diagnosis", out_dir: Path) -> list[str]:
    """``diagnosis-overlay.png`` (H1 recorded, spec as given and improved spec, replayed the same way) and
    ``diagnosis-residual.png`` (noise-weighted residual per frequency before/after, and per hit)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    spectra = diagnosis.spectra
    freq_hz = spectra.freq_hz
    measured = diagnosis.replayed_mean(None)
    given = diagnosis.replayed_mean(diagnosis.given_model)
    improved = diagnosis.replayed_mean(diagnosis.improved_model)

    figure = Figure(figsize=(9, 7))
    FigureCanvasAgg(figure)
    axes = figure.subplots(2, 1, sharex=True)
    for values, label, style in ((measured, "recorded H1", "k-"), (given, "spec as given (replayed)", "C3--"),
                                 (improved, "improved spec (replayed)", "C0:")):
        axes[0].semilogy(freq_hz, np.abs(values) / G_M_S2, style, label=label, lw=1.2)
        axes[1].plot(freq_hz, np.degrees(np.angle(values)), style, lw=1.2)
    for finding in diagnosis.findings:
        for axis in axes:
            axis.axvspan(*finding.band_hz, color="C1", alpha=0.12)
    axes[0].set_ylabel("|H| (g/N)")
    axes[1].set_ylabel("phase (°)")
    axes[1].set_xlabel("frequency (Hz)")
    axes[0].legend(loc="best", fontsize=8)
    axes[0].set_title(f"diagnosis: {diagnosis.verdict} — RMS {diagnosis.rms_before / G_M_S2:.3g} → "
                      f"{diagnosis.rms_after / G_M_S2:.3g} g/N")
    figure.tight_layout()
    overlay = out_dir / "diagnosis-overlay.png"
    figure.savefig(overlay, dpi=110)

    figure = Figure(figsize=(9, 7))
    FigureCanvasAgg(figure)
    axes = figure.subplots(2, 1)
    for model, label, colour in ((diagnosis.given_model, "spec as given", "C3"),
                                 (diagnosis.improved_model, "improved spec", "C0")):
        axes[0].plot(freq_hz, diagnosis.weighted_residual(model), color=colour, lw=1.0, label=label)
    axes[0].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[0].set_yscale("log")
    axes[0].set_xlabel("frequency (Hz)")
    axes[0].set_ylabel("χ² per point (1 = noise)")
    axes[0].legend(fontsize=8)
    per_hit = diagnosis.per_hit_residual(diagnosis.improved_model)
    hit_numbers = spectra.hit_numbers
    axes[1].plot(hit_numbers, diagnosis.per_hit_residual(diagnosis.given_model), "o", color="C3",
                 label="spec as given")
    axes[1].plot(hit_numbers, per_hit, "s", color="C0", label="improved spec")
    axes[1].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[1].set_xlabel("hit")
    axes[1].set_ylabel("χ² per point")
    axes[1].legend(fontsize=8)
    figure.tight_layout()
    residual = out_dir / "diagnosis-residual.png"
    figure.savefig(residual, dpi=110)
    return [str(overlay), str(residual)]
