"""The diagnosis itself: where the spec and the recordings differ, what is missing, and what is still not explained.

1. **compare** the spec with the recordings under the recordings' own conditions (the spec played with each hit's
   recorded force through the same windows, weighted by the measured noise, :mod:`.measurement`);
2. **recalibrate** the spec's own parameters; a mismatch this removes is ``parameters-only``, never physics;
3. **forward selection** over the candidate effects (:mod:`.candidates`): each is fitted with the spec's parameters;
   the best enters when its χ² gain, in units of the current model's noise scale, beats its BIC cost on all hits and
   on hits left out of the fit, and when its parameters are physical and not at a bound;
4. **check back**: with the final noise scale every term must still pay for itself;
5. **adequacy**: the final spec is tested against the measured noise per band and per hit; what is beyond the noise
   is reported as ``unexplained`` with its character, and the verdict says so.

The pipeline writes no files: callers write ``Diagnosis.improved`` and the figures.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from gasfilm.analysis.diagnosis.candidates import (
    EQUIVALENT,
    GENERIC_DESCRIPTIONS,
    TERM_CHANGES,
    candidates_for,
    gain_is_not_a_mass,
    separating_measurement,
)
from gasfilm.analysis.diagnosis.fitspace import (effect_slots, fit_context, kept_positions, removed_with, spec_slots,
                                                without_effect)
from gasfilm.analysis.diagnosis.measurement import HitSpectra, QualityNote, contiguous_bands, weighted_mean
from gasfilm.analysis.diagnosis.mechanisms import mechanisms_for
from gasfilm.analysis.diagnosis.modes import unmodelled_resonances_hz
from gasfilm.analysis.diagnosis.parallel import shared_map
from gasfilm.analysis.diagnosis.restoring import RestoringForce
from gasfilm.analysis.diagnosis.result import Alternative, CandidateDescription, Diagnosis, Finding, Unexplained
from gasfilm.analysis.diagnosis.structure import (
    STRUCTURE_CHANGED,
    beside_transfer,
    mode_change_text,
    reread_mode,
    side_modes_as_structure,
)
from gasfilm.analysis.diagnosis.selection import (
    BIC_MARGIN,
    FINISHED_STARTS,
    HELD_OUT_THRESHOLD,
    Evidence,
    FitOutcome,
    HeldOut,
    best_finished,
    candidate_starts,
    changing_description,
    bic,
    disagreement,
    fit,
    held_out_band_gain,
    held_out_gain,
    model_function,
    PACE_MARGIN,
    screening_fit,
    shared_fits,
    to_finish,
    finishing_fit,
)
from gasfilm.analysis.physics.effects import EFFECT_TYPES, FitContext, TermChange
from gasfilm.analysis.quantities import band_text, in_band
from gasfilm.analysis.physics.response import simulate_response
from gasfilm.analysis.physics.spec import DescriptionError, RigSpec
from gasfilm.analysis.threads import one_blas_thread
from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2
from gasfilm.drivers.errors import GasfilmError

logger = logging.getLogger(__name__)

MAX_TERMS = 6
#: Passes of the catalog's selection: after terms were taken out on their claims, the rest is selected again without
#: them (another term may take the place of one that could not be claimed).
SELECTION_PASSES = 2
#: Generic descriptions at most, after the catalog's terms (modes beside the mover, film branches, channel factors).
MAX_DESCRIPTIONS = 8
#: A generic description whose own band stays beyond the noise is still a description of what it removed when it
#: removed at least this share of the excess there (the rest is another description's, or not explained).
DESCRIBED_SHARE = 0.5
#: Refits at most against the replay of their own result when the replay quantises the response.
QUANTISED_REFITS = 8
NONLINEAR_ITERATIONS = 3
#: χ² per point above which the final spec does not explain the recordings (1 is the measured noise; the noise
#: estimate itself is uncertain by some 10–20 %).
ADEQUATE_CHI2_PER_POINT = 1.5
#: A band whose own χ² per point exceeds this is listed as unexplained even when the whole is adequate.
LOCAL_CHI2_PER_POINT = 4.0
#: Where the current model is beyond SHARE_RULE_NOISE_SCALE times the noise, a term must remove at least this share
#: of the χ² still in excess of it: a model that leaves most of the mismatch unexplained is not padded with terms that
#: shave a few per cent off it. (Near the noise, the excess is partly the noise model's, and small terms still count.)
MIN_EXCESS_SHARE = 0.2
SHARE_RULE_NOISE_SCALE = 2.0
#: Beyond this χ² per point the final spec is grossly inadequate: then only terms that removed at least GROSS_SHARE
#: of the mismatch left at their step are findings.
GROSS_CHI2_PER_POINT = 20.0
GROSS_SHARE = 0.5
#: Terms whose BIC score lies within this margin of the chosen one's are reported as alternatives.
ALTERNATIVE_MARGIN = 10.0
#: Amplitude-dependent terms: chosen among by the shape of the film's restoring force (:mod:`.restoring`).
AMPLITUDE_TERMS = ("cubic-stiffness", "friction", "quadratic-damping")
#: A finding leaves its own band (where 80 % of its χ² gain lies) within the noise: its χ² there, in noise units over
#: the band's real numbers, is compared with the measured noise by a one-sided F test with the band's and the noise
#: estimate's degrees of freedom at this false-alarm probability (with 6 hits a 4-line band has 48 real numbers, whose
#: χ²/point exceeds 1.76 by chance once in a thousand — a fixed 1.5 rejects true terms there); otherwise it is a
#: partial description. The reference is the level the written spec reaches outside the band, between 1 and
#: ADEQUATE_CHI2_PER_POINT; a band is never held to less than that margin (the simulated rig's true spec leaves a
#: wide band at 1.2–1.25, which the F test alone calls beyond the noise).
OWN_BAND_FALSE_ALARM = 1e-3
#: An added mass whose move of the mass line the written spec's measurement terms cancel to below this share is not
#: seen at the mass line (:func:`_mass_line_unmoved`).
MASS_LINE_SHARE = 0.5
#: A term of the other kind (rig / measurement chain) fitted in a term's place on the written spec within this BIC
#: margin (noise units) leaves the rig and the measurement untold apart (:func:`_other_kind_in_its_place`): below
#: Kass and Raftery's "strong" evidence.
SWAP_MARGIN = 6.0
#: A term whose χ² gain is below this share of another term's is within that term's form error
#: (:func:`_beside_a_larger_term`).
MODEL_FORM_SHARE = 1e-3
#: A term beside others that moves a film parameter by more than this factor (against the spec refitted without it)
#: takes the film's place instead of adding to it.
FILM_DISPLACEMENT = 2.0


@dataclass
class Step:
    """One accepted term: its type, its label in the spec (``extra-mode``, ``extra-mode#2`` for the second of a type:
    :func:`_label_at`), χ² before and after, its held-out gains (hits, frequency bands) and the close alternatives."""

    identifier: str
    chi2_before: float
    chi2_after: float
    held_out_gain: float
    held_out_band_gain: float = 0.0
    alternatives: list[str] = field(default_factory=list)
    label: str = ""
    #: candidates of its step that fitted better (a lower χ²) but lost on their extra parameters at the step's noise
    #: scale: judged again at the final one (:func:`_reselected_at_final_scale`), then cleared
    contenders: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.label = self.label or self.identifier


@dataclass
class Claim:
    """How a term of the final spec fares on the claims every finding must survive on the written spec."""

    own_band_chi2_per_point: float
    own_band_limit: float
    gain_over_recalibrated: float
    reason: str | None
    own_band_without: float = np.inf  # the own band's χ² per point of the written spec refitted without the term
    own_band_chance: float = 0.0  # the χ² per point the noise reaches there by chance (1 in 1000)


def _silent(message: str) -> None:
    del message


#: Progress messages that start with this indent are the trace of the search (each candidate's scores); the others
#: say which step the diagnosis is at and what it has so far: what a user is shown unless asking for the trace.
TRACE_INDENT = "  "


def is_trace(message: str) -> bool:
    """Whether a progress message is the search's trace (:data:`TRACE_INDENT`) rather than a step or a result so far."""
    return message.startswith(TRACE_INDENT)


@one_blas_thread
def diagnose_spectra(
    spectra: HitSpectra,
    spec: RigSpec,
    progress: Callable[[str], None] = _silent,
    restoring: RestoringForce | None = None,
    structure_read_off_frf: bool = False,
    recording: str = "these recordings",
) -> Diagnosis:
    """Diagnose per-hit spectra against a rig spec; ``restoring`` (the film's restoring force from the same hits)
    chooses among the amplitude-dependent terms and characterises what they leave unexplained.

    ``structure_read_off_frf``: the spec's structure modes are a start read off these recordings' FRF, which the
    recalibration finishes. A given spec's structure modes are its description of the structure and are held: freed,
    their complex constants would take up a channel delay, a leak or a gain mode by mode; they are fitted last,
    only when no term explains what the spec leaves (:func:`_redescribe_structure`).
    A spec's recorded description error (``[description_error]``) is taken into the noise model
    (:func:`_with_description_error`), and no term is sought when the spec is within it: a term would describe the
    spec's known error, not a change; the spec written records its own (``recording`` names the recordings there)."""
    started = time.monotonic()
    measured = spectra
    spectra = _with_description_error(spectra, spec)
    context = fit_context(spec, spectra.conditions, (float(spectra.freq_hz[0]), float(spectra.freq_hz[-1])))
    evidence = evidence_for(spectra, spec)
    level_notes = _level_note(evidence, spec)
    points = evidence.point_count
    chi2_given = evidence.chi2(spec)
    rms_given = replay_rms(spectra, spec)
    progress(f"step 1 of 3, locate: compared {evidence.hit_count} hits on {len(evidence.freq_hz)} frequencies "
             f"{band_text(evidence.freq_hz[0], evidence.freq_hz[-1])}: χ²/point {chi2_given / points:.2f} "
             f"(1 = the measured noise)")

    own_slots = spec_slots(spec, context, recalibration=structure_read_off_frf)
    recalibrated = _settle_quantised_replay(spectra, fit(evidence, spec, own_slots))
    # a film parameter that runs into a bound, and whose given value the recordings fit as well (BIC in noise units),
    # is not determined by them (a spare arm of a network, an order at 2: an inertance): it keeps the given value in
    # every fit, never filled in with one that invents a feature (one the data do want beyond its range stays free,
    # and is said to be at its bound)
    while undetermined := [slot.name for slot in own_slots
                           if slot.effect is None and slot.at_bound(recalibrated.spec)]:
        holding = dataclasses.replace(context, held_film=context.held_film | set(undetermined))
        held_slots = spec_slots(spec, holding, recalibration=structure_read_off_frf)
        held = _settle_quantised_replay(spectra, fit(evidence, spec, held_slots))
        cost = (held.chi2 - recalibrated.chi2) / _noise_scale(recalibrated, points)
        if cost > len(undetermined) * np.log(points):
            break
        progress(_held_film_note(undetermined))
        context, own_slots, recalibrated = holding, held_slots, held
    # a spec already within the noise and its own recorded description error: what a recalibration would move is that
    # known error, not a change (no change smaller than it can be seen)
    recalibration_significant = (chi2_given - recalibrated.chi2 > len(own_slots) * np.log(points) + BIC_MARGIN
                                 and not (spectra is not measured and _nothing_unexplained(evidence, spec)))
    if recalibration_significant:
        evidence = evidence_for(spectra, recalibrated.spec)
        current = fit(evidence, recalibrated.spec, own_slots)
        if level_notes and not _level_note(evidence, current.spec):
            level_notes = []  # the spec's own parameters account for the level: nothing about the sensors to check
    else:
        current = FitOutcome(spec, chi2_given, own_slots, recalibrated.covariance, 0)
    structure_recalibration = _recalibration_table(spec, current, held_only=True)
    if len(spec_slots(current.spec, context)) < len(own_slots):  # a structure's modes are held from here on
        current = fit(evidence, current.spec, spec_slots(current.spec, context))
    recalibrated_spec = current.spec
    progress(f"recalibrated {len(own_slots)} spec parameter(s): χ²/point {chi2_given / points:.3g} → "
             f"{recalibrated.chi2 / points:.3g}" + (" (significant)" if recalibration_significant
                                                    else " (within the noise)"))

    steps: list[Step] = []
    rejected: list[CandidateDescription] = []
    within_known_error = spectra is not measured and _nothing_unexplained(evidence, current.spec)
    if within_known_error:
        progress("within the noise and the spec's recorded description error: nothing changed that a term could "
                 "describe, none is sought")
    else:
        progress("step 2 of 3, model: the catalogue's terms tried on what is left, each judged on the hits left out "
                 "of its fit")
    rms_recalibrated = replay_rms(spectra, recalibrated_spec)
    excluded: set[str] = set()
    passes = exchanges = 0
    while passes < SELECTION_PASSES:
        while len(steps) < MAX_TERMS and not within_known_error:
            accepted = _select_one(spectra, evidence, current, context, points, rejected, progress, restoring,
                                   excluded=excluded)
            if accepted is None:
                break
            new_steps, outcome, evidence = accepted
            steps.extend(new_steps)
            current = fit(evidence, outcome.spec, outcome.slots)
            progress(f"so far: {', '.join(step.label for step in steps)}: χ²/point {current.chi2 / points:.3g}")
        demoted_before = len(rejected)
        steps, current, evidence, refits_without = _check_back(spectra, evidence, steps, current, recalibrated_spec,
                                                               context, progress)
        steps, current, evidence, refits_without = _drop_partial_terms(spectra, evidence, steps, current,
                                                                       refits_without, rejected, recalibrated_spec,
                                                                       context, progress)
        steps, current, evidence, refits_without, claims = _drop_unsupported_terms(
            spectra, evidence, steps, current, refits_without, rejected, recalibrated_spec, rms_recalibrated, context,
            progress, restoring)
        # the end state, judged again at its own noise scale: a choice that no longer stands is replaced, and the
        # selection goes on from there (what was taken out beside the replaced term is judged again)
        reselected = (None if exchanges >= MAX_TERMS else
                      _reselected_at_final_scale(spectra, evidence, steps, current, context, progress, restoring))
        if reselected is not None:
            steps, current, evidence = reselected
            del rejected[demoted_before:]
            exchanges += 1
            continue
        passes += 1
        # a term taken out leaves its mismatch to the others: another term of the catalog may take its place (a
        # cross-talk where an added mass was not claimed because the two are as good)
        taken_out = {candidate.effect for candidate in rejected[demoted_before:]
                     if not EFFECT_TYPES[candidate.effect].repeatable}
        if not taken_out - excluded or _nothing_unexplained(evidence, current.spec):
            break
        excluded |= taken_out
        progress(f"{', '.join(sorted(taken_out))} taken out again (not a finding: the report says why); what "
                 f"{'it' if len(taken_out) == 1 else 'they'} left is tried again without "
                 f"{'it' if len(taken_out) == 1 else 'them'}")
    unexplained = _unexplained(spectra, evidence, current.spec, rejected, restoring)
    structure_changes: list[str] = []
    if unexplained and not steps and not structure_read_off_frf:
        redescribed = _redescribe_structure(spectra, evidence, current, context, progress)
        if redescribed is not None:
            current, evidence, structure_changes = redescribed
            recalibration_significant = True
            recalibrated_spec = current.spec
            rms_recalibrated = replay_rms(spectra, recalibrated_spec)
            unexplained = _unexplained(spectra, evidence, current.spec, rejected, restoring)
    if unexplained and not within_known_error:
        progress("what no catalogue term explains is described in its place: a factor of a channel, a branch of the "
                 "film, a mode beside the mover")
        described, current, evidence = _describe_the_rest(spectra, evidence, spec, current, context, points,
                                                          rejected, progress, restoring)
        if described:
            steps, current, evidence, refits_without = _check_back(spectra, evidence, steps + described, current,
                                                                   recalibrated_spec, context, progress)
            steps, current, evidence, refits_without, claims = _drop_partial_descriptions(
                spectra, evidence, steps, current, refits_without, rejected, recalibrated_spec, rms_recalibrated,
                context, progress)
            unexplained = _unexplained(spectra, evidence, current.spec, rejected, restoring)
    progress("step 3 of 3, name: each description read against the table of mechanisms")
    findings = [_finding(evidence, step, current, refits_without[step.label], claims[step.label], context)
                for step in steps]
    chi2_after = current.chi2
    if unexplained:
        verdict = "partly explained" if findings else "not explained"
    elif any(finding.status == "modelled" for finding in findings):
        verdict = "modelled"
    elif findings:
        verdict = "missing physics"
    elif recalibration_significant:
        verdict = "parameters-only"
    else:
        verdict = "consistent"
    recalibration = ({**_recalibration_table(spec, current), **structure_recalibration} if recalibration_significant
                     else {})
    free = len(current.slots) if (steps or recalibration_significant) else 0
    diagnosis = Diagnosis(
        verdict=verdict,
        findings=findings,
        unexplained=unexplained,
        quality=list(spectra.quality) + level_notes,
        recalibration=recalibration,
        rms_before=rms_given,
        rms_recalibrated=rms_recalibrated,
        rms_after=replay_rms(spectra, current.spec),
        bic_before=bic(chi2_given, 0, points),
        bic_after=bic(chi2_after, free, points),
        chi2_per_point_before=chi2_given / points,
        chi2_per_point_after=chi2_after / points,
        given=spec,
        recalibrated=recalibrated_spec,
        improved=side_modes_as_structure(current.spec).with_description_error(
            _description_error(measured, current.spec, unexplained, spec.description_error, recording)),
        spectra=spectra,
        evidence=evidence,
        wall_time_s=time.monotonic() - started,
        candidates=rejected,
        restoring_force=restoring,
    )
    diagnosis.notes.extend(STRUCTURE_CHANGED + change for change in structure_changes)
    if context.held_film:
        diagnosis.notes.append(_held_film_note(sorted(context.held_film)))
    logger.info("diagnosis: %s, %d finding(s), %d unexplained band(s), χ²/point %.2f → %.2f", verdict, len(findings),
                len(unexplained), diagnosis.chi2_per_point_before, diagnosis.chi2_per_point_after)
    return diagnosis


