"""Recordings to diagnose and the diagnosis entry point: hits from a session (HDF5) or UFF 58 time records, the
default spec when none is given, and :func:`diagnose` (no files written: the CLI and GUI write what they keep)."""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from gasfilm.analysis.diagnosis.measurement import (
    AC_COUPLING_HZ,
    HitSpectra,
    QualityNote,
    coarsely_quantised_response,
    default_window,
    hit_spectra,
    without_dc_offsets,
)
from gasfilm.analysis.diagnosis.pipeline import diagnose_spectra
from gasfilm.analysis.diagnosis.restoring import RestoringForce, restoring_force
from gasfilm.analysis.diagnosis.result import Diagnosis
from gasfilm.analysis.diagnosis.structure import LSCF_ORDER, UPPER_RANGE, Structure, read_structure
from gasfilm.analysis.physics.effects import (
    MAX_MODAL_CONSTANT_PER_KG,
    MIN_DAMPING_RATIO,
    AcCoupling,
    ExtraMode,
    Polarity,
    StructureMode,
)
from gasfilm.analysis.physics.elements import get_model
from gasfilm.analysis.physics.spec import MASS_RANGE_KG, RigSpec, film_parameter_range
from gasfilm.analysis.quantities import band_text
from gasfilm.analysis.spectra import (
    READ_MIN_COHERENCE,
    FrfResult,
    WindowSettings,
    compute_frf,
    hammer_band_lines,
    readable_lines,
    resonance_lines,
)
from gasfilm.analysis.threads import one_blas_thread
from gasfilm.drivers.errors import SettingError

logger = logging.getLogger(__name__)


def _silent(message: str) -> None:
    del message


@dataclass
class Recordings:
    """Hits to diagnose: records (hits, 2, samples), force in N and response in m/s², with what is known about them.
    :func:`load_recordings` reads them from a session or a UFF file; any other source can fill one in directly."""

    records: np.ndarray
    sample_rate_hz: float
    hit_times_s: np.ndarray
    window: WindowSettings | None
    overload: np.ndarray | None
    rig_spec_toml: str | None
    source: str
    quality: list[QualityNote] = field(default_factory=list)


def load_recordings(path: str | Path | list[Path]) -> Recordings:
    """Accepted hits of a gasfilm session (HDF5), every hit of a UFF 58 file with time records, or .npy hit records
    (one hit per file, rows time/force/response; a list of paths)."""
    paths = [Path(p) for p in path] if isinstance(path, (list, tuple)) else [Path(path)]
    if paths[0].suffix.lower() == ".npy":
        from gasfilm.analysis.sources import load_source

        source = load_source(paths)
        records = np.stack([hit.data[[hit.force_channel, hit.response_channel]] for hit in source.hits])
        times = np.array([hit.start_time_s for hit in source.hits], float)
        return Recordings(records, source.sample_rate_hz, times, None, None, None,
                          str(paths[0]) if len(paths) == 1 else f"{len(paths)} .npy records in {paths[0].parent}")
    if len(paths) > 1:
        raise SettingError(f"{paths[1]}: several input files are read only as .npy records; give one session or UFF "
                           f"file")
    path = paths[0]
    if path.suffix.lower() in (".uff", ".unv"):
        from gasfilm.analysis.uff import read_uff_time_records

        uff = read_uff_time_records(path)
        times = np.asarray(uff.start_times_s, float)
        notes = [] if uff.length_note is None else [QualityNote("record length", uff.length_note)]
        if times.size > 1 and np.ptp(times) == 0:
            notes.append(QualityNote("session time", "the UFF records carry no start times: changes during the "
                                     "session (drift, a step) cannot be assessed from these records"))
        return Recordings(uff.records, uff.sample_rate_hz, times, None, None, None, str(path), notes)
    from gasfilm.analysis.session import Session

    with Session.open(path) as session:
        stored = session.hits()
        accepted = [hit for hit in stored if hit.verdict.accepted]
        rigid_note = _one_hammer_point(session, accepted)
        if rigid_note is not None:  # a rigid-body test's roving hammer: its spec describes one point's hits
            accepted, note = rigid_note
        rejected = [hit for hit in stored if not hit.verdict.accepted]
        if len(accepted) < 2:
            raise SettingError(f"{path}: {len(accepted)} accepted hit(s); the diagnosis needs at least 2")
        records = np.stack([np.stack((hit.data[hit.force_channel], hit.data[hit.response_channel]))
                            for hit in accepted])
        times = np.array([hit.start_time_s + hit.trigger_index / hit.sample_rate_hz for hit in accepted])
        overload = np.stack([hit.overload[[hit.force_channel, hit.response_channel]] for hit in accepted])
        window = session.settings_as("window", WindowSettings)  # missing windows are filled in by hit_spectra
        quality = [] if rigid_note is None else [note]
        if rejected:
            reasons: dict[str, int] = {}
            for hit in rejected:
                for reason in hit.verdict.reasons or ("by the user",):
                    reasons[reason] = reasons.get(reason, 0) + 1
            summary = ", ".join(f"{reason}: {count}" for reason, count in sorted(reasons.items()))
            quality.append(QualityNote("rejected hits", f"{len(rejected)} hit(s) rejected in the session ({summary}); "
                                       f"only accepted hits are compared", hits=tuple(h.index for h in rejected)))
        return Recordings(records, session.sample_rate_hz, times, window, overload, session.rig_spec_toml,
                          str(path), quality)


