"""The project's own error types.

Every message is one line that names the device, file or setting and says what is wrong. The command line prints
``str(error)`` and exits non-zero; the GUI shows it in a non-modal banner. Device errors carry the NI-DAQmx error
code when one exists, so the simulated and the real backend raise the same types for the same faults.
"""

from __future__ import annotations


class GasfilmError(Exception):
    """Base of every error gasfilm raises on purpose (never shown with a traceback)."""


class SettingError(GasfilmError, ValueError):
    """A setting is invalid; the message names the setting and the allowed values."""


class DeviceError(GasfilmError):
    """A fault reported by the acquisition device (real or simulated)."""

    code: int | None = None

    def __init__(self, message: str, code: int | None = None) -> None:
        super().__init__(message)
        if code is not None:
            self.code = code


class FellBehindError(DeviceError):
    """The reader did not keep up and the device overwrote unread samples (DAQmx -200279)."""

    code = -200279


class ReadTimeoutError(DeviceError):
    """The requested samples did not arrive in time (DAQmx -200284)."""

    code = -200284


class BufferOverflowError(DeviceError):
    """The device's onboard FIFO overflowed (DAQmx -200010 / -200361)."""

    code = -200361


class DeviceRemovedError(DeviceError):
    """The device was unplugged or powered off mid-stream (DAQmx -201003)."""

    code = -201003


class DeviceReservedError(DeviceError):
    """Another task or process holds the device (DAQmx -50103)."""

    code = -50103


class OpenSensorError(DeviceError):
    """An IEPE channel sees an open circuit: the sensor is unplugged or its cable is broken."""


class GasfilmWarning(UserWarning):
    """Base of gasfilm's warnings: conditions that taint data without stopping acquisition."""


class ADCOverloadWarning(GasfilmWarning):
    """An input exceeded the ±5 V range; affected samples are clipped (DAQmx warning 200005)."""

    code = 200005
