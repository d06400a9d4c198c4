"""The diagnosis on the shared real recording (fixtures/real-data/pyfrf-5-hits) and on variants of it made in software
with concealed measurement effects — a 10 µs response delay (exact, as a phase e^{-jωτ}), cross-talk of the force into
the response, a 3 % response gain error and 50 Hz mains on both channels (random phase per hit) — and with changes
of its structure: modes moved 0.3 % and 1.5 %, a mode's damping doubled, a mode added (:func:`structure_variants`).

The untouched recording is diagnosed from a start read off its FRF; its written spec, read back from its TOML, is then
the reference every variant is diagnosed against, and the untouched recording is diagnosed against it once more (the
loop). Prints one row per case: verdict, what was named (findings with their values, the modes re-read), candidate
descriptions, unexplained bands, noise source, quality notes, χ²/point and time.

    python benchmarks/real_variants.py [--record-s 1.0 0.25]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import numpy as np

from gasfilm.analysis.diagnosis.recordings import Recordings, diagnose
from gasfilm.analysis.diagnosis.structure import STRUCTURE_CHANGED
from gasfilm.analysis.physics.effects import StructureMode
from gasfilm.analysis.quantities import unit_suffix
from gasfilm.analysis.physics.spec import RigSpec

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "real-data" / "pyfrf-5-hits"
RATE_HZ = 25_600.0
DELAY_S = 10e-6
LEAK_M_S2_PER_N = 0.05
GAIN = 1.03
MAINS_HZ = 50.0
#: The structure changes of the last rows (:func:`structure_variants`): a mode's frequency lowered by MODE_SHIFT,
#: another one's raised by MODE_MOVE, a mode's damping ratio times DAMPING_FACTOR, and a mode added with a modal
#: constant ADDED_SHARE of its stronger neighbour's.
MODE_SHIFT = 0.003
MODE_MOVE = 0.015
DAMPING_FACTOR = 2.0
ADDED_SHARE = 0.1


def variants(records: np.ndarray, record_s: float | None = None) -> dict[str, np.ndarray]:
    """The untouched records and the four variants (hits, force/response, samples), cut to ``record_s`` after they
    are made. The delay is ``e^{-jωτ}`` on the response spectrum of the record zero-padded to twice its length, so
    that the ringing at the record's end is not wrapped round into its start (a circular fractional delay spreads
    that jump over the whole record), and it is made before the cut."""
    n_samples = records.shape[-1]
    padded = 2 * n_samples
    freq_hz = np.fft.rfftfreq(padded, 1.0 / RATE_HZ)
    delayed = records.copy()
    delayed[:, 1] = np.fft.irfft(np.fft.rfft(records[:, 1], padded, axis=1) * np.exp(-2j * np.pi * freq_hz * DELAY_S),
                                 padded, axis=1)[:, :n_samples]
    leaking = records.copy()
    leaking[:, 1] += LEAK_M_S2_PER_N * records[:, 0]
    scaled = records.copy()
    scaled[:, 1] *= GAIN
    rng = np.random.default_rng(50)
    time_s = np.arange(n_samples) / RATE_HZ
    mains = records.copy()
    for hit in mains:
        phase = rng.uniform(0, 2 * np.pi)
        hit[0] += 0.05 * np.sin(2 * np.pi * MAINS_HZ * time_s + phase)
        hit[1] += 0.5 * np.sin(2 * np.pi * MAINS_HZ * time_s + phase + 0.3)
    cut = n_samples if record_s is None else int(round(record_s * RATE_HZ))
    return {name: data[:, :, :cut] for name, data in (
        ("untouched", records), ("delay 10 µs", delayed), ("cross-talk 0.05 (m/s²)/N", leaking),
        ("gain +3 %", scaled), ("mains 50 Hz", mains))}


@dataclasses.dataclass(frozen=True)
class StructureChange:
    """A change of the structure made exactly in software: ``kind`` "moved", "damping" or "added", the mode it is
    about (its frequency in the spec, Hz) and its new frequency (Hz) and damping ratio, the records made with it."""

    name: str
    kind: str
    mode_hz: float
    new_hz: float
    new_damping_ratio: float
    records: np.ndarray


def _modes(spec: RigSpec, band_hz: tuple[float, float]) -> list[int]:
    """Indices of the spec's structure modes inside ``band_hz``, by frequency."""
    found = [i for i, e in enumerate(spec.effects)
             if e.type_name == "structure-mode" and band_hz[0] <= e.freq_hz <= band_hz[1]]
    return sorted(found, key=lambda i: spec.effects[i].freq_hz)


