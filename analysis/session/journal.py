"""The hit journal: every change to a session's hits, durable as its own small file before the HDF5 file is touched.

A writer keeps ``NAME.journal/`` next to the session file ``NAME`` while it has the session open. The journal starts
with the session's setup and every hit already committed (written under a hidden name and renamed into place, so it
appears complete or not at all); then each new hit, each changed verdict and each settings change is one more entry.
An entry is a NumPy ``.npz`` (a zip: its CRC-32 checks catch damage) written to a hidden temporary name, fsynced,
renamed to ``NNNNNNNNNN.KIND.npz`` and made durable by an fsync of the folder; only then does the HDF5 file change.
Entries are never rewritten, so no later failure can reach them. A clean close checks that the HDF5 file holds
exactly the journaled hits and removes the journal; a journal left behind (a failed write, a full disk, a killed
writer) rebuilds the session: :func:`write_session_file` makes a fresh HDF5 file from it, taking what else the old
file holds (FRF, fits, diagnoses) where it can still be read. Layout in ``docs/session-format.md``.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import logging
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

try:
    import fcntl
except ImportError:  # Windows: no lock on the journal (HDF5's own locking guards the session file)
    fcntl = None

from gasfilm.analysis.session.layout import SessionError, one_line, utc_now

logger = logging.getLogger(__name__)

JOURNAL_SUFFIX = ".journal"
#: Groups whose attributes the setup entry holds (the journal is authoritative for them and for the hits).
SETUP_GROUPS = ("/", "rig", "daq", "settings")
_ENTRY = re.compile(r"^(\d{10})\.(setup|hits|row|settings)\.npz$")


def journal_path(path: Path) -> Path:
    """The journal folder of the session file ``path``."""
    return path.with_name(path.name + JOURNAL_SUFFIX)


def starting_path(path: Path) -> Path:
    """The hidden folder this process builds a journal in before it appears under its name."""
    return path.with_name(f".{path.name}{JOURNAL_SUFFIX}.{os.getpid()}.starting")


def hit_digest(record: np.ndarray, row: np.ndarray) -> bytes:
    """A hit's fingerprint: its samples and its table row, byte for byte."""
    digest = hashlib.blake2b(np.ascontiguousarray(record, dtype="<f8").tobytes(), digest_size=16)
    digest.update(np.asarray(row).tobytes())
    return digest.digest()


def _fsync_folder(folder: Path) -> None:
    if os.name == "nt":
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _lock_folder(folder: Path) -> int:
    """An exclusive ``flock`` on the journal folder (-1 where there is none); raises ``BlockingIOError`` when another
    process holds it."""
    if fcntl is None:
        return -1
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise BlockingIOError(f"{folder} is locked") from None
    return fd


def _plain(array: np.ndarray) -> np.ndarray:
    """The array without h5py's dtype metadata (string encodings), which ``.npz`` cannot hold."""
    dtype = array.dtype
    if dtype.names is None:
        return array if dtype.metadata is None else array.astype(dtype.str)
    plain = np.dtype([(name, dtype[name].base.str, dtype[name].shape) for name in dtype.names])
    return array.astype(plain)


def _encode_attribute(value: Any) -> list[Any]:
    if isinstance(value, (bytes, np.bytes_)):
        return ["bytes", bytes(value).decode("latin-1")]
    if isinstance(value, (bool, np.bool_)):
        return ["bool", bool(value)]
    if isinstance(value, (int, np.integer)):
        return ["int", int(value)]
    if isinstance(value, (float, np.floating)):
        return ["float", float(value)]
    if isinstance(value, str):
        return ["str", value]
    array = np.asarray(value)
    if array.dtype.kind not in "biuf":
        raise ValueError(f"attribute of type {array.dtype} cannot be journaled")
    return ["array", array.tolist(), array.dtype.str]


def _decode_attribute(encoded: list[Any]) -> Any:
    kind, value = encoded[0], encoded[1]
    if kind == "bytes":
        return np.bytes_(value.encode("latin-1"))
    if kind == "array":
        return np.asarray(value, dtype=encoded[2])
    return {"bool": bool, "int": int, "float": float, "str": str}[kind](value)


def setup_of(file: h5py.File) -> tuple[dict[str, Any], np.ndarray]:
    """What the journal keeps of a session besides its hits: the attributes of the root, ``rig``, ``daq`` and
    ``settings``, the rig spec text, the record chunking; and an empty hit table of the file's row type."""
    setup = {
        "attrs": {name: {key: _encode_attribute(value) for key, value in file[name].attrs.items()}
                  for name in SETUP_GROUPS},
        "rig_spec_toml": file["rig/spec_toml"].asstr()[()],
        "data_chunks": list(file["hits/data"].chunks),
    }
    return setup, np.zeros(0, dtype=file["hits/table"].dtype)


