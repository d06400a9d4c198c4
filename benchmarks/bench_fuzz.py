"""Fuzz benchmark: ten thousand damaged inputs of every kind gasfilm reads, through the command line.

Goal (issue 10 item 8, issue 33 item 4): 0 internal errors and 0 hangs (a case over ``--timeout`` s, 20 by default),
every ``--json`` answer strict JSON (no NaN or Infinity). The kinds are those of ``tests/test_fuzz.py`` (same
mutations, same commands, run in-process): UFF 58 files, HDF5 sessions (killed writers' files among them, appended to),
TOML rig specs, ``.npy`` hit records, the JSON of ``gasfilm fit --json`` (through ``model``), folders of sessions
(through ``campaign``, on one dask scheduler started here: a cluster per case would take most of the time) and the
GUI's sensor libraries; a diagnosis every ``--diagnose-every`` UFF, .npy and rig-spec cases. Prints the counts by kind,
the internal errors and hangs with their distinct causes. Run:
``.venv/bin/python benchmarks/bench_fuzz.py [--cases 10000] [--seed 1] [--diagnose-every 200] [--kinds uff npy …]``.
"""

from __future__ import annotations

import argparse
import collections
import logging
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_fuzz  # noqa: E402
from test_fuzz import KINDS, make_seeds, run_case  # noqa: E402

TIMEOUT_S = 20.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000, help="inputs in all, shared evenly by the kinds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--diagnose-every", type=int, default=200,
                        help="every n-th UFF/.npy/rig-spec case is diagnosed")
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S, help="a case running longer is a hang (s)")
    parser.add_argument("--kinds", nargs="*", default=list(KINDS), choices=list(KINDS))
    parser.add_argument("--show", type=int, default=3, help="examples printed per distinct cause")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # a warning printed by the CLI still counts: it lands in the case's stderr
    logging.disable(logging.CRITICAL)
    counts: collections.Counter = collections.Counter()
    causes: dict[str, list[str]] = collections.defaultdict(list)
    slowest = (0.0, "")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gasfilm-fuzz-") as folder, scheduler("campaign" in args.kinds):
        seeds = make_seeds(Path(folder) / "seeds")
        for index in range(args.cases):
            kind = args.kinds[index % len(args.kinds)]
            number = index // len(args.kinds)
            outcome = run_case(kind, seeds, number, args.seed, Path(folder) / "case", args.diagnose_every,
                               args.timeout)
            counts[kind, outcome.code] += 1
            if outcome.seconds > slowest[0]:
                slowest = (outcome.seconds, f"{kind} case {number} ({outcome.mutation}; gasfilm {outcome.argv[0]})")
            if outcome.problem:
                example = f"{kind} case {number} ({outcome.mutation}; gasfilm {outcome.argv[0]}): " \
                          f"{outcome.problem[:300]}"
                causes[outcome.cause].append(example)
            if (index + 1) % 500 == 0:
                print(f"  {index + 1} inputs, {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - start
    print(f"fuzz: {args.cases} inputs (seed {args.seed}) in {elapsed:.0f} s; slowest {slowest[0]:.1f} s: {slowest[1]}")
    for kind in args.kinds:
        by_code = {code: n for (k, code), n in sorted(counts.items(), key=lambda item: str(item[0][1])) if k == kind}
        print(f"  {kind}: {sum(by_code.values())} inputs, " + ", ".join(
            f"exit {'timeout' if code is None else code}: {n}" for code, n in by_code.items()))
    problems = [example for examples in causes.values() for example in examples]
    internal = sum("internal error" in example for example in problems)
    hangs = sum(": hang: " in example for example in problems)
    invalid_json = sum("invalid JSON" in example for example in problems)
    print(f"{internal} internal errors, {hangs} hangs (> {args.timeout:g} s), {invalid_json} invalid JSON answers, "
          f"{len(problems) - internal - hangs - invalid_json} other problems; {len(causes)} distinct causes")
    for cause, examples in sorted(causes.items(), key=lambda item: -len(item[1])):
        print(f"  {len(examples):5d} × {cause}")
        for example in examples[: args.show]:
            print(f"          e.g. {example}")
    return 0


class scheduler:
    """A local dask scheduler with one worker for the campaign cases (``--scheduler ADDRESS``), while in use."""

    def __init__(self, wanted: bool) -> None:
        self.wanted = wanted
        self.cluster = None

    def __enter__(self) -> "scheduler":
        if self.wanted:
            from distributed import LocalCluster

            self.cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                                        silence_logs=logging.ERROR)
            test_fuzz.CAMPAIGN_SCHEDULER[:] = [self.cluster.scheduler_address]
        return self

    def __exit__(self, *exc_info: object) -> None:
        test_fuzz.CAMPAIGN_SCHEDULER.clear()
        if self.cluster is not None:
            self.cluster.close()


if __name__ == "__main__":
    sys.exit(main())
