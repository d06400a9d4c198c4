"""Session files on disk: the writer lock, opening with HDF5 (directly, or through the rollback journal's file),
checking a file whose writer died, giving a new file its name."""

from __future__ import annotations

import ctypes
import errno
import glob
import logging
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import h5py

try:
    import fcntl
except ImportError:  # Windows: HDF5's own file locking guards the file instead of :class:`WriterLock`
    fcntl = None

from gasfilm.analysis.session.journal import RollbackFile
from gasfilm.analysis.session.layout import SessionError, one_line

logger = logging.getLogger(__name__)

#: A file left open by a killed writer is checked in a child process before it is read: HDF5 in SWMR mode retries
#: (and sleeps) for minutes on metadata beyond the end of a truncated file. The child asks HDF5 for a single read
#: attempt (H5Pset_metadata_read_attempts through ctypes, where h5py's HDF5 library can be found) and is stopped
#: after this long in any case.
PROBE_TIMEOUT_S = 8.0
PROBE_SCRIPT = """
import ctypes, os, sys, h5py
path = sys.argv[1]
size = os.path.getsize(path)
fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
fapl.set_file_locking(False, True)
libraries = [line.split()[-1] for line in open("/proc/self/maps") if "/libhdf5" in line] if os.path.exists(
    "/proc/self/maps") else []
if libraries:
    ctypes.CDLL(libraries[0]).H5Pset_metadata_read_attempts(ctypes.c_int64(fapl.id), ctypes.c_uint(1))
fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
with h5py.File(fid) as f:
    if f.attrs.get("format") != "gasfilm-session":
        sys.exit(0)  # not a session: opening it says so
    f.visit(lambda name: None)
    f["hits/table"][()]
    ends = []
    for name in ("hits/table", "hits/data"):
        f[name].id.chunk_iter(lambda chunk: ends.append(chunk.byte_offset + chunk.size))
    sys.exit(3 if ends and max(ends) > size else 0)
"""
#: Hidden files a creation builds before it moves them into place: ``.NAME.PID.creating``.
BUILDING_SUFFIXES = ("creating",)


def describe_open_failure(path: Path, error: OSError) -> SessionError:
    text = str(error)
    if "truncated file" in text:
        return SessionError(f"{path}: truncated HDF5 file (the file ends before its data does)")
    if "signature not found" in text:
        return SessionError(f"{path}: wrong file type: not an HDF5 file")
    return SessionError(f"{path}: cannot open the HDF5 file ({one_line(error)})")


class WriterLock:
    """An exclusive ``flock`` on the session file, held by the one process that writes it.

    HDF5's own file locking is switched off (``locking=False``) so SWMR readers can follow a recording; this lock
    keeps a second writer (or a recovery) away from a session that a live process is still recording into. The
    kernel drops it when the process ends, killed or not. Without ``fcntl`` (Windows) HDF5's locking stays on.

    A process knows the locks it holds itself (:meth:`held_here`): a look at its own session (the GUI diagnosing the
    session it has open) is not another process writing it, and asking for its own lock a second time says so.
    """

    #: (device, inode) of each file this process holds the writer lock of.
    _held: set[tuple[int, int]] = set()

    def __init__(self, path: Path) -> None:
        self._fd = -1
        self._key: tuple[int, int] | None = None
        if fcntl is None:
            return
        try:
            self._fd = os.open(path, os.O_RDONLY)
        except OSError as error:
            raise SessionError(f"{path}: cannot open the session file ({error.strerror})") from None
        status = os.fstat(self._fd)
        key = (status.st_dev, status.st_ino)
        if key in WriterLock._held:
            self.release()
            raise SessionError(f"{path}: this process has the session open for writing already; close it first")
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.release()
            raise SessionError(
                f"{path}: another process is writing this session; wait until it has finished"
            ) from None
        self._key = key
        WriterLock._held.add(key)

    @staticmethod
    def held_by_a_writer(path: Path) -> bool:
        """Whether a live process holds the writer lock of ``path`` (probed without keeping it): another process, or
        this one (:meth:`held_here` tells which)."""
        if WriterLock.held_here(path):
            return True
        try:
            WriterLock(path).release()
        except SessionError:
            return True
        return False

    @staticmethod
    def held_here(path: Path) -> bool:
        """Whether this process itself holds the writer lock of ``path`` (links followed)."""
        try:
            status = os.stat(path)
        except OSError:
            return False
        return (status.st_dev, status.st_ino) in WriterLock._held

    def release(self) -> None:
        if self._key is not None:
            WriterLock._held.discard(self._key)
            self._key = None
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


def open_h5(path: Path, mode: str, **options: Any) -> h5py.File:
    """Open with HDF5's file locking off where :class:`WriterLock` replaces it."""
    if mode != "r":
        options.setdefault("libver", "latest")
    if fcntl is not None:
        options["locking"] = False
    return h5py.File(path, mode, **options)


