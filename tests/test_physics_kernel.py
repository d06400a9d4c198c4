"""One physics kernel: every effect defined once, round-tripped through TOML exactly, and the diagnosis closing its own
loop — the spec it writes is the spec it fitted, replayed."""

from __future__ import annotations

import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from gasfilm.analysis.diagnosis import load_recordings
from gasfilm.analysis.diagnosis.measurement import hit_spectra
from gasfilm.analysis.diagnosis.pipeline import replay_rms
from gasfilm.analysis.physics.effects import (
    EFFECT_TYPES,
    AcCoupling,
    AddedMass,
    ChannelDelay,
    ChannelPoleZero,
    ChannelPowerLaw,
    ChannelResonance,
    CrossTalk,
    CubicStiffness,
    Drift,
    Effect,
    FitContext,
    ExtraMode,
    FilmBranch,
    FilmMemory,
    Friction,
    Mains,
    PneumaticLag,
    QuadraticDamping,
    SensitivityError,
    SideMode,
    SqueezeFilm,
    StepChange,
    StructureMode,
    SupportMode,
    Polarity,
    TermDrift,
    TermLevel,
    TermOnset,
)
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.response import (
    NONLINEAR_TOLERANCE,
    GridPieces,
    HitConditions,
    accelerance_parts,
    rig_accelerance,
    simulate_response,
)
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.app.cli import main as gasfilm
from gasfilm.drivers.errors import SettingError
from test_diagnose import NOMINAL, record

#: One instance of every registered effect type, at values a real rig could have.
EXAMPLES: dict[str, Effect] = {
    "extra-mode": ExtraMode(freq_hz=610.0, damping_ratio=0.02, mass_kg=0.25),
    "cubic-stiffness": CubicStiffness(k3_n_per_m3=3e16),
    "channel-delay": ChannelDelay(channel="acceleration", delay_s=2.5e-5),
    "added-mass": AddedMass(mass_kg=0.7),
    "drift": Drift(fraction_per_hour=40.0, damping_fraction_per_hour=-10.0),
    "step-change": StepChange(at_time_s=3.5, fraction=0.03, damping_fraction=0.1),
    "mains": Mains(channel="acceleration", amplitude=0.01, harmonics=(1.0, 0.3)),
    "pneumatic-lag": PneumaticLag(k_lag=2e6, tau_lag=3e-4),
    "film-memory": FilmMemory(k_memory=5e6, eta_memory=2e3, alpha_memory=0.6),
    "ac-coupling": AcCoupling(channel="acceleration", corner_hz=3.0),
    "sensitivity-error": SensitivityError(channel="acceleration", fraction=0.04),
    "cross-talk": CrossTalk(leak_m_s2_per_n=4e-4),
    "squeeze-film": SqueezeFilm(gap_m=3e-5, length_m=0.05),
    "friction": Friction(friction_force_n=3.0),
    "quadratic-damping": QuadraticDamping(coefficient_n_s2_per_m2=1.5e5),
    "structure-mode": StructureMode(freq_hz=1400.0, damping_ratio=0.004, modal_constant_per_kg=-0.02,
                                    quadrature_per_kg=0.005),
    "polarity": Polarity(channel="acceleration"),
    "side-mode": SideMode(freq_hz=430.0, damping_ratio=0.015, modal_constant_per_kg=-0.004),
    "film-branch": FilmBranch(stiffness_n_per_m=2e6, order=0.4, reference_hz=200.0),
    "channel-resonance": ChannelResonance(channel="acceleration", freq_hz=1800.0, damping_ratio=0.05),
    "channel-pole-zero": ChannelPoleZero(pole_hz=900.0, zero_hz=5000.0, gain=0.95, reference_hz=200.0),
    "channel-power-law": ChannelPowerLaw(exponent=-0.012, reference_hz=100.0),
    "support-mode": SupportMode(freq_hz=430.0, damping_ratio=0.02, mass_kg=30.0),
}
#: Changes between hits act on another term: each example changes the first effect of a spec whose first effect is
#: :data:`CHANGED` (checked on their own, :func:`test_a_term_that_changes_between_hits_is_played_hit_by_hit`).
CHANGED = ExtraMode(freq_hz=610.0, damping_ratio=0.02, mass_kg=0.25)
CHANGES: dict[str, Effect] = {
    "term-drift": TermDrift(term=0, parameter="freq_hz", fraction_per_hour=-20.0),
    "term-level": TermLevel(term=0, parameter="damping_ratio", exponent=0.8, reference_impulse_ns=0.15),
    "term-onset": TermOnset(term=0, parameter="mass_kg", at_time_s=5.0),
}
CONDITIONS = HitConditions(time_s=np.array([0.0, 3.0, 7.0, 12.0]), impulse_ns=np.array([0.12, 0.15, 0.16, 0.2]))
FREQ_HZ = np.linspace(5.0, 2000.0, 257)


