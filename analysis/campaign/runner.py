"""Running a campaign on dask.distributed: one task per session, on a LocalCluster or any running scheduler.

Dask does the scheduling, the transport and the retries of lost workers; this module only finds the sessions, skips
those whose content was analysed before (the cache, keyed by the SHA-256 of the file and the options), submits one
:func:`~gasfilm.analysis.campaign.session_task.analyse_session` per remaining session (its *path*: workers read the
file themselves, so they must see the same paths, as on one machine or a shared file system) and gathers the rows as
they complete. A task that fails, even by killing its worker, is a row with its one-line error.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from gasfilm.analysis.campaign.session_task import CampaignOptions, analyse_session
from gasfilm.drivers.errors import SettingError

logger = logging.getLogger(__name__)

#: File name patterns of sessions found in a folder (searched recursively).
SESSION_SUFFIXES = (".h5", ".hdf5")
#: Sub-folder of the output folder that keeps one JSON row per analysed session content.
CACHE_FOLDER = "cache"
#: dask configuration of the workers (local ones get it; docs/campaigns.md says how to give it to others).
WORKER_CONFIG_PATH = Path(__file__).with_name("dask-workers.yaml")
#: How long to wait for a scheduler given with --scheduler before saying it cannot be reached.
CONNECT_TIMEOUT_S = 20


@dataclass
class CampaignRun:
    """What a campaign run produced: rows in input order and how many were computed, cached or failed."""

    rows: list[dict[str, Any]]
    computed: int
    cached: int
    failed: int
    wall_time_s: float
    workers: int
    scheduler: str
    notes: list[str] = field(default_factory=list)


def find_sessions(inputs: Sequence[Path]) -> list[Path]:
    """Session files named or found (recursively) in the folders named; each input must exist."""
    found: list[Path] = []
    for item in inputs:
        if item.is_dir():
            inside = sorted(path for path in item.rglob("*") if path.suffix.lower() in SESSION_SUFFIXES
                            and path.is_file())
            if not inside:
                raise SettingError(f"{item}: no session files (*.h5) in this folder")
            found.extend(inside)
        elif item.is_file():
            found.append(item)
        else:
            raise SettingError(f"{item}: no such session file or folder")
    unique: dict[Path, Path] = {}
    for path in found:
        unique.setdefault(path.resolve(), path)
    return list(unique.values())


def recorded_conditions(paths: Sequence[Path]) -> set[str] | None:
    """The condition keys the sessions record (their settings only, no hits read); None when no session can be read
    (their tasks then say why)."""
    from gasfilm.analysis.conditions import decode_conditions
    from gasfilm.analysis.session import Session
    from gasfilm.drivers.errors import GasfilmError

    keys: set[str] = set()
    readable = False
    for path in paths:
        try:
            with Session.open(path, "r") as session:
                keys.update(decode_conditions(session.settings, str(path)))
        except GasfilmError:
            continue  # a damaged session: its own row says what is wrong
        readable = True
    return keys if readable else None


def check_grouping(paths: Sequence[Path], by: Sequence[str]) -> None:
    """Refuse, before anything is computed, a ``--by`` key that no session records; one line listing the keys the
    sessions do record."""
    keys = recorded_conditions(paths)
    if keys is None:
        return
    from gasfilm.analysis.conditions import converted_condition

    missing = [key for key in by if converted_condition(dict.fromkeys(keys, 1.0), key)[1] is None]
    if missing:
        recorded = ", ".join(sorted(keys)) if keys else "none (record them with acquire --condition KEY=VALUE)"
        which = "this condition" if len(missing) == 1 else "these conditions"
        raise SettingError(f"--by {','.join(missing)}: no session records {which}; the {len(paths)} session(s) "
                           f"record: {recorded}")


def content_digest(path: Path, options: CampaignOptions) -> str | None:
    """SHA-256 of the file's bytes and the options (None when the file cannot be read: its task says why)."""
    digest = hashlib.sha256(options.fingerprint().encode())
    try:
        with path.open("rb") as file:
            for block in iter(lambda: file.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


class RowCache:
    """One JSON file per analysed session content in ``folder`` (rows without an error only: failures run again)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def get(self, digest: str | None) -> dict[str, Any] | None:
        if digest is None:
            return None
        try:
            row = json.loads((self.folder / f"{digest}.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        return row if isinstance(row, dict) and row.get("error") is None else None

    def put(self, digest: str | None, row: dict[str, Any]) -> None:
        if digest is None or row.get("error") is not None:
            return
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            temporary = self.folder / f".{digest}.json.part"
            temporary.write_text(json.dumps(row), encoding="utf-8")
            os.replace(temporary, self.folder / f"{digest}.json")
        except OSError as error:  # a cache that cannot be written costs time on the next run, nothing else
            logger.warning("cache %s: cannot keep a row (%s)", self.folder, error.strerror or error)


@contextlib.contextmanager
def dask_client(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """A dask client: on a new LocalCluster of ``workers`` single-threaded processes, or connected to ``scheduler``
    (``tcp://HOST:PORT``)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError, ValueError) as error:
            raise SettingError(f"--scheduler {scheduler}: cannot connect ({str(error).splitlines()[0]})") from None
        try:
            yield client
        finally:
            client.close()
        return
    count = workers or max(1, min(os.cpu_count() or 1, 8))
    # the workers' profiler and malloc tuning cost 8 % and 21-24 % of a session's CPU time (see the YAML file)
    worker_config = dask.config.merge(dask.config.config,
                                      dask.config.collect(paths=[str(WORKER_CONFIG_PATH)], env={}))
    with dask.config.set(worker_config), warnings.catch_warnings():
        # the scheduler's HTTP routes take another port when 8787 is taken (another cluster on this machine): not the
        # user's concern (its three-line warning was printed on every such campaign)
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        with LocalCluster(n_workers=count, threads_per_worker=1, processes=True, dashboard_address=":0",
                          silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
            yield client


def run_sessions(
    paths: Sequence[Path],
    options: CampaignOptions,
    cache_folder: Path | None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int, dict[str, Any]], None] | None = None,
) -> CampaignRun:
    """Analyse every session (cached ones from ``cache_folder``), on dask; rows in the order of ``paths``.

    ``progress(done, total, row)`` is called as each session completes (cached ones first)."""
    from distributed import as_completed

    started = time.perf_counter()
    cache = RowCache(cache_folder) if cache_folder is not None else None
    digests = [content_digest(path, options) for path in paths]
    rows: list[dict[str, Any] | None] = [None] * len(paths)
    done = 0
    for index, (path, digest) in enumerate(zip(paths, digests)):
        row = cache.get(digest) if cache is not None else None
        if row is not None:
            rows[index] = {**row, "session": str(path), "cached": True}
            done += 1
            if progress:
                progress(done, len(paths), rows[index])
    pending = [index for index, row in enumerate(rows) if row is None]
    worker_count = 0
    address = "none needed"
    if pending:
        with dask_client(workers, scheduler) as client:
            address = client.scheduler.address
            worker_count = len(client.scheduler_info().get("workers", {}))
            if worker_count == 0:
                client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
                worker_count = len(client.scheduler_info().get("workers", {}))
            futures = {}
            for index in pending:
                future = client.submit(analyse_session, str(paths[index]), options, pure=False,
                                       key=f"gasfilm-session-{index}-{(digests[index] or 'unreadable')[:16]}")
                futures[future] = index
            for future in as_completed(futures):
                index = futures[future]
                try:
                    row = future.result()
                except Exception as error:  # the worker died (KilledWorker) or the task could not be run at all
                    row = {"session": str(paths[index]),
                           "error": f"{paths[index]}: the worker running it failed: "
                                    f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"}
                row["session"] = str(paths[index])
                row["cached"] = False
                rows[index] = row
                if cache is not None:
                    cache.put(digests[index], row)
                done += 1
                if progress:
                    progress(done, len(paths), row)
                future.release()
    final = [row for row in rows if row is not None]
    failed = sum(1 for row in final if row.get("error"))
    return CampaignRun(final, computed=len(pending), cached=len(paths) - len(pending), failed=failed,
                       wall_time_s=time.perf_counter() - started, workers=worker_count, scheduler=address)
