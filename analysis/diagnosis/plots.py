"""What a caller keeps of a diagnosis: the improved spec (exactly the spec that was fitted) and before/after figures
(matplotlib, PNG, headless)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from gasfilm.analysis.diagnosis.parallel import shared_map
from gasfilm.analysis.diagnosis.pipeline import replayed_mean, residuals
from gasfilm.analysis.diagnosis.restoring import RestoringForce
from gasfilm.analysis.diagnosis.result import Diagnosis
from gasfilm.analysis.physics.elements import laplace_variable
from gasfilm.analysis.physics.response import rig_dynamic_stiffness
from gasfilm.analysis.diagnosis.structure import STABILITY, Structure
from gasfilm.analysis.figures import FAST_PNG, TITLE_Y, plain_log_labels
from gasfilm.analysis.paths import written_whole
from gasfilm.analysis.threads import one_blas_thread
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2 as G_M_S2


#: The files :func:`write_outputs` writes into its folder.
SPEC_FILE = "improved-rig.toml"
OVERLAY_FILE = "diagnosis-overlay.png"
RESIDUAL_FILE = "diagnosis-residual.png"
RESTORING_FILE = "diagnosis-restoring-force.png"
STABILIZATION_FILE = "diagnosis-stabilization.png"
FILM_FILE = "diagnosis-film.png"
OUTPUT_FILES = (SPEC_FILE, OVERLAY_FILE, RESIDUAL_FILE, RESTORING_FILE, STABILIZATION_FILE, FILM_FILE)
#: How the stabilization diagram draws each stability class (:data:`STABILITY`): marker, size, colour.
STABILITY_STYLE = ((".", 2.0, "0.75"), ("x", 3.0, "C1"), ("+", 4.0, "C2"), ("o", 3.5, "C0"))


def has_film_view(diagnosis: Diagnosis) -> bool:
    """Whether the film's dynamic stiffness is read off the recordings (:func:`film_view`): a film on a point mover,
    not a measured structure or a rigid body."""
    return diagnosis.structure is None and diagnosis.given.rigid_body is None


def figure_files(diagnosis: Diagnosis) -> tuple[str, ...]:
    """The figures a diagnosis draws: the overlay, the residual, with a restoring force its figure, with a structure
    read off the FRF its stabilization diagram, and else (a film on a point mover) the film's dynamic stiffness."""
    files = [OVERLAY_FILE, RESIDUAL_FILE]
    if has_film_view(diagnosis):
        files.append(FILM_FILE)
    if diagnosis.restoring_force is not None:
        files.append(RESTORING_FILE)
    if diagnosis.structure is not None:
        files.append(STABILIZATION_FILE)
    return tuple(files)


def write_figures(diagnosis: Diagnosis, paths: dict[str, Path]) -> list[str]:
    """The figures :func:`figure_files` names, each to the path ``paths`` gives its name: ``diagnosis-overlay.png``
    (H1 recorded, spec as given and improved spec, replayed the same way), ``diagnosis-residual.png``
    (noise-weighted residual per frequency before/after, and per hit), ``diagnosis-restoring-force.png``,
    ``diagnosis-stabilization.png`` and ``diagnosis-film.png`` (the film's dynamic stiffness, measured and
    modelled); drawn by two processes at once (:func:`shared_map`: each figure is the same file either way)."""
    drawers: dict[str, Callable[[Path], Path]] = {
        OVERLAY_FILE: lambda path: write_overlay_figure(diagnosis, path),
        RESIDUAL_FILE: lambda path: write_residual_figure(diagnosis, path),
        FILM_FILE: lambda path: write_film_figure(diagnosis, path),
        RESTORING_FILE: lambda path: write_restoring_force_figure(diagnosis.restoring_force, path),
        STABILIZATION_FILE: lambda path: write_stabilization_figure(diagnosis.structure, path)}
    drawings: list[Callable[[], Path]] = [
        (lambda draw=drawers[name], path=paths[name]: draw(path)) for name in figure_files(diagnosis)]
    written = shared_map(lambda draw: draw(), drawings)
    for path in written:
        if isinstance(path, Exception):
            raise path
    return [str(path) for path in written]


