"""The session API: :class:`Session` (create, open, append hits, store results) and :class:`StoredHit`."""

from __future__ import annotations

import contextlib
import functools
import io
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
from typing import Any, Callable, Iterator, Mapping, TypeVar

import h5py
import numpy as np

from gasfilm.analysis.session.files import (
    WriterLock,
    building_path,
    check_unclosed_file,
    describe_open_failure,
    move_into_place,
    open_for_salvage,
    open_h5,
    remove_leftovers,
    replace_durably,
)
from gasfilm.analysis.session.journal import (
    Journal,
    JournalContent,
    hit_digest,
    journal_held_elsewhere,
    journal_path,
    read_journal,
    setup_of,
    write_session_file,
)
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
#: Free space a rebuild needs besides 110 % of the larger of the old file and the hits (HDF5's metadata).
REBUILD_MARGIN_BYTES = 64 << 10
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


def _detach(file: h5py.File, path: Path) -> None:
    """Point an HDF5 file's descriptor at /dev/null after a write failed, so HDF5 cannot put part of its cached metadata
    over what is on disk, and closing it does not fail (a failed close leaves HDF5 in a state that crashes the process
    when it exits). Not on Windows, where the handle is not a file descriptor."""
    if os.name == "nt":
        return
    try:
        _detach_descriptor(file.id.get_vfd_handle(), path)
    except (OSError, RuntimeError) as error:
        logger.warning("%s: cannot detach the file after the write failure: %s", path, one_line(error))


def _close_or_detach(file: h5py.File, path: Path) -> BaseException | None:
    """Close an HDF5 file; when closing fails (its last writes fail), point its descriptor at /dev/null and close it
    again, so that HDF5 lets go of it instead of retrying, and crashing, when the process exits. Returns the
    failure, or None."""
    try:
        handle = file.id.get_vfd_handle()
    except RuntimeError:  # a session rebuilt in memory: no descriptor
        handle = None
    try:
        with _h5py_errors_raised():
            file.close()
    except (OSError, RuntimeError) as error:
        if handle is not None:
            _detach_descriptor(handle, path)
        with contextlib.suppress(OSError, RuntimeError), _h5py_errors_raised():
            file.close()
        return error
    return None


def _detach_descriptor(handle: int, path: Path) -> None:
    """Point the file descriptor ``handle`` at /dev/null (see :func:`_detach`)."""
    if os.name == "nt":
        return
    try:
        null = os.open(os.devnull, os.O_RDWR)
        os.dup2(null, handle)
        os.close(null)
    except OSError as error:
        logger.warning("%s: cannot detach the file after the write failure: %s", path, one_line(error))


def _write_error_text(error: BaseException) -> str:
    """The operating system's reason in an HDF5 write error (e.g. "No space left on device"), else its message."""
    match = re.search(r"error message = '([^']*)'", str(error))
    if match:
        return match.group(1)
    return getattr(error, "strerror", None) or one_line(error)


#: Passed as the status of a rebuild from a journal left behind: :func:`_rebuilt_status` decides it.
_STATUS_OF_A_LEFT_JOURNAL = ("", "")


def _rebuilt_status(salvage: h5py.File | None, closed: bool, content: JournalContent) -> tuple[str, str] | None:
    """The status of a session rebuilt from a journal its writer left: the old file's when that says complete or
    aborted — the journal outlived a clean close, or its writer only viewed the session or stored results (a hit or
    a verdict written would have set "recording" first) — else "interrupted"."""
    if salvage is not None and salvage.attrs.get("status") in ("complete", "aborted"):
        return None
    return ("interrupted", f"the recording process ended without closing the session; {content.hit_count} hits "
                           f"rebuilt from its journal")


