"""Record a session from the simulated NI 9234 playing a rig spec (used by the concealed-data generator)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from gasfilm.analysis.capture import ImpactCapture, TriggerSettings
from gasfilm.analysis.recording import HitRecorder
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import ValidationSettings
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.drivers.interface import ChannelKind, default_hammer_and_accelerometer
from gasfilm.drivers.simulated import SimulatedNI9234

SAMPLE_RATE_HZ = 51200.0 / 4
TRIGGER = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=1.0)
WINDOW = WindowSettings(force_window_ms=4.0, force_taper_ms=0.5, exponential_end_fraction=0.01)


def record_session(
    spec: RigSpec,
    path: Path,
    accepted_hits: int = 20,
    seed: int = 0,
    sample_rate_hz: float = SAMPLE_RATE_HZ,
    trigger: TriggerSettings = TRIGGER,
    window: WindowSettings = WINDOW,
    **device_options: object,
) -> Path:
    """Stream the simulated module until ``accepted_hits`` hits are accepted; every hit is stored in ``path``."""
    config = default_hammer_and_accelerometer(sample_rate_hz)
    device = SimulatedNI9234(RigPlant(spec), seed=seed, pacing="fast", hit_interval_s=(1.5, 2.5), **device_options)
    device.configure(config)
    force_row = config.channel_index(ChannelKind.FORCE)
    response_row = config.channel_index(ChannelKind.ACCELERATION)
    validation = ValidationSettings()
    full_scale = tuple(channel.full_scale_si for channel in config.channels)
    with Session.create(path, config, spec.to_toml(), {"trigger": trigger, "validation": validation,
                                                       "window": window}, overwrite=True,
                        sync_each_hit=False) as session:
        capture = ImpactCapture(trigger, sample_rate_hz, len(config.channels), force_row, response_row)
        recorder = HitRecorder(session, capture, validation, full_scale_si=full_scale)
        buffer = np.empty((len(config.channels), config.chunk_samples))
        with device:
            device.start()
            while recorder.accepted_count < accepted_hits:
                device.read(buffer)
                recorder.feed(buffer, device.status().overload)
    return Path(path)


def windowed_copy(source: Path, target: Path, decay_rate_1_s: float) -> Path:
    """A copy of a session whose every hit record (both channels) was multiplied by ``exp(-σ t)`` from its first
    sample, as a program that exports already windowed time records would deliver them."""
    with Session.open(source) as session:
        hits = session.hits()
        config = session.daq_config
        settings = session.settings
        spec_toml = session.rig_spec_toml
        rate_hz = session.sample_rate_hz
    with Session.create(target, config, spec_toml, settings, overwrite=True, sync_each_hit=False) as copy:
        for stored in hits:
            record = stored.as_hit_record()
            window = np.exp(-decay_rate_1_s * np.arange(record.data.shape[1]) / rate_hz)
            copy.append_hit(replace(record, data=record.data * window), stored.verdict)
    return Path(target)
