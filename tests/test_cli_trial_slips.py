"""The everyday slips of the second new-user trial on the command line: a stored fit or diagnosis never silently
replaced, inputs checked before outputs, a file where a folder is needed called a file, hits numbered from 1, the
version, percentages that mean percent, and refusals that name the file and the flag."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gasfilm.analysis.session import Session
from test_cli_acquire_replay import FAST_SIM, gasfilm


@pytest.fixture(scope="module")
def session_path(tmp_path_factory):
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("trial") / "run.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "3", "--seed", "2"]) == 0
    return path


def new_session(tmp_path, capsys, hits: int = 3):
    """A session of its own for a test that stores results in it (the module's session is shared)."""
    path = tmp_path / "own.h5"
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", hits, "--seed", 2)
    assert status == 0, err
    return path


def one_line_error(capsys, *argv) -> str:
    status, out, err = gasfilm(capsys, *argv)
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, (status, out, err)
    return err


def test_a_stored_fit_is_not_replaced_by_one_made_with_other_settings(tmp_path, capsys):
    """Before: `fit --mass 1e9` replaced the good stored SD fit with one stuck at its bounds, and the report then
    compared every model with it."""
    session_path = new_session(tmp_path, capsys)
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


def test_each_diagnosis_is_kept_and_latest_is_the_newest_with_its_options(tmp_path, capsys):
    """Before: every `diagnose` replaced the session's only stored diagnosis (diagnoses/latest)."""
    session_path = new_session(tmp_path, capsys)
    from gasfilm.analysis.report import read_report_data, report_html

    status, out, err = gasfilm(capsys, "diagnose", session_path, "--out", tmp_path / "a", "--json",
                               "--no-figures")
    assert status == 0, err
    first = json.loads(out)
    assert first["options"] == {"command": "gasfilm diagnose", "rig": None, "mass_kg": None, "band_hz": None}
    status, out, err = gasfilm(capsys, "diagnose", session_path, "--mass", "25", "--band", "30:900",
                               "--out", tmp_path / "b", "--json", "--no-figures")
    assert status == 0, err
    assert "as diagnoses/run-002" in err
    with Session.open(session_path) as session:
        names = session.result_names("diagnoses")
        assert {"run-001", "run-002", "latest"} <= set(names)
        assert session.newest_diagnosis_name() == "run-002"
        assert session.read_diagnosis("run-001")["verdict"] == first["verdict"]  # nothing erased
        assert session.read_diagnosis("run-001")["options"]["mass_kg"] is None
        latest = session.read_diagnosis("latest")
    assert latest["options"] == {"command": "gasfilm diagnose", "rig": None, "mass_kg": 25.0, "band_hz": [30.0, 900.0]}
    page = report_html(read_report_data(session_path))
    assert "diagnoses/run-002" in page and "--mass 25 kg" in page and "--band 30:900 Hz" in page
    assert "earlier runs are kept" in page


def test_a_diagnosis_stored_as_latest_by_an_older_gasfilm_becomes_a_run(tmp_path):
    from gasfilm.app.cli import main

    path = tmp_path / "old.h5"

    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "1", "--seed", "2"]) == 0
    with Session.open(path, "a") as session:
        session.write_diagnosis("diagnosis", {"verdict": "missing physics"})  # the old GUI's name, older
        session.write_diagnosis("latest", {"verdict": "consistent"})  # the old command line's
    with Session.open(path) as session:
        assert session.read_diagnosis(session.newest_diagnosis_name())["verdict"] in ("consistent", "missing physics")
    with Session.open(path, "a") as session:
        assert session.add_diagnosis({"verdict": "not explained"}) == "run-002"
    with Session.open(path) as session:
        assert session.read_diagnosis("run-001")["verdict"] == "consistent"
        assert session.read_diagnosis("diagnosis")["verdict"] == "missing physics"
        assert session.read_diagnosis("latest")["verdict"] == "not explained"
        assert session.newest_diagnosis_name() == "run-002"


