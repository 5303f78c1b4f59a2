"""The calibration task: board images in, a camera or stereo calibration out — headless,
as the Calibration page and the tests run it.

- :class:`CalibrationRequest` is what the page sends (mode, where the images are, board,
  model, outlier factor, name); :func:`check_request` cleans it and finds its image
  *sources* ``{"left": [...], "right": [...]}`` (one camera: left only), each
  ``{name, path, hash, item}``: the name the operator knows, the path it was read from,
  the project file hash when the image lives in the project and the item id; with
  ``roots`` (an object with ``check(path, what)`` and ``allows(path)``, as the GUI's) a
  folder elsewhere is refused before it is looked at;
- :func:`run` reads the images, runs the plugin found by the task (:data:`CAMERA` or
  :data:`STEREO`) through :func:`camcmm.worker.run` (``progress(fraction, message)``,
  ``cancel``: a :class:`threading.Event`), holds its outputs to the contract and makes
  each camera's projection-uncertainty map (:data:`PROJECTION`);
- :func:`first_source` and :func:`check_board` look for the board in the first image
  before calibrating (the plugin found by :data:`BOARD_CHECK`): how many of its points
  are found, or why none;
- :func:`store` keeps the calibration JSON and OpenCV YAML, the page document (the
  request, sources, outputs, warnings, maps and the page's thumbnails) and the result row
  (``RunResult.to_json()``), and remembers them as the project's current calibration;
  :func:`stored` / :func:`restore` give them back; :func:`use_for_system` lets a
  measuring system refer to it.

The plugins are found by the task they declare, as the CLI finds them, so the page shows
the CLI's numbers.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import tempfile
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import worker
from ..contracts import Need, OutputContract, check_outputs, register
from ..errors import InputError
from ..host import Cancelled
from ..jsonable import to_jsonable
from .items import IMAGE_EXTS, folder_images

CAMERA, STEREO, PROJECTION, RECTIFY, BOARD_CHECK = (
    "camera-calibration",
    "stereo-calibration",
    "projection-uncertainty",
    "rectification",
    "board-detection",
)
#: the task the page runs (one camera; a pair runs :data:`STEREO`)
TASK = CAMERA
CURRENT_KEY, INPUTS_KEY = "calibration.current", "calibration.inputs"
#: (columns, rows) of the projection-uncertainty map
MAP_GRID = (48, 36)
#: the value of "use for" that makes a new measuring system
NEW = "new"
BOARD_HELP = (
    "chessboard:COLSxROWS:SQUARE_MM counts inner corners (chessboard:9x6:25); "
    "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT] counts squares; circles:COLSxROWS:SPACING_MM; "
    "acircles:COLSxROWS:SPACING_MM (OpenCV's asymmetric grid)"
)

_CAMERA_NEEDS = (
    Need("camera_matrix", "json", why="the numbers fx fy cx cy"),
    Need("dist_coeffs", "any", why="the distortion coefficients"),
    Need("rms", "float", why="the RMS reprojection error"),
    Need("per_view_rms", "dict", why="each view's RMS and which views were used"),
    Need("detections", "list", why="the image list and the corners drawn"),
    Need("calibration", "dict", optional=True, why="the heat map's board poses"),
    Need("rejected", "list", optional=True, why="the views left out with their reason"),
    Need("std_named", "dict", optional=True, why="the numbers' standard deviations"),
    Need("image_size", "any", optional=True, why="the heat map's extent"),
    Need("board_distance", "float", optional=True, why="the heat map's first working distance"),
)
#: what the page (numbers, image list, charts, heat map, rectified pair) reads of each provider
CONTRACTS = {
    CAMERA: register(OutputContract(CAMERA, needs=_CAMERA_NEEDS)),
    STEREO: register(
        OutputContract(
            STEREO,
            needs=(
                Need("left", "dict", why="the left camera's numbers"),
                Need("right", "dict", why="the right camera's numbers"),
                Need("rms", "float", why="the stereo RMS"),
                Need("detections", "dict", why="each camera's image list"),
                Need("calibration", "dict", why="the rectified pair"),
                Need("single", "dict", optional=True, why="each camera's heat map"),
                Need("rejected", "list", optional=True, why="the pairs left out"),
                Need("pairs", "list", optional=True, why="the pairs used and the rectified view"),
                Need("rvec", "any", optional=True, why="the pose rows"),
                Need("T", "any", optional=True, why="the pose rows"),
                Need("baseline", "float", optional=True, why="the summary and the pose rows"),
                Need("epipolar", "dict", optional=True, why="the epipolar rows"),
                Need("rectified_dy", "dict", optional=True, why="the rectified rows"),
            ),
        )
    ),
    PROJECTION: register(
        OutputContract(
            PROJECTION,
            needs=(
                Need("map", "list", why="the heat map"),
                Need("u", "any", why="the heat map's columns"),
                Need("v", "any", why="the heat map's rows"),
                Need("min", "float", why="the heat map's range"),
                Need("max", "float", why="the heat map's range"),
                Need("centre", "float", why="the heat map's note"),
                Need("distance", "float", optional=True, why="the heat map's title"),
                Need("method", "str", optional=True, why="the heat map's note"),
            ),
        )
    ),
    RECTIFY: register(
        OutputContract(
            RECTIFY,
            needs=(Need("left", "any", why="the rectified pair"), Need("right", "any", why="the rectified pair")),
        )
    ),
    BOARD_CHECK: register(
        OutputContract(
            BOARD_CHECK,
            needs=(
                Need("found", "bool", why="the board check's verdict"),
                Need("count", "int", why="the points found"),
                Need("expected", "int", why="the points of the whole board"),
                Need("points", "str", why="what the points are, in words"),
                Need("reason", "str", why="why the board was not found"),
                Need("corners", "list", why="the points drawn over the image"),
            ),
        )
    ),
}
#: what to check when the board is not found in an image, per kind of board
BOARD_HINTS = {
    "chessboard": "count the inner corners, where four squares meet: one fewer than the squares along each side",
    "charuco": "check the squares across × down and the marker dictionary",
    "circles": "check the circles across × down",
    "acircles": "check the circles per row × the rows",
}


@dataclass
class CalibrationRequest:
    """A calibration as the page asks for it (None: not given). ``mode`` "camera" or
    "stereo"; ``source`` "items" (``left``/``right``: image item ids) or "folder"
    (``folder`` with a glob per camera); ``board`` e.g. ``chessboard:9x6:25``; ``model``
    the distortion model; ``outlier_factor`` views whose RMS exceeds it × the median are
    left out; ``name`` the calibration's name ("" = made up)."""

    mode: str = "camera"
    source: str | None = None
    left: list[str] | None = None
    right: list[str] | None = None
    folder: str | None = None
    left_pattern: str | None = None
    right_pattern: str | None = None
    board: str = ""
    model: str = "standard"
    outlier_factor: Any = 3.0
    name: str | None = None

    @classmethod
    def of(cls, raw: dict[str, Any] | CalibrationRequest | None) -> CalibrationRequest:
        """A request from the page's or the project's dict (unknown keys dropped)."""
        if isinstance(raw, CalibrationRequest):
            return raw
        raw = dict(raw or {})
        known = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in raw.items() if k in known and v is not None})

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


