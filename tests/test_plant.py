"""The simulated device's plant: the Protocol is all the simulator needs, and RigPlant is the rig spec's physics."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gasfilm.analysis.physics.effects import ChannelDelay, Drift, ExtraMode, Mains
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.response import rig_accelerance
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import default_hammer_and_accelerometer
from gasfilm.drivers.plant import TIPS_PULSE_WIDTH_S, Plant
from gasfilm.drivers.simulated import SimulatedNI9234

FS_HZ = 51200.0 / 8


class FreeMass:
    """A plant that is no rig spec: a free mass hit by a hammer, with ideal sensors and 10 mN of 50 Hz on the force."""

    hammer = SimpleNamespace(tip="soft", force_n=50.0, force_spread=0.0, double_hit_rate=0.0)
    is_linear = True

    def __init__(self, mass_kg: float) -> None:
        self.mass_kg = mass_kg

    def sensitivity_v_per_si(self, channel: str) -> float:
        return 11.2e-3 if channel == "force" else 10.2e-3  # as configured: the samples are in true SI units

    def noise_per_sqrt_hz(self, channel: str) -> float:
        return 0.0

    def response_duration_s(self, sample_rate_hz: float) -> float:
        return 0.05

    def acceleration_spectrum(self, force_spectrum, s, sample_rate_hz, time_s):
        return force_spectrum / self.mass_kg

    def channel_transfer(self, channel: str, s: np.ndarray) -> np.ndarray:
        return np.ones_like(s)

    def interference(self, channel: str, time_s: np.ndarray) -> np.ndarray | None:
        return 0.01 * np.sin(2 * np.pi * 50.0 * time_s) if channel == "force" else None


def test_a_plant_that_is_no_rig_spec_drives_the_simulator():
    plant = FreeMass(2.0)
    assert isinstance(plant, Plant)
    device = SimulatedNI9234(plant, seed=1, hit_interval_s=None, noise=False, quantize=False)
    device.configure(default_hammer_and_accelerometer(FS_HZ))
    device.start()
    device.read(np.empty((2, int(0.5 * FS_HZ))))
    hit = device.sim_hit()
    force, acceleration = data = np.empty((2, int(0.05 * FS_HZ)))
    device.read(data)
    assert (hit.tip, hit.peak_force_n) == ("soft", 50.0)  # the plant's hammer
    assert force.max() == pytest.approx(50.0, rel=0.05)
    # the acceleration channel is the force over the mass (same AA filter and coupling on both channels) ...
    np.testing.assert_allclose(acceleration, force / 2.0, atol=0.006)  # of a 25 m/s² peak
    # ... but for the 10 mN of interference the plant adds on the force channel only
    assert np.abs(force - 2.0 * acceleration).max() == pytest.approx(0.01, rel=0.1)


def test_rig_plant_is_a_plant_and_a_spec_is_not():
    assert isinstance(RigPlant.nominal(), Plant)
    with pytest.raises(SettingError, match="sim plant: .* is not a Plant"):
        SimulatedNI9234(RigSpec.nominal("FOMGF"))


def test_rig_plant_answers_with_the_specs_physics():
    spec = RigSpec.nominal("FOMGF", effects=(ExtraMode(640.0, 0.02, 0.8), Drift(0.5), ChannelDelay("acceleration", 2e-5),
                                             Mains("force", 0.2)))
    plant = RigPlant(spec)
    freq_hz = np.linspace(10.0, 1000.0, 100)
    s = 2j * np.pi * freq_hz
    force = np.exp(-s * 1e-3)
    time_s = 1800.0
    measured = plant.acceleration_spectrum(force, s, FS_HZ, time_s) * plant.channel_transfer("acceleration", s)
    np.testing.assert_allclose(measured / force, rig_accelerance(spec, freq_hz, time_s=time_s), rtol=1e-12)
    assert plant.interference("acceleration", np.zeros(3)) is None
    np.testing.assert_allclose(plant.interference("force", np.array([0.005])), [0.2])
    assert plant.sensitivity_v_per_si("force") == spec.force_sensor.sensitivity_mv * 1e-3
    assert plant.hammer.tip == "medium" and plant.is_linear


@pytest.mark.parametrize("rate_hz", [51200.0, 51200.0 / 3, 2560.0])
def test_mains_on_a_streams_chunks_equals_the_direct_sum_of_harmonics(rate_hz):
    # a uniform grid (a stream's chunk) is computed by angle addition from a table: the same values as
    # Σ h_n sin(2π n f t) to the rounding of the phase itself, hours into a stream; other times directly
    mains = Mains("acceleration", 0.02, 50.0, (1.0, 0.3, 0.1))
    for first in (0, 3, 5120 * 77, int(rate_hz * 7200)):
        time_s = np.arange(first, first + 5120) / rate_hz
        phase = 2 * np.pi * 50.0 * time_s
        direct = 0.02 * (np.sin(phase) + 0.3 * np.sin(2 * phase) + 0.1 * np.sin(3 * phase))
        rounding = 0.02 * 8 * np.spacing(phase.max())  # Σ n·h_n ≈ 2, a few roundings of the largest phase
        np.testing.assert_allclose(mains.interference("acceleration", time_s), direct, rtol=0, atol=rounding)
    uneven = np.array([0.0, 0.001, 0.0035, 0.004])
    np.testing.assert_allclose(mains.interference("acceleration", uneven),
                               0.02 * (np.sin(100 * np.pi * uneven) + 0.3 * np.sin(200 * np.pi * uneven)
                                       + 0.1 * np.sin(300 * np.pi * uneven)), rtol=0, atol=1e-15)


def test_the_tips_a_spec_accepts_are_the_simulated_hammers():
    base = "mass_kg = 25.05\n[film]\nmodel = 'SD'\n[film.parameters]\nk = 3.78e7\neta = 3.45e3\n"
    for tip in TIPS_PULSE_WIDTH_S:
        assert RigSpec.from_toml(base + f"[hammer]\ntip = '{tip}'\n").hammer.tip == tip
    with pytest.raises(SettingError, match="hammer.tip"):
        RigSpec.from_toml(base + "[hammer]\ntip = 'rubber'\n")
