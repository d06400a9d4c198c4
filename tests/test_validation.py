"""Hit checks: each reason on synthetic hits built to have (or not have) the fault, overrides, settings."""

import warnings

import numpy as np
import pytest

from gasfilm.analysis.capture import HitRecord, ImpactCapture, TriggerSettings
from gasfilm.analysis.physics.elements import PAPER_MODELS, PAPER_TABLE1, accelerance
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import REASONS, ValidationSettings, Verdict, validate_hit
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import ChannelKind, default_hammer_and_accelerometer
from gasfilm.drivers.simulated import SimulatedNI9234

FS_HZ = 10_240.0
PRE = 102  # 10 ms of pre-trigger
MASS_KG = 25.05


def pulse(n, start_s, width_s, peak_n):
    """Half-sine hammer pulse."""
    t = np.arange(n) / FS_HZ - start_s
    return np.where((t >= 0) & (t < width_s), peak_n * np.sin(np.pi * np.clip(t, 0, width_s) / width_s), 0.0)


def sd_response(force, seed=0, noise=0.005):
    n_long = 2**15
    padded = np.zeros(n_long)
    padded[: force.size] = force
    freq = np.fft.rfftfreq(n_long, 1 / FS_HZ)
    h = accelerance(PAPER_MODELS["SD"], PAPER_TABLE1["SD"], freq, MASS_KG)
    response = np.fft.irfft(np.fft.rfft(padded) * h, n_long)[: force.size]
    return response + np.random.default_rng(seed).normal(0, noise, force.size)


def make_hit(force, response=None, overload=(False, False, False), seed=0, force_noise=0.02):
    """A hit as the capture makes it: channels force, response, spare; trigger at the first sample >= 20 N."""
    rng = np.random.default_rng(seed)
    force = force + rng.normal(0, force_noise, force.size)
    if response is None:
        response = sd_response(force, seed)
    data = np.stack((force, response, rng.normal(0, 1.0, force.size)))
    above = np.flatnonzero(np.abs(force) >= 20.0)
    trigger = int(above[0]) if above.size else PRE
    return HitRecord(0, data, FS_HZ, trigger, 0.0, np.array(overload), force_channel=0, response_channel=1)


def clean_force(n=5120, width_s=1e-3, peak_n=200.0):
    return pulse(n, PRE / FS_HZ, width_s, peak_n)


@pytest.mark.parametrize("width_s", [0.25e-3, 1e-3, 2e-3, 5e-3])
@pytest.mark.parametrize("peak_n", [40.0, 200.0, 1500.0])
def test_clean_hits_are_accepted(width_s, peak_n):
    verdict = validate_hit(make_hit(clean_force(width_s=width_s, peak_n=peak_n)), ValidationSettings())
    assert verdict == Verdict(True, ())


def test_double_hits_are_found_and_clean_ringing_hits_are_not():
    rng = np.random.default_rng(5)
    for trial in range(40):
        width = rng.uniform(0.3e-3, 1.5e-3)
        delay = rng.uniform(2e-3, 30e-3)
        fraction = rng.uniform(0.15, 0.6)
        force = clean_force(width_s=width) + pulse(5120, PRE / FS_HZ + delay, width, 200.0 * fraction)
        verdict = validate_hit(make_hit(force, seed=trial))
        assert "double hit" in verdict.reasons, (width, delay, fraction)
        assert not verdict.accepted
    for trial in range(20):
        width = rng.uniform(0.3e-3, 1.5e-3)
        force = clean_force(width_s=width)
        t = np.arange(5120) / FS_HZ - PRE / FS_HZ - width
        # hammer-tip ringing at 3 kHz, 15 % of the peak, after the pulse; plus 1 % noise
        force += np.where(t > 0, 30.0 * np.exp(-t / 1e-3) * np.sin(2 * np.pi * 3000 * t), 0.0)
        verdict = validate_hit(make_hit(force, seed=100 + trial, force_noise=2.0))
        assert "double hit" not in verdict.reasons


def test_a_later_larger_impact_is_a_double_hit():
    force = clean_force(peak_n=100.0) + pulse(5120, PRE / FS_HZ + 0.004, 1e-3, 300.0)
    assert "double hit" in validate_hit(make_hit(force)).reasons


