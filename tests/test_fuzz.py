"""Damaged files through the command line: seeded mutations of UFF 58 time records, HDF5 sessions (a killed writer's
among them), TOML rig specs, ``.npy`` hit records, the JSON of ``gasfilm fit --json``, folders of sessions and the GUI's
sensor libraries go through ``gasfilm.app.cli.main`` in-process (replay, export, fit, acquire and acquire --append,
model, campaign, diagnose as fits each file; the sensor library through its reader). Every case must end with exit
status 0, 1 (a replay with no accepted hit) or 2, never an "internal error", a refusal on one line of stderr, a
``--json`` answer in strict JSON (no NaN), in under 10 s.

The mutations: byte flips, truncation, random bytes inserted, slices deleted or repeated, and edits that know the
format (numbers replaced by NaN/huge/negative values, keys and lines removed, tables and JSON nested deep, invalid
UTF-8, thousands of effects, HDF5 attributes and datasets replaced, resized, retyped, deleted or declared giant, .npy
headers declaring other shapes and types, records cut to a few samples, sessions that are not sessions in a campaign's
folder). ``benchmarks/bench_fuzz.py`` runs the same cases by the ten thousand.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import signal
import sys
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import h5py
import numpy as np
import pytest
import pyuff

ROOT = Path(__file__).resolve().parents[1]
RIG_SPECS = sorted((ROOT / "fixtures" / "rigs").glob("*.toml"))
CASE_TIMEOUT_S = 10.0
KINDS = ("uff", "session", "toml", "npy", "fit-json", "campaign", "sensors")

#: Values a damaged or hostile file may hold in place of a number (text formats).
ODD_NUMBERS = ("NaN", "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "-1", "0", "-0.0", "99999999999999999999",
               "4294967296", "-7", "abc", "")
#: Values put in place of an HDF5 attribute.
ODD_ATTRIBUTES = (np.nan, np.inf, -1, 0, 2**62, np.array([1.0, 2.0]), "text", b"\xff\xfe", np.zeros((2, 2)), "")


class CaseTimeout(BaseException):
    """Raised by the alarm when one case runs longer than ``CASE_TIMEOUT_S`` (a BaseException: the CLI's own
    handler must not turn it into an answer)."""


@dataclass
class Outcome:
    kind: str
    mutation: str
    argv: list[str]
    code: int | None
    stderr: str
    seconds: float
    origin: str = ""  # for an internal error: path:line of the deepest gasfilm frame
    stdout: str = ""
    timeout_s: float = CASE_TIMEOUT_S

    @property
    def problem(self) -> str | None:
        """What is wrong with this outcome, or None."""
        if self.code is None:
            return f"hang: more than {self.timeout_s:g} s"
        lines = [line for line in self.stderr.splitlines() if line.strip()]
        if "internal error" in self.stderr or "Traceback" in self.stderr:
            return f"internal error at {self.origin}: {self.stderr.strip().splitlines()[-1]}"
        if self.code not in (0, 1, 2):  # 1: a replay that accepted no hit (its summary says why)
            return f"exit status {self.code}: {self.stderr.strip()[:300]}"
        if self.code == 2 and len(lines) != 1:
            return f"{len(lines)} lines on stderr: {' | '.join(lines)[:300]}"
        if "--json" in self.argv and self.code in (0, 1):
            return invalid_json(self.stdout)
        return None

    @property
    def cause(self) -> str:
        """The problem without file names and numbers, to count distinct causes."""
        text = re.sub(r"(?<= )/\S+|0x[0-9a-f]+|:\d+\b", "X", self.problem or "")
        return re.sub(r"[-+]?\d[\d.e+-]*", "N", text)[:160]


def invalid_json(text: str) -> str | None:
    """Why ``text`` is not one strict JSON document (NaN and Infinity are not JSON), or None."""
    def refuse(constant: str) -> None:
        raise ValueError(f"{constant} is not JSON")

    try:
        json.loads(text, parse_constant=refuse)
    except ValueError as error:
        return f"invalid JSON on stdout: {' '.join(str(error).split())[:200]}"
    return None


# --- the seed files ------------------------------------------------------------------------------------------------


def make_seeds(folder: Path) -> dict[str, list[Path]]:
    """Valid files of each kind to mutate: UFF time records (ASCII and binary) and an FRF export, a session with
    hits, a stored FRF and a rig spec, and the shipped rig specs."""
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings, compute_frf
    from gasfilm.analysis.uff import export_frf_uff
    from gasfilm.analysis.validation import ValidationSettings, Verdict, validate_hit
    from gasfilm.analysis.capture import TriggerSettings
    from gasfilm.drivers.interface import default_hammer_and_accelerometer
    from test_session import RATE_HZ, synthetic_hits

    folder.mkdir(parents=True, exist_ok=True)
    hits = synthetic_hits(3, seed=11, samples=512)
    session_path = folder / "seed-session.h5"
    settings = {"trigger": TriggerSettings(record_s=512 / RATE_HZ), "validation": ValidationSettings(),
                "window": WindowSettings()}
    rig_toml = RigSpec.load(ROOT / "fixtures" / "rigs" / "sd.toml").to_toml()
    with Session.create(session_path, default_hammer_and_accelerometer(RATE_HZ), rig_toml, settings,
                        sync_each_hit=False) as session:
        for hit in hits:
            session.append_hit(hit, validate_hit(hit))
        session.write_frf(compute_frf(np.stack([hit.data for hit in hits]), RATE_HZ))
    killed_path = folder / "seed-killed-session.h5"  # a writer killed mid-recording: its file left open for writing
    pid = os.fork()
    if pid == 0:
        try:
            killed = Session.create(killed_path, default_hammer_and_accelerometer(RATE_HZ), rig_toml, settings)
            for hit in hits:
                killed.append_hit(hit, validate_hit(hit))
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    uff_seeds = []
    for binary in (0, 1):
        datasets = []
        for hit in hits:
            for row, (node, data_type, units) in enumerate(((1, 13, "N"), (2, 12, "m/s^2"))):
                datasets.append(pyuff.prepare_58(
                    binary=binary, id1=f"hit {hit.index}", func_type=1, rsp_node=node, rsp_dir=3, ref_node=1,
                    ref_dir=3, abscissa_spacing=1, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
                    ordinate_spec_data_type=data_type, ordinate_axis_units_lab=units, orddenom_spec_data_type=0,
                    data=hit.data[row], x=np.arange(hit.data.shape[1]) / RATE_HZ))
        path = folder / f"seed-hits-{'binary' if binary else 'ascii'}.uff"
        pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
        uff_seeds.append(path)
    frf = compute_frf(np.stack([hit.data for hit in hits]), RATE_HZ)
    uff_seeds.append(export_frf_uff(frf, folder / "seed-frf.uff"))
    toml_seeds = []
    for spec in RIG_SPECS:
        toml_seeds.append(folder / f"seed-{spec.name}")
        shutil.copyfile(spec, toml_seeds[-1])
    npy_seeds = []
    for hit in hits:
        npy_seeds.append(folder / f"seed-hit{hit.index + 1}.npy")
        np.save(npy_seeds[-1], np.vstack((np.arange(hit.data.shape[1]) / RATE_HZ, hit.data)))
    from gasfilm.app.cli import main

    fit_seed = folder / "seed-fit.json"
    with contextlib.redirect_stdout(io.StringIO()) as printed:
        assert main(["fit", str(session_path), "--models", "SD,Zener", "--json", "--out", str(folder)]) == 0
    fit_seed.write_text(printed.getvalue())
    campaign_seed = folder / "seed-campaign"
    campaign_seed.mkdir()
    for number, pressure_mpa in enumerate((0.3, 0.6)):
        with Session.create(campaign_seed / f"s{number}.h5", default_hammer_and_accelerometer(RATE_HZ), rig_toml,
                            {**settings, "conditions": {"supply_pressure_mpa": pressure_mpa}},
                            sync_each_hit=False) as session:
            for hit in synthetic_hits(3, seed=number, samples=512):
                session.append_hit(hit, Verdict(True))
    sensors_seed = folder / "seed-sensors.toml"
    shutil.copyfile(ROOT / "fixtures" / "sensors.toml", sensors_seed)
    return {"uff": uff_seeds, "session": [session_path, killed_path], "toml": toml_seeds, "npy": npy_seeds,
            "fit-json": [fit_seed],
            "campaign": [campaign_seed], "sensors": [sensors_seed]}


# --- mutations -----------------------------------------------------------------------------------------------------


def _byte_flips(data: bytes, rng: np.random.Generator) -> bytes:
    buffer = bytearray(data)
    for _ in range(int(rng.integers(1, 9))):
        if buffer:
            buffer[int(rng.integers(len(buffer)))] ^= 1 << int(rng.integers(8))
    return bytes(buffer)


def _truncate(data: bytes, rng: np.random.Generator) -> bytes:
    return data[: int(rng.integers(0, max(1, len(data))))]


def _insert_bytes(data: bytes, rng: np.random.Generator) -> bytes:
    at = int(rng.integers(0, len(data) + 1))
    return data[:at] + rng.bytes(int(rng.integers(1, 64))) + data[at:]


def _delete_slice(data: bytes, rng: np.random.Generator) -> bytes:
    at = int(rng.integers(0, max(1, len(data))))
    return data[:at] + data[at + int(rng.integers(1, 512)):]


def _repeat_slice(data: bytes, rng: np.random.Generator) -> bytes:
    at = int(rng.integers(0, max(1, len(data))))
    piece = data[at: at + int(rng.integers(1, 2048))]
    return data[:at] + piece * int(rng.integers(2, 6)) + data[at:]


BYTE_MUTATIONS: dict[str, Callable[[bytes, np.random.Generator], bytes]] = {
    "byte flips": _byte_flips,
    "truncation": _truncate,
    "random bytes inserted": _insert_bytes,
    "slice deleted": _delete_slice,
    "slice repeated": _repeat_slice,
}

_NUMBER = re.compile(rb"(?<![A-Za-z_])[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def _replace_numbers(data: bytes, rng: np.random.Generator, keep_width: bool) -> bytes:
    matches = list(_NUMBER.finditer(data))
    if not matches:
        return data
    out = bytearray(data)
    for match in sorted((matches[int(i)] for i in rng.integers(0, len(matches), int(rng.integers(1, 4)))),
                        key=lambda m: m.start(), reverse=True):
        value = ODD_NUMBERS[int(rng.integers(len(ODD_NUMBERS)))].encode()
        if keep_width:  # UFF is a fixed-width format
            value = value.rjust(match.end() - match.start())[: match.end() - match.start()]
        out[match.start(): match.end()] = value
    return bytes(out)


def _lines_edit(data: bytes, rng: np.random.Generator) -> bytes:
    lines = data.split(b"\n")
    at = int(rng.integers(len(lines)))
    choice = int(rng.integers(3))
    if choice == 0:
        del lines[at]
    elif choice == 1:
        lines.insert(at, lines[at])
    else:
        del lines[at: at + int(rng.integers(2, 40))]
    return b"\n".join(lines)


def mutate_uff(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    choice = int(rng.integers(9))
    if choice < 5:
        name = list(BYTE_MUTATIONS)[choice]
        return name, BYTE_MUTATIONS[name](data, rng)
    if choice == 5:
        return "numbers replaced (fixed width)", _replace_numbers(data, rng, keep_width=True)
    if choice == 6:
        return "lines removed or repeated", _lines_edit(data, rng)
    if choice == 7:
        kind = [b"    58", b"    59", b"   164", b"    15", b"    -1", b"  58b "][int(rng.integers(6))]
        return "dataset type changed", re.sub(rb"(?m)^ {4}58(b?) *$", kind, data, count=int(rng.integers(1, 4)))
    # function type (first field of record 6 of a dataset 58): time response → FRF, coherence, nonsense
    new = [b"4", b"6", b"0", b"99", b"-3"][int(rng.integers(5))]
    return "function type changed", re.sub(rb"(?m)^(\s+)1(\s+\d+\s+\d+\s+\d+ +\S+ +\d+ +\d+ +\S+ +\d+ +\d+\s*)$",
                                           lambda m: m.group(1) + new + m.group(2), data, count=int(rng.integers(1, 7)))


def _deep_table(rng: np.random.Generator) -> str:
    depth = int(rng.integers(50, 5000))
    if rng.integers(2):
        return "[" * depth + "1" + "]" * depth
    return "{a = " * depth + "1" + "}" * depth


def mutate_toml(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    choice = int(rng.integers(10))
    if choice < 4:
        name = list(BYTE_MUTATIONS)[choice]
        return name, BYTE_MUTATIONS[name](data, rng)
    text = data.decode("utf-8")
    lines = text.splitlines()
    if choice == 4:
        return "numbers replaced", _replace_numbers(data, rng, keep_width=False)
    if choice == 5:
        keys = [i for i, line in enumerate(lines) if "=" in line]
        if keys:
            del lines[keys[int(rng.integers(len(keys)))]]
        return "key removed", "\n".join(lines).encode()
    if choice == 6:
        keys = [i for i, line in enumerate(lines) if "=" in line]
        at = keys[int(rng.integers(len(keys)))]
        lines[at] = lines[at].split("=")[0] + "= " + _deep_table(rng)
        return "table nested deep", "\n".join(lines).encode()
    if choice == 7:
        at = int(rng.integers(len(data) + 1))
        return "invalid UTF-8", data[:at] + bytes([0xFF, 0xC3, 0x28, 0xA0])[: int(rng.integers(1, 5))] + data[at:]
    if choice == 8:
        count = int(10 ** rng.uniform(2, 4.3))
        effect = f'\n[[effects]]\ntype = "extra-mode"\nfreq_hz = 640.0\ndamping_ratio = 0.02\nmass_kg = {rng.uniform(0, 1):.3f}\n'
        return f"{count} effects", (text + effect * count).encode()
    extreme = ["1e-300", "1e300", "1e30", "1e-30", "1e15", "5e-324", "1.7e308", "3", "-0.5", "2.0000001"]
    numbered = [i for i, line in enumerate(lines) if re.search(r"=\s*[-+]?\d", line)]
    for _ in range(int(rng.integers(1, 4))):
        at = numbered[int(rng.integers(len(numbered)))]
        lines[at] = lines[at].split("=")[0] + "= " + extreme[int(rng.integers(len(extreme)))]
    return "extreme values", "\n".join(lines).encode()


def _h5_objects(file: h5py.File) -> list[str]:
    names: list[str] = []
    file.visit(names.append)
    return names


def _odd_dataset(rng: np.random.Generator, old: np.ndarray | None) -> np.ndarray:
    choice = int(rng.integers(6))
    if old is not None and old.size and old.dtype.kind in "fc" and choice == 0:
        bad = np.array(old, copy=True)
        bad.flat[int(rng.integers(bad.size))] = np.nan
        return bad
    if old is not None and old.ndim and old.shape[0] > 1 and choice == 1:
        return old[: int(rng.integers(0, old.shape[0]))]
    if choice == 2:
        return np.zeros((0,))
    if choice == 3:
        return np.array(["text", "more"], dtype=h5py.string_dtype())
    if choice == 4:
        return np.full(int(rng.integers(1, 20)), [np.inf, -1.0, 1e308][int(rng.integers(3))])
    return rng.normal(size=tuple(int(n) for n in rng.integers(1, 6, int(rng.integers(1, 4)))))


def mutate_session(path: Path, rng: np.random.Generator) -> str:
    """Edit the session file at ``path`` in place; return what was done."""
    choice = int(rng.integers(10))
    try:
        h5py.File(path, "r").close()
    except OSError:  # a killed writer's file (HDF5 refuses to edit it): its bytes are damaged instead
        choice = choice % 3
    if choice < 3:
        name = list(BYTE_MUTATIONS)[choice]
        path.write_bytes(BYTE_MUTATIONS[name](path.read_bytes(), rng))
        return name
    with h5py.File(path, "r+") as file:
        objects = _h5_objects(file)
        target = objects[int(rng.integers(len(objects)))]
        item = file[target]
        if choice == 3:
            del file[target]
            return f"{target} deleted"
        if choice in (4, 5):
            holder = [file, item][int(rng.integers(2))]
            keys = list(holder.attrs)
            if not keys:
                return "nothing changed"
            key = keys[int(rng.integers(len(keys)))]
            where = holder.name.strip("/") or "/"
            if choice == 4:
                del holder.attrs[key]
                return f"{where} attribute {key} deleted"
            holder.attrs[key] = ODD_ATTRIBUTES[int(rng.integers(len(ODD_ATTRIBUTES)))]
            return f"{where} attribute {key} replaced"
        datasets = [name for name in objects if isinstance(file[name], h5py.Dataset)]
        target = datasets[int(rng.integers(len(datasets)))]
        old = file[target]
        if choice in (6, 7):
            values = old[()] if old.size < 10**6 else None
            del file[target]
            file[target] = _odd_dataset(rng, np.asarray(values) if values is not None else None)
            return f"{target} replaced"
        if choice == 8:
            del file[target]
            file.create_dataset(target, shape=(2**40, 2), maxshape=(None, 2), chunks=(1024, 2), dtype="f8")
            return f"{target} declared giant"
        if old.maxshape and old.maxshape[0] is None and old.ndim:
            old.resize(int(rng.integers(0, 2 * old.shape[0] + 3)), axis=0)
            return f"{target} resized"
        return "nothing changed"


_NPY_SHAPES = (b"(3, 99999999999999)", b"(3, 0)", b"(0,)", b"(3,)", b"(3, 512, 2)", b"(-3, 512)", b"(9223372036854775807, 3)")
_NPY_DTYPES = (b"'<i4'", b"'|O'", b"'>f8'", b"'|S10'", b"'<c16'", b"'<f2'", b"'<V8'", b"'<f8x'")


def mutate_npy(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    """A hit record's .npy file: its bytes, its header (shape, type, order, version) or its values."""
    choice = int(rng.integers(9))
    if choice < 4:
        name = list(BYTE_MUTATIONS)[choice]
        return name, BYTE_MUTATIONS[name](data, rng)
    if choice == 4:
        shape = _NPY_SHAPES[int(rng.integers(len(_NPY_SHAPES)))]
        return f"header shape {shape.decode()}", re.sub(rb"\(3, \d+\)", lambda _: shape, data, count=1)
    if choice == 5:
        dtype = _NPY_DTYPES[int(rng.integers(len(_NPY_DTYPES)))]
        return f"header type {dtype.decode()}", data.replace(b"'<f8'", dtype, 1)
    if choice == 6:
        edits = [(b"'fortran_order': False", b"'fortran_order': True"), (b"\x93NUMPY\x01", b"\x93NUMPY\x03"),
                 (b"{'descr'", b"{'descr' 'x'"), (b"}", b"(" * 40), (b"'descr'", b"'shape'")]
        old, new = edits[int(rng.integers(len(edits)))]
        return f"header edit {new[:20]!r}", data.replace(old, new, 1)
    record = np.load(io.BytesIO(data))
    if choice == 7:
        row, at = int(rng.integers(3)), int(rng.integers(record.shape[1]))
        record[row, at] = [np.nan, np.inf, 1e308, -1e308, 0.0][int(rng.integers(5))]
        what = "value replaced"
    else:
        what, record = [("one sample", record[:, :1]), ("two samples", record[:, :2]), ("four rows", np.vstack((record, record[:1]))),
                        ("transposed", record.T.copy()), ("time reversed", record[:, ::-1].copy()),
                        ("short record", record[:, :int(rng.integers(3, 40))]), ("float16", record.astype(np.float16)),
                        ("complex", record.astype(complex)), ("time constant", np.vstack((np.zeros(record.shape[1]), record[1:])))][
            int(rng.integers(9))]
    buffer = io.BytesIO()
    np.save(buffer, record)
    return what, buffer.getvalue()


