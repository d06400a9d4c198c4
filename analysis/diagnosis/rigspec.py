"""Between rig specs (:mod:`gasfilm.analysis.physics`) and the diagnosis's augmented model, both ways.

Every catalog term that changes the rig has an effect type in :mod:`gasfilm.analysis.physics` (``pneumatic-lag`` and
``ac-coupling`` included), so an improved spec loads and plays in the simulator in any process. ``film-memory`` needs no
type: it extends the film network itself with a fractional Maxwell branch ``k_memory -- pot(eta_memory, alpha_memory)``. ``window-damping`` is a property of how the
records were processed, not of the rig; the improved spec says so in a comment.

``amplitude-nonlinearity`` is fitted as a stiffness change that grows with the square of the hit's impulse; the
spec's ``cubic-stiffness`` term ``k3·x³`` is its cause. The two are linked by equivalent linearisation: a hit of
impulse J starts the mover at ``x0 = J / (M ω0)`` and the windowed FRF sees on average ``Δk = c · k3 · x0²`` with
c ≈ 1/4. The constant only needs to be used consistently: the diagnosis replays a hardening model with the exact
nonlinear simulation of :mod:`gasfilm.analysis.physics` at ``k3 = Δk / (c x0²)``, so what it fits is the spec's k3.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gasfilm.analysis.diagnosis.catalog import AugmentedModel
from gasfilm.analysis.physics.elements import PAPER_MODELS, get_model
from gasfilm.analysis.physics.effects import CHANNELS, AddedMass, ChannelDelay, CubicStiffness, Drift, Effect, ExtraMode, Mains, AcCoupling, PneumaticLag
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import SettingError

#: Equivalent linearisation of a cubic spring seen through an FRF of a free decay: ``Δk = c · k3 · x0²``
#: (harmonic balance gives 3/4 at amplitude x0; the decaying amplitude weights it down to about 1/4).
CUBIC_CONSTANT = 0.25
MEMORY_K = "k_memory"
MEMORY_ETA = "eta_memory"
MEMORY_ALPHA = "alpha_memory"


def _resonance_omega(model: AugmentedModel) -> float:
    """Undamped natural frequency of the mass on the film's stiffness at the resonance (fixed-point)."""
    omega = np.sqrt(abs(model.film.stiffness(np.array([1j]), model.film_parameters)[0]) / model.mass_kg)
    for _ in range(20):
        stiffness = model.film.stiffness(np.array([1j * omega]), model.film_parameters)[0].real
        omega = float(np.sqrt(max(stiffness, 1e-9) / model.mass_kg))
    return omega


def reference_displacement_m(model: AugmentedModel, impulse_ns: float) -> float:
    """Initial displacement amplitude ``J / (M ω0)`` of a hit of impulse J."""
    mass_kg = model.mass_kg + model.effects.get("added-mass", {}).get("delta_mass_kg", 0.0)
    return impulse_ns / (mass_kg * _resonance_omega(model))


def model_from_spec(
    spec: RigSpec, reference_impulse_ns: float = 1.0, cubic_constant: float = CUBIC_CONSTANT
) -> AugmentedModel:
    """The augmented model of a rig spec (``mains`` is measurement interference and plays no part in it)."""
    film = get_model(spec.film_model)
    model = AugmentedModel(film, dict(spec.film_parameters), spec.mass_kg, {})
    for effect in spec.effects:
        kind = type(effect).type_name
        if kind in model.effects and kind not in ("added-mass", "channel-delay"):
            raise SettingError(f"{spec.source}: the diagnosis handles one '{kind}' effect per spec, found more")
        if isinstance(effect, AddedMass):
            entry = model.effects.setdefault("added-mass", {"delta_mass_kg": 0.0})
            entry["delta_mass_kg"] += effect.mass_kg
        elif isinstance(effect, ChannelDelay):
            entry = model.effects.setdefault("channel-delay", {"delay_s": 0.0})
            entry["delay_s"] += effect.delay_s if effect.channel == "acceleration" else -effect.delay_s
        elif isinstance(effect, ExtraMode):
            model.effects["extra-mode"] = {"freq_hz": effect.freq_hz, "damping_ratio": effect.damping_ratio,
                                           "mass_kg": effect.mass_kg}
        elif isinstance(effect, Drift):
            model.effects["drift"] = {"fraction_per_hour": effect.fraction_per_hour}
        elif isinstance(effect, PneumaticLag):
            model.effects["pneumatic-lag"] = {"k_lag": effect.k_lag, "tau_lag": effect.tau_lag}
        elif isinstance(effect, AcCoupling):
            if effect.channel != "acceleration":
                raise SettingError(f"{spec.source}: the diagnosis models ac-coupling on the acceleration channel only")
            model.effects["ac-coupling"] = {"corner_hz": effect.corner_hz}
        elif isinstance(effect, CubicStiffness):
            x0 = reference_displacement_m(model, reference_impulse_ns)
            model.effects["amplitude-nonlinearity"] = {
                "delta_k_at_reference_n_per_m": cubic_constant * effect.k3_n_per_m3 * x0**2
            }
        elif not isinstance(effect, Mains):
            raise SettingError(f"{spec.source}: effect type '{kind}' is not known to the diagnosis")
    return model