def check_unclosed_file(path: Path) -> None:
    """Raise unless a file left open by its writer can be read in SWMR mode without running past its end."""
    try:
        probe = subprocess.run(
            [sys.executable, "-c", PROBE_SCRIPT, str(path)], capture_output=True, text=True, timeout=PROBE_TIMEOUT_S
        )
    except subprocess.TimeoutExpired:
        raise SessionError(
            f"{path}: truncated or damaged HDF5 file: left open by its writer, and reading it runs past its end"
        ) from None
    if probe.returncode == 3:
        raise SessionError(f"{path}: truncated HDF5 file: left open by its writer, its hit records end early")
    if probe.returncode != 0:
        last_line = (probe.stderr.strip().splitlines() or ["no message"])[-1]
        raise SessionError(
            f"{path}: truncated or damaged HDF5 file: left open by its writer, and part of it cannot be read "
            f"({last_line})"
        )



def _hdf5_library() -> ctypes.CDLL | None:
    """h5py's HDF5 library in this process, for the few settings h5py does not wrap (None where it cannot be found)."""
    try:
        with open("/proc/self/maps") as maps:
            libraries = [line.split()[-1] for line in maps if "/libhdf5" in line]
        return ctypes.CDLL(libraries[0])
    except (OSError, IndexError):
        return None


def _set_single_read_attempt(fapl: Any) -> bool:
    library = _hdf5_library()
    try:
        return library is not None and library.H5Pset_metadata_read_attempts(
            ctypes.c_int64(fapl.id), ctypes.c_uint(1)) >= 0
    except AttributeError:
        return False


def open_store(store: RollbackFile, mode: str, clear_status_flags: bool = False, swmr_read: bool = False,
               single_read_attempt: bool = False) -> h5py.File:
    """Open the session file HDF5 reads and writes through ``store`` (h5py's file-object driver): ``mode`` "w"
    (a new file), "r+" or "r". ``clear_status_flags``: open for writing a file whose writer was killed (HDF5 refuses
    it as "already open for write", as ``h5clear -s`` would); ``swmr_read``: read such a file;
    ``single_read_attempt``: one attempt per metadata read (no minutes of retries past the end of a cut file)."""
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    fapl.set_fileobj_driver(h5py.h5fd.fileobj_driver, store)
    if mode != "r":
        fapl.set_libver_bounds(h5py.h5f.LIBVER_LATEST, h5py.h5f.LIBVER_LATEST)
    if single_read_attempt:
        _set_single_read_attempt(fapl)
    if clear_status_flags:
        library = _hdf5_library()
        flag = ctypes.c_bool(True)
        if library is None or library.H5Pset(ctypes.c_int64(fapl.id), b"clear_status_flags",
                                             ctypes.byref(flag)) < 0:
            raise SessionError(f"{store.path}: left open by a writer that did not close it, and this HDF5 library "
                               f"cannot clear its flags; run h5clear -s on it")
    name = repr(store).encode("ascii", "replace")
    if mode == "w":
        file_id = h5py.h5f.create(name, h5py.h5f.ACC_TRUNC, fapl=fapl)
    elif mode == "r+":
        file_id = h5py.h5f.open(name, h5py.h5f.ACC_RDWR, fapl=fapl)
    else:
        file_id = h5py.h5f.open(name, h5py.h5f.ACC_RDONLY | (h5py.h5f.ACC_SWMR_READ if swmr_read else 0), fapl=fapl)
    return h5py.File(file_id)


def building_path(path: Path, suffix: str) -> Path:
    """The hidden file next to ``path`` that this process builds before moving it into place."""
    return path.with_name(f".{path.name}.{os.getpid()}.{suffix}")


def _process_alive(pid: int) -> bool:
    if os.name == "nt":
        return True  # os.kill would terminate it: leftovers are kept on Windows
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_leftovers(path: Path) -> None:
    """Delete the hidden files that killed creations of ``path`` left behind (their process has ended and no process
    holds their lock); a live creation keeps its file."""
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.({'|'.join(BUILDING_SUFFIXES)})$")
    try:
        candidates = [Path(name) for suffix in BUILDING_SUFFIXES
                      for name in glob.glob(str(path.parent / f".{glob.escape(path.name)}.*.{suffix}"))]
    except OSError:
        return
    for leftover in candidates:
        match = pattern.match(leftover.name)
        if match is None:
            continue
        pid = int(match.group(1))
        if pid == os.getpid() or _process_alive(pid) or WriterLock.held_by_a_writer(leftover):
            continue
        try:
            if leftover.is_dir():
                shutil.rmtree(leftover)
            else:
                leftover.unlink()
        except OSError as error:
            logger.warning("%s: cannot remove the leftover of an interrupted creation (%s)", leftover, error.strerror)
        else:
            logger.warning("%s: removed the leftover of a killed creation (process %d)", leftover, pid)


def move_into_place(building: Path, path: Path, overwrite: bool) -> None:
    """Give the finished file ``building`` its name ``path`` atomically; unless ``overwrite``, fail if ``path``
    exists, also when another process created it a moment ago (a hard link cannot replace a file)."""
    if overwrite:
        os.replace(building, path)
        return
    try:
        try:
            os.link(building, path)
        except FileExistsError:
            raise
        except OSError as error:
            if error.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.ENOSYS, errno.EMLINK):
                raise
            # no hard links on this file system: claim the name exclusively, then move the file onto the claim
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            os.replace(building, path)
            return
    except FileExistsError:
        raise SessionError(
            f"{path}: the session file exists already (another process created it at the same moment)"
        ) from None
    os.unlink(building)
