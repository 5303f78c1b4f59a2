"""The photogrammetry task: an image series in, a reconstruction (sparse and dense cloud,
the registered cameras) out — headless, as the Photogrammetry page and the tests run it.

- :class:`PhotogrammetryRequest` says where the series comes from (a folder on the server
  with a name pattern, or the project's image items) and the cloud's name;
- :func:`sources_of` checks it: a *source* is ``{name, path, item}`` (the file name the
  plugin reports the image by, the path it is read from, the item id when the image is an
  item); with ``roots`` (an object with ``check(path, what)`` and ``allows(path)``, as the
  GUI's) a folder outside them is refused before it is looked at;
- :func:`run` runs the plugin found by :data:`TASK` through :func:`camcmm.worker.run`
  (the images go as paths, read in the worker; ``progress(fraction, message)``, ``cancel``:
  a :class:`threading.Event`) and holds its outputs to :data:`CONTRACT`;
- :func:`store` puts the run into the project: the clouds as files and items made by the
  plugin, the result row (``RunResult.to_json()``) naming the image items, and the page's
  record under :data:`CURRENT_KEY`; :func:`stored` / :func:`restore` give it back;
- :func:`stage_of` reads the plugin's progress messages as :data:`STAGES`, :func:`summary`
  writes the reconstruction's figures as rows.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import numbers, worker
from ..contracts import Need, OutputContract, check_outputs, register
from ..errors import InputError
from ..host import default_host
from ..jsonable import to_jsonable
from .items import IMAGE_EXTS, folder_images, stored_record

TASK = "photogrammetry"
CURRENT_KEY = "photogrammetry.current"
#: the plugin's stages, in order, as its progress messages begin
STAGES = ("features", "matching", "mapping", "dense", "scale")
#: other words the plugin's messages begin with -> the stage they belong to
WORDS = {
    "sift": "features",
    "extract": "features",
    "extraction": "features",
    "registered": "mapping",
    "bundle": "mapping",
    "depth": "dense",
    "fusion": "dense",
    "stereo": "dense",
}


def max_images(host: Any = None) -> int:
    """Most images a series may hold (the page and the state stay responsive): the
    provider's declared ``max`` of its images input (camcmm's: plugin.yaml of
    photogrammetry.reconstruct, which the host also applies to the CLI), 0 for none."""
    return next((p.max for p in (host or default_host()).provider(TASK).inputs if p.type == "images"), 0)


#: what the Photogrammetry page (summary, image rows, scene) reads of the provider's outputs
CONTRACT = register(
    OutputContract(
        TASK,
        needs=(
            Need("cloud", "pointcloud", why="the dense cloud (the sparse one with dense off), stored and shown"),
            Need("reconstruction", "json", why="the figures, image counts and cameras stored in the record"),
            Need("sparse", "pointcloud", optional=True, why="the sparse cloud, stored and shown"),
            Need("reconstruction.n_images", "int", optional=True, why="registered of how many"),
            Need("reconstruction.n_registered", "int", optional=True, why="registered of how many"),
            Need("reconstruction.images", "list", optional=True, why="each image's counts and reason"),
            Need("reconstruction.views", "list", optional=True, why="the registered cameras as frusta"),
            Need("reconstruction.camera", "dict", optional=True, why="the frusta's opening and the camera row"),
            Need("reconstruction.reprojection_rms_px", "float", optional=True, why="the RMS row"),
            Need("reconstruction.scale", "dict", optional=True, why="the scale row"),
            Need("reconstruction.timings", "dict", optional=True, why="the time row"),
            Need("reconstruction.warnings", "list", optional=True, why="the page's warnings"),
        ),
    )
)


@dataclass
class PhotogrammetryRequest:
    """Where the series comes from: ``source`` "folder" (``folder`` on the server, name
    ``pattern``: globs separated by ';') or "items" (``items``: project image item ids);
    ``name`` the cloud's item name ("" = made up)."""

    source: str = "folder"
    folder: str = ""
    pattern: str = "*"
    items: list[str] = field(default_factory=list)
    name: str = ""

    @classmethod
    def of(cls, raw: dict[str, Any] | PhotogrammetryRequest | None) -> PhotogrammetryRequest:
        if isinstance(raw, PhotogrammetryRequest):
            return raw
        raw = dict(raw or {})
        items = raw.get("items")
        return cls(
            str(raw.get("source") or "folder"),
            str(raw.get("folder") or ""),
            str(raw.get("pattern") or "*"),
            [str(i) for i in items] if isinstance(items, (list, tuple)) else [],
            str(raw.get("name") or ""),
        )

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def stage_of(message: str) -> str:
    """The stage a progress message is in ("" when it names none of :data:`STAGES`)."""
    words = str(message or "").lower().replace(":", " ").split()[:3]
    return next((w for w in words if w in STAGES), "") or next((WORDS[w] for w in words if w in WORDS), "")


