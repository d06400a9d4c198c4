"""The real NI 9234 backend at the ``nidaqmx`` boundary (no NI driver needed).

Two levels, both with ``create_autospec`` so that a wrong method, argument or property name fails:
- ``nidaqmx.Task`` and ``AnalogMultiChannelReader`` replaced by autospecs: every call and argument of the backend;
- NI's own unit-test set-up: a real ``nidaqmx.Task`` over an autospec of nidaqmx's ``BaseInterpreter``, so the
  values reaching the DAQmx C API (enum values, attribute ids) are checked too.
"""

from __future__ import annotations

import dataclasses
import warnings
from unittest import mock

import nidaqmx
import nidaqmx.errors
import nidaqmx.stream_readers
import nidaqmx.utils
import numpy as np
import pytest
from nidaqmx._base_interpreter import BaseInterpreter
from nidaqmx.constants import (
    AccelSensitivityUnits,
    AccelUnits,
    AcquisitionType,
    Edge,
    ExcitationSource,
    FillMode,
    ForceIEPESensorSensitivityUnits,
    ForceUnits,
    TaskMode,
    TerminalConfiguration,
)
from nidaqmx.constants import Coupling as DaqmxCoupling
from nidaqmx.task import InStream, Timing
from nidaqmx.task.channels import AIChannel
from nidaqmx.task.collections import AIChannelCollection

from gasfilm.drivers import open_device
from gasfilm.drivers.errors import (
    ADCOverloadWarning,
    BufferOverflowError,
    DeviceError,
    DeviceRemovedError,
    DeviceReservedError,
    FellBehindError,
    GasfilmWarning,
    OpenSensorError,
    ReadTimeoutError,
    SettingError,
)
from gasfilm.drivers.interface import (
    SENSITIVITY_UNITS,
    ChannelKind,
    Coupling,
    DaqDevice,
    default_hammer_and_accelerometer,
)
from gasfilm.drivers.nidaqmx_backend import DAQMX_SENSITIVITY_FACTORS, NidaqmxNI9234

DEVICE = "cDAQ1Mod1"
RATE_HZ = 51200.0 / 4
CHUNK = 1280
HOST_BUFFER_SAMPLES = 64000  # 5 s at 12.8 kS/s
HAMMER_FULL_SCALE_N = 5.0 / 11.2e-3
ACCEL_FULL_SCALE_M_S2 = 5.0 / 10.2e-3
ACCEL_MV_PER_G = 10.2 * 9.80665  # 100.02783 mV/g


@dataclasses.dataclass
class FakeDaqmx:
    """The autospecced DAQmx objects one test sees."""

    task_class: mock.Mock
    task: mock.Mock
    force_channel: mock.Mock
    accel_channel: mock.Mock
    reader_class: mock.Mock
    reader: mock.Mock


@pytest.fixture
def daqmx(monkeypatch: pytest.MonkeyPatch) -> FakeDaqmx:
    task_class = mock.create_autospec(nidaqmx.Task, spec_set=True)
    task = task_class.return_value
    # Properties of an autospec are not specced; give them autospecs of the classes nidaqmx returns.
    task.ai_channels = mock.create_autospec(AIChannelCollection, instance=True, spec_set=True)
    task.timing = mock.create_autospec(Timing, instance=True, spec_set=True)
    task.in_stream = mock.create_autospec(InStream, instance=True, spec_set=True)
    force_channel = mock.create_autospec(AIChannel, instance=True, spec_set=True)
    accel_channel = mock.create_autospec(AIChannel, instance=True, spec_set=True)
    task.ai_channels.add_ai_force_iepe_chan.return_value = force_channel
    task.ai_channels.add_ai_accel_chan.return_value = accel_channel
    task.timing.samp_clk_rate = RATE_HZ
    task.in_stream.overloaded_chans_exist = False
    task.in_stream.overloaded_chans = []
    task.in_stream.open_chans_exist = False
    task.in_stream.open_chans = []
    reader_class = mock.create_autospec(nidaqmx.stream_readers.AnalogMultiChannelReader, spec_set=True)
    reader = reader_class.return_value

    def fill(data, number_of_samples_per_channel, timeout):
        data[:, :number_of_samples_per_channel] = np.arange(data.shape[0])[:, None] + 0.5
        return number_of_samples_per_channel

    reader.read_many_sample.side_effect = fill
    monkeypatch.setattr(nidaqmx, "Task", task_class)
    monkeypatch.setattr(nidaqmx.stream_readers, "AnalogMultiChannelReader", reader_class)
    return FakeDaqmx(task_class, task, force_channel, accel_channel, reader_class, reader)


