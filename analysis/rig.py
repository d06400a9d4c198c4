"""The rig behind the NI 9234: a TOML rig spec and its physics.

A rig spec (``docs/rig-spec.md``) describes the mover (mass), the gas film (a model of :mod:`gasfilm.analysis.models` with
its parameters), the sensors, optional hammer defaults and a list of **effects** that make a real rig differ from
the ideal mass-on-a-film: an extra mode, cubic hardening, a channel delay, added mass, drift, mains interference.
The simulated module plays a spec; the mismatch diagnosis reads one and writes an improved one.

Physics (SI units throughout). With ``s = σ + j2πf`` and ``M = m + Σ added mass``, the mover obeys
``(Z_film(s)·drift(t) + Σ Z_effect(s) + M s²)·X(s) = F(s)`` plus, with ``cubic-stiffness``, the force ``k3·x³``.
The linear accelerance the channels see is ``s² / (Z_film·drift + Σ Z_effect + M s²) · T_a(s) / T_f(s)`` where
``T_a``, ``T_f`` are the per-channel transfers (``channel-delay`` gives ``exp(-sτ)`` on the delayed channel).

Adding an effect type is one small class registered with :func:`register_effect`; it overrides the hooks of
:class:`Effect` it needs (added mass, film scale, added dynamic stiffness, channel transfer, cubic stiffness,
interference).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np
import scipy.fft
from scipy.sparse.linalg import LinearOperator, bicgstab

from gasfilm.analysis.models import PAPER_MASS_KG, PAPER_MODELS, PAPER_TABLE1, FilmModel, get_model, laplace_variable
from gasfilm.drivers.errors import GasfilmError, SettingError

CHANNELS = ("force", "acceleration")
TIPS_PULSE_WIDTH_S: dict[str, float] = {"soft": 2.0e-3, "medium": 0.8e-3, "hard": 0.25e-3}

#: PCB 086C02 hammer and PCB 352B accelerometer as in the paper; noise densities from their broadband resolution.
DEFAULT_FORCE_SENSITIVITY_MV_PER_N = 11.2
DEFAULT_FORCE_NOISE_N_PER_SQRT_HZ = 9.0e-5
DEFAULT_ACCELERATION_SENSITIVITY_MV_PER_M_S2 = 10.2
DEFAULT_ACCELERATION_NOISE_M_S2_PER_SQRT_HZ = 3.0e-5

#: Relative level below which a response counts as decayed, and the longest response the synthesis will pad for.
DECAY_TOLERANCE = 1e-7
MAX_RESPONSE_DURATION_S = 16.0


class EffectValueError(ValueError):
    """Raised by an effect's ``validate`` with the key at fault; the loader turns it into a SettingError."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


# --- value rules shared by the spec and the effects ---------------------------------------------------------------


def _positive(value: float) -> str | None:
    return None if value > 0 else "must be > 0"


def _non_negative(value: float) -> str | None:
    return None if value >= 0 else "must be ≥ 0"


def _fraction(value: float) -> str | None:
    return None if 0 <= value <= 1 else "must be between 0 and 1"


def _any_number(value: float) -> str | None:
    return None


def _number(unit: str, rule: Callable[[float], str | None] = _any_number, default: Any = dataclasses.MISSING) -> Any:
    """A float field of an effect with its unit and rule (metadata read by the loader and the docs)."""
    return field(default=default, metadata={"unit": unit, "rule": rule})


def _channel_field(default: Any = dataclasses.MISSING) -> Any:
    return field(default=default, metadata={"unit": "", "choices": CHANNELS})


# --- effects -------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Effect:
    """One departure from the ideal mass on a film. Subclasses set ``type_name`` and override the hooks they need."""

    type_name: ClassVar[str] = ""

    def validate(self) -> None:
        """Cross-field checks; raise :class:`EffectValueError` naming the key."""

    def added_mass_kg(self) -> float:
        return 0.0

    def film_scale(self, time_s: float) -> float:
        """Factor on the film's complex stiffness at session time ``time_s``."""
        return 1.0

    def added_stiffness(self, s: np.ndarray) -> np.ndarray | float:
        """Dynamic stiffness (N/m) this effect adds to the mover's, at the Laplace variable ``s``."""
        return 0.0

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        """Multiplicative transfer applied to a channel's signal (``channel`` is "force" or "acceleration")."""
        return 1.0

    def cubic_stiffness_n_per_m3(self) -> float:
        return 0.0

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        """An additive signal in the channel's SI unit at the given times, or ``None``."""
        return None

    def to_table(self) -> dict[str, Any]:
        table: dict[str, Any] = {"type": self.type_name}
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            table[item.name] = list(value) if isinstance(value, tuple) else value
        return table


