"""Effects: the ways a real rig or its measurement chain departs from the ideal mass on a film.

Each effect is defined here once: its parameters (units, and the physical ranges a fit may explore, derived from the
rig and the session rather than fixed per-hour rates), its frequency-domain term (hooks of :class:`Effect`), its
time-domain form where it is nonlinear (``cubic_stiffness_n_per_m3``, solved by :mod:`.response`), its spec entry
(``to_table``), its plain-language explanation and its evidence sentence. The simulator, the replay, identification
and the diagnosis all evaluate effects through :mod:`.response`, so what the diagnosis fits is what a spec plays.

Kinds: ``rig`` (physics of the mover and film), ``measurement`` (the sensor/DAQ chain: reported as measurement, never
as rig physics) and ``interference`` (additive signals such as mains, never fitted).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from gasfilm.analysis.quantities import with_uncertainty
from gasfilm.drivers.errors import GasfilmError

CHANNELS = ("force", "acceleration")

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


def _finite(value: float) -> str | None:
    return None if math.isfinite(value) else "must be finite"


def _nonzero(value: float) -> str | None:
    return None if value != 0 else "must not be 0"


def _order(value: float) -> str | None:
    return None if 0.0 < value < 2.0 else "must be between 0 and 2"


def _channel_field(default: Any = dataclasses.MISSING) -> Any:
    return field(default=default, metadata={"unit": "", "choices": CHANNELS})


# --- effects -------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FitRange:
    """Where a fit may look for one effect parameter: ``scale`` "log" (> 0) or "linear", and physical bounds."""

    scale: str
    lower: float
    upper: float


@dataclass(frozen=True)
class FitContext:
    """What bounds a term physically in one session: the mover, the film near resonance, the band and the hits."""

    mass_kg: float
    film_stiffness_n_per_m: float  # |Z_film| at the resonance
    resonance_hz: float
    band_hz: tuple[float, float]
    session_span_s: float  # last hit time − first hit time
    max_displacement_m: float  # initial displacement amplitude of the hardest hit, J / (M ω0)
    film_damping_ratio: float = 0.05  # Im Z / (2 Re Z) of the film at the resonance
    blow_span: float = 0.0  # last hit's blow number − first hit's (blows delivered between them)
    #: Film parameters these recordings do not determine (they ran into a bound in the recalibration): held at the
    #: given spec's values in every fit of the diagnosis, never filled in.
    held_film: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Effect:
    """One departure from the ideal mass on a film. Subclasses set ``type_name`` and override the hooks they need."""

    type_name: ClassVar[str] = ""
    kind: ClassVar[str] = "rig"  # "rig", "measurement" or "interference"
    explanation: ClassVar[str] = ""
    per_hit: ClassVar[bool] = False  # the term differs from hit to hit (session time, hit level)
    #: Parameters whose upper fit bound is a valid limiting form of the term, not a failed measurement.
    open_upper: ClassVar[frozenset[str]] = frozenset()
    #: Parameters whose lower fit bound is a valid limiting form of the term (a zero far below the band: at the origin).
    open_lower: ClassVar[frozenset[str]] = frozenset()
    #: Fitted with the spec's own parameters in a diagnosis's recalibration, then held while candidate terms are
    #: tried (a measured structure's modes: many parameters that no candidate term competes with).
    held_after_recalibration: ClassVar[bool] = False
    #: Several effects of this type may describe one rig (several modes beside or on the mover).
    repeatable: ClassVar[bool] = False
    #: A generic description of a place in the chain (a mode beside the mover, a film branch, a channel factor),
    #: not a mechanism: what it is made of is named from its features (analysis/diagnosis/mechanisms.py).
    generic: ClassVar[bool] = False

    def validate(self) -> None:
        """Cross-field checks; raise :class:`EffectValueError` naming the key."""

    # physics hooks ------------------------------------------------------------------------------------------------

    def added_mass_kg(self) -> float:
        return 0.0

    def film_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        """Factor on the film's whole complex stiffness at session time(s) ``time_s``."""
        return 1.0

    def viscous_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        """Extra factor on the film's viscous coefficients (dashpots, spring-pots) at session time(s) ``time_s``."""
        return 1.0

    def added_stiffness(self, s: np.ndarray) -> np.ndarray | float:
        """Dynamic stiffness (N/m) this effect adds to the mover's, at the Laplace variable ``s``."""
        return 0.0

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        """Multiplicative transfer applied to a channel's signal (``channel`` is "force" or "acceleration")."""
        return 1.0

    def added_accelerance(self, s: np.ndarray) -> np.ndarray | float:
        """Accelerance ((m/s²)/N) this effect adds beside the mover's ``s²/Z``: a mode of the measured structure in
        modal superposition (it does not load the mover)."""
        return 0.0

    def support_stiffness(self, s: np.ndarray) -> np.ndarray | None:
        """Dynamic stiffness (N/m) of what the film stands on, in series with the film (``None``: rigid ground)."""
        return None

    def force_leak_m_s2_per_n(self) -> float:
        """Part of the force signal that leaks into the acceleration channel, in (m/s²)/N (electrical cross-talk)."""
        return 0.0

    def cubic_stiffness_n_per_m3(self) -> float:
        return 0.0

    def level_damping_ns_per_m(self, velocity_m_s: np.ndarray) -> np.ndarray | float:
        """Equivalent viscous damping (N·s/m) of an amplitude-dependent damper for hits that start the mover at
        ``velocity_m_s`` (impulse / moving mass)."""
        return 0.0

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        """An additive signal in the channel's SI unit at the given times, or ``None``."""
        return None

    # diagnosis hooks ----------------------------------------------------------------------------------------------

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        """The parameters a fit varies, with the physical ranges it may explore in this session."""
        return {}

    def implausible(self, context: FitContext) -> str | None:
        """Why fitted values are physically absurd (then the term is no finding), or None."""
        return None

    def implausible_in(self, spec: Any, context: FitContext) -> str | None:
        """:meth:`implausible`, with what the term makes of the rig ``spec`` it belongs to (a :class:`RigSpec`)."""
        return self.implausible(context)

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        """What the recordings show, in words, with this term's values; ``where`` says where, with its preposition
        ("in 4065–4155 Hz", "at 3111 Hz": :func:`gasfilm.analysis.quantities.in_band`)."""
        return f"the term improves the fit {where}"

    def place(self) -> str:
        """Where in the chain the effect sits (:data:`PLACES`): a change between hits for per-hit terms, the
        measurement chain for a measurement term whose channel the FRF cannot tell, else the film."""
        if self.per_hit:
            return "between hits"
        return "measurement chain" if self.kind == "measurement" else "film"

    def features(self) -> dict[str, float]:
        """What the description shows, read off its values (frequencies in Hz, damping ratios, delays in s, …): by
        default its fields."""
        return {item.name: float(getattr(self, item.name)) for item in dataclasses.fields(self)
                if isinstance(getattr(self, item.name), (int, float))}

    def features_on(self, spec: Any) -> dict[str, float]:
        """:meth:`features`, with what the term makes of the rig ``spec`` it belongs to (a :class:`RigSpec`): by
        default its features alone."""
        return self.features()

    def to_table(self) -> dict[str, Any]:
        table: dict[str, Any] = {"type": self.type_name}
        for item in dataclasses.fields(self):
            value = getattr(self, item.name)
            table[item.name] = list(value) if isinstance(value, tuple) else value
        return table


#: Where a mismatch can sit in the chain from hammer to accelerometer (:meth:`Effect.place`).
PLACES = ("force channel", "response channel", "measurement chain", "mover", "film", "beside the mover",
          "between hits")

EFFECT_TYPES: dict[str, type[Effect]] = {}


def register_effect(type_name: str) -> Callable[[type[Effect]], type[Effect]]:
    """Class decorator: make an :class:`Effect` subclass available under ``type = "<type_name>"`` in rig specs."""

    def register(cls: type[Effect]) -> type[Effect]:
        cls.type_name = type_name
        EFFECT_TYPES[type_name] = cls
        return cls

    return register


def _channel_place(channel: str) -> str:
    return "force channel" if channel == "force" else "response channel"


def _band_excitable(freq_hz: float, context: FitContext) -> str | None:
    low, high = context.band_hz
    if freq_hz < low or freq_hz > high:
        return f"its frequency {freq_hz:.1f} Hz lies outside the analysis band {low:.0f}–{high:.0f} Hz"
    return None


