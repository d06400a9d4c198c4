"""``gasfilm demo``: a short hammer session on the simulated rig, summarised.

The main job end to end on the simulated NI 9234, paced in real time: stream, trigger, validate, store every hit in an
HDF5 session, average the FRF, identify the film (SD and FOMGF), and print what a technician would check first. An
existing ``--out`` file is replaced only with ``--overwrite``; without ``--out`` a new file is chosen.

``gasfilm demo --campaign`` records a small campaign instead (3 supply pressures × 2 gaps on a rig whose film follows
them, ``analysis/campaign/demo-rig.toml``) and runs ``gasfilm campaign`` on it: table, report, and the identified
stiffness at each condition against the rig's law.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from gasfilm.app.commands.common import (UNITS, accelerance_text, add_units_flag, check_output_file,
                                         check_output_folder, check_session_path, hit_line, positive_flag)
from gasfilm.drivers.errors import SettingError

DEFAULT_OUT = Path("out/demo-session.h5")
DEFAULT_CAMPAIGN_OUT = Path("out/demo-campaign")
#: Accepted hits per session: a single demo session, a campaign's session.
DEFAULT_HITS, DEFAULT_CAMPAIGN_HITS = 8, 4
#: Most hits a demo collects: it is paced in real time, about 0.85 s per hit (acquire records longer runs).
MAX_DEMO_HITS = 50


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="run a short hammer session on the simulated rig and summarise it")
    parser.add_argument("--hits", type=int, help=f"accepted hits to collect, 1 to {MAX_DEMO_HITS} (default "
                        f"{DEFAULT_HITS}, about 0.85 s each; per session with --campaign {DEFAULT_CAMPAIGN_HITS})")
    parser.add_argument("--rig", type=Path, help="rig spec TOML (default: the paper's FOMGF film on 25.05 kg)")
    parser.add_argument("--out", type=Path, help="session file to write (default: out/demo-session.h5, or the next "
                        "free out/demo-session-N.h5: an earlier demo is never replaced)")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    parser.add_argument("--seed", type=int, default=1, help="simulator seed")
    parser.add_argument("--no-fit", action="store_true", help="skip the film identification")
    add_units_flag(parser)
    parser.add_argument("--campaign", action="store_true",
                        help="record a small campaign (3 supply pressures × 2 gaps) and run `gasfilm campaign` on it; "
                        "--out is then a folder (default out/demo-campaign, or the next free out/demo-campaign-N)")
    parser.add_argument("--workers", type=int, default=2, help="--campaign: dask worker processes (default 2)")
    parser.set_defaults(func=run)


def _free_default_path(default: Path = DEFAULT_OUT) -> Path:
    """``default`` (out/demo-session.h5), else the first out/demo-session-N.h5 that does not exist."""
    path, number = default, 1
    while path.exists() or path.is_symlink():
        number += 1
        path = default.with_name(f"{default.stem}-{number}{default.suffix}")
    return path


def run_campaign_demo(args: argparse.Namespace) -> int:
    """Record the demo campaign into ``--out``/sessions, run the campaign on it, compare k with the rig's law."""
    from gasfilm.analysis.campaign import CSV_NAME, PARQUET_NAME, REPORT_NAME, CampaignOptions, run_campaign
    from gasfilm.analysis.campaign.simulated import DEMO_GRID, DEMO_RIG_PATH, record_campaign
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.app.commands.campaign import _Progress

    hits = args.hits if args.hits is not None else DEFAULT_CAMPAIGN_HITS
    positive_flag("--hits", hits)
    positive_flag("--workers", args.workers)
    out = args.out if args.out is not None else _free_default_path(DEFAULT_CAMPAIGN_OUT)
    if out.exists() and not out.is_dir():
        raise SettingError(f"--out {out}: is a file; --campaign writes a folder")
    if out.is_dir() and any(out.iterdir()) and not args.overwrite:
        raise SettingError(f"--out {out}: the folder is not empty (add --overwrite to record the campaign again)")
    check_output_folder(out, "--out", (PARQUET_NAME, CSV_NAME, REPORT_NAME), overwrite=True)
    spec = RigSpec.load(args.rig) if args.rig else RigSpec.load(DEMO_RIG_PATH)
    by = list(DEMO_GRID)
    started = time.monotonic()
    print(f"gasfilm demo --campaign — rig '{spec.name}', {len(by)} conditions: "
          + ", ".join(f"{key} {', '.join(f'{v:g}' for v in values)}" for key, values in DEMO_GRID.items()))
    sessions = out / "sessions"
    if sessions.exists() and args.overwrite:
        for old in sessions.glob("*.h5"):
            old.unlink()
    record_campaign(sessions, spec, DEMO_GRID, hits=hits, seed=args.seed, on_session=lambda path, conditions: print(
        f"  recorded {path.name}: {hits} hit{'s' if hits != 1 else ''} at " + ", ".join(f"{k} = {v:g}" for k, v in conditions.items()),
        flush=True))
    result = run_campaign([sessions], by, out, CampaignOptions(), workers=args.workers, progress=_Progress())
    analysed = [row for row in result.run.rows if not row.get("error")]
    model = spec.film.name
    print(f"identified {model} film against the rig's law (± 1 σ of the fit, which holds the noise only):")
    for row in sorted(analysed, key=lambda r: tuple(r.get(f"condition.{key}", 0) for key in by)):
        for parameter in spec.film.parameters:
            if parameter.name not in spec.film_laws:
                continue
            column = f"{model}.{parameter.name} [{parameter.unit}]"
            value, sigma = row.get(column), row.get(f"{model}.{parameter.name} sigma [{parameter.unit}]")
            law = row.get(f"spec.{parameter.name} [{parameter.unit}]")
            where = ", ".join(f"{key} = {row.get(f'condition.{key}'):g}" for key in by)
            if value is None or law is None:
                continue
            spread = f"± {sigma:.3g} ({abs(value - law) / sigma:.1f} σ)" if sigma else "(at a bound, no σ)"
            print(f"  {where}: {parameter.name} = {value:.6g} {spread} {parameter.unit}; law {law:.6g}, "
                  f"{100 * (value - law) / law:+.4f} %")
    print(f"  table:  {result.parquet_path}, {result.csv_path}")
    print(f"  report: {result.report_path}  ({time.monotonic() - started:.1f} s, {result.run.failed} failed)")
    return 0 if not result.run.failed else 1


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from gasfilm.analysis.acquisition import AcquisitionLoop
    from gasfilm.analysis.identification import default_fit_band_hz  # the one default fit band
    from gasfilm.app.commands.replay import ONE_AVERAGE_NOTE
    from gasfilm.analysis.capture import ImpactCapture, TriggerSettings
    from gasfilm.analysis.fit_settings import FitHits, FitSettings
    from gasfilm.analysis.identification import fit_model
    from gasfilm.analysis.physics.elements import PAPER_MODELS
    from gasfilm.analysis.physics.plant import RigPlant
    from gasfilm.analysis.physics.spec import RigSpec
    from gasfilm.analysis.recording import HitRecorder
    from gasfilm.analysis.session import Session
    from gasfilm.analysis.spectra import WindowSettings, session_frf
    from gasfilm.analysis.validation import ValidationSettings
    from gasfilm.drivers import open_device
    from gasfilm.drivers.errors import GasfilmError
    from gasfilm.drivers.interface import ChannelKind, default_hammer_and_accelerometer
    from gasfilm.drivers.units import STANDARD_GRAVITY_M_S2 as G_M_S2

    if args.campaign:
        return run_campaign_demo(args)
    if args.hits is None:
        args.hits = DEFAULT_HITS
    if not 1 <= args.hits <= MAX_DEMO_HITS:
        raise SettingError(f"--hits: {args.hits} must be 1 to {MAX_DEMO_HITS} (the demo runs in real time, about "
                           f"0.85 s per hit; `gasfilm acquire --pacing fast` records more)")
    if args.out is None:
        args.out = _free_default_path()
    check_session_path(args.out, "--out")
    check_output_file(args.out, "--out", args.overwrite, make_parent=True)
    spec = RigSpec.load(args.rig) if args.rig else RigSpec.nominal("FOMGF")
    config = default_hammer_and_accelerometer(51200.0 / 4)
    trigger = TriggerSettings(level_n=20.0, pretrigger_s=0.01, record_s=0.5)
    validation = ValidationSettings()
    window = WindowSettings()
    device = open_device("sim", plant=RigPlant(spec), seed=args.seed, pacing="realtime", hit_interval_s=(0.7, 1.0))
    device.configure(config)
    force_row = config.channel_index(ChannelKind.FORCE)
    response_row = config.channel_index(ChannelKind.ACCELERATION)
    full_scale = tuple(channel.full_scale_si for channel in config.channels)
    started = time.monotonic()
    with Session.create(
        args.out,
        config,
        spec.to_toml(),
        {"trigger": trigger, "validation": validation, "window": window},
        overwrite=args.overwrite,
        actual_sample_rate_hz=device.sample_rate_hz,
        device_name=device.name,
    ) as session:
        capture = ImpactCapture(trigger, device.sample_rate_hz, len(config.channels), force_row, response_row)
        recorder = HitRecorder(session, capture, validation, full_scale_si=full_scale)
        with device, AcquisitionLoop(device) as loop:
            chunks = loop.subscribe("demo")
            while recorder.accepted_count < args.hits:
                chunk = chunks.get(timeout_s=30.0)
                if chunk is None:
                    break
                for event in recorder.feed(chunk.data, chunk.status.overload):
                    print(hit_line(event), flush=True)  # as `gasfilm acquire` prints it
        if loop.error is not None:
            raise loop.error
        if chunks.dropped_chunks:
            raise GasfilmError(f"demo: the recorder fell behind and lost {chunks.dropped_chunks} chunk(s)")
        hits = session.hits()
        accepted = [hit for hit in hits if hit.verdict.accepted]
        frf = session_frf(accepted, window)
        frf_hits = FitHits(len(accepted), tuple(hit.index for hit in accepted))
        session.write_frf(frf, hit_indices=np.array(frf_hits.indices, dtype=np.int64))
        peak_forces = [float(np.max(np.abs(hit.data[hit.force_channel]))) for hit in hits]
        peak_responses = [float(np.max(np.abs(hit.data[hit.response_channel]))) for hit in hits]
        band = (frf.freq_hz >= 20) & (frf.freq_hz <= 1000)
        peak_hz = float(frf.freq_hz[band][np.argmax(np.abs(frf.h1[band]))])
        print(f"gasfilm demo — simulated NI 9234, rig '{spec.name}', {device.sample_rate_hz:.0f} S/s")
        print(f"  hits seen:         {len(hits)} ({len(accepted)} accepted, {len(hits) - len(accepted)} rejected)")
        print(f"  peak force:        {min(peak_forces):.0f} … {max(peak_forces):.0f} N")
        print(f"  peak response:     {min(peak_responses):.2f} … {max(peak_responses):.2f} m/s²")
        print(f"  resonance |H1|:    {peak_hz:.1f} Hz, {accelerance_text(np.max(np.abs(frf.h1[band])), args.units)}")
        if frf.n_averages < 2:
            print(f"  coherence:         {ONE_AVERAGE_NOTE}")
        else:
            print(f"  coherence 20–1000 Hz: mean {np.mean(frf.coherence[band]):.4f}, "
                  f"min {np.min(frf.coherence[band]):.4f}")
        if not args.no_fit:
            fit_low_hz, fit_high_hz = default_fit_band_hz(frf.sample_rate_hz)
            fit_band = (frf.freq_hz >= fit_low_hz) & (frf.freq_hz <= fit_high_hz)
            for name in ("SD", "FOMGF"):
                fit = fit_model(
                    PAPER_MODELS[name],
                    frf.freq_hz[fit_band],
                    frf.h1[fit_band],
                    spec.mass_kg,
                    decay_rate_1_s=frf.decay_rate_1_s,
                )
                session.write_fit(name, {**fit.to_dict(), **FitSettings.of_fit(fit, "frf").stored_keys(),
                                         **frf_hits.stored_keys()})
                rms = fit.rms / G_M_S2 if args.units == "g" else fit.rms
                print(f"  fit {name:6s} RMS {rms:.3e} {UNITS[args.units]}  ({fit.wall_time_s:.2f} s)")
        print(f"  session:           {args.out} ({time.monotonic() - started:.1f} s)")
    return 0
