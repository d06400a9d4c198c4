"""``gasfilm acquire``: headless acquisition from the simulated or an NI device into a session file.

Every hit is stored (flushed) before it is reported, so each "accepted hit N" line printed here is on disk: a killed
process leaves a session holding every hit it reported. A device error ends the run: the session is closed as
"aborted" with the reason, the hits stay, and the error is printed as one line.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import queue
import sys
import time
from pathlib import Path
from typing import Any, Iterator

from gasfilm.analysis.interrupts import signals_deferred
from gasfilm.analysis.paths import link_target
from gasfilm.app.commands.common import (check_force_window_length, check_output_file, check_session_path, device_name,
                                         hit_line, is_terminal, positive_flag, settings_from_flags, window_value)
from gasfilm.drivers.errors import DeviceError, GasfilmError, SettingError

logger = logging.getLogger(__name__)

SIMULATED_DEVICE_NAME = "sim"  # gasfilm.drivers.SIMULATED_DEVICE_NAME, without importing the drivers to register
#: Longest wait for a chunk before the run is declared stuck (the reader has its own device timeout).
CHUNK_WAIT_S = 30.0
#: Most accepted hits one run collects (a hammer test averages tens; 10 000 one-second hits at 12.8 kS/s fill 2 GB).
MAX_HITS = 10_000
#: Longest run in s of signal (one week).
MAX_SECONDS = 604_800.0
#: The simulator stops a run in which no hit triggers for this long (s of signal, or 3 × the longest hit interval):
#: its hammer never reaches the trigger level.
SIM_SILENCE_S = 60.0


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "acquire",
        help="record hammer hits from the simulated or an NI device into a session file",
        description="Record hammer hits into an HDF5 session: every hit (accepted or rejected) is stored as soon as "
        "it is complete. Stops after --hits accepted hits, after --seconds of signal, or on Ctrl-C.",
    )
    parser.add_argument("--device", default=SIMULATED_DEVICE_NAME, type=device_name,
                        help="'sim' (the default: the simulated rig) or an NI-DAQmx device name")
    parser.add_argument("--out", type=Path, required=True, help="session file to write (HDF5)")
    limit = parser.add_mutually_exclusive_group()
    limit.add_argument("--hits", type=int, help="stop after this many accepted hits")
    limit.add_argument("--seconds", type=float, help="stop after this many seconds of signal")
    parser.add_argument("--rig", type=Path, help="rig spec TOML (drives the simulator; stored with the session)")
    parser.add_argument("--condition", action="append", default=[], metavar="KEY=VALUE",
                        help="operating condition of the session, the unit at the end of the key (repeatable): "
                        "supply_pressure_mpa=0.4, gap_um=10, load_n=250, temperature_c=21, or a label such as "
                        "bearing=B-17; a rig spec with film laws is played at these conditions")
    parser.add_argument("--rate", type=float, default=12800.0, help="sample rate in S/s (51200/n; default 12800)")
    parser.add_argument("--record-s", type=float, default=1.0, help="record length per hit in s (default 1.0)")
    parser.add_argument("--trigger-n", type=float, default=20.0, help="trigger level on the force in N (default 20)")
    parser.add_argument("--pretrigger-s", type=float, default=0.01, help="pre-trigger length in s (default 0.01)")
    parser.add_argument("--force-window-ms", type=window_value,
                        help="force window width after the peak in ms ('none': no force window)")
    parser.add_argument("--exp-end", type=window_value,
                        help="exponential window: value at the record end, e.g. 0.01 ('none': no window)")
    parser.add_argument("--double-hit-fraction", type=float,
                        help="a second impact above this fraction of the first rejects the hit (default 0.1)")
    parser.add_argument("--operator", help="who runs the test (stored with the session, shown by the report)")
    parser.add_argument("--test-object", help="what is tested, e.g. 'bearing B-17 on mover M2' (stored, reported)")
    parser.add_argument("--seed", type=int,
                        help="simulator: random seed (default: a new one each run, stored with the session; give "
                             "the stored one to repeat a run)")
    parser.add_argument("--pacing", choices=("fast", "realtime"), default="realtime",
                        help="simulator: deliver samples as fast as possible or at the real rate (default)")
    parser.add_argument("--hit-interval", type=float, nargs=2, metavar=("MIN_S", "MAX_S"),
                        help="simulator: time between hammer hits, drawn between MIN_S and MAX_S")
    parser.add_argument("--double-hit-rate", type=float,
                        help="simulator: fraction of double hits (default: the rig spec's, else 0)")
    parser.add_argument("--hammer-point", metavar="NAME",
                        help="rigid-body rig: the hammer point struck in this run (a name of the rig spec's "
                             "[[rigid_body.hammer_points]]; default its hammer_point); --append a run per point for "
                             "a roving test")
    parser.add_argument("--append", action="store_true", help="append to an existing session instead of creating")
    parser.add_argument("--max-rejected", type=int,
                        help="stop after this many consecutive rejected hits (default 20, the recorder's)")
    parser.add_argument("--max-session-gb", type=float,
                        help="stop before the session file grows past this size in GB (default 4, the session's)")
    parser.set_defaults(func=run)


def _open_device(args: argparse.Namespace, rig_spec: Any, seed: int | None = None) -> Any:
    from gasfilm.analysis.physics.plant import RigPlant
    from gasfilm.drivers import open_device

    if args.device == SIMULATED_DEVICE_NAME:
        options = {"plant": RigPlant(rig_spec), "seed": args.seed if seed is None else seed,
                   "pacing": args.pacing,
                   "double_hit_rate": args.double_hit_rate}
        if args.hit_interval is not None:
            options["hit_interval_s"] = tuple(args.hit_interval)
        return open_device(SIMULATED_DEVICE_NAME, **options)
    return open_device(args.device)


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    """The trigger, validation and window settings from the flags, refused up front (naming the flag) when they
    cannot produce a valid hit."""
    from gasfilm.analysis.capture import TriggerSettings, check_record_length
    from gasfilm.analysis.spectra import WindowSettings
    from gasfilm.analysis.validation import ValidationSettings

    if args.hits is not None and not 1 <= args.hits <= MAX_HITS:
        raise SettingError(f"--hits: {args.hits} must be 1 to {MAX_HITS} (one run; --append adds more)")
    positive_flag("--seconds", args.seconds, "s")
    if args.seconds is not None and args.seconds > MAX_SECONDS:
        raise SettingError(f"--seconds: {args.seconds:g} s is longer than one week ({MAX_SECONDS:g} s); "
                           f"use --append for more")
    positive_flag("--rate", args.rate, "S/s")
    positive_flag("--trigger-n", args.trigger_n, "N")
    positive_flag("--record-s", args.record_s, "s")
    check_record_length(args.record_s, "--record-s")
    if args.hit_interval is not None:
        low, high = args.hit_interval
        if not 0 < low <= high:
            raise SettingError(f"--hit-interval: {low:g} {high:g} must be MIN_S MAX_S with 0 < MIN_S ≤ MAX_S")
        if high <= args.record_s:
            raise SettingError(f"--hit-interval: hits every {low:g}–{high:g} s all fall inside the --record-s "
                               f"{args.record_s:g} s record of the previous one (every hit would be a double hit)")
    if args.double_hit_rate is not None and not 0 <= args.double_hit_rate < 1:
        raise SettingError(f"--double-hit-rate: {args.double_hit_rate} must be at least 0 and below 1")
    if args.max_rejected is not None and args.max_rejected < 1:
        raise SettingError(f"--max-rejected: {args.max_rejected} must be at least 1")
    positive_flag("--max-session-gb", args.max_session_gb, "GB")
    trigger = settings_from_flags(TriggerSettings, None, {
        "level_n": ("--trigger-n", args.trigger_n),
        "pretrigger_s": ("--pretrigger-s", args.pretrigger_s),
        "record_s": ("--record-s", args.record_s),
    })
    validation = settings_from_flags(ValidationSettings, None, {
        "double_hit_fraction": ("--double-hit-fraction", args.double_hit_fraction),
    })
    check_force_window_length(args.force_window_ms, args.rate, f"--rate {args.rate:g}")
    window = settings_from_flags(WindowSettings, None, {
        "force_window_ms": ("--force-window-ms", args.force_window_ms),
        "exponential_end_fraction": ("--exp-end", args.exp_end),
    })
    settings = {"trigger": trigger, "validation": validation, "window": window}
    if args.operator is not None or args.test_object is not None:
        settings["test"] = {"operator": (args.operator or "").strip(), "test_object": (args.test_object or "").strip()}
    return settings


class _SessionLog(logging.FileHandler):
    """The session's log file; when it cannot be written (the disk is full), its messages still reach the user on
    stderr and the session's journal keeps the hits: the log's failure is not reported on top."""

    def handleError(self, record: logging.LogRecord) -> None:  # noqa: N802 - logging's name
        pass

    def close(self) -> None:
        with contextlib.suppress(OSError):
            super().close()


#: Flags an appended run takes from its session when they are not typed: (destination, flag).
APPEND_FROM_SESSION = (("rate", "--rate"), ("record_s", "--record-s"), ("pretrigger_s", "--pretrigger-s"),
                       ("trigger_n", "--trigger-n"), ("force_window_ms", "--force-window-ms"),
                       ("exp_end", "--exp-end"), ("double_hit_fraction", "--double-hit-fraction"),
                       ("condition", "--condition"))


def _settings_of_the_session(args: argparse.Namespace) -> None:
    """--append: the flags not typed take the session's own values (its rate, records, trigger, windows and
    conditions), said in one line; typed ones stay and are checked against the session as before."""
    from gasfilm.analysis.conditions import decode_conditions
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.settings import decode_settings
    from gasfilm.analysis.validation import ValidationSettings

    with Session.open(args.out) as session:
        stored = decode_settings(session.settings, str(args.out))
        stored_values = {
            "rate": session.requested_sample_rate_hz or session.sample_rate_hz,
            "record_s": stored.trigger.record_s, "pretrigger_s": stored.trigger.pretrigger_s,
            "trigger_n": stored.trigger.level_n,
            "force_window_ms": stored.window.force_window_ms,  # (None, no window: as when the flag is not typed)
            "exp_end": stored.window.exponential_end_fraction,
            "double_hit_fraction": (None if stored.validation.double_hit_fraction
                                    == ValidationSettings().double_hit_fraction else
                                    stored.validation.double_hit_fraction),
            "condition": [f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}" for key, value in
                          decode_conditions(session.settings, str(args.out)).items()],
        }
    typed = getattr(args, "typed_flags", set())
    taken = []
    for dest, flag in APPEND_FROM_SESSION:
        if dest in typed or stored_values[dest] in (None, []) or stored_values[dest] == getattr(args, dest):
            continue
        setattr(args, dest, stored_values[dest])
        value = stored_values[dest]
        shown = " ".join(f"{flag} {item}" for item in value) if isinstance(value, list) else f"{flag} {value:g}" \
            if isinstance(value, float) else f"{flag} {value}"
        taken.append(shown)
    if taken:
        print(f"appending with the session's settings: {' '.join(taken)}", flush=True)


def _attach_log(session_path: Path) -> logging.Handler:
    """Faults, dropped chunks, recoveries and the run's summary, appended to ``<session>.log`` next to it (beside the
    file a link points to; the file is made at the first message, so a run refused up front leaves none)."""
    handler = _SessionLog(link_target(session_path).with_suffix(".log"), encoding="utf-8", delay=True)
    handler.setLevel(logging.INFO)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    logging.getLogger("gasfilm").addHandler(handler)
    return handler


def _open_session(args: argparse.Namespace, config: Any, rate_hz: float, device_name: str,
                  rig_toml: str | None, settings: dict) -> Any:
    from gasfilm.analysis.session import Session, SessionError

    if args.append:
        session = Session.open(args.out, "a")
        if session.recovered:
            logger.warning("%s: recovered before appending (%s)", args.out, session.status_reason)
        stored, stored_rate_hz = session.daq_config, session.sample_rate_hz
        if len(stored.channels) != len(config.channels) or abs(stored_rate_hz - rate_hz) > 1e-6:
            session.close()
            raise SessionError(
                f"{args.out}: recorded with {len(stored.channels)} channels at {stored_rate_hz:g} S/s; "
                f"cannot append {len(config.channels)} channels at {rate_hz:g} S/s (give --rate {stored_rate_hz:g})"
            )
        record_samples = settings["trigger"].record_samples(rate_hz)
        stored_samples = session.record_samples
        if stored_samples not in (0, record_samples):
            session.close()
            raise SessionError(
                f"{args.out}: holds records of {stored_samples} samples; --record-s {args.record_s} gives "
                f"{record_samples}"
            )
        _check_same_conditions(args.out, session, settings["conditions"])
        session.update_settings({key: value for key, value in settings.items() if key != "conditions"})
        return session
    return Session.create(args.out, config, rig_toml, settings, actual_sample_rate_hz=rate_hz,
                          device_name=device_name, record_samples=settings["trigger"].record_samples(rate_hz))


def _check_same_conditions(path: Path, session: Any, conditions: dict) -> None:
    """A session is one operating point: hits appended with other ``--condition`` values are refused."""
    from gasfilm.analysis.conditions import decode_conditions, format_conditions

    stored = decode_conditions(session.settings, str(path))
    if conditions and conditions != stored:
        session.close()
        raise SettingError(f"--condition: {path} was recorded at {format_conditions(stored)}; a session holds one "
                           f"operating point (record {format_conditions(conditions)} into a new session)")


def rig_at_conditions(rig_spec: Any, conditions: dict, simulated: bool) -> tuple[Any, dict]:
    """The rig spec at the session's operating point and the conditions to store: on the simulator, a condition the
    spec's film laws need and ``--condition`` does not give is played (and stored) at the spec's reference value.
    (Conditions a simulated rig has no film law for are stored as given: :func:`_say_inert_conditions`.)"""
    from gasfilm.analysis.physics.laws import played_at

    if rig_spec is None or not rig_spec.film_laws:
        return rig_spec, conditions
    if not simulated:
        return rig_spec.at_conditions(conditions), conditions
    played, conditions, missing = played_at(rig_spec, conditions)
    if missing:
        logger.warning("the rig spec's film laws are played at its reference %s (not given by --condition)",
                       ", ".join(f"{key} = {value:g}" for key, value in missing.items()))
    return played, conditions


def _say_inert_conditions(rig_spec: Any, conditions: dict) -> None:
    """Say which ``--condition`` keys the simulated rig's spec has no film law for: stored with the session, they do
    not change the simulated film (two runs at two pressures give the same film)."""
    from gasfilm.analysis.physics.laws import law_keys

    followed = law_keys(rig_spec.film_laws) if rig_spec is not None and rig_spec.film_laws else []
    inert = [key for key in conditions if key not in followed]
    if inert:
        logger.warning("--condition %s: stored with the session, but the simulated rig's spec has no film law for %s, "
                       "so its film is the same at any value (a rig spec with [film.laws] follows them: "
                       "docs/campaigns.md; `gasfilm demo --campaign` shows one)", ", ".join(inert),
                       "it" if len(inert) == 1 else "them")


def _fresh_seed() -> int:
    """A new simulator seed for a run not given ``--seed``: two runs (at two pressures, say) are two draws of the
    rig's noise and hammer, not the same hits twice. It is stored with the session (``acquisition.seed``)."""
    return int.from_bytes(os.urandom(4), "little")


