"""What a diagnosis returns: findings, what is not explained, measurement notes, and the improved spec.

The JSON form (:meth:`Diagnosis.to_dict`) is the contract documented in ``docs/diagnosis.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from gasfilm.analysis.diagnosis.measurement import HitSpectra, QualityNote
from gasfilm.analysis.diagnosis.mechanisms import MechanismMatch
from gasfilm.analysis.diagnosis.restoring import RestoringForce
from gasfilm.analysis.diagnosis.selection import Evidence
from gasfilm.analysis.diagnosis.structure import Structure, structure_summary
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.quantities import band_text, rounded_band
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

VERDICTS = ("consistent", "parameters-only", "missing physics", "modelled", "partly explained", "not explained")


@dataclass
class Alternative:
    """Another explanation that fits the recordings as well (or exactly as well) as a finding."""

    effect: str
    note: str

    def to_dict(self) -> dict:
        return {"effect": self.effect, "note": self.note}


def within_one_sigma_of_zero(value: float, uncertainty: float) -> bool:
    """Whether a fitted value is within one σ of zero: the data do not determine it (a frequency or a time constant
    there is not measured, a signed change there may be none)."""
    return uncertainty > abs(value)


@dataclass
class Finding:
    """A description of a mismatch in the written spec: located (``place`` in the chain), fitted (``parameters``,
    ``features``) and named (``mechanisms``, best first). ``status`` "named": a catalog term of known mechanism
    that passed every claim; "modelled": a generic description of its place, whose mechanisms are candidates."""

    effect: str
    kind: str  # "rig" or "measurement"
    band_hz: tuple[float, float]
    where: str
    parameters: dict[str, dict[str, float | str]]  # name → {"value", "uncertainty", "unit"}
    evidence: str
    explanation: str
    hits: str
    chi2_gain: float
    held_out_gain: float
    gain_over_recalibrated: float  # RMS (% of the recalibrated spec's) the written spec loses without this term
    alternatives: list[Alternative] = field(default_factory=list)
    held_out_band_gain: float = 0.0  # χ² gain (noise units) on interleaved sub-bands left out of the fit
    own_band_chi2_per_point: float = 0.0  # χ² per point of the written spec in the term's own band (1 = noise)
    own_band_limit: float = 0.0  # χ² per point beyond which that band is beyond the noise (F test)
    #: χ² per point in that band of the written spec refitted without the term (None: stored before it was kept)
    own_band_chi2_per_point_without: float | None = None
    place: str = ""  # where in the chain (gasfilm.analysis.physics.effects.PLACES)
    status: str = "named"  # "named" or "modelled"
    features: dict[str, float] = field(default_factory=dict)  # what the description shows (frequency_hz, …)
    mechanisms: list[MechanismMatch] = field(default_factory=list)  # consistent mechanisms, best first

    @property
    def undetermined(self) -> list[str]:
        """The parameters the data do not determine (:func:`within_one_sigma_of_zero`): a smaller description may
        describe the data as well."""
        return [name for name, row in self.parameters.items()
                if isinstance(row.get("value"), (int, float)) and isinstance(row.get("uncertainty"), (int, float))
                and within_one_sigma_of_zero(row["value"], row["uncertainty"])]

    def to_dict(self) -> dict:
        return {
            "effect": self.effect,
            "kind": self.kind,
            "place": self.place,
            "status": self.status,
            "undetermined": self.undetermined,
            "features": {name: _finite_or_none(value) for name, value in self.features.items()},
            "mechanisms": [mechanism.to_dict() for mechanism in self.mechanisms],
            "band_hz": rounded_band(*self.band_hz),
            "where": self.where,
            "parameters": self.parameters,
            "evidence": self.evidence,
            "explanation": self.explanation,
            "hits": self.hits,
            "chi2_gain": round(self.chi2_gain, 1),
            "held_out_gain": round(self.held_out_gain, 1),
            "gain_over_recalibrated": round(self.gain_over_recalibrated, 2),
            "held_out_band_gain": round(self.held_out_band_gain, 1),
            "own_band_chi2_per_point": round(self.own_band_chi2_per_point, 3),
            "own_band_chi2_per_point_without": _rounded_or_none(self.own_band_chi2_per_point_without, 3),
            "own_band_limit": round(self.own_band_limit, 3),
            "alternatives": [alternative.to_dict() for alternative in self.alternatives],
        }

    @classmethod
    def from_dict(cls, values: dict) -> "Finding":
        """A finding as stored in a session (older sessions lack the newer fields)."""
        band = tuple(values.get("band_hz", (0.0, 0.0)))
        return cls(
            effect=values["effect"], kind=values.get("kind", "rig"), band_hz=band,
            where=values.get("where", band_text(*band)), parameters=values.get("parameters", {}),
            evidence=values.get("evidence", ""), explanation=values.get("explanation", ""),
            hits=values.get("hits", ""), chi2_gain=values.get("chi2_gain", 0.0),
            held_out_gain=values.get("held_out_gain", 0.0),
            gain_over_recalibrated=values.get("gain_over_recalibrated", 0.0),
            alternatives=[Alternative(a["effect"], a["note"]) for a in values.get("alternatives", [])],
            held_out_band_gain=values.get("held_out_band_gain", 0.0),
            own_band_chi2_per_point=values.get("own_band_chi2_per_point", 0.0),
            own_band_limit=values.get("own_band_limit", 0.0),
            own_band_chi2_per_point_without=values.get("own_band_chi2_per_point_without"),
            place=values.get("place", ""), status=values.get("status", "named"),
            features={name: value for name, value in values.get("features", {}).items() if value is not None},
            mechanisms=[MechanismMatch(m["name"], m.get("note", ""), m.get("tell_apart", ""), bool(m.get("tied")))
                        for m in values.get("mechanisms", [])],
        )


def _finite_or_none(value: float) -> float | None:
    """A number for JSON: non-finite values are null (JSON has no NaN)."""
    return float(value) if value == value and abs(value) != float("inf") else None


def _rounded_or_none(value: float | None, digits: int) -> float | None:
    """A number for JSON rounded to ``digits`` decimals; null when there is none or it is not finite."""
    finite = None if value is None else _finite_or_none(value)
    return None if finite is None else round(finite, digits)


@dataclass
class CandidateDescription:
    """A term that fitted better but did not survive as a finding (at a bound, absurd, not predicting data left out
    of its fit, parameters that change between halves of the data, its own band left beyond the noise, or no gain in
    the written spec): reported with its fitted values and the reason, never as a finding."""

    effect: str
    band_hz: tuple[float, float]
    parameters: dict[str, dict[str, float | str]]  # name → {"value", "uncertainty", "unit"}
    reason: str

    def to_dict(self) -> dict:
        return {"effect": self.effect, "band_hz": rounded_band(*self.band_hz),
                "parameters": self.parameters, "reason": self.reason}


@dataclass
class Unexplained:
    """A part of the recordings the final spec does not explain within the noise."""

    band_hz: tuple[float, float]
    hits: list[int]  # hit numbers of the recordings (0-based, as loaded)
    chi2_share: float  # fraction of the final χ² excess over the noise that lies here
    character: str  # in words: harmonics → nonlinearity, a jump → a change during the session, ...
    candidates: list[CandidateDescription] = field(default_factory=list)  # partial descriptions fitted here
    unmodelled_resonances_hz: list[float] = field(default_factory=list)  # resonances here the spec does not have

    def to_dict(self) -> dict:
        return {"band_hz": rounded_band(*self.band_hz),
                "hits": [hit + 1 for hit in self.hits],
                "chi2_share": round(self.chi2_share, 3), "character": self.character,
                "candidates": [candidate.to_dict() for candidate in self.candidates],
                "unmodelled_resonances_hz": [round(f, 1) for f in self.unmodelled_resonances_hz]}


@dataclass
class Diagnosis:
    """Everything the diagnosis found. ``improved`` is the spec that was fitted; it is what a caller writes, and
    every "after" figure is of it replayed."""

    verdict: str
    findings: list[Finding]
    unexplained: list[Unexplained]
    quality: list[QualityNote]
    recalibration: dict[str, dict[str, float]]  # name → {"spec", "fitted", "uncertainty", "at_bound"}
    rms_before: float
    rms_recalibrated: float
    rms_after: float
    bic_before: float
    bic_after: float
    chi2_per_point_before: float
    chi2_per_point_after: float
    given: RigSpec
    recalibrated: RigSpec
    improved: RigSpec
    spectra: HitSpectra
    evidence: Evidence
    wall_time_s: float
    notes: list[str] = field(default_factory=list)
    candidates: list[CandidateDescription] = field(default_factory=list)  # every term that is not a finding
    restoring_force: RestoringForce | None = None  # model-free shape of the film's force (amplitude physics)
    improved_spec_path: str | None = None  # where a caller wrote ``improved``
    #: the written spec diagnosed again on the same recordings (``diagnose(check_loop=True)``): verdict, χ²/point,
    #: findings, closed (nothing more found)
    loop: dict | None = None
    figures: list[str] = field(default_factory=list)
    structure: Structure | None = None  # the measured structure read off the FRF (modes, stabilization diagram)

    @property
    def improvement_e(self) -> float:
        """Equation (35) with the given spec as the reference: RMS reduction in %."""
        return 100.0 * (self.rms_before - self.rms_after) / self.rms_before if self.rms_before > 0 else 0.0

    def to_dict(self) -> dict:
        g = STANDARD_GRAVITY_M_S2
        return {
            "verdict": self.verdict,
            "findings": [finding.to_dict() for finding in self.findings],
            "unexplained": [item.to_dict() for item in self.unexplained],
            "candidates": [candidate.to_dict() for candidate in self.candidates],
            "restoring_force": self.restoring_force.to_dict() if self.restoring_force is not None else None,
            "structure": structure_summary(self.improved, self.structure, (float(self.evidence.freq_hz[0]),
                                                                            float(self.evidence.freq_hz[-1]))),
            "quality": [note.to_dict() for note in self.quality],
            "noise": self.spectra.noise.to_dict() if self.spectra.noise else None,
            "recalibration": self.recalibration,
            "rms_before": self.rms_before,
            "rms_recalibrated": self.rms_recalibrated,
            "rms_after": self.rms_after,
            "rms_unit": "(m/s^2)/N",
            "rms_before_g_per_n": self.rms_before / g,
            "rms_recalibrated_g_per_n": self.rms_recalibrated / g,
            "rms_after_g_per_n": self.rms_after / g,
            "e_percent": self.improvement_e,
            "bic_before": self.bic_before,
            "bic_after": self.bic_after,
            "chi2_per_point_before": self.chi2_per_point_before,
            "chi2_per_point_after": self.chi2_per_point_after,
            "band_hz": [float(self.evidence.freq_hz[0]), float(self.evidence.freq_hz[-1])],
            "hits_used": int(self.evidence.hit_count),
            "hit_numbers_used": [int(n) + 1 for n in self.spectra.hit_numbers],
            "hits_numbered_from": 1,
            "decay_rate_1_s": self.evidence.decay_rate_1_s,
            "improved_spec": self.improved_spec_path,
            "loop": self.loop,
            "notes": self.notes,
            "figures": self.figures,
            "wall_time_s": self.wall_time_s,
        }

