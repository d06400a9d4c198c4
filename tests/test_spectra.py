"""Spectra and FRF: pyFRF agreement (rectangular), windowed magnitude vs the analytic accelerance, damping after the
window correction, averaging of spectra (not ratios), uncertainty, views and round trips."""

import multiprocessing

import numpy as np
import pytest
from pyFRF import FRF

from gasfilm.analysis.physics.elements import PAPER_MODELS, PAPER_TABLE1, accelerance
from gasfilm.analysis import spectra
from gasfilm.analysis.spectra import (
    FrfResult,
    WindowSettings,
    compute_frf,
    exponential_window,
    force_window,
    session_frf,
    remove_window_damping,
)
from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.validation import validate_hit
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import default_hammer_and_accelerometer
from gasfilm.drivers.simulated import SimulatedNI9234
from gasfilm.drivers.interface import STANDARD_GRAVITY_M_S2

SD = PAPER_MODELS["SD"]
SD_PARAMS = PAPER_TABLE1["SD"]  # k = 3.78e7 N/m, eta = c = 3.45e3 N·s/m
MASS_KG = 25.05
K, C = SD_PARAMS["k"], SD_PARAMS["eta"]
OMEGA_N = np.sqrt(K / MASS_KG)
FN_HZ = OMEGA_N / (2 * np.pi)
ZETA = C / (2 * np.sqrt(K * MASS_KG))


def sd_hits(n_hits=5, sample_rate_hz=5120.0, record_s=0.05, pulse_at_s=0.005, seed=1, noise=(0.02, 0.002)):
    """Hits on the SD system: Gaussian force pulse, response exact in the frequency domain on a long zero-padded
    grid (the structure rings out completely there), then cut to a short record and given sensor noise."""
    rng = np.random.default_rng(seed)
    n_long = 2**16
    n = int(round(record_s * sample_rate_hz))
    t = np.arange(n_long) / sample_rate_hz
    freq = np.fft.rfftfreq(n_long, 1 / sample_rate_hz)
    h = accelerance(SD, SD_PARAMS, freq, MASS_KG)
    records = []
    for _ in range(n_hits):
        force = (150 + 50 * rng.random()) * np.exp(-0.5 * ((t - pulse_at_s) / 0.25e-3) ** 2)
        response = np.fft.irfft(np.fft.rfft(force) * h, n_long)
        records.append(
            np.stack((force[:n] + rng.normal(0, noise[0], n), response[:n] + rng.normal(0, noise[1], n)))
        )
    return np.array(records), sample_rate_hz


def noisy_hits(n_hits=6, n_samples=512, seed=3):
    """Random broadband hits through a circular SD-like filter with noise on both channels (coherence < 1)."""
    rng = np.random.default_rng(seed)
    freq = np.fft.rfftfreq(n_samples, 1 / 2560.0)
    h = accelerance(SD, SD_PARAMS, freq, MASS_KG)
    force = rng.normal(0, 10.0, (n_hits, n_samples))
    response = np.fft.irfft(np.fft.rfft(force) * h, n_samples) + rng.normal(0, 0.05, (n_hits, n_samples))
    force += rng.normal(0, 0.5, force.shape)
    return np.stack((force, response), axis=1), 2560.0


def relative(a, b):
    return np.max(np.abs(a - b) / np.abs(b))


def test_rectangular_windows_equal_pyfrf():
    records, fs = noisy_hits()
    result = compute_frf(records, fs)
    reference = FRF(int(fs), exc=records[:, 0], resp=records[:, 1], exc_type="f", resp_type="a")
    h1 = reference.get_FRF("H1", frf_form="accelerance")[0, 0]
    h2 = reference.get_FRF("H2", frf_form="accelerance")[0, 0]
    coherence = reference.get_coherence()[0]
    lines = slice(1, None)  # pyFRF removes the mean (its DC line is 0/0) and its a→x→a conversion is nan at 0 Hz
    assert relative(result.h1[lines], h1[lines]) < 1e-9
    assert relative(result.h2[lines], h2[lines]) < 1e-9
    assert relative(result.coherence[lines], coherence[lines]) < 1e-9
    assert relative(result.gff[lines], reference.S_FF[0, 0, lines].real) < 1e-9
    assert result.coherence[lines].min() < 0.9  # the noise makes this a real test of the averaging


