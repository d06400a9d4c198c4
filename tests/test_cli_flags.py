"""Settings that cannot give a valid hit are refused up front, under the flag the user typed; the command's own
usage on a typo; no raw warnings, no BrokenPipeError, no progress bar off a terminal, a fast --help."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import warnings

import pytest

from gasfilm.app import cli
from test_cli_acquire_replay import FAST_SIM, gasfilm

FIELD_NAMES = ("record_s", "level_n", "pretrigger_s", "hysteresis_n", "double_hit_fraction", "force_window_ms",
               "exponential_end_fraction", "hit_interval_s")


@pytest.mark.parametrize("flags, named", [
    (("--record-s", 100), "--record-s"),
    (("--record-s", 0), "--record-s"),
    (("--trigger-n", -20), "--trigger-n"),
    (("--trigger-n", 0), "--trigger-n"),
    (("--trigger-n", "nan"), "--trigger-n"),
    (("--pretrigger-s", 0.5), "--pretrigger-s"),
    (("--hits", 0), "--hits"),
    (("--hits", -3), "--hits"),
    (("--seconds", 0), "--seconds"),
    (("--hit-interval", 3, 1), "--hit-interval"),
    (("--hit-interval", 0, 1), "--hit-interval"),
    (("--hit-interval", 0.1, 0.2), "--hit-interval"),  # every hit inside the previous 0.25 s record
    (("--exp-end", 2), "--exp-end"),
    (("--force-window-ms", -1), "--force-window-ms"),
    (("--double-hit-fraction", 1.5), "--double-hit-fraction"),
])
def test_acquire_refuses_settings_that_cannot_give_a_hit_naming_the_flag(tmp_path, capsys, flags, named):
    out_path = tmp_path / "never.h5"
    limit = () if flags[0] in ("--hits", "--seconds") else ("--hits", 2)
    status, out, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", out_path, *limit, *flags)
    assert status == 2, err
    assert err.startswith(f"gasfilm acquire: error: {named}") and err.count("\n") == 1, err
    assert not any(field in err for field in FIELD_NAMES), err
    assert not out_path.exists() and not out_path.with_suffix(".log").exists()


def test_pretrigger_message_names_both_flags(tmp_path, capsys):
    status, _, err = gasfilm(capsys, "acquire", *FAST_SIM, "--out", tmp_path / "x.h5", "--pretrigger-s", 0.3)
    assert status == 2 and "--pretrigger-s" in err and "--record-s" in err and "record_s" not in err, err


@pytest.mark.parametrize("argv, line", [
    (["acquire", "--out", "x.h5", "--hitz", "3"],
     "gasfilm acquire: error: unrecognized arguments: --hitz 3; did you mean --hits? (`gasfilm acquire --help` lists "
     "the flags)"),
    (["acquire", "--out", "x.h5", "--hits", "three"],
     "gasfilm acquire: error: argument --hits: invalid int value: 'three' (`gasfilm acquire --help` lists the flags)"),
    (["fitt"], "gasfilm: error: argument COMMAND: invalid choice: 'fitt' (choose from"),
])
def test_a_usage_error_is_one_line_with_the_nearest_flag(capsys, argv, line):
    """New-user trial, round 3: every usage error printed the whole usage block (15+ lines); one line now, as every
    other refusal, with the nearest flag or command for a typo."""
    with pytest.raises(SystemExit) as stop:
        cli.main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(line), err
    if argv == ["fitt"]:
        assert "did you mean 'fit'?" in err


def test_replay_that_gives_no_frf_exits_non_zero(tmp_path, capsys):
    path = tmp_path / "run.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3)[0] == 0
    status, _, err = gasfilm(capsys, "replay", path, "--trigger-n", -1)
    assert status == 2 and err.startswith("gasfilm replay: error: --trigger-n") and "level_n" not in err, err
    status, out, _ = gasfilm(capsys, "replay", path, "--min-force-snr", 1e12, "--json")
    assert status == 1 and json.loads(out)["accepted"] == 0
    status, _, err = gasfilm(capsys, "replay", path, "--trigger-n", 1e6)  # no record would trigger: said up front
    assert status == 2 and "above every stored record's force" in err
    log = path.with_suffix(".log").read_text()
    assert "recording into" in log and "3 accepted" in log  # acquire's log next to the session


def test_python_warnings_become_one_clean_line(capsys):
    with cli._user_messages("replay"), warnings.catch_warnings():
        warnings.simplefilter("always")
        for _ in range(3):
            warnings.warn("overload on channel ai1", RuntimeWarning)
        logging.getLogger("gasfilm.analysis.capture").info("not for the user")
    err = capsys.readouterr().err
    assert err == "gasfilm replay: WARNING: RuntimeWarning: overload on channel ai1\n"


def test_fit_draws_no_progress_bar_off_a_terminal(tmp_path, capsys):
    path = tmp_path / "run.h5"
    assert gasfilm(capsys, "acquire", *FAST_SIM, "--out", path, "--hits", 3)[0] == 0
    status, out, err = gasfilm(capsys, "fit", path, "--models", "SD")
    assert status == 0, err
    assert "%" not in err and "\r" not in err and "[" not in err, err
    assert "Identified parameters" in out and "N/m" in out and "±" in out


def run_cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gasfilm.app.cli", *argv], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "GASFILM_DEBUG": "0"})


def test_json_into_a_closed_pipe_ends_quietly(tmp_path):
    path = tmp_path / "run.h5"
    assert run_cli("acquire", *map(str, FAST_SIM), "--out", str(path), "--hits", "3").returncode == 0
    # `gasfilm replay --json | head -c 0`: the reader has gone before the first byte is written (reading a few bytes
    # first would race: a small JSON can fit the pipe's buffer before the reader closes it)
    producer = subprocess.Popen([sys.executable, "-m", "gasfilm.app.cli", "replay", str(path), "--json"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    producer.stdout.close()
    err = producer.stderr.read().decode()
    assert producer.wait(timeout=60) == cli.BROKEN_PIPE_STATUS, err
    assert err == "", err


def test_registering_the_commands_imports_no_heavy_library():
    code = ("import sys; from gasfilm.app.cli import build_parser; build_parser(); "
            "print(sorted(m for m in ('numpy', 'scipy', 'h5py', 'matplotlib', 'PySide6', 'pyuff') if m in sys.modules))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert result.stdout.strip() == "[]", result.stderr
    assert run_cli("--help").returncode == 0 and "fit" in run_cli("--help").stdout


def test_a_user_error_shows_where_it_was_raised_only_with_gasfilm_debug_2(tmp_path):
    missing = tmp_path / "missing.h5"
    plain = run_cli("replay", str(missing))
    assert plain.returncode == 2 and plain.stderr == f"gasfilm replay: error: {missing}: no such session file\n"
    traced = subprocess.run([sys.executable, "-m", "gasfilm.app.cli", "replay", str(missing)], capture_output=True,
                            text=True, timeout=120, env={**os.environ, "GASFILM_DEBUG": "2"})
    assert traced.returncode == 2 and traced.stderr.startswith("Traceback")
    assert traced.stderr.endswith(f"gasfilm replay: error: {missing}: no such session file\n")
    internal_only = subprocess.run([sys.executable, "-m", "gasfilm.app.cli", "replay", str(missing)],
                                   capture_output=True, text=True, timeout=120, env={**os.environ, "GASFILM_DEBUG": "1"})
    assert internal_only.stderr == plain.stderr  # GASFILM_DEBUG=1 traces internal errors only
