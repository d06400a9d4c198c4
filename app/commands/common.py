"""What every command shares: may an output path be written, settings built from the flags the user typed, and
whether progress may be drawn. Light imports only (the parsers are registered without numpy)."""

from __future__ import annotations

import dataclasses
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, Mapping, TypeVar

from gasfilm.drivers.errors import SettingError

T = TypeVar("T")


def check_output_file(path: Path, flag: str, overwrite: bool, make_parent: bool = False) -> Path:
    """May this command write ``path``? Checked BEFORE any work; raises one :class:`SettingError` naming ``flag``.

    An existing file is replaced only with ``--overwrite``; a symbolic link is never written through (with
    ``--overwrite`` the link itself is removed, its target untouched); the folder must exist (or is made with
    ``make_parent``) and accept a new file. ``flag`` is empty for a path the user did not type (a default)."""
    where = f"{flag} {path}" if flag else str(path)
    if path.is_symlink():
        if not overwrite:
            raise SettingError(f"{where}: is a symbolic link; gasfilm does not write through links "
                               f"(--overwrite replaces the link itself)")
        try:
            path.unlink()
        except OSError as error:
            raise SettingError(f"{where}: cannot remove the link ({error.strerror or error})") from None
    if path.is_dir():
        raise SettingError(f"{where}: is a folder, not a file")
    if path.exists():
        if not overwrite:
            raise SettingError(f"{where}: exists already (add --overwrite to replace it)")
        if not os.access(path, os.W_OK):
            raise SettingError(f"{where}: exists and is not writable")
    parent = path.parent
    if make_parent:
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise SettingError(f"{where}: cannot make the folder {parent} ({error.strerror or error})") from None
    if not parent.is_dir():
        raise SettingError(f"{where}: the folder {parent} does not exist")
    try:  # the only reliable test of "a new file can be made here" (root, read-only mounts, /proc)
        handle, probe = tempfile.mkstemp(dir=parent, prefix=f".{path.name}.", suffix=".probe")
        os.close(handle)
        os.unlink(probe)
    except OSError as error:
        raise SettingError(f"{where}: cannot write in {parent} ({error.strerror or error})") from None
    return path


def check_output_folder(folder: Path, flag: str, names: tuple[str, ...], overwrite: bool) -> list[Path]:
    """May this command write the files ``names`` into ``folder`` (made if missing)? Same rules as
    :func:`check_output_file` for each file."""
    if folder.exists() and not folder.is_dir():
        raise SettingError(f"{flag + ' ' if flag else ''}{folder}: is a file, not a folder")
    return [check_output_file(folder / name, flag, overwrite, make_parent=True) for name in names]


def settings_from_flags(cls: type[T], base: T | None, flags: Mapping[str, tuple[str, Any]]) -> T:
    """``cls`` (or ``base`` with changes) from the flags the user gave: ``flags`` maps a field name to (the flag
    as typed, its value; None when not given). A refused value is reported under its flag, not the field name."""
    changes = {name: value for name, (_flag, value) in flags.items() if value is not None}
    try:
        return dataclasses.replace(base, **changes) if base is not None else cls(**changes)
    except SettingError as error:
        message = str(error)
        for name, (flag, _value) in flags.items():
            message = re.sub(rf"\b{name}\b", flag, message)
        raise SettingError(message) from None


def positive_flag(flag: str, value: float | int | None, unit: str = "") -> None:
    """Refuse a flag whose value must be a positive finite number (None: the flag was not given)."""
    if value is not None and not (value > 0 and value != float("inf")):
        raise SettingError(f"{flag}: {value}{' ' + unit if unit else ''} must be positive")


def is_terminal(stream: Any = None) -> bool:
    """Whether progress may be drawn on ``stream`` (stderr by default): only on a terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def source_conditions(paths: list[Path]) -> dict[str, Any]:
    """The operating conditions stored in a session (``{}`` for UFF or .npy records, which carry none)."""
    from gasfilm.analysis.conditions import decode_conditions
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import is_time_record_file

    if len(paths) != 1 or is_time_record_file(paths[0]):
        return {}
    with Session.open(paths[0], "r") as session:
        return decode_conditions(session.settings, str(paths[0]))


def load_frf(paths: list[Path], name: str | None = None) -> tuple[Any, str, str | None]:
    """The FRF to export or fit, its description and the rig spec TOML it was recorded with (None for files).

    A session gives its stored FRF ``name`` (default: "frf" or its only one), else one averaged now from its accepted
    hits with its stored window; UFF or .npy time records give the FRF of all their hits (no window stored)."""
    from gasfilm.analysis.session import Session, SessionError
    from gasfilm.analysis.settings import decode_setting
    from gasfilm.analysis.sources import is_time_record_file, load_source
    from gasfilm.analysis.spectra import WindowSettings, session_frf

    if len(paths) == 1 and not is_time_record_file(paths[0]):
        with Session.open(paths[0], "r") as session:
            stored = session.result_names("frf")
            if name is not None:
                return session.read_frf(name), f"FRF '{name}'", session.rig_spec_toml
            if "frf" in stored or len(stored) == 1:
                chosen = "frf" if "frf" in stored else stored[0]
                return session.read_frf(chosen), f"FRF '{chosen}'", session.rig_spec_toml
            if len(stored) > 1:
                raise SettingError(f"--frf: {session.path} holds several FRFs ({', '.join(stored)}); choose one")
            hits = [hit for hit in session.hits() if hit.verdict.accepted]
            if not hits:
                raise SessionError(f"{session.path}: no stored FRF and no accepted hits to average")
            frf = session_frf(hits, session.settings_as("window", WindowSettings))
            return frf, f"FRF averaged now from {len(hits)} accepted hits", session.rig_spec_toml
    if name is not None:
        raise SettingError(f"--frf: {paths[0]} is not a session; only sessions store named FRFs")
    source = load_source(paths)
    hits = source.judged_hits()
    window = decode_setting(source.settings, "window", WindowSettings, str(source.path))
    return session_frf(hits, window), f"FRF averaged from the {len(hits)} hits of {source.kind} records", None