def _continuation(session: Any, seed: int) -> tuple[int, int, float]:
    """For a run appended to ``session``: its run number (0 for the first), the simulator seed that does not repeat
    an earlier run's hits, and the session time (s) where the earlier runs' signal ended, so hit times go on."""
    import numpy as np

    if session.hit_count == 0:
        return 0, seed, 0.0
    acquisition = session.settings.get("acquisition")
    acquisition = acquisition if isinstance(acquisition, dict) else {}
    runs = int(acquisition.get("runs") or 1)
    end_s = acquisition.get("stream_end_s")
    if not isinstance(end_s, (int, float)):  # an older session, or a run that was killed: from its stored hits
        end_s = max(hit.start_time_s + hit.data.shape[-1] / session.sample_rate_hz
                    for hit in session.hits(check_finite=False))
    run_seed = int(np.random.SeedSequence([seed, runs]).generate_state(1)[0])
    return runs, run_seed, float(end_s)


def _rigid_spec_of_session(path: Path) -> Any:
    """The rig spec stored in a session when it has a rigid body (an appended run of a roving test plays it)."""
    from gasfilm.analysis.rigid_session import session_spec
    from gasfilm.analysis.session import Session

    if not path.is_file():
        return None
    with Session.open(path) as session:
        return session_spec(session)


