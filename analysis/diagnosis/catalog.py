"""The catalog of physical effects the diagnosis can name, and the augmented rig model it fits.

The model is evaluated at the FRF level for every accepted hit: the accelerance of the mass on the film, at the
Laplace variable ``s = σ + jω`` of the session's exponential window (an exponentially windowed FRF is the Laplace
accelerance there), with the terms of the effects found so far. Effects that change from hit to hit (drift with the
hit's time, film stiffness with the hit's level) make the model differ per hit:

* ``film-memory``: a fractional Maxwell branch ``k_m -- pot(η, α)`` (complex stiffness ``k_m η s^α / (k_m + η s^α)``)
  in parallel with the film — viscoelastic memory, the paper's FOMGF arms;
* ``pneumatic-lag``: a lagged spring ``k_p / (1 + s τ)`` in parallel with the film — its damping is negative;
* ``extra-mode``: a mass ``m_e`` on a spring and damper (``ω_e``, ``ζ_e``) riding on the mover, adding the dynamic
  stiffness ``m_e s² (k_e + c_e s) / (m_e s² + k_e + c_e s)`` (as :class:`gasfilm.analysis.physics.effects.ExtraMode`);
* ``added-mass``: the moving mass is ``m + Δm``;
* ``drift``: the film's stiffness scales with ``1 + fraction_per_hour · t / 3600 s`` (t the hit's session time);
* ``amplitude-nonlinearity``: the film stiffness gains ``Δk (J / J_ref)²`` (J the hit's impulse) — the equivalent
  linear stiffness of a cubic spring grows with the square of the displacement amplitude;
* ``channel-delay``: the response lags the force by τ: ``× e^{-s τ}``;
* ``ac-coupling``: a first-order high-pass on the response channel: ``× s / (s + 2π f_c)``;
* ``window-damping``: the records carry an exponential window of decay rate ``σ_x`` that the spec does not know
  about: the whole FRF is evaluated at ``s + σ_x``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import numpy as np

from gasfilm.analysis.physics.elements import FilmModel, laplace_variable


@dataclass(frozen=True)
class EffectParameter:
    """One fitted parameter of an effect: name, unit, search scale ("log" > 0 or "linear") and bounds."""

    name: str
    unit: str
    scale: str
    lower: float
    upper: float


@dataclass(frozen=True)
class Effect:
    """A catalog entry: what it is, what it changes and how to explain it to a technician."""

    identifier: str
    parameters: tuple[EffectParameter, ...]
    explanation: str
    per_hit: bool = False


CATALOG: dict[str, Effect] = {
    effect.identifier: effect
    for effect in (
        Effect(
            "film-memory",
            (
                EffectParameter("k_memory", "N/m", "log", 1e2, 1e12),
                EffectParameter("eta_memory", "N·s^α/m", "log", 1e-2, 1e14),
                EffectParameter("alpha_memory", "1", "linear", 0.05, 1.9),
            ),
            "The gas film is stiffer and damps differently at high frequency than at low frequency: it has a "
            "viscoelastic memory that a plain spring and damper cannot describe (a fractional Maxwell branch, a "
            "spring in series with a spring-pot, is added to the film).",
        ),
        Effect(
            "pneumatic-lag",
            (
                EffectParameter("k_lag", "N/m", "log", 1e2, 1e10),
                EffectParameter("tau_lag", "s", "log", 1e-6, 1e-1),
            ),
            "Air in the orifices and pockets reacts with a delay: part of the film force lags the motion, which "
            "lowers (or even reverses) the film's damping near the resonance.",
        ),
        Effect(
            "extra-mode",
            (
                EffectParameter("freq_hz", "Hz", "linear", 1.0, 1e5),
                EffectParameter("damping_ratio", "1", "log", 1e-4, 0.5),
                EffectParameter("mass_kg", "kg", "log", 1e-6, 1e4),
            ),
            "Something on the mover (a plate, the sensor mount, the fixture) has its own resonance that adds a "
            "small peak and dip to the measured FRF.",
        ),
        Effect(
            "added-mass",
            (EffectParameter("delta_mass_kg", "kg", "linear", -1e3, 1e3),),
            "The moving mass is not the nominal one (sensor, cable, fixture or a wrong nominal value): the "
            "high-frequency level 1/m and the resonance both move as a mass change predicts.",
        ),
        Effect(
            "drift",
            (EffectParameter("fraction_per_hour", "1/h", "linear", -1.0, 10.0),),
            "The rig changed during the session (for example the supply pressure): the film stiffness follows the "
            "hit time, so early and late hits resonate at slightly different frequencies.",
            per_hit=True,
        ),
        Effect(
            "amplitude-nonlinearity",
            (EffectParameter("delta_k_at_reference_n_per_m", "N/m", "linear", -1e10, 1e10),),
            "The film stiffness depends on how hard the mover is hit: harder hits resonate at a different frequency "
            "than softer ones (a nonlinear, cubic-type film spring).",
            per_hit=True,
        ),
        Effect(
            "channel-delay",
            (EffectParameter("delay_s", "s", "linear", -1e-2, 1e-2),),
            "The response channel is shifted in time against the force channel: the phase error grows in "
            "proportion to frequency while the magnitude is right.",
        ),
        Effect(
            "ac-coupling",
            (EffectParameter("corner_hz", "Hz", "log", 1e-3, 1e3),),
            "A high-pass in the sensor or DAQ chain (AC coupling) removes low frequencies from the response only: "
            "the phase leads and the magnitude drops at the low end of the band.",
        ),
        Effect(
            "window-damping",
            (EffectParameter("decay_rate_1_s", "1/s", "linear", -1e3, 1e3),),
            "The records were multiplied by an exponential window that the spec does not account for: every "
            "resonance looks more damped than the film really is.",
        ),
    )
}

#: Forward-selection order of preference when candidates explain the data equally well (fewest parameters first).
CANDIDATE_ORDER = (
    "added-mass",
    "channel-delay",
    "drift",
    "amplitude-nonlinearity",
    "ac-coupling",
    "window-damping",
    "film-memory",
    "pneumatic-lag",
    "extra-mode",
)


@dataclass
class HitConditions:
    """What differs between hits: the hit's time in the session (s) and its force impulse (N·s)."""

    time_s: np.ndarray
    impulse_ns: np.ndarray

    @property
    def reference_impulse_ns(self) -> float:
        return float(np.median(self.impulse_ns))