_JSON_ODD = ("NaN", "Infinity", "-Infinity", "1e308", "-1e308", "0", "-1", "1e-320", '"text"', "null", "true", "[]", "{}",
             "[1, 2, 3]", "99999999999999999999999")


def mutate_fit_json(data: bytes, rng: np.random.Generator) -> tuple[str, bytes]:
    """The JSON of ``gasfilm fit --json``: its bytes, its numbers, its keys and its structure."""
    choice = int(rng.integers(8))
    if choice < 3:
        name = list(BYTE_MUTATIONS)[choice]
        return name, BYTE_MUTATIONS[name](data, rng)
    document = json.loads(data)
    paths = []

    def walk(node, path):  # noqa: ANN001
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, value in items:
            paths.append(path + [key])
            walk(value, path + [key])

    walk(document, [])
    target = paths[int(rng.integers(len(paths)))]
    holder = document
    for key in target[:-1]:
        holder = holder[key]
    if choice == 3:
        odd = _JSON_ODD[int(rng.integers(len(_JSON_ODD)))]
        holder[target[-1]] = "@@ODD@@"
        return f"{target} = {odd}", json.dumps(document).replace('"@@ODD@@"', odd).encode()
    if choice == 4:
        numbers = [path for path in paths if isinstance(_at(document, path), (int, float))]
        for path in (numbers[int(i)] for i in rng.integers(0, len(numbers), 3)):
            _set(document, path, [1e308, -1e308, 1e-300, 0.0, -1.0, 1e30][int(rng.integers(6))])
        return "numbers made extreme", json.dumps(document).encode()
    if choice == 5:
        if isinstance(holder, dict):
            del holder[target[-1]]
        else:
            holder.pop(target[-1])
        return f"{target} removed", json.dumps(document).encode()
    if choice == 6:
        depth = int(rng.integers(100, 100_000))
        holder[target[-1]] = "@@DEEP@@"
        return f"{target} nested {depth} deep", json.dumps(document).replace(
            '"@@DEEP@@"', "[" * depth + "1" + "]" * depth).encode()
    holder[target[-1]] = list(range(int(rng.integers(1000, 200_000))))
    return f"{target} made a long list", json.dumps(document).encode()


