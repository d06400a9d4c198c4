"""Figures of a rigid-body test, written as PNG (matplotlib without pyplot, as :mod:`gasfilm.analysis.figures`):
each direction's accelerance (the other directions held still) with its fitted models, and every accelerometer's
FRF at every hammer point."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from gasfilm.analysis.figures import _save
from gasfilm.analysis.identification.rigid import RigidIdentification
from gasfilm.analysis.physics.rigid_body import ACCELERATION_UNITS, LOAD_UNITS
from gasfilm.analysis.rigid_frf import RigidFrf


def direction_figure(path: str | Path, rigid: RigidFrf, identification: RigidIdentification) -> Path:
    """|H| and phase of each identified direction's accelerance in the band, measured and fitted."""
    directions = list(identification.directions)
    figure = Figure(figsize=(12, 3.2 * max(1, len(directions))))
    figure.subplots_adjust(left=0.08, right=0.98, bottom=0.06, top=0.95, hspace=0.45, wspace=0.2)
    axes = figure.subplots(max(1, len(directions)), 2, squeeze=False)
    low, high = identification.band_hz
    lines = rigid.readable() & (rigid.freq_hz >= low) & (rigid.freq_hz <= high)
    freq = rigid.freq_hz[lines]
    for row, direction in enumerate(directions):
        measured = rigid.direction_accelerance(direction)[lines]
        load = LOAD_UNITS[direction]
        unit = f"({ACCELERATION_UNITS[direction]})/{load if direction == 'heave' else f'({load})'}"
        magnitude, phase = axes[row]
        magnitude.semilogy(freq, np.abs(measured), color="black", linewidth=2.0, label="measured")
        phase.plot(freq, np.degrees(np.angle(measured)), color="black", linewidth=2.0, label="measured")
        for fit in identification.directions[direction].fits:
            model = fit.accelerance(freq)
            magnitude.semilogy(freq, np.abs(model), linewidth=1.0, label=fit.model_name)
            phase.plot(freq, np.degrees(np.angle(model)), linewidth=1.0, label=fit.model_name)
        magnitude.set_ylabel(f"|H| {unit}")
        magnitude.set_title(f"{direction}: s²/D (the other directions held still)")
        phase.set_ylabel("phase (°)")
        magnitude.legend(fontsize="small")
        for axis in (magnitude, phase):
            axis.grid(True, which="both", alpha=0.3)
            axis.set_xlabel("frequency (Hz)")
    return _save(figure, path)


def channel_figure(path: str | Path, rigid: RigidFrf) -> Path:
    """|H1| and coherence of every accelerometer at every hammer point."""
    figure = Figure(figsize=(12, 3.0 * len(rigid.point_names)))
    figure.subplots_adjust(left=0.08, right=0.98, bottom=0.06, top=0.95, hspace=0.45, wspace=0.2)
    axes = figure.subplots(len(rigid.point_names), 2, squeeze=False)
    for row, (point, frfs) in enumerate(zip(rigid.point_names, rigid.channel_frfs)):
        magnitude, coherence = axes[row]
        for name, frf in zip(rigid.sensor_names, frfs):
            shown = frf.freq_hz > 0
            magnitude.semilogy(frf.freq_hz[shown], np.abs(frf.h1[shown]), linewidth=1.0, label=name)
            coherence.plot(frf.freq_hz[shown], frf.coherence[shown], linewidth=1.0, label=name)
        magnitude.set_title(f"hammer at {point}: H1 per accelerometer")
        magnitude.set_ylabel("|H1| (m/s²)/N")
        coherence.set_ylabel("coherence")
        coherence.set_ylim(0, 1.05)
        magnitude.legend(fontsize="small")
        for axis in (magnitude, coherence):
            axis.set_xlim(0, 0.45 * rigid.sample_rate_hz)
            axis.grid(True, which="both", alpha=0.3)
            axis.set_xlabel("frequency (Hz)")
    return _save(figure, path)