def test_gui_without_a_display_says_so_in_one_line_before_qt_starts(monkeypatch, capsys):
    """Before: Qt aborted ("Could not load the Qt platform plugin xcb", exit status 134)."""
    import sys

    import gasfilm.app.gui.main_window as main_window

    for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(main_window, "run_gui", lambda **_: pytest.fail("Qt started without a display"))
    err = one_line_error(capsys, "gui")
    assert err.startswith("gasfilm gui: error: no display") and "./run gui" in err
    assert "QT_QPA_PLATFORM=offscreen" in err
    monkeypatch.setenv("QT_QPA_PLATFORM", "xcb")
    assert "no display" in one_line_error(capsys, "gui")
    from gasfilm.app.commands.gui import missing_display

    assert missing_display({"DISPLAY": ":0"}, "linux") is None
    assert missing_display({"WAYLAND_DISPLAY": "wayland-0"}, "linux") is None
    assert missing_display({"QT_QPA_PLATFORM": "offscreen"}, "linux") is None
    assert missing_display({}, "darwin") is None


def test_the_report_shows_the_fits_warnings_beside_them(tmp_path, capsys):
    """Before: the report dropped "not a mass on a gas film … the fitted parameters mean little" and "NOT explained by
    any film model" that `gasfilm fit` printed for the real pyFRF structure."""
    from pathlib import Path

    records = sorted((Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits")
                     .glob("measurements_*.npy"))
    path = tmp_path / "real.h5"
    assert gasfilm(capsys, "replay", *records, "--force-window-ms", 2, "--exp-end", 0.01, "--out", path)[0] == 0
    status, out, err = gasfilm(capsys, "fit", path, "--models", "SD", "--out", tmp_path, "--json")
    assert status == 0, err
    warnings = [line.split("WARNING: ", 1)[1] for line in err.splitlines() if "WARNING: " in line]
    assert any("the fitted parameters mean little" in w for w in warnings)
    assert any(w.startswith("NOT explained by any film model") for w in warnings)
    assert gasfilm(capsys, "report", path, "--out", tmp_path / "report.html")[0] == 0
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    fits_section = page[page.index("Identified models"):page.index("Control design")]
    import html

    for warning in warnings:
        assert html.escape(warning) in fits_section, warning


@pytest.mark.parametrize("verdict", ["not explained", "partly explained", "consistent"])
def test_the_reports_diagnosis_shows_what_is_not_explained_the_noise_and_the_options(verdict, tmp_path, capsys):
    """Before: "Verdict: not explained — … No missing physics found." without its bands, the noise or the options."""
    import html

    from gasfilm.analysis.report import read_report_data, report_html

    path = tmp_path / "run.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 1, "--seed", 2)[0] == 0
    stored = {
        "verdict": verdict, "findings": [], "hits_numbered_from": 1, "rms_before_g_per_n": 0.1,
        "rms_after_g_per_n": 0.05, "e_percent": 50.0,
        "noise": {"source": "hit scatter", "degrees_of_freedom": 8, "detail": "from the scatter of the hits"},
        "unexplained": [] if verdict == "consistent" else [
            {"band_hz": [810.0, 851.0], "hits": [1, 3], "chi2_share": 0.84, "character": "a localised peak near 824 Hz",
             "candidates": [{"effect": "extra mode"}], "unmodelled_resonances_hz": [824.0]}],
        "options": {"command": "gasfilm diagnose", "rig": None, "mass_kg": 0.001, "band_hz": None},
    }
    with Session.open(path, "a") as session:
        session.add_diagnosis(stored)
    page = html.unescape(report_html(read_report_data(path)))
    section = page[page.index("<h2>Diagnosis"):]
    assert f"Verdict: <b>{verdict}</b>" in section and "Noise: hit scatter" in section and "--mass 0.001 kg" in section
    if verdict == "consistent":
        assert "No missing physics found" in section and "NOT explained" not in section
    else:
        assert "No missing physics found" not in section
        assert "<td>810–851</td><td>1, 3</td><td>84.0</td><td>a localised peak near 824 Hz</td><td>824</td>" \
               "<td>extra mode</td>" in section
    if verdict == "not explained":  # (the page with the most in it, on paper too)
        assert gasfilm(capsys, "report", path, "--out", tmp_path / "report.pdf")[0] == 0


def test_model_max_error_is_a_percentage_with_or_without_its_sign(tmp_path, capsys):
    """Before: the help said the default was 0.5%, but `--max-error 0.5` meant 50 % and `--max-error 5` was refused."""
    from pathlib import Path

    spec = Path(__file__).resolve().parents[1] / "fixtures" / "rigs" / "fomgf.toml"
    for given, fraction in (("0.5", 0.005), ("5", 0.05), ("0.5%", 0.005), ("2 %", 0.02)):
        status, out, err = gasfilm(capsys, "model", spec, "--max-error", given, "--out", tmp_path / "m.json",
                                   "--overwrite", "--json")
        assert status == 0, err
        assert json.loads(out)["model"]["target_error"] == pytest.approx(fraction)
    status, out, err = gasfilm(capsys, "model", spec, "--max-error", "5", "--out", tmp_path / "m.json", "--overwrite")
    assert status == 0 and "target: within 5 %" in out, err
    for bad in ("100", "0", "-1", "150%"):
        assert "--max-error" in one_line_error(capsys, "model", spec, "--max-error", bad, "--out", tmp_path / "x.json")


def test_diagnose_overwrite_removes_its_own_outputs_this_run_does_not_write(session_path, tmp_path, capsys,
                                                                            monkeypatch):
    """Before: an earlier run's diagnosis-restoring-force.png stayed beside the new spec."""
    from gasfilm.analysis.diagnosis import recordings

    out = tmp_path / "d"
    status, _, err = gasfilm(capsys, "diagnose", session_path, "--out", out)
    assert status == 0, err
    assert (out / "diagnosis-restoring-force.png").exists()
    (out / "notes.txt").write_text("mine")
    (out / "diagnosis-restoring-force-old.png").write_bytes(b"mine too")
    monkeypatch.setattr(recordings, "film_restoring_force", lambda *_: None)  # records with no free decay to read
    status, out_text, err = gasfilm(capsys, "diagnose", session_path, "--out", out, "--overwrite", "--json")
    assert status == 0, err
    assert json.loads(out_text)["restoring_force"] is None
    assert not (out / "diagnosis-restoring-force.png").exists() and "removed" in err
    assert sorted(path.name for path in out.iterdir()) == [
        "diagnosis-film.png", "diagnosis-overlay.png", "diagnosis-residual.png", "diagnosis-restoring-force-old.png",
        "improved-rig.toml", "notes.txt"]


def test_diagnose_without_figures_writes_the_spec_alone_and_says_so(session_path, tmp_path, capsys):
    out = tmp_path / "d"
    status, out_text, err = gasfilm(capsys, "diagnose", session_path, "--out", out, "--json", "--no-figures")
    assert status == 0, err
    result = json.loads(out_text)
    assert result["figures"] == [] and Path(result["improved_spec"]) == out / "improved-rig.toml"
    assert sorted(path.name for path in out.iterdir()) == ["improved-rig.toml"]


def test_model_numbers_the_recorded_hits_from_1(tmp_path, capsys):
    """Before: `gasfilm model s1.h5 --model FOMGF` printed `hit   0: …`."""
    session_path = new_session(tmp_path, capsys)
    assert gasfilm(capsys, "fit", session_path, "--models", "SD", "--out", tmp_path)[0] == 0
    status, out, err = gasfilm(capsys, "model", session_path, "--model", "SD", "--out", tmp_path / "m.json")
    assert status == 0, err
    numbers = [int(line.split()[1].rstrip(":")) for line in out.splitlines() if line.strip().startswith("hit ")]
    assert numbers == [1, 2, 3], out
    status, out, err = gasfilm(capsys, "model", session_path, "--model", "SD", "--out", tmp_path / "j.json", "--json")
    assert status == 0 and json.loads(out)["time_domain"]["hits"] == [1, 2, 3], err


@pytest.mark.parametrize("command, outputs", [
    ("diagnose", ["--out", "{out}"]),
    ("fit", ["--out", "{out}"]),
    ("export", ["--csv", "{out}/x.csv"]),
    ("replay", ["--out", "{out}/x.h5"]),
    ("report", ["--out", "{out}/x.html"]),
    ("model", ["--out", "{out}/x.json"]),
])
def test_the_input_is_checked_before_the_outputs(command, outputs, tmp_path, capsys):
    """Before: `gasfilm diagnose s1.csv` said `--out out/diagnosis/improved-rig.toml: exists already`."""
    out = tmp_path / "out"
    out.mkdir()
    for name in ("improved-rig.toml", "x-figure18.png", "x.csv", "x.h5", "x.html", "x.json", "folder-figure18.png",
                 "missing-figure18.png"):
        (out / name).write_text("an earlier output")
    flags = [flag.format(out=out) for flag in outputs]
    text = tmp_path / "x.csv"
    text.write_text("frequency,H1\n")
    err = one_line_error(capsys, command, text, *flags)
    assert f"{text}: wrong file type" in err and "exists" not in err, err
    err = one_line_error(capsys, command, tmp_path / "missing.h5", *flags)
    assert f"{tmp_path / 'missing.h5'}: no such session file" in err, err
    folder = tmp_path / "folder"
    folder.mkdir()
    err = one_line_error(capsys, command, folder, *flags)
    assert f"{folder}: is a folder" in err, err


def test_a_file_where_a_folder_is_needed_is_called_a_file(session_path, tmp_path, capsys):
    """Before: `export s1.h5 --csv notes.txt/x.csv` said "the folder notes.txt does not exist"."""
    from gasfilm.analysis.spectra import write_frf_csv

    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    for argv in (("export", session_path, "--csv", notes / "x.csv"),
                 ("export", session_path, "--uff", notes / "deeper" / "x.uff"),
                 ("report", session_path, "--out", notes / "r.html"),
                 ("replay", session_path, "--out", notes / "x.h5"),
                 ("fit", session_path, "--out", notes / "figures"),
                 ("diagnose", session_path, "--out", notes / "d"),
                 ("acquire", *FAST_SIM, "--out", notes / "a.h5", "--hits", 1)):
        err = one_line_error(capsys, *argv)
        assert f"{notes} is a file, not a folder" in err and "does not exist" not in err, err
    assert notes.read_text() == "mine"
    err = one_line_error(capsys, "export", session_path, "--csv", tmp_path / "nowhere" / "x.csv")
    assert f"the folder {tmp_path / 'nowhere'} does not exist" in err
    with pytest.raises(Exception, match="is a file, not a folder"):
        with Session.open(session_path) as session:
            write_frf_csv(session.read_frf(), notes / "x.csv")


def test_version_is_printed(capsys):
    from importlib.metadata import version

    from gasfilm.app.cli import main

    with pytest.raises(SystemExit) as ended:
        main(["--version"])
    assert ended.value.code == 0
    assert capsys.readouterr().out == f"gasfilm {version('gasfilm')}\n"


def test_a_diagnosis_refused_by_the_measurement_checks_names_the_file(tmp_path, capsys):
    """Before: `diagnosis records: only 0 hit(s) have a quiet pre-trigger …` named no file."""
    import numpy as np

    session_path = new_session(tmp_path, capsys, hits=2)
    with Session.open(session_path) as session:
        hits = session.hits()
        rate_hz = session.sample_rate_hz
    paths = []
    for number, hit in enumerate(hits, start=1):  # each record cut to start at its trigger: no quiet pre-trigger
        force_n, response = hit.data[hit.force_channel], hit.data[hit.response_channel]
        start = max(hit.trigger_index - 2, 0)
        time_s = np.arange(force_n.size - start) / rate_hz
        paths.append(tmp_path / f"cut{number}.npy")
        np.save(paths[-1], np.vstack((time_s, force_n[start:], response[start:])))
    from gasfilm.analysis.diagnosis.recordings import load_recordings

    source = load_recordings(paths).source
    err = one_line_error(capsys, "diagnose", *paths, "--mass", "25", "--out", tmp_path / "d")
    assert err.startswith(f"gasfilm diagnose: error: {source}: only 0 hit(s) have a quiet pre-trigger"), err
    assert "diagnosis records" not in err
    err = one_line_error(capsys, "diagnose", session_path, "--band", "100:101", "--out", tmp_path / "e")
    assert "error: --band 100:101: fewer than 8 frequency lines" in err  # a flag's refusal names the flag


def test_campaign_refuses_a_by_key_no_session_records_before_computing(tmp_path, capsys):
    """Before: `campaign --by` with a key no session has only warned after every session was computed, exit 0."""
    folder = tmp_path / "sessions"
    folder.mkdir()
    for number, pressure in enumerate(("0.4", "0.5"), start=1):
        status, _, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", folder / f"s{number}.h5", "--hits", 1,
                                 "--condition", f"supply_pressure_mpa={pressure}", "--condition", "bearing=B-17")
        assert status == 0, err
    out = tmp_path / "campaign"
    err = one_line_error(capsys, "campaign", folder, "--by", "gap_um", "--out", out, "--models", "SD",
                         "--no-diagnosis", "--workers", 1)
    assert "--by gap_um: no session records this condition" in err and "record: bearing, supply_pressure_mpa" in err
    assert not (out / "campaign.parquet").exists() and not (out / "cache").exists()