@dataclass
class JournalContent:
    """A journal read back: the setup and every hit it holds, with the latest verdicts and settings applied."""

    setup: dict[str, Any]
    records: np.ndarray  # (hits, channels, samples), float64
    rows: np.ndarray  # hit table rows
    skipped: list[str]  # entries that could not be read (damaged) or did not follow on

    @property
    def hit_count(self) -> int:
        return len(self.rows)

    def digests(self) -> list[bytes]:
        return [hit_digest(record, row) for record, row in zip(self.records, self.rows)]


class Journal:
    """The journal of one session, held (locked) by the process writing it."""

    def __init__(self, folder: Path, next_entry: int, lock_fd: int) -> None:
        self.folder = folder
        self._next_entry = next_entry
        self._lock_fd = lock_fd

    @classmethod
    def start(cls, path: Path, setup: dict[str, Any], table_template: np.ndarray, records: np.ndarray,
              rows: np.ndarray) -> "Journal":
        """A new journal holding the setup and the hits committed so far; it appears under its name complete or not at
        all. Raises ``FileExistsError`` when the session has a journal already."""
        building = starting_path(path)
        shutil.rmtree(building, ignore_errors=True)
        os.mkdir(building)
        journal = cls(building, 0, -1)
        try:
            journal._lock_fd = _lock_folder(building)
            journal._write("setup", setup=np.array(json.dumps(setup, allow_nan=True)), table_template=table_template)
            if len(rows):
                journal._write("hits", first_index=np.int64(0), records=records, rows=rows)
            try:
                os.rename(building, journal_path(path))
            except OSError as error:  # the session has a journal already (EEXIST or ENOTEMPTY)
                if error.errno in (errno.EEXIST, errno.ENOTEMPTY):
                    raise FileExistsError(f"{journal_path(path)} exists") from None
                raise
            journal.folder = journal_path(path)
            _fsync_folder(path.parent)
        except BaseException:
            journal.release()
            shutil.rmtree(building, ignore_errors=True)
            raise
        return journal

    @classmethod
    def resume(cls, path: Path) -> "Journal | None":
        """Take over the journal a writer left behind (None when there is none); raises :class:`SessionError` when a
        live process holds it."""
        folder = journal_path(path)
        try:
            lock_fd = _lock_folder(folder)
        except FileNotFoundError:
            return None
        except BlockingIOError:
            raise SessionError(f"{path}: another process is writing this session; wait until it has finished") from None
        numbers = [int(match.group(1)) for match in map(_ENTRY.match, os.listdir(folder)) if match]
        return cls(folder, max(numbers, default=-1) + 1, lock_fd)

    def add_hits(self, first_index: int, records: np.ndarray, rows: np.ndarray, sync: bool = True) -> None:
        """Hits from ``first_index`` on; without ``sync`` (bulk imports) the entry is not fsynced: it survives a
        killed process, not a power cut."""
        self._write("hits", first_index=np.int64(first_index), records=records, rows=rows, sync=sync)

    def set_row(self, index: int, row: np.ndarray) -> None:
        """A hit's table row replaced (its verdict changed)."""
        self._write("row", index=np.int64(index), row=np.asarray(row).reshape(1))

    def set_settings(self, attributes: dict[str, str]) -> None:
        """Attributes of ``/settings`` added or replaced."""
        self._write("settings", settings=np.array(json.dumps(attributes, allow_nan=True)))

    def read(self) -> JournalContent:
        return read_journal(self.folder)

    def remove(self) -> None:
        """Delete the journal (its hits are all in a verified session file) and let go of it."""
        for name in os.listdir(self.folder):
            (self.folder / name).unlink()
        try:
            os.rmdir(self.folder)  # while still locked: a reader sees a locked journal or none
        finally:
            self.release()
        _fsync_folder(self.folder.parent)

    def release(self) -> None:
        if self._lock_fd >= 0:
            os.close(self._lock_fd)
            self._lock_fd = -1

    def _write(self, kind: str, sync: bool = True, **arrays: Any) -> None:
        """One entry, durable before this returns: written under a hidden name, fsynced, renamed, folder fsynced
        (without ``sync``: written and renamed only)."""
        buffer = io.BytesIO()
        np.savez(buffer, **{key: _plain(np.asarray(value)) for key, value in arrays.items()})
        name = f"{self._next_entry:010d}.{kind}.npz"
        temporary = self.folder / f".{name}.tmp"
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            try:
                view = memoryview(buffer.getbuffer())
                while view:
                    view = view[os.write(fd, view):]
                if sync:
                    os.fsync(fd)
            finally:
                os.close(fd)
            os.rename(temporary, self.folder / name)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise
        self._next_entry += 1
        if sync:
            _fsync_folder(self.folder)


