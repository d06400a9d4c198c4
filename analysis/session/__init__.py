"""HDF5 session files: everything one hammer session recorded, safe against a killed process, a full disk or a failed
write.

One file per session (layout in ``docs/session-format.md``), written in place through a rollback journal: writes
inside the bytes of the last commit are held until the next commit, which journals the bytes they replace
(``NAME.journal``, fsynced) before writing them, so the file always holds its last commit or a journal that restores
it. A hit or a verdict is committed before it is reported; a failed write rolls back to the last commit; a command that
fails leaves its session byte for byte as it was. Hits are appended to chunked, resizable datasets in HDF5's
single-writer/multiple-reader (SWMR) mode; structural changes (FRF, fits, diagnoses, status) are made with the file
out of SWMR mode.

Modules: :mod:`.layout` (constants and codecs), :mod:`.files` (writer lock, opening, naming), :mod:`.journal` (the
rollback journal), :mod:`.api`.
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