def _at(document, path):  # noqa: ANN001, ANN202
    for key in path:
        document = document[key]
    return document


def _set(document, path, value) -> None:  # noqa: ANN001
    _at(document, path[:-1])[path[-1]] = value


def mutate_campaign(folder: Path, rng: np.random.Generator) -> str:
    """A campaign's folder of sessions: one session damaged, or something that is not a session added."""
    choice = int(rng.integers(6))
    sessions = sorted(folder.glob("*.h5"))
    if choice < 3:
        return f"{sessions[0].name}: {mutate_session(sessions[int(rng.integers(len(sessions)))], rng)}"
    if choice == 3:
        (folder / "empty.h5").write_bytes(b"")
        (folder / "noise.h5").write_bytes(rng.bytes(int(rng.integers(1, 5000))))
        return "empty and random .h5 files added"
    if choice == 4:
        (folder / "folder.h5").mkdir()
        (folder / "dangling.h5").symlink_to(folder / "missing.h5")
        (folder / "loop.h5").symlink_to(folder / "loop.h5")
        return "a folder and broken links named .h5 added"
    for session in sessions:
        with h5py.File(session, "r+") as file:
            file["settings"].attrs["conditions"] = json.dumps(
                {"supply_pressure_mpa": [None, "0.4", [1], {"a": 1}, -1e308, 1e308, True][int(rng.integers(7))]})
    return "conditions replaced by odd values"