# -- the image sources --------------------------------------------------------------------
def _unique(names: Iterable[str]) -> list[str]:
    """Names made unique by a suffix: the calibration keys its per-view errors by name."""
    seen: dict[str, int] = {}
    out = []
    for n in names:
        k = seen.get(n, 0)
        seen[n] = k + 1
        out.append(n if k == 0 else f"{n} ({k + 1})")
    return out


def folder_sources(folder: Any, pattern: Any = "*", what: str = "images", roots: Any = None) -> list[dict[str, Any]]:
    """Image files in ``folder`` matching ``pattern`` (a glob; ';' separates several),
    sorted by name. With ``roots`` a folder elsewhere is refused before it is looked at,
    and a link to a file elsewhere stays out."""
    text = str(folder or "").strip().strip('"')
    if not text:
        raise InputError(f"{what}: give the folder on the server that holds the board images")
    root, files, pats = folder_images(text, pattern, roots)
    if not files:
        raise InputError(f"{what}: no image files ({', '.join(IMAGE_EXTS)}) matching {';'.join(pats)!r} in {root}")
    return [{"name": p.name, "path": str(p.resolve()), "hash": None, "item": None} for p in files]


def item_sources(project: Any, item_ids: Iterable[Any] | None, what: str = "images") -> list[dict[str, Any]]:
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
            {"name": str(m.get("name") or i), "path": str(project.file_path(m["hash"])), "hash": m["hash"],
             "item": m["id"]}
        )  # fmt: skip
    for s, n in zip(out, _unique([s["name"] for s in out])):
        s["name"] = n
    return out


