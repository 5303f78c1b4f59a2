"""The "Photogrammetry" page's state and handlers (``pg_*`` keys): an image series in,
a reconstruction (sparse and dense cloud, the registered cameras) out.

Listing a series (the sources checked, thumbnails made) goes to one
:class:`~camcmm.gui.jobs.Job`, the reconstruction to another, with progress per stage
and cancel; the plugin computes in a worker process. The result goes
into the project (loop thread) and into the page's own scene (:mod:`.scene`) with the
cameras drawn around the cloud (:mod:`.display`); "send to" hands the cloud to Inspect,
Compare with CAD or the Acceptance test. The task (sources checked, the plugin run, the
result stored) is :mod:`camcmm.tasks.photogrammetry`. Tests call
``asyncio.run(page.run_async(...))``; ``runner`` may be replaced by a stand-in with
:func:`camcmm.tasks.photogrammetry.run`'s signature.
"""

from __future__ import annotations

import logging
from typing import Any

from ....errors import CamcmmError, one_line
from ....tasks import photogrammetry as task
from ...jobs import Job, in_background
from ...runpage import RunShared
from ...runpage import mount as mount_page
from ...widgets import declared_fields, form_values
from . import inputs, links
from .display import Display
from .scene import PhotoScene

log = logging.getLogger("camcmm.gui.photogrammetry")
KEY = "photogrammetry"
#: request key -> state variable of the input it comes from
FIELDS = {"source": "pg_source", "folder": "pg_folder", "pattern": "pg_pattern", "items": "pg_items", "name": "pg_name"}
EMPTY_HINT = (
    "No image series yet. Give a folder on the server that holds the photographs (inside the project "
    "folder or a folder the server was started with, --data-root) and press Show, or import the images "
    "(Import in the toolbar) and choose them here. A series: at least 3 overlapping photographs of one "
    "object from one camera, e.g. a turntable series with laser speckle on a bare surface."
)


