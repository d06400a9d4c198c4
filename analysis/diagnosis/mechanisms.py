"""Step 3 of the diagnosis, *name*: the mechanisms consistent with a description, read off its features.

A description (a term of the written spec: a catalog effect or a generic one — a mode beside the mover, a film branch,
a channel factor) has a place in the chain and features (frequency, damping, sign, order, …). The table below lists,
per place, the mechanisms from the literature that produce a description of that form, with the features each needs
and the measurement that tells it from the others. :func:`mechanisms_for` returns every mechanism consistent with a
description, best first: the first is the name a finding gives; those its features point at as much are ``tied``
with it (the data cannot tell them apart; the measurement listed with each would), the rest are consistent but less
likely.

Sources: D. J. Ewins, *Modal Testing: Theory, Practice and Application* (2000), §3 (hammer tips, force transducers,
accelerometer mounting); Brüel & Kjær, *Piezoelectric Accelerometers and Vibration Preamplifiers* (1987), ch. 4
(mounting resonance) and ch. 5 (a charge sensor on a voltage amplifier: the cable's capacitance and the input
resistance); F. Al-Bender, *Air Bearings: Theory, Design and Applications* (2021), ch. 7–9 (pneumatic
hammer, squeeze films, tilt stiffness); J. J. Blech, *On isothermal squeeze films*, J. Lubrication Technol. 105 (1983);
NI 9234 user manual (AC coupling at 0.5 Hz, the delta-sigma filter's delay); the paper (fractional film models).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from gasfilm.analysis.physics.effects import Effect, FitContext


def _always(effect: Effect, context: FitContext) -> bool:
    return True


@dataclass(frozen=True)
class Mechanism:
    """A physical cause of descriptions of some effect types, when their features fit ``when``."""

    name: str
    effects: tuple[str, ...]
    note: str
    tell_apart: str
    when: Callable[[Effect, FitContext], bool] = _always
    #: how strongly the features point at this mechanism among those consistent (higher first; ties keep the table's
    #: order)
    preference: Callable[[Effect, FitContext], float] = lambda effect, context: 0.0


@dataclass(frozen=True)
class MechanismMatch:
    name: str
    note: str
    tell_apart: str
    tied: bool

    def to_dict(self) -> dict:
        return {"name": self.name, "note": self.note, "tell_apart": self.tell_apart, "tied": self.tied}


def _above_resonance(effect: Effect, context: FitContext) -> bool:
    return getattr(effect, "freq_hz", 0.0) > 1.2 * context.resonance_hz


def _lightly_damped(effect: Effect, context: FitContext) -> bool:
    """A mode damped far less than the film damps the mover (a structure's own mode, not one the film carries)."""
    return getattr(effect, "damping_ratio", 1.0) < 0.3 * context.film_damping_ratio


def _below_resonance(effect: Effect, context: FitContext) -> bool:
    return getattr(effect, "freq_hz", 0.0) < 0.8 * context.resonance_hz


def _positive(effect: Effect, context: FitContext) -> bool:
    """A mode that moves the accelerometer with the hammer's force (a positive modal constant): what a part riding on
    the mover in heave makes; a negative one is seen across a nodal line (tilt or an elastic mode off-centre)."""
    return getattr(effect, "modal_constant_per_kg", 1.0) > 0


def _order_between(low: float, high: float) -> Callable[[Effect, FitContext], bool]:
    """A film branch's spring-pot order within [low, high] (a term without an order, e.g. a squeeze film, passes)."""
    return lambda effect, context: (not hasattr(effect, "order")) or low <= effect.order <= high


def _low_pass(effect: Effect, context: FitContext) -> bool:
    return effect.pole_hz < effect.zero_hz


def _high_pass_in_band(effect: Effect, context: FitContext) -> bool:
    """A first-order factor whose zero lies below the band (a high-pass's zero at the origin) and whose pole lies
    inside it: a discharge far faster than any conditioner's coupling (those sit below the band)."""
    low, high = context.band_hz
    return effect.zero_hz < low <= effect.pole_hz <= high


def _reads_low(effect: Effect, context: FitContext) -> bool:
    """A factor whose gain above its corners is below 1: the signal divided before it is read."""
    return effect.gain_above_corners() < 1.0


#: The mechanisms, by description, the more common first within a description.
MECHANISMS: tuple[Mechanism, ...] = (
    # beside the mover: modes that move the accelerometer beside the mover's own translation
    Mechanism("tilt (pitch or roll) of the mover on its film, seen by an accelerometer off its centre",
              ("side-mode", "structure-mode"),
              "a rigid-body rotation of the mover on the film's tilt stiffness: a mode of its own that an accelerometer "
              "or a hammer off the centre line sees, with a modal constant of either sign, damped by the film as the "
              "heave is", "an accelerometer on the other side of the centre (the sign of the mode flips) or a hit at "
              "the centre", preference=lambda effect, context: float(not _lightly_damped(effect, context))),
    Mechanism("an elastic (bending or twisting) mode of the mover's plate", ("side-mode", "structure-mode"),
              "the mover's own structural mode: far less damped than the modes the gas film carries",
              "accelerometers at two points of the mover (their ratio changes across the mode)", _above_resonance,
              lambda effect, context: float(_lightly_damped(effect, context))),
    Mechanism("a mode of the base, frame or table the bearing stands on (or of a guide in series with the film)",
              ("side-mode", "structure-mode"),
              "the support moves the guide, and with it the mover, in a mode of its own: below the film's resonance "
              "(a soft support) or damped as the film is (a support or guide in series with it)",
              "an accelerometer on the base (it moves most there)",
              preference=lambda effect, context: float(_below_resonance(effect, context)
                                                       or not _lightly_damped(effect, context))),
    Mechanism("a mode of the base, frame, guide or beam the bearing stands on, in series with the film",
              ("support-mode",),
              "what the film stands on moves in a mode of its own (its modal mass at the bearing on its own stiffness, "
              "e.g. a gantry beam's torsion seen off its shear centre): the film's resonance falls and a second one "
              "appears above the support's own frequency (Altintas 2012 ch. 3; Ewins 2000 §2.3)",
              "an accelerometer on the support beside the bearing (it moves most in the second resonance)"),
    Mechanism("a part or fixture riding on the mover (sensor block, cable, clamp)", ("extra-mode", "side-mode"),
              "a small mass on its own compliance on the mover: a peak/dip pair at its frequency, a positive modal "
              "constant", "removing or clamping the part (the pair moves or goes)",
              preference=lambda effect, context: float(_positive(effect, context))),
    Mechanism("an exciter (shaker) left attached to the mover through its stinger", ("extra-mode", "side-mode"),
              "the armature's mass on the stinger's stiffness is a mode on the mover (Ewins §3.3: the exciter "
              "attached alters the structure), lightly damped, with a positive modal constant",
              "disconnecting the stinger (the mode goes)",
              preference=lambda effect, context: float(_positive(effect, context)
                                                       and _lightly_damped(effect, context))),
    Mechanism("a tuned mass damper or absorber on the mover", ("extra-mode",),
              "a deliberate mass-spring-damper on the mover, often heavy and damped, near the film's resonance",
              "the mover's drawings; locking the absorber"),
    # the film's dynamic stiffness
    Mechanism("viscoelastic memory of the film (fractional damping of a porous or graphite restrictor)",
              ("film-memory",), "a fractional Maxwell branch: stiffness and damping changing with frequency as a "
              "power law, as the paper's fractional films and porous bearings have", "a wider band (a softer or harder "
              "tip), or a test at another supply pressure"),
    Mechanism("gas compressibility in the film (a squeeze film stiffening with frequency)",
              ("film-branch", "squeeze-film"),
              "trapped air cannot escape at high squeeze numbers: the film stiffens and damps less as the frequency "
              "rises (stiffness growing as a low power of frequency)",
              "a test at another gap or supply pressure (a squeeze film scales as h0⁻¹ and h0⁻²)",
              _order_between(0.0, 0.7)),
    Mechanism("viscoelastic memory of the film (fractional damping)", ("film-branch",),
              "a power law of frequency between a spring and a dashpot, as the paper's fractional films have",
              "a wider band (a softer or harder tip)", _order_between(0.2, 1.3)),
    Mechanism("extra viscous damping (air shear in a seal or a narrow gap, an eddy-current damper)", ("film-branch",),
              "a dashpot beside the film: damping constant with frequency", "a test at another gap",
              _order_between(0.8, 1.2)),
    Mechanism("inertia of the air moved with the mover or a spread-out moving mass", ("film-branch",),
              "a branch growing close to the square of frequency acts as mass", "weighing the mover",
              _order_between(1.6, 2.0)),
    Mechanism("pneumatic lag of the supply (orifice and pocket volume)", ("pneumatic-lag",),
              "the film force lags the motion through the pocket's air volume; at worst a pneumatic hammer",
              "a change of supply pressure or restrictor"),
    # the measurement chain
    Mechanism("accelerometer mounting resonance (a loose stud, wax, adhesive, magnet or adapter)",
              ("channel-resonance",),
              "the accelerometer on a compliant mount resonates with it: the response reads high towards the "
              "mount's resonance, whatever the structure does",
              "re-mounting the accelerometer on a tightened stud (the resonance moves up or goes)",
              lambda effect, context: effect.channel == "acceleration"),
    Mechanism("hammer head or force-gauge resonance (an extender, a loose tip, a heavy head)", ("channel-resonance",),
              "the force gauge reads the head's own mode on top of the contact force: the FRF falls towards it",
              "another hammer or tip (the resonance moves with the head, not with the structure)",
              lambda effect, context: effect.channel == "force"),
    Mechanism("a low-pass in one channel (signal conditioner, smoothing or a filter in the recorder)",
              ("channel-pole-zero",),
              "the response is filtered where the force is not: its magnitude falls and its phase lags smoothly",
              "both channels through the same conditioner, or its settings checked", _low_pass),
    Mechanism("a high-pass or lead in one channel (a conditioner's coupling, a sensor's discharge time constant)",
              ("channel-pole-zero", "ac-coupling"),
              "the response leads and its magnitude changes smoothly at one end of the band",
              "the conditioners' coupling settings; a static (DC) calibration",
              lambda effect, context: not _low_pass(effect, context) if hasattr(effect, "pole_hz") else True),
    Mechanism("a charge-output sensor read by a voltage input (no charge amplifier): the sensor's and the cable's "
              "capacitance discharging through the input's resistance", ("channel-pole-zero",),
              "a piezoelectric charge accelerometer plugged straight into a voltage input (IEPE off, no charge "
              "amplifier) discharges through the input resistance R: a first-order high-pass at 1/(2πR(C_s + C_c)), "
              "inside the band for a nanofarad on a few hundred kΩ, and the cable's capacitance C_c divides the "
              "sensor's open-circuit sensitivity by C_s/(C_s + C_c), so the response reads low above the corner",
              "the sensor's type (charge or IEPE output) and the input's setting; a charge amplifier in the line (the "
              "corner falls below the band and the gain returns to the sensor's)", _high_pass_in_band,
              lambda effect, context: float(_reads_low(effect, context))),
    Mechanism("a sensor whose sensitivity changes with frequency (a piezoceramic's dielectric relaxation, a charge "
              "amplifier's or a long cable's loss)", ("channel-power-law",),
              "the FRF scaled by a power of frequency with a constant phase", "a back-to-back calibration of the sensor "
              "against a reference over the band"),
    Mechanism("a time offset between the channels (mismatched anti-aliasing filters, a skewed module, an export "
              "shifted by samples)", ("channel-delay",),
              "the phase error grows in proportion to frequency while the magnitude is right",
              "both sensors on one module, or a loop-back of one signal into both channels"),
    Mechanism("a wrong sensitivity or unit (calibration, TEDS, g against m/s², lbf against N)",
              ("sensitivity-error",), "the FRF scaled at every frequency", "a calibration check of both sensors"),
    Mechanism("electrical cross-talk of the force signal into the response (cabling, a shared ground)",
              ("cross-talk",), "a constant added to the FRF, seen where it is small",
              "a recording with the hammer resting on the mover (no impact)"),
    # the mover and changes between hits
    Mechanism("mass added to the mover or a wrong nominal mass (sensor, cable, fixture)", ("added-mass",),
              "the mass line and the resonance move together", "weighing the mover with what rides on it"),
    Mechanism("a steady change of the rig over the session (supply pressure, temperature)", ("drift",),
              "early and late hits resonate differently", "a log of the supply pressure and temperature"),
    Mechanism("a sudden change of the rig during the session (a pressure step, a re-seated part)", ("step-change",),
              "two groups of hits", "the session log"),
    Mechanism("a film whose stiffness depends on the amplitude (hardening or softening)", ("cubic-stiffness",),
              "harder hits resonate at another frequency", "hits over a wider range of force levels"),
    Mechanism("dry friction (a cable, a seal, a contact in the guide)", ("friction",),
              "soft hits look more damped", "hits over a wider range of force levels"),
    Mechanism("flow (quadratic) damping through a gap or an orifice", ("quadratic-damping",),
              "hard hits look more damped", "hits over a wider range of force levels"),
    Mechanism("a sensor mounted or wired the other way round", ("polarity",), "the mass line is negative",
              "the sensor's orientation"),
    # changes between hits of a term (keys "change:target.value"; "*" any)
    Mechanism("a sensor mount loosening during the session (a stud backing off, adhesive or wax softening)",
              ("term-drift:channel-resonance.freq_hz", "term-onset:channel-resonance.*",
               "term-level:channel-resonance.freq_hz"),
              "the chain's own resonance moves from hit to hit", "re-tightening the mount between hits"),
    Mechanism("a part whose stiffness changes with temperature or time (a rubber mount warming, a relaxing joint)",
              ("term-drift:side-mode.freq_hz", "term-drift:extra-mode.freq_hz", "term-drift:side-mode.damping_ratio",
               "term-drift:extra-mode.damping_ratio"),
              "a mode's frequency or damping moves steadily over the session", "a temperature log of the rig"),
    Mechanism("a joint or contact that slips more at higher levels (microslip in a bolted joint, a clamp)",
              ("term-level:side-mode.freq_hz", "term-level:side-mode.damping_ratio", "term-level:extra-mode.freq_hz",
               "term-level:extra-mode.damping_ratio"),
              "a mode softens and damps more on harder hits", "hits over a wider range of force levels"),
    Mechanism("the sensor or the excitation point moving over a mode's nodal line (a walking magnet base, a hammer "
              "that wanders)", ("term-drift:side-mode.modal_constant_per_kg", "term-onset:side-mode.*"),
              "a mode's modal constant changes, even its sign, from hit to hit",
              "marking the sensor's and the hit's positions"),
    Mechanism("the supply or the orifices changing during the session (clogging, a regulator drifting)",
              ("term-drift:pneumatic-lag.tau_lag", "term-drift:pneumatic-lag.k_lag", "term-drift:film-branch.*",
               "term-drift:film-memory.*", "term-drift:squeeze-film.*"),
              "the film's lag or its frequency dependence moves steadily over the session",
              "a log of the supply pressure and flow"),
    Mechanism("a part set down on or taken off the mover during the session (a tool, an indicator, a cable)",
              ("term-onset:added-mass.*", "term-onset:extra-mode.*", "term-onset:side-mode.*",
               "term-onset:film-branch.*"),
              "a term acts from one moment on", "the session log or a photograph of the set-up"),
    Mechanism("an amplitude-dependent film or mount (stiffening or softening with the hit level)",
              ("term-level:*",), "a value follows the hit level", "hits over a wider range of force levels"),
    Mechanism("a value of the rig or of the chain drifting during the session (temperature, supply)",
              ("term-drift:*",), "a value moves steadily over the session", "a log of the rig's conditions"),
    Mechanism("a change of the set-up at one moment of the session", ("term-onset:*",),
              "a term acts from one moment on", "the session log"),
)


def _keys(effect: Effect, target: Effect | None) -> set[str]:
    """The table keys a description answers to: its type, and for a change between hits ``change:target.value``
    with the wildcards ``change:target.*`` and ``change:*``."""
    if target is None:
        return {effect.type_name}
    change, parameter = effect.type_name, getattr(effect, "parameter", "")
    return {f"{change}:{target.type_name}.{parameter}", f"{change}:{target.type_name}.*", f"{change}:*"}


def mechanisms_for(effect: Effect, context: FitContext, target: Effect | None = None,
                   alternatives: tuple[str, ...] = ()) -> list[MechanismMatch]:
    """Every mechanism of :data:`MECHANISMS` consistent with ``effect``'s features (for a change between hits,
    ``target`` is the term it changes), best first: the one its features point at most, ties in the table's order
    (the more specific and the more common first). ``tied`` marks the first and every other whose features point at
    it as much: the data cannot tell those apart (the listed measurement does); the rest are consistent, but less
    likely. ``alternatives``: the types of other terms the data cannot tell from this one (they fitted as well): the
    mechanisms those make whatever their values are tied too."""
    keys = _keys(effect, target)
    subject = effect if target is None else target
    scored = [(mechanism.preference(subject, context), mechanism) for mechanism in MECHANISMS
              if keys & set(mechanism.effects) and mechanism.when(subject, context)]
    scored.sort(key=lambda item: -item[0])
    best = scored[0][0] if scored else 0.0
    matches = [MechanismMatch(mechanism.name, mechanism.note, mechanism.tell_apart, preference == best)
               for preference, mechanism in scored]
    listed = {match.name for match in matches}
    for mechanism in MECHANISMS:
        if (mechanism.name not in listed and mechanism.when is _always
                and any(alternative in mechanism.effects for alternative in alternatives)):
            matches.append(MechanismMatch(mechanism.name, mechanism.note, mechanism.tell_apart, True))
            listed.add(mechanism.name)
    return sorted(matches, key=lambda match: not match.tied)
