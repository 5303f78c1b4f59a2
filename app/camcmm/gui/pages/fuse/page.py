"""The "Fuse" page's state and handlers (``fu_*`` keys): a coloured photogrammetry cloud
and CSI height maps in (project items), the fused cloud and the difference analysis out
(thesis ch. 6.1).

The fusion is the headless task :mod:`camcmm.tasks.fusion` (inputs checked, the plugin
run in a worker process, the result stored); the page runs it in a
:class:`~camcmm.gui.jobs.Job` with progress and cancel. The result goes into the project (loop
thread); the page shows each map's grey images with the inlier matches, its difference
map, histogram and Abbott-Firestone curve (:mod:`.figures`), the numbers, and the fused
cloud with the footprints in its own scene (:mod:`.scene`). Tests call
``asyncio.run(page.run_async(...))``; ``runner`` may be replaced by a stand-in with
:func:`camcmm.tasks.fusion.run`'s signature.
"""

from __future__ import annotations

import logging
from typing import Any

from ....errors import CamcmmError, one_line
from ....tasks import fusion
from ...jobs import Job
from ...runpage import RunShared
from ...runpage import mount as mount_page
from ...view import color_fields
from ...widgets import declared_fields, form_values
from . import figures
from .scene import FuseScene

log = logging.getLogger("camcmm.gui.fuse")
KEY = "fuse"
FIELDS = {"cloud": "fu_cloud", "maps": "fu_maps", "name": "fu_name"}
EMPTY_HINT = (
    "Nothing to fuse yet. The fusion needs a photogrammetry cloud, best with colour (make one on the "
    "Photogrammetry page, or import a .ply) and one or more CSI height maps of the same part "
    "(Import in the toolbar: Zygo .dat/.datx, Wyko .opd, Sensofar .plu, .x3p, .sdf, .sur ...). "
    "Choose them here and press Run: the maps are registered on the cloud, the cloud's scale is "
    "fixed from the CSI's, and the difference CSI − photogrammetry is shown (thesis ch. 6.1). "
    "To try it first: Load the sample pair (a cloud and a CSI map of a synthetic coin) and press Run."
)
SAMPLE_LOADED = (
    "the sample pair is chosen (a synthetic coin: the cloud 2 % too large, the map turned 25° and tilted); "
    "the parameters are at their defaults: press Run"
)


