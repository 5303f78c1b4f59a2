"""The "Calibration" page's logic: board images in, a camera or stereo calibration out,
published through the trame state (``cal_*`` keys).

The numbers come from the calibration plugins, called through the host by id
(``calibration.camera``, ``calibration.stereo``, ``calibration.projection-uncertainty``,
``calibration.rectify``) as the CLI calls them, so the page shows the CLI's numbers.
A run (reading the images, detection, calibration, heat maps, thumbnails, storing) goes
to the page's one worker thread with progress and cancel; its calibration is stored in
the project (the calibration as JSON and OpenCV YAML, a result row, and a page document
that shows it again on reopen). What is shown is in :mod:`calibration_show`.

Threading as in the other pages: state and view updates on the server loop; plugin runs
and file writing in the worker.
"""

from __future__ import annotations

import asyncio
import json
import logging
import shutil
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from .. import worker
from ..errors import CamcmmError, InputError
from ..host import to_jsonable
from . import calibration_draw as draw
from . import calibration_inputs as inputs
from . import calibration_results as res
from .calibration_show import CalibrationShow
from .downloads import Downloads

log = logging.getLogger("camcmm.gui.calibration")

CAMERA, STEREO = "calibration.camera", "calibration.stereo"
PROJECTION, RECTIFY = "calibration.projection-uncertainty", "calibration.rectify"
CURRENT_KEY, INPUTS_KEY = "calibration.current", "calibration.inputs"
MAP_GRID = (48, 36)
REQUEST_KEYS = ("mode", "source", "left", "right", "folder", "left_pattern", "right_pattern", "board", "model",
                "outlier_factor", "name")


def one_line(exc: BaseException | str) -> str:
    msg = str(exc) if isinstance(exc, (CamcmmError, str)) else f"{type(exc).__name__}: {exc}"
    return " ".join(msg.split()) or "unknown error"


