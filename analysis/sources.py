"""Every file a hammer test can come from, read into one shape: the hits, how they were judged, and the setup.

- a gasfilm session (``.h5``): the stored hits with their verdicts, channel layout, rig spec and settings;
- UFF 58 time records (``.uff``/``.unv``): force and response per hit (see :mod:`gasfilm.analysis.uff`);
- NumPy records (``.npy``), one hit per file, rows time in s, force in N, response in m/s² (the layout pyFRF
  publishes; fixtures/real-data/pyfrf-5-hits): the sample rate comes from the time row.

Files other than sessions carry no verdicts, no rig spec and no sensor ranges (no limit is invented for them).
"""

from __future__ import annotations

import errno
import logging
import tokenize
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from gasfilm.analysis.capture import HitRecord
from gasfilm.analysis.validation import Verdict, recorded_full_scale_si
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import ChannelKind, DaqConfig, default_hammer_and_accelerometer

logger = logging.getLogger(__name__)

UFF_SUFFIXES = (".uff", ".unv")
NPY_SUFFIX = ".npy"
#: Largest .npy record read (samples per row): 10 minutes at the NI 9234's top rate.
MAX_NPY_SAMPLES = 600 * 51_200


@dataclass
class Source:
    """Hits from one session or a set of time-record files, with what is known about how they were taken."""

    path: Path
    kind: str  # "session", "uff" or "npy"
    config: DaqConfig
    sample_rate_hz: float
    rig_spec_toml: str | None
    settings: dict[str, Any]
    hits: list[HitRecord]
    verdicts: list[Verdict | None]
    full_scale_si: tuple[float, ...] | None

    @property
    def is_session(self) -> bool:
        return self.kind == "session"

    @property
    def from_elsewhere(self) -> bool:
        """Recorded by another program (a UFF or .npy file, or a session imported from one): nobody can hit again."""
        source = self.settings.get("source") if isinstance(self.settings, Mapping) else None
        return not self.is_session or (isinstance(source, Mapping)
                                       and bool(source.get("uff_file") or source.get("npy_files")))

    def judge(self, validation: Any, window: Any, hits: Sequence[HitRecord] | None = None,
              previous: Sequence[Verdict | None] | None = None) -> list[Verdict]:
        """Verdicts of ``hits`` (default: this source's, with their stored verdicts as ``previous``) under
        ``validation`` and ``window``: a person's decision is kept, every other hit is validated again; a recording
        from elsewhere keeps a hit that only rings at the record end, flagged (:func:`keep_truncated`)."""
        from gasfilm.analysis.validation import keep_truncated, validate_hit

        if hits is None:
            hits, previous = self.hits, self.verdicts
        previous = list(previous) if previous is not None else [None] * len(hits)
        verdicts = []
        for hit, before in zip(hits, previous):
            if before is not None and before.overridden:
                verdicts.append(before)
                continue
            verdict = validate_hit(hit, validation, self.full_scale_si, window=window)
            verdicts.append(keep_truncated(verdict) if self.from_elsewhere else verdict)
        return verdicts

    def judged_hits(self) -> list[HitRecord]:
        """The hits a person or gasfilm accepted (a session's stored verdicts); the hits of a file, which holds no
        verdicts, validated with the default settings and its window (as ``replay`` judges them)."""
        if all(verdict is not None for verdict in self.verdicts):
            return [hit for hit, verdict in zip(self.hits, self.verdicts) if verdict.accepted]
        from gasfilm.analysis.settings import decode_settings

        stored = decode_settings(self.settings, str(self.path))
        self.verdicts = self.judge(stored.validation, stored.window)
        return [hit for hit, verdict in zip(self.hits, self.verdicts) if verdict.accepted]


def is_time_record_file(path: Path) -> bool:
    """UFF or NumPy time records (not a session)."""
    return path.suffix.lower() in UFF_SUFFIXES + (NPY_SUFFIX,)


def _hit_from_rows(index: int, force_n: np.ndarray, response: np.ndarray, sample_rate_hz: float,
                   start_time_s: float) -> HitRecord:
    from gasfilm.analysis.uff import trigger_sample

    return HitRecord(index=index, data=np.stack((force_n, response)), sample_rate_hz=sample_rate_hz,
                     trigger_index=trigger_sample(force_n), start_time_s=start_time_s,
                     overload=np.zeros(2, bool), force_channel=0, response_channel=1)