def _one_hammer_point(session: Any, accepted: list) -> tuple[list, QualityNote] | None:
    """A rigid-body session struck at several points: the hits at its spec's point (those its one-FRF view, the
    first accelerometer for that point, describes) and a note saying so; None for any other session."""
    from gasfilm.analysis.rigid_session import hits_at_spec_point, hits_by_point, session_spec

    spec = session_spec(session)
    if spec is None or len(hits_by_point(spec, session.settings, accepted)) < 2:
        return None
    kept = hits_at_spec_point(spec, session.settings, accepted)
    return kept, QualityNote("hammer points", f"a roving rigid-body test: the {len(kept)} hits at hammer point "
                             f"{spec.rigid_body.hammer_point} are compared (the spec's first accelerometer there; "
                             f"`gasfilm rigid` reads every point)")


#: Above the film resonance by this factor, |H1| approaches the mass line 1/m (within ~10 % at 3×).
MASS_LINE_FROM = 3.0
#: Lines this close (relative) to another resonance are left out of the mass-line reading.
MASS_LINE_CLEARANCE = 0.1
#: A structure with at least this many resonances above the film's is described in the start (one extra mode each);
#: a single further resonance is left to the diagnosis, which tests it as a candidate extra mode against the noise.
MULTI_MODE_MIN = 2
#: At most this many extra modes (the strongest) in a start read off the FRF; weaker ones are left to the diagnosis.
MAX_START_MODES = 6


def _low_coherence_hint(frf: FrfResult) -> str:
    """What a coherence below 0.9 across the whole hammer band suggests, or nothing when it is not that low."""
    band = hammer_band_lines(frf)
    coherence = np.nan_to_num(frf.coherence[band])
    if not band.any() or np.median(coherence) >= READ_MIN_COHERENCE:
        return ""
    return (f": the coherence is {np.median(coherence):.2f} (median) across the hammer's band, so the response is not "
            f"driven by the recorded force alone — check that each force record is paired with its own response "
            f"(an export that shifted the records), the channels and the sensors")


def read_start(recordings: Recordings, mass_kg: float | None = None) -> tuple[RigSpec, str]:
    """The starting spec read off the recordings' FRF when no rig spec is known, and what was read, in words
    (:func:`read_start_with_structure` without the structure reading)."""
    spec, text, _ = read_start_with_structure(recordings, mass_kg)
    return spec, text