def test_replay_says_when_the_pretrigger_asked_is_longer_than_the_records_hold(session_path, tmp_path, capsys):
    """Before: `replay --pretrigger-s 0.3` on records with 10 ms before their trigger printed nothing about it and
    stored 0.3 s as the new session's pre-trigger: 0.29 s of pulse and ringing that the diagnosis would take for the
    quiet part measuring the noise."""
    out_path = tmp_path / "longer-pretrigger.h5"
    status, out, err = gasfilm(capsys, "replay", session_path, "--pretrigger-s", "0.1", "--out", out_path)
    assert status == 0, err
    assert "--pretrigger-s 0.1 s: 3 of 3 records hold less before their trigger" in out
    with Session.open(out_path, "r") as session:
        assert session.settings["trigger"]["pretrigger_s"] == pytest.approx(0.01, abs=2e-4)
    status, out, err = gasfilm(capsys, "replay", session_path, "--pretrigger-s", "0.005", "--json")
    assert status == 0 and json.loads(out)["pretrigger_note"] is None
    # a pre-trigger that leaves no record is refused by its own flag, not by --record-s (which was not typed)
    err = one_line_error(capsys, "replay", session_path, "--pretrigger-s", "0.2")
    assert err.startswith("gasfilm replay: error: --pretrigger-s: 0.2 s leaves no record") and "0.25 s long" in err


