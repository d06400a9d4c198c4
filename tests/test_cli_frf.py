"""One session FRF (running sums, each hit's own channels) and one settings decoder, through the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gasfilm.analysis.capture import HitRecord
from gasfilm.analysis.physics.plant import RigPlant
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.session import Session
from gasfilm.analysis.settings import ProcessingSettings, decode_settings
from gasfilm.analysis.spectra import FrfAccumulator, WindowSettings, compute_frf, session_frf
from gasfilm.analysis.uff import trigger_sample
from gasfilm.analysis.validation import Verdict
from gasfilm.app.cli import main
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import ChannelConfig, ChannelKind, DaqConfig
from gasfilm.drivers.simulated import SimulatedNI9234

RATE_HZ = 51200.0 / 8
RECORD_SAMPLES = 1600  # 0.25 s
#: ai1 carries an accelerometer configured with a third of its true sensitivity: it reads 3 × the response, so an
#: FRF taken on ai1 instead of ai2 is 3 × too large (and far from the mass line 1/m).
AI1_SCALE = 3.0


def three_channel_config() -> DaqConfig:
    return DaqConfig(
        channels=(
            ChannelConfig("ai0", ChannelKind.FORCE, 11.2, "mV/N", name="hammer"),
            ChannelConfig("ai1", ChannelKind.ACCELERATION, 10.2 / AI1_SCALE, "mV/(m/s^2)", name="unused"),
            ChannelConfig("ai2", ChannelKind.ACCELERATION, 10.2, "mV/(m/s^2)", name="response"),
        ),
        sample_rate_hz=RATE_HZ,
    )


def simulated_records(config: DaqConfig, hits: int = 6, seed: int = 5) -> np.ndarray:
    device = SimulatedNI9234(RigPlant.nominal(), seed=seed, pacing="fast", hit_interval_s=None)
    device.configure(config)
    with device:
        device.start()
        return device.sim_record_hits(hits, RECORD_SAMPLES)


def write_session(path, config: DaqConfig, records: np.ndarray, response_channel: int) -> None:
    with Session.create(path, config, RigSpec.nominal("FOMGF").to_toml(), {"window": WindowSettings()},
                        actual_sample_rate_hz=RATE_HZ) as session:
        for index, record in enumerate(records):
            hit = HitRecord(index, record, RATE_HZ, trigger_sample(record[0]), 0.5 * index,
                            np.zeros(len(config.channels), bool), force_channel=0, response_channel=response_channel)
            session.append_hit(hit, Verdict(True))


@pytest.fixture(scope="module")
def records() -> np.ndarray:
    return simulated_records(three_channel_config())


def test_accumulator_hit_by_hit_equals_the_batched_average(records):
    window = WindowSettings(force_window_ms=5.0, exponential_end_fraction=0.1)
    accumulator = FrfAccumulator(RATE_HZ, RECORD_SAMPLES, window, capacity_hits=1)  # grows while hits come
    running = []
    for index, record in enumerate(records):
        accumulator.add_hit(HitRecord(index, record, RATE_HZ, 0, 0.0, force_channel=0, response_channel=2))
        running.append(accumulator.result())
    batched = compute_frf(records, RATE_HZ, window, force_row=0, response_row=2)
    final = running[-1]
    assert final.n_averages == len(records) and running[0].n_averages == 1
    for name in ("h1", "h2", "coherence", "gff", "gxx", "gfx", "h1_std_coherence", "h1_std_scatter", "h1_per_hit"):
        np.testing.assert_allclose(getattr(final, name), getattr(batched, name), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(running[2].h1, compute_frf(records[:3], RATE_HZ, window, 0, 2).h1, rtol=1e-12)


def test_session_frf_takes_each_hits_own_channels(records):
    hits = [HitRecord(i, r, RATE_HZ, 0, 0.0, force_channel=0, response_channel=2) for i, r in enumerate(records)]
    on_ai2 = session_frf(hits)
    np.testing.assert_allclose(on_ai2.h1, compute_frf(records, RATE_HZ, force_row=0, response_row=2).h1, rtol=1e-12)
    on_ai1 = compute_frf(records, RATE_HZ, force_row=0, response_row=1)
    band = (on_ai2.freq_hz > 20) & (on_ai2.freq_hz < 1000)
    ratio = np.median(np.abs(on_ai1.h1[band]) / np.abs(on_ai2.h1[band]))
    assert ratio == pytest.approx(AI1_SCALE, rel=0.02)  # the two channels really differ
    with pytest.raises(SettingError, match="different lengths"):
        session_frf([hits[0], HitRecord(9, records[0][:, :-2], RATE_HZ, 0, 0.0)])


@pytest.mark.parametrize("response_channel, mass_line_ok", [(2, True), (1, False)])
def test_a_session_recorded_on_ai2_is_fitted_on_ai2(tmp_path, capsys, records, response_channel, mass_line_ok):
    path = tmp_path / "ai2.h5"
    write_session(path, three_channel_config(), records, response_channel)
    status = main(["fit", str(path), "--models", "SD", "--band", "20:1000", "--json", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    assert status == 0, err
    result = json.loads(out)
    expected = compute_frf(records, RATE_HZ, force_row=0, response_row=response_channel)
    band = (expected.freq_hz >= 20) & (expected.freq_hz <= 1000)
    level = float(np.sqrt(np.mean(np.abs(expected.h1[band]) ** 2)))
    # on ai2 the mass-on-film model follows the FRF closely; on the 3×-scaled ai1 no film on 25.05 kg can
    assert (result["fits"][0]["rms"] < 0.2 * level) == mass_line_ok
    # the JSON says the unit of its RMS and gives it in g/N too, as the diagnosis's does (new-user trial)
    fit = result["fits"][0]
    assert fit["rms_unit"] == "(m/s^2)/N" and fit["rms_g_per_n"] == pytest.approx(fit["rms"] / 9.80665)
    assert fit["peak_error_g_per_n"] == pytest.approx(fit["peak_error"] / 9.80665)
    assert (result["mass_line_warning"] is None) == mass_line_ok
    assert ("not a mass on a gas film" in err) == (not mass_line_ok)
    csv = tmp_path / "frf.csv"
    assert main(["export", str(path), "--csv", str(csv)]) == 0
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 1] + 1j * table[:, 2], expected.h1, rtol=1e-9)


def test_settings_decoder_defaults_ignores_unknown_fields_and_names_the_file():
    assert decode_settings({}) == ProcessingSettings()
    decoded = decode_settings({"trigger": {"level_n": 35.0, "from_the_future": 1}, "window": {"force_window_ms": 3}})
    assert decoded.trigger.level_n == 35.0 and decoded.window.force_window_ms == 3
    assert decoded.validation == ProcessingSettings().validation
    with pytest.raises(SettingError, match=r"^run\.h5: the stored 'trigger' settings are unusable: record_s"):
        decode_settings({"trigger": {"record_s": -1.0}}, "run.h5")
    with pytest.raises(SettingError, match=r"^run\.h5: the stored 'window' settings are not a table"):
        decode_settings({"window": [1, 2]}, "run.h5")
    with pytest.raises(SettingError, match="unusable"):
        decode_settings({"validation": {"double_hit_fraction": "half"}}, "run.h5")


def test_a_session_with_damaged_settings_gets_one_line(tmp_path, capsys, records):
    path = tmp_path / "damaged.h5"
    write_session(path, three_channel_config(), records, 2)
    with Session.open(path, "a") as session:
        session.update_settings({"window": {"exponential_end_fraction": 7.0}})
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "damaged.h5: the stored 'window' settings are unusable" in err
