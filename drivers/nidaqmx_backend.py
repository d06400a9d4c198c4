"""The real NI 9234 backend on NI's ``nidaqmx`` package (needs the NI-DAQmx driver at run time).

This is the only module of gasfilm that imports ``nidaqmx``. It maps a :class:`DaqConfig` to one DAQmx task
(IEPE force and accelerometer channels, 2 mA excitation, AC coupling, continuous sample clock), reads chunks through
``AnalogMultiChannelReader.read_many_sample`` straight into the caller's buffer, refreshes the overload and
open-sensor flags after every chunk, and turns DAQmx errors and warnings into gasfilm's own types
(``docs/ni9234.md`` has the table).
"""

from __future__ import annotations

import contextlib
import math
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass

import nidaqmx
import nidaqmx.errors
import nidaqmx.stream_readers
import nidaqmx.system
import numpy as np
from nidaqmx.constants import (
    AccelSensitivityUnits,
    AccelUnits,
    AcquisitionType,
    ExcitationSource,
    ForceIEPESensorSensitivityUnits,
    ForceUnits,
    TaskMode,
    TerminalConfiguration,
)
from nidaqmx.constants import Coupling as DaqmxCoupling

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
    NI9234_IEPE_CURRENT_A,
    STANDARD_GRAVITY_M_S2,
    ChannelConfig,
    ChannelKind,
    ChannelStatus,
    Coupling,
    DaqConfig,
    TedsSensor,
    check_read_buffer,
    validate_config,
)

#: Sensitivity as DAQmx takes it: mV/N for IEPE force sensors, mV/g for accelerometers (factor from gasfilm's units).
DAQMX_SENSITIVITY_FACTORS: dict[ChannelKind, dict[str, float]] = {
    ChannelKind.FORCE: {"mV/N": 1.0, "V/N": 1000.0},
    ChannelKind.ACCELERATION: {"mV/(m/s^2)": STANDARD_GRAVITY_M_S2, "mV/g": 1.0, "V/g": 1000.0},
}

#: Seconds of samples the DAQmx host buffer holds in continuous mode (at least ten chunks).
HOST_BUFFER_S = 5.0
HOST_BUFFER_MIN_CHUNKS = 10

#: Relative difference between requested and read-back sample clock rate that counts as coercion.
RATE_TOLERANCE = 1e-9

#: DAQmx error for a property the device does not support in this task (then open-sensor detection is off).
DAQMX_ATTRIBUTE_NOT_SUPPORTED = -200452


@dataclass(frozen=True)
class _KnownFault:
    error_type: type[DeviceError]
    what: str
    remedy: str


#: DAQmx error codes gasfilm translates into its own error types.
DAQMX_FAULTS: dict[int, _KnownFault] = {
    -200279: _KnownFault(
        FellBehindError,
        "the reader fell behind and DAQmx overwrote unread samples",
        "read about ten chunks per second and keep consumers off the reader thread",
    ),
    -200284: _KnownFault(
        ReadTimeoutError,
        "the requested samples did not arrive before the read timeout",
        "check that the chassis is powered and connected, or raise timeout_s",
    ),
    -200010: _KnownFault(
        BufferOverflowError,
        "the module's onboard FIFO overflowed",
        "lower the sample rate or the number of channels or modules streaming on this bus",
    ),
    -200361: _KnownFault(
        BufferOverflowError,
        "the module's onboard FIFO overflowed",
        "lower the sample rate or the number of channels or modules streaming on this bus",
    ),
    -201003: _KnownFault(
        DeviceRemovedError,
        "the device cannot be accessed: it was removed or powered off",
        "reconnect it, then configure and start again",
    ),
    -50103: _KnownFault(
        DeviceReservedError,
        "the device is reserved by another task or program",
        "close NI MAX test panels and other programs that use it",
    ),
}

#: DAQmx warning: an ADC overload occurred, samples are clipped.
DAQMX_ADC_OVERLOAD_WARNING = 200005

_DAQMX_BOILERPLATE = re.compile(r"^(Warning -?\d+ occurred\.|Status Code: .*|Task Name: .*)$")


def _first_line(text: str) -> str:
    """The first informative line of a DAQmx message (which spans many lines)."""
    for line in text.splitlines():
        line = line.strip()
        if line and not _DAQMX_BOILERPLATE.match(line):
            return line
    return "no description"


