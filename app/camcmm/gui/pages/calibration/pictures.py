"""The pictures of one calibration, made in a worker thread: an image with its detected
board, and a used pair rectified by the rectification plugin with horizontal lines.

Each is ``(data URL, note)``; a picture that cannot be made is ``("", note saying why)``
so the list and the numbers stay. Images already read by the run are used again; else
they are read from their source (the project's copy or the original file).
"""

from __future__ import annotations

from typing import Any

from ....errors import InputError, one_line
from ....tasks.calibration import read_source, rectify
from . import draw, inputs
from . import results as res


def image(project: Any, doc: dict[str, Any], side: str, name: str, images: dict[str, list] | None = None) -> Any:
    """Image ``name`` of camera ``side`` (a :class:`camcmm.model.Image`)."""
    for img in (images or {}).get(side) or []:
        if img.name == name:
            return img
    src = next((x for x in doc["sources"].get(side) or [] if x["name"] == name), None)
    if src is None:
        raise InputError(f"{name}: not among the calibration's images")
    return read_source(src, project)


def first_used(doc: dict[str, Any], side: str = "left") -> str | None:
    """The first image the calibration used (else the first image) of camera ``side``."""
    rows = res.view_rows(res.camera_part(doc["outputs"], doc["request"]["mode"], side))
    return next((r["name"] for r in rows if r["status"] == "used"), rows[0]["name"] if rows else None)


def overlay(
    project: Any, doc: dict[str, Any], side: str, name: str, images: dict[str, list] | None = None
) -> tuple[str, str]:
    """(data URL, note) of image ``name`` with its detected board drawn."""
    cam = res.camera_part(doc["outputs"], doc["request"]["mode"], side)
    det = next((d for d in cam["detections"] if d["image"] == name), None)
    row = next((r for r in res.view_rows(cam) if r["name"] == name), None)
    if det is None or row is None:
        return "", f"{name}: not among the calibration's images"
    if row["status"] == "used":
        note = f"{name}: {row['n']} points, view RMS {res.fmt(row['rms'], 3)} px"
    else:
        note = f"{name}: {row['status']}: {row['reason']}"
    try:
        img = image(project, doc, side, name, images)
    except Exception as exc:
        return "", f"{note} (image not shown: {one_line(exc)})"
    _, layout = inputs.board_layout(doc["request"]["board"])
    text = "" if row["status"] == "used" else f"{row['status']}: {row['reason']}"
    return draw.data_url(draw.draw_detection(img.data, det.get("corners"), layout, row["status"], text)), note


def rectified(
    host: Any, project: Any, doc: dict[str, Any], index: int, images: dict[str, list] | None = None
) -> tuple[str, str]:
    """(data URL, note) of used pair ``index`` rectified by the plugin, with horizontal lines."""
    pairs = doc["outputs"].get("pairs") or []
    if not 0 <= int(index) < len(pairs):
        return "", "no pair to show"
    ln, rn = pairs[int(index)]
    try:
        left, right = image(project, doc, "left", ln, images), image(project, doc, "right", rn, images)
        left, right = rectify(host, doc["outputs"]["calibration"], left, right)
        pic = draw.rectified_pair(left.data, right.data)
    except Exception as exc:
        return "", f"{ln} / {rn}: the rectified pair cannot be shown: {one_line(exc)}"
    dy = doc["outputs"].get("rectified_dy") or {}
    return draw.data_url(pic), (
        f"{ln} / {rn} rectified: a board corner lies on the same row in both images "
        f"(row difference over all pairs: RMS {res.fmt(dy.get('rms'), 2)} px, "
        f"max {res.fmt(dy.get('max'), 2)} px)"
    )