@dataclass
class AugmentedModel:
    """The rig spec as the diagnosis sees it: film model and parameters, mass, and effects with their parameters."""

    film: FilmModel
    film_parameters: dict[str, float]
    mass_kg: float
    effects: dict[str, dict[str, float]] = field(default_factory=dict)

    def copy(self) -> "AugmentedModel":
        return AugmentedModel(
            self.film, dict(self.film_parameters), self.mass_kg, {k: dict(v) for k, v in self.effects.items()}
        )

    def accelerance(
        self, freq_hz: np.ndarray, decay_rate_1_s: float, hits: HitConditions | None = None
    ) -> np.ndarray:
        """Accelerance in (m/s²)/N: shape (hits, frequencies) with ``hits``, else (frequencies,)."""
        effects = self.effects
        extra_decay = effects.get("window-damping", {}).get("decay_rate_1_s", 0.0)
        s = laplace_variable(freq_hz, decay_rate_1_s + extra_decay)
        stiffness = self.film.stiffness(s, self.film_parameters)
        if "film-memory" in effects:
            memory = effects["film-memory"]
            pot = memory["eta_memory"] * s ** memory["alpha_memory"]
            stiffness = stiffness + memory["k_memory"] * pot / (memory["k_memory"] + pot)
        if "pneumatic-lag" in effects:
            lag = effects["pneumatic-lag"]
            stiffness = stiffness + lag["k_lag"] / (1.0 + s * lag["tau_lag"])
        if hits is not None:
            scale = np.ones(len(hits.time_s))
            if "drift" in effects:
                scale = scale + effects["drift"]["fraction_per_hour"] * hits.time_s / 3600.0
            stiffness = scale[:, np.newaxis] * stiffness[np.newaxis, :]
            if "amplitude-nonlinearity" in effects:
                level = (hits.impulse_ns / hits.reference_impulse_ns) ** 2
                delta_k = effects["amplitude-nonlinearity"]["delta_k_at_reference_n_per_m"]
                stiffness = stiffness + (delta_k * level)[:, np.newaxis]
        if "extra-mode" in effects:
            mode = effects["extra-mode"]
            omega = 2 * np.pi * mode["freq_hz"]
            spring_damper = mode["mass_kg"] * (omega**2 + 2 * mode["damping_ratio"] * omega * s)
            stiffness = stiffness + mode["mass_kg"] * s**2 * spring_damper / (mode["mass_kg"] * s**2 + spring_damper)
        mass_kg = self.mass_kg + effects.get("added-mass", {}).get("delta_mass_kg", 0.0)
        h = s**2 / (stiffness + mass_kg * s**2)
        if "channel-delay" in effects:
            h = h * np.exp(-s * effects["channel-delay"]["delay_s"])
        if "ac-coupling" in effects:
            corner = 2 * np.pi * effects["ac-coupling"]["corner_hz"]
            h = h * s / (s + corner)
        return h


@dataclass
class ParameterSlot:
    """One free parameter of a fit: where it lives in the model, how it is scaled, its bounds."""

    owner: str  # "film" or an effect identifier
    name: str
    scale: str
    lower: float
    upper: float

    def to_search(self, value: float) -> float:
        return float(np.log(value)) if self.scale == "log" else float(value)

    def from_search(self, value: float) -> float:
        return float(np.exp(value)) if self.scale == "log" else float(value)

    def search_bounds(self) -> tuple[float, float]:
        return self.to_search(self.lower), self.to_search(self.upper)


def film_slots(model: AugmentedModel) -> list[ParameterSlot]:
    """The film model's own parameters as free slots (orders linear, everything else log-scaled)."""
    return [
        ParameterSlot("film", p.name, p.scale, max(p.lower, 1e-12) if p.scale == "log" else p.lower, p.upper)
        for p in model.film.parameters
    ]


def effect_slots(identifier: str) -> list[ParameterSlot]:
    return [
        ParameterSlot(identifier, p.name, p.scale, p.lower, p.upper) for p in CATALOG[identifier].parameters
    ]


def read_slots(model: AugmentedModel, slots: list[ParameterSlot]) -> np.ndarray:
    """The search-space vector of the slots' current values in ``model``."""
    values = []
    for slot in slots:
        source = model.film_parameters if slot.owner == "film" else model.effects[slot.owner]
        low, high = slot.search_bounds()
        values.append(float(np.clip(slot.to_search(source[slot.name]), low, high)))
    return np.array(values)


def write_slots(model: AugmentedModel, slots: list[ParameterSlot], vector: np.ndarray) -> AugmentedModel:
    """A copy of ``model`` with the slots set from a search-space vector."""
    updated = model.copy()
    for slot, value in zip(slots, vector):
        target = updated.film_parameters if slot.owner == "film" else updated.effects[slot.owner]
        target[slot.name] = slot.from_search(value)
    return updated

