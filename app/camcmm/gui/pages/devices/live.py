"""A camera frame as the page shows it: a small PNG and a one-line caption."""

from __future__ import annotations

import base64
from typing import Any

LIVE_MAX_PX = 640
"""Longest side of the image sent to the browser, px (a live view needs no more)."""


def frame_data_url(data: Any, max_px: int = LIVE_MAX_PX) -> str:
    """A camera frame (H, W) or (H, W, 3) as a PNG data URL, downscaled to ``max_px``.

    Integer frames of more than 8 bits are scaled so that their brightest pixel is 255:
    for looking at, not for measuring.
    """
    import cv2
    import numpy as np

    img = np.asarray(data)
    if img.dtype != np.uint8:
        top = float(img.max()) or 1.0
        img = np.clip(img.astype(np.float32) * (255.0 / top), 0, 255).astype(np.uint8)
    h, w = img.shape[:2]
    s = max_px / max(h, w)
    if s < 1:
        img = cv2.resize(img, (max(1, round(w * s)), max(1, round(h * s))), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".png", img)
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode() if ok else ""


def frame_note(frame: Any) -> str:
    """``#frame · time · exposure ms · W×H px`` from a frame's metadata."""
    meta = getattr(frame, "metadata", {}) or {}
    h, w = frame.data.shape[:2]
    return " · ".join(
        str(x)
        for x in (f"#{meta.get('frame')}", meta.get("time", ""), f"{meta.get('exposure_ms', '')} ms", f"{w}×{h} px")
        if x
    )
