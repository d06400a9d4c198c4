"""Campaign benchmark: simulated sessions analysed serially in one process and on a 2-worker dask LocalCluster.

Goal (issue 16): 200 sessions, speed-up ≥ 1.8× with 2 local workers on 2 cores; it prints the speed-up, the time
per session (serial and with the workers), the peak memory of each worker process and of the serial process, and
the machine's load average before and after (on a shared machine other processes take cores: the speed-up then says
more about them than about dask). The serial run calls the same task function as the workers, in this process,
without dask. Both runs compute every session (no cache) and must give the same rows. Run:
``.venv/bin/python benchmarks/bench_campaign.py [--sessions 200] [--hits 3] [--models all] [--no-diagnosis]``.
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures
import multiprocessing
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

# one BLAS/OpenMP thread in the serial process, as dask's nanny sets for every worker (distributed's
# ``nanny.pre-spawn-environ``): otherwise "serial" would use both cores inside numpy and the comparison would be unfair
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from gasfilm.analysis.campaign import RUN_COLUMNS, CampaignOptions, analyse_session
from gasfilm.analysis.campaign.runner import run_sessions
from gasfilm.analysis.campaign.simulated import DEMO_RIG_PATH, grid_points, record_session
from gasfilm.analysis.physics.elements import PAPER_MODEL_ORDER
from gasfilm.analysis.physics.spec import RigSpec

#: The benchmark's operating points (cycled over the sessions).
GRID = {"supply_pressure_mpa": (0.3, 0.4, 0.5, 0.6), "gap_um": (8.0, 10.0, 12.0)}


def comparable(rows: list[dict]) -> list[dict]:
    return [{key: value for key, value in row.items() if key not in RUN_COLUMNS} for row in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=200)
    parser.add_argument("--hits", type=int, default=3, help="accepted hits per session")
    parser.add_argument("--record-s", type=float, default=0.5, help="record length per hit in s")
    parser.add_argument("--models", default="all", help="comma-separated model names or 'all'")
    parser.add_argument("--no-diagnosis", action="store_true")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--folder", type=Path, help="keep the sessions here (default: a temporary folder)")
    parser.add_argument("--no-pool", action="store_true",
                        help="skip the peer: the same tasks on a plain process pool of as many workers, no dask")
    args = parser.parse_args()

    models = PAPER_MODEL_ORDER if args.models == "all" else tuple(args.models.split(","))
    options = CampaignOptions(models=tuple(models), diagnose=not args.no_diagnosis)
    spec = RigSpec.load(DEMO_RIG_PATH)
    points = grid_points(GRID)
    with tempfile.TemporaryDirectory() as temporary:
        folder = args.folder or Path(temporary)
        folder.mkdir(parents=True, exist_ok=True)
        print(f"cores {os.cpu_count()}, load average {os.getloadavg()[0]:.1f} (1 min) before; {args.sessions} "
              f"sessions × {args.hits} hits of {args.record_s:g} s, models {','.join(models)}, diagnosis "
              f"{'off' if args.no_diagnosis else 'on'}", flush=True)
        started = time.perf_counter()
        paths = []
        for number in range(args.sessions):
            path = folder / f"session-{number:04d}.h5"
            if not path.exists():
                record_session(path, spec, points[number % len(points)], args.hits, seed=number,
                               record_s=args.record_s)
            paths.append(path)
        print(f"recorded {len(paths)} sessions in {time.perf_counter() - started:.1f} s "
              f"({sum(path.stat().st_size for path in paths) / 1e6:.1f} MB)", flush=True)

        started = time.perf_counter()
        serial = [analyse_session(str(path), options) for path in paths]
        serial_s = time.perf_counter() - started
        serial_peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
        print(f"serial (one process, no dask): {serial_s:.1f} s, {serial_s / len(paths):.2f} s per session, "
              f"peak memory {serial_peak_mb:.0f} MB, task CPU median "
              f"{sorted(row['cpu_seconds'] for row in serial)[len(serial) // 2]:.2f} s", flush=True)

        parallel = run_sessions(paths, options, cache_folder=None, workers=args.workers)
        parallel_s = parallel.wall_time_s
        peaks = collections.defaultdict(float)
        for row in parallel.rows:
            peaks[row.get("worker", "?")] = max(peaks[row.get("worker", "?")], row.get("worker_peak_rss_mb", 0.0))
        print(f"dask LocalCluster, {parallel.workers} workers: {parallel_s:.1f} s (cluster start included), "
              f"{parallel_s / len(paths):.2f} s per session; peak memory per worker: "
              + ", ".join(f"{peak:.0f} MB" for peak in peaks.values()), flush=True)
        task_s = sorted(row["seconds"] for row in parallel.rows)
        cpu_s = sorted(row["cpu_seconds"] for row in parallel.rows)
        print(f"task time per session on the workers: median {task_s[len(task_s) // 2]:.2f} s wall, "
              f"{cpu_s[len(cpu_s) // 2]:.2f} s CPU (max {task_s[-1]:.2f} s wall, {cpu_s[-1]:.2f} s CPU)")
        if not args.no_pool:
            # the peer: what two plain processes reach on this machine, without dask's scheduler, nanny or transport
            started = time.perf_counter()
            with concurrent.futures.ProcessPoolExecutor(args.workers,
                                                        mp_context=multiprocessing.get_context("spawn")) as pool:
                pooled = list(pool.map(analyse_session, [str(path) for path in paths], [options] * len(paths)))
            pool_s = time.perf_counter() - started
            pool_cpu_s = sorted(row["cpu_seconds"] for row in pooled)
            print(f"peer, plain process pool of {args.workers} (no dask): {pool_s:.1f} s, speed-up "
                  f"{serial_s / pool_s:.2f}×, task CPU median {pool_cpu_s[len(pool_cpu_s) // 2]:.2f} s; dask reaches "
                  f"{pool_s / parallel_s:.2f} of the pool's speed; rows identical: "
                  f"{comparable(pooled) == comparable(serial)}", flush=True)
        failed = sum(1 for row in serial if row.get("error"))
        same = comparable(serial) == comparable(parallel.rows)
        print(f"speed-up {serial_s / parallel_s:.2f}× (goal ≥ 1.8× on 2 otherwise idle cores); failed sessions "
              f"{failed}; serial and dask rows identical: {same}; load average after {os.getloadavg()[0]:.1f}")
        if not same or failed:
            sys.exit(1)


if __name__ == "__main__":
    main()