def test_double_hit_fraction_sets_the_threshold():
    force = clean_force() + pulse(5120, PRE / FS_HZ + 0.01, 1e-3, 200.0 * 0.3)
    assert "double hit" in validate_hit(make_hit(force), ValidationSettings(double_hit_fraction=0.2)).reasons
    assert "double hit" not in validate_hit(make_hit(force), ValidationSettings(double_hit_fraction=0.4)).reasons


def test_negative_pulses_are_judged_like_positive_ones():
    clean = make_hit(-clean_force())
    assert validate_hit(clean).accepted
    double = make_hit(-(clean_force() + pulse(5120, PRE / FS_HZ + 0.005, 1e-3, 80.0)))
    assert validate_hit(double).reasons == ("double hit",)


def test_overload_from_the_flag_from_full_scale_and_from_clipping():
    force = clean_force()
    assert validate_hit(make_hit(force, overload=(True, False, False))).reasons == ("overload",)
    assert validate_hit(make_hit(force, overload=(False, True, False))).reasons == ("overload",)
    assert validate_hit(make_hit(force, overload=(False, False, True))).accepted  # a channel not in the FRF
    hit = make_hit(force)
    full_scale = (float(np.max(np.abs(hit.data[0]))) / 0.99, 1e3, 1e3)
    assert validate_hit(hit, full_scale_si=full_scale).reasons == ("overload",)
    assert validate_hit(hit, full_scale_si=(2 * full_scale[0], 1e3, 1e3)).accepted
    clipped = make_hit(np.clip(clean_force(width_s=2e-3), None, 150.0), force_noise=0.0)
    assert validate_hit(clipped).reasons == ("overload",)


def test_force_too_low_for_the_noise_floor():
    weak = make_hit(clean_force(peak_n=25.0), force_noise=2.0)
    assert "force too low" in validate_hit(weak).reasons
    assert "force too low" not in validate_hit(weak, ValidationSettings(min_force_snr=5.0)).reasons
    assert validate_hit(make_hit(clean_force(peak_n=25.0), force_noise=0.2)).accepted


def test_response_not_decayed_in_a_short_record_and_the_exponential_window_cures_it():
    force = clean_force(n=int(0.04 * FS_HZ))
    short = make_hit(force)
    assert validate_hit(short).reasons == ("response not decayed",)
    windowed = validate_hit(short, window=WindowSettings(exponential_end_fraction=0.01))
    assert windowed.accepted


def test_ringing_from_a_previous_hit_makes_the_pretrigger_not_quiet():
    n = 5120
    earlier = pulse(n + 205, 0.0, 1e-3, 200.0)  # 20 ms before this hit's record starts
    response = sd_response(earlier + np.concatenate((np.zeros(205), clean_force(n))))[205:]
    hit = make_hit(clean_force(n), response=response)
    assert "pre-trigger not quiet" in validate_hit(hit).reasons
    far = sd_response(np.concatenate((pulse(8192, 0.0, 1e-3, 200.0), np.zeros(n))))[8192:]
    quiet_hit = make_hit(clean_force(n), response=far + sd_response(clean_force(n)))
    assert validate_hit(quiet_hit).accepted


def test_several_reasons_at_once_in_a_fixed_order():
    force = clean_force(n=int(0.03 * FS_HZ)) + pulse(int(0.03 * FS_HZ), PRE / FS_HZ + 0.006, 1e-3, 100.0)
    verdict = validate_hit(make_hit(force, overload=(True, False, False)))
    assert verdict.reasons == ("double hit", "overload", "response not decayed")
    assert set(verdict.reasons) <= set(REASONS)


def test_override_keeps_the_reasons_and_round_trips():
    rejected = validate_hit(make_hit(clean_force(), overload=(True, False, False)))
    forced = rejected.overridden_to(True)
    assert forced.accepted and forced.overridden and forced.reasons == rejected.reasons
    assert rejected.overridden_to(False) == Verdict(False, ("overload",), overridden=True)
    assert Verdict.from_dict(forced.to_dict()) == forced


@pytest.mark.parametrize(
    "field, value",
    [("double_hit_fraction", 0.0), ("decay_fraction", 1.5), ("tail_fraction", -0.1),
     ("pretrigger_quiet_fraction", 1.0), ("full_scale_fraction", 1.2), ("min_force_snr", -1.0),
     ("clip_run_samples", 1), ("noise_margin", 0.5)],
)
def test_bad_validation_settings_name_the_field(field, value):
    with pytest.raises(SettingError, match=field):
        ValidationSettings(**{field: value})