# --- running a case ------------------------------------------------------------------------------------------------


def _origin(error: BaseException) -> str:
    """``path:line`` of the deepest gasfilm frame of an exception's traceback (where gasfilm let it through)."""
    ours = [frame for frame in traceback.extract_tb(error.__traceback__)
            if Path(frame.filename).is_relative_to(ROOT) and not Path(frame.filename).is_relative_to(ROOT / ".venv")]
    return f"{Path(ours[-1].filename).relative_to(ROOT)}:{ours[-1].lineno}" if ours else "?"


def run_cli(argv: list[str], timeout_s: float = CASE_TIMEOUT_S) -> tuple[int | None, str, float, str, str]:
    """Run ``gasfilm argv`` in-process; the exit status (None on timeout), stderr, the seconds taken and, for an
    internal error, where in gasfilm it came from (the CLI runs with GASFILM_DEBUG=1 so that the traceback can be
    read; the line the user would see is rebuilt from it)."""
    from gasfilm.app.cli import main

    def alarm(signum, frame):  # noqa: ARG001
        raise CaseTimeout()

    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, alarm)
    debug = os.environ.get("GASFILM_DEBUG")
    os.environ["GASFILM_DEBUG"] = "1"
    start = time.perf_counter()
    code: int | None
    origin = ""
    try:
        signal.setitimer(signal.ITIMER_REAL, timeout_s)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = load_sensors(argv[1]) if argv[0] == "sensor-library" else main(argv)
            except SystemExit as exit_:  # argparse refusals
                code = int(exit_.code or 0)
            except Exception as error:  # what main prints as "internal error" without GASFILM_DEBUG
                code = 3
                origin = _origin(error)
                print(f"gasfilm {argv[0]}: internal error: {type(error).__name__}: {error}", file=sys.stderr)
    except CaseTimeout:
        code = None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        if debug is None:
            del os.environ["GASFILM_DEBUG"]
        else:
            os.environ["GASFILM_DEBUG"] = debug
    return code, err.getvalue(), time.perf_counter() - start, origin, out.getvalue()