def check_request(
    req: CalibrationRequest | dict[str, Any], project: Any, roots: Any = None
) -> tuple[CalibrationRequest, dict[str, list[dict[str, Any]]]]:
    """The request cleaned (mode, board, model, outlier factor) and its image sources;
    InputError naming what is wrong. The plugin judges the board spec itself."""
    req = dataclasses.replace(CalibrationRequest.of(req))
    mode = req.mode = "stereo" if req.mode == "stereo" else "camera"
    req.board = str(req.board or "").strip()
    if not req.board:
        raise InputError("board: give the board and its square size, e.g. chessboard:9x6:25 (" + BOARD_HELP + ")")
    try:
        req.outlier_factor = float(req.outlier_factor if req.outlier_factor not in (None, "") else 3.0)
    except (TypeError, ValueError):
        raise InputError(f"outlier factor: {req.outlier_factor!r} is not a number") from None
    req.model = req.model or "standard"
    first = "left images" if mode == "stereo" else "images"
    if req.source == "folder":
        src = {"left": folder_sources(req.folder, req.left_pattern or "*", first, roots=roots)}
        if mode == "stereo":
            src["right"] = folder_sources(req.folder, req.right_pattern or "*", "right images", roots=roots)
    else:
        req.source = "items"
        src = {"left": item_sources(project, req.left, first)}
        if mode == "stereo":
            src["right"] = item_sources(project, req.right, "right images")
    if mode == "stereo":
        both = {s["path"] for s in src["left"]} & {s["path"] for s in src["right"]}
        if both:
            raise InputError(
                f"the same image is among the left and the right images ({len(both)} of them); "
                "give each camera its own images"
            )
    return req, src


def resolve(path: str | None, h: str | None, project: Any) -> Path | None:
    """The file of a source now: the project's copy, else the original path."""
    if h:
        try:
            if project.has_file(h):
                return Path(project.file_path(h))
        except Exception:
            pass
    if path and Path(path).is_file():
        return Path(path)
    return None


def read_source(src: dict[str, Any], project: Any) -> Any:
    """A source read as a :class:`camcmm.model.Image` named as the operator knows it."""
    from .. import io as cio

    p = resolve(src.get("path"), src.get("hash"), project)
    if p is None:
        raise InputError(f"{src.get('name')}: the image is no longer at {src.get('path')}")
    img = cio.read(p)
    if not hasattr(img, "data") or not hasattr(img, "size"):
        raise InputError(f"{src.get('name')}: not an image file")
    img.name = str(src.get("name"))
    return img


# -- the board checked on the first image, before calibrating ------------------------------
def first_source(req: CalibrationRequest | dict[str, Any], project: Any, roots: Any = None) -> dict[str, Any] | None:
    """The first image the request names (the left camera's), or None while it names none
    (no items chosen, no folder typed, no file matching): the board check has nothing
    to look at yet, which is not an error."""
    req = CalibrationRequest.of(req)
    try:
        if req.source == "folder":
            src = folder_sources(req.folder, req.left_pattern or "*", roots=roots)
        else:
            src = item_sources(project, req.left)
    except InputError:
        return None
    return src[0] if src else None


def check_board(host: Any, image: Any, board: str) -> dict[str, Any]:
    """The board ``board`` (a spec) looked for in one ``image`` (a read source, see
    :func:`read_source`) by the plugin found by :data:`BOARD_CHECK`, as the calibration
    will look for it: ``{image, found, count, expected, points, reason, corners, text}``;
    ``text`` says it in one line, e.g. "found 54 of 54 inner corners on left01.jpg", or
    why not and what to check."""
    spec = host.provider(BOARD_CHECK)
    out = to_jsonable(worker.run(host, spec.id, {"image": image}, {"board": board}).outputs)
    check_outputs(BOARD_CHECK, spec.id, out)
    name, n, total = str(image.name), int(out["count"]), int(out["expected"])
    text = f"found {n} of {total} {out['points']} on {name}"
    if not out["found"]:
        kind = board.split(":", 1)[0].strip().lower()
        text += f": {out['reason'] or 'board not found'}; {BOARD_HINTS.get(kind, 'check the board')}"
    return {"image": name, **{k: out[k] for k in ("found", "count", "expected", "points", "reason", "corners")},
            "text": text}  # fmt: skip


# -- one camera of the outputs ------------------------------------------------------------
def sides(mode: str) -> list[str]:
    return ["left", "right"] if mode == "stereo" else ["left"]


def side_title(mode: str, side: str) -> str:
    return "camera" if mode != "stereo" else f"{side} camera"


