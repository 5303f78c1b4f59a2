"""Project items as the tasks use them: look an item up by id, check its kind, load it, add
one a run made — the same interface the GUI session offers (``measurement``, ``load``,
``add_measurement``), here on a bare :class:`~camcmm.project.Project` (no trame), so a task
runs the same headless as behind a page. What an item is called (``kind_of``) and how it is
summarised (``describe``, ``size_text``) is said here once for both."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CamcmmError, InputError, one_line
from ..numbers import significant


def fmt_count(n: int) -> str:
    """``2000000`` -> ``"2 000 000"`` (thin grouping, as metrology reports write it)."""
    return f"{int(n):,}".replace(",", " ")


def kind_of(obj: Any) -> str:
    if type(obj).__name__ == "CadModel":  # a STEP/IGES nominal (camcmm.cad), stored as its file
        return "cad"
    if hasattr(obj, "faces") and hasattr(obj, "vertices"):
        return "mesh"
    if hasattr(obj, "points") and hasattr(obj, "n_points"):
        return "pointcloud"
    if hasattr(obj, "data") and hasattr(obj, "size"):
        return "image"
    return type(obj).__name__.lower()


def describe(obj: Any) -> str:
    k = kind_of(obj)
    if k == "pointcloud":
        # the fields in words (``radial_deviation`` -> "radial deviation"): the summary is read
        extra = (
            f", fields: {', '.join(str(f).replace('_', ' ') for f in obj.fields)}"
            if getattr(obj, "fields", None)
            else ""
        )
        return f"{fmt_count(obj.n_points)} points{extra}"
    if k == "mesh":
        return f"{fmt_count(obj.n_vertices)} vertices, {fmt_count(obj.n_faces)} faces"
    if k == "cad":
        return f"{obj.format} CAD model, {fmt_count(obj.n_faces)} faces"
    if k == "image":
        w, h = obj.size
        return f"image {w} × {h} px"
    if k == "heightmap":
        ny, nx = obj.shape
        return f"height map {nx} × {ny} points, {obj.n_valid / (nx * ny):.1%} valid"
    return k


def size_text(obj: Any) -> str:
    """The bounding box of a cloud or mesh in mm, e.g. ``138 × 106 × 99.3 mm``."""
    from ..units import object_span

    if kind_of(obj) == "heightmap":  # width × height, and the height range
        w, h = obj.size_mm
        z = obj.heights[obj.valid]
        span = float(np.ptp(z)) * 1e3 if z.size else 0.0
        return f"{significant(w, 3)} × {significant(h, 3)} mm, heights {significant(span, 3)} µm"
    return " × ".join(significant(x, 3) for x in object_span(obj)) + " mm"


def joined_name(*parts: Any, sep: str = "-") -> str:
    """Parts of a name joined by ``sep``, a part left out when the next one already starts with
    it (``-`` and ``_`` alike, any case): test ``sphere`` and position ``sphere-01`` give
    ``sphere-01``, not ``sphere-sphere-01``; ``ball_bar`` and ``ball-bar-01`` give
    ``ball-bar-01`` (issue 30: a name must not say its test twice). Empty parts are dropped."""

    def key(x: str) -> str:
        return re.sub(r"[-_\s]+", "-", x.strip().lower())

    texts = [str(p).strip() for p in parts if p is not None and str(p).strip()]
    kept = [t for t, nxt in zip(texts, texts[1:] + [""]) if not (nxt and (key(nxt) + "-").startswith(key(t) + "-"))]
    return sep.join(kept)


def safe_name(name: str) -> str:
    """A file name safe to write in a temp folder, keeping its extension."""
    base = Path(str(name).replace("\\", "/")).name.strip() or "upload"
    return re.sub(r"[^\w.\-+ ()\[\]]", "_", base)


def item_meta(obj: Any, source: str = "", unit: str = "", display: dict | None = None) -> dict[str, Any]:
    """What an item keeps about itself: its summary, who made it (``source``), the length unit
    its file was read in (an import's: the size in mm it gave joins the summary) and the units
    its fields are shown in (``{"deviation": "µm"}``; the data stay in mm)."""
    meta: dict[str, Any] = {"summary": describe(obj)}
    if source:
        meta["made_by"] = source
    if unit:
        meta["unit"] = unit
        meta["summary"] = f"{meta['summary']} · {size_text(obj)}"
    if display:
        meta["display_units"] = dict(display)
    return meta


def read_item(project: Any, m: dict[str, Any]) -> Any:
    """The geometry of measurement row ``m`` read from its file; InputError naming the item
    when it cannot be read (a CamcmmError passes as it is)."""
    try:
        return project.load_measurement(m["id"])
    except CamcmmError:
        raise
    except Exception as exc:
        raise InputError(one_line(exc, f"{m.get('name', m.get('id'))}: cannot load from the project")) from exc


class ProjectItems:
    """The items of ``project`` with the GUI session's interface; loaded objects are kept."""

    def __init__(self, project: Any):
        self.project = project
        self._objects: dict[str, Any] = {}

    def measurement(self, key: Any) -> dict[str, Any] | None:
        """The item ``key`` (a measurement id, as text or int); None if there is none or it
        was removed."""
        try:
            row = self.project.measurement(int(str(key).strip()))
        except (CamcmmError, TypeError, ValueError):
            return None
        return None if row.get("removed") else row

    def load(self, key: Any) -> Any:
        """The geometry of item ``key``; InputError naming it when it cannot be read."""
        key = str(key)
        if key in self._objects:
            return self._objects[key]
        m = self.measurement(key)
        if m is None:
            raise InputError(f"no item with id {key!r} in the project")
        obj = read_item(self.project, m)
        self._objects[key] = obj
        return obj

    def add_measurement(
        self, name: str, h: str, obj: Any, source: str = "", unit: str = "", display: dict | None = None
    ) -> Any:
        """Record ``obj`` (stored as file hash ``h``) as a new item; returns its id."""
        mid = self.project.add_measurement(name, h, kind_of(obj), meta=item_meta(obj, source, unit, display))
        self._objects[str(mid)] = obj
        return mid


def checked(items: Any, key: Any, kind: str) -> dict[str, str]:
    """The item ``key`` of ``items`` (a session or :class:`ProjectItems`), which must be of
    ``kind``: ``{id, name, kind}``; InputError naming the item otherwise."""
    m = items.measurement(str(key))
    if m is None:
        raise InputError(f"no item with id {key!r} in the project")
    have = str(m.get("kind") or "")
    name = str(m.get("name") or key)
    if have != kind:
        raise InputError(f"item {name!r} is a {have or 'thing of no kind'}, not a {kind}")
    return {"id": str(key), "name": name, "kind": have}


def stored_record(project: Any, key: str) -> dict[str, Any] | None:
    """A task's record of its last run under the project state ``key`` (None: none yet, or not
    readable — a damaged record must not keep a page from opening)."""
    try:
        rec = project.get_state(key)
    except Exception:
        return None
    return rec if isinstance(rec, dict) and rec.get("result") is not None else None


#: the image files a folder source lists (what OpenCV and pycolmap read)
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def folder_images(text: str, pattern: Any = "*", roots: Any = None) -> tuple[Path, list[Path], list[str]]:
    """The image files in the server folder ``text`` matching ``pattern`` (globs separated by
    ';'), sorted by name: ``(folder, files, globs)``. With ``roots`` (the page's
    :class:`~camcmm.gui.roots.Roots`) a folder outside them is refused before it is looked at,
    and a link to a file elsewhere is left out; InputError for what is not a folder. An empty
    list is the caller's to refuse in its own words."""
    import fnmatch

    root = roots.check(text, "server folder") if roots is not None else Path(text).expanduser().resolve()
    if not root.is_dir():
        raise InputError(f"folder {text}: {'is not a folder' if root.exists() else 'no such folder'}")
    globs = [p.strip() for p in str(pattern or "*").split(";") if p.strip()] or ["*"]
    files = sorted(
        p
        for p in root.iterdir()
        if p.is_file()
        and p.suffix.lower() in IMAGE_EXTS
        and any(fnmatch.fnmatch(p.name, q) for q in globs)
        and (roots is None or roots.allows(p))
    )
    return root, files, globs