def translate_daq_error(error: nidaqmx.errors.DaqError, device_name: str, action: str) -> DeviceError:
    """The gasfilm error for a DAQmx error raised while doing ``action`` on ``device_name``."""
    code = error.error_code
    read_before = ""
    if isinstance(error, nidaqmx.errors.DaqReadError) and error.samps_per_chan_read:
        read_before = f"; {error.samps_per_chan_read} samples per channel were read before it"
    fault = DAQMX_FAULTS.get(code)
    if fault is None:
        return DeviceError(
            f"device '{device_name}': DAQmx error {code} while {action}: {_first_line(str(error))}{read_before}",
            code=code,
        )
    return fault.error_type(
        f"device '{device_name}': {fault.what} while {action} (DAQmx error {code}){read_before}; {fault.remedy}",
        code=code,
    )


def _missing_driver_error(device_name: str, error: Exception) -> DeviceError:
    return DeviceError(
        f"device '{device_name}': the NI-DAQmx driver is not installed or not usable on this machine "
        f"({_first_line(str(error))}); install NI-DAQmx, or use the simulated device 'sim'"
    )


def virtual_channel_name(channel: ChannelConfig) -> str:
    """The DAQmx virtual channel name gasfilm gives a channel, e.g. ``force_ai0``."""
    return f"{ChannelKind(channel.kind).value}_{channel.physical_channel}"


def daqmx_sensitivity(channel: ChannelConfig) -> float:
    """The sensor sensitivity in DAQmx's units: mV/N for force, mV/g for acceleration."""
    return channel.sensitivity * DAQMX_SENSITIVITY_FACTORS[ChannelKind(channel.kind)][channel.sensitivity_units]


class _CallRecord:
    """What one guarded block of DAQmx calls reported besides its result."""

    def __init__(self) -> None:
        self.adc_overload = False


