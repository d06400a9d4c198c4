"""The session's rollback journal: HDF5 writes a session in place, and no failed or cut-short write can change what
the file held at its last commit.

HDF5 reads and writes the session file through :class:`RollbackFile` (h5py's file-object driver). Bytes past the end
the file had at its last commit are written through at once (new hit records, new results: nothing of the committed
session lives there); a write inside the committed bytes (HDF5's metadata: the superblock, object headers, chunk
indices, the last rows of the hit table) is held in memory. :meth:`RollbackFile.commit` makes the held writes durable
the way a database's rollback journal does: the bytes they replace are written to ``NAME.journal`` next to the
session and fsynced (with the folder), then the held writes go into the file and are fsynced, then the journal is
deleted (and the folder fsynced). So at every moment the file holds its last committed state, or a journal is left
that restores it byte for byte (:func:`restore`, done by the next writer; a reader applies it in memory:
:func:`rolled_back_view`). :meth:`RollbackFile.rollback` drops everything since the last commit. A commit costs the
bytes it changes, not the session: appending a hit to a session of a thousand writes one record and a few kB of
metadata. Layout of the journal in ``docs/session-format.md``.
"""

from __future__ import annotations

import bisect
import hashlib
import io
import logging
import os
import struct
from pathlib import Path

from gasfilm.analysis.interrupts import signals_deferred
from gasfilm.analysis.session.layout import SessionError

logger = logging.getLogger(__name__)

JOURNAL_SUFFIX = ".journal"
#: The first bytes of a rollback journal; then the size the file had at its last commit and the number of extents
#: (unsigned 64-bit, little-endian), each extent's offset and length and its bytes as they were, and a BLAKE2b digest
#: (16 bytes) of everything before it.
MAGIC = b"gasfilm rollback journal 1\n"
_HEADER = struct.Struct("<QQ")
_DIGEST_BYTES = 16
#: HDF5's file signature, the superblock bytes read to mark it (v2/v3: 12 + 4 addresses of up to 16 bytes + checksum),
#: and its file consistency flags.
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_SUPERBLOCK_HEAD = 12 + 4 * 16 + 4
_WRITE_ACCESS, _SWMR_WRITE_ACCESS = 0x01, 0x04
_MASK32 = 0xFFFFFFFF


def _rotate(value: int, bits: int) -> int:
    return ((value << bits) | (value >> (32 - bits))) & _MASK32


def lookup3(data: bytes, initial: int = 0) -> int:
    """Bob Jenkins' lookup3 hash ("hashlittle"), HDF5's checksum of its metadata (H5_checksum_lookup3)."""
    length = len(data)
    a = b = c = (0xDEADBEEF + length + initial) & _MASK32
    words = data + bytes(-length % 12)
    at = 0
    while length > 12:
        a = (a + int.from_bytes(words[at:at + 4], "little")) & _MASK32
        b = (b + int.from_bytes(words[at + 4:at + 8], "little")) & _MASK32
        c = (c + int.from_bytes(words[at + 8:at + 12], "little")) & _MASK32
        for x, y, z, bits in ((0, 2, 1, 4), (1, 0, 2, 6), (2, 1, 0, 8), (0, 2, 1, 16), (1, 0, 2, 19), (2, 1, 0, 4)):
            state = [a, b, c]  # mix(a, b, c): x -= y; x ^= rot(y, bits); y += z
            state[x] = ((state[x] - state[y]) & _MASK32) ^ _rotate(state[y], bits)
            state[y] = (state[y] + state[z]) & _MASK32
            a, b, c = state
        length -= 12
        at += 12
    if length == 0:
        return c
    a = (a + int.from_bytes(words[at:at + 4], "little")) & _MASK32
    b = (b + int.from_bytes(words[at + 4:at + 8], "little")) & _MASK32
    c = (c + int.from_bytes(words[at + 8:at + 12], "little")) & _MASK32
    for x, y, bits in ((2, 1, 14), (0, 2, 11), (1, 0, 25), (2, 1, 16), (0, 2, 4), (1, 0, 14), (2, 1, 24)):
        state = [a, b, c]  # final(a, b, c): x ^= y; x -= rot(y, bits)
        state[x] = ((state[x] ^ state[y]) - _rotate(state[y], bits)) & _MASK32
        a, b, c = state
    return c


def journal_path(path: Path) -> Path:
    """The rollback journal of the session file ``path``."""
    return path.with_name(path.name + JOURNAL_SUFFIX)


def _fsync_folder(folder: Path) -> None:
    if os.name == "nt":
        return
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _sync_data(fd: int) -> None:
    """Make a file's data durable (its size included; not its times): fdatasync where there is one."""
    (getattr(os, "fdatasync", None) or os.fsync)(fd)


