"""What the GUI's acquisition does for a rigid-body rig (``[rigid_body]``): strike the chosen hammer point, check
every accelerometer, and keep the roving test's runs in the session — the same rules as ``gasfilm acquire
--hammer-point`` (:mod:`gasfilm.analysis.rigid_session`)."""

from __future__ import annotations

from typing import Any

from gasfilm.analysis.physics.rigid_body import RovingPlan, struck_at
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_session import HAMMER_POINTS_SETTING, roving_plan
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import ChannelKind, DaqConfig


def rigid_plan(spec: RigSpec, point: str | None, config: DaqConfig, response_row: int
               ) -> tuple[RigSpec, tuple[int, ...]]:
    """The spec struck at ``point`` (None: its own) and the acceleration rows checked besides the response; the
    spec as it is for a rig without a rigid body. Refused in one line when the channels cannot hold its
    accelerometers."""
    body = spec.rigid_body
    if body is None:
        return spec, ()
    rows = [row for row, channel in enumerate(config.channels) if channel.kind is ChannelKind.ACCELERATION]
    if len(rows) < len(body.accelerometers):
        raise SettingError(f"channels: the rig spec's mover has {len(body.accelerometers)} accelerometers "
                           f"({', '.join(body.sensor_names)}); enable as many acceleration channels on the Setup "
                           f"tab (ai1… in that order)")
    chosen = point if point in body.point_names else body.hammer_point
    return struck_at(spec, chosen), tuple(row for row in rows[: len(body.accelerometers)] if row != response_row)


def same_rig(stored_toml: str | None, spec: RigSpec) -> bool:
    """Whether a session's stored spec is ``spec``'s rig; a rigid body struck at another point is the same rig
    (the next run of a roving test)."""
    if not stored_toml:
        return False
    if stored_toml == spec.to_toml():
        return True
    if spec.rigid_body is None:
        return False
    stored = RigSpec.from_toml(stored_toml)
    return stored.rigid_body is not None and struck_at(spec, stored.rigid_body.hammer_point).to_toml() == stored_toml


def note_hammer_run(session: Any, spec: RigSpec) -> RovingPlan | None:
    """The run about to be recorded strikes ``spec``'s point: kept in the session's ``hammer_points`` runs; returns
    the runs (None for a rig without a rigid body)."""
    if spec.rigid_body is None or session is None:
        return None
    before = roving_plan(session.settings)
    plan = before.with_run(spec.rigid_body.hammer_point, session.hit_count)
    if plan.runs != before.runs:
        session.update_settings({HAMMER_POINTS_SETTING: plan.to_setting()})
    return plan


def struck_point(spec: RigSpec | None) -> str | None:
    return None if spec is None or spec.rigid_body is None else spec.rigid_body.hammer_point


def entries_at_point(entries: list, plan: RovingPlan | None, point: str | None) -> list:
    """The hits struck at ``point`` in a roving test (the running FRF and its coherence are one point's: hits at
    other points are other FRFs); every hit when there is no roving test."""
    if plan is None or point is None or not plan.runs:
        return entries
    return [entry for entry in entries if plan.point_of_hit(entry.index, plan.runs[0].point) == point]