@pytest.mark.parametrize("tip", ["soft", "medium", "hard"])
def test_simulated_session_with_25_percent_double_hits(tip):
    """Chunks from the simulated module through the capture and the checks, judged against the simulator's truth."""
    device = SimulatedNI9234(RigPlant.nominal(), seed=7, double_hit_rate=0.25, hit_interval_s=(0.4, 0.6), tip=tip)
    config = default_hammer_and_accelerometer(12_800.0)
    device.configure(config)
    force_channel = config.channel_index(ChannelKind.FORCE)
    response_channel = config.channel_index(ChannelKind.ACCELERATION)
    full_scale = tuple(channel.full_scale_si for channel in config.channels)
    capture = ImpactCapture(TriggerSettings(record_s=0.25), 12_800.0, 2, force_channel, response_channel)
    buffer = np.empty((2, 1280))
    judged = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the ADC overload warnings of the clipping hits
        device.start()
        for read in range(1200):
            if read % 200 == 100:
                device.sim_inject_fault("overload")  # the next hit clips
            n = device.read(buffer)
            for hit in capture.feed(buffer[:, :n], device.status().overload):
                judged.append((hit, validate_hit(hit, ValidationSettings(), full_scale)))
    stream_end_s = capture.samples_seen / 12_800.0
    truth = [t for t in device.sim_hits if t.time_s < stream_end_s - 0.25]  # hits whose record is complete
    assert len(judged) == len(truth) > 200
    doubles = clean = overloads = 0
    caught_doubles = 0
    for hit, verdict in judged:
        true = min(truth, key=lambda t, when=hit.trigger_time_s: abs(t.time_s - when))
        assert abs(true.time_s - hit.trigger_time_s) < 0.005
        if true.overload:
            overloads += 1
            assert "overload" in verdict.reasons and not verdict.accepted
        if true.double:
            doubles += 1
            caught_doubles += "double hit" in verdict.reasons
        elif not true.overload:
            clean += 1
            assert verdict.accepted, verdict.reasons
    assert doubles > 40 and overloads == 6 and clean > 100
    assert caught_doubles >= 0.95 * doubles


@pytest.mark.parametrize("end_ratio", [0.015, 0.01, 0.02])
def test_a_lightly_damped_tail_still_ringing_at_one_to_two_percent_is_flagged_with_the_window_to_use(end_ratio):
    """A single lightly damped mode whose envelope ends at 1-2 % of its start, far above the sensor noise: leakage."""
    n = 10_240  # 1 s
    force = clean_force(n=n)
    t = np.maximum(np.arange(n) - PRE, 0) / FS_HZ
    record_s = (n - 1 - PRE) / FS_HZ
    rate_1_s = -np.log(end_ratio) / record_s
    ringing = np.where(np.arange(n) >= PRE, 50.0 * np.exp(-rate_1_s * t) * np.sin(2 * np.pi * 312.0 * t), 0.0)
    hit = make_hit(force, response=ringing + np.random.default_rng(1).normal(0, 0.005, n))
    verdict = validate_hit(hit)
    assert verdict.reasons == ("response not decayed",)
    (note,) = verdict.notes
    assert f"{end_ratio:.2%}"[:3] in note  # the fitted end level, e.g. "1.50%"
    assert "leakage" in note
    suggested = float(note.split("--exp-end ")[1].split(")")[0])
    assert 0 < suggested < 1
    assert validate_hit(hit, window=WindowSettings(exponential_end_fraction=suggested)).accepted
    # the same mode in a record three times as long decays into the noise: nothing to flag
    long_n = 3 * n
    t_long = np.maximum(np.arange(long_n) - PRE, 0) / FS_HZ
    long_ringing = np.where(np.arange(long_n) >= PRE,
                            50.0 * np.exp(-rate_1_s * t_long) * np.sin(2 * np.pi * 312.0 * t_long), 0.0)
    long_hit = make_hit(clean_force(n=long_n), response=long_ringing + np.random.default_rng(1).normal(0, 0.005,
                                                                                                        long_n))
    assert validate_hit(long_hit).accepted


def test_a_steady_tail_that_does_not_decay_is_flagged():
    n = 5120
    t = np.arange(n) / FS_HZ
    steady = np.where(np.arange(n) >= PRE, 5.0 * np.sin(2 * np.pi * 200.0 * t), 0.0)
    verdict = validate_hit(make_hit(clean_force(n=n), response=steady + sd_response(clean_force(n=n))))
    assert "response not decayed" in verdict.reasons
    assert "does not decay" in verdict.notes[0]
