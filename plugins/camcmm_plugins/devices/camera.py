"""The OpenCV ``VideoCapture`` camera. The interface (:class:`camcmm.api.Camera`) is in
the core; GenICam cameras are in :mod:`.genicam`, simulated ones in :mod:`.simulated`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import Camera, checked_path


class OpenCVCamera(Camera):
    """A camera (or video file, or image sequence ``frame_%03d.png``) through
    ``cv2.VideoCapture``. ``source`` is a device index (``0``) or a path/URL.

    OpenCV drivers stream: the trigger mode is ``free-run``. Exposure and gain are
    passed to the driver as ``CAP_PROP_EXPOSURE = exposure_ms * exposure_scale`` and
    ``CAP_PROP_GAIN = gain_db`` because their units differ between back-ends (V4L2
    counts 100 µs steps: ``exposure_scale`` 10, the default); a driver that refuses a
    property is noted in the status health as ``unsupported``, not an error, since
    many webcams have no manual exposure. ``loop`` rewinds a file at its end."""

    trigger_modes = ("free-run",)

    def __init__(
        self,
        source: int | str = 0,
        name: str = "",
        backend: str = "",
        exposure_scale: float = 10.0,
        loop: bool = False,
        width: int = 0,
        height: int = 0,
        **settings: Any,
    ):
        self.source = int(source) if isinstance(source, str) and source.strip().isdigit() else source
        self.backend, self.exposure_scale, self.loop = backend, float(exposure_scale), bool(loop)
        self.width, self.height = int(width), int(height)
        self._cap: Any = None
        super().__init__(name or f"opencv-{source}", str(source), **settings)

    def _open(self) -> None:
        import cv2

        api = getattr(cv2, f"CAP_{self.backend.upper()}", None) if self.backend else cv2.CAP_ANY
        if api is None:
            raise self.error(f"OpenCV has no back-end {self.backend!r}")
        source = self.source
        if isinstance(source, str) and "://" not in source:
            # a video or image file: in a run the web server confines (the Devices page) it must
            # lie in the project folder or a data root, or any image on the machine could be
            # shown as a frame; refused before OpenCV opens it (the CLI only resolves it)
            source = str(checked_path(source, "source"))
        cap = cv2.VideoCapture(source, api)
        if not cap.isOpened():
            cap.release()
            raise self.error("cannot open (no such camera or file, or another program uses it)")
        if self.width and self.height:
            cap.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
            cap.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        self._cap = cap
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        self.sensor_size = (w, h) if w and h else None

    def _close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None

    def _apply(self, changed: dict[str, Any]) -> None:
        import cv2

        unsupported = []
        if "exposure_ms" in changed:
            self._cap.set(cv2.CAP_PROP_AUTO_EXPOSURE, 1)  # V4L2 'manual'; ignored elsewhere
            if not self._cap.set(cv2.CAP_PROP_EXPOSURE, changed["exposure_ms"] * self.exposure_scale):
                unsupported.append("exposure")
        if "gain_db" in changed and not self._cap.set(cv2.CAP_PROP_GAIN, changed["gain_db"]):
            unsupported.append("gain")
        if unsupported:
            self._set_status(self._status.state, self._status.message, unsupported=unsupported)

    def _grab(self, timeout: float) -> tuple[np.ndarray, dict[str, Any]]:
        import cv2

        ok, frame = self._cap.read()
        if not ok and self.loop:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, frame = self._cap.read()
        if not ok or frame is None:
            raise self.error("no frame (camera unplugged, or the end of the file)")
        return frame, {"driver_time_ms": float(self._cap.get(cv2.CAP_PROP_POS_MSEC))}

    def _ping(self) -> None:
        if self._cap is None or not self._cap.isOpened():
            raise self.error("the capture is closed")
