"""The everyday slips of the second new-user trial on the command line: a stored fit or diagnosis never silently
replaced, inputs checked before outputs, a file where a folder is needed called a file, hits numbered from 1, the
version, percentages that mean percent, and refusals that name the file and the flag."""

from __future__ import annotations

import json

import pytest

from gasfilm.analysis.session import Session
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("trial") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "3", "--seed", "2"]) == 0
    return path


def one_line_error(capsys, *argv) -> str:
    status, out, err = gasfilm(capsys, *argv)
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, (status, out, err)
    return err


def test_a_stored_fit_is_not_replaced_by_one_made_with_other_settings(session_path, tmp_path, capsys):
    """Before: `fit --mass 1e9` replaced the good stored SD fit with one stuck at its bounds, and the report then
    compared every model with it."""
    status, out, err = gasfilm(capsys, "fit", session_path, "--models", "SD", "--out", tmp_path)
    assert status == 0, err
    status, out, err = gasfilm(capsys, "replay", session_path, "--exp-end", "0.01", "--json")  # FRF 'replay'
    assert status == 0, err
    with Session.open(session_path) as session:
        stored = session.read_fit("SD")
    assert stored["frf_name"] == "frf" and stored["mass_given_kg"] == stored["mass_kg"]
    mass = stored["mass_kg"]
    for flags, named, words in ((["--mass", "1e9"], "--mass", f"with m = {mass:g} kg"),
                                (["--fit-mass"], "--fit-mass", "with the mass fixed"),
                                (["--method", "gapso"], "--method", "by the default fitter"),
                                (["--frf", "replay"], "--frf", "FRF 'frf'")):
        err = one_line_error(capsys, "fit", session_path, "--models", "SD", *flags, "--out", tmp_path / "a")
        assert err.startswith(f"gasfilm fit: error: {named}") and "--overwrite" in err and words in err, err
        assert "SD fit" in err
    err = one_line_error(capsys, "fit", session_path, "--models", "SD", "--mass", "1e9", "--band", "50:900",
                         "--out", tmp_path / "b")
    assert "--band, --mass:" in err and "(--band 20:1000, --mass" in err, err
    with Session.open(session_path) as session:
        kept = session.read_fit("SD")  # untouched by every refusal
    assert (kept["params"], kept["mass_kg"], list(kept["band_hz"])) == \
        (stored["params"], stored["mass_kg"], list(stored["band_hz"]))
    status, out, err = gasfilm(capsys, "fit", session_path, "--models", "SD", "--mass", "30", "--out", tmp_path,
                               "--overwrite", "--json")
    assert status == 0, err
    with Session.open(session_path) as session:
        assert session.read_fit("SD")["mass_given_kg"] == 30.0
    status, out, err = gasfilm(capsys, "fit", session_path, "--models", "SD", "--mass", "30", "--out",
                               tmp_path / "c", "--json")  # the same settings again: replaced without --overwrite
    assert status == 0, err