def _note_hammer_point(session: Any, rig_spec: Any) -> None:
    """Record the run's hammer point in the session (its ``hammer_points`` runs) and say where the roving test
    stands."""
    from gasfilm.analysis.rigid_session import HAMMER_POINTS_SETTING, next_point, roving_plan

    point = rig_spec.rigid_body.hammer_point
    plan = roving_plan(session.settings).with_run(point, session.hit_count)
    session.update_settings({HAMMER_POINTS_SETTING: plan.to_setting()})
    coming = next_point(rig_spec, plan)
    print(f"hammer point {point} (struck so far: {', '.join(plan.points())}; "
          + (f"next: {coming}, with --append --hammer-point {coming})" if coming else "every point struck)"),
          flush=True)


def _write_session_frf(session: Any, window: Any) -> None:
    """The session's FRF "frf": its accepted hits' (of a rigid-body session, those at its spec's hammer point, on
    its first accelerometer: what the spec's one-FRF view describes)."""
    import numpy as np

    from gasfilm.analysis.rigid_session import hits_at_spec_point, session_spec
    from gasfilm.analysis.spectra import session_frf

    spec = session_spec(session)
    if spec is None or spec.rigid_body is None:  # (read block by block: the whole session is never in memory)
        indices = session.accepted_indices()
        session.write_frf(session_frf(session.stored_hits(indices), window), hit_indices=indices)
        return
    accepted = hits_at_spec_point(spec, session.settings, [hit for hit in session.hits() if hit.verdict.accepted])
    if accepted:
        session.write_frf(session_frf(accepted, window), hit_indices=np.array([hit.index for hit in accepted]))