def camera_part(outputs: dict[str, Any], mode: str, side: str = "left") -> dict[str, Any]:
    """One camera's numbers, detections and the calibration its heat map comes from (a
    pair's outputs hold them per camera, the pairs left out under ``rejected``)."""
    if mode != "stereo":
        return {
            **outputs,
            "detections": outputs.get("detections") or [],
            "map_calibration": outputs.get("calibration"),
            "pair_rejected": {},
        }
    cam = dict(outputs.get(side) or {})
    k = 0 if side == "left" else 1
    pair_rejected = {}
    for r in outputs.get("rejected") or []:
        rms = r.get("rms")
        pair_rejected[r.get(side)] = {
            "reason": r.get("reason", ""),
            "rms": rms[k] if isinstance(rms, list) and len(rms) == 2 else None,
        }
    cam["detections"] = (outputs.get("detections") or {}).get(side) or []
    cam["map_calibration"] = (outputs.get("single") or {}).get(side)
    cam["pair_rejected"] = pair_rejected
    return cam


def default_distance(cam: dict[str, Any]) -> float:
    """The working distance (mm) the heat map first shows: the board's median depth in
    the views the calibration used (the plugin's ``board_distance``), to 3 digits; 1000 mm
    when the plugin gives none."""
    try:
        d = float(cam.get("board_distance"))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return 1000.0
    if not (math.isfinite(d) and d > 0):
        return 1000.0
    return float(f"{d:.3g}")


def projection_map(host: Any, cam: dict[str, Any], distance: float) -> dict[str, Any] | None:
    """The projection-uncertainty plugin's map (σ px over a (rows, columns) grid, u, v,
    min, max, centre) of one camera at ``distance`` mm; None without a calibration with
    board poses."""
    cal = cam.get("map_calibration")
    if not cal:
        return None
    spec = host.provider(PROJECTION)
    params = {"distance": float(distance), "columns": MAP_GRID[0], "rows": MAP_GRID[1]}
    out = to_jsonable(worker.run(host, spec.id, {"calibration": cal}, params).outputs)
    check_outputs(PROJECTION, spec.id, out)
    out.setdefault("distance", float(distance))
    return {k: out.get(k) for k in ("map", "u", "v", "distance", "min", "max", "centre", "method")}


def rectify(host: Any, calibration: dict[str, Any], left: Any, right: Any) -> tuple[Any, Any]:
    """A left and right image rectified by the plugin found by :data:`RECTIFY` with a
    stereo ``calibration`` (a pair's outputs' ``calibration``)."""
    spec = host.provider(RECTIFY)
    out = worker.run(host, spec.id, {"calibration": calibration, "left": left, "right": right}).outputs
    check_outputs(RECTIFY, spec.id, out)
    return out["left"], out["right"]


