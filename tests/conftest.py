"""Test-wide set-up: Qt runs offscreen; matplotlib draws to files."""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest  # noqa: E402


@pytest.fixture(autouse=True, scope="session")
def every_written_spec_is_read_back():
    """Every rig spec any test writes (``RigSpec.to_toml``: the CLI's and the GUI's improved-rig.toml, sessions'
    stored specs, benchmarks' helpers) is read back by the spec reader at once, and equals what was written: what
    gasfilm writes, ``--rig`` accepts (issue 30, item 4)."""
    from gasfilm.analysis.physics.spec import RigSpec

    write = RigSpec.to_toml

    def written_and_read_back(spec: RigSpec) -> str:
        text = write(spec)
        assert RigSpec.from_toml(text, "spec written by a test") == spec, "a written spec reads back differently"
        return text

    patch = pytest.MonkeyPatch()
    patch.setattr(RigSpec, "to_toml", written_and_read_back)
    yield
    patch.undo()
