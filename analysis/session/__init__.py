"""HDF5 session files: everything one hammer session recorded, safe against a killed process, a full disk or a failed
write.

One file per session (layout in ``docs/session-format.md``). Every change to the hits goes first into the session's
journal (``NAME.journal/``, one small fsynced file per change, never written again), then into the HDF5 file, where
hits are appended to chunked, resizable datasets in HDF5's single-writer/multiple-reader (SWMR) mode. Opening a session
for writing rewrites the file from the journal; a clean close checks the file against the journal and removes it; a
journal left by a failed or killed writer rebuilds the session when it is next opened (``recovered`` is then True).
Structural changes (FRF, fits, diagnoses, status) are made with the file out of SWMR mode.

Modules: :mod:`.layout` (constants and codecs), :mod:`.files` (writer lock, opening, replacing), :mod:`.journal` (the
journal and rebuilding from it), :mod:`.api`.
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