def _pwrite_all(fd: int, data: bytes | memoryview, offset: int) -> None:
    view = memoryview(data)
    while view:
        written = os.pwrite(fd, view, offset)
        view, offset = view[written:], offset + written


def _pread_exactly(fd: int, length: int, offset: int) -> bytes:
    """``length`` bytes from ``offset`` (zeros past the end of the file)."""
    data = os.pread(fd, length, offset)
    return data + bytes(length - len(data)) if len(data) < length else data


class Extents:
    """Byte extents held in memory: non-overlapping, sorted by offset; a later write replaces what it covers."""

    def __init__(self) -> None:
        self._starts: list[int] = []
        self._blocks: list[bytearray] = []

    def __bool__(self) -> bool:
        return bool(self._starts)

    def __iter__(self):
        return iter(zip(self._starts, self._blocks))

    @property
    def nbytes(self) -> int:
        return sum(len(block) for block in self._blocks)

    def clear(self) -> None:
        self._starts, self._blocks = [], []

    def write(self, offset: int, data: bytes | memoryview) -> None:
        end = offset + len(data)
        if end == offset:
            return
        first = bisect.bisect_left(self._starts, offset)
        if first and self._starts[first - 1] + len(self._blocks[first - 1]) >= offset:
            first -= 1  # the extent before reaches (or touches) this write: merge with it
        last = first
        while last < len(self._starts) and self._starts[last] <= end:
            last += 1
        if first == last:
            self._starts.insert(first, offset)
            self._blocks.insert(first, bytearray(data))
            return
        start = min(offset, self._starts[first])
        stop = max(end, self._starts[last - 1] + len(self._blocks[last - 1]))
        merged = bytearray(stop - start)
        for index in range(first, last):
            at = self._starts[index] - start
            merged[at:at + len(self._blocks[index])] = self._blocks[index]
        merged[offset - start:end - start] = data
        self._starts[first:last] = [start]
        self._blocks[first:last] = [merged]

    def patch(self, offset: int, view: memoryview) -> None:
        """Copy what the extents hold of ``[offset, offset + len(view))`` into ``view``."""
        end = offset + len(view)
        index = max(bisect.bisect_right(self._starts, offset) - 1, 0)
        while index < len(self._starts) and self._starts[index] < end:
            start, block = self._starts[index], self._blocks[index]
            low, high = max(start, offset), min(start + len(block), end)
            if low < high:
                view[low - offset:high - offset] = block[low - start:high - start]
            index += 1

    def clip(self, end: int) -> None:
        """Drop what lies at or past ``end``."""
        while self._starts and self._starts[-1] >= end:
            self._starts.pop()
            self._blocks.pop()
        if self._starts and self._starts[-1] + len(self._blocks[-1]) > end:
            del self._blocks[-1][end - self._starts[-1]:]


def _encode_journal(size: int, extents: list[tuple[int, bytes]]) -> bytes:
    parts = [MAGIC, _HEADER.pack(size, len(extents))]
    for offset, data in extents:
        parts += [_HEADER.pack(offset, len(data)), data]
    body = b"".join(parts)
    return body + hashlib.blake2b(body, digest_size=_DIGEST_BYTES).digest()


def read_journal(path: Path) -> tuple[int, list[tuple[int, bytes]]] | None:
    """The size and the extents a rollback journal restores; None when it is incomplete or damaged (it was being
    written when its process died, before anything in the file changed)."""
    data = path.read_bytes()
    body, digest = data[:-_DIGEST_BYTES], data[-_DIGEST_BYTES:]
    if (len(data) < len(MAGIC) + _HEADER.size + _DIGEST_BYTES or not body.startswith(MAGIC)
            or hashlib.blake2b(body, digest_size=_DIGEST_BYTES).digest() != digest):
        return None
    at = len(MAGIC)
    size, count = _HEADER.unpack_from(body, at)
    at += _HEADER.size
    extents = []
    for _ in range(count):
        offset, length = _HEADER.unpack_from(body, at)
        at += _HEADER.size
        extents.append((offset, body[at:at + length]))
        at += length
    return size, extents


def restore(path: Path) -> bool:
    """Apply the rollback journal a process left (killed or failing during a commit) to the session file: its bytes
    as at the last commit. Returns whether a journal was applied; an incomplete one is only removed. Raises
    ``OSError`` when the file cannot be written (the journal is then kept)."""
    journal = journal_path(path)
    if not journal.is_file():
        return False
    content = read_journal(journal)
    if content is not None:
        size, extents = content
        fd = os.open(path, os.O_RDWR)
        try:
            for offset, data in extents:
                _pwrite_all(fd, data, offset)
            os.ftruncate(fd, size)
            _sync_data(fd)
        finally:
            os.close(fd)
        logger.warning("%s: restored as it was at its last commit from %s (its writer stopped during a commit)",
                       path, journal.name)
    journal.unlink()
    _fsync_folder(path.parent)
    return content is not None