def film_view(diagnosis: Diagnosis) -> dict[str, np.ndarray]:
    """The film's dynamic stiffness ``Z(s) = F/X − M s² = s²/H − M s²`` read off the recordings (H1 at the analysis
    lines, ``s = σ + jω``, M the written spec's moving mass) with its one-σ uncertainty (``sigma``, of each of its
    real and imaginary parts), against what the specs give — the paper's K(ω) = Re Z and C(ω) = Im Z/ω (eqs. 19–20).
    ``apparent``: what the written spec's whole accelerance implies the same way (channel terms and modes beside the
    mover included, so it follows the recordings); ``written_film``: its film with the terms acting on the mover —
    where the two differ, the written spec puts the mismatch outside the film."""
    spectra = diagnosis.spectra
    s = laplace_variable(spectra.freq_hz, spectra.decay_rate_1_s)
    mass_kg = diagnosis.improved.moving_mass_kg
    measured, weight = spectra.mean()

    def from_accelerance(h: np.ndarray) -> np.ndarray:
        return s**2 / h - mass_kg * s**2

    def film(spec) -> np.ndarray:
        return rig_dynamic_stiffness(spec, s) - spec.moving_mass_kg * s**2

    return {"freq_hz": spectra.freq_hz, "omega_rad_s": 2 * np.pi * spectra.freq_hz,
            "measured": from_accelerance(measured),
            "sigma": np.abs(s**2 / measured**2) * np.sqrt(1.0 / np.maximum(weight, 1e-300)),
            "apparent": from_accelerance(replayed_mean(spectra, diagnosis.improved)),
            "given_film": film(diagnosis.given), "written_film": film(diagnosis.improved)}


def written_film_label(diagnosis: Diagnosis, view: dict[str, np.ndarray]) -> str:
    """The film figure's name for the written spec's ``F/X − M·s²``: the film, or the film and what rides on the
    mover (an extra mode, an added mass: they are in it too, and a film drawn with their peaks looks resonant)."""
    improved = diagnosis.improved
    plain_film = improved.film.stiffness(laplace_variable(view["freq_hz"], diagnosis.spectra.decay_rate_1_s),
                                         improved.film_parameters)
    if np.allclose(view["written_film"], plain_film, rtol=1e-9, atol=0.0):
        return "written spec: film"
    return "written spec: film and what rides on the mover"


@dataclass(frozen=True)
class FilmPart:
    """One part of the film's dynamic stiffness against frequency, as the film figure and the GUI draw it: the
    stiffness K(ω) = Re Z (N/m) or the damping C(ω) = Im Z / ω (N·s/m), the paper's eqs. 19–20 (:func:`film_view`)."""

    name: str  # "stiffness K" or "damping C"
    unit: str  # "N/m" or "N·s/m"
    recorded: np.ndarray  # read off the recordings
    two_sigma: np.ndarray  # its ±2σ half-width
    given_film: np.ndarray  # the film of the spec as given
    written_film: np.ndarray  # the written spec's film (and what rides on the mover: :func:`written_film_label`)
    apparent: np.ndarray  # the written spec as a whole (channel terms and modes beside the mover included)

    def view_range(self) -> tuple[float, float]:
        """The range shown: the recorded values' 2nd to 98th percentile and half as much again on either side (a
        line near an antiresonance of the chain, where Z is undetermined, does not flatten the rest)."""
        low, high = np.percentile(self.recorded, [2, 98])
        margin = 0.5 * (high - low) + 1e-12
        return float(low - margin), float(high + margin)


#: The film figure's curves in words (the written spec's film is named by :func:`written_film_label`).
FILM_CURVE_LABELS = {"band": "recorded ±2σ", "recorded": "recorded", "given_film": "film as given",
                     "apparent": "written spec: whole chain"}


def film_parts(diagnosis: Diagnosis) -> tuple[np.ndarray, tuple[FilmPart, FilmPart], str]:
    """Frequencies (Hz), the film's stiffness K(ω) and damping C(ω) (:class:`FilmPart`) and the written spec's film's
    name: what ``diagnosis-film.png`` draws and the GUI's Diagnose tab shows (:func:`film_view`)."""
    view = film_view(diagnosis)
    omega = view["omega_rad_s"]
    parts = tuple(
        FilmPart(name, unit, recorded=part(view["measured"]) * scale, two_sigma=2 * view["sigma"] * np.abs(scale),
                 given_film=part(view["given_film"]) * scale, written_film=part(view["written_film"]) * scale,
                 apparent=part(view["apparent"]) * scale)
        for name, unit, part, scale in (("stiffness K", "N/m", np.real, 1.0),
                                        ("damping C", "N·s/m", np.imag, 1.0 / omega)))
    return view["freq_hz"], parts, written_film_label(diagnosis, view)


