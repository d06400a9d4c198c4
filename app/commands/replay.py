"""``gasfilm replay``: reprocess the raw hits of a session or a UFF file with other settings, without the rig.

The stored records are validated again with the given validation and window settings. When a trigger setting is
given, the trigger is first run again over each stored record: a record that no longer triggers is dropped, one that
now triggers twice gives two hits if both fit, and the new records are one pre-trigger length shorter than the stored
ones (unless ``--record-s`` says otherwise) so that a trigger firing a little later still finds a whole record. Hits a
person accepted or rejected by hand keep that decision while their records are unchanged. The result is summarised
(hits and reasons, peak of |H1|, coherence by band) and written: as a new session with ``--out``, else as the FRF
group "replay" of the input session.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.session import Session, SessionError, settings_from_json
from gasfilm.analysis.spectra import FrfResult, WindowSettings, compute_frf
from gasfilm.analysis.uff import read_uff_time_records, trigger_sample
from gasfilm.analysis.validation import ValidationSettings, Verdict, recorded_full_scale_si, validate_hit
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import DaqConfig, default_hammer_and_accelerometer

UFF_SUFFIXES = (".uff", ".unv")
#: Band edges (Hz) for the coherence summary; bands above the Nyquist frequency are left out.
COHERENCE_BAND_EDGES_HZ = (0.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 30000.0)
#: Lines below this frequency are not searched for the peak (the DC line and the rigid-body rise).
PEAK_SEARCH_FROM_HZ = 5.0
#: Only lines with at least this coherence are searched for the peak (zeros of the hammer spectrum give noisy
#: spikes in |H1|); when no line has it, all lines are searched.
PEAK_MIN_COHERENCE = 0.9


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "replay",
        help="reprocess the hits of a session or UFF file with other trigger/window/validation settings",
        description="Validate the stored hits again (and re-trigger them if a trigger setting is given), average "
        "the FRF, print a summary and store the result.",
    )
    parser.add_argument("source", type=Path, metavar="SESSION.h5|FILE.uff", help="session file or UFF time records")
    parser.add_argument("--trigger-n", type=float, help="new trigger level on the force in N (re-runs the trigger)")
    parser.add_argument("--pretrigger-s", type=float, help="new pre-trigger length in s (re-runs the trigger)")
    parser.add_argument("--record-s", type=float, help="new record length in s, at most the stored one")
    parser.add_argument("--force-window-ms", type=float, help="force window width after the peak in ms")
    parser.add_argument("--exp-end", type=float, help="exponential window: value at the record end, e.g. 0.01")
    parser.add_argument("--rectangular", action="store_true", help="no force or exponential window")
    parser.add_argument("--double-hit-fraction", type=float, help="double-hit threshold as a fraction of the peak")
    parser.add_argument("--min-force-snr", type=float, help="lowest accepted peak force over force noise")
    parser.add_argument("--decay-fraction", type=float, help="largest accepted end level of the response's decay, as a fraction of its start (default 0.005)")
    parser.add_argument("--force-dof", type=int, nargs=2, metavar=("NODE", "DIR"), help="UFF: force node, direction")
    parser.add_argument("--response-dof", type=int, nargs=2, metavar=("NODE", "DIR"),
                        help="UFF: response node and direction")
    parser.add_argument("--out", type=Path, help="write the result as a new session file (HDF5)")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(func=run)


@dataclass
class Source:
    """What replay starts from: the stored hits and the settings they were recorded with."""

    path: Path
    kind: str  # "session" or "uff"
    config: DaqConfig
    sample_rate_hz: float
    rig_spec_toml: str | None
    settings: dict[str, Any]
    hits: list[HitRecord]
    verdicts: list[Verdict | None]
    full_scale_si: tuple[float, ...] | None


def _load_source(path: Path, force_dof: Any, response_dof: Any) -> Source:
    if path.suffix.lower() in UFF_SUFFIXES:
        records = read_uff_time_records(
            path, tuple(force_dof) if force_dof else None, tuple(response_dof) if response_dof else None
        )
        hits = [
            HitRecord(
                index=i,
                data=record,
                sample_rate_hz=records.sample_rate_hz,
                trigger_index=trigger_sample(record[0]),
                start_time_s=float(records.start_times_s[i]),
                overload=np.zeros(2, bool),
                force_channel=0,
                response_channel=1,
            )
            for i, record in enumerate(records.records)
        ]
        config = default_hammer_and_accelerometer(records.sample_rate_hz)
        settings = {"source": {"uff_file": str(path), "force_dof": records.force_dof,
                               "response_dof": records.response_dof}}
        return Source(path, "uff", config, records.sample_rate_hz, None, settings, hits, [None] * len(hits), None)
    with Session.open(path, "r") as session:
        stored = session.hits()
        config = session.daq_config
        return Source(
            path=path,
            kind="session",
            config=config,
            sample_rate_hz=session.sample_rate_hz,
            rig_spec_toml=session.rig_spec_toml,
            settings=session.settings,
            hits=[hit.as_hit_record() for hit in stored],
            verdicts=[hit.verdict for hit in stored],
            full_scale_si=recorded_full_scale_si(config, session.settings),
        )


def _new_settings(args: argparse.Namespace, source: Source) -> tuple[TriggerSettings, bool, ValidationSettings,
                                                                       WindowSettings]:
    record_s = source.hits[0].n_samples / source.sample_rate_hz if source.hits else 1.0
    trigger = settings_from_json(source.settings.get("trigger"), TriggerSettings)
    if "trigger" not in source.settings:
        trigger = replace(trigger, record_s=record_s, pretrigger_s=min(trigger.pretrigger_s, record_s / 2))
    changes = {name: value for name, value in (("level_n", args.trigger_n), ("pretrigger_s", args.pretrigger_s),
                                               ("record_s", args.record_s)) if value is not None}
    retrigger = bool(changes)
    if retrigger and args.record_s is None:
        # room for the trigger to move later in the pulse by up to one pre-trigger length
        pretrigger_s = changes.get("pretrigger_s", trigger.pretrigger_s)
        changes["record_s"] = record_s - pretrigger_s
    trigger = replace(trigger, **changes)
    if trigger.record_s > record_s * (1 + 1e-9):
        raise SettingError(f"--record-s: {trigger.record_s} s is longer than the stored records ({record_s:g} s)")
    validation = replace(
        settings_from_json(source.settings.get("validation"), ValidationSettings),
        **{name: value for name, value in (("double_hit_fraction", args.double_hit_fraction),
                                           ("min_force_snr", args.min_force_snr),
                                           ("decay_fraction", args.decay_fraction)) if value is not None},
    )
    window = settings_from_json(source.settings.get("window"), WindowSettings)
    if args.rectangular:
        window = WindowSettings()
    window = replace(
        window,
        **{name: value for name, value in (("force_window_ms", args.force_window_ms),
                                           ("exponential_end_fraction", args.exp_end)) if value is not None},
    )
    return trigger, retrigger, validation, window


def _retrigger(
    hits: list[HitRecord], trigger: TriggerSettings, sample_rate_hz: float
) -> tuple[list[HitRecord], int]:
    """Run the trigger over each stored record as its own stream; return the new records and how many stored
    records gave none."""
    found = []
    silent = 0
    for hit in hits:
        capture = ImpactCapture(trigger, sample_rate_hz, hit.data.shape[0], hit.force_channel, hit.response_channel)
        records = capture.feed(hit.data, hit.overload)
        silent += not records
        for record in records:
            found.append(replace(record, index=len(found), start_time_s=hit.start_time_s + record.start_time_s))
    return found, silent


def _bands(freq_hz: np.ndarray, coherence: np.ndarray) -> list[dict[str, float]]:
    nyquist = float(freq_hz[-1])
    bands = []
    edges = [edge for edge in COHERENCE_BAND_EDGES_HZ if edge < nyquist] + [nyquist]
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (freq_hz >= low) & (freq_hz < high) & np.isfinite(coherence)
        if np.any(inside):
            bands.append({"low_hz": low, "high_hz": high, "mean_coherence": float(np.mean(coherence[inside]))})
    return bands


def summarise(frf: FrfResult | None, verdicts: list[Verdict], dropped: int, record_samples: int) -> dict[str, Any]:
    """Hits and reasons, peak frequency of |H1| and mean coherence by band."""
    reasons: dict[str, int] = {}
    for verdict in verdicts:
        for reason in verdict.reasons:
            reasons[reason] = reasons.get(reason, 0) + 1
    summary: dict[str, Any] = {
        "hits": len(verdicts),
        "accepted": sum(v.accepted for v in verdicts),
        "rejected": sum(not v.accepted for v in verdicts),
        "overridden": sum(v.overridden for v in verdicts),
        "records_without_trigger": dropped,
        "record_samples": record_samples,
        "reasons": dict(sorted(reasons.items())),
        "notes": [f"hit {index}: {note}" for index, verdict in enumerate(verdicts) for note in verdict.notes],
    }
    if frf is not None:
        magnitude = np.abs(frf.h1)
        search = (frf.freq_hz >= PEAK_SEARCH_FROM_HZ) & np.isfinite(magnitude)
        coherent = search & (frf.coherence >= PEAK_MIN_COHERENCE)
        if np.any(coherent):
            search = coherent
        peak = int(np.flatnonzero(search)[np.argmax(magnitude[search])])
        summary.update(
            peak_frequency_hz=float(frf.freq_hz[peak]),
            peak_accelerance_m_s2_per_n=float(magnitude[peak]),
            decay_rate_1_s=frf.decay_rate_1_s,
            coherence_bands=_bands(frf.freq_hz, frf.coherence),
        )
    return summary


def _print_summary(summary: dict[str, Any], source: Path, written: str) -> None:
    print(f"replay of {source}")
    print(f"  hits: {summary['hits']} of {summary['record_samples']} samples ({summary['accepted']} accepted, "
          f"{summary['rejected']} rejected"
          f"{', %d overridden by hand' % summary['overridden'] if summary['overridden'] else ''})")
    if summary["records_without_trigger"]:
        print(f"  records that no longer trigger: {summary['records_without_trigger']}")
    for reason, count in summary["reasons"].items():
        print(f"    {reason}: {count}")
    if summary["notes"]:
        more = len(summary["notes"]) - 1
        print(f"  note: {summary['notes'][0]}" + (f" (and {more} more notes; --json lists them)" if more else ""))
    if "peak_frequency_hz" in summary:
        print(f"  peak of |H1| (lines with coherence >= {PEAK_MIN_COHERENCE}): {summary['peak_frequency_hz']:.2f} Hz, "
              f"{summary['peak_accelerance_m_s2_per_n']:.4g} (m/s^2)/N")
        for band in summary["coherence_bands"]:
            print(f"  coherence {band['low_hz']:.0f}-{band['high_hz']:.0f} Hz: mean {band['mean_coherence']:.4f}")
    else:
        print("  no accepted hits: no FRF")
    print(f"  result: {written}")


def run(args: argparse.Namespace) -> int:
    if args.out is None and args.source.suffix.lower() in UFF_SUFFIXES:
        raise SettingError(f"--out: give a session file to store the replay of {args.source}")
    source = _load_source(args.source, args.force_dof, args.response_dof)
    if not source.hits:
        raise SessionError(f"{args.source}: holds no hits to replay")
    trigger, retrigger, validation, window = _new_settings(args, source)
    hits, dropped = _retrigger(source.hits, trigger, source.sample_rate_hz) if retrigger else (source.hits, 0)
    verdicts = []
    for position, hit in enumerate(hits):
        previous = None if retrigger else source.verdicts[position]
        if previous is not None and previous.overridden:
            verdicts.append(previous)
        else:
            verdicts.append(validate_hit(hit, validation, source.full_scale_si, window=window))
    accepted = [hit for hit, verdict in zip(hits, verdicts) if verdict.accepted]
    frf = None
    if accepted:
        records = np.stack([np.stack((hit.force_n, hit.response)) for hit in accepted])
        frf = compute_frf(records, source.sample_rate_hz, window)
    accepted_indices = np.array([i for i, verdict in enumerate(verdicts) if verdict.accepted], dtype=np.int64)
    settings = {"trigger": trigger, "validation": validation, "window": window,
                "replay": {"source": str(args.source), "retriggered": retrigger}}
    if args.out is not None:
        if args.out.resolve() == args.source.resolve():
            raise SettingError(f"--out: {args.out} is the input; leave --out out to store the result in the input")
        with Session.create(args.out, source.config, source.rig_spec_toml, {**source.settings, **settings},
                            overwrite=args.overwrite, actual_sample_rate_hz=source.sample_rate_hz,
                            sync_each_hit=False, record_samples=hits[0].n_samples if hits else None) as result:
            for hit, verdict in zip(hits, verdicts):
                result.append_hit(hit, verdict)
            if frf is not None:
                result.write_frf(frf, hit_indices=accepted_indices)
        written = f"new session {args.out}"
    elif source.kind == "session" and frf is not None:
        with Session.open(args.source, "a") as session:
            session.write_frf(frf, name="replay", hit_indices=accepted_indices if not retrigger else None)
            session.update_settings({"replay": settings})
        written = f"FRF group 'replay' in {args.source}"
    else:
        written = "nothing written (no accepted hits)"
    summary = summarise(frf, verdicts, dropped, hits[0].n_samples if hits else 0)
    if args.json:
        json.dump({"source": str(args.source), "result": written, **summary}, sys.stdout, indent=2)
        print()
    else:
        _print_summary(summary, args.source, written)
    return 0
