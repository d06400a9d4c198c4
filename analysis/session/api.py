"""The session API: :class:`Session` (create, open, append hits, store results) and :class:`StoredHit`."""

from __future__ import annotations

import bisect
import collections.abc
import contextlib
import functools
import json
import logging
import os
import re
import shutil
import sys
import threading
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence, TypeVar

import h5py
import numpy as np

from gasfilm.analysis.interrupts import signals_deferred
from gasfilm.analysis.session.files import (
    WriterLock,
    building_path,
    check_unclosed_file,
    describe_open_failure,
    move_into_place,
    open_h5,
    open_store,
    remove_leftovers,
)
from gasfilm.analysis.session.journal import RollbackFile, journal_path, restore, rolled_back_view
from gasfilm.analysis.session.layout import (
    DEFAULT_SAMPLES_PER_CHUNK,
    FORMAT_NAME,
    MAX_ABS_SI,
    MAX_SAMPLE_RATE_HZ,
    MAX_SAMPLES_PER_CHUNK,
    SCHEMA_VERSION,
    SessionError,
    SessionWriteError,
    check_declared_rows,
    committed_hits,
    config_from_dict,
    config_to_dict,
    decode_reasons,
    encode_reasons,
    hit_table_dtype,
    json_dumps,
    one_line,
    read_mapping,
    utc_now,
    write_mapping,
)

from gasfilm.analysis.paths import missing_folder
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import DaqConfig

logger = logging.getLogger(__name__)

#: A session refuses to grow past this size unless told otherwise (``Session.size_limit_bytes``).
DEFAULT_SIZE_LIMIT_BYTES = 4_000_000_000
#: Free space kept on the disk besides the next hit: room for HDF5's metadata and for closing the session properly.
FREE_SPACE_MARGIN_BYTES = 1 << 20
#: What a damaged file's metadata can make h5py, numpy or the decoders raise while it is read.
_READ_ERRORS = (OSError, KeyError, ValueError, TypeError, RuntimeError, IndexError, AttributeError, MemoryError,
                OverflowError, UnicodeError)
#: What a failing write (full disk, I/O error) or HDF5 writing over damaged metadata can raise.
_WRITE_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError, IndexError, AttributeError, OverflowError)
#: The groups every session holds.
_GROUPS = ("rig", "daq", "settings", "hits", "frf", "fits", "diagnoses")
#: A rigid-body identification (``gasfilm rigid``), when one was made (an optional group).
RIGID_BODY_GROUP = "rigid_body"
#: The diagnosis most recently stored is found under this name: a link to its run (``Session.add_diagnosis``).
LATEST_DIAGNOSIS = "latest"
#: Each stored diagnosis run is kept as ``run-001``, ``run-002``, … (numbered from 1, never reused).
DIAGNOSIS_RUN = re.compile(r"run-(\d+)")
#: FrfResult fields with one value per frequency line.
_FRF_LINE_FIELDS = ("h1", "h2", "coherence", "gff", "gxx", "gfx", "h1_std_coherence", "h1_std_scatter")

Method = TypeVar("Method", bound=Callable[..., Any])


def _reading(what: str) -> Callable[[Method], Method]:
    """Turn anything a damaged file makes the decorated reader raise into one :class:`SessionError` line naming the
    file and ``what`` could not be read."""

    def decorate(method: Method) -> Method:
        @functools.wraps(method)
        def reader(self: "Session", *args: Any, **kwargs: Any) -> Any:
            try:
                return method(self, *args, **kwargs)
            except SessionError:
                raise
            except GasfilmError as error:
                raise SessionError(f"{self.path}: damaged session: {what}: {error}") from None
            except _READ_ERRORS as error:
                raise SessionError(f"{self.path}: damaged session: {what} cannot be read ({one_line(error)})") from None

        return reader  # type: ignore[return-value]

    return decorate


@contextlib.contextmanager
def _h5py_errors_raised(on_error: Callable[[], None] = lambda: None) -> Iterator[None]:
    """Raise the HDF5 write errors that h5py can only report when it frees an object whose cached data cannot be
    written (e.g. on a full disk): it prints them through ``sys.excepthook`` and ``sys.unraisablehook`` and goes on.
    Both hooks collect them instead while the block runs (only h5py runs inside it, in this thread). On an error,
    ``on_error`` runs before the h5py objects of the failed call are freed."""
    swallowed: list[BaseException] = []
    previous = sys.unraisablehook, sys.excepthook
    thread = threading.get_ident()

    def unraisable_hook(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, (OSError, RuntimeError)) and threading.get_ident() == thread:
            swallowed.append(unraisable.exc_value)
        else:
            previous[0](unraisable)

    def except_hook(kind: type, value: BaseException, trace: Any) -> None:
        if isinstance(value, (OSError, RuntimeError)) and threading.get_ident() == thread:
            swallowed.append(value)
        else:
            previous[1](kind, value, trace)

    sys.unraisablehook, sys.excepthook = unraisable_hook, except_hook
    try:
        yield
    except (OSError, RuntimeError) as error:
        on_error()
        traceback.clear_frames(error.__traceback__)  # frees the h5py objects its frames hold while the hooks listen
        raise
    finally:
        sys.unraisablehook, sys.excepthook = previous
    if swallowed:
        raise swallowed[0]



def _write_error_text(error: BaseException) -> str:
    """The operating system's reason in an HDF5 write error (e.g. "No space left on device"), else its message."""
    match = re.search(r"error message = '([^']*)'", str(error))
    if match:
        return match.group(1)
    return getattr(error, "strerror", None) or one_line(error)



def _close_quietly(file: h5py.File, store: RollbackFile | None) -> BaseException | None:
    """Close an HDF5 file; when closing fails (its last writes fail), let go of the file through ``store`` (HDF5's
    writes then reach nothing) and close it again, so that HDF5 does not retry, and crash, when the process exits.
    Returns the failure, or None."""
    try:
        with _h5py_errors_raised():
            file.close()
    except (OSError, RuntimeError) as error:
        if store is not None:
            store.rollback()
        with contextlib.suppress(OSError, RuntimeError), _h5py_errors_raised():
            file.close()
        return error
    return None


def real_path(path: Path) -> Path:
    """The file a session path names, links followed: a session named through a symbolic link is written where the
    link points (in place, the link kept), its journal and hidden files beside it."""
    return Path(os.path.realpath(path))


def _refuse_old_journal(path: Path) -> None:
    """A ``NAME.journal/`` folder is the hit journal of a gasfilm before the rollback journal: its hits may be missing
    from the file, so the session is left as it is, with one line saying how to rebuild it."""
    if journal_path(path).is_dir():
        raise SessionError(
            f"{path}: {journal_path(path).name}/ is the hit journal of an earlier gasfilm version (its writer stopped "
            f"before closing the session); open the session once with that version, which rebuilds it from the "
            f"journal, then with this one"
        )