#: The lightest damping an extra mode may have: its ringing must decay within a simulated record.
MIN_DAMPING_RATIO = 1e-4
#: Where a fit looks for a mode's damping ratio: from :data:`MIN_DAMPING_RATIO`, the fitter's floor, to 0.5.
MODE_DAMPING_RANGE = FitRange("log", MIN_DAMPING_RATIO, 0.5)
#: The lightest part an extra mode may model (kg): lighter ones are far below any measurement's noise.
MIN_MODE_MASS_KG = 1e-9
#: An extra mode more damped than this has no localised peak/dip (half-power width above a fifth of its frequency).
MAX_LOCAL_DAMPING_RATIO = 0.1


@register_effect("extra-mode")
@dataclass(frozen=True)
class ExtraMode(Effect):
    """A mass–spring–damper attached to the mover (natural frequency measured with the mover held still)."""

    explanation: ClassVar[str] = (
        "Something on the mover (a plate, the sensor mount, the fixture) has its own resonance that adds a small "
        "peak and dip to the measured FRF.")
    repeatable: ClassVar[bool] = True

    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    mass_kg: float = _number("kg", _positive)

    def validate(self) -> None:
        if self.mass_kg < MIN_MODE_MASS_KG:
            raise EffectValueError("mass_kg", f"must be at least {MIN_MODE_MASS_KG:g} kg (a lighter part cannot show)")
        if self.damping_ratio < MIN_DAMPING_RATIO:
            raise EffectValueError("damping_ratio", f"must be at least {MIN_DAMPING_RATIO:g} (a mode that never "
                                                    f"decays cannot be simulated)")

    def place(self) -> str:
        return "mover"

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        omega = 2 * np.pi * self.freq_hz
        spring_damper = self.mass_kg * omega**2 + 2 * self.damping_ratio * self.mass_kg * omega * s
        return self.mass_kg * s**2 * spring_damper / (self.mass_kg * s**2 + spring_damper)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        return {"freq_hz": FitRange("log", 0.5 * low, 1.5 * high), "damping_ratio": MODE_DAMPING_RANGE,
                "mass_kg": FitRange("log", 1e-6 * context.mass_kg, context.mass_kg)}

    def implausible(self, context: FitContext) -> str | None:
        if self.mass_kg > 0.2 * context.mass_kg:
            return (f"its mass {self.mass_kg:.3g} kg is {100 * self.mass_kg / context.mass_kg:.0f} % of the mover's "
                    f"{context.mass_kg:.3g} kg: a body that heavy (a counterweight, a second carriage) is a second mode "
                    f"of the rig, not a small part riding on the mover, and a term that heavy can reshape the whole FRF")
        if self.damping_ratio > MAX_LOCAL_DAMPING_RATIO:
            return (f"its damping ratio {self.damping_ratio:.2g} is too large for a peak/dip of its own: it only "
                    f"reshapes the band around {self.freq_hz:.0f} Hz, which other causes do as well")
        if abs(self.freq_hz - context.resonance_hz) < 0.1 * context.resonance_hz:
            return (f"its frequency {self.freq_hz:.1f} Hz lies on the film's own resonance "
                    f"({context.resonance_hz:.0f} Hz): it only reshapes that peak, which other causes do as well")
        return _band_excitable(self.freq_hz, context)

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        mass = f"{self.mass_kg:.3g} kg" if self.mass_kg >= 1.0 else f"{self.mass_kg * 1e3:.3g} g"
        freq = with_uncertainty(self.freq_hz, sigma["freq_hz"], "Hz", ".1f", ".1f")
        return (f"a localised peak/dip pattern near {freq} that the film model cannot produce: an additional resonance "
                f"of {mass} (damping ratio {self.damping_ratio:.3g})")


@register_effect("support-mode")
@dataclass(frozen=True)
class SupportMode(Effect):
    """A mode of what the bearing stands on (a base, a frame, a guide or beam), in series with the film: the film's
    dynamic stiffness ``Z_f`` reaches the ground through the support's ``M s² + 2ζMω s + Mω²`` (its modal mass ``M``
    at the bearing, its natural frequency ``ω`` with the bearing removed), so the mover sees ``Z_f Z_b/(Z_f + Z_b)``:
    the film's resonance falls and a second resonance appears above the support's own."""

    explanation: ClassVar[str] = (
        "What the bearing stands on moves in a mode of its own, in series with the film: the film's resonance is "
        "lower than the film alone gives and a second resonance appears above the support's own frequency.")

    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    mass_kg: float = _number("kg", _positive)

    def validate(self) -> None:
        if self.damping_ratio < MIN_DAMPING_RATIO:
            raise EffectValueError("damping_ratio", f"must be at least {MIN_DAMPING_RATIO:g} (a mode that never "
                                                    f"decays cannot be simulated)")

    def support_stiffness(self, s: np.ndarray) -> np.ndarray:
        omega = 2 * np.pi * self.freq_hz
        return self.mass_kg * (s**2 + 2 * self.damping_ratio * omega * s + omega**2)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        return {"freq_hz": FitRange("log", 0.5 * low, high), "damping_ratio": MODE_DAMPING_RANGE,
                "mass_kg": FitRange("log", 0.05 * context.mass_kg, 100.0 * context.mass_kg)}

    def system_resonances(self, spec: Any) -> tuple[tuple[float, float], tuple[float, float]]:
        """The two resonances (frequency in Hz, damping ratio) of the mover on its film on this support — the film's,
        nearest the film's alone, and the one the support adds: the roots of ``m s²(Z_f + Z_b) + Z_f Z_b``, the film
        taken as the spring and dashpot it is at its own resonance."""
        mass_kg = spec.moving_mass_kg
        # the film's spring and dashpot at its resonance (a fractional film is not constant)
        omega_film = spec.film.resonance_omega_rad_s(spec.film_parameters, mass_kg)
        film_stiffness = complex(spec.film.stiffness(np.array([1j * omega_film]), spec.film_parameters)[0])
        k_f, c_f = film_stiffness.real, film_stiffness.imag / omega_film
        omega = 2 * np.pi * self.freq_hz
        m_b, c_b, k_b = self.mass_kg, 2 * self.damping_ratio * self.mass_kg * omega, self.mass_kg * omega**2
        # m s²·(M s² + (c_f + c_b) s + k_f + k_b) + (k_f + c_f s)(M s² + c_b s + k_b)
        quartic = np.polyadd(mass_kg * np.polymul([1, 0, 0], [m_b, c_f + c_b, k_f + k_b]),
                             np.polymul([c_f, k_f], [m_b, c_b, k_b]))
        roots = np.roots(quartic)
        resonances = [(float(abs(root) / (2 * np.pi)), float(-root.real / abs(root)))
                      for root in roots if root.imag > 0]
        # an over-damped pair is two real roots: its resonance is their geometric mean, its damping ratio ≥ 1
        real = sorted(float(-root.real) for root in roots if root.imag == 0)
        for slow, fast in zip(real[0::2], real[1::2]):
            resonances.append((float(np.sqrt(slow * fast) / (2 * np.pi)), (slow + fast) / (2 * np.sqrt(slow * fast))))
        film_alone_hz = omega_film / (2 * np.pi)
        film, added = sorted(resonances, key=lambda resonance: abs(np.log(resonance[0] / film_alone_hz)))
        return film, added

    def features_on(self, spec: Any) -> dict[str, float]:
        (film_hz, film_zeta), (added_hz, added_zeta) = self.system_resonances(spec)
        return {**self.features(), "film_resonance_hz": film_hz, "film_resonance_damping_ratio": film_zeta,
                "added_resonance_hz": added_hz, "added_resonance_damping_ratio": added_zeta}

    def implausible(self, context: FitContext) -> str | None:
        return _band_excitable(self.freq_hz, context)

    def implausible_in(self, spec: Any, context: FitContext) -> str | None:
        """A support shows itself by the resonance it adds beside the film's: both in the band, the added one a
        resonance of its own; otherwise it only re-describes the film (a film run rigid on the support, whose own
        resonance leaves the band, or the film's damping moved onto the support)."""
        (film_hz, _), (added_hz, added_zeta) = self.system_resonances(spec)
        low, high = context.band_hz
        for name, hz in (("the film's resonance on it", film_hz), ("the resonance it adds", added_hz)):
            if not low <= hz <= high:
                return (f"{name}, {hz:.0f} Hz, lies outside the analysis band {low:.0f}–{high:.0f} Hz: a support "
                        f"whose two resonances the data do not both show only re-describes the film")
        if added_zeta > MAX_LOCAL_DAMPING_RATIO:
            return (f"the resonance it adds at {added_hz:.0f} Hz has a damping ratio of {added_zeta:.2g}: too damped "
                    f"for a resonance of its own, it only reshapes the band, which other causes do as well")
        return self.implausible(context)

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"a second resonance and a lower film resonance that a mode of the support in series with the film "
                f"makes: {with_uncertainty(self.mass_kg, sigma['mass_kg'], 'kg', '.3g')} at the bearing, "
                f"{with_uncertainty(self.freq_hz, sigma['freq_hz'], 'Hz', '.1f', '.1f')} on its own (damping ratio "
                f"{self.damping_ratio:.3g}), {where}")


