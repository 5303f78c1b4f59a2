"""Cameras: the common interface (grab a frame with metadata, live view). Concrete
cameras (OpenCV, GenICam, simulated) live in device plugins.

A frame is a :class:`camcmm.api.Image` whose ``metadata`` holds ``camera``, ``frame``
(counter since connect), ``time`` (UTC ISO 8601), ``time_s`` (epoch s), ``exposure_ms``,
``gain_db``, ``trigger``, ``roi`` [x, y, w, h] px and, when the camera knows it,
``temperature_c``.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..model import Image
from .base import Device, DeviceError, param, utc_iso


class Camera(Device):
    """Base class. Subclasses implement ``_grab(timeout) -> (ndarray, extra_metadata)``
    and list the trigger modes they support in :attr:`trigger_modes`:

    * ``software``: a frame is exposed when :meth:`grab` asks for it;
    * ``free-run``: the camera streams and :meth:`grab` returns the next frame;
    * ``hardware``: :meth:`grab` waits (up to ``timeout``) for an external trigger.
    """

    kind = "camera"
    trigger_modes: tuple[str, ...] = ("software",)
    hardware_roi = False  # True: the camera crops; False: frames are cropped here
    settings_schema = (
        param("exposure_ms", "float", 10.0, unit="ms", min=0.001, max=600000),
        param("gain_db", "float", 0.0, unit="dB", min=0, max=60),
        param("trigger", "choice", "software", choices=["software", "free-run", "hardware"]),
        param("roi", "vector", [0, 0, 0, 0], length=4, unit="px", help="x, y, width, height; zeros: the full frame."),
        param("timeout_s", "float", 2.0, unit="s", min=0.01, help="Longest wait for one frame (plus the exposure)."),
    )

    def __init__(self, name: str = "", port: str = "", **settings: Any):
        self.sensor_size: tuple[int, int] | None = None  # (width, height) px once known
        self._count = 0
        self._live: threading.Thread | None = None
        self._live_stop = threading.Event()
        if "trigger" not in settings and "software" not in self.trigger_modes:
            settings["trigger"] = self.trigger_modes[0]
        super().__init__(name, port, **settings)

    def _check(self, new: dict[str, Any]) -> None:
        trig = new.get("trigger")
        if trig is not None and trig not in self.trigger_modes:
            raise ParameterError(
                f"{self.label}: trigger {trig!r} is not supported; this camera offers {', '.join(self.trigger_modes)}"
            )
        roi = new.get("roi")
        if roi is not None:
            x, y, w, h = (int(v) for v in roi)
            if min(x, y, w, h) < 0:
                raise ParameterError(f"{self.label}: roi {roi} has a negative entry")
            if self.sensor_size and (w or h) and (x + w > self.sensor_size[0] or y + h > self.sensor_size[1]):
                raise ParameterError(
                    f"{self.label}: roi {roi} exceeds the sensor {self.sensor_size[0]}x{self.sensor_size[1]} px"
                )

    def capabilities(self) -> dict[str, Any]:
        return {
            **super().capabilities(),
            "trigger_modes": list(self.trigger_modes),
            "sensor_size": list(self.sensor_size) if self.sensor_size else None,
            "hardware_roi": self.hardware_roi,
        }

    def temperature(self) -> float | None:
        """Sensor temperature in °C when the camera reports one."""
        return None

    def grab(self, timeout: float | None = None) -> Image:
        """Take one frame; emits ``frame`` with it and returns it."""
        with self.guard("grabbing a frame"):
            self.require()
            s = self._settings
            wait = float(s["timeout_s"] if timeout is None else timeout) + float(s["exposure_ms"]) / 1000.0
            t = time.time()
            data, extra = self._grab(wait)
            data = np.asarray(data)
            roi = [int(v) for v in s["roi"]]
            if not self.hardware_roi and roi[2] and roi[3]:
                data = data[roi[1] : roi[1] + roi[3], roi[0] : roi[0] + roi[2]]
            self._count += 1
            meta = {
                "camera": self.name,
                "frame": self._count,
                "time": utc_iso(t),
                "time_s": t,
                "exposure_ms": float(s["exposure_ms"]),
                "gain_db": float(s["gain_db"]),
                "trigger": s["trigger"],
                "roi": roi if roi[2] and roi[3] else [0, 0, data.shape[1], data.shape[0]],
            }
            temp = extra.pop("temperature_c", None)
            if temp is None:
                temp = self.temperature()
            if temp is not None:
                meta["temperature_c"] = float(temp)
            meta.update(extra)
            frame = Image(data, name=f"{self.name}-{self._count:05d}", metadata=meta)
        self.events.emit("frame", frame)
        return frame

    # -- live view -------------------------------------------------------------------------
    def start_live(self, fps: float = 10.0) -> None:
        """Grab continuously on a daemon thread at up to ``fps``; each frame is emitted
        as ``frame``. A failure stops the live view and is emitted as ``fault``."""
        if self._live is not None and self._live.is_alive():
            return
        self._live_stop.clear()
        period = 1.0 / max(float(fps), 0.01)

        def loop() -> None:
            while not self._live_stop.is_set():
                t0 = time.monotonic()
                try:
                    self.grab()
                except DeviceError:
                    return
                self._live_stop.wait(max(0.0, period - (time.monotonic() - t0)))

        self._live = threading.Thread(target=loop, name=f"camcmm-live-{self.name}", daemon=True)
        self._live.start()

    def stop_live(self) -> None:
        self._live_stop.set()
        if self._live is not None and self._live is not threading.current_thread():
            self._live.join(timeout=5)
        self._live = None

    @property
    def live(self) -> bool:
        return self._live is not None and self._live.is_alive()

    def disconnect(self) -> None:
        self.stop_live()
        super().disconnect()

    def _grab(self, timeout: float) -> tuple[np.ndarray, dict[str, Any]]:
        raise NotImplementedError