def make_case(kind: str, seeds: dict[str, list[Path]], index: int, seed: int, work: Path,
              diagnose_every: int = 0) -> tuple[str, list[str]]:
    """Write case ``index`` of ``kind`` into ``work`` (a fresh folder); return the mutation and the command.
    Every ``diagnose_every``-th UFF or rig-spec case goes through ``diagnose`` (0: none; a diagnosis of an intact
    file takes seconds, too long for the test)."""
    rng = np.random.default_rng([seed, KINDS.index(kind), index])
    source = seeds[kind][int(rng.integers(len(seeds[kind])))]
    session = work / "session.h5"
    diagnosed = diagnose_every > 0 and index % diagnose_every == diagnose_every - 1
    if kind == "uff":
        mutation, data = mutate_uff(source.read_bytes(), rng)
        target = work / "case.uff"
        target.write_bytes(data)
        if diagnosed:
            return mutation, ["diagnose", str(target), "--out", str(work / "diagnosis")]
        return mutation, ["replay", str(target), "--out", str(work / "replayed.h5"), "--json"]
    if kind == "session":
        shutil.copyfile(source, session)
        mutation = mutate_session(session, rng)
        command = index % 30
        if command < 3:  # (the simulator's rate and record length are the session's own: the flags not typed)
            return mutation, ["acquire", "--device", "sim", "--pacing", "fast", "--hit-interval", "0.4", "0.6",
                              "--out", str(session), "--append", "--hits", "1"]
        if command < 15:
            return mutation, ["replay", str(session), "--json"]
        if command < 24:
            return mutation, ["export", str(session), "--csv", str(work / "frf.csv")]
        if command < 29:
            return mutation, ["export", str(session), "--uff", str(work / "frf.uff")]
        return mutation, ["fit", str(session), "--models", "SD", "--json", "--out", str(work)]
    if kind == "npy":
        mutation, data = mutate_npy(source.read_bytes(), rng)
        target = work / "hit.npy"
        target.write_bytes(data)
        others = []
        for number, other in enumerate(seeds["npy"][:2]):
            others.append(work / f"other{number}.npy")
            shutil.copyfile(other, others[-1])
        if diagnosed:
            return mutation, ["diagnose", str(target), *map(str, others), "--out", str(work / "diagnosis")]
        return mutation, [
            ["replay", str(target), "--json"], ["replay", str(target), "--exp-end", "0.01"],
            ["replay", str(target), "--force-window-ms", "2", "--json"],
            ["fit", str(target), *map(str, others), "--models", "SD", "--json", "--out", str(work)],
            ["export", str(target), *map(str, others), "--csv", str(work / "frf.csv")]][index % 5]
    if kind == "fit-json":
        mutation, data = mutate_fit_json(source.read_bytes(), rng)
        target = work / "fit.json"
        target.write_bytes(data)
        return mutation, [["model", str(target), "--model", "SD", "--out", str(work / "model.json"), "--json"],
                          ["model", str(target), "--model", "Zener", "--order", "4", "--out", str(work / "m.npz")],
                          ["model", str(target), "--out", str(work / "m.mat")]][index % 3]
    if kind == "campaign":
        folder = work / "sessions"
        shutil.copytree(source, folder)
        mutation = mutate_campaign(folder, rng)
        cluster = ["--scheduler", CAMPAIGN_SCHEDULER[0]] if CAMPAIGN_SCHEDULER else ["--workers", "1"]
        return mutation, ["campaign", str(folder), "--by", "supply_pressure_mpa", "--models", "SD", "--no-diagnosis",
                          *cluster, "--out", str(work / "campaign")]
    if kind == "sensors":
        mutation, data = mutate_toml(source.read_bytes(), rng)
        target = work / "sensors.toml"
        target.write_bytes(data)
        return mutation, ["sensor-library", str(target)]
    mutation, data = mutate_toml(source.read_bytes(), rng)
    target = work / "rig.toml"
    target.write_bytes(data)
    if diagnosed:
        shutil.copyfile(seeds["session"][0], session)
        return mutation, ["diagnose", str(session), "--rig", str(target), "--out", str(work / "diagnosis")]
    return mutation, ["acquire", "--device", "sim", "--rig", str(target), "--pacing", "fast", "--seconds", "3",
                      "--rate", "2560", "--record-s", "0.2", "--hit-interval", "0.4", "0.6",
                      "--out", str(work / "acquired.h5")]


