"""Why a file cannot be made where a path says, in words every writer shares."""

from __future__ import annotations

from pathlib import Path


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


def results_folder(source: Path, what: str) -> Path:
    """Where a command writes the files of its ``what`` ("fit", "diagnosis") of ``source`` when not told: a folder
    beside the input named after it, ``NAME-fit/`` or ``NAME-diagnosis/`` (the one rule of every command and the
    GUI, issue 32): two recordings' results never meet, and an existing file there is replaced only when asked."""
    source = Path(source)
    return source.with_name(f"{source.stem}-{what}")