def read_start_with_structure(
    recordings: Recordings, mass_kg: float | None = None
) -> tuple[RigSpec, str, Structure | None]:
    """The starting spec read off the recordings' FRF when no rig spec is known, what was read, in words, and the
    structure reading (modes, stabilization diagram) when it is a measured structure (else None).

    Only readable lines count (:func:`gasfilm.analysis.spectra.readable_lines`: the usable band of the hammer and
    coherence ≥ 0.9), never a noise peak. The lowest resonance is the mover on its film (a spring-damper: k = m·ω²,
    c from the peak height less the exponential window's damping); the mass is ``mass_kg`` or, without it, read off
    the mass line 1/|H1| well above that resonance; every further resonance in the band is an extra mode riding on
    the mover when there are at least :data:`MULTI_MODE_MIN` of them (its own frequency at the antiresonance below
    the peak, its mass from their spacing; one alone is left to the diagnosis to test as a candidate). Raises
    :class:`SettingError` (one line) when no resonance or mass can be read: a start that cannot be read is not
    recalibrated into parameters at their bounds.

    A recording whose |H1| is flat below its first resonance (a mass line), or whose FRF is not a driving point (the
    imaginary part of the accelerance changes sign: modal constants of both signs), is a measured structure
    (:func:`_read_structure`)."""
    records, rate_hz = recordings.records, recordings.sample_rate_hz
    window = recordings.window
    fallback = default_window(records, rate_hz)
    if window is None or window.force_window_ms is None or window.exponential_end_fraction is None:
        window = WindowSettings(
            force_window_ms=(window.force_window_ms if window else None) or fallback.force_window_ms,
            force_taper_ms=window.force_taper_ms if window else fallback.force_taper_ms,
            exponential_end_fraction=(window.exponential_end_fraction if window else None)
            or fallback.exponential_end_fraction)
    frf = compute_frf(records, rate_hz, window)
    readable = readable_lines(frf)
    resonances = sorted(resonance_lines(frf))
    left_out = _outlier_hits(records, rate_hz, window, frf) if not resonances else []
    if left_out:  # a minority of disturbed hits (spliced, struck elsewhere) can spoil the coherence of all
        frf = compute_frf(np.delete(records, left_out, axis=0), rate_hz, window)
        readable = readable_lines(frf)
        resonances = sorted(resonance_lines(frf))
    if not resonances:
        band = band_text(frf.freq_hz[readable][0], frf.freq_hz[readable][-1]) if readable.any() else "no line of it"
        raise SettingError(f"{recordings.source}: no resonance can be read off the FRF in the band the hammer "
                           f"excites with coherence ≥ 0.9 ({band}){_low_coherence_hint(frf)}; give the rig spec "
                           f"with --rig")
    freq_hz, magnitude, sigma = frf.freq_hz, np.abs(frf.h1), frf.decay_rate_1_s
    if mass_kg is None:
        if _mass_line_below(freq_hz, magnitude, readable, float(freq_hz[resonances[0]])):
            return _read_structure(recordings, frf, readable, resonances,
                                   f"below its first clear resonance ({freq_hz[resonances[0]]:.0f} Hz) the FRF is flat "
                                   f"as a mass line, not rising as a mover on a film")
        if _transfer_frf(frf.h1, readable):
            return _read_structure(recordings, frf, readable, resonances,
                                   "the FRF is not a driving point (its imaginary part changes sign: modal constants "
                                   "of both signs), not a mover on a film")
    main = resonances[0]
    main_hz = float(freq_hz[main])
    how = "--mass"
    if mass_kg is None:
        clear = readable & (freq_hz >= MASS_LINE_FROM * main_hz)
        for line in resonances[1:]:
            clear &= np.abs(freq_hz - freq_hz[line]) > MASS_LINE_CLEARANCE * freq_hz[line]
        if np.count_nonzero(clear) < 5:
            raise SettingError(f"{recordings.source}: the mass cannot be read off the FRF (no clean line above "
                               f"{MASS_LINE_FROM:g}× the resonance at {main_hz:.0f} Hz inside the hammer's band); "
                               f"give --mass or --rig")
        mass_kg = _mass_from_line(frf.h1[clear], freq_hz[clear], sigma)
        how = f"mass line above {MASS_LINE_FROM * main_hz:.0f} Hz"
    modes = []
    further = resonances[1:] if len(resonances) - 1 >= MULTI_MODE_MIN else []
    quantised = coarsely_quantised_response(records)
    if quantised:  # the quantiser's distortion makes peaks of its own, the same in every hit
        further = []
    further = sorted(sorted(further, key=lambda line: -magnitude[line])[:MAX_START_MODES])
    for line in further:
        previous = resonances[resonances.index(line) - 1]
        between = np.arange(previous + 1, line)
        dip = int(between[np.argmin(magnitude[between])]) if between.size else line
        peak_hz = float(freq_hz[line])
        own_hz = float(freq_hz[dip]) if dip != line else peak_hz / 1.01
        ratio = min(max((peak_hz / own_hz) ** 2 - 1.0, 1e-4), 0.2)
        zeta = max(_half_power_width_hz(freq_hz, magnitude, line) / (2 * peak_hz) - sigma / (2 * np.pi * peak_hz),
                   2 * MIN_DAMPING_RATIO)
        modes.append(ExtraMode(freq_hz=own_hz, damping_ratio=min(zeta, 0.05), mass_kg=ratio * mass_kg))
    total_kg = mass_kg + sum(mode.mass_kg for mode in modes)
    omega = 2 * np.pi * main_hz
    damping = max(omega / magnitude[main] - 2 * total_kg * sigma, 1e-4 * total_kg * omega)
    spec = RigSpec.nominal("SD", mass_kg=mass_kg, parameters={"k": total_kg * omega**2, "eta": damping},
                           effects=modes)
    spec = dataclasses.replace(spec, name=f"read off the FRF of {Path(recordings.source).name}")
    text = (f"resonance at {main_hz:.1f} Hz inside the hammer's band (force within 20 dB, coherence ≥ 0.9, "
            f"{band_text(freq_hz[readable][0], freq_hz[readable][-1])}): spring-damper film k ≈ "
            f"{spec.film_parameters['k']:.3g} N/m, c ≈ {damping:.3g} N·s/m on {mass_kg:.4g} kg ({how})")
    if quantised and len(resonances) > 1:
        text += (f"; the response is coarsely quantised, so the further peaks near "
                 + ", ".join(f"{freq_hz[line]:.0f}" for line in sorted(resonances[1:]))
                 + " Hz may be the quantiser's distortion: they are left to the diagnosis, whose replay is quantised "
                   "the same way")
    if left_out and resonances:
        text += (f"; read from {len(records) - len(left_out)} of {len(records)} hits: hits "
                 + ", ".join(str(i + 1) for i in left_out)
                 + " differ from the others far beyond their scatter (disturbed records) and spoil the coherence")
    if modes:
        text += ("; a multi-mode structure: extra modes at " + ", ".join(f"{mode.freq_hz:.0f}" for mode in modes)
                 + " Hz are part of the start (read, not findings)")
    return spec, text, None


