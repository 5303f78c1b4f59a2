"""The Photogrammetry page's image list: thumbnails and rows with the plugin's counts.

Where a series comes from (a folder inside the roots, or image items) is checked by the
task (:func:`camcmm.tasks.photogrammetry.sources_of`); a *source* is ``{name, path, item}``.

Thumbnails are small PNG ``data:`` URLs made server-side (at most :data:`MAX_THUMBS` of
:data:`THUMB_WIDTH` px): a large JPEG is decoded at 1/4 or 1/8 of its size by libjpeg's
own scaling, so a 24-MP series costs little.
"""

from __future__ import annotations

import base64
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ....errors import CamcmmError

#: thumbnails made for a series (the rest are listed by name only): ~13 kB each in the state
MAX_THUMBS = 60
THUMB_WIDTH = 96


def image_items(items: Iterable[dict[str, Any]] | None) -> list[dict[str, Any]]:
    """The session's item rows of kind image."""
    return [it for it in items or [] if it.get("kind") == "image"]


def _decode_small(path: Path, width: int) -> np.ndarray | None:
    """The image at ``path`` decoded at a reduced size where libjpeg can (BGR 8-bit)."""
    import cv2

    from ....io.image import load_bytes, measure

    buf = load_bytes(path, path.name)
    measure(buf, path.suffix, path.name)  # the project's pixel cap, before any decode
    size = buf.size
    flag = cv2.IMREAD_COLOR
    if size > 8_000_000:
        flag = cv2.IMREAD_REDUCED_COLOR_8
    elif size > 1_000_000:
        flag = cv2.IMREAD_REDUCED_COLOR_4
    img = cv2.imdecode(buf, flag)
    if img is None:
        return None
    h, w = img.shape[:2]
    if w > width:
        img = cv2.resize(img, (width, max(1, round(h * width / w))), interpolation=cv2.INTER_AREA)
    return img


def thumbnail(path: str | Path, width: int = THUMB_WIDTH) -> str:
    """A small PNG ``data:`` URL of the image at ``path`` ("" when it cannot be read)."""
    import cv2

    try:
        img = _decode_small(Path(path), int(width))
    except (OSError, ValueError, cv2.error, CamcmmError):  # no thumbnail; the run says why
        return ""
    if img is None:
        return ""
    ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 6])
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode("ascii") if ok else ""


def rows(sources: list[dict[str, Any]], thumbs: list[str] | None = None) -> list[dict[str, Any]]:
    """The image list's rows before a reconstruction: name, thumbnail, no counts yet."""
    thumbs = list(thumbs or [])
    return [
        {
            "name": s["name"],
            "thumb": thumbs[i] if i < len(thumbs) else "",
            "n_features": None,
            "n_matched": None,
            "registered": None,
            "reason": "",
            "status": "listed",
        }
        for i, s in enumerate(sources)
    ]


def without_counts(row: dict[str, Any]) -> dict[str, Any]:
    """A row as listed before a run: its name and thumbnail kept, a run's counts and status gone."""
    return dict(row, n_features=None, n_matched=None, registered=None, reason="", status="listed")


def with_counts(listed: list[dict[str, Any]], images: list[dict[str, Any]] | None) -> list[dict[str, Any]]:
    """The rows with the plugin's per-image counts (``reconstruction["images"]``:
    ``{image, n_features, n_matched, registered, reason}``), matched by file name;
    status ``registered`` or ``unregistered`` (with the plugin's reason)."""
    by_name = {Path(str(d.get("image", ""))).name: d for d in images or []}
    out = []
    for r in listed:
        d = by_name.get(Path(r["name"]).name)
        row = dict(r)
        if d is not None:
            reg = bool(d.get("registered"))
            row.update(
                n_features=d.get("n_features"),
                n_matched=d.get("n_matched"),
                registered=reg,
                reason="" if reg else str(d.get("reason") or "not registered"),
                status="registered" if reg else "unregistered",
            )
        out.append(row)
    return out
