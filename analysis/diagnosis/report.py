"""The diagnosis in words for a terminal or a report: verdict, findings, what is not explained, quality notes."""

from __future__ import annotations

from gasfilm.analysis.diagnosis.pipeline import own_band_limit_text
from gasfilm.analysis.diagnosis.result import Diagnosis, Finding, within_one_sigma_of_zero
from gasfilm.analysis.diagnosis.structure import STRUCTURE_CHANGED, mode_row_notes, structure_summary
from gasfilm.analysis.physics.effects import EFFECT_TYPES
from gasfilm.analysis.quantities import band_text, bands_text, is_number, unit_suffix, with_uncertainty
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2 as G_M_S2

#: A band not explained is listed on its own line when it holds at least this share of the excess χ²; the others are
#: counted in one line (all are in --json and the session report).
LISTED_SHARE = 0.01

#: Each verdict in words (the terminal report's line, the session report's).
VERDICT_LINES = {
    "consistent": "no missing physics: the spec explains the recordings within the noise",
    "parameters-only": "no missing physics: the recalibrated parameters explain the recordings within the noise",
    "missing physics": "the spec with the terms above explains the recordings within the noise",
    "modelled": ("the spec with the descriptions above explains the recordings within the noise; what is only "
                 "modelled has the mechanisms listed, none of them certain"),
    "partly explained": "the descriptions above explain part of the mismatch; the rest is NOT explained (below)",
    "not explained": "no description brings the recordings within the noise: the mismatch is NOT explained (below)",
}


def chi2_headline(before: float, after: float) -> str:
    """The diagnosis's headline figure, worded as the terminal report gives it and the GUI shows it: χ² per point of
    the spec as given and of the written spec against the recordings, in units of their measured noise (1 = within
    the noise)."""
    return f"χ²/point {before:.3f} → {after:.3f} (1 = noise)"