def _configured(daqmx: FakeDaqmx, config=None) -> NidaqmxNI9234:
    device = NidaqmxNI9234(DEVICE)
    device.configure(config or default_hammer_and_accelerometer(RATE_HZ))
    return device


def _buffer(samples: int = CHUNK) -> np.ndarray:
    return np.zeros((2, samples))


def _call_names(task_class: mock.Mock) -> list[str]:
    return [name for name, _args, _kwargs in task_class.mock_calls]


# -- configuration ---------------------------------------------------------------------------------------------------


def test_configure_adds_hammer_and_accelerometer_with_every_argument(daqmx: FakeDaqmx) -> None:
    _configured(daqmx)

    daqmx.task_class.assert_called_once_with()
    daqmx.task.ai_channels.add_ai_force_iepe_chan.assert_called_once_with(
        physical_channel="cDAQ1Mod1/ai0",
        name_to_assign_to_channel="force_ai0",
        terminal_config=TerminalConfiguration.DEFAULT,
        min_val=pytest.approx(-HAMMER_FULL_SCALE_N, rel=1e-12),
        max_val=pytest.approx(HAMMER_FULL_SCALE_N, rel=1e-12),
        units=ForceUnits.NEWTONS,
        sensitivity=pytest.approx(11.2, rel=1e-12),
        sensitivity_units=ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON,
        current_excit_source=ExcitationSource.INTERNAL,
        current_excit_val=0.002,
    )
    daqmx.task.ai_channels.add_ai_accel_chan.assert_called_once_with(
        physical_channel="cDAQ1Mod1/ai1",
        name_to_assign_to_channel="acceleration_ai1",
        terminal_config=TerminalConfiguration.DEFAULT,
        min_val=pytest.approx(-ACCEL_FULL_SCALE_M_S2, rel=1e-12),
        max_val=pytest.approx(ACCEL_FULL_SCALE_M_S2, rel=1e-12),
        units=AccelUnits.METERS_PER_SECOND_SQUARED,
        sensitivity=pytest.approx(ACCEL_MV_PER_G, rel=1e-12),
        sensitivity_units=AccelSensitivityUnits.MILLIVOLTS_PER_G,
        current_excit_source=ExcitationSource.INTERNAL,
        current_excit_val=0.002,
    )
    accel_kwargs = daqmx.task.ai_channels.add_ai_accel_chan.call_args.kwargs
    assert round(accel_kwargs["sensitivity"], 2) == 100.03
    assert daqmx.force_channel.ai_coupling is DaqmxCoupling.AC
    assert daqmx.accel_channel.ai_coupling is DaqmxCoupling.AC
    assert _call_names(daqmx.task_class).count("().ai_channels.add_ai_force_iepe_chan") == 1
    assert _call_names(daqmx.task_class).count("().ai_channels.add_ai_accel_chan") == 1