def _peak(mode) -> float:
    """A mode's peak accelerance, |A + jB|/(2ζ) ((m/s²)/N)."""
    return float(np.hypot(mode.modal_constant_per_kg, mode.quadrature_per_kg) / (2 * mode.damping_ratio))


def _changed(records: np.ndarray, spec: RigSpec, changed: RigSpec) -> np.ndarray:
    """The records as if the rig were ``changed`` instead of ``spec``: the response gains the force convolved with
    the difference of the two specs' accelerances (linear, zero-padded, before any cut)."""
    from gasfilm.analysis.physics.response import rig_accelerance

    n_samples = records.shape[-1]
    padded = 2 * n_samples
    freq_hz = np.fft.rfftfreq(padded, 1.0 / RATE_HZ)
    difference = rig_accelerance(changed, freq_hz, 0.0, 0.0) - rig_accelerance(spec, freq_hz, 0.0, 0.0)
    result = records.copy()
    result[:, 1] += np.fft.irfft(np.fft.rfft(records[:, 0], padded, axis=1) * difference, padded,
                                 axis=1)[:, :n_samples]
    return result


def structure_variants(records: np.ndarray, spec: RigSpec, record_s: float) -> list[StructureChange]:
    """The records as if the structure had changed, each made exactly from the 1 s records (:func:`_changed`) and cut
    to ``record_s``; the modes are chosen by rule from ``spec`` (the written spec), among those in the 100 Hz–7 kHz
    band the hammer excites:

    - the strongest mode above 5 kHz :data:`MODE_SHIFT` lower (a change smaller than its neighbours' spacing);
    - the strongest mode below 1 kHz :data:`MODE_MOVE` higher;
    - the strongest mode's damping ratio × :data:`DAMPING_FACTOR`;
    - a mode added at the geometric mean of the widest gap between neighbouring modes, damping ratio the modes'
      median, modal constant :data:`ADDED_SHARE` of the stronger neighbour's.

    Changes of the structure, not of the chain: the diagnosis must re-describe the mode (parameters-only) or find
    the added one, never a chain term."""
    band = (100.0, 7000.0)
    indices = _modes(spec, band)
    modes = [spec.effects[i] for i in indices]
    cut = int(round(record_s * RATE_HZ))
    made = []

    def replaced(index: int, **values) -> RigSpec:
        return spec.with_values(effects=[dataclasses.replace(e, **values) if i == index else e
                                         for i, e in enumerate(spec.effects)])

    high = max((i for i in indices if spec.effects[i].freq_hz > 5000), key=lambda i: _peak(spec.effects[i]))
    low = max((i for i in indices if spec.effects[i].freq_hz < 1000), key=lambda i: _peak(spec.effects[i]))
    strongest = max(indices, key=lambda i: _peak(spec.effects[i]))
    for index, kind, factor, text in ((high, "moved", 1 - MODE_SHIFT, f"{100 * MODE_SHIFT:g} % lower"),
                                      (low, "moved", 1 + MODE_MOVE, f"{100 * MODE_MOVE:g} % higher")):
        mode = spec.effects[index]
        data = _changed(records, spec, replaced(index, freq_hz=mode.freq_hz * factor))
        made.append(StructureChange(f"structure changed: mode at {mode.freq_hz:.0f} Hz {text}", kind, mode.freq_hz,
                                    mode.freq_hz * factor, mode.damping_ratio, data[:, :, :cut]))
    mode = spec.effects[strongest]
    data = _changed(records, spec, replaced(strongest, damping_ratio=mode.damping_ratio * DAMPING_FACTOR))
    made.append(StructureChange(f"structure changed: damping of the mode at {mode.freq_hz:.0f} Hz × {DAMPING_FACTOR:g}",
                                "damping", mode.freq_hz, mode.freq_hz, mode.damping_ratio * DAMPING_FACTOR,
                                data[:, :, :cut]))
    gaps = [(modes[k + 1].freq_hz / modes[k].freq_hz, k) for k in range(len(modes) - 1)]
    _, k = max(gaps)
    below, above = modes[k], modes[k + 1]
    added_hz = float(np.sqrt(below.freq_hz * above.freq_hz))
    zeta = float(np.median([m.damping_ratio for m in modes]))
    constant = ADDED_SHARE * max(abs(below.modal_constant_per_kg), abs(above.modal_constant_per_kg))
    added = spec.with_values(effects=[*spec.effects, StructureMode(freq_hz=added_hz, damping_ratio=zeta,
                                                                   modal_constant_per_kg=constant)])
    data = _changed(records, spec, added)
    made.append(StructureChange(f"structure changed: a mode added at {added_hz:.0f} Hz (between {below.freq_hz:.0f} "
                                f"and {above.freq_hz:.0f} Hz)", "added", added_hz, added_hz, zeta, data[:, :, :cut]))
    return made


