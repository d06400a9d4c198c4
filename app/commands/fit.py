"""``gasfilm fit SESSION``: identify gas-film models from a session's FRF, compare them like Table 2, draw Figures
18 and 19, and store the fits in the session.

The FRF is the session's stored one (``frf``), or computed from its accepted hits when none is stored yet. The mass
is ``--mass``, else the rig spec's mover mass stored in the session, else the paper's 25.05 kg.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

from gasfilm.analysis.identification import METHODS, compare_models, fit_model, format_table2
from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_MODEL_ORDER, get_model
from gasfilm.drivers.errors import SettingError

DEFAULT_BAND_HZ = (20.0, 1000.0)
MIN_BAND_LINES = 10


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit", help="fit the paper's gas-film models to a session's FRF (Table 2, Figures 18/19)"
    )
    parser.add_argument("session", type=Path, help="session file (.h5)")
    parser.add_argument(
        "--models", default="all", help=f"comma-separated model names or 'all' ({','.join(PAPER_MODEL_ORDER)})"
    )
    parser.add_argument("--method", choices=METHODS, default="default", help="fitter (default: the fast one)")
    parser.add_argument("--band", help="frequency band LO:HI in Hz (default 20:1000, capped at 0.45·fs)")
    parser.add_argument("--mass", type=float, help="mover mass in kg (default: the session's rig spec, else 25.05)")
    parser.add_argument("--fit-mass", action="store_true", help="identify the mass too, starting from --mass")
    parser.add_argument("--seed", type=int, default=0, help="seed of the fitters' random starts")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    parser.add_argument("--out", type=Path, help="folder for the figures (default: next to the session)")
    parser.set_defaults(func=run)


def parse_band(text: str | None, sample_rate_hz: float) -> tuple[float, float]:
    """``LO:HI`` in Hz; the default band is 20–1000 Hz below 0.45·fs (the module's alias-free band)."""
    if text is None:
        return DEFAULT_BAND_HZ[0], min(DEFAULT_BAND_HZ[1], 0.45 * sample_rate_hz)
    parts = text.split(":")
    try:
        low, high = (float(part) for part in parts)
    except ValueError:
        raise SettingError(f"--band '{text}': write LO:HI in Hz, e.g. 20:800") from None
    if not (np.isfinite(low) and np.isfinite(high) and 0 <= low < high):
        raise SettingError(f"--band '{text}': needs 0 ≤ LO < HI")
    return low, high


def parse_models(text: str) -> list:
    names = PAPER_MODEL_ORDER if text.strip().lower() == "all" else [n for n in text.split(",") if n.strip()]
    if not names:
        raise SettingError("--models: give at least one model name or 'all'")
    models = []
    for name in names:
        if any(operator in name for operator in ("||", "--", "(")):
            raise SettingError(f"--models '{name}': give model names, not network text")
        models.append(get_model(name))
    return models


def _session_frf(session):
    """The stored FRF, or one computed from the accepted hits with the session's window settings."""
    from gasfilm.analysis.spectra import WindowSettings, compute_frf
    from gasfilm.drivers.interface import ChannelKind

    if "frf" in session.result_names("frf"):
        return session.read_frf()
    records = session.accepted_records()
    if len(records) == 0:
        raise SettingError(f"{session.path}: no FRF stored and no accepted hits to compute one from")
    window_settings = session.settings.get("window")
    window = WindowSettings(**window_settings) if isinstance(window_settings, dict) else WindowSettings()
    config = session.daq_config
    return compute_frf(
        records,
        session.sample_rate_hz,
        window,
        force_row=config.channel_index(ChannelKind.FORCE),
        response_row=config.channel_index(ChannelKind.ACCELERATION),
    )


def _session_mass_kg(session) -> float:
    from gasfilm.analysis.physics.spec import RigSpec

    toml = session.rig_spec_toml
    return RigSpec.from_toml(toml, f"{session.path} rig spec").mass_kg if toml else PAPER_MASS_KG


def _progress_printer(name: str, index: int, count: int):
    def show(fraction: float) -> None:
        bar = "#" * int(20 * fraction)
        print(f"\r  [{index}/{count}] {name:<8} [{bar:<20}] {100 * fraction:3.0f}%", end="", file=sys.stderr)

    return show


def run(args: argparse.Namespace) -> int:
    from gasfilm.analysis.figures import figure18, figure19
    from gasfilm.analysis.session import Session

    models = parse_models(args.models)
    if args.mass is not None and not args.mass > 0:
        raise SettingError(f"--mass {args.mass}: must be a positive mass in kg")
    with Session.open(args.session, "a") as session:
        frf = _session_frf(session)
        low, high = parse_band(args.band, frf.sample_rate_hz)
        keep = (frf.freq_hz >= max(low, 1e-9)) & (frf.freq_hz <= high)
        if np.count_nonzero(keep) < MIN_BAND_LINES:
            raise SettingError(
                f"--band {low:g}:{high:g}: only {np.count_nonzero(keep)} FRF lines in it (the FRF spans "
                f"{frf.freq_hz[0]:g}–{frf.freq_hz[-1]:g} Hz every {frf.freq_hz[1] - frf.freq_hz[0]:g} Hz)"
            )
        freq_hz, h = frf.freq_hz[keep], frf.h1[keep]
        mass_kg = args.mass if args.mass is not None else _session_mass_kg(session)
        fits = []
        for index, model in enumerate(models, start=1):
            fit = fit_model(
                model,
                freq_hz,
                h,
                mass_kg,
                method=args.method,
                decay_rate_1_s=frf.decay_rate_1_s,
                fit_mass=args.fit_mass,
                seed=args.seed,
                progress=_progress_printer(model.name, index, len(models)),
            )
            print(f"  RMS {fit.rms:.4e} (m/s²)/N in {fit.wall_time_s:.2f} s", file=sys.stderr)
            session.write_fit(model.name, fit.to_dict())
            fits.append(fit)
    rows = compare_models(fits, freq_hz, h)
    out = args.out if args.out is not None else args.session.parent
    stem = args.session.stem
    figures = [
        figure18(out / f"{stem}-figure18.png", freq_hz, h, fits),
        figure19(out / f"{stem}-figure19.png", freq_hz, h, fits),
    ]
    if args.json:
        print(
            json.dumps(
                {
                    "session": str(args.session),
                    "band_hz": [float(freq_hz[0]), float(freq_hz[-1])],
                    "mass_kg": mass_kg,
                    "method": args.method,
                    "decay_rate_1_s": frf.decay_rate_1_s,
                    "fits": [fit.to_dict() for fit in fits],
                    "table": [asdict(row) for row in rows],
                    "figures": [str(path) for path in figures],
                }
            )
        )
        return 0
    print(f"{args.session}: {len(freq_hz)} lines, {freq_hz[0]:g}–{freq_hz[-1]:g} Hz, m = {mass_kg:g} kg, "
          f"method {args.method}")
    print("\nTable 2 (g/N)\n" + format_table2(rows, "g/N"))
    print("\nTable 2 (SI)\n" + format_table2(rows, "SI"))
    for fit in fits:
        if fit.flags:
            print(f"{fit.model_name}: " + "; ".join(fit.flags))
    print("\nfigures: " + ", ".join(str(path) for path in figures))
    return 0
