"""Measurement-property controls for the diagnosis (issue 14 item 5): a nominal simulated session, exported as UFF 58
time records in five ways — untouched, already windowed (exponential and force windows), quantised to 8 bits of the
NI 9234's ±5 V range, with narrowband floor vibration on the response only, and triggered 3 ms late (the records
start after the pulse has begun) — then ``gasfilm diagnose FILE.uff --mass M`` on each. Every one is rig-physics-free:
the verdict must be ``consistent`` or ``parameters-only`` with the property named under ``quality``.

    python benchmarks/measurement_controls.py [--hits 8] [--out DIR] [--only NAME ...]

Prints one table row per control (verdict, findings, quality kinds, noise source, χ²/point, time).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Callable

import numpy as np

from gasfilm.analysis.diagnosis.recordings import load_recordings
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.spectra import WindowSettings, compute_frf, exponential_window, force_window
from gasfilm.analysis.uff import export_frf_uff
from gasfilm.app.cli import main as gasfilm

SD_RIG = Path(__file__).resolve().parents[1] / "fixtures" / "rigs" / "sd.toml"
#: The NI 9234's input range (V, ±).
FULL_SCALE_V = 5.0


def exported_windowed(records: np.ndarray, rate_hz: float, spec: RigSpec) -> np.ndarray:
    """Records as a recorder exports them after its own windows: a force window (2 ms after the peak, 0.5 ms taper)
    on the force, a 1 %-at-the-end exponential window on both channels."""
    window = WindowSettings(force_window_ms=2.0, force_taper_ms=0.5, exponential_end_fraction=0.01)
    exponential = exponential_window(records.shape[-1], 0.01)
    out = records * exponential
    out[:, 0] *= force_window(records[:, 0], rate_hz, window)
    return out


def quantised_8_bit(records: np.ndarray, rate_hz: float, spec: RigSpec) -> np.ndarray:
    """Records stored with 8 bits over ±5 V at the sensors' sensitivities (the force step ≈ 3.5 N, the response's
    ≈ 3.8 m/s²)."""
    volts_per_si = np.array([spec.force_sensor.sensitivity_v_per_si, spec.acceleration_sensor.sensitivity_v_per_si])
    step_si = 2 * FULL_SCALE_V / 2**8 / volts_per_si
    return np.round(records / step_si[np.newaxis, :, np.newaxis]) * step_si[np.newaxis, :, np.newaxis]


def floor_vibration(records: np.ndarray, rate_hz: float, spec: RigSpec) -> np.ndarray:
    """Narrowband floor vibration at 30 Hz and 87 Hz on the response only (0.05 and 0.03 m/s², random phase per hit,
    slowly modulated): uncorrelated with the hammer."""
    rng = np.random.default_rng(7)
    time_s = np.arange(records.shape[-1]) / rate_hz
    out = records.copy()
    for hit in out:
        for freq_hz, amplitude in ((30.0, 0.05), (87.0, 0.03)):
            hit[1] += amplitude * np.sin(2 * np.pi * freq_hz * time_s + rng.uniform(0, 2 * np.pi)) * (
                1 + 0.3 * np.sin(2 * np.pi * rng.uniform(0.3, 1.0) * time_s))
    return out


def late_trigger(records: np.ndarray, rate_hz: float, spec: RigSpec) -> np.ndarray:
    """The trigger fired late: each record starts halfway up its force pulse's rise (the first part of the pulse, and
    of the response, are not recorded; the pre-trigger misses the pulse start)."""
    firsts = []
    for record in records:
        magnitude = np.abs(record[0])
        peak = int(np.argmax(magnitude))
        start = int(np.flatnonzero(magnitude > 0.02 * magnitude[peak])[0])
        firsts.append(start + (peak - start) // 2)
    length = records.shape[-1] - max(firsts)
    return np.stack([record[:, first : first + length] for record, first in zip(records, firsts)])


#: A recorder without pre-trigger that triggers on the force starts each record at its first force sample at or above
#: this fraction of the hit's peak (:func:`triggered_late`).
LATE_FRACTION = 0.1


def triggered_late(records: np.ndarray, fraction: float = LATE_FRACTION) -> np.ndarray:
    """Records (hits, 2, samples) cut to start at their first force sample ≥ ``fraction`` of their peak force, all
    to the shortest length: a recorder without pre-trigger that triggers on the force (the pulse's front is lost)."""
    firsts = [int(np.flatnonzero(np.abs(r[0]) >= fraction * np.abs(r[0]).max())[0]) for r in records]
    length = records.shape[-1] - max(firsts)
    return np.stack([record[:, first : first + length] for record, first in zip(records, firsts)])


CONTROLS: dict[str, Callable[[np.ndarray, float, RigSpec], np.ndarray] | None] = {
    "untouched": None,
    "exported-windowed": exported_windowed,
    "quantised-8-bit": quantised_8_bit,
    "floor-vibration": floor_vibration,
    "late-trigger": late_trigger,
}
#: The quality kind (or noise source) each control must be recognised by.
EXPECTED_NOTE = {"untouched": None, "exported-windowed": "exponential window", "quantised-8-bit": "quantisation",
                 "floor-vibration": "floor vibration", "late-trigger": "late trigger"}


def write_control(session: Path, name: str, out: Path) -> Path:
    """The session's accepted hits changed by control ``name``, written as UFF 58 time records to ``out``."""
    recordings = load_recordings(session)
    spec = RigSpec.from_toml(recordings.rig_spec_toml, str(session))
    change = CONTROLS[name]
    records = recordings.records if change is None else change(recordings.records, recordings.sample_rate_hz, spec)
    rate_hz = recordings.sample_rate_hz
    hits = [SimpleNamespace(data=record, force_channel=0, response_channel=1, sample_rate_hz=rate_hz,
                            start_time_s=float(start_s)) for record, start_s in zip(records, recordings.hit_times_s)]
    frf = compute_frf(records, rate_hz, WindowSettings(force_window_ms=None, exponential_end_fraction=None))
    return export_frf_uff(frf, out / f"{session.stem}-{name}.uff", hits=hits, description=f"control {name}")


def record_session(path: Path, hits: int, seed: int, rig: Path) -> Path:
    """``gasfilm acquire --device sim --rig RIG`` with the defaults otherwise; an existing session is reused."""
    if path.exists():
        return path
    with contextlib.redirect_stdout(io.StringIO()):
        assert gasfilm(["acquire", "--device", "sim", "--out", str(path), "--hits", str(hits), "--pacing", "fast",
                        "--seed", str(seed), "--rig", str(rig)]) == 0
    return path


def diagnose_control(path: Path, start: list[str], out: Path) -> dict:
    """``gasfilm diagnose FILE START --json`` (START: ``--mass M`` or ``--rig SPEC``) and its result."""
    buffer, errors = io.StringIO(), io.StringIO()
    started = time.monotonic()
    with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(errors):
        code = gasfilm(["diagnose", str(path), *start, "--json", "--out", str(out / path.stem), "--overwrite"])
    text = buffer.getvalue()
    result = json.loads(text[text.index("{"):]) if code == 0 else {"verdict": f"exit {code}",
                                                                     "error": errors.getvalue().strip()[-300:]}
    result["time_s"] = time.monotonic() - started
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hits", type=int, default=8)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--rig", type=Path, default=SD_RIG,
                        help="rig the simulator plays (default: the paper's SD film, the class a start read off the "
                             "FRF has)")
    parser.add_argument("--with-rig", action="store_true",
                        help="diagnose against the rig spec the session was recorded with (--rig) instead of --mass")
    parser.add_argument("--out", type=Path, default=None, help="folder for the UFF files and the diagnoses")
    parser.add_argument("--only", nargs="*", default=list(CONTROLS), choices=list(CONTROLS))
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="controls-"))
    out.mkdir(parents=True, exist_ok=True)
    session = record_session(out / f"nominal-{args.rig.stem}.h5", args.hits, args.seed, args.rig)
    recorded = RigSpec.from_toml(load_recordings(session).rig_spec_toml, str(session))
    start = ["--mass", f"{recorded.mass_kg:g}"]
    if args.with_rig:
        rig_path = out / f"{session.stem}-rig.toml"
        rig_path.write_text(recorded.to_toml())
        start = ["--rig", str(rig_path)]
    print(f"controls in {out} ({args.hits} hits of '{recorded.name}'; diagnose {' '.join(start)})")
    print("| control | verdict | findings | not explained | quality | noise | χ²/point after | time |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    failures = 0
    for name in args.only:
        path = write_control(session, name, out)
        result = diagnose_control(path, start, out)
        findings = ", ".join(f["effect"] for f in result.get("findings", [])) or "none"
        unexplained = ", ".join(f"{u['band_hz'][0]:.0f}–{u['band_hz'][1]:.0f} Hz"
                                for u in result.get("unexplained", [])) or "none"
        kinds = [q["kind"] for q in result.get("quality", [])]
        noise = result.get("noise", {}).get("source", "?")
        expected = EXPECTED_NOTE[name]
        ok = (result["verdict"] in ("consistent", "parameters-only")
              and (expected is None or expected in kinds or expected == noise))
        failures += not ok
        chi2 = result.get("chi2_per_point_after", float("nan"))
        print(f"| {name} | {result['verdict']} | {findings} | {unexplained} | {', '.join(kinds) or 'none'} | {noise} | "
              f"{chi2:.2f} | {result['time_s']:.1f} s |{'' if ok else ' ✗'}")
        if "error" in result:
            print("   ", (result["error"].splitlines() or ["(no message)"])[-1])
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