def test_every_registered_effect_has_an_example():
    assert set(EXAMPLES) | set(CHANGES) == set(EFFECT_TYPES)
    for effect in [*EXAMPLES.values(), *CHANGES.values()]:
        assert type(effect).explanation or effect.kind == "interference", type(effect).type_name


@pytest.mark.parametrize("names", [(name,) for name in EXAMPLES] + list(itertools.combinations(EXAMPLES, 2)),
                         ids=lambda names: "+".join(names))
def test_spec_toml_spec_frf_is_exact(names):
    """spec → TOML → spec → FRF equals the original to 1e-12, per hit (time, level) and at σ > 0."""
    spec = RigSpec.nominal("FOMGF").with_effects(*(EXAMPLES[name] for name in names))
    again = RigSpec.from_toml(spec.to_toml())
    assert again == spec
    for decay_rate_1_s in (0.0, 3.0):
        expected = rig_accelerance(spec, FREQ_HZ, decay_rate_1_s, conditions=CONDITIONS)
        actual = rig_accelerance(again, FREQ_HZ, decay_rate_1_s, conditions=CONDITIONS)
        np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("name", CHANGES)
def test_a_term_that_changes_between_hits_is_played_hit_by_hit(name):
    """spec → TOML → spec exactly; each hit's accelerance is that of the spec at the hit (the changed term's value
    moved, the change left out), and the simulator's plant plays the same (1e-9)."""
    spec = RigSpec.nominal("FOMGF").with_effects(CHANGED, EXAMPLES["channel-delay"], CHANGES[name])
    assert RigSpec.from_toml(spec.to_toml()) == spec
    per_hit = rig_accelerance(spec, FREQ_HZ, 0.0, conditions=CONDITIONS)
    for row, time_s, impulse_ns in zip(per_hit, CONDITIONS.time_s, CONDITIONS.impulse_ns):
        factor = CHANGES[name].factor(time_s, impulse_ns)
        moved = dataclasses.replace(CHANGED, **{CHANGES[name].parameter: getattr(CHANGED, CHANGES[name].parameter)
                                                * factor})
        expected = rig_accelerance(RigSpec.nominal("FOMGF").with_effects(moved, EXAMPLES["channel-delay"]), FREQ_HZ,
                                   0.0, time_s=time_s)
        np.testing.assert_allclose(row, expected, rtol=1e-12, atol=0)
    assert len({round(float(abs(row[100])), 12) for row in per_hit}) > 1  # the hits differ
    plant = RigPlant(spec)
    freq_hz = np.fft.rfftfreq(4096, 1.0 / RATE_HZ)[1:]
    s = 2j * np.pi * freq_hz
    force_spectrum = np.full(s.shape, 0.15 + 0j)
    for time_s in (0.0, 9.0):
        sensed = plant.acceleration_spectrum(force_spectrum, s, RATE_HZ, time_s) * plant.channel_transfer(
            "acceleration", s)
        hit = HitConditions(time_s=np.array([time_s]), impulse_ns=np.array([0.15]))
        np.testing.assert_allclose(sensed / (force_spectrum * plant.channel_transfer("force", s)),
                                   rig_accelerance(spec, freq_hz, conditions=hit)[0], rtol=1e-9, atol=0)


