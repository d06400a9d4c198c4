"""The rig spec: mover mass, film model and parameters, sensors, hammer defaults and effects, read from TOML
(``docs/rig-spec.md``) and written back.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import tomli_w


from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_MODELS, PAPER_TABLE1, FilmModel, get_model
from gasfilm.analysis.physics.rigid_body import (RigidBody, pad_spec_parts, rigid_body_from_table,
                                                 rigid_body_to_table, validate_rigid_body)
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.plant import TIPS_PULSE_WIDTH_S

from gasfilm.analysis.physics.effects import (
    CHANNELS,
    DEFAULT_ACCELERATION_NOISE_M_S2_PER_SQRT_HZ,
    DEFAULT_ACCELERATION_SENSITIVITY_MV_PER_M_S2,
    DEFAULT_FORCE_NOISE_N_PER_SQRT_HZ,
    DEFAULT_FORCE_SENSITIVITY_MV_PER_N,
    EFFECT_TYPES,
    Effect,
    EffectValueError,
    TermChange,
    _any_number,
    signed_field,
    FitRange,
    _fraction,
    _non_negative,
    _positive,
)
#: Sizes and physical ranges a rig spec must keep to, checked before anything is computed from it.
MAX_SPEC_CHARACTERS = 1_000_000
MAX_EFFECTS = 64
MAX_MODEL_TEXT_CHARACTERS = 500
MASS_RANGE_KG = (1e-3, 1e4)
RESONANCE_RANGE_HZ = (0.1, 50e3)
SENSITIVITY_RANGE_MV = (1e-3, 1e5)
MAX_NOISE_PER_SQRT_HZ = 1e3
MAX_HAMMER_FORCE_N = 1e5
#: Magnitude ranges of effect values by unit (a lower bound of 0: none): beyond them a simulation of the rig runs for
#: minutes or overflows. Lists (harmonic amplitudes) are held to the upper bound only.
EFFECT_UNIT_RANGES = {
    "Hz": (1e-3, 1e6),
    "1": (0.0, 10.0),
    "kg": (0.0, MASS_RANGE_KG[1]),
    "N/m³": (0.0, 1e22),
    "N/m": (0.0, 1e13),
    "s": (0.0, 10.0),
    "s of session time": (0.0, 1e7),
    "1/h": (0.0, 3.6e5),  # 100 % per second: a session of seconds may show a few per cent
    "N or m/s²": (0.0, 1e6),
    "m": (0.0, 10.0),
    "Pa": (0.0, 1e8),
    "Pa·s": (0.0, 1.0),
    "N": (0.0, 1e6),
    "N·s²/m²": (0.0, 1e12),
    "(m/s²)/N": (0.0, 10.0),
    "1/kg": (0.0, 1e3),
    "N·s^α/m": (0.0, 1e14),
    "N·s": (0.0, 1e5),
}


# --- the spec ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SensorSpec:
    """A sensor's true sensitivity (mV per SI unit) and noise density (SI unit per √Hz)."""

    sensitivity_mv: float
    noise_per_sqrt_hz: float

    @property
    def sensitivity_v_per_si(self) -> float:
        return self.sensitivity_mv * 1e-3


@dataclass(frozen=True)
class HammerSpec:
    """Defaults for the simulated hammer."""

    tip: str = "medium"
    force_n: float = 200.0
    force_spread: float = 0.2
    double_hit_rate: float = 0.0


DEFAULT_FORCE_SENSOR = SensorSpec(DEFAULT_FORCE_SENSITIVITY_MV_PER_N, DEFAULT_FORCE_NOISE_N_PER_SQRT_HZ)
DEFAULT_ACCELERATION_SENSOR = SensorSpec(
    DEFAULT_ACCELERATION_SENSITIVITY_MV_PER_M_S2, DEFAULT_ACCELERATION_NOISE_M_S2_PER_SQRT_HZ
)
#: At most this many analysis lines in a spec's recorded description error.
MAX_DESCRIPTION_LINES = 100_000


@dataclass(frozen=True)
class DescriptionError:
    """How far the spec is known to be from the recording it was written from, beyond that recording's noise: the
    RMS (m/s²)/N of the systematic difference between the recorded and the replayed H1 at each listed frequency (the
    bands the writing diagnosis left unexplained; 0 elsewhere). A diagnosis against the spec takes it into its noise
    model: the spec does not claim to describe the structure better than that (``[description_error]``)."""

    freq_hz: tuple[float, ...]
    rms_m_s2_per_n: tuple[float, ...]
    #: The writing diagnosis's χ² per point on its recording (1 = the noise), and that recording's name.
    chi2_per_point: float
    recording: str

    def power(self, freq_hz: np.ndarray) -> np.ndarray:
        """The systematic error's power |ΔH|² ((m/s²)/N)² at ``freq_hz``, interpolated, 0 outside the listed
        bands."""
        return np.interp(freq_hz, np.asarray(self.freq_hz), np.asarray(self.rms_m_s2_per_n) ** 2, left=0.0,
                         right=0.0)

    def to_table(self) -> dict[str, Any]:
        return {"recording": self.recording, "chi2_per_point": self.chi2_per_point, "freq_hz": list(self.freq_hz),
                "rms_m_s2_per_n": list(self.rms_m_s2_per_n)}


