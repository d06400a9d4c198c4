"""HDF5 session files: everything one hammer session recorded, safe against a killed process or a full disk.

One file per session (layout in ``docs/session-format.md``). Hits are appended to pre-created chunked, resizable
datasets while the file is in HDF5's single-writer/multiple-reader (SWMR) mode: the raw record is written and
flushed first, then its row in the hit table, then the file descriptor is fsync'ed. SWMR keeps the file's metadata
consistent on disk at every moment, so a process killed at any point leaves a file whose committed hits (the rows of
the hit table) can always be read. Such a file still carries HDF5's "open for writing" flags: :meth:`Session.open`
reads it in SWMR mode and, when opened for appending, first rewrites it into a clean file (``recovered`` is then
True). Structural changes (FRF, fits, diagnoses, status) are made with the file out of SWMR mode.

Modules: :mod:`.layout` (constants and codecs), :mod:`.files` (writer lock, opening, recovery), :mod:`.api`.
"""

from gasfilm.analysis.session.api import DEFAULT_SIZE_LIMIT_BYTES, Session, StoredHit
from gasfilm.analysis.session.layout import (
    FORMAT_NAME,
    SCHEMA_VERSION,
    SessionError,
    SessionWriteError,
    to_jsonable,
)

__all__ = [
    "DEFAULT_SIZE_LIMIT_BYTES", "FORMAT_NAME", "SCHEMA_VERSION", "Session", "SessionError", "SessionWriteError", "StoredHit",
    "to_jsonable",
]