class CalibrationPage(CalibrationShow):
    def __init__(self, session: Any, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.offered = Downloads("camcmm-calibration-downloads", "camcmm-calibration-", downloads)
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="camcmm-calibration")
        self._cancel: threading.Event | None = None
        self._last_progress = 0.0
        self.doc: dict[str, Any] | None = None
        self._init_state()
        self.refresh_systems()
        self.restore()

    # -- state ------------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.cal_mode = "camera"
        s.cal_source = "items" if inputs.image_items(s.items) else "folder"
        s.cal_left_items, s.cal_right_items = [], []
        s.cal_folder, s.cal_left_pattern, s.cal_right_pattern = "", "*", "right*"
        s.cal_upload_left = s.cal_upload_right = None
        s.cal_board = "chessboard:9x6:25"
        s.cal_board_hints = inputs.BOARD_HINTS
        s.cal_models = inputs.MODELS
        s.cal_model = "standard"
        s.cal_outlier = 3.0
        s.cal_name = ""
        s.cal_running = False
        s.cal_progress = 0.0
        s.cal_message = ""
        s.cal_error = ""
        self._init_results()
        s.cal_systems, s.cal_system_options = [], []
        s.cal_system_target, s.cal_system_name = "new", ""

    def flush(self) -> None:
        self.session.flush()

    def _error(self, msg: Any) -> None:
        line = one_line(msg)
        self.state.cal_error = line
        self.session.error(line)

    # -- inputs -----------------------------------------------------------------------------
    def request(self) -> dict[str, Any]:
        """The inputs as they stand in the page (the layout sends the same dict)."""
        s = self.state
        return {"mode": s.cal_mode, "source": s.cal_source, "left": list(s.cal_left_items or []),
                "right": list(s.cal_right_items or []), "folder": s.cal_folder, "left_pattern": s.cal_left_pattern,
                "right_pattern": s.cal_right_pattern, "board": s.cal_board, "model": s.cal_model,
                "outlier_factor": s.cal_outlier, "name": s.cal_name}

    def _set_request(self, req: dict[str, Any]) -> None:
        s = self.state
        for key, attr in (("mode", "cal_mode"), ("source", "cal_source"), ("left", "cal_left_items"),
                          ("right", "cal_right_items"), ("folder", "cal_folder"), ("left_pattern", "cal_left_pattern"),
                          ("right_pattern", "cal_right_pattern"), ("board", "cal_board"), ("model", "cal_model"),
                          ("outlier_factor", "cal_outlier"), ("name", "cal_name")):
            if key in req and req[key] is not None:
                s[attr] = req[key]

    def _check(self, req: dict[str, Any]) -> tuple[dict[str, Any], dict[str, list[dict[str, Any]]]]:
        """The request cleaned and its image sources (loop thread: reads the project)."""
        req = {k: req.get(k) for k in REQUEST_KEYS}
        mode = "stereo" if req["mode"] == "stereo" else "camera"
        req["mode"] = mode
        req["board"] = str(req.get("board") or "").strip()
        if not req["board"]:
            raise InputError("board: give the board spec, e.g. chessboard:9x6:25 (" + inputs.BOARD_HELP + ")")
        try:
            req["outlier_factor"] = float(req.get("outlier_factor") if req.get("outlier_factor") not in (None, "")
                                          else 3.0)
        except (TypeError, ValueError):
            raise InputError(f"outlier factor: {req.get('outlier_factor')!r} is not a number") from None
        req["model"] = req.get("model") or "standard"
        first = "left images" if mode == "stereo" else "images"
        if req.get("source") == "folder":
            src = {"left": inputs.folder_sources(req["folder"], req.get("left_pattern") or "*", first,
                                                   roots=getattr(self.session, "roots", None))}
            if mode == "stereo":
                src["right"] = inputs.folder_sources(req["folder"], req.get("right_pattern") or "*", "right images",
                                                     roots=getattr(self.session, "roots", None))
        else:
            req["source"] = "items"
            src = {"left": inputs.item_sources(self.project, req.get("left"), first)}
            if mode == "stereo":
                src["right"] = inputs.item_sources(self.project, req.get("right"), "right images")
        if mode == "stereo":
            both = {s["path"] for s in src["left"]} & {s["path"] for s in src["right"]}
            if both:
                raise InputError(f"the same image is among the left and the right images ({len(both)} of them); "
                                 "give each camera its own images")
        return req, src

    def add_uploads(self, upload: Any, side: str = "left") -> list[str]:
        """Uploaded images become image items of the project, chosen for ``side``."""
        from .session import describe

        keys = []
        for f in self.session.import_upload(upload):
            try:
                path, obj, name = self.session.read_file(f["content"], f["name"])
                if not (hasattr(obj, "data") and hasattr(obj, "size")):
                    raise InputError(f"{name}: not an image")
                h = self.project.add_file(path)
                keys.append(str(self.project.add_measurement(name, h, "image", meta={
                    "summary": describe(obj), "made_by": "calibration page upload"})))
            except Exception as exc:
                self._error(self.session._reason(exc, f["name"]))
            finally:
                self.session.drop_upload(f["content"])
        if keys:
            self.session.refresh_items()
            attr = "cal_right_items" if side == "right" else "cal_left_items"
            self.state[attr] = list(self.state[attr] or []) + keys
            self.state.cal_source = "items"
            self.session.info(f"{len(keys)} image(s) added to the project")
        return keys

    def pick_by_name(self) -> None:
        """Choose every image item (one camera) or split them by 'left'/'right' in the name."""
        left, right = inputs.split_by_name(self.state.items, self.state.cal_mode == "stereo")
        self.state.cal_left_items, self.state.cal_right_items = left, right
        self.state.cal_source = "items"
        if not left:
            self._error("no image items" + (" named left…" if self.state.cal_mode == "stereo" else "")
                        + " in the project: upload the board images or import them")

    # -- the run ----------------------------------------------------------------------------
    def _begin(self) -> threading.Event:
        s = self.state
        self._cancel = threading.Event()
        self._last_progress = 0.0
        s.cal_running, s.cal_progress, s.cal_message, s.cal_error = True, 0.0, "starting …", ""
        return self._cancel

    def _progress_cb(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last_progress < 0.15:
            return
        self._last_progress = now

        def show() -> None:
            self.state.cal_progress = round(100.0 * float(fraction), 1)
            self.state.cal_message = message or "calibrating"
        self.session.post(show)

    def cancel(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
            self.state.cal_message = "cancelling …"

    def _compute(self, req: dict[str, Any], src: dict[str, list], cancel: threading.Event) -> tuple[dict, dict]:
        """Worker: read, calibrate, heat maps, thumbnails, pictures; store in the project."""
        from ..host import Cancelled

        mode = req["mode"]
        total = sum(len(v) for v in src.values())
        images: dict[str, list] = {}
        k = 0
        for side, lst in src.items():
            images[side] = []
            for s in lst:
                if cancel.is_set():
                    raise Cancelled("calibration: cancelled")
                images[side].append(inputs.read_source(s, self.project))
                k += 1
                self._progress_cb(0.1 * k / total, f"reading {s['name']}")
        tmp = Path(tempfile.mkdtemp(prefix="camcmm-cal-"))
        try:
            params = {"board": req["board"], "model": req["model"], "outlier_factor": req["outlier_factor"],
                      "save": str(tmp / "calibration.json")}
            ins = {"left": images["left"], "right": images["right"]} if mode == "stereo" else {"images": images["left"]}
            run = worker.run(self.host, STEREO if mode == "stereo" else CAMERA, ins, params,
                             progress=lambda f, m: self._progress_cb(0.1 + 0.7 * f, m), cancel=cancel)
            run.outputs.pop("written", None)
            outputs = to_jsonable(run.outputs)
            doc = {"version": 1, "request": req, "sources": src, "outputs": outputs, "warnings": list(run.warnings),
                   "plugin": run.plugin_id, "plugin_version": run.plugin_version, "maps": {}, "thumbs": {}}
            kind, layout = inputs.board_layout(req["board"])
            for side in res.sides(mode):
                self._progress_cb(0.82, f"projection uncertainty, {res.side_title(mode, side)}")
                cam = res.camera_part(outputs, mode, side)
                doc["maps"][side] = self.projection_map(cam, res.default_distance(cam.get("map_calibration")))
                rows = {r["name"]: r for r in res.view_rows(cam)}
                thumbs = {}
                for img, d in zip(images[side], cam["detections"]):
                    if cancel.is_set():
                        raise Cancelled("calibration: cancelled")
                    thumbs[d["image"]] = draw.thumbnail(img.data, d.get("corners"), layout,
                                                        rows[d["image"]]["status"])
                doc["thumbs"][side] = thumbs
            self._progress_cb(0.9, "storing the calibration in the project")
            self._store(doc, run, tmp)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        self._progress_cb(0.95, "drawing")
        return doc, self.pictures(doc, images)

    def projection_map(self, cam: dict[str, Any], distance: float) -> dict[str, Any] | None:
        cal = cam.get("map_calibration")
        if not cal:
            return None
        out = worker.run(self.host, PROJECTION, {"calibration": cal},
                         {"distance": float(distance), "columns": MAP_GRID[0], "rows": MAP_GRID[1]}).outputs
        return to_jsonable({k: out[k] for k in ("map", "u", "v", "distance", "min", "max", "centre", "method")})

    def _store(self, doc: dict[str, Any], run: Any, tmp: Path) -> None:
        """Worker: calibration JSON (as the plugin wrote it) and OpenCV YAML, the page
        document, a result row; the project remembers it as the current calibration."""
        from ..io import read_calibration, write_calibration

        req = doc["request"]
        name = str(req.get("name") or "").strip() or \
            f"{'stereo pair' if req['mode'] == 'stereo' else 'camera'} {req['board']} ({time.strftime('%Y-%m-%d %H:%M')})"
        write_calibration(tmp / "calibration.yaml", read_calibration(tmp / "calibration.json"))
        (tmp / "calibration-page.json").write_text(json.dumps(doc), encoding="utf-8")
        files = {"calibration": self.project.add_file(tmp / "calibration.json"),
                 "calibration_yaml": self.project.add_file(tmp / "calibration.yaml"),
                 "page": self.project.add_file(tmp / "calibration-page.json")}
        mids = [s["item"] for lst in doc["sources"].values() for s in lst if s.get("item") is not None]
        rid = self.project.add_result(run, measurement_ids=mids, files=files, label=f"calibration: {name}")
        doc["current"] = {"result": rid, "file": files["page"], "calibration": files["calibration"],
                          "yaml": files["calibration_yaml"], "name": name, "kind": req["mode"], "board": req["board"],
                          "rms": doc["outputs"].get("rms")}
        self.project.set_state(CURRENT_KEY, doc["current"])
        self.project.set_state(INPUTS_KEY, req)

    def _prepare(self, req: dict[str, Any] | None) -> tuple[dict[str, Any], Any] | None:
        """The checked request (the form's when None) and its image source, kept as the
        page's inputs; None with the reason shown."""
        req = self.request() if req is None else req
        try:
            req, src = self._check(req)
        except Exception as exc:
            self._error(exc)
            return None
        self._set_request(req)
        return req, src

    def run(self, req: dict[str, Any] | None = None) -> dict[str, Any] | None:
        """Calibrate in the calling thread (tests, scripts); the doc, or None after an error."""
        checked = self._prepare(req)
        if checked is None:
            return None
        req, src = checked
        cancel = self._begin()
        try:
            doc, pics = self._compute(req, src, cancel)
        except Exception as exc:
            return self._failed(exc)
        return self._finished(doc, pics)

    async def run_async(self, req: dict[str, Any] | None = None) -> dict[str, Any] | None:
        if self.state.cal_running:
            self._error("a calibration is running; wait for it or cancel it")
            return None
        if self.session._loop is None:
            self.session.bind_loop()
        checked = self._prepare(req)
        if checked is None:
            return None
        req, src = checked
        cancel = self._begin()
        self.flush()
        try:
            doc, pics = await asyncio.get_running_loop().run_in_executor(self._executor, self._compute, req, src, cancel)
        except Exception as exc:
            out = self._failed(exc)
            self.flush()
            return out
        out = self._finished(doc, pics)
        self.flush()
        return out

    def _failed(self, exc: BaseException) -> None:
        s = self.state
        s.cal_running = False
        s.cal_progress = 0.0
        s.cal_message = "cancelled" if "cancelled" in str(exc) else "failed"
        self._error(exc)
        return None

    def _finished(self, doc: dict[str, Any], pics: dict[str, Any]) -> dict[str, Any]:
        s = self.state
        s.cal_running = False
        s.cal_progress = 100.0
        out = doc["outputs"]
        s.cal_message = f"done: RMS {res.fmt(out.get('rms'), 4)} px, result #{doc['current']['result']}"
        self.show_doc(doc, pics)
        self.session.refresh_results()
        self.session.info(f"calibration stored as result #{doc['current']['result']}")
        return doc

    # -- restore ----------------------------------------------------------------------------
    def restore(self) -> None:
        """The inputs of the last run and the current calibration, as stored."""
        try:
            req = self.project.get_state(INPUTS_KEY)
            if isinstance(req, dict):
                self._set_request(req)
            cur = self.project.get_state(CURRENT_KEY)
            if isinstance(cur, dict) and cur.get("file") and self.project.has_file(str(cur["file"])):
                doc = json.loads(self.project.file_path(str(cur["file"])).read_text("utf-8"))
                doc["current"] = cur
                self.show_doc(doc)
                self.state.cal_message = f"result #{cur.get('result')} from the project"
        except Exception as exc:  # a damaged file must not keep the page from opening
            log.warning("cannot restore the calibration: %s", exc)
            self.state.cal_message = f"the stored calibration could not be read: {one_line(exc)}"

    def close(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
        self._executor.shutdown(wait=False, cancel_futures=True)
        self.offered.close()


def mount(server: Any, session: Any) -> CalibrationPage:
    """Create the page for a session and serve its downloads (before the server starts)."""
    page = CalibrationPage(session)
    page.offered.mount(server)
    return page