def test_spectra_are_averaged_not_the_frf_ratios():
    records, fs = noisy_hits(n_hits=4, n_samples=256)
    result = compute_frf(records, fs)
    forces = np.fft.rfft(records[:, 0], axis=-1)
    responses = np.fft.rfft(records[:, 1], axis=-1)
    h1 = np.sum(np.conj(forces) * responses, axis=0) / np.sum(np.abs(forces) ** 2, axis=0)
    np.testing.assert_allclose(result.h1, h1, rtol=1e-10)
    np.testing.assert_allclose(result.h1_per_hit, responses / forces, rtol=1e-10)
    assert relative(result.h1_per_hit.mean(axis=0), result.h1) > 0.01  # the ratio average would be different
    np.testing.assert_allclose(result.h2, result.gxx / np.conj(result.gfx), rtol=1e-12)
    assert result.n_averages == 4 and result.h1_per_hit.shape == (4, 129)
    assert np.all(result.coherence <= 1 + 1e-12)


def test_list_and_array_inputs_and_row_choice_agree():
    records, fs = noisy_hits(n_hits=3, n_samples=128)
    stacked = compute_frf(records, fs)
    listed = compute_frf([r for r in records], fs)
    swapped = compute_frf(records[:, ::-1], fs, force_row=1, response_row=0)
    three_rows = compute_frf(np.concatenate((records, records[:, :1] * 0), axis=1), fs)
    for other in (listed, swapped, three_rows):
        np.testing.assert_array_equal(other.h1, stacked.h1)
        np.testing.assert_array_equal(other.coherence, stacked.coherence)


def test_frf_from_hits_uses_each_hits_channels():
    records, fs = noisy_hits(n_hits=3, n_samples=128)
    hits = [
        HitRecord(i, np.stack((np.zeros(128), r[1], r[0])), fs, 10, 0.0, np.zeros(3, bool), 2, 1)
        for i, r in enumerate(records)
    ]
    np.testing.assert_array_equal(session_frf(hits).h1, compute_frf(records, fs).h1)


def levy_sd_fit(freq_hz, h):
    """Damping ratio and natural frequency of a second-order rational (numerator and denominator of degree 2 in jω)
    fitted by linear least squares (Levy's method): the FRF model of an SD system in any window."""
    jw = 2j * np.pi * freq_hz
    columns = np.column_stack((h, h * jw, -np.ones_like(jw), -jw, -(jw**2)))
    rhs = -h * jw**2
    solution = np.linalg.lstsq(
        np.vstack((columns.real, columns.imag)), np.concatenate((rhs.real, rhs.imag)), rcond=None
    )[0]
    omega = np.sqrt(solution[0])
    return solution[1] / (2 * omega), omega / (2 * np.pi)


def test_force_and_exponential_windows_give_the_analytic_accelerance():
    records, fs = sd_hits()
    window = WindowSettings(force_window_ms=3.0, force_taper_ms=0.5, exponential_end_fraction=0.01)
    result = compute_frf(records, fs, window)
    sigma = result.decay_rate_1_s
    assert sigma == pytest.approx(np.log(100) * fs / (records.shape[-1] - 1))
    assert result.window["decay_rate_1_s"] == sigma and result.window["exponential_end_fraction"] == 0.01
    band = (result.freq_hz >= 20) & (result.freq_hz <= 1400)  # where the pulse has force well above the noise
    windowed_model = accelerance(SD, SD_PARAMS, result.freq_hz[band], MASS_KG, decay_rate_1_s=sigma)
    error = np.abs(np.abs(result.h1[band]) / np.abs(windowed_model) - 1)
    assert error.max() < 0.01
    off_resonance = (result.freq_hz >= 3 * FN_HZ) & (result.freq_hz <= 1400)
    plain_model = accelerance(SD, SD_PARAMS, result.freq_hz[off_resonance], MASS_KG)
    off_error = np.abs(np.abs(result.h1[off_resonance]) / np.abs(plain_model) - 1)
    assert off_error.max() < 0.01
    # the same hits without windows leak: the short record truncates the ringing
    rectangular = compute_frf(records, fs)
    leak = np.abs(np.abs(rectangular.h1[band]) / np.abs(accelerance(SD, SD_PARAMS, result.freq_hz[band], MASS_KG)) - 1)
    assert leak.max() > 0.03


