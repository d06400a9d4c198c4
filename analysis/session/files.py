"""Session files on disk: the writer lock, opening with HDF5, checking a file whose writer died, replacing a file
with its rebuilt copy."""

from __future__ import annotations

import contextlib
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

from gasfilm.analysis.session.layout import (
    FORMAT_NAME,
    SessionError,
    one_line,
)

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
#: Hidden files a creation or a recovery builds before it moves them into place: ``.NAME.PID.creating``; and the
#: folder a journal is started in, ``.NAME.journal.PID.starting``.
BUILDING_SUFFIXES = ("creating", "recovering", "starting")


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
    """

    def __init__(self, path: Path) -> None:
        self._fd = -1
        if fcntl is None:
            return
        try:
            self._fd = os.open(path, os.O_RDONLY)
        except OSError as error:
            raise SessionError(f"{path}: cannot open the session file ({error.strerror})") from None
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.release()
            raise SessionError(
                f"{path}: another process is writing this session; wait until it has finished"
            ) from None

    @staticmethod
    def held_elsewhere(path: Path) -> bool:
        """Whether a live process holds the writer lock of ``path`` (probed without keeping it)."""
        try:
            WriterLock(path).release()
        except SessionError:
            return True
        return False

    def release(self) -> None:
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



def open_for_salvage(path: Path) -> tuple[h5py.File | None, bool]:
    """The old session file opened read-only to take what it still holds, and whether it was closed properly;
    (None, False) when it cannot be opened (missing, damaged, not a session, or reading it would run past its end)."""
    try:
        return _checked_session(open_h5(path, "r")), True
    except (OSError, SessionError) as error:
        if "already open for write" not in str(error):
            return None, False
    try:
        fapl = _single_read_attempt_access()
        if fapl is None:  # no way to stop HDF5's retries in this process: check the file in a child first
            check_unclosed_file(path)
            return _checked_session(open_h5(path, "r", swmr=True)), False
        file_id = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
        return _checked_session(h5py.File(file_id)), False
    except (OSError, SessionError):
        return None, False


def _single_read_attempt_access() -> Any:
    """File access properties that read a file left open by its writer in SWMR mode with a single attempt per metadata
    read (HDF5's default retries and sleeps for minutes past the end of a truncated file); None where HDF5's library
    cannot be found in this process (H5Pset_metadata_read_attempts is called through ctypes: h5py does not wrap it)."""
    try:
        with open("/proc/self/maps") as maps:
            libraries = [line.split()[-1] for line in maps if "/libhdf5" in line]
        function = ctypes.CDLL(libraries[0]).H5Pset_metadata_read_attempts
    except (OSError, IndexError, AttributeError):
        return None
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    if fcntl is not None:
        fapl.set_file_locking(False, True)
    if function(ctypes.c_int64(fapl.id), ctypes.c_uint(1)) < 0:
        return None
    return fapl


def _checked_session(file: h5py.File) -> h5py.File:
    if file.attrs.get("format") != FORMAT_NAME:
        file.close()
        raise SessionError("not a session")
    return file


def replace_durably(building: Path, path: Path, lock: bool) -> "WriterLock | None":
    """Move the finished file ``building`` over ``path`` after an fsync of its data, and fsync the folder; with
    ``lock``, take the writer lock on it first (so no other writer gets in between) and return it."""
    fd = os.open(building, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    with contextlib.suppress(OSError):
        shutil.copymode(path, building)
    writer_lock = WriterLock(building) if lock else None
    try:
        os.replace(building, path)
        if os.name != "nt":
            folder = os.open(path.parent, os.O_RDONLY)
            try:
                os.fsync(folder)
            finally:
                os.close(folder)
    except BaseException:
        if writer_lock is not None:
            writer_lock.release()
        raise
    return writer_lock


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
    """Delete the hidden files that killed creations or recoveries of ``path`` left behind (their process has ended
    and no process holds their lock); a live creation or recovery keeps its file."""
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
        if pid == os.getpid() or _process_alive(pid) or WriterLock.held_elsewhere(leftover):
            continue
        try:
            if leftover.is_dir():
                shutil.rmtree(leftover)
            else:
                leftover.unlink()
        except OSError as error:
            logger.warning("%s: cannot remove the leftover of an interrupted %s (%s)", leftover, match.group(2),
                           error.strerror)
        else:
            logger.warning("%s: removed the leftover of a killed %s (process %d)", leftover,
                           {"creating": "creation", "recovering": "recovery"}.get(match.group(2), "journal start"), pid)


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
