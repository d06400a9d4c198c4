"""How fast a session stores hits, journal included (issue 15 items 23–24: each hit is written twice, fsynced twice).

Appends hits of a typical record (hammer and accelerometer, 1 s at 12.8 kS/s: 200 kB) to a session with
``Session.append_hit`` (journal entry fsynced, then the HDF5 file in SWMR mode, fsynced), and, as the peer measured in
the same run, the same records to a bare h5py SWMR dataset flushed and fsynced per hit (the store before the journal).
Prints hits per second of each and their ratio; the live goal is far below either (a hit every ~1 s). Run:
``.venv/bin/python benchmarks/bench_session_append.py [--hits 100] [--samples 12800] [--folder DIR]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_session import new_session, synthetic_hits  # noqa: E402

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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hits", type=int, default=100)
    parser.add_argument("--samples", type=int, default=12800, help="samples per channel and hit")
    parser.add_argument("--folder", type=Path, default=None, help="where to write (default: a temporary folder)")
    args = parser.parse_args()
    hits = synthetic_hits(args.hits, samples=args.samples)
    with tempfile.TemporaryDirectory(prefix="gasfilm-append-", dir=args.folder) as folder:
        bare = bare_swmr_rate(Path(folder), hits)
        journaled = session_rate(Path(folder), hits)
    megabytes = hits[0].data.nbytes / 1e6
    print(f"session append (journal + HDF5): {journaled:7.1f} hits/s ({journaled * megabytes:.1f} MB/s of records)")
    print(f"bare h5py SWMR append (peer):    {bare:7.1f} hits/s ({bare * megabytes:.1f} MB/s)")
    print(f"ratio session / peer: {journaled / bare:.2f} ({args.hits} hits of {megabytes * 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