def test_damping_after_the_window_correction_matches_the_true_damping():
    records, fs = sd_hits()
    result = compute_frf(records, fs, WindowSettings(force_window_ms=3.0, exponential_end_fraction=0.01))
    near = (result.freq_hz > 0.5 * FN_HZ) & (result.freq_hz < 1.6 * FN_HZ)
    zeta_fit, fn_fit = levy_sd_fit(result.freq_hz[near], result.h1[near])
    added = result.decay_rate_1_s / (2 * np.pi * fn_fit)
    assert zeta_fit > 2 * ZETA  # the window's damping dominates the raw fit
    assert abs((zeta_fit - added) / ZETA - 1) < 0.02  # first-order correction Δζ = σ/ω_n
    zeta_exact, fn_exact = remove_window_damping(zeta_fit, fn_fit, result.decay_rate_1_s)
    assert abs(zeta_exact / ZETA - 1) < 0.005
    assert abs(fn_exact / FN_HZ - 1) < 0.002


def test_simulated_rig_through_capture_and_windows_gives_the_windowed_accelerance():
    """The whole chain on the simulated module (SD film, medium tip, sensor noise, AA filter, AC coupling): capture
    short 0.05 s records, validate them with the window, average; the magnitude matches the windowed model."""
    fs = 12_800.0
    window = WindowSettings(force_window_ms=3.0, exponential_end_fraction=0.01)
    device = SimulatedNI9234(RigPlant.nominal("SD"), seed=3, hit_interval_s=(0.3, 0.4))
    device.configure(default_hammer_and_accelerometer(fs))
    capture = ImpactCapture(TriggerSettings(record_s=0.05, pretrigger_s=0.005), fs, 2)
    buffer = np.empty((2, 1280))
    hits = []
    device.start()
    for _ in range(40):
        n = device.read(buffer)
        hits += capture.feed(buffer[:, :n], device.status().overload)
    assert len(hits) >= 10
    assert all(validate_hit(hit).reasons == ("response not decayed",) for hit in hits)  # 0.05 s is too short ...
    assert all(validate_hit(hit, window=window).accepted for hit in hits)  # ... unless windowed
    result = session_frf(hits, window)
    band = (result.freq_hz >= 20) & (result.freq_hz <= 1500)  # below the first zero of the 0.8 ms pulse's spectrum
    model = accelerance(SD, SD_PARAMS, result.freq_hz[band], MASS_KG, decay_rate_1_s=result.decay_rate_1_s)
    assert np.max(np.abs(np.abs(result.h1[band]) / np.abs(model) - 1)) < 0.01
    assert result.coherence[band].min() > 0.99


