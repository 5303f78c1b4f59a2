"""Pictures of the Calibration page, drawn server-side with OpenCV: the detected board
over an image, thumbnails for the image list, the rectified pair with epipolar lines.

Images are downscaled before drawing (the page shows at most about a thousand pixels
across), so a 12-MP image costs one resize, and OpenCV's fixed-width strokes stay
readable. The pictures go to the page as ``data:`` URLs (JPEG for photographs).
"""

from __future__ import annotations

import base64
from collections.abc import Sequence

import numpy as np

STATUS_COLOURS = {"used": (60, 160, 40), "left out": (30, 30, 220), "not found": (30, 30, 220)}  # BGR


def bgr8(data: np.ndarray) -> np.ndarray:
    """An 8-bit BGR copy of an image (grey, BGR(A), any depth; a 16-bit or float image
    stretched to its own range)."""
    import cv2

    a = np.asarray(data)
    if a.dtype != np.uint8:
        f = a.astype(np.float64)
        lo, hi = float(np.nanmin(f)), float(np.nanmax(f))
        a = (
            np.zeros(a.shape, np.uint8)
            if hi <= lo
            else np.clip((f - lo) * (255.0 / (hi - lo)), 0, 255).astype(np.uint8)
        )
    if a.ndim == 2:
        return cv2.cvtColor(a, cv2.COLOR_GRAY2BGR)
    if a.shape[2] == 4:
        return cv2.cvtColor(a, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(a[:, :, :3])


def downscale(img: np.ndarray, max_width: int) -> tuple[np.ndarray, float]:
    """(image, scale) with the width at most ``max_width`` px (area averaging)."""
    import cv2

    h, w = img.shape[:2]
    if w <= max_width:
        return img, 1.0
    s = max_width / float(w)
    return cv2.resize(img, (max_width, max(1, round(h * s))), interpolation=cv2.INTER_AREA), s


def data_url(img: np.ndarray, fmt: str = ".jpg", quality: int = 88) -> str:
    import cv2

    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)] if fmt == ".jpg" else []
    ok, buf = cv2.imencode(fmt, img, params)
    if not ok:
        raise ValueError("the picture could not be encoded")
    mime = "image/jpeg" if fmt == ".jpg" else "image/png"
    return f"data:{mime};base64," + base64.b64encode(buf.tobytes()).decode("ascii")


def url_bytes(url: str) -> bytes:
    """The encoded bytes of a ``data:`` URL."""
    return base64.b64decode(url.split(",", 1)[1])


def _label(img: np.ndarray, text: str, colour: tuple[int, int, int]) -> None:
    import cv2

    if not text:
        return
    scale = max(0.45, img.shape[1] / 1400.0)
    th = max(1, round(scale * 2))
    (tw, tht), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, th)
    cv2.rectangle(img, (0, 0), (min(img.shape[1], tw + 12), tht + base + 10), (255, 255, 255), -1)
    cv2.putText(img, text, (6, tht + 5), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, th, cv2.LINE_AA)


def draw_detection(
    data: np.ndarray,
    corners: Sequence[Sequence[float]] | None,
    layout: tuple[int, int] | None,
    status: str = "used",
    text: str = "",
    max_width: int = 960,
) -> np.ndarray:
    """The image (BGR, downscaled to ``max_width``) with the detected board drawn:
    OpenCV's coloured chessboard rows when every point of the board was found
    (cv2.drawChessboardCorners; ``layout`` is (cols, rows)), else a ring per point.
    ``text`` (e.g. the reason a view was left out) goes into a banner at the top."""
    import cv2

    img, s = downscale(bgr8(data), max_width)
    img = np.ascontiguousarray(img)
    pts = np.asarray(corners if corners is not None else [], np.float32).reshape(-1, 2) * s
    colour = STATUS_COLOURS.get(status, (30, 30, 220))
    if len(pts):
        if layout is not None and layout[0] * layout[1] == len(pts):
            cv2.drawChessboardCorners(img, tuple(int(v) for v in layout), pts.reshape(-1, 1, 2), True)
        else:
            r = max(2, round(img.shape[1] / 200))
            for x, y in pts:
                cv2.circle(img, (round(float(x)), round(float(y))), r, colour, max(1, r // 2), cv2.LINE_AA)
    _label(img, text, colour)
    return img


def thumbnail(data: np.ndarray, corners, layout, status: str, width: int = 150) -> str:
    """A small JPEG data URL of the image with its board drawn (for the image list)."""
    import cv2

    img = draw_detection(data, corners, layout, status, max_width=width)
    if status != "used":  # a red frame says "not in the calibration" at a glance
        cv2.rectangle(img, (0, 0), (img.shape[1] - 1, img.shape[0] - 1), STATUS_COLOURS[status], 3)
    return data_url(img, quality=80)


def rectified_pair(left: np.ndarray, right: np.ndarray, n_lines: int = 16, max_width: int = 1400) -> np.ndarray:
    """The two rectified images side by side (BGR, downscaled to ``max_width`` in all)
    with ``n_lines`` horizontal lines across both: in a good calibration a board corner
    sits on the same line in both images."""
    import cv2

    a, b = bgr8(left), bgr8(right)
    h = max(a.shape[0], b.shape[0])
    pad = lambda x: cv2.copyMakeBorder(x, 0, h - x.shape[0], 0, 0, cv2.BORDER_CONSTANT, value=(0, 0, 0))  # noqa: E731
    gap = np.full((h, max(4, a.shape[1] // 100), 3), 255, np.uint8)
    pair, s = downscale(np.hstack([pad(a), gap, pad(b)]), max_width)
    pair = np.ascontiguousarray(pair)
    colours = ((40, 200, 40), (40, 40, 230), (230, 120, 30))
    for k in range(n_lines):
        y = round((k + 0.5) * pair.shape[0] / n_lines)
        cv2.line(pair, (0, y), (pair.shape[1] - 1, y), colours[k % len(colours)], 1, cv2.LINE_AA)
    return pair


def image_png(img: np.ndarray) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise ValueError("the picture could not be encoded")
    return buf.tobytes()