class NidaqmxNI9234:
    """An NI 9234 in a CompactDAQ chassis (or any NI-DAQmx device name), driven through ``nidaqmx``.

    ``device_name`` is the DAQmx device, e.g. ``"cDAQ1Mod1"``. Faults raise :class:`gasfilm.drivers.errors.DeviceError`
    subclasses; an ADC overload warns :class:`gasfilm.drivers.errors.ADCOverloadWarning` and sets the overload flag.
    """

    def __init__(self, device_name: str) -> None:
        self.name = device_name
        self._config: DaqConfig | None = None
        self._sample_rate_hz = 0.0
        self._task: nidaqmx.Task | None = None
        self._reader: nidaqmx.stream_readers.AnalogMultiChannelReader | None = None
        self._channel_index: dict[str, int] = {}
        self._open_detection = False
        self._status = ChannelStatus.clear(0)

    # -- configuration -------------------------------------------------------------------------------------------

    def configure(self, config: DaqConfig) -> None:
        """Validate ``config``, build the DAQmx task and check that the sample clock runs at exactly that rate."""
        validate_config(config)
        self.close()
        with self._daqmx("creating the task"):
            task = nidaqmx.Task()
        try:
            for channel in config.channels:
                self._add_channel(task, channel)
            buffer_samples = max(
                HOST_BUFFER_MIN_CHUNKS * config.chunk_samples, math.ceil(HOST_BUFFER_S * config.sample_rate_hz)
            )
            with self._daqmx("configuring the sample clock"):
                task.timing.cfg_samp_clk_timing(
                    config.sample_rate_hz, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=buffer_samples
                )
            with self._daqmx("committing the task"):
                task.control(TaskMode.TASK_COMMIT)
                actual_rate_hz = float(task.timing.samp_clk_rate)
            if abs(actual_rate_hz - config.sample_rate_hz) > RATE_TOLERANCE * config.sample_rate_hz:
                raise SettingError(
                    f"sample_rate_hz: device '{self.name}' runs at {actual_rate_hz:.6g} S/s, not the requested "
                    f"{config.sample_rate_hz:.6g} S/s; choose a rate the module supports (51200/n S/s for an NI 9234)"
                )
            reader = nidaqmx.stream_readers.AnalogMultiChannelReader(task.in_stream)
        except BaseException:
            with contextlib.suppress(Exception):
                task.close()
            raise
        self._task = task
        self._reader = reader
        self._config = config
        self._sample_rate_hz = actual_rate_hz
        self._channel_index = {virtual_channel_name(ch): index for index, ch in enumerate(config.channels)}
        self._open_detection = any(ch.iepe_current_a > 0 for ch in config.channels)
        self._status = ChannelStatus.clear(len(config.channels))

    def _add_channel(self, task: nidaqmx.Task, channel: ChannelConfig) -> None:
        iepe_on = channel.iepe_current_a > 0
        full_scale = channel.full_scale_si
        common = dict(
            physical_channel=f"{self.name}/{channel.physical_channel}",
            name_to_assign_to_channel=virtual_channel_name(channel),
            terminal_config=TerminalConfiguration.DEFAULT,
            min_val=-full_scale,
            max_val=full_scale,
            sensitivity=daqmx_sensitivity(channel),
            current_excit_source=ExcitationSource.INTERNAL if iepe_on else ExcitationSource.NONE,
            current_excit_val=channel.iepe_current_a if iepe_on else 0.0,
        )
        coupling = DaqmxCoupling.AC if Coupling(channel.coupling) is Coupling.AC else DaqmxCoupling.DC
        with self._daqmx(f"adding channel {channel.physical_channel}"):
            if ChannelKind(channel.kind) is ChannelKind.FORCE:
                daqmx_channel = task.ai_channels.add_ai_force_iepe_chan(
                    units=ForceUnits.NEWTONS,
                    sensitivity_units=ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON,
                    **common,
                )
            else:
                daqmx_channel = task.ai_channels.add_ai_accel_chan(
                    units=AccelUnits.METERS_PER_SECOND_SQUARED,
                    sensitivity_units=AccelSensitivityUnits.MILLIVOLTS_PER_G,
                    **common,
                )
            daqmx_channel.ai_coupling = coupling

    @property
    def config(self) -> DaqConfig:
        if self._config is None:
            raise DeviceError(f"device '{self.name}': not configured; call configure() first")
        return self._config

    @property
    def sample_rate_hz(self) -> float:
        """The sample clock rate the device reported after configuration."""
        if self._config is None:
            raise DeviceError(f"device '{self.name}': not configured; call configure() first")
        return self._sample_rate_hz

    # -- acquisition ---------------------------------------------------------------------------------------------

    def start(self) -> None:
        task = self._configured_task()
        self._status = ChannelStatus.clear(len(self.config.channels))
        with self._daqmx("starting"):
            task.start()

    def read(self, out: np.ndarray, timeout_s: float = 10.0) -> int:
        """Fill ``out`` (channels × samples, float64, N and m/s²) with the next samples; return samples per channel.

        Afterwards the overload and open-sensor flags of this chunk are in :meth:`status`; an overload warns
        :class:`ADCOverloadWarning`, an open IEPE sensor raises :class:`OpenSensorError` (the chunk stays in ``out``).
        """
        task = self._configured_task()
        assert self._reader is not None
        check_read_buffer(out, len(self.config.channels))
        with self._daqmx("reading", report_overload=False) as record:
            samples_read = self._reader.read_many_sample(
                out, number_of_samples_per_channel=out.shape[1], timeout=timeout_s
            )
            self._status = self._query_status(task)
        overload = self._status.overload
        if overload.any():
            warnings.warn(ADCOverloadWarning(self._overload_message(self._channel_list(overload))), stacklevel=2)
        elif record.adc_overload:
            overload[:] = True
            warnings.warn(ADCOverloadWarning(self._overload_message("a channel DAQmx did not name")), stacklevel=2)
        if self._status.open_sensor.any():
            names = self._channel_list(self._status.open_sensor)
            raise OpenSensorError(
                f"device '{self.name}': open IEPE sensor on {names}: the sensor is unplugged or its cable is broken; "
                f"check the connection"
            )
        return int(samples_read)

    def _query_status(self, task: nidaqmx.Task) -> ChannelStatus:
        """Read (and so clear) DAQmx's overload and open-channel flags for the last chunk."""
        status = ChannelStatus.clear(len(self.config.channels))
        in_stream = task.in_stream
        if in_stream.overloaded_chans_exist:
            for name in in_stream.overloaded_chans:
                status.overload[self._channel_index[name]] = True
        if self._open_detection:
            try:
                open_exist = in_stream.open_chans_exist
            except nidaqmx.errors.DaqError as error:
                if error.error_code != DAQMX_ATTRIBUTE_NOT_SUPPORTED:
                    raise
                self._open_detection = False
                warnings.warn(
                    GasfilmWarning(
                        f"device '{self.name}': DAQmx does not report open channels for this device; "
                        f"open IEPE sensors will not be flagged"
                    ),
                    stacklevel=3,
                )
                open_exist = False
            if open_exist:
                for name in in_stream.open_chans:
                    status.open_sensor[self._channel_index[name]] = True
        return status

    def status(self) -> ChannelStatus:
        """Overload and open-sensor flags of the last chunk read."""
        return ChannelStatus(self._status.overload.copy(), self._status.open_sensor.copy())

    def stop(self) -> None:
        if self._task is None:
            return
        with self._daqmx("stopping"):
            self._task.stop()

    def close(self) -> None:
        """Release the DAQmx task; calling it again does nothing."""
        task, self._task, self._reader = self._task, None, None
        if task is None:
            return
        with self._daqmx("closing"):
            task.close()

    def __enter__(self) -> NidaqmxNI9234:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc_info: object) -> None:
        """Close; a failure to close does not hide an error already on its way out of the ``with`` block."""
        if exc_type is None:
            self.close()
            return
        with contextlib.suppress(DeviceError):
            self.close()

    # -- helpers -------------------------------------------------------------------------------------------------

    def _configured_task(self) -> nidaqmx.Task:
        if self._task is None:
            raise DeviceError(f"device '{self.name}': not configured or already closed; call configure() first")
        return self._task

    def _channel_list(self, flags: np.ndarray) -> str:
        channels = [self.config.channels[index] for index in np.flatnonzero(flags)]
        return ", ".join(
            f"{channel.physical_channel} ({channel.name or ChannelKind(channel.kind).value})" for channel in channels
        )

    def _overload_message(self, where: str) -> str:
        return (
            f"device '{self.name}': ADC overload on {where}: samples clipped at ±5 V "
            f"(DAQmx warning {DAQMX_ADC_OVERLOAD_WARNING}); hit softer or use a less sensitive sensor"
        )

    @contextlib.contextmanager
    def _daqmx(self, action: str, report_overload: bool = True) -> Iterator[_CallRecord]:
        """Run DAQmx calls, turning DAQmx errors and warnings into gasfilm's.

        DAQmx reports warnings through :mod:`warnings` (``DaqWarning``); they are caught here and re-issued as
        gasfilm warnings, other warnings pass through unchanged. With ``report_overload=False`` the ADC overload
        warning only sets ``record.adc_overload`` so that the caller can name the channels.
        """
        record = _CallRecord()
        foreign: list[warnings.WarningMessage] = []
        daq_warnings: list[nidaqmx.errors.DaqWarning] = []
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    yield record
                finally:
                    for message in caught:
                        if isinstance(message.message, nidaqmx.errors.DaqWarning):
                            daq_warnings.append(message.message)
                        else:
                            foreign.append(message)
        except nidaqmx.errors.DaqError as error:
            raise translate_daq_error(error, self.name, action) from error
        except (nidaqmx.errors.DaqNotFoundError, nidaqmx.errors.DaqNotSupportedError) as error:
            raise _missing_driver_error(self.name, error) from error
        except nidaqmx.errors.DaqFunctionNotSupportedError as error:
            raise DeviceError(
                f"device '{self.name}': the installed NI-DAQmx driver is too old for {action} "
                f"({_first_line(str(error))}); update NI-DAQmx"
            ) from error
        finally:
            for message in foreign:
                warnings.warn_explicit(message.message, message.category, message.filename, message.lineno)
            for daq_warning in daq_warnings:
                self._reissue(daq_warning, action, record, report_overload)

    def _reissue(
        self, daq_warning: nidaqmx.errors.DaqWarning, action: str, record: _CallRecord, report_overload: bool
    ) -> None:
        code = daq_warning.error_code
        if code == DAQMX_ADC_OVERLOAD_WARNING:
            record.adc_overload = True
            if report_overload:
                warnings.warn(ADCOverloadWarning(self._overload_message(f"an input while {action}")), stacklevel=5)
            return
        warnings.warn(
            GasfilmWarning(
                f"device '{self.name}': DAQmx warning {code} while {action}: {_first_line(str(daq_warning))}"
            ),
            stacklevel=5,
        )