def _load_npy(paths: Sequence[Path]) -> Source:
    from gasfilm.analysis.session.layout import MAX_ABS_SI

    hits, rate_hz = [], None
    for path in paths:
        try:
            with np.errstate(over="ignore"):  # (a header declaring a giant shape: numpy refuses it with a ValueError)
                record = np.load(path, mmap_mode="r", allow_pickle=False)
        except OSError as error:
            if error.errno == errno.ENOMEM:  # (the record cannot be mapped: memory, not the file, ran out)
                raise MemoryError(f"{path}: {error.strerror}") from None
            raise SettingError(f"{path}: not a readable NumPy array ({error.strerror or error})") from None
        except (ValueError, OverflowError, SyntaxError, TypeError, EOFError,
                tokenize.TokenError) as error:  # (numpy parses the header as Python literals)
            raise SettingError(f"{path}: not a readable NumPy array ({' '.join(str(error).split())[:160]})") from None
        if record.ndim != 2 or record.shape[0] != 3 or not np.issubdtype(record.dtype, np.floating):
            raise SettingError(f"{path}: expected a float array of 3 rows (time s, force N, response m/s²), "
                               f"got {record.dtype} {record.shape}")
        if not 2 < record.shape[1] <= MAX_NPY_SAMPLES:
            raise SettingError(f"{path}: {record.shape[1]} samples per row (2 to {MAX_NPY_SAMPLES} are read)")
        record = np.array(record, dtype=np.float64)
        if not np.all(np.isfinite(record)):
            raise SettingError(f"{path}: holds NaN or infinite samples")
        for row, name, kind, unit in ((1, "force", ChannelKind.FORCE, "N"),
                                      (2, "response", ChannelKind.ACCELERATION, "m/s²")):
            if not np.max(np.abs(record[row])) <= MAX_ABS_SI[kind]:
                raise SettingError(f"{path}: row {row} ({name}) holds values beyond {MAX_ABS_SI[kind]:g} {unit}: "
                                   f"a damaged file")
        steps = np.diff(record[0])
        step = float(np.median(steps))
        if not step > 0 or np.max(np.abs(steps - step)) > 1e-6 * step:
            raise SettingError(f"{path}: row 0 is not an evenly spaced time in s")
        hit_rate_hz = (record.shape[1] - 1) / float(record[0, -1] - record[0, 0])
        if rate_hz is not None and abs(hit_rate_hz - rate_hz) > 1e-6 * rate_hz:
            raise SettingError(f"{path}: sampled at {hit_rate_hz:g} S/s, the other files at {rate_hz:g} S/s")
        rate_hz = hit_rate_hz if rate_hz is None else rate_hz  # one rate for all the files
        hits.append(_hit_from_rows(len(hits), record[1], record[2], rate_hz, float(len(hits))))
    lengths = {hit.n_samples for hit in hits}
    if len(lengths) != 1:
        raise SettingError(f"{paths[0].parent}: the .npy records have different lengths ({sorted(lengths)} samples)")
    settings = {"source": {"npy_files": [str(path) for path in paths]}}
    logger.info("read %d .npy hit records at %g S/s from %s", len(hits), rate_hz, paths[0].parent)
    return Source(paths[0], "npy", default_hammer_and_accelerometer(rate_hz), rate_hz, None, settings, hits,
                  [None] * len(hits), None)


def _load_uff(path: Path, force_dof: Any, response_dof: Any) -> Source:
    from gasfilm.analysis.uff import read_uff_time_records

    records = read_uff_time_records(path, tuple(force_dof) if force_dof else None,
                                    tuple(response_dof) if response_dof else None)
    if records.length_note:
        logger.warning("%s: %s", path, records.length_note)
    hits = [_hit_from_rows(i, record[0], record[1], records.sample_rate_hz, float(records.start_times_s[i]))
            for i, record in enumerate(records.records)]
    settings = {"source": {"uff_file": str(path), "force_dof": records.force_dof,
                           "response_dof": records.response_dof}}
    if records.conditions:  # written by a gasfilm export: the session's operating point travels with its records
        settings["conditions"] = records.conditions
    return Source(path, "uff", default_hammer_and_accelerometer(records.sample_rate_hz), records.sample_rate_hz,
                  None, settings, hits, [None] * len(hits), None)


def _load_session(path: Path) -> Source:
    from gasfilm.analysis.session import Session

    with Session.open(path, "r") as session:
        stored = session.hits()
        config = session.daq_config
        return Source(
            path=path,
            kind="session",
            config=config,
            sample_rate_hz=session.sample_rate_hz,
            rig_spec_toml=session.rig_spec_toml,
            settings=session.settings,
            hits=[hit.as_hit_record() for hit in stored],
            verdicts=[hit.verdict for hit in stored],
            full_scale_si=recorded_full_scale_si(config, session.settings),
        )


def check_several(paths: Sequence[Path]) -> None:
    """Several input files are read only as .npy records (one per hit); one line naming the second otherwise."""
    if len(paths) > 1 and {Path(path).suffix.lower() for path in paths} != {NPY_SUFFIX}:
        raise SettingError(f"{paths[1]}: several input files are read only as .npy records; give one session "
                           f"or UFF file")


def load_source(paths: Path | Sequence[Path], force_dof: Any = None, response_dof: Any = None) -> Source:
    """Read a session, a UFF file or one or more .npy records (``force_dof``/``response_dof``: UFF node and
    direction pairs, else the file's only ones)."""
    paths = [Path(paths)] if isinstance(paths, (str, Path)) else [Path(path) for path in paths]
    if not paths:
        raise SettingError("no input file given")
    if {path.suffix.lower() for path in paths} == {NPY_SUFFIX}:
        return _load_npy(paths)
    check_several(paths)
    if force_dof or response_dof:
        if paths[0].suffix.lower() not in UFF_SUFFIXES:
            raise SettingError(f"--force-dof/--response-dof: {paths[0]} is not a UFF file")
    if paths[0].suffix.lower() in UFF_SUFFIXES:
        return _load_uff(paths[0], force_dof, response_dof)
    return _load_session(paths[0])