class RollbackFile(io.RawIOBase):
    """The session file as HDF5 sees it through h5py's file-object driver; see the module's description.

    ``writable=False`` gives a read-only view; with ``undo`` (a left journal's size and extents) the view shows the
    file as at its last commit without writing anything."""

    def __init__(self, path: Path, writable: bool, undo: tuple[int, list[tuple[int, bytes]]] | None = None) -> None:
        super().__init__()
        self.path = path
        self.journal = journal_path(path)
        self._fd = os.open(path, os.O_RDWR if writable else os.O_RDONLY)
        self._writable = writable
        self._position = 0
        self._held = Extents()  # writes (or, for a view, old bytes) inside [0, self._committed_size)
        self._size = os.fstat(self._fd).st_size
        if undo is not None:
            self._size = undo[0]
            for offset, data in undo[1]:
                self._held.write(offset, data)
        self._committed_size = self._size
        self._detached = False
        #: The first write that failed since the last commit: the next commit refuses, only a rollback goes on.
        self.failure: OSError | None = None
        self.sync = True

    @classmethod
    def created(cls, path: Path) -> "RollbackFile":
        """A new, empty file at ``path`` (which must not exist), to be written through."""
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        return cls(path, writable=True)

    def moved_to(self, path: Path) -> None:
        """The file now has the name ``path`` (its journal is kept beside it from now on)."""
        self.path = path
        self.journal = journal_path(path)

    def held_ranges(self) -> list[tuple[int, int]]:
        """The (offset, length) of each held write, in file order."""
        return [(offset, len(data)) for offset, data in self._held]

    # ----- what h5py's driver calls -----------------------------------------------------------------------------

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return self._writable

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        self._position = offset + (self._position if whence == io.SEEK_CUR else self._size if whence == io.SEEK_END
                                   else 0)
        return self._position

    def tell(self) -> int:
        return self._position

    def readinto(self, buffer) -> int:  # noqa: ANN001 - a writable buffer
        view = memoryview(buffer).cast("B")
        count = max(0, min(len(view), self._size - self._position))
        view = view[:count]
        try:
            data = os.pread(self._fd, count, self._position)
        except OSError as error:  # (HDF5 then meets zeros, which its checksums refuse)
            self._fail(error)
            data = b""
        view[:len(data)] = data
        view[len(data):] = bytes(count - len(data))
        if self._held:
            self._held.patch(self._position, view)
        self._position += count
        return count

    def write(self, data) -> int:  # noqa: ANN001 - a bytes-like object
        view = memoryview(data).cast("B")
        if self._detached:
            return len(view)
        if not self._writable:
            raise io.UnsupportedOperation("the session is open read-only")
        self._put(self._position, view)
        self._position += len(view)
        return len(view)

    def _put(self, start: int, view: memoryview) -> None:
        """Write ``view`` at ``start``: held inside the committed bytes, through to the file past them."""
        end = start + len(view)
        inside = max(0, min(end, self._committed_size) - start)
        if inside:
            self._held.write(start, view[:inside])
        if inside < len(view):
            try:
                _pwrite_all(self._fd, view[inside:], start + inside)
            except OSError as error:
                self._fail(error)
                return
        self._size = max(self._size, end)

    def _fail(self, error: OSError) -> None:
        """A write failed: note it and take no more writes. Nothing is raised to HDF5 (an exception raised inside
        h5py's driver can crash the process later); the session sees :attr:`failure` and rolls back."""
        self.failure = self.failure or error
        self._detached = True

    def truncate(self, size: int | None = None) -> int:
        size = self._position if size is None else size
        if self._detached:
            return size
        if not self._writable:
            raise io.UnsupportedOperation("the session is open read-only")
        try:
            if size < self._committed_size:  # committed bytes cut off: held as zeros until the commit
                self._held.clip(size)
                self._held.write(size, bytes(self._committed_size - size))
                os.ftruncate(self._fd, self._committed_size)
            else:
                os.ftruncate(self._fd, size)
        except OSError as error:
            self._fail(error)
            return size
        self._size = size
        return size

    def flush(self) -> None:
        """Nothing: writes past the committed end are in the file already, the others wait for :meth:`commit`."""

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
        super().close()

    # ----- commits ----------------------------------------------------------------------------------------------

    @property
    def uncommitted_bytes(self) -> int:
        """Bytes written since the last commit (held, and written past the committed end)."""
        return self._held.nbytes + max(0, self._size - self._committed_size)

    def commit(self) -> None:
        """Make everything written since the last commit durable (fsynced unless ``sync`` is False), through the
        rollback journal; raises ``OSError`` when a write fails (the file and the journal then hold the last commit)."""
        if self.failure is not None:
            raise self.failure
        if self._detached:
            raise OSError(f"{self.path}: the file was let go after an earlier failure")
        with signals_deferred():  # (a stop signal waits until the commit is whole: never half applied)
            self._commit()

    def _commit(self) -> None:
        self._mark_open_for_writing()
        if not self._held and self._size == os.fstat(self._fd).st_size:
            if self.sync:
                _sync_data(self._fd)
            self._committed_size = self._size
            return
        changes = list(self._held)
        old = [(offset, _pread_exactly(self._fd, len(data), offset)) for offset, data in changes]
        self._write_journal(old)
        try:
            for offset, data in changes:
                _pwrite_all(self._fd, data, offset)
            if os.fstat(self._fd).st_size != self._size:
                os.ftruncate(self._fd, self._size)
            if self.sync:
                _sync_data(self._fd)
        except OSError as error:
            self._undo(old, error)
            raise
        try:
            self.journal.unlink()
            if self.sync:
                _fsync_folder(self.path.parent)
        except OSError as error:  # the journal would undo this commit: undo it now, while the bytes are at hand
            self._undo(old, error)
            raise
        self._held.clear()
        self._committed_size = self._size

    def _superblock(self) -> bytearray | None:
        """The first bytes of a version 2 or 3 superblock at the start of the file (None for any other)."""
        head = bytearray(_SUPERBLOCK_HEAD)
        self.seek(0)
        if self.readinto(head) < len(head) or head[:8] != HDF5_SIGNATURE or head[8] < 2:
            return None
        return head

    @property
    def left_open(self) -> bool:
        """Whether the superblock says a writer has the file open: its writer did not close it, when no live process
        holds its writer lock."""
        head = self._superblock()
        return head is not None and head[11] != 0

    def _mark_open_for_writing(self) -> None:
        """Give a superblock that says "open for SWMR writing" the "open for writing" flag with it, as HDF5 writes it
        through its own file driver (through h5py's file-object driver it leaves that flag out, and then no reader,
        HDF5's SWMR readers included, can open the file while it is written or after its writer was killed)."""
        head = self._superblock()
        if head is None:
            return
        checked = 12 + 4 * head[9]  # signature, versions and flags, then four addresses; the checksum follows
        if head[11] != _SWMR_WRITE_ACCESS or checked + 4 > len(head):
            return
        head[11] |= _WRITE_ACCESS
        head[checked:checked + 4] = lookup3(bytes(head[:checked])).to_bytes(4, "little")
        self._put(0, memoryview(head)[:checked + 4])

    def _write_journal(self, old: list[tuple[int, bytes]]) -> None:
        data = _encode_journal(self._committed_size, old)
        try:
            fd = os.open(self.journal, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                _pwrite_all(fd, data, 0)
                if self.sync:
                    _sync_data(fd)
            finally:
                os.close(fd)
            if self.sync:
                _fsync_folder(self.path.parent)
        except OSError:
            try:
                self.journal.unlink(missing_ok=True)
            except OSError:
                pass  # an incomplete journal is ignored (and removed) by the next open
            raise

    def _undo(self, old: list[tuple[int, bytes]], error: OSError) -> None:
        """Put back the bytes a failed commit may have changed; the journal stays when that fails too."""
        self.failure = self.failure or error
        try:
            for offset, data in old:
                _pwrite_all(self._fd, data, offset)
            os.ftruncate(self._fd, self._committed_size)
            _sync_data(self._fd)
            self.journal.unlink(missing_ok=True)
            _fsync_folder(self.path.parent)
        except OSError as again:
            logger.error("%s: the failed commit cannot be undone now (%s); %s restores the file when the session "
                         "is next opened", self.path, again.strerror or again, self.journal.name)

    def rollback(self) -> None:
        """Drop everything written since the last commit and let go of the file: HDF5's later writes (its cache
        being freed, closing) reach nothing. A committed file that a failed commit left changed keeps its journal."""
        self._held.clear()
        self._detached = True
        if not self.journal.exists():  # (no commit under way to undo, or undone)
            try:
                os.ftruncate(self._fd, self._committed_size)
            except OSError as error:
                logger.warning("%s: cannot cut off the uncommitted bytes (%s); readers ignore them", self.path,
                               error.strerror or error)
        self._size = self._committed_size


def rolled_back_view(path: Path) -> RollbackFile:
    """A read-only view of a session whose writer left a rollback journal: the file as at its last commit (an
    incomplete journal is ignored: the file was not changed yet)."""
    try:
        undo = read_journal(journal_path(path))
    except OSError as error:
        raise SessionError(f"{path}: its journal {journal_path(path).name} cannot be read "
                           f"({error.strerror or error})") from None
    return RollbackFile(path, writable=False, undo=undo)
