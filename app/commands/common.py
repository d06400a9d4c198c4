"""What every command shares: may an output path be written, settings built from the flags the user typed, and
whether progress may be drawn. Light imports only (the parsers are registered without numpy)."""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, Mapping, Sequence, TypeVar

from gasfilm.analysis.interrupts import signals_deferred
from gasfilm.analysis.paths import file_in_the_way, link_target, missing_folder
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2

#: ``--units`` choices: accelerance in g/N (the paper's tables and figures; the default everywhere on the command line)
#: or in (m/s²)/N.
UNITS = {"g": "g/N", "si": "(m/s²)/N"}
DEFAULT_UNITS = "g"

T = TypeVar("T")


def add_units_flag(parser: Any) -> None:
    """The one ``--units`` flag every command that prints an accelerance takes."""
    parser.add_argument("--units", choices=tuple(UNITS), default=DEFAULT_UNITS,
                        help="accelerance printed in g/N ('g', the default, as the paper's tables) or in (m/s²)/N "
                             "('si'); JSON keys name their unit and stay SI")


def device_name(text: str) -> str:
    """argparse type of ``--device``: "sim" in any case (``SIM``, ``Sim``) is the simulated rig, any other text an
    NI-DAQmx device name as typed (NI's names are not case-sensitive either, but are kept as the user wrote them)."""
    name = text.strip()
    return "sim" if name.lower() == "sim" else name


#: ``--estimator`` choices: the FrfResult attribute and the name printed.
ESTIMATOR_NAMES = {"h1": "H1", "h2": "H2", "hv": "Hv"}


def add_estimator_flag(parser: Any, what: str) -> None:
    """The one ``--estimator`` flag of ``replay`` and ``export``."""
    parser.add_argument("--estimator", choices=tuple(ESTIMATOR_NAMES), default="h1",
                        help=f"{what}: H1 (noise on the response; the default, what fit and diagnose use), H2 (noise "
                             f"on the force) or Hv (both alike, between the two)")


def accelerance_text(value_m_s2_per_n: float, units: str = DEFAULT_UNITS, digits: int = 4) -> str:
    """An accelerance given in (m/s²)/N, printed in the chosen ``--units`` with its unit."""
    value = value_m_s2_per_n / STANDARD_GRAVITY_M_S2 if units == "g" else value_m_s2_per_n
    return f"{value:.{digits}g} {UNITS[units]}"


def hit_line(event: Any) -> str:
    """The one line a recorded hit gets on every command (``demo``, ``acquire``): numbered from 1, its trigger time
    in session time, its peak force and, when rejected, why."""
    head = f"{'accepted' if event.verdict.accepted else 'rejected'} hit {event.index + 1} at " \
           f"{event.trigger_time_s:.2f} s, peak {event.peak_force_n:.0f} N"
    return head if event.verdict.accepted else f"{head}: {', '.join(event.verdict.reasons)}"


#: The first bytes of an HDF5 file (at its start, or after a user block of 512, 1024, 2048, … bytes).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: What the commands that read recordings take, in words.
RECORDINGS = "a session (HDF5), UFF 58 records (.uff/.unv) or .npy hit records"
#: Extensions of the recordings that are not sessions.
RECORD_FILE_SUFFIXES = (".uff", ".unv", ".npy")


def _is_hdf5(path: Path) -> bool:
    """Whether ``path`` starts like an HDF5 file (a damaged one included: its reader then says what is wrong)."""
    with open(path, "rb") as stream:
        offset = 0
        while True:
            stream.seek(offset)
            head = stream.read(len(HDF5_SIGNATURE))
            if head == HDF5_SIGNATURE:
                return True
            if len(head) < len(HDF5_SIGNATURE):
                return False
            offset = 512 if offset == 0 else 2 * offset


