"""Command-line start-up benchmark: wall time of ``gasfilm --help`` and ``gasfilm fit --help`` in fresh processes.

Goal (issue 10 item 10): at most 0.3 s each; registering the commands imports no numpy, scipy, h5py, matplotlib or
Qt (each command imports them when it runs). Run: ``.venv/bin/python benchmarks/bench_cli_startup.py [--repeats 7]``.
The median wall time of the repeats is printed, with the fastest and slowest, and the median CPU time of the process
(user + system), which a loaded machine inflates far less than the wall time.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

GOAL_S = 0.3


def gasfilm_command() -> list[str]:
    """The installed ``gasfilm`` script next to this interpreter (as a user runs it), else ``python -m``."""
    script = Path(sys.executable).with_name("gasfilm")
    if script.exists():
        return [str(script)]
    found = shutil.which("gasfilm")
    return [found] if found else [sys.executable, "-m", "gasfilm.app.cli"]


def time_command(argv: list[str], repeats: int) -> tuple[list[float], list[float]]:
    """Wall times and CPU times (user + system of the child) in s, one per run."""
    wall, cpu = [], []
    for _ in range(repeats):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    command = gasfilm_command()
    print(f"gasfilm start-up ({' '.join(command)}), {args.repeats} runs each, goal <= {GOAL_S} s")
    for extra in (["--help"], ["fit", "--help"]):
        wall, cpu = time_command(command + extra, args.repeats)
        median = statistics.median(wall)
        print(f"  gasfilm {' '.join(extra):<12} wall median {median:6.3f} s (min {min(wall):.3f}, max {max(wall):.3f}),"
              f" CPU median {statistics.median(cpu):.3f} s  {'ok' if median <= GOAL_S else 'SLOWER THAN THE GOAL'}")


if __name__ == "__main__":
    main()
