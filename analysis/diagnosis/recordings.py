"""Recordings to diagnose and the diagnosis entry point: hits from a session (HDF5) or UFF 58 time records, the
default spec when none is given, and :func:`diagnose` (no files written: the CLI and GUI write what they keep)."""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from gasfilm.analysis.diagnosis.measurement import QualityNote, hit_spectra
from gasfilm.analysis.diagnosis.pipeline import diagnose_spectra
from gasfilm.analysis.diagnosis.result import Diagnosis
from gasfilm.analysis.physics.elements import PAPER_MASS_KG
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import WindowSettings
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


def load_recordings(path: str | Path) -> Recordings:
    """Accepted hits of a gasfilm session (HDF5) or every hit of a UFF 58 file with time records."""
    path = Path(path)
    if path.suffix.lower() in (".uff", ".unv"):
        from gasfilm.analysis.uff import read_uff_time_records

        uff = read_uff_time_records(path)
        times = np.asarray(uff.start_times_s, float)
        notes = []
        if times.size > 1 and np.ptp(times) == 0:
            notes.append(QualityNote("session time", "the UFF records carry no start times: changes during the "
                                     "session (drift, a step) cannot be assessed from these records"))
        return Recordings(uff.records, uff.sample_rate_hz, times, None, None, None, str(path), notes)
    from gasfilm.analysis.session import Session

    with Session.open(path) as session:
        stored = session.hits()
        accepted = [hit for hit in stored if hit.verdict.accepted]
        rejected = [hit for hit in stored if not hit.verdict.accepted]
        if len(accepted) < 2:
            raise SettingError(f"{path}: {len(accepted)} accepted hit(s); the diagnosis needs at least 2")
        records = np.stack([np.stack((hit.data[hit.force_channel], hit.data[hit.response_channel]))
                            for hit in accepted])
        times = np.array([hit.start_time_s + hit.trigger_index / hit.sample_rate_hz for hit in accepted])
        overload = np.stack([hit.overload[[hit.force_channel, hit.response_channel]] for hit in accepted])
        window = session.settings_as("window", WindowSettings)  # missing windows are filled in by hit_spectra
        quality = []
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


def nominal_spec(recordings: Recordings, mass_kg: float) -> RigSpec:
    """A spring-damper film on ``mass_kg`` with k and c read off the recordings' resonance (peak and height)."""
    records = recordings.records
    force = np.fft.rfft(records[:, 0], axis=1)
    response = np.fft.rfft(records[:, 1], axis=1)
    freq_hz = np.fft.rfftfreq(records.shape[-1], 1.0 / recordings.sample_rate_hz)
    h1 = (response * np.conj(force)).sum(axis=0) / (np.abs(force) ** 2).sum(axis=0)
    band = (freq_hz >= 5.0) & (freq_hz <= 0.4 * recordings.sample_rate_hz)
    peak = np.flatnonzero(band)[np.argmax(np.abs(h1[band]))]
    omega = 2 * np.pi * freq_hz[peak]
    return RigSpec.nominal("SD", mass_kg=mass_kg,
                           parameters={"k": mass_kg * omega**2, "eta": omega / np.abs(h1[peak])})


def diagnose(
    source: str | Path | Recordings,
    rig_spec: RigSpec | None = None,
    mass_kg: float | None = None,
    band_hz: tuple[float, float] | None = None,
    progress: Callable[[str], None] = _silent,
) -> Diagnosis:
    """Diagnose a session or UFF file against a rig spec (default: a spring-damper film on ``mass_kg``, its k and c
    then found by the recalibration). Writes nothing: ``Diagnosis.improved`` is the spec to write."""
    recordings = source if isinstance(source, Recordings) else load_recordings(source)
    if rig_spec is None:
        rig_spec = nominal_spec(recordings, mass_kg if mass_kg is not None else PAPER_MASS_KG)
        progress(f"no rig spec given: spring-damper film on {rig_spec.mass_kg:g} kg "
                 f"(k ≈ {rig_spec.film_parameters['k']:.3g} N/m, c ≈ {rig_spec.film_parameters['eta']:.3g} N·s/m "
                 f"from the resonance)")
    elif mass_kg is not None:
        rig_spec = dataclasses.replace(rig_spec, mass_kg=mass_kg)
    spectra = hit_spectra(recordings.records, recordings.sample_rate_hz, recordings.window,
                          hit_times_s=recordings.hit_times_s, overload=recordings.overload, band_hz=band_hz)
    spectra.quality[:0] = recordings.quality
    diagnosis = diagnose_spectra(spectra, rig_spec, progress)
    logger.info("diagnosed %s against %s: %s", recordings.source, rig_spec.name, diagnosis.verdict)
    return diagnosis