# -- the run ------------------------------------------------------------------------------
@dataclass
class CalibrationRun:
    """A finished calibration not stored yet: the plugin's run (``result``; its outputs
    JSON-able in ``outputs``), the images read per camera, each camera's heat map, and
    the folder holding the calibration JSON the plugin wrote (:meth:`discard` removes it;
    :func:`store` does)."""

    result: Any
    outputs: dict[str, Any]
    images: dict[str, list[Any]]
    maps: dict[str, Any]
    folder: Path

    def discard(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def _check(cancel: threading.Event | None) -> None:
    if cancel is not None and cancel.is_set():
        raise Cancelled("calibration: cancelled")


def run(
    host: Any,
    req: CalibrationRequest,
    sources: dict[str, list[dict[str, Any]]],
    project: Any = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> CalibrationRun:
    """Read the images of a checked request (``project``: where an item's file is), run
    the calibration and each camera's projection-uncertainty map; progress 0 … 0.85."""
    say = progress or (lambda f, m: None)
    total = sum(len(v) for v in sources.values())
    images: dict[str, list[Any]] = {}
    k = 0
    for side, lst in sources.items():
        images[side] = []
        for s in lst:
            _check(cancel)
            images[side].append(read_source(s, project))
            k += 1
            say(0.1 * k / total, f"reading {s['name']}")
    task = STEREO if req.mode == "stereo" else CAMERA
    tmp = Path(tempfile.mkdtemp(prefix="camcmm-cal-"))
    try:
        spec = host.provider(task)
        params = {"board": req.board, "model": req.model, "outlier_factor": req.outlier_factor,
                  "save": str(tmp / "calibration.json")}  # fmt: skip
        ins = {"left": images["left"], "right": images["right"]} if req.mode == "stereo" else {"images": images["left"]}
        result = worker.run(
            host, spec.id, ins, params, progress=lambda f, m: say(0.1 + 0.7 * f, m), cancel=cancel
        )  # fmt: skip
        result.outputs.pop("written", None)
        outputs = to_jsonable(result.outputs)
        check_outputs(task, spec.id, outputs)
        maps = {}
        for side in sides(req.mode):
            _check(cancel)
            say(0.82, f"projection uncertainty, {side_title(req.mode, side)}")
            cam = camera_part(outputs, req.mode, side)
            maps[side] = projection_map(host, cam, default_distance(cam))
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return CalibrationRun(result, outputs, images, maps, tmp)


def store(
    project: Any,
    cal: CalibrationRun,
    req: CalibrationRequest,
    sources: dict[str, list[dict[str, Any]]],
    thumbs: dict[str, dict[str, str]] | None = None,
    board_words: str = "",
) -> dict[str, Any]:
    """The calibration into ``project``: its JSON (as the plugin wrote it) and OpenCV YAML,
    the page document (with the page's ``thumbs`` per camera: image name -> data URL) and
    a result row naming the image items; the project remembers them as the current
    calibration (:data:`CURRENT_KEY`) and the request (:data:`INPUTS_KEY`). Without a
    name in the request, one is made of the kind, ``board_words`` (the board in words;
    else its spec) and the time. Returns the page document, whose ``current`` says where
    they are; ``cal``'s folder is removed."""
    from ..io import read_calibration, write_calibration

    try:
        doc = {
            "version": 1,
            "request": req.to_dict(),
            "sources": sources,
            "outputs": cal.outputs,
            "warnings": list(cal.result.warnings),
            "plugin": cal.result.plugin_id,
            "plugin_version": cal.result.plugin_version,
            "maps": cal.maps,
            "thumbs": thumbs or {side: {} for side in sides(req.mode)},
        }
        name = (req.name or "").strip() or (
            f"{'stereo pair' if req.mode == 'stereo' else 'camera'}, {board_words or req.board} "
            f"({time.strftime('%Y-%m-%d %H:%M')})"
        )
        tmp = cal.folder
        write_calibration(tmp / "calibration.yaml", read_calibration(tmp / "calibration.json"))
        (tmp / "calibration-page.json").write_text(json.dumps(doc), encoding="utf-8")
        files = {
            "calibration": project.add_file(tmp / "calibration.json"),
            "calibration_yaml": project.add_file(tmp / "calibration.yaml"),
            "page": project.add_file(tmp / "calibration-page.json"),
        }
        mids = [s["item"] for lst in sources.values() for s in lst if s.get("item") is not None]
        row = dataclasses.replace(cal.result, outputs=cal.outputs).to_json()
        rid = project.add_result(row, measurement_ids=mids, files=files, label=f"calibration: {name}")
    finally:
        cal.discard()
    doc["current"] = {
        "result": rid,
        "file": files["page"],
        "calibration": files["calibration"],
        "yaml": files["calibration_yaml"],
        "name": name,
        "kind": req.mode,
        "board": req.board,
        "rms": cal.outputs.get("rms"),
    }
    project.set_state(CURRENT_KEY, doc["current"])
    project.set_state(INPUTS_KEY, req.to_dict())
    return doc


def stored_inputs(project: Any) -> CalibrationRequest | None:
    """The request of the last run, as the project keeps it (None: none yet)."""
    req = project.get_state(INPUTS_KEY)
    return CalibrationRequest.of(req) if isinstance(req, dict) else None


def stored(project: Any) -> dict[str, Any] | None:
    """The current calibration's page document, as the project keeps it (None: none yet)."""
    cur = project.get_state(CURRENT_KEY)
    if not (isinstance(cur, dict) and cur.get("file") and project.has_file(str(cur["file"]))):
        return None
    doc = json.loads(Path(project.file_path(str(cur["file"]))).read_text("utf-8"))
    doc["current"] = cur
    return doc


def restore(project: Any) -> tuple[CalibrationRequest | None, dict[str, Any] | None]:
    """The last run's request and the current calibration's page document (each None
    when the project has none)."""
    return stored_inputs(project), stored(project)


def use_for_system(project: Any, current: dict[str, Any], target: Any = NEW, name: str = "") -> int:
    """Let measuring system ``target`` (an id, or :data:`NEW` named ``name``) refer to the
    calibration ``current`` (a page document's ``current``); the rest of its meta is kept.
    Its id."""
    ref = {k: current.get(k) for k in ("name", "result", "kind", "board", "rms", "yaml")}
    ref["file"] = current["calibration"]
    if target in (None, "", NEW):
        label = (
            str(name or "").strip()
            or f"{'stereo system' if current['kind'] == 'stereo' else 'camera'} ({current['name']})"
        )
        return int(project.add_system(label, {"calibration": ref}))
    sid = int(target)
    meta = dict(project.system(sid).get("meta") or {})
    meta["calibration"] = ref
    project.update_system(sid, meta=meta)
    return sid