def report_text(diagnosis: Diagnosis) -> str:
    """A plain-text report, every number with its unit."""
    lines = [f"gasfilm diagnose — verdict: {diagnosis.verdict}"]
    evidence = diagnosis.evidence
    lines.append(f"  compared {evidence.hit_count} hits, {band_text(evidence.freq_hz[0], evidence.freq_hz[-1])}, "
                 f"replayed with the recorded forces through the same windows")
    if diagnosis.spectra.noise is not None:
        lines.append(f"  noise: {diagnosis.spectra.noise.source} — {diagnosis.spectra.noise.detail}")
    band = (float(evidence.freq_hz[0]), float(evidence.freq_hz[-1]))
    structure = structure_summary(diagnosis.improved, diagnosis.structure, band)
    if diagnosis.recalibration:
        lines.append("  recalibrated spec parameters:")
        modal = {name: row for name, row in diagnosis.recalibration.items() if name.startswith("structure-mode")}
        for name, row in diagnosis.recalibration.items():
            if name in modal:
                continue
            unit = unit_suffix(row.get("unit"))
            if row.get("at_bound"):
                lines.append(f"    {name:34s} {row['spec']:.6g}{unit} → {row['fitted']:.6g}{unit} at the edge of its "
                             f"range: not a measurement (the data do not determine it)")
            else:
                lines.append(f"    {name:34s} {row['spec']:.6g}{unit} → "
                             f"{with_uncertainty(row['fitted'], row['uncertainty'], row.get('unit'))}"
                             + ("  (within one σ of zero: not determined by the data)"
                                if within_one_sigma_of_zero(row["fitted"], row["uncertainty"]) else ""))
        if modal:
            edge = sum(bool(row.get("at_bound")) for row in modal.values())
            lines.append(f"    the structure's modes: {len(modal)} parameters recalibrated (the mode table below)"
                         + (f", {edge} at the edge of their range: not a measurement" if edge else "")
                         + "; each one with its uncertainty in --json and the session report")
        lines.extend(f"    {note}" for note in diagnosis.notes if note.startswith(STRUCTURE_CHANGED))
    if structure is not None:
        lines.extend(_structure_lines(structure, diagnosis))
    for finding in diagnosis.findings:
        if finding.status == "modelled":
            label = f"modelled in the {finding.place}" if finding.place.endswith(("channel", "chain")) else \
                f"modelled ({finding.place})"
        else:
            label = "measurement chain" if finding.kind == "measurement" else "missing physics"
        lines.append(f"  {label}: {finding.effect}  (where: {finding.where}; {finding.hits})")
        for name, row in finding.parameters.items():
            lines.append(f"      {name:30s} {with_uncertainty(row['value'], row['uncertainty'], row['unit'])}"
                         + ("  (not determined by the data)" if name in finding.undetermined else ""))
        if finding.undetermined:
            lines.append(f"      the data do not determine its {', '.join(finding.undetermined)} (within one σ of "
                         f"zero): a smaller description may do as well")
        lines.append(f"      why:  {finding.evidence}")
        lines.append(f"      what: {finding.explanation}")
        lines.extend(f"      {sentence}" for sentence in gain_sentences(finding))
        for alternative in finding.alternatives:
            lines.append(f"      or:   {alternative.effect} — {alternative.note}")
        if finding.mechanisms:
            first, *others = finding.mechanisms
            lines.append(f"      {'named' if finding.status == 'named' else 'likely'}: {first.name}")
            if others:
                lines.append(f"      also consistent: {'; '.join(m.name for m in others)} — {first.tell_apart} "
                             f"would tell them apart")
    lines.append(f"  {VERDICT_LINES[diagnosis.verdict]}")
    minor = [item for item in diagnosis.unexplained if item.chi2_share < LISTED_SHARE]
    for item in (item for item in diagnosis.unexplained if item.chi2_share >= LISTED_SHARE):
        hits = "all hits" if len(item.hits) == diagnosis.evidence.hit_count else \
            f"hits {', '.join(str(hit + 1) for hit in item.hits)}"  # numbered from 1, as everywhere the user sees
        lines.append(f"  NOT explained: {band_text(*item.band_hz)}, {hits}, "
                     f"{100 * item.chi2_share:.0f} % of the excess χ²: {item.character}")
        for candidate in item.candidates:
            values = ", ".join(f"{name} {with_uncertainty(row['value'], row['uncertainty'], row['unit'], '.4g')}"
                               for name, row in candidate.parameters.items())
            lines.append(f"      candidate description (not a finding): {candidate.effect} ({values})")
    if minor:
        lines.append(f"  and {len(minor)} more band(s) beyond the noise holding under {100 * LISTED_SHARE:.0f} % of the "
                     f"excess χ² each ({bands_text([item.band_hz for item in minor])}; in --json)")
    listed = {id(candidate) for item in diagnosis.unexplained for candidate in item.candidates}
    others = [candidate for candidate in diagnosis.candidates if id(candidate) not in listed]
    if others:
        lines.append("  terms tried and not claimed:")
        for candidate in others:
            lines.append(f"    {candidate.effect} ({band_text(*candidate.band_hz)}): "
                         f"{candidate.reason}")
    if diagnosis.restoring_force is not None:
        lines.append(f"  restoring force: {diagnosis.restoring_force.description()}")
    if diagnosis.quality:
        lines.append("  measurement quality (not physics):")
        lines.extend(f"    {note.kind}: {note.message}" for note in diagnosis.quality)
    lines.append(f"  RMS {diagnosis.rms_before / G_M_S2:.4g} g/N as given → {diagnosis.rms_recalibrated / G_M_S2:.4g} "
                 f"recalibrated → {diagnosis.rms_after / G_M_S2:.4g} g/N improved spec (E = "
                 f"{diagnosis.improvement_e:.1f} %); "
                 + chi2_headline(diagnosis.chi2_per_point_before, diagnosis.chi2_per_point_after))
    if diagnosis.loop is not None:
        loop = diagnosis.loop
        lines.append(f"  loop: the written spec diagnosed again gives '{loop['verdict_on_written_spec']}' (χ²/point "
                     f"{loop['chi2_per_point']:.3f})" + (": closed" if loop["closed"] else
                                                        f": NOT closed, it finds {', '.join(loop['findings'])}"))
    lines.extend(f"  note: {note}" for note in diagnosis.notes
                 if not (diagnosis.recalibration and note.startswith(STRUCTURE_CHANGED)))
    if diagnosis.improved_spec_path:
        lines.append(f"  improved spec: {diagnosis.improved_spec_path}")
    lines.extend(f"  figure: {figure}" for figure in diagnosis.figures)
    lines.append(f"  time: {diagnosis.wall_time_s:.1f} s from loading the recordings")
    return "\n".join(lines)