#: Ranges of the throw-away TEDS channel (only its sensitivity is read): well inside ±5 V for any hammer or
#: accelerometer the sensor library knows.
TEDS_RANGE_N = 100.0
TEDS_RANGE_M_S2 = 50.0
#: DAQmx errors of a channel whose sensor carries no TEDS (none detected; the terminal cannot read TEDS).
DAQMX_NO_TEDS = (-200709, -200741)
#: DAQmx's sensitivity units of a TEDS channel → gasfilm's (:data:`gasfilm.drivers.interface.SENSITIVITY_UNITS`)
#: and the factor to them (mV/lb → mV/N: 1 lbf = 4.448 N).
_TEDS_UNITS = {
    ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON: ("mV/N", 1.0),
    ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_POUND: ("mV/N", 1.0 / 4.4482216152605),
    AccelSensitivityUnits.MILLIVOLTS_PER_G: ("mV/g", 1.0),
    AccelSensitivityUnits.VOLTS_PER_G: ("V/g", 1.0),
}


def read_teds(device_name: str, channels: dict[str, ChannelKind]) -> dict[str, TedsSensor | None]:
    """Read the TEDS of the IEPE sensors on ``channels`` (physical channel → kind) through NI-DAQmx: the physical
    channel is configured from the sensor's TEDS chip (``PhysicalChannel.configure_teds``, which reads it), its basic
    TEDS read back, and a TEDS channel created in a task of its own (``add_teds_ai_force_iepe_chan`` or
    ``add_teds_ai_accel_chan``, 2 mA IEPE excitation) gives the sensitivity NI-DAQmx scales with. A sensor without
    TEDS gives None. (The calibration date sits in the TEDS template, which NI-DAQmx does not decode.)"""
    found: dict[str, TedsSensor | None] = {}
    for channel, kind in channels.items():
        path = f"{device_name}/{channel}"
        physical = nidaqmx.system.PhysicalChannel(path)
        try:
            physical.configure_teds()
        except nidaqmx.errors.DaqError as error:
            if error.error_code in DAQMX_NO_TEDS:
                found[channel] = None
                continue
            raise translate_daq_error(error, device_name, f"reading the TEDS of {channel}") from error
        except (nidaqmx.errors.DaqNotFoundError, nidaqmx.errors.DaqNotSupportedError) as error:
            raise _missing_driver_error(device_name, error) from error
        try:
            with nidaqmx.Task() as task:
                if ChannelKind(kind) is ChannelKind.FORCE:
                    created = task.ai_channels.add_teds_ai_force_iepe_chan(
                        path, name_to_assign_to_channel=f"teds_{channel}", min_val=-TEDS_RANGE_N, max_val=TEDS_RANGE_N,
                        units=ForceUnits.NEWTONS, current_excit_source=ExcitationSource.INTERNAL,
                        current_excit_val=NI9234_IEPE_CURRENT_A)
                    value, units = created.ai_force_iepe_sensor_sensitivity, created.ai_force_iepe_sensor_sensitivity_units
                else:
                    created = task.ai_channels.add_teds_ai_accel_chan(
                        path, name_to_assign_to_channel=f"teds_{channel}", min_val=-TEDS_RANGE_M_S2,
                        max_val=TEDS_RANGE_M_S2, units=AccelUnits.METERS_PER_SECOND_SQUARED,
                        current_excit_source=ExcitationSource.INTERNAL, current_excit_val=NI9234_IEPE_CURRENT_A)
                    value, units = created.ai_accel_sensitivity, created.ai_accel_sensitivity_units
            name, factor = _TEDS_UNITS[units]
            found[channel] = TedsSensor(
                manufacturer_id=int(physical.teds_mfg_id), model_number=int(physical.teds_model_num),
                serial_number=int(physical.teds_serial_num),
                version=f"{physical.teds_version_num}{physical.teds_version_letter}",
                sensitivity=float(value) * factor, sensitivity_units=name)
        except nidaqmx.errors.DaqError as error:
            raise translate_daq_error(error, device_name, f"reading the TEDS of {channel}") from error
    return found


def local_ni9234_names() -> list[str]:
    """Names of the NI 9234 modules NI-DAQmx reports on this machine; empty when the NI driver is absent."""
    try:
        devices = nidaqmx.system.System.local().devices
        return [device.name for device in devices if "9234" in str(device.product_type)]
    except (nidaqmx.errors.DaqNotFoundError, nidaqmx.errors.DaqNotSupportedError, nidaqmx.errors.DaqError):
        return []
