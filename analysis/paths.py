"""Where gasfilm writes, in rules every writer shares: why a file cannot be made where a path says, and writing
output files whole or not at all.

Symbolic links are followed everywhere, one rule for sessions, output files and output folders: a path that is a link
names what the link points to, which is read or written in place (a file replaced by a new version is replaced where
the link points), and the link itself is never replaced by a copy (docs/architecture.md, "Files and links")."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from gasfilm.analysis.interrupts import signals_deferred
from gasfilm.drivers.errors import GasfilmError


def file_in_the_way(folder: Path) -> Path | None:
    """What stands where ``folder``, or a folder above it, should be and is not a folder (None: nothing does)."""
    for above in (folder, *folder.parents):
        if above.exists() or above.is_symlink():
            return None if above.is_dir() else above
    return None


def missing_folder(folder: Path) -> str:
    """Why ``folder`` cannot hold a new file: a file stands where a folder is needed, or the folder does not exist."""
    blocker = file_in_the_way(folder)
    if blocker is None:
        return f"the folder {folder} does not exist"
    return f"{blocker} is a file, not a folder" if blocker.is_file() else f"{blocker} is not a folder"


def link_target(path: Path) -> Path:
    """The file ``path`` names, symbolic links followed (the path itself when it is no link)."""
    return Path(os.path.realpath(path))


def write_error(error: BaseException) -> OSError | None:
    """The operating system's error behind a failed write (a full disk, an I/O error), also when a library wrapped it
    in an error of its own (pyuff's "Error writing data-set #58"); None when there is none."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, OSError):
            return error
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return None


def partial_name(target: Path) -> Path:
    """The hidden name a file is written under before it gets its name (the suffix kept: writers choose the format
    by it)."""
    return target.with_name(f".{target.stem}.{os.getpid()}.partial{target.suffix}")


@contextlib.contextmanager
def written_whole(*paths: Path, what: str = "the output") -> Iterator[list[Path]]:
    """Write files whole or not at all: the block writes each to the hidden name it is given (one per path, beside the
    file the path names, links followed); when the block ends they are fsynced and renamed to their names together,
    replacing what was there. When the block fails, every one of them is removed; a failed write (a full disk, an
    I/O error) becomes one :class:`GasfilmError` line naming the file and the reason, anything else is raised as
    it is."""
    targets = [link_target(Path(path)) for path in paths]
    temporaries = [partial_name(target) for target in targets]
    try:
        yield temporaries
        with signals_deferred():  # (a stop signal waits until every file has its name)
            for temporary in temporaries:
                _fsync(temporary)
            for temporary, target in zip(temporaries, targets):
                os.replace(temporary, target)
    except BaseException as error:
        for temporary in temporaries:
            with contextlib.suppress(OSError):
                temporary.unlink()
        cause = write_error(error)
        if cause is None or isinstance(error, GasfilmError) or not paths:
            raise
        named = next((path for path, temporary in zip(paths, temporaries)
                      if cause.filename in (str(temporary), os.fsencode(temporary))), paths[0])
        reason = cause.strerror or " ".join(str(cause).split())[:160]
        raise GasfilmError(f"{named}: cannot write {what} ({reason}); nothing was written") from None


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
def results_folder(source: Path, what: str) -> Path:
    """Where a command writes the files of its ``what`` ("fit", "diagnosis") of ``source`` when not told: a folder
    beside the input named after it, ``NAME-fit/`` or ``NAME-diagnosis/`` (the one rule of every command and the
    GUI, issue 32): two recordings' results never meet, and an existing file there is replaced only when asked."""
    source = Path(source)
    return source.with_name(f"{source.stem}-{what}")
