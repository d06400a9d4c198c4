"""Every fixture rig with effects, recorded on the simulated module and diagnosed against its film alone through the
command line, as an engineer would: every effect named or modelled in its place, nothing claimed that the rig does
not have, the written spec within the noise, and the loop closed (the written spec, diagnosed again on the same
recordings, finds nothing more). The test and ``benchmarks/fixture_rigs.py`` share one procedure and one scoring."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from gasfilm.analysis.physics.spec import RigSpec

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from fixture_rigs import run_rig  # noqa: E402  (one procedure and one scoring for the test and the benchmark)

RIGS = Path(__file__).resolve().parent.parent / "fixtures" / "rigs"
WITH_EFFECTS = sorted(path.name for path in RIGS.glob("*.toml")
                      if any(effect.kind != "interference" for effect in RigSpec.load(path).effects))


def test_every_fixture_rig_with_effects_is_listed():
    assert WITH_EFFECTS == ["all-effects.toml", "three-modes.toml"]


@pytest.mark.parametrize("rig", WITH_EFFECTS)
def test_a_fixture_rig_diagnosed_against_its_film_alone_has_every_effect_described(rig, tmp_path):
    # 8 hits 7–8 s apart: a minute of session time, in which the all-effects rig's drift (−5 %/h) moves its resonance
    # by ten times the noise
    row = run_rig(RIGS / rig, hits=8, seed=5, work=tmp_path)
    assert "error" not in row, row
    assert all(answer != "—" for _, answer in row["scored"]), row["scored"]
    assert not row["false_claims"], row
    assert row["verdict"] in ("missing physics", "modelled"), row
    assert row["chi2_after"] <= 1.5, row
    assert row["loop_closed"] and row["loop_verdict"] in ("consistent", "parameters-only"), row
