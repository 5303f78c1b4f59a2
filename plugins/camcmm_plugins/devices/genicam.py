"""GenICam machine-vision cameras (thesis ch. 5: Basler ace acA4024-29um) through the
optional package ``harvesters`` and the camera maker's GenTL producer (a ``.cti`` file).

``harvesters`` is imported when the camera connects, never before: without it the
camera's status says how to install it and the rest of camcmm is unaffected. Feature
names are the GenICam SFNC ones (ExposureTime in µs, Gain in dB, TriggerMode,
TriggerSource, TriggerSoftware, OffsetX/OffsetY/Width/Height, DeviceTemperature).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import DeviceDisconnected, DeviceTimeout

from .camera import Camera

INSTALL_HINT = (
    "GenICam cameras need the optional package 'harvesters' (pip install harvesters) "
    "and the camera maker's GenTL producer (.cti file)"
)


class GenICamCamera(Camera):
    """``cti``: path of the GenTL producer; ``serial``: the camera's serial number
    (else the ``index``-th camera found)."""

    trigger_modes = ("software", "free-run", "hardware")
    hardware_roi = True

    def __init__(
        self,
        cti: str = "",
        name: str = "",
        serial: str = "",
        index: int = 0,
        trigger_line: str = "Line1",
        **settings: Any,
    ):
        self.cti, self.serial, self.index, self.trigger_line = str(cti), str(serial or ""), int(index), trigger_line
        self._h: Any = None
        self._ia: Any = None
        super().__init__(name or f"genicam-{serial or index}", f"{cti}#{serial or index}", **settings)

    def _open(self) -> None:
        try:
            from harvesters.core import Harvester
        except ImportError:
            raise self.error(INSTALL_HINT, DeviceDisconnected) from None
        if not self.cti:
            raise self.error("no GenTL producer given (cti: path of the camera maker's .cti file)")
        h = Harvester()
        try:
            h.add_file(self.cti)
            h.update()
            if not h.device_info_list:
                raise self.error("no GenICam camera found through this GenTL producer", DeviceDisconnected)
            ia = h.create({"serial_number": self.serial} if self.serial else self.index)
        except BaseException:
            h.reset()
            raise
        self._h, self._ia = h, ia
        nm = ia.remote_device.node_map
        self.sensor_size = (int(nm.WidthMax.value), int(nm.HeightMax.value)) if hasattr(nm, "WidthMax") else None

    def _close(self) -> None:
        try:
            if self._ia is not None:
                if self._ia.is_acquiring():
                    self._ia.stop()
                self._ia.destroy()
        finally:
            if self._h is not None:
                self._h.reset()
            self._h = self._ia = None

    def _apply(self, changed: dict[str, Any]) -> None:
        ia = self._ia
        nm = ia.remote_device.node_map
        was = ia.is_acquiring()
        if was and ("roi" in changed or "trigger" in changed):
            ia.stop()  # ROI and trigger features are locked while streaming
        if "exposure_ms" in changed:
            nm.ExposureTime.value = float(changed["exposure_ms"]) * 1000.0
        if "gain_db" in changed and hasattr(nm, "Gain"):
            nm.Gain.value = float(changed["gain_db"])
        if "trigger" in changed:
            mode = changed["trigger"]
            nm.TriggerMode.value = "Off" if mode == "free-run" else "On"
            if mode != "free-run":
                nm.TriggerSource.value = "Software" if mode == "software" else self.trigger_line
        if "roi" in changed:
            x, y, w, h = (int(v) for v in changed["roi"])
            if not (w and h):
                x, y, (w, h) = 0, 0, self.sensor_size or (nm.Width.max, nm.Height.max)
            nm.OffsetX.value = 0
            nm.OffsetY.value = 0
            nm.Width.value, nm.Height.value = w, h
            nm.OffsetX.value, nm.OffsetY.value = x, y
        if not ia.is_acquiring():
            ia.start()

    def temperature(self) -> float | None:
        nm = self._ia.remote_device.node_map if self._ia is not None else None
        try:
            return float(nm.DeviceTemperature.value) if nm is not None and hasattr(nm, "DeviceTemperature") else None
        except Exception:  # a camera may list the feature but not implement it
            return None

    def _grab(self, timeout: float) -> tuple[np.ndarray, dict[str, Any]]:
        nm = self._ia.remote_device.node_map
        if self._settings["trigger"] == "software":
            nm.TriggerSoftware.execute()
        try:
            with self._ia.fetch(timeout=timeout) as buffer:
                c = buffer.payload.components[0]
                shape = (
                    (c.height, c.width)
                    if c.num_components_per_pixel <= 1
                    else (c.height, c.width, int(c.num_components_per_pixel))
                )
                data = np.array(c.data, copy=True).reshape(shape)
                extra = {"device_timestamp": int(buffer.timestamp)} if hasattr(buffer, "timestamp") else {}
        except Exception as exc:
            if type(exc).__name__ in ("TimeoutException", "TimeoutError"):
                raise self.error(f"no frame within {timeout:g} s", DeviceTimeout) from None
            raise
        return data, extra

    def _ping(self) -> None:
        _ = self._ia.remote_device.node_map.DeviceVendorName.value if self._ia is not None else None
