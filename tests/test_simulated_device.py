"""The simulated NI 9234: band-limited impacts that give the exact FRF, faults, determinism, hooks, signal chain."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest
import scipy.signal

from gasfilm.analysis.physics.elements import PAPER_MASS_KG, PAPER_MODELS, PAPER_TABLE1, accelerance
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.effects import AddedMass, ChannelDelay, CubicStiffness, Drift, ExtraMode, Mains
from gasfilm.analysis.physics.response import rig_accelerance, simulate_response
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.drivers import open_device
from gasfilm.drivers.errors import (
    ADCOverloadWarning,
    BufferOverflowError,
    DeviceRemovedError,
    OpenSensorError,
    ReadTimeoutError,
    SettingError,
)
from gasfilm.drivers.interface import (
    ChannelConfig,
    ChannelKind,
    DaqConfig,
    DaqDevice,
    default_hammer_and_accelerometer,
)
from gasfilm.drivers.simulated import LSB_V, PRE_HIT_SAMPLES, SimulatedNI9234, half_sine_spectrum

FS_HZ = 51200.0 / 8  # 6400 S/s: alias-free band to 2880 Hz, plenty for 20–800 Hz
BAND_HZ = (20.0, 800.0)


def _device(spec=None, fs=FS_HZ, **options) -> SimulatedNI9234:
    device = SimulatedNI9234(RigPlant.from_spec(spec), **options)
    device.configure(default_hammer_and_accelerometer(fs))
    device.start()
    return device


def _read_seconds(device: SimulatedNI9234, seconds: float) -> np.ndarray:
    out = np.empty((len(device.config.channels), int(round(seconds * device.sample_rate_hz))))
    device.read(out)
    return out


def _h1_from_records(forces: np.ndarray, responses: np.ndarray) -> np.ndarray:
    """Plain H1 = Σ F*·A / Σ |F|² with rectangular windows."""
    force_spectra = np.fft.rfft(forces, axis=-1)
    response_spectra = np.fft.rfft(responses, axis=-1)
    return (np.conj(force_spectra) * response_spectra).sum(0) / (np.abs(force_spectra) ** 2).sum(0)


def _errors(h1: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    ratio = h1 / reference
    return float(np.max(np.abs(np.abs(ratio) - 1)) * 100), float(np.max(np.abs(np.angle(ratio, deg=True))))


@pytest.mark.parametrize("film", ["SD", "FOMGF"])
def test_accelerance_from_50_noise_free_hits_matches_the_analytic_one(film):
    """Acceptance: H1 from the simulated time records within 0.5 % and 0.5° of -ω²/(Z(ω) - mω²) over 20–800 Hz.

    The AA filter, the module's input delay and the AC coupling act identically on both channels, so they cancel
    in A/F; records of 2.5 s let the film response (< 0.3 s) and the 0.5 Hz coupling's tail (τ = 0.32 s) decay.
    """
    device = _device(RigSpec.nominal(film), seed=3, hit_interval_s=(3.0, 3.5), noise=False, quantize=False)
    data = _read_seconds(device, 52 * 3.5)
    record = int(2.5 * FS_HZ)
    starts = [int(hit.time_s * FS_HZ) - PRE_HIT_SAMPLES for hit in device.sim_hits[:50]]
    assert len(starts) == 50 and not any(hit.double for hit in device.sim_hits)
    h1 = _h1_from_records(np.stack([data[0, i : i + record] for i in starts]),
                          np.stack([data[1, i : i + record] for i in starts]))
    freq_hz = np.fft.rfftfreq(record, 1 / FS_HZ)
    band = (freq_hz >= BAND_HZ[0]) & (freq_hz <= BAND_HZ[1])
    reference = accelerance(PAPER_MODELS[film], PAPER_TABLE1[film], freq_hz[band], PAPER_MASS_KG)
    magnitude_percent, phase_deg = _errors(h1[band], reference)
    print(f"{film}: max |H1| error {magnitude_percent:.2e} %, max phase error {phase_deg:.2e} °")
    assert magnitude_percent < 0.5 and phase_deg < 0.5


def test_sampling_the_pulse_directly_would_fail_the_acceptance():
    """Without oversampling and the common AA filter, the pulse's aliased high frequencies ride on the mass line
    into the low-frequency FRF: the same 0.5 % / 0.5° check fails. This is what the simulator avoids."""
    spec = RigSpec.nominal("SD")
    oversampling = 16
    fine_fs = oversampling * FS_HZ
    n = int(2.5 * FS_HZ) * oversampling
    time_s = np.arange(n) / fine_fs
    width_s = 0.8e-3  # the medium tip
    pulse = np.where(time_s - 0.01 < width_s, 200.0 * np.sin(np.pi * np.clip(time_s - 0.01, 0, width_s) / width_s), 0)
    response = simulate_response(spec, pulse, fine_fs)  # the analog world, closely
    force, acceleration = pulse[::oversampling], response[::oversampling]  # sampled with no AA filter
    h1 = _h1_from_records(force[np.newaxis], acceleration[np.newaxis])
    freq_hz = np.fft.rfftfreq(force.size, 1 / FS_HZ)
    band = (freq_hz >= BAND_HZ[0]) & (freq_hz <= BAND_HZ[1])
    magnitude_percent, phase_deg = _errors(h1[band], rig_accelerance(spec, freq_hz[band]))
    assert magnitude_percent > 0.5 or phase_deg > 0.5
    # and the simulator's pulse spectrum is the continuous one the naive sampling misrepresents
    np.testing.assert_allclose(half_sine_spectrum(np.array([0.0]), width_s), [2 * width_s / np.pi])
    mid = half_sine_spectrum(np.array([1 / (2 * width_s)]), width_s)  # ω = π/T, the removable singularity
    np.testing.assert_allclose(np.abs(mid), width_s / 2)


def test_module_chain_is_flat_to_045_fs_with_one_group_delay_on_both_channels():
    """A hard-tip hit, noise-free: recorded force / true pulse spectrum is the AA filter (and the 0.5 Hz coupling)."""
    spec = RigSpec.nominal("SD")
    device = _device(spec, seed=1, hit_interval_s=(3.0, 3.5), noise=False, quantize=False, tip="hard")
    data = _read_seconds(device, 5.0)
    hit = device.sim_hits[0]
    freq_hz = np.fft.rfftfreq(data.shape[1], 1 / FS_HZ)
    band = (freq_hz >= 50.0) & (freq_hz <= 0.45 * FS_HZ)
    _, coupling = scipy.signal.freqz(*scipy.signal.butter(1, 0.5, "highpass", fs=FS_HZ), worN=freq_hz[band], fs=FS_HZ)
    true_force = hit.peak_force_n * half_sine_spectrum(freq_hz[band], 0.25e-3) * FS_HZ * coupling
    delay = np.exp(2j * np.pi * freq_hz[band] * (hit.time_s + device.sim_input_delay_s))
    chain = np.fft.rfft(data[0])[band] / true_force * delay
    response = np.fft.rfft(data[1])[band] / (true_force * rig_accelerance(spec, freq_hz[band])) * delay
    inner = freq_hz[band] <= 0.3 * FS_HZ
    for measured in (chain, response):  # the same filter and delay on both channels
        # flat and zero phase once the input delay 38.4/fs + 3 µs is taken out: 1e-3 = 0.009 dB at the band edge
        np.testing.assert_allclose(measured, 1.0, atol=1e-3)
        np.testing.assert_allclose(measured[inner], 1.0, atol=2e-5)
    # a delay of one sample more would be far outside
    assert np.abs(chain * np.exp(2j * np.pi * freq_hz[band] / FS_HZ) - 1).max() > 0.1


def test_linear_effects_are_played_as_rig_accelerance_says():
    """A rig with an extra mode, added mass, a channel delay and drift: each hit's A/F is that hit's accelerance."""
    spec = RigSpec.nominal("FOMGF").with_effects(
        ExtraMode(640.0, 0.02, 0.8), AddedMass(0.3), ChannelDelay("acceleration", 4e-5), Drift(-5.0)
    )
    device = _device(spec, seed=5, hit_interval_s=(3.0, 3.5), noise=False, quantize=False)
    data = _read_seconds(device, 12.0)
    record = int(2.5 * FS_HZ)
    freq_hz = np.fft.rfftfreq(record, 1 / FS_HZ)
    band = (freq_hz >= BAND_HZ[0]) & (freq_hz <= BAND_HZ[1])
    for hit in device.sim_hits[:3]:
        start = int(hit.time_s * FS_HZ) - PRE_HIT_SAMPLES
        h = _h1_from_records(data[0:1, start : start + record], data[1:2, start : start + record])
        magnitude_percent, phase_deg = _errors(h[band], rig_accelerance(spec, freq_hz[band], time_s=hit.time_s))
        assert magnitude_percent < 0.05 and phase_deg < 0.05
        drifted_away, _ = _errors(h[band], rig_accelerance(spec, freq_hz[band], time_s=hit.time_s + 60.0))
        assert drifted_away > 0.5  # the drift is visible from one hit to a minute later


def test_nonlinear_hits_follow_the_cubic_equation_of_motion():
    spec = RigSpec.nominal("SD").with_effects(CubicStiffness(2e17))
    device = _device(spec, seed=2, hit_interval_s=None, noise=False, quantize=False, force_n=300.0)
    _read_seconds(device, 0.05)
    device.sim_hit(force_n=300.0)
    data = _read_seconds(device, 0.5)
    replayed = simulate_response(spec, data[0], FS_HZ)
    peak = np.abs(data[1]).max()
    assert np.abs(replayed - data[1]).max() < 2e-3 * peak
    linear = simulate_response(RigSpec.nominal("SD"), data[0], FS_HZ)
    assert np.abs(linear - data[1]).max() > 0.05 * peak


def test_same_seed_same_samples_whatever_the_chunk_size():
    options = dict(seed=11, hit_interval_s=(0.2, 0.4), double_hit_rate=0.3)
    whole = _read_seconds(_device(None, **options), 2.0)
    chunked_device = _device(None, **options)
    pieces = []
    for size in (1, 7, 640, 1000, 3333, 6419, 1400):
        out = np.empty((2, size))
        chunked_device.read(out)
        pieces.append(out)
    chunked = np.concatenate(pieces, axis=1)
    assert chunked.shape == whole.shape
    np.testing.assert_array_equal(chunked, whole)
    other_seed = _read_seconds(_device(None, **{**options, "seed": 12}), 2.0)
    assert not np.allclose(other_seed, whole)
    assert np.abs(whole[0]).max() > 100  # there really are hits in there


def test_sim_hit_starts_at_the_next_unread_sample():
    device = _device(None, seed=1, hit_interval_s=None, noise=False, quantize=False, tip="hard")
    quiet = _read_seconds(device, 0.2)
    assert np.abs(quiet).max() == 0.0
    hit = device.sim_hit(force_n=150.0)
    assert hit.time_s == pytest.approx(0.2) and hit.on_demand and hit.tip == "hard"
    data = _read_seconds(device, 0.2)
    peak_index = int(np.argmax(data[0]))
    expected_index = (hit.time_s - 0.2 + device.sim_input_delay_s + 0.125e-3) * FS_HZ
    assert abs(peak_index - expected_index) <= 1.5
    # the hard tip is wider-band than the AA filter: the recorded peak is lower than the true one, area preserved
    assert 0.4 * 150.0 < data[0].max() < 150.0
    pulse_area = np.sum(data[0, peak_index - 20 : peak_index + 20]) / FS_HZ  # ±3 ms: before the 0.5 Hz coupling bites
    assert pulse_area == pytest.approx(2 * 150.0 * 0.25e-3 / np.pi, rel=0.01)
    assert device.sim_hits == (hit,)


def test_double_hit_rate_is_roughly_honoured_and_visible():
    device = _device(None, seed=4, hit_interval_s=(0.05, 0.1), double_hit_rate=0.3, noise=False, quantize=False)
    data = _read_seconds(device, 20.0)
    hits = device.sim_hits
    assert len(hits) > 200
    fraction = np.mean([hit.double for hit in hits])
    assert 0.2 < fraction < 0.4
    intervals = np.diff([hit.time_s for hit in hits])
    assert intervals.min() >= 0.05 and intervals.max() <= 0.1
    assert all(0.8 * 200.0 <= hit.peak_force_n <= 1.2 * 200.0 for hit in hits)
    never = _device(None, seed=4, hit_interval_s=(0.05, 0.1), double_hit_rate=0.0)
    _read_seconds(never, 5.0)
    assert not any(hit.double for hit in never.sim_hits)
    # a double hit has a second force pulse a few ms after the first
    double = next(hit for hit in hits if hit.double)
    start = int(double.time_s * FS_HZ)
    force = data[0, start : start + int(0.01 * FS_HZ)]
    above = force > 0.1 * double.peak_force_n
    assert np.count_nonzero(np.diff(above.astype(int)) == 1) == 2


def test_overload_hit_clips_sets_the_flag_and_warns():
    device = _device(None, seed=1, hit_interval_s=None)
    _read_seconds(device, 0.1)
    assert not device.status().overload.any()
    device.sim_inject_fault("overload")
    device.sim_hit()
    with pytest.warns(ADCOverloadWarning, match="overload"):
        data = _read_seconds(device, 0.3)
    assert device.status().overload.tolist() == [True, False]
    full_scale_n = device.config.channels[0].full_scale_si
    assert data[0].max() == pytest.approx(full_scale_n, rel=1e-5)
    assert device.sim_hits[-1].overload
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _read_seconds(device, 0.5)  # the next hit is a normal one again; no warning
    assert not device.status().overload.any()


@pytest.mark.parametrize(
    "kind, error_type",
    [("overflow", BufferOverflowError), ("device_removed", DeviceRemovedError), ("open_sensor", OpenSensorError)],
)
def test_each_fault_raises_its_error_after_delivering_earlier_data(kind, error_type):
    reference = _read_seconds(_device(None, seed=9, hit_interval_s=(0.1, 0.2)), 0.3)
    device = _device(None, seed=9, hit_interval_s=(0.1, 0.2))
    before = _read_seconds(device, 0.3)
    device.sim_inject_fault(kind)
    np.testing.assert_array_equal(before, reference)  # data read before the fault was delivered intact
    out = np.empty((2, 640))
    with pytest.raises(error_type) as caught:
        device.read(out)
    assert "\n" not in str(caught.value) and str(caught.value).startswith("sim:")
    with pytest.raises(error_type):
        device.read(out)  # the fault persists
    if kind == "open_sensor":
        assert device.status().open_sensor.tolist() == [False, True]
    if kind == "device_removed":
        device.stop()
        with pytest.raises(DeviceRemovedError):
            device.start()
    device.sim_clear_faults()
    device.stop()
    device.start()
    device.read(out)
    assert not device.status().open_sensor.any()


def test_realtime_pacing_blocks_and_overflows_when_the_reader_falls_behind():
    device = _device(None, pacing="realtime", buffer_s=0.3)
    out = np.empty((2, int(0.1 * FS_HZ)))
    started = time.monotonic()
    device.read(out)
    device.read(out)
    assert time.monotonic() - started >= 0.19
    time.sleep(0.5)
    with pytest.raises(BufferOverflowError, match="fell behind"):
        device.read(out)
    patient = _device(None, pacing="realtime")
    started = time.monotonic()
    with pytest.raises(ReadTimeoutError, match="did not arrive"):
        patient.read(np.empty((2, int(2 * FS_HZ))), timeout_s=0.1)
    assert 0.09 < time.monotonic() - started < 1.0


def test_realtime_pacing_at_a_speed_streams_that_many_seconds_of_signal_a_second_and_buffers_as_many():
    device = _device(None, pacing="realtime", speed=4.0, buffer_s=0.5)
    out = np.empty((2, int(0.4 * FS_HZ)))
    started = time.monotonic()
    device.read(out)
    device.read(out)
    assert 0.19 <= time.monotonic() - started < 0.7  # 0.8 s of signal: 0.2 s at four times real time
    time.sleep(0.25)  # 1 s of signal unread: more than 0.5 s, within the 4 × 0.5 s that the device holds at this speed
    device.read(out)
    time.sleep(1.0)
    with pytest.raises(BufferOverflowError, match=" 2 s device buffer"):
        device.read(out)
    with pytest.raises(SettingError, match="speed"):
        _device(None, pacing="realtime", speed=0.0)


def test_noise_and_quantisation_of_the_module_chain():
    device = _device(None, seed=6, hit_interval_s=None)
    data = _read_seconds(device, 2.0)[:, int(0.5 * FS_HZ) :]  # after the coupling's start-up
    spec = device.plant.spec
    for row, channel in enumerate(("force", "acceleration")):
        sensor = spec.sensor(channel)
        configured = device.config.channels[row].sensitivity_v_per_si
        sensor_v = sensor.noise_per_sqrt_hz * sensor.sensitivity_v_per_si
        expected_rms_si = np.sqrt(FS_HZ / 2) * np.hypot(sensor_v, 3.1e-7) / configured
        assert np.std(data[row]) == pytest.approx(expected_rms_si, rel=0.05)
        codes = data[row] * configured / LSB_V
        np.testing.assert_allclose(codes, np.round(codes), atol=1e-6)


def test_mains_interference_appears_at_its_frequency():
    spec = RigSpec.nominal("SD").with_effects(Mains("acceleration", 0.05, 50.0, (1.0, 0.5)))
    device = _device(spec, seed=1, hit_interval_s=None)
    data = _read_seconds(device, 3.0)[:, int(1.0 * FS_HZ) :]
    spectrum = np.abs(np.fft.rfft(data[1])) * 2 / data.shape[1]
    freq_hz = np.fft.rfftfreq(data.shape[1], 1 / FS_HZ)
    assert spectrum[np.argmin(np.abs(freq_hz - 50.0))] == pytest.approx(0.05, rel=0.01)
    assert spectrum[np.argmin(np.abs(freq_hz - 100.0))] == pytest.approx(0.025, rel=0.01)
    assert np.abs(np.fft.rfft(data[0]))[np.argmin(np.abs(freq_hz - 50.0))] * 2 / data.shape[1] < 1e-3


def test_four_channels_extra_acceleration_gets_the_response_extra_force_only_noise():
    config = DaqConfig(
        channels=(
            ChannelConfig("ai0", ChannelKind.FORCE, 11.2, "mV/N"),
            ChannelConfig("ai1", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)"),
            ChannelConfig("ai2", ChannelKind.ACCELERATION, 100.0, "mV/g"),
            ChannelConfig("ai3", ChannelKind.FORCE, 11.2, "mV/N"),
        ),
        sample_rate_hz=FS_HZ,
    )
    device = SimulatedNI9234(RigPlant.nominal(), seed=1, hit_interval_s=None, noise=False, quantize=False)
    device.configure(config)
    device.start()
    device.sim_hit(force_n=200.0)
    data = _read_seconds(device, 0.5)
    # ai2's sensor really is 10.2 mV/(m/s²) (the rig spec); configured as 100 mV/g it reads 0.03 % high
    np.testing.assert_allclose(data[2], data[1] * 10.2e-3 / (0.1 / 9.80665), rtol=1e-12, atol=1e-12)
    assert np.abs(data[1]).max() > 1.0 and np.abs(data[0]).max() > 100.0
    assert np.abs(data[3]).max() == 0.0
    noisy = SimulatedNI9234(RigPlant.nominal(), seed=1, hit_interval_s=None)
    noisy.configure(config)
    noisy.start()
    noisy_data = _read_seconds(noisy, 0.5)
    assert np.corrcoef(noisy_data[1], noisy_data[2])[0, 1] < 0.2  # independent noise on every channel


def test_it_is_a_daq_device_opened_by_name_and_validates_its_setup():
    device = open_device("sim", plant=RigPlant.nominal(), seed=2, hit_interval_s=None)
    assert isinstance(device, SimulatedNI9234) and isinstance(device, DaqDevice)
    assert device.config == default_hammer_and_accelerometer()  # the paper's setup until configured
    with pytest.raises(SettingError, match="sample_rate_hz"):
        device.configure(default_hammer_and_accelerometer(50000.0))
    device.configure(default_hammer_and_accelerometer(FS_HZ))
    with pytest.raises(SettingError, match="start"):
        device.read(np.empty((2, 10)))
    with pytest.raises(SettingError, match="pacing"):
        SimulatedNI9234(RigPlant.nominal(), pacing="slow")
    with pytest.raises(SettingError, match="tip"):
        SimulatedNI9234(RigPlant.nominal(), tip="rubber")
    with pytest.raises(SettingError, match="fault"):
        device.sim_inject_fault("fire")
    with device:
        device.start()
        assert device.read(np.empty((2, 64))) == 64
    with pytest.raises(SettingError, match="closed"):
        device.start()
