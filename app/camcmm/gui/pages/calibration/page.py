"""The "Calibration" page's state and handlers: board images in, a camera or stereo
calibration out, published through the trame state (``cal_*`` keys).

A run (reading the images, calibrating, heat maps, storing: the headless task
:mod:`camcmm.tasks.calibration`; the thumbnails drawn here) goes to the page's
calibration :class:`~camcmm.gui.jobs.Job` with progress and cancel;
pictures made on demand go to a second job, so choosing an image never waits for a
run. What is shown of a calibration is :class:`.show.Results`; the measuring systems
that use it are :mod:`.systems` (the task's ``use_for_system``). State changes happen on the server's loop; plugin runs
and file writing in the jobs' workers.
"""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path
from typing import Any

from ....errors import InputError, one_line
from ....host import Cancelled
from ....tasks import calibration as task
from ...downloads import Downloads
from ...jobs import Job, in_background
from ...runpage import RunShared
from . import board as boardform
from . import boardsvg, draw, inputs, systems
from . import results as res
from .show import Results

log = logging.getLogger("camcmm.gui.calibration")

#: request key -> state variable of the input it comes from
FIELDS = {
    "mode": "cal_mode",
    "source": "cal_source",
    "left": "cal_left_items",
    "right": "cal_right_items",
    "folder": "cal_folder",
    "left_pattern": "cal_left_pattern",
    "right_pattern": "cal_right_pattern",
    "board": "cal_board",
    "model": "cal_model",
    "outlier_factor": "cal_outlier",
    "name": "cal_name",
}
#: the inputs that change which image is checked for the board, or what is looked for
CHECKED = ("cal_mode", "cal_source", "cal_left_items", "cal_folder", "cal_left_pattern", *boardform.FIELDS.values())
#: the cause of a refusal of the board form (it goes when the form is complete)
BOARD_CAUSE = "calibration:board"
#: how long the board check waits for the typing to stop before it looks (s)
CHECK_DELAY_S = 0.4


