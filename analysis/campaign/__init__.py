"""Campaigns: many sessions at many operating conditions, analysed as one — on dask.distributed.

:func:`run_campaign` finds the sessions, analyses each as one dask task (:mod:`.session_task`: FRF, the nine-model
fit, the diagnosis), keeps one row per session content in a cache so a re-run computes only new sessions
(:mod:`.runner`), writes the results table as Parquet and CSV (:mod:`.table`) and the HTML report (:mod:`.report`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from gasfilm.analysis.campaign.runner import CACHE_FOLDER, CampaignRun, check_grouping, find_sessions, run_sessions
from gasfilm.analysis.campaign.session_task import RUN_COLUMNS, CampaignOptions, analyse_session
from gasfilm.analysis.campaign.table import CSV_NAME, PARQUET_NAME, REPORT_NAME, read_table, write_table

logger = logging.getLogger(__name__)

__all__ = ["CSV_NAME", "PARQUET_NAME", "REPORT_NAME", "RUN_COLUMNS", "CampaignOptions", "CampaignResult",
           "CampaignRun", "analyse_session", "find_sessions", "read_table", "run_campaign"]


@dataclass
class CampaignResult:
    """A finished campaign: the run and the files written."""

    run: CampaignRun
    parquet_path: Path
    csv_path: Path
    report_path: Path


def run_campaign(
    inputs: Sequence[Path],
    by: Sequence[str],
    out: Path,
    options: CampaignOptions = CampaignOptions(),
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int, dict[str, Any]], None] | None = None,
) -> CampaignResult:
    """Analyse the sessions in ``inputs`` (files or folders) on dask and write ``campaign.parquet``,
    ``campaign.csv`` and ``campaign.html`` into ``out`` (cache in ``out/cache``). A ``by`` key no session records is
    refused before anything is computed."""
    from gasfilm.analysis.campaign.report import write_campaign_report
    from gasfilm.analysis.paths import written_whole

    paths = find_sessions(inputs)
    check_grouping(paths, by)  # before anything is computed
    out.mkdir(parents=True, exist_ok=True)
    run = run_sessions(paths, options, out / CACHE_FOLDER, workers, scheduler, progress)
    analysed = [row for row in run.rows if not row.get("error")]
    _convert_units(run.rows, by, run.notes)
    for key in by:
        if analysed and not any(f"condition.{key}" in row for row in analysed):
            message = (f"--by {key}: no session analysed records this condition (those that do failed); the sessions "
                       f"are grouped as 'not recorded'")
            run.notes.append(message)
            logger.warning(message)
    parquet_path, csv_path, report_path = out / PARQUET_NAME, out / CSV_NAME, out / REPORT_NAME
    with written_whole(parquet_path, csv_path, report_path, what="the campaign's table and report") as building:
        write_table(run.rows, *building[:2])  # all three, or none (a full disk leaves no partial file)
        write_campaign_report(run.rows, by, building[2])
    logger.info("campaign of %d sessions into %s: %d computed, %d cached, %d failed in %.1f s", len(paths), out,
                run.computed, run.cached, run.failed, run.wall_time_s)
    return CampaignResult(run, parquet_path, csv_path, report_path)


def _convert_units(rows: list[dict[str, Any]], by: Sequence[str], notes: list[str]) -> None:
    """A session that recorded a ``by`` condition in another unit of the same quantity (kPa for MPa) is grouped by
    the converted value, said once per key."""
    from gasfilm.analysis.conditions import converted_condition

    prefix = "condition."
    for key in by:
        sources = set()
        for row in rows:
            if f"{prefix}{key}" in row:
                continue
            recorded = {name[len(prefix):]: value for name, value in row.items() if name.startswith(prefix)}
            value, source = converted_condition(recorded, key)
            if source is not None:
                row[f"{prefix}{key}"] = value
                sources.add(source)
        if sources:
            message = f"--by {key}: sessions recording {', '.join(sorted(sources))} are grouped by it converted to {key}"
            notes.append(message)
            logger.info(message)
