"""The session file's layout and codecs: constants, the hit-table dtype, settings, DAQ configuration and result
mappings to and from HDF5 attributes and datasets."""

from __future__ import annotations

import dataclasses
import datetime
import enum
import json
import math
import re
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import SENSITIVITY_UNITS, ChannelConfig, ChannelKind, Coupling, DaqConfig

SCHEMA_VERSION = 1
FORMAT_NAME = "gasfilm-session"
REASONS_LENGTH = 256
MAX_SAMPLES_PER_CHUNK = 16384  # per channel: 128 KiB per channel and chunk
DEFAULT_SAMPLES_PER_CHUNK = 4096  # when the record length is not known in advance
#: A recording's sample rate above this is damage, not a test (the NI 9234 runs at up to 51.2 kS/s).
MAX_SAMPLE_RATE_HZ = 1e7
#: Largest magnitudes a recorded sample may have in SI units, by channel kind: beyond them a file is damaged.
MAX_ABS_SI = {ChannelKind.FORCE: 1e7, ChannelKind.ACCELERATION: 1e8}  # N, m/s²


class SessionError(GasfilmError):
    """A session file is missing, damaged, foreign, too new, or holds unusable data."""


class SessionWriteError(SessionError):
    """Writing to a session failed or was refused (full disk, I/O error, size limit): recording must stop; the hits
    stored before are kept."""