def row(name: str, diagnosis, seconds: float) -> str:
    unexplained = ", ".join(f"{u.band_hz[0]:.0f}–{u.band_hz[1]:.0f}" for u in diagnosis.unexplained) or "—"
    quality = ", ".join(sorted({note.kind for note in diagnosis.quality})) or "—"
    candidates = ", ".join(sorted({c.effect for c in diagnosis.candidates})) or "—"
    return (f"| {name} | {diagnosis.verdict} | {'; '.join(named(diagnosis)) or '—'} | {candidates} | {unexplained} | "
            f"{diagnosis.spectra.noise.source} | {quality} | {diagnosis.chi2_per_point_before:.3g} → "
            f"{diagnosis.chi2_per_point_after:.3g} | {seconds:.0f} s |")


def named(diagnosis) -> list[str]:
    """What a diagnosis says changed: its findings with their values, and the structure's modes it re-read."""
    said = [f"{f.effect} (" + ", ".join(f"{key} {value['value']:.4g}{unit_suffix(value['unit'])}"
                                        for key, value in f.parameters.items()) + ")" for f in diagnosis.findings]
    return said + [note.removeprefix(STRUCTURE_CHANGED) for note in diagnosis.notes
                   if note.startswith(STRUCTURE_CHANGED)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record-s", type=float, nargs="+", default=[1.0, 0.25],
                        help="cut the 1 s records to these lengths (s); one table each")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for record_s in args.record_s:
        table(record_s)


def table(record_s: float) -> None:
    """Print the table of one record length."""
    records = np.stack([np.load(FIXTURE / f"measurements_{i}.npy") for i in range(1, 6)])[:, 1:]
    print(f"\n{record_s:g} s records\n")
    print("| recording | verdict | named (findings with their values; modes re-read) | candidate descriptions (not "
          "findings) | not explained (Hz) | noise | quality | χ²/point before → after | time |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    written = None
    for name, data in variants(records, record_s).items():
        started = time.monotonic()
        diagnosis = diagnose(Recordings(data, RATE_HZ, np.arange(5.0), None, None, None, name), written)
        print(row(name + (" (start read off the FRF)" if written is None else ""), diagnosis,
                  time.monotonic() - started), flush=True)
        if written is None:
            written = RigSpec.from_toml(diagnosis.improved.to_toml(), "the written spec")
            started = time.monotonic()
            again = diagnose(Recordings(data, RATE_HZ, np.arange(5.0), None, None, None, name), written)
            print(row("untouched against its written spec (the loop)", again, time.monotonic() - started),
                  flush=True)
    for change in structure_variants(records, written, record_s):
        started = time.monotonic()
        diagnosis = diagnose(Recordings(change.records, RATE_HZ, np.arange(5.0), None, None, None, change.name),
                             written)
        print(row(change.name, diagnosis, time.monotonic() - started), flush=True)


if __name__ == "__main__":
    main()
