"""Command-line overhead: ``gasfilm --help`` and ``gasfilm fit --help`` in fresh processes, and ``gasfilm fit`` and
``gasfilm diagnose`` end to end against the work they do.

Goals: ``--help`` at most 0.3 s (issue 10 item 10: registering the commands imports no numpy, scipy, h5py,
matplotlib or Qt); a command at most about 1 s more than its work (issue 32 item 16): ``fit --models SD,FOMGF`` of a
4-hit session against the fits' own time (``wall_time_s`` of each fit in its JSON), ``diagnose`` against the
diagnosis's (``diagnosis_s``). The session is recorded on the simulated rig first (not timed).

Run: ``.venv/bin/python benchmarks/bench_cli_startup.py [--repeats 7]``. The median wall time of the repeats is
printed with the fastest and slowest, and the median CPU time of the process (user + system, children included),
which a loaded machine inflates far less than the wall time.
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine import machine_line  # noqa: E402

HELP_GOAL_S = 0.3
OVERHEAD_GOAL_S = 1.0


def gasfilm_command() -> list[str]:
    """The installed ``gasfilm`` script next to this interpreter (as a user runs it), else ``python -m``."""
    script = Path(sys.executable).with_name("gasfilm")
    if script.exists():
        return [str(script)]
    found = shutil.which("gasfilm")
    return [found] if found else [sys.executable, "-m", "gasfilm.app.cli"]


def time_command(argv: list[str], repeats: int, before=None) -> tuple[list[float], list[float], list[str]]:
    """Wall times and CPU times (user + system of the children) in s, and the outputs, one per run; ``before()``
    runs untimed before each."""
    wall, cpu, outputs = [], [], []
    for _ in range(repeats):
        if before is not None:
            before()
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        result = subprocess.run(argv, check=True, capture_output=True, text=True)
        wall.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - usage.ru_utime + after.ru_stime - usage.ru_stime)
        outputs.append(result.stdout)
    return wall, cpu, outputs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    command = gasfilm_command()
    print(machine_line())
    print(f"gasfilm start-up ({' '.join(command)}), {args.repeats} runs each, goal <= {HELP_GOAL_S} s")
    for extra in (["--help"], ["fit", "--help"]):
        wall, cpu, _ = time_command(command + extra, args.repeats)
        median = statistics.median(wall)
        print(f"  gasfilm {' '.join(extra):<12} wall median {median:6.3f} s (min {min(wall):.3f}, max {max(wall):.3f}),"
              f" CPU median {statistics.median(cpu):.3f} s  {'ok' if median <= HELP_GOAL_S else 'SLOWER THAN THE GOAL'}")

    with tempfile.TemporaryDirectory(prefix="gasfilm-bench-cli-") as folder:
        session = Path(folder) / "bench.h5"
        subprocess.run(command + ["acquire", "--device", "sim", "--pacing", "fast", "--rate", "6400", "--record-s",
                                  "0.5", "--hit-interval", "0.6", "0.8", "--hits", "4", "--seed", "1", "--out",
                                  str(session)], check=True, capture_output=True)
        print(f"commands end to end against their work ({args.repeats} runs each), goal: at most "
              f"{OVERHEAD_GOAL_S:g} s more than the work")
        fit_argv = command + ["fit", str(session), "--models", "SD,FOMGF", "--json", "--overwrite"]
        wall, cpu, outputs = time_command(fit_argv, args.repeats)
        work = [sum(fit["wall_time_s"] for fit in json.loads(out)["fits"]) for out in outputs]
        report("fit --models SD,FOMGF", wall, cpu, work)
        wall, cpu, outputs = time_command(command + ["fit", str(session), "--models", "SD,FOMGF", "--json",
                                                     "--overwrite", "--figures"], args.repeats)
        work = [sum(fit["wall_time_s"] for fit in json.loads(out)["fits"]) for out in outputs]
        report("  … --figures", wall, cpu, work)
        out_folder = Path(folder) / "diagnosis"
        wall, cpu, outputs = time_command(
            command + ["diagnose", str(session), "--json", "--out", str(out_folder), "--overwrite"], args.repeats)
        work = [json.loads(out)["diagnosis_s"] for out in outputs]
        report("diagnose", wall, cpu, work)


def report(name: str, wall: list[float], cpu: list[float], work: list[float]) -> None:
    overhead = [total - part for total, part in zip(wall, work)]
    median = statistics.median(overhead)
    print(f"  gasfilm {name:<22} wall median {statistics.median(wall):6.2f} s, work {statistics.median(work):5.2f} s,"
          f" overhead {median:5.2f} s (min {min(overhead):.2f}, max {max(overhead):.2f}), CPU median "
          f"{statistics.median(cpu):5.2f} s  {'ok' if median <= OVERHEAD_GOAL_S else 'MORE THAN THE GOAL'}")


if __name__ == "__main__":
    main()
