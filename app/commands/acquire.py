"""``gasfilm acquire``: headless acquisition from the simulated or an NI device into a session file.

Every hit is stored (flushed) before it is reported, so each "accepted hit N" line printed here is on disk: a killed
process leaves a session holding every hit it reported. A device error ends the run: the session is closed as
"aborted" with the reason, the hits stay, and the error is printed as one line.
"""

from __future__ import annotations

import argparse
import contextlib
import queue
import sys
import time
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from gasfilm.analysis.acquisition import AcquisitionLoop
from gasfilm.analysis.capture import ImpactCapture, TriggerSettings
from gasfilm.analysis.recording import (
    DEFAULT_MAX_CONSECUTIVE_REJECTIONS,
    HitEvent,
    HitRecorder,
    RecordingStopped,
    StopSignal,
)
from gasfilm.analysis.session import DEFAULT_SIZE_LIMIT_BYTES, Session, SessionError
from gasfilm.analysis.spectra import WindowSettings, compute_frf
from gasfilm.analysis.validation import ValidationSettings
from gasfilm.drivers import SIMULATED_DEVICE_NAME, open_device
from gasfilm.drivers.errors import DeviceError, SettingError
from gasfilm.drivers.interface import ChannelKind, DaqConfig, DaqDevice, default_hammer_and_accelerometer

#: Longest wait for a chunk before the run is declared stuck (the reader has its own device timeout).
CHUNK_WAIT_S = 30.0


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "acquire",
        help="record hammer hits from the simulated or an NI device into a session file",
        description="Record hammer hits into an HDF5 session: every hit (accepted or rejected) is stored as soon as "
        "it is complete. Stops after --hits accepted hits, after --seconds of signal, or on Ctrl-C.",
    )
    parser.add_argument("--device", default=SIMULATED_DEVICE_NAME, help="'sim' or an NI-DAQmx device name")
    parser.add_argument("--out", type=Path, required=True, help="session file to write (HDF5)")
    limit = parser.add_mutually_exclusive_group()
    limit.add_argument("--hits", type=int, help="stop after this many accepted hits")
    limit.add_argument("--seconds", type=float, help="stop after this many seconds of signal")
    parser.add_argument("--rig", type=Path, help="rig spec TOML (drives the simulator; stored with the session)")
    parser.add_argument("--rate", type=float, default=12800.0, help="sample rate in S/s (51200/n; default 12800)")
    parser.add_argument("--record-s", type=float, default=1.0, help="record length per hit in s (default 1.0)")
    parser.add_argument("--trigger-n", type=float, default=20.0, help="trigger level on the force in N (default 20)")
    parser.add_argument("--pretrigger-s", type=float, default=0.01, help="pre-trigger length in s (default 0.01)")
    parser.add_argument("--force-window-ms", type=float, help="force window width after the peak in ms")
    parser.add_argument("--exp-end", type=float, help="exponential window: value at the record end, e.g. 0.01")
    parser.add_argument("--double-hit-fraction", type=float, default=ValidationSettings().double_hit_fraction,
                        help="a second impact above this fraction of the first rejects the hit")
    parser.add_argument("--seed", type=int, default=0, help="simulator: random seed")
    parser.add_argument("--pacing", choices=("fast", "realtime"), default="realtime",
                        help="simulator: deliver samples as fast as possible or at the real rate (default)")
    parser.add_argument("--hit-interval", type=float, nargs=2, metavar=("MIN_S", "MAX_S"),
                        help="simulator: time between hammer hits, drawn between MIN_S and MAX_S")
    parser.add_argument("--double-hit-rate", type=float,
                        help="simulator: fraction of double hits (default: the rig spec's, else 0)")
    parser.add_argument("--append", action="store_true", help="append to an existing session instead of creating")
    parser.add_argument("--max-rejected", type=int, default=DEFAULT_MAX_CONSECUTIVE_REJECTIONS,
                        help=f"stop after this many consecutive rejected hits (default {DEFAULT_MAX_CONSECUTIVE_REJECTIONS})")
    parser.add_argument("--max-session-gb", type=float, default=DEFAULT_SIZE_LIMIT_BYTES / 1e9,
                        help=f"stop before the session file grows past this size in GB "
                        f"(default {DEFAULT_SIZE_LIMIT_BYTES / 1e9:g})")
    parser.set_defaults(func=run)