def check_inputs(paths: Sequence[Path], suffixes: tuple[str, ...] = RECORD_FILE_SUFFIXES,
                 what: str = RECORDINGS) -> None:
    """Each input exists, is a file and is of a type the command reads (a session, whatever its name, or a file with
    one of ``suffixes``; several files only as .npy records): checked BEFORE the outputs, so that a mistyped input is
    what the user hears about. A session whose file is missing or damaged but whose journal is left is passed on:
    opening it rebuilds it."""
    from gasfilm.analysis.session.journal import journal_path
    from gasfilm.analysis.sources import check_several

    check_several(paths)
    for path in paths:
        if journal_path(path).is_dir():
            continue
        suffix = path.suffix.lower()
        if not path.exists():
            kind = "UFF " if suffix in (".uff", ".unv") else "" if suffix in suffixes else "session "
            raise SettingError(f"{path}: no such {kind}file")
        if path.is_dir():
            raise SettingError(f"{path}: is a folder, not {what}")
        if suffix in suffixes:
            continue
        try:
            hdf5 = _is_hdf5(path)
        except OSError as error:
            raise SettingError(f"{path}: cannot be read ({error.strerror or error})") from None
        if not hdf5:
            raise SettingError(f"{path}: wrong file type: not an HDF5 file (this command reads {what})")


def check_output_file(path: Path, flag: str, overwrite: bool, make_parent: bool = False) -> Path:
    """May this command write ``path``? Checked BEFORE any work; raises one :class:`SettingError` naming ``flag``.

    An existing file is replaced only with ``--overwrite``; a symbolic link names the file it points to, which is
    what is written (replaced in place with ``--overwrite``, the link kept; made where the link points when it does
    not exist yet), as for every path gasfilm reads or writes (docs/architecture.md, "Files and links"); the folder
    must exist (or is made with ``make_parent``) and accept a new file. ``flag`` is empty for a path the user did not
    type (a default)."""
    where = f"{flag} {path}" if flag else str(path)
    if path.is_dir():
        raise SettingError(f"{where}: is a folder, not a file")
    if path.exists():
        if not overwrite:
            linked = f" (the file its link points to, {link_target(path)})" if path.is_symlink() else ""
            raise SettingError(f"{where}: exists already{linked} (add --overwrite to replace it)")
        if not os.access(path, os.W_OK):
            raise SettingError(f"{where}: exists and is not writable")
    parent = link_target(path).parent
    if make_parent:
        if file_in_the_way(parent) is not None:
            raise SettingError(f"{where}: {missing_folder(parent)}")
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise SettingError(f"{where}: cannot make the folder {parent} ({error.strerror or error})") from None
    if not parent.is_dir():
        raise SettingError(f"{where}: {missing_folder(parent)}")
    try:  # the only reliable test of "a new file can be made here" (root, read-only mounts, /proc)
        with signals_deferred():  # (a stop signal in between would leave the probe behind)
            handle, probe = tempfile.mkstemp(dir=parent, prefix=f".{path.name}.", suffix=".probe")
            os.close(handle)
            os.unlink(probe)
    except OSError as error:
        raise SettingError(f"{where}: cannot write in {parent} ({error.strerror or error})") from None
    return path


def check_output_suffix(path: Path, flag: str, suffixes: tuple[str, ...]) -> None:
    """Refuse an output path that is a folder, or whose extension does not say what is written into it (a UFF file
    named .csv)."""
    if path.is_dir():
        raise SettingError(f"{flag} {path}: is a folder, not a file")
    if path.suffix.lower() not in suffixes:
        raise SettingError(f"{flag} {path}: the file name must end in {' or '.join(suffixes)} "
                           f"(it says what the file holds)")


#: Extensions of a session file (HDF5).
SESSION_SUFFIXES = (".h5", ".hdf5")


def check_session_path(path: Path, flag: str) -> None:
    """Refuse a session path that is a folder or does not end in .h5 (a session is an HDF5 file)."""
    if path.is_dir():
        raise SettingError(f"{flag} {path}: is a folder; name the session file in it, e.g. {path / 'session.h5'}")
    check_output_suffix(path, flag, SESSION_SUFFIXES)


def check_output_folder(folder: Path, flag: str, names: tuple[str, ...], overwrite: bool) -> list[Path]:
    """May this command write the files ``names`` into ``folder`` (made if missing)? Same rules as
    :func:`check_output_file` for each file."""
    if folder.exists() and not folder.is_dir():
        raise SettingError(f"{flag + ' ' if flag else ''}{folder}: is a file, not a folder")
    return [check_output_file(folder / name, flag, overwrite, make_parent=True) for name in names]