#: A hit is an outlier for the start when its FRF's median relative distance from the hits' median FRF is this many
#: times the hits' median distance; at most OUTLIER_SHARE of the hits are left out.
OUTLIER_DISTANCE = 5.0
OUTLIER_SHARE = 1 / 3


def _outlier_hits(records: np.ndarray, rate_hz: float, window: WindowSettings, frf: FrfResult) -> list[int]:
    """Hits whose own FRF departs from the others' far beyond their scatter, in the hammer's band (a minority)."""
    if len(records) < 4:
        return []
    band = np.flatnonzero(hammer_band_lines(frf))
    per_hit = np.array([compute_frf(records[[index]], rate_hz, window).h1[band] for index in range(len(records))])
    median = np.median(per_hit.real, axis=0) + 1j * np.median(per_hit.imag, axis=0)
    distance = np.median(np.abs(per_hit - median) / np.maximum(np.abs(median), 1e-300), axis=1)
    outliers = np.flatnonzero(distance > OUTLIER_DISTANCE * np.median(distance))
    return [int(i) for i in outliers] if 0 < outliers.size <= OUTLIER_SHARE * len(records) else []


def _mass_from_line(h1: np.ndarray, freq_hz: np.ndarray, decay_rate_1_s: float) -> float:
    """The moving mass (kg) from clean lines above the film's resonance: ``1/H = m + Z(s)/s²`` with the film's
    stiffness ``Z ≈ k + c·s`` over those lines, solved for m, k and c by complex least squares — the film's share,
    which falls only as 1/f² and is still a few per cent at three times the resonance (the median of 1/|H1| there read
    a 25.05 kg mover on the paper's fractional film as 24.3 kg), is fitted instead of ignored. The median of 1/|H1|
    when that fit gives no positive mass."""
    s = decay_rate_1_s + 2j * np.pi * freq_hz
    design = np.column_stack((np.ones_like(s), 1.0 / s**2, 1.0 / s))
    solution, *_ = np.linalg.lstsq(np.concatenate((design.real, design.imag)),
                                   np.concatenate(((1.0 / h1).real, (1.0 / h1).imag)), rcond=None)
    return float(solution[0]) if solution[0] > 0 else float(1.0 / np.median(np.abs(h1)))


