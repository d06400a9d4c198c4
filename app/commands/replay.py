"""``gasfilm replay``: reprocess the raw hits of a session, a UFF file or .npy records with other settings.

The stored records are validated again with the given validation and window settings. When a trigger setting is
given, the trigger is first run again over each stored record: a record that no longer triggers is dropped, one that
now triggers twice gives two hits if both fit, and the new records are one pre-trigger length shorter than the stored
ones (unless ``--record-s`` says otherwise) so that a trigger firing a little later still finds a whole record. Hits a
person accepted or rejected by hand keep that decision while their records are unchanged. The result is summarised
(hits and reasons, peak of |H1|, coherence by band) and written: as a new session with ``--out`` (never replacing a
file without ``--overwrite``), else as the FRF group "replay" of an input session; a file's result is only printed.
The exit status is 1 when no hit is accepted (no FRF).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from gasfilm.analysis.jsontext import dumps
from gasfilm.app.commands.common import (ESTIMATOR_NAMES, add_estimator_flag, add_units_flag, check_force_window_length,
                                         check_inputs, check_output_file, check_session_path, positive_flag,
                                         settings_from_flags, window_value)
from gasfilm.drivers.errors import GasfilmError, SettingError

#: Band edges (Hz) for the coherence summary; bands above the Nyquist frequency are left out.
COHERENCE_BAND_EDGES_HZ = (0.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 30000.0)
#: Said instead of the coherence figures when the FRF averages one hit.
ONE_AVERAGE_NOTE = ("not meaningful: one average gives a coherence of 1 at every line by construction; "
                    "average at least 2 hits (5 or more to judge the noise)")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "replay",
        help="reprocess the hits of a session, UFF or .npy files with other trigger/window/validation settings",
        description="Validate the stored hits again (and re-trigger them if a trigger setting is given), average "
        "the FRF, print a summary and store the result.",
    )
    parser.add_argument("source", type=Path, nargs="+", metavar="SESSION.h5|FILE.uff|HIT.npy",
                        help="a session, UFF 58 time records, or .npy hit records (rows time s, force N, "
                             "response m/s²; several files give several hits)")
    parser.add_argument("--trigger-n", type=float, help="new trigger level on the force in N (re-runs the trigger)")
    parser.add_argument("--pretrigger-s", type=float, help="new pre-trigger length in s (re-runs the trigger)")
    parser.add_argument("--record-s", type=float, help="new record length in s, at most the stored one")
    parser.add_argument("--force-window-ms", type=window_value,
                        help="force window width after the peak in ms ('none': no force window)")
    parser.add_argument("--exp-end", type=window_value,
                        help="exponential window: value at the record end, e.g. 0.01 ('none': no window)")
    parser.add_argument("--rectangular", action="store_true", help="no force or exponential window")
    parser.add_argument("--double-hit-fraction", type=float, help="double-hit threshold as a fraction of the peak")
    parser.add_argument("--min-force-snr", type=float, help="lowest accepted peak force over force noise")
    parser.add_argument("--decay-fraction", type=float,
                        help="largest accepted end level of the response's decay, as a fraction of its start "
                             "(default 0.005)")
    parser.add_argument("--force-dof", type=int, nargs=2, metavar=("NODE", "DIR"), help="UFF: force node, direction")
    parser.add_argument("--response-dof", type=int, nargs=2, metavar=("NODE", "DIR"),
                        help="UFF: response node and direction")
    parser.add_argument("--out", type=Path, help="write the result as a new session file (HDF5); without it a "
                        "session's result is stored as its FRF group 'replay' and a file's is only printed")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    parser.add_argument("--condition", action="append", default=[], metavar="KEY=VALUE",
                        help="with --out: the new session's operating condition, the unit at the end of the key "
                        "(repeatable; replaces the input's value of that key), e.g. supply_pressure_mpa=0.4")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_estimator_flag(parser, "the FRF estimator whose peak is read")
    add_units_flag(parser)
    parser.set_defaults(func=run)


def _new_settings(args: argparse.Namespace, source: Any) -> tuple[Any, bool, Any, Any]:
    """Trigger (and whether to re-run it), validation and window: the stored ones changed by the flags given."""
    from gasfilm.analysis.capture import TriggerSettings
    from gasfilm.analysis.settings import decode_settings
    from gasfilm.analysis.spectra import WindowSettings
    from gasfilm.analysis.validation import ValidationSettings

    record_s = source.hits[0].n_samples / source.sample_rate_hz
    stored = decode_settings(source.settings, str(source.path))
    trigger = stored.trigger
    if "trigger" not in source.settings:
        trigger = TriggerSettings(record_s=record_s, pretrigger_s=min(trigger.pretrigger_s, record_s / 2))
    positive_flag("--trigger-n", args.trigger_n, "N")
    retrigger = any(value is not None for value in (args.trigger_n, args.pretrigger_s, args.record_s))
    new_record_s = args.record_s
    if retrigger and new_record_s is None:
        # room for the trigger to move later in the pulse by up to one pre-trigger length
        pretrigger_s = args.pretrigger_s if args.pretrigger_s is not None else trigger.pretrigger_s
        new_record_s = record_s - pretrigger_s
        if args.pretrigger_s is not None and new_record_s <= pretrigger_s:
            raise SettingError(
                f"--pretrigger-s: {pretrigger_s:g} s leaves no record: the stored records are {record_s:g} s long and a "
                f"re-triggered one is a pre-trigger shorter ({new_record_s:.3g} s), which must exceed the pre-trigger; "
                f"give a shorter --pretrigger-s or a --record-s"
            )
    trigger = settings_from_flags(TriggerSettings, trigger, {
        "level_n": ("--trigger-n", args.trigger_n),
        "pretrigger_s": ("--pretrigger-s", args.pretrigger_s),
        "record_s": ("--record-s", new_record_s),
    })
    if trigger.record_s > record_s * (1 + 1e-9):
        raise SettingError(f"--record-s: {trigger.record_s} s is longer than the stored records ({record_s:g} s)")
    validation = settings_from_flags(ValidationSettings, stored.validation, {
        "double_hit_fraction": ("--double-hit-fraction", args.double_hit_fraction),
        "min_force_snr": ("--min-force-snr", args.min_force_snr),
        "decay_fraction": ("--decay-fraction", args.decay_fraction),
    })
    given = [flag for flag, value in (("--force-window-ms", args.force_window_ms), ("--exp-end", args.exp_end))
             if value is not None]
    check_force_window_length(args.force_window_ms, source.sample_rate_hz, f"{source.sample_rate_hz:g}")
    if args.rectangular and given:  # (which would win was said nowhere)
        raise SettingError(f"--rectangular: no window at all, but {' and '.join(given)} asks for one; give one or the "
                           f"other")
    window = settings_from_flags(WindowSettings, WindowSettings() if args.rectangular else stored.window, {
        "force_window_ms": ("--force-window-ms", args.force_window_ms),
        "exponential_end_fraction": ("--exp-end", args.exp_end),
    })
    return trigger, retrigger, validation, window


def _retrigger(hits: list, trigger: Any, sample_rate_hz: float) -> tuple[list, int]:
    """Run the trigger over each stored record as its own stream; return the new records and how many stored
    records gave none."""
    from dataclasses import replace

    from gasfilm.analysis.capture import ImpactCapture

    found = []
    silent = 0
    for hit in hits:
        capture = ImpactCapture(trigger, sample_rate_hz, hit.data.shape[0], hit.force_channel, hit.response_channel)
        records = capture.feed(hit.data, hit.overload)
        silent += not records
        for record in records:
            found.append(replace(record, index=len(found), start_time_s=hit.start_time_s + record.start_time_s))
    return found, silent


def _pretrigger_kept(trigger: Any, hits: list, sample_rate_hz: float, flag_given: bool) -> tuple[Any, str | None]:
    """The trigger settings with the pre-trigger the re-triggered records really hold (a record cannot start before
    its stored one), and a note when that is markedly shorter than asked (None otherwise). Later steps (the diagnosis measures
    the noise there) must not take part of the pulse for pre-trigger."""
    from dataclasses import replace

    if not hits:
        return trigger, None
    held_s = min(hit.trigger_index for hit in hits) / sample_rate_hz
    if held_s >= trigger.pretrigger_s - 0.5 / sample_rate_hz:
        return trigger, None
    if held_s >= 0.9 * trigger.pretrigger_s:  # a trigger firing a sample or two earlier is not worth a note
        return replace(trigger, pretrigger_s=held_s), None
    asked = f"--pretrigger-s {trigger.pretrigger_s:g} s" if flag_given else f"the pre-trigger of {trigger.pretrigger_s:g} s"
    short = sum(hit.trigger_index / sample_rate_hz < trigger.pretrigger_s - 0.5 / sample_rate_hz for hit in hits)
    note = (f"{asked}: {short} of {len(hits)} records hold less before their trigger (shortest {held_s * 1e3:.3g} ms: "
            f"a record cannot start before the stored one); the result says {held_s * 1e3:.3g} ms of pre-trigger")
    return replace(trigger, pretrigger_s=held_s), note


def _bands(freq_hz: Any, coherence: Any) -> list[dict[str, float]]:
    import numpy as np

    nyquist = float(freq_hz[-1])
    bands = []
    edges = [edge for edge in COHERENCE_BAND_EDGES_HZ if edge < nyquist] + [nyquist]
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (freq_hz >= low) & (freq_hz < high) & np.isfinite(coherence)
        if np.any(inside):
            bands.append({"low_hz": low, "high_hz": high, "mean_coherence": float(np.mean(coherence[inside]))})
    return bands


def _advised_exp_end(notes: list[str]) -> float | None:
    """The strongest exponential window the hits' notes advise (``--exp-end X``), None when none does."""
    import re

    values = [float(match) for note in notes for match in re.findall(r"--exp-end ([0-9.eE+-]+)\)", note)]
    return min(values) if values else None


