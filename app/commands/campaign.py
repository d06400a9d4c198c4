"""``gasfilm campaign SESSIONS_OR_FOLDERS... --by KEY[,KEY] --out DIR``: every session's FRF, nine-model fit and
diagnosis as dask tasks (a LocalCluster, or any scheduler with ``--scheduler``), one results table (Parquet, CSV) and
an HTML report across the operating conditions (:mod:`gasfilm.analysis.campaign`, ``docs/campaigns.md``)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from gasfilm.app.commands.common import check_output_folder, is_terminal
from gasfilm.drivers.errors import SettingError

BAR_WIDTH = 30


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "campaign", help="analyse many sessions across operating conditions on dask (table + report)",
        description="For every session: the FRF, the nine-model fit and the diagnosis, one dask task each; a results "
        "table (Parquet and CSV) and an HTML report grouped by the conditions --by. Results are cached per session "
        "content in DIR/cache: a re-run computes only new or changed sessions.")
    parser.add_argument("inputs", type=Path, nargs="+", metavar="SESSION_OR_FOLDER",
                        help="session files (.h5) or folders searched for them")
    parser.add_argument("--by", required=True, metavar="KEY[,KEY]",
                        help="the operating conditions to group by, e.g. supply_pressure_mpa,gap_um")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help="folder for campaign.parquet, campaign.csv, campaign.html and the cache")
    cluster = parser.add_mutually_exclusive_group()
    cluster.add_argument("--workers", type=int, help="worker processes of the local cluster (default: the cores)")
    cluster.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="a running dask scheduler to use instead")
    parser.add_argument("--models", default="all", help="comma-separated model names or 'all' (default)")
    parser.add_argument("--method", default="default", help="fitter: 'default' (the fast one) or 'gapso'")
    parser.add_argument("--band", help="identification band LO:HI in Hz (default 20:1000, capped at 0.45·fs)")
    parser.add_argument("--rig", type=Path,
                        help="diagnose against this rig spec at each session's conditions (default: the session's)")
    parser.add_argument("--no-diagnosis", action="store_true", help="fit only, no diagnosis")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the table and report of an earlier run in --out (its cache is reused)")
    parser.set_defaults(func=run)


class _Progress:
    """A bar on stderr when it is a terminal, else one line per finished session on stdout."""

    def __init__(self) -> None:
        self.live = is_terminal()
        self.failed = 0
        self.started = time.monotonic()

    def __call__(self, done: int, total: int, row: dict[str, Any]) -> None:
        if row.get("error"):
            self.failed += 1
        if self.live:
            filled = int(BAR_WIDTH * done / max(total, 1))
            elapsed = time.monotonic() - self.started
            sys.stderr.write(f"\r[{'#' * filled}{'.' * (BAR_WIDTH - filled)}] {done}/{total} sessions, "
                             f"{self.failed} failed, {elapsed:.0f} s")
            sys.stderr.flush()
            if done == total:
                sys.stderr.write("\n")
            return
        name = Path(row["session"]).name
        if row.get("error"):
            what = f"failed: {row['error']}"
        else:
            what = (f"best {row.get('best_model', '—')}, diagnosis {row.get('diagnosis_verdict') or 'not run'}"
                    f"{' (cached)' if row.get('cached') else ''}"
                    + (f"; warning: {row['fit_warnings']}" if row.get("fit_warnings") else ""))
        print(f"  {done}/{total} {name}: {what}", flush=True)


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.campaign import CSV_NAME, PARQUET_NAME, REPORT_NAME, CampaignOptions, run_campaign
    from gasfilm.analysis.conditions import check_condition_name
    from gasfilm.analysis.identification import METHODS
    from gasfilm.app.commands.fit import parse_band, parse_models

    by = [key.strip() for key in args.by.split(",") if key.strip()]
    if not by:
        raise SettingError("--by: name at least one condition, e.g. supply_pressure_mpa")
    for key in by:
        check_condition_name(key, f"--by {args.by}")
    if args.workers is not None and args.workers < 1:
        raise SettingError(f"--workers: {args.workers} must be at least 1")
    if args.scheduler is not None and ":" not in args.scheduler:
        raise SettingError(f"--scheduler {args.scheduler}: give the scheduler's address, e.g. tcp://10.0.0.5:8786")
    if args.method not in METHODS:
        raise SettingError(f"--method '{args.method}': choose one of {', '.join(METHODS)}")
    models = tuple(model.name for model in parse_models(args.models))
    band = parse_band(args.band, float("inf")) if args.band is not None else None
    rig_toml = None
    if args.rig is not None:
        from gasfilm.analysis.physics.spec import RigSpec

        rig_toml = RigSpec.load(args.rig).to_toml()
    check_output_folder(args.out, "--out", (PARQUET_NAME, CSV_NAME, REPORT_NAME), args.overwrite)
    options = CampaignOptions(models=models, method=args.method, band_hz=band, diagnose=not args.no_diagnosis,
                              rig_spec_toml=rig_toml)
    result = run_campaign(args.inputs, by, args.out, options, args.workers, args.scheduler, _Progress())
    outcome = result.run
    print(f"campaign: {len(outcome.rows)} sessions, {outcome.computed} computed on {outcome.workers} dask "
          f"worker(s) ({outcome.scheduler}), {outcome.cached} from the cache, {outcome.failed} failed; "
          f"{outcome.wall_time_s:.1f} s")
    for row in outcome.rows:
        if row.get("error"):
            print(f"  failed: {row['error']}")
    for note in outcome.notes:
        print(f"  note: {note}")
    print(f"table:  {result.parquet_path} and {result.csv_path}")
    print(f"report: {result.report_path}")
    return 1 if outcome.failed == len(outcome.rows) else 0