#: A running dask scheduler's address for the campaign cases (the benchmark starts one: a cluster per case would take
#: most of the time); empty: each case starts its own one-worker cluster.
CAMPAIGN_SCHEDULER: list[str] = []


def load_sensors(path: str) -> int:
    """The GUI's sensor library read as its Setup tab reads it, answered like a command: 0, or 2 and one line."""
    from gasfilm.app.gui.sensors import load_sensor_library
    from gasfilm.drivers.errors import GasfilmError

    try:
        load_sensor_library(path)
    except GasfilmError as error:
        print(f"sensor library: error: {error}", file=sys.stderr)
        return 2
    return 0


def run_case(kind: str, seeds: dict[str, list[Path]], index: int, seed: int, work: Path,
             diagnose_every: int = 0, timeout_s: float = CASE_TIMEOUT_S) -> Outcome:
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    mutation, argv = make_case(kind, seeds, index, seed, work, diagnose_every)
    code, stderr, seconds, origin, stdout = run_cli(argv, timeout_s)
    return Outcome(kind, mutation, argv, code, stderr, seconds, origin, stdout, timeout_s)


# --- the test ------------------------------------------------------------------------------------------------------

#: The suite samples each kind (a new seed each run of the benchmark: benchmarks/bench_fuzz.py runs 10 000 cases).
CASES_PER_KIND = {"uff": 75, "session": 60, "toml": 50, "npy": 40, "fit-json": 25, "campaign": 2, "sensors": 40}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, list[Path]]:
    return make_seeds(tmp_path_factory.mktemp("fuzz-seeds"))


@pytest.mark.parametrize("kind", KINDS)
def test_damaged_files_get_one_line_answers_in_time(kind, seeds, tmp_path):
    problems = []
    answers = 0
    for index in range(CASES_PER_KIND[kind]):
        outcome = run_case(kind, seeds, index, 2026, tmp_path / "case")
        if outcome.problem:
            problems.append(f"case {index} ({outcome.mutation}; gasfilm {outcome.argv[0]}): {outcome.problem}")
        answers += outcome.code == 2
    assert not problems, "\n".join(problems)
    assert answers >= CASES_PER_KIND[kind] // 8  # the mutations do damage: many files are refused, with a reason


# --- the damage classes of issue 10 item 8, one by one ------------------------------------------------------------

SD_SPEC = (ROOT / "fixtures" / "rigs" / "sd.toml").read_text()


def refusal(argv: list[str]) -> str:
    """The one line gasfilm answers ``argv`` with (exit status 2), at once (the command modules loaded first)."""
    from gasfilm.app.cli import build_parser

    build_parser()
    code, stderr, seconds, origin, _ = run_cli(argv)
    assert code == 2 and not origin, stderr
    assert seconds < 3.0
    (line,) = stderr.strip().splitlines()
    return line


def acquire_with(spec: Path, work: Path) -> list[str]:
    return ["acquire", "--device", "sim", "--rig", str(spec), "--pacing", "fast", "--seconds", "2",
            "--out", str(work / "out.h5")]


