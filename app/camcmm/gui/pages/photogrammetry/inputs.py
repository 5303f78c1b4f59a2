"""Where the Photogrammetry page's image series comes from, and its thumbnails.

A series is a folder on the server (inside the project folder or a ``--data-root``:
every path from the browser goes through :meth:`camcmm.gui.roots.Roots.check`) with a
name pattern, or the project's image items. A *source* is a JSON-able dict
``{name, path, item}``: the file name the plugin reports the image by, the path it is
read from, and the item id when the image lives in the project.

Thumbnails are small PNG ``data:`` URLs made server-side (at most :data:`MAX_THUMBS` of
:data:`THUMB_WIDTH` px): a large JPEG is decoded at 1/4 or 1/8 of its size by libjpeg's
own scaling, so a 24-MP series costs little.
"""

from __future__ import annotations

import base64
import fnmatch
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ....errors import InputError

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
#: most images a series may hold (the page and the state stay responsive)
MAX_IMAGES = 400
#: thumbnails made for a series (the rest are listed by name only): ~13 kB each in the state
MAX_THUMBS = 60
THUMB_WIDTH = 96


def folder_sources(folder: Any, pattern: Any = "*", roots: Any = None) -> list[dict[str, Any]]:
    """The image files in ``folder`` matching ``pattern`` (globs separated by ';'),
    sorted by name. With ``roots`` a folder outside them is refused before it is
    looked at, and a link to a file elsewhere is left out."""
    text = str(folder or "").strip().strip('"')
    if not text:
        raise InputError(
            "image series: give a folder on the server that holds the images (inside the project "
            "folder or a --data-root), or choose image items of the project"
        )
    root = roots.check(text, "server folder") if roots is not None else Path(text).expanduser().resolve()
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
    )
    if not files:
        raise InputError(f"folder {text}: no image files ({', '.join(IMAGE_EXTS)}) matching {';'.join(pats)!r}")
    if len(files) > MAX_IMAGES:
        raise InputError(
            f"folder {text}: {len(files)} images match {';'.join(pats)!r}; at most {MAX_IMAGES} make one "
            "series here: narrow the pattern"
        )
    return [{"name": p.name, "path": str(p.resolve()), "item": None} for p in files]


def item_sources(project: Any, item_ids: Iterable[Any]) -> list[dict[str, Any]]:
    """The project's image items ``item_ids`` (in the given order; ids from the browser
    are looked up, never used as paths)."""
    ids = [str(i) for i in (item_ids or [])]
    if not ids:
        raise InputError("image series: choose image items of the project (or give a folder on the server)")
    if len(ids) > MAX_IMAGES:
        raise InputError(f"image series: {len(ids)} items chosen; at most {MAX_IMAGES} make one series here")
    known = {str(m["id"]): m for m in project.measurements()}
    out, names = [], set()
    for i in ids:
        m = known.get(i)
        if m is None:
            raise InputError(f"image series: item {i[:40]!r} is not in the project")
        if m.get("kind") != "image":
            raise InputError(f"image series: item {m.get('name', i)!r} is a {m.get('kind')}, not an image")
        path = Path(project.file_path(m["hash"]))
        name = str(m.get("name") or path.name)
        if name in names:  # the plugin reports images by name: two alike could not be told apart
            name = f"{Path(name).stem} ({m['id']}){Path(name).suffix}"
        names.add(name)
        out.append({"name": name, "path": str(path), "item": m["id"]})
    return out


def image_items(items: Iterable[dict[str, Any]] | None) -> list[dict[str, Any]]:
    """The session's item rows of kind image."""
    return [it for it in items or [] if it.get("kind") == "image"]


def _decode_small(path: Path, width: int) -> np.ndarray | None:
    """The image at ``path`` decoded at a reduced size where libjpeg can (BGR 8-bit)."""
    import cv2

    buf = np.fromfile(str(path), dtype=np.uint8)
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
    except (OSError, ValueError, cv2.error):
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