def test_a_change_between_hits_must_act_on_a_number_of_another_term():
    with pytest.raises(SettingError, match="'term'"):
        RigSpec.nominal("FOMGF").with_effects(CHANGES["term-drift"])
    with pytest.raises(SettingError, match="'parameter'"):
        RigSpec.nominal("FOMGF").with_effects(CHANGED, dataclasses.replace(CHANGES["term-drift"], parameter="gap"))


def test_drift_and_pneumatic_lag_combine_as_one_rig():
    """The combination that once differed by 19.5 % between two copies of the physics: the film drifts, the lag
    (an effect beside the film) does not."""
    lag = PneumaticLag(k_lag=2e6, tau_lag=3e-4)
    spec = RigSpec.nominal("FOMGF").with_effects(Drift(fraction_per_hour=0.5), lag)
    s = 2j * np.pi * FREQ_HZ
    film = spec.film.stiffness(s, spec.film_parameters) * (1 + 0.5 * 1800.0 / 3600.0)
    expected = s**2 / (film + lag.k_lag / (1 + s * lag.tau_lag) + spec.mass_kg * s**2)
    np.testing.assert_allclose(rig_accelerance(spec, FREQ_HZ, time_s=1800.0), expected, rtol=1e-12)


def test_a_first_order_factor_of_the_chain_reads_its_gain_at_its_reference_and_stays_finite_at_its_limits():
    """``gain·P(s)/|P(j2π f_ref)|``: its magnitude at the reference is the gain; with its zero far below the band it
    is the high-pass ``g·s/(s + ω_p)`` (a charge sensor on a voltage input), which no unity-at-DC form can hold; a
    pole-zero written without gain and reference (reference 0: DC) is ``(1 + s/ω_z)/(1 + s/ω_p)`` as before."""
    s = 2j * np.pi * FREQ_HZ
    factor = ChannelPoleZero(pole_hz=373.0, zero_hz=1e-3, gain=0.5, reference_hz=200.0)
    assert abs(factor.channel_transfer("acceleration", np.array([2j * np.pi * 200.0]))[0]) == pytest.approx(0.5)
    high_pass = factor.gain_above_corners() * s / (s + 2 * np.pi * 373.0)
    np.testing.assert_allclose(factor.channel_transfer("acceleration", s), high_pass, rtol=1e-3)
    assert factor.gain_above_corners() == pytest.approx(0.5 * abs(1 + 373.0 / (200.0j)), rel=1e-5)
    assert factor.channel_transfer("force", s) == 1.0
    unity_at_dc = ChannelPoleZero(pole_hz=900.0, zero_hz=5000.0)
    np.testing.assert_allclose(unity_at_dc.channel_transfer("acceleration", s),
                               (1 + s / (2 * np.pi * 5000.0)) / (1 + s / (2 * np.pi * 900.0)), rtol=1e-14)
    assert RigSpec.from_toml(RigSpec.nominal("SD").with_effects(unity_at_dc).to_toml()).effects == (unity_at_dc,)


