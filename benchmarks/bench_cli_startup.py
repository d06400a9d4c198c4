"""Command-line start-up benchmark: wall time of ``gasfilm --help`` and ``gasfilm fit --help`` in fresh processes.

Goal (issue 10 item 10): at most 0.3 s each; registering the commands imports no numpy, scipy, h5py, matplotlib or
Qt (each command imports them when it runs). Run: ``.venv/bin/python benchmarks/bench_cli_startup.py [--repeats 7]``.
The median of the repeats is printed, with the fastest and slowest.
"""

from __future__ import annotations

import argparse
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


def time_command(argv: list[str], repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - started)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    command = gasfilm_command()
    print(f"gasfilm start-up ({' '.join(command)}), {args.repeats} runs each, goal <= {GOAL_S} s")
    for extra in (["--help"], ["fit", "--help"]):
        times = time_command(command + extra, args.repeats)
        median = statistics.median(times)
        print(f"  gasfilm {' '.join(extra):<12} median {median:6.3f} s  (min {min(times):.3f}, max {max(times):.3f})"
              f"  {'ok' if median <= GOAL_S else 'SLOWER THAN THE GOAL'}")


if __name__ == "__main__":
    main()