def journal_held_elsewhere(path: Path) -> bool:
    """Whether a live process holds the journal of the session ``path`` (it is writing the session)."""
    try:
        fd = _lock_folder(journal_path(path))
    except FileNotFoundError:
        return False
    except BlockingIOError:
        return True
    if fd >= 0:
        os.close(fd)
    return False


def read_journal(folder: Path) -> JournalContent:
    """Every entry in order; a damaged entry, or hits that do not follow on from the ones before, are skipped (and
    named in ``skipped``). Raises :class:`SessionError` when the setup cannot be read."""
    setup: dict[str, Any] | None = None
    template = None
    records: list[np.ndarray] = []
    rows: list[np.ndarray] = []
    skipped: list[str] = []
    names = sorted(name for name in os.listdir(folder) if _ENTRY.match(name))
    for name in names:
        kind = _ENTRY.match(name).group(2)
        try:
            with np.load(folder / name, allow_pickle=False) as entry:
                values = {key: entry[key] for key in entry.files}
            if kind == "setup":
                setup, template = json.loads(str(values["setup"])), values["table_template"]
            elif setup is None:
                raise ValueError("before the setup")
            elif kind == "hits":
                first = int(values["first_index"])
                if first != sum(len(block) for block in rows):
                    raise ValueError(f"hits from {first} do not follow on")
                if values["rows"].dtype != template.dtype or len(values["rows"]) != len(values["records"]):
                    raise ValueError("hit rows of another type")
                records.append(values["records"])
                rows.append(values["rows"])
            elif kind == "row":
                index = int(values["index"])
                flat = np.concatenate(rows) if rows else template
                if not 0 <= index < len(flat) or values["row"].dtype != template.dtype:
                    raise ValueError(f"row {index} out of range")
                rows = [flat]
                records = [np.concatenate(records)]
                rows[0][index] = values["row"][0]
            else:
                setup["attrs"]["settings"].update(
                    {key: ["str", value] for key, value in json.loads(str(values["settings"])).items()})
        except Exception as error:  # a damaged entry: whatever np.load or the checks raise
            logger.error("%s: journal entry %s cannot be used: %s", folder, name, one_line(error))
            skipped.append(name)
    if setup is None:
        raise SessionError(f"{folder}: the session's journal has no readable setup")
    all_records = np.concatenate(records) if records else np.zeros((0, int(setup["data_chunks"][1]), 0))
    all_rows = np.concatenate(rows) if rows else template
    return JournalContent(setup, all_records, all_rows, skipped)


def write_session_file(file: h5py.File, content: JournalContent, salvage: h5py.File | None,
                       status: tuple[str, str] | None) -> list[str]:
    """Fill an empty HDF5 file with the session the journal describes: setup and hits from the journal, every other
    group and the root's attributes from ``salvage`` (the old session file, or None) where they can be read; ``status``
    (status, reason) then replaces the status. Returns what could not be salvaged."""
    lost = []
    setup = content.setup
    for name in SETUP_GROUPS:
        group = file if name == "/" else file.create_group(name)
        for key, encoded in setup["attrs"][name].items():
            group.attrs[key] = _decode_attribute(encoded)
    if salvage is not None:  # the root's attributes as last written (status, closed_utc, …), the format mark excepted
        for key in salvage.attrs:
            if key in ("format", "schema_version"):
                continue
            try:
                file.attrs[key] = salvage.attrs[key]
            except Exception as error:  # a damaged attribute: whatever h5py raises reading it
                lost.append(f"attribute '{key}' ({one_line(error, 80)})")
    file["rig"].create_dataset("spec_toml", data=setup["rig_spec_toml"], dtype=h5py.string_dtype())
    hits = file.create_group("hits")
    chunks = tuple(setup["data_chunks"])
    channels = chunks[1]
    samples = content.records.shape[2] if content.hit_count else 0
    data = hits.create_dataset("data", shape=(content.hit_count, channels, samples), maxshape=(None, channels, None),
                               chunks=chunks, dtype="<f8", fillvalue=np.nan)
    if content.hit_count:
        data[...] = content.records
    table = hits.create_dataset("table", shape=(content.hit_count,), maxshape=(None,), chunks=(64,),
                                dtype=content.rows.dtype)
    if content.hit_count:
        table[...] = content.rows
    if salvage is not None:
        for name in salvage:
            if name in SETUP_GROUPS or name == "hits":
                continue
            try:
                salvage.copy(salvage[name], file, name=name)
            except Exception as error:  # a damaged group: whatever h5py raises copying it
                lost.append(f"'{name}' ({one_line(error, 80)})")
                if name in file:
                    del file[name]
    for name in ("frf", "fits", "diagnoses"):
        if name not in file:
            file.create_group(name)
    if status is not None:
        file.attrs["status"], file.attrs["status_reason"] = status
        file.attrs["recovered_utc"] = utc_now()
    return lost