def test_a_support_mode_puts_the_film_in_series_with_the_supports_mass_spring_damper():
    """A mode of what the bearing stands on: the mover sees ``Z_f Z_b/(Z_f + Z_b)`` (a two-body chain written out
    here on its own), and the resonances the finding reports are that chain's poles: the film's, lowered, and a
    second one above the support's own frequency."""
    spec = RigSpec.nominal("SD").with_values(film_parameters={"k": 3.8e7, "eta": 3500.0})
    support = SupportMode(freq_hz=430.0, damping_ratio=0.02, mass_kg=30.0)
    s = 2j * np.pi * FREQ_HZ
    film = 3.8e7 + 3500.0 * s
    beam = 30.0 * (s**2 + 2 * 0.02 * 2 * np.pi * 430.0 * s + (2 * np.pi * 430.0) ** 2)
    chain = s**2 / (spec.mass_kg * s**2 + film * beam / (film + beam))
    np.testing.assert_allclose(rig_accelerance(spec.with_effects(support), FREQ_HZ), chain, rtol=1e-12)
    mass = spec.mass_kg
    poles = np.roots(np.polyadd(np.polymul([mass, 0, 0], [30.0, 3500.0 + 30.0 * 0.04 * 2 * np.pi * 430.0,
                                                           3.8e7 + 30.0 * (2 * np.pi * 430.0) ** 2]),
                                np.polymul([3500.0, 3.8e7], [30.0, 30.0 * 0.04 * 2 * np.pi * 430.0,
                                                             30.0 * (2 * np.pi * 430.0) ** 2])))
    expected = sorted(abs(pole) / (2 * np.pi) for pole in poles if pole.imag > 0)
    features = support.features_on(spec.with_effects(support))
    assert [features["film_resonance_hz"], features["added_resonance_hz"]] == pytest.approx(expected, rel=1e-9)
    assert features["film_resonance_hz"] < np.sqrt(3.8e7 / mass) / (2 * np.pi) < 430.0 < features["added_resonance_hz"]


def test_a_support_mode_must_show_both_resonances_in_the_band_the_added_one_of_its_own():
    """A support re-describes the film when the data cannot see it: a film run rigid on it (the film's resonance far
    above the band), or the film's damping moved onto it (the resonance it adds too damped to be one of its own); an
    over-damped pair is still a resonance (damping ratio ≥ 1), never a crash."""
    film = RigSpec.nominal("SD").with_values(film_parameters={"k": 3.8e7, "eta": 3500.0})
    context = FitContext(mass_kg=25.05, film_stiffness_n_per_m=3.8e7, resonance_hz=196.0, band_hz=(10.0, 1300.0),
                         session_span_s=60.0, max_displacement_m=1e-5)
    seen = SupportMode(freq_hz=430.0, damping_ratio=0.02, mass_kg=30.0)
    assert seen.implausible_in(film.with_effects(seen), context) is None
    rigid = film.with_values(film_parameters={"k": 6.9e11, "eta": 3.9e6})
    hidden = SupportMode(freq_hz=392.0, damping_ratio=0.11, mass_kg=8.3)
    assert "outside the analysis band" in hidden.implausible_in(rigid.with_effects(hidden), context)
    smeared = SupportMode(freq_hz=588.0, damping_ratio=0.36, mass_kg=6.7)
    assert "too damped" in smeared.implausible_in(film.with_effects(smeared), context)
    overdamped = SupportMode(freq_hz=100.0, damping_ratio=0.5, mass_kg=3.0)
    resonances = overdamped.system_resonances(film.with_values(film_parameters={"k": 3.8e7, "eta": 3e5})
                                              .with_effects(overdamped))
    assert len(resonances) == 2 and max(zeta for _, zeta in resonances) >= 1.0


RATE_HZ = 12800.0
LINEAR = [name for name, effect in EXAMPLES.items() if effect.kind != "interference" and name != "cubic-stiffness"]


@pytest.mark.parametrize("names", [(name,) for name in LINEAR] + list(itertools.combinations(LINEAR, 2)),
                         ids=lambda names: "+".join(names))