def test_uncertainty_matches_the_scatter_of_repeated_sessions():
    rng = np.random.default_rng(11)
    n_sessions, n_hits, n_samples, fs = 300, 8, 64, 2560.0
    freq = np.fft.rfftfreq(n_samples, 1 / fs)
    h = accelerance(SD, SD_PARAMS, freq, MASS_KG)
    t = np.arange(n_samples) / fs
    amplitude = rng.uniform(100.0, 200.0, (n_sessions, n_hits, 1))
    force = amplitude * np.exp(-0.5 * ((t - 0.002) / 0.2e-3) ** 2)  # impacts: |F| smooth and far from zero
    response = np.fft.irfft(np.fft.rfft(force) * h, n_samples) + rng.normal(0, 0.3, force.shape)
    force += rng.normal(0, 0.05, force.shape)
    results = [compute_frf(np.stack((f, x), axis=1), fs) for f, x in zip(force, response)]
    lines = slice(1, -1)
    h1 = np.array([r.h1 for r in results])[:, lines]
    predicted_magnitude = np.mean([r.h1_std_coherence for r in results], axis=0)[lines]
    observed_magnitude = np.std(np.abs(h1), axis=0)
    ratio = np.median(observed_magnitude / predicted_magnitude)
    assert 0.8 < ratio < 1.25
    per_hit_mean = np.array([r.h1_per_hit.mean(axis=0) for r in results])[:, lines]
    observed_complex = np.sqrt(np.mean(np.abs(per_hit_mean - per_hit_mean.mean(axis=0)) ** 2, axis=0))
    predicted_complex = np.mean([r.h1_std_scatter for r in results], axis=0)[lines]
    assert 0.8 < np.median(observed_complex / predicted_complex) < 1.25


def test_scatter_in_one_pass_equals_the_standard_deviation_of_the_per_hit_frfs():
    # the scatter is summed while the hits are transformed, as deviations from the first hit's FRF; it must equal
    # the two-pass definition, also when the first hit is an outlier and when the spread is at round-off level
    records, fs = noisy_hits(n_hits=9, n_samples=256)
    records[0] *= np.array([[1.0], [3.0]])  # the first hit's response three times too large: far from the mean
    for hits in (records, np.repeat(records[:1], 4, axis=0) * (1.0 + 1e-13 * np.arange(4))[:, None, None]):
        result = compute_frf(hits, fs)
        n = len(hits)
        per_hit = result.h1_per_hit
        two_pass = np.sqrt(np.sum(np.abs(per_hit - per_hit.mean(axis=0)) ** 2, axis=0) / (n - 1) / n)
        lines = slice(1, None)
        np.testing.assert_allclose(result.h1_std_scatter[lines], two_pass[lines], rtol=1e-6,
                                   atol=1e-12 * np.abs(result.h1[lines]).max())
    identical = compute_frf(np.repeat(records[:1], 3, axis=0), fs)
    assert np.all(identical.h1_std_scatter[1:] == 0.0)


def test_blocks_transformed_on_a_second_thread_give_the_same_bits(monkeypatch):
    # large blocks are transformed while the block before is combined: the same sums, in the same order, as one
    # block after the other in one thread (here blocks of 2 hits, every block handed over, an odd last block)
    records, fs = noisy_hits(n_hits=19, n_samples=4096)
    window = WindowSettings(force_window_ms=20.0, exponential_end_fraction=0.1)
    monkeypatch.setattr(spectra, "_BLOCK_VALUES", 1 << 12)
    monkeypatch.setattr(spectra, "_OVERLAPPED_VALUES", 1)
    overlapped = compute_frf(records, fs, window)
    monkeypatch.setattr(spectra, "_OVERLAPPED_VALUES", 1 << 40)
    serial = compute_frf(records, fs, window)
    assert overlapped.n_averages == serial.n_averages == 19
    for name in ("h1", "h2", "coherence", "gff", "gxx", "gfx", "h1_per_hit", "h1_std_scatter", "h1_std_coherence"):
        assert np.array_equal(getattr(overlapped, name), getattr(serial, name), equal_nan=True), name


def _overlapped_h1(records, fs):
    return compute_frf(records, fs).h1


def test_a_forked_process_transforms_on_its_own_thread(monkeypatch):
    # the parent's transform thread does not exist in a forked child (a process pool, the GUI's job processes)
    records, fs = noisy_hits(n_hits=4, n_samples=1024)
    monkeypatch.setattr(spectra, "_BLOCK_VALUES", 1 << 10)
    monkeypatch.setattr(spectra, "_OVERLAPPED_VALUES", 1)
    parent = compute_frf(records, fs).h1
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.apply_async(_overlapped_h1, (records, fs)).get(timeout=30)
    assert np.array_equal(parent, child)