def summarise(frf: Any, verdicts: list, dropped: int, record_samples: int, estimator: str = "h1") -> dict[str, Any]:
    """Hits and reasons, peak frequency of |H| (the ``estimator``'s: "h1", "h2" or "hv") and mean coherence by band
    (``frf``: an FrfResult or None). Hits are numbered from 1, as everywhere the user sees them."""
    import dataclasses

    import numpy as np

    from gasfilm.analysis.spectra import peak_line

    reasons: dict[str, int] = {}
    flagged: dict[str, int] = {}
    for verdict in verdicts:
        counts = reasons if not verdict.accepted else flagged if not verdict.overridden else {}
        for reason in verdict.reasons:
            counts[reason] = counts.get(reason, 0) + 1
    notes = [f"hit {number}: {note}" for number, verdict in enumerate(verdicts, start=1) for note in verdict.notes]
    summary: dict[str, Any] = {
        "hits": len(verdicts),
        "accepted": sum(v.accepted for v in verdicts),
        "rejected": sum(not v.accepted for v in verdicts),
        "overridden": sum(v.overridden for v in verdicts),
        "records_without_trigger": dropped,
        "record_samples": record_samples,
        "reasons": dict(sorted(reasons.items())),
        "flagged": dict(sorted(flagged.items())),
        "advised_exp_end": _advised_exp_end(notes),
        "notes": notes,
    }
    if frf is not None:
        frf = dataclasses.replace(frf, h1=getattr(frf, estimator))  # the peak is read on the chosen estimator
        magnitude = np.abs(frf.h1)
        peak = peak_line(frf)  # the strongest resonance, else the largest readable line (as the GUI's FRF tab)
        summary.update(
            estimator=ESTIMATOR_NAMES[estimator],
            peak_frequency_hz=float(frf.freq_hz[peak]),
            peak_accelerance_m_s2_per_n=float(magnitude[peak]),
            decay_rate_1_s=frf.decay_rate_1_s,
            averages=int(frf.n_averages),
            coherence_bands=_bands(frf.freq_hz, frf.coherence),
            coherence_note=(ONE_AVERAGE_NOTE if frf.n_averages < 2 else None),
        )
    return summary


