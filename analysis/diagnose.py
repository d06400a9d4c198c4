"""Mismatch diagnosis: where simulation and recordings differ, which physics is missing, and how much it helps.

The rig spec is compared with the recordings under the recordings' own conditions (per-hit FRFs through the same
force and exponential windows, weighted by the measured noise, see :mod:`gasfilm.analysis.diagnosis.measurement`). Then:

1. **recalibrate** the spec's own parameters (film parameters and the parameters of effects it already has); a
   mismatch that this removes is ``parameters-only`` and never blamed on physics;
2. **forward selection** over the catalog (:mod:`gasfilm.analysis.diagnosis.catalog`): each candidate term is fitted
   together with the spec's parameters; the best one enters when it beats its BIC cost on all hits and improves the
   prediction of hits that were not used to fit it; repeat until nothing significant is left;
3. **check back**: with the noise scale of the final model, every term must still pay for itself;
4. **report** findings (where, what, why, how much better) and measurement-quality notes separately.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from gasfilm.analysis.diagnosis.catalog import CATALOG, CANDIDATE_ORDER, AugmentedModel, effect_slots
from gasfilm.analysis.diagnosis.measurement import HitSpectra, QualityNote, hit_spectra
from gasfilm.analysis.diagnosis.rigspec import model_from_spec, spec_from_model
from gasfilm.analysis.diagnosis.selection import (
    BIC_MARGIN,
    HELD_OUT_THRESHOLD,
    Evidence,
    FitOutcome,
    Step,
    best_candidate_fit,
    bic,
    fit,
    held_out_gain,
    model_slots,
)
from gasfilm.analysis.physics.elements import PAPER_MASS_KG
from gasfilm.analysis.physics.response import simulate_response
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.drivers.errors import SettingError

G_M_S2 = 9.80665
MAX_TERMS = 3
NONLINEAR_ITERATIONS = 3


@dataclass
class Finding:
    """A missing piece of physics, named, located, fitted and explained."""

    effect: str
    band_hz: tuple[float, float]
    parameters: dict[str, dict[str, float | str]]  # name → {"value", "uncertainty", "unit"}
    evidence: str
    explanation: str
    hits: str
    chi2_gain: float
    held_out_gain: float

    def to_dict(self) -> dict:
        return {
            "effect": self.effect,
            "band_hz": [round(self.band_hz[0], 1), round(self.band_hz[1], 1)],
            "parameters": self.parameters,
            "evidence": self.evidence,
            "explanation": self.explanation,
            "hits": self.hits,
            "chi2_gain": round(self.chi2_gain, 1),
            "held_out_gain": round(self.held_out_gain, 1),
        }


@dataclass
class Diagnosis:
    """Everything the diagnosis found; ``improved_model`` is the spec with the corrections and terms added."""

    verdict: str  # "consistent", "parameters-only", "missing physics"
    findings: list[Finding]
    quality: list[QualityNote]
    recalibration: dict[str, dict[str, float]]  # name → {"spec", "fitted", "uncertainty"}
    rms_before: float
    rms_recalibrated: float
    rms_after: float
    bic_before: float
    bic_after: float
    chi2_per_point_before: float
    chi2_per_point_after: float
    given_model: AugmentedModel
    improved_model: AugmentedModel
    spectra: HitSpectra
    evidence: Evidence
    wall_time_s: float
    improved_spec: str | None = None  # path of the improved spec TOML when written
    improved_rig_spec: RigSpec | None = None
    spec_notes: list[str] = field(default_factory=list)
    figures: list[str] = field(default_factory=list)

    def replayed_mean(self, model: AugmentedModel | None) -> np.ndarray:
        """H1 of the recordings (``model`` None) or of ``model`` replayed with the recorded forces."""
        return _replayed_mean(self.spectra, model)

    def weighted_residual(self, model: AugmentedModel) -> np.ndarray:
        """χ² per real number at each analysis frequency (replay of ``model`` against the recordings): 1 is noise."""
        return _evidence_for(self.spectra, model).chi2_per_frequency(model) / (2 * self.evidence.hit_count)

    def per_hit_residual(self, model: AugmentedModel) -> np.ndarray:
        """χ² per point of each hit (replay of ``model`` against the recordings)."""
        evidence = _evidence_for(self.spectra, model)
        return np.array([evidence.chi2(model, np.array([hit])) for hit in range(evidence.hit_count)]) / (
            2 * len(evidence.freq_hz)
        )

    @property
    def improvement_e(self) -> float:
        """Equation (35) with the given spec as the reference: RMS reduction in %."""
        return 100.0 * (self.rms_before - self.rms_after) / self.rms_before if self.rms_before > 0 else 0.0

    def to_dict(self) -> dict:
        return {
            "verdict": self.verdict,
            "findings": [f.to_dict() for f in self.findings],
            "quality": [q.to_dict() for q in self.quality],
            "recalibration": self.recalibration,
            "rms_before": self.rms_before,
            "rms_recalibrated": self.rms_recalibrated,
            "rms_after": self.rms_after,
            "rms_unit": "(m/s^2)/N",
            "rms_before_g_per_n": self.rms_before / G_M_S2,
            "rms_after_g_per_n": self.rms_after / G_M_S2,
            "e_percent": self.improvement_e,
            "bic_before": self.bic_before,
            "bic_after": self.bic_after,
            "chi2_per_point_before": self.chi2_per_point_before,
            "chi2_per_point_after": self.chi2_per_point_after,
            "band_hz": [float(self.evidence.freq_hz[0]), float(self.evidence.freq_hz[-1])],
            "hits_used": int(self.evidence.hit_count),
            "decay_rate_1_s": self.evidence.decay_rate_1_s,
            "improved_spec": self.improved_spec,
            "improved_spec_notes": self.spec_notes,
            "figures": self.figures,
            "wall_time_s": self.wall_time_s,
        }


def _silent(message: str) -> None:
    del message


def diagnose_spectra(
    spectra: HitSpectra,
    model: AugmentedModel,
    progress: Callable[[str], None] = _silent,
) -> Diagnosis:
    """Diagnose per-hit spectra against the augmented model of a rig spec."""
    started = time.monotonic()
    evidence = _evidence_for(spectra, model)
    points = evidence.point_count
    chi2_given = evidence.chi2(model)
    rms_given = replay_rms(spectra, model)
    progress(f"compared {evidence.hit_count} hits on {len(evidence.freq_hz)} frequencies "
             f"{evidence.freq_hz[0]:.0f}–{evidence.freq_hz[-1]:.0f} Hz: χ²/point {chi2_given / points:.2f}")

    own_slots = model_slots(model)
    recalibrated = fit(evidence, model, own_slots)
    recalibration_gain = chi2_given - recalibrated.chi2
    recalibration_significant = recalibration_gain > len(own_slots) * np.log(points) + BIC_MARGIN
    current = recalibrated if recalibration_significant else FitOutcome(model, chi2_given, own_slots,
                                                                          recalibrated.covariance, 0)
    if recalibration_significant:
        evidence = _evidence_for(spectra, current.model)
        current = fit(evidence, current.model, own_slots)
    progress(f"recalibrated {len(own_slots)} spec parameter(s): χ² {chi2_given:.0f} → {recalibrated.chi2:.0f}"
             + (" (significant)" if recalibration_significant else " (within the noise)"))

    steps: list[Step] = []
    while len(steps) < MAX_TERMS:
        trials = []
        for identifier in CANDIDATE_ORDER:
            if identifier in current.model.effects:
                continue
            outcome, candidate_evidence = _candidate_fit(spectra, evidence, current.model, identifier)
            extra = len(CATALOG[identifier].parameters)
            gain = current.chi2 - outcome.chi2
            trials.append((gain - extra * np.log(points), identifier, outcome, candidate_evidence))
        trials.sort(key=lambda trial: trial[0], reverse=True)
        summary = ", ".join(f"{identifier} {score:+.0f}" for score, identifier, _, _ in trials[:4])
        progress(f"step {len(steps) + 1}: BIC gain of the best candidates: {summary}")
        accepted = None
        for score, identifier, outcome, candidate_evidence in trials[:3]:
            if score <= BIC_MARGIN:
                break
            gain_held_out = held_out_gain(evidence, current.model, candidate_evidence, outcome.model)
            progress(f"  {identifier}: held-out χ² gain {gain_held_out:.0f} (needs > {HELD_OUT_THRESHOLD:.0f})")
            if gain_held_out > HELD_OUT_THRESHOLD:
                accepted = (identifier, outcome, gain_held_out, candidate_evidence)
                break
        if accepted is None:
            break
        identifier, outcome, gain_held_out, evidence = accepted
        steps.append(Step(identifier, current.chi2, outcome.chi2, gain_held_out))
        evidence = _evidence_for(spectra, outcome.model)
        current = fit(evidence, outcome.model, outcome.slots)

    steps, current, refits_without = _check_back(evidence, steps, current, progress)
    findings = [_finding(evidence, step, current, refits_without[step.identifier]) for step in steps]
    if findings:
        verdict = "missing physics"
    elif recalibration_significant:
        verdict = "parameters-only"
    else:
        verdict = "consistent"
    recalibration = _recalibration_table(model, current) if recalibration_significant else {}
    chi2_after = current.chi2
    return Diagnosis(
        verdict=verdict,
        findings=findings,
        quality=list(spectra.quality),
        recalibration=recalibration,
        rms_before=rms_given,
        rms_recalibrated=replay_rms(spectra, recalibrated.model),
        rms_after=replay_rms(spectra, current.model),
        bic_before=bic(chi2_given, 0, points),
        bic_after=bic(chi2_after, len(current.slots) if (steps or recalibration_significant) else 0, points),
        chi2_per_point_before=chi2_given / points,
        chi2_per_point_after=chi2_after / points,
        given_model=model,
        improved_model=current.model,
        spectra=spectra,
        evidence=evidence,
        wall_time_s=time.monotonic() - started,
    )


def _model_function(model: AugmentedModel, spectra: HitSpectra) -> Callable[[np.ndarray, float], np.ndarray]:
    return lambda freq_hz, decay_rate_1_s: model.accelerance(freq_hz, decay_rate_1_s, spectra.conditions)


def _model_key(model: AugmentedModel) -> tuple:
    return (model.film.text, model.mass_kg, tuple(sorted(model.film_parameters.items())),
            tuple(sorted((name, tuple(sorted(values.items()))) for name, values in model.effects.items())))


def _nonlinear_replay(spectra: HitSpectra, model: AugmentedModel) -> np.ndarray | None:
    """Per-hit FRFs of the exact nonlinear simulation (cubic film spring) played with the recorded forces, or None
    when the model is linear (or softening, which the rig cannot simulate). Remembered per model."""
    replay = spectra.replay
    delta_k = model.effects.get("amplitude-nonlinearity", {}).get("delta_k_at_reference_n_per_m", 0.0)
    if replay is None or delta_k <= 0:
        return None
    key = _model_key(model)
    if key not in replay.nonlinear_cache:
        replay.nonlinear_cache[key] = _simulate_nonlinear(spectra, model)
    return replay.nonlinear_cache[key]


def _simulate_nonlinear(spectra: HitSpectra, model: AugmentedModel) -> np.ndarray:
    """Replay with the hardening film: the exact nonlinear simulation of the median hit gives the shape of the
    nonlinear distortion beyond the equivalent linear stiffness; to first order in k3 it scales with the square of
    each hit's impulse (``x0² ∝ J²``), which is how it is carried to the other hits' (exact) linear replays."""
    replay = spectra.replay
    impulses = spectra.conditions.impulse_ns
    reference = int(np.argmin(np.abs(impulses - np.median(impulses))))
    spec, _ = spec_from_model(model, None, spectra.conditions.reference_impulse_ns)
    response = simulate_response(spec, replay.forces_n[reference], replay.sample_rate_hz,
                                 time_s=float(spectra.conditions.time_s[reference]))
    exact = replay.single(reference).windowed_frf(response[np.newaxis, :])[0]
    linear = replay.replayed(_model_function(model, spectra))
    distortion = exact / linear[reference] - 1.0
    scale = (impulses / impulses[reference]) ** 2
    return linear * (1.0 + scale[:, np.newaxis] * distortion[np.newaxis, :])


def _evidence_for(spectra: HitSpectra, model: AugmentedModel) -> Evidence:
    """Evidence whose per-hit FRFs are corrected by the replay of ``model`` (see :class:`HitSpectra`); the replay is
    the exact nonlinear simulation when the model has a hardening film spring."""
    return Evidence(spectra.correct_for_replay(_model_function(model, spectra), _nonlinear_replay(spectra, model)))


def _replayed_mean(spectra: HitSpectra, model: AugmentedModel | None) -> np.ndarray:
    """H1 (noise-weighted mean over hits) of the recordings, or of ``model`` replayed with the recorded forces."""
    replay = spectra.replay
    if replay is None:
        raise SettingError("diagnosis: these spectra keep no recorded forces to replay a model with")
    if model is None:
        per_hit = replay.measured_h
    else:
        per_hit = _nonlinear_replay(spectra, model)
        if per_hit is None:
            per_hit = replay.replayed(_model_function(model, spectra))
    weight = 1.0 / replay.measured_variance
    return (weight * per_hit).sum(axis=0) / weight.sum(axis=0)


def replay_rms(spectra: HitSpectra, model: AugmentedModel) -> float:
    """Equation (33) under identical conditions: RMS over the analysis frequencies of |H1 recorded − H1 replayed|,
    in (m/s²)/N (both averaged over hits the same way)."""
    difference = _replayed_mean(spectra, None) - _replayed_mean(spectra, model)
    return float(np.sqrt(np.mean(np.abs(difference) ** 2)))


def _candidate_fit(
    spectra: HitSpectra, evidence: Evidence, model: AugmentedModel, identifier: str
) -> tuple[FitOutcome, Evidence]:
    """Fit the model plus one candidate; a hardening film is refitted against its exact nonlinear replay until the
    stiffness change settles (the equivalent linear fit only starts it)."""
    outcome = best_candidate_fit(evidence, model, identifier)
    if identifier != "amplitude-nonlinearity":
        return outcome, evidence
    current_chi2 = evidence.chi2(fit(evidence, model, model_slots(model)).model)
    if current_chi2 - outcome.chi2 < np.log(evidence.point_count):
        return outcome, evidence  # not even the equivalent linear term pays for itself: no nonlinear replay
    key = "delta_k_at_reference_n_per_m"
    for _ in range(NONLINEAR_ITERATIONS):
        previous = outcome.model.effects[identifier][key]
        if previous <= 0:
            break
        evidence = _evidence_for(spectra, outcome.model)
        outcome = fit(evidence, outcome.model, outcome.slots)
        if abs(outcome.model.effects[identifier][key] - previous) <= 0.02 * abs(previous):
            break
    return outcome, evidence


def _check_back(
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    progress: Callable[[str], None],
) -> tuple[list[Step], FitOutcome, dict[str, AugmentedModel]]:
    """Drop terms that no longer pay for themselves once the final model's noise scale is known.

    Also returns, for every term kept, the final model refitted without it (where the term is needed is where
    that refit fails).
    """
    points = evidence.point_count
    while steps:
        noise_scale = max(1.0, current.chi2 / (points - len(current.slots)))
        trials = []
        for step in steps:
            reduced = current.model.copy()
            del reduced.effects[step.identifier]
            refit = fit(evidence, reduced, model_slots(reduced))
            cost = (refit.chi2 - current.chi2) / noise_scale - len(CATALOG[step.identifier].parameters) * np.log(points)
            trials.append((cost, step, refit))
        cost, step, refit = min(trials, key=lambda trial: trial[0])
        if cost > BIC_MARGIN:
            return steps, current, {trial_step.identifier: trial_refit.model for _, trial_step, trial_refit in trials}
        progress(f"check back: {step.identifier} no longer significant (noise scale {noise_scale:.2f}); removed")
        steps = [s for s in steps if s is not step]
        current = refit
    return steps, current, {}


def _recalibration_table(model: AugmentedModel, outcome: FitOutcome) -> dict[str, dict[str, float]]:
    table = {}
    for index, slot in enumerate(outcome.slots):
        if slot.owner != "film" and slot.owner not in model.effects:
            continue  # a term the diagnosis added: reported as a finding
        source = model.film_parameters if slot.owner == "film" else model.effects[slot.owner]
        target = outcome.model.film_parameters if slot.owner == "film" else outcome.model.effects[slot.owner]
        name = slot.name if slot.owner == "film" else f"{slot.owner}.{slot.name}"
        table[name] = {"spec": source[slot.name], "fitted": target[slot.name],
                       "uncertainty": outcome.uncertainty(index)}
    return table


def _effect_band(evidence: Evidence, final: AugmentedModel, without: AugmentedModel) -> tuple[float, float]:
    """The band holding 80 % of the χ² the term removes against the rest refitted without it.

    Refitting matters: a term that also shifts the main resonance (an extra mode's mass, say) is partly absorbed by
    the recalibrated film, and what is left is where the term itself is needed.
    """
    gain = np.clip(evidence.chi2_per_frequency(without) - evidence.chi2_per_frequency(final), 0.0, None)
    freq_hz = evidence.freq_hz
    if gain.sum() <= 0:
        return float(freq_hz[0]), float(freq_hz[-1])
    cumulative = np.cumsum(gain) / gain.sum()
    low = freq_hz[min(np.searchsorted(cumulative, 0.1), len(freq_hz) - 1)]
    high = freq_hz[min(np.searchsorted(cumulative, 0.9), len(freq_hz) - 1)]
    return float(low), float(high)


def _finding(evidence: Evidence, step: Step, final: FitOutcome, without: AugmentedModel) -> Finding:
    identifier = step.identifier
    slots = effect_slots(identifier)
    parameters: dict[str, dict[str, float | str]] = {}
    values = final.model.effects[identifier]
    for slot, spec in zip(slots, CATALOG[identifier].parameters):
        index = next(i for i, s in enumerate(final.slots) if s.owner == identifier and s.name == slot.name)
        parameters[slot.name] = {"value": values[slot.name], "uncertainty": final.uncertainty(index),
                                 "unit": spec.unit}
    band = _effect_band(evidence, final.model, without)
    gain = step.chi2_before - step.chi2_after
    hits = "all hits"
    if CATALOG[identifier].per_hit:
        hits = f"all {evidence.hit_count} hits, " + (
            "trend with hit time" if identifier == "drift" else "trend with hit force level"
        )
    return Finding(
        effect=identifier,
        band_hz=band,
        parameters=parameters,
        evidence=_evidence_sentence(identifier, parameters, band, gain, step.held_out_gain, evidence),
        explanation=CATALOG[identifier].explanation,
        hits=hits,
        chi2_gain=gain,
        held_out_gain=step.held_out_gain,
    )


def _value(parameters: dict, name: str) -> tuple[float, float]:
    return float(parameters[name]["value"]), float(parameters[name]["uncertainty"])


def _evidence_sentence(
    identifier: str, parameters: dict, band: tuple[float, float], gain: float, held_out: float, evidence: Evidence
) -> str:
    where = f"{band[0]:.0f}–{band[1]:.0f} Hz"
    scale = f"χ² falls by {gain:.0f} on all hits and by {held_out:.0f} on hits left out of the fit"
    if identifier == "channel-delay":
        delay, sigma = _value(parameters, "delay_s")
        phase = 360 * band[1] * delay
        return (f"The phase error grows linearly with frequency while the magnitude matches: the response lags by "
                f"{delay * 1e6:.1f} ± {sigma * 1e6:.1f} µs ({phase:.2f}° at {band[1]:.0f} Hz); {scale}.")
    if identifier == "added-mass":
        mass, sigma = _value(parameters, "delta_mass_kg")
        return (f"The high-frequency level and the resonance both move as a mass change of {mass * 1e3:+.0f} ± "
                f"{sigma * 1e3:.0f} g predicts ({where}); {scale}.")
    if identifier == "drift":
        rate, sigma = _value(parameters, "fraction_per_hour")
        span = float(np.ptp(evidence.spectra.conditions.time_s))
        return (f"The resonance moves steadily from early to late hits: the film stiffness changes by "
                f"{rate * span / 36:+.2f} % over the {span:.0f} s session ({rate * 100:+.1f} ± "
                f"{sigma * 100:.1f} %/h), in {where}; {scale}.")
    if identifier == "amplitude-nonlinearity":
        delta_k, sigma = _value(parameters, "delta_k_at_reference_n_per_m")
        impulses = evidence.spectra.conditions.impulse_ns
        return (f"Harder hits resonate differently from softer ones: the stiffness changes by {delta_k:.3g} ± "
                f"{sigma:.2g} N/m at the median hit (impulses {impulses.min():.3f}–{impulses.max():.3f} N·s), "
                f"in {where}; {scale}.")
    if identifier == "extra-mode":
        frequency, sigma = _value(parameters, "freq_hz")
        return (f"A localised peak/dip pattern near {frequency:.1f} ± {sigma:.1f} Hz that the film model cannot "
                f"produce: an additional resonance ({where}); {scale}.")
    if identifier == "film-memory":
        alpha, sigma = _value(parameters, "alpha_memory")
        return (f"The residual changes smoothly across {where} the way a frequency-dependent stiffness and damping "
                f"does (spring-pot order {alpha:.2f} ± {sigma:.2f}); {scale}.")
    if identifier == "pneumatic-lag":
        tau, sigma = _value(parameters, "tau_lag")
        return (f"Near the resonance the film damps less than a spring-damper can explain: a lagged film force "
                f"(time constant {tau * 1e3:.3f} ± {sigma * 1e3:.3f} ms), in {where}; {scale}.")
    if identifier == "ac-coupling":
        corner, sigma = _value(parameters, "corner_hz")
        return (f"At the low end of the band the response phase leads and its magnitude drops like a high-pass at "
                f"{corner:.2f} ± {sigma:.2f} Hz on the response channel; {scale}.")
    decay, sigma = _value(parameters, "decay_rate_1_s")
    return (f"Every resonance is wider by the same decay rate {decay:.2f} ± {sigma:.2f} 1/s, as an exponential "
            f"window the spec does not know about would make it; {scale}.")


@dataclass
class Recordings:
    """Hits to diagnose: records (hits, 2, samples), force in N and response in m/s², with what is known about them.
    :func:`load_recordings` reads them from a session or a UFF file; any other source can fill one in directly."""

    records: np.ndarray
    sample_rate_hz: float
    hit_times_s: np.ndarray
    window: WindowSettings | None
    overload: np.ndarray | None
    rig_spec_toml: str | None
    source: str
    quality: list[QualityNote] = field(default_factory=list)


def load_recordings(path: str | Path) -> Recordings:
    """Accepted hits of a gasfilm session (HDF5) or every hit of a UFF 58 file with time records."""
    path = Path(path)
    if path.suffix.lower() in (".uff", ".unv"):
        from gasfilm.analysis.uff import read_uff_time_records

        uff = read_uff_time_records(path)
        return Recordings(uff.records, uff.sample_rate_hz, np.asarray(uff.start_times_s, float), None, None, None,
                          str(path))
    from gasfilm.analysis.session import Session

    with Session.open(path) as session:
        stored = session.hits()
        accepted = [hit for hit in stored if hit.verdict.accepted]
        rejected = [hit for hit in stored if not hit.verdict.accepted]
        if len(accepted) < 2:
            raise SettingError(f"{path}: {len(accepted)} accepted hit(s); the diagnosis needs at least 2")
        records = np.stack([np.stack((hit.data[hit.force_channel], hit.data[hit.response_channel]))
                            for hit in accepted])
        times = np.array([hit.start_time_s + hit.trigger_index / hit.sample_rate_hz for hit in accepted])
        overload = np.stack([hit.overload[[hit.force_channel, hit.response_channel]] for hit in accepted])
        window_settings = session.settings.get("window")
        window = None
        if isinstance(window_settings, dict):
            known = {key: window_settings[key] for key in ("force_window_ms", "force_taper_ms",
                                                            "exponential_end_fraction") if key in window_settings}
            window = WindowSettings(**known)
        quality = []
        if rejected:
            reasons: dict[str, int] = {}
            for hit in rejected:
                for reason in hit.verdict.reasons or ("by the user",):
                    reasons[reason] = reasons.get(reason, 0) + 1
            summary = ", ".join(f"{reason}: {count}" for reason, count in sorted(reasons.items()))
            quality.append(QualityNote("rejected hits", f"{len(rejected)} hit(s) rejected in the session ({summary}); "
                                       f"only accepted hits are compared", hits=tuple(h.index for h in rejected)))
        return Recordings(records, session.sample_rate_hz, times, window, overload, session.rig_spec_toml,
                          str(path), quality)


def nominal_spec(recordings: Recordings, mass_kg: float) -> RigSpec:
    """A spring-damper film on ``mass_kg`` with k and c read off the recordings' resonance (peak and height)."""
    records = recordings.records
    force = np.fft.rfft(records[:, 0], axis=1)
    response = np.fft.rfft(records[:, 1], axis=1)
    freq_hz = np.fft.rfftfreq(records.shape[-1], 1.0 / recordings.sample_rate_hz)
    h1 = (response * np.conj(force)).sum(axis=0) / (np.abs(force) ** 2).sum(axis=0)
    band = (freq_hz >= 5.0) & (freq_hz <= 0.4 * recordings.sample_rate_hz)
    peak = np.flatnonzero(band)[np.argmax(np.abs(h1[band]))]
    omega = 2 * np.pi * freq_hz[peak]
    return RigSpec.nominal("SD", mass_kg=mass_kg,
                           parameters={"k": mass_kg * omega**2, "eta": omega / np.abs(h1[peak])})


def diagnose(
    source: str | Path | Recordings,
    rig_spec: RigSpec | None = None,
    mass_kg: float | None = None,
    out_dir: str | Path | None = None,
    band_hz: tuple[float, float] | None = None,
    progress: Callable[[str], None] = _silent,
) -> Diagnosis:
    """Diagnose a session or UFF file against a rig spec (default: a spring-damper film on ``mass_kg``, its k and c
    then found by the recalibration). With ``out_dir``: writes the improved spec TOML and the figures there."""
    started = time.monotonic()
    recordings = source if isinstance(source, Recordings) else load_recordings(source)
    if rig_spec is None:
        rig_spec = nominal_spec(recordings, mass_kg if mass_kg is not None else PAPER_MASS_KG)
        progress(f"no rig spec given: spring-damper film on {rig_spec.mass_kg:g} kg "
                 f"(k ≈ {rig_spec.film_parameters['k']:.3g} N/m, c ≈ {rig_spec.film_parameters['eta']:.3g} N·s/m "
                 f"from the resonance)")
    elif mass_kg is not None:
        rig_spec = dataclasses.replace(rig_spec, mass_kg=mass_kg)
    spectra = hit_spectra(recordings.records, recordings.sample_rate_hz, recordings.window,
                          hit_times_s=recordings.hit_times_s, overload=recordings.overload, band_hz=band_hz)
    spectra.quality[:0] = recordings.quality
    reference_impulse_ns = spectra.conditions.reference_impulse_ns
    model = model_from_spec(rig_spec, reference_impulse_ns)
    diagnosis = diagnose_spectra(spectra, model, progress)
    improved, notes = spec_from_model(diagnosis.improved_model, rig_spec, reference_impulse_ns)
    diagnosis.spec_notes = notes
    diagnosis.improved_rig_spec = improved
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        spec_path = out / "improved-rig.toml"
        header = "".join(f"# {note}\n" for note in notes)
        spec_path.write_text(header + improved.to_toml(), encoding="utf-8")
        diagnosis.improved_spec = str(spec_path)
        from gasfilm.analysis.diagnosis.plots import write_figures

        diagnosis.figures = write_figures(diagnosis, out)
    diagnosis.wall_time_s = time.monotonic() - started
    return diagnosis


__all__ = ["Diagnosis", "Finding", "Recordings", "diagnose", "diagnose_spectra",
           "load_recordings", "nominal_spec", "replay_rms"]