def write_film_figure(diagnosis: Diagnosis, path: Path) -> Path:
    """The view an air-bearing engineer reads (the paper's K(ω) and C(ω), eqs. 19–20): the film's stiffness and
    damping measured (±2σ) against the spec as given, the written spec's film, and what the written spec as a whole
    implies (:func:`film_parts`)."""
    freq_hz, parts, written_label = film_parts(diagnosis)
    figure = Figure(figsize=(9, 7))
    FigureCanvasAgg(figure)
    axes = figure.subplots(2, 1, sharex=True)
    for axis, part in zip(axes, parts):
        axis.fill_between(freq_hz, part.recorded - part.two_sigma, part.recorded + part.two_sigma, color="0.8",
                          label=FILM_CURVE_LABELS["band"])
        axis.plot(freq_hz, part.recorded, "k-", lw=1.0, label=FILM_CURVE_LABELS["recorded"])
        axis.plot(freq_hz, part.given_film, "C3--", lw=1.2, label=FILM_CURVE_LABELS["given_film"])
        axis.plot(freq_hz, part.written_film, "C0-", lw=1.2, label=written_label)
        axis.plot(freq_hz, part.apparent, "C1:", lw=1.2, label=FILM_CURVE_LABELS["apparent"])
        axis.set_ylabel(f"{part.name} ({part.unit})")
        axis.set_xscale("log")
        plain_log_labels(axis.xaxis)
        axis.set_ylim(*part.view_range())
    axes[1].set_xlabel("frequency (Hz)")
    axes[0].legend(loc="best", fontsize=8)
    axes[0].set_title(f"the film's dynamic stiffness F/X − M·s² (M = {diagnosis.improved.moving_mass_kg:.4g} kg): "
                      f"{diagnosis.verdict}", fontsize=10, y=TITLE_Y)
    figure.subplots_adjust(left=0.11, right=0.97, bottom=0.08, top=0.94, hspace=0.2)
    figure.savefig(path, dpi=110, pil_kwargs=FAST_PNG)
    return path


def write_overlay_figure(diagnosis: Diagnosis, path: Path) -> Path:
    """H1 recorded, the spec as given and the improved spec replayed the same way: magnitude and phase."""
    spectra = diagnosis.spectra
    freq_hz = spectra.freq_hz
    measured = replayed_mean(spectra, None)
    given = replayed_mean(spectra, diagnosis.given)
    improved = replayed_mean(spectra, diagnosis.improved)

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
    plain_log_labels(axes[0].yaxis)
    axes[0].set_ylabel("|H| (g/N)")
    axes[1].set_ylabel("phase (°)")
    axes[1].set_xlabel("frequency (Hz)")
    axes[0].legend(loc="best", fontsize=8)
    axes[0].set_title(f"diagnosis: {diagnosis.verdict} — RMS {diagnosis.rms_before / G_M_S2:.3g} → "
                      f"{diagnosis.rms_after / G_M_S2:.3g} g/N", y=TITLE_Y)
    figure.subplots_adjust(left=0.1, right=0.97, bottom=0.08, top=0.94, hspace=0.28)  # (tight_layout draws twice)
    figure.savefig(path, dpi=110, pil_kwargs=FAST_PNG)
    return path


def write_residual_figure(diagnosis: Diagnosis, path: Path) -> Path:
    """χ² per point of the spec as given and of the improved spec, per frequency (unexplained bands shaded) and per
    hit."""
    spectra = diagnosis.spectra
    freq_hz = spectra.freq_hz
    figure = Figure(figsize=(9, 7))
    FigureCanvasAgg(figure)
    axes = figure.subplots(2, 1)
    given_residuals = residuals(diagnosis, diagnosis.given)
    improved_residuals = residuals(diagnosis, diagnosis.improved)
    for (per_frequency, _), label, colour in ((given_residuals, "spec as given", "C3"),
                                             (improved_residuals, "improved spec", "C0")):
        axes[0].plot(freq_hz, per_frequency, color=colour, lw=1.0, label=label)
    for item in diagnosis.unexplained:
        axes[0].axvspan(*item.band_hz, color="C3", alpha=0.10)
    axes[0].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[0].set_yscale("log")
    plain_log_labels(axes[0].yaxis)
    axes[0].set_xlabel("frequency (Hz)")
    axes[0].set_ylabel("χ² per point (1 = noise)")
    axes[0].legend(fontsize=8)
    hit_numbers = spectra.hit_numbers + 1  # numbered from 1, as everywhere the user sees
    axes[1].plot(hit_numbers, given_residuals[1], "o", color="C3", label="spec as given")
    axes[1].plot(hit_numbers, improved_residuals[1], "s", color="C0", label="improved spec")
    axes[1].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[1].set_xlabel("hit")
    axes[1].xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[1].set_ylabel("χ² per point")
    axes[1].legend(fontsize=8)
    figure.subplots_adjust(left=0.1, right=0.97, bottom=0.08, top=0.94, hspace=0.28)  # (tight_layout draws twice)
    figure.savefig(path, dpi=110, pil_kwargs=FAST_PNG)
    return path