class FusePage:
    KEY = KEY

    def __init__(self, server: Any, session: Any):
        self.server, self.session, self.state, self.host = server, session, session.state, session.host
        self.shared = RunShared(session, KEY, "fu", "fusion", fusion)
        self.view = FuseScene(session.view.display_limit)
        self.tools: Any = None  # the view's toolbar (mount)
        self.record: dict[str, Any] | None = None
        self._shown_result: Any = None
        self.job = Job("fusion", state=self.state, on_progress=self._show_progress, interval=0.2)
        self.runner = fusion.run
        self._init_state()
        self.refresh_form()
        self.restore()

    def spec(self) -> Any:
        """The manifest of the plugin that does the fusion."""
        return self.shared.spec()

    def restore(self) -> None:
        """The last run, as the project keeps it (the scene is drawn when the page opens)."""
        self.shared.restore(lambda req: self._set_request(req.to_dict()), self.show_record)

    # -- state ------------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.fu_cloud, s.fu_maps, s.fu_name = None, [], ""
        s.fu_fields, s.fu_params = [], {}
        s.fu_running, s.fu_progress, s.fu_message, s.fu_error = False, 0.0, "", ""
        s.fu_title, s.fu_warnings, s.fu_numbers, s.fu_map_names, s.fu_map = "", [], [], [], 0
        s.fu_fig_matches = s.fu_fig_diff = s.fu_fig_hist = s.fu_fig_abbott = figures.empty("")
        s.fu_items_made, s.fu_colours, s.fu_colour, s.fu_note, s.fu_outlines = {}, [], None, "", 0
        s.fu_empty_hint = EMPTY_HINT

    def refresh_form(self) -> None:
        """The run form from the plugin's declared parameters."""
        s = self.state
        try:
            spec = self.spec()
        except CamcmmError as exc:
            s.fu_fields, s.fu_params = [], {}
            s.fu_message = f"no fusion plugin: {one_line(exc)}"
            return
        fields, values = declared_fields(spec.parameters)
        s.fu_fields, s.fu_params = fields, values

    def request(self) -> dict[str, Any]:
        """The inputs as they stand in the page."""
        return {
            "cloud": None if self.state.fu_cloud in (None, "") else str(self.state.fu_cloud),
            "maps": [str(m) for m in self.state.fu_maps or []],
            "name": str(self.state.fu_name or ""),
        }

    def _set_request(self, req: dict[str, Any]) -> None:
        for key, var in FIELDS.items():
            if key in req and req[key] is not None:
                self.state[var] = req[key]

    def load_sample(self) -> dict[str, Any] | None:
        """The sample pair (:func:`camcmm.tasks.fusion.load_sample`) as the inputs and the
        form at its declared defaults, at which the pair fuses; the request, or None with the
        reason shown on the page."""
        if self.job.running:
            self.shared.error("a fusion is running; wait for it or cancel it")
            return None
        try:
            req = fusion.load_sample(self.host, self.project, self.session)
        except Exception as exc:
            self.shared.error(exc)
            return None
        self.session.refresh_items()
        self._set_request(req.to_dict())
        self.refresh_form()
        self.shared.clear_error()
        self.state.fu_message = SAMPLE_LOADED
        self.session.flush()
        return req.to_dict()

    # -- the run ----------------------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        self.state.fu_progress = round(100.0 * float(fraction), 1)
        self.state.fu_message = message or self.state.fu_message

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.fu_message = "cancelling …"

    async def run_async(
        self, params: dict[str, Any] | None = None, req: dict[str, Any] | None = None
    ) -> dict[str, Any] | None:
        """Fuse the chosen cloud and maps (``req``/``params``, else the page's) and store
        the result; the page's record, or None with the one-line reason shown on the page."""
        s = self.state
        if self.job.running:
            self.shared.error("a fusion is running; wait for it or cancel it")
            return None
        req = self.request() if req is None else {**self.request(), **req}
        try:
            spec = self.spec()
            values = form_values(spec, s.fu_params if params is None else params, self.session.roots)
            inputs = fusion.inputs_of(self.session, req)
        except Exception as exc:
            self.shared.error(exc)
            return None
        self._set_request(req)
        self.shared.clear_error()
        s.fu_running, s.fu_progress, s.fu_message = True, 0.0, "starting …"
        self.session.flush()
        try:
            result = await self.shared.run_in(self.job, self.runner, self.host, inputs, values)
            rec = fusion.store(self.project, self.session, result, req, inputs)
        except Exception as exc:
            status, line = Job.outcome(exc)
            s.fu_running, s.fu_progress, s.fu_message = False, 0.0, status
            self.shared.error(line)
            self.session.flush()
            return None
        s.fu_running, s.fu_progress = False, 100.0
        self.show_record(rec, result.outputs.get("fused"))
        s.fu_message = f"done: {len(inputs.maps)} map(s) fused, result #{rec['result']}"
        self.session.refresh_items()
        self.session.refresh_results()
        self.session.info(f"fusion stored as result #{rec['result']}", page=KEY)
        self.session.flush()
        return rec

    # -- what is shown ----------------------------------------------------------------------
    def show_record(self, rec: dict[str, Any], fused: Any = None, draw: bool = True) -> None:
        """A run's record on the page: numbers and figures of the first map and (``draw``)
        the fused cloud with the footprints; a restored record is drawn when the page opens."""
        s = self.state
        self.record = rec
        summary = rec.get("summary") or {}
        s.fu_title = f"{rec.get('name', '')} — result #{rec.get('result')} ({rec.get('plugin', '')})"
        s.fu_warnings = [str(w) for w in rec.get("warnings") or summary.get("warnings") or []]
        s.fu_items_made = dict(rec.get("items") or {})
        maps = summary.get("maps") or []
        s.fu_map_names = [{"title": f"{k + 1}: {m.get('file') or 'map'}", "value": k} for k, m in enumerate(maps)] or [
            {"title": "1", "value": 0}
        ]
        self.show_map(0)
        if draw:
            self.show_fused(fused)

    def show_map(self, k: Any) -> None:
        """Map ``k``'s figures and numbers (several maps: one at a time)."""
        rec = self.record or {}
        views = rec.get("views") or []
        try:
            k = int(k)
        except (TypeError, ValueError):
            k = 0
        k = k if 0 <= k < max(len(views), 1) else 0
        v = views[k] if k < len(views) and isinstance(views[k], dict) else {}
        s = self.state
        s.fu_map = k
        s.fu_numbers = fusion.numbers(rec.get("summary") or {}, k)
        s.fu_fig_matches = figures.matches_figure(v)
        s.fu_fig_diff = figures.difference_figure(v)
        s.fu_fig_hist = figures.histogram_figure(v)
        s.fu_fig_abbott = figures.abbott_figure(v)

    def show_fused(self, obj: Any = None) -> None:
        """The fused cloud, coloured by source, with every map's footprint outlined."""
        s, rec = self.state, self.record or {}
        key = (rec.get("items") or {}).get("fused")
        if key is None:
            return
        try:
            obj = obj if obj is not None else self.session.load(key)
            self.view.set_footprints(rec.get("views") or [])
            field = "source" if "source" in (getattr(obj, "fields", {}) or {}) else None
            self.view.show(key, obj, field)
        except Exception as exc:
            self.shared.error(f"the fused cloud cannot be shown: {one_line(exc)}")
            return
        s.fu_colours, s.fu_colour = color_fields(obj), self.view.field
        s.fu_outlines = self.view.outlines_drawn()
        s.fu_note = f"{self.view.note}; {s.fu_outlines} CSI footprint(s) outlined"
        self._shown_result = rec.get("result")

    def set_colour(self, name: Any) -> None:
        """Colour the fused cloud by field ``name`` (source, its measured colour, x/y/z)."""
        if self.view.shown is None or name not in {f["value"] for f in self.state.fu_colours or []}:
            return
        self.view.set_field(str(name))
        self.state.fu_colour = self.view.field

    def opened(self) -> None:
        """The page is shown: the form again (a plugin installed meanwhile), the stored run's scene."""
        if not self.state.fu_fields:
            self.refresh_form()
        if self.record is None or self.job.running:
            return
        if self._shown_result != self.record.get("result"):
            self.show_fused()

    @property
    def project(self) -> Any:
        return self.session.project

    def close(self) -> None:
        self.job.close()
        try:
            self.view.plotter.close()
        except Exception:
            pass


def mount(server: Any, session: Any) -> FusePage:
    """Create the page for a session and its view tools (before the server starts)."""
    return mount_page(FusePage(server, session), server, "fuv")