def _rebuild_on_disk(path: Path, content: JournalContent, status: tuple[str, str] | None) -> WriterLock | None:
    """Write the session the journal describes into a fresh file (with what the old file still holds besides the
    hits) and put it in place of ``path``; return the writer lock on it. Raises :class:`SessionWriteError` when the
    fresh file cannot be written (the old file and the journal are left as they are)."""
    building = building_path(path, "recovering")
    with contextlib.suppress(OSError):
        old_bytes = os.path.getsize(path) if path.exists() else 0
        needed = int(1.1 * max(old_bytes, content.records.nbytes + content.rows.nbytes)) + REBUILD_MARGIN_BYTES
        free_bytes = shutil.disk_usage(path.parent).free
        if free_bytes < needed:  # refused before HDF5 writes: a write failing inside HDF5 can crash the process later
            raise SessionWriteError(
                f"{path}: cannot rewrite the session: disk full ({free_bytes / 1e6:.3g} MB free, "
                f"{needed / 1e6:.3g} MB needed); its {content.hit_count} hits are safe in {journal_path(path).name}, "
                f"which gasfilm reads and rebuilds from when the session is opened"
            )
    salvage, closed = open_for_salvage(path)
    if status == _STATUS_OF_A_LEFT_JOURNAL:
        status = _rebuilt_status(salvage, closed, content)
    try:
        target = open_h5(building, "w")
        try:
            with _h5py_errors_raised():
                lost = write_session_file(target, content, salvage, status)
        finally:
            failure = _close_or_detach(target, building)
        if failure is not None:
            raise failure
        if salvage is not None:
            salvage.close()
            salvage = None
        _check_rebuilt(building, content)
        lock = replace_durably(building, path, lock=True)
    except (*_WRITE_ERRORS, SessionError) as error:
        building.unlink(missing_ok=True)
        logger.error("%s: rebuilding the session from its journal failed: %s", path, one_line(error))
        raise SessionWriteError(
            f"{path}: cannot rewrite the session ({_write_error_text(error)}); its {content.hit_count} hits are safe "
            f"in {journal_path(path).name}, which gasfilm reads and rebuilds from when the session is opened"
        ) from None
    finally:
        if salvage is not None:
            salvage.close()
    for what in lost:
        logger.warning("%s: not carried over from the damaged file: %s", path, what)
    return lock


def _check_rebuilt(building: Path, content: JournalContent) -> None:
    """Read a rebuilt file back before it replaces anything: the setup and every hit as the journal has them (HDF5
    does not report every failed write)."""
    with _h5py_errors_raised(), open_h5(building, "r") as file:
        setup, _ = setup_of(file)
        for name in ("rig", "daq", "settings"):
            if setup["attrs"][name] != content.setup["attrs"][name]:
                raise ValueError(f"the rebuilt file's '{name}' differs from the journal's")
        if setup["rig_spec_toml"] != content.setup["rig_spec_toml"]:
            raise ValueError("the rebuilt file's rig spec differs from the journal's")
        table, data = file["hits/table"], file["hits/data"]
        if committed_hits(table, data) != content.hit_count or content.digests() != [
                hit_digest(record, row) for record, row in zip(data[:content.hit_count], table[:content.hit_count])]:
            raise ValueError("the rebuilt file's hits differ from the journal's")


def _remove_empty_journal(path: Path, overwrite: bool) -> None:
    """Before creating ``path``: remove a journal left by a killed creation (no hits), or by the session being
    replaced (``overwrite``); refuse to create over a journal that holds hits of a session whose file is gone."""
    journal = Journal.resume(path)
    if journal is None:
        return
    try:
        try:
            hits = read_journal(journal.folder).hit_count
        except SessionError:
            hits = 0
        if hits and not overwrite:
            raise SessionError(
                f"{path}: {journal.folder.name} holds {hits} hits of a session whose file is missing; open "
                f"{path.name} to rebuild it from them, or move the journal away"
            )
        journal.remove()
        logger.warning("%s: removed the journal %s (%d hits) left before this creation", path, journal.folder, hits)
    finally:
        journal.release()


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



#: Sessions this process has said it read while another process held them for writing (said once each).
_SAID_HELD_ELSEWHERE: set[Path] = set()


