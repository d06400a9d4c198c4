"""How fast a session stores hits and results, and what storing costs against the session's size.

1. Rate (issue 15 items 23–24): hits of a typical record's size (hammer and accelerometer, 12 800 samples: 200 kB) appended
   to a new session with ``Session.append_hit`` (each committed through the rollback journal: held metadata journaled
   and fsynced, written and fsynced), and, as the peer measured in the same run, the same records to a bare h5py SWMR
   dataset flushed and fsynced per hit.
2. Cost against size (issue 33 item 7): sessions of 10, 100 and 1 000 such hits (2 MB to 205 MB); in a fresh process
   each, one hit appended (``Session.open(path, "a")``, ``append_hit``, close) and one fit stored (``Session.updating``,
   ``write_fit``), timed and with the process's peak memory over its baseline; the peer is bare h5py appending the
   same hit to the same file (open, resize, write, close). Storing costs the result, not the session: the times and
   the memory stay flat from 10 to 1 000 hits (before the rollback journal, opening for writing rewrote the session:
   5.9 s and 554 MB to append a hit to a 1 000-hit session, 9.8 s and 684 MB for ``gasfilm fit --models SD``).
   With ``--cli``, also ``gasfilm fit SESSION --models SD`` and ``gasfilm acquire --append --hits 1`` end to end (the
   latter averages the session's FRF again over all its hits, by design).

Run: ``.venv/bin/python benchmarks/bench_session_append.py [--hits 100] [--samples 12800] [--sizes 10 100 1000]
[--cli] [--folder DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_session import RATE_HZ, new_session, synthetic_hits  # noqa: E402

from gasfilm.analysis.validation import Verdict  # noqa: E402


def session_rate(folder: Path, hits: list) -> float:
    start = time.perf_counter()
    with new_session(folder / "session.h5") as session:
        for hit in hits:
            session.append_hit(hit, Verdict(True))
    return len(hits) / (time.perf_counter() - start)


def bare_swmr_rate(folder: Path, hits: list) -> float:
    start = time.perf_counter()
    channels, samples = hits[0].data.shape
    with h5py.File(folder / "bare.h5", "w", libver="latest", locking=False) as file:
        data = file.create_dataset("data", shape=(0, channels, samples), maxshape=(None, channels, samples),
                                   chunks=(1, channels, min(samples, 16384)), dtype="<f8")
        times = file.create_dataset("time", shape=(0,), maxshape=(None,), chunks=(64,), dtype="<f8")
        file.swmr_mode = True
        for index, hit in enumerate(hits):
            data.resize((index + 1, channels, samples))
            data[index] = hit.data
            data.flush()
            times.resize((index + 1,))
            times[index] = hit.start_time_s
            times.flush()
            file.flush()
            os.fsync(file.id.get_vfd_handle())
    return len(hits) / (time.perf_counter() - start)


def make_session(path: Path, count: int, hits: list) -> None:
    """A session of ``count`` hits (the ``hits`` given, repeated) on the paper's SD rig, its settings those of its
    records (so that ``acquire --append`` takes them), written without an fsync per hit."""
    from gasfilm.analysis.capture import TriggerSettings
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings
    from gasfilm.analysis.validation import ValidationSettings
    from gasfilm.drivers.interface import default_hammer_and_accelerometer

    samples = hits[0].data.shape[1]
    settings = {"trigger": TriggerSettings(record_s=samples / RATE_HZ), "validation": ValidationSettings(),
                "window": WindowSettings()}
    with Session.create(path, default_hammer_and_accelerometer(RATE_HZ), RigSpec.nominal("SD").to_toml(), settings,
                        sync_each_hit=False, record_samples=samples) as session:
        for index in range(count):
            session.append_hit(hits[index % len(hits)], Verdict(True))


FIT = {"model_name": "SD", "network": "k || dashpot(eta)", "params": {"k": 3.78e7, "eta": 3450.0},
       "std_errors": {"k": 5e4, "eta": 40.0}, "rms": 0.0135, "band_hz": [20.0, 1000.0], "mass_kg": 25.05,
       "freq_hz": np.linspace(20.0, 1000.0, 246), "h_fit": np.ones(246, complex)}


def measure(action: str, path: Path, samples: int) -> dict:
    """In this process: the seconds and the peak memory (MB over the baseline after the imports) of one action."""
    from gasfilm.analysis.capture import HitRecord
    from gasfilm.analysis.session import Session

    hit = HitRecord(index=0, data=np.random.default_rng(0).normal(size=(2, samples)), sample_rate_hz=12800.0,
                    trigger_index=128, start_time_s=1e4, overload=np.zeros(2, bool), force_channel=0,
                    response_channel=1)
    baseline_kb = _reset_peak_memory_kb()
    start = time.perf_counter()
    if action == "hit":
        with Session.open(path, "a") as session:
            session.append_hit(hit, Verdict(True))
    elif action == "fit":
        with Session.updating(path) as session:
            session.write_fit("SD", FIT)
    else:  # the peer: bare h5py appends the same hit
        with h5py.File(path, "r+", libver="latest", locking=False) as file:
            data = file["hits/data"]
            data.resize(data.shape[0] + 1, axis=0)
            data[-1] = hit.data
            table = file["hits/table"]
            table.resize(table.shape[0] + 1, axis=0)
            file.flush()
            os.fsync(file.id.get_vfd_handle())
    seconds = time.perf_counter() - start
    return {"seconds": seconds, "memory_mb": (_status_kb("VmHWM") - baseline_kb) / 1024}


def _status_kb(field: str) -> int:
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith(field + ":"))


def _reset_peak_memory_kb() -> int:
    """Reset the process's peak resident memory to its current value (Linux: /proc/self/clear_refs); return it."""
    with open("/proc/self/clear_refs", "w") as clear_refs:
        clear_refs.write("5")
    return _status_kb("VmRSS")