#: Below its first resonance a mover on a film rises as ω² (log-log slope 2); a slope under this is a mass line.
MASS_LINE_SLOPE = 1.0
#: The mover's suspension in a structure read off the FRF resonates this far below the lowest readable line.
SUSPENSION_BELOW = 0.2


def _mass_line_below(freq_hz: np.ndarray, magnitude: np.ndarray, readable: np.ndarray, first_hz: float) -> bool:
    """Whether |H1| is flat (a mass line, log-log slope < :data:`MASS_LINE_SLOPE`) below the first resonance, where a
    mover on its film would rise as ω²."""
    below = readable & (freq_hz <= 0.5 * first_hz)
    if np.count_nonzero(below) < 5:
        return False
    slope = np.polyfit(np.log(freq_hz[below]), np.log(magnitude[below]), 1)[0]
    return bool(slope < MASS_LINE_SLOPE)


#: An FRF whose imaginary part has the minority sign over more than this share of its size (Σ|Im H1| on the
#: readable lines) is not a driving point: a driving point's accelerance keeps Im H ≥ 0 (a passive structure).
TRANSFER_SHARE = 0.2


def _transfer_frf(h1: np.ndarray, readable: np.ndarray) -> bool:
    """Whether the FRF is a transfer FRF (not a driving point): its imaginary part changes sign over more than
    :data:`TRANSFER_SHARE` of it, as modal constants of both signs make it."""
    imaginary = h1[readable].imag
    total = float(np.sum(np.abs(imaginary)))
    if total <= 0:
        return False
    minority = min(float(np.sum(imaginary[imaginary > 0])), float(-np.sum(imaginary[imaginary < 0])))
    return minority > TRANSFER_SHARE * total


def _read_structure(
    recordings: Recordings, frf, readable: np.ndarray, resonances: list[int], why: str
) -> tuple[RigSpec, str, Structure]:
    """A start for a measured structure (:mod:`.structure`): its modes beside a residual mass line with the response
    polarity, the upper residual as a mode above the band; the mover's suspension (a spring-damper film) is the soft
    support read in the band, else it resonates below the band, so that in band the mover is that mass line."""
    freq_hz = frf.freq_hz
    lines = np.flatnonzero(readable)
    structure = read_structure(freq_hz, frf.h1, frf.coherence, frf.decay_rate_1_s, lines,
                               [float(freq_hz[line]) for line in resonances], int(frf.n_averages))
    mass_kg = float(np.clip(structure.mass_kg, MASS_RANGE_KG[0], MASS_RANGE_KG[1]))
    effects: list = ([Polarity(channel="acceleration")] if structure.polarity < 0 else []) + structure.modes
    if structure.upper_residual is not None:
        effects.append(structure.upper_residual)
    if structure.suspension is not None:
        suspension_hz, zeta = structure.suspension
        omega = 2 * np.pi * suspension_hz
        parameters = {"k": mass_kg * omega**2, "eta": 2 * zeta * mass_kg * omega}
    else:
        omega = 2 * np.pi * max(SUSPENSION_BELOW * float(freq_hz[lines[0]]), 0.5)
        parameters = {"k": max(mass_kg * omega**2, 1e2), "eta": max(0.1 * mass_kg * omega, 1e-2)}
    parameters = {name: float(np.clip(value, *film_parameter_range(get_model("SD"), name, mass_kg)))
                  for name, value in parameters.items()}
    spec = RigSpec.nominal("SD", mass_kg=mass_kg, parameters=parameters, effects=effects)
    spec = dataclasses.replace(spec, name=f"structure read off the FRF of {Path(recordings.source).name}")
    suspension_hz = np.sqrt(spec.film_parameters["k"] / mass_kg) / (2 * np.pi)
    text = (f"{why}: a structure read as modal analysis does (LSCF poles over {2 * LSCF_ORDER} model orders, stable in "
            f"frequency, damping and participation; LSFD constants with lower and upper residuals, "
            f"{band_text(freq_hz[lines[0]], freq_hz[lines[-1]])}), {len(structure.modes)} modes at "
            + ", ".join(f"{frequency:.0f}" for frequency in sorted(mode.freq_hz for mode in structure.modes))
            + f" Hz beside a mass line of {mass_kg:.4g} kg"
            + (" read with the opposite sign (response polarity −1)" if structure.polarity < 0 else "")
            + ("; a driving point (every modal constant of the mass line's sign)" if structure.driving_point
               else "; a transfer FRF, not a driving point (modal constants of both signs)")
            + (f"; a rigid body on a soft support: the suspension at {suspension_hz:.3g} Hz, read in the band"
               if structure.suspension
               else f", on a suspension resonating below the band ({suspension_hz:.2g} Hz)")
            + ("" if structure.upper_residual is None else
               f"; the modes above the band as one at {structure.upper_residual.freq_hz:.0f} Hz (upper residual)")
            + ("" if not structure.rejected else
               "; not modes: " + ", ".join(f"{pole.freq_hz:.0f} Hz ({pole.reason})" for pole in structure.rejected))
            + "; read, not findings")
    return spec, text, structure