def write_restoring_force_figure(restoring: RestoringForce, path: Path) -> Path:
    """The film's restoring force F − m·a of every hit's free decay: its stiffness section (r − c·v against x) and
    damping section (r − k·x against v), coloured by hit, with the linear film and the best catalogue shape."""
    figure = Figure(figsize=(10, 4.8))
    FigureCanvasAgg(figure)
    axes = figure.subplots(1, 2)
    sections = restoring.sections()
    x_um, v_mm_s, hit = sections.displacement_um, sections.velocity_mm_s, sections.hit_index
    stiffness_part, damping_part = sections.stiffness_part_n, sections.damping_part_n
    k, c = restoring.stiffness_n_per_m, restoring.damping_ns_per_m
    colours = matplotlib.colormaps["viridis"](np.linspace(0.0, 1.0, int(hit.max()) + 1))
    for number in np.unique(hit):  # one line of pixel markers per hit: far faster than a coloured scatter
        rows = hit == number
        axes[0].plot(x_um[rows], stiffness_part[rows], ".", ms=1.5, color=colours[number])
        axes[1].plot(v_mm_s[rows], damping_part[rows], ".", ms=1.5, color=colours[number])
    x_line = np.linspace(x_um.min(), x_um.max(), 50)
    v_line = np.linspace(v_mm_s.min(), v_mm_s.max(), 50)
    axes[0].plot(x_line, k * x_line * 1e-6, "k--", lw=1, label=f"linear film k = {k:.3g} N/m")
    axes[1].plot(v_line, c * v_line * 1e-3, "k--", lw=1, label=f"linear film c = {c:.3g} N·s/m")
    axes[0].set_xlabel("displacement x (µm)")
    axes[0].set_ylabel("r − c·v (N)")
    axes[1].set_xlabel("velocity v (mm/s)")
    axes[1].set_ylabel("r − k·x (N)")
    for axis in axes:
        axis.legend(loc="upper left", fontsize=8)
        axis.grid(True, lw=0.3)
    best = restoring.best
    verdict = (f"shape: {best.name} (χ² gain {best.chi2_gain:.0f}, {100 * best.share:.0f} % of the linear misfit)"
               if best is not None else "linear within the noise (no catalogue shape stands out)")
    figure.suptitle(f"film restoring force r = F − m·a, {restoring.band_hz[0]:.0f}–{restoring.band_hz[1]:.0f} Hz, "
                    f"colour = hit — {verdict}", fontsize=9)
    figure.subplots_adjust(left=0.08, right=0.98, bottom=0.12, top=0.9, wspace=0.25)
    figure.savefig(path, dpi=110, pil_kwargs=FAST_PNG)
    return path


def write_stabilization_figure(structure: Structure, path: Path) -> Path:
    """``diagnosis-stabilization.png`` of a structure read off the FRF (:func:`stabilization_figure`)."""
    figure = stabilization_figure(structure.to_dict(), structure.diagram.frf_freq_hz, structure.diagram.frf_magnitude)
    figure.savefig(path, dpi=110, pil_kwargs=FAST_PNG)
    return path


