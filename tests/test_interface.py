"""The NI 9234's rules: every invalid setting gives one line naming the setting and the allowed values."""

import dataclasses

import pytest

from gasfilm.drivers import open_device
from gasfilm.drivers.errors import SettingError
from gasfilm.drivers.interface import (
    NI9234_VALID_RATES_HZ,
    ChannelConfig,
    ChannelKind,
    Coupling,
    DaqConfig,
    default_hammer_and_accelerometer,
    validate_config,
)


def _with_channel(**changes):
    config = default_hammer_and_accelerometer()
    hammer = dataclasses.replace(config.channels[0], **changes)
    return dataclasses.replace(config, channels=(hammer, config.channels[1]))


def _one_line_error(config) -> str:
    with pytest.raises(SettingError) as caught:
        validate_config(config)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_valid_rates_are_51200_over_n():
    assert len(NI9234_VALID_RATES_HZ) == 31
    assert NI9234_VALID_RATES_HZ[0] == 51200.0 and NI9234_VALID_RATES_HZ[-1] == pytest.approx(51200 / 31)
    validate_config(default_hammer_and_accelerometer(51200 / 7))


def test_rate_50000_is_rejected_with_nearest_valid_rates():
    message = _one_line_error(dataclasses.replace(default_hammer_and_accelerometer(), sample_rate_hz=50_000.0))
    assert "sample_rate_hz" in message and "51200/n" in message
    assert "51200 S/s" in message and "25600 S/s" in message


def test_channel_ai7_is_rejected_naming_allowed_channels():
    message = _one_line_error(_with_channel(physical_channel="ai7"))
    assert "ai7" in message and "ai0, ai1, ai2, ai3" in message


@pytest.mark.parametrize("sensitivity", [0.0, -11.2, float("nan")])
def test_non_positive_sensitivity_is_rejected(sensitivity):
    message = _one_line_error(_with_channel(sensitivity=sensitivity))
    assert "sensitivity" in message and "positive" in message


def test_dc_coupling_with_iepe_is_rejected():
    message = _one_line_error(_with_channel(coupling=Coupling.DC))
    assert "coupling" in message and "IEPE" in message and "allowed: AC" in message


def test_dc_coupling_without_iepe_is_allowed():
    validate_config(_with_channel(coupling=Coupling.DC, iepe_current_a=0.0))


def test_iepe_current_other_than_2ma_is_rejected():
    message = _one_line_error(_with_channel(iepe_current_a=0.004))
    assert "iepe_current_a" in message and "0.002" in message


def test_five_channels_and_duplicates_are_rejected():
    hammer = default_hammer_and_accelerometer().channels[0]
    five = tuple(dataclasses.replace(hammer, physical_channel=f"ai{i % 4}") for i in range(5))
    assert "4 channels" in _one_line_error(DaqConfig(five))
    assert "twice" in _one_line_error(DaqConfig((hammer, hammer)))


def test_wrong_sensitivity_units_name_the_allowed_ones():
    message = _one_line_error(_with_channel(sensitivity_units="mV/g"))
    assert "mV/N" in message


def test_sensitivity_conversions():
    accelerometer = ChannelConfig("ai1", ChannelKind.ACCELERATION, 100.0, "mV/g")
    assert accelerometer.sensitivity_v_per_si == pytest.approx(0.1 / 9.80665)
    hammer = default_hammer_and_accelerometer().channels[0]
    assert hammer.full_scale_si == pytest.approx(5.0 / 0.0112)


def test_open_device_names_options_that_do_not_apply():
    with pytest.raises(SettingError, match="only apply to the simulated device"):
        open_device("cDAQ1Mod1", seed=3)