class Session:
    """An open session file. Create with :meth:`create`, open with :meth:`open`; use as a context manager."""

    def __init__(
        self, path: Path, file: h5py.File, lock: WriterLock | None = None, recovered: bool = False
    ) -> None:
        self.path = path
        self._file = file
        self._lock = lock
        self.writable = lock is not None
        self.recovered = recovered
        self.sync_each_hit = True
        #: Appending a hit that would make the file larger than this raises :class:`SessionWriteError`.
        self.size_limit_bytes = DEFAULT_SIZE_LIMIT_BYTES
        self._write_failure: str | None = None  # why writing failed: the file is then closed without more writes
        self._hit_count = 0
        #: A writer's journal (``NAME.journal``) and the fingerprint of each hit it holds, in order.
        self._journal: Journal | None = None
        self._digests: list[bytes] = []
        self._close_failed = False  # closing the HDF5 file failed: its h5py object is left alone
        try:
            self._check_layout()
        except SessionError:
            self._file.close()
            if lock is not None:
                lock.release()
            raise

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
        """
        path = Path(path)
        if path.exists() and not overwrite:
            raise SessionError(f"{path}: the session file exists already (choose another name, or append to it)")
        if path.is_dir():
            raise SessionError(f"{path}: is a folder, not a session file")
        if not path.parent.is_dir():
            raise SessionError(f"{path}: {missing_folder(path.parent)}")
        remove_leftovers(path)
        remove_leftovers(journal_path(path))
        _remove_empty_journal(path, overwrite)
        free_bytes = shutil.disk_usage(path.parent).free
        if free_bytes < FREE_SPACE_MARGIN_BYTES:  # HDF5 failing mid-creation can crash the process when it exits
            raise SessionWriteError(f"{path}: disk full ({free_bytes / 1e6:.3g} MB free); the session is not created")
        replaced = WriterLock(path) if overwrite and path.exists() else None  # never replace a session being recorded
        building = building_path(path, "creating")
        try:
            file = open_h5(building, "w")
        except OSError as error:
            if replaced is not None:
                replaced.release()
            raise SessionError(f"{path}: cannot create the session file ({_write_error_text(error)})") from None
        lock = None
        journal = None
        try:
            lock = WriterLock(building)
            with _h5py_errors_raised(on_error=lambda: _detach(file, building)):
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
                hits.create_dataset(
                    "data",
                    shape=(0, channel_count, 0),
                    maxshape=(None, channel_count, None),
                    chunks=(1, channel_count, chunk_samples),
                    dtype="<f8",
                    fillvalue=np.nan,
                )
                hits.create_dataset(
                    "table",
                    shape=(0,),
                    maxshape=(None,),
                    chunks=(64,),
                    dtype=hit_table_dtype(channel_count),
                )
                for name in ("frf", "fits", "diagnoses"):
                    file.create_group(name)
                file.flush()
                file.swmr_mode = True
                del rig, daq, settings_group, hits
                setup, table_template = setup_of(file)
            try:
                journal = Journal.start(path, setup, table_template, np.zeros((0, channel_count, 0)),
                                        table_template)
            except FileExistsError:
                raise SessionError(
                    f"{path}: the session file exists already (another process created it at the same moment)"
                ) from None
            move_into_place(building, path, overwrite)
        except BaseException as error:
            if journal is not None:
                with contextlib.suppress(OSError):
                    journal.remove()
            if isinstance(error, (OSError, RuntimeError)):
                logger.error("%s: creating the session failed: %s", path, error)
                error = SessionError(f"{path}: cannot create the session file ({_write_error_text(error)})")
            with contextlib.suppress(OSError, RuntimeError):
                file.close()
            if lock is not None:
                lock.release()
            building.unlink(missing_ok=True)
            if isinstance(error, SessionError):
                raise error from None
            raise
        finally:
            if replaced is not None:
                replaced.release()
        session = cls(path, file, lock)
        session._journal = journal
        session.sync_each_hit = sync_each_hit
        return session

    @classmethod
    def open(cls, path: str | Path, mode: str = "r") -> "Session":
        """Open a session for reading (``"r"``) or for appending and adding results (``"a"``).

        A session whose writer failed or was killed has a journal left next to it: reading rebuilds the session from
        it in memory, appending rebuilds the file on disk first (``recovered`` is then True)."""
        path = Path(path)
        if mode not in ("r", "a"):
            raise SessionError(f"{path}: mode '{mode}' is not valid; use 'r' or 'a'")
        if path.is_dir():
            raise SessionError(f"{path}: is a folder, not a session file")
        leftover_journal = journal_path(path).is_dir() and not journal_held_elsewhere(path)
        if not path.exists() and not leftover_journal:
            raise SessionError(f"{path}: no such session file")
        if mode == "a":
            return cls._open_for_writing(path)
        if leftover_journal:
            return cls._rebuilt_in_memory(path)
        return cls._open_read_only(path, writer_lock_held=False)

    @classmethod
    def _open_read_only(cls, path: Path, writer_lock_held: bool) -> "Session":
        """The session file as it is on disk (``writer_lock_held``: this process holds its writer lock)."""
        try:
            file = open_h5(path, "r")
        except OSError as error:
            if "already open for write" not in str(error):
                raise describe_open_failure(path, error) from None
            # The flags of a writer that is still recording or that ended without closing the file (killed, crashed,
            # power lost): the latter is checked first (reading a truncated one in SWMR mode can run for minutes).
            live = not writer_lock_held and WriterLock.held_elsewhere(path)
            if not live:
                check_unclosed_file(path)
            try:
                file = open_h5(path, "r", swmr=True)
            except OSError as swmr_error:
                raise describe_open_failure(path, swmr_error) from None
            if live and path.resolve() not in _SAID_HELD_ELSEWHERE:  # (export, report … of a session being
                _SAID_HELD_ELSEWHERE.add(path.resolve())                 # recorded: what it holds now, said once)
                logger.warning("%s: open for writing in another gasfilm process (a recording or the GUI): read as "
                               "it stands now", path)
            return cls(path, file, recovered=not live)
        return cls(path, file)

    @classmethod
    def _rebuilt_in_memory(cls, path: Path) -> "Session":
        """A read-only session rebuilt from the journal a failed or killed writer left (nothing is written to disk)."""
        content = read_journal(journal_path(path))
        salvage, closed = open_for_salvage(path)
        try:
            file = h5py.File(io.BytesIO(), "w")
            try:
                with _h5py_errors_raised():
                    write_session_file(file, content, salvage, _rebuilt_status(salvage, closed, content))
            except _WRITE_ERRORS as error:
                file.close()
                raise SessionError(
                    f"{path}: the session cannot be rebuilt from its journal ({one_line(error)})"
                ) from None
        finally:
            if salvage is not None:
                salvage.close()
        logger.warning("%s: read from its journal %s (%d hits): its writer did not close it", path,
                       journal_path(path), content.hit_count)
        return cls(path, file, recovered=True)

    @classmethod
    def _open_for_writing(cls, path: Path) -> "Session":
        """Take the writer lock; journal the committed hits (or take over a journal left behind); rewrite the session
        file from the journal, so that the writes to come go into a file this process made; open it for appending."""
        lock = WriterLock(path) if path.exists() else None
        journal = None
        try:
            remove_leftovers(path)
            remove_leftovers(journal_path(path))
            journal = Journal.resume(path)
            started = journal is None
            if journal is not None:
                content = journal.read()
                status = _STATUS_OF_A_LEFT_JOURNAL
            else:
                if lock is None:
                    raise SessionError(f"{path}: no such session file")
                with cls._open_read_only(path, writer_lock_held=True) as source:
                    content = source._committed_content()
                    status = None
                    if source.recovered:
                        status = ("interrupted", f"the recording process ended without closing the session; "
                                                 f"{content.hit_count} hits recovered")
                try:
                    journal = Journal.start(path, content.setup, content.rows[:0], content.records, content.rows)
                except OSError as error:
                    raise SessionWriteError(
                        f"{path}: cannot start the session's journal for writing ({_write_error_text(error)}); "
                        f"nothing was changed"
                    ) from None
            try:
                new_lock = _rebuild_on_disk(path, content, status)
            except SessionWriteError:
                if started:  # the session file is untouched: the journal just started holds nothing more
                    journal.remove()
                    journal = None
                raise
            if lock is not None:
                lock.release()
            lock = new_lock
            try:
                file = open_h5(path, "a")
            except OSError as error:
                raise SessionWriteError(
                    f"{path}: cannot open the session for writing ({_write_error_text(error)}); its "
                    f"{content.hit_count} hits are safe in {journal_path(path).name}"
                ) from None
            session = cls(path, file, lock, recovered=status is not None)
            with session._writing("the session's open state"):
                session._settled()  # (a viewer killed now leaves a readable file, its results kept)
            if status is not None:
                logger.warning("%s: rebuilt before writing (status %s: %s)", path, session.status,
                               session.status_reason)
        except BaseException:
            if journal is not None:
                journal.release()
            if lock is not None:
                lock.release()
            raise
        session._journal = journal
        session._digests = content.digests()
        return session

    @_reading("the hits")
    def _committed_content(self) -> JournalContent:
        """The setup and every committed hit, as a journal starts with them."""
        rows = self._rows()
        records = self._read_data(slice(0, len(rows)))
        setup, _ = setup_of(self._file)
        return JournalContent(setup, np.asarray(records, dtype=np.float64), rows, [])

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
        return not self._close_failed and bool(self._file.id.valid)

    def close(self, status: str | None = None, reason: str = "") -> None:
        """Close the file, recording how the session ended: ``"complete"`` or ``"aborted"`` (with a reason).

        Without a status, a session that was recording becomes ``"complete"`` and any other keeps its status (so
        adding a fit to an aborted session does not make it complete)."""
        if self._write_failure is not None:
            if self._journal is not None or self._lock is not None:
                self._close_after_write_failure()
            return
        if not self.is_open:
            return
        final_status = None
        if self.writable:
            if status is None:
                status = "complete" if self._file.attrs["status"] == "recording" else None
            elif status not in ("complete", "aborted"):
                raise SessionError(f"{self.path}: close status '{status}' is not valid; use 'complete' or 'aborted'")
            if status is not None:
                try:
                    with self._writing(f"its status '{status}'"):
                        self._set_status(status, reason)
                        self._file.attrs["closed_utc"] = utc_now()
                        self._file.flush()
                except SessionWriteError:
                    self._close_after_write_failure()
                    raise
            final_status = (str(self._file.attrs["status"]), str(self._file.attrs["status_reason"]))
        failure = _close_or_detach(self._file, self.path)
        if failure is not None:
            self._write_failure = _write_error_text(failure)
            logger.error("%s: closing the file failed: %s", self.path, one_line(failure))
        try:
            if self._journal is not None:
                self._settle_journal(final_status if self._write_failure is None else None)
        finally:
            if self._lock is not None:
                self._lock.release()

    @contextlib.contextmanager
    def _writing(self, what: str) -> Iterator[None]:
        """Run HDF5 writes; when one fails (full disk, I/O error), detach the file at once, note the failure (nothing
        more is written) and raise one :class:`SessionWriteError` line naming ``what`` was being written."""
        try:
            with _h5py_errors_raised(on_error=self._detach_file):
                yield
        except _WRITE_ERRORS as error:
            self._detach_file()
            self._write_failure = _write_error_text(error)
            kept = len(self._digests) if self._journal is not None else self._hit_count
            logger.error("%s: writing %s failed: %s; %d hits kept", self.path, what, one_line(error), kept)
            also = " and this one" if kept > self._hit_count else ""
            raise SessionWriteError(
                f"{self.path}: writing {what} failed ({self._write_failure}); recording stopped, the "
                f"{self._hit_count} hits before it{also} are kept"
            ) from None

    def _detach_file(self) -> None:
        """Detach the file after a write failure (see :func:`_detach`): it keeps its "open for writing" mark and opens
        as an interrupted session with every committed hit."""
        if self._write_failure is None and self.is_open:
            _detach(self._file, self.path)

    def _close_after_write_failure(self) -> None:
        """Let go of a file that could not be written (detached, so nothing more reaches the disk), then rebuild it
        from the journal where the disk allows (else the journal stays, and the next open rebuilds from it)."""
        if not self._close_failed:
            try:
                with _h5py_errors_raised():
                    self._file.close()
            except (OSError, RuntimeError) as error:
                logger.info("%s: closing after the write failure: %s", self.path, one_line(error))
        try:
            if self._journal is not None:
                self._settle_journal(None)
        finally:
            if self._lock is not None:
                self._lock.release()
                self._lock = None

    def _settle_journal(self, final_status: tuple[str, str] | None) -> None:
        """After the file is closed: remove the journal once the file on disk holds exactly the journaled hits,
        rebuilding the file from the journal first when it does not (or when writing failed: ``final_status`` None).
        When the rebuild fails (a full disk), the journal stays for the next open, which rebuilds from it."""
        journal, self._journal = self._journal, None
        try:
            if final_status is None or not self._file_holds_journaled_hits():
                content = journal.read()
                if final_status is None:
                    status = ("interrupted", f"writing failed ({self._write_failure}); {content.hit_count} hits "
                                             f"rebuilt from its journal")
                else:
                    status = (final_status[0], f"{final_status[1]}; {content.hit_count} hits rebuilt from its journal"
                              .lstrip("; "))
                    logger.error("%s: the closed file does not hold the %d journaled hits; rebuilding it",
                                 self.path, len(self._digests))
                lock = _rebuild_on_disk(self.path, content, status)
                if lock is not None:
                    lock.release()
                logger.info("%s: rebuilt from its journal: %d hits", self.path, content.hit_count)
            journal.remove()
        except (SessionError, OSError) as error:
            logger.error("%s: the journal %s is kept (%s)", self.path, journal.folder, one_line(error))
            journal.release()

    def _file_holds_journaled_hits(self) -> bool:
        """Whether the closed session file reads back with exactly the hits of the journal, sample for sample."""
        try:
            with _h5py_errors_raised(), open_h5(self.path, "r") as file:
                table, data = file["hits/table"], file["hits/data"]
                count = committed_hits(table, data)
                if count != len(self._digests):
                    return False
                for start in range(0, count, 64):
                    stop = min(start + 64, count)
                    rows, records = table[start:stop], data[start:stop]
                    if any(hit_digest(record, row) != self._digests[start + offset]
                           for offset, (record, row) in enumerate(zip(records, rows))):
                        return False
        except _READ_ERRORS as error:
            logger.error("%s: the closed file cannot be read back: %s", self.path, one_line(error))
            return False
        return True

    def _set_status(self, status: str, reason: str) -> None:
        self._structural()
        self._file.attrs["status"] = status
        self._file.attrs["status_reason"] = reason
        self._file.flush()

    # ----- file modes ------------------------------------------------------------------------------------------

    def _require_writable(self) -> None:
        if not self.writable:
            raise SessionError(f"{self.path}: the session is open read-only (open it with mode 'a' to change it)")
        if not self.is_open:
            raise SessionError(f"{self.path}: the session is closed")
        if self._write_failure is not None:
            raise SessionWriteError(f"{self.path}: writing failed earlier ({self._write_failure}); nothing more is written")

    def _structural(self) -> None:
        """Leave SWMR mode (by reopening the file) so groups and attributes can be created."""
        self._require_writable()
        if self._file.swmr_mode:
            failure = _close_or_detach(self._file, self.path)  # raised here, before the file is opened again
            if failure is not None:
                self._close_failed = True  # the h5py object must not be used again (HDF5 crashes on it)
                raise failure
            self._file = open_h5(self.path, "a")

    def _settled(self) -> None:
        """After a change of groups or attributes: flush and enter SWMR mode, so that the file on disk stays readable
        (and its results salvageable) if this process is killed before it closes the file; a file left open for
        writing outside SWMR mode cannot be read at all, and rebuilding the session from its journal then lost every
        stored FRF, fit and diagnosis. The status is left as it is."""
        self._file.flush()
        if not self._file.swmr_mode:
            self._file.swmr_mode = True

    def _appending(self) -> None:
        """Enter SWMR mode: from now on the file on disk is consistent after every flush."""
        self._require_writable()
        if self._file.attrs["status"] != "recording":  # (a session opened for writing is already in SWMR mode)
            self._set_status("recording", "")
        self._settled()

    def _sync(self) -> None:
        if self.sync_each_hit:
            os.fsync(self._file.id.get_vfd_handle())

    # ----- metadata ----------------------------------------------------------------------------------------------

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
        """Store (or replace) processing settings by key."""
        self._require_writable()
        encoded = {key: json_dumps(value) for key, value in settings.items()}
        with self._writing("the settings"):
            self._journal_write().set_settings(encoded)
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
        """Store one hit and its verdict, flushed to disk before returning; return its index in the session.

        Raises :class:`SessionWriteError` when the hit would pass the size limit or the free disk space, or when
        writing fails (full disk, I/O error): the hits stored before stay in the file, and nothing more is written."""
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
        self._check_room(2 * (data.nbytes + row.nbytes))  # the journal's copy and the file's
        with self._writing("a new hit"):
            self._journal_write().add_hits(index, data[np.newaxis], row.reshape(1), sync=self.sync_each_hit)
            self._digests.append(hit_digest(data, row))
            self._appending()
            records, table = self._data, self._table
            records.resize((index + 1, channels, samples))
            records[index] = data
            records.flush()
            table.resize((index + 1,))
            table[index] = row
            table.flush()
            self._file.flush()  # nothing left for HDF5 to write when the objects are freed, where errors pass unseen
            del records, table
            self._sync()
        self._hit_count = index + 1
        return index

    def _journal_write(self) -> Journal:
        if self._journal is None:
            raise SessionError(f"{self.path}: the session has no journal to write to")
        return self._journal

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
        """Replace a hit's verdict (e.g. the user overrides a rejection); flushed at once."""
        self._require_writable()
        if not 0 <= index < self.hit_count:
            raise SessionError(f"{self.path}: hit {index + 1} does not exist (the session holds {self.hit_count})")
        reasons = encode_reasons(tuple(verdict.reasons), self.path)
        with self._writing(f"the verdict of hit {index + 1}"):
            table = self._table
            row = table[index]
            row["accepted"] = bool(verdict.accepted)
            row["overridden"] = bool(getattr(verdict, "overridden", False))
            row["reasons"] = reasons
            self._journal_write().set_row(index, row)
            self._digests[index] = hit_digest(self._data[index], row)
            del table
            self._appending()  # (may reopen the file to mark it recording: the table is taken again after it)
            table = self._table
            table[index] = row
            table.flush()
            self._file.flush()
            del table
            self._sync()

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