@pytest.mark.parametrize(
    "text, expected",
    [
        (SD_SPEC.encode().replace(b"SD film", b"SD \xff\xfe film"), r"not UTF-8 text \(byte 0xff at position \d+\)"),
        (SD_SPEC.replace("mass_kg = 25.05", "mass_kg = " + "[" * 3000 + "1" + "]" * 3000).encode(),
         "nested too deeply"),
        (SD_SPEC.replace("mass_kg = 25.05", "mass_kg = 2e-4").encode(), r"mass_kg' = 0.0002: must be ≥ 0.001"),
        (SD_SPEC.replace("mass_kg = 25.05", "mass_kg = 3e4").encode(), r"must be ≥ 0.001 and ≤ 10000 \(kg\)"),
        (SD_SPEC.replace("k = 37800000.0", "k = 1e300").encode(), r"k' = 1e\+300: must be ≥ 100 and ≤ 1e\+12"),
        (SD_SPEC.replace("k = 37800000.0", "k = 1e12").replace("mass_kg = 25.05", "mass_kg = 0.001").encode(),
         "resonates with the 0.001 kg mass above 50000 Hz"),
        (SD_SPEC.replace("k = 37800000.0", "k = 100").replace("eta = 3450.0", "eta = 0.01")
         .replace("mass_kg = 25.05", "mass_kg = 1e4").encode(), "resonates with the 10000 kg mass below 0.1 Hz"),
        (SD_SPEC.replace("eta = 3450.0", "eta = 1e10").replace("mass_kg = 25.05", "mass_kg = 0.001").encode(),
         "resonates .* above 50000 Hz"),
        (SD_SPEC.replace("eta = 3450.0", "eta = nan").encode(), "must be a finite number"),
        (SD_SPEC.replace('model = "SD"', 'model = "' + "(" * 2000 + "k" + ")" * 2000 + '"').encode(),
         "film.model': 4001 characters"),
        (SD_SPEC.replace("sensitivity_mv_per_n = 11.2", "sensitivity_mv_per_n = 1e-300").encode(),
         "sensitivity_mv_per_n' = 1e-300: must be ≥ 0.001"),
        ((SD_SPEC + '\n[[effects]]\ntype = "added-mass"\nmass_kg = 0.1\n' * 10_000).encode(),
         "10000 effects; a rig spec has at most 64"),
        (SD_SPEC.replace("[sensors.force]", '[[effects]]\ntype = "extra-mode"\nfreq_hz = 640.0\n'
                         'damping_ratio = 1e300\nmass_kg = 0.8\n\n[sensors.force]').encode(),
         r"damping_ratio' = 1e\+300: outside the physical range, at most 10"),
    ],
    ids=["invalid-utf8", "deep-nesting", "tiny-mass", "giant-mass", "absurd-film", "stiff-film", "soft-film",
         "overdamped-film",
         "nan", "deep-network", "absurd-sensor", "10000-effects", "absurd-effect"],
)
def test_rig_spec_damage_is_refused_in_one_line_before_any_computing(text, expected, tmp_path):
    spec = tmp_path / "rig.toml"
    spec.write_bytes(text)
    line = refusal(acquire_with(spec, tmp_path))
    assert line.startswith(f"gasfilm acquire: error: {spec}")
    assert re.search(expected, line), line


def test_the_shipped_rig_specs_still_load():
    from gasfilm.analysis.physics.spec import RigSpec

    for path in RIG_SPECS:
        assert RigSpec.load(path).mass_kg == pytest.approx(25.05)


@pytest.fixture(scope="module")
def uff_seed(tmp_path_factory) -> bytes:
    return make_seeds(tmp_path_factory.mktemp("uff-seed"))["uff"][0].read_bytes()