def stabilization_figure(reading: dict, frf_freq_hz: np.ndarray | None = None,
                         frf_magnitude: np.ndarray | None = None) -> Figure:
    """The stabilization diagram of a structure read off the FRF (``reading``: :meth:`Structure.to_dict`, as stored
    with a diagnosis): every LSCF pole by frequency and model order, marked by its stability (new; stable in
    frequency; and damping; and participation), the modes read as lines, over |H1| ((m/s²)/N) when given."""
    diagram = reading["stabilization"]
    order, freq_hz = np.asarray(diagram["order"], float), np.asarray(diagram["freq_hz"], float)
    stability = np.asarray(diagram["stability"], int)
    band = reading["band_hz"]
    figure = Figure(figsize=(11, 6.5))
    FigureCanvasAgg(figure)
    axis = figure.subplots()
    if frf_freq_hz is not None and frf_magnitude is not None:
        magnitude_axis = axis.twinx()
        inside = (frf_freq_hz >= band[0]) & (frf_freq_hz <= band[1]) & (frf_magnitude > 0)
        magnitude_axis.semilogy(frf_freq_hz[inside], frf_magnitude[inside] / G_M_S2, color="k", lw=0.7)
        plain_log_labels(magnitude_axis.yaxis)
        magnitude_axis.set_ylabel("|H1| (g/N)")
        axis.set_zorder(magnitude_axis.get_zorder() + 1)
        axis.patch.set_visible(False)
    for index, (name, (marker, size, colour)) in enumerate(zip(STABILITY, STABILITY_STYLE)):
        rows = stability == index
        axis.plot(freq_hz[rows], order[rows], marker, ms=size, color=colour, ls="none",
                  mfc="none" if marker == "o" else colour, label=f"{name} ({np.count_nonzero(rows)})")
    for mode in reading.get("modes_read", []):
        axis.axvline(mode["freq_hz"], color="C0", lw=0.6, alpha=0.5)
    if reading.get("suspension_hz"):
        axis.axvline(reading["suspension_hz"], color="C4", lw=1.0, ls="--", label="suspension (soft support)")
    for pole in reading.get("rejected_poles", []):
        axis.axvline(pole["freq_hz"], color="C3", lw=0.8, ls=":")
    if reading.get("rejected_poles"):
        axis.plot([], [], color="C3", lw=0.8, ls=":", label="stable, not a mode (antiresonance, low coherence)")
    axis.set_xlim(*band)
    axis.set_xlabel("frequency (Hz)")
    axis.set_ylabel("model order (LSCF)")
    axis.legend(loc="upper left", fontsize=7, title="poles stable in", title_fontsize=7, framealpha=0.9)
    kind = "driving point" if reading.get("driving_point") else "transfer FRF"
    axis.set_title(f"stabilization diagram: {len(reading.get('modes_read', []))} modes (lines), {kind}, mass line "
                   f"{reading['mass_line_kg']:.4g} kg, polarity {int(reading['polarity']):+d}", fontsize=10, y=TITLE_Y)
    figure.subplots_adjust(left=0.07, right=0.92, bottom=0.09, top=0.94)
    return figure


@one_blas_thread
def write_outputs(diagnosis: Diagnosis, out_dir: Path, figures: bool = True) -> None:
    """Write the improved spec (the spec that was fitted, exactly) and, unless ``figures`` is false, the figures into
    ``out_dir``, all of them or none (a full disk leaves no partial file:
    :func:`~gasfilm.analysis.paths.written_whole`); the paths are kept in ``diagnosis.improved_spec_path`` and
    ``diagnosis.figures``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = (SPEC_FILE, *(figure_files(diagnosis) if figures else ()))
    with written_whole(*(out_dir / name for name in names), what="the diagnosis's files") as temporaries:
        building = dict(zip(names, temporaries))
        header = "".join(f"# {note}\n" for note in diagnosis.notes)
        building[SPEC_FILE].write_text(header + diagnosis.improved.to_toml(), encoding="utf-8")
        if figures:
            write_figures(diagnosis, building)
    diagnosis.improved_spec_path = str(out_dir / SPEC_FILE)
    diagnosis.figures = [str(out_dir / name) for name in names[1:]]


def remove_stale_outputs(diagnosis: Diagnosis, out_dir: Path) -> list[Path]:
    """Remove the files of :data:`OUTPUT_FILES` in ``out_dir`` that this diagnosis did not write (an earlier run's
    restoring-force figure beside a new spec would be read as this run's); no other file is touched. Returns them."""
    written = {Path(path).name for path in [*diagnosis.figures, diagnosis.improved_spec_path] if path}
    removed = []
    for name in OUTPUT_FILES:
        path = out_dir / name
        if name not in written and (path.is_file() or path.is_symlink()):
            path.unlink()
            removed.append(path)
    return removed
