"""Damaged session files: a few hundred mutations of a real session (bit flips anywhere and in the metadata,
truncations, h5py-level edits of attributes, groups, datasets and shapes) are opened, read and appended to through the
public API. Each answer is either a good read or one GasfilmError line naming the file, within 10 s."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest

from gasfilm.analysis.capture import TriggerSettings
from gasfilm.analysis.session import Session
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.validation import Verdict
from gasfilm.drivers.errors import GasfilmError
from test_session import RATE_HZ, new_session, synthetic_hits

SEED = 20261122
SAMPLES = 512
RANDOM_FLIPS = 60
METADATA_FLIPS = 60
TRUNCATIONS = 12
HUGE = 2**40


def write_base_session(path) -> None:
    """A small session with hits (one rejected), an FRF, a fit and a diagnosis."""
    hits = synthetic_hits(4, samples=SAMPLES, double_hit=(2,))
    with new_session(path) as session:
        for hit in hits:
            session.append_hit(hit, Verdict(hit.index != 2, ("double hit",) if hit.index == 2 else ()))
        frf = compute_frf(session.accepted_records(), RATE_HZ, WindowSettings())
        session.write_frf(frf, hit_indices=session.accepted_indices())
        session.write_fit("SD", {"params": np.array([1.5, 2.5e6]), "rms": 0.25, "bounds": {"k": [0, 1e8]}})
        session.write_diagnosis("mismatch", {"findings": [{"effect": "added mass"}], "rms_before": 2.0})


@pytest.fixture(scope="module")
def base_session(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "base.h5"
    write_base_session(path)
    return path


def read_everything(path) -> None:
    """What the commands and the GUI read from a session, then an append as ``acquire --append`` makes it."""
    with Session.open(path) as session:
        (session.schema_version, session.status, session.status_reason, session.daq_config, session.sample_rate_hz,
         session.requested_sample_rate_hz, session.device_name, session.rig_spec_toml, session.settings,
         session.record_samples, session.hit_count)
        session.settings_as("trigger", TriggerSettings)
        session.verdicts()
        session.hits()
        session.accepted_records()
        for name in session.result_names("frf"):
            session.read_frf(name)
            session.frf_hit_indices(name)
        for name in session.result_names("fits"):
            session.read_fit(name)
        for name in session.result_names("diagnoses"):
            session.read_diagnosis(name)
    with Session.open(path, "a") as session:
        session.verdicts()
        session.update_settings({"trigger": TriggerSettings()})
        hit = synthetic_hits(1, samples=session.record_samples or SAMPLES)[0]
        session.append_hit(hit, Verdict(True))


def flip_bit(offset: int, bit: int):
    def mutate(path) -> None:
        with open(path, "r+b") as file:
            file.seek(offset)
            byte = file.read(1)[0]
            file.seek(offset)
            file.write(bytes([byte ^ (1 << bit)]))

    return mutate


def truncate(size: int):
    def mutate(path) -> None:
        with open(path, "r+b") as file:
            file.truncate(size)

    return mutate


def edit(change):
    """An edit made with h5py on the closed file."""

    def mutate(path) -> None:
        with h5py.File(path, "a") as file:
            change(file)

    return mutate


def set_attr(where: str, name: str, value):
    return edit(lambda f: f[where].attrs.__setitem__(name, value))


def delete(name: str):
    return edit(lambda f: f.__delitem__(name))


def replace_dataset(name: str, **options):
    def change(f) -> None:
        del f[name]
        f.create_dataset(name, **options)

    return edit(change)


def resize(name: str, shape: tuple):
    return edit(lambda f: f[name].resize(shape))


def set_row_field(field: str, value, row: int = 1):
    def change(f) -> None:
        rows = f["hits/table"][()]
        rows[field][row] = value
        f["hits/table"][...] = rows

    return edit(change)


def set_sample(value):
    return edit(lambda f: f["hits/data"].__setitem__((1, 0, 10), value))


def edit_config(change_config):
    def change(f) -> None:
        config = json.loads(f["daq"].attrs["config"])
        f["daq"].attrs["config"] = json.dumps(change_config(config))

    return edit(change)


def structural_edits() -> dict[str, object]:
    edits: dict[str, object] = {}
    for value in (np.nan, np.array([1, 2]), "1", -1, 0, HUGE, 1.5, True, np.array([[1]])):
        edits[f"schema_version={value!r}"] = set_attr("/", "schema_version", value)
    for value in (np.array([1, 2]), b"gasfilm-session", 7):
        edits[f"format={value!r}"] = set_attr("/", "format", value)
    edits["format deleted"] = edit(lambda f: f.attrs.__delitem__("format"))
    for value in (np.array([1, 2]), 3, b"\xff\xfe"):
        edits[f"status={value!r}"] = set_attr("/", "status", value)
    for name in ("rig", "daq", "settings", "hits", "frf", "fits", "diagnoses", "hits/data", "hits/table",
                 "rig/spec_toml", "frf/frf", "frf/frf/h1", "frf/frf/freq_hz", "fits/SD/params"):
        edits[f"delete {name}"] = delete(name)
    edits["spec_toml numbers"] = replace_dataset("rig/spec_toml", data=np.arange(3))
    edits["spec_toml group"] = edit(lambda f: (f.__delitem__("rig/spec_toml"), f.create_group("rig/spec_toml")))
    edits["rig present array"] = set_attr("rig", "present", np.array([1, 0]))
    for value in ("{not json", "[1, 2]", "null", '{"channels": 3}', "1e999"):
        edits[f"daq config {value}"] = set_attr("daq", "config", value)
    edits["daq config: kind"] = edit_config(lambda c: {**c, "channels": [{**c["channels"][0], "kind": "x"}] * 2})
    edits["daq config: 3 channels"] = edit_config(lambda c: {**c, "channels": c["channels"] + c["channels"][:1]})
    edits["daq config: 1 channel"] = edit_config(lambda c: {**c, "channels": c["channels"][:1]})
    edits["daq config: no channels"] = edit_config(lambda c: {**c, "channels": []})
    edits["daq config: rate text"] = edit_config(lambda c: {**c, "sample_rate_hz": "fast"})
    edits["daq config: sensitivity"] = edit_config(
        lambda c: {**c, "channels": [{**ch, "sensitivity": None} for ch in c["channels"]]})
    for value in (np.array([1.0, 2.0]), "fast", np.nan):
        edits[f"sample_rate_hz={value!r}"] = set_attr("daq", "sample_rate_hz", value)
    edits["device array"] = set_attr("daq", "device", np.arange(4))
    for value in ("{not json", '{"level_n": "high"}', '{"record_s": -1}', '{"level_n": [1, 2]}', "[]"):
        edits[f"settings trigger {value}"] = set_attr("settings", "trigger", value)
    edits["settings number"] = set_attr("settings", "window", 5)
    for field, value in (("force_channel", 7), ("force_channel", -1), ("response_channel", 9),
                         ("sample_rate_hz", 0.0), ("sample_rate_hz", np.nan), ("trigger_index", HUGE),
                         ("trigger_index", -5), ("start_time_s", np.inf), ("reasons", b"\xff\xfe\xfd")):
        edits[f"row {field}={value!r}"] = set_row_field(field, value)
    edits["last row zero sample rate"] = set_row_field("sample_rate_hz", 0.0, row=3)
    edits["NaN sample"] = set_sample(np.nan)
    edits["inf sample"] = set_sample(np.inf)
    edits["data declares 2^40 hits"] = resize("hits/data", (HUGE, 2, SAMPLES))
    edits["table declares 2^40 hits"] = resize("hits/table", (HUGE,))
    edits["both declare 2^40 hits"] = edit(lambda f: (f["hits/data"].resize((HUGE, 2, SAMPLES)),
                                                      f["hits/table"].resize((HUGE,))))
    edits["data declares 2^32 samples"] = resize("hits/data", (4, 2, 2**32))
    edits["data fewer samples"] = resize("hits/data", (4, 2, 3))
    edits["data no samples"] = resize("hits/data", (4, 2, 0))
    edits["data integers"] = replace_dataset("hits/data", data=np.zeros((4, 2, SAMPLES), dtype=np.int16))
    edits["data 2-D"] = replace_dataset("hits/data", data=np.zeros((4, SAMPLES)))
    edits["data 3 channels"] = replace_dataset("hits/data", data=np.zeros((4, 3, SAMPLES)))
    edits["table floats"] = replace_dataset("hits/table", data=np.zeros(4))
    edits["table missing column"] = replace_dataset(
        "hits/table", data=np.zeros(4, dtype=[("accepted", "?"), ("sample_rate_hz", "<f8")]))
    edits["table 2-D"] = replace_dataset("hits/table", data=np.zeros((4, 2)))
    for field in ("h1", "coherence", "h1_std_scatter", "h1_per_hit"):
        edits[f"frf {field} short"] = replace_dataset(f"frf/frf/{field}", data=np.ones(7))
    edits["frf freq_hz 2-D"] = replace_dataset("frf/frf/freq_hz", data=np.ones((3, 3)))
    edits["frf h1_per_hit wide"] = replace_dataset("frf/frf/h1_per_hit", data=np.ones((3, 9999)))
    edits["frf n_averages array"] = set_attr("frf/frf", "n_averages", np.arange(3))
    edits["frf window bad json"] = set_attr("frf/frf", "window", "{oops")
    edits["frf json_keys bad"] = set_attr("frf/frf", "json_keys", "[not json")
    edits["frf json_keys number"] = set_attr("frf/frf", "json_keys", "7")
    edits["frf hit_indices text"] = replace_dataset("frf/frf/hit_indices", data=np.array([b"a", b"b"]))
    edits["fit declares 2^40 values"] = replace_dataset("fits/SD/params", shape=(HUGE,), maxshape=(None,),
                                                        chunks=(1024,), dtype="<f8")
    edits["frf declares 2^40 lines"] = replace_dataset("frf/frf/freq_hz", shape=(HUGE,), maxshape=(None,),
                                                       chunks=(1024,), dtype="<f8")
    edits["fit group in group"] = edit(lambda f: f["fits/SD"].create_group("nested"))
    edits["diagnosis json bad"] = set_attr("diagnoses/mismatch", "findings", "{oops")
    return edits


def raw_chunk_ranges(path) -> list[tuple[int, int]]:
    ranges = []
    with h5py.File(path, "r", swmr=True, locking=False) as f:
        f["hits/data"].id.chunk_iter(lambda chunk: ranges.append((chunk.byte_offset, chunk.byte_offset + chunk.size)))
    return ranges


def byte_mutations(path, random_flips: int, metadata_flips: int, truncations: int) -> dict[str, object]:
    """Bit flips anywhere, bit flips outside the hit records (HDF5's metadata, the table, the results), truncations."""
    rng = np.random.default_rng(SEED)
    size = path.stat().st_size
    mutations = {}
    for offset in rng.integers(0, size, random_flips):
        mutations[f"flip byte {offset}"] = flip_bit(int(offset), int(rng.integers(8)))
    raw = raw_chunk_ranges(path)
    metadata = np.array([offset for offset in range(size) if not any(lo <= offset < hi for lo, hi in raw)])
    for offset in rng.choice(metadata, metadata_flips, replace=False):
        mutations[f"flip metadata byte {offset}"] = flip_bit(int(offset), int(rng.integers(8)))
    for cut in rng.integers(0, size, truncations):
        mutations[f"truncate to {cut}"] = truncate(int(cut))
    return mutations


def test_damaged_sessions_give_one_line_naming_the_file(base_session, tmp_path):
    mutations = {**structural_edits(), **byte_mutations(base_session, RANDOM_FLIPS, METADATA_FLIPS, TRUNCATIONS)}
    assert len(mutations) >= 200
    check_answers(mutations, base_session, tmp_path, min_refused=100)


def test_damaged_files_of_a_killed_writer_give_one_line_naming_the_file(tmp_path):
    """The same for a file whose writer was killed (read through the unclosed-file check, recovered to append)."""
    path = tmp_path / "killed.h5"
    script = textwrap.dedent(
        f"""
        import os, signal, sys
        sys.path.insert(0, {os.path.dirname(__file__)!r})
        from test_session_fuzz import write_base_session
        from test_session import synthetic_hits
        from gasfilm.analysis.session import Session
        from gasfilm.analysis.validation import Verdict
        write_base_session({str(path)!r})
        session = Session.open({str(path)!r}, "a")
        session.append_hit(synthetic_hits(1, samples={SAMPLES})[0], Verdict(True))
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    assert subprocess.run([sys.executable, "-c", script], timeout=60).returncode == -9
    check_answers(byte_mutations(path, 0, 10, 4), path, tmp_path, min_refused=4)


def check_answers(mutations: dict[str, object], original, tmp_path, min_refused: int) -> None:
    """Each mutation of ``original`` is read, or refused with one GasfilmError line naming the file, within 10 s."""
    outcomes: dict[str, int] = {"read": 0, "refused": 0}
    failures = []
    for number, (name, mutate) in enumerate(mutations.items()):
        path = tmp_path / f"m{number}.h5"
        shutil.copyfile(original, path)
        mutate(path)
        started = time.monotonic()
        try:
            read_everything(path)
            outcomes["read"] += 1
        except GasfilmError as error:
            outcomes["refused"] += 1
            message = str(error)
            if "\n" in message or str(path) not in message:
                failures.append(f"{name}: not one line naming the file: {message!r}")
        except BaseException as error:  # noqa: BLE001 - the point of the test
            failures.append(f"{name}: {type(error).__name__}: {error}")
        elapsed_s = time.monotonic() - started
        if elapsed_s > 10:
            failures.append(f"{name}: took {elapsed_s:.1f} s")
        path.unlink(missing_ok=True)
    print(f"\n{len(mutations)} mutations: {outcomes}")
    assert not failures, "\n".join(failures)
    assert outcomes["refused"] >= min_refused  # the mutations are damage, not only noise