_DEFAULT_SENSORS = {"force": DEFAULT_FORCE_SENSOR, "acceleration": DEFAULT_ACCELERATION_SENSOR}

_SENSOR_KEYS = {
    "force": ("sensitivity_mv_per_n", "noise_n_per_sqrt_hz"),
    "acceleration": ("sensitivity_mv_per_m_s2", "noise_m_s2_per_sqrt_hz"),
}


@dataclass(frozen=True)
class RigSpec:
    """A rig: mass, film model and parameters, sensors, hammer defaults and effects (``docs/rig-spec.md``)."""

    name: str
    mass_kg: float
    film_model: str
    film_parameters: Mapping[str, float]
    force_sensor: SensorSpec = DEFAULT_FORCE_SENSOR
    acceleration_sensor: SensorSpec = DEFAULT_ACCELERATION_SENSOR
    hammer: HammerSpec | None = None
    effects: tuple[Effect, ...] = ()
    source: str = field(default="rig spec", compare=False)
    #: The operating conditions ``film_parameters`` hold at (``[film.conditions]``; keys name their unit).
    film_conditions: Mapping[str, float] = field(default_factory=dict)
    #: Power laws of film coefficients in the conditions: parameter → {condition: exponent} (``[film.laws.*]``).
    film_laws: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    #: How far the spec is known to be from the recording it was written from (``[description_error]``).
    description_error: DescriptionError | None = None
    #: The mover as a rigid body on its films, with accelerometers and hammer points (``[rigid_body]``); None: the
    #: mover in one direction, seen by one accelerometer (:mod:`gasfilm.analysis.physics.rigid_body`).
    rigid_body: RigidBody | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "film_parameters", {k: float(v) for k, v in self.film_parameters.items()})
        object.__setattr__(self, "effects", tuple(self.effects))
        object.__setattr__(self, "film_conditions", {k: float(v) for k, v in self.film_conditions.items()})
        object.__setattr__(self, "film_laws", {k: {c: float(e) for c, e in v.items()} for k, v in
                                               self.film_laws.items()})
        check_readable(self)

    # construction ---------------------------------------------------------------------------------------------

    @classmethod
    def nominal(
        cls,
        film: str = "FOMGF",
        mass_kg: float = PAPER_MASS_KG,
        parameters: Mapping[str, float] | None = None,
        effects: Sequence[Effect] = (),
    ) -> "RigSpec":
        """The paper's rig: ``film`` is a paper model name (Table 1 parameters) or a network text + ``parameters``."""
        model = get_model(film)
        if parameters is None:
            if model.name not in PAPER_TABLE1:
                raise SettingError(f"rig spec: film '{film}' has no Table 1 parameters; pass parameters=")
            parameters = PAPER_TABLE1[model.name]
        model_text = model.name if model.name in PAPER_MODELS else model.text
        return cls(
            name=f"nominal {model_text} film on {mass_kg:g} kg",
            mass_kg=mass_kg,
            film_model=model_text,
            film_parameters=dict(parameters),
            effects=tuple(effects),
            source="nominal rig spec",
        )

    @classmethod
    def from_toml(cls, text: str, source: str = "rig spec") -> "RigSpec":
        """Parse TOML text; errors name ``source`` (a file name) and the key at fault."""
        if len(text) > MAX_SPEC_CHARACTERS:
            raise SettingError(f"{source}: {len(text)} characters; a rig spec has at most {MAX_SPEC_CHARACTERS}")
        try:
            table = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise SettingError(f"{source}: not valid TOML: {error}") from None
        except RecursionError:
            raise SettingError(f"{source}: not a rig spec: arrays or tables nested too deeply") from None
        return _spec_from_table(table, source)

    @classmethod
    def load(cls, path: str | Path) -> "RigSpec":
        path = Path(path)
        try:
            with path.open("rb") as file:
                data = file.read(MAX_SPEC_CHARACTERS * 4 + 1)
        except OSError as error:
            raise SettingError(f"{path}: cannot read the rig spec ({error.strerror or error})") from None
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as error:
            raise SettingError(f"{path}: not a rig spec: not UTF-8 text (byte {data[error.start]:#04x} at position "
                               f"{error.start})") from None
        return cls.from_toml(text, source=str(path))

    def save(self, path: str | Path) -> None:
        Path(path).write_text(self.to_toml(), encoding="utf-8")

    def to_toml(self) -> str:
        """The spec as TOML text (written by tomli-w; floats round-trip exactly). The writer applies the reader's
        checks first (:func:`check_readable`): a spec the reader would refuse is never written."""
        check_readable(self)
        table: dict[str, Any] = {"name": self.name, "mass_kg": self.mass_kg,
                                 "film": {"model": self.film_model, "parameters": dict(self.film_parameters)}}
        if self.rigid_body is not None and self.rigid_body.has_pads:
            del table["film"]  # the pads' films (written under [[rigid_body.pads]]) are the spec's film
        if self.film_laws:
            table["film"]["conditions"] = dict(self.film_conditions)
            table["film"]["laws"] = {name: dict(exponents) for name, exponents in self.film_laws.items()}
        table["sensors"] = {
            channel: {_SENSOR_KEYS[channel][0]: sensor.sensitivity_mv, _SENSOR_KEYS[channel][1]: sensor.noise_per_sqrt_hz}
            for channel, sensor in (("force", self.force_sensor), ("acceleration", self.acceleration_sensor))
        }
        if self.hammer is not None:
            table["hammer"] = dataclasses.asdict(self.hammer)
        if self.effects:
            table["effects"] = [effect.to_table() for effect in self.effects]
        if self.description_error is not None:
            table["description_error"] = self.description_error.to_table()
        if self.rigid_body is not None:
            table["rigid_body"] = rigid_body_to_table(self.rigid_body, self.film_parameters)
        return "# gasfilm rig spec (docs/rig-spec.md)\n" + tomli_w.dumps(table, multiline_strings=False)

    def with_values(self, film_parameters: Mapping[str, float] | None = None,
                    effects: Sequence[Effect] | None = None) -> "RigSpec":
        """A copy with other film parameter values and/or effects, not re-validated: for fits that stay inside the
        effects' physical ranges. What a fit returns is such a spec, and what it writes is that same spec."""
        updated = object.__new__(type(self))  # copy.copy's shallow copy, without its generic protocol (a fit's
        updated.__dict__.update(self.__dict__)  # Jacobian asks for thousands)
        if film_parameters is not None:
            object.__setattr__(updated, "film_parameters", dict(film_parameters))
        if effects is not None:
            object.__setattr__(updated, "effects", tuple(effects))
        return updated

    def with_description_error(self, error: DescriptionError | None) -> "RigSpec":
        """A copy that records another description error (None: none)."""
        updated = copy.copy(self)
        object.__setattr__(updated, "description_error", error)
        return updated

    def at_conditions(self, conditions: Mapping[str, Any]) -> "RigSpec":
        """The rig at an operating point: film coefficients moved along their laws to ``conditions`` (the laws
        kept, re-based there; :mod:`gasfilm.analysis.physics.laws`). A spec without laws is returned unchanged."""
        if not self.film_laws:
            return self
        from gasfilm.analysis.physics.laws import film_at_conditions

        parameters, reference = film_at_conditions(self.film_parameters, self.film_conditions, self.film_laws,
                                                   conditions, self.source)
        return dataclasses.replace(self, film_parameters=parameters, film_conditions=reference)

    # derived --------------------------------------------------------------------------------------------------

    @property
    def film(self) -> FilmModel:
        return _film_model(self.film_model)

    @property
    def moving_mass_kg(self) -> float:
        return self.mass_kg + sum(effect.added_mass_kg() for effect in self.effects)

    @property
    def cubic_stiffness_n_per_m3(self) -> float:
        return sum(effect.cubic_stiffness_n_per_m3() for effect in self.effects)

    @property
    def is_linear(self) -> bool:
        return self.cubic_stiffness_n_per_m3 == 0.0

    @property
    def is_per_hit(self) -> bool:
        """Whether hits of one session see different linear rigs (session time, hit level)."""
        return any(effect.per_hit for effect in self.effects)

    @property
    def force_leak_m_s2_per_n(self) -> float:
        return sum(effect.force_leak_m_s2_per_n() for effect in self.effects)

    def support_stiffness(self, s: np.ndarray) -> np.ndarray | None:
        """Dynamic stiffness (N/m) of what the film stands on, in series with it (``None``: rigid ground)."""
        supports = [stiffness for effect in self.effects
                    if (stiffness := effect.support_stiffness(s)) is not None]
        if not supports:
            return None
        compliance = sum(1.0 / stiffness for stiffness in supports)  # supports stacked one on another
        return 1.0 / compliance

    def sensor(self, channel: str) -> SensorSpec:
        return self.force_sensor if channel == "force" else self.acceleration_sensor

    def film_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        """Factor on the film's whole complex stiffness at session time(s) ``time_s`` (drift, step changes)."""
        scale: np.ndarray | float = 1.0
        for effect in self.effects:
            scale = scale * effect.film_scale(time_s)
        return scale

    def viscous_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        """Further factor on the film's viscous coefficients at session time(s) ``time_s``."""
        scale: np.ndarray | float = 1.0
        for effect in self.effects:
            scale = scale * effect.viscous_scale(time_s)
        return scale

    def with_effects(self, *effects: Effect) -> "RigSpec":
        """A copy with more effects appended."""
        return dataclasses.replace(self, effects=self.effects + tuple(effects))

    @property
    def has_term_changes(self) -> bool:
        """Whether a term of the spec changes between hits (term-drift, term-level, term-onset)."""
        return any(isinstance(effect, TermChange) for effect in self.effects)

    def at_hit(self, time_s: float, impulse_ns: float, blow: float = 0.0) -> "RigSpec":
        """The spec a hit at session time ``time_s`` with impulse ``impulse_ns``, the session's blow number ``blow``
        (0 for the first), sees: each changing term's value moved by its changes, the changes themselves left out
        (their indices are those of :attr:`effects`)."""
        if not self.has_term_changes:
            return self
        effects = list(self.effects)
        for change in self.effects:
            if isinstance(change, TermChange):
                target = effects[change.term]
                factor = change.factor(time_s, impulse_ns, blow, signed_field(target, change.parameter))
                value = getattr(target, change.parameter) * factor
                effects[change.term] = dataclasses.replace(target, **{change.parameter: value})
        return self.with_values(effects=[effect for effect in effects if not isinstance(effect, TermChange)])