#: A structure read off the FRF is finished on the diagnosis's own comparison with its poles within this fraction of
#: their frequencies.
POLISH_FREEDOM = 0.01
POLISH_ROUNDS = 3


def polished_structure(spec: RigSpec, spectra: HitSpectra) -> RigSpec:
    """The modes of a structure read off the FRF finished on the comparison the diagnosis makes: the per-hit FRFs
    corrected for the replay on the analysis grid, averaged as H1 with their measured noise (what a spec's χ² measures
    when it is the same for every hit), by variable projection (:func:`.structure._projected`): the mass line's
    level (the mass and the suspension scaled together), each mode's complex constant, and its pole within
    :data:`POLISH_FREEDOM` (a mode above the band, the upper residual, within its range above the band). The reading
    at full resolution placed the poles; the grid only finishes them."""
    from gasfilm.analysis.diagnosis.pipeline import evidence_for
    from gasfilm.analysis.diagnosis.structure import _projected
    from gasfilm.analysis.physics.response import rig_accelerance

    indices = [i for i, effect in enumerate(spec.effects) if effect.type_name == "structure-mode"]
    if not indices or spectra.replay is None:
        return spec
    freq_hz, sigma = spectra.freq_hz, spectra.decay_rate_1_s
    mean, total = evidence_for(spectra, spec).spectra.mean()
    s = sigma + 2j * np.pi * freq_hz
    bare = spec.with_values(effects=[e for i, e in enumerate(spec.effects) if i not in indices])
    base = rig_accelerance(bare, freq_hz, sigma)
    probe_hz = float(np.median(freq_hz))
    probe = StructureMode(freq_hz=probe_hz, damping_ratio=0.1, modal_constant_per_kg=1.0)
    omega = 2 * np.pi * probe_hz
    transfer = ((rig_accelerance(bare.with_values(effects=[*bare.effects, probe]), freq_hz, sigma) - base)
                / (s**2 / (s**2 + 0.2 * omega * s + omega**2)))
    modes = [spec.effects[i] for i in indices]
    top_hz = float(freq_hz[-1])
    hz = np.array([mode.freq_hz for mode in modes])
    zeta = np.array([mode.damping_ratio for mode in modes])
    above = hz > top_hz
    low = np.concatenate((np.where(above, UPPER_RANGE[0] * top_hz, hz * (1 - POLISH_FREEDOM)),
                          np.full(hz.size, MIN_DAMPING_RATIO)))
    high = np.concatenate((np.where(above, np.maximum(UPPER_RANGE[1] * top_hz, hz), hz * (1 + POLISH_FREEDOM)),
                           np.full(hz.size, 0.5)))
    hz, zeta, constants = _projected(s, mean, np.sqrt(total), hz, zeta, low, high, base, transfer)
    if not constants[0] > 0:
        return spec
    limit = MAX_MODAL_CONSTANT_PER_KG
    polished = {index: dataclasses.replace(
        mode, freq_hz=float(hz[k]), damping_ratio=float(zeta[k]),
        modal_constant_per_kg=float(np.clip(constants[1 + k], -limit, limit)) or mode.modal_constant_per_kg,
        quadrature_per_kg=float(np.clip(constants[1 + hz.size + k], -limit, limit)))
        for k, (index, mode) in enumerate(zip(indices, modes))}
    scale = float(constants[0])  # the mass line's level: the mass and the suspension's coefficients over it
    mass_kg = float(np.clip(spec.mass_kg / scale, *MASS_RANGE_KG))
    film = {name: float(np.clip(value / scale, *film_parameter_range(spec.film, name, mass_kg, spec.film_parameters)))
            if name in _coefficients(spec) else value for name, value in spec.film_parameters.items()}
    candidate = dataclasses.replace(spec, mass_kg=mass_kg, film_parameters=film,
                                    effects=[polished.get(i, effect) for i, effect in enumerate(spec.effects)])
    return candidate


