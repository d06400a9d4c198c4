"""Memory running out is one line naming it (issue 33 item 6): under ``ulimit -v`` of 100 or 200 MB a command refused
up front (was a bare "OpenBLAS error: Memory allocation still failed", or "internal error: ImportError … failed to map
segment", or OpenBLAS retrying its buffers for ever), at 450 MB a fit runs (one BLAS thread reserves its buffer, not
one per core), and a record too large for the limit is "out of memory", naming the limit."""

from __future__ import annotations

import resource
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from test_startup_signals import GASFILM, recorded  # noqa: F401 - the fixture

pytestmark = pytest.mark.skipif(not GASFILM.exists() or not sys.platform.startswith("linux"),
                                reason="needs the installed gasfilm command and Linux resource limits")


def limited(megabytes: int):
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (megabytes << 20, megabytes << 20))

    return apply


def run_limited(megabytes: int, *argv: str, folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(GASFILM), *argv], cwd=folder, capture_output=True, text=True, timeout=300,
                          preexec_fn=limited(megabytes))


@pytest.mark.parametrize("megabytes", [100, 200])
def test_too_little_memory_to_start_is_one_line(megabytes, recorded, tmp_path):  # noqa: F811
    run = run_limited(megabytes, "fit", str(recorded), "--models", "SD", "--out", "figures", folder=tmp_path)
    assert run.returncode == 2, run.stderr
    assert run.stderr.count("\n") == 1 and "out of memory" in run.stderr and f"{megabytes} MB" in run.stderr, run.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_fit_runs_in_450_mb_and_a_record_too_large_is_out_of_memory(recorded, tmp_path):  # noqa: F811
    session = tmp_path / "session.h5"
    shutil.copyfile(recorded, session)
    run = run_limited(450, "fit", str(session), "--models", "SD", "--out", "figures", folder=tmp_path)
    assert run.returncode == 0, run.stderr
    huge = tmp_path / "huge.npy"  # 300 MB of samples (sparse on disk): more than 450 MB leaves for it
    with huge.open("wb") as stream:
        np.lib.format.write_array_header_1_0(stream, {"descr": "<f8", "fortran_order": False,
                                                      "shape": (3, 12_500_000)})
        stream.truncate(stream.tell() + 3 * 12_500_000 * 8)
    run = run_limited(450, "replay", str(huge), "--json", folder=tmp_path)
    assert run.returncode == 2 and run.stdout == "", run.stderr
    assert run.stderr.count("\n") == 1 and "out of memory (this process may use 450 MB" in run.stderr, run.stderr