def _open_device(args: argparse.Namespace, rig_spec: Any) -> DaqDevice:
    if args.device == SIMULATED_DEVICE_NAME:
        options = {"rig": rig_spec, "seed": args.seed, "pacing": args.pacing, "double_hit_rate": args.double_hit_rate}
        if args.hit_interval is not None:
            low, high = sorted(args.hit_interval)
            if low <= 0:
                raise SettingError(f"--hit-interval: {low} s must be positive")
            options["hit_interval_s"] = (low, high)
        return open_device(SIMULATED_DEVICE_NAME, **options)
    return open_device(args.device)


def _check_limits(args: argparse.Namespace) -> None:
    if args.hits is not None and args.hits < 1:
        raise SettingError(f"--hits: {args.hits} must be at least 1")
    if args.seconds is not None and not args.seconds > 0:
        raise SettingError(f"--seconds: {args.seconds} must be positive")


def _check_storage_limits(args: argparse.Namespace) -> None:
    if args.max_rejected < 1:
        raise SettingError(f"--max-rejected: {args.max_rejected} must be at least 1")
    if not args.max_session_gb > 0:
        raise SettingError(f"--max-session-gb: {args.max_session_gb} must be positive")


def _open_session(args: argparse.Namespace, config: DaqConfig, rate_hz: float, device_name: str,
                  rig_toml: str | None, settings: dict) -> Session:
    if args.append:
        session = Session.open(args.out, "a")
        stored = session.daq_config
        if len(stored.channels) != len(config.channels) or abs(session.sample_rate_hz - rate_hz) > 1e-6:
            session.close()
            raise SessionError(
                f"{args.out}: recorded with {len(stored.channels)} channels at {session.sample_rate_hz:g} S/s; "
                f"cannot append {len(config.channels)} channels at {rate_hz:g} S/s"
            )
        record_samples = settings["trigger"].record_samples(rate_hz)
        stored_samples = session.record_samples
        if stored_samples not in (0, record_samples):
            session.close()
            raise SessionError(
                f"{args.out}: holds records of {stored_samples} samples; --record-s {args.record_s} gives "
                f"{record_samples}"
            )
        session.update_settings(settings)
        return session
    if args.out.exists():
        raise SessionError(f"{args.out}: the session file exists already (use --append to add hits to it)")
    return Session.create(args.out, config, rig_toml, settings, actual_sample_rate_hz=rate_hz,
                          device_name=device_name, record_samples=settings["trigger"].record_samples(rate_hz))


class _Progress:
    """One line per hit on stdout (flushed at once), a running counter on stderr when it is a terminal."""

    def __init__(self) -> None:
        self.live = sys.stderr.isatty()

    def hit(self, event: HitEvent) -> None:
        if event.verdict.accepted:
            line = f"accepted hit {event.index + 1} at {event.trigger_time_s:.2f} s, peak {event.peak_force_n:.0f} N"
        else:
            line = f"rejected hit {event.index + 1} at {event.trigger_time_s:.2f} s: {', '.join(event.verdict.reasons)}"
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


def _stream(device: DaqDevice, synchronous: bool) -> Iterator[tuple[np.ndarray, np.ndarray, int]]:
    """Chunks as (samples, overload flags, samples read so far). A device that waits for its samples is read on
    the acquisition loop's thread; the simulator at fast pacing is read here, so nothing outruns the recorder."""
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
                raise DeviceError(
                    f"device '{device.name}': {chunks.dropped_chunks} chunks were lost because recording fell behind"
                )
            yield chunk.data, chunk.status.overload, chunk.first_sample + chunk.data.shape[1]