class PhotogrammetryPage:
    KEY = KEY

    def __init__(self, server: Any, session: Any):
        self.server, self.session, self.state, self.host = server, session, session.state, session.host
        self.shared = RunShared(session, KEY, "pg", "reconstruction", task)
        self.view = PhotoScene(session.view.display_limit)
        self.display = Display(self.state, self.view, session, self.shared.error)
        self.tools: Any = None  # the view's toolbar (mount)
        self.job = Job("reconstruction", state=self.state, on_progress=self._show_progress, interval=0.2)
        self.lister = Job("image list", state=self.state)
        self.runner = task.run
        self._sources: list[dict[str, Any]] = []
        self._task: Any = None  # the running task started by a button (start)
        self._init_state()
        self.refresh_form()
        self.restore()

    @property
    def project(self) -> Any:
        return self.session.project

    @property
    def record(self) -> dict[str, Any] | None:
        """The run shown (the last one made or restored)."""
        return self.display.record

    def spec(self) -> Any:
        """The manifest of the plugin that reconstructs."""
        return self.shared.spec()

    def restore(self) -> None:
        """The last run, as the project keeps it (the scene is drawn when the page opens)."""
        self.shared.restore(lambda req: self._set_request(req.to_dict()), self.show_record)

    def show_record(self, rec: dict[str, Any], outputs: dict[str, Any] | None = None, draw: bool = True) -> None:
        self.display.show_record(rec, outputs, draw)

    def show_cloud(self, which: str = "cloud") -> None:
        """Show the dense ("cloud") or the sparse cloud with the registered cameras."""
        self.display.show_cloud(which)

    def set_colour(self, name: Any) -> None:
        """Colour the shown cloud by field ``name``."""
        self.display.set_colour(name)

    # -- state ------------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.pg_source = "items" if inputs.image_items(s.items) else "folder"
        s.pg_folder, s.pg_pattern, s.pg_items, s.pg_name = "", "*", [], ""
        s.pg_images, s.pg_listing, s.pg_list_note = [], False, ""
        s.pg_fields, s.pg_params = [], {}
        s.pg_use_cal, s.pg_cal_note = False, ""
        s.pg_running, s.pg_progress, s.pg_stage, s.pg_message, s.pg_error = False, 0.0, "", "", ""
        s.pg_stages = [{"name": n, "state": "todo"} for n in task.STAGES]
        s.pg_summary, s.pg_warnings, s.pg_title = [], [], ""
        s.pg_items_made, s.pg_display, s.pg_cameras, s.pg_note = {}, "cloud", 0, ""
        s.pg_colours, s.pg_colour = [], None
        s.pg_empty_hint = EMPTY_HINT

    def refresh_form(self) -> None:
        """The run form from the plugin's declared parameters; the calibration offered."""
        s = self.state
        try:
            spec = self.spec()
        except CamcmmError as exc:
            s.pg_fields, s.pg_params = [], {}
            s.pg_message = f"no reconstruction plugin: {one_line(exc)}"
            return
        fields, values = declared_fields(spec.parameters)
        for f in fields:  # the camera models in words; the key stays the value sent
            if f.get("name") == "camera_model":
                # items: what the select shows (widgets.param_form prefers them to the bare choices)
                words = [{"title": task.camera_words(c), "value": c} for c in f.get("choices") or []]
                f["choices"] = f["items"] = words
        s.pg_fields, s.pg_params = fields, values
        self.refresh_calibration()

    def refresh_calibration(self) -> None:
        """Offer the project's camera calibration when it has one (made meanwhile, too)."""
        s = self.state
        cal = task.calibration_file(self.project)
        s.pg_cal_note = "" if cal is None else "the project's camera calibration (Calibration page)"
        s.pg_use_cal = bool(s.pg_use_cal) and cal is not None

    def request(self, given: dict[str, Any] | None = None) -> dict[str, Any]:
        """The inputs as they stand in the page, with ``given`` (the browser's) over them;
        only the known keys, as text (the items a list of ids)."""
        req = {key: self.state[var] for key, var in FIELDS.items()}
        req.update({k: v for k, v in dict(given or {}).items() if k in FIELDS})
        items = req.get("items")
        req["items"] = [str(i) for i in items] if isinstance(items, (list, tuple)) else []
        for key in ("source", "folder", "pattern", "name"):
            req[key] = "" if req.get(key) is None else str(req[key])
        return req

    def _set_request(self, req: dict[str, Any]) -> None:
        for key, var in FIELDS.items():
            if key in req and req[key] is not None:
                self.state[var] = req[key]

    # -- the series -------------------------------------------------------------------------
    def pick_all_items(self) -> None:
        """Choose every image item of the project, by name."""
        imgs = sorted(inputs.image_items(self.state.items), key=lambda it: it["name"].lower())
        self.state.pg_items = [it["id"] for it in imgs]
        self.state.pg_source = "items"
        if not imgs:
            self.shared.error("no image items in the project: import the photographs (Import in the toolbar)")

    def _thumbs(self, sources: list[dict[str, Any]]) -> list[str]:
        """Thumbnails (worker thread), at most inputs.MAX_THUMBS."""
        out = []
        for k, src in enumerate(sources[: inputs.MAX_THUMBS]):
            self.lister.check()
            out.append(inputs.thumbnail(src["path"]))
            self.lister.progress(k / max(1, len(sources)), f"thumbnails {k + 1}/{len(sources)}")
        return out

    async def list_async(self, req: dict[str, Any] | None = None) -> list[dict[str, Any]] | None:
        """Check the series (``req``, else the page's inputs) and show it as thumbnails."""
        req = self.request(req)
        try:
            sources = task.sources_of(req, self.project, self.session.roots)
        except Exception as exc:
            self.shared.error(exc)
            return None
        self._set_request(req)
        self.shared.clear_error()
        self.state.pg_listing = True
        self.session.flush()
        try:
            thumbs = await self.lister.run(self._thumbs, sources)
        except Exception as exc:
            self.state.pg_listing = False
            self.shared.error(Job.outcome(exc)[1])
            return None
        self._sources = sources
        s = self.state
        s.pg_listing = False
        s.pg_images = inputs.rows(sources, thumbs)
        more = len(sources) - len(thumbs)
        s.pg_list_note = f"{len(sources)} images" + (f" ({more} without thumbnail)" if more > 0 else "")
        self.session.flush()
        return sources

    # -- the run ----------------------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        s = self.state
        s.pg_progress = round(100.0 * float(fraction), 1)
        s.pg_message = message or s.pg_message
        stage = task.stage_of(message)
        if stage:
            s.pg_stage = stage
            at = task.STAGES.index(stage)
            s.pg_stages = [
                {"name": n, "state": "done" if i < at else ("now" if i == at else "todo")}
                for i, n in enumerate(task.STAGES)
            ]

    def start(self, coro: Any) -> Any:
        """Run ``coro`` (a run, a listing) in the background and return at once
        (:func:`camcmm.gui.jobs.in_background`: an awaited run would hold back Cancel)."""
        self._task = in_background(coro, self.state)
        return self._task

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.pg_message = "cancelling …"

    async def run_async(
        self, params: dict[str, Any] | None = None, req: dict[str, Any] | None = None
    ) -> dict[str, Any] | None:
        """Reconstruct the series (``req``/``params``, else the page's) and store it; the
        page's record, or None with the one-line reason shown on the page."""
        s = self.state
        if self.job.running:
            self.shared.error("a reconstruction is running; wait for it or cancel it")
            return None
        req = self.request(req)
        try:
            spec = self.spec()
            values = task.scale_checked(
                form_values(spec, s.pg_params if params is None else params, self.session.roots), self.session.roots
            )
            sources = task.sources_of(req, self.project, self.session.roots)
            cal = task.calibration_file(self.project) if s.pg_use_cal else None
            if s.pg_use_cal and cal is None:
                raise CamcmmError("the project has no camera calibration: calibrate on the Calibration page first")
        except Exception as exc:
            self.shared.error(exc)
            return None
        self._set_request(req)
        # the previous run's figures, warnings, counts and cloud go while this one runs: nothing
        # on the page may be taken for the new series' (it comes back if this run stores nothing)
        previous = self.record
        self.display.clear()
        if [x["path"] for x in sources] != [x["path"] for x in self._sources]:
            s.pg_images = inputs.rows(sources, [r.get("thumb", "") for r in s.pg_images or []])
        self._sources = sources
        self.shared.clear_error()
        s.pg_running, s.pg_progress, s.pg_stage, s.pg_message = True, 0.0, "", "starting …"
        s.pg_stages = [{"name": n, "state": "todo"} for n in task.STAGES]
        self.session.flush()
        try:
            result = await self.shared.run_in(self.job, self.runner, self.host, sources, values, cal)
            rec = task.store(self.project, self.session, result, req, sources)
        except Exception as exc:
            status, line = Job.outcome(exc)
            s.pg_running, s.pg_progress, s.pg_message = False, 0.0, status
            if status == "cancelled":  # the operator's wish, not a fault: a note, no red alert
                self.session.info(f"{line}; nothing was stored", page=KEY)
            else:
                self.shared.error(line)
            self._show_previous(previous, sources)
            self.session.flush()
            return None
        s.pg_running, s.pg_progress = False, 100.0
        # the stages the plugin went through are done; one it skipped (dense off) stays grey
        s.pg_stages = [dict(st, state="done" if st["state"] != "todo" else "todo") for st in s.pg_stages]
        self.show_record(rec, result.outputs)
        rc = rec["reconstruction"]
        s.pg_message = (
            f"done: {rc.get('n_registered', '?')} of {rc.get('n_images', '?')} registered, result #{rec['result']}"
        )
        self.session.refresh_items()
        self.session.refresh_results()
        self.session.info(f"reconstruction stored as result #{rec['result']}", page=KEY)
        self.session.flush()
        return rec

    def _show_previous(self, previous: dict[str, Any] | None, sources: list[dict[str, Any]]) -> None:
        """After a run that stored nothing: the project's last result again, said to be the
        previous one, when it was of the series this run was given (else the rows stay as
        listed, and the result is shown when the page opens next)."""
        if previous is None or [x.get("path") for x in previous.get("sources") or []] != [x["path"] for x in sources]:
            return
        self.show_record(previous)
        self.state.pg_message += f"; the previous result #{previous.get('result')} is shown"

    def send_to(self, target: str) -> bool:
        """The shown cloud to another page (:mod:`.links`); False with the reason shown."""
        made = self.state.pg_items_made or {}
        key = made.get(self.state.pg_display) or made.get("cloud") or made.get("sparse")
        try:
            links.send(self.server, self.session, str(target), key)
        except Exception as exc:
            self.shared.error(exc)
            return False
        return True

    def opened(self) -> None:
        """The page is shown: the calibration offered, the stored run's thumbnails and scene."""
        self.refresh_calibration()
        if self.record is None or self.job.running:
            return
        if self.display.shown_result != self.record.get("result"):
            self.show_cloud(self.display.which())
        if not any(r.get("thumb") for r in self.state.pg_images or []):
            srcs = [x for x in self.record.get("sources") or [] if x.get("path")]
            thumbs = [inputs.thumbnail(x["path"]) for x in srcs[: min(24, inputs.MAX_THUMBS)]]
            self.state.pg_images = [
                dict(r, thumb=thumbs[i] if i < len(thumbs) else "") for i, r in enumerate(self.state.pg_images)
            ]

    def close(self) -> None:
        for job in (self.job, self.lister):
            job.close()
        try:
            self.view.plotter.close()
        except Exception:
            pass


def mount(server: Any, session: Any) -> PhotogrammetryPage:
    """Create the page for a session, its view tools and downloads (before the server starts)."""
    page = mount_page(PhotogrammetryPage(server, session), server, "pgv")

    @server.state.change("items")
    def _items_changed(**_: Any) -> None:
        if page.state.pg_source == "folder" and not page.state.pg_folder and inputs.image_items(page.state.items):
            page.state.pg_source = "items"

    return page