class CalibrationPage:
    def __init__(self, session: Any, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.offered = Downloads("camcmm-calibration-downloads", "camcmm-calibration-", downloads)
        self.job = Job("calibration", state=self.state, on_progress=self._show_progress, interval=0.15)
        self.pictures = Job("calibration pictures", state=self.state)
        self.checker = Job("board check", state=self.state)
        self._check_generation = 0
        self._init_state()
        self.results = Results(session, self.offered, self.pictures, self._error)
        self.refresh_systems()
        self.restore()
        self.board_changed()
        self.state.change(*boardform.FIELDS.values())(lambda **_: self.board_changed())
        self.state.change(*CHECKED)(lambda **_: self.schedule_check())

    # -- state ------------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.cal_mode = "camera"
        s.cal_source = "items" if inputs.image_items(s.items) else "folder"
        s.cal_left_items, s.cal_right_items = [], []
        s.cal_folder, s.cal_left_pattern, s.cal_right_pattern = "", "*", "right*"
        s.cal_upload_left = s.cal_upload_right = None
        s.cal_board = ""  # composed from the form (board_changed): no size, no board
        for key, value in boardform.blank().items():
            s[boardform.FIELDS[key]] = value
        s.cal_board_kinds, s.cal_board_units = boardform.KINDS, list(boardform.UNITS)
        s.cal_board_dicts = boardform.DICTIONARIES
        s.cal_board_error = ""
        s.cal_board_words = ""
        s.cal_board_svg = ""
        s.cal_board_check = {"text": "", "state": "", "image": ""}
        s.cal_models = inputs.MODELS
        s.cal_model = "standard"
        s.cal_outlier = 3.0
        s.cal_name = ""
        s.cal_running = False
        s.cal_progress = 0.0
        s.cal_message = ""
        s.cal_error = ""
        s.cal_systems, s.cal_system_options = [], []
        s.cal_system_target, s.cal_system_name = systems.NEW, ""

    def flush(self) -> None:
        self.session.flush()

    def _error(self, msg: Any, cause: str = "") -> None:
        line = one_line(msg)
        self.state.cal_error = line
        self.session.error(line, cause=cause)

    # -- what is shown (see show.Results) ---------------------------------------------------
    @property
    def doc(self) -> dict[str, Any] | None:
        """The page document of the calibration shown (None: none yet)."""
        return self.results.doc

    @property
    def shown_side(self) -> str:
        return self.results.shown_side

    def show_doc(self, doc: dict[str, Any], pics: dict[str, Any] | None = None) -> None:
        self.results.show_doc(doc, pics)
        self.refresh_systems()

    def show_side(self, side: str) -> None:
        self.results.show_side(side)

    async def select_image_async(self, name: str) -> None:
        await self.results.select_image_async(name)

    async def show_pair_async(self, index: Any) -> None:
        await self.results.show_pair_async(index)

    async def set_distance_async(self, distance: Any) -> None:
        await self.results.set_distance_async(distance)

    # -- inputs -----------------------------------------------------------------------------
    def board_form(self) -> dict[str, Any]:
        """The board form as it stands in the page (see :mod:`.board`)."""
        return {key: self.state[var] for key, var in boardform.FIELDS.items()}

    def request(self) -> dict[str, Any]:
        """The inputs as they stand in the page (the layout sends the same dict, with the
        board form under ``board_form``); the board composed from the form."""
        req = {key: self.state[var] for key, var in FIELDS.items()}
        req["left"], req["right"] = list(req["left"] or []), list(req["right"] or [])
        req["board_form"] = self.board_form()
        return req

    def _set_request(self, req: dict[str, Any]) -> None:
        for key, var in FIELDS.items():
            if key in req and req[key] is not None:
                self.state[var] = req[key]
        if req.get("board"):  # the form shows the board run (a stored spec is in mm)
            try:
                form = boardform.parse(req["board"])
            except InputError as exc:
                log.warning("the stored board does not fill the form: %s", exc)
                return
            for key, value in form.items():
                self.state[boardform.FIELDS[key]] = value
            self.board_changed()

    # -- the board form ---------------------------------------------------------------------
    def board_changed(self) -> None:
        """The board spec, its words, its drawing and what is missing, from the form."""
        s, form = self.state, self.board_form()
        try:
            s.cal_board = boardform.compose(form)
            s.cal_board_error, s.cal_board_words = "", boardform.describe(s.cal_board)
            if self.session.resolve(BOARD_CAUSE):  # the form's refusal is resolved: it goes
                s.cal_error = ""
        except InputError as exc:
            s.cal_board, s.cal_board_error, s.cal_board_words = "", one_line(exc), ""
        s.cal_board_svg = boardsvg.data_url(boardsvg.svg(form))

    def schedule_check(self) -> None:
        """Check the board on the first image soon (the server's loop; none in a test
        without one, which calls :meth:`check_board_async` itself)."""
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            return
        in_background(self.check_board_async(delay=CHECK_DELAY_S), self.state)

    async def check_board_async(self, delay: float = 0.0) -> dict[str, Any] | None:
        """Look for the form's board in the first image (the task's :func:`check_board`),
        shown as ``cal_board_check`` {text, state: ok / missing / "", image}. Waits
        ``delay`` s first; a newer change meanwhile makes this one give way."""
        self._check_generation += 1
        gen = self._check_generation
        if delay:
            await asyncio.sleep(delay)
        if gen != self._check_generation:
            return None
        req, form = self.request(), self.board_form()
        try:
            spec = boardform.detection_spec(form)
        except InputError as exc:
            self.state.cal_board_check = {"text": one_line(exc), "state": "missing", "image": ""}
            return None
        try:
            out = await self.checker.call(self._check_first, req, spec)
        except Exception as exc:
            out = {"text": f"board check: {one_line(exc)}", "state": "missing", "image": ""}
        if gen == self._check_generation:
            self.state.cal_board_check = out
            self.flush()
        return out

    def _check_first(self, req: dict[str, Any], spec: str) -> dict[str, Any]:
        """In the check job's worker: the board on the first image, and a small picture."""
        src = task.first_source(req, self.project, self.session.roots)
        if src is None:
            return {"text": "no image chosen yet: the board is checked on the first one", "state": "", "image": ""}
        img = task.read_source(src, self.project)
        out = task.check_board(self.host, img, spec)
        _, layout = inputs.board_layout(spec)
        out["image"] = draw.thumbnail(img.data, out["corners"], layout, "used" if out["found"] else "not found", 240)
        out["state"] = "ok" if out["found"] and out["count"] == out["expected"] else "missing"
        out.pop("corners")
        return out

    def add_uploads(self, upload: Any, side: str = "left") -> list[str]:
        """Uploaded images become image items of the project, chosen for ``side``."""
        keys = []
        for f in self.session.import_upload(upload):
            try:
                path, obj, name = self.session.read_file(f["content"], f["name"])
                if not (hasattr(obj, "data") and hasattr(obj, "size")):
                    raise InputError(f"{name}: not an image")
                h = self.project.add_file(path)
                keys.append(str(self.session.add_measurement(name, h, obj, "calibration page upload")))
            except Exception as exc:
                self._error(one_line(exc, f["name"]))
            finally:
                self.session.drop_upload(f["content"])
        if keys:
            self.session.refresh_items()
            var = "cal_right_items" if side == "right" else "cal_left_items"
            self.state[var] = list(self.state[var] or []) + keys
            self.state.cal_source = "items"
            self.session.info(f"{len(keys)} image(s) added to the project")
        return keys

    def pick_by_name(self) -> None:
        """Choose every image item (one camera) or split them by 'left'/'right' in the name."""
        left, right = inputs.split_by_name(self.state.items, self.state.cal_mode == "stereo")
        self.state.cal_left_items, self.state.cal_right_items = left, right
        self.state.cal_source = "items"
        if not left:
            self._error(
                "no image items"
                + (" named left…" if self.state.cal_mode == "stereo" else "")
                + " in the project: upload the board images or import them"
            )

    # -- the run ----------------------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        self.state.cal_progress = round(100.0 * fraction, 1)
        self.state.cal_message = message or "calibrating"

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.cal_message = "cancelling …"

    def _work(
        self, req: Any, src: dict[str, list], progress: Any, cancel: Any
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """In the job's worker: calibrate (the task), the thumbnails, store (the task), then
        the first pictures and the downloads."""
        cal = task.run(self.host, req, src, self.project, progress, cancel)
        try:
            thumbs = self._thumbnails(req, cal, cancel)
        except BaseException:
            cal.discard()
            raise
        progress(0.9, "storing the calibration in the project")
        doc = task.store(self.project, cal, req, src, thumbs, boardform.describe(req.board))
        progress(0.95, "drawing")
        return doc, self.results.pictures(doc, cal.images)

    @staticmethod
    def _thumbnails(req: Any, cal: Any, cancel: Any) -> dict[str, dict[str, str]]:
        """Each image with its detected board, small (image name -> data URL), per camera."""
        _, layout = inputs.board_layout(req.board)
        out: dict[str, dict[str, str]] = {}
        for side in task.sides(req.mode):
            cam = task.camera_part(cal.outputs, req.mode, side)
            rows = {r["name"]: r for r in res.view_rows(cam)}
            out[side] = {}
            for img, d in zip(cal.images[side], cam["detections"]):
                if cancel is not None and cancel.is_set():
                    raise Cancelled("calibration: cancelled")
                out[side][d["image"]] = draw.thumbnail(img.data, d.get("corners"), layout, rows[d["image"]]["status"])
        return out

    async def run_async(self, req: dict[str, Any] | None = None) -> dict[str, Any] | None:
        """Calibrate with ``req`` (the form's inputs when None); the page document, or
        None with the reason shown."""
        s = self.state
        if self.job.running:
            self._error("a calibration is running; wait for it or cancel it")
            return None
        try:
            raw = dict(self.request() if req is None else req)
            form = raw.pop("board_form", None)
            if form is not None:  # the form's fields: the square size is required
                try:
                    raw["board"] = boardform.compose(form)
                except InputError as exc:
                    self._error(exc, cause=BOARD_CAUSE)
                    return None
            checked, src = task.check_request(raw, self.project, self.session.roots)
        except Exception as exc:
            self._error(exc)
            return None
        self._set_request(checked.to_dict())
        s.cal_running, s.cal_progress, s.cal_message, s.cal_error = True, 0.0, "starting …", ""
        self.flush()
        try:
            doc, pics = await RunShared.run_in(self.job, self._work, checked, src)
        except Exception as exc:
            status, line = Job.outcome(exc)
            s.cal_running, s.cal_progress, s.cal_message = False, 0.0, status
            self._error(line)
            self.flush()
            return None
        s.cal_running, s.cal_progress = False, 100.0
        s.cal_message = f"done: RMS {res.fmt(doc['outputs'].get('rms'), 3)} px, result #{doc['current']['result']}"
        self.show_doc(doc, pics)
        self.session.refresh_results()
        self.session.info(f"calibration stored as result #{doc['current']['result']}")
        self.flush()
        return doc

    # -- restore ----------------------------------------------------------------------------
    def restore(self) -> None:
        """The inputs of the last run and the current calibration, as stored."""
        try:
            req, doc = task.restore(self.project)
            if req is not None:
                self._set_request(req.to_dict())
            if doc is not None:
                self.show_doc(doc)
                self.state.cal_message = f"result #{doc['current'].get('result')} from the project"
        except Exception as exc:  # a damaged file must not keep the page from opening
            log.warning("cannot restore the calibration: %s", exc)
            self.state.cal_message = f"the stored calibration could not be read: {one_line(exc)}"

    # -- measuring systems ------------------------------------------------------------------
    def refresh_systems(self) -> None:
        """The project's measuring systems and the calibration each refers to."""
        s = self.state
        try:
            s.cal_systems, s.cal_system_options = systems.rows(self.project, (self.doc or {}).get("current"))
        except Exception as exc:
            s.cal_systems, s.cal_system_options = [], [systems.new_option()]
            self._error(f"measuring systems: {one_line(exc)}")
            return
        if s.cal_system_target not in [o["value"] for o in s.cal_system_options]:
            s.cal_system_target = systems.NEW

    def use_calibration(self, target: Any = systems.NEW, name: str = "") -> int | None:
        """Let measuring system ``target`` (an id, or "new" with ``name``) refer to the
        shown calibration (:func:`camcmm.tasks.calibration.use_for_system`). Returns the system's id."""
        cur = (self.doc or {}).get("current")
        if not cur:
            self._error("no calibration to use yet: run one first")
            return None
        try:
            sid = task.use_for_system(self.project, cur, target, name)
        except Exception as exc:
            self._error(f"measuring system: {one_line(exc)}")
            return None
        self.state.cal_system_target = sid
        self.refresh_systems()
        self.state.cal_system_target = sid
        self.session.info(f"measuring system #{sid} uses calibration {cur['name']!r}")
        return sid

    def close(self) -> None:
        self.job.close()
        self.pictures.close()
        self.offered.close()


def mount(server: Any, session: Any) -> CalibrationPage:
    """Create the page for a session and serve its downloads (before the server starts)."""
    page = CalibrationPage(session)
    page.offered.mount(server)
    return page