def _note_stream_end(session: Any, stream_end_s: float) -> None:
    """Record where this run's signal ended (session time), for the next --append; a failing file is left alone."""
    try:
        acquisition = dict(session.settings.get("acquisition") or {})
        session.update_settings({"acquisition": {**acquisition, "stream_end_s": stream_end_s}})
    except Exception as error:  # noqa: BLE001 - the hits are what matters; the session is being closed anyway
        logger.warning("%s: the end of the signal was not recorded (%s)", session.path, error)


class _Progress:
    """One line per hit on stdout (flushed at once), a running counter on stderr when it is a terminal."""

    def __init__(self) -> None:
        self.live = is_terminal()

    def hit(self, event: Any) -> None:
        line = hit_line(event)
        if self.live:
            sys.stderr.write("\r\033[K")
        print(line, flush=True)
        self.counter(event.accepted_count, event.rejected_count)

    def counter(self, accepted: int, rejected: int, stream_s: float | None = None) -> None:
        if self.live:
            clock = "" if stream_s is None else f" | {stream_s:.1f} s"
            sys.stderr.write(f"\raccepted {accepted}, rejected {rejected}{clock}")
            sys.stderr.flush()

    def done(self) -> None:
        if self.live:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()


def _nothing_recorded(args: argparse.Namespace, recorder: Any, hits_before: int) -> bool:
    """Whether a run that ends now leaves no trace: before the recording started (a new session), or before its
    first hit (an appended one: a run that adds no hit leaves its session byte for byte as it was)."""
    return recorder is None or (args.append and recorder.hit_count == hits_before)


