"""Every fixture rig with effects, recorded on the simulated module and diagnosed against its film alone: every effect
named or modelled in its place, the written spec within the noise, and the loop closed (the written spec, diagnosed
again on the same recordings, finds nothing more). ``benchmarks/fixture_rigs.py`` does the same through the command
line for every fixture rig, the slow all-effects rig included."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from gasfilm.analysis.diagnosis import diagnose
from gasfilm.analysis.physics.spec import RigSpec
from test_diagnose import record

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from fixture_rigs import film_alone, rig_effects, score  # noqa: E402  (one scoring for the test and the benchmark)

RIGS = Path(__file__).resolve().parent.parent / "fixtures" / "rigs"
WITH_EFFECTS = sorted(path.name for path in RIGS.glob("*.toml")
                      if any(effect.kind != "interference" for effect in RigSpec.load(path).effects))


def test_every_fixture_rig_with_effects_is_listed():
    assert WITH_EFFECTS == ["all-effects.toml", "three-modes.toml"]


#: all-effects (six effects, a drift among them) takes minutes: benchmarks/fixture_rigs.py scores it the same way
@pytest.mark.parametrize("rig", ["three-modes.toml"])
def test_a_fixture_rig_diagnosed_against_its_film_alone_has_every_effect_described(rig, tmp_path):
    spec = RigSpec.load(RIGS / rig)
    # a minute of session time: the all-effects rig's drift (−5 %/h) moves its resonance by ten times the noise
    session = record(spec, tmp_path / "session.h5", hits=8, seed=5, hit_interval_s=(7.0, 8.0))
    diagnosis = diagnose(session, film_alone(spec))
    effects, places = rig_effects(RIGS / rig)
    findings = [finding.to_dict() for finding in diagnosis.findings]
    answers = score(effects, places, findings)
    assert "—" not in answers, (list(zip((effect["type"] for effect in effects), answers)), findings)
    assert diagnosis.verdict in ("missing physics", "modelled"), diagnosis.verdict
    assert diagnosis.chi2_per_point_after <= 1.5
    again = diagnose(session, diagnosis.improved)
    assert again.verdict in ("consistent", "parameters-only") and not again.findings, again.verdict
