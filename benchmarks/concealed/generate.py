"""Generate the concealed-data benchmark: sessions recorded on the simulated NI 9234 with hidden physics.

Every session is recorded by :class:`gasfilm.drivers.simulated.SimulatedNI9234` playing a *true* rig spec, through the real
capture, validation and session code (:mod:`benchmarks.concealed.sessions`). The diagnosis is later given only the
*nominal* spec (a spring-damper film on 25.05 kg); what the true spec adds is hidden and written to
``manifest.json`` for the scorer alone. Effect sizes are chosen so that a single hit's own goodness of fit against the
nominal spec stays within its noise (the scorer measures and prints this) while the averaged statistics of 20 hits
show it. Kinds: one hidden effect, two at once, clean controls, parameter-only controls (the film's own k and c off by
a few %), artefact sessions (mains interference, double hits that validation must reject), a "subtle" tier with
the six headline effects three times smaller, and a "strict" tier with the six headline effects sized so that no
frequency of any single hit differs from the truth by more than 3σ, recorded with 40–80 hits (both tiers scored
apart from the acceptance set).

    python benchmarks/concealed/generate.py [--out out/concealed] [--kind strict] [--only NAME ...] [--seed-offset N]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from sessions import record_session, windowed_copy  # noqa: E402

from gasfilm.analysis.physics.effects import (  # noqa: E402
    AcCoupling, AddedMass, ChannelDelay, CubicStiffness, Drift, Effect, ExtraMode, Mains, PneumaticLag,
)
from gasfilm.analysis.physics.spec import RigSpec  # noqa: E402

K_N_PER_M = 3.78e7
C_NS_PER_M = 3.45e3
MASS_KG = 25.05
NOMINAL = RigSpec.nominal("SD", mass_kg=MASS_KG, parameters={"k": K_N_PER_M, "eta": C_NS_PER_M})
MEMORY_FILM = "k || dashpot(eta) || pot(eta_memory, alpha_memory)"


@dataclass
class Case:
    """One benchmark session: what is hidden in the true rig and what the diagnosis should report."""

    name: str
    kind: str  # "effect", "two effects", "subtle", "strict", "clean", "parameters-only", "artefact"
    expected: tuple[str, ...]
    effects: tuple[Effect, ...] = ()
    memory: tuple[float, float] | None = None  # (eta_memory, alpha_memory) of a spring-pot branch
    film_scale: tuple[float, float] = (1.0, 1.0)  # true k and c over the nominal ones
    device: dict = field(default_factory=dict)
    seed: int = 0
    prewindow_1_s: float = 0.0  # records exported already multiplied by exp(-σ t)
    hits: int = 20  # accepted hits to record

    def true_spec(self) -> RigSpec:
        parameters = {"k": K_N_PER_M * self.film_scale[0], "eta": C_NS_PER_M * self.film_scale[1]}
        if self.memory is None:
            spec = RigSpec.nominal("SD", mass_kg=MASS_KG, parameters=parameters)
        else:
            parameters.update({"eta_memory": self.memory[0], "alpha_memory": self.memory[1]})
            spec = RigSpec.nominal(MEMORY_FILM, mass_kg=MASS_KG, parameters=parameters)
        return spec.with_effects(*self.effects)


def _memory(fraction: float, alpha: float) -> tuple[float, float]:
    """A spring-pot whose stiffness magnitude at the 195 Hz resonance is ``fraction`` of the film's k."""
    omega = 2 * 3.141592653589793 * 195.5
    return fraction * K_N_PER_M / omega**alpha, alpha