def _left_unchanged(session: Any, args: argparse.Namespace) -> str:
    """A run that recorded no hit leaves no trace: an appended session as it was (nothing it wrote is committed),
    a new one removed. Says which."""
    session.discard()
    if args.append:
        return f"{args.out} left as it was"
    link_target(args.out).unlink(missing_ok=True)
    return f"{args.out} not created"


def _close_device(device: Any) -> None:
    """Close a device the recording loop did not reach (closing twice is harmless)."""
    with contextlib.suppress(DeviceError):
        device.close()


def _stream(device: Any, synchronous: bool) -> Iterator[tuple[Any, Any, int]]:
    """Chunks as (samples, overload flags, samples read so far). A device that waits for its samples is read on
    the acquisition loop's thread; the simulator at fast pacing is read here, so nothing outruns the recorder."""
    import numpy as np

    from gasfilm.analysis.acquisition import AcquisitionLoop

    if synchronous:
        device.start()
        try:
            read = 0
            while True:
                block = np.empty((len(device.config.channels), device.config.chunk_samples))
                read += device.read(block)
                yield block, device.status().overload, read
        finally:
            try:
                device.stop()
            except DeviceError:
                pass  # a removed device cannot be stopped; the read already raised why
    with AcquisitionLoop(device) as loop:
        chunks = loop.subscribe("acquire")
        while True:
            try:
                chunk = chunks.get(timeout_s=CHUNK_WAIT_S)
            except queue.Empty:
                raise DeviceError(f"device '{device.name}': no samples for {CHUNK_WAIT_S:.0f} s") from None
            if chunk is None:
                raise loop.error or DeviceError(f"device '{device.name}': the stream ended unexpectedly")
            if chunks.dropped_chunks:
                logger.error("%d chunks dropped: recording fell behind", chunks.dropped_chunks)
                raise DeviceError(
                    f"device '{device.name}': {chunks.dropped_chunks} chunks were lost because recording fell behind"
                )
            yield chunk.data, chunk.status.overload, chunk.first_sample + chunk.data.shape[1]