EFFECT_TYPES: dict[str, type[Effect]] = {}


def register_effect(type_name: str) -> Callable[[type[Effect]], type[Effect]]:
    """Class decorator: make an :class:`Effect` subclass available under ``type = "<type_name>"`` in rig specs."""

    def register(cls: type[Effect]) -> type[Effect]:
        cls.type_name = type_name
        EFFECT_TYPES[type_name] = cls
        return cls

    return register


@register_effect("extra-mode")
@dataclass(frozen=True)
class ExtraMode(Effect):
    """A mass–spring–damper attached to the mover (natural frequency measured with the mover held still)."""

    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    mass_kg: float = _number("kg", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        omega = 2 * np.pi * self.freq_hz
        spring_damper = self.mass_kg * omega**2 + 2 * self.damping_ratio * self.mass_kg * omega * s
        return self.mass_kg * s**2 * spring_damper / (self.mass_kg * s**2 + spring_damper)


@register_effect("cubic-stiffness")
@dataclass(frozen=True)
class CubicStiffness(Effect):
    """Hardening of the film: the restoring force gains ``k3·x³`` (nonlinear)."""

    k3_n_per_m3: float = _number("N/m³", _positive)

    def cubic_stiffness_n_per_m3(self) -> float:
        return self.k3_n_per_m3


@register_effect("channel-delay")
@dataclass(frozen=True)
class ChannelDelay(Effect):
    """One channel's signal arrives ``delay_s`` late (cable, conditioning, a mismatched module)."""

    channel: str = _channel_field()
    delay_s: float = _number("s", _positive)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return np.exp(-s * self.delay_s) if channel == self.channel else 1.0


@register_effect("added-mass")
@dataclass(frozen=True)
class AddedMass(Effect):
    """Mass moving with the mover that the nominal mass leaves out (sensor, fixture, cable)."""

    mass_kg: float = _number("kg", _positive)

    def added_mass_kg(self) -> float:
        return self.mass_kg


@register_effect("drift")
@dataclass(frozen=True)
class Drift(Effect):
    """The film's stiffness changes linearly over the session: ``Z·(1 + fraction_per_hour·t/3600 s)``."""

    fraction_per_hour: float = _number("1/h", _any_number)

    def film_scale(self, time_s: float) -> float:
        scale = 1.0 + self.fraction_per_hour * time_s / 3600.0
        if scale <= 0:
            raise GasfilmError(f"drift: the film stiffness scale reaches {scale:.3g} at t = {time_s:.0f} s")
        return scale


@register_effect("mains")
@dataclass(frozen=True)
class Mains(Effect):
    """Mains interference on one channel: ``amplitude·Σ h_n·sin(2π n f t)`` with ``harmonics = [h_1, h_2, …]``."""

    channel: str = _channel_field()
    amplitude: float = _number("N or m/s²", _positive)
    frequency_hz: float = _number("Hz", _positive, 50.0)
    harmonics: tuple[float, ...] = field(default=(1.0,), metadata={"unit": "1", "list": True})

    def validate(self) -> None:
        if not self.harmonics or not all(math.isfinite(h) and h >= 0 for h in self.harmonics):
            raise EffectValueError("harmonics", "must be a non-empty list of relative amplitudes ≥ 0")

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        if channel != self.channel:
            return None
        phase = 2 * np.pi * self.frequency_hz * np.asarray(time_s, dtype=float)
        return self.amplitude * sum(h * np.sin((n + 1) * phase) for n, h in enumerate(self.harmonics))


@register_effect("pneumatic-lag")
@dataclass(frozen=True)
class PneumaticLag(Effect):
    """Part of the film force lags the motion by a first-order time constant: ``k_lag / (1 + s·tau_lag)``."""

    k_lag: float = _number("N/m", _positive)
    tau_lag: float = _number("s", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        return self.k_lag / (1.0 + s * self.tau_lag)


@register_effect("ac-coupling")
@dataclass(frozen=True)
class AcCoupling(Effect):
    """A first-order high-pass ``s / (s + 2π corner_hz)`` on one channel (beyond the module's own, equal on all)."""

    channel: str = _channel_field()
    corner_hz: float = _number("Hz", _positive)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return s / (s + 2 * np.pi * self.corner_hz) if channel == self.channel else 1.0


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

    def __post_init__(self) -> None:
        object.__setattr__(self, "film_parameters", {k: float(v) for k, v in self.film_parameters.items()})
        object.__setattr__(self, "effects", tuple(self.effects))
        _validate_spec(self)

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
        try:
            table = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise SettingError(f"{source}: not valid TOML: {error}") from None
        return _spec_from_table(table, source)

    @classmethod
    def load(cls, path: str | Path) -> "RigSpec":
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as error:
            raise SettingError(f"{path}: cannot read the rig spec ({error.strerror or error})") from None
        return cls.from_toml(text, source=str(path))

    def save(self, path: str | Path) -> None:
        Path(path).write_text(self.to_toml(), encoding="utf-8")

    def to_toml(self) -> str:
        lines = ["# gasfilm rig spec (docs/rig-spec.md)", f"name = {_toml_value(self.name)}",
                 f"mass_kg = {_toml_value(self.mass_kg)}", "", "[film]", f"model = {_toml_value(self.film_model)}",
                 "", "[film.parameters]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in self.film_parameters.items()]
        for channel, sensor in (("force", self.force_sensor), ("acceleration", self.acceleration_sensor)):
            sensitivity_key, noise_key = _SENSOR_KEYS[channel]
            lines += ["", f"[sensors.{channel}]", f"{sensitivity_key} = {_toml_value(sensor.sensitivity_mv)}",
                      f"{noise_key} = {_toml_value(sensor.noise_per_sqrt_hz)}"]
        if self.hammer is not None:
            lines += ["", "[hammer]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in dataclasses.asdict(self.hammer).items()]
        for effect in self.effects:
            lines += ["", "[[effects]]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in effect.to_table().items()]
        return "\n".join(lines) + "\n"

    # derived --------------------------------------------------------------------------------------------------

    @property
    def film(self) -> FilmModel:
        return get_model(self.film_model)

    @property
    def moving_mass_kg(self) -> float:
        return self.mass_kg + sum(effect.added_mass_kg() for effect in self.effects)

    @property
    def cubic_stiffness_n_per_m3(self) -> float:
        return sum(effect.cubic_stiffness_n_per_m3() for effect in self.effects)

    @property
    def is_linear(self) -> bool:
        return self.cubic_stiffness_n_per_m3 == 0.0

    def sensor(self, channel: str) -> SensorSpec:
        return self.force_sensor if channel == "force" else self.acceleration_sensor

    def film_scale(self, time_s: float) -> float:
        scale = 1.0
        for effect in self.effects:
            scale *= effect.film_scale(time_s)
        return scale

    def with_effects(self, *effects: Effect) -> "RigSpec":
        """A copy with more effects appended."""
        return dataclasses.replace(self, effects=self.effects + tuple(effects))


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    raise TypeError(f"cannot write {value!r} to TOML")


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
    _check_keys(table, ("name", "mass_kg", "film", "sensors", "hammer", "effects"), source)
    if "mass_kg" not in table:
        raise SettingError(f"{source}: key 'mass_kg' is missing (the mover's mass in kg)")
    mass_kg = _float_value(table["mass_kg"], f"{source} key 'mass_kg'", _positive, "kg")
    name = table.get("name", Path(source).stem)
    if not isinstance(name, str):
        raise SettingError(f"{source} key 'name': must be a string")
    film = _table(table, "film", source)
    _check_keys(film, ("model", "parameters"), f"{source} [film]")
    model_text = film.get("model")
    if not isinstance(model_text, str):
        raise SettingError(f"{source} key 'film.model': missing; a paper model name or a network such as "
                           f"'k || dashpot(eta)'")
    try:
        get_model(model_text)
    except SettingError as error:
        raise SettingError(f"{source} key 'film.model': {error}") from None
    parameters = {
        key: _float_value(value, f"{source} key 'film.parameters.{key}'", _any_number, "SI")
        for key, value in _table(film, "parameters", f"{source} [film]").items()
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
                         f"{source} key 'sensors.{channel}.{sensitivity_key}'", _positive, "mV per SI unit"),
            _float_value(sensor.get(noise_key, default.noise_per_sqrt_hz),
                         f"{source} key 'sensors.{channel}.{noise_key}'", _non_negative, "SI unit/√Hz"),
        )
    hammer = None
    if "hammer" in table:
        hammer_table = _table(table, "hammer", source)
        _check_keys(hammer_table, [f.name for f in dataclasses.fields(HammerSpec)], f"{source} [hammer]")
        tip = hammer_table.get("tip", HammerSpec.tip)
        if tip not in TIPS_PULSE_WIDTH_S:
            raise SettingError(f"{source} key 'hammer.tip' = {tip!r}: allowed: {', '.join(TIPS_PULSE_WIDTH_S)}")
        hammer = HammerSpec(
            tip=tip,
            force_n=_float_value(hammer_table.get("force_n", HammerSpec.force_n), f"{source} key 'hammer.force_n'",
                                 _positive, "N"),
            force_spread=_float_value(hammer_table.get("force_spread", HammerSpec.force_spread),
                                      f"{source} key 'hammer.force_spread'", _fraction, "fraction"),
            double_hit_rate=_float_value(hammer_table.get("double_hit_rate", HammerSpec.double_hit_rate),
                                         f"{source} key 'hammer.double_hit_rate'", _fraction, "fraction of hits"),
        )
    effect_tables = table.get("effects", [])
    if not isinstance(effect_tables, list):
        raise SettingError(f"{source} key 'effects': must be an array of tables ([[effects]])")
    effects = tuple(_effect_from_table(item, f"{source} effects[{index}]") for index, item in
                    enumerate(effect_tables))
    return RigSpec(name, mass_kg, model_text, parameters, sensor_specs["force"], sensor_specs["acceleration"],
                   hammer, effects, source)


def _effect_from_table(table: Any, where: str) -> Effect:
    if not isinstance(table, Mapping):
        raise SettingError(f"{where}: must be a table")
    type_name = table.get("type")
    if type_name not in EFFECT_TYPES:
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
            for entry in value:
                _float_value(entry, key_where, _any_number, item.metadata["unit"])
        elif "rule" in item.metadata:
            _float_value(value, key_where, item.metadata["rule"], item.metadata["unit"])
    try:
        effect.validate()
    except EffectValueError as error:
        value = getattr(effect, error.key)
        raise SettingError(f"{where} ({type_name}) key '{error.key}' = {value!r}: {error}") from None


def _validate_spec(spec: RigSpec) -> None:
    source = spec.source
    _float_value(spec.mass_kg, f"{source} key 'mass_kg'", _positive, "kg")
    try:
        model = get_model(spec.film_model)
    except SettingError as error:
        raise SettingError(f"{source} key 'film.model': {error}") from None
    for parameter in model.parameters:
        key = f"{source} key 'film.parameters.{parameter.name}'"
        if parameter.name not in spec.film_parameters:
            raise SettingError(f"{key}: missing; {model.name} needs {', '.join(model.parameter_names)}")
        value = spec.film_parameters[parameter.name]
        if parameter.scale == "log":
            _float_value(value, key, _positive, parameter.unit)
        elif not 0.0 <= value <= 2.0:
            raise SettingError(f"{key} = {value!r}: an order must be between 0 and 2")
    for name in spec.film_parameters:
        if name not in model.parameter_names:
            raise SettingError(f"{source} key 'film.parameters.{name}': not a parameter of {model.name} "
                               f"({', '.join(model.parameter_names)})")
    for index, effect in enumerate(spec.effects):
        if type(effect).type_name not in EFFECT_TYPES:
            raise SettingError(f"{source} effects[{index}]: {type(effect).__name__} is not a registered effect")
        _check_effect(effect, f"{source} effects[{index}]")
    for channel in CHANNELS:
        sensor = spec.sensor(channel)
        sensitivity_key, noise_key = _SENSOR_KEYS[channel]
        _float_value(sensor.sensitivity_mv, f"{source} key 'sensors.{channel}.{sensitivity_key}'", _positive, "mV")
        _float_value(sensor.noise_per_sqrt_hz, f"{source} key 'sensors.{channel}.{noise_key}'", _non_negative, "SI")


# --- physics -------------------------------------------------------------------------------------------------------


def rig_dynamic_stiffness(
    spec: RigSpec, s: np.ndarray, time_s: float = 0.0, *, film_scale: float | None = None
) -> np.ndarray:
    """Linear dynamic stiffness of the mover on its film, ``Z_film·drift + Σ Z_effect + M s²`` (N/m).

    The film's scale is the spec's at ``time_s`` unless ``film_scale`` gives it.
    """
    s = np.asarray(s, dtype=complex)
    scale = spec.film_scale(time_s) if film_scale is None else film_scale
    total = spec.film.stiffness(s, spec.film_parameters) * scale + spec.moving_mass_kg * s**2
    for effect in spec.effects:
        total = total + effect.added_stiffness(s)
    return total


def channel_transfer(spec: RigSpec, channel: str, s: np.ndarray) -> np.ndarray:
    """Product of the effects' transfers on one channel ("force" or "acceleration")."""
    s = np.asarray(s, dtype=complex)
    transfer = np.ones_like(s)
    for effect in spec.effects:
        transfer = transfer * effect.channel_transfer(channel, s)
    return transfer


def rig_accelerance(
    spec: RigSpec, freq_hz: np.ndarray, decay_rate_1_s: float = 0.0, time_s: float = 0.0
) -> np.ndarray:
    """Linear accelerance (m/s²)/N the channels of ``spec`` show at ``s = σ + j2πf`` (cubic stiffness left out)."""
    s = laplace_variable(freq_hz, decay_rate_1_s)
    accelerance = s**2 / rig_dynamic_stiffness(spec, s, time_s)
    return accelerance * channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s)


def _grid_laplace(n_samples: int, sample_rate_hz: float) -> np.ndarray:
    """``s = j2πf`` on the rfft grid of ``n_samples``; the DC bin is nudged off zero so every film is finite."""
    freq_hz = scipy.fft.rfftfreq(n_samples, 1.0 / sample_rate_hz)
    freq_hz[0] = 1e-9 * sample_rate_hz / n_samples
    return 2j * np.pi * freq_hz


def response_duration_s(spec: RigSpec, sample_rate_hz: float, time_s: float = 0.0) -> float:
    """Time after which the rig's impulse response stays below ``DECAY_TOLERANCE`` of its peak (capped).

    Cached per spec, sample rate and film scale (to 0.1 %), so replaying many records costs one evaluation.
    """
    return _cached_response_duration_s(spec.to_toml(), float(sample_rate_hz), round(spec.film_scale(time_s), 3))


@functools.lru_cache(maxsize=64)
def _cached_response_duration_s(spec_toml: str, sample_rate_hz: float, film_scale: float) -> float:
    spec = RigSpec.from_toml(spec_toml)
    n_samples = scipy.fft.next_fast_len(int(MAX_RESPONSE_DURATION_S * sample_rate_hz), real=True)
    s = _grid_laplace(n_samples, sample_rate_hz)
    # a smooth band limit (raised cosine 0.2–0.4·fs) keeps the truncation at Nyquist from ringing on for ever
    ramp = np.clip((s.imag / (2 * np.pi * sample_rate_hz) - 0.2) / 0.2, 0.0, 1.0)
    accelerance = 0.5 * (1.0 + np.cos(np.pi * ramp)) * s**2 / rig_dynamic_stiffness(spec, s, film_scale=film_scale)
    impulse = np.abs(scipy.fft.irfft(accelerance, n_samples))
    causal = impulse[: n_samples // 2]  # the second half holds the band limit's (zero-phase) ringing before t = 0
    envelope_from_end = np.maximum.accumulate(causal[::-1])[::-1]
    decayed = np.flatnonzero(envelope_from_end < DECAY_TOLERANCE * impulse.max())
    if not decayed.size:
        return MAX_RESPONSE_DURATION_S
    return min(MAX_RESPONSE_DURATION_S, 1.25 * decayed[0] / sample_rate_hz + 0.01)


def mover_displacement_spectrum(
    spec: RigSpec, force_spectrum: np.ndarray, s: np.ndarray, n_samples: int, time_s: float = 0.0
) -> np.ndarray:
    """The mover's displacement spectrum (rfft grid of ``n_samples``) for a force spectrum on the same grid.

    Linear films: ``X = F / Z_total``. With cubic stiffness, the periodic problem ``x + R*(k3·x³) = R*f``
    (``R = 1/Z_total``, ``*`` a circular convolution done by FFT) is solved by damped Newton steps with BiCGSTAB on
    matrix-free Jacobian products ``J v = v + R*(3·k3·x²·v)``, continued from the linear response in steps of k3
    when the full hardening is too strong to reach at once. The grid must be long enough for the response to decay.
    """
    receptance = 1.0 / rig_dynamic_stiffness(spec, s, time_s)
    linear = force_spectrum * receptance
    k3 = spec.cubic_stiffness_n_per_m3
    if k3 == 0.0:
        return linear
    x_linear = scipy.fft.irfft(linear, n_samples)
    scale = float(np.max(np.abs(x_linear))) or 1.0

    def apply_receptance(signal: np.ndarray) -> np.ndarray:
        return scipy.fft.irfft(receptance * scipy.fft.rfft(signal), n_samples)

    def residual_norm(displacement: np.ndarray, k3_now: float) -> tuple[np.ndarray, float]:
        residual = displacement - x_linear + apply_receptance(k3_now * displacement**3)
        return residual, float(np.max(np.abs(residual))) / scale

    def newton(k3_now: float, displacement: np.ndarray) -> np.ndarray | None:
        residual, norm = residual_norm(displacement, k3_now)
        for _ in range(12):  # a good continuation step converges fast; a slow one is better halved
            if norm <= 1e-12:
                return displacement
            local_stiffness = 3.0 * k3_now * displacement**2
            jacobian = LinearOperator(
                (n_samples, n_samples), matvec=lambda v: v + apply_receptance(local_stiffness * v), dtype=float
            )
            with np.errstate(all="ignore"):
                step, _ = bicgstab(jacobian, -residual / scale, rtol=min(0.1, norm), atol=0.0, maxiter=200)
            if not np.all(np.isfinite(step)):
                return None
            damping = 1.0
            while damping >= 1 / 64:
                trial = displacement + damping * scale * step
                trial_residual, trial_norm = residual_norm(trial, k3_now)
                if trial_norm < norm:
                    break
                damping /= 2
            else:
                return None
            displacement, residual, norm = trial, trial_residual, trial_norm
        return None

    solved, fraction, increment = x_linear, 0.0, 1.0
    while fraction < 1.0:
        target = min(1.0, fraction + increment)
        result = newton(target * k3, solved)
        if result is None:
            increment /= 2
            if increment < 1 / 256:
                raise GasfilmError(
                    f"{spec.source}: cubic-stiffness k3 = {k3:.3g} N/m³ is too strong for this force; the nonlinear "
                    f"response does not converge"
                )
            continue
        solved, fraction, increment = result, target, 2 * increment
    return scipy.fft.rfft(solved)


def simulate_response(
    spec: RigSpec, force_n: np.ndarray, sample_rate_hz: float, time_s: float = 0.0
) -> np.ndarray:
    """Acceleration (m/s²) the rig's accelerometer channel records for a sampled force record (last axis = time).

    The force is the *recorded* force (band-limited, as measured); channel delays are applied relative to it.
    Linear specs: exact, by a zero-padded FFT long enough for the response to decay (no wrap-around).
    Cubic stiffness: the nonlinear equation of motion solved on a ×2 band-limited-interpolated grid
    (:func:`mover_displacement_spectrum`), the acceleration returned band-limited to the sample rate.
    """
    force = np.asarray(force_n, dtype=float)
    n_record = force.shape[-1]
    pad = int(np.ceil(response_duration_s(spec, sample_rate_hz, time_s) * sample_rate_hz))
    n_fft = scipy.fft.next_fast_len(n_record + pad)
    force_spectrum = scipy.fft.rfft(force, n_fft)
    s = _grid_laplace(n_fft, sample_rate_hz)
    delays = channel_transfer(spec, "acceleration", s) / channel_transfer(spec, "force", s)
    if spec.is_linear:
        response = force_spectrum * (s**2 / rig_dynamic_stiffness(spec, s, time_s)) * delays
        return scipy.fft.irfft(response, n_fft)[..., :n_record]
    oversampling = 2
    n_fine = oversampling * n_fft
    s_fine = _grid_laplace(n_fine, oversampling * sample_rate_hz)
    records = force_spectrum.reshape(-1, force_spectrum.shape[-1])
    out = np.empty((records.shape[0], n_record))
    for row, spectrum in enumerate(records):
        fine_force = np.zeros(s_fine.size, dtype=complex)
        fine_force[: spectrum.size] = spectrum * oversampling
        fine_force[spectrum.size - 1] *= 0.5 if n_fft % 2 == 0 else 1.0
        displacement = mover_displacement_spectrum(spec, fine_force, s_fine, n_fine, time_s)
        acceleration = (s_fine**2 * displacement)[: spectrum.size] / oversampling * delays
        out[row] = scipy.fft.irfft(acceleration, n_fft)[:n_record]
    return out.reshape(force.shape)
