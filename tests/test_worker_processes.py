"""A killed parent takes its worker processes with it (issue 33 item 7): ``diagnose``'s forked copy and ``campaign``'s
dask nannies and workers, killed with SIGKILL while they compute, leave no process running."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gasfilm.analysis.campaign.simulated import DEMO_RIG_PATH, record_session
from gasfilm.analysis.physics.spec import RigSpec
from test_startup_signals import GASFILM

pytestmark = pytest.mark.skipif(not GASFILM.exists() or not sys.platform.startswith("linux"),
                                reason="needs the installed gasfilm command and Linux's /proc")


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from /proc's children lists)."""
    found, todo = set(), [pid]
    while todo:
        parent = todo.pop()
        for task in Path(f"/proc/{parent}/task").glob("*"):
            try:
                children = [int(child) for child in (task / "children").read_text().split()]
            except OSError:
                continue
            new = set(children) - found
            found |= new
            todo += new
    return found


def alive(pids: set[int]) -> set[int]:
    running = set()
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().split(") ")[-1].split()[0]
        except OSError:
            continue
        if state != "Z":
            running.add(pid)
    return running


def test_killed_diagnose_and_campaign_leave_no_worker_running(tmp_path):
    spec = RigSpec.load(DEMO_RIG_PATH)
    sessions = tmp_path / "sessions"
    sessions.mkdir()
    for number, pressure_mpa in enumerate((0.3, 0.6)):
        record_session(sessions / f"s{number}.h5", spec, {"supply_pressure_mpa": pressure_mpa, "gap_um": 10.0},
                       hits=3, seed=number, record_s=0.25, sample_rate_hz=6400.0)
    shutil.copyfile(sessions / "s0.h5", tmp_path / "diagnosed.h5")
    commands = {
        "diagnose": [str(GASFILM), "diagnose", str(tmp_path / "diagnosed.h5"), "--out", str(tmp_path / "diagnosis")],
        "campaign": [str(GASFILM), "campaign", str(sessions), "--by", "supply_pressure_mpa", "--workers", "1",
                     "--out", str(tmp_path / "campaign")],
    }
    processes = {name: subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                 for name, argv in commands.items()}
    workers: dict[str, set[int]] = {}
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline and len(workers) < len(processes):
            for name, process in processes.items():
                below = alive(descendants(process.pid))
                if below and name not in workers:  # the copy or the workers are computing: kill the parent now
                    time.sleep(0.5)
                    workers[name] = alive(descendants(process.pid)) | below
                    os.kill(process.pid, signal.SIGKILL)
                    process.wait(30)
                assert process.poll() is None or name in workers, f"{name} ended before it had workers"
            time.sleep(0.05)
        assert set(workers) == set(processes), f"no workers seen for {set(processes) - set(workers)}"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and any(alive(pids) for pids in workers.values()):
            time.sleep(0.5)
        assert {name: alive(pids) for name, pids in workers.items()} == {name: set() for name in workers}
    finally:
        for process in processes.values():
            if process.poll() is None:
                process.kill()
                process.wait()
        for pids in workers.values():
            for pid in alive(pids):
                os.kill(pid, signal.SIGKILL)
