"""A rigid-body test as UFF (pyuff): geometry (dataset 15), every accelerometer's H1 and coherence at every hammer
point (dataset 58, function types 4 and 6) and the hits' time records (dataset 58, function type 1), written and
read back.

Nodes: accelerometer k of the rig spec (``[[rigid_body.accelerometers]]``, from 1) is node k, hammer point p node
100 + p; dataset 15 gives their x, y (z = 0) in m. An accelerometer's direction is +3 (+z) or −3 (−z), the hammer's
+3. A response's reference node is the hammer point it was struck at, so another program (or gasfilm's own UFF
import, which pairs each force with the responses that reference its node) can tell the columns of the roving test
apart. Units: SI (dataset 164).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pyuff

from gasfilm.analysis.paths import missing_folder
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.rigid_frf import RigidFrf, rigid_frf
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.uff import (
    DATA_TYPE_ACCELERATION,
    DATA_TYPE_EXCITATION_FORCE,
    FUNCTION_COHERENCE,
    FUNCTION_FRF,
    FUNCTION_TIME_RESPONSE,
    UNITS_SI,
    UffError,
    _dof,
    _frf_dataset,
    _frf_id3,
    _number,
    _read_datasets,
    _role,
    _sample_rate,
    _si_factor,
    _time_record_dataset,
)

#: Node of hammer point p (from 1) is POINT_NODE_OFFSET + p.
POINT_NODE_OFFSET = 100
#: Dataset 15's coordinates must match the spec's positions this closely (m).
GEOMETRY_TOLERANCE_M = 1e-3


def sensor_node(index: int) -> int:
    return index + 1


def point_node(index: int) -> int:
    return POINT_NODE_OFFSET + index + 1


def _sensor_dof(spec: RigSpec, index: int) -> tuple[int, int]:
    return sensor_node(index), 3 if spec.rigid_body.accelerometers[index].direction > 0 else -3


def export_rigid_uff(path: str | Path, spec: RigSpec, rigid: RigidFrf,
                     point_hits: Mapping[str, Sequence[Any]] | None = None, accelerometer_rows: Sequence[int] = (),
                     description: str = "gasfilm rigid-body test", conditions: str = "") -> Path:
    """Write the test's geometry, every accelerometer's H1 and coherence per hammer point and (``point_hits``:
    stored hits or hit records per point, accelerometers at ``accelerometer_rows``) the time records."""
    path = Path(path)
    if not path.parent.is_dir():
        raise UffError(f"{path}: {missing_folder(path.parent)}")
    body = spec.rigid_body
    nodes = [(sensor_node(k), *sensor.position_m) for k, sensor in enumerate(body.accelerometers)]
    nodes += [(point_node(p), *point.position_m) for p, point in enumerate(body.hammer_points)]
    datasets = [
        pyuff.prepare_164(units_code=UNITS_SI, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0,
                          temp_offset=273.15),
        pyuff.prepare_15(node_nums=[n for n, _, _ in nodes], def_cs=[0] * len(nodes), disp_cs=[0] * len(nodes),
                         color=[1] * len(nodes), x=[x for _, x, _ in nodes], y=[y for _, _, y in nodes],
                         z=[0.0] * len(nodes)),
    ]
    for point, frfs in zip(rigid.point_names, rigid.channel_frfs):
        reference = (point_node(body.point_names.index(point)), 3)
        for k, (name, frf) in enumerate(zip(rigid.sensor_names, frfs)):
            for kind, values, label, ordinate, denominator in (
                    (FUNCTION_FRF, frf.h1, "H1 accelerance", (DATA_TYPE_ACCELERATION, "m/s^2"),
                     (DATA_TYPE_EXCITATION_FORCE, "N")),
                    (FUNCTION_COHERENCE, frf.coherence, "coherence", (0, "NONE"), (0, "NONE"))):
                dataset = _frf_dataset(kind, np.asarray(values), frf.freq_hz, _sensor_dof(spec, k), reference,
                                       f"{description} {name} at {point} {label}", ordinate, denominator, conditions)
                dataset["id3"] = _frf_id3(frf)
                datasets.append(dataset)
    number = 0
    for point, hits in (point_hits or {}).items():
        reference = (point_node(body.point_names.index(point)), 3)
        for hit in hits:
            number += 1
            data = np.asarray(hit.data, dtype=float)
            datasets.append(_time_record_dataset(data[hit.force_channel], float(hit.sample_rate_hz),
                                                 float(hit.start_time_s), reference, reference, "force", number,
                                                 f"{description} {point}"))
            for k, row in enumerate(accelerometer_rows):
                datasets.append(_time_record_dataset(data[row], float(hit.sample_rate_hz), float(hit.start_time_s),
                                                     _sensor_dof(spec, k), reference, "response", number,
                                                     f"{description} {point} {body.accelerometers[k].name}"))
    try:
        pyuff.UFF(str(path)).write_sets(datasets, mode="overwrite")
    except OSError as error:
        raise UffError(f"{path}: cannot write the UFF file ({error.strerror or error})") from None
    return path


def read_rigid_uff(path: str | Path, spec: RigSpec, window: WindowSettings = WindowSettings(),
                   points: Sequence[str] | None = None) -> RigidFrf:
    """The rigid-body FRFs of a UFF file's time records (every hit; ``points``: only at these hammer points), with
    the spec's geometry (checked against the file's dataset 15 when it has one)."""
    path = Path(path)
    body = spec.rigid_body
    if body is None:
        raise UffError(f"{spec.source}: the rig spec has no [rigid_body]")
    datasets = _read_datasets(path)
    units = {"length": 1.0, "force": 1.0}
    for dataset in datasets:
        if dataset.get("type") == 164:
            units = {key: _number(dataset, key, 1.0) for key in ("length", "force")}
        if dataset.get("type") == 15:
            _check_geometry(path, spec, dataset, units["length"])
    forces: dict[int, list[tuple[int, dict]]] = {}
    responses: dict[tuple[int, int], list[tuple[int, dict]]] = {}
    for number, dataset in enumerate(datasets, start=1):
        if dataset.get("type") != 58 or _number(dataset, "func_type", -1) != FUNCTION_TIME_RESPONSE:
            continue
        node, _ = _dof(dataset, "rsp")
        reference, _ = _dof(dataset, "ref")
        if _role(dataset) == "force":
            forces.setdefault(node, []).append((number, dataset))
        else:
            responses.setdefault((reference, node), []).append((number, dataset))
    if not forces:
        raise UffError(f"{path}: no force time records (dataset 58, function type 1, at a hammer point's node)")
    point_records: dict[str, np.ndarray] = {}
    rates = []
    for p, point in enumerate(body.point_names):
        hits = forces.get(point_node(p), [])
        if not hits:
            continue
        channels = [hits]
        for k in range(len(body.accelerometers)):
            measured = responses.get((point_node(p), sensor_node(k)), [])
            if len(measured) != len(hits):
                raise UffError(f"{path}: hammer point {point} (node {point_node(p)}) has {len(hits)} force records "
                               f"and {len(measured)} of accelerometer {body.accelerometers[k].name} (node "
                               f"{sensor_node(k)}); each hit needs one of each")
            channels.append(measured)
        samples = min(len(dataset["data"]) for records in channels for _, dataset in records)
        data = np.empty((len(hits), len(channels), samples))
        for row, records in enumerate(channels):
            role = "force" if row == 0 else "response"
            for hit, (number, dataset) in enumerate(records):
                values = np.asarray(dataset["data"])[:samples]
                if np.iscomplexobj(values) or not np.all(np.isfinite(values)):
                    raise UffError(f"{path}: dataset {number} is not a record of finite real samples")
                data[hit, row] = values * _si_factor(path, number, dataset, role, units)
            rates.extend(_number(dataset, "abscissa_inc") for _, dataset in records)
        point_records[point] = data
    if points is not None:
        from gasfilm.analysis.rigid_session import check_points

        check_points(spec, points, point_records)
        point_records = {point: records for point, records in point_records.items() if point in points}
    if not point_records:
        raise UffError(f"{path}: no force records at the nodes of the spec's hammer points "
                       f"({', '.join(str(point_node(p)) for p in range(len(body.hammer_points)))})")
    sample_rate_hz = _sample_rate(path, rates)
    return rigid_frf(spec, point_records, sample_rate_hz, window, 0, list(range(1, len(body.accelerometers) + 1)))


def _check_geometry(path: Path, spec: RigSpec, dataset: Mapping[str, Any], length_m: float) -> None:
    """Dataset 15's nodes where the spec puts its accelerometers and hammer points (within 1 mm)."""
    body = spec.rigid_body
    numbers = [int(n) for n in np.atleast_1d(dataset.get("node_nums", []))]
    coordinates = {n: (float(x) * length_m, float(y) * length_m) for n, x, y in
                   zip(numbers, np.atleast_1d(dataset.get("x", [])), np.atleast_1d(dataset.get("y", [])))}
    expected = {sensor_node(k): (sensor.name, sensor.position_m) for k, sensor in enumerate(body.accelerometers)}
    expected.update({point_node(p): (point.name, point.position_m) for p, point in enumerate(body.hammer_points)})
    for node, (name, position) in expected.items():
        if node in coordinates and np.hypot(*(np.subtract(coordinates[node], position))) > GEOMETRY_TOLERANCE_M:
            raise UffError(f"{path}: node {node} ({name}) is at {coordinates[node]} m in the file's geometry; the "
                           f"rig spec {spec.source} puts it at {position} m")