@pytest.mark.parametrize(
    "edit, expected",
    [
        (lambda data: data[: len(data) // 2], "force records but 1 response records"),
        (lambda data: b"", "empty UFF file"),
        (lambda data: data.replace(b"6.79873770155e-02", b"NaN".rjust(17), 1), "dataset 1 .* has NaN samples"),
        (lambda data: re.sub(rb"(?m)^    1(\s+0\s+0\s+0 +NONE)", rb"    4\g<1>", data), r"holds an FRF but no time records"),
        (lambda data: re.sub(rb"(?m)^    1(\s+0\s+0\s+0 +NONE)", rb"    6\g<1>", data, count=1),
         "2 force records but 3 response records"),
        (lambda data: data.replace(b"3.90625e-04", b"1.00000e-30"), r"sampled at 1e\+30 S/s"),
    ],
    ids=["truncated", "empty", "nan", "frf-function-type", "coherence-function-type", "absurd-rate"],
)
def test_uff_damage_is_refused_in_one_line(uff_seed, edit, expected, tmp_path):
    damaged = tmp_path / "damaged.uff"
    damaged.write_bytes(edit(uff_seed))
    line = refusal(["replay", str(damaged), "--out", str(tmp_path / "out.h5")])
    assert line.startswith(f"gasfilm replay: error: {damaged}: ")
    assert re.search(expected, line), line


def test_uff_records_of_absurd_magnitude_or_mismatched_length_are_refused(tmp_path):
    from gasfilm.analysis.uff import UffError, read_uff_time_records

    def write(force, response):
        path = tmp_path / "records.uff"
        datasets = [pyuff.prepare_58(binary=0, func_type=1, rsp_node=node, rsp_dir=3, ref_node=1, ref_dir=3,
                                     abscissa_spacing=1, abscissa_spec_data_type=17, ordinate_spec_data_type=kind, orddenom_spec_data_type=0,
                                     ordinate_axis_units_lab=units, data=values, x=np.arange(values.size) / 2560.0)
                    for node, kind, units, values in ((1, 13, "N", force), (2, 12, "m/s^2", response))]
        pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
        return path

    pulse = np.zeros(256)
    pulse[10:14] = 100.0
    with pytest.raises(UffError, match=r"records.uff: dataset 1 \(force time record of hit 1\) holds values beyond"):
        read_uff_time_records(write(pulse * 1e12, pulse))
    with pytest.raises(UffError, match=r"records.uff: time records have inconsistent lengths \(200, 256 samples\)"):
        read_uff_time_records(write(pulse, pulse[:200]))


# --- the causes of issue 15 item 26, one by one --------------------------------------------------------------------


def _set_channel_units(file: h5py.File) -> None:
    config = json.loads(file["daq"].attrs["config"])
    config["channels"][0]["sensitivity_units"] = "mV/g"  # an acceleration unit on the force channel
    file["daq"].attrs["config"] = json.dumps(config)


def _set_hit_sample_rate(file: h5py.File) -> None:
    row = file["hits/table"][1]
    row["sample_rate_hz"] = 1e308
    file["hits/table"][1] = row


def _scale_hit_record(file: h5py.File) -> None:
    records = file["hits/data"][()]
    records[1, 1] *= 1e200  # finite, but beyond any accelerometer: squaring it overflowed in the replay
    file["hits/data"][...] = records


@pytest.mark.parametrize(
    "edit, expected, command",
    [
        (_set_channel_units, r"the DAQ configuration cannot be read \(channel 0 is a force sensor with sensitivity "
                             r"units 'mV/g'\)", "replay"),
        (_set_channel_units, r"channel 0 is a force sensor with sensitivity units 'mV/g'", "export"),
        (_set_hit_sample_rate, r"hit 2 has sample rate 1e\+308, out of range", "replay"),
        (_scale_hit_record, r"hit 2 has samples beyond 1e\+08 m/s\^2 in channel 1 \(accelerometer\)", "replay"),
    ],
    ids=["replay-channel-kind-and-units-disagree", "export-channel-kind-and-units-disagree", "replay-hit-rate-1e308",
         "replay-record-1e200"],
)
def test_session_damage_found_by_fuzzing_is_refused_in_one_line(seeds, edit, expected, command, tmp_path):
    session = tmp_path / "damaged.h5"
    shutil.copyfile(seeds["session"][0], session)
    with h5py.File(session, "r+") as file:
        edit(file)
    argv = {"replay": ["replay", str(session), "--json"],
            "export": ["export", str(session), "--csv", str(tmp_path / "frf.csv")]}[command]
    line = refusal(argv)
    assert line.startswith(f"gasfilm {command}: error: {session}: damaged session: "), line
    assert re.search(expected, line), line


def test_response_decay_at_an_absurd_sample_rate_prints_nothing(capfd):
    """A record's decay is fitted against samples, so no sample rate makes the fit ill-conditioned (LAPACK printed
    "On entry to DLASCL parameter number 4 had an illegal value" and numpy raised LinAlgError at 1e308 S/s)."""
    from gasfilm.analysis.validation import response_decay

    samples = np.arange(4096)
    ringing = np.exp(-samples / 3000) * np.sin(0.3 * samples)
    decays = [response_decay(ringing, 100, rate, noise_rms=1e-6) for rate in (2560.0, 1e308, 1e-300)]
    assert all(decay is not None for decay in decays)
    assert decays[0].end_ratio == pytest.approx(decays[1].end_ratio) == pytest.approx(decays[2].end_ratio)
    assert decays[1].decay_rate_1_s > 1e300
    captured = capfd.readouterr()
    assert captured.out == "" and captured.err == ""


def test_replays_of_odd_but_readable_sessions_print_no_warnings(seeds, tmp_path):
    """Issue 15 item 26: numpy overflow warnings were printed on replays that succeed."""
    def huge_start_time(file: h5py.File) -> None:
        row = file["hits/table"][1]
        row["start_time_s"] = 1e300
        file["hits/table"][1] = row

    for edit in (lambda file: None, huge_start_time):
        session = tmp_path / "odd.h5"
        shutil.copyfile(seeds["session"][0], session)
        with h5py.File(session, "r+") as file:
            edit(file)
        code, stderr, _, origin, _ = run_cli(["replay", str(session), "--json"])
        assert code in (0, 1) and not origin and "Warning" not in stderr, stderr


def test_damaged_frf_uff_files_are_read_or_refused_with_a_reason(seeds, tmp_path):
    """``fit`` reads an FRF-only UFF (issue 15 item 1): a damaged one is read or refused with a UffError, never an
    internal error; a few go through the whole command (one line, in time)."""
    from gasfilm.analysis.uff import UffError, read_uff_frf

    frf_seed = next(path for path in seeds["uff"] if path.name == "seed-frf.uff").read_bytes()
    problems = []
    for index in range(60):
        rng = np.random.default_rng([2026, 15, index])
        mutation, data = mutate_uff(frf_seed, rng)
        path = tmp_path / f"case{index}.uff"
        path.write_bytes(data)
        try:
            frf = read_uff_frf(path)
        except UffError:
            continue
        except Exception as error:  # noqa: BLE001 - what the test looks for
            problems.append(f"case {index} ({mutation}): {type(error).__name__}: {error}")
            continue
        if frf is not None and not (np.all(np.isfinite(frf.h1)) and np.all(np.diff(frf.freq_hz) > 0)):
            problems.append(f"case {index} ({mutation}): an FRF with NaN or unordered lines was read")
        if index % 20 == 0:
            argv = ["fit", str(path), "--models", "SD", "--json", "--out", str(tmp_path)]
            outcome = Outcome("uff", mutation, argv, *run_cli(argv, timeout_s=3 * CASE_TIMEOUT_S),
                              timeout_s=3 * CASE_TIMEOUT_S)
            if outcome.problem:
                problems.append(f"case {index} ({mutation}): {outcome.problem}")
    assert not problems, "\n".join(problems)