def test_replay_refuses_a_trigger_level_above_every_stored_force_up_front(session_path, capsys):
    """Before: every record was re-triggered, then 'records that no longer trigger: 3', 'no accepted hits', exit 1."""
    err = one_line_error(capsys, "replay", session_path, "--trigger-n", "1e5")
    assert "--trigger-n: 100000 N is above every stored record's force (largest peak" in err


def test_acquire_out_dot_is_called_a_folder(tmp_path, capsys, monkeypatch):
    """New-user trial, round 3: `acquire --out .` was 'internal error: ValueError: PosixPath('.') has an empty name'."""
    monkeypatch.chdir(tmp_path)
    err = one_line_error(capsys, "acquire", *FAST_SIM, "--out", ".", "--hits", "1")
    assert "--out .: is a folder; name the session file in it" in err


def test_diagnoses_of_two_sessions_without_out_go_to_their_own_folders(session_path, tmp_path, capsys, monkeypatch):
    """New-user trial, round 3: `diagnose g.h5` then `diagnose s1.h5` was refused with '--out out/diagnosis/
    improved-rig.toml: exists already' — a flag nobody typed — and the --overwrite it suggested would have destroyed
    the first session's results."""
    import shutil

    monkeypatch.chdir(tmp_path)
    first, other = tmp_path / "first.h5", tmp_path / "other.h5"
    shutil.copy(session_path, first)  # (the module's session stays as it is)
    shutil.copy(session_path, other)
    for source in (first, other):
        status, out, err = gasfilm(capsys, "diagnose", source)
        assert status == 0, err
        assert (tmp_path / f"{source.stem}-diagnosis" / "improved-rig.toml").is_file()  # beside it (issue 32)
    err = one_line_error(capsys, "diagnose", other)
    assert f"{tmp_path / 'other-diagnosis'}: holds an earlier diagnosis of other.h5 (its default folder)" in err
    assert "--out " in err