def _coefficients(spec: RigSpec) -> set[str]:
    """The film's coefficients (springs, dashpots, spring-pot coefficients): scaled with the mass, the film's
    accelerance keeps its shape and scales by the inverse."""
    return {parameter.name for parameter in spec.film.parameters if parameter.scale == "log"}


def _half_power_width_hz(freq_hz: np.ndarray, magnitude: np.ndarray, peak: int) -> float:
    """Width (Hz) where |H| stays above peak/√2 around ``peak`` (at least one line)."""
    level = magnitude[peak] / np.sqrt(2.0)
    low = peak
    while low > 0 and magnitude[low - 1] > level:
        low -= 1
    high = peak
    while high < magnitude.size - 1 and magnitude[high + 1] > level:
        high += 1
    return float(max(freq_hz[high] - freq_hz[low], freq_hz[1] - freq_hz[0]))


def starting_spec(
    recordings: Recordings, rig_spec: RigSpec | None, mass_kg: float | None
) -> tuple[RigSpec, str]:
    """The spec to start from, and where it comes from in words: ``rig_spec`` (--rig), else the rig spec the session
    was recorded with, else one read off the FRF (:func:`read_start`); ``mass_kg`` overrides the spec's mass."""
    spec, origin, _ = _starting_spec(recordings, rig_spec, mass_kg)
    return spec, origin


def _starting_spec(
    recordings: Recordings, rig_spec: RigSpec | None, mass_kg: float | None
) -> tuple[RigSpec, str, Structure | None]:
    """:func:`starting_spec` with the structure reading of a start read off the FRF (None otherwise)."""
    if rig_spec is not None:
        origin = f"the given rig spec '{rig_spec.name}'"
    elif recordings.rig_spec_toml:
        rig_spec = RigSpec.from_toml(recordings.rig_spec_toml, f"{recordings.source} rig spec")
        origin = f"the rig spec recorded in the session ('{rig_spec.name}')"
    else:
        spec, text, structure = read_start_with_structure(recordings, mass_kg)
        return spec, f"no rig spec given: a start read off the FRF: {text}", structure
    if mass_kg is not None:
        rig_spec = dataclasses.replace(rig_spec, mass_kg=mass_kg)
        origin += f" with the mass set to {mass_kg:g} kg (--mass)"
    return rig_spec, f"starting from {origin}", None


def film_restoring_force(recordings: Recordings, spectra: HitSpectra, mass_kg: float) -> RestoringForce | None:
    """The film's restoring force from the hits the spectra use, in the band around the recorded resonance."""
    mean, _ = spectra.mean()
    resonance_hz = float(spectra.freq_hz[np.argmax(np.abs(mean))])
    return restoring_force(recordings.records[spectra.hit_numbers], recordings.sample_rate_hz, mass_kg,
                           resonance_hz, (float(spectra.freq_hz[0]), float(spectra.freq_hz[-1])))


def _check_records(recordings: Recordings) -> None:
    """What no diagnosis can start from, said in one line naming the source: fewer than 2 hits, no force recorded."""
    records = np.asarray(recordings.records)
    if records.ndim == 3 and records.shape[1] == 2 and records.shape[0] < 2:
        raise SettingError(f"{recordings.source}: only {records.shape[0]} hit; the diagnosis compares at least 2 hits "
                           f"(3 or more to check the noise against their scatter)")
    if records.ndim == 3 and records.shape[1] == 2 and not np.any(records[:, 0]):
        raise SettingError(f"{recordings.source}: the force records are all zero: no hammer impact was recorded "
                           f"(check the force channel, its wiring and its sensitivity)")


