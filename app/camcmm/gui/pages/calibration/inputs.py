"""The Calibration page's input helpers: the distortion models offered, the image
items chosen by name, a board's layout for drawing. Where the board images come from (the
project's image items, an upload made items, or a folder on the server) is checked by the
task (:func:`camcmm.tasks.calibration.check_request`).
"""

from __future__ import annotations

from typing import Any

from ....errors import InputError
from ....tasks.calibration import IMAGE_EXTS
from .board import parse

__all__ = ["IMAGE_EXTS", "MODELS", "board_layout", "image_items", "split_by_name"]
MODELS = [
    {"title": "standard: k1 k2 p1 p2 k3", "value": "standard"},
    {"title": "thin prism: + s1-s4", "value": "thin-prism"},
    {"title": "rational: + k4-k6", "value": "rational"},
    {"title": "rational + thin prism", "value": "rational-thin-prism"},
]


def image_items(items: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The session's item rows of kind image."""
    return [it for it in items or [] if it.get("kind") == "image"]


def split_by_name(items: list[dict[str, Any]], stereo: bool) -> tuple[list[str], list[str]]:
    """Image item ids sorted by name: all of them for one camera; for a pair, names
    holding 'left' to the left, those holding 'right' to the right."""
    imgs = sorted(image_items(items), key=lambda it: it["name"].lower())
    if not stereo:
        return [it["id"] for it in imgs], []
    left = [it["id"] for it in imgs if "left" in it["name"].lower()]
    right = [it["id"] for it in imgs if "right" in it["name"].lower()]
    return left, right


def board_layout(spec: str) -> tuple[str, tuple[int, int] | None]:
    """(kind, (cols, rows) as OpenCV's drawing takes it) of a board spec, or (kind, None)
    when the spec cannot be read: only for drawing, the plugin judges the spec."""
    try:
        form = parse(spec)
    except InputError:
        return str(spec or "").split(":")[0].strip().lower(), None
    c, r = form["cols"], form["rows"]
    return form["kind"], ((c - 1, r - 1) if form["kind"] == "charuco" else (c, r))
