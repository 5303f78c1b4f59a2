"""Where the Calibration page's board images come from: the project's image items, an
upload (which becomes image items) or a folder on the server (a glob per camera).

A *source* is a JSON-able dict ``{name, path, hash, item}``: the name the operator knows
(the item's or the file's name), the path it was read from, the project file hash when
the image lives in the project (so a reopened page finds it again) and the item id.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ....errors import InputError

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
BOARD_HELP = (
    "chessboard:COLSxROWS:SQUARE_MM counts inner corners (chessboard:9x6:25); "
    "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT] counts squares; circles:COLSxROWS:SPACING_MM; "
    "acircles:COLSxROWS:SPACING_MM (OpenCV's asymmetric grid)"
)
#: one line per board kind, shown under the board field for the kind being typed
BOARD_HINTS = {
    "chessboard": "chessboard:COLSxROWS:SQUARE_MM, inner corners as OpenCV counts them, e.g. chessboard:9x6:25",
    "charuco": "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT], squares, e.g. charuco:11x8:15:11 (DICT_5X5_100)",
    "circles": "circles:COLSxROWS:SPACING_MM, symmetric grid of circles, e.g. circles:7x6:20",
    "acircles": "acircles:COLSxROWS:SPACING_MM, OpenCV's asymmetric circle grid, e.g. acircles:4x11:10",
    "": "chessboard:9x6:25 (inner corners), charuco:11x8:15:11, circles:7x6:20 or acircles:4x11:10",
}
#: the keys of a run request (the layout sends them; the project remembers the last)
REQUEST_KEYS = (
    "mode",
    "source",
    "left",
    "right",
    "folder",
    "left_pattern",
    "right_pattern",
    "board",
    "model",
    "outlier_factor",
    "name",
)
MODELS = [
    {"title": "standard: k1 k2 p1 p2 k3", "value": "standard"},
    {"title": "thin prism: + s1-s4", "value": "thin-prism"},
    {"title": "rational: + k4-k6", "value": "rational"},
    {"title": "rational + thin prism", "value": "rational-thin-prism"},
]


def _unique(names: Iterable[str]) -> list[str]:
    """Names made unique by a suffix: the calibration keys its per-view errors by name."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        k = seen.get(n, 0)
        seen[n] = k + 1
        out.append(n if k == 0 else f"{n} ({k + 1})")
    return out


def folder_sources(folder: str, pattern: str = "*", what: str = "images", roots: Any = None) -> list[dict[str, Any]]:
    """Image files in ``folder`` matching ``pattern`` (a glob; ';' separates several),
    sorted by name. With ``roots`` (a :class:`~camcmm.gui.roots.Roots`, the folders the
    browser may reach) a folder elsewhere is refused before it is looked at."""
    text = str(folder or "").strip().strip('"')
    if not text:
        raise InputError(f"{what}: give the folder on the server that holds the board images")
    root = roots.check(text, "server folder") if roots is not None else Path(text).expanduser()
    if not root.is_dir():
        raise InputError(f"folder {text}: {'is not a folder' if root.exists() else 'no such folder'}")
    pats = [p.strip() for p in str(pattern or "*").split(";") if p.strip()] or ["*"]
    files = sorted(
        p
        for p in root.iterdir()
        if p.is_file()
        and p.suffix.lower() in IMAGE_EXTS
        and any(fnmatch.fnmatch(p.name, q) for q in pats)
        and (roots is None or roots.allows(p))
    )  # a link to a file elsewhere stays out
    if not files:
        raise InputError(f"{what}: no image files ({', '.join(IMAGE_EXTS)}) matching {';'.join(pats)!r} in {root}")
    return [{"name": p.name, "path": str(p.resolve()), "hash": None, "item": None} for p in files]


