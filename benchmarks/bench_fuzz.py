"""Fuzz benchmark: ten thousand damaged UFF 58, HDF5 session and TOML rig-spec files through the command line.

Goal (issue 10 item 8): 0 internal errors and 0 hangs (> 10 s per input). The cases are those of
``tests/test_fuzz.py`` (same mutations, same commands, run in-process), by the thousand, with a diagnosis every
``--diagnose-every`` UFF and rig-spec cases. Prints the counts by kind, the internal errors and hangs with their
distinct causes, and those raised inside the session reader (analysis/session.py) apart. Run:
``.venv/bin/python benchmarks/bench_fuzz.py [--cases 10000] [--seed 1] [--diagnose-every 200]``.
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

from test_fuzz import CASE_TIMEOUT_S, KINDS, make_seeds, run_case  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000, help="inputs in all, shared evenly by the three kinds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--diagnose-every", type=int, default=200, help="every n-th UFF/rig-spec case is diagnosed")
    parser.add_argument("--show", type=int, default=3, help="examples printed per distinct cause")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # a warning printed by the CLI still counts: it lands in the case's stderr
    logging.disable(logging.CRITICAL)
    counts: collections.Counter = collections.Counter()
    causes: dict[str, list[str]] = collections.defaultdict(list)
    slowest = (0.0, "")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gasfilm-fuzz-") as folder:
        seeds = make_seeds(Path(folder) / "seeds")
        for index in range(args.cases):
            kind = KINDS[index % len(KINDS)]
            outcome = run_case(kind, seeds, index // len(KINDS), args.seed, Path(folder) / "case",
                               args.diagnose_every)
            counts[kind, outcome.code] += 1
            if outcome.seconds > slowest[0]:
                slowest = (outcome.seconds, f"{kind} case {index // len(KINDS)} ({outcome.mutation}; "
                                            f"gasfilm {outcome.argv[0]})")
            if outcome.problem:
                example = f"{kind} case {index // len(KINDS)} ({outcome.mutation}; gasfilm {outcome.argv[0]}): " \
                          f"{outcome.problem[:300]}"
                causes[outcome.cause].append(example)
            if (index + 1) % 500 == 0:
                print(f"  {index + 1} inputs, {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - start
    print(f"fuzz: {args.cases} inputs (seed {args.seed}) in {elapsed:.0f} s; slowest {slowest[0]:.1f} s: {slowest[1]}")
    for kind in KINDS:
        by_code = {code: n for (k, code), n in sorted(counts.items(), key=lambda item: str(item[0][1])) if k == kind}
        print(f"  {kind}: " + ", ".join(f"exit {'timeout' if code is None else code}: {n}"
                                        for code, n in by_code.items()))
    problems = [example for examples in causes.values() for example in examples]
    internal = sum("internal error" in example for example in problems)
    hangs = sum(f"more than {CASE_TIMEOUT_S:g} s" in example for example in problems)
    print(f"{internal} internal errors, {hangs} hangs (> {CASE_TIMEOUT_S:g} s), "
          f"{len(problems) - internal - hangs} other problems; {len(causes)} distinct causes")
    for cause, examples in sorted(causes.items(), key=lambda item: -len(item[1])):
        print(f"  {len(examples):5d} × {cause}")
        for example in examples[: args.show]:
            print(f"          e.g. {example}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
