"""Stop signals at random moments of a command's start-up (issue 33 item 5): one line, exit 128 + the signal, nothing
left behind — whether the signal lands in the imports, while the session is created, or once the work runs.

Before, SIGINT in the first 0.2 s printed a 21-line traceback, SIGTERM or SIGHUP in the first 1.8 s killed the process
without a word, SIGHUP during the session's creation said "not created" while the file existed, and SIGINT left a
hidden ``.NAME.PID.creating`` file. The installed ``gasfilm`` command handles them from its first instruction
(``gasfilm.app.entry``); the interpreter's own start comes before it, so the test starts each process with the stop
signals blocked (a signal sent then waits for gasfilm's handlers, as it would be handled at gasfilm's first
instruction) — from there on, every moment is gasfilm's.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.session import Session
from test_cli_acquire_replay import FAST_SIM

GASFILM = Path(sys.executable).with_name("gasfilm")
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: (signal, delay after the start in s): random moments over the start-up, each signal at each stage.
MOMENTS_SEED = 33


def blocked_stop_signals() -> None:
    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)


def start(argv: list[str], folder: Path) -> subprocess.Popen:
    return subprocess.Popen([str(GASFILM), *argv], cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=blocked_stop_signals,
                            env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    from gasfilm.app.cli import main

    path = tmp_path_factory.mktemp("startup") / "recorded.h5"
    assert main(["acquire", *FAST_SIM, "--out", str(path), "--hits", "4", "--seed", "1"]) == 0
    return path


@pytest.mark.skipif(not GASFILM.exists() or not hasattr(signal, "pthread_sigmask"),
                    reason="needs the installed gasfilm command and POSIX signal masks")
def test_a_stop_signal_at_any_moment_of_start_up_gives_one_line_and_leaves_nothing(recorded, tmp_path):
    rng = np.random.default_rng(MOMENTS_SEED)
    trials = []
    for number in range(18):
        signum = SIGNALS[number % 3]
        delay_s = float(rng.uniform(0.0, 2.5))
        folder = tmp_path / f"trial-{number}"
        folder.mkdir()
        if number % 2:  # a recording into a new session (realtime: still recording when the signal comes)
            argv = ["acquire", "--device", "sim", "--rate", "6400", "--record-s", "0.25", "--seconds", "1000",
                    "--out", "new.h5"]
            before = None
        else:  # a fit that stores into its session and draws figures
            shutil.copyfile(recorded, folder / "session.h5")
            argv = ["fit", "session.h5", "--models", "all", "--out", "figures"]
            before = (folder / "session.h5").read_bytes()
        trials.append((number, signum, delay_s, folder, argv, before, start(argv, folder)))
        time.sleep(0.05)
    started = time.monotonic()
    pending = sorted(trials, key=lambda trial: trial[2])
    for number, signum, delay_s, folder, argv, before, process in pending:
        time.sleep(max(0.0, started + delay_s - time.monotonic()))
        process.send_signal(signum)
    problems = []
    deadline = time.monotonic() + 120  # (one for all: lost signals cost 2 minutes, not 2 minutes each)
    for number, signum, delay_s, folder, argv, before, process in trials:
        name = signal.Signals(signum).name
        where = f"{argv[0]} {name} at {delay_s:.2f} s"
        try:
            stdout, stderr = process.communicate(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:  # the signal was lost: say which moment, and go on with the others
            process.kill()
            stdout, stderr = process.communicate()
            problems.append(f"{where}: still running 120 s after the signals were sent ({stdout[-200:]!r}, "
                            f"{stderr[-200:]!r})")
            continue
        if process.returncode == 0:  # (a fit can finish before a late signal: then it is complete)
            continue
        if process.returncode != 128 + signum:
            problems.append(f"{where}: exit {process.returncode}: {stderr[-300:]}")
        if "Traceback" in stderr or len(stderr.strip().splitlines()) > 1:
            problems.append(f"{where}: stderr {stderr.strip()[-300:]!r}")
        said = stdout.strip().splitlines()[-1:] + stderr.strip().splitlines()
        if not any("interrupted" in line or f"stopped by {name}" in line for line in said):
            problems.append(f"{where}: nothing said ({stdout[-200:]!r}, {stderr[-200:]!r})")
        left = sorted(os.listdir(folder))
        hidden = [entry for entry in left if entry.startswith(".") or entry.endswith(".journal")]
        if hidden:
            problems.append(f"{where}: left behind {hidden}")
        if argv[0] == "acquire":
            created = (folder / "new.h5").exists()
            if "not created" in stdout and created:
                problems.append(f"{where}: said 'not created' but new.h5 exists")
            if created:
                with Session.open(folder / "new.h5") as session:
                    if session.status != "aborted":
                        problems.append(f"{where}: new.h5 left {session.status}")
        else:
            if (folder / "session.h5").read_bytes() != before:
                problems.append(f"{where}: the stopped fit changed its session")
            figures = folder / "figures"
            if figures.exists() and os.listdir(figures):
                problems.append(f"{where}: the stopped fit left {os.listdir(figures)}")
    assert not problems, "\n".join(problems)
    assert sum(re.search(r"^acquire", " ".join(trial[4])) is not None for trial in trials) >= 9


@pytest.mark.parametrize("stopped", [False, True])
def test_an_import_error_printed_by_an_interrupted_extension_is_silent_only_once_a_stop_signal_came(stopped):
    """numpy's ``import_array`` in an extension module prints the ImportError a stop signal turned its import into
    (through ``sys.excepthook``): after a stop signal the command's one line is all that is said; otherwise an error
    printed that way is still shown."""
    code = "\n".join([
        "import sys",
        "from gasfilm.app import entry",
        "from gasfilm.analysis.interrupts import raise_stop_signal",
        "if sys.argv[1] == 'stopped':",
        "    try:",
        "        raise_stop_signal(1, None)",
        "    except KeyboardInterrupt:",
        "        pass",
        "try:",
        "    raise ImportError('_multiarray_umath failed to import')",
        "except ImportError:",
        "    sys.excepthook(*sys.exc_info())",
    ])
    done = subprocess.run([sys.executable, "-c", code, "stopped" if stopped else "running"], capture_output=True,
                          text=True, timeout=60, check=True)
    assert ("_multiarray_umath failed to import" in done.stderr) is not stopped


def test_a_stop_signal_during_an_import_waits_for_the_import_and_is_then_raised(tmp_path):
    """A stop signal inside an import is not raised there (an extension module would turn it into an ImportError that
    a library may take for a missing optional dependency, and the stop was lost: 6 of 304 starts ran on): the import
    finishes, and the signal is raised once it is done — at once, also when the main thread then waits in a blocking
    call (a re-delivery to another thread would leave it waiting out its sleep)."""
    (tmp_path / "signalled_while_imported.py").write_text("\n".join([
        "import os, signal, time",
        "try:",
        "    os.kill(os.getpid(), signal.SIGHUP)",
        "    time.sleep(0.3)",
        "    print('imported', flush=True)",
        "except BaseException as error:  # what a library's 'except ImportError' would see",
        "    print('raised inside the import:', type(error).__name__, flush=True)",
    ]))
    code = "\n".join([
        "import signal, sys, time",
        "from gasfilm.analysis.interrupts import StopSignal, raise_stop_signal",
        "signal.signal(signal.SIGHUP, raise_stop_signal)",
        f"sys.path.insert(0, {str(tmp_path)!r})",
        "try:",
        "    import signalled_while_imported",
        "    imported = time.monotonic()",
        "    time.sleep(30)",
        "    print('never stopped')",
        "except StopSignal as stop:",
        "    print('stopped by', stop, flush=True)",
        "    print(f'{time.monotonic() - imported:.3f}')",
    ])
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True)
    imported, stopped, waited_s = done.stdout.splitlines()
    assert [imported, stopped] == ["imported", "stopped by SIGHUP"]
    assert float(waited_s) < 5.0, f"the stop waited {waited_s} s after the import (re-delivered after 0.02 s)"
