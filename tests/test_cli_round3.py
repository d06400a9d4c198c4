"""The command line's part of issue 32: Hv in replay and export, conditions that survive UFF, output places, the
model's default fit, the FRF a command uses, and the slips of item 15."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gasfilm.analysis.session import Session
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("round3") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "3",
                 "--condition", "supply_pressure_mpa=0.4"]) == 0
    return path


def test_replay_reads_the_peak_on_the_estimator_asked_for(session_path, capsys):
    peaks = {}
    for estimator in ("h1", "h2", "hv"):
        status, out, err = gasfilm(capsys, "replay", session_path, "--estimator", estimator, "--json")
        assert status == 0, err
        summary = json.loads(out)
        assert summary["estimator"] == {"h1": "H1", "h2": "H2", "hv": "Hv"}[estimator]
        peaks[estimator] = summary["peak_accelerance_m_s2_per_n"]
    assert peaks["h1"] <= peaks["hv"] <= peaks["h2"]
    status, out, err = gasfilm(capsys, "replay", session_path, "--estimator", "hv")
    assert "peak of |Hv|" in out


def test_export_writes_the_estimator_asked_for_and_the_csv_holds_hv(session_path, tmp_path, capsys):
    from gasfilm.analysis.uff import read_uff_frf

    with Session.open(session_path, "r") as session:
        stored = session.read_frf()
    status, out, err = gasfilm(capsys, "export", session_path, "--uff", tmp_path / "hv.uff", "--estimator", "hv")
    assert status == 0 and out.startswith("Hv of the "), (out, err)
    np.testing.assert_allclose(read_uff_frf(tmp_path / "hv.uff").h1, stored.hv, rtol=1e-6)
    status, out, err = gasfilm(capsys, "export", session_path, "--csv", tmp_path / "frf.csv")
    lines = (tmp_path / "frf.csv").read_text().splitlines()
    comments = sum(line.startswith("#") for line in lines)
    assert lines[0] == "# condition supply_pressure_mpa = 0.4"
    table = np.genfromtxt(tmp_path / "frf.csv", delimiter=",", names=True, skip_header=comments)
    np.testing.assert_allclose(table["hv_real_m_s2_per_n"] + 1j * table["hv_imag_m_s2_per_n"], stored.hv,
                               rtol=1e-9, atol=1e-12)
    # an FRF read from a file has no spectra: Hv is refused in one line
    status, out, err = gasfilm(capsys, "export", tmp_path / "hv.uff", "--uff", tmp_path / "again.uff",
                               "--estimator", "hv")
    assert status == 2 and "holds no force and response spectra" in err and err.count("\n") == 1


def test_acquire_stores_who_tested_what_and_the_report_shows_it(tmp_path, capsys):
    path = tmp_path / "who.h5"
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 1, "--operator", "B. Engineer",
                               "--test-object", "mover M2")
    assert status == 0, err
    with Session.open(path, "r") as session:
        assert session.settings["test"] == {"operator": "B. Engineer", "test_object": "mover M2"}
    status, out, err = gasfilm(capsys, "report", path, "--out", tmp_path / "who.html")
    report = (tmp_path / "who.html").read_text(encoding="utf-8")
    assert "Operator <b>B. Engineer</b>; test object <b>mover M2</b>" in report


def test_conditions_the_simulated_rig_cannot_follow_are_said_and_each_run_draws_new_hits(tmp_path, capsys):
    """Issue 32 item 7: two runs at two pressures on the default rig (no film laws) were byte-identical."""
    runs = {}
    for pressure in ("0.4", "0.5"):
        path = tmp_path / f"p{pressure}.h5"
        status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 2,
                                   "--condition", f"supply_pressure_mpa={pressure}")
        assert status == 0, err
        assert "supply_pressure_mpa: stored with the session, but the simulated rig's spec has no film law" in err
        with Session.open(path, "r") as session:
            runs[pressure] = (session.hits()[0].data.copy(), session.settings["acquisition"]["seed"])
    assert runs["0.4"][1] != runs["0.5"][1]
    assert not np.array_equal(runs["0.4"][0], runs["0.5"][0])
    # a stored seed repeats its run
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", tmp_path / "again.h5", "--hits", 2,
                               "--seed", runs["0.4"][1], "--condition", "supply_pressure_mpa=0.4")
    with Session.open(tmp_path / "again.h5", "r") as session:
        np.testing.assert_array_equal(session.hits()[0].data, runs["0.4"][0])


def test_fit_and_diagnose_write_beside_their_input_in_a_folder_named_after_it(session_path, tmp_path, capsys):
    """Issue 32 item 8: fit wrote its figures beside its input, diagnose into ./out/diagnosis/NAME/, the GUI into
    SESSION-diagnosis/: one rule now, NAME-fit/ and NAME-diagnosis/ beside the input (the GUI's too)."""
    import shutil

    source = tmp_path / "rig.h5"
    shutil.copy(session_path, source)
    status, out, err = gasfilm(capsys, "fit", source, "--models", "SD")  # figures only when asked (item 16)
    assert status == 0 and f"figures: not drawn (--figures draws Figures 18 and 19 into {tmp_path / 'rig-fit'})" in out
    assert not (tmp_path / "rig-fit").exists()
    status, out, err = gasfilm(capsys, "fit", source, "--models", "SD", "--figures", "--overwrite")
    assert status == 0, err
    assert (tmp_path / "rig-fit" / "rig-figure18.png").is_file() and not (tmp_path / "rig-figure18.png").exists()
    status, out, err = gasfilm(capsys, "diagnose", source)
    assert status == 0, err
    assert (tmp_path / "rig-diagnosis" / "improved-rig.toml").is_file() and not (tmp_path / "out").exists()
    status, out, err = gasfilm(capsys, "fit", source, "--models", "SD", "--figures")  # an existing figure: asked
    assert status == 2 and "exists already (add --overwrite" in err


def test_model_takes_the_lowest_bic_fit_and_a_second_format_has_its_own_figures(session_path, tmp_path, capsys):
    """Issue 32 item 9: `model S.h5 --out x.json` needed --model although several fits were stored, and x.json after
    x.mat was refused for x.mat's figure x-error.png."""
    import shutil

    from gasfilm.analysis.identification import FitResult, best_by_bic, compare_models

    source = tmp_path / "fits.h5"
    shutil.copy(session_path, source)
    assert gasfilm(capsys, "fit", source, "--models", "SD,Zener", "--out", tmp_path / "f")[0] == 0
    with Session.open(source, "r") as session:
        fits = [FitResult.from_dict(session.read_fit(name)) for name in session.result_names("fits")]
        frf = session.read_frf()
    band = (frf.freq_hz >= fits[0].band_hz[0]) & (frf.freq_hz <= fits[0].band_hz[1])
    best = best_by_bic(compare_models(fits, frf.freq_hz[band], frf.h1[band])).model_name
    status, out, err = gasfilm(capsys, "model", source, "--out", tmp_path / "x.mat", "--json")
    assert status == 0, err
    assert f"--model not given: {best}, the lowest BIC of the 2 fits" in err
    assert json.loads(out)["figures"][0] == str(tmp_path / "x.mat-error.png")
    status, out, err = gasfilm(capsys, "model", source, "--out", tmp_path / "x.json")
    assert status == 0, err
    assert (tmp_path / "x.json-error.png").is_file() and (tmp_path / "x.mat-error.png").is_file()


def test_the_replayed_frf_is_named_by_every_command_that_could_take_it(session_path, tmp_path, capsys):
    """Issue 32 item 10: replay stores its FRF as 'replay', fit, export and report kept using 'frf' without a word,
    and report had no --frf."""
    import shutil

    source = tmp_path / "replayed.h5"
    shutil.copy(session_path, source)
    status, out, err = gasfilm(capsys, "replay", source, "--exp-end", "0.1")
    assert status == 0 and "take it with --frf replay" in out, (out, err)
    status, out, err = gasfilm(capsys, "export", source, "--csv", tmp_path / "x.csv")
    assert "holds 2 FRFs: this is 'frf' (--frf replay takes that)" in err
    status, out, err = gasfilm(capsys, "fit", source, "--models", "SD", "--out", tmp_path / "f")
    assert status == 0 and "holds 2 FRFs: this is 'frf'" in err
    status, out, err = gasfilm(capsys, "report", source, "--out", tmp_path / "r.html", "--frf", "replay")
    assert status == 0, err
    assert "FRF 'replay' stored in the session (it also holds 'frf'" in (tmp_path / "r.html").read_text(encoding="utf-8")
    status, out, err = gasfilm(capsys, "report", source, "--out", tmp_path / "s.html", "--frf", "nosuch")
    assert status == 2 and "--frf nosuch" in err and "holds no such FRF (it holds frf, replay)" in err


def test_a_uff_export_carries_the_sessions_conditions_through_replay_fit_and_diagnose(session_path, tmp_path, capsys):
    """Issue 32 item 11: a UFF export and its replay said "conditions: not recorded"."""
    uff = tmp_path / "run.uff"
    assert gasfilm(capsys, "export", session_path, "--uff", uff)[0] == 0
    status, out, err = gasfilm(capsys, "replay", uff, "--out", tmp_path / "again.h5")
    assert status == 0 and "conditions: supply_pressure_mpa = 0.4 MPa" in out, (out, err)
    with Session.open(tmp_path / "again.h5", "r") as session:
        assert session.settings["conditions"] == {"supply_pressure_mpa": 0.4}
    status, out, err = gasfilm(capsys, "fit", uff, "--models", "SD", "--out", tmp_path / "f")
    assert "conditions: supply_pressure_mpa = 0.4 MPa" in out
    # the line holds what fits its 80 characters, and says what it leaves out
    from gasfilm.analysis.uff import conditions_line

    line = conditions_line({f"label_{n}": "x" * 12 for n in range(6)})
    assert len(line) <= 80 and line.startswith("conditions: label_0=xxxxxxxxxxxx; label_1=")


def test_ctrl_c_after_one_hit_says_one_hit_and_sim_in_capitals_is_the_simulator(tmp_path, capsys):
    """Issue 32 item 15: "closed with 1 accepted hits"; --device SIM was taken for an NI device name."""
    import signal
    import subprocess
    import sys

    status, out, err = gasfilm(capsys, "acquire", "--device", "SIM", "--pacing", "fast", "--rate", 6400,
                               "--record-s", 0.25, "--hit-interval", 0.3, 0.45, "--out", tmp_path / "upper.h5",
                               "--hits", 1)
    assert status == 0 and "from sim at 6400 S/s" in out, (out, err)
    process = subprocess.Popen([sys.executable, "-m", "gasfilm.app.cli", "acquire", "--device", "sim", "--rate",
                                "6400", "--record-s", "0.25", "--hit-interval", "4", "5", "--hits", "10", "--out",
                                str(tmp_path / "one.h5")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    for line in process.stdout:
        lines.append(line)
        if line.startswith("accepted hit 1"):
            process.send_signal(signal.SIGINT)
            break
    out = "".join(lines) + process.stdout.read()
    process.wait(60)
    assert "closed with 1 accepted hit\n" in out, out


def test_a_campaign_says_what_fit_warns_and_keeps_dasks_port_warning_to_itself(tmp_path, capsys):
    """Issue 32 item 15: a campaign of a measured structure named "best SD" without fit's "not a mass on a film"
    warning, and dask's "Port 8787 is already in use" reached the user."""
    import socket

    from test_cli_files import REAL_FILES, REAL_WINDOW

    folder = tmp_path / "sessions"
    folder.mkdir()
    assert gasfilm(capsys, "replay", *REAL_FILES, *REAL_WINDOW, "--out", folder / "real.h5",
                   "--condition", "bearing=pyFRF beam")[0] == 0
    holder = socket.socket()
    try:
        holder.bind(("127.0.0.1", 8787))
        holder.listen()
    except OSError:
        pass  # held already: the case itself
    try:
        status, out, err = gasfilm(capsys, "campaign", folder, "--by", "bearing", "--out", tmp_path / "c",
                                   "--models", "SD", "--no-diagnosis", "--workers", 1)
    finally:
        holder.close()
    assert status == 0, err
    assert "8787" not in err and "already in use" not in err, err
    assert "best SD" in out and "not a mass on a gas film" in out, out
    assert "not a mass on a gas film" in (tmp_path / "c" / "campaign.html").read_text(encoding="utf-8")