def test_append_takes_the_sessions_own_settings_unless_typed(tmp_path, capsys):
    """New-user trial, round 3: `acquire --append` without the first run's --rate failed with 'the session is closed';
    rate and record length had to be retyped, --exp-end silently went back to its default and the conditions were
    printed 'not recorded'."""
    path = tmp_path / "appended.h5"
    fast = ["--device", "sim", "--pacing", "fast", "--hit-interval", "0.6", "0.8"]
    status, _, err = gasfilm(capsys, "acquire", *fast, "--out", path, "--hits", 2, "--rate", 25600, "--record-s", 0.5,
                             "--exp-end", 0.1, "--condition", "gap_um=10")
    assert status == 0, err
    status, out, err = gasfilm(capsys, "acquire", *fast, "--out", path, "--hits", 1, "--append")
    assert status == 0, err
    assert ("appending with the session's settings: --rate 25600 --record-s 0.5 --exp-end 0.1 --condition gap_um=10"
            in out) and "gap_um = 10 µm" in out
    with Session.open(path) as session:
        assert session.hit_count == 3 and session.settings["window"]["exponential_end_fraction"] == 0.1
    err = one_line_error(capsys, "acquire", *fast, "--out", path, "--hits", 1, "--append", "--rate", 12800)
    assert "recorded with 2 channels at 25600 S/s; cannot append 2 channels at 12800 S/s (give --rate 25600)" in err