def gain_sentences(finding: Finding) -> list[str]:
    """How much better the written spec is with a finding's term, in words a test engineer reads: in the term's own
    band, χ²/point without it → with it (1 = the noise) against where that band would be beyond the noise; and the
    RMS gain over the whole band, said only when it shows (a narrow resonance hardly moves the RMS of the whole band,
    however well it fits its own)."""
    band = band_text(*finding.band_hz)
    before = finding.own_band_chi2_per_point_without
    change = (f"χ²/point {before:.2f} without it → {finding.own_band_chi2_per_point:.2f} with it"
              if is_number(before) else f"χ²/point {finding.own_band_chi2_per_point:.2f} with it")
    sentences = [f"in its own band ({band}): {change} (1 = the measured noise; "
                 f"{own_band_limit_text(finding.own_band_limit)})"]
    gain = f"{finding.gain_over_recalibrated:.1f}"
    if float(gain) != 0:
        per_hit = finding.effect in EFFECT_TYPES and EFFECT_TYPES[finding.effect].per_hit
        sentences.append(f"over the whole band{', hit by hit' if per_hit else ''}: RMS {gain} % lower with it than "
                         f"the written spec refitted without it (in % of the recalibrated spec's RMS)")
    return sentences


def _structure_lines(structure: dict, diagnosis: Diagnosis) -> list[str]:
    """The measured structure: how it was read off the FRF (when it was) and its mode table, by frequency."""
    lines = []
    read = structure["read_off_frf"]
    if read is not None:
        poles = read["poles"]
        lines.append(f"  structure read off the FRF ({band_text(*read['band_hz'])}): LSCF over "
                     f"{read['lscf_orders']} model orders, {poles['frequency, damping and participation']} poles "
                     f"stable in frequency, damping and participation; "
                     + ("a driving point" if read["driving_point"] else "a transfer FRF (modal constants of both signs)")
                     + f", polarity {read['polarity']:+d}, mass line {read['mass_line_kg']:.4g} kg"
                     + (f", suspension (soft support) at {read['suspension_hz']:.3g} Hz" if read["suspension_hz"]
                        else "")
                     + (f", upper residual as a mode at {read['upper_residual_hz']:.0f} Hz"
                        if read["upper_residual_hz"] else "")
                     + "; stabilization diagram in diagnosis-stabilization.png")
        for pole in read["rejected_poles"]:
            lines.append(f"    stable pole at {pole['freq_hz']:.0f} Hz is not a mode: {pole['reason']}")
    rows = structure["modes"]
    lines.append(f"  modes of the improved spec ({len(rows)}, by frequency; modal constants with the polarity taken "
                 f"out):")
    lines.append(f"    {'#':>3} {'frequency (Hz)':>14} {'damping ratio':>13} {'modal constant (1/kg)':>23}")
    for number, row in enumerate(rows, start=1):
        constant = f"{row['modal_constant_per_kg']:+.4g} {row['quadrature_per_kg']:+.2g}j"
        lines.append(f"    {number:>3} {row['freq_hz']:14.2f} {row['damping_ratio']:13.3g} {constant:>23}  "
                     f"{mode_row_notes(row)}".rstrip())
    return lines