def test_the_simulator_plays_what_the_diagnosis_predicts(names):
    """The simulated device's plant, given a force spectrum, senses exactly the diagnosis's accelerance of the same
    spec, at any session time (1e-9 relative)."""
    spec = RigSpec.nominal("FOMGF").with_effects(*(EXAMPLES[name] for name in names))
    plant = RigPlant(spec)
    n_samples = 4096
    freq_hz = np.fft.rfftfreq(n_samples, 1.0 / RATE_HZ)[1:]
    s = 2j * np.pi * freq_hz
    force_spectrum = np.exp(-s * 1e-3) * (1.0 + 0.3j * np.sin(freq_hz / 50.0))
    for time_s in (0.0, 9.0):
        sensed = plant.acceleration_spectrum(force_spectrum, s, RATE_HZ, time_s) * plant.channel_transfer(
            "acceleration", s)
        recorded_force = force_spectrum * plant.channel_transfer("force", s)
        hit = HitConditions(time_s=np.array([time_s]), impulse_ns=np.array([force_spectrum[0].real]))
        np.testing.assert_allclose(sensed / recorded_force, rig_accelerance(spec, freq_hz, conditions=hit)[0],
                                   rtol=1e-9, atol=0)


def test_the_nonlinear_simulator_and_replay_agree_within_the_solver_tolerance():
    """A hardening film: the plant's periodic solve and the diagnosis's replay of a recorded force agree within the
    nonlinear solver's stated tolerance (:data:`NONLINEAR_TOLERANCE` of the peak in the pass band)."""
    spec = NOMINAL.with_effects(EXAMPLES["cubic-stiffness"], EXAMPLES["channel-delay"])
    n_samples = int(RATE_HZ)  # 1 s: the response has decayed
    time_axis_s = np.arange(n_samples) / RATE_HZ
    width_s = 0.8e-3
    force_n = np.where(time_axis_s < width_s, 200.0 * np.sin(np.pi * time_axis_s / width_s), 0.0)
    replayed = simulate_response(spec, force_n, RATE_HZ)
    plant = RigPlant(spec)
    # the plant solves on a grid twice as fine as the sample rate, as the simulator asks it to
    n_grid = 2 * n_samples
    force_spectrum = np.zeros(n_grid + 1, complex)
    force_spectrum[: n_samples + 1] = np.fft.rfft(force_n, n_grid) / RATE_HZ
    force_spectrum[n_samples] *= 0.5
    s = 2j * np.pi * np.fft.rfftfreq(2 * n_grid, 1.0 / (2 * RATE_HZ))
    s[0] = 2j * np.pi * 1e-9 * RATE_HZ / n_grid
    sensed = plant.acceleration_spectrum(force_spectrum, s, 2 * RATE_HZ, 0.0)[: n_samples + 1]
    sensed *= plant.channel_transfer("acceleration", s[: n_samples + 1])
    simulated = np.fft.irfft(sensed * RATE_HZ, n_grid)[:n_samples]
    # compared where the module passes signals (below its 0.45·fs anti-aliasing edge): the periodic grid of the
    # simulator and the zero-padded grid of the replay treat the sampled pulse's Nyquist content differently
    in_band = np.fft.rfftfreq(n_samples, 1.0 / RATE_HZ) <= 0.45 * RATE_HZ
    simulated_band, replayed_band = (np.fft.irfft(np.fft.rfft(x) * in_band, n_samples) for x in (simulated, replayed))
    assert np.max(np.abs(simulated_band - replayed_band)) < NONLINEAR_TOLERANCE * np.max(np.abs(replayed_band))
    linear = simulate_response(NOMINAL.with_effects(EXAMPLES["channel-delay"]), force_n, RATE_HZ)
    assert np.max(np.abs(linear - replayed)) > 1e-3 * np.max(np.abs(replayed))  # the nonlinearity is visible


# --- the closed loop, by construction ------------------------------------------------------------------------------

SINGLES = ["added-mass", "channel-delay", "drift", "step-change", "cubic-stiffness", "ac-coupling", "film-memory",
           "pneumatic-lag", "extra-mode", "cross-talk", "squeeze-film", "friction", "quadratic-damping", "support-mode"]
#: pairs whose terms share a band or a shape (a mass and a delay, a drift and a mode, a lag and a high-pass …)
PAIRS = [("added-mass", "channel-delay"), ("drift", "extra-mode"), ("pneumatic-lag", "ac-coupling"),
         ("film-memory", "added-mass"), ("step-change", "cubic-stiffness"), ("cross-talk", "extra-mode"),
         ("drift", "pneumatic-lag")]