#: A window flag's value "none" (or "off"): that window is switched off.
NO_WINDOW = "none"


def check_force_window_length(force_window_ms: float | str | None, sample_rate_hz: float, rate_text: str) -> None:
    """A --force-window-ms (as typed: a number, :data:`NO_WINDOW` or None) must hold at least one sample at
    ``sample_rate_hz`` (``rate_text`` says where that rate comes from in the message)."""
    if isinstance(force_window_ms, float) and force_window_ms * 1e-3 < 1.0 / sample_rate_hz:
        raise SettingError(f"--force-window-ms: {force_window_ms:g} ms is shorter than one sample "
                           f"({1e3 / sample_rate_hz:.3g} ms at {rate_text} S/s)")


def window_value(text: str) -> float | str:
    """argparse type of a window flag: a number, or "none"/"off" for no window."""
    if text.strip().lower() in ("none", "off"):
        return NO_WINDOW
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number or 'none'") from None


def settings_from_flags(cls: type[T], base: T | None, flags: Mapping[str, tuple[str, Any]]) -> T:
    """``cls`` (or ``base`` with changes) from the flags the user gave: ``flags`` maps a field name to (the flag
    as typed, its value; None when not given, :data:`NO_WINDOW` for "off"). A refused value is reported under its
    flag, not the field name."""
    changes = {name: (None if value is NO_WINDOW else value) for name, (_flag, value) in flags.items()
               if value is not None}
    try:
        return dataclasses.replace(base, **changes) if base is not None else cls(**changes)
    except SettingError as error:
        message = str(error).replace("or None for", "or none for")
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
    """The operating conditions stored in a session, or written into a UFF file by a gasfilm export (``{}`` for .npy
    records and other programs' files, which carry none)."""
    from gasfilm.analysis.conditions import decode_conditions
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.sources import UFF_SUFFIXES, is_time_record_file

    if len(paths) == 1 and paths[0].suffix.lower() in UFF_SUFFIXES:
        from gasfilm.analysis.uff import read_uff_conditions

        return read_uff_conditions(paths[0])
    if len(paths) != 1 or is_time_record_file(paths[0]):
        return {}
    with Session.open(paths[0], "r") as session:
        return decode_conditions(session.settings, str(paths[0]))


@dataclasses.dataclass
class LoadedFrf:
    """The FRF to export or fit: what it is, the rig spec TOML it was recorded with (None for files), when asked
    for the hits it averages (for the time records of an export), and the session's name for it ("" when it is not
    one a session stores)."""

    frf: Any
    what: str
    rig_spec_toml: str | None
    hits: list = dataclasses.field(default_factory=list)
    name: str = ""
    #: the session's hit indices the FRF averages (None when not recorded) and the hits the session accepts now
    hit_indices: tuple[int, ...] | None = None
    accepted_indices: tuple[int, ...] | None = None
    note: str = ""  # which stored FRF was taken when the session holds others too

    def fit_hits(self) -> Any:
        """The :class:`~gasfilm.analysis.fit_settings.FitHits` of a fit of this FRF."""
        from gasfilm.analysis.fit_settings import FitHits

        return FitHits(len(self.hit_indices) if self.hit_indices is not None else int(self.frf.n_averages),
                       self.hit_indices)


def load_frf(paths: list[Path], name: str | None = None) -> tuple[Any, str, str | None]:
    """The FRF to export or fit, its description and the rig spec TOML (None for files): :func:`load_frf_and_hits`
    without the hits."""
    loaded = load_frf_and_hits(paths, name)
    return loaded.frf, loaded.what, loaded.rig_spec_toml