def test_replay_refuses_rectangular_with_a_window_and_counts_one_hit_as_one(session_path, capsys):
    """New-user trial, round 3: `replay --rectangular --exp-end 0.1` ran without saying which won; '1 hits'."""
    err = one_line_error(capsys, "replay", session_path, "--rectangular", "--exp-end", "0.1")
    assert "--rectangular: no window at all, but --exp-end asks for one" in err


def test_the_report_warns_when_a_bands_fits_were_made_with_different_masses(tmp_path, capsys):
    """New-user trial, round 3: after `fit --mass 25050 --overwrite` and `fit --models SD --overwrite` the report's
    Table 2 compared eight models at 25 050 kg with SD at 25.05 kg (E = −471 %) without a word."""
    path = new_session(tmp_path, capsys)
    assert gasfilm(capsys, "fit", path, "--models", "SD,Zener", "--out", tmp_path / "figs")[0] == 0
    assert gasfilm(capsys, "fit", path, "--models", "Zener", "--mass", "30", "--overwrite",
                   "--out", tmp_path / "figs")[0] == 0
    report = tmp_path / "r.html"
    assert gasfilm(capsys, "report", path, "--out", report)[0] == 0
    assert "these fits were made with different mover masses" in report.read_text()
    assert "30 kg: Zener" in report.read_text()


def test_a_force_window_shorter_than_a_sample_is_refused_and_a_second_replay_says_it_replaces(session_path,
                                                                                              tmp_path, capsys):
    """New-user trial, round 3: `--force-window-ms 0.005` (a 156 µs sample at 6400 S/s) was accepted by acquire and
    replay; a second replay replaced the first one's stored result silently."""
    err = one_line_error(capsys, "replay", session_path, "--force-window-ms", "0.005")
    assert "--force-window-ms: 0.005 ms is shorter than one sample (0.156 ms at 6400 S/s)" in err
    err = one_line_error(capsys, "acquire", *FAST_SIM, "--out", tmp_path / "w.h5", "--force-window-ms", "0.005")
    assert "--force-window-ms: 0.005 ms is shorter than one sample" in err
    own = new_session(tmp_path, capsys, hits=2)  # (the module's session may hold a replay already)
    outputs = [gasfilm(capsys, "replay", own)[1] for _ in range(2)]
    assert "replacing" not in outputs[0] and "(replacing the earlier replay's" in outputs[1]


def test_export_and_report_of_a_session_held_by_another_process_say_so(session_path, tmp_path, capsys):
    """New-user trial, round 3: `export --csv` and `report` of a session being recorded quietly wrote what it held
    then. They still do (a look during a recording is useful), and say so."""
    import shutil

    from another_writer import held_by_another_process
    from gasfilm.analysis.session import api

    held = tmp_path / "held.h5"
    shutil.copy(session_path, held)
    with held_by_another_process(held):
        status, out, err = gasfilm(capsys, "export", held, "--csv", tmp_path / "held.csv")
        assert status == 0 and "open for writing in another gasfilm process" in err, (out, err)
        api._SAID_HELD_ELSEWHERE.clear()  # (said once per process; each command is a process of its own)
        status, out, err = gasfilm(capsys, "report", held, "--out", tmp_path / "held.html")
        assert status == 0 and "read as it stands now" in err, (out, err)
    api._SAID_HELD_ELSEWHERE.clear()
    status, _, err = gasfilm(capsys, "export", held, "--csv", tmp_path / "after.csv")
    assert status == 0 and "another gasfilm process" not in err
