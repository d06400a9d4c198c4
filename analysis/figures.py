"""Figures like the paper's 18 (measured and fitted accelerance) and 19 (fit errors), written as PNG.

Matplotlib figures drawn without pyplot (no backend or global state is touched, no Qt here; PNG goes through Agg);
the GUI draws the same curves live with pyqtgraph. Every function takes plain arrays and
:class:`gasfilm.analysis.identification.FitResult`\\ s and a path, and returns the path written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullFormatter
from numpy.typing import ArrayLike

from gasfilm.analysis.identification import FitResult
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

#: PNG compression of gasfilm's figures: zlib's fastest level (the default level took longer than drawing a plot's
#: lines, for files a third smaller).
FAST_PNG = {"compress_level": 1}
#: A panel's title height (fraction of the axes): where matplotlib puts it when no tick labels are above the axes, as
#: in these figures. Set, it spares matplotlib measuring tick labels to place each title on every draw: 5–10 % of a
#: figure's time, the same pixels.
TITLE_Y = 1.0
UNITS = {"g/N": 1.0 / STANDARD_GRAVITY_M_S2, "SI": 1.0}
UNIT_LABEL = {"g/N": "g/N", "SI": "(m/s²)/N"}


def plain_log_labels(axis: Axis) -> None:
    """A log axis (``axes.xaxis`` or ``axes.yaxis``) labelled in plain numbers (0.001, 1, 100) at its decades:
    matplotlib's default 10ⁿ labels are typeset by its mathtext parser, much of the time a figure takes to draw."""
    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}" if 1e-4 <= value < 1e6
                                           else f"1e{np.log10(value):.0f}"))
    axis.set_minor_formatter(NullFormatter())


def _scale(units: str) -> float:
    if units not in UNITS:
        raise SettingError(f"figure units '{units}': choose 'g/N' or 'SI'")
    return UNITS[units]


def _phase_deg(h: np.ndarray) -> np.ndarray:
    """Phase in degrees within (−90°, 270°]: an accelerance goes from 180° below resonance to 0° above without
    wrapping."""
    return (np.degrees(np.angle(h)) + 90.0) % 360.0 - 90.0


def _save(figure: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # fixed margins (a "tight" layout draws the figure twice) and light PNG compression: a figure is written in a
    # third of the time (issue 32: `fit` took seconds more than its fits)
    figure.savefig(path, dpi=120, format="png", pil_kwargs=FAST_PNG)
    return path


def figure18(
    path: str | Path, freq_hz: ArrayLike, h_measured: ArrayLike, fits: Sequence[FitResult], units: str = "g/N"
) -> Path:
    """Four panels like Figure 18: log10|H|, real part, imaginary part and phase, data and every model."""
    scale = _scale(units)
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex) * scale
    curves = [("measured", h, {"color": "black", "linewidth": 2.0})]
    curves += [(fit.model_name, fit.accelerance(freq) * scale, {"linewidth": 1.0}) for fit in fits]
    figure = Figure(figsize=(12, 8))
    figure.subplots_adjust(left=0.07, right=0.985, bottom=0.07, top=0.91, wspace=0.2, hspace=0.2)
    axes = figure.subplots(2, 2, sharex=True)
    panels = [
        (axes[0, 0], lambda x: np.log10(np.abs(x)), f"log10 |H| ({UNIT_LABEL[units]})", "(a) log magnitude"),
        (axes[0, 1], np.real, f"Re H ({UNIT_LABEL[units]})", "(b) real part"),
        (axes[1, 0], np.imag, f"Im H ({UNIT_LABEL[units]})", "(c) imaginary part"),
        (axes[1, 1], _phase_deg, "phase (°)", "(d) phase"),
    ]
    for axis, part, label, title in panels:
        for name, values, style in curves:
            axis.plot(freq, part(values), label=name, **style)
        axis.set_ylabel(label)
        axis.set_title(title, y=TITLE_Y)
        axis.grid(True, alpha=0.3)
    for axis in axes[1]:
        axis.set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=8)
    figure.suptitle("Accelerance: measured and fitted models")
    return _save(figure, path)


def figure19(
    path: str | Path, freq_hz: ArrayLike, h_measured: ArrayLike, fits: Sequence[FitResult], units: str = "g/N"
) -> Path:
    """Three panels like Figure 19: |H_d − H|, and the errors of the real and of the imaginary part, per model."""
    scale = _scale(units)
    freq = np.asarray(freq_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex) * scale
    figure = Figure(figsize=(10, 10))
    figure.subplots_adjust(left=0.1, right=0.98, bottom=0.06, top=0.92, hspace=0.25)
    axes = figure.subplots(3, 1, sharex=True)
    for fit in fits:
        error = h - fit.accelerance(freq) * scale
        axes[0].plot(freq, np.abs(error), label=fit.model_name, linewidth=1.0)
        axes[1].plot(freq, error.real, label=fit.model_name, linewidth=1.0)
        axes[2].plot(freq, error.imag, label=fit.model_name, linewidth=1.0)
    unit = UNIT_LABEL[units]
    for axis, label, title in zip(
        axes,
        (f"|H_d − H| ({unit})", f"Re(H_d − H) ({unit})", f"Im(H_d − H) ({unit})"),
        ("(a) error of H", "(b) error of the real part", "(c) error of the imaginary part"),
    ):
        axis.set_ylabel(label)
        axis.set_title(title, y=TITLE_Y)
        axis.grid(True, alpha=0.3)
    axes[2].set_xlabel("frequency (Hz)")
    axes[0].legend(fontsize=8)
    figure.suptitle("Fitting errors of the models")
    return _save(figure, path)
