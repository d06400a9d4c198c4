"""Simulated campaigns: sessions recorded on the simulated NI 9234 over a grid of operating conditions.

The rig spec is played at each operating point (:meth:`~gasfilm.analysis.physics.spec.RigSpec.at_conditions`: its
film laws move the film), hit by the simulated hammer and recorded through the same capture → validation → session
chain as ``gasfilm acquire`` (:class:`~gasfilm.analysis.recording.HitRecorder`), at fast pacing. Used by
``gasfilm demo --campaign``, the tests and ``benchmarks/bench_campaign.py``.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from gasfilm.drivers.errors import GasfilmError

#: Sample rate of simulated campaign sessions in S/s (51 200/4).
SAMPLE_RATE_HZ = 12800.0
#: The demo campaign's grid: 3 supply pressures × 2 gaps.
DEMO_GRID: dict[str, tuple[float, ...]] = {"supply_pressure_mpa": (0.3, 0.4, 0.6), "gap_um": (8.0, 12.0)}
#: The demo campaign's rig: an SD film whose k and c follow supply pressure and gap (docs/rig-spec.md).
DEMO_RIG_PATH = Path(__file__).with_name("demo-rig.toml")
#: Simulated seconds of signal after which a session that still lacks its hits is given up.
MAX_STREAM_S = 120.0


def grid_points(grid: Mapping[str, Sequence[float]]) -> list[dict[str, float]]:
    """Every combination of the grid's values, as conditions tables."""
    keys = list(grid)
    return [dict(zip(keys, values)) for values in itertools.product(*(grid[key] for key in keys))]


def session_name(conditions: Mapping[str, Any], repeat: int = 0) -> str:
    """A file name that says the operating point: ``p0.4mpa_gap8um_r0.h5``-like."""
    parts = []
    for key, value in conditions.items():
        stem, _, unit = key.rpartition("_")
        parts.append(f"{'p' if stem == 'supply_pressure' else stem}{value:g}{unit}")
    return "_".join(parts) + f"_r{repeat}.h5"


def record_session(path: Path, spec: Any, conditions: Mapping[str, Any], hits: int = 4, seed: int = 0,
                   record_s: float = 0.5, sample_rate_hz: float = SAMPLE_RATE_HZ) -> Path:
    """Record ``hits`` accepted hits of ``spec`` played at ``conditions`` into a new session at ``path``
    (``record_s`` seconds per hit at ``sample_rate_hz``, one of the NI 9234's 51 200/n S/s)."""
    import numpy as np

    from gasfilm.analysis.capture import ImpactCapture, TriggerSettings
    from gasfilm.analysis.physics.plant import RigPlant
    from gasfilm.analysis.recording import HitRecorder
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings, session_frf
    from gasfilm.analysis.validation import ValidationSettings
    from gasfilm.drivers import open_device
    from gasfilm.drivers.interface import ChannelKind, default_hammer_and_accelerometer

    played = spec.at_conditions(conditions)
    config = default_hammer_and_accelerometer(sample_rate_hz)
    trigger = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=record_s)
    validation, window = ValidationSettings(), WindowSettings()
    device = open_device("sim", plant=RigPlant(played), seed=seed, pacing="fast",
                         hit_interval_s=(record_s + 0.2, record_s + 0.5))
    device.configure(config)
    force_row = config.channel_index(ChannelKind.FORCE)
    response_row = config.channel_index(ChannelKind.ACCELERATION)
    settings = {"trigger": trigger, "validation": validation, "window": window, "conditions": dict(conditions)}
    with Session.create(path, config, played.to_toml(), settings, actual_sample_rate_hz=device.sample_rate_hz,
                        device_name=device.name, sync_each_hit=False,
                        record_samples=trigger.record_samples(device.sample_rate_hz)) as session:
        capture = ImpactCapture(trigger, device.sample_rate_hz, len(config.channels), force_row, response_row)
        recorder = HitRecorder(session, capture, validation,
                               full_scale_si=[channel.full_scale_si for channel in config.channels])
        block = np.empty((len(config.channels), config.chunk_samples))
        read = 0
        with device:
            device.start()
            while recorder.accepted_count < hits:
                read += device.read(block)
                recorder.feed(block, device.status().overload)
                if read / device.sample_rate_hz > MAX_STREAM_S:
                    raise GasfilmError(f"{path}: {recorder.accepted_count} of {hits} hits accepted after "
                                       f"{MAX_STREAM_S:g} s of simulated signal")
            device.stop()
        accepted = [hit for hit in session.hits() if hit.verdict.accepted]
        session.write_frf(session_frf(accepted, window), hit_indices=session.accepted_indices())
    return path


def record_campaign(folder: Path, spec: Any, grid: Mapping[str, Sequence[float]] = DEMO_GRID, hits: int = 4,
                    repeats: int = 1, seed: int = 0, record_s: float = 0.5, sample_rate_hz: float = SAMPLE_RATE_HZ,
                    on_session: Callable[[Path, dict[str, float]], None] | None = None) -> list[Path]:
    """One session per grid point (× ``repeats``) in ``folder``; each session has its own simulator seed."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for number, (conditions, repeat) in enumerate(itertools.product(grid_points(grid), range(repeats))):
        path = record_session(folder / session_name(conditions, repeat), spec, conditions, hits, seed + number,
                              record_s, sample_rate_hz)
        paths.append(path)
        if on_session:
            on_session(path, conditions)
    return paths
