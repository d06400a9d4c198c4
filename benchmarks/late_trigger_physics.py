"""A late trigger must not hide physics: sessions of the simulator-world benchmark (`benchmarks/concealed/`, hidden
effects recorded on the simulated NI 9234) diagnosed against the nominal spec as recorded, and again with every
record cut to start at its first force sample ≥ 10 % of its peak (no pre-trigger, the pulse front lost: a late
trigger), as a user's recorder without pre-trigger would deliver them (no windows, no spec).

    python benchmarks/late_trigger_physics.py [--out out/late-trigger-physics] [--only CASE ...]

Prints one row per case and cut: verdict, findings, χ²/point after, the late-trigger note, time.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent / "concealed"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from generate import NOMINAL, generate  # noqa: E402
from measurement_controls import triggered_late  # noqa: E402

from gasfilm.analysis.diagnosis import Recordings, diagnose, load_recordings  # noqa: E402

CASES = ("clean-a", "mass-a", "mode-a", "memory-a", "subtle-mass")


def late_cut(recordings: Recordings) -> Recordings:
    """The recordings triggered late (:func:`triggered_late`), without windows or spec, as UFF time records would
    carry them."""
    return dataclasses.replace(recordings, records=triggered_late(np.asarray(recordings.records)), window=None,
                               rig_spec_toml=None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/late-trigger-physics"))
    parser.add_argument("--only", nargs="+", default=list(CASES))
    args = parser.parse_args()
    missing = [name for name in args.only if not (args.out / f"{name}.h5").exists()]
    if missing:
        generate(args.out, set(missing))
    print(f"{'case':12s} {'records':9s} {'verdict':17s} {'findings':34s} {'χ²/pt':>7s} {'s':>5s}  late-trigger note")
    for name in args.only:
        recorded = load_recordings(args.out / f"{name}.h5")
        for label, recordings in (("as is", recorded), ("late", late_cut(recorded))):
            started = time.monotonic()
            result = diagnose(recordings, NOMINAL)
            found = ", ".join(f.effect for f in result.findings) or "-"
            note = next((q.message[:60] for q in result.quality if q.kind == "late trigger"), "-")
            print(f"{name:12s} {label:9s} {result.verdict:17s} {found:34s} {result.chi2_per_point_after:7.3f} "
                  f"{time.monotonic() - started:5.1f}  {note}", flush=True)


if __name__ == "__main__":
    main()