def scale_checked(values: dict[str, Any], roots: Any) -> dict[str, Any]:
    """``values`` with ``scale``'s ``lengths:FILE`` made absolute, the file inside ``roots``."""
    scale = str(values.get("scale") or "").strip()
    if scale.lower().startswith("lengths:") and roots is not None:
        values = dict(values, scale="lengths:" + str(roots.check(scale.split(":", 1)[1], "scale lengths file")))
    return values


def calibration_file(project: Any) -> Path | None:
    """The project's current camera calibration (JSON, from the calibration task), or None."""
    try:
        cur = project.get_state("calibration.current")
    except Exception:
        return None
    if not (isinstance(cur, dict) and cur.get("kind") == "camera" and cur.get("calibration")):
        return None
    try:
        return Path(project.file_path(str(cur["calibration"]))) if project.has_file(str(cur["calibration"])) else None
    except Exception:
        return None


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
    root, files, pats = folder_images(text, pattern, roots)
    if not files:
        raise InputError(f"folder {text}: no image files ({', '.join(IMAGE_EXTS)}) matching {';'.join(pats)!r}")
    most = max_images()
    if most and len(files) > most:
        raise InputError(
            f"folder {text}: {len(files)} images match {';'.join(pats)!r}; at most {most} make one "
            "series here: narrow the pattern"
        )
    return [{"name": p.name, "path": str(p.resolve()), "item": None} for p in files]


def item_sources(project: Any, item_ids: Iterable[Any]) -> list[dict[str, Any]]:
    """The project's image items ``item_ids`` (in the given order; ids are looked up,
    never used as paths)."""
    ids = [str(i) for i in (item_ids or [])]
    if not ids:
        raise InputError("image series: choose image items of the project (or give a folder on the server)")
    most = max_images()
    if most and len(ids) > most:
        raise InputError(f"image series: {len(ids)} items chosen; at most {most} make one series here")
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


def sources_of(req: PhotogrammetryRequest | dict[str, Any], project: Any, roots: Any = None) -> list[dict[str, Any]]:
    """The image sources of a request (``source``: folder or items)."""
    req = PhotogrammetryRequest.of(req)
    if req.source == "items":
        return item_sources(project, req.items)
    return folder_sources(req.folder, req.pattern, roots=roots)


