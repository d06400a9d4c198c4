"""The rig spec (TOML round trip, one-line errors) and the rig physics (accelerance, response synthesis)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_MODELS, PAPER_TABLE1, accelerance
from gasfilm.analysis.physics.effects import EFFECT_TYPES, AddedMass, ChannelDelay, CubicStiffness, Drift, Effect, ExtraMode, Mains, _number, _positive, register_effect
from gasfilm.analysis.physics.response import response_duration_s, rig_accelerance, simulate_response
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import SettingError

RIGS = Path(__file__).resolve().parents[1] / "fixtures" / "rigs"
FREQ_HZ = np.linspace(20.0, 800.0, 157)


@pytest.mark.parametrize("film", ["SD", "FOMGF"])
def test_nominal_spec_is_the_paper_rig(film):
    spec = RigSpec.nominal(film)
    assert spec.mass_kg == PAPER_MASS_KG
    assert dict(spec.film_parameters) == PAPER_TABLE1[film]
    expected = accelerance(PAPER_MODELS[film], PAPER_TABLE1[film], FREQ_HZ, PAPER_MASS_KG)
    np.testing.assert_allclose(rig_accelerance(spec, FREQ_HZ), expected, rtol=1e-12)


def test_nominal_spec_from_a_network_text_needs_parameters():
    spec = RigSpec.nominal("k || dashpot(c)", parameters={"k": 1e7, "c": 2e3})
    assert spec.film_model == "k || dashpot(c)"
    with pytest.raises(SettingError, match="parameters"):
        RigSpec.nominal("k || dashpot(c)")


@pytest.mark.parametrize("name", ["sd", "fomgf", "all-effects"])
def test_fixture_round_trips_through_toml(name, tmp_path):
    spec = RigSpec.load(RIGS / f"{name}.toml")
    again = RigSpec.from_toml(spec.to_toml())
    assert again == spec
    spec.save(tmp_path / "copy.toml")
    assert RigSpec.load(tmp_path / "copy.toml") == spec


def test_fixtures_hold_the_paper_films():
    assert RigSpec.load(RIGS / "sd.toml").film_parameters == PAPER_TABLE1["SD"]
    fomgf = RigSpec.load(RIGS / "fomgf.toml")
    assert fomgf.film_model == "FOMGF" and fomgf.film_parameters == PAPER_TABLE1["FOMGF"]
    assert fomgf.mass_kg == 25.05 and fomgf.effects == ()
    every = RigSpec.load(RIGS / "all-effects.toml")
    assert {type(e) for e in every.effects} == {ExtraMode, CubicStiffness, ChannelDelay, AddedMass, Drift, Mains}


GOOD = (RIGS / "sd.toml").read_text()


def _load_error(path: Path, text: str) -> str:
    """The one-line error loading ``text`` written to ``path`` gives (it names the file)."""
    path.write_text(text)
    with pytest.raises(SettingError) as caught:
        RigSpec.load(path)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message
    return message


@pytest.mark.parametrize(
    "change, key",
    [
        (("mass_kg = 25.05", "mass_kg = -1.0"), "mass_kg"),
        (("mass_kg = 25.05", "mass_kg = \"heavy\""), "mass_kg"),
        (("k = 37800000.0", "k = 0.0"), "film.parameters.k"),
        (("k = 37800000.0", "kk = 1.0"), "film.parameters.k"),
        (("model = \"SD\"", "model = \"SDX\""), "film.model"),
        (("sensitivity_mv_per_n = 11.2", "sensitivity_mv_per_n = -11.2"), "sensors.force.sensitivity_mv_per_n"),
        (("mass_kg = 25.05", "mass_kg = 25.05\nmas_kg = 1.0"), "mas_kg"),
    ],
)
def test_bad_spec_gives_one_line_error_naming_file_and_key(change, key, tmp_path):
    assert key in _load_error(tmp_path / "bad-rig.toml", GOOD.replace(*change))


@pytest.mark.parametrize(
    "effect, key",
    [
        ('type = "wobble"\nfreq_hz = 3.0', "wobble"),
        ('type = "extra-mode"\nfreq_hz = 600.0\ndamping_ratio = -0.1\nmass_kg = 1.0', "damping_ratio"),
        ('type = "extra-mode"\nfreq_hz = 600.0\nmass_kg = 1.0', "damping_ratio"),
        ('type = "channel-delay"\nchannel = "velocity"\ndelay_s = 1e-5', "channel"),
        ('type = "added-mass"\nmass_kg = 0.1\nmass_g = 100.0', "mass_g"),
        ('type = "mains"\nchannel = "force"\namplitude = 0.1\nharmonics = []', "harmonics"),
        ('type = "drift"\nfraction_per_hour = "fast"', "fraction_per_hour"),
        ('type = "mains"\nchannel = "force"\namplitude = 0.1\nharmonics = [1.0, "x"]', "harmonics"),
    ],
)
def test_bad_effect_gives_one_line_error_naming_file_and_key(effect, key, tmp_path):
    path = tmp_path / "bad-effect.toml"
    path.write_text(GOOD + "\n[[effects]]\n" + effect + "\n")
    with pytest.raises(SettingError) as caught:
        RigSpec.load(path)
    message = str(caught.value)
    assert "\n" not in message
    assert str(path) in message and key in message and "effects[0]" in message


def test_effects_made_in_code_are_checked_too():
    with pytest.raises(SettingError, match=r"effects\[0\] \(added-mass\) key 'mass_kg' = 0.0: must not be 0"):
        RigSpec.nominal("SD").with_effects(AddedMass(0.0))
    with pytest.raises(SettingError, match="moving mass with the added masses is -4.95 kg"):
        RigSpec.nominal("SD").with_effects(AddedMass(-30.0))
    with pytest.raises(SettingError, match="allowed: force, acceleration"):
        RigSpec.nominal("SD").with_effects(ChannelDelay("velocity", 1e-5))


def test_invalid_toml_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("mass_kg = = 3\n")
    with pytest.raises(SettingError, match="broken.toml: not valid TOML"):
        RigSpec.load(path)


def test_a_new_effect_type_is_one_small_registered_class():
    @register_effect("test-stiffener")
    @dataclasses.dataclass(frozen=True)
    class Stiffener(Effect):
        stiffness_n_per_m: float = _number("N/m", _positive)

        def added_stiffness(self, s):
            return self.stiffness_n_per_m

    try:
        spec = RigSpec.from_toml(GOOD + '\n[[effects]]\ntype = "test-stiffener"\nstiffness_n_per_m = 1e6\n')
        stiffer = RigSpec.nominal("SD", parameters={"k": PAPER_TABLE1["SD"]["k"] + 1e6, "eta": 3.45e3})
        np.testing.assert_allclose(rig_accelerance(spec, FREQ_HZ), rig_accelerance(stiffer, FREQ_HZ), rtol=1e-12)
        assert RigSpec.from_toml(spec.to_toml()) == spec
    finally:
        del EFFECT_TYPES["test-stiffener"]


def test_linear_effects_in_the_accelerance():
    base = RigSpec.nominal("SD")
    omega = 2 * np.pi * FREQ_HZ
    z_film = PAPER_MODELS["SD"].stiffness(1j * omega, PAPER_TABLE1["SD"])
    heavier = base.with_effects(AddedMass(0.5))
    np.testing.assert_allclose(rig_accelerance(heavier, FREQ_HZ), -(omega**2) / (z_film - 25.55 * omega**2))
    plain = rig_accelerance(base, FREQ_HZ)
    late = base.with_effects(ChannelDelay("acceleration", 1e-4))
    np.testing.assert_allclose(rig_accelerance(late, FREQ_HZ), plain * np.exp(-1j * omega * 1e-4))
    early = base.with_effects(ChannelDelay("force", 1e-4))
    np.testing.assert_allclose(rig_accelerance(early, FREQ_HZ), plain * np.exp(1j * omega * 1e-4))
    drifting = base.with_effects(Drift(-0.1))
    np.testing.assert_allclose(
        rig_accelerance(drifting, FREQ_HZ, time_s=1800.0), -(omega**2) / (0.95 * z_film - 25.05 * omega**2)
    )
    # an attached oscillator: an anti-resonance at its own frequency (there the mover cannot move)
    mode = base.with_effects(ExtraMode(500.0, 1e-4, 1.0))
    magnitude = np.abs(rig_accelerance(mode, np.array([450.0, 500.0, 550.0])))
    assert magnitude[1] < 0.01 * min(magnitude[0], magnitude[2])
    # the windowed accelerance is the Laplace one at s = σ + jω
    np.testing.assert_allclose(
        rig_accelerance(base, FREQ_HZ, decay_rate_1_s=8.0),
        accelerance(PAPER_MODELS["SD"], PAPER_TABLE1["SD"], FREQ_HZ, 25.05, decay_rate_1_s=8.0),
    )


def _hann_pulse(time_s: np.ndarray, peak_n: float, width_s: float) -> np.ndarray:
    inside = (time_s >= 0) & (time_s <= width_s)
    return np.where(inside, peak_n * np.sin(np.pi * time_s / width_s) ** 2, 0.0)


@pytest.mark.parametrize("film, delay_s, tolerance", [("SD", 0.0, 1e-8), ("FOMGF", 0.0, 1e-8), ("FOMGF", 3e-4, 1e-5)])
def test_linear_response_is_exact_and_does_not_wrap(film, delay_s, tolerance):
    fs = 6400.0
    spec = RigSpec.nominal(film)
    if delay_s:
        spec = spec.with_effects(ChannelDelay("acceleration", delay_s))
    n = 4096
    time_s = np.arange(n) / fs
    force = _hann_pulse(time_s - 0.1, 200.0, 2e-3)
    response = simulate_response(spec, force, fs)
    # reference on a 16× longer zero-padded grid: any wrap-around in the short synthesis would show
    # (a fractional delay rings slightly differently on different grid lengths: hence the looser tolerance)
    long_n = 16 * n
    freq_hz = np.fft.rfftfreq(long_n, 1 / fs)
    freq_hz[0] = 1e-6
    reference = np.fft.irfft(np.fft.rfft(force, long_n) * rig_accelerance(spec, freq_hz), long_n)[:n]
    np.testing.assert_allclose(response, reference, rtol=0, atol=tolerance * np.abs(reference).max())
    # a pulse near the end: the response is cut at the record's end, nothing wraps to the start (wrapping would put
    # the full response there; what remains is the discrete-time ringing of the sampled pulse, ~1e-7)
    late = simulate_response(spec, _hann_pulse(time_s - (n - 40) / fs, 200.0, 2e-3), fs)
    assert np.abs(late[: n // 2]).max() < 1e-5 * np.abs(late).max()
    assert 0.05 < response_duration_s(spec, fs) < 2.0


def test_batch_of_records_is_simulated_row_by_row():
    fs = 6400.0
    spec = RigSpec.nominal("SD")
    time_s = np.arange(2048) / fs
    forces = np.stack([_hann_pulse(time_s - 0.01, 100.0, 1e-3), _hann_pulse(time_s - 0.05, 300.0, 2e-3)])
    together = simulate_response(spec, forces, fs)
    np.testing.assert_allclose(together[1], simulate_response(spec, forces[1], fs), rtol=1e-12, atol=1e-14)


def test_cubic_hardening_agrees_with_time_integration():
    """m·x'' + c·x' + k·x + k3·x³ = f(t) for the paper's SD film, against scipy's DOP853."""
    fs, mass, k, c = 12800.0, 25.05, PAPER_TABLE1["SD"]["k"], PAPER_TABLE1["SD"]["eta"]
    k3 = 3e17  # about 40 % extra stiffness at the peak displacement
    spec = RigSpec.nominal("SD").with_effects(CubicStiffness(k3))
    time_s = np.arange(int(0.3 * fs)) / fs

    def force(t):
        return _hann_pulse(t - 0.005, 300.0, 2e-3)

    sampled_force = force(time_s)
    nonlinear = simulate_response(spec, sampled_force, fs)
    linear = simulate_response(RigSpec.nominal("SD"), sampled_force, fs)

    def motion(t, state):
        x, v = state
        return [v, (force(t) - c * v - k * x - k3 * x**3) / mass]

    solution = solve_ivp(motion, (0.0, time_s[-1]), [0.0, 0.0], t_eval=time_s, method="DOP853", rtol=1e-11,
                         atol=1e-16, max_step=0.5 / fs)
    x, v = solution.y
    reference = (sampled_force - c * v - k * x - k3 * x**3) / mass
    peak = np.abs(reference).max()
    assert np.abs(nonlinear - reference).max() < 1e-4 * peak
    assert np.abs(linear - reference).max() > 0.1 * peak  # the hardening really matters in this test