def to_jsonable(value: Any) -> Any:
    """Plain JSON types for settings: dataclasses, enums, numpy values, tuples and paths included."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {field.name: to_jsonable(getattr(value, field.name)) for field in dataclasses.fields(value)}
    if isinstance(value, enum.Enum):
        return to_jsonable(value.value)
    if isinstance(value, Mapping):
        return {str(key): to_jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, complex):
        return {"real": value.real, "imag": value.imag}
    if isinstance(value, Path):
        return str(value)
    return value


def json_dumps(value: Any) -> str:
    return json.dumps(to_jsonable(value), allow_nan=True)


def utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def hit_table_dtype(channel_count: int) -> np.dtype:
    return np.dtype(
        [
            ("accepted", "?"),
            ("overridden", "?"),
            ("reasons", f"S{REASONS_LENGTH}"),
            ("start_time_s", "<f8"),
            ("trigger_index", "<i8"),
            ("capture_index", "<i8"),
            ("sample_rate_hz", "<f8"),
            ("force_channel", "<i2"),
            ("response_channel", "<i2"),
            ("overload", "?", (channel_count,)),
        ]
    )


def encode_reasons(reasons: tuple[str, ...], path: Path) -> bytes:
    for reason in reasons:
        if ";" in reason:
            raise SessionError(f"{path}: hit reason '{reason}' contains ';', which separates stored reasons")
    encoded = "; ".join(reasons).encode("utf-8")
    if len(encoded) > REASONS_LENGTH:
        raise SessionError(f"{path}: hit reasons '{'; '.join(reasons)}' exceed {REASONS_LENGTH} bytes")
    return encoded


def decode_reasons(raw: bytes) -> tuple[str, ...]:
    text = raw.decode("utf-8")
    return tuple(reason for reason in text.split("; ") if reason)


def config_to_dict(config: DaqConfig) -> dict[str, Any]:
    return {
        "channels": [
            {
                "physical_channel": channel.physical_channel,
                "kind": channel.kind.value,
                "sensitivity": channel.sensitivity,
                "sensitivity_units": channel.sensitivity_units,
                "iepe_current_a": channel.iepe_current_a,
                "coupling": Coupling(channel.coupling).value,
                "name": channel.name,
                "unit": channel.kind.unit,
                "full_scale_si": channel.full_scale_si,
            }
            for channel in config.channels
        ],
        "sample_rate_hz": config.sample_rate_hz,
        "samples_per_chunk": config.samples_per_chunk,
    }


def config_from_dict(data: Mapping[str, Any]) -> DaqConfig:
    """The stored DAQ configuration; raises ``ValueError`` for a channel whose sensitivity cannot be used (units
    that do not fit its kind, a sensitivity that is not a positive number)."""
    channels = tuple(
        ChannelConfig(
            physical_channel=channel["physical_channel"],
            kind=ChannelKind(channel["kind"]),
            sensitivity=float(channel["sensitivity"]),
            sensitivity_units=channel["sensitivity_units"],
            iepe_current_a=float(channel["iepe_current_a"]),
            coupling=Coupling(channel["coupling"]),
            name=channel["name"],
        )
        for channel in data["channels"]
    )
    for number, channel in enumerate(channels):
        if channel.sensitivity_units not in SENSITIVITY_UNITS[channel.kind]:
            raise ValueError(f"channel {number} is a {channel.kind.value} sensor with sensitivity units "
                             f"'{channel.sensitivity_units}'")
        if not (math.isfinite(channel.sensitivity) and channel.sensitivity > 0):
            raise ValueError(f"channel {number} has sensitivity {channel.sensitivity}")
    return DaqConfig(channels, float(data["sample_rate_hz"]), int(data["samples_per_chunk"]))


def write_mapping(group: h5py.Group, values: Mapping[str, Any]) -> None:
    """Arrays become datasets, strings and numbers attributes, anything else a JSON attribute."""
    json_keys = []
    for key, value in values.items():
        if isinstance(value, (list, tuple)) and value and all(
            isinstance(item, (int, float, complex, np.number)) and not isinstance(item, bool) for item in value
        ):
            value = np.asarray(value)
        if isinstance(value, np.ndarray) and value.dtype.kind in "biufc":
            group.create_dataset(key, data=value)
        elif isinstance(value, (str, bool, int, float, np.number, np.bool_)):
            group.attrs[key] = value
        else:
            group.attrs[key] = json_dumps(value)
            json_keys.append(key)
    group.attrs["json_keys"] = json_dumps(json_keys)


def read_mapping(group: h5py.Group) -> dict[str, Any]:
    json_keys = set(json.loads(group.attrs.get("json_keys", "[]")))
    values: dict[str, Any] = {}
    for key, value in group.attrs.items():
        if key == "json_keys":
            continue
        if key in json_keys:
            values[key] = json.loads(value)
        elif isinstance(value, np.generic):
            values[key] = value.item()
        else:
            values[key] = value
    for key, dataset in group.items():
        values[key] = dataset[()]
    return values



def one_line(error: BaseException, limit: int = 200) -> str:
    """An exception's message on one line (HDF5's messages span lines), shortened to ``limit`` characters."""
    text = re.sub(r"\s+", " ", str(error)).strip() or type(error).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check_declared_rows(path: Path, table: h5py.Dataset, data: h5py.Dataset, file_bytes: int) -> None:
    """Refuse hit datasets declaring more rows than the file of ``file_bytes`` can hold (one more for a hit whose
    write was cut short): shrinking a dataset that declares 2^40 rows walks every chunk it could have, for hours."""
    record_bytes = int(np.prod(data.shape[1:])) * data.dtype.itemsize
    for name, rows, row_bytes in (("hits/data", data.shape[0], record_bytes),
                                  ("hits/table", table.shape[0], table.dtype.itemsize)):
        if (name == "hits/table" or data.compression is None) and (rows - 1) * row_bytes > file_bytes:
            raise SessionError(
                f"{path}: damaged session: '{name}' declares {rows} hits of {row_bytes} bytes, more than the file's "
                f"{file_bytes} bytes hold"
            )


def committed_hits(table: h5py.Dataset, data: h5py.Dataset) -> int:
    """Hits whose record and table row are both written: a row is written last, and a row of zeros (a table grown
    by a write that then failed) has no sample rate, so it does not count."""
    count = min(table.shape[0], data.shape[0])
    if count and not float(table[count - 1]["sample_rate_hz"]) > 0:
        count -= 1
    return count