def _record_extents(data: h5py.Dataset) -> list[tuple[int, int]]:
    """Where the stored records' chunks lie in the file, as sorted (start, end) byte ranges."""
    extents: list[tuple[int, int]] = []
    data.id.chunk_iter(lambda chunk: extents.append((chunk.byte_offset, chunk.byte_offset + chunk.size)))
    return sorted(extents)


def _write_setup(file: h5py.File, daq_config: DaqConfig, rig_spec_toml: str | None, settings: Mapping[str, Any],
                 actual_sample_rate_hz: float | None, device_name: str, record_samples: int | None) -> None:
    """A new session's attributes, groups and empty hit datasets (docs/session-format.md)."""
    file.attrs["format"] = FORMAT_NAME
    file.attrs["schema_version"] = SCHEMA_VERSION
    file.attrs["created_utc"] = utc_now()
    file.attrs["status"] = "recording"
    file.attrs["status_reason"] = ""
    file.attrs["closed_utc"] = ""
    rig = file.create_group("rig")
    rig.attrs["present"] = rig_spec_toml is not None
    rig.create_dataset("spec_toml", data=rig_spec_toml or "", dtype=h5py.string_dtype())
    daq = file.create_group("daq")
    daq.attrs["config"] = json_dumps(config_to_dict(daq_config))
    daq.attrs["requested_sample_rate_hz"] = float(daq_config.sample_rate_hz)
    daq.attrs["sample_rate_hz"] = float(actual_sample_rate_hz or daq_config.sample_rate_hz)
    daq.attrs["device"] = device_name
    settings_group = file.create_group("settings")
    for key, value in settings.items():
        settings_group.attrs[key] = json_dumps(value)
    channel_count = len(daq_config.channels)
    chunk_samples = min(record_samples or DEFAULT_SAMPLES_PER_CHUNK, MAX_SAMPLES_PER_CHUNK)
    hits = file.create_group("hits")
    hits.create_dataset("data", shape=(0, channel_count, 0), maxshape=(None, channel_count, None),
                        chunks=(1, channel_count, chunk_samples), dtype="<f8", fillvalue=np.nan)
    hits.create_dataset("table", shape=(0,), maxshape=(None,), chunks=(64,), dtype=hit_table_dtype(channel_count))
    for name in ("frf", "fits", "diagnoses"):
        file.create_group(name)


@dataclass(frozen=True)
class StoredHit:
    """One hit as stored in a session: the raw record and how it was judged."""

    index: int  # row in the session, 0-based
    data: np.ndarray  # (channels, samples), N and m/s²
    sample_rate_hz: float
    trigger_index: int
    start_time_s: float
    overload: np.ndarray  # (channels,) bool
    force_channel: int
    response_channel: int
    capture_index: int  # the hit's index as numbered by the capture that produced it
    verdict: Any  # analysis.validation.Verdict

    @property
    def trigger_time_s(self) -> float:
        return self.start_time_s + self.trigger_index / self.sample_rate_hz

    def as_hit_record(self) -> Any:
        """The stored hit as an :class:`gasfilm.analysis.capture.HitRecord` (for re-validation)."""
        from gasfilm.analysis.capture import HitRecord

        return HitRecord(
            index=self.index,
            data=self.data,
            sample_rate_hz=self.sample_rate_hz,
            trigger_index=self.trigger_index,
            start_time_s=self.start_time_s,
            overload=self.overload,
            force_channel=self.force_channel,
            response_channel=self.response_channel,
        )



class StoredHits(collections.abc.Sequence):
    """Hits of a session read on demand (:meth:`Session.stored_hits`): an item or a slice reads just those records."""

    def __init__(self, session: "Session", indices: np.ndarray, rows: np.ndarray) -> None:
        self._session, self._indices, self._rows = session, indices, rows

    def __len__(self) -> int:
        return len(self._indices)

    def __getitem__(self, key: int | slice) -> Any:
        if isinstance(key, slice):
            return self._session._stored(self._indices[key], self._rows)
        return self._session._stored(self._indices[key: key + 1 or None], self._rows)[0]


#: Sessions this process has said it read while another process held them for writing (said once each).
_SAID_HELD_ELSEWHERE: set[Path] = set()


