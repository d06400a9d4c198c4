"""NI 9234 acquisition: one interface, a simulated rig backend and a real backend on NI's ``nidaqmx``."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from gasfilm.drivers.errors import SettingError

if TYPE_CHECKING:  # numpy is imported with the device, not with the package (the command line starts fast)
    from gasfilm.drivers.interface import ChannelKind, DaqDevice, TedsSensor

SIMULATED_DEVICE_NAME = "sim"


def open_device(name: str | None = None, **options: Any) -> DaqDevice:
    """Open an acquisition backend by name.

    ``"sim"`` opens the simulated NI 9234 (options go to :class:`gasfilm.drivers.simulated.SimulatedNI9234`;
    ``plant=`` the rig behind it, a :class:`gasfilm.drivers.plant.Plant` the caller builds); any other name is an
    NI-DAQmx device name such as ``"cDAQ1Mod1"``.
    Without a name, the ``GASFILM_DEVICE`` environment variable is used, then ``"sim"``.
    """
    name = name or os.environ.get("GASFILM_DEVICE", SIMULATED_DEVICE_NAME)
    if name.strip().lower() == SIMULATED_DEVICE_NAME:  # "SIM" too: never taken for an NI device
        from gasfilm.drivers.simulated import SimulatedNI9234

        return SimulatedNI9234(**options)
    if options:
        raise SettingError(f"device '{name}': options {sorted(options)} only apply to the simulated device 'sim'")
    from gasfilm.drivers.nidaqmx_backend import NidaqmxNI9234

    return NidaqmxNI9234(name)


def read_teds(name: str, channels: dict[str, "ChannelKind"]) -> dict[str, "TedsSensor | None"]:
    """The TEDS of the sensors on ``channels`` (physical channel, e.g. "ai0" → what it measures) of device ``name``:
    each a :class:`gasfilm.drivers.interface.TedsSensor`, or None where the sensor has no TEDS chip. The simulated
    device's sensors have none."""
    if name == SIMULATED_DEVICE_NAME:
        return {channel: None for channel in channels}
    from gasfilm.drivers.nidaqmx_backend import read_teds as read_ni_teds

    return read_ni_teds(name, channels)


def list_devices() -> list[str]:
    """Device names a user can pick: ``"sim"`` first, then the NI 9234 modules NI-DAQmx reports on this machine."""
    from gasfilm.drivers.nidaqmx_backend import local_ni9234_names

    return [SIMULATED_DEVICE_NAME, *local_ni9234_names()]