CASES: tuple[Case, ...] = (
    # one hidden effect: the six headline ones, three sessions each
    Case("memory-a", "effect", ("film-memory",), memory=_memory(0.001, 0.5), seed=11),
    Case("memory-b", "effect", ("film-memory",), memory=_memory(0.0012, 0.3), seed=12),
    Case("memory-c", "effect", ("film-memory",), memory=_memory(0.001, 0.7), seed=13),
    Case("mode-a", "effect", ("extra-mode",), (ExtraMode(freq_hz=600.0, damping_ratio=0.02, mass_kg=0.008),), seed=21),
    Case("mode-b", "effect", ("extra-mode",), (ExtraMode(freq_hz=420.0, damping_ratio=0.03, mass_kg=0.008),), seed=22),
    Case("mode-c", "effect", ("extra-mode",), (ExtraMode(freq_hz=950.0, damping_ratio=0.015, mass_kg=0.009),),
         seed=23),
    Case("cubic-a", "effect", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=5.5e15),), seed=31),
    Case("cubic-b", "effect", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=6.0e15),), seed=32),
    Case("cubic-c", "effect", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=5.5e15),),
         device={"force_spread": 0.3}, seed=33),
    Case("delay-a", "effect", ("channel-delay",), (ChannelDelay(channel="acceleration", delay_s=0.6e-6),), seed=41),
    Case("delay-b", "effect", ("channel-delay",), (ChannelDelay(channel="acceleration", delay_s=0.8e-6),), seed=42),
    Case("delay-c", "effect", ("channel-delay",), (ChannelDelay(channel="force", delay_s=0.7e-6),), seed=43),
    Case("mass-a", "effect", ("added-mass",), (AddedMass(mass_kg=0.012),), seed=51),
    Case("mass-b", "effect", ("added-mass",), (AddedMass(mass_kg=0.015),), seed=52),
    Case("mass-c", "effect", ("added-mass",), (AddedMass(mass_kg=0.010),), seed=53),
    Case("drift-a", "effect", ("drift",), (Drift(fraction_per_hour=0.10),), seed=61),
    Case("drift-b", "effect", ("drift",), (Drift(fraction_per_hour=-0.12),), seed=62),
    Case("drift-c", "effect", ("drift",), (Drift(fraction_per_hour=0.15),), seed=63),
    # the rest of the catalog
    Case("accoupling-a", "effect", ("ac-coupling",), (AcCoupling(channel="acceleration", corner_hz=0.5),), seed=71),
    Case("accoupling-b", "effect", ("ac-coupling",), (AcCoupling(channel="acceleration", corner_hz=0.6),), seed=72),
    Case("lag-a", "effect", ("pneumatic-lag",), (PneumaticLag(k_lag=6.0e4, tau_lag=5.0e-4),), seed=81),
    Case("lag-b", "effect", ("pneumatic-lag",), (PneumaticLag(k_lag=5.0e4, tau_lag=8.0e-4),), seed=82),
    Case("window-a", "effect", ("window-damping",), prewindow_1_s=1.0, seed=83),
    Case("window-b", "effect", ("window-damping",), prewindow_1_s=0.6, seed=84),
    # two hidden effects at once
    Case("two-delay-mass", "two effects", ("channel-delay", "added-mass"),
         (ChannelDelay(channel="acceleration", delay_s=0.7e-6), AddedMass(mass_kg=0.012)), seed=91),
    Case("two-mode-drift", "two effects", ("extra-mode", "drift"),
         (ExtraMode(freq_hz=700.0, damping_ratio=0.02, mass_kg=0.012), Drift(fraction_per_hour=0.14)), seed=92),
    Case("two-memory-cubic", "two effects", ("film-memory", "cubic-stiffness"),
         (CubicStiffness(k3_n_per_m3=4.5e15),), memory=_memory(0.001, 0.5), seed=93),
    # subtle: the six headline effects three times smaller, at or below what one hit's own statistics can see
    Case("subtle-memory", "subtle", ("film-memory",), memory=_memory(0.0003, 0.5), seed=141),
    Case("subtle-mode", "subtle", ("extra-mode",), (ExtraMode(freq_hz=600.0, damping_ratio=0.02, mass_kg=0.003),),
         seed=142),
    Case("subtle-cubic", "subtle", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=2.0e15),),
         device={"force_spread": 0.3}, seed=143),
    Case("subtle-delay", "subtle", ("channel-delay",), (ChannelDelay(channel="acceleration", delay_s=0.25e-6),),
         seed=144),
    Case("subtle-mass", "subtle", ("added-mass",), (AddedMass(mass_kg=0.004),), seed=145),
    Case("subtle-drift", "subtle", ("drift",), (Drift(fraction_per_hour=0.035),), seed=146),
    # strict: sized so that no frequency of any single hit differs from the truth by more than 3σ (and no hit's χ²
    # excess reaches its 3σ fluctuation), with 80 accepted hits, and 40 for those still found so (drift: the rate is
    # doubled with half the hits, so that the last hit has drifted as far)
    Case("strict-memory", "strict", ("film-memory",), memory=_memory(1.05e-4, 0.5), hits=80, seed=151),
    Case("strict-memory-steep", "strict", ("film-memory",), memory=_memory(1.0e-4, 1.75), hits=80, seed=157),
    Case("strict-mode", "strict", ("extra-mode",), (ExtraMode(freq_hz=600.0, damping_ratio=0.02, mass_kg=0.002),),
         hits=80, seed=152),
    Case("strict-cubic", "strict", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=6.5e14),),
         device={"force_spread": 0.3}, hits=80, seed=153),
    Case("strict-delay", "strict", ("channel-delay",), (ChannelDelay(channel="acceleration", delay_s=0.18e-6),),
         hits=80, seed=154),
    Case("strict-mass", "strict", ("added-mass",), (AddedMass(mass_kg=0.0025),), hits=80, seed=155),
    Case("strict-drift", "strict", ("drift",), (Drift(fraction_per_hour=0.00225),), hits=80, seed=156),
    Case("strict-mode-40", "strict", ("extra-mode",), (ExtraMode(freq_hz=600.0, damping_ratio=0.02, mass_kg=0.002),),
         hits=40, seed=162),
    Case("strict-cubic-40", "strict", ("cubic-stiffness",), (CubicStiffness(k3_n_per_m3=6.5e14),),
         device={"force_spread": 0.3}, hits=40, seed=163),
    Case("strict-delay-40", "strict", ("channel-delay",), (ChannelDelay(channel="acceleration", delay_s=0.18e-6),),
         hits=40, seed=164),
    Case("strict-mass-40", "strict", ("added-mass",), (AddedMass(mass_kg=0.0025),), hits=40, seed=165),
    Case("strict-drift-40", "strict", ("drift",), (Drift(fraction_per_hour=0.0045),), hits=40, seed=166),
    # strict-tier controls: with 40 and 80 hits the diagnosis must still claim nothing in clean sessions, and only
    # recalibrate a film whose own k and c are off by as little as the strict effects' equivalent
    Case("strict-clean", "strict", (), hits=80, seed=167),
    Case("strict-clean-40", "strict", (), hits=40, seed=168),
    Case("strict-params", "strict", (), film_scale=(1.00008, 1.0005), hits=80, seed=169),
    # controls: nothing hidden, or only the film's own parameters off
    Case("clean-a", "clean", (), seed=101),
    Case("clean-b", "clean", (), seed=102),
    Case("clean-c", "clean", (), device={"tip": "hard"}, seed=103),
    Case("params-a", "parameters-only", (), film_scale=(1.03, 1.0), seed=111),
    Case("params-b", "parameters-only", (), film_scale=(0.97, 1.05), seed=112),
    Case("params-c", "parameters-only", (), film_scale=(1.02, 0.94), seed=113),
    # measurement artefacts: quality findings only, never physics
    Case("mains-a", "artefact", (), (Mains(channel="acceleration", amplitude=0.02, harmonics=(1.0, 0.4, 0.2)),),
         seed=121),
    Case("mains-b", "artefact", (), (Mains(channel="acceleration", amplitude=0.01, frequency_hz=60.0,
                                           harmonics=(1.0, 0.5)),), seed=122),
    Case("double-a", "artefact", (), device={"double_hit_rate": 0.3}, seed=131),
    Case("double-b", "artefact", (), device={"double_hit_rate": 0.5}, seed=132),
)