@functools.lru_cache(maxsize=256)
def _film_model(text: str) -> FilmModel:
    """The film model of a spec's ``film.model`` text (parsed once per text)."""
    return get_model(text)


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise SettingError(f"{where}: unknown key '{key}'; allowed: {', '.join(allowed)}")


def _float_value(value: Any, where: str, rule: Callable[[float], str | None], unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SettingError(f"{where} = {value!r}: must be a finite number ({unit})")
    problem = rule(float(value))
    if problem:
        raise SettingError(f"{where} = {value!r}: {problem} ({unit})")
    return float(value)


def _table(table: Mapping[str, Any], key: str, where: str) -> Mapping[str, Any]:
    value = table.get(key, {})
    if not isinstance(value, Mapping):
        raise SettingError(f"{where} key '{key}': must be a table")
    return value


def _spec_from_table(table: Mapping[str, Any], source: str) -> RigSpec:
    _check_keys(table, ("name", "mass_kg", "film", "sensors", "hammer", "effects", "description_error", "rigid_body"),
                source)
    if "mass_kg" not in table:
        raise SettingError(f"{source}: key 'mass_kg' is missing (the mover's mass in kg)")
    mass_kg = _float_value(table["mass_kg"], f"{source} key 'mass_kg'", _within(*MASS_RANGE_KG), "kg")
    name = table.get("name", Path(source).stem)
    if not isinstance(name, str):
        raise SettingError(f"{source} key 'name': must be a string")
    film = _table(table, "film", source)
    _check_keys(film, ("model", "parameters", "conditions", "laws"), f"{source} [film]")
    rigid_body = None
    if "rigid_body" in table:
        rigid_body, pad_tables = rigid_body_from_table(table["rigid_body"], source)
    if rigid_body is not None and rigid_body.has_pads:
        if "model" in film or "parameters" in film:
            raise SettingError(f"{source} [film]: a mover on pads takes its film from [[rigid_body.pads]]; give "
                               f"either [film] with roll and pitch films, or pads")
        model_text, parameters = pad_spec_parts(rigid_body.pads, pad_tables, source)
    else:
        model_text = film.get("model")
        if not isinstance(model_text, str):
            raise SettingError(f"{source} key 'film.model': missing; a paper model name or a network such as "
                               f"'k || dashpot(eta)'")
        _checked_film_model(model_text, source)
        parameters = {
            key: _float_value(value, f"{source} key 'film.parameters.{key}'", _any_number, "SI")
            for key, value in _table(film, "parameters", f"{source} [film]").items()
        }
    film_conditions = {
        key: _float_value(value, f"{source} key 'film.conditions.{key}'", _within(0.0, 1e9, low_included=False),
                          "the unit in its name")
        for key, value in _table(film, "conditions", f"{source} [film]").items()
    }
    film_laws = {
        name: {key: _float_value(value, f"{source} key 'film.laws.{name}.{key}'", _any_number, "exponent")
               for key, value in _table(laws, name, f"{source} [film.laws]").items()}
        for laws in (_table(film, "laws", f"{source} [film]"),) for name in laws
    }
    sensors = _table(table, "sensors", source)
    _check_keys(sensors, CHANNELS, f"{source} [sensors]")
    sensor_specs = {}
    for channel in CHANNELS:
        default = _DEFAULT_SENSORS[channel]
        sensor = _table(sensors, channel, f"{source} [sensors]")
        sensitivity_key, noise_key = _SENSOR_KEYS[channel]
        _check_keys(sensor, (sensitivity_key, noise_key), f"{source} [sensors.{channel}]")
        sensor_specs[channel] = SensorSpec(
            _float_value(sensor.get(sensitivity_key, default.sensitivity_mv),
                         f"{source} key 'sensors.{channel}.{sensitivity_key}'", _within(*SENSITIVITY_RANGE_MV),
                         "mV per SI unit"),
            _float_value(sensor.get(noise_key, default.noise_per_sqrt_hz),
                         f"{source} key 'sensors.{channel}.{noise_key}'", _within(0.0, MAX_NOISE_PER_SQRT_HZ),
                         "SI unit/√Hz"),
        )
    hammer = None
    if "hammer" in table:
        hammer_table = _table(table, "hammer", source)
        _check_keys(hammer_table, [f.name for f in dataclasses.fields(HammerSpec)], f"{source} [hammer]")
        tip = hammer_table.get("tip", HammerSpec.tip)
        if not isinstance(tip, str) or tip not in TIPS_PULSE_WIDTH_S:
            raise SettingError(f"{source} key 'hammer.tip' = {tip!r}: allowed: {', '.join(TIPS_PULSE_WIDTH_S)}")
        hammer = HammerSpec(
            tip=tip,
            force_n=_float_value(hammer_table.get("force_n", HammerSpec.force_n), f"{source} key 'hammer.force_n'",
                                 _within(0.0, MAX_HAMMER_FORCE_N, low_included=False), "N"),
            force_spread=_float_value(hammer_table.get("force_spread", HammerSpec.force_spread),
                                      f"{source} key 'hammer.force_spread'", _fraction, "fraction"),
            double_hit_rate=_float_value(hammer_table.get("double_hit_rate", HammerSpec.double_hit_rate),
                                         f"{source} key 'hammer.double_hit_rate'", _fraction, "fraction of hits"),
        )
    effect_tables = table.get("effects", [])
    if not isinstance(effect_tables, list):
        raise SettingError(f"{source} key 'effects': must be an array of tables ([[effects]])")
    if len(effect_tables) > MAX_EFFECTS:
        raise SettingError(f"{source} key 'effects': {len(effect_tables)} effects; a rig spec has at most "
                           f"{MAX_EFFECTS}")
    effects = tuple(_effect_from_table(item, f"{source} effects[{index}]") for index, item in
                    enumerate(effect_tables))
    description_error = (_description_error(_table(table, "description_error", source), source)
                         if "description_error" in table else None)
    return RigSpec(name, mass_kg, model_text, parameters, sensor_specs["force"], sensor_specs["acceleration"],
                   hammer, effects, source, film_conditions=film_conditions, film_laws=film_laws,
                   description_error=description_error, rigid_body=rigid_body)


def _description_error(table: Mapping[str, Any], source: str) -> DescriptionError:
    """``[description_error]``: equally long lists of ascending frequencies (Hz) and RMS values ((m/s²)/N, ≥ 0)."""
    where = f"{source} [description_error]"
    _check_keys(table, ("recording", "chi2_per_point", "freq_hz", "rms_m_s2_per_n"), where)
    lists = {}
    for key, unit, rule in (("freq_hz", "Hz", _within(1e-3, 1e6)), ("rms_m_s2_per_n", "(m/s²)/N", _within(0.0, 1e6))):
        values = table.get(key)
        if not isinstance(values, list) or len(values) > MAX_DESCRIPTION_LINES:
            raise SettingError(f"{where} key '{key}': must be a list of at most {MAX_DESCRIPTION_LINES} numbers "
                               f"({unit})")
        lists[key] = tuple(_float_value(value, f"{where} key '{key}'", rule, unit) for value in values)
    if len(lists["freq_hz"]) != len(lists["rms_m_s2_per_n"]):
        raise SettingError(f"{where}: 'freq_hz' and 'rms_m_s2_per_n' must be equally long")
    if any(b <= a for a, b in zip(lists["freq_hz"], lists["freq_hz"][1:])):
        raise SettingError(f"{where} key 'freq_hz': the frequencies must ascend")
    recording = table.get("recording", "")
    if not isinstance(recording, str):
        raise SettingError(f"{where} key 'recording': must be a string")
    chi2 = _float_value(table.get("chi2_per_point", 1.0), f"{where} key 'chi2_per_point'", _within(0.0, 1e12), "1")
    return DescriptionError(lists["freq_hz"], lists["rms_m_s2_per_n"], chi2, recording)


def _effect_from_table(table: Any, where: str) -> Effect:
    if not isinstance(table, Mapping):
        raise SettingError(f"{where}: must be a table")
    type_name = table.get("type")
    if not isinstance(type_name, str) or type_name not in EFFECT_TYPES:
        raise SettingError(f"{where}: unknown effect type {type_name!r}; known: {', '.join(EFFECT_TYPES)}")
    cls = EFFECT_TYPES[type_name]
    fields = {f.name: f for f in dataclasses.fields(cls)}
    _check_keys(table, ("type", *fields), f"{where} ({type_name})")
    values: dict[str, Any] = {}
    for name, item in fields.items():
        key_where = f"{where} ({type_name}) key '{name}'"
        if name not in table:
            if item.default is dataclasses.MISSING:
                raise SettingError(f"{key_where}: missing ({item.metadata.get('unit', '')})")
            continue
        value = table[name]
        if item.metadata.get("list"):
            if not isinstance(value, list):
                raise SettingError(f"{key_where} = {value!r}: must be a list of numbers")
            values[name] = tuple(value)
        else:
            values[name] = value
    effect = cls(**values)
    _check_effect(effect, where)
    return effect


def _check_effect(effect: Effect, where: str) -> None:
    """Apply the field rules (numbers, units, choices) and the effect's own ``validate``."""
    type_name = type(effect).type_name
    for item in dataclasses.fields(effect):
        value = getattr(effect, item.name)
        key_where = f"{where} ({type_name}) key '{item.name}'"
        if "choices" in item.metadata:
            if value not in item.metadata["choices"]:
                raise SettingError(f"{key_where} = {value!r}: allowed: {', '.join(item.metadata['choices'])}")
        elif item.metadata.get("list"):
            if len(value) > MAX_EFFECTS:
                raise SettingError(f"{key_where}: {len(value)} values; at most {MAX_EFFECTS}")
            for entry in value:
                _float_value(entry, key_where, _any_number, item.metadata["unit"])
                _check_unit_range(entry, key_where, item.metadata["unit"], upper_only=True)
        elif "rule" in item.metadata:
            _float_value(value, key_where, item.metadata["rule"], item.metadata["unit"])
            _check_unit_range(value, key_where, item.metadata["unit"])
    try:
        effect.validate()
    except EffectValueError as error:
        value = getattr(effect, error.key)
        raise SettingError(f"{where} ({type_name}) key '{error.key}' = {value!r}: {error}") from None


def _within(low: float, high: float, low_included: bool = True) -> Callable[[float], str | None]:
    """A value rule: between ``low`` and ``high`` (``low`` itself allowed unless ``low_included`` is False)."""

    def rule(value: float) -> str | None:
        inside = (low <= value if low_included else low < value) and value <= high
        return None if inside else f"must be {'≥' if low_included else '>'} {low:g} and ≤ {high:g}"

    return rule


def _checked_film_model(model_text: str, source: str) -> FilmModel:
    if len(model_text) > MAX_MODEL_TEXT_CHARACTERS:
        raise SettingError(f"{source} key 'film.model': {len(model_text)} characters; at most "
                           f"{MAX_MODEL_TEXT_CHARACTERS}")
    try:
        return get_model(model_text)
    except SettingError as error:
        raise SettingError(f"{source} key 'film.model': {error}") from None
    except RecursionError:
        raise SettingError(f"{source} key 'film.model': parentheses nested too deeply") from None


def _check_resonance(spec: RigSpec, model: FilmModel) -> None:
    """The mass on the film must resonate inside ``RESONANCE_RANGE_HZ``: the film's stiffness magnitude exceeds the
    mass's m·ω² at the low end and falls below it at the high end (a film far outside would make every simulation
    and fit of it run for ever or say nothing)."""
    low_hz, high_hz = RESONANCE_RANGE_HZ
    omega = 2 * math.pi * np.array([low_hz, high_hz])
    with np.errstate(all="ignore"):
        film = np.abs(model.stiffness(1j * omega, dict(spec.film_parameters)))
    mass = spec.mass_kg * omega**2
    where = f"{spec.source} [film.parameters]"
    if not np.all(np.isfinite(film)):
        raise SettingError(f"{where}: the film's stiffness is not finite between {low_hz:g} Hz and {high_hz:g} Hz")
    if film[0] < mass[0]:
        raise SettingError(f"{where}: the film resonates with the {spec.mass_kg:g} kg mass below {low_hz:g} Hz "
                           f"(|Z| = {film[0]:.3g} N/m there); supported: {low_hz:g} Hz to {high_hz:g} Hz")
    if film[1] > mass[1]:
        raise SettingError(f"{where}: the film resonates with the {spec.mass_kg:g} kg mass above {high_hz:g} Hz "
                           f"(|Z| = {film[1]:.3g} N/m there); supported: {low_hz:g} Hz to {high_hz:g} Hz")


def _check_laws(spec: RigSpec, model: FilmModel) -> None:
    """Laws only on the film's coefficients (not its orders), in conditions named with their unit and given at the
    reference, with exponents of at most ``MAX_EXPONENT``."""
    from gasfilm.analysis.conditions import check_condition, condition_unit
    from gasfilm.analysis.physics.laws import MAX_EXPONENT

    where = f"{spec.source} [film.laws]"
    coefficients = {parameter.name for parameter in model.parameters if parameter.scale == "log"}
    for key, value in spec.film_conditions.items():
        check_condition(key, value, f"{spec.source} [film.conditions]")
        if condition_unit(key) is None or not value > 0:
            raise SettingError(f"{spec.source} key 'film.conditions.{key}' = {value!r}: a law's condition needs its "
                               f"unit in its name (e.g. gap_um) and a positive value")
    for name, exponents in spec.film_laws.items():
        if name not in coefficients:
            raise SettingError(f"{where}: '{name}' is not a coefficient of {model.name} (laws apply to "
                               f"{', '.join(sorted(coefficients))})")
        for key, exponent in exponents.items():
            if key not in spec.film_conditions:
                raise SettingError(f"{where} key '{name}.{key}': the condition {key} needs its reference value in "
                                   f"[film.conditions]")
            if not abs(exponent) <= MAX_EXPONENT:
                raise SettingError(f"{where} key '{name}.{key}' = {exponent!r}: an exponent must be within "
                                   f"±{MAX_EXPONENT:g}")


def _check_unit_range(value: float, where: str, unit: str, upper_only: bool = False) -> None:
    low, high = EFFECT_UNIT_RANGES.get(unit, (0.0, math.inf))
    if value == 0.0:
        return  # whether a field may be 0 is its own rule's question
    if upper_only:
        low = 0.0
    if not (abs(value) <= high and (low == 0.0 or abs(value) >= low)):
        bounds = f"{low:g} to {high:g}" if low else f"at most {high:g} in magnitude"
        raise SettingError(f"{where} = {value!r}: outside the physical range, {bounds} ({unit})")


def _check_term_change(spec: RigSpec, index: int, change: TermChange) -> None:
    """A change between hits acts on a number of another effect of the spec (not on another change)."""
    where = f"{spec.source} effects[{index}] ({type(change).type_name})"
    if not 0 <= change.term < len(spec.effects) or isinstance(spec.effects[change.term], TermChange):
        raise SettingError(f"{where} key 'term' = {change.term!r}: must be the index (from 0) of another effect of the "
                           f"spec that is not itself a change")
    target = spec.effects[change.term]
    numbers = [item.name for item in dataclasses.fields(target) if "rule" in item.metadata]
    if change.parameter not in numbers:
        raise SettingError(f"{where} key 'parameter' = {change.parameter!r}: {type(target).type_name} has "
                           f"{', '.join(numbers) or 'no numbers'}")


def within_readable_range(fit_range: FitRange, unit: str) -> FitRange:
    """A fit range cut to what the spec reader takes for a value in ``unit`` (:data:`EFFECT_UNIT_RANGES`, the range
    :func:`_check_unit_range` applies): a fitted value at its bound is written at most there, and read back."""
    low, high = EFFECT_UNIT_RANGES.get(unit, (0.0, math.inf))
    if fit_range.scale == "log":
        return FitRange("log", max(fit_range.lower, low), min(fit_range.upper, high))
    return FitRange(fit_range.scale, max(fit_range.lower, -high), min(fit_range.upper, high))


def film_parameter_range(
    model: FilmModel, name: str, mass_kg: float, values: Mapping[str, float] | None = None
) -> tuple[float, float]:
    """The range (in the parameter's unit) the spec reader takes for film parameter ``name`` of ``model`` on
    ``mass_kg``: its element's bounds and, with the film's other parameters at ``values``, the values with which the
    film resonates with the mass inside ``RESONANCE_RANGE_HZ`` (:func:`_check_resonance`) with a margin of
    :data:`RESONANCE_MARGIN` at both ends (a spring run to 1e12 N/m on a 1.74 kg structure, or a Maxwell arm's dashpot
    letting the film sag below 0.1 Hz, is never written). Remembered per network, parameter, mass and values (a fit
    asks for the same ranges at every step)."""
    parameter = next(p for p in model.parameters if p.name == name)
    low, high = parameter.lower, parameter.upper
    if parameter.scale != "log" or values is None or not all(p.name in values for p in model.parameters):
        return low, high
    key = (model.network, name, float(mass_kg), tuple((p.name, float(values[p.name])) for p in model.parameters))
    remembered = _PARAMETER_RANGES.get(key)
    if remembered is None:
        if len(_PARAMETER_RANGES) >= 1024:
            _PARAMETER_RANGES.clear()
        remembered = _PARAMETER_RANGES[key] = _resonance_range(model, name, mass_kg, values, low, high)
    return remembered


#: film_parameter_range's answers, by network, parameter, mass and the film's values.
_PARAMETER_RANGES: dict[tuple, tuple[float, float]] = {}


def _resonance_range(
    model: FilmModel, name: str, mass_kg: float, values: Mapping[str, float], low: float, high: float
) -> tuple[float, float]:
    """The part of [low, high] in which parameter ``name`` keeps the film resonating with ``mass_kg`` inside
    ``RESONANCE_RANGE_HZ`` with its margins (:func:`film_parameter_range`)."""
    low_omega, top_omega = (2 * math.pi * f for f in RESONANCE_RANGE_HZ)
    values = dict(values)

    def stiffness(value: float, omega: float) -> float:
        with np.errstate(all="ignore"):
            result = abs(complex(model.stiffness(np.array([1j * omega]), {**values, name: value})[0]))
        return result if np.isfinite(result) else math.inf

    def soft_enough_at_top(value: float) -> bool:
        return stiffness(value, top_omega) * RESONANCE_MARGIN <= mass_kg * top_omega**2

    def stiff_enough_at_bottom(value: float) -> bool:
        return stiffness(value, low_omega) >= RESONANCE_MARGIN * mass_kg * low_omega**2

    # a coefficient stiffens the film: the bottom check holds above some value, the top check below another
    if not stiff_enough_at_bottom(low) and stiff_enough_at_bottom(high):
        low = _boundary(stiff_enough_at_bottom, low, high, holds_above=True)
    if not soft_enough_at_top(high) and soft_enough_at_top(low):
        high = _boundary(soft_enough_at_top, low, high, holds_above=False)
    return low, max(high, low)


#: A written film's stiffness stays this many times inside the mass's m·ω² at the edges of RESONANCE_RANGE_HZ.
RESONANCE_MARGIN = 2.0


def _boundary(holds: Callable[[float], bool], low: float, high: float, holds_above: bool) -> float:
    """The value in [low, high] where ``holds`` changes (bisection on a log scale), on the side where it holds."""
    lower, upper = math.log(low), math.log(high)
    for _ in range(60):
        middle = 0.5 * (lower + upper)
        if holds(math.exp(middle)) == holds_above:
            upper = middle
        else:
            lower = middle
    return math.exp(upper if holds_above else lower)


def check_readable(spec: RigSpec) -> None:
    """The spec reader's checks, which the writer applies too (:meth:`RigSpec.to_toml`): one line naming the key
    when a value is out of its range."""
    _validate_spec(spec)
    if not spec.moving_mass_kg > 0:
        raise SettingError(f"{spec.source}: the moving mass with the added masses is {spec.moving_mass_kg:.4g} kg; "
                           f"it must be > 0")


def _validate_spec(spec: RigSpec) -> None:
    source = spec.source
    _float_value(spec.mass_kg, f"{source} key 'mass_kg'", _within(*MASS_RANGE_KG), "kg")
    pads = spec.rigid_body is not None and spec.rigid_body.has_pads  # (their network is as long as they make it)
    model = spec.film if pads else _checked_film_model(spec.film_model, source)
    if len(spec.effects) > MAX_EFFECTS:
        raise SettingError(f"{source}: {len(spec.effects)} effects; a rig spec has at most {MAX_EFFECTS}")
    for parameter in model.parameters:
        key = f"{source} key 'film.parameters.{parameter.name}'"
        if parameter.name not in spec.film_parameters:
            raise SettingError(f"{key}: missing; {model.name} needs {', '.join(model.parameter_names)}")
        value = spec.film_parameters[parameter.name]
        if parameter.scale == "log":  # within the element's physical bounds (those the fitters search)
            _float_value(value, key, _within(parameter.lower, parameter.upper), parameter.unit)
        elif not 0.0 <= value <= 2.0:
            raise SettingError(f"{key} = {value!r}: an order must be between 0 and 2")
    for name in spec.film_parameters:
        if name not in model.parameter_names:
            raise SettingError(f"{source} key 'film.parameters.{name}': not a parameter of {model.name} "
                               f"({', '.join(model.parameter_names)})")
    _check_laws(spec, model)
    _check_resonance(spec, model)
    for index, effect in enumerate(spec.effects):
        if type(effect).type_name not in EFFECT_TYPES:
            raise SettingError(f"{source} effects[{index}]: {type(effect).__name__} is not a registered effect")
        _check_effect(effect, f"{source} effects[{index}]")
        if isinstance(effect, TermChange):
            _check_term_change(spec, index, effect)
    for channel in CHANNELS:
        sensor = spec.sensor(channel)
        sensitivity_key, noise_key = _SENSOR_KEYS[channel]
        _float_value(sensor.sensitivity_mv, f"{source} key 'sensors.{channel}.{sensitivity_key}'", _positive, "mV")
        _float_value(sensor.noise_per_sqrt_hz, f"{source} key 'sensors.{channel}.{noise_key}'", _non_negative, "SI")
    if spec.rigid_body is not None:
        validate_rigid_body(spec)