def load_frf_and_hits(paths: list[Path], name: str | None = None, with_hits: bool = False,
                      fresh: bool = False) -> LoadedFrf:
    """The FRF to export or fit, its description and the rig spec TOML it was recorded with (None for files).

    A session gives its stored FRF ``name`` (default: "frf" or its only one), else (or with ``fresh``) one averaged
    now from its accepted hits with its stored window; a UFF file its stored FRF, else the FRF of its time records;
    UFF or .npy time records give the FRF of their hits validated as ``replay`` validates them (no window stored).
    ``with_hits``: also the hits the FRF averages (a session's stored FRF: the hits it names, else its accepted
    ones)."""
    from gasfilm.analysis.session import Session, SessionError
    from gasfilm.analysis.settings import decode_setting
    from gasfilm.analysis.sources import UFF_SUFFIXES, is_time_record_file, load_source
    from gasfilm.analysis.spectra import WindowSettings, session_frf

    if len(paths) == 1 and not is_time_record_file(paths[0]):
        with Session.open(paths[0], "r") as session:
            stored = [] if fresh else session.result_names("frf")
            accepted_indices = tuple(int(i) for i in session.accepted_indices())
            chosen = name
            if chosen is None and ("frf" in stored or len(stored) == 1):
                chosen = "frf" if "frf" in stored else stored[0]
            elif chosen is None and len(stored) > 1:
                raise SettingError(f"--frf: {session.path} holds several FRFs ({', '.join(stored)}); choose one")
            others = [other for other in stored if other != chosen]
            note = (f"{session.path} holds {len(stored)} FRFs: this is '{chosen}' (--frf "
                    f"{' or --frf '.join(others)} takes {'that' if len(others) == 1 else 'another'})"
                    if name is None and chosen is not None and others else "")
            if chosen is not None:
                frf = session.read_frf(chosen)
                indices = session.frf_hit_indices(chosen)
                hits = []
                if with_hits:
                    every = session.hits()
                    hits = ([every[i] for i in indices if 0 <= i < len(every)] if indices is not None
                            else [hit for hit in every if hit.verdict.accepted])
                return LoadedFrf(frf, f"FRF '{chosen}'", session.rig_spec_toml, hits, chosen,
                                 None if indices is None else tuple(int(i) for i in indices), accepted_indices, note)
            hits = [hit for hit in session.hits() if hit.verdict.accepted]
            if not hits:
                raise SessionError(f"{session.path}: no {'' if fresh else 'stored FRF and no '}accepted hits to "
                                   f"average")
            frf = session_frf(hits, session.settings_as("window", WindowSettings))
            return LoadedFrf(frf, f"FRF averaged now from {len(hits)} accepted hits", session.rig_spec_toml,
                             hits if with_hits else [], hit_indices=tuple(hit.index for hit in hits),
                             accepted_indices=accepted_indices)
    if name is not None:
        raise SettingError(f"--frf: {paths[0]} is not a session; only sessions store named FRFs")
    if len(paths) == 1 and paths[0].suffix.lower() in UFF_SUFFIXES:
        from gasfilm.analysis.uff import has_uff_time_records, read_uff_frf

        frf = read_uff_frf(paths[0])
        if frf is not None:
            hits = load_source(paths).hits if with_hits and has_uff_time_records(paths[0]) else []
            return LoadedFrf(frf, f"FRF stored in the file ({frf.n_averages} averages)", None, hits)
    source = load_source(paths)
    hits = source.judged_hits()
    rejected = len(source.hits) - len(hits)
    flagged = sum(1 for verdict in source.verdicts if verdict is not None and verdict.accepted and verdict.reasons)
    if not hits:
        reasons = sorted({reason for verdict in source.verdicts if verdict is not None for reason in verdict.reasons})
        raise SettingError(f"{paths[0]}: all {len(source.hits)} hits are rejected ({', '.join(reasons)}); "
                           f"`gasfilm replay` shows why and takes other validation settings")
    window = decode_setting(source.settings, "window", WindowSettings, str(source.path))
    what = (f"FRF averaged from {len(hits)} of the {len(source.hits)} hit{'s' if len(source.hits) != 1 else ''} of "
            f"{source.kind} records")
    if rejected:
        what += f" ({rejected} rejected as `gasfilm replay` rejects them)"
    if flagged:
        what += f" ({flagged} still ringing at the record end: leakage; `gasfilm replay` advises a window)"
    return LoadedFrf(session_frf(hits, window), what, None, hits if with_hits else [])