def generate(out_dir: Path, names: set[str] | None = None, seed_offset: int = 0) -> Path:
    """Record every case (or the named ones) into ``out_dir``, each with its seed plus ``seed_offset`` (another
    draw of the same cases); returns the manifest path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    NOMINAL.save(out_dir / "nominal-rig.toml")
    manifest = []
    for case in CASES:
        entry = {"name": case.name, "kind": case.kind, "expected": list(case.expected),
                 "session": f"{case.name}.h5", "true_spec": f"{case.name}-true.toml",
                 "prewindow_1_s": case.prewindow_1_s, "hits": case.hits}
        manifest.append(entry)
        if names and case.name not in names:
            continue
        started = time.monotonic()
        spec = case.true_spec()
        spec.save(out_dir / entry["true_spec"])
        record_session(spec, out_dir / entry["session"], case.hits, seed=case.seed + seed_offset, **case.device)
        if case.prewindow_1_s:
            plain = out_dir / f"{case.name}-plain.h5"
            (out_dir / entry["session"]).rename(plain)
            windowed_copy(plain, out_dir / entry["session"], case.prewindow_1_s)
            plain.unlink()
        print(f"  {case.name:18s} {case.kind:16s} {time.monotonic() - started:5.1f} s", file=sys.stderr)
    path = out_dir / "manifest.json"
    path.write_text(json.dumps({"nominal_spec": "nominal-rig.toml", "sessions": manifest}, indent=1))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/concealed"))
    parser.add_argument("--only", nargs="*", help="case names to (re)record")
    parser.add_argument("--kind", nargs="*", help="case kinds to (re)record (e.g. strict)")
    parser.add_argument("--seed-offset", type=int, default=0, help="added to every case's seed: another draw")
    args = parser.parse_args()
    names = set(args.only or ()) | {case.name for case in CASES if args.kind and case.kind in args.kind}
    print(generate(args.out, names or None, args.seed_offset))


if __name__ == "__main__":
    main()