class Session:
    """An open session file. Create with :meth:`create`, open with :meth:`open`; use as a context manager.

    A session opened for writing is written in place through its rollback journal (:mod:`.journal`): a hit or a
    verdict is committed (durable) before its method returns, and so is a result (unless the session was opened with
    :meth:`updating`: all at its close); settings are committed with the next of them or at the close. A failed write
    rolls back everything since the last commit, and closing a session that nothing was written to leaves its file as
    it was, byte for byte."""

    def __init__(self, path: Path, file: h5py.File, lock: WriterLock | None = None, recovered: bool = False,
                 store: RollbackFile | None = None) -> None:
        self.path = path
        self._file = file
        self._lock = lock
        self._store = store
        self.writable = lock is not None
        self.recovered = recovered
        #: Appending a hit that would make the file larger than this raises :class:`SessionWriteError`.
        self.size_limit_bytes = DEFAULT_SIZE_LIMIT_BYTES
        self._write_failure: str | None = None  # why writing failed: the file is then closed without more writes
        self._hit_count = 0
        self._changed = False  # written since the last commit
        self._committed = False  # something was committed since the session was opened
        self._deferred = 0  # opened by updating(): results wait for the close
        self._records: list[tuple[int, int]] = []  # byte ranges of the stored records (a writer never writes there)
        try:
            self._check_layout()
            if self.writable:
                with _h5py_errors_raised():
                    self._records = _record_extents(self._data)
        except (SessionError, *_READ_ERRORS) as error:
            _close_quietly(self._file, store)
            if store is not None:
                store.rollback()
                store.close()
            if lock is not None:
                lock.release()
            if isinstance(error, SessionError):
                raise
            raise SessionError(f"{path}: damaged session: its hit records cannot be located "
                               f"({one_line(error)})") from None

    @property
    def sync_each_hit(self) -> bool:
        """Whether each commit is fsynced (False for bulk imports: a killed process loses nothing, a power cut may)."""
        return self._store is None or self._store.sync

    @sync_each_hit.setter
    def sync_each_hit(self, value: bool) -> None:
        if self._store is not None:
            self._store.sync = bool(value)

    # ----- creating and opening -------------------------------------------------------------------------------

    @classmethod
    def create(
        cls,
        path: str | Path,
        daq_config: DaqConfig,
        rig_spec_toml: str | None,
        settings: Mapping[str, Any],
        overwrite: bool = False,
        actual_sample_rate_hz: float | None = None,
        device_name: str = "",
        sync_each_hit: bool = True,
        record_samples: int | None = None,
    ) -> "Session":
        """A new session file holding the setup; it appears at ``path`` only once complete.

        ``actual_sample_rate_hz`` is the rate the device reports (the NI 9234 may coerce the requested rate);
        ``sync_each_hit=False`` skips the fsync after each hit (for bulk imports, not for live acquisition);
        ``record_samples``, the expected samples per record, sizes the storage chunks (any length can be stored).
        A ``path`` that is a symbolic link names the file it points to: that file is created (or replaced), the link
        kept.
        """
        path = Path(path)
        if path.exists() and not overwrite:
            raise SessionError(f"{path}: the session file exists already (choose another name, or append to it)")
        if path.is_dir():
            raise SessionError(f"{path}: is a folder, not a session file")
        real = real_path(path)
        if not real.parent.is_dir():
            raise SessionError(f"{path}: {missing_folder(real.parent)}")
        _refuse_old_journal(real)
        remove_leftovers(real)
        free_bytes = shutil.disk_usage(real.parent).free
        if free_bytes < FREE_SPACE_MARGIN_BYTES:  # HDF5 failing mid-creation can crash the process when it exits
            raise SessionWriteError(f"{path}: disk full ({free_bytes / 1e6:.3g} MB free); the session is not created")
        replaced = WriterLock(real) if overwrite and real.exists() else None  # never replace a session being recorded
        building = building_path(real, "creating")
        store = None
        lock = None
        try:
            try:
                store = RollbackFile.created(building)
                store.sync = sync_each_hit
                file = open_store(store, "w")
            except OSError as error:
                raise SessionError(f"{path}: cannot create the session file ({_write_error_text(error)})") from None
            try:
                lock = WriterLock(building)
                with _h5py_errors_raised():
                    _write_setup(file, daq_config, rig_spec_toml, settings, actual_sample_rate_hz, device_name,
                                 record_samples)
                    file.flush()
                    file.swmr_mode = True
                store.commit()
                with signals_deferred():  # (named and handed over whole: a stop signal is raised after, see below)
                    move_into_place(building, real, overwrite)
                    store.moved_to(real)
                    if replaced is not None:
                        journal_path(real).unlink(missing_ok=True)  # the replaced session's, left by a killed writer
                    session = cls(path, file, lock, store=store)
                    session._committed = True
            except KeyboardInterrupt:
                if store.path == real:  # a stop signal during the creation, raised once the session was whole
                    session._take_back(replaced is None)
                raise
            except BaseException as error:
                if isinstance(error, (OSError, RuntimeError)):
                    logger.error("%s: creating the session failed: %s", path, error)
                    error = SessionError(f"{path}: cannot create the session file ({_write_error_text(error)})")
                store.rollback()
                _close_quietly(file, store)
                if lock is not None:
                    lock.release()
                if isinstance(error, SessionError):
                    raise error from None
                raise
        except BaseException:
            if store is not None:
                store.close()
            building.unlink(missing_ok=True)
            raise
        finally:
            if replaced is not None:
                replaced.release()
        return session

    def _take_back(self, remove: bool) -> None:
        """A creation stopped by a signal once the session was in place: close it as aborted and, unless it replaced
        another file, remove it (the caller never had it: "not created" is then true)."""
        with signals_deferred():
            try:
                self.close("aborted", "stopped during its creation")
            except SessionError:
                self.discard()
            if remove:
                with contextlib.suppress(OSError):
                    real_path(self.path).unlink()

    @classmethod
    def open(cls, path: str | Path, mode: str = "r") -> "Session":
        """Open a session for reading (``"r"``) or for appending and adding results (``"a"``).

        A session whose writer was killed during a commit has a rollback journal left next to it: reading shows the
        session as at its last commit (in memory), appending restores the file on disk first. A session whose
        writer was killed at another moment is as at its last commit already; appending to it marks it recovered.
        A ``path`` that is a symbolic link names the session it points to, which is written in place."""
        path = Path(path)
        if mode not in ("r", "a"):
            raise SessionError(f"{path}: mode '{mode}' is not valid; use 'r' or 'a'")
        if path.is_dir():
            raise SessionError(f"{path}: is a folder, not a session file")
        if not path.exists():
            raise SessionError(f"{path}: no such session file")
        _refuse_old_journal(real_path(path))
        if mode == "a":
            return cls._open_for_writing(path)
        return cls._open_read_only(path)

    @classmethod
    @contextlib.contextmanager
    def updating(cls, path: str | Path) -> Iterator["Session"]:
        """Open a session for writing to store results and settings in it, all or nothing: they are committed
        together when the block ends and the session closes; when the block raises or a write fails, nothing of it
        reaches the file (byte for byte as it was). Hits and verdicts are committed at once, as always."""
        session = cls.open(path, "a")
        session._deferred += 1
        try:
            yield session
        except BaseException:
            session.discard()
            raise
        session._deferred -= 1
        session.close()

    @classmethod
    def _open_read_only(cls, path: Path) -> "Session":
        """The session file as its last commit left it."""
        real = real_path(path)
        live = WriterLock.held_by_a_writer(real)
        # (export, report … of a session another process records: what it holds now, said once; never of a session
        # this process has open itself, as the GUI diagnosing its own session)
        if live and not WriterLock.held_here(real) and real not in _SAID_HELD_ELSEWHERE:
            _SAID_HELD_ELSEWHERE.add(real)
            logger.warning("%s: open for writing in another gasfilm process (a recording or the GUI): read as it "
                           "stands now", path)
        if not live and journal_path(real).is_file():
            return cls._rolled_back(path, real)
        try:
            file = open_h5(path, "r")
        except OSError as error:
            if "already open for write" not in str(error):
                raise describe_open_failure(path, error) from None
            # The flags of a writer that is still recording or that ended without closing the file (killed, crashed,
            # power lost): the latter is checked first (reading a truncated one in SWMR mode can run for minutes).
            if not live:
                check_unclosed_file(path)
            try:
                file = open_h5(path, "r", swmr=True)
            except OSError as swmr_error:
                raise describe_open_failure(path, swmr_error) from None
            return cls(path, file, recovered=not live)
        return cls(path, file)

    @classmethod
    def _rolled_back(cls, path: Path, real: Path) -> "Session":
        """A read-only view of a session whose writer was killed during a commit: the file with its journal applied in
        memory (nothing is written)."""
        view = rolled_back_view(real)
        try:
            try:
                file = open_store(view, "r")
            except OSError as error:
                if "already open for write" not in str(error):
                    raise describe_open_failure(path, error) from None
                file = open_store(view, "r", swmr_read=True, single_read_attempt=True)
        except OSError as error:
            view.close()
            raise describe_open_failure(path, error) from None
        except BaseException:
            view.close()
            raise
        logger.warning("%s: read as at its last commit (its writer stopped during a commit; %s restores the file "
                       "when the session is next opened for writing)", path, journal_path(real).name)
        return cls(path, file, recovered=True, store=view)

    @classmethod
    def _open_for_writing(cls, path: Path, announce: bool = True) -> "Session":
        """Take the writer lock, restore the file from a journal a killed writer left, and open it in place for
        appending (a file whose writer was killed is opened with its flags cleared, and marked recovered)."""
        real = real_path(path)
        lock = WriterLock(real)
        store = None
        file = None
        try:
            remove_leftovers(real)
            try:
                restored = restore(real)
            except OSError as error:
                raise SessionWriteError(f"{path}: cannot restore the session from its journal "
                                        f"{journal_path(real).name} ({error.strerror or error}); nothing was changed")
            try:
                store = RollbackFile(real, writable=True)
            except OSError as error:
                raise SessionWriteError(
                    f"{path}: cannot open the session for writing ({error.strerror or error})") from None
            killed = store.left_open  # a writer that ended without closing the file (killed, crashed)
            try:
                if killed:  # checked first; then, as h5clear -s, opened with its flags cleared and closed (the clean
                    check_unclosed_file(real)  # flags held), then opened
                    open_store(store, "r+", clear_status_flags=True).close()
                file = open_store(store, "r+")
            except OSError as error:
                raise describe_open_failure(path, error) from None
            session = cls(path, file, lock, recovered=killed or restored, store=store)
            file = None  # (the session owns it now, and let go of it if it refused it)
            if killed:
                session._mark_recovered(announce)
            with session._writing("the session's open state"):
                session._settled()
        except BaseException:
            if file is not None:
                _close_quietly(file, store)
            if store is not None:
                store.rollback()
                store.close()
            lock.release()
            raise
        return session

    def _mark_recovered(self, announce: bool) -> None:
        """A session whose writer ended without closing it: status "interrupted" when it was recording, and when."""
        with self._writing("the recovered session's status"):
            self._structural()
            if self._file.attrs["status"] == "recording":
                self._file.attrs["status"] = "interrupted"
                self._file.attrs["status_reason"] = (f"the recording process ended without closing the session; "
                                                     f"{self._hit_count} hits recovered")
            self._file.attrs["recovered_utc"] = utc_now()
            self._changed = True
        logger.log(logging.WARNING if announce else logging.INFO, "%s: its writer ended without closing it (status "
                   "%s: %s)", self.path, self.status, self.status_reason)

    @_reading("its layout")
    def _check_layout(self) -> None:
        """Refuse a file that is not a session, is too new, or whose structure or declared sizes are damaged."""
        attrs = self._file.attrs
        format_mark = attrs.get("format")
        if not (isinstance(format_mark, str) and format_mark == FORMAT_NAME) or "schema_version" not in attrs:
            raise SessionError(f"{self.path}: an HDF5 file, but not a gasfilm session (no '{FORMAT_NAME}' format mark)")
        version = attrs["schema_version"]
        version = version.item() if isinstance(version, np.generic) else version
        if isinstance(version, bool) or not isinstance(version, int) or version < 1:
            raise SessionError(
                f"{self.path}: damaged session: schema_version {one_line(repr(version), 60)} is not a positive integer"
            )
        if version > SCHEMA_VERSION:
            raise SessionError(
                f"{self.path}: session schema_version {version} is newer than this gasfilm reads "
                f"(up to {SCHEMA_VERSION}); update gasfilm"
            )
        for name in ("status", "status_reason"):
            if not isinstance(attrs.get(name), str):
                raise SessionError(f"{self.path}: damaged session: the '{name}' attribute is missing or not text")
        for name in _GROUPS:
            if not isinstance(self._file.get(name), h5py.Group):
                raise SessionError(f"{self.path}: damaged session: the group '{name}' is missing")
        for name in ("data", "table"):
            if not isinstance(self._file["hits"].get(name), h5py.Dataset):
                raise SessionError(f"{self.path}: damaged session: the dataset 'hits/{name}' is missing")
        data, table = self._data, self._table
        channels = len(self.daq_config.channels)
        if data.ndim != 3 or data.dtype.kind != "f" or data.shape[1] != channels:
            raise SessionError(
                f"{self.path}: damaged session: 'hits/data' has shape {data.shape} and type {data.dtype}; expected "
                f"(hits, {channels} channels, samples) floats"
            )
        expected = hit_table_dtype(channels)
        if table.ndim != 1 or table.dtype.names is None or any(
            name not in table.dtype.names or table.dtype[name].shape != expected[name].shape for name in expected.names
        ):
            raise SessionError(f"{self.path}: damaged session: 'hits/table' does not have the hit table's columns")
        check_declared_rows(self.path, table, data, self._file.id.get_filesize())
        self._hit_count = committed_hits(table, data)

    # ----- context manager and closing ----------------------------------------------------------------------

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, exc_type: type | None, exc: BaseException | None, traceback: object) -> None:
        if not self.is_open:
            return
        failed = self._write_failure is not None
        if exc is not None and self.writable and not failed and self._file.attrs["status"] == "recording":
            self.close("aborted", f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__)
        else:
            self.close()

    @property
    def is_open(self) -> bool:
        return bool(self._file.id.valid)

    def close(self, status: str | None = None, reason: str = "") -> None:
        """Close the file, recording how the session ended: ``"complete"`` or ``"aborted"`` (with a reason).

        Without a status, a session that was recording becomes ``"complete"`` and any other keeps its status (so
        adding a fit to an aborted session does not make it complete). A session opened for writing that nothing was
        written to is closed without a write: its file stays as it was, byte for byte. A stop signal waits until the
        session is closed."""
        with signals_deferred():
            self._close(status, reason)

    def _close(self, status: str | None, reason: str) -> None:
        if not self.is_open:
            return
        if not self.writable or self._write_failure is not None:
            self._let_go()
            if self._write_failure is not None and self._committed:
                self._finish_after_failure()
            return
        if status is not None and status not in ("complete", "aborted"):
            raise SessionError(f"{self.path}: close status '{status}' is not valid; use 'complete' or 'aborted'")
        if not (self._changed or self._committed):
            self.discard()
            return
        if status is None:
            status = "complete" if self._file.attrs["status"] == "recording" else None
        try:
            with self._writing(f"its status '{status}'" if status else "the session's closing"):
                if status is not None:
                    self._set_status(status, reason)
                    self._file.attrs["closed_utc"] = utc_now()
                    self._file.flush()
                self._file.close()
                self._guard_records()
                self._store.commit()
            self._changed = False
        finally:
            self._let_go()

    def _finish_after_failure(self) -> None:
        """After a failed write, close the session at its last commit as "interrupted", saying why, where the disk
        still allows it (else it is left as that commit left it, open for writing: it reads as interrupted)."""
        reason = f"writing failed ({self._write_failure}); the {self._hit_count} hits before it are kept"
        try:
            again = Session._open_for_writing(self.path, announce=False)
        except SessionError as error:
            logger.info("%s: the status is left as at the last commit (%s)", self.path, error)
            return
        try:
            with again._writing("the status after the failure"):
                again._set_status("interrupted", reason)
                again._file.attrs["closed_utc"] = utc_now()
            again.close()
        except SessionError as error:
            logger.info("%s: the status is left as at the last commit (%s)", self.path, error)

    def discard(self) -> None:
        """Close without committing what was written since the last commit: the file stays as that commit left it
        (as it was when opened, when nothing was committed since)."""
        if self._store is not None:
            self._store.rollback()
        self._let_go()

    def _let_go(self) -> None:
        """Close the HDF5 file (after a failure its writes reach nothing), the file behind it and the writer lock."""
        if self.is_open:
            failure = _close_quietly(self._file, self._store)
            if failure is not None and self._write_failure is None and self.writable:
                logger.error("%s: closing the file failed: %s", self.path, one_line(failure))
        if self._store is not None:
            if self.writable and self._write_failure is None and (self._changed or self._store.uncommitted_bytes):
                self._store.rollback()  # (a close that did not commit: nothing of it reaches the file)
            self._store.close()
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    @contextlib.contextmanager
    def _writing(self, what: str) -> Iterator[None]:
        """Run HDF5 writes; when one fails (full disk, I/O error), roll back everything since the last commit and let
        go of the file (nothing more is written), and raise one :class:`SessionWriteError` line naming ``what`` was
        being written."""
        try:
            with _h5py_errors_raised(on_error=self._roll_back):
                yield
            if self._store is not None and self._store.failure is not None:
                raise self._store.failure  # a write h5py reported nowhere
        except _WRITE_ERRORS as error:
            self._roll_back()
            self._write_failure = _write_error_text(error)
            logger.error("%s: writing %s failed: %s; %d hits kept", self.path, what, one_line(error),
                         self._hit_count)
            kept = (f"recording stopped, the {self._hit_count} hits before it are kept" if what == "a new hit" else
                    "the session is left as it was before it")
            raise SessionWriteError(f"{self.path}: writing {what} failed ({self._write_failure}); {kept}") from None

    def _roll_back(self) -> None:
        if self._store is not None and self._write_failure is None:
            self._store.rollback()

    def _commit(self, what: str) -> None:
        """Make what was written durable (unless opened by :meth:`updating`, whose close commits)."""
        if self._deferred:
            return
        with self._writing(what), signals_deferred():
            self._file.flush()
            self._guard_records()
            self._store.commit()
        self._changed = False
        self._committed = True

    def _guard_records(self) -> None:
        """Refuse a commit that would write over a stored record (HDF5 misled by damaged metadata into reusing its
        bytes): the session is then rolled back, its hits as they were."""
        starts = [start for start, _ in self._records]
        for offset, length in self._store.held_ranges():
            before = bisect.bisect_left(starts, offset + length) - 1  # the last record starting before the write ends
            if before >= 0 and self._records[before][1] > offset:
                raise ValueError(f"damaged session: HDF5 was about to write over the stored record at byte "
                                 f"{self._records[before][0]}")

    def _set_status(self, status: str, reason: str) -> None:
        self._structural()
        self._file.attrs["status"] = status
        self._file.attrs["status_reason"] = reason
        self._file.flush()

    # ----- file modes ------------------------------------------------------------------------------------------

    def _require_writable(self) -> None:
        if not self.writable:
            raise SessionError(f"{self.path}: the session is open read-only (open it with mode 'a' to change it)")
        if self._write_failure is not None:
            raise SessionWriteError(f"{self.path}: writing failed earlier ({self._write_failure}); nothing more is written")
        if not self.is_open:
            raise SessionError(f"{self.path}: the session is closed")

    def _structural(self) -> None:
        """Leave SWMR mode (by reopening the file) so groups and attributes can be created."""
        self._require_writable()
        self._changed = True
        if self._file.swmr_mode:
            self._file.close()
            self._file = open_store(self._store, "r+")

    def _settled(self) -> None:
        """After a change of groups or attributes: flush and enter SWMR mode, so that the file a commit leaves is
        readable while this process writes it, and after it was killed (a file left open for writing outside SWMR
        mode cannot be read at all). The status is left as it is."""
        self._file.flush()
        if not self._file.swmr_mode:
            self._file.swmr_mode = True

    def _appending(self) -> None:
        """Enter SWMR mode, the status "recording": from now on the file on disk is consistent after every commit."""
        self._require_writable()
        if self._file.attrs["status"] != "recording":  # (a session opened for writing is already in SWMR mode)
            self._set_status("recording", "")
        self._settled()

    @property
    def _data(self) -> h5py.Dataset:
        return self._group("hits")["data"]

    @property
    def _table(self) -> h5py.Dataset:
        return self._group("hits")["table"]

    def _group(self, name: str) -> h5py.Group:
        if not self.is_open:
            raise SessionError(f"{self.path}: the session is closed")
        return self._file[name]

    @property
    @_reading("schema_version")
    def schema_version(self) -> int:
        return int(self._file.attrs["schema_version"])

    @property
    @_reading("the status")
    def status(self) -> str:
        """``recording``, ``complete``, ``aborted``; ``interrupted`` when the writer ended without closing."""
        status = str(self._file.attrs["status"])
        if status == "recording" and self.recovered:
            return "interrupted"
        return status

    @property
    @_reading("the status reason")
    def status_reason(self) -> str:
        return str(self._file.attrs["status_reason"])

    @property
    @_reading("the DAQ configuration")
    def daq_config(self) -> DaqConfig:
        return config_from_dict(json.loads(self._group("daq").attrs["config"]))

    @property
    @_reading("the sample rate")
    def sample_rate_hz(self) -> float:
        """The sample rate the device actually ran at."""
        return float(self._group("daq").attrs["sample_rate_hz"])

    @property
    @_reading("the requested sample rate")
    def requested_sample_rate_hz(self) -> float:
        return float(self._group("daq").attrs["requested_sample_rate_hz"])

    @property
    @_reading("the device name")
    def device_name(self) -> str:
        return str(self._group("daq").attrs["device"])

    @property
    @_reading("the rig spec")
    def rig_spec_toml(self) -> str | None:
        if not bool(self._group("rig").attrs["present"]):
            return None
        return self._group("rig")["spec_toml"].asstr()[()]

    @property
    @_reading("the settings")
    def settings(self) -> dict[str, Any]:
        """Processing settings as stored (plain JSON values)."""
        return {key: json.loads(value) for key, value in self._group("settings").attrs.items()}

    @_reading("the stored settings")
    def settings_as(self, key: str, cls: type) -> Any:
        """The stored settings under ``key`` as a ``cls`` dataclass (``cls()`` when none were stored)."""
        from gasfilm.analysis.settings import decode_setting

        return decode_setting(self.settings, key, cls, str(self.path))


    def update_settings(self, settings: Mapping[str, Any]) -> None:
        """Store (or replace) processing settings by key; committed with the next hit, verdict or result, or when the
        session is closed (a run that ends before recording anything can :meth:`discard` them)."""
        self._require_writable()
        encoded = {key: json_dumps(value) for key, value in settings.items()}
        with self._writing("the settings"):
            self._structural()
            for key, value in encoded.items():
                self._group("settings").attrs[key] = value
            self._settled()

    # ----- hits ---------------------------------------------------------------------------------------------------

    @property
    def hit_count(self) -> int:
        """Hits committed to the file (a row in the hit table, written after the hit's record).

        A read-only view of a session being recorded shows the hits committed when it was opened; open it again to
        see newer ones. (``Dataset.refresh`` is not used: with HDF5 2.0.0 it returned wrong table rows from a killed
        writer's file after a partial read.)"""
        return self._hit_count

    @property
    def record_samples(self) -> int:
        """Samples per record (0 before the first hit)."""
        return int(self._data.shape[2])

    def append_hit(self, hit: Any, verdict: Any) -> int:
        """Store one hit and its verdict, committed (durable) before returning; return its index in the session.

        Raises :class:`SessionWriteError` when the hit would pass the size limit or the free disk space, or when
        writing fails (full disk, I/O error): the session is rolled back to its last commit (the hits stored before
        are kept), and nothing more is written."""
        self._require_writable()
        data = np.asarray(hit.data, dtype=np.float64)
        channels = self._data.shape[1]
        if data.ndim != 2 or data.shape[0] != channels:
            raise SessionError(f"{self.path}: hit record of shape {data.shape} does not have {channels} channels")
        if not np.all(np.isfinite(data)):
            raise SessionError(f"{self.path}: hit {self.hit_count + 1} has NaN or infinite samples; not stored")
        if not float(hit.sample_rate_hz) > 0:
            raise SessionError(
                f"{self.path}: hit {self.hit_count + 1} has sample rate {hit.sample_rate_hz}; not stored")
        index = self.hit_count
        samples = self.record_samples
        if index == 0 and self._data.shape[0] == 0:
            samples = data.shape[1]
        elif data.shape[1] != samples:
            raise SessionError(
                f"{self.path}: hit {index + 1} has {data.shape[1]} samples per channel; this session stores {samples}"
            )
        row = np.zeros((), dtype=self._table.dtype)
        row["accepted"] = bool(verdict.accepted)
        row["overridden"] = bool(getattr(verdict, "overridden", False))
        row["reasons"] = encode_reasons(tuple(verdict.reasons), self.path)
        row["start_time_s"] = float(hit.start_time_s)
        row["trigger_index"] = int(hit.trigger_index)
        row["capture_index"] = int(hit.index)
        row["sample_rate_hz"] = float(hit.sample_rate_hz)
        row["force_channel"] = int(hit.force_channel)
        row["response_channel"] = int(hit.response_channel)
        row["overload"] = np.asarray(hit.overload, dtype=bool).reshape(channels)
        self._check_room(data.nbytes + row.nbytes)
        with self._writing("a new hit"):
            self._appending()
            self._changed = True
            records, table = self._data, self._table
            records.resize((index + 1, channels, samples))
            records[index] = data
            table.resize((index + 1,))
            table[index] = row
            del records, table
        self._commit("a new hit")
        with self._writing("a new hit"):
            self._records = sorted(self._records + self._chunks_of_hit(index))
        self._hit_count = index + 1
        return index

    def _chunks_of_hit(self, index: int) -> list[tuple[int, int]]:
        """Where the record of hit ``index`` lies in the file (one range per chunk)."""
        data = self._data
        step = data.chunks[2]
        ranges = []
        for first in range(0, max(data.shape[2], 1), step):
            info = data.id.get_chunk_info_by_coord((index, 0, first))
            if info.byte_offset is not None:
                ranges.append((info.byte_offset, info.byte_offset + info.size))
        return ranges

    def _check_room(self, hit_bytes: int) -> None:
        """Refuse a hit that would pass the size limit or leave the disk without room to close the session."""
        file_bytes = os.path.getsize(self.path)
        if file_bytes + hit_bytes > self.size_limit_bytes:
            logger.error("%s: size limit %d bytes reached with %d hits", self.path, self.size_limit_bytes,
                         self._hit_count)
            raise SessionWriteError(
                f"{self.path}: the session reached its size limit of {self.size_limit_bytes / 1e9:.3g} GB; recording "
                f"stopped, its {self._hit_count} hits are kept"
            )
        free_bytes = shutil.disk_usage(self.path.parent).free
        if free_bytes < hit_bytes + FREE_SPACE_MARGIN_BYTES:
            logger.error("%s: disk full (%d bytes free) with %d hits", self.path, free_bytes, self._hit_count)
            raise SessionWriteError(
                f"{self.path}: disk full ({free_bytes / 1e6:.3g} MB free; a hit needs {hit_bytes / 1e6:.3g} MB "
                f"plus {FREE_SPACE_MARGIN_BYTES / 1e6:.3g} MB kept to close the session); recording stopped, its "
                f"{self._hit_count} hits are kept"
            )

    @_reading("the hit table")
    def _rows(self) -> np.ndarray:
        """The committed rows of the hit table, checked: channels, sample rate and trigger within range."""
        rows = self._table[: self.hit_count]
        channels, samples = self._data.shape[1], self.record_samples
        checks = (
            ("force channel", "force_channel", (rows["force_channel"] >= 0) & (rows["force_channel"] < channels)),
            ("response channel", "response_channel",
             (rows["response_channel"] >= 0) & (rows["response_channel"] < channels)),
            ("sample rate", "sample_rate_hz",
             (rows["sample_rate_hz"] > 0) & (rows["sample_rate_hz"] <= MAX_SAMPLE_RATE_HZ)),
            ("trigger sample", "trigger_index", (rows["trigger_index"] >= 0) & (rows["trigger_index"] <= samples)),
            ("start time", "start_time_s", np.isfinite(rows["start_time_s"])),
        )
        for label, field, valid in checks:
            if not np.all(valid):
                hit = int(np.argmin(valid))
                raise SessionError(
                    f"{self.path}: damaged session: hit {hit + 1} has {label} {rows[field][hit]}, out of range "
                    f"({channels} channels, {samples} samples per record)"
                )
        return rows

    def _verdict(self, row: np.void) -> Any:
        from gasfilm.analysis.validation import Verdict

        return Verdict(
            accepted=bool(row["accepted"]),
            reasons=decode_reasons(bytes(row["reasons"])),
            overridden=bool(row["overridden"]),
        )

    @_reading("the hit verdicts")
    def verdicts(self) -> list[Any]:
        """Every hit's verdict, in order (no sample data read)."""
        return [self._verdict(row) for row in self._rows()]

    @_reading("the hit records")
    def _read_data(self, indices: np.ndarray | slice) -> np.ndarray:
        return self._data[indices]

    def _check_finite(self, records: np.ndarray, indices: np.ndarray) -> None:
        """Raise naming the first hit and channel with NaN samples, or with samples beyond any sensor's range."""
        bad = ~np.all(np.isfinite(records), axis=(1, 2))
        if np.any(bad):
            hit = int(indices[np.argmax(bad)])
            channel = int(np.argmax(~np.all(np.isfinite(records[np.argmax(bad)]), axis=1)))
            label = self.daq_config.channels[channel].label
            raise SessionError(f"{self.path}: hit {hit + 1} has NaN samples in channel {channel} ({label})")
        for channel, config in enumerate(self.daq_config.channels):
            peaks = np.max(np.abs(records[:, channel]), axis=1) if records.shape[2] else np.zeros(len(records))
            beyond = peaks > MAX_ABS_SI[config.kind]
            if np.any(beyond):
                raise SessionError(
                    f"{self.path}: damaged session: hit {int(indices[np.argmax(beyond)]) + 1} has samples beyond "
                    f"{MAX_ABS_SI[config.kind]:g} {config.kind.unit} in channel {channel} ({config.label})"
                )

    @_reading("the hits")
    def hits(self, check_finite: bool = True) -> list[StoredHit]:
        """Every stored hit with its record and verdict."""
        rows = self._rows()
        indices = np.arange(len(rows))
        records = self._read_data(slice(0, len(rows)))
        if check_finite and len(rows):
            self._check_finite(records, indices)
        return [
            StoredHit(
                index=int(index),
                data=records[index],
                sample_rate_hz=float(row["sample_rate_hz"]),
                trigger_index=int(row["trigger_index"]),
                start_time_s=float(row["start_time_s"]),
                overload=np.array(row["overload"], dtype=bool),
                force_channel=int(row["force_channel"]),
                response_channel=int(row["response_channel"]),
                capture_index=int(row["capture_index"]),
                verdict=self._verdict(row),
            )
            for index, row in zip(indices, rows)
        ]

    def stored_hits(self, indices: Sequence[int] | None = None) -> "StoredHits":
        """The hits ``indices`` (all by default) as a sequence read from the file on demand, a slice at a time: what
        averages a large session without holding its records in memory (NaN samples are named as by :meth:`hits`)."""
        rows = self._rows()
        return StoredHits(self, np.arange(len(rows)) if indices is None else np.asarray(indices, dtype=np.int64),
                          rows)

    @_reading("the hits")
    def _stored(self, indices: np.ndarray, rows: np.ndarray) -> list[StoredHit]:
        """The hits ``indices`` (increasing) with their records, checked for NaN samples."""
        if len(indices) == 0:
            return []
        records = self._read_data(indices if len(indices) > 1 else slice(int(indices[0]), int(indices[0]) + 1))
        self._check_finite(records, indices)
        return [
            StoredHit(
                index=int(index),
                data=record,
                sample_rate_hz=float(rows[index]["sample_rate_hz"]),
                trigger_index=int(rows[index]["trigger_index"]),
                start_time_s=float(rows[index]["start_time_s"]),
                overload=np.array(rows[index]["overload"], dtype=bool),
                force_channel=int(rows[index]["force_channel"]),
                response_channel=int(rows[index]["response_channel"]),
                capture_index=int(rows[index]["capture_index"]),
                verdict=self._verdict(rows[index]),
            )
            for index, record in zip(indices, records)
        ]

    @_reading("the hit table")
    def accepted_indices(self) -> np.ndarray:
        return np.flatnonzero(self._rows()["accepted"])

    @_reading("the accepted hits")
    def accepted_records(self) -> np.ndarray:
        """The accepted hits' records, ``(hits, channels, samples)``; raises naming a hit with NaN samples."""
        indices = self.accepted_indices()
        if len(indices) == 0:
            return np.empty((0, self._data.shape[1], self.record_samples))
        records = self._read_data(indices)
        self._check_finite(records, indices)
        return records

    def set_verdict(self, index: int, verdict: Any) -> None:
        """Replace a hit's verdict (e.g. the user overrides a rejection); committed at once."""
        self._require_writable()
        if not 0 <= index < self.hit_count:
            raise SessionError(f"{self.path}: hit {index + 1} does not exist (the session holds {self.hit_count})")
        reasons = encode_reasons(tuple(verdict.reasons), self.path)
        with self._writing(f"the verdict of hit {index + 1}"):
            self._appending()  # (may reopen the file to mark it recording: the table is taken after it)
            self._changed = True
            table = self._table
            row = table[index]
            row["accepted"] = bool(verdict.accepted)
            row["overridden"] = bool(getattr(verdict, "overridden", False))
            row["reasons"] = reasons
            table[index] = row
            del table
        self._commit(f"the verdict of hit {index + 1}")

    # ----- results ------------------------------------------------------------------------------------------------

    def _write_result(self, kind: str, name: str, values: Mapping[str, Any]) -> None:
        self._require_writable()
        with self._writing(f"the {kind} result '{name}'"):
            self._structural()
            parent = self._group(kind)
            if name in parent:
                del parent[name]
            group = parent.create_group(name)
            write_mapping(group, values)
            group.attrs["written_utc"] = utc_now()
            del parent, group
            self._settled()
        self._commit(f"the {kind} result '{name}'")

    def _read_result(self, kind: str, name: str) -> dict[str, Any]:
        if name not in self._group(kind):
            available = ", ".join(self._group(kind)) or "none"
            raise SessionError(f"{self.path}: no {kind} result named '{name}' (available: {available})")
        return self._read_result_group(kind, name)

    @_reading("a stored result")
    def _read_result_group(self, kind: str, name: str) -> dict[str, Any]:
        group = self._group(kind)[name]
        file_bytes = self._file.id.get_filesize()
        for key, dataset in group.items():
            if not isinstance(dataset, h5py.Dataset):
                raise SessionError(f"{self.path}: damaged session: {kind} result '{name}': '{key}' is not a dataset")
            if dataset.compression is None and dataset.size * dataset.dtype.itemsize > file_bytes:
                raise SessionError(
                    f"{self.path}: damaged session: {kind} result '{name}': '{key}' declares {dataset.shape}, "
                    f"more than the file holds"
                )
        values = read_mapping(group)
        values.pop("written_utc", None)
        return values

    @_reading("the stored results")
    def result_names(self, kind: str) -> list[str]:
        """Names stored under ``"frf"``, ``"fits"`` or ``"diagnoses"``."""
        return list(self._group(kind))

    def write_frf(self, frf: Any, name: str = "frf", hit_indices: np.ndarray | None = None) -> None:
        """Store an :class:`gasfilm.analysis.spectra.FrfResult` field by field (optionally with the hits it averages)."""
        values = dict(frf.to_dict())
        if hit_indices is not None:
            values["hit_indices"] = np.asarray(hit_indices, dtype=np.int64)
        self._write_result("frf", name, values)

    def read_frf(self, name: str = "frf") -> Any:
        """The :class:`gasfilm.analysis.spectra.FrfResult` stored under ``name``."""
        from gasfilm.analysis.spectra import FrfResult

        values = self._read_result("frf", name)
        values.pop("hit_indices", None)
        lines = np.shape(values.get("freq_hz"))
        for field in _FRF_LINE_FIELDS:
            if field in values and np.shape(values[field]) != lines:
                raise SessionError(
                    f"{self.path}: damaged session: FRF '{name}': '{field}' has shape {np.shape(values[field])}, "
                    f"'freq_hz' {lines}"
                )
        per_hit = np.shape(values.get("h1_per_hit"))
        if len(lines) != 1 or len(per_hit) != 2 or per_hit[1] != lines[0]:
            raise SessionError(
                f"{self.path}: damaged session: FRF '{name}': 'freq_hz' {lines} and 'h1_per_hit' {per_hit} do not match"
            )
        try:
            return FrfResult.from_dict(values)
        except (GasfilmError, *_READ_ERRORS) as error:
            raise SessionError(f"{self.path}: damaged session: FRF '{name}': {one_line(error)}") from None

    @_reading("the FRF's hit list")
    def frf_hit_indices(self, name: str = "frf") -> np.ndarray | None:
        group = self._group("frf").get(name)
        return None if group is None or "hit_indices" not in group else group["hit_indices"][()]

    def write_fit(self, name: str, values: Mapping[str, Any]) -> None:
        """Store a fit (arrays as datasets, scalars and strings as attributes, nested values as JSON)."""
        self._write_result("fits", name, values)

    def read_fit(self, name: str) -> dict[str, Any]:
        return self._read_result("fits", name)

    def write_diagnosis(self, name: str, values: Mapping[str, Any]) -> None:
        """Store a diagnosis (same rules as :meth:`write_fit`)."""
        self._write_result("diagnoses", name, values)

    def read_diagnosis(self, name: str) -> dict[str, Any]:
        return self._read_result("diagnoses", name)


    def add_diagnosis(self, values: Mapping[str, Any]) -> str:
        """Store a diagnosis as a new run (``run-001``, ``run-002``, …) and point ``latest`` at it; no earlier
        diagnosis is erased (one stored as ``latest`` itself, before runs were kept, becomes a run first). Returns the
        run's name."""
        self._require_writable()
        with self._writing("a diagnosis"):
            self._structural()
            parent = self._group("diagnoses")
            link = parent.get(LATEST_DIAGNOSIS, getlink=True)
            if isinstance(link, h5py.SoftLink):
                del parent[LATEST_DIAGNOSIS]
            elif link is not None:  # a diagnosis stored under "latest" by an older gasfilm: kept as a run
                parent.move(LATEST_DIAGNOSIS, self._next_run_name(parent))
            name = self._next_run_name(parent)
            group = parent.create_group(name)
            write_mapping(group, values)
            group.attrs["written_utc"] = utc_now()
            parent[LATEST_DIAGNOSIS] = h5py.SoftLink(f"{parent.name}/{name}")
            del parent, group
            self._settled()
        self._commit("a diagnosis")
        return name

    @staticmethod
    def _next_run_name(parent: h5py.Group) -> str:
        numbers = [int(match.group(1)) for match in map(DIAGNOSIS_RUN.fullmatch, parent) if match]
        return f"run-{max(numbers, default=0) + 1:03d}"

    @_reading("the stored diagnoses")
    def newest_diagnosis_name(self) -> str | None:
        """The name of the newest stored diagnosis: the run ``latest`` points at, unless a diagnosis stored under
        another name by an older gasfilm (the GUI's "diagnosis") was written later; None when there is none."""
        parent = self._group("diagnoses")
        link = parent.get(LATEST_DIAGNOSIS, getlink=True)
        newest = None
        for name in parent:
            if name == LATEST_DIAGNOSIS and isinstance(link, h5py.SoftLink):
                continue  # the run it points at is listed under its own name
            match = DIAGNOSIS_RUN.fullmatch(name)
            key = (str(parent[name].attrs.get("written_utc", "")), int(match.group(1)) if match else 0)
            if newest is None or key > newest[0]:
                newest = (key, name)
        return None if newest is None else newest[1]

    # ----- a rigid body's identification (gasfilm rigid) ------------------------------------------------------------

    def write_rigid_body(self, values: Mapping[str, Any]) -> None:
        """Store a rigid-body identification (:class:`gasfilm.analysis.identification.rigid.RigidIdentification`'s
        dict) as ``/rigid_body`` (replacing an earlier one; the group is made at the first)."""
        self._require_writable()
        with self._writing("the rigid-body identification"):
            self._structural()
            if RIGID_BODY_GROUP in self._file:
                del self._file[RIGID_BODY_GROUP]
            group = self._file.create_group(RIGID_BODY_GROUP)
            write_mapping(group, values)
            group.attrs["written_utc"] = utc_now()
            del group
            self._settled()

    @_reading("the rigid-body identification")
    def read_rigid_body(self) -> dict[str, Any] | None:
        """The stored rigid-body identification, or None when there is none."""
        group = self._file.get(RIGID_BODY_GROUP)
        if not isinstance(group, h5py.Group):
            return None
        values = read_mapping(group)
        values.pop("written_utc", None)
        return values