@register_effect("structure-mode")
@dataclass(frozen=True)
class StructureMode(Effect):
    """One mode of the measured structure in modal superposition, beside the mover: accelerance
    ``(A + B·s/ω_r)·s² / (s² + 2ζω_r s + ω_r²)`` with a signed modal constant ``A`` (1/kg, the mode's high-frequency
    accelerance; the product of the mode shape at the response and the excitation points over the modal mass) and
    ``B`` the quadrature part of a complex modal constant (non-proportional damping; 0 for a real mode). How experimental
    modal analysis describes a structure whose resonances are not each preceded by an antiresonance (a transfer FRF,
    or modes that do not ride on the mover): the mover's ``s²/Z`` is then the residual (rigid-body) mass line."""

    explanation: ClassVar[str] = (
        "The measured structure has a resonance of its own that the mover on its film does not make: a mode in the "
        "modal superposition of the FRF, with its frequency, damping and signed modal constant.")
    held_after_recalibration: ClassVar[bool] = True

    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    modal_constant_per_kg: float = _number("1/kg", _nonzero)
    #: The quadrature part of a complex modal constant (non-proportional damping): 0 for a real mode.
    quadrature_per_kg: float = _number("1/kg", _finite, 0.0)

    def validate(self) -> None:
        if self.damping_ratio < MIN_DAMPING_RATIO:
            raise EffectValueError("damping_ratio", f"must be at least {MIN_DAMPING_RATIO:g} (a mode that never "
                                                    f"decays cannot be simulated)")
        for key in ("modal_constant_per_kg", "quadrature_per_kg"):
            if abs(getattr(self, key)) > MAX_MODAL_CONSTANT_PER_KG:
                raise EffectValueError(key, f"must be at most {MAX_MODAL_CONSTANT_PER_KG:g} 1/kg in size")

    def place(self) -> str:
        return "beside the mover"

    def added_accelerance(self, s: np.ndarray) -> np.ndarray:
        omega = 2 * np.pi * self.freq_hz
        numerator = self.modal_constant_per_kg + self.quadrature_per_kg * s / omega
        return numerator * s**2 / (s**2 + 2 * self.damping_ratio * omega * s + omega**2)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        limit = MAX_MODAL_CONSTANT_PER_KG
        return {"freq_hz": FitRange("log", 0.5 * low, 1.5 * high), "damping_ratio": MODE_DAMPING_RANGE,
                "modal_constant_per_kg": FitRange("linear", -limit, limit),
                "quadrature_per_kg": FitRange("linear", -limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        freq = with_uncertainty(self.freq_hz, sigma["freq_hz"], "Hz", ".1f", ".1f")
        return (f"a resonance near {freq} (damping ratio {self.damping_ratio:.3g}, modal constant "
                f"{self.modal_constant_per_kg:+.3g} 1/kg), {where}")


#: The largest modal constant a structure mode may have (1/kg): a modal mass of a milligram.
MAX_MODAL_CONSTANT_PER_KG = 1e3


@register_effect("polarity")
@dataclass(frozen=True)
class Polarity(Effect):
    """A channel reads the opposite sign: ``T = −1`` on it (a sensor mounted or wired the other way round, or a
    transfer FRF whose rigid-body line is negative)."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "The response has the opposite sign to the one a mass on a film gives: the FRF's mass line is negative "
        "(phase 180° where it should be 0°), as an accelerometer mounted or wired the other way round makes it.")

    channel: str = _channel_field()

    def place(self) -> str:
        return _channel_place(self.channel)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return -1.0 if channel == self.channel else 1.0


@register_effect("cubic-stiffness")
@dataclass(frozen=True)
class CubicStiffness(Effect):
    """The film spring depends on the amplitude: the restoring force gains ``k3·x³`` (k3 > 0 hardening, < 0
    softening; nonlinear, solved in the time domain)."""

    explanation: ClassVar[str] = (
        "The film stiffness depends on how hard the mover is hit: harder hits resonate at a different frequency "
        "than softer ones (a nonlinear, cubic-type film spring).")
    per_hit: ClassVar[bool] = True

    k3_n_per_m3: float = _number("N/m³", _nonzero)

    def cubic_stiffness_n_per_m3(self) -> float:
        return self.k3_n_per_m3

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        # the equivalent stiffness change of the hardest hit stays within ±50 % of the film's
        limit = 0.5 * context.film_stiffness_n_per_m / (CUBIC_EQUIVALENT * context.max_displacement_m**2)
        return {"k3_n_per_m3": FitRange("linear", -limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        change = CUBIC_EQUIVALENT * self.k3_n_per_m3 * context.max_displacement_m**2 / context.film_stiffness_n_per_m
        kind = "stiffer" if self.k3_n_per_m3 > 0 else "softer"
        k3 = with_uncertainty(self.k3_n_per_m3, sigma["k3_n_per_m3"], "N/m³", ".3g")
        return (f"harder hits resonate differently from softer ones: the film is {kind} at large amplitude "
                f"(k3 = {k3}, {100 * change:+.2f} % stiffness at the hardest hit), {where}")


#: Equivalent linearisation of a cubic spring seen through the FRF of a free decay: ``Δk = c · k3 · x0²`` (harmonic
#: balance gives 3/4 at amplitude x0; the decaying amplitude weights it down to about 1/4). Used only to start and
#: bound fits; what is compared with the recordings is the exact nonlinear response.
CUBIC_EQUIVALENT = 0.25


@register_effect("channel-delay")
@dataclass(frozen=True)
class ChannelDelay(Effect):
    """One channel's signal arrives ``delay_s`` late (negative: early) — cable, conditioning, a mismatched module."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "The response channel is shifted in time against the force channel: the phase error grows in proportion to "
        "frequency while the magnitude is right.")

    channel: str = _channel_field()
    delay_s: float = _number("s", _finite)

    def validate(self) -> None:
        if not 0 < abs(self.delay_s) <= 0.1:
            raise EffectValueError("delay_s", "must be non-zero and at most 0.1 s in size")

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return np.exp(-s * self.delay_s) if channel == self.channel else 1.0

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        # more than a quarter period at the top of the band would be a phase wrap, not a delay
        limit = 0.25 / context.band_hz[1]
        return {"delay_s": FitRange("linear", -limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        top_hz = context.band_hz[1]
        lag = self.delay_s if self.channel == "acceleration" else -self.delay_s
        delay = with_uncertainty(lag * 1e6, sigma["delay_s"] * 1e6, "µs", ".1f", ".1f")
        return (f"the phase error grows linearly with frequency while the magnitude matches: the response lags the "
                f"force by {delay} ({360 * top_hz * lag:.2f}° at {top_hz:.0f} Hz)")


@register_effect("added-mass")
@dataclass(frozen=True)
class AddedMass(Effect):
    """Mass moving with the mover that the nominal mass leaves out (sensor, cable, fixture); negative: the nominal
    mass was too large."""

    explanation: ClassVar[str] = (
        "The moving mass is not the nominal one (sensor, cable, fixture or a wrong nominal value): the "
        "high-frequency level 1/m and the resonance both move as a mass change predicts.")

    mass_kg: float = _number("kg", _nonzero)

    def place(self) -> str:
        return "mover"

    def added_mass_kg(self) -> float:
        return self.mass_kg

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"mass_kg": FitRange("linear", -0.5 * context.mass_kg, 0.5 * context.mass_kg)}

    def implausible(self, context: FitContext) -> str | None:
        if abs(self.mass_kg) > 0.3 * context.mass_kg:
            return f"a mass change of {self.mass_kg:+.3g} kg is comparable to the mover's {context.mass_kg:.3g} kg"
        return None

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the high-frequency level and the resonance both move as a mass change of "
                f"{with_uncertainty(self.mass_kg * 1e3, sigma['mass_kg'] * 1e3, 'g', '+.4g')} predicts ({where})")


@register_effect("drift")
@dataclass(frozen=True)
class Drift(Effect):
    """The film changes steadily over the session: its complex stiffness scales with ``1 + fraction_per_hour·t/3600``
    and its viscous coefficients additionally with ``1 + damping_fraction_per_hour·t/3600`` (t = session time)."""

    explanation: ClassVar[str] = (
        "The rig changed steadily during the session (for example the supply pressure): the film follows the hit "
        "time, so early and late hits resonate at slightly different frequencies or damp differently.")
    per_hit: ClassVar[bool] = True

    fraction_per_hour: float = _number("1/h", _finite)
    damping_fraction_per_hour: float = _number("1/h", _finite, 0.0)

    def film_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        return _positive_scale(1.0 + self.fraction_per_hour * np.asarray(time_s) / 3600.0, "drift", time_s)

    def viscous_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        return _positive_scale(1.0 + self.damping_fraction_per_hour * np.asarray(time_s) / 3600.0, "drift", time_s)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        # at most ±50 % change over the session, whatever its length
        limit = 0.5 * 3600.0 / max(context.session_span_s, 1e-3)
        return {"fraction_per_hour": FitRange("linear", -limit, limit),
                "damping_fraction_per_hour": FitRange("linear", -limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        span_h = context.session_span_s / 3600.0
        stiffness, damping = (with_uncertainty(100 * getattr(self, name) * span_h, 100 * sigma[name] * span_h, "%",
                                               "+.2f", ".2f")
                              for name in ("fraction_per_hour", "damping_fraction_per_hour"))
        return (f"the resonance moves steadily from early to late hits: over the {context.session_span_s:.0f} s "
                f"session the film stiffness changes by {stiffness} and its damping by a further {damping}, {where}")


def _positive_scale(scale: np.ndarray, name: str, time_s: np.ndarray | float) -> np.ndarray | float:
    if np.any(scale <= 0):
        raise GasfilmError(f"{name}: the film scale reaches {np.min(scale):.3g} at t = {np.max(time_s):.0f} s")
    return scale if scale.ndim else float(scale)


@register_effect("step-change")
@dataclass(frozen=True)
class StepChange(Effect):
    """The film changes at one moment of the session: from ``at_time_s`` on, its complex stiffness is scaled by
    ``1 + fraction`` and its viscous coefficients further by ``1 + damping_fraction``."""

    explanation: ClassVar[str] = (
        "The rig changed at one moment during the session (a pressure step, a re-seated part): hits before and after "
        "that moment resonate or damp differently, with no trend within each group.")
    per_hit: ClassVar[bool] = True

    at_time_s: float = _number("s of session time", _non_negative)
    fraction: float = _number("1", _finite)
    damping_fraction: float = _number("1", _finite, 0.0)

    def validate(self) -> None:
        if not (-1 < self.fraction and -1 < self.damping_fraction):
            raise EffectValueError("fraction", "the film must keep a positive stiffness and damping (> -1)")

    def film_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        scale = np.where(np.asarray(time_s) >= self.at_time_s, 1.0 + self.fraction, 1.0)
        return scale if scale.ndim else float(scale)

    def viscous_scale(self, time_s: np.ndarray | float) -> np.ndarray | float:
        scale = np.where(np.asarray(time_s) >= self.at_time_s, 1.0 + self.damping_fraction, 1.0)
        return scale if scale.ndim else float(scale)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        # the moment itself is chosen among the gaps between hits, not fitted continuously
        return {"fraction": FitRange("linear", -0.5, 0.5), "damping_fraction": FitRange("linear", -0.5, 0.5)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        stiffness, damping = (with_uncertainty(100 * getattr(self, name), 100 * sigma[name], "%", "+.2f", ".2f")
                              for name in ("fraction", "damping_fraction"))
        return (f"hits before and after t = {self.at_time_s:.1f} s form two groups with no trend inside either: the "
                f"film stiffness steps by {stiffness} and its damping by a further {damping}, {where}")


@register_effect("mains")
@dataclass(frozen=True)
class Mains(Effect):
    """Mains interference on one channel: ``amplitude·Σ h_n·sin(2π n f t)`` with ``harmonics = [h_1, h_2, …]``."""

    kind: ClassVar[str] = "interference"

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
        return self.amplitude * _sine_series(2 * np.pi * self.frequency_hz, self.harmonics,
                                             np.asarray(time_s, dtype=float))


def _sine_series(angular_frequency_rad_s: float, weights: tuple[float, ...], time_s: np.ndarray) -> np.ndarray:
    """``Σ_n w_n·sin(nωt)``, n = 1, 2, …

    On a uniform time grid (a stream's chunk: every time within a millionth of a sample period of a grid met before at
    the same rate) by the angle-addition theorem, ``sin(n(φ₀ + θ_k)) = sin nφ₀·cos nθ_k + cos nφ₀·sin nθ_k`` with
    ``φ₀`` the first time's phase and ``θ_k`` the phase of the k-th offset: one product of 2N numbers with a table of
    ``cos nθ_k, sin nθ_k`` kept per grid, instead of two transcendental functions per time (the same values to about
    1e-12 of the weights, the rounding of ωt itself). On other times directly, the harmonics by
    ``sin((n+1)φ) = 2cos φ·sin(nφ) − sin((n−1)φ)``.
    """
    n_times = time_s.size
    if n_times > 2 and time_s.ndim == 1:
        step_s = (time_s[-1] - time_s[0]) / (n_times - 1)
        if step_s > 0:
            offsets_s, table = _grid_table(angular_frequency_rad_s, len(weights), step_s, n_times)
            start_s = float(time_s[0])
            if np.max(np.abs(time_s - start_s - offsets_s)) <= 1e-6 * step_s:
                start = angular_frequency_rad_s * start_s
                coefficients = [weight * function(n * start) for n, weight in enumerate(weights, 1)
                                for function in (math.sin, math.cos)]
                return np.einsum("h,hk->k", np.array(coefficients), table)  # numpy's loop: no BLAS threads
    phase = angular_frequency_rad_s * time_s
    sine = np.sin(phase)
    total = weights[0] * sine
    if len(weights) > 1:
        twice_cosine = 2.0 * np.cos(phase)
        previous = np.zeros_like(sine)
        for weight in weights[1:]:
            previous, sine = sine, twice_cosine * sine - previous
            total += weight * sine
    return total


#: tables of :func:`_sine_series` by (ω, harmonics, rate to 9 significant digits, times); a few streams at a time
_GRID_TABLES: dict[tuple[float, int, float, int], tuple[np.ndarray, np.ndarray]] = {}


def _grid_table(angular_frequency_rad_s: float, harmonics: int, step_s: float, n_times: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Time offsets ``k·step`` of a uniform grid and the rows ``cos nθ_k, sin nθ_k`` (θ_k = ω·k·step) of the
    harmonics n = 1 … ``harmonics`` (read-only arrays), kept per rate: a stream's later chunks, whose step is known
    less exactly (their times are larger), use the table of its first."""
    key = (angular_frequency_rad_s, harmonics, float(f"{1.0 / step_s:.9g}"), n_times)
    kept = _GRID_TABLES.get(key)
    if kept is None:
        if len(_GRID_TABLES) >= 8:
            _GRID_TABLES.clear()
        offsets_s = np.arange(n_times) * step_s
        angles = np.arange(1, harmonics + 1)[:, np.newaxis] * (angular_frequency_rad_s * offsets_s)
        table = np.stack([np.cos(angles), np.sin(angles)], axis=1).reshape(2 * harmonics, n_times)
        for array in (offsets_s, table):
            array.flags.writeable = False
        kept = _GRID_TABLES[key] = (offsets_s, table)
    return kept


def _time_constant_range(context: FitContext) -> FitRange:
    """Time constants the band can see: a tenth of the shortest to ten times the longest period."""
    low, high = context.band_hz
    return FitRange("log", 0.1 / (2 * np.pi * high), 10.0 / (2 * np.pi * low))


@register_effect("pneumatic-lag")
@dataclass(frozen=True)
class PneumaticLag(Effect):
    """Part of the film force lags the motion by a first-order time constant: ``k_lag / (1 + s·tau_lag)``."""

    explanation: ClassVar[str] = (
        "Air in the orifices and pockets reacts with a delay: part of the film force lags the motion, which lowers "
        "(or even reverses) the film's damping near the resonance.")
    repeatable: ClassVar[bool] = True  # several volumes behind restrictors (pockets, a plenum) each lag on their own

    k_lag: float = _number("N/m", _positive)
    tau_lag: float = _number("s", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        return self.k_lag / (1.0 + s * self.tau_lag)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"k_lag": FitRange("log", 1e-4 * context.film_stiffness_n_per_m, 2.0 * context.film_stiffness_n_per_m),
                "tau_lag": _time_constant_range(context)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"near the resonance the film damps less than a spring-damper can explain: a lagged film force "
                f"(k = {self.k_lag:.3g} N/m, time constant "
                f"{with_uncertainty(self.tau_lag * 1e3, sigma['tau_lag'] * 1e3, 'ms', '.3f', '.3f')}), {where}")


@register_effect("film-memory")
@dataclass(frozen=True)
class FilmMemory(Effect):
    """Viscoelastic memory of the film: a fractional Maxwell branch ``k_memory -- pot(eta_memory, alpha_memory)``
    (complex stiffness ``k η s^α / (k + η s^α)``) in parallel with the film — the paper's FOMGF arms."""

    explanation: ClassVar[str] = (
        "The gas film is stiffer and damps differently at high frequency than at low frequency: it has a "
        "viscoelastic memory that a plain spring and damper cannot describe (a fractional Maxwell branch, a spring "
        "in series with a spring-pot, in parallel with the film).")

    #: k_memory at its upper bound: the branch is a pure spring-pot η s^α beside the film, a valid limit
    open_upper: ClassVar[frozenset[str]] = frozenset({"k_memory"})
    repeatable: ClassVar[bool] = True

    k_memory: float = _number("N/m", _positive)
    eta_memory: float = _number("N·s^α/m", _positive)
    alpha_memory: float = _number("1", _order)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        pot = self.eta_memory * s**self.alpha_memory
        return self.k_memory * pot / (self.k_memory + pot)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        k = context.film_stiffness_n_per_m
        omega = 2 * np.pi * context.resonance_hz
        return {"k_memory": FitRange("log", 1e-4 * k, 1e3 * k),
                "eta_memory": FitRange("log", 1e-6 * k / omega**1.9, 1e3 * k / omega**0.05),
                "alpha_memory": FitRange("linear", 0.05, 1.9)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the residual changes smoothly {where} the way a frequency-dependent stiffness and damping does "
                f"(spring-pot order {with_uncertainty(self.alpha_memory, sigma['alpha_memory'], '', '.2f', '.2f')})")


@register_effect("ac-coupling")
@dataclass(frozen=True)
class AcCoupling(Effect):
    """A first-order high-pass ``s / (s + 2π corner_hz)`` on one channel (beyond the module's own, equal on all)."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "A high-pass in the sensor or DAQ chain (AC coupling) removes low frequencies from the response only: the "
        "phase leads and the magnitude drops at the low end of the band.")

    channel: str = _channel_field()
    corner_hz: float = _number("Hz", _positive)

    def place(self) -> str:
        return _channel_place(self.channel)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return s / (s + 2 * np.pi * self.corner_hz) if channel == self.channel else 1.0

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"corner_hz": FitRange("log", 1e-3 * context.band_hz[0], context.band_hz[0])}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"at the low end of the band the {self.channel} phase leads and its magnitude drops like a high-pass "
                f"at {with_uncertainty(self.corner_hz, sigma['corner_hz'], 'Hz', '.2f', '.2f')}")


@register_effect("sensitivity-error")
@dataclass(frozen=True)
class SensitivityError(Effect):
    """A channel's true sensitivity differs from the configured one: its signal reads ``1 + fraction`` times the
    truth."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "The sensitivity entered for a sensor is not its true sensitivity: the whole FRF is scaled by a constant "
        "factor at every frequency.")

    channel: str = _channel_field()
    fraction: float = _number("1", _finite)

    def validate(self) -> None:
        if not -0.5 < self.fraction < 0.5 or self.fraction == 0:
            raise EffectValueError("fraction", "must be non-zero and between -0.5 and 0.5")

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        return 1.0 + self.fraction if channel == self.channel else 1.0

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"fraction": FitRange("linear", -0.3, 0.3)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        fraction = with_uncertainty(100 * self.fraction, 100 * sigma["fraction"], "%", "+.2f", ".2f")
        return f"the FRF is {fraction} off at every frequency, as a wrong {self.channel} sensitivity makes it"


@register_effect("cross-talk")
@dataclass(frozen=True)
class CrossTalk(Effect):
    """Electrical cross-talk: the acceleration channel also carries ``leak_m_s2_per_n`` times the force signal."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "The response channel picks up a copy of the hammer signal (cabling, a shared ground, the module): a "
        "constant is added to the FRF, which shows most where the true FRF is small (low frequencies, "
        "anti-resonances).")

    leak_m_s2_per_n: float = _number("(m/s²)/N", _nonzero)

    def place(self) -> str:
        return "response channel"

    def force_leak_m_s2_per_n(self) -> float:
        return self.leak_m_s2_per_n

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        limit = 0.5 / context.mass_kg  # half the mass line
        return {"leak_m_s2_per_n": FitRange("linear", -limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        share = 100 * self.leak_m_s2_per_n * context.mass_kg
        leak = with_uncertainty(self.leak_m_s2_per_n, sigma["leak_m_s2_per_n"], "(m/s²)/N", ".3g")
        return (f"a constant {leak} is added to the FRF ({share:+.2f} % of the mass line), most visible where the true "
                f"FRF is small, {where}")


#: The squeeze number at which a squeeze film's loss (the imaginary part of ``1 − tanh(q/2)/(q/2)``, q = √(jσ))
#: peaks: σ ≈ 10.16.
SQUEEZE_LOSS_PEAK = 10.16
#: Air at 20 °C and sea level: the defaults of a squeeze film's ambient pressure and viscosity.
AIR_PRESSURE_PA = 101325.0
AIR_VISCOSITY_PA_S = 1.81e-5


@register_effect("squeeze-film")
@dataclass(frozen=True)
class SqueezeFilm(Effect):
    """The compressible squeeze film of a plate (length × width) on a gap ``gap_m`` (the paper's eqs. 8–11): complex
    stiffness ``(L B Pa / h0)·[1 − tanh(q/2)/(q/2)]`` with ``q = √(12 μ B² s / (Pa h0²))`` — at s = jω its real part
    is K(ω) and its imaginary part ω·C(ω) of eq. 11. A frequency-dependent film named physically: stiff and lightly
    damped at high squeeze numbers, a damper at low ones."""

    explanation: ClassVar[str] = (
        "The air trapped between the mover and its guide is squeezed: at low frequency it flows out and damps, at "
        "high frequency it cannot escape and acts as a spring — the film's stiffness rises and its damping falls with "
        "frequency, as the compressible squeeze-film equation predicts.")

    gap_m: float = _number("m", _positive)
    length_m: float = _number("m", _positive)
    width_m: float = _number("m", _positive, 0.1)
    ambient_pa: float = _number("Pa", _positive, AIR_PRESSURE_PA)
    viscosity_pa_s: float = _number("Pa·s", _positive, AIR_VISCOSITY_PA_S)

    @property
    def static_stiffness_n_per_m(self) -> float:
        """``L B Pa / h0``: the stiffness the film tends to when the air cannot escape (N/m)."""
        return self.length_m * self.width_m * self.ambient_pa / self.gap_m

    @property
    def squeeze_time_s(self) -> float:
        """``12 μ B² / (Pa h0²)``: the squeeze number is this time constant times ω."""
        return 12.0 * self.viscosity_pa_s * self.width_m**2 / (self.ambient_pa * self.gap_m**2)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        half = 0.5 * np.sqrt(self.squeeze_time_s * np.asarray(s, dtype=complex))
        small = np.abs(half) < 1e-3
        if not small.any():  # (the series below only where the squeeze number is tiny)
            return self.static_stiffness_n_per_m * (1.0 - np.tanh(half) / half)
        safe = np.where(small, 1.0, half)
        ratio = np.where(small, half**2 / 3.0 - 2.0 * half**4 / 15.0, 1.0 - np.tanh(safe) / safe)
        return self.static_stiffness_n_per_m * ratio

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"gap_m": FitRange("log", 5e-7, 5e-4), "length_m": FitRange("log", 1e-3, 10.0)}

    def features(self) -> dict[str, float]:
        """Its fields, its air spring, and the frequency where its loss peaks (squeeze number
        :data:`SQUEEZE_LOSS_PEAK`): the film turns there from a damper into a spring, a relaxation's characteristic
        frequency."""
        return {**super().features(), "static_stiffness_n_per_m": self.static_stiffness_n_per_m,
                "characteristic_frequency_hz": SQUEEZE_LOSS_PEAK / (2 * np.pi * self.squeeze_time_s)}

    def implausible(self, context: FitContext) -> str | None:
        if self.static_stiffness_n_per_m > 100 * context.film_stiffness_n_per_m:
            return "its air spring would be a hundred times stiffer than the whole film"
        return None

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        omega = 2 * np.pi * context.resonance_hz
        gap = with_uncertainty(self.gap_m * 1e6, sigma["gap_m"] * 1e6, "µm", ".2f", ".2f")
        return (f"the film stiffens and its damping falls with frequency as a squeeze film does: gap {gap} under a "
                f"{self.length_m * 1e3:.0f} × {self.width_m * 1e3:.0f} mm plate (squeeze number "
                f"{self.squeeze_time_s * omega:.2g} at the resonance), {where}")


@register_effect("friction")
@dataclass(frozen=True)
class Friction(Effect):
    """Dry (Coulomb) friction ``F_c·sign(v)`` on the mover, as an equivalent viscous damping per hit: harmonic balance
    at the hit's initial velocity v gives ``c_eq = 4 F_c / (π v)`` — softer hits are damped more. An effective value:
    the decaying amplitude weights the real friction differently, and the time-domain force is not solved."""

    explanation: ClassVar[str] = (
        "Something rubs (a cable, a seal, a contact in the guide): the damping does not scale with the motion, so "
        "soft hits look more damped than hard ones.")
    per_hit: ClassVar[bool] = True

    friction_force_n: float = _number("N", _positive)

    def level_damping_ns_per_m(self, velocity_m_s: np.ndarray) -> np.ndarray | float:
        return 4.0 * self.friction_force_n / (np.pi * np.maximum(velocity_m_s, 1e-12))

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        film_force_n = context.film_stiffness_n_per_m * context.max_displacement_m
        return {"friction_force_n": FitRange("log", 1e-6 * film_force_n, 0.5 * film_force_n)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the damping grows as hits get softer, as dry friction makes it: an effective friction force of "
                f"{with_uncertainty(self.friction_force_n, sigma['friction_force_n'], 'N', '.3g')}, {where}")


@register_effect("quadratic-damping")
@dataclass(frozen=True)
class QuadraticDamping(Effect):
    """Velocity-squared damping ``c2·|v|·v`` on the mover, as an equivalent viscous damping per hit: harmonic balance
    at the hit's initial velocity v gives ``c_eq = 8 c2 v / (3π)`` — harder hits are damped more. An effective value,
    as for friction."""

    explanation: ClassVar[str] = (
        "The damping grows with speed (air forced through a gap or an orifice at high velocity): hard hits look "
        "more damped than soft ones.")
    per_hit: ClassVar[bool] = True

    coefficient_n_s2_per_m2: float = _number("N·s²/m²", _positive)

    def level_damping_ns_per_m(self, velocity_m_s: np.ndarray) -> np.ndarray | float:
        return 8.0 * self.coefficient_n_s2_per_m2 * np.asarray(velocity_m_s) / (3.0 * np.pi)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        omega = 2 * np.pi * context.resonance_hz
        velocity_m_s = context.max_displacement_m * omega
        # at most the damping of a film with ζ ≈ 0.5 at the hardest hit
        limit = context.film_stiffness_n_per_m / omega / velocity_m_s
        return {"coefficient_n_s2_per_m2": FitRange("log", 1e-6 * limit, limit)}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        c2 = with_uncertainty(self.coefficient_n_s2_per_m2, sigma["coefficient_n_s2_per_m2"], "N·s²/m²", ".3g")
        return f"the damping grows with the hit's velocity, as quadratic (flow) damping makes it: c2 = {c2}, {where}"


# --- generic descriptions: the smallest model of a place in the chain, named afterwards from its features ----------


@register_effect("side-mode")
@dataclass(frozen=True)
class SideMode(StructureMode):
    """A mode beside the mover, as the diagnosis describes a resonance no mechanism of the catalog makes: accelerance
    ``A·s² / (s² + 2ζω s + ω²)`` added to the mover's (modal superposition) with a real signed modal constant ``A``
    (1/kg: positive where the mode moves the accelerometer with the hammer's force, as the mover does; negative
    where it moves it against it)."""

    explanation: ClassVar[str] = (
        "The FRF has a resonance the mover on its film does not make: a mode of something that moves the "
        "accelerometer beside the mover's own motion (a second mode of the mover seen off its centre, the base or "
        "frame, a fixture), described by its frequency, damping and signed modal constant.")
    held_after_recalibration: ClassVar[bool] = False
    repeatable: ClassVar[bool] = True
    generic: ClassVar[bool] = True

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        limit = SIDE_MODE_MASS_LINES / context.mass_kg
        return {"freq_hz": FitRange("log", 0.5 * low, 1.5 * high), "damping_ratio": MODE_DAMPING_RANGE,
                "modal_constant_per_kg": FitRange("linear", -limit, limit)}

    def implausible(self, context: FitContext) -> str | None:
        return _band_excitable(self.freq_hz, context)

    def features(self) -> dict[str, float]:
        return {"frequency_hz": self.freq_hz, "damping_ratio": self.damping_ratio,
                "modal_constant_per_kg": self.modal_constant_per_kg, "sign": float(np.sign(self.modal_constant_per_kg))}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        share = self.modal_constant_per_kg * context.mass_kg
        freq = with_uncertainty(self.freq_hz, sigma["freq_hz"], "Hz", ".1f", ".1f")
        constant = with_uncertainty(self.modal_constant_per_kg, sigma["modal_constant_per_kg"], "1/kg", "+.3g")
        return (f"a resonance near {freq} (damping ratio {self.damping_ratio:.3g}) beside the mover's own motion, with "
                f"a modal constant of {constant} ({share:+.3g} times the mover's mass line), {where}")


#: A side mode's modal constant is at most this many times the mover's mass line 1/M (a modal mass of M/10).
SIDE_MODE_MASS_LINES = 10.0


@register_effect("film-branch")
@dataclass(frozen=True)
class FilmBranch(Effect):
    """A branch added to the film's dynamic stiffness, described by a spring-pot: ``k_ref·(s/(2π f_ref))^order`` —
    a spring at order 0, a dashpot at order 1, a mass at order 2, a power law in between — of stiffness magnitude
    ``stiffness_n_per_m`` at the reference frequency ``reference_hz`` (the film's resonance when it was found)."""

    explanation: ClassVar[str] = (
        "The film's dynamic stiffness differs from the spec's by a part that grows as a power of frequency: its "
        "stiffness and damping change together in a way the spec's film does not have.")
    repeatable: ClassVar[bool] = True
    generic: ClassVar[bool] = True

    stiffness_n_per_m: float = _number("N/m", _positive)
    order: float = _number("1", _order)
    reference_hz: float = _number("Hz", _positive)

    def added_stiffness(self, s: np.ndarray) -> np.ndarray:
        return self.stiffness_n_per_m * (s / (2 * np.pi * self.reference_hz)) ** self.order

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        k = context.film_stiffness_n_per_m
        return {"stiffness_n_per_m": FitRange("log", 1e-5 * k, 10.0 * k), "order": FitRange("linear", *FILM_BRANCH_ORDERS)}

    def features(self) -> dict[str, float]:
        phase = np.pi / 2 * self.order
        return {"order": self.order, "stiffness_n_per_m": self.stiffness_n_per_m * float(np.cos(phase)),
                "damping_ns_per_m": self.stiffness_n_per_m * float(np.sin(phase)) / (2 * np.pi * self.reference_hz),
                "reference_hz": self.reference_hz}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        phase = np.pi / 2 * self.order
        return (f"the film's dynamic stiffness differs by a branch growing as frequency to the power "
                f"{with_uncertainty(self.order, sigma['order'], '', '.2f', '.2f')}: at {self.reference_hz:.0f} Hz "
                f"{self.stiffness_n_per_m * np.cos(phase):+.3g} N/m of stiffness and "
                f"{self.stiffness_n_per_m * np.sin(phase) / (2 * np.pi * self.reference_hz):+.3g} N·s/m of damping, "
                f"{where}")


#: The orders a film branch may take: at 0 a spring-pot is a spring beside the film's own, at 2 a mass beside the
#: mover's — a branch that runs there duplicates the spec (or invents a resonance) and ends at its bound.
FILM_BRANCH_ORDERS = (0.05, 1.95)


@register_effect("channel-resonance")
@dataclass(frozen=True)
class ChannelResonance(Effect):
    """A resonance inside the measurement chain, unity at low frequency, in one of two forms (:data:`RESONANCE_FORMS`):
    a part on a spring and damper whose own motion is read (a sensor on a compliant mount, a head on an extender in
    front of the gauge) transmits ``(ω² + 2ζω s)/(s² + 2ζω s + ω²)``, the damper's force with the spring's; a seismic
    element read by its motion relative to its base (a sensor's own resonance) gives ``ω²/(s² + 2ζω s + ω²)``. On the
    response channel the FRF rises towards it; on the force channel it falls towards it."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "Something between the structure and the recorded signal resonates: the channel's signal is amplified "
        "towards a resonance of the chain itself, whatever the mover does.")
    generic: ClassVar[bool] = True

    channel: str = _channel_field()
    freq_hz: float = _number("Hz", _positive)
    damping_ratio: float = _number("1", _positive)
    form: str = field(default="seismic", metadata={"unit": "", "choices": ("seismic", "transmitted")})

    def place(self) -> str:
        return _channel_place(self.channel)

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        if channel != self.channel:
            return 1.0
        omega = 2 * np.pi * self.freq_hz
        damper = 2 * self.damping_ratio * omega * s
        numerator = omega**2 + damper if self.form == "transmitted" else omega**2
        return numerator / (s**2 + damper + omega**2)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        return {"freq_hz": FitRange("log", 0.5 * low, 5.0 * high), "damping_ratio": FitRange("log", 1e-3, 1.0)}

    def features(self) -> dict[str, float]:
        return {"frequency_hz": self.freq_hz, "damping_ratio": self.damping_ratio}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        way = "rises" if self.channel == "acceleration" else "falls"
        return (f"the FRF {way} towards a resonance of the {self.channel} channel itself near "
                f"{with_uncertainty(self.freq_hz, sigma['freq_hz'], 'Hz', '.0f', '.0f')} (damping ratio "
                f"{self.damping_ratio:.2g}), whatever the mover does, {where}")


@register_effect("channel-pole-zero")
@dataclass(frozen=True)
class ChannelPoleZero(Effect):
    """A first-order factor in the measurement chain: the response reads ``gain·P(s)/|P(j2π·reference_hz)|`` times
    the truth, ``P(s) = (1 + s/ω_z)/(1 + s/ω_p)``: ``gain`` is the factor's magnitude at ``reference_hz`` (0: at DC,
    where P is 1). A low-pass where only the pole lies in or near the band, a lead where only the zero does, a
    high-pass where the pole lies in the band and the zero far below it (at the origin, as every coupling's zero is).
    Normalised inside the band, every corner may run to either side of the band and the factor stays finite there.
    The FRF cannot tell the channel: the same factor inverted on the force channel is the same FRF."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "The measurement chain filters the signals: a first-order lag, lead or high-pass (a pole and a zero) with a "
        "gain scales and turns the FRF smoothly with frequency, whatever the mover does.")
    generic: ClassVar[bool] = True
    #: a corner at its upper bound is far above the band: the factor is then a pure lag or a pure lead, a valid limit
    open_upper: ClassVar[frozenset[str]] = frozenset({"pole_hz", "zero_hz"})
    #: a zero at its lower bound is far below the band: the factor is a high-pass there (its zero at the origin)
    open_lower: ClassVar[frozenset[str]] = frozenset({"zero_hz"})

    pole_hz: float = _number("Hz", _positive)
    zero_hz: float = _number("Hz", _positive)
    gain: float = _number("1", _positive, 1.0)
    reference_hz: float = _number("Hz", _non_negative, 0.0)

    def _shape(self, s: np.ndarray | complex) -> np.ndarray | complex:
        return (1.0 + s / (2 * np.pi * self.zero_hz)) / (1.0 + s / (2 * np.pi * self.pole_hz))

    def _scale(self) -> float:
        """The gain over P's magnitude at the reference frequency."""
        return self.gain / float(abs(self._shape(2j * np.pi * self.reference_hz)))

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        if channel != "acceleration":
            return 1.0
        return self._scale() * self._shape(s)

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        low, high = context.band_hz
        return {"pole_hz": FitRange("log", 0.05 * low, 100.0 * high),
                "zero_hz": FitRange("log", 1e-3 * low, 100.0 * high),
                "gain": FitRange("log", 0.1, 10.0)}

    def implausible(self, context: FitContext) -> str | None:
        """Where it reads most in the band the factor's gain lies within :data:`CHAIN_GAIN_LIMITS`, as a power law's
        gain does: with its corners together or beyond the band it is a gain alone, a power law of exponent 0. (A
        first-order factor's magnitude is monotonic in frequency: largest at an edge of the band.)"""
        edges = 2j * np.pi * np.asarray(context.band_hz, dtype=float)
        largest = float(np.max(np.abs(self.channel_transfer("acceleration", edges))))
        low, high = CHAIN_GAIN_LIMITS
        if low <= largest <= high:
            return None
        return (f"at its largest in the band the response reads {largest:.3g} times the truth: a chain that far off "
                f"everywhere has a wrong sensitivity or unit (the level note), not a filter")

    def gain_below_corners(self) -> float:
        """The factor's magnitude below both corners."""
        return self._scale()

    def gain_above_corners(self) -> float:
        """The factor's magnitude above both corners."""
        return self._scale() * self.pole_hz / self.zero_hz

    def features(self) -> dict[str, float]:
        return {"pole_hz": self.pole_hz, "zero_hz": self.zero_hz, "gain_below_corners": self.gain_below_corners(),
                "gain_above_corners": self.gain_above_corners()}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the FRF is scaled and turned smoothly with frequency as a first-order factor of the measurement "
                f"chain does: a pole at {with_uncertainty(self.pole_hz, sigma['pole_hz'], 'Hz', '.4g')} and a zero at "
                f"{with_uncertainty(self.zero_hz, sigma['zero_hz'], 'Hz', '.4g')}, a gain of "
                f"{with_uncertainty(self.gain, sigma['gain'], '', '.3g')} at "
                f"{self.reference_hz:.0f} Hz ({self.gain_below_corners():.3g} below both corners, "
                f"{self.gain_above_corners():.3g} above both), {where}")


@register_effect("channel-power-law")
@dataclass(frozen=True)
class ChannelPowerLaw(Effect):
    """The measurement chain reads ``gain·(s/(2π f_ref))^exponent`` times the truth: a sensitivity that changes as a
    power of frequency with a constant phase of ``exponent·90°`` (a piezoceramic's dielectric relaxation, a charge
    amplifier's or cable's loss), ``gain`` its magnitude at the reference frequency. The FRF cannot tell the
    channel."""

    kind: ClassVar[str] = "measurement"
    explanation: ClassVar[str] = (
        "A sensor's sensitivity changes slowly with frequency: the FRF is scaled by a power of frequency with a "
        "constant phase, whatever the mover does.")
    generic: ClassVar[bool] = True

    exponent: float = _number("1", _finite)
    reference_hz: float = _number("Hz", _positive)
    gain: float = _number("1", _positive, 1.0)

    def validate(self) -> None:
        if not -POWER_LAW_LIMIT <= self.exponent <= POWER_LAW_LIMIT:
            raise EffectValueError("exponent", f"must be between {-POWER_LAW_LIMIT:g} and {POWER_LAW_LIMIT:g}")

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray | float:
        if channel != "acceleration":
            return 1.0
        return self.gain * (s / (2 * np.pi * self.reference_hz)) ** self.exponent

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"exponent": FitRange("linear", -POWER_LAW_LIMIT, POWER_LAW_LIMIT),
                "gain": FitRange("log", *CHAIN_GAIN_LIMITS)}

    def features(self) -> dict[str, float]:
        return {"exponent": self.exponent, "percent_per_decade": 100.0 * (10.0**self.exponent - 1.0),
                "phase_deg": 90.0 * self.exponent, "gain": self.gain}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the FRF is scaled by frequency to the power "
                f"{with_uncertainty(self.exponent, sigma['exponent'], '', '+.4f', '.4f')} "
                f"({100 * (10**self.exponent - 1):+.2f} % per decade, a constant phase of {90 * self.exponent:+.2f}°; "
                f"{self.gain:.4f} at {self.reference_hz:.0f} Hz), as a sensor whose sensitivity changes with frequency "
                f"makes it, {where}")


#: A channel power law's exponent stays within ±this (±0.3: a factor of 2 per decade).
POWER_LAW_LIMIT = 0.3
#: What a chain factor reads, against the truth, where it reads most in the band: beyond a factor of two a sensitivity
#: or a unit is wrong (the `level` note says which), which no filter of the chain describes.
CHAIN_GAIN_LIMITS = (0.5, 2.0)


# --- changes between hits: a term of the spec whose value moves from hit to hit -------------------------------------


def _term_field() -> Any:
    """The index (in the spec's effects, from 0) of the term a change acts on."""
    return field(metadata={"unit": "", "rule": _term_index})


def _term_index(value: float) -> str | None:
    return None if value >= 0 and float(value) == int(value) else "must be the index (0, 1, …) of an effect"


@dataclass(frozen=True)
class TermChange(Effect):
    """A change between hits of one value of another term of the spec (``term``: its index among the effects,
    ``parameter``: the field): the spec a hit sees is :meth:`RigSpec.at_hit`'s, the term's value moved by
    :meth:`factor` at the hit's session time, impulse and blow number. Adds nothing by itself."""

    per_hit: ClassVar[bool] = True
    generic: ClassVar[bool] = True
    repeatable: ClassVar[bool] = True

    def factor(self, time_s: float, impulse_ns: float, blow: float = 0.0, signed: bool = False) -> float:
        """The factor on the term's value for a hit at ``time_s`` with impulse ``impulse_ns``, the session's blow
        number ``blow`` (0 for the first hit); ``signed``: the value may take either sign (a modal constant)."""
        return 1.0

    def fit_ranges_on(self, target: Effect, context: FitContext) -> dict[str, FitRange]:
        """:meth:`fit_ranges` for a change of ``target``'s value :attr:`parameter`."""
        return self.fit_ranges(context)

    def place(self) -> str:
        return "between hits"


#: The two clocks a steady change runs on: the session's time, or the blows delivered (each hit, wanted or not).
DRIFT_CLOCKS = ("session time", "blows")


@register_effect("term-drift")
@dataclass(frozen=True)
class TermDrift(TermChange):
    """A term's value moves steadily over the session, on one of two clocks (:data:`DRIFT_CLOCKS`): session time
    (``fraction_per_hour``: warming, clogging, creep) or the blows delivered (``fraction_per_blow``, the hit's number
    in the session from 0: a stud backing off, a magnet base walking, a tip wearing, a change each impact makes).

    With ``x`` the rate times the clock: a signed value (a modal constant, a leak) changes by a constant amount,
    ``× (1 + x)``, and may pass through zero (a sensor walking across a nodal line). A value that must stay positive
    (a frequency, a damping, a stiffness, a time constant) changes with session time to first order, ``× (1 + x)``
    (kept above :data:`TERM_CHANGE_FLOOR` of itself), and per blow by a constant fraction of what is left,
    compounded, ``× exp(x)`` (each impact loosens or wears by a share of the present state), never reaching zero."""

    explanation: ClassVar[str] = (
        "A value of the rig or of the measurement chain moves steadily during the session (warming, wear, a "
        "loosening mount, a sensor that walks): early and late hits see it differently.")

    term: int = _term_field()
    parameter: str = field(metadata={"unit": ""})
    fraction_per_hour: float = _number("1/h", _finite, 0.0)
    clock: str = field(default="session time", metadata={"unit": "", "choices": DRIFT_CLOCKS})
    fraction_per_blow: float = _number("1/blow", _finite, 0.0)

    def validate(self) -> None:
        if self.clock == "session time" and self.fraction_per_blow:
            raise EffectValueError("fraction_per_blow", "must be 0 for a drift with session time")
        if self.clock == "blows" and self.fraction_per_hour:
            raise EffectValueError("fraction_per_hour", "must be 0 for a drift with the blows")

    def amount(self, time_s: float, blow: float) -> float:
        """The rate times the clock at a hit (session time ``time_s``, blow number ``blow``)."""
        return self.fraction_per_blow * blow if self.clock == "blows" else self.fraction_per_hour * time_s / 3600.0

    def factor(self, time_s: float, impulse_ns: float, blow: float = 0.0, signed: bool = False) -> float:
        x = self.amount(time_s, blow)
        if signed:
            return 1.0 + x
        if self.clock == "blows":
            return math.exp(min(x, MAX_DRIFT_EXPONENT))
        return max(1.0 + x, TERM_CHANGE_FLOOR)

    def _rate_name(self) -> str:
        return "fraction_per_blow" if self.clock == "blows" else "fraction_per_hour"

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return self._range(context, DRIFT_LIMIT)

    def fit_ranges_on(self, target: Effect, context: FitContext) -> dict[str, FitRange]:
        """A signed value may move by up to :data:`SIGNED_DRIFT_LIMIT` times its first hit's value over the session
        (through zero, anywhere but at the very first hits); a positive one by :data:`DRIFT_LIMIT` with session time,
        by :data:`BLOWS_DRIFT_LIMIT` in its logarithm over the blows."""
        return self._range(context, SIGNED_DRIFT_LIMIT if signed_field(target, self.parameter) else DRIFT_LIMIT)

    def _range(self, context: FitContext, over_session: float) -> dict[str, FitRange]:
        if over_session == DRIFT_LIMIT and self.clock == "blows":
            over_session = BLOWS_DRIFT_LIMIT
        span = context.blow_span if self.clock == "blows" else context.session_span_s / 3600.0
        limit = over_session / max(span, 1e-6)
        return {self._rate_name(): FitRange("linear", -limit, limit)}

    def features(self) -> dict[str, float]:
        return {self._rate_name(): getattr(self, self._rate_name())}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        name = self._rate_name()
        blows = self.clock == "blows"
        span = context.blow_span if blows else context.session_span_s / 3600.0
        rate, spread = getattr(self, name), sigma[name]
        return (f"the term's {self.parameter} moves steadily {'blow by blow' if blows else 'over the session'}: "
                f"{with_uncertainty(rate, spread, '', '+.4g')} per {'blow' if blows else 'hour'} "
                f"({with_uncertainty(rate * span, spread * span, '', '+.3g')} from the first hit to the last), {where}")


#: A steady change of a positive value moves it by at most this fraction over the session with session time (±90 %),
#: its logarithm by at most this over the blows (a factor of 10), and a signed value by at most this many times its
#: first hit's value (through zero).
DRIFT_LIMIT = 0.9
BLOWS_DRIFT_LIMIT = math.log(10.0)
SIGNED_DRIFT_LIMIT = 20.0
#: The exponent a positive value's change is evaluated at, at most (far beyond any fitted session: no overflow).
MAX_DRIFT_EXPONENT = 50.0


def signed_field(effect: Effect, name: str) -> bool:
    """Whether ``effect``'s value ``name`` may take either sign (its rule asks no sign: a modal constant, a leak)."""
    return _signed_field(type(effect), name)


@functools.cache
def _signed_field(kind: type, name: str) -> bool:
    """:func:`signed_field` of an effect type (asked for every hit of every evaluation of a changing spec)."""
    rule = next((item.metadata.get("rule") for item in dataclasses.fields(kind) if item.name == name), None)
    return rule in (_any_number, _finite, _nonzero)


@register_effect("term-level")
@dataclass(frozen=True)
class TermLevel(TermChange):
    """A term's value follows the hit's level: × ``(J/J_ref)^exponent`` for a hit of impulse J (a joint that slips
    more, a mount that softens, a film that stiffens at larger amplitude)."""

    explanation: ClassVar[str] = (
        "A value of the rig depends on how hard the mover is hit: harder hits see it changed (an amplitude-dependent "
        "joint, mount or film).")

    term: int = _term_field()
    parameter: str = field(metadata={"unit": ""})
    exponent: float = _number("1", _finite)
    reference_impulse_ns: float = _number("N·s", _positive)

    def factor(self, time_s: float, impulse_ns: float, blow: float = 0.0, signed: bool = False) -> float:
        return (max(abs(impulse_ns), 1e-12) / self.reference_impulse_ns) ** self.exponent

    def fit_ranges(self, context: FitContext) -> dict[str, FitRange]:
        return {"exponent": FitRange("linear", -2.0, 2.0)}

    def features(self) -> dict[str, float]:
        return {"exponent": self.exponent}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return (f"the term's {self.parameter} follows the hit level as impulse to the power "
                f"{with_uncertainty(self.exponent, sigma['exponent'], '', '+.3f', '.3f')} "
                f"({100 * (2**self.exponent - 1):+.1f} % for a hit twice as hard), {where}")


@register_effect("term-onset")
@dataclass(frozen=True)
class TermOnset(TermChange):
    """A term acts only from one moment of the session on (a part set down on the mover, a sensor re-mounted): its
    value is scaled by ``before`` (0: absent) for hits before ``at_time_s``."""

    explanation: ClassVar[str] = (
        "Something changed at one moment of the session: a term acts from then on (a part set down, a sensor "
        "re-mounted), which hits before that moment do not see.")

    term: int = _term_field()
    parameter: str = field(metadata={"unit": ""})
    at_time_s: float = _number("s of session time", _non_negative)
    before: float = _number("1", _non_negative, 0.0)

    def factor(self, time_s: float, impulse_ns: float, blow: float = 0.0, signed: bool = False) -> float:
        return 1.0 if time_s >= self.at_time_s else max(self.before, TERM_CHANGE_FLOOR)

    def features(self) -> dict[str, float]:
        return {"at_time_s": self.at_time_s}

    def evidence(self, sigma: Mapping[str, float], where: str, context: FitContext) -> str:
        return f"the term acts from {self.at_time_s:.1f} s of the session on, not before, {where}"


#: A change never takes a term's value below this share of itself (a value of 0 is no term, and many are > 0).
TERM_CHANGE_FLOOR = 1e-6