def measured_in_child(action: str, path: Path, samples: int) -> dict:
    work = path.with_name(f"work-{action}.h5")
    shutil.copyfile(path, work)
    try:
        run = subprocess.run([sys.executable, __file__, "--measure", action, str(work), "--samples", str(samples)],
                             capture_output=True, text=True, check=True)
        return json.loads(run.stdout.splitlines()[-1])
    finally:
        work.unlink(missing_ok=True)


#: Runs gasfilm with the given arguments and prints its peak memory (kB) last on stderr.
CLI_PROBE = ("import resource, sys\nsys.argv = ['gasfilm', *sys.argv[1:]]\nfrom gasfilm.app.entry import run\n"
             "status = run()\nprint(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)\n"
             "sys.exit(status)")


def cli_cost(argv: list[str], path: Path) -> dict:
    """Wall time and peak memory of ``gasfilm argv`` (SESSION replaced by a copy of ``path``)."""
    work = path.with_name("work-cli.h5")
    shutil.copyfile(path, work)
    try:
        start = time.perf_counter()
        run = subprocess.run([sys.executable, "-c", CLI_PROBE,
                              *[str(work) if arg == "SESSION" else arg for arg in argv]],
                             check=True, capture_output=True, text=True, cwd=path.parent)
        return {"seconds": time.perf_counter() - start, "peak_mb": int(run.stderr.split()[-1]) / 1024}
    finally:
        work.unlink(missing_ok=True)
        shutil.rmtree(path.parent / "figures", ignore_errors=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hits", type=int, default=100, help="hits of the rate measurement")
    parser.add_argument("--samples", type=int, default=12800, help="samples per channel and hit")
    parser.add_argument("--sizes", type=int, nargs="*", default=[10, 100, 1000], help="session sizes in hits")
    parser.add_argument("--cli", action="store_true", help="also gasfilm fit and acquire --append end to end")
    parser.add_argument("--folder", type=Path, default=None, help="where to write (default: a temporary folder)")
    parser.add_argument("--measure", nargs=2, metavar=("ACTION", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure(args.measure[0], Path(args.measure[1]), args.samples)))
        return 0
    hits = synthetic_hits(min(args.hits, 20), samples=args.samples)
    megabytes = hits[0].data.nbytes / 1e6
    with tempfile.TemporaryDirectory(prefix="gasfilm-append-", dir=args.folder) as folder:
        rate_hits = [hits[index % len(hits)] for index in range(args.hits)]
        bare = bare_swmr_rate(Path(folder), rate_hits)
        journaled = session_rate(Path(folder), rate_hits)
        print(f"session append (rollback journal + HDF5): {journaled:7.1f} hits/s "
              f"({journaled * megabytes:.1f} MB/s of records)")
        print(f"bare h5py SWMR append (peer):             {bare:7.1f} hits/s ({bare * megabytes:.1f} MB/s)")
        print(f"ratio session / peer: {journaled / bare:.2f} ({args.hits} hits of {megabytes * 1e3:.0f} kB)")
        print(f"\nstoring one result against the session's size ({megabytes * 1e3:.0f} kB hits; a fresh process each; "
              f"memory: the process's peak resident memory over what it held before)")
        print(f"{'hits':>6} {'file MB':>8} | {'append s':>8} {'MB':>5} | {'fit s':>6} {'MB':>5} | "
              f"{'peer s':>6} {'MB':>5} | append/peer")
        for size in args.sizes:
            path = Path(folder) / f"session-{size}.h5"
            make_session(path, size, hits)
            costs = {action: measured_in_child(action, path, args.samples) for action in ("hit", "fit", "peer")}
            print(f"{size:>6} {path.stat().st_size / 1e6:>8.1f} | {costs['hit']['seconds']:>8.3f} "
                  f"{costs['hit']['memory_mb']:>5.1f} | {costs['fit']['seconds']:>6.3f} {costs['fit']['memory_mb']:>5.1f}"
                  f" | {costs['peer']['seconds']:>6.3f} {costs['peer']['memory_mb']:>5.1f} | "
                  f"{costs['hit']['seconds'] / costs['peer']['seconds']:.2f}", flush=True)
            if args.cli:
                fit = cli_cost(["fit", "SESSION", "--models", "SD", "--out", "figures"], path)
                append = cli_cost(["acquire", "--device", "sim", "--pacing", "fast", "--hit-interval", "6", "8", "--out",
                                   "SESSION", "--append",
                                   "--hits", "1"], path)
                print(f"{'':>6} {'':>8}   gasfilm fit --models SD: {fit['seconds']:.2f} s, peak {fit['peak_mb']:.0f} MB;"
                      f" gasfilm acquire --append --hits 1: {append['seconds']:.2f} s, peak {append['peak_mb']:.0f} MB",
                      flush=True)
            if size != args.sizes[-1]:
                path.unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