def test_sample_clock_is_continuous_and_configured_before_commit_and_start(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()

    daqmx.task.timing.cfg_samp_clk_timing.assert_called_once_with(
        RATE_HZ, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=HOST_BUFFER_SAMPLES
    )
    daqmx.task.control.assert_called_once_with(TaskMode.TASK_COMMIT)
    daqmx.task.start.assert_called_once_with()
    names = _call_names(daqmx.task_class)
    clock = names.index("().timing.cfg_samp_clk_timing")
    assert clock < names.index("().control") < names.index("().start")
    assert all(name.startswith("().ai_channels.") for name in names[1:clock])
    daqmx.reader_class.assert_called_once_with(daqmx.task.in_stream)
    assert device.sample_rate_hz == RATE_HZ
    assert device.config.sample_rate_hz == RATE_HZ


def test_coerced_sample_rate_is_an_error_and_releases_the_task(daqmx: FakeDaqmx) -> None:
    daqmx.task.timing.samp_clk_rate = 12_500.0
    device = NidaqmxNI9234(DEVICE)
    with pytest.raises(SettingError) as caught:
        device.configure(default_hammer_and_accelerometer(RATE_HZ))
    message = str(caught.value)
    assert "\n" not in message
    assert "sample_rate_hz" in message and "12500 S/s" in message and "12800 S/s" in message and DEVICE in message
    daqmx.task.close.assert_called_once_with()
    with pytest.raises(DeviceError):
        device.start()


@pytest.mark.parametrize(
    ("units", "sensitivity", "expected_mv_per_g"),
    [("mV/(m/s^2)", 10.2, 10.2 * 9.80665), ("mV/g", 100.0, 100.0), ("V/g", 0.1, 100.0)],
)
def test_accelerometer_sensitivity_reaches_daqmx_in_mv_per_g(
    daqmx: FakeDaqmx, units: str, sensitivity: float, expected_mv_per_g: float
) -> None:
    config = default_hammer_and_accelerometer(RATE_HZ)
    accel = dataclasses.replace(config.channels[1], sensitivity=sensitivity, sensitivity_units=units)
    _configured(daqmx, dataclasses.replace(config, channels=(config.channels[0], accel)))
    kwargs = daqmx.task.ai_channels.add_ai_accel_chan.call_args.kwargs
    assert kwargs["sensitivity"] == pytest.approx(expected_mv_per_g, rel=1e-12)
    assert kwargs["sensitivity_units"] is AccelSensitivityUnits.MILLIVOLTS_PER_G
    if units == "mV/g":
        assert kwargs["sensitivity"] == sensitivity  # given as is, no round trip through m/s²
    # ±5 V in m/s²: full scale in g times 9.80665
    assert kwargs["max_val"] == pytest.approx(5000.0 / expected_mv_per_g * 9.80665, rel=1e-12)


def test_force_sensitivity_in_volts_per_newton_reaches_daqmx_in_mv_per_n(daqmx: FakeDaqmx) -> None:
    config = default_hammer_and_accelerometer(RATE_HZ)
    hammer = dataclasses.replace(config.channels[0], sensitivity=0.0112, sensitivity_units="V/N")
    _configured(daqmx, dataclasses.replace(config, channels=(hammer, config.channels[1])))
    kwargs = daqmx.task.ai_channels.add_ai_force_iepe_chan.call_args.kwargs
    assert kwargs["sensitivity"] == pytest.approx(11.2, rel=1e-12)
    assert kwargs["max_val"] == pytest.approx(HAMMER_FULL_SCALE_N, rel=1e-12)


def test_every_interface_sensitivity_unit_has_a_daqmx_factor() -> None:
    for kind in ChannelKind:
        assert set(DAQMX_SENSITIVITY_FACTORS[kind]) == set(SENSITIVITY_UNITS[kind])


def test_iepe_off_means_no_excitation_dc_coupling_and_no_open_channel_query(daqmx: FakeDaqmx) -> None:
    config = default_hammer_and_accelerometer(RATE_HZ)
    channels = tuple(
        dataclasses.replace(channel, iepe_current_a=0.0, coupling=Coupling.DC) for channel in config.channels
    )
    open_exist = mock.PropertyMock(return_value=False)
    type(daqmx.task.in_stream).open_chans_exist = open_exist
    device = _configured(daqmx, dataclasses.replace(config, channels=channels))
    for method in (daqmx.task.ai_channels.add_ai_force_iepe_chan, daqmx.task.ai_channels.add_ai_accel_chan):
        assert method.call_args.kwargs["current_excit_source"] is ExcitationSource.NONE
        assert method.call_args.kwargs["current_excit_val"] == 0.0
    assert daqmx.force_channel.ai_coupling is DaqmxCoupling.DC
    assert daqmx.accel_channel.ai_coupling is DaqmxCoupling.DC
    device.start()
    device.read(_buffer())
    open_exist.assert_not_called()


def test_invalid_setting_is_rejected_before_any_daqmx_call(daqmx: FakeDaqmx) -> None:
    config = dataclasses.replace(default_hammer_and_accelerometer(RATE_HZ), sample_rate_hz=50_000.0)
    with pytest.raises(SettingError, match="sample_rate_hz"):
        NidaqmxNI9234(DEVICE).configure(config)
    daqmx.task_class.assert_not_called()


def test_reconfigure_closes_the_previous_task(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    daqmx.task.timing.samp_clk_rate = 51200.0 / 8
    device.configure(default_hammer_and_accelerometer(51200.0 / 8))
    assert daqmx.task_class.call_count == 2
    daqmx.task.close.assert_called_once_with()
    assert device.sample_rate_hz == 6400.0


# -- reading ---------------------------------------------------------------------------------------------------------


def test_read_fills_the_preallocated_buffer_itself(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    buffer = _buffer()
    samples = device.read(buffer, timeout_s=2.5)

    assert samples == CHUNK
    daqmx.reader.read_many_sample.assert_called_once_with(
        buffer, number_of_samples_per_channel=CHUNK, timeout=2.5
    )
    assert daqmx.reader.read_many_sample.call_args.args[0] is buffer
    np.testing.assert_array_equal(buffer[:, 0], [0.5, 1.5])
    status = device.status()
    np.testing.assert_array_equal(status.overload, [False, False])
    np.testing.assert_array_equal(status.open_sensor, [False, False])


def test_read_rejects_a_buffer_daqmx_cannot_fill_in_place(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    with pytest.raises(SettingError, match="read buffer"):
        device.read(np.zeros((2, CHUNK), np.float32))
    with pytest.raises(SettingError, match="read buffer"):
        device.read(np.zeros((CHUNK, 2)).T)
    daqmx.reader.read_many_sample.assert_not_called()


def test_overloaded_channel_warns_and_sets_its_flag(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    daqmx.task.in_stream.overloaded_chans_exist = True
    daqmx.task.in_stream.overloaded_chans = ["acceleration_ai1"]
    with pytest.warns(ADCOverloadWarning) as caught:
        device.read(_buffer())
    message = str(caught[0].message)
    assert "ai1" in message and "ai0" not in message and DEVICE in message and "\n" not in message
    np.testing.assert_array_equal(device.status().overload, [False, True])

    daqmx.task.in_stream.overloaded_chans_exist = False
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        device.read(_buffer())
    np.testing.assert_array_equal(device.status().overload, [False, False])


def test_open_iepe_sensor_raises_after_delivering_the_chunk(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    daqmx.task.in_stream.open_chans_exist = True
    daqmx.task.in_stream.open_chans = ["force_ai0"]
    buffer = _buffer()
    with pytest.raises(OpenSensorError) as caught:
        device.read(buffer)
    message = str(caught.value)
    assert "ai0" in message and "ai1" not in message and DEVICE in message and "\n" not in message
    np.testing.assert_array_equal(buffer[:, -1], [0.5, 1.5])
    np.testing.assert_array_equal(device.status().open_sensor, [True, False])


def test_device_without_open_channel_reporting_warns_once_and_keeps_reading(daqmx: FakeDaqmx) -> None:
    unsupported = nidaqmx.errors.DaqError("Specified property is not supported by the device.", -200452)
    open_exist = mock.PropertyMock(side_effect=unsupported)
    type(daqmx.task.in_stream).open_chans_exist = open_exist
    device = _configured(daqmx)
    device.start()
    with pytest.warns(GasfilmWarning, match="open IEPE sensors will not be flagged"):
        device.read(_buffer())
    device.read(_buffer())
    open_exist.assert_called_once_with()


# -- error translation -----------------------------------------------------------------------------------------------

TRANSLATED_CODES = [
    (-200279, FellBehindError),
    (-200284, ReadTimeoutError),
    (-200010, BufferOverflowError),
    (-200361, BufferOverflowError),
    (-201003, DeviceRemovedError),
    (-50103, DeviceReservedError),
]


def _assert_one_line(error: Exception, code: int) -> None:
    message = str(error)
    assert "\n" not in message
    assert DEVICE in message and str(code) in message
    assert isinstance(error.__cause__, nidaqmx.errors.DaqError)


@pytest.mark.parametrize(("code", "error_type"), TRANSLATED_CODES)
def test_read_errors_become_project_errors(daqmx: FakeDaqmx, code: int, error_type: type) -> None:
    device = _configured(daqmx)
    device.start()
    daqmx.reader.read_many_sample.side_effect = nidaqmx.errors.DaqReadError(
        f"DAQmx says no.\nStatus Code: {code}", code, 0
    )
    with pytest.raises(error_type) as caught:
        device.read(_buffer())
    assert type(caught.value) is error_type
    assert caught.value.code == code
    _assert_one_line(caught.value, code)


@pytest.mark.parametrize(("code", "error_type"), TRANSLATED_CODES)
def test_start_errors_become_project_errors(daqmx: FakeDaqmx, code: int, error_type: type) -> None:
    device = _configured(daqmx)
    daqmx.task.start.side_effect = nidaqmx.errors.DaqError("DAQmx says no.", code)
    with pytest.raises(error_type) as caught:
        device.start()
    assert caught.value.code == code
    _assert_one_line(caught.value, code)


def test_reserved_device_at_commit_is_reported_and_the_task_released(daqmx: FakeDaqmx) -> None:
    daqmx.task.control.side_effect = nidaqmx.errors.DaqError("The specified resource is reserved.", -50103)
    with pytest.raises(DeviceReservedError) as caught:
        NidaqmxNI9234(DEVICE).configure(default_hammer_and_accelerometer(RATE_HZ))
    assert "committing" in str(caught.value)
    _assert_one_line(caught.value, -50103)
    daqmx.task.close.assert_called_once_with()


def test_removed_device_while_adding_a_channel_is_reported(daqmx: FakeDaqmx) -> None:
    daqmx.task.ai_channels.add_ai_accel_chan.side_effect = nidaqmx.errors.DaqError("Device gone.", -201003)
    with pytest.raises(DeviceRemovedError) as caught:
        NidaqmxNI9234(DEVICE).configure(default_hammer_and_accelerometer(RATE_HZ))
    assert "ai1" in str(caught.value)
    daqmx.task.close.assert_called_once_with()


def test_partial_read_before_an_error_is_named(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    daqmx.reader.read_many_sample.side_effect = nidaqmx.errors.DaqReadError("Timed out.", -200284, 300)
    with pytest.raises(ReadTimeoutError, match="300 samples per channel were read"):
        device.read(_buffer())


def test_other_daqmx_errors_become_device_errors_with_their_code(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()
    daqmx.reader.read_many_sample.side_effect = nidaqmx.errors.DaqReadError(
        "Requested value is not a supported value for this property.\nProperty: AI.Max", -200077, 0
    )
    with pytest.raises(DeviceError) as caught:
        device.read(_buffer())
    assert type(caught.value) is DeviceError
    assert caught.value.code == -200077
    assert "Requested value is not a supported value" in str(caught.value)
    _assert_one_line(caught.value, -200077)


def test_daqmx_adc_overload_warning_becomes_adc_overload_warning(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()

    def read_with_warning(data, number_of_samples_per_channel, timeout):
        warnings.warn(nidaqmx.errors.DaqWarning("ADC has been overloaded.", 200005))
        return number_of_samples_per_channel

    daqmx.reader.read_many_sample.side_effect = read_with_warning
    daqmx.task.in_stream.overloaded_chans_exist = True
    daqmx.task.in_stream.overloaded_chans = ["force_ai0"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        device.read(_buffer())
    categories = [type(w.message) for w in caught]
    assert categories == [ADCOverloadWarning]
    assert caught[0].message.code == 200005 and "ai0" in str(caught[0].message)
    np.testing.assert_array_equal(device.status().overload, [True, False])


def test_daqmx_adc_overload_warning_without_channel_names_flags_every_channel(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)
    device.start()

    def read_with_warning(data, number_of_samples_per_channel, timeout):
        warnings.warn(nidaqmx.errors.DaqWarning("ADC has been overloaded.", 200005))
        return number_of_samples_per_channel

    daqmx.reader.read_many_sample.side_effect = read_with_warning
    with pytest.warns(ADCOverloadWarning, match="200005"):
        device.read(_buffer())
    np.testing.assert_array_equal(device.status().overload, [True, True])


def test_other_daqmx_warnings_become_gasfilm_warnings_and_foreign_warnings_pass(daqmx: FakeDaqmx) -> None:
    device = _configured(daqmx)

    def start_with_warnings():
        warnings.warn(nidaqmx.errors.DaqWarning("Stopped before done.", 200010))
        warnings.warn("unrelated", RuntimeWarning)

    daqmx.task.start.side_effect = start_with_warnings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        device.start()
    categories = sorted(type(w.message).__name__ for w in caught)
    assert categories == ["GasfilmWarning", "RuntimeWarning"]
    gasfilm = next(w.message for w in caught if isinstance(w.message, GasfilmWarning))
    assert "200010" in str(gasfilm) and "Stopped before done." in str(gasfilm) and "\n" not in str(gasfilm)


@pytest.mark.parametrize(
    "missing",
    [
        nidaqmx.errors.DaqNotFoundError("Could not find an installation of NI-DAQmx."),
        nidaqmx.errors.DaqNotSupportedError("NI-DAQmx Python is not supported on this platform: sunos5."),
    ],
)
def test_missing_ni_daqmx_driver_says_so_and_points_to_sim(daqmx: FakeDaqmx, missing: Exception) -> None:
    daqmx.task_class.side_effect = missing
    with pytest.raises(DeviceError) as caught:
        NidaqmxNI9234(DEVICE).configure(default_hammer_and_accelerometer(RATE_HZ))
    message = str(caught.value)
    assert "NI-DAQmx driver is not installed" in message and "'sim'" in message and DEVICE in message


def test_too_old_ni_daqmx_driver_is_a_device_error(daqmx: FakeDaqmx) -> None:
    daqmx.task.control.side_effect = nidaqmx.errors.DaqFunctionNotSupportedError("DAQmxTaskControl not found.")
    with pytest.raises(DeviceError, match="too old for committing the task") as caught:
        NidaqmxNI9234(DEVICE).configure(default_hammer_and_accelerometer(RATE_HZ))
    assert "\n" not in str(caught.value)


def test_unpatched_nidaqmx_without_driver_gives_a_device_error() -> None:
    # No mocks. Without the NI-DAQmx runtime nidaqmx raises on Task creation; with it, DAQmx rejects the name.
    with pytest.raises(DeviceError, match="NoSuchModule"):
        NidaqmxNI9234("NoSuchModule").configure(default_hammer_and_accelerometer(RATE_HZ))


# -- life cycle ------------------------------------------------------------------------------------------------------


def test_stop_close_and_context_manager(daqmx: FakeDaqmx) -> None:
    with _configured(daqmx) as device:
        device.start()
        device.read(_buffer())
        device.stop()
        daqmx.task.stop.assert_called_once_with()
    daqmx.task.close.assert_called_once_with()
    device.close()
    device.stop()
    daqmx.task.close.assert_called_once_with()
    with pytest.raises(DeviceError, match="configure"):
        device.read(_buffer())


def test_use_before_configure_is_a_clear_error() -> None:
    device = NidaqmxNI9234(DEVICE)
    for action in (device.start, lambda: device.read(_buffer()), lambda: device.sample_rate_hz):
        with pytest.raises(DeviceError, match="configure"):
            action()


def test_open_device_with_an_ni_name_returns_the_nidaqmx_backend(daqmx: FakeDaqmx) -> None:
    device = open_device(DEVICE)
    assert isinstance(device, NidaqmxNI9234)
    assert device.name == DEVICE
    device.configure(default_hammer_and_accelerometer(RATE_HZ))
    assert isinstance(device, DaqDevice)  # on Python 3.11 this reads the properties, so only once configured
    daqmx.task_class.assert_called_once_with()
    assert daqmx.task.ai_channels.add_ai_force_iepe_chan.call_args.kwargs["physical_channel"] == "cDAQ1Mod1/ai0"
    device.close()


# -- NI's own set-up: a real nidaqmx.Task over an autospecced interpreter ------------------------------------------

HANDLE = "SomeTaskHandle"
CHANNEL_NAMES = "force_ai0, acceleration_ai1"


def _by_attribute(values: dict[int, object]):
    """A side effect for the interpreter's ``get_*_attribute_*(task, attribute, ...)`` methods."""
    return lambda task, attribute, *size_hint: values[attribute]


@pytest.fixture
def interpreter(monkeypatch: pytest.MonkeyPatch) -> mock.Mock:
    fake = mock.create_autospec(BaseInterpreter, instance=True)
    select = mock.create_autospec(nidaqmx.utils._select_interpreter, return_value=fake)
    monkeypatch.setattr(nidaqmx.utils, "_select_interpreter", select)
    fake.create_task.return_value = (HANDLE, True)
    fake.get_task_attribute_string.side_effect = _by_attribute({0x1276: "gasfilm", 0x1273: CHANNEL_NAMES})
    fake.internal_get_last_created_chan.side_effect = NotImplementedError
    fake.get_timing_attribute_double.side_effect = _by_attribute({0x1344: RATE_HZ})
    fake.get_read_attribute_uint32.side_effect = _by_attribute({0x217B: 2})  # channels per read
    fake.get_read_attribute_bool.side_effect = _by_attribute({0x2174: False, 0x3100: False})

    def read_analog_f64(task, num_samps_per_chan, timeout, fill_mode, read_array):
        read_array[:] = 1.0
        return read_array, num_samps_per_chan

    fake.read_analog_f64.side_effect = read_analog_f64
    return fake


def test_daqmx_c_api_sees_the_right_values(interpreter: mock.Mock) -> None:
    device = NidaqmxNI9234(DEVICE)
    device.configure(default_hammer_and_accelerometer(RATE_HZ))
    device.start()
    buffer = _buffer()
    assert device.read(buffer, timeout_s=1.5) == CHUNK
    device.close()

    interpreter.create_ai_force_iepe_chan.assert_called_once_with(
        HANDLE, "cDAQ1Mod1/ai0", "force_ai0", TerminalConfiguration.DEFAULT.value,
        pytest.approx(-HAMMER_FULL_SCALE_N), pytest.approx(HAMMER_FULL_SCALE_N), ForceUnits.NEWTONS.value,
        pytest.approx(11.2), ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON.value,
        ExcitationSource.INTERNAL.value, 0.002, "",
    )  # fmt: skip
    interpreter.create_ai_accel_chan.assert_called_once_with(
        HANDLE, "cDAQ1Mod1/ai1", "acceleration_ai1", TerminalConfiguration.DEFAULT.value,
        pytest.approx(-ACCEL_FULL_SCALE_M_S2), pytest.approx(ACCEL_FULL_SCALE_M_S2),
        AccelUnits.METERS_PER_SECOND_SQUARED.value, pytest.approx(ACCEL_MV_PER_G),
        AccelSensitivityUnits.MILLIVOLTS_PER_G.value, ExcitationSource.INTERNAL.value, 0.002, "",
    )  # fmt: skip
    ai_coupling = 0x64
    interpreter.set_chan_attribute_int32.assert_has_calls(
        [
            mock.call(HANDLE, "force_ai0", ai_coupling, DaqmxCoupling.AC.value),
            mock.call(HANDLE, "acceleration_ai1", ai_coupling, DaqmxCoupling.AC.value),
        ]
    )
    interpreter.cfg_samp_clk_timing.assert_called_once_with(
        HANDLE, RATE_HZ, "", Edge.RISING.value, AcquisitionType.CONTINUOUS.value, HOST_BUFFER_SAMPLES
    )
    interpreter.task_control.assert_called_once_with(HANDLE, TaskMode.TASK_COMMIT.value)
    interpreter.read_analog_f64.assert_called_once_with(
        HANDLE, CHUNK, 1.5, FillMode.GROUP_BY_CHANNEL.value, buffer
    )
    assert interpreter.read_analog_f64.call_args.args[4] is buffer
    np.testing.assert_array_equal(buffer, 1.0)
    overloaded_chans_exist, open_chans_exist = 0x2174, 0x3100
    interpreter.get_read_attribute_bool.assert_has_calls(
        [mock.call(HANDLE, overloaded_chans_exist), mock.call(HANDLE, open_chans_exist)]
    )
    names = [name for name, _args, _kwargs in interpreter.mock_calls]
    clock = names.index("cfg_samp_clk_timing")
    assert clock < names.index("task_control") < names.index("start_task") < names.index("read_analog_f64")
    assert "get_timing_attribute_double" in names[clock:names.index("start_task")]
    interpreter.clear_task.assert_called_once_with(HANDLE)


def test_daqmx_c_api_overload_channel_names_map_to_flags(interpreter: mock.Mock) -> None:
    interpreter.get_read_attribute_bool.side_effect = _by_attribute({0x2174: True, 0x3100: False})
    interpreter.get_read_attribute_string.side_effect = _by_attribute({0x2175: "acceleration_ai1"})
    with NidaqmxNI9234(DEVICE) as device:
        device.configure(default_hammer_and_accelerometer(RATE_HZ))
        device.start()
        with pytest.warns(ADCOverloadWarning, match="ai1"):
            device.read(_buffer())
        np.testing.assert_array_equal(device.status().overload, [False, True])


def test_daqmx_c_api_read_error_is_translated(interpreter: mock.Mock) -> None:
    interpreter.read_analog_f64.side_effect = nidaqmx.errors.DaqReadError(
        "Attempted to read samples that are no longer available.", -200279, 0
    )
    with NidaqmxNI9234(DEVICE) as device:
        device.configure(default_hammer_and_accelerometer(RATE_HZ))
        device.start()
        with pytest.raises(FellBehindError) as caught:
            device.read(_buffer())
    assert caught.value.code == -200279
    interpreter.clear_task.assert_called_once_with(HANDLE)


def test_kind_and_coupling_given_as_plain_strings_are_understood(daqmx: FakeDaqmx) -> None:
    config = default_hammer_and_accelerometer(RATE_HZ)
    channels = tuple(
        dataclasses.replace(channel, kind=channel.kind.value, coupling="AC", name="") for channel in config.channels
    )
    device = _configured(daqmx, dataclasses.replace(config, channels=channels))
    assert daqmx.task.ai_channels.add_ai_force_iepe_chan.call_args.kwargs["name_to_assign_to_channel"] == "force_ai0"
    assert daqmx.task.ai_channels.add_ai_accel_chan.call_args.kwargs["sensitivity"] == pytest.approx(ACCEL_MV_PER_G)
    assert daqmx.force_channel.ai_coupling is DaqmxCoupling.AC
    assert daqmx.accel_channel.ai_coupling is DaqmxCoupling.AC
    device.start()
    daqmx.task.in_stream.overloaded_chans_exist = True
    daqmx.task.in_stream.overloaded_chans = ["force_ai0"]
    with pytest.warns(ADCOverloadWarning, match=r"ai0 \(force\)"):
        device.read(_buffer())


def test_close_failure_does_not_hide_the_error_that_left_the_with_block(daqmx: FakeDaqmx) -> None:
    daqmx.task.close.side_effect = nidaqmx.errors.DaqError("Device gone.", -201003)
    with pytest.raises(FellBehindError):
        with _configured(daqmx) as device:
            device.start()
            daqmx.reader.read_many_sample.side_effect = nidaqmx.errors.DaqReadError("Behind.", -200279, 0)
            device.read(_buffer())
    daqmx.task.close.assert_called_once_with()
    with pytest.raises(DeviceRemovedError, match="closing"):
        with _configured(daqmx):
            pass


def test_list_devices_offers_sim_and_the_ni9234_modules_daqmx_reports():
    from types import SimpleNamespace

    from gasfilm.drivers import list_devices

    assert list_devices() == ["sim"]  # no NI-DAQmx runtime on this machine
    modules = [SimpleNamespace(name="cDAQ1Mod1", product_type="NI 9234"),
               SimpleNamespace(name="cDAQ1Mod2", product_type="NI 9263")]
    with mock.patch("nidaqmx.system.System.local", return_value=SimpleNamespace(devices=modules)):
        assert list_devices() == ["sim", "cDAQ1Mod1"]


# -- TEDS (issue 32 item 5) -----------------------------------------------------------------------------------------


def test_teds_is_read_through_the_physical_channel_and_a_teds_channel_of_its_own(interpreter: mock.Mock) -> None:
    """The hammer's and the accelerometer's TEDS chips are read (configure_teds, then the basic TEDS attributes of
    the physical channel), each sensitivity from a TEDS channel NI-DAQmx scales from the chip; a sensor without TEDS
    (DAQmx -200709) is None, not an error."""
    from gasfilm.drivers import read_teds
    from gasfilm.drivers.interface import TedsSensor

    def configure_teds(name, file_path):
        if name == "cDAQ1Mod1/ai2":
            raise nidaqmx.errors.DaqError("TEDS sensor not detected.", -200709)

    interpreter.configure_teds.side_effect = configure_teds
    basic = {0x21da: 12, 0x21db: 8602, 0x21dd: 3}  # manufacturer (PCB), model, version number
    serials = {"cDAQ1Mod1/ai0": 31415, "cDAQ1Mod1/ai1": 27182}
    interpreter.get_physical_chan_attribute_uint32.side_effect = (
        lambda name, attribute: serials[name] if attribute == 0x21dc else basic[attribute])
    interpreter.get_physical_chan_attribute_string.side_effect = lambda name, attribute: {0x21de: "B"}[attribute]
    sensitivities = {("teds_ai0", 0x2f81): 11.42, ("teds_ai1", 0x692): 101.3}
    units = {("teds_ai0", 0x2f82): ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON.value,
             ("teds_ai1", 0x219c): AccelSensitivityUnits.MILLIVOLTS_PER_G.value}
    interpreter.get_chan_attribute_double.side_effect = lambda task, name, attribute: sensitivities[name, attribute]
    interpreter.get_chan_attribute_int32.side_effect = lambda task, name, attribute: units[name, attribute]

    found = read_teds(DEVICE, {"ai0": ChannelKind.FORCE, "ai1": ChannelKind.ACCELERATION,
                               "ai2": ChannelKind.ACCELERATION})

    assert found == {
        "ai0": TedsSensor(12, 8602, 31415, "3B", 11.42, "mV/N"),
        "ai1": TedsSensor(12, 8602, 27182, "3B", 101.3, "mV/g"),
        "ai2": None,
    }
    assert [c.args for c in interpreter.configure_teds.call_args_list] == [
        ("cDAQ1Mod1/ai0", ""), ("cDAQ1Mod1/ai1", ""), ("cDAQ1Mod1/ai2", "")]
    interpreter.create_tedsai_force_iepe_chan.assert_called_once_with(
        HANDLE, "cDAQ1Mod1/ai0", "teds_ai0", TerminalConfiguration.DEFAULT.value, -100.0, 100.0,
        ForceUnits.NEWTONS.value, ExcitationSource.INTERNAL.value, 0.002, "")
    interpreter.create_tedsai_accel_chan.assert_called_once_with(
        HANDLE, "cDAQ1Mod1/ai1", "teds_ai1", TerminalConfiguration.DEFAULT.value, -50.0, 50.0,
        AccelUnits.METERS_PER_SECOND_SQUARED.value, ExcitationSource.INTERNAL.value, 0.002, "")
    assert interpreter.clear_task.call_count == 2  # each TEDS channel's task closed


def test_a_teds_read_that_daqmx_refuses_is_a_device_error_naming_the_channel(interpreter: mock.Mock) -> None:
    from gasfilm.drivers import read_teds

    interpreter.configure_teds.side_effect = nidaqmx.errors.DaqError("Device cannot be accessed.", -201003)
    with pytest.raises(DeviceRemovedError, match="reading the TEDS of ai1"):
        read_teds(DEVICE, {"ai1": ChannelKind.ACCELERATION})


def test_the_simulated_sensors_carry_no_teds() -> None:
    from gasfilm.drivers import read_teds

    assert read_teds("sim", {"ai0": ChannelKind.FORCE}) == {"ai0": None}