def item_sources(project: Any, item_ids: Iterable[Any], what: str = "images") -> list[dict[str, Any]]:
    """The project's image items ``item_ids`` (in the given order)."""
    ids = [str(i) for i in (item_ids or [])]
    if not ids:
        raise InputError(f"{what}: choose the board images among the project's image items (or upload them)")
    known = {str(m["id"]): m for m in project.measurements()}
    out = []
    for i in ids:
        m = known.get(i)
        if m is None:
            raise InputError(f"{what}: item {i} is no longer in the project")
        if m.get("kind") != "image":
            raise InputError(f"{what}: item {m.get('name', i)!r} is a {m.get('kind')}, not an image")
        out.append(
            {
                "name": str(m.get("name") or i),
                "path": str(project.file_path(m["hash"])),
                "hash": m["hash"],
                "item": m["id"],
            }
        )
    for s, n in zip(out, _unique([s["name"] for s in out])):
        s["name"] = n
    return out


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


def resolve(path: str | None, h: str | None, project: Any) -> Path | None:
    """The file of a source now: the project's copy, else the original path."""
    if h:
        try:
            if project.has_file(h):
                return project.file_path(h)
        except Exception:
            pass
    if path and Path(path).is_file():
        return Path(path)
    return None


def read_source(src: dict[str, Any], project: Any) -> Any:
    """A source read as a :class:`camcmm.model.Image` named as the operator knows it."""
    from .... import io as cio

    p = resolve(src.get("path"), src.get("hash"), project)
    if p is None:
        raise InputError(f"{src.get('name')}: the image is no longer at {src.get('path')}")
    img = cio.read(p)
    if not hasattr(img, "data") or not hasattr(img, "size"):
        raise InputError(f"{src.get('name')}: not an image file")
    img.name = str(src.get("name"))
    return img


def board_layout(spec: str) -> tuple[str, tuple[int, int] | None]:
    """(kind, (cols, rows) as OpenCV's drawing takes it) of a board spec, or (kind, None)
    when the spec cannot be read: only for drawing, the plugin judges the spec."""
    parts = str(spec or "").split(":")
    kind = parts[0].strip().lower()
    try:
        c, r = (int(v) for v in parts[1].lower().replace("×", "x").split("x"))
    except (IndexError, ValueError):
        return kind, None
    return kind, ((c - 1, r - 1) if kind == "charuco" else (c, r))


def check_request(
    req: dict[str, Any], project: Any, roots: Any = None
) -> tuple[dict[str, Any], dict[str, list[dict[str, Any]]]]:
    """The request cleaned (mode, board, model, outlier factor) and its image sources
    ``{"left": [...], "right": [...]}`` (one camera: left only); InputError naming what is
    wrong. Reads the project (loop thread); the plugin judges the board spec itself."""
    req = {k: req.get(k) for k in REQUEST_KEYS}
    mode = "stereo" if req["mode"] == "stereo" else "camera"
    req["mode"] = mode
    req["board"] = str(req.get("board") or "").strip()
    if not req["board"]:
        raise InputError("board: give the board spec, e.g. chessboard:9x6:25 (" + BOARD_HELP + ")")
    try:
        req["outlier_factor"] = float(req.get("outlier_factor") if req.get("outlier_factor") not in (None, "") else 3.0)
    except (TypeError, ValueError):
        raise InputError(f"outlier factor: {req.get('outlier_factor')!r} is not a number") from None
    req["model"] = req.get("model") or "standard"
    first = "left images" if mode == "stereo" else "images"
    if req.get("source") == "folder":
        src = {"left": folder_sources(req["folder"], req.get("left_pattern") or "*", first, roots=roots)}
        if mode == "stereo":
            src["right"] = folder_sources(req["folder"], req.get("right_pattern") or "*", "right images", roots=roots)
    else:
        req["source"] = "items"
        src = {"left": item_sources(project, req.get("left"), first)}
        if mode == "stereo":
            src["right"] = item_sources(project, req.get("right"), "right images")
    if mode == "stereo":
        both = {s["path"] for s in src["left"]} & {s["path"] for s in src["right"]}
        if both:
            raise InputError(
                f"the same image is among the left and the right images ({len(both)} of them); "
                "give each camera its own images"
            )
    return req, src