def _held_film_note(names: list[str]) -> str:
    return (f"the film's {', '.join(names)} ran into the edge of {'its' if len(names) == 1 else 'their'} range when "
            f"recalibrated: not determined by these recordings, held at the given spec's "
            f"{'value' if len(names) == 1 else 'values'}")


def _with_description_error(spectra: HitSpectra, spec: RigSpec) -> HitSpectra:
    """The spectra with the spec's recorded description error added to every hit's noise variance (the systematic
    difference the spec is known to leave, as a model-discrepancy term: a difference the same in every hit adds its
    power to each hit's expected |H_i − H_spec|²), and a quality note saying so; unchanged without one."""
    error = spec.description_error
    if error is None or spectra.replay is None:
        return spectra
    power = error.power(spectra.freq_hz)
    if not np.any(power > 0):
        return spectra
    replay = dataclasses.replace(spectra.replay, measured_variance=spectra.replay.measured_variance + power,
                                 nonlinear_cache={}, damped_force_padded=spectra.replay.damped_force_padded)
    covered = spectra.freq_hz[power > 0]
    note = QualityNote("description error", (
        f"the spec records how far it is from the recording it was written from ('{error.recording}', χ²/point "
        f"{error.chi2_per_point:.2f} there) {in_band(covered[0], covered[-1])}: that systematic error is "
        f"taken into the noise model, so a change smaller than it cannot be seen there"),
        (float(covered[0]), float(covered[-1])))
    return dataclasses.replace(spectra, variance=spectra.variance + power, replay=replay,
                               quality=[*spectra.quality, note])


def _description_error(
    measured: HitSpectra, spec: RigSpec, unexplained: list[Unexplained], previous: DescriptionError | None,
    recording: str,
) -> DescriptionError | None:
    """What the written spec records of its own description error on these recordings when it leaves some of them
    unexplained: at every analysis line, the power by which the recorded per-hit FRFs differ from the spec replayed
    hit by hit beyond their noise, averaged over the hits (the mean difference and any scatter between hits the spec
    does not describe; 5 lines smoothed, as the unexplained bands are found). With nothing unexplained, the error the
    given spec recorded, if any. Recorded whatever its size: a spec far from the recordings still says how far, and
    a later diagnosis against it says that no change smaller than that can be seen there."""
    if not unexplained or measured.replay is None:
        return previous
    evidence = evidence_for(measured, spec)
    chi2_per_point = evidence.chi2(spec) / evidence.point_count
    freq_hz = measured.freq_hz
    replay = measured.replay
    per_hit = np.abs(replay.measured_h - replayed_per_hit(measured, spec)) ** 2 - replay.measured_variance
    power = np.convolve(np.clip(per_hit.mean(axis=0), 0.0, None), np.ones(5) / 5, mode="same")
    if not np.any(power > 0):
        return previous
    keep = power > 0
    keep[1:] |= power[:-1] > 0  # a zero either side of a band ends it in the interpolation
    keep[:-1] |= power[1:] > 0
    return DescriptionError(tuple(float(f) for f in freq_hz[keep]),
                            tuple(float(f"{v:.4g}") for v in np.sqrt(power[keep])), round(chi2_per_point, 3),
                            recording)


#: A re-read mode of a given structure costs its pole and complex constant (four parameters) at a BIC's price; of the
#: modes re-read in a round, this many (those whose scan gains most) are finished by a fit.
MODE_PARAMETERS = 4
REREAD_FITS = 2


def _redescribe_structure(
    spectra: HitSpectra, evidence: Evidence, current: FitOutcome, context: FitContext,
    progress: Callable[[str], None],
) -> tuple[FitOutcome, Evidence, list[str]] | None:
    """When no term explains what a given spec leaves beyond the noise, the structure it describes may itself have
    changed: mode by mode, as terms are selected, after every few-parameter explanation was tried. Every held mode is
    re-read where it now is (:func:`.structure.reread_mode`: its pole scanned near the spec's, its constant solved on
    the recordings less the rest of the spec, around it), the :data:`REREAD_FITS` that gain most there are finished by
    a fit with the spec's free parameters, and the best is kept when its χ² gain (in units of what is left) pays its
    four parameters' BIC cost; again while bands stay beyond the noise. Returns the outcome with the re-read modes free,
    its evidence and each change in words; None when no mode pays."""
    held = [index for index, effect in enumerate(current.spec.effects) if effect.type_name == "structure-mode"]
    if not held:
        return None
    points = evidence.point_count
    cost = MODE_PARAMETERS * np.log(points) + BIC_MARGIN
    given = current.spec
    changed: list[int] = []
    s = evidence.decay_rate_1_s + 2j * np.pi * evidence.freq_hz
    while len(changed) < MAX_TERMS and not _nothing_unexplained(evidence, current.spec):
        mean, weight = evidence.spectra.mean()
        predicted = evidence.mean_prediction(current.spec)
        transfer = beside_transfer(current.spec, evidence.freq_hz, evidence.decay_rate_1_s)
        scanned = []
        for index in held:
            if index in changed:
                continue
            mode = current.spec.effects[index]
            target = mean - predicted + transfer * mode.added_accelerance(s)
            reread, gain = reread_mode(mode, evidence.freq_hz, evidence.decay_rate_1_s, target, weight, transfer)
            scanned.append((gain, index, reread))
        best = None
        for _, index, reread in sorted(scanned, key=lambda item: -item[0])[:REREAD_FITS]:
            start = current.spec.with_values(effects=[reread if i == index else effect
                                                      for i, effect in enumerate(current.spec.effects)])
            refit = fit(evidence, start, [*current.slots, *effect_slots(start, index, context)], covariance=False)
            gain = (current.chi2 - refit.chi2) / _noise_scale(refit, points)
            if best is None or gain > best[0]:
                best = (gain, index, refit)
        if best is None or best[0] <= cost:
            break
        gain, index, refit = best
        progress(f"no term explains the rest: the structure's mode at {given.effects[index].freq_hz:.1f} Hz re-read, "
                 f"χ² {current.chi2:.0f} → {refit.chi2:.0f} (a gain of {gain:.0f} noise units, needs {cost:.0f})")
        changed.append(index)
        evidence = evidence_for(spectra, refit.spec)
        current = fit(evidence, refit.spec, refit.slots)
    if not changed:
        return None
    words = [mode_change_text(given.effects[index], current.spec.effects[index]) for index in sorted(
        changed, key=lambda index: given.effects[index].freq_hz)]
    return current, evidence, words


def _settle_quantised_replay(spectra: HitSpectra, outcome: FitOutcome) -> FitOutcome:
    """A fit whose replay quantises the response (a coarsely quantised recording) refitted against the replay of its
    own result until χ² stops falling: the quantiser's error changes with the spec, so one replay ratio held fixed
    through a fit leaves the parameters short of their minimum."""
    if spectra.replay is None or spectra.replay.response_step <= 0:
        return outcome
    for _ in range(QUANTISED_REFITS):
        evidence = evidence_for(spectra, outcome.spec)
        refit = fit(evidence, outcome.spec, outcome.slots)
        if refit.chi2 > 0.98 * evidence.chi2(outcome.spec):
            return refit
        outcome = refit
    return outcome


# --- forward selection ---------------------------------------------------------------------------------------------


def _noise_scale(outcome: FitOutcome, points: int) -> float:
    """χ² per degree of freedom of a fit, at least 1: gains are judged in units of what is left unexplained."""
    return max(1.0, outcome.chi2 / max(points - len(outcome.slots), 1))


