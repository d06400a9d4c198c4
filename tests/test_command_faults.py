"""A command that fails leaves its input session byte for byte as it found it, or completes what it reported, and a full
disk on any output is one line and no partial file (issue 33 items 2 and 3).

The faults are real: tests/faults/failing_writes.c, preloaded, makes one of the process's writes fail (the disk full
from write N on, or write N alone failing with EIO), and tests/faults/command_write_faults.py runs a command with each
sampled write failing in turn, comparing the session's bytes before and after. ``command_write_faults.py SHIM MODE``
without ``--every`` fails every write of every command (``benchmarks/README.md`` has the figures); the test samples.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from test_session_journal import FAULTS, failing_writes, preloaded  # noqa: F401 - the fixture


@pytest.mark.parametrize("mode, commands, every", [
    ("disk-full", ["append", "fit", "export-uff"], 17),
    ("one-write", ["replay", "model", "export-csv"], 9),
])
def test_a_failed_write_in_a_command_leaves_its_session_as_it_was(failing_writes, mode, commands, every):  # noqa: F811
    run = subprocess.run([sys.executable, str(FAULTS / "command_write_faults.py"), str(failing_writes), mode,
                          "--commands", *commands, "--every", str(every)],
                         env=preloaded(failing_writes), capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    results = [json.loads(line) for line in run.stdout.splitlines() if line.startswith("{")]
    assert [result["command"] for result in results] == commands
    for result in results:
        assert result["problems"] == [], result
        assert result["trials"] >= 3, result
        failures = {answer: count for answer, count in result["answers"].items() if answer != "completed"}
        assert failures, result  # the faults did happen, and were answered in one line each
