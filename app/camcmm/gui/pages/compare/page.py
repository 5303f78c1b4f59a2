"""Compare with CAD: the inspection page's logic, apart from the layout.

The operator picks the measured cloud and the nominal (a CAD mesh or a reference
cloud) from the project's items, an alignment method (the choices declared by the
plugin providing ``compare-with-cad``; the ``pairs`` methods take three point pairs
clicked in the 3D view: on the measured cloud, then on the nominal, three times) and a
tolerance, and runs the comparison in the page's job. The result is shown as

* the deviations cloud in the page's own 3D view: a diverging colour map on
  ±``colour_limit`` with a legend titled ``deviation [µm]`` or ``[mm]`` (whichever
  reads better), or tolerance bands (within ±tolerance green, above red, below blue);
* a histogram and the Abbott-Firestone (material-ratio) curve as plotly figures, with
  the 95 % interval, ±tolerance and the ISO 13565-2 construction drawn in;
* a statistics table, the alignment (rms, scale, converged and its reason);
* a picked point's coordinates and deviation (click in the view);
* a section: a plane across an axis at a position, the nominal cut as polylines and
  the measured points within ±half a point spacing of the plane, coloured by deviation.

Export writes the coloured cloud as PLY with the field ``deviation`` (offered for
download and added to the project as an item); Report runs the inspection plugin's own
report writer (HTML, PDF, JSON, added to the project). The comparison is stored in the
project (the result, its deviations cloud as a result file, project state key
``inspection.current``), so reopening the project shows the last comparison.

Checking the request, running the plugin, storing, restoring and recording the report
are the headless task :class:`camcmm.tasks.compare.CompareTask` (tested without trame in
tests/tasks/). :class:`ComparePage` holds it and shows what it gives, with a part per
topic, each a module readable alone and made with the page it serves:

* :mod:`.inputs` — :class:`~.inputs.Inputs`: the form, the items, point pairs, picking;
* :mod:`.run` — :class:`~.run.Display`: the result drawn, its numbers, tolerance (bands
  from the ``tolerance-bands`` plugin), display mode;
* :mod:`.section` — :class:`~.section.Section` (cut by the ``deviation-section`` plugin);
* :mod:`.legend` — :class:`~.legend.Legend`: continuous, stepped or ±tolerance;
* :mod:`.export` — :class:`~.export.Export`: export, report and their links;

over plain modules testable without trame: :mod:`.tables` (units, legends, tables),
:mod:`.figures` (plotly figures), :mod:`.picking` (picking maths) and :mod:`.scene`
(:class:`CompareView`, the page's off-screen pyvista plotter). The page publishes
everything through the trame ``state`` (keys ``ins_*``) for :mod:`.layout`. VTK, the
state and the page's scene are touched only from the server loop; the plugin run, the
display preparation, storing, export and report run in the job's thread.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from ....errors import InputError, one_line
from ....host import RunResult
from ....tasks.compare import STATE_KEY, Checked, CompareTask, Comparison
from ...downloads import Downloads
from ...jobs import Job
from ...viewtools import ViewTools
from .characteristics import Characteristics
from .export import Export
from .figures import empty_figure
from .inputs import Inputs
from .legend import Legend
from .run import Display
from .scene import CompareView, Prepared, prepare_cloud
from .section import Section

__all__ = ["DOWNLOAD_ROUTE", "STATE_KEY", "ComparePage", "mount"]

DOWNLOAD_ROUTE = "camcmm-inspect-downloads"


class ComparePage:
    """Publishes the comparison through the session's trame state (``ins_*`` keys) and
    runs the task's slow steps in its job. One per server."""

    def __init__(self, session: Any, downloads: str | Path | None = None, display_limit: int | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.task = CompareTask(session.host, session, session.project)
        limit = display_limit or getattr(getattr(session, "view", None), "display_limit", None) or 500_000
        self.view = CompareView(int(limit))
        self.offered = Downloads(DOWNLOAD_ROUTE, "camcmm-inspect-", downloads)
        self.downloads, self.download_route = self.offered.folder, self.offered.route
        # the view's toolbar (state keys insv_*); screenshots go to the page's downloads
        self.tools = ViewTools(self.view, self.state, "insv", self.offered)
        self.job = Job("the comparison", state=self.state, on_progress=self._set_progress)
        # the comparison on show
        self.comparison: Comparison | None = None
        self.result: RunResult | None = None
        self.outputs: dict[str, Any] | None = None
        self.deviations: Any = None  # PointCloud with field "deviation"
        self.prepared: Prepared | None = None
        self.bands: dict[str, Any] | None = None  # the plugin's bands for the tolerance shown
        self.nominal: Any = None
        self.measured: Any = None
        self.result_id: int | None = None
        self.spacing_mm: float | None = None  # the deviations cloud's point spacing (section)
        self.timing: dict[str, float] = {}
        # its parts
        self.inputs = Inputs(self)
        self.display = Display(self)
        self.sections = Section(self)
        self.legend = Legend(self)
        self.exports = Export(self)
        self._init_state()
        self.refresh_inputs()
        self.restore()
        # the GD&T characteristics panel (plan, run, results, flags): after the comparison is
        # restored, so that its own last result is what the view shows when there is one
        self.gdt = Characteristics(self)

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.ins_measured = None
        s.ins_nominal = None
        s.ins_align_options = []
        s.ins_align = "icp"
        s.ins_tolerance = ""
        s.ins_fields = []
        s.ins_params = {}
        s.ins_running = False
        s.ins_progress = 0.0
        s.ins_progress_message = ""
        s.ins_error = ""
        s.ins_has_result = False
        s.ins_failed = False
        s.ins_failed_reason = ""
        s.ins_title = ""
        s.ins_mode = "inputs"
        s.ins_unit = "mm"
        s.ins_legend_title = ""
        s.ins_limit_text = ""
        s.ins_legend_kind = "continuous"
        s.ins_legend_n = 10
        s.ins_bands = []
        s.ins_note = ""
        s.ins_stats = []
        s.ins_alignment = []
        s.ins_warnings = []
        s.ins_picked = None
        s.ins_pairs = []
        s.ins_pick_hint = ""
        s.ins_fig_hist = empty_figure("the histogram of the deviations appears here after Run")
        s.ins_fig_af = empty_figure("the Abbott-Firestone curve appears here after Run")
        s.ins_fig_section = empty_figure("a section through the part appears here after Run")
        s.ins_section_axis = "z"
        s.ins_section_pos = 0.0
        s.ins_section_range = [0.0, 1.0, 0.01]
        s.ins_export_links = []
        s.ins_report_links = []
        s.ins_busy = ""
        s.ins_result_id = None
        s.ins_timing = {}

    def flush(self) -> None:
        self.session.flush()

    def error(self, msg: Any) -> None:
        """Show ``msg`` (one line) as the page's error."""
        line = one_line(msg)
        self.state.ins_error = line
        self.session.error(line)

    # -- the inputs (Inputs) ---------------------------------------------------------------
    def refresh_inputs(self) -> None:
        self.inputs.refresh_inputs()

    def set_inputs(self, measured: Any = None, nominal: Any = None) -> None:
        self.inputs.set_inputs(measured, nominal)

    def show_inputs(self, reset_camera: bool = True, push: bool = True) -> bool:
        return self.inputs.show_inputs(reset_camera, push)

    def load(self, key: Any, what: str) -> Any:
        return self.inputs.load(key, what)

    def unit_note(self, measured: Any, nominal: Any) -> str:
        return self.inputs.unit_note(measured, nominal)

    def set_align(self, method: str) -> None:
        self.inputs.set_align(method)

    def opened(self) -> None:
        self.inputs.opened()

    def pairs(self) -> dict[str, list[list[float]]] | None:
        return self.inputs.pairs()

    def add_pair_point(self, which: str, point: Any) -> None:
        self.inputs.add_pair_point(which, point)

    def clear_pairs(self, render: bool = True) -> None:
        self.inputs.clear_pairs(render)

    def undo_pair_point(self) -> None:
        self.inputs.undo_pair_point()

    def pick_at(self, fx: float, fy: float) -> dict[str, Any] | None:
        return self.inputs.pick_at(fx, fy)

    def pick_display(self, x: float, y: float) -> dict[str, Any] | None:
        return self.inputs.pick_display(x, y)

    def pick_index(self, i: int, label: bool = True) -> dict[str, Any]:
        return self.inputs.pick_index(i, label)

    # -- what is shown (Display, Section, Legend) --------------------------------------------
    def set_mode(self, mode: str) -> None:
        self.display.set_mode(mode)

    def set_tolerance(self, value: Any) -> None:
        self.display.set_tolerance(value)

    def set_section(self, axis: str | None = None, position: float | None = None) -> dict[str, Any] | None:
        return self.sections.set_section(axis, position)

    def spacing(self) -> float:
        return self.sections.spacing()

    def set_legend(self, kind: Any = None, n: Any = None) -> None:
        self.legend.set(kind, n)

    # -- export and report (Export) ----------------------------------------------------------
    async def export_async(self) -> dict[str, Any] | None:
        return await self.exports.export_async()

    async def report_async(self) -> dict[str, Any] | None:
        return await self.exports.report_async()

    # -- running -------------------------------------------------------------------------
    def _set_progress(self, fraction: float, message: str) -> None:
        """The job's progress (fraction 0..1), on the loop thread."""
        self.state.ins_progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.ins_progress_message = message

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.ins_progress_message = "cancelling …"

    def _checked(self, params: dict[str, Any] | None) -> Checked:
        self.task.spec  # noqa: B018 -- no provider: said before anything else
        self.refresh_inputs()  # the items may have changed without a flush
        return self.task.check(self.inputs.request(params))

    async def run_async(self, params: dict[str, Any] | None = None) -> RunResult | None:
        """Check the form, run the task (and store) in the page's job while the page stays
        live, show the result. None (with the reason shown) if it did not run."""
        if self.job.running:
            self.error("a comparison is running; wait for it or cancel it")
            return None
        try:
            checked = self._checked(params)
        except Exception as exc:
            self.error(exc)
            return None
        self.job.begin()
        try:
            return await self._run_begun(checked)
        finally:
            self.job.end()

    def _compute(self, checked: Checked) -> tuple[Comparison, Prepared, dict[str, float]]:
        """Worker thread: the task's run, then the display's preparation."""
        t0 = time.time()
        comparison = self.task.run(checked, progress=self.job.progress, cancel=self.job.cancel_event)
        self.measured, self.nominal = comparison.measured, comparison.nominal
        t_result = time.time()
        dev = comparison.deviations
        prep = prepare_cloud(dev.points, dev.fields["deviation"], self.view.display_limit)
        return comparison, prep, {"started": t0, "result": t_result, "prepared": time.time()}

    async def _run_begun(self, checked: Checked) -> RunResult | None:
        s = self.state
        s.ins_running = True
        s.ins_progress = 0.0
        s.ins_progress_message = f"running {checked.spec.id} …"
        s.ins_error = ""
        self.session.clear_error()
        self.flush()
        try:
            comparison, prep, timing = await self.job.call(self._compute, checked)
        except Exception as exc:
            self._failed(exc)
            self.flush()
            return None
        self.comparison = comparison
        self.display.show(comparison.result, prep, timing)
        self.flush()
        self.timing["flushed"] = time.time()
        s.ins_timing = dict(self.timing)
        self.sections.auto()  # after the colour map is on its way: it needs the point spacing
        self.flush()
        try:
            record = await self.job.call(self.task.store, comparison)
        except Exception as exc:
            # the result is shown all the same: only reopening the project will miss it
            self.error(f"the comparison could not be stored in the project: {one_line(exc)}")
            self.flush()
            return comparison.result
        self._stored(record)
        self.flush()
        return comparison.result

    def _failed(self, exc: BaseException) -> None:
        s = self.state
        s.ins_running = False
        # an input the operator gave speaks for itself; anything else names the plugin
        status, msg = Job.outcome(exc, "" if isinstance(exc, InputError) else self.task.spec.id)
        s.ins_progress_message = status
        self.error(msg)

    def _stored(self, record: dict[str, Any]) -> None:
        self.result_id = record["result"]
        self.state.ins_result_id = record["result"]
        self.state.ins_report_links = []
        self.state.ins_export_links = []
        self.session.refresh_results()
        c = "" if not self.state.ins_failed else " (the alignment failed)"
        self.session.info(f"comparison stored as result #{record['result']}{c}")

    # -- restoring -------------------------------------------------------------------------
    def restore(self) -> bool:
        """Show the last comparison stored in the project (``inspection.current``)."""
        record = self.task.stored()
        if record is None:
            return False
        s = self.state
        try:
            comparison = self.task.restore()
        except Exception as exc:
            s.ins_error = f"the last comparison (result {record.get('result')}) cannot be shown: {one_line(exc)}"
            return False
        if comparison is None:
            return False
        for key, attr in (("measured", "ins_measured"), ("nominal", "ins_nominal")):
            if record.get(key) is not None and self.session.measurement(record[key]) is not None:
                setattr(s, attr, str(record[key]))
        if record.get("align"):
            s.ins_align = record["align"]
        if record.get("tolerance") is not None:
            s.ins_tolerance = record["tolerance"]
        self.inputs.set_pairs(record.get("pairs"))
        self.measured, self.nominal = comparison.measured, comparison.nominal
        cloud = comparison.deviations
        prep = prepare_cloud(cloud.points, cloud.fields.get("deviation"), self.view.display_limit)
        self.comparison = comparison
        self.display.show(comparison.result, prep)
        self.result_id = int(record["result"])
        s.ins_result_id = self.result_id
        s.ins_progress = 0.0
        s.ins_progress_message = ""
        self.sections.auto()
        s.ins_report_links = self.exports.links(record.get("report") or {}, "report")
        s.ins_export_links = self.exports.links({"ply": record["export"]} if record.get("export") else {}, "export")
        return True

    # -- shutdown --------------------------------------------------------------------------
    def close(self) -> None:
        self.job.close()
        self.gdt.close()
        self.offered.close()
        try:
            self.view.plotter.close()
        except Exception:
            pass


def mount(server: Any, session: Any, display_limit: int | None = None) -> ComparePage:
    """Create the page for a session, serve its downloads folder and follow the
    project's items (call before the server starts)."""
    page = ComparePage(session, display_limit=display_limit)
    page.offered.mount(server)

    @server.state.change("items")
    def _items_changed(**_):
        page.refresh_inputs()

    @server.state.change("page")
    def _page_changed(**changes):
        if changes.get("page") == "compare":
            page.opened()

    return page