DESCRIBED = GOOD + ('\n[description_error]\nrecording = "a.uff"\nchi2_per_point = 3.2\n'
                    'freq_hz = [100.0, 104.0, 108.0]\nrms_m_s2_per_n = [0.0, 0.02, 0.0]\n')


def test_a_description_error_round_trips_and_is_zero_outside_its_lines():
    spec = RigSpec.from_toml(DESCRIBED)
    error = spec.description_error
    assert error.recording == "a.uff" and error.chi2_per_point == 3.2
    assert RigSpec.from_toml(spec.to_toml()) == spec
    power = error.power(np.array([50.0, 102.0, 104.0, 200.0]))
    assert power[0] == 0.0 and power[-1] == 0.0
    assert power[2] == pytest.approx(4e-4) and power[1] == pytest.approx(2e-4)
    assert spec.with_description_error(None).description_error is None


@pytest.mark.parametrize(
    "change, key",
    [
        (("freq_hz = [100.0, 104.0, 108.0]", "freq_hz = [100.0, 108.0, 104.0]"), "freq_hz"),
        (("rms_m_s2_per_n = [0.0, 0.02, 0.0]", "rms_m_s2_per_n = [0.0, 0.02]"), "rms_m_s2_per_n"),
        (("rms_m_s2_per_n = [0.0, 0.02, 0.0]", "rms_m_s2_per_n = [0.0, -0.02, 0.0]"), "rms_m_s2_per_n"),
        (("chi2_per_point = 3.2", "chi2 = 3.2"), "chi2"),
    ],
)
def test_a_bad_description_error_gives_one_line_naming_the_file_and_key(change, key, tmp_path):
    assert key in _load_error(tmp_path / "bad-error.toml", DESCRIBED.replace(*change))
