"""The campaign's results table: one row per session, written as Parquet (pyarrow) and CSV, and grouped by conditions.

Columns: ``session``, ``error`` (one line, empty when the session was analysed), the session's status and hits,
``fit_hits`` (the hits the campaign's fits average: all accepted ones) and ``stored_fits_stale`` (the session's own
stored fits made on fewer hits, with how many), ``condition.<key>`` (unit in the key), the rig spec's film at the
session's conditions (``spec.<name> [unit]``), band, ``best_model`` (lowest BIC), per model ``<model>.network`` (its
identifiable form: the network the data determine) and ``<model>.notes`` (what was taken out), ``<model>.<parameter>
[unit]`` and ``... sigma [unit]`` (1 σ; empty for a parameter at its bound, which is not a measurement; both empty for
a parameter the identifiable form leaves out), ``<model>.rms [(m/s²)/N]``, ``<model>.E [%]``, ``<model>.BIC``,
``<model>.at_bound``, the diagnosis verdict, findings and unexplained bands, and what the task cost (``seconds`` of
wall time, ``cpu_seconds``, ``worker_peak_rss_mb``, ``worker``, ``cached``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence


#: File names written into the campaign's output folder.
PARQUET_NAME = "campaign.parquet"
CSV_NAME = "campaign.csv"
REPORT_NAME = "campaign.html"

_FIRST = ("session", "error", "status", "hits", "accepted_hits", "fit_hits", "stored_fits_stale", "sample_rate_hz")
_LAST = ("diagnosis_verdict", "diagnosis_findings", "diagnosis_unexplained", "diagnosis_rms_before_m_s2_per_n",
         "diagnosis_rms_after_m_s2_per_n", "seconds", "cpu_seconds", "worker_peak_rss_mb", "worker", "cached")


def column_order(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Every column of the rows: session and error first, conditions, then in the order first seen, costs last."""
    seen: list[str] = []
    for row in rows:
        seen.extend(key for key in row if key not in seen)
    conditions = sorted(key for key in seen if key.startswith("condition."))
    middle = [key for key in seen if key not in _FIRST and key not in _LAST and key not in conditions]
    return ([key for key in _FIRST if key in seen] + conditions + middle + [key for key in _LAST if key in seen])


def to_arrow(rows: Sequence[dict[str, Any]]) -> Any:
    """The rows as a ``pyarrow.Table`` (missing cells null; a column mixing numbers and text becomes text)."""
    import pyarrow as pa

    columns = column_order(rows)
    arrays = {}
    for name in columns:
        values = [row.get(name) for row in rows]
        try:
            arrays[name] = pa.array(values)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            arrays[name] = pa.array([None if value is None else str(value) for value in values], pa.string())
    return pa.table(arrays)


def write_table(rows: Sequence[dict[str, Any]], parquet_path: Path, csv_path: Path) -> None:
    """The rows as Parquet and as CSV (``campaign.parquet`` and ``campaign.csv`` of a campaign's folder)."""
    import pyarrow.csv as pa_csv
    import pyarrow.parquet as pq

    table = to_arrow(rows)
    pq.write_table(table, parquet_path)
    pa_csv.write_csv(table, csv_path)


def read_table(path: Path) -> list[dict[str, Any]]:
    """The rows of a campaign's Parquet table."""
    import pyarrow.parquet as pq

    return pq.read_table(path).to_pylist()


def group_key(row: dict[str, Any], by: Sequence[str]) -> tuple[Any, ...]:
    """The row's values of the conditions ``by`` (None where the session does not give one)."""
    return tuple(row.get(f"condition.{key}") for key in by)


def group_label(key: Sequence[str], values: Sequence[Any]) -> str:
    """``supply_pressure_mpa = 0.4 MPa, gap_um = 10 µm`` for a group."""
    from gasfilm.analysis.conditions import format_value

    return ", ".join(format_value(name, value) if value is not None else f"{name} not recorded"
                     for name, value in zip(key, values))


def grouped(rows: Sequence[dict[str, Any]], by: Sequence[str]) -> dict[tuple[Any, ...], list[dict[str, Any]]]:
    """Rows by the values of the conditions ``by``, groups sorted (numbers by value, then text, missing last)."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for row in rows:
        groups.setdefault(group_key(row, by), []).append(row)

    def order(key: tuple[Any, ...]) -> tuple:
        return tuple((value is None, isinstance(value, str), value if not isinstance(value, str) else 0,
                      str(value)) for value in key)

    return {key: groups[key] for key in sorted(groups, key=order)}
