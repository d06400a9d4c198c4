"""A rigid-body hammer test in a session: its channels, its roving hammer's runs, and its FRFs.

A rig spec with ``[rigid_body]`` (docs/rig-spec.md) is recorded as the hammer on ai0 and the accelerometers on ai1…
in the spec's order (NI 9234: at most three with the hammer). A roving test records one run per hammer point
(``gasfilm acquire --hammer-point P``, ``--append`` for the next point); the session keeps the runs in its setting
``hammer_points``, ``[{"point": name, "first_hit": index}, …]`` (docs/session-format.md): a hit was struck at the
point of the last run that starts at or before it. A session without that setting was struck at its spec's point.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from gasfilm.analysis.physics.rigid_body import RovingPlan
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_frf import RigidFrf, rigid_frf
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import NI9234_CHANNELS, ChannelConfig, ChannelKind, DaqConfig

#: The setting that holds a session's hammer-point runs.
HAMMER_POINTS_SETTING = "hammer_points"
#: The hammer's sensor when a rigid-body test is recorded (the paper's PCB 086C02).
HAMMER_SENSITIVITY_MV_PER_N = 11.2
DEFAULT_ACCELEROMETER_MV_PER_M_S2 = 10.2


def rigid_daq_config(spec: RigSpec, sample_rate_hz: float) -> DaqConfig:
    """The hammer on ai0 and the spec's accelerometers on ai1, ai2, ai3 (IEPE 2 mA, AC), each channel named after
    its accelerometer (and serial number) with its calibrated sensitivity when the spec gives one."""
    body = spec.rigid_body
    if body is None:
        raise SettingError(f"{spec.source}: not a rigid-body rig spec")
    if len(body.accelerometers) > len(NI9234_CHANNELS) - 1:
        raise SettingError(f"{spec.source} [[rigid_body.accelerometers]]: {len(body.accelerometers)} accelerometers; "
                           f"the NI 9234 records the hammer and at most {len(NI9234_CHANNELS) - 1}")
    channels = [ChannelConfig("ai0", ChannelKind.FORCE, HAMMER_SENSITIVITY_MV_PER_N, "mV/N", name="hammer")]
    for index, sensor in enumerate(body.accelerometers, start=1):
        sensitivity = sensor.sensitivity_mv_per_m_s2 or DEFAULT_ACCELEROMETER_MV_PER_M_S2
        name = sensor.name + (f" (s/n {sensor.serial})" if sensor.serial else "")
        channels.append(ChannelConfig(NI9234_CHANNELS[index], ChannelKind.ACCELERATION, sensitivity, "mV/(m/s^2)",
                                      name=name))
    return DaqConfig(channels=tuple(channels), sample_rate_hz=sample_rate_hz)


def roving_plan(settings: Mapping[str, Any]) -> RovingPlan:
    return RovingPlan.from_settings(settings)


def next_point(spec: RigSpec, plan: RovingPlan) -> str | None:
    """The first hammer point of the spec not struck yet in the session (the roving test's next), or None."""
    struck = set(plan.points())
    return next((point for point in spec.rigid_body.point_names if point not in struck), None)


def hits_by_point(spec: RigSpec, settings: Mapping[str, Any], hits: Sequence[Any]) -> dict[str, list[Any]]:
    """A session's hits grouped by the hammer point they were struck at (the ``hammer_points`` setting's runs;
    a session without it was struck at the spec's point)."""
    plan = RovingPlan.from_settings(settings)
    grouped: dict[str, list[Any]] = {}
    for hit in hits:
        grouped.setdefault(plan.point_of_hit(hit.index, spec.rigid_body.hammer_point), []).append(hit)
    return grouped


def hits_at_spec_point(spec: RigSpec, settings: Mapping[str, Any], hits: Sequence[Any]) -> list[Any]:
    """The hits struck at the point the spec is struck at: those a one-FRF view of a roving session compares with
    the spec (its "frf", a diagnosis); every hit for a spec without a rigid body."""
    if spec.rigid_body is None:
        return list(hits)
    return hits_by_point(spec, settings, hits).get(spec.rigid_body.hammer_point, [])


def accelerometer_rows(spec: RigSpec, daq_config: Any) -> list[int]:
    """The rows of the spec's accelerometers in a recording: its acceleration channels in order."""
    rows = [row for row, channel in enumerate(daq_config.channels)
            if ChannelKind(channel.kind) is ChannelKind.ACCELERATION]
    count = len(spec.rigid_body.accelerometers)
    if len(rows) < count:
        raise SettingError(f"{spec.source}: the spec has {count} accelerometers; the recording {len(rows)} "
                           f"acceleration channels")
    return rows[:count]


def session_spec(session: Any) -> RigSpec | None:
    """The session's rig spec when it has a rigid body, else None."""
    text = session.rig_spec_toml
    if not text:
        return None
    spec = RigSpec.from_toml(text, f"{session.path} (its rig spec)")
    return spec if spec.rigid_body is not None else None


def session_rigid_frf(session: Any, window: WindowSettings | None = None, spec: RigSpec | None = None,
                      points: Sequence[str] | None = None) -> RigidFrf:
    """The rigid-body FRFs of a session's accepted hits (its rig spec, hammer-point runs and window); ``points``:
    only the hits at these hammer points."""
    spec = spec or session_spec(session)
    if spec is None:
        raise SettingError(f"{session.path}: its rig spec has no [rigid_body] (a one-accelerometer session); a "
                           f"rigid-body test is recorded with one (gasfilm acquire --rig, docs/rig-spec.md)")
    window = window if window is not None else session.settings_as("window", WindowSettings)
    accepted = [hit for hit in session.hits() if hit.verdict.accepted]
    if not accepted:
        raise SettingError(f"{session.path}: no accepted hits")
    rows = accelerometer_rows(spec, session.daq_config)
    grouped = hits_by_point(spec, session.settings, accepted)
    check_points(spec, points, grouped)
    records = {point: np.stack([hit.data for hit in hits]) for point, hits in grouped.items()
               if points is None or point in points}
    return rigid_frf(spec, records, session.sample_rate_hz, window, accepted[0].force_channel, rows)


def check_points(spec: RigSpec, points: Sequence[str] | None, struck: Mapping[str, Any]) -> None:
    """Refuse a chosen hammer point that is not the spec's or has no hits, naming the ones there are."""
    for point in points or ():
        if point not in spec.rigid_body.point_names:
            raise SettingError(f"--points {point}: not a hammer point of the rig spec "
                               f"({', '.join(spec.rigid_body.point_names)})")
        if point not in struck:
            raise SettingError(f"--points {point}: no accepted hits there (struck: {', '.join(struck) or 'none'})")
