"""Universal File Format (UFF) dataset 58 through pyuff: time records in, averaged FRF and coherence out.

Import: every dataset 58 with function type 1 (time response) is a channel of one hit. A record is the force when
its ordinate specific data type is 13 (excitation force), the response when it is 12 (acceleration); records of
another data type are sorted by node and direction: a record measured at its own reference DOF (response node/dir
equal to reference node/dir) is the force, any other is the response. The k-th force record and the k-th response
record (in file order, after choosing the force and response DOF) make hit k. Values are converted to SI (N, m/s²)
from the ordinate units label ("N", "lbf", "m/s^2", "g", …) or, without a label, from a units dataset 164.

Export: the averaged H1 as function type 4 (accelerance, ordinate acceleration 12 over excitation force 13,
m/s^2 / N, complex double) and the coherence as function type 6 (real double), preceded by a units dataset 164 (SI),
and optionally the hits' time records (function type 1: the force, data type 13 in N, at the reference DOF, and the
response, data type 12 in m/s^2, at the response DOF), so that gasfilm reads back what it writes. The FRF's record
length, sample rate, averages and the exponential window's decay rate go into its ID line 3 (``gasfilm: ...``) so
that a fit of the file removes the window's damping as a fit of the session does (:func:`read_uff_frf`).
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pyuff

from gasfilm.analysis.paths import missing_folder, written_whole
from gasfilm.analysis.session.layout import MAX_ABS_SI as LAYOUT_MAX_ABS_SI
from gasfilm.analysis.session.layout import MAX_SAMPLE_RATE_HZ
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import NI9234_VALID_RATES_HZ, ChannelKind
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2

logger = logging.getLogger(__name__)

FUNCTION_TIME_RESPONSE = 1
FUNCTION_FRF = 4
FUNCTION_COHERENCE = 6
DATA_TYPE_ACCELERATION = 12
DATA_TYPE_EXCITATION_FORCE = 13
DATA_TYPE_TIME = 17
DATA_TYPE_FREQUENCY = 18
UNITS_SI = 1
POUND_FORCE_N = 4.4482216152605

#: Factors from an ordinate units label to SI, per channel role.
FORCE_UNITS_TO_N = {"n": 1.0, "newton": 1.0, "kn": 1e3, "lbf": POUND_FORCE_N, "lb": POUND_FORCE_N}
ACCELERATION_UNITS_TO_M_S2 = {
    "m/s^2": 1.0,
    "m/s2": 1.0,
    "m/s**2": 1.0,
    "m s^-2": 1.0,
    "g": STANDARD_GRAVITY_M_S2,
    "mm/s^2": 1e-3,
    "mm/s2": 1e-3,
}
NO_LABEL = ("", "none")
MAX_HEADER_INTEGER = 2**31
SAMPLE_RATE_RANGE_HZ = (1.0, MAX_SAMPLE_RATE_HZ)
#: Largest magnitudes a time record may hold after conversion to SI: beyond them the file is damaged, not a test.
MAX_ABS_SI = {"force": LAYOUT_MAX_ABS_SI[ChannelKind.FORCE], "response": LAYOUT_MAX_ABS_SI[ChannelKind.ACCELERATION]}
RATE_SNAP_RELATIVE = 1e-4  # UFF stores the abscissa increment with 5 significant digits


class UffError(GasfilmError):
    """A UFF file is missing, empty, or holds time records gasfilm cannot use."""


Dof = tuple[int, int]  # (node, direction); direction 1…3 = +X/+Y/+Z translation, negative = opposite sense


@dataclass(frozen=True)
class UffTimeRecords:
    """Hits read from a UFF file: row 0 force (N), row 1 response (m/s²)."""

    path: Path
    records: np.ndarray  # (hits, 2, samples)
    sample_rate_hz: float
    force_dof: Dof
    response_dof: Dof
    start_times_s: np.ndarray  # (hits,)
    descriptions: tuple[str, ...] = field(default=())
    #: what was done to records of different lengths (all cut to the shortest), or None when all had one length
    length_note: str | None = None
    #: the operating conditions a gasfilm export wrote into the datasets' ID line 4 ({} for another program's file)
    conditions: dict = field(default_factory=dict)

    @property
    def hit_count(self) -> int:
        return int(self.records.shape[0])


def _read_datasets(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        raise UffError(f"{path}: no such UFF file")
    if path.is_dir():
        raise UffError(f"{path}: is a folder, not a UFF file")
    try:
        uff = pyuff.UFF(str(path))
        count = uff.get_n_sets()
    except Exception as error:  # pyuff raises bare Exception for every malformed file
        raise UffError(f"{path}: not a readable UFF file ({error})") from None
    if not count:
        raise UffError(f"{path}: empty UFF file: no datasets (is it a UFF file?)")
    sets = []
    for index in range(count):
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")  # numpy warnings on damaged numbers; the checks below judge them
                dataset = uff.read_sets(index)
        except Exception as error:  # pyuff: bare Exception; numpy/struct errors on damaged numbers pass through
            cause = getattr(error, "value", None) or (str(error).strip() or type(error).__name__)
            raise UffError(f"{path}: dataset {index + 1} of {count} is damaged and cannot be read "
                           f"({cause[:120]})") from None
        if not isinstance(dataset, Mapping) or dataset.get("type") in (None, 0):
            dataset = {"type": "unknown"}  # pyuff could not read the dataset's type line
        sets.append(dict(dataset))
    return sets


def _label(dataset: Mapping[str, Any], key: str) -> str:
    return str(dataset.get(key, "") or "").strip()


def _number(dataset: Mapping[str, Any], key: str, default: float = 0.0) -> float:
    """A header field as a finite number; a damaged field raises :class:`UffError` (the caller adds the file)."""
    value = dataset.get(key, default)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise UffError(f"field '{key}' is {str(value)[:40]!r}, not a number") from None
    if not math.isfinite(number):
        raise UffError(f"field '{key}' is {number}")
    return number


def _integer(dataset: Mapping[str, Any], key: str, default: int = 0) -> int:
    number = _number(dataset, key, default)
    if number != int(number) or abs(number) > MAX_HEADER_INTEGER:
        raise UffError(f"field '{key}' is {number:g}, not a node, direction or type number")
    return int(number)


def _dof(dataset: Mapping[str, Any], prefix: str) -> Dof:
    return _integer(dataset, f"{prefix}_node"), _integer(dataset, f"{prefix}_dir")


def _role(dataset: Mapping[str, Any]) -> str:
    data_type = _integer(dataset, "ordinate_spec_data_type")
    if data_type == DATA_TYPE_EXCITATION_FORCE:
        return "force"
    if data_type == DATA_TYPE_ACCELERATION:
        return "response"
    return "force" if _dof(dataset, "rsp") == _dof(dataset, "ref") else "response"


def _si_factor(path: Path, number: int, dataset: Mapping[str, Any], role: str, units: Mapping[str, float]) -> float:
    label = _label(dataset, "ordinate_axis_units_lab")
    table = FORCE_UNITS_TO_N if role == "force" else ACCELERATION_UNITS_TO_M_S2
    if label.lower() in NO_LABEL:
        # No label: the file's unit system (dataset 164: values in file units = SI value × factor).
        return 1.0 / units["force" if role == "force" else "length"]
    factor = table.get(label.lower().replace(" ", ""))
    if factor is None:
        raise UffError(
            f"{path}: dataset {number} ({role}) has units '{label}', which gasfilm cannot convert; "
            f"allowed: {', '.join(sorted(table))}"
        )
    return factor


def _sample_rate(path: Path, increments_s: Sequence[float]) -> float:
    increments = np.asarray(increments_s, dtype=float)
    if np.any(~np.isfinite(increments)) or np.any(increments <= 0):
        raise UffError(f"{path}: time records have no positive abscissa increment (sample interval)")
    if np.ptp(increments) > RATE_SNAP_RELATIVE * increments.max():
        raise UffError(
            f"{path}: time records have different sample intervals ({increments.min():.6g} … {increments.max():.6g} s)"
        )
    rate_hz = 1.0 / float(np.mean(increments))
    if not SAMPLE_RATE_RANGE_HZ[0] <= rate_hz <= SAMPLE_RATE_RANGE_HZ[1]:
        raise UffError(f"{path}: time records sampled at {rate_hz:.6g} S/s; gasfilm reads "
                       f"{SAMPLE_RATE_RANGE_HZ[0]:g} to {SAMPLE_RATE_RANGE_HZ[1]:g} S/s")
    nearest = min(NI9234_VALID_RATES_HZ, key=lambda valid: abs(valid - rate_hz))
    return nearest if abs(nearest - rate_hz) <= RATE_SNAP_RELATIVE * rate_hz else rate_hz


def _choose_dof(path: Path, role: str, available: Sequence[Dof], wanted: Dof | None) -> Dof:
    distinct = sorted(set(available))
    if wanted is not None:
        if tuple(wanted) not in distinct:
            listed = ", ".join(f"node {node} dir {direction}" for node, direction in distinct) or "none"
            raise UffError(
                f"{path}: no {role} time record at node {wanted[0]} dir {wanted[1]} (found: {listed})"
            )
        return (int(wanted[0]), int(wanted[1]))
    if len(distinct) > 1:
        listed = ", ".join(f"node {node} dir {direction}" for node, direction in distinct)
        raise UffError(f"{path}: {role} time records at several DOFs ({listed}); choose one by node and direction")
    return distinct[0]


def read_uff_time_records(
    path: str | Path, force_dof: Dof | None = None, response_dof: Dof | None = None
) -> UffTimeRecords:
    """Read the force/response time records of every hit from a UFF file (dataset 58, function type 1)."""
    path = Path(path)
    datasets = _read_datasets(path)
    try:
        return _time_records(path, datasets, force_dof, response_dof)
    except UffError as error:
        message = str(error)
        raise UffError(message if message.startswith(str(path)) else f"{path}: {message}") from None


def _time_records(
    path: Path, datasets: list[dict[str, Any]], force_dof: Dof | None, response_dof: Dof | None
) -> UffTimeRecords:
    units = {"length": 1.0, "force": 1.0}
    for number, dataset in enumerate(datasets, start=1):
        if dataset.get("type") == 164:
            units = {key: _number(dataset, key, 1.0) for key in ("length", "force")}
            if not all(factor > 0 for factor in units.values()):
                raise UffError(f"dataset {number} (units) has a length or force factor that is not positive")
    time_records = [
        (number, dataset)
        for number, dataset in enumerate(datasets, start=1)
        if dataset.get("type") == 58 and _number(dataset, "func_type", -1) == FUNCTION_TIME_RESPONSE
    ]
    if not time_records:
        if any(d.get("type") == 58 and _number(d, "func_type", -1) == FUNCTION_FRF for d in datasets):
            raise UffError(f"{path}: holds an FRF but no time records (dataset 58 with function type 1); this needs "
                           f"the hits' time records (`gasfilm export SOURCE --uff OUT.uff` writes them; "
                           f"`gasfilm fit` reads the FRF alone)")
        types = sorted({str(dataset.get("type", "unknown")) for dataset in datasets})
        raise UffError(
            f"{path}: no time records (dataset 58 with function type 1) among {len(datasets)} datasets "
            f"of type {', '.join(types)}"
        )
    by_role: dict[str, list[tuple[int, dict[str, Any]]]] = {"force": [], "response": []}
    for number, dataset in time_records:
        by_role[_role(dataset)].append((number, dataset))
    for role in ("force", "response"):
        if not by_role[role]:
            raise UffError(f"{path}: no {role} time records among the {len(time_records)} time records")
    chosen_force = _choose_dof(path, "force", [_dof(d, "rsp") for _, d in by_role["force"]], force_dof)
    chosen_response = _choose_dof(path, "response", [_dof(d, "rsp") for _, d in by_role["response"]], response_dof)
    forces = [(n, d) for n, d in by_role["force"] if _dof(d, "rsp") == chosen_force]
    responses = [(n, d) for n, d in by_role["response"] if _dof(d, "rsp") == chosen_response]
    if len({_dof(d, "ref") for _, d in responses}) > 1:  # a roving hammer: the responses to the chosen force's hits
        responses = [(n, d) for n, d in responses if _dof(d, "ref") == chosen_force]
    if len(forces) != len(responses):
        raise UffError(
            f"{path}: {len(forces)} force records but {len(responses)} response records; each hit needs one of each"
        )
    for number, dataset in forces + responses:
        values = dataset.get("data")
        if not isinstance(values, np.ndarray) or values.ndim != 1 or values.dtype.kind not in "fciu":
            raise UffError(f"dataset {number} holds no column of numbers")
    for hit, ((force_number, force), (response_number, response)) in enumerate(zip(forces, responses), start=1):
        if len(force["data"]) != len(response["data"]):  # a hit's own force and response must pair sample by sample
            pair = sorted((len(force["data"]), len(response["data"])))
            raise UffError(f"{path}: time records have inconsistent lengths ({pair[0]}, {pair[1]} samples): hit {hit}'s "
                           f"force (dataset {force_number}) and response (dataset {response_number})")
    lengths = [len(force["data"]) for _, force in forces]
    samples = min(lengths)
    length_note = None
    if len(set(lengths)) > 1:
        cut = [hit + 1 for hit, length in enumerate(lengths) if length > samples]
        length_note = (f"the time records have different lengths ({', '.join(str(n) for n in sorted(set(lengths)))} "
                       f"samples): every record is cut to the shortest, {samples} samples from its start (hits "
                       f"{_hit_list(cut)} lose their later samples), so that all hits share one frequency grid")
        logger.info("%s: %s", path, length_note)
    if samples < 2:
        raise UffError(f"{path}: time records hold {samples} sample; at least 2 are needed")
    records = np.empty((len(forces), 2, samples))
    for hit, pair in enumerate(zip(forces, responses)):
        for row, (role, (number, dataset)) in enumerate(zip(("force", "response"), pair)):
            values = np.asarray(dataset["data"])[:samples]
            if np.iscomplexobj(values):
                raise UffError(f"{path}: dataset {number} ({role} time record of hit {hit + 1}) holds complex values")
            if not np.all(np.isfinite(values)):
                raise UffError(f"{path}: dataset {number} ({role} time record of hit {hit + 1}) has NaN samples")
            with np.errstate(all="ignore"):
                records[hit, row] = values * _si_factor(path, number, dataset, role, units)
            if not np.max(np.abs(records[hit, row])) <= MAX_ABS_SI[role]:
                raise UffError(f"dataset {number} ({role} time record of hit {hit + 1}) holds values beyond "
                               f"{MAX_ABS_SI[role]:g} {'N' if role == 'force' else 'm/s^2'}: a damaged file")
    increments = [_number(d, "abscissa_inc") or _abscissa_step(d) for _, d in forces]
    sample_rate_hz = _sample_rate(path, increments + [_number(d, "abscissa_inc") for _, d in responses])
    minima = np.array([_number(d, "abscissa_min") for _, d in forces])
    if np.all(minima == minima[0]):
        start_times_s = np.arange(len(forces)) * samples / sample_rate_hz
    else:
        start_times_s = minima
    descriptions = tuple(_label(d, "id1") for _, d in forces)
    return UffTimeRecords(path, records, sample_rate_hz, chosen_force, chosen_response, start_times_s, descriptions,
                          length_note, uff_conditions(path, datasets))


def _hit_list(hits: list[int]) -> str:
    """Hit numbers as runs: 1–8, 11, 13–16."""
    runs: list[list[int]] = []
    for hit in hits:
        if runs and hit == runs[-1][-1] + 1:
            runs[-1].append(hit)
        else:
            runs.append([hit])
    return ", ".join(f"{run[0]}–{run[-1]}" if len(run) > 2 else ", ".join(map(str, run)) for run in runs)


def _abscissa_step(dataset: Mapping[str, Any]) -> float:
    """The sample interval from the abscissa values when the header gives none (0 when it cannot)."""
    x = dataset.get("x")
    if not isinstance(x, np.ndarray) or x.ndim != 1 or x.size < 2 or x.dtype.kind not in "fiu":
        return 0.0
    return float(x[1] - x[0])


def trigger_sample(force_n: np.ndarray, level_n: float | None = None) -> int:
    """First sample at or above ``level_n`` (default: 10 % of the peak force); the peak when none is."""
    peak = float(np.max(force_n))
    level = 0.1 * peak if level_n is None else level_n
    above = np.flatnonzero(force_n >= level)
    return int(above[0]) if above.size else int(np.argmax(force_n))


def _frf_dataset(
    func_type: int,
    data: np.ndarray,
    freq_hz: np.ndarray,
    response_dof: Dof,
    reference_dof: Dof,
    description: str,
    ordinate: tuple[int, str],
    denominator: tuple[int, str],
    note: str = "",
) -> dict[str, Any]:
    increment_hz = float(freq_hz[1] - freq_hz[0]) if len(freq_hz) > 1 else 0.0
    even = bool(len(freq_hz) > 1 and np.allclose(np.diff(freq_hz), increment_hz, rtol=1e-9, atol=0.0))
    return pyuff.prepare_58(
        binary=0,
        id1=description[:80] or "NONE",
        id2="gasfilm",
        id4=note[:80] or "NONE",
        func_type=func_type,
        rsp_node=int(response_dof[0]),
        rsp_dir=int(response_dof[1]),
        ref_node=int(reference_dof[0]),
        ref_dir=int(reference_dof[1]),
        abscissa_spacing=1 if even else 0,
        abscissa_spec_data_type=DATA_TYPE_FREQUENCY,
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=ordinate[0],
        ordinate_axis_units_lab=ordinate[1],
        orddenom_spec_data_type=denominator[0],
        orddenom_axis_units_lab=denominator[1],
        data=data,
        x=np.asarray(freq_hz, dtype=float),
    )


#: ID line 3 of an exported FRF: how it was averaged, read back by :func:`read_uff_frf`.
FRF_ID3_PREFIX = "gasfilm:"


def _frf_id3(frf: Any) -> str:
    return (f"{FRF_ID3_PREFIX} n_averages={int(frf.n_averages)} sample_rate_hz={float(frf.sample_rate_hz):.10g} "
            f"n_samples={int(frf.n_samples)} decay_rate_1_s={float(frf.decay_rate_1_s):.10g}")


#: How ID line 4 of a gasfilm export begins when it holds the session's operating conditions (``KEY=VALUE; …``).
CONDITIONS_PREFIX = "conditions: "
#: The characters of a UFF ID line.
ID_LINE_CHARS = 80


def conditions_line(conditions: Mapping[str, Any]) -> str:
    """The operating conditions as one ID line, ``conditions: supply_pressure_mpa=0.4; bearing=B-17``, read back by
    :func:`uff_conditions`. A table too long for the line's 80 characters keeps the entries that fit and says which
    it leaves out (a warning)."""
    if not conditions:
        return ""
    line, left_out = CONDITIONS_PREFIX, []
    for key, value in conditions.items():
        entry = f"{key}={value:.10g}" if isinstance(value, float) else f"{key}={value}"
        joined = entry if line == CONDITIONS_PREFIX else f"; {entry}"
        if len(line) + len(joined) <= ID_LINE_CHARS:
            line += joined
        else:
            left_out.append(key)
    if left_out:
        logger.warning("UFF: the operating conditions %s do not fit the 80 characters of ID line 4 and are left out "
                       "of the export", ", ".join(left_out))
    return line if line != CONDITIONS_PREFIX else ""


def uff_conditions(path: Path, datasets: Sequence[Mapping[str, Any]]) -> dict:
    """The operating conditions in the first dataset 58's ID line 4 written by :func:`conditions_line` ({} when
    none); a damaged entry is one line naming the file."""
    from gasfilm.analysis.conditions import parse_condition_flags

    for dataset in datasets:
        if dataset.get("type") != 58:
            continue
        text = _label(dataset, "id4")
        if not text.startswith(CONDITIONS_PREFIX):
            continue
        entries = [entry.strip() for entry in text[len(CONDITIONS_PREFIX):].split(";") if entry.strip()]
        return parse_condition_flags(entries, f"{path}: ID line 4 condition")
    return {}


def read_uff_conditions(path: str | Path) -> dict:
    """The operating conditions a gasfilm export wrote into a UFF file ({} when none)."""
    path = Path(path)
    return uff_conditions(path, _read_datasets(path))


def _time_record_dataset(values: np.ndarray, sample_rate_hz: float, start_time_s: float, dof: Dof,
                         reference_dof: Dof, role: str, hit_number: int, description: str,
                         conditions: str = "") -> dict[str, Any]:
    data_type, unit = (DATA_TYPE_EXCITATION_FORCE, "N") if role == "force" else (DATA_TYPE_ACCELERATION, "m/s^2")
    values = np.asarray(values, dtype=float)
    return pyuff.prepare_58(
        binary=0,
        id1=f"{description} hit {hit_number} {role}"[:80],
        id2="gasfilm",
        id4=conditions[:ID_LINE_CHARS] or "NONE",
        func_type=FUNCTION_TIME_RESPONSE,
        ver_num=hit_number,
        rsp_node=int(dof[0]),
        rsp_dir=int(dof[1]),
        ref_node=int(reference_dof[0]),
        ref_dir=int(reference_dof[1]),
        abscissa_spacing=1,
        abscissa_spec_data_type=DATA_TYPE_TIME,
        abscissa_axis_units_lab="s",
        ordinate_spec_data_type=data_type,
        ordinate_axis_units_lab=unit,
        orddenom_spec_data_type=0,
        data=values,
        x=start_time_s + np.arange(values.size) / sample_rate_hz,
    )


def export_frf_uff(
    frf: Any,
    path: str | Path,
    response_dof: Dof = (1, 3),
    reference_dof: Dof = (1, 3),
    description: str = "gasfilm averaged FRF",
    hits: Sequence[Any] = (),
    conditions: Mapping[str, Any] | None = None,
    estimator: str = "H1",
) -> Path:
    """Write the averaged FRF (accelerance, m/s²/N; ``frf.h1``, named ``estimator`` in its description: the caller
    puts H2 or Hv there to export those) and the coherence of an ``FrfResult`` as UFF 58, then the time
    records of ``hits`` (:class:`gasfilm.analysis.capture.HitRecord` or stored hits: force at ``reference_dof``,
    response at ``response_dof``), which ``replay``, ``diagnose`` and ``fit`` read back; the session's operating
    ``conditions`` go into ID line 4 of each dataset (:func:`conditions_line`), and come back with the records."""
    conditions = conditions_line(conditions or {})
    path = Path(path)
    if not path.parent.is_dir():
        raise UffError(f"{path}: {missing_folder(path.parent)}")
    try:
        freq_hz = np.asarray(frf.freq_hz, dtype=float)
        h1 = np.asarray(frf.h1, dtype=complex)
        coherence = np.asarray(frf.coherence, dtype=float)
    except (TypeError, ValueError):
        raise UffError(f"{path}: the FRF's frequencies, H1 or coherence are not numbers; nothing written") from None
    if not (freq_hz.ndim == h1.ndim == coherence.ndim == 1 and freq_hz.size == h1.size == coherence.size > 0):
        raise UffError(f"{path}: the FRF's frequencies, H1 and coherence have different lengths "
                       f"({freq_hz.size}, {h1.size}, {coherence.size} values); nothing written")
    if not (np.all(np.isfinite(freq_hz)) and np.all(np.isfinite(h1)) and np.all(np.isfinite(coherence))):
        raise UffError(f"{path}: the FRF holds NaN values; nothing written")
    datasets = [
        pyuff.prepare_164(
            units_code=UNITS_SI,
            units_description="SI",
            temp_mode=1,
            length=1.0,
            force=1.0,
            temp=1.0,
            temp_offset=273.15,
        ),
        _frf_dataset(
            FUNCTION_FRF,
            h1,
            freq_hz,
            response_dof,
            reference_dof,
            f"{description} {estimator} accelerance",
            (DATA_TYPE_ACCELERATION, "m/s^2"),
            (DATA_TYPE_EXCITATION_FORCE, "N"),
            conditions,
        ),
        _frf_dataset(
            FUNCTION_COHERENCE,
            coherence,
            freq_hz,
            response_dof,
            reference_dof,
            f"{description} coherence",
            (0, "NONE"),
            (0, "NONE"),
            conditions,
        ),
    ]
    for dataset in datasets[1:]:
        dataset["id3"] = _frf_id3(frf)
    for number, hit in enumerate(hits, start=1):
        records = np.asarray(hit.data, dtype=float)
        for role, row, dof in (("force", hit.force_channel, reference_dof),
                               ("response", hit.response_channel, response_dof)):
            datasets.append(_time_record_dataset(records[row], float(hit.sample_rate_hz),
                                                 float(hit.start_time_s), dof, reference_dof, role, number,
                                                 description, conditions))
    with written_whole(path, what="the UFF file") as (building,):  # a full disk leaves no partial file
        pyuff.UFF(str(building)).write_sets(datasets, mode="overwrite")
    return path


def _frf_metadata(dataset: Mapping[str, Any]) -> dict[str, float]:
    """The ``gasfilm: key=value ...`` fields of an exported FRF's ID line 3 (empty for another program's file)."""
    text = _label(dataset, "id3")
    if not text.startswith(FRF_ID3_PREFIX):
        return {}
    values = {}
    for item in text[len(FRF_ID3_PREFIX):].split():
        key, _, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            continue
        if math.isfinite(number):
            values[key] = number
    return values


def read_uff_frf(path: str | Path) -> Any:
    """The FRF (function type 4, accelerance) and its coherence (type 6) stored in a UFF file, as an
    :class:`gasfilm.analysis.spectra.FrfResult`, or None when the file holds no FRF.

    What UFF does not carry (H2, auto-spectra, per-hit FRFs, the uncertainty) is NaN. The averaging details come from
    gasfilm's ID line 3; another program's FRF is taken as unwindowed, sampled at twice its top frequency."""
    from gasfilm.analysis.spectra import FrfResult

    path = Path(path)
    datasets = _read_datasets(path)
    try:
        return _frf_from_datasets(path, datasets, FrfResult)
    except UffError as error:
        message = str(error)
        raise UffError(message if message.startswith(str(path)) else f"{path}: {message}") from None


def _frf_from_datasets(path: Path, datasets: list[dict[str, Any]], frf_class: Any) -> Any:
    def of_type(func_type: int) -> list[dict[str, Any]]:
        return [d for d in datasets if d.get("type") == 58 and _number(d, "func_type", -1) == func_type]

    frfs, coherences = of_type(FUNCTION_FRF), of_type(FUNCTION_COHERENCE)
    if not frfs:
        return None
    if len(frfs) > 1:
        raise UffError(f"{path}: holds {len(frfs)} FRFs; gasfilm fits one (write one FRF per file)")
    dataset = frfs[0]
    try:
        with np.errstate(all="ignore"):
            h1 = np.asarray(dataset.get("data"), dtype=complex)
            freq_hz = np.asarray(dataset.get("x"), dtype=float)
    except (TypeError, ValueError):
        raise UffError(f"{path}: the FRF holds no column of numbers with its frequencies") from None
    if h1.ndim != 1 or h1.size < 2 or freq_hz.shape != h1.shape:
        raise UffError(f"{path}: the FRF holds no column of numbers with its frequencies")
    if not (np.all(np.isfinite(h1)) and np.all(np.isfinite(freq_hz)) and np.all(np.diff(freq_hz) > 0)):
        raise UffError(f"{path}: the FRF has NaN values or frequencies that do not rise")
    numerator = _label(dataset, "ordinate_axis_units_lab").lower().replace(" ", "")
    denominator = _label(dataset, "orddenom_axis_units_lab").lower().replace(" ", "")
    factor = ACCELERATION_UNITS_TO_M_S2.get(numerator or "m/s^2")
    per = FORCE_UNITS_TO_N.get(denominator or "n")
    if factor is None or per is None:
        raise UffError(f"{path}: the FRF is in {numerator or '?'}/{denominator or '?'}; gasfilm reads an "
                       f"accelerance (m/s^2, g or mm/s^2 per N, kN or lbf)")
    h1 = h1 * factor / per
    coherence = np.full(h1.size, np.nan)
    if coherences:
        try:
            values = np.asarray(coherences[0].get("data"), dtype=float)
        except (TypeError, ValueError):
            values = np.empty(0)
        if values.shape == h1.shape and np.all(np.isfinite(values)):
            coherence = values
    meta = _frf_metadata(dataset)
    sample_rate_hz = meta.get("sample_rate_hz", 2.0 * float(freq_hz[-1]))
    if not SAMPLE_RATE_RANGE_HZ[0] <= sample_rate_hz <= SAMPLE_RATE_RANGE_HZ[1]:
        raise UffError(f"{path}: the FRF's sample rate {sample_rate_hz:.6g} S/s is outside "
                       f"{SAMPLE_RATE_RANGE_HZ[0]:g}–{SAMPLE_RATE_RANGE_HZ[1]:g} S/s")
    n_samples = int(min(max(meta.get("n_samples", 2 * (h1.size - 1)), 2), 2**40))
    if not 1 <= meta.get("n_averages", 1) <= 2**31 or not np.isfinite(meta.get("decay_rate_1_s", 0.0)):
        raise UffError(f"{path}: the FRF's ID line 3 is damaged ({_label(dataset, 'id3')[:60]!r})")
    unknown = np.full(h1.size, np.nan)
    return frf_class(
        freq_hz=freq_hz, h1=h1, h2=unknown.astype(complex), coherence=coherence, gff=unknown, gxx=unknown,
        gfx=unknown.astype(complex), h1_per_hit=np.empty((0, h1.size), complex),
        n_averages=int(meta.get("n_averages", 1)), sample_rate_hz=float(sample_rate_hz), n_samples=n_samples,
        decay_rate_1_s=float(meta.get("decay_rate_1_s", 0.0)), h1_std_coherence=unknown,
        h1_std_scatter=unknown, window={"source": str(path)},
    )


def has_uff_time_records(path: str | Path) -> bool:
    """Whether a UFF file holds time records (dataset 58, function type 1)."""
    return any(d.get("type") == 58 and _number(d, "func_type", -1) == FUNCTION_TIME_RESPONSE
               for d in _read_datasets(Path(path)))


def import_uff_session(
    uff_path: str | Path,
    session_path: str | Path,
    validation: Any = None,
    window: Any = None,
    force_dof: Dof | None = None,
    response_dof: Dof | None = None,
    trigger_level_n: float | None = None,
    overwrite: bool = False,
) -> Path:
    """Store the hits of a UFF file as a new session; each hit is validated with ``validation``
    (:class:`gasfilm.analysis.validation.ValidationSettings`, default settings when None) and ``window``
    (:class:`gasfilm.analysis.spectra.WindowSettings`, whose exponential counts in the decay check).

    A UFF file gives units, not input ranges: the session records ``source.full_scale_known = false``. Its channel
    setup is the default hammer and accelerometer (a session stores one), whose ranges are not the recording's, so
    neither the import nor a replay judges overload against them
    (:func:`gasfilm.analysis.validation.recorded_full_scale_si`); clipping still counts."""
    from gasfilm.analysis.capture import HitRecord
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.validation import ValidationSettings, validate_hit

    from gasfilm.drivers.interface import default_hammer_and_accelerometer

    time_records = read_uff_time_records(uff_path, force_dof, response_dof)
    validation = validation or ValidationSettings()
    config = default_hammer_and_accelerometer(time_records.sample_rate_hz)
    settings = {
        "validation": validation,
        "window": window,
        "source": {
            "uff_file": str(time_records.path),
            "force_dof": time_records.force_dof,
            "response_dof": time_records.response_dof,
            "trigger_level_n": trigger_level_n,
            "full_scale_known": False,
        },
    }
    with Session.create(
        session_path, config, None, settings, overwrite=overwrite, sync_each_hit=False,
        record_samples=time_records.records.shape[2],
    ) as session:
        for hit_index, record in enumerate(time_records.records):
            hit = HitRecord(
                index=hit_index,
                data=record,
                sample_rate_hz=time_records.sample_rate_hz,
                trigger_index=trigger_sample(record[0], trigger_level_n),
                start_time_s=float(time_records.start_times_s[hit_index]),
                overload=np.zeros(2, bool),
                force_channel=0,
                response_channel=1,
            )
            session.append_hit(hit, validate_hit(hit, validation, window=window))
    return Path(session_path)
