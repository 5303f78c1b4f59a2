"""The device interface (see docs/devices.md): :class:`Device` with status, settings and
events, the :class:`Camera` and :class:`Stage` interfaces, the device errors and a
health monitor. Concrete devices (OpenCV, GenICam, Zaber, simulators) are plugins;
labs subclass these through :mod:`camcmm.api`."""

from .base import (
    Device,
    DeviceDisconnected,
    DeviceError,
    DeviceMonitor,
    DeviceStatus,
    DeviceTimeout,
    Events,
    param,
    port_errors,
    utc_iso,
)
from .camera import Camera
from .stage import Stage

__all__ = [
    "Camera",
    "Device",
    "DeviceDisconnected",
    "DeviceError",
    "DeviceMonitor",
    "DeviceStatus",
    "DeviceTimeout",
    "Events",
    "Stage",
    "param",
    "port_errors",
    "utc_iso",
]