def test_single_hit_has_unit_coherence_and_no_scatter_estimate():
    records, fs = noisy_hits(n_hits=1, n_samples=64)
    result = compute_frf(records[0], fs)
    assert result.n_averages == 1
    np.testing.assert_allclose(result.coherence[1:], 1.0, rtol=1e-9)
    assert np.all(np.isnan(result.h1_std_scatter))
    np.testing.assert_allclose(result.h1_std_coherence[1:], 0.0, atol=1e-6 * np.abs(result.h1[1:]).max())


def test_windows_shapes():
    fs = 10_000.0
    force = np.zeros((2, 400))
    force[0, 50] = 1.0
    force[1, 120] = -3.0
    w = force_window(force, fs, WindowSettings(force_window_ms=2.0, force_taper_ms=1.0))
    assert np.all(w[0, :71] == 1.0) and np.all(w[1, :141] == 1.0)
    assert np.all(np.diff(w[0, 70:81]) < 0) and np.all(w[0, 80:] == 0.0)
    assert w[0, 75] == pytest.approx(0.5)
    assert np.all(force_window(force, fs, WindowSettings()) == 1.0)
    decay = exponential_window(400, 0.01)
    sigma = WindowSettings(exponential_end_fraction=0.01).decay_rate_1_s(400, fs)
    np.testing.assert_allclose(decay, np.exp(-sigma * np.arange(400) / fs))
    assert decay[0] == 1.0 and decay[-1] == pytest.approx(0.01)
    assert WindowSettings().decay_rate_1_s(400, fs) == 0.0


def test_g_per_n_view_band_and_dict_round_trip():
    records, fs = noisy_hits(n_hits=3, n_samples=256)
    result = compute_frf(records, fs, WindowSettings(exponential_end_fraction=0.1))
    g = result.in_g_per_n()
    np.testing.assert_allclose(g.h1 * STANDARD_GRAVITY_M_S2, result.h1)
    np.testing.assert_allclose(g.h1_per_hit * STANDARD_GRAVITY_M_S2, result.h1_per_hit)
    np.testing.assert_allclose(g.gxx * STANDARD_GRAVITY_M_S2**2, result.gxx)
    np.testing.assert_array_equal(g.coherence, result.coherence)
    assert g.frf_unit == "g/N" and result.frf_unit == "(m/s^2)/N" and g.in_g_per_n() is g
    part = result.band(100.0, 300.0)
    assert part.freq_hz.min() >= 100.0 and part.freq_hz.max() <= 300.0
    assert part.h1_per_hit.shape == (3, part.freq_hz.size) and part.gff.shape == part.freq_hz.shape
    again = FrfResult.from_dict(result.to_dict())
    for name, value in result.to_dict().items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(getattr(again, name), value)
        else:
            assert getattr(again, name) == value


@pytest.mark.parametrize(
    "settings, field",
    [
        (dict(force_window_ms=0.0), "force_window_ms"),
        (dict(force_taper_ms=-1.0), "force_taper_ms"),
        (dict(exponential_end_fraction=0.0), "exponential_end_fraction"),
        (dict(exponential_end_fraction=1.5), "exponential_end_fraction"),
    ],
)
def test_bad_window_settings_name_the_field(settings, field):
    with pytest.raises(SettingError, match=field):
        WindowSettings(**settings)


def test_bad_records_are_one_line_errors():
    records, fs = noisy_hits(n_hits=2, n_samples=64)
    broken = records.copy()
    broken[1, 1, 5] = np.nan
    with pytest.raises(SettingError, match="NaN"):
        compute_frf(broken, fs)
    with pytest.raises(SettingError, match="different lengths"):
        compute_frf([records[0], records[1][:, :32]], fs)
    with pytest.raises(SettingError, match="no hits"):
        compute_frf([], fs)
    with pytest.raises(SettingError, match="response_row"):
        compute_frf(records, fs, response_row=2)