def spec_from_model(
    model: AugmentedModel,
    base: RigSpec | None,
    reference_impulse_ns: float,
    cubic_constant: float = CUBIC_CONSTANT,
    name: str | None = None,
) -> tuple[RigSpec, list[str]]:
    """The rig spec of an augmented model, keeping the base spec's sensors, hammer and mains (defaults without a
    base); also notes for what a spec cannot hold (``window-damping``, a softening film)."""
    if base is None:
        base = RigSpec(name="diagnosis model", mass_kg=model.mass_kg, film_model=model.film.text,
                       film_parameters=dict(model.film_parameters))
    notes: list[str] = []
    film_text = model.film.name if model.film.name in PAPER_MODELS else model.film.text
    parameters = dict(model.film_parameters)
    effects: list[Effect] = [effect for effect in base.effects if isinstance(effect, Mains)]
    mass_kg = model.mass_kg
    for identifier, values in model.effects.items():
        if identifier == "film-memory":
            film_text = f"({model.film.text}) || ({MEMORY_K} -- pot({MEMORY_ETA}, {MEMORY_ALPHA}))"
            parameters[MEMORY_K] = values["k_memory"]
            parameters[MEMORY_ETA] = values["eta_memory"]
            parameters[MEMORY_ALPHA] = values["alpha_memory"]
        elif identifier == "added-mass":
            delta = values["delta_mass_kg"]
            if delta > 0:
                effects.append(AddedMass(mass_kg=delta))
            else:
                mass_kg = model.mass_kg + delta
        elif identifier == "channel-delay":
            delay = values["delay_s"]
            if delay != 0:
                effects.append(ChannelDelay(channel="acceleration" if delay > 0 else "force", delay_s=abs(delay)))
        elif identifier == "extra-mode":
            effects.append(ExtraMode(freq_hz=values["freq_hz"], damping_ratio=values["damping_ratio"],
                                     mass_kg=values["mass_kg"]))
        elif identifier == "drift":
            effects.append(Drift(fraction_per_hour=values["fraction_per_hour"]))
        elif identifier == "pneumatic-lag":
            effects.append(PneumaticLag(k_lag=values["k_lag"], tau_lag=values["tau_lag"]))
        elif identifier == "ac-coupling":
            effects.append(AcCoupling(channel="acceleration", corner_hz=values["corner_hz"]))
        elif identifier == "amplitude-nonlinearity":
            delta_k = values["delta_k_at_reference_n_per_m"]
            x0 = reference_displacement_m(model, reference_impulse_ns)
            if delta_k > 0:
                effects.append(CubicStiffness(k3_n_per_m3=delta_k / (cubic_constant * x0**2)))
            else:
                notes.append(f"amplitude-nonlinearity: softening (Δk = {delta_k:.3g} N/m at the median hit) has no "
                             f"rig effect type; the spec keeps the linear film")
        elif identifier == "window-damping":
            notes.append(f"window-damping: the records carry an exponential window of decay rate "
                         f"{values['decay_rate_1_s']:.4g} 1/s; process them with it, the rig itself is unchanged")
    spec = dataclasses.replace(
        base,
        name=name or f"{base.name} (improved by gasfilm diagnose)",
        mass_kg=mass_kg,
        film_model=film_text,
        film_parameters=parameters,
        effects=tuple(effects),
    )
    return spec, notes


__all__ = ["AcCoupling", "PneumaticLag", "CHANNELS", "model_from_spec", "spec_from_model",
           "reference_displacement_m"]