def run(args: argparse.Namespace) -> int:
    check_session_path(args.out, "--out")  # (before its log is named after it: `--out .` has no name to take)
    if args.append and args.out.is_file():
        _settings_of_the_session(args)
    handler = _attach_log(args.out)
    try:
        return _record(args)
    finally:
        logging.getLogger("gasfilm").removeHandler(handler)
        handler.close()


def _record(args: argparse.Namespace) -> int:
    from gasfilm.analysis.recording import stop_signals_raised

    # before anything is opened or printed: a SIGTERM or SIGHUP from now on ends the run through the cleanup below
    with stop_signals_raised():
        return _record_until_stopped(args)


def _record_until_stopped(args: argparse.Namespace) -> int:
    from gasfilm.analysis.capture import ImpactCapture
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.recording import DEFAULT_MAX_CONSECUTIVE_REJECTIONS, HitRecorder, RecordingStopped, StopSignal
    from gasfilm.drivers.interface import ChannelKind, default_hammer_and_accelerometer

    from gasfilm.analysis.conditions import format_conditions, parse_condition_flags

    settings = _settings(args)
    if args.seed is None:
        args.seed = _fresh_seed()
    conditions = parse_condition_flags(args.condition)
    trigger, validation, window = settings["trigger"], settings["validation"], settings["window"]
    check_session_path(args.out, "--out")
    if not args.append:
        if args.out.exists():
            raise SettingError(f"--out {args.out}: the session file exists already (use --append to add hits to it)")
        check_output_file(args.out, "--out", overwrite=False)
    elif not args.out.is_file():
        raise SettingError(f"--out {args.out}: --append needs an existing session file")
    rig_spec = None
    if args.rig is not None:
        rig_spec = RigSpec.load(args.rig)
    elif args.append:
        rig_spec = _rigid_spec_of_session(args.out)  # a roving test's next run plays the session's rigid body
    if rig_spec is None and args.device == SIMULATED_DEVICE_NAME:
        rig_spec = RigSpec.nominal("FOMGF")  # the simulated rig's default
    rig_spec, settings["conditions"] = rig_at_conditions(rig_spec, conditions,
                                                         args.device == SIMULATED_DEVICE_NAME)
    rigid = rig_spec is not None and rig_spec.rigid_body is not None
    if args.hammer_point is not None and not rigid:
        raise SettingError("--hammer-point: the rig spec has no [rigid_body] with hammer points (docs/rig-spec.md)")
    stored_spec = rig_spec
    if rigid:
        from gasfilm.analysis.physics.rigid_body import struck_at
        from gasfilm.analysis.rigid_session import rigid_daq_config

        point = args.hammer_point or rig_spec.rigid_body.hammer_point
        if point not in rig_spec.rigid_body.point_names:
            raise SettingError(f"--hammer-point {point}: not a hammer point of the rig spec (points: "
                               f"{', '.join(rig_spec.rigid_body.point_names)})")
        rig_spec = struck_at(rig_spec, point)
        stored_spec = rig_spec  # a new session is struck first where this run strikes
        config = rigid_daq_config(rig_spec, args.rate)
    else:
        config = default_hammer_and_accelerometer(args.rate)
    force_full_scale_n = config.channels[config.channel_index(ChannelKind.FORCE)].full_scale_si
    if args.trigger_n >= force_full_scale_n:
        raise SettingError(f"--trigger-n {args.trigger_n:g}: at or above the force channel's full scale "
                           f"({force_full_scale_n:.0f} N): no hit could ever trigger")
    session = None
    hits_before = 0
    stream_start_s = 0.0
    recorder = None
    started = time.monotonic()
    stream_s = 0.0
    progress = _Progress()
    device = _open_device(args, rig_spec)
    try:
        try:
            device.configure(config)
        except SettingError as error:  # the module's rules name the field; the user typed --rate
            raise SettingError(str(error).replace("sample_rate_hz:", f"--rate {args.rate:g}:")) from None
        rate_hz = device.sample_rate_hz
        with signals_deferred():  # (the session is handed over whole before a stop signal is raised)
            session = _open_session(args, config, rate_hz, device.name,
                                    stored_spec.to_toml() if stored_spec else None, settings)
        hits_before = session.hit_count
        if args.device == SIMULATED_DEVICE_NAME and args.condition:  # said once the run can start, not before a refusal
            _say_inert_conditions(rig_spec, conditions)
        run, seed, stream_start_s = _continuation(session, args.seed) if args.append else (0, args.seed, 0.0)
        if args.append and run and args.device == SIMULATED_DEVICE_NAME:
            device = _open_device(args, rig_spec, seed)  # the appended run goes on, it does not repeat the first
            device.configure(config)
        session.update_settings({"acquisition": {"runs": run + 1, "seed": seed, "stream_start_s": stream_start_s,
                                                 "stream_end_s": None}})
        if args.max_session_gb is not None:
            session.size_limit_bytes = int(args.max_session_gb * 1e9)
        force_row = config.channel_index(ChannelKind.FORCE)
        response_row = config.channel_index(ChannelKind.ACCELERATION)
        capture = ImpactCapture(trigger, rate_hz, len(config.channels), force_row, response_row, stream_start_s)
        other_responses: tuple[int, ...] = ()
        if rigid:
            other_responses = tuple(row for row, channel in enumerate(config.channels)
                                    if channel.kind is ChannelKind.ACCELERATION and row != response_row)
            _note_hammer_point(session, rig_spec)
        recorder = HitRecorder(
            session,
            capture,
            validation,
            full_scale_si=[channel.full_scale_si for channel in config.channels],
            window=window,
            on_hit=progress.hit,
            max_consecutive_rejections=args.max_rejected or DEFAULT_MAX_CONSECUTIVE_REJECTIONS,
            other_responses=other_responses,
        )
        accepted_before = recorder.accepted_count
        print(f"recording into {args.out} from {device.name} at {rate_hz:g} S/s; conditions: "
              f"{format_conditions(settings['conditions'])}", flush=True)
        logger.info("recording into %s from %s at %g S/s, settings %s", args.out, device.name, rate_hz, settings)
        simulated = args.device == SIMULATED_DEVICE_NAME
        silence_limit_s = max(SIM_SILENCE_S, 3 * args.hit_interval[1] if args.hit_interval else 0.0)
        last_hit_s, hits_seen = 0.0, recorder.hit_count
        synchronous = simulated and args.pacing == "fast"
        with recorder.stop_on_signals(), device, contextlib.closing(_stream(device, synchronous)) as chunks:
            for data, overload, end_sample in chunks:
                recorder.feed(data, overload)
                stream_s = end_sample / rate_hz
                if recorder.hit_count != hits_seen:
                    last_hit_s, hits_seen = stream_s, recorder.hit_count
                elif simulated and stream_s - last_hit_s > silence_limit_s:
                    raise DeviceError(f"no hit triggered in {silence_limit_s:g} s of simulated signal: the simulated "
                                      f"hammer does not reach --trigger-n {args.trigger_n:g} N")
                progress.counter(recorder.accepted_count, recorder.rejected_count, stream_s)
                if args.hits is not None and recorder.accepted_count - accepted_before >= args.hits:
                    break
                if args.seconds is not None and stream_s >= args.seconds:
                    break
    except (DeviceError, RecordingStopped) as error:
        progress.done()
        if session is None:
            _close_device(device)
            raise
        with signals_deferred():  # (the clean-up is not cut short by a second signal)
            if _nothing_recorded(args, recorder, hits_before):
                raise DeviceError(f"{error} — {_left_unchanged(session, args)}", getattr(error, "code", None)) from None
            accepted = recorder.accepted_count
            logger.error("%s: %s; session closed as aborted, %d accepted hits kept",
                         "device fault" if isinstance(error, DeviceError) else "stopped", error, accepted)
            _note_stream_end(session, stream_start_s + stream_s)
            session.close("aborted", str(error))
        raise DeviceError(
            f"{error} — session {args.out} closed as aborted, {accepted} accepted hits kept",
            getattr(error, "code", None),
        ) from None
    except KeyboardInterrupt as interrupt:  # Ctrl-C, or SIGTERM/SIGHUP through the stop-signal handlers
        with signals_deferred():  # (the clean-up is not cut short by a second signal)
            progress.done()
            signum = interrupt.signum if isinstance(interrupt, StopSignal) else 2
            how = "interrupted by the user" if signum == 2 else f"stopped by {interrupt}"
            _close_device(device)
            if session is None or _nothing_recorded(args, recorder, hits_before):
                left = _left_unchanged(session, args) if session is not None else (
                    f"{args.out} left as it was" if args.append else f"{args.out} not created")
                logger.info("%s before recording into %s started", how, args.out)
                print(f"{how} before recording started: {left}", flush=True)
                return 128 + signum
            accepted = recorder.accepted_count
            _note_stream_end(session, stream_start_s + stream_s)
            session.close("aborted", how)
            logger.info("%s: %s, %d accepted hits kept", args.out, how, accepted)
            print(f"{how}: session {args.out} closed with {accepted} accepted hit{'' if accepted == 1 else 's'}",
                  flush=True)
            return 128 + signum
    except BaseException as error:
        progress.done()
        _close_device(device)
        if session is None:
            raise
        if _nothing_recorded(args, recorder, hits_before):
            _left_unchanged(session, args)
            raise
        logger.error("stopped by %s: %s; session closed as aborted", type(error).__name__, error)
        session.close("aborted", f"{type(error).__name__}: {error}")
        raise
    progress.done()
    try:
        if recorder.accepted_count:
            _write_session_frf(session, window)
    except GasfilmError as error:  # (an earlier hit that cannot be read or averaged): the new hits are kept
        _note_stream_end(session, stream_start_s + stream_s)
        session.close("complete")
        raise GasfilmError(f"{error} — the session's FRF is not updated; its {recorder.hit_count} hits are stored "
                           f"and it is closed") from None
    _note_stream_end(session, stream_start_s + stream_s)
    session.close("complete")
    reasons = ", ".join(f"{reason}: {count}" for reason, count in sorted(recorder.reason_counts.items()))
    summary = (f"session {args.out}: {recorder.hit_count} hit{'s' if recorder.hit_count != 1 else ''}, "
               f"{recorder.accepted_count} accepted, "
               f"{recorder.rejected_count} rejected{f' ({reasons})' if reasons else ''}; "
               f"{stream_s:.1f} s of signal in {time.monotonic() - started:.1f} s")
    print(summary, flush=True)
    logger.info(summary)
    return 0
