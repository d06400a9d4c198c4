"""Every fixture rig with effects, recorded on the simulated module and diagnosed against its film alone: every effect
named or modelled in its place, the written spec within the noise, and the loop closed (the written spec, diagnosed
again on the same recordings, finds nothing more). ``benchmarks/fixture_rigs.py`` does the same through the command
line for every fixture rig, the slow all-effects rig included."""

from __future__ import annotations

from pathlib import Path

import pytest

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.physics.effects import EFFECT_TYPES
from gasfilm.analysis.physics.spec import RigSpec
from test_diagnose import record

RIGS = Path(__file__).resolve().parent.parent / "fixtures" / "rigs"
WITH_EFFECTS = sorted(path.name for path in RIGS.glob("*.toml")
                      if any(effect.kind != "interference" for effect in RigSpec.load(path).effects))


def film_alone(spec: RigSpec) -> RigSpec:
    """The rig as an engineer would first model it: its mass on its film, the sensors and hammer, no effect."""
    return RigSpec(name=f"{spec.name}: film alone", mass_kg=spec.mass_kg, film_model=spec.film_model,
                   film_parameters=spec.film_parameters, force_sensor=spec.force_sensor,
                   acceleration_sensor=spec.acceleration_sensor, hammer=spec.hammer)


def covers(finding, effect) -> bool:
    """A finding describes an effect of the rig: it names it (the same term), or models it in its place with its
    frequency (within 2 %) where it has one."""
    if finding.effect == effect.type_name:
        return True
    if finding.status != "modelled" or finding.place != effect.place():
        return False
    frequency = getattr(effect, "freq_hz", None)
    found = finding.features.get("frequency_hz")
    return frequency is None or (found is not None and abs(found / frequency - 1) <= 0.02)


def test_every_fixture_rig_with_effects_is_listed():
    assert WITH_EFFECTS == ["all-effects.toml", "three-modes.toml"]


#: all-effects (six effects, a drift among them) takes minutes: benchmarks/fixture_rigs.py scores it the same way
@pytest.mark.parametrize("rig", ["three-modes.toml"])
def test_a_fixture_rig_diagnosed_against_its_film_alone_has_every_effect_described(rig, tmp_path):
    spec = RigSpec.load(RIGS / rig)
    # a minute of session time: the all-effects rig's drift (−5 %/h) moves its resonance by ten times the noise
    session = record(spec, tmp_path / "session.h5", hits=8, seed=5, hit_interval_s=(7.0, 8.0))
    diagnosis = diagnose(session, film_alone(spec))
    effects = [effect for effect in spec.effects if effect.kind != "interference"]
    missing = [effect.type_name for effect in effects if not any(covers(f, effect) for f in diagnosis.findings)]
    assert not missing, (missing, [(f.effect, f.place, f.features) for f in diagnosis.findings])
    assert diagnosis.verdict in ("missing physics", "modelled"), diagnosis.verdict
    assert diagnosis.chi2_per_point_after <= 1.5
    again = diagnose(session, diagnosis.improved)
    assert again.verdict in ("consistent", "parameters-only") and not again.findings, again.verdict
