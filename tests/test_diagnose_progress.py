"""What ``gasfilm diagnose`` says while it works: the step it is at (locate, model, name) and what it has so far,
in χ²/point; the search's trace (every candidate's scores) only with ``--verbose``."""

from __future__ import annotations

from gasfilm.analysis.diagnosis.pipeline import is_trace
from test_cli_acquire_replay import gasfilm
from test_cli_roundtrip import session_path  # noqa: F401  (a 3-hit session on the simulated rig)


def test_diagnose_says_its_steps_and_keeps_the_search_trace_for_verbose(session_path, tmp_path, capsys):
    status, _, quiet = gasfilm(capsys, "diagnose", session_path, "--out", tmp_path / "quiet", "--no-figures")
    assert status == 0, quiet
    for step in ("step 1 of 3, locate", "step 2 of 3, model", "step 3 of 3, name"):
        assert step in quiet, quiet
    assert "BIC gain" not in quiet and "held-out χ² gain" not in quiet, quiet

    status, _, verbose = gasfilm(capsys, "diagnose", session_path, "--out", tmp_path / "verbose", "--no-figures",
                                 "--verbose")
    assert status == 0, verbose
    assert "BIC gain of the best candidates" in verbose, verbose
    assert len(verbose.splitlines()) > len(quiet.splitlines())


def test_a_trace_line_is_told_from_a_step_by_its_indent():
    assert is_trace("  extra-mode: held-out χ² gain 1379 (needs > 25)")
    assert not is_trace("so far: extra-mode: χ²/point 1.9")