def test_hv_lies_between_h1_and_h2_and_is_unbiased_when_force_and_response_are_equally_noisy():
    """Issue 32 item 4. A known system (a two-pole low-pass, |H| about 1 in N and m/s²) driven by random force, with
    uncorrelated noise of the same variance added to the measured force and response: H1 is biased low by
    1/(1 + N_ff/G_ff), H2 high by (1 + N_xx/G_xx); Hv, weighing both noises alike, is not."""
    rng = np.random.default_rng(4)
    rate, n, hits = 1024.0, 512, 150
    freq = np.fft.rfftfreq(n, 1 / rate)
    s = 2j * np.pi * freq
    wn = 2 * np.pi * 100
    true_h = wn**2 / (s**2 + 2 * 0.3 * wn * s + wn**2)
    records = np.empty((hits, 2, n))
    for hit in range(hits):
        force = rng.standard_normal(n)
        response = np.fft.irfft(np.fft.rfft(force) * true_h, n)
        records[hit, 0] = force + 0.5 * rng.standard_normal(n)
        records[hit, 1] = response + 0.5 * rng.standard_normal(n)
    frf = compute_frf(records, rate)
    band = (freq > 5) & (freq < 80)
    h1, h2, hv = (np.abs(h[band]) for h in (frf.h1, frf.h2, frf.hv))
    assert np.all(h1 <= hv * (1 + 1e-12)) and np.all(hv <= h2 * (1 + 1e-12))
    error = {name: float(np.median(np.abs(h / np.abs(true_h[band]) - 1))) for name, h in
             (("H1", h1), ("H2", h2), ("Hv", hv))}
    assert error["Hv"] < 0.03 and error["H1"] > 0.15 and error["H2"] > 0.15, error
    # noise-free, the three are one
    clean = compute_frf(records[:, :, :] * 0 + np.stack([records[:, 0], np.fft.irfft(
        np.fft.rfft(records[:, 0], axis=-1) * true_h, n, axis=-1)], axis=1), rate)
    np.testing.assert_allclose(clean.hv[1:], clean.h1[1:], rtol=1e-9)
    # Hv is weighed in N and m/s² whatever unit the result is shown in
    np.testing.assert_allclose(frf.in_g_per_n().hv, frf.hv / STANDARD_GRAVITY_M_S2, rtol=1e-12)


def test_prominent_peaks_are_scipys_find_peaks_with_prominence():
    """Issue 32 item 16: the resonance search no longer imports scipy.signal (and the scipy.stats it loads) for
    find_peaks; the same peaks, flat tops included."""
    import scipy.signal

    from gasfilm.analysis.spectra import prominent_peaks

    rng = np.random.default_rng(0)
    for _ in range(200):
        values = np.round(rng.standard_normal(int(rng.integers(3, 300))).cumsum(), int(rng.integers(0, 3)))
        prominence = float(rng.uniform(0, 2))
        np.testing.assert_array_equal(prominent_peaks(values, prominence),
                                      scipy.signal.find_peaks(values, prominence=prominence)[0])


def test_peak_half_widths_are_scipys_prominences_and_widths_at_half_prominence():
    """The film's features (resonances, antiresonances: gasfilm.analysis.physics.features) are read without
    scipy.signal too: the same prominences and half-prominence crossings, bit for bit, flat tops included."""
    import scipy.signal

    from gasfilm.analysis.spectra import peak_half_widths, prominent_peaks

    rng = np.random.default_rng(1)
    for _ in range(200):
        values = np.round(rng.standard_normal(int(rng.integers(3, 300))).cumsum(), int(rng.integers(0, 3)))
        peaks = prominent_peaks(values, float(rng.uniform(0, 2)))
        prominences, left, right = peak_half_widths(values, peaks)
        np.testing.assert_array_equal(prominences, scipy.signal.peak_prominences(values, peaks)[0])
        _, _, their_left, their_right = scipy.signal.peak_widths(values, peaks, rel_height=0.5)
        np.testing.assert_array_equal(left, their_left)
        np.testing.assert_array_equal(right, their_right)