def _select_one(
    spectra: HitSpectra,
    evidence: Evidence,
    current: FitOutcome,
    context: FitContext,
    points: int,
    rejected: list[CandidateDescription],
    progress: Callable[[str], None],
    restoring: RestoringForce | None = None,
    generic: bool = False,
    other_films: tuple[dict[str, float], ...] = (),
    excluded: set[str] = frozenset(),
    changing: bool = False,
) -> tuple[list[Step], FitOutcome, Evidence] | None:
    """The next term of the forward selection (its step; with ``changing`` the steps of a new description and of its
    change between hits), or None when no candidate earns its place: from the catalog, or with ``generic`` from the
    generic descriptions. An amplitude-dependent term whose shape the measured restoring force contradicts is not
    tried. ``other_films``: film parameters each candidate is also started from (see :func:`_candidate_fits`);
    ``excluded``: types not tried (taken out on their claims in an earlier pass); ``changing``: each candidate is a
    new description whose values move steadily between hits (:func:`changing_starts`)."""
    noise_scale = _noise_scale(current, points)
    trials = []
    identifiers = [identifier for identifier in _candidate_identifiers(current.spec, evidence, context, restoring,
                                                                         generic)
                   if identifier not in excluded]
    if changing:
        identifiers = [f"{identifier}+term-drift" for identifier in identifiers if identifier not in TERM_CHANGES]

    # a candidate matters when it scores above BIC_MARGIN (chosen, or listed as an alternative)
    fitted_candidates = _candidate_fits(
        spectra, evidence, current.spec, identifiers, context, noise_scale,
        worth=lambda slot_count: current.chi2 - (BIC_MARGIN + (slot_count - len(current.slots)) * np.log(points))
        * noise_scale, other_films=other_films)
    for identifier in identifiers:
        fitted = fitted_candidates[identifier]
        if isinstance(fitted, GasfilmError):  # a nonlinear replay that does not converge is no candidate
            logger.info("candidate %s skipped: %s", identifier, fitted)
            continue
        if isinstance(fitted, Exception):
            raise fitted
        outcome, candidate_evidence = fitted
        if outcome is None:
            continue
        extra = len(outcome.slots) - len(current.slots)
        score = (current.chi2 - outcome.chi2) / noise_scale - extra * np.log(points)
        share = (current.chi2 - outcome.chi2) / max(current.chi2 - points, 1e-9)
        padding = noise_scale > SHARE_RULE_NOISE_SCALE and share < MIN_EXCESS_SHARE
        trials.append((min(score, 0.0) if padding else score, identifier, outcome, candidate_evidence))
    trials.sort(key=lambda trial: trial[0], reverse=True)
    summary = ", ".join(f"{identifier} {score:+.0f}" for score, identifier, _, _ in trials[:4])
    progress(f"{TRACE_INDENT}BIC gain of the best candidates (noise scale {noise_scale:.2f}): {summary}")
    for score, identifier, outcome, candidate_evidence in trials[:4]:
        if score <= BIC_MARGIN:
            return None
        new = range(len(current.spec.effects), len(outcome.spec.effects))  # the term (and its change)
        index = new[0]
        reason = next((why for why in (_not_a_finding(outcome, i, context) for i in new) if why), None)
        if reason is not None and all(_not_a_finding(outcome, i, context, within_noise=True) is None for i in new):
            if _nothing_unexplained(evidence_for(spectra, outcome.spec), outcome.spec):
                progress(f"  {identifier}: its values are unusual ({reason}), but with it nothing is left unexplained")
                reason = None
        if reason is not None:
            band = _term_band(candidate_evidence, outcome.spec, current.spec)
            rejected.append(CandidateDescription(changing_description(identifier)[0], band,
                                                 _term_parameters(outcome, index), reason))
            progress(f"  {identifier}: not a finding ({reason})")
            continue
        hit_folds = held_out_gain(evidence, current.spec, candidate_evidence, outcome.spec, context)
        gain_held_out = hit_folds.gain / noise_scale
        progress(f"  {identifier}: held-out χ² gain {gain_held_out:.0f} (needs > {HELD_OUT_THRESHOLD:.0f})")
        if gain_held_out <= HELD_OUT_THRESHOLD:
            continue
        close = [changing_description(other)[0] for other_score, other, _, _ in trials if other != identifier
                 and score - other_score < ALTERNATIVE_MARGIN and other_score > BIC_MARGIN]
        contenders = [other for other_score, other, other_outcome, _ in trials if other != identifier
                      and other_score > BIC_MARGIN and other_outcome.chi2 < outcome.chi2]
        steps = [Step(outcome.spec.effects[i].type_name, current.chi2, outcome.chi2, gain_held_out, 0.0,
                      close if i == index else [], _label_at(outcome.spec, i), contenders if i == index else [])
                 for i in new]
        return steps, outcome, evidence_for(spectra, outcome.spec)
    return None


def _reselected_at_final_scale(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    context: FitContext,
    progress: Callable[[str], None],
    restoring: RestoringForce | None,
) -> tuple[list[Step], FitOutcome, Evidence] | None:
    """The selection's choices judged again at its final noise scale: the steps with a new spec, or None when every
    choice stands.

    A step chooses among its candidates in units of the noise scale of the model before it, which is the mismatch the
    chosen term then removes: far from the noise, a candidate that fits better by a hundred noise units loses to one
    with a parameter fewer (``Δχ²/83 < ln N``), and on the written spec, diagnosed again, the same candidate wins (the
    loop does not close). So each step's *contenders* — the candidates that fitted better than the chosen term but
    lost on their extra parameters — are fitted in its place on the final spec (the rest refitted) and scored at the
    final noise scale, by the criterion that chose (BIC gain in noise units, hits left out of the fit): one better
    by more than :data:`ALTERNATIVE_MARGIN` takes the place, with the candidates within that margin as its
    alternatives; one within the margin is listed as an alternative (the data cannot tell them apart), and the terms'
    claims are judged again with it (a measurement term as good as a rig term leaves it unclaimed). Only a
    contender can win at a smaller noise scale: a candidate with a higher χ² and fewer parameters loses by more
    there."""
    points = evidence.point_count
    for position, step in enumerate(steps):
        present = {effect.type_name for effect in current.spec.effects if not type(effect).repeatable}
        contenders = [other for other in step.contenders if other not in present]
        step.contenders = []
        index = _effect_index(current.spec, step.label)
        if not contenders or len(removed_with(current.spec, index)) > 1:  # (a term others change stays)
            continue
        noise_scale = _noise_scale(current, points)
        reduced = without_effect(current.spec, index)
        reduced_evidence = evidence_for(spectra, reduced)
        fitted = _candidate_fits(
            spectra, reduced_evidence, reduced, contenders, context, noise_scale,
            worth=lambda slot_count: current.chi2 + (ALTERNATIVE_MARGIN - (slot_count - len(current.slots))
                                                     * np.log(points)) * noise_scale)
        costs: list[tuple[float, str, FitOutcome, Evidence]] = []
        for other in contenders:
            result = fitted[other]
            if isinstance(result, Exception) or result[0] is None:
                continue
            outcome, other_evidence = result
            if _not_a_finding(outcome, len(outcome.spec.effects) - 1, context) is not None:
                continue
            cost = (outcome.chi2 - current.chi2) / noise_scale + (len(outcome.slots) - len(current.slots)) * np.log(
                points)
            costs.append((cost, other, outcome, other_evidence))
        costs.sort(key=lambda item: item[0])
        tied = [other for cost, other, _, _ in costs
                if abs(cost) < ALTERNATIVE_MARGIN and other not in step.alternatives]
        if tied and costs[0][0] >= -ALTERNATIVE_MARGIN:  # the claims are judged again with these alternatives
            step.alternatives += tied
            progress(f"  at the final noise scale ({noise_scale:.2f}) {', '.join(tied)} fits as well as "
                     f"{step.label} in its place: listed as its alternative")
            return steps, current, evidence
        if not costs or costs[0][0] >= -ALTERNATIVE_MARGIN:
            continue
        cost, other, outcome, other_evidence = costs[0]
        held_out = held_out_gain(reduced_evidence, reduced, other_evidence, outcome.spec, context).gain / noise_scale
        progress(f"  at the final noise scale ({noise_scale:.2f}) {other} in the place of {step.label}: BIC "
                 f"{-cost:+.0f} better, held-out χ² gain {held_out:.0f} (needs > {HELD_OUT_THRESHOLD:.0f})")
        if held_out <= HELD_OUT_THRESHOLD:
            continue
        alternatives = [name for name_cost, name, _, _ in costs[1:] if name_cost - cost < ALTERNATIVE_MARGIN]
        kept = _without_steps(steps, [step], current.spec)
        replaced = Step(other, step.chi2_before, step.chi2_after - (current.chi2 - outcome.chi2), held_out, 0.0,
                        alternatives, _label_at(outcome.spec, len(outcome.spec.effects) - 1))
        new_steps = [*kept[:position], replaced, *kept[position:]]
        return new_steps, fit(other_evidence, outcome.spec, outcome.slots), other_evidence
    return None


def _drop_partial_descriptions(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    refits_without: dict[str, RigSpec],
    rejected: list[CandidateDescription],
    recalibrated: RigSpec,
    rms_recalibrated: float,
    context: FitContext,
    progress: Callable[[str], None],
) -> tuple[list[Step], FitOutcome, Evidence, dict[str, RigSpec], dict[str, Claim]]:
    """A generic description must describe what lies in its own band: one that leaves that band beyond the noise
    having removed less than :data:`DESCRIBED_SHARE` of its excess there (against the written spec refitted without
    it) describes something else, and is taken out (the latest first) and listed with its values. One that removed
    most of it describes its part, and what is left there is another's, or is not explained. The catalog's terms here
    passed their claims already."""
    while True:
        claims = {step.label: _claim(spectra, evidence, current, refits_without[step.label], step.label,
                                     recalibrated, rms_recalibrated) for step in steps}
        partial = [step for step in steps if EFFECT_TYPES[step.identifier].generic
                   and claims[step.label].reason is not None
                   and not _described_share_met(claims[step.label])][-1:]
        if not partial:
            return steps, current, evidence, refits_without, claims
        reasons = {step.label: claims[step.label].reason for step in partial}
        for label, reason in reasons.items():
            progress(f"  {label}: a candidate description, not a model of the data ({reason})")
        steps, current, evidence, refits_without = _demote_terms(spectra, evidence, steps, current, reasons,
                                                                 refits_without, rejected, recalibrated, context)


def _describes_its_part(claim: Claim) -> bool:
    """Whether a term whose own band stays beyond the noise still describes its part there, as a generic description
    does (:func:`_described_share_met`): it removed most of the excess there and the written spec replayed is closer
    to the recordings with it. Taking it out would hand its mismatch to the terms beside it, whose bands it shares: a
    term fails its claim on its own values, not on what another leaves."""
    return claim.own_band_chi2_per_point > claim.own_band_limit and _described_share_met(claim)


def _described_share_met(claim: Claim) -> bool:
    """Whether a term removed at least :data:`DESCRIBED_SHARE` of the excess over the noise in its own band."""
    before, after = claim.own_band_without, claim.own_band_chi2_per_point
    return before > 1.0 and (before - after) >= DESCRIBED_SHARE * (before - 1.0) and claim.gain_over_recalibrated > 0


def _film_moved_from(spec: RigSpec, film: dict[str, float], tolerance: float = 0.1) -> bool:
    """Whether any of ``spec``'s film parameters differs from ``film``'s by more than ``tolerance`` (relative)."""
    return any(abs(value - film.get(name, value)) > tolerance * abs(film.get(name, value)) for name, value in
               spec.film_parameters.items())


#: The hits' residuals about their mean (the spec's per hit) beyond the noise by this factor (and beyond what the noise
#: reaches by chance) say that the hits differ in a way the spec does not have: changes between hits are tried.
HITS_DIFFER = 1.2


def _hits_differ(evidence: Evidence, spec: RigSpec) -> bool:
    """Whether the hits differ from each other beyond the noise about the spec: the χ² of each hit's residual about
    the hits' weighted mean residual, per real degree of freedom, above :data:`HITS_DIFFER` and the 1 in 1000 chance
    level of the F test with the noise estimate's degrees of freedom."""
    if evidence.hit_count < 3:
        return False
    residual = evidence.residual_per_hit(spec)
    weight = evidence.spectra.weight
    mean = (weight * residual).sum(axis=0) / weight.sum(axis=0)
    dof = 2 * (evidence.hit_count - 1) * residual.shape[1]
    per_dof = float(np.sum(weight * np.abs(residual - mean) ** 2)) / dof
    noise = evidence.spectra.noise
    import scipy.stats  # (on first use: reading a stored diagnosis does not wait for it)
    chance = float(scipy.stats.f.isf(OWN_BAND_FALSE_ALARM, dof, max(noise.degrees_of_freedom, 1.0))) \
        if noise is not None else 1.0
    return per_dof > max(HITS_DIFFER, chance)


def _describe_the_rest(
    spectra: HitSpectra,
    evidence: Evidence,
    given: RigSpec,
    current: FitOutcome,
    context: FitContext,
    points: int,
    rejected: list[CandidateDescription],
    progress: Callable[[str], None],
    restoring: RestoringForce | None,
) -> tuple[list[Step], FitOutcome, Evidence]:
    """Step 2 for what the catalog's terms leave beyond the noise: generic descriptions of each place in the chain
    (a factor of a channel, a branch of the film, modes beside the mover), as many as the data need, chosen by the
    same criterion as the catalog's terms (BIC gain in noise units, hits left out of the fit). Each is also started
    from the ``given`` spec's film when the recalibration moved it: a recalibration that absorbed part of a
    mismatch of the chain into the film leaves a minimum the description's fit cannot leave."""
    described: list[Step] = []
    other_films = tuple(film for film in (given.film_parameters,) if _film_moved_from(current.spec, film))
    while len(described) < MAX_DESCRIPTIONS and not _nothing_unexplained(evidence, current.spec):
        accepted = _select_one(spectra, evidence, current, context, points, rejected, progress, restoring,
                               generic=True, other_films=other_films)
        if accepted is None and _hits_differ(evidence, current.spec):
            progress("  the hits differ in a way no description, or change of one, gives: each description tried as "
                     "a new term whose values move steadily over the session")
            accepted = _select_one(spectra, evidence, current, context, points, rejected, progress, restoring,
                                   generic=True, changing=True)
        if accepted is None:
            break
        new_steps, outcome, evidence = accepted
        described.extend(new_steps)
        current = fit(evidence, outcome.spec, outcome.slots)
    return described, current, evidence