#: every effect of SINGLES in one closed loop: alone when no pair holds it
LOOPS = [(name,) for name in SINGLES if not any(name in pair for pair in PAIRS)] + PAIRS


@pytest.mark.parametrize("names", LOOPS, ids=lambda names: "+".join(names))
def test_closed_loop(names, tmp_path, capsys):
    """Simulate, diagnose against the nominal spec, write the improved spec, diagnose again with it: exit 0, nothing
    found, and the written spec replayed has exactly the RMS the first diagnosis reported as "after"."""
    truth = NOMINAL.with_effects(*(EXAMPLES[name] for name in names))
    session = record(truth, tmp_path / "session.h5", hits=6, seed=sum(map(ord, "".join(names))) % 97)
    NOMINAL.save(tmp_path / "nominal.toml")
    assert gasfilm(["diagnose", str(session), "--rig", str(tmp_path / "nominal.toml"), "--json", "--no-figures",
                    "--out", str(tmp_path / "first")]) == 0
    first = json.loads(capsys.readouterr().out)
    written = RigSpec.load(first["improved_spec"])

    recordings = load_recordings(session)
    spectra = hit_spectra(recordings.records, recordings.sample_rate_hz, recordings.window,
                          hit_times_s=recordings.hit_times_s, overload=recordings.overload)
    assert replay_rms(spectra, written) == pytest.approx(first["rms_after"], rel=1e-9)

    assert gasfilm(["diagnose", str(session), "--rig", first["improved_spec"], "--json", "--no-figures",
                    "--out", str(tmp_path / "second")]) == 0
    second = json.loads(capsys.readouterr().out)
    assert second["findings"] == [], second["findings"]
    assert second["verdict"] in ("consistent", "parameters-only"), second["unexplained"]
    assert Path(second["improved_spec"]).exists()


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_first_order_changes_of_the_accelerance_match_whole_differences(name):
    """A fit's Jacobian columns (``AcceleranceParts.change``: only the part of the accelerance an effect touches
    evaluated again) agree with the whole accelerance evaluated at the changed spec, for every field of every effect
    and every film parameter, one curve and per hit (beside a cubic spring, whose equivalent stiffness moves with the
    film)."""
    pieces = GridPieces(FREQ_HZ, 30.0)
    for base in (NOMINAL.with_effects(EXAMPLES[name]),
                 NOMINAL.with_effects(CubicStiffness(k3_n_per_m3=3e16), EXAMPLES[name])):
        index = len(base.effects) - 1
        effect = base.effects[index]
        fields = [(None, key) for key in base.film_parameters] + [
            (index, field.name) for field in dataclasses.fields(effect) if isinstance(getattr(effect, field.name), float)]
        for conditions in (None, CONDITIONS):
            if conditions is None and base.is_per_hit:
                continue
            parts = accelerance_parts(base, pieces, conditions=conditions)
            assert np.array_equal(parts.accelerance, rig_accelerance(base, FREQ_HZ, 30.0, conditions=conditions))
            for effect_index, field in fields:
                if effect_index is None:
                    value = base.film_parameters[field]
                    changed = base.with_values(film_parameters={**base.film_parameters, field: value * (1 + 1e-6)})
                else:
                    value = getattr(effect, field)
                    if value == 0.0:
                        continue
                    effects = list(base.effects)
                    effects[index] = dataclasses.replace(effect, **{field: value * (1 + 1e-6)})
                    changed = base.with_values(effects=effects)
                whole = rig_accelerance(changed, FREQ_HZ, 30.0, conditions=conditions) - parts.accelerance
                change = parts.change(base, changed, effect_index)
                if change is None:  # an effect that changes something else: its columns are whole differences
                    continue
                scale = max(float(np.max(np.abs(whole))), 1e-300)
                assert np.max(np.abs(change - whole)) <= 1e-4 * scale, (name, field, conditions is not None)