def run(args: argparse.Namespace) -> int:
    _check_limits(args)
    _check_storage_limits(args)
    rig_spec = None
    if args.rig is not None:
        from gasfilm.analysis.physics.spec import RigSpec

        rig_spec = RigSpec.load(args.rig)
    trigger = TriggerSettings(level_n=args.trigger_n, pretrigger_s=args.pretrigger_s, record_s=args.record_s)
    validation = ValidationSettings(double_hit_fraction=args.double_hit_fraction)
    window = WindowSettings(force_window_ms=args.force_window_ms, exponential_end_fraction=args.exp_end)
    config = default_hammer_and_accelerometer(args.rate)
    device = _open_device(args, rig_spec)
    if args.device == SIMULATED_DEVICE_NAME:
        rig_spec = device.rig  # the simulator's rig, also when it chose its default
    device.configure(config)
    rate_hz = device.sample_rate_hz
    settings = {"trigger": trigger, "validation": validation, "window": window}
    session = _open_session(args, config, rate_hz, device.name, rig_spec.to_toml() if rig_spec else None, settings)
    session.size_limit_bytes = int(args.max_session_gb * 1e9)
    force_row = config.channel_index(ChannelKind.FORCE)
    response_row = config.channel_index(ChannelKind.ACCELERATION)
    capture = ImpactCapture(trigger, rate_hz, len(config.channels), force_row, response_row)
    progress = _Progress()
    recorder = HitRecorder(
        session,
        capture,
        validation,
        full_scale_si=[channel.full_scale_si for channel in config.channels],
        window=window,
        on_hit=progress.hit,
        max_consecutive_rejections=args.max_rejected,
    )
    accepted_before = recorder.accepted_count
    print(f"recording into {args.out} from {device.name} at {rate_hz:g} S/s", flush=True)
    started = time.monotonic()
    stream_s = 0.0
    try:
        synchronous = args.device == SIMULATED_DEVICE_NAME and args.pacing == "fast"
        with recorder.stop_on_signals(), device, contextlib.closing(_stream(device, synchronous)) as chunks:
            for data, overload, end_sample in chunks:
                recorder.feed(data, overload)
                stream_s = end_sample / rate_hz
                progress.counter(recorder.accepted_count, recorder.rejected_count, stream_s)
                if args.hits is not None and recorder.accepted_count - accepted_before >= args.hits:
                    break
                if args.seconds is not None and stream_s >= args.seconds:
                    break
    except (DeviceError, RecordingStopped) as error:
        progress.done()
        session.close("aborted", str(error))
        raise DeviceError(
            f"{error} — session {args.out} closed as aborted, {recorder.accepted_count} accepted hits kept",
            getattr(error, "code", None),
        ) from None
    except KeyboardInterrupt as interrupt:  # Ctrl-C, or SIGTERM/SIGHUP through recorder.stop_on_signals
        progress.done()
        signum = interrupt.signum if isinstance(interrupt, StopSignal) else 2
        how = "interrupted by the user" if signum == 2 else f"stopped by {interrupt}"
        session.close("aborted", how)
        print(f"{how}: session {args.out} closed with {recorder.accepted_count} accepted hits", flush=True)
        return 128 + signum
    except BaseException as error:
        progress.done()
        session.close("aborted", f"{type(error).__name__}: {error}")
        raise
    progress.done()
    if recorder.accepted_count:
        frf = compute_frf(session.accepted_records(), rate_hz, window, force_row, response_row)
        session.write_frf(frf, hit_indices=session.accepted_indices())
    session.close("complete")
    reasons = ", ".join(f"{reason}: {count}" for reason, count in sorted(recorder.reason_counts.items()))
    print(
        f"session {args.out}: {recorder.hit_count} hits, {recorder.accepted_count} accepted, "
        f"{recorder.rejected_count} rejected{f' ({reasons})' if reasons else ''}; "
        f"{stream_s:.1f} s of signal in {time.monotonic() - started:.1f} s",
        flush=True,
    )
    return 0