#: How the measurement checks begin a refusal about the records (replaced by the name of their source).
RECORDS_PREFIX = "diagnosis records: "


def named_refusal(source: str, message: str) -> str:
    """A refusal of the measurement checks (:func:`hit_spectra`) naming the file it is about: "diagnosis records: …"
    becomes "<source>: …"; one about a flag (``--band …``) names the flag already and is left as it is."""
    if message.startswith("--") or message.startswith(f"{source}:"):
        return message
    return f"{source}: {message.removeprefix(RECORDS_PREFIX)}"


@one_blas_thread
def diagnose(
    source: str | Path | list[Path] | Recordings,
    rig_spec: RigSpec | None = None,
    mass_kg: float | None = None,
    band_hz: tuple[float, float] | None = None,
    progress: Callable[[str], None] = _silent,
    check_loop: bool = False,
) -> Diagnosis:
    """Diagnose a session or UFF file against a rig spec (default: the session's recorded spec, else one read off
    the FRF, :func:`starting_spec`). Writes nothing: ``Diagnosis.improved`` is the spec to write; ``Diagnosis.notes``
    starts with where the starting spec came from. ``check_loop``: the written spec, read back from its TOML, is
    diagnosed again on the same recordings (``Diagnosis.loop``: it must find nothing more)."""
    started = time.monotonic()
    recordings = source if isinstance(source, Recordings) else load_recordings(source)
    _check_records(recordings)
    records, offset_note, response_dc_coupled = without_dc_offsets(recordings.records, recordings.sample_rate_hz)
    if offset_note is not None:
        recordings = dataclasses.replace(recordings, records=records, quality=[*recordings.quality, offset_note])
    read_off_frf = rig_spec is None and not recordings.rig_spec_toml
    try:
        spectra = hit_spectra(recordings.records, recordings.sample_rate_hz, recordings.window,
                              hit_times_s=recordings.hit_times_s, overload=recordings.overload, band_hz=band_hz)
    except SettingError as error:
        raise SettingError(named_refusal(recordings.source, str(error))) from None
    rig_spec, origin, structure = _starting_spec(recordings, rig_spec, mass_kg)
    if structure is not None:
        for _ in range(POLISH_ROUNDS):  # each round with the replay correction of the spec it starts from
            rig_spec = polished_structure(rig_spec, spectra)
    if response_dc_coupled:
        rig_spec = rig_spec.with_effects(AcCoupling(channel="force", corner_hz=AC_COUPLING_HZ))
    progress(origin)
    spectra.quality[:0] = recordings.quality
    # (a rigid body's accelerometer does not read the film's force as F − m·a: its rotation is in it)
    restoring = None if rig_spec.rigid_body is not None else film_restoring_force(recordings, spectra,
                                                                                  rig_spec.moving_mass_kg)
    diagnosis = diagnose_spectra(spectra, rig_spec, progress, restoring, structure_read_off_frf=read_off_frf,
                                 recording=Path(recordings.source).name)
    diagnosis.notes.insert(0, origin)
    diagnosis.structure = structure
    if check_loop:
        written = RigSpec.from_toml(diagnosis.improved.to_toml(), source="the written spec")
        progress("the loop: the written spec, read back, diagnosed again on the same recordings")
        again = diagnose_spectra(spectra, written, restoring=restoring, recording=Path(recordings.source).name)
        diagnosis.loop = {"verdict_on_written_spec": again.verdict, "chi2_per_point": again.chi2_per_point_after,
                          "findings": [finding.effect for finding in again.findings],
                          "closed": again.verdict in ("consistent", "parameters-only") and not again.findings}
    if read_off_frf and mass_kg is None and "(mass line" in origin and diagnosis.verdict not in (
            "consistent", "parameters-only"):
        diagnosis.notes.append(f"the moving mass was read off the FRF's mass line ({rig_spec.moving_mass_kg:.4g} kg): "
                               f"a mass read a few per cent off reads as an added mass or a change of the film — give "
                               f"--mass (or --rig) if you know it")
    diagnosis.wall_time_s = time.monotonic() - started  # loading, spectra, start and restoring force included
    logger.info("diagnosed %s against %s: %s", recordings.source, rig_spec.name, diagnosis.verdict)
    return diagnosis
