"""Camera images: PNG, JPEG, TIFF, BMP through OpenCV (imported only when needed).

Reading keeps the stored depth and channels (``IMREAD_UNCHANGED``): ``data`` is
(H, W) for grey, (H, W, 3) or (H, W, 4) in OpenCV's **BGR(A)** order, uint8 or
uint16 (16-bit PNG/TIFF from machine-vision cameras) or float32 (TIFF). Only the first
page of a multi-page TIFF is read. The bytes are read by Python and decoded from
memory, so paths with non-ASCII characters work on every platform.

Writing encodes ``Image.data`` unchanged (BGR order) with the extension's codec.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..model import Image
from ._common import fail


def read(path: Path, name: str) -> Image:
    import cv2

    buf = np.fromfile(path, np.uint8)
    try:
        data = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise fail(name, f"cannot decode the image ({' '.join(str(exc).split())[:160]})") from exc
    if data is None:
        raise fail(name, f"cannot decode the image: not a valid {path.suffix.lstrip('.').upper()} file")
    meta = {"file": name, "channel_order": "BGR" if data.ndim == 3 else "grey"}
    return Image(data, name=name, metadata=meta)


def write(obj, path: Path, *, binary: bool, unit: str, factor: float, name: str) -> None:
    import cv2

    try:
        ok, encoded = cv2.imencode(path.suffix.lower(), np.asarray(obj.data))
    except cv2.error as exc:
        raise fail(name, f"cannot encode the image ({' '.join(str(exc).split())[:160]})") from exc
    if not ok:
        raise fail(name, f"OpenCV cannot encode a {obj.data.dtype} {obj.data.shape} image as {path.suffix}")
    encoded.tofile(path)