def _candidate_identifiers(
    spec: RigSpec, evidence: Evidence, context: FitContext, restoring: RestoringForce | None, generic: bool = False
) -> list[str]:
    """The candidate terms that may be added to ``spec`` (the catalog's, or with ``generic`` the generic
    descriptions): not already in it unless several of a type can be, a change between hits only when the hits
    differ about ``spec`` (else one spec for every hit is all the data can describe), a time term only when the hits'
    times are known, an amplitude-dependent term only when the measured restoring force allows its shape."""
    present = {effect.type_name for effect in spec.effects if not type(effect).repeatable}
    pool = (*(GENERIC_DESCRIPTIONS if generic else candidates_for(spec)),
            *(TERM_CHANGES if _hits_differ(evidence, spec) else ()))
    return [identifier for identifier in pool
            if identifier not in present
            and not (identifier in ("drift", "step-change", "term-drift", "term-onset")
                     and context.session_span_s <= 0)
            and not (identifier in AMPLITUDE_TERMS and restoring is not None and not restoring.allows(identifier))]


def _unstable(band_folds: HeldOut, hit_folds: HeldOut, index: int, noise_scale: float, points: int) -> str | None:
    """Why a term does not survive data left out of its fit: it does not predict the frequency bands left out, or its
    parameters differ between disjoint halves of the band or of the hits beyond their uncertainties."""
    band_gain = band_folds.gain / noise_scale
    if band_gain <= HELD_OUT_THRESHOLD:
        return (f"it does not predict the frequency bands left out of its fit (χ² gain {band_gain:.0f} noise units "
                f"on interleaved sub-bands, needs > {HELD_OUT_THRESHOLD:.0f})")
    halves = (points // 2, points // 2)
    for folds, halves_name in ((band_folds.fold_fits, "interleaved halves of the band"),
                               (hit_folds.fold_fits, "the odd and the even hits")):
        differs = disagreement(*folds, index, halves)
        if differs is not None:
            return f"its parameters differ between {halves_name} beyond their uncertainties: {differs}"
    return None


def _term_parameters(outcome: FitOutcome, index: int) -> dict[str, dict[str, float | str]]:
    """The fitted fields of effect ``index`` with their one-σ uncertainties and units."""
    effect = outcome.spec.effects[index]
    parameters: dict[str, dict[str, float | str]] = {}
    for slot_index, slot in enumerate(outcome.slots):
        if slot.effect == index:
            unit = next(f.metadata.get("unit", "") for f in dataclasses.fields(effect) if f.name == slot.name)
            parameters[slot.name] = {"value": slot.value(outcome.spec), "uncertainty": outcome.uncertainty(slot_index),
                                     "unit": unit}
    return parameters


def _not_a_finding(
    outcome: FitOutcome, index: int, context: FitContext, within_noise: bool = False
) -> str | None:
    """Why the term at ``index`` is not a measurement of anything: a parameter at its bound, or absurd values — a
    term's rule of what is plausible (a part riding on the mover is light, a peak of its own is narrow) is a prior
    against stand-ins, which yields to the data when the spec with the term leaves nothing unexplained
    (``within_noise``): a 10 kg counterweight or a tuned absorber on the film's resonance is then what it is."""
    spec = outcome.spec
    at_bound = [slot.name for slot in outcome.slots if slot.effect == index and slot.at_bound(spec)]
    if at_bound:
        return f"{', '.join(at_bound)} ran into the edge of the physical range"
    return None if within_noise else spec.effects[index].implausible_in(spec, context)


def _candidate_fits(
    spectra: HitSpectra, evidence: Evidence, spec: RigSpec, identifiers: list[str], context: FitContext,
    noise_scale: float,
    worth: Callable[[int], float] | None = None,
    other_films: tuple[dict[str, float], ...] = (),
) -> dict[str, tuple[FitOutcome | None, Evidence] | Exception]:
    """Each candidate's best fit (the steps listed at :func:`candidate_starts`; None without a start) and the
    evidence it is judged on (its own for a cubic spring: :func:`_nonlinear_refit`), or the exception its fit raised.
    ``worth`` gives, for a candidate spec's number of free slots, the χ² below which its fit matters to the caller:
    fits that cannot get there stop early (:func:`fit`'s ``worth_below``); a cubic spring's equivalent-linear fit
    runs to its end (its exact replay may still move it far), its exact refits stop the same way.

    The fits are shared by two processes (:func:`shared_map`) in two rounds: every start of every candidate screened
    (and at once finished when the candidate has no more starts than are finished), then the best starts of the
    others finished. Single fits balance the two processes better than whole candidates (a film term's three starts
    took as long as all other candidates together); each result is what one process gives, bit for bit. A cubic
    spring's exact nonlinear replays come last, here, each replay's hits shared. Each start is also tried with the
    film parameters of ``other_films`` (a recalibration may have bent the film to absorb part of what the term
    describes, a local minimum the term's fit cannot leave).
    """
    results: dict[str, tuple[FitOutcome | None, Evidence] | Exception] = {}
    starts: list[tuple[str, RigSpec, bool]] = []
    for identifier in identifiers:
        try:
            specs = candidate_starts(evidence, spec, identifier, context)
            specs += [start.with_values(film_parameters=film) for film in other_films for start in specs]
        except GasfilmError as error:
            results[identifier] = error
            continue
        if not specs:
            results[identifier] = (None, evidence)
        starts.extend((identifier, start, len(specs) <= FINISHED_STARTS) for start in specs)

    def worth_below(identifier: str, slot_count: int) -> float | None:
        return None if worth is None or identifier == "cubic-stiffness" else worth(slot_count)

    def screen(item: tuple[str, RigSpec, bool]) -> tuple[FitOutcome, FitOutcome | None]:
        identifier, start, finish = item
        screened = screening_fit(evidence, start, context, worth_below(identifier, len(spec_slots(start, context))))
        finished = finishing_fit(evidence, screened, worth_below(identifier, len(screened.slots))) if finish else None
        return screened, finished

    # CANDIDATES lists the terms with fewest parameters (and starts) first: the quickest fits
    by_candidate: dict[str, list[tuple[FitOutcome, FitOutcome | None]]] = {}
    for (identifier, _, _), outcome in zip(starts, shared_map(screen, starts, longest_first=True)):
        if isinstance(outcome, Exception):
            results.setdefault(identifier, outcome)
        elif identifier not in results:
            by_candidate.setdefault(identifier, []).append(outcome)
    finishing = [(identifier, screened) for identifier, outcomes in by_candidate.items()
                 if outcomes[0][1] is None for screened in to_finish([screened for screened, _ in outcomes])]
    finished: dict[str, list] = {}
    for (identifier, _), outcome in zip(finishing, shared_map(
            lambda item: finishing_fit(evidence, item[1], worth_below(item[0], len(item[1].slots))), finishing,
            longest_first=True)):
        finished.setdefault(identifier, []).append(outcome)
    for identifier, outcomes in by_candidate.items():
        if outcomes[0][1] is not None:  # finished with their screening: in the order to_finish gives
            order = to_finish([screened for screened, _ in outcomes])
            finished[identifier] = [next(done for screened, done in outcomes if screened is chosen)
                                    for chosen in order]
    for identifier in (identifier for identifier in by_candidate if identifier in finished):
        outcomes = finished[identifier]
        failed = [outcome for outcome in outcomes if isinstance(outcome, Exception)]
        if failed:
            results[identifier] = failed[0]
            continue
        best = best_finished(outcomes)
        try:
            results[identifier] = (_nonlinear_refit(spectra, evidence, spec, best, noise_scale,
                                                    None if worth is None else worth(len(best.slots)))
                                   if identifier == "cubic-stiffness" else (best, evidence))
        except GasfilmError as error:  # a nonlinear replay that does not converge
            results[identifier] = error
    return results


def _nonlinear_refit(
    spectra: HitSpectra, evidence: Evidence, spec: RigSpec, outcome: FitOutcome, noise_scale: float,
    worth_below: float | None = None,
) -> tuple[FitOutcome, Evidence]:
    """A cubic film spring's fit refitted against its exact nonlinear replay until k3 settles (the
    equivalent-linear fit only starts it), when the equivalent-linear fit alone would already pay its BIC cost. The
    refits stop early when one leaves χ² above the spec's without the term: the exact response contradicts the
    spring (a few per cent more or less k3 cannot turn that round); and, given ``worth_below`` (the χ² at which the
    term would count, as for :func:`fit`), when one leaves it above that level by more than the remaining refits could
    remove at :data:`PACE_MARGIN` times the last one's fall."""
    chi2_without = evidence.chi2(spec)
    if (chi2_without - outcome.chi2) / noise_scale < np.log(evidence.point_count) + BIC_MARGIN:
        return outcome, evidence  # not even the equivalent linear term pays for itself: no nonlinear replay
    for iteration in range(NONLINEAR_ITERATIONS):
        previous, previous_chi2 = outcome.spec.cubic_stiffness_n_per_m3, outcome.chi2
        evidence = evidence_for(spectra, outcome.spec)
        outcome = fit(evidence, outcome.spec, outcome.slots)
        left = NONLINEAR_ITERATIONS - 1 - iteration
        hopeless = (worth_below is not None and outcome.chi2
                    - PACE_MARGIN * max(previous_chi2 - outcome.chi2, 0.0) * left > worth_below)
        if (abs(outcome.spec.cubic_stiffness_n_per_m3 - previous) <= 0.02 * abs(previous)
                or outcome.chi2 >= chi2_without or hopeless):
            break
    return outcome, evidence


def _check_back(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    recalibrated: RigSpec,
    context: FitContext,
    progress: Callable[[str], None],
) -> tuple[list[Step], FitOutcome, Evidence, dict[str, RigSpec]]:
    """Drop terms that no longer pay for themselves once the final model's noise scale is known.

    Also returns, for every term kept, the final spec refitted without it (where the term is needed is where that
    refit fails).
    """
    points = evidence.point_count
    while steps:
        noise_scale = _noise_scale(current, points)
        trials = []
        for step in steps:
            refit = _refit_without(evidence, current.spec, _effect_index(current.spec, step.label), recalibrated,
                                   context)
            extra = len(current.slots) - len(refit.slots)
            trials.append(((refit.chi2 - current.chi2) / noise_scale - extra * np.log(points), step, refit))
        cost, step, refit = min(trials, key=lambda trial: trial[0])
        if cost > BIC_MARGIN:
            return steps, current, evidence, {trial_step.label: trial_refit.spec
                                              for _, trial_step, trial_refit in trials}
        progress(f"{TRACE_INDENT}check back: {step.label} no longer significant (noise scale {noise_scale:.2f}); removed")
        steps = _without_steps(steps, [step], current.spec)
        evidence = evidence_for(spectra, refit.spec)
        current = fit(evidence, refit.spec, refit.slots)
    return steps, current, evidence, {}


def _drop_partial_terms(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    refits_without: dict[str, RigSpec],
    rejected: list[CandidateDescription],
    recalibrated: RigSpec,
    context: FitContext,
    progress: Callable[[str], None],
) -> tuple[list[Step], FitOutcome, Evidence, dict[str, RigSpec]]:
    """When the final spec is still far beyond the noise, a term that removed less than half of the mismatch left at
    its step is one of several ways to shave a mismatch nothing explains: it is reported as unexplained, not found."""
    points = evidence.point_count
    if current.chi2 / points <= GROSS_CHI2_PER_POINT:
        return steps, current, evidence, refits_without
    partial = [step for step in steps
               if step.chi2_before - step.chi2_after < GROSS_SHARE * (step.chi2_before - points)]
    if not partial:
        return steps, current, evidence, refits_without
    reasons = {}
    for step in partial:
        share = (step.chi2_before - step.chi2_after) / (step.chi2_before - points)
        reasons[step.label] = (f"it removed only {100 * share:.0f} % of the mismatch left at its step, and the "
                               f"rest stays far beyond the noise")
        progress(f"  {step.label}: not a finding (removed {100 * share:.0f} % of a mismatch that stays "
                 f"{current.chi2 / points:.0f}× the noise)")
    return _demote_terms(spectra, evidence, steps, current, reasons, refits_without, rejected, recalibrated, context)


def _drop_unsupported_terms(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    refits_without: dict[str, RigSpec],
    rejected: list[CandidateDescription],
    recalibrated: RigSpec,
    rms_recalibrated: float,
    context: FitContext,
    progress: Callable[[str], None],
    restoring: RestoringForce | None,
) -> tuple[list[Step], FitOutcome, Evidence, dict[str, RigSpec], dict[str, Claim]]:
    """Every term of the final spec must leave its own band within the noise, make the written spec replayed closer to
    the recordings than refitted without it, survive data left out of its fit, leave the spec's other parameters off
    their bounds and not be replaceable by a term of the other kind (the checks of docs/diagnosis.md §3 step 4). A
    term that fails is a candidate description (with its values and the reason), removed from the spec, the latest
    added first; the rest are refitted and checked again."""
    claims: dict[str, Claim] = {}
    while steps:
        claims = {step.label: _claim(spectra, evidence, current, refits_without[step.label], step.label,
                                      recalibrated, rms_recalibrated) for step in steps}
        within_noise = _nothing_unexplained(evidence, current.spec)
        # the latest term first: the first that fails is the one taken out (the earlier ones are judged again on the
        # spec refitted without it)
        for step in reversed(steps):
            if EFFECT_TYPES[step.identifier].generic:  # a change between hits is a description: its own band only
                continue
            if _describes_its_part(claims[step.label]):
                claims[step.label].reason = None  # what it leaves in its band is another's, or not explained
            if claims[step.label].reason is None:  # its own values on the written spec, as when it entered
                claims[step.label].reason = _not_a_finding(current, _effect_index(current.spec, step.label),
                                                                context, within_noise)
            if claims[step.label].reason is None:
                claims[step.label].reason = _survives_left_out_data(spectra, evidence, current, step,
                                                                         refits_without[step.label], context)
            if claims[step.label].reason is None and len(steps) > 1:
                claims[step.label].reason = _displaces_a_parameter(current, step.label,
                                                                        refits_without[step.label])
            if claims[step.label].reason is None:
                claims[step.label].reason = _beside_a_larger_term(
                    step, steps, claims[step.label], lambda: _given_term_gains(
                        spectra, current, step, steps, refits_without[step.label], recalibrated, context))
            if claims[step.label].reason is None:
                claims[step.label].reason = _measurement_alternative(step)
            if claims[step.label].reason is None and step.identifier == "added-mass":
                claims[step.label].reason = _mass_line_unmoved(spectra, current.spec)
            if claims[step.label].reason is None and len(steps) > 1:
                claims[step.label].reason = _other_kind_in_its_place(spectra, evidence, current, step.label,
                                                                          context, restoring)
            if claims[step.label].reason is not None:
                break
        failing = [step for step in steps if claims[step.label].reason is not None][-1:]
        if not failing:  # (the latest failing term goes first: the others may stand once it is out)
            break
        reasons = {step.label: claims[step.label].reason for step in failing}
        for identifier, reason in reasons.items():
            progress(f"  {identifier}: a candidate description, not a finding ({reason})")
        steps, current, evidence, refits_without = _demote_terms(spectra, evidence, steps, current, reasons,
                                                                 refits_without, rejected, recalibrated, context)
    return steps, current, evidence, refits_without, claims


def _demote_terms(
    spectra: HitSpectra,
    evidence: Evidence,
    steps: list[Step],
    current: FitOutcome,
    reasons: dict[str, str],
    refits_without: dict[str, RigSpec],
    rejected: list[CandidateDescription],
    recalibrated: RigSpec,
    context: FitContext,
) -> tuple[list[Step], FitOutcome, Evidence, dict[str, RigSpec]]:
    """Take the terms named in ``reasons`` out of the spec as candidate descriptions (band, values, reason), refit
    the rest, and refit that spec once without each term kept (where a term is needed is where that refit fails)."""
    demoted = [step for step in steps if step.label in reasons]
    for step in demoted:
        band = _term_band(evidence, current.spec, refits_without[step.label])
        rejected.append(CandidateDescription(
            step.identifier, band, _term_parameters(current, _effect_index(current.spec, step.label)),
            reasons[step.label]))
    spec = current.spec
    for index in sorted((_effect_index(current.spec, step.label) for step in demoted), reverse=True):
        spec = without_effect(spec, index)
    kept = _without_steps(steps, demoted, current.spec)
    current, evidence = _refit(spectra, spec, recalibrated, context)
    refits = {step.label: _refit_without(evidence, current.spec, _effect_index(current.spec, step.label),
                                         recalibrated, context).spec for step in kept}
    return kept, current, evidence, refits


def _refit_without(
    evidence: Evidence, spec: RigSpec, index: int, recalibrated: RigSpec, context: FitContext
) -> FitOutcome:
    """The spec refitted without effect ``index``: from its own values and from the recalibrated film's, the better
    fit. The term may have bent the film to suit it (a film memory that took the dashpot's place leaves the film
    without damping): refitted from there alone, the spec without the term is a straw man the term beats by far."""
    reduced = without_effect(spec, index)
    starts = [reduced]
    if reduced.film_parameters != recalibrated.film_parameters:
        starts.append(reduced.with_values(film_parameters=recalibrated.film_parameters))
    return min(shared_fits([(evidence, start, spec_slots(start, context)) for start in starts]),
               key=lambda outcome: outcome.chi2)


def _survives_left_out_data(
    spectra: HitSpectra, evidence: Evidence, final: FitOutcome, step: Step, without: RigSpec, context: FitContext
) -> str | None:
    """Why a term of the final spec does not survive data left out of its fit (frequency bands left out, parameters
    between disjoint halves of the band and of the hits), judged against the final spec refitted without it; sets
    the step's held-out band gain. Judged on the final spec, not when the term enters: a stand-in that the forward
    selection takes on the way (and the check back removes) must not push the true terms out of its place."""
    points = evidence.point_count
    noise_scale = _noise_scale(final, points)
    index = _effect_index(final.spec, step.label)
    base_evidence = evidence_for(spectra, without)
    band_folds = held_out_band_gain(base_evidence, without, evidence, final.spec, context)
    hit_folds = held_out_gain(base_evidence, without, evidence, final.spec, context)
    step.held_out_band_gain = band_folds.gain / noise_scale
    return _unstable(band_folds, hit_folds, index, noise_scale, points)


def _beside_a_larger_term(
    step: Step, steps: list[Step], claim: Claim, given_gains: Callable[[], list[tuple[str, float]]] = list
) -> str | None:
    """Why a term removes no excess of its own: without it (the rest refitted) its own band is already within the
    noise, and its χ² gain is below :data:`MODEL_FORM_SHARE` of another term's — a catalog term is a model of real
    physics, not the physics itself, and what it leaves grows with the mismatch it removes: such a term is a
    correction to the larger term's form, not told apart from its form error. The other terms are those found here
    (their gains at their steps) and those the spec was given with (``given_gains``, asked for only when no term
    found here is larger: the spec refitted without each): a written spec diagnosed again judges a term beside the
    ones written as the diagnosis that wrote them did (the loop closes)."""
    if claim.own_band_without > claim.own_band_chance:
        return None
    gain = step.chi2_before - step.chi2_after
    others = [(other.identifier, other.chi2_before - other.chi2_after) for other in steps if other is not step]
    if not others or gain >= MODEL_FORM_SHARE * max(other_gain for _, other_gain in others):
        others += given_gains()
    if not others:
        return None
    larger, larger_gain = max(others, key=lambda other: other[1])
    if gain >= MODEL_FORM_SHARE * larger_gain:
        return None
    return (f"without it its own band is already within the noise (χ²/point {claim.own_band_without:.2f}, what the "
            f"noise reaches by chance: {claim.own_band_chance:.2f}), and its χ² gain ({gain:.0f}) is "
            f"{100 * gain / larger_gain:.3f} % of the {larger}'s ({larger_gain:.0f}): a correction to the "
            f"{larger}'s form, not told apart from its form error")


def _given_term_gains(
    spectra: HitSpectra, final: FitOutcome, step: Step, steps: list[Step], without: RigSpec, recalibrated: RigSpec,
    context: FitContext,
) -> list[tuple[str, float]]:
    """The χ² gain of each term the spec was given with (not found here, not held) where a term found before
    ``step`` had its gain measured: in the spec without ``step`` (``without``, refitted), which loses that much more
    χ² when the given term is taken out too (the rest refitted)."""
    position = kept_positions(final.spec, _effect_index(final.spec, step.label))
    found = {_effect_index(final.spec, other.label) for other in steps}
    base_evidence = evidence_for(spectra, without)
    base_chi2 = base_evidence.chi2(without)
    gains = []
    for i, effect in enumerate(final.spec.effects):
        if i in found or i not in position or type(effect).held_after_recalibration:
            continue
        refit = _refit_without(base_evidence, without, position[i], recalibrated, context)
        gains.append((_label_at(final.spec, i), refit.chi2 - base_chi2))
    return gains


def _displaces_a_parameter(final: FitOutcome, identifier: str, without: RigSpec) -> str | None:
    """Why a term is not a measurement when, with it, another parameter of the written spec sits at the edge of its
    range and, without it (the rest refitted), does not: the term has taken that parameter's place instead of adding
    to it (a film memory that replaced the film's dashpot leaves a film without damping), and a parameter at its bound
    is not a measurement — the written spec would claim a value the data did not determine. Asked of a term with
    others beside it: a lone term that takes a film parameter's place re-describes the film (a fractional film has no
    dashpot), one that needs others beside it to do so is part of a combination standing in for something else."""
    # (the term goes out with the changes between hits that act on it: their slots are not compared)
    position = kept_positions(final.spec, _effect_index(final.spec, identifier))
    for slot in final.slots:
        if (slot.effect is not None and slot.effect not in position) or not slot.at_bound(final.spec):
            continue
        reduced = slot if slot.effect is None else dataclasses.replace(slot, effect=position[slot.effect])
        if reduced.at_bound(without):
            continue
        label = slot.label(final.spec)
        return (f"with it, {label} runs into the edge of its range ({slot.value(final.spec):.4g}), where it is "
                f"{reduced.value(without):.4g} without it: the term takes the place of the spec's own {label} "
                f"instead of adding to it, and a parameter at its bound is not a measurement")
    for name, value in final.spec.film_parameters.items():
        alone = without.film_parameters.get(name, value)
        factor = max(value / alone, alone / value) if value > 0 and alone > 0 else 1.0
        if factor > FILM_DISPLACEMENT:
            return (f"with it, the film's {name} is {value:.4g}, {factor:.1f}× from "
                    f"the {alone:.4g} it has without it: beside the other terms it takes the film's place instead of "
                    f"adding to it — together they re-describe the film, a combination standing in for something "
                    f"else")
    return None


def _measurement_alternative(step: Step) -> str | None:
    """Why a rig term is not a finding when a measurement-chain term fits about as well: these data cannot tell
    whether the rig or the measurement differs, and measurement properties are never claimed as physics."""
    if EFFECT_TYPES[step.identifier].kind != "rig":
        return None
    chain = [other for other in step.alternatives if EFFECT_TYPES[other].kind == "measurement"]
    if not chain:
        return None
    return (f"{' and '.join(chain)} in the measurement chain fits about as well (BIC within {ALTERNATIVE_MARGIN:.0f}): "
            f"these data cannot tell whether the rig or the measurement differs — "
            f"{separating_measurement(step.identifier, chain[0])} would")


def _other_kind_in_its_place(
    spectra: HitSpectra, evidence: Evidence, final: FitOutcome, identifier: str, context: FitContext,
    restoring: RestoringForce | None,
) -> str | None:
    """Why a term is not claimed when, on the written spec, a term of the other kind (the rig for a measurement-chain
    term, the measurement chain for a rig term) fits about as well in its place (BIC within :data:`SWAP_MARGIN` in
    the written spec's noise units, the rest refitted): these data cannot tell whether the rig or the measurement
    differs. Asked of a term with others beside it: its alternatives were judged when it entered, alone beside the
    spec (:func:`_measurement_alternative`), and what stands beside it on the written spec may change which forms can
    take its place (a servo's integral action beside a squeeze film reads as an AC coupling of the response)."""
    index = _effect_index(final.spec, identifier)
    kind = final.spec.effects[index].kind
    type_name = final.spec.effects[index].type_name
    reduced = without_effect(final.spec, index)
    others = [other for other in _candidate_identifiers(reduced, evidence, context, restoring)
              if EFFECT_TYPES[other].kind in ("rig", "measurement") and EFFECT_TYPES[other].kind != kind]
    points = evidence.point_count
    noise_scale = _noise_scale(final, points)
    # another term matters when its swap costs less than SWAP_MARGIN
    fitted = _candidate_fits(
        spectra, evidence, reduced, others, context, noise_scale,
        worth=lambda slot_count: final.chi2 + (SWAP_MARGIN - (slot_count - len(final.slots)) * np.log(points))
        * noise_scale)
    closest: tuple[float, str] | None = None
    for other in others:
        result = fitted[other]
        if isinstance(result, Exception) or result[0] is None:
            continue
        outcome = result[0]
        if _not_a_finding(outcome, len(outcome.spec.effects) - 1, context) is not None:
            continue
        extra = len(outcome.slots) - len(final.slots)
        cost = (outcome.chi2 - final.chi2) / noise_scale + extra * np.log(points)
        if cost < SWAP_MARGIN and (closest is None or cost < closest[0]):
            closest = (cost, other)
    if closest is None:
        return None
    cost, other = closest
    where = "the rig" if kind == "measurement" else "the measurement chain"
    return (f"{other} in {where} fits about as well in its place on the written spec (BIC {cost:+.1f}, within "
            f"{SWAP_MARGIN:.0f}): these data cannot tell whether the rig or the measurement differs — "
            f"{separating_measurement(type_name, other)} would")


def _mass_line_unmoved(spectra: HitSpectra, spec: RigSpec) -> str | None:
    """Why an added mass is not seen where a mass shows: a mass added to the mover moves the mass line (the FRF
    above the resonance, 1/m), but when a measurement term of the written spec (a force leaking into the response,
    a sensitivity error) cancels most of that move there, the pair describes the response, not the mover. A
    response that reads a share g of the film's force (an accelerometer's base-strain sensitivity: a + g·(F − m·a))
    is exactly a cross-talk g with an added mass g·m²; these data cannot tell the two apart."""
    index = _effect_index(spec, "added-mass")
    chain = [i for i, effect in enumerate(spec.effects) if effect.kind == "measurement"]
    if not chain:
        return None
    top = spectra.freq_hz >= spectra.freq_hz[0] + 0.75 * (spectra.freq_hz[-1] - spectra.freq_hz[0])
    written = replayed_mean(spectra, spec)[top]
    without_mass = replayed_mean(spectra, without_effect(spec, index))[top]
    bare = spec
    for i in sorted([index, *chain], reverse=True):
        bare = without_effect(bare, i)
    own = float(np.sqrt(np.mean(np.abs(written - without_mass) ** 2)))
    net = float(np.sqrt(np.mean(np.abs(written - replayed_mean(spectra, bare)[top]) ** 2)))
    if own <= 0 or net >= MASS_LINE_SHARE * own:
        return None
    names = " and ".join(sorted({spec.effects[i].type_name for i in chain}))
    mass_kg = getattr(spec.effects[index], "mass_kg", 0.0)
    return (f"the mass line does not move: above {spectra.freq_hz[top][0]:.0f} Hz the {names} beside it cancels "
            f"{100 * (1 - net / own):.0f} % of what the added mass of {1e3 * mass_kg:.3g} g does to the FRF, and a "
            f"mass on the mover would move it; together they describe the response, not the mover — e.g. a "
            f"response that reads a share of the film's force (accelerometer base strain, a + g·(F − m·a)), which "
            f"is exactly such a pair; these data cannot tell them apart")


def _refit(spectra: HitSpectra, spec: RigSpec, recalibrated: RigSpec, context: FitContext) -> tuple[FitOutcome, Evidence]:
    """Refit a spec some terms were taken out of: from its values and from the recalibrated film's (the film may
    have been bent to suit the terms taken out), the better fit."""
    starts = (spec, spec.with_values(film_parameters=recalibrated.film_parameters))
    evidences = [evidence_for(spectra, start) for start in starts]
    fitted = shared_fits([(evidence, start, spec_slots(start, context)) for evidence, start in zip(evidences, starts)])
    outcome = min(fitted, key=lambda fitted_start: fitted_start.chi2)
    evidence = evidence_for(spectra, outcome.spec)  # the replay of the spec that won
    return fit(evidence, outcome.spec, outcome.slots), evidence


def _band_lines(freq_hz: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    return np.flatnonzero((freq_hz >= band[0]) & (freq_hz <= band[1]))


def _claim(
    spectra: HitSpectra,
    evidence: Evidence,
    final: FitOutcome,
    without: RigSpec,
    identifier: str,
    recalibrated: RigSpec,
    rms_recalibrated: float,
) -> Claim:
    """The checks on the written spec: the term's own band within the noise (:data:`OWN_BAND_FALSE_ALARM`) and a
    positive RMS gain within the written spec (against the written spec refitted without it, both replayed with the
    recorded forces; per hit for terms that differ between hits), in % of the recalibrated spec's RMS."""
    band = _term_band(evidence, final.spec, without)
    lines = _band_lines(evidence.freq_hz, band)
    per_point = evidence.chi2_per_hit_and_frequency(final.spec) / 2.0
    after = float(per_point[:, lines].mean())
    before = float(evidence.chi2_per_hit_and_frequency(without)[:, lines].mean()) / 2.0
    limit = own_band_limit(spectra, per_point, lines)
    index = _effect_index(final.spec, identifier)
    per_hit = type(final.spec.effects[index]).per_hit
    measure = replay_rms_per_hit if per_hit else replay_rms
    reference = measure(spectra, recalibrated) if per_hit else rms_recalibrated
    in_written = (100.0 * (measure(spectra, without) - measure(spectra, final.spec)) / reference if reference > 0
                  else 0.0)
    reason = None
    if after > limit:
        share = (before - after) / (before - 1.0) if before > 1.0 else 0.0
        removed = (f"{100 * share:.0f} % of the excess there removed" if share >= 0
                   else "worse there than without it")
        reason = (f"a partial description: with it, its own band ({band_text(*band)}) stays at χ²/point {after:.2f} "
                  f"(1 = noise; {own_band_limit_text(limit)}), {removed}")
    elif in_written <= 0:
        reason = (f"the written spec replayed is not closer to the recordings with it than refitted without it "
                  f"(RMS gain {in_written:+.2f} % of the recalibrated spec's)")
    return Claim(after, limit, in_written, reason, before, own_band_chance(spectra, per_point, lines))


def own_band_limit(spectra: HitSpectra, per_point: np.ndarray, lines: np.ndarray) -> float:
    """The χ² per point above which a band is beyond the noise: :func:`own_band_chance`, never below
    ADEQUATE_CHI2_PER_POINT (a band of many lines is not held to a stricter standard than the whole)."""
    return max(own_band_chance(spectra, per_point, lines), ADEQUATE_CHI2_PER_POINT)


def own_band_limit_text(limit: float) -> str:
    """What the limit :func:`own_band_limit` gave a band means, in words: the χ²/point up to which it is noise."""
    if limit > ADEQUATE_CHI2_PER_POINT:
        return (f"up to {limit:.2f} counts as noise there, a level an F test says the noise alone exceeds only once in "
                f"{1 / OWN_BAND_FALSE_ALARM:.0f}")
    return f"up to {limit:.2f} counts as noise there, the margin the whole comparison is held to"


def own_band_chance(spectra: HitSpectra, per_point: np.ndarray, lines: np.ndarray) -> float:
    """The χ² per point a band (``lines`` of the analysis grid) reaches by chance: the one-sided F test at
    :data:`OWN_BAND_FALSE_ALARM` with the band's real numbers and the noise estimate's degrees of freedom, scaled by
    the level the spec reaches outside the band (clipped to 1 … ADEQUATE_CHI2_PER_POINT)."""
    band_dof = 2 * per_point.shape[0] * max(lines.size, 1)
    noise_dof = spectra.noise.degrees_of_freedom if spectra.noise is not None else 1e6
    outside = np.ones(per_point.shape[1], bool)
    outside[lines] = False
    rest = float(per_point[:, outside].mean()) if outside.any() else 1.0
    level = min(max(rest, 1.0), ADEQUATE_CHI2_PER_POINT)
    import scipy.stats  # (on first use: reading a stored diagnosis does not wait for it)
    return level * float(scipy.stats.f.isf(OWN_BAND_FALSE_ALARM, band_dof, max(noise_dof, 1.0)))


def _effect_index(spec: RigSpec, label: str) -> int:
    """The index in ``spec.effects`` of the effect a label names: ``type`` the first of its type, ``type#n`` the n-th
    (as :meth:`Slot.label` numbers repeated effects)."""
    type_name, _, number = label.partition("#")
    same = [i for i, effect in enumerate(spec.effects) if effect.type_name == type_name]
    return same[int(number) - 1 if number else 0]


def _label_at(spec: RigSpec, index: int) -> str:
    """The label of ``spec.effects[index]``: its type, numbered (``#n``) when it is not the first of its type."""
    type_name = spec.effects[index].type_name
    number = [i for i, effect in enumerate(spec.effects) if effect.type_name == type_name].index(index) + 1
    return type_name if number == 1 else f"{type_name}#{number}"


def _without_steps(steps: list[Step], removed: list[Step], spec: RigSpec) -> list[Step]:
    """``steps`` less ``removed`` (and less the changes between hits of a removed term, which go with it),
    relabelled for ``spec`` less their effects (a second extra mode is the first once the first is taken out)."""
    gone: set[int] = set()
    for step in removed:
        gone |= removed_with(spec, _effect_index(spec, step.label))
    reduced = spec
    for index in sorted(gone, reverse=True):
        reduced = reduced.with_values(effects=[e for i, e in enumerate(reduced.effects) if i != index])
    position = {old: new for new, old in enumerate(i for i in range(len(spec.effects)) if i not in gone)}
    return [dataclasses.replace(step, label=_label_at(reduced, position[_effect_index(spec, step.label)]))
            for step in steps if _effect_index(spec, step.label) not in gone]


# --- reporting ------------------------------------------------------------------------------------------------------


def _recalibration_table(given: RigSpec, outcome: FitOutcome, held_only: bool = False) -> dict[str, dict[str, float]]:
    """Spec value, fitted value and uncertainty of every recalibrated parameter; one that ran into the edge of its
    range has no uncertainty (``nan``) and ``at_bound`` set: the data did not measure it. ``held_only``: only the
    parameters held after the recalibration (a structure's modes)."""
    table = {}
    for index, slot in enumerate(outcome.slots):
        if slot.effect is not None and slot.effect >= len(given.effects):
            continue  # a term the diagnosis added: reported as a finding
        if held_only and (slot.effect is None or not type(outcome.spec.effects[slot.effect]).held_after_recalibration):
            continue
        at_bound = slot.at_bound(outcome.spec)  # a value at the edge of its range is not a measurement
        table[slot.label(outcome.spec)] = {"spec": slot.value(given), "fitted": slot.value(outcome.spec),
                                           "uncertainty": float("nan") if at_bound else outcome.uncertainty(index),
                                           "at_bound": at_bound, "unit": slot.unit(given)}
    return table


def _term_band(evidence: Evidence, final: RigSpec, without: RigSpec) -> tuple[float, float]:
    """The band holding 80 % of the χ² a term removes against the rest refitted without it."""
    gain = np.clip(evidence.chi2_per_frequency(without) - evidence.chi2_per_frequency(final), 0.0, None)
    freq_hz = evidence.freq_hz
    if gain.sum() <= 0:
        return float(freq_hz[0]), float(freq_hz[-1])
    cumulative = np.cumsum(gain) / gain.sum()
    low = freq_hz[min(np.searchsorted(cumulative, 0.1), len(freq_hz) - 1)]
    high = freq_hz[min(np.searchsorted(cumulative, 0.9), len(freq_hz) - 1)]
    return float(low), float(high)


def _where(index: int, spec: RigSpec, band: tuple[float, float]) -> str:
    """A finding's location in words: its own signature's frequency first, consequences elsewhere as such; a band as
    :func:`~gasfilm.analysis.quantities.band_text` writes it (its width shown, "at 3111 Hz" for one frequency)."""
    if spec.effects[index].type_name == "extra-mode":
        mode_hz = spec.effects[index].freq_hz
        own = f"near {mode_hz:.0f} Hz (its own peak/dip)"
        if band[0] <= mode_hz <= band[1]:
            return own
        return f"{own}; its mass also moves the main resonance, where most of its χ² gain lies ({band_text(*band)})"
    return band_text(*band)


def _values_at_the_ends(spec: RigSpec, index: int, evidence: Evidence) -> dict[str, float]:
    """The values of term ``index`` that change between hits, as the session's first and last hits (in blow order)
    see them (``first_hit_<value>``, ``last_hit_<value>``); none for a term no change acts on."""
    moved = {effect.parameter for effect in spec.effects if isinstance(effect, TermChange) and effect.term == index}
    if not moved:
        return {}
    conditions = evidence.spectra.conditions
    order = np.argsort(conditions.blows, kind="stable")
    values: dict[str, float] = {}
    for end, hit in (("first_hit", order[0]), ("last_hit", order[-1])):
        seen = spec.at_hit(float(conditions.time_s[hit]), float(conditions.impulse_ns[hit]),
                           float(conditions.blows[hit]))
        term = seen.effects[index - sum(1 for effect in spec.effects[:index] if isinstance(effect, TermChange))]
        values.update({f"{end}_{name}": float(getattr(term, name)) for name in sorted(moved)})
    return values


def _finding(
    evidence: Evidence, step: Step, final: FitOutcome, without: RigSpec, claim: Claim, context: FitContext
) -> Finding:
    identifier = step.identifier
    index = _effect_index(final.spec, step.label)
    effect = final.spec.effects[index]
    parameters = _term_parameters(final, index)
    sigma = {name: float(row["uncertainty"]) for name, row in parameters.items()}
    band = _term_band(evidence, final.spec, without)
    where = _where(index, final.spec, band)
    gain = step.chi2_before - step.chi2_after
    hits = f"all {evidence.hit_count} hits"
    if identifier in ("drift", "step-change"):
        hits += ", changing with the hit's session time"
    elif identifier == "cubic-stiffness":
        hits += ", changing with the hit's force level"
    sentence = effect.evidence(sigma, in_band(*band), context)
    # (a generic description is judged on the hits left out and on its own band, not on bands left out: none given)
    bands = ("" if type(effect).generic else
             f" and by {step.held_out_band_gain:.0f} on frequency bands left out of it")
    sentence = (f"{sentence[0].upper()}{sentence[1:]}; χ² falls by {gain:.0f} on all hits"
                f"{',' if bands else ' and'} by {step.held_out_gain:.0f} (noise units) on hits left out of the fit"
                f"{bands}.")
    alternatives = _alternatives(identifier, step.alternatives, final.spec, index)
    unusual = effect.implausible_in(final.spec, context)
    if unusual is not None:
        sentence += (f" Its values are unusual for this term ({unusual}); it is named because with it nothing is left "
                     f"unexplained.")
    return Finding(
        effect=identifier,
        kind=effect.kind,
        band_hz=band,
        where=where,
        parameters=parameters,
        evidence=sentence,
        explanation=type(effect).explanation,
        hits=hits,
        chi2_gain=gain,
        held_out_gain=step.held_out_gain,
        gain_over_recalibrated=claim.gain_over_recalibrated,
        alternatives=alternatives,
        held_out_band_gain=step.held_out_band_gain,
        own_band_chi2_per_point=claim.own_band_chi2_per_point,
        own_band_chi2_per_point_without=claim.own_band_without,
        own_band_limit=claim.own_band_limit,
        place=effect.place(),
        status="modelled" if type(effect).generic else "named",
        features={**effect.features_on(final.spec), **_values_at_the_ends(final.spec, index, evidence)},
        mechanisms=mechanisms_for(effect, context, final.spec.effects[effect.term] if isinstance(effect, TermChange)
                                  else None, alternatives=tuple(
                                      alternative.effect for alternative in alternatives
                                      if EFFECT_TYPES[alternative.effect].kind == effect.kind)),
    )


def _alternatives(identifier: str, close: list[str], spec: RigSpec, index: int) -> list[Alternative]:
    alternatives = []
    if identifier in EQUIVALENT and not gain_is_not_a_mass(spec):
        other, measurement = EQUIVALENT[identifier]
        mass_kg = getattr(spec.effects[index], "mass_kg", 0.0)
        fraction = -mass_kg / (spec.moving_mass_kg) if mass_kg else 0.0
        alternatives.append(Alternative(
            other, f"exactly equivalent: a uniform accelerometer sensitivity error of {100 * fraction:+.2f} % with a "
                   f"recalibrated film scales the FRF the same way; these data cannot tell them apart — {measurement}"))
    absorber = _lag_as_absorber(spec, index) if identifier == "pneumatic-lag" else None
    if absorber is not None:
        alternatives.append(absorber)
    for other in close:
        alternatives.append(Alternative(
            other, f"fits almost as well (BIC within {ALTERNATIVE_MARGIN:.0f}); these data cannot tell it from "
                   f"{identifier} — {separating_measurement(identifier, other)} would"))
    return alternatives


def _lag_as_absorber(spec: RigSpec, index: int) -> Alternative | None:
    """On a spring-damper film a lag ``k_lag/(1 + sτ)`` is exactly a mass ``m = k_lag·τ²`` coupled to the mover by a
    dashpot ``c = k_lag·τ`` alone (a viscous, Houdaille, absorber: ``m c s²/(m s + c) = c s − k_lag + k_lag/(1 + sτ)``)
    with the film's stiffness ``k + k_lag`` and damping ``η − c`` — when that damping stays positive (red team round
    8's viscous absorber was named a lag with exactly these values)."""
    if set(spec.film_parameters) != {"k", "eta"}:
        return None
    lag = spec.effects[index]
    coupling = lag.k_lag * lag.tau_lag
    if coupling >= spec.film_parameters["eta"]:
        return None
    mass = coupling * lag.tau_lag
    return Alternative(
        "extra-mode",
        f"exactly equivalent on a spring-damper film: a mass of {mass:.3g} kg coupled to the mover by a dashpot of "
        f"{coupling:.3g} N·s/m alone (a viscous absorber: a part on oil or air shear, an extra mode without a spring), "
        f"with the film's stiffness {spec.film_parameters['k'] + lag.k_lag:.4g} N/m and damping "
        f"{spec.film_parameters['eta'] - coupling:.4g} N·s/m; these data cannot tell them apart — a change of supply "
        f"pressure would (a lag in the film's air moves with it, a separate mass does not)")


# --- adequacy ---------------------------------------------------------------------------------------------------------


def _unexplained(
    spectra: HitSpectra,
    evidence: Evidence,
    spec: RigSpec,
    rejected: list[CandidateDescription],
    restoring: RestoringForce | None = None,
) -> list[Unexplained]:
    """Bands and hits where the final spec is beyond the measured noise, with their character."""
    per_point, bands, overall = _beyond_the_noise(evidence, spec)
    per_frequency = per_point.mean(axis=0)
    excess = np.clip(per_frequency - 1.0, 0.0, None)
    total_excess = float(excess.sum()) or 1.0
    freq_hz = evidence.freq_hz
    items: list[Unexplained] = []
    for low, high, share in bands:
        band = (float(freq_hz[low]), float(freq_hz[high]))
        items.append(Unexplained(band, _hits_in(spectra, per_point[:, low : high + 1]), share,
                                 _character(spectra, evidence, spec, low, high)))
    if overall > ADEQUATE_CHI2_PER_POINT and not items:
        items.append(Unexplained((float(freq_hz[0]), float(freq_hz[-1])), _hits_in(spectra, per_point), 1.0,
                                 _character(spectra, evidence, spec, 0, len(freq_hz) - 1)))
    for item in items:
        item.unmodelled_resonances_hz = unmodelled_resonances_hz(evidence, spec, item.band_hz)
        if item.unmodelled_resonances_hz:
            item.character = (f"resonances near {', '.join(f'{f:.0f}' for f in item.unmodelled_resonances_hz)} Hz "
                              f"that the spec does not have (modes of the structure no term describes); "
                              + item.character)
    for term in rejected:
        overlapping = [item for item in items
                       if item.band_hz[0] <= term.band_hz[1] and term.band_hz[0] <= item.band_hz[1]]
        lines = _band_lines(freq_hz, term.band_hz)
        if (not overlapping and lines.size
                and float(per_frequency[lines].mean()) > own_band_limit(spectra, per_point, lines)):
            low, high = int(lines[0]), int(lines[-1])
            share = float(excess[low : high + 1].sum()) / total_excess
            overlapping = [Unexplained(term.band_hz, _hits_in(spectra, per_point[:, low : high + 1]), share,
                                       _character(spectra, evidence, spec, low, high))]
            items.extend(overlapping)
        for item in overlapping:
            if any(candidate.effect == term.effect for candidate in item.candidates):
                continue
            item.candidates.append(term)
            item.character += f"; the {term.effect} term fitted here is not a finding: {term.reason}"
    if restoring is not None:
        for item in items:
            amplitude_character = (item.character.startswith("changing with the hit level")
                                   or "distorted by a nonlinearity" in item.character)
            overlaps = item.band_hz[0] <= restoring.band_hz[1] and restoring.band_hz[0] <= item.band_hz[1]
            if amplitude_character or (overlaps and restoring.best is not None):
                item.character += f"; {restoring.description()}"
    return items


def _beyond_the_noise(evidence: Evidence, spec: RigSpec) -> tuple[np.ndarray, list[tuple[int, int, float]], float]:
    """χ² per real number of every hit and line (1 is noise), the bands (first, last line, share of the excess) where
    the spec is beyond the noise, and its χ² per point over everything."""
    per_point = evidence.chi2_per_hit_and_frequency(spec) / 2.0
    overall = float(per_point.mean())
    per_frequency = per_point.mean(axis=0)
    smooth = np.convolve(per_frequency, np.ones(5) / 5, mode="same")
    threshold = LOCAL_CHI2_PER_POINT if overall <= ADEQUATE_CHI2_PER_POINT else max(2.0, 0.05 * overall)
    excess = np.clip(per_frequency - 1.0, 0.0, None)
    total_excess = float(excess.sum()) or 1.0
    bands = []
    for low, high in contiguous_bands(smooth > threshold, 2):
        share = float(excess[low : high + 1].sum()) / total_excess
        if overall > ADEQUATE_CHI2_PER_POINT or share >= 0.05:
            bands.append((low, high, share))
    return per_point, bands, overall


def _nothing_unexplained(evidence: Evidence, spec: RigSpec) -> bool:
    """Whether the spec leaves no band beyond the noise (what :func:`_unexplained` would list, without its words)."""
    _, bands, overall = _beyond_the_noise(evidence, spec)
    return not bands and overall <= ADEQUATE_CHI2_PER_POINT


#: The measured FRF's level against the given spec's, beyond which a note says so (a ratio of magnitudes)
LEVEL_RATIO_NOTE = 2.0
#: The measured-over-spec ratio's log-log slope that names a wrong quantity (velocity or displacement recorded as an
#: acceleration), within RATIO_SLOPE_TOLERANCE.
RATIO_SLOPES = ((-1.0, "a velocity recorded as an acceleration (a vibrometer's or a velocity sensor's output?)"),
                (-2.0, "a displacement recorded as an acceleration"))
RATIO_SLOPE_TOLERANCE = 0.2


#: Level ratios that are a unit mixed up, and what each would be; matched within :data:`UNIT_FACTOR_TOLERANCE`.
UNIT_FACTORS = (
    (STANDARD_GRAVITY_M_S2, "the ratio of g to m/s² (a sensitivity entered per g as per m/s², or the reverse)"),
    (4.4482216, "the ratio of a pound-force to a newton (a force recorded in lbf and read as N, or the reverse)"),
    (1000.0, "a factor of 1000 (mV taken for V, or a sensitivity per mN or per mm/s² taken per N or per m/s²)"),
)
UNIT_FACTOR_TOLERANCE = 0.03


def _level_note(evidence: Evidence, spec: RigSpec) -> list[QualityNote]:
    """A note when the measured FRF's level is far from the given spec's over most of the band (the median ratio of
    magnitudes), or their ratio rises or falls with frequency as f or 1/f would: beyond what a film or a mass change
    does, it points at the sensors' sensitivities, units or quantity."""
    measured, _ = evidence.spectra.mean()
    ratio_per_line = np.abs(measured) / np.maximum(np.abs(evidence.mean_prediction(spec)), 1e-300)
    ratio = float(np.median(ratio_per_line))
    slope = float(np.polyfit(np.log(evidence.freq_hz), np.log(np.maximum(ratio_per_line, 1e-300)), 1)[0])
    quantity = next((words for power, words in RATIO_SLOPES if abs(slope - power) < RATIO_SLOPE_TOLERANCE), "")
    if 1 / LEVEL_RATIO_NOTE <= ratio <= LEVEL_RATIO_NOTE and not quantity:
        return []
    factor = max(ratio, 1 / ratio)
    units = next((f"; {factor:.3g}× is {words}" for unit_factor, words in UNIT_FACTORS
                  if abs(factor / unit_factor - 1) < UNIT_FACTOR_TOLERANCE), "")
    if quantity:
        units += f"; the ratio goes as f^{slope:.2f} across the band: {quantity}"
    return [QualityNote(
        "level",
        f"the measured FRF is {ratio:.3g}× the spec's over most of the band (median of the magnitude ratios): check "
        f"the sensors' sensitivities, units and quantities, and the spec's mass, before reading physics into it"
        f"{units}")]


def _hits_in(spectra: HitSpectra, per_point: np.ndarray) -> list[int]:
    """Hit numbers whose χ² per point in the band stands out (all hits when none does)."""
    per_hit = per_point.mean(axis=1)
    outliers = np.flatnonzero(per_hit > 3.0 * max(np.median(per_hit), 1.0))
    chosen = outliers if outliers.size else np.arange(per_hit.size)
    return [int(spectra.hit_numbers[i]) for i in chosen]


def _character(spectra: HitSpectra, evidence: Evidence, spec: RigSpec, low: int, high: int) -> str:
    """What the unexplained residual looks like, in words that point at its cause."""
    freq_hz = evidence.freq_hz
    resonance_hz = float(freq_hz[np.argmax(np.abs(evidence.mean_prediction(spec)))])
    band = (freq_hz[low], freq_hz[high])
    residual = evidence.residual_per_hit(spec)[:, low : high + 1]
    weight = evidence.spectra.weight[:, low : high + 1]
    per_hit_mean = (weight * residual).sum(axis=1) / weight.sum(axis=1)
    gain_spread = _per_hit_gain_spread(evidence.spectra)
    order = np.argsort(spectra.conditions.time_s, kind="stable")
    change = _change_in_session(per_hit_mean[order], np.sqrt(1.0 / weight.sum(axis=1))[order])
    if change is not None:
        kind, split = change
        if kind == "step":
            first, second = spectra.hit_numbers[order[split - 1]], spectra.hit_numbers[order[split]]
            if gain_spread is not None:
                return (f"a jump between hits {first + 1} and {second + 1} that scales the whole FRF alike at every "
                        f"frequency: a sensor's sensitivity changed at one point (a sensor swapped or re-plugged, a "
                        f"gain setting) rather than the film, which no term explained")
            return (f"a jump between hits {first + 1} and {second + 1}: the rig changed at one point during the session, "
                    f"which no term explained")
        if gain_spread is not None:
            return ("a steady trend from early to late hits that scales the whole FRF alike at every frequency: a "
                    "sensor's sensitivity (or the force reaching the mover) changed during the session rather than the "
                    "film, which no term explained")
        return "a steady trend from early to late hits: the rig changed during the session, which no term explained"
    amplitude_trend = _level_trend(per_hit_mean, spectra.conditions.impulse_ns)
    if band[0] > 1.3 * resonance_hz and _at_harmonics(freq_hz[low : high + 1], weight * np.abs(residual) ** 2,
                                                       resonance_hz, float(np.median(np.diff(freq_hz)))):
        harmonic = f"at a harmonic of the resonance ({resonance_hz:.0f} Hz)"
        if amplitude_trend:
            return f"{harmonic}, growing with the hit level: the response is distorted by a nonlinearity"
        if _at_one_level(spectra.conditions.impulse_ns):
            return (f"{harmonic}, where a nonlinearity would distort the response; the hits, all at one level, cannot "
                    f"show whether it grows with the level as distortion does")
        return (f"{harmonic}, but its size does not follow the hits' levels as a nonlinearity's distortion would: "
                f"a localised excess no term explained")
    if amplitude_trend:
        return ("changing with the hit level: something is not linear — the rig (its stiffness, damping or moving "
                "mass depending on the amplitude: friction, quadratic damping, a nonlinear spring, a loose part that "
                "lifts off) or the measurement chain (a force gauge or converter whose gain depends on the level)")
    if gain_spread is not None:
        return (f"the hits differ from one another by a scale factor alone, the same at every frequency "
                f"({100 * gain_spread:.1f} % RMS): a gain that changes from hit to hit (the hit's direction, the force "
                f"gauge or a sensor), not the film")
    film_change = _per_hit_film_change(evidence, spec, order)
    if film_change is not None:
        return film_change
    centre = 0.5 * (band[0] + band[1])
    if band[1] - band[0] < 0.3 * centre:
        return f"a localised peak/dip near {centre:.0f} Hz that no term explained"
    return "a broadband excess over the measured noise: an effect no term describes, or the noise model"


#: Half-width of the line around a harmonic of the resonance, as a fraction of the resonance frequency (plus the
#: harmonic number times half a line spacing: the resonance is read on the analysis grid).
HARMONIC_HALF_WIDTH = 0.1


def _at_harmonics(freq_hz: np.ndarray, chi2: np.ndarray, resonance_hz: float, spacing_hz: float) -> bool:
    """Whether a band's misfit (``chi2``: hits × lines) sits at harmonics 2–6 of the resonance: the lines near them
    hold most of the excess over the noise, and they make up half the band or hold at least twice their share of it
    (a broad excess merely spanning harmonics is not distortion)."""
    order = np.arange(2, 7)
    distance = np.abs(freq_hz[:, np.newaxis] - order * resonance_hz)
    near = np.any(distance <= HARMONIC_HALF_WIDTH * resonance_hz + order * spacing_hz / 2, axis=1)
    excess = np.maximum(chi2.sum(axis=0) - chi2.shape[0], 0.0)
    share = float(excess[near].sum() / max(excess.sum(), 1e-300))
    fraction = float(near.mean())
    return share > 0.5 and (fraction >= 0.5 or share > 2 * fraction)


#: The hits differ by a gain alone when one complex scale factor per hit leaves at most this many times the noise
#: of their scatter about their mean, where the scatter itself was at least GAIN_SCATTER_MIN times it.
GAIN_ONLY_LEFT = 1.5
GAIN_SCATTER_MIN = 2.0


def _per_hit_gain_spread(spectra: HitSpectra) -> float | None:
    """RMS relative spread of a per-hit scale factor when it alone explains why the hits differ, else None.

    A sensor's sensitivity, the force gauge or the hit's direction scale a hit's whole FRF alike; a change of the
    film, the mass or a mode changes its shape. Each hit's FRF is fitted as one complex factor times the hits' mean.
    """
    h, weight = spectra.h, 1.0 / spectra.variance  # weight per complex value
    mean, _ = spectra.mean()
    factor = (weight * h * np.conj(mean)).sum(axis=1) / (weight * np.abs(mean) ** 2).sum(axis=1)
    expected = h.size * (1.0 - 1.0 / h.shape[0])
    scatter = float((weight * np.abs(h - mean) ** 2).sum()) / expected
    left = float((weight * np.abs(h - factor[:, np.newaxis] * mean) ** 2).sum()) / expected
    if scatter < GAIN_SCATTER_MIN or left > GAIN_ONLY_LEFT:
        return None
    return float(np.std(np.abs(factor)))


#: A smooth pattern in session time: the lag-one autocorrelation of a per-hit quantity in time order above this.
SESSION_PATTERN_CORRELATION = 0.5
#: Log-scaled film parameters are moved by this (relative) for their first-order effect on the prediction.
FILM_STEP = 1e-4
#: Gauss–Newton steps of each hit's own film parameters, each at most this (natural log) far.
FILM_ITERATIONS = 3
FILM_MAX_STEP = 0.5


def _film_moved(spec: RigSpec, names: list[str], log_changes) -> RigSpec:
    """The spec with the film parameters ``names`` multiplied by ``exp(log_changes)``."""
    film = dict(spec.film_parameters)
    for name, change in zip(names, log_changes):
        film[name] = film[name] * float(np.exp(change))
    return spec.with_values(film_parameters=film)


def _per_hit_film_change(evidence: Evidence, spec: RigSpec, order: np.ndarray) -> str | None:
    """Words for hits that differ from one another by their film alone — each hit's film parameters moved by their own
    small amounts leaves the hits within the noise (:data:`GAIN_ONLY_LEFT`) where their scatter about the spec was
    beyond it (:data:`GAIN_SCATTER_MIN`) — and whether those changes follow the session time in a pattern (a
    supply-pressure or temperature cycle: red team round 8's compressor cycling, a sawtooth of ±1.5 % in k, was "a
    broadband excess") or not (hit to hit); None when they do not."""
    names = [p.name for p in spec.film.parameters if p.scale == "log"]
    if not names or evidence.hit_count < 3 or spec.is_per_hit:
        return None
    sqrt_weight = np.sqrt(evidence.spectra.weight)  # per real number: each part of the residual has unit variance
    residual = evidence.residual_per_hit(spec)
    before = float(np.sum(np.abs(residual * sqrt_weight) ** 2)) / (2 * residual.size)
    if before < GAIN_SCATTER_MIN:
        return None
    changes = np.zeros((evidence.hit_count, len(names)))  # each hit's film parameters, log relative to the spec's
    left = 0.0
    for hit in range(evidence.hit_count):  # Gauss–Newton per hit: a resonance moved by a fraction of its width
        for _ in range(FILM_ITERATIONS):
            moved = _film_moved(spec, names, changes[hit])
            predicted = evidence.predicted(moved)
            columns = np.stack([(evidence.predicted(_film_moved(moved, [name], [FILM_STEP])) - predicted) / FILM_STEP
                                for name in names], axis=-1) * sqrt_weight[hit, :, np.newaxis]
            difference = (evidence.spectra.h[hit] - predicted) * sqrt_weight[hit]
            design = np.concatenate((columns.real, columns.imag))
            target = np.concatenate((difference.real, difference.imag))
            if not (np.all(np.isfinite(design)) and np.all(np.isfinite(target))):
                return None  # a spec this far from a hit is no film that changed a little
            step, *_ = np.linalg.lstsq(design, target, rcond=None)
            changes[hit] += np.clip(step, -FILM_MAX_STEP, FILM_MAX_STEP)
        difference = (evidence.spectra.h[hit] - evidence.predicted(_film_moved(spec, names, changes[hit])))
        left += float(np.sum(np.abs(difference * sqrt_weight[hit]) ** 2))
    after = left / max(2 * residual.size - changes.size, 1)
    if after > GAIN_ONLY_LEFT:
        return None
    spread = np.std(changes, axis=0)
    main = int(np.argmax(spread))
    in_time = changes[order, main] - changes[order, main].mean()
    correlation = float(np.sum(in_time[1:] * in_time[:-1]) / max(np.sum(in_time**2), 1e-300))
    amounts = ", ".join(f"{name} ±{100 * value:.2g} %" for name, value in zip(names, spread))
    pattern = ("following the session time in a pattern neither a steady trend nor one jump describes (a cycle of "
               "the supply pressure or the temperature?)" if correlation > SESSION_PATTERN_CORRELATION
               else "from hit to hit, with no order in session time")
    return (f"the hits differ from one another as if their film alone changed ({amounts} RMS between hits), "
            f"{pattern}: the film, or something that acts on the mover as it does (a hand, a cable, a cover), changed "
            f"between hits, which no term explained")


def _change_in_session(values: np.ndarray, sigma: np.ndarray) -> tuple[str, int] | None:
    """A significant step or trend of a per-hit quantity in time order: ("step", split) or ("trend", 0), or None."""
    count = values.size
    if count < 6:
        return None
    scatter = float(np.sum((values - values.mean()) ** 2 / sigma**2).real)
    if scatter < 4.0 * count:  # the hits agree within their noise: nothing changes
        return None
    position = np.arange(count, dtype=float)
    best_step, best_split = np.inf, 0
    for split in range(2, count - 1):
        before, after = values[:split], values[split:]
        cost = float(np.sum(np.abs(before - before.mean()) ** 2 / sigma[:split] ** 2)
                     + np.sum(np.abs(after - after.mean()) ** 2 / sigma[split:] ** 2))
        if cost < best_step:
            best_step, best_split = cost, split
    design = np.vstack((np.ones(count), position)).T / sigma[:, np.newaxis]
    trend_cost = 0.0
    for part in (values.real, values.imag):
        coefficients, *_ = np.linalg.lstsq(design, part / sigma, rcond=None)
        trend_cost += float(np.sum((part / sigma - design @ coefficients) ** 2))
    if min(best_step, trend_cost) > 0.5 * scatter:
        return None
    return ("step", best_split) if best_step < 0.7 * trend_cost else ("trend", 0)


def _at_one_level(impulse_ns: np.ndarray) -> bool:
    """Whether the hits' impulses (N·s) spread by no more than 10 % of their median: too alike to show a trend."""
    return bool(np.ptp(impulse_ns) <= 0.1 * np.median(impulse_ns))


def _level_trend(values: np.ndarray, impulse_ns: np.ndarray) -> bool:
    """Whether the per-hit residual follows the hit level strongly (rank correlation of its size with the impulse)."""
    if values.size < 6 or _at_one_level(impulse_ns):
        return False
    size = np.abs(values)
    ranks_size = np.argsort(np.argsort(size))
    ranks_level = np.argsort(np.argsort(impulse_ns))
    correlation = np.corrcoef(ranks_size, ranks_level)[0, 1]
    return bool(abs(correlation) > 0.7)


# --- replay -------------------------------------------------------------------------------------------------------


def evidence_for(spectra: HitSpectra, spec: RigSpec) -> Evidence:
    """Evidence whose per-hit FRFs are corrected by the replay of ``spec`` (see :class:`HitSpectra`); the replay is
    the exact nonlinear simulation when the spec has a cubic film spring."""
    return Evidence(spectra.correct_for_replay(model_function(spec, spectra.conditions),
                                               _nonlinear_replay(spectra, spec)))


def _nonlinear_replay(spectra: HitSpectra, spec: RigSpec) -> np.ndarray | None:
    """Per-hit FRFs of the exact nonlinear response played with the recorded forces, or None for a linear spec.
    Remembered per spec."""
    replay = spectra.replay
    if replay is None or spec.is_linear:
        return None
    key = spec.to_toml()
    if key not in replay.nonlinear_cache:
        replay.nonlinear_cache[key] = _simulate_nonlinear(spectra, spec)
    return replay.nonlinear_cache[key]


def _simulate_nonlinear(spectra: HitSpectra, spec: RigSpec) -> np.ndarray:
    """Replay with the cubic film spring: every hit's exact nonlinear response to its own recorded force, through
    the same windows (the hits shared by two processes, :func:`shared_map`). (Carrying one reference hit's distortion
    to the others by the first-order law ``x0² ∝ J²`` leaves χ²/point ~6–100 at the resonance when the shift is
    comparable to the bandwidth.)"""
    replay = spectra.replay
    forces_n = replay.forces_n
    responses = shared_map(lambda hit: simulate_response(spec, forces_n[hit], replay.sample_rate_hz,
                                                         time_s=float(spectra.conditions.time_s[hit])),
                           range(forces_n.shape[0]))
    failed = [response for response in responses if isinstance(response, Exception)]
    if failed:
        raise failed[0]
    return replay.windowed_frf(np.stack(responses))


def replayed_per_hit(spectra: HitSpectra, spec: RigSpec) -> np.ndarray:
    """Per-hit FRFs (hits, G) of ``spec`` played with each hit's recorded force through the same windows (the exact
    nonlinear response when the spec has a cubic film spring), each late-triggered record's missing impulse fitted."""
    replay = spectra.replay
    if replay is None:
        raise GasfilmError("diagnosis: these spectra keep no recorded forces to replay a spec with")
    model = model_function(spec, spectra.conditions)
    per_hit = _nonlinear_replay(spectra, spec)
    if per_hit is None:
        per_hit = np.broadcast_to(replay.replayed(model), replay.measured_h.shape)
    return replay.with_missing_fronts(per_hit, model)


def replayed_mean(spectra: HitSpectra, spec: RigSpec | None) -> np.ndarray:
    """H1 (noise-weighted mean over hits) of the recordings (``spec`` None), or of ``spec`` replayed with the
    recorded forces through the same windows."""
    replay = spectra.replay
    if replay is None:
        raise GasfilmError("diagnosis: these spectra keep no recorded forces to replay a spec with")
    per_hit = replay.measured_h if spec is None else replayed_per_hit(spectra, spec)
    return weighted_mean(per_hit, 1.0 / replay.measured_variance)[0]


def replay_rms(spectra: HitSpectra, spec: RigSpec) -> float:
    """Equation (33) under identical conditions: RMS over the analysis frequencies of |H1 recorded − H1 replayed|,
    in (m/s²)/N (both averaged over hits the same way)."""
    difference = replayed_mean(spectra, None) - replayed_mean(spectra, spec)
    return float(np.sqrt(np.mean(np.abs(difference) ** 2)))


def replay_rms_per_hit(spectra: HitSpectra, spec: RigSpec) -> float:
    """RMS over hits and analysis frequencies of |H_i recorded − H_i replayed| in (m/s²)/N: equation (33) hit by
    hit, for terms that differ between hits (their effect averages out of H1)."""
    difference = spectra.replay.measured_h - replayed_per_hit(spectra, spec)
    return float(np.sqrt(np.mean(np.abs(difference) ** 2)))


def residuals(diagnosis: Diagnosis, spec: RigSpec) -> tuple[np.ndarray, np.ndarray]:
    """χ² per real number of ``spec`` replayed against the recordings, at each analysis frequency and for each hit
    (1 is noise), from one replay."""
    evidence = evidence_for(diagnosis.spectra, spec)
    per_point = evidence.chi2_per_hit_and_frequency(spec) / 2.0
    return per_point.mean(axis=0), per_point.mean(axis=1)


__all__ = ["diagnose_spectra", "evidence_for", "replay_rms", "replayed_mean", "replayed_per_hit", "residuals"]