def _print_summary(summary: dict[str, Any], source: Path, written: str, units: str = "si") -> None:
    from gasfilm.analysis.conditions import format_conditions
    from gasfilm.app.commands.common import accelerance_text

    print(f"replay of {source}")
    print(f"  conditions: {format_conditions(summary['conditions'])}")
    print(f"  hits: {summary['hits']}, records of {summary['record_samples']} samples ({summary['accepted']} accepted, "
          f"{summary['rejected']} rejected"
          f"{', %d overridden by hand' % summary['overridden'] if summary['overridden'] else ''})")
    if summary["records_without_trigger"]:
        print(f"  records that no longer trigger: {summary['records_without_trigger']}")
    if summary.get("pretrigger_note"):
        print(f"  note: {summary['pretrigger_note']}")
    for reason, count in summary["reasons"].items():
        print(f"    {reason}: {count}")
    for reason, count in summary["flagged"].items():
        print(f"  accepted but flagged ({reason}): {count} — a recording from elsewhere cannot be hit again; "
              f"its truncation leaks (see the notes)")
    if summary["notes"]:
        more = len(summary["notes"]) - 1
        print(f"  note: {summary['notes'][0]}" + (f" (and {more} more notes; --json lists them)" if more else ""))
    if summary["advised_exp_end"] is not None:
        print(f"  advice: add --exp-end {summary['advised_exp_end']:g} to window the ringing away")
    if "peak_frequency_hz" in summary:
        print(f"  peak of |{summary['estimator']}| (usable band, coherence >= 0.9): {summary['peak_frequency_hz']:.2f} Hz, "
              f"{accelerance_text(summary['peak_accelerance_m_s2_per_n'], units)}")
        if summary["coherence_note"]:
            print(f"  coherence: {summary['coherence_note']}")
        else:
            for band in summary["coherence_bands"]:
                print(f"  coherence {band['low_hz']:.0f}-{band['high_hz']:.0f} Hz: mean {band['mean_coherence']:.4f} "
                      f"({summary['averages']} averages)")
    else:
        print("  no accepted hits: no FRF")
    print(f"  result: {written}")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from gasfilm.analysis.conditions import decode_conditions, parse_condition_flags
    from gasfilm.analysis.session import Session, SessionError
    from gasfilm.analysis.sources import load_source
    from gasfilm.analysis.spectra import session_frf

    check_inputs(args.source)  # the inputs before the outputs
    if args.out is not None:
        if any(args.out.resolve() == path.resolve() for path in args.source):
            raise SettingError(f"--out: {args.out} is the input; leave --out out to store the result in the input")
        check_session_path(args.out, "--out")
        check_output_file(args.out, "--out", args.overwrite)
    given_conditions = parse_condition_flags(args.condition)
    if given_conditions and args.out is None:
        raise SettingError("--condition: only with --out (a session keeps the operating point it was recorded at)")
    source = load_source(args.source, args.force_dof, args.response_dof)
    conditions = {**decode_conditions(source.settings, str(source.path)), **given_conditions}
    if not source.hits:
        raise SessionError(f"{source.path}: holds no hits to replay")
    trigger, retrigger, validation, window = _new_settings(args, source)
    if args.trigger_n is not None:
        largest_n = max(float(np.max(np.abs(hit.force_n))) for hit in source.hits)
        if args.trigger_n >= largest_n:
            raise SettingError(f"--trigger-n: {args.trigger_n:g} N is above every stored record's force (largest "
                               f"peak {largest_n:.4g} N): no record would trigger")
    hits, dropped = _retrigger(source.hits, trigger, source.sample_rate_hz) if retrigger else (source.hits, 0)
    trigger, pretrigger_note = _pretrigger_kept(trigger, hits, source.sample_rate_hz, args.pretrigger_s is not None)
    verdicts = source.judge(validation, window, hits, None if retrigger else source.verdicts)
    accepted = [hit for hit, verdict in zip(hits, verdicts) if verdict.accepted]
    frf = session_frf(accepted, window) if accepted else None
    accepted_indices = np.array([i for i, verdict in enumerate(verdicts) if verdict.accepted], dtype=np.int64)
    settings = {"trigger": trigger, "validation": validation, "window": window,
                "replay": {"source": [str(path) for path in args.source], "retriggered": retrigger}}
    if args.out is not None:
        with Session.create(args.out, source.config, source.rig_spec_toml,
                            {**source.settings, **settings, "conditions": conditions},
                            overwrite=args.overwrite, actual_sample_rate_hz=source.sample_rate_hz,
                            sync_each_hit=False, record_samples=hits[0].n_samples if hits else None) as result:
            for hit, verdict in zip(hits, verdicts):
                result.append_hit(hit, verdict)
            if frf is not None:
                result.write_frf(frf, hit_indices=accepted_indices)
        written = f"new session {args.out}"
    elif source.is_session and frf is not None:
        try:
            with Session.updating(source.path) as session:  # the FRF and the settings, or nothing
                replaced = "replay" in session.result_names("frf")
                session.write_frf(frf, name="replay", hit_indices=accepted_indices if not retrigger else None)
                session.update_settings({"replay": settings})
            written = (f"FRF group 'replay' in {source.path}"
                       + (" (replacing the earlier replay's; --out S.h5 keeps a replay as a session of its own)"
                          if replaced else "")
                       + "; fit, export and report take it with --frf replay (without it: the stored 'frf')")
        except GasfilmError as error:  # a read-only session (or folder): the replay is shown, not kept
            written = (f"not stored in {source.path} ({error}); --out S.h5 keeps the replay as a session of its "
                       f"own")
    elif frf is not None:
        written = "printed only (add --out SESSION.h5 to keep it as a session)"
    else:
        written = "nothing written (no accepted hits)"
    summary = {"conditions": conditions,
               **summarise(frf, verdicts, dropped, hits[0].n_samples if hits else 0, args.estimator),
               "pretrigger_note": pretrigger_note}
    shown = source.path if len(args.source) == 1 else f"{source.path} and {len(args.source) - 1} more files"
    if args.json:
        print(dumps({"source": str(shown), "result": written, **summary}, indent=2))
    else:
        _print_summary(summary, shown, written, args.units)
    return 0 if frf is not None else 1