def run(
    host: Any,
    sources: list[dict[str, Any]],
    params: dict[str, Any] | None = None,
    calibration: Path | None = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """The provider's :class:`~camcmm.host.RunResult`: the images go as paths, read in the
    worker process; ``calibration`` a camera calibration JSON the camera is held to."""
    if len(sources) < 2:
        raise InputError(f"image series: {len(sources)} image; a reconstruction needs several overlapping views")
    spec = host.provider(TASK)
    ins: dict[str, Any] = {"images": [s["path"] for s in sources]}
    if calibration is not None:
        ins["calibration"] = str(calibration)
    result = worker.run(host, spec.id, ins, params, progress=progress, cancel=cancel)
    check_outputs(TASK, spec.id, result.outputs)
    return result


def store(
    project: Any,
    items: Any,
    result: Any,
    req: PhotogrammetryRequest | dict[str, Any],
    sources: list[dict[str, Any]],
) -> dict[str, Any]:
    """The run into ``project`` (``items``: where the clouds are added, the session or
    :class:`~camcmm.tasks.items.ProjectItems`); returns the page's record, also kept as
    :data:`CURRENT_KEY`. InputError when the run made no points (nothing is stored)."""
    req = PhotogrammetryRequest.of(req)
    out = result.outputs
    stamp = time.strftime("%Y-%m-%d %H:%M")
    base = req.name.strip() or f"photogrammetry {len(sources)} images ({stamp})"
    # with dense off the plugin's "cloud" is the sparse cloud: one item, not the same points twice
    dense = bool((result.params or {}).get("dense", True))
    sparse = out.get("sparse") if out.get("sparse") is not None else out.get("cloud")
    clouds = [("cloud", out.get("cloud")), ("sparse", sparse)] if dense else [("sparse", sparse)]
    clouds = [(k, obj) for k, obj in clouds if getattr(obj, "n_points", 0)]
    if not clouds:
        raise InputError("the reconstruction returned no points: nothing was stored")
    hashes = {k: project.add_object(obj, f"{base} {k}") for k, obj in clouds}
    mids = [s["item"] for s in sources if s.get("item") is not None]
    rid = project.add_result(result.to_json(), measurement_ids=mids, files=hashes, label=f"photogrammetry: {base}")
    plugin = f"{result.plugin_id} {result.plugin_version}"
    made = {}
    for k, obj in clouds:
        name = base if k == "cloud" else f"{base} (sparse)"
        made[k] = str(items.add_measurement(name, hashes[k], obj, source=f"{plugin} (result #{rid})"))
    rec = {
        "result": rid,
        "items": made,
        "name": base,
        "request": req.to_dict(),
        "sources": [{"name": s["name"], "path": s["path"], "item": s.get("item")} for s in sources],
        "reconstruction": to_jsonable(out.get("reconstruction") or {}),
        "warnings": list(result.warnings),
        "plugin": plugin,
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last run, as the project keeps it (None: none yet, or unreadable)."""
    return stored_record(project, CURRENT_KEY)


def restore(project: Any) -> tuple[PhotogrammetryRequest, dict[str, Any]] | None:
    """The last run's request and record (None: none stored)."""
    rec = stored(project)
    return None if rec is None else (PhotogrammetryRequest.of(rec.get("request")), rec)


#: COLMAP's camera models (the key stays in files, parameters and the JSON) as a person reads
#: them: the model's name in words and its parameters (f focal length, c principal point,
#: k radial and p tangential distortion; COLMAP's src/colmap/sensor/models.h)
CAMERA_MODELS = {
    "SIMPLE_PINHOLE": "simple pinhole (f, cx, cy)",
    "PINHOLE": "pinhole (fx, fy, cx, cy)",
    "SIMPLE_RADIAL": "simple radial (f, cx, cy, k)",
    "RADIAL": "radial (f, cx, cy, k1, k2)",
    "OPENCV": "OpenCV (fx, fy, cx, cy, k1, k2, p1, p2)",
    "FULL_OPENCV": "full OpenCV (fx, fy, cx, cy, k1, k2, p1, p2, k3 … k6)",
}
#: the plugin's stage timings (keys of ``timings``) in words
TIMING_WORDS = {"extract": "features", "match": "matching", "map": "mapping", "refine": "final adjustment"}


def camera_words(model: Any) -> str:
    """A camera model's key (``SIMPLE_RADIAL``) in words (``simple radial (f, cx, cy, k)``)."""
    key = str(model or "")
    return CAMERA_MODELS.get(key.upper(), numbers.words(key.lower()) if key else "—")


def summary(rc: dict[str, Any]) -> list[dict[str, str]]:
    """The reconstruction's figures (``rc``: its JSON) as rows ``{name, label, value}``,
    numbers by :mod:`camcmm.numbers`."""

    def num(x: Any, digits: int = 3) -> str:  # significant digits, trailing zeros dropped
        try:
            return numbers.significant(float(x), digits)
        except (TypeError, ValueError):
            return "—"

    def whole(x: Any) -> str:
        return numbers.count(x) if isinstance(x, (int, float)) and not isinstance(x, bool) else "—"

    cam = rc.get("camera") or {}
    scale = rc.get("scale") or {}
    dense = rc.get("n_points_dense")
    out = [
        ("registered", "Registered images", f"{whole(rc.get('n_registered'))} of {whole(rc.get('n_images'))}"),
        ("rms", "Reprojection RMS", f"{num(rc.get('reprojection_rms_px'), 2)} px"),
        ("sparse", "Sparse points", whole(rc.get("n_points_sparse"))),
        ("dense", "Dense points", whole(dense) if dense else "— (off)"),
        (
            "camera",
            "Camera",
            f"{camera_words(cam.get('model'))}: f = {num(cam.get('fx'), 5)} / {num(cam.get('fy'), 5)} px, "
            f"c = ({num(cam.get('cx'), 5)}, {num(cam.get('cy'), 5)}) px"
            if cam
            else "—",
        ),
    ]
    if scale:
        u = scale.get("u")
        out.append(
            (
                "scale",
                "Scale",
                f"{numbers.words(scale.get('method', '?'))}: × {num(scale.get('factor'), 6)}"
                + (f" (standard uncertainty u {num(u, 2)})" if u else ""),
            )
        )
    timings = rc.get("timings") or {}
    if isinstance(timings, dict) and timings:
        out.append(
            (
                "timings",
                "Time",
                ", ".join(f"{TIMING_WORDS.get(k) or numbers.words(k)} {numbers.time(v)}" for k, v in timings.items()),
            )
        )
    return [{"name": n, "label": label, "value": v} for n, label, v in out]
