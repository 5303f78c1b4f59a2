"""Compare with CAD: the inspection page's logic, apart from the layout.

The operator picks the measured cloud and the nominal (a CAD mesh or a reference
cloud) from the project's items, an alignment method (the choices declared by the
plugin providing ``compare-with-cad``; the ``pairs`` methods take three point pairs
clicked in the 3D view: on the measured cloud, then on the nominal, three times) and a
tolerance, and runs the plugin in the page's job. The result is shown as

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

The page is one :class:`ComparePage` made of mixins, a module each, each readable alone:

* :mod:`.inputs` — the form, the items, point pairs, picking in the view;
* :mod:`.run` — running (in the page's :class:`~camcmm.gui.jobs.Job`), showing the
  result, tolerance (bands from the ``tolerance-bands`` plugin), display mode;
* :mod:`.section` — the section (cut by the ``deviation-section`` plugin);
* :mod:`.export` — storing, restoring, export, report and their links;

over plain modules testable without trame: :mod:`.tables` (units, legends, tables),
:mod:`.figures` (plotly figures), :mod:`.picking` (picking maths) and :mod:`.scene`
(:class:`CompareView`, the page's off-screen pyvista plotter). :class:`ComparePage`
publishes everything through the trame ``state`` (keys ``ins_*``) for :mod:`.layout`.
VTK, the state and the page's scene are touched only from the server loop; the plugin
run, the display preparation, storing, export and report run in the job's thread.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ....errors import one_line
from ....host import RunResult
from ...downloads import Downloads
from ...jobs import Job
from ...viewtools import ViewTools
from .export import STATE_KEY, Export
from .figures import empty_figure
from .inputs import TASK, Inputs
from .legend import Legend
from .run import Run
from .scene import CompareView, Prepared
from .section import Section

__all__ = ["DOWNLOAD_ROUTE", "STATE_KEY", "ComparePage", "mount"]

DOWNLOAD_ROUTE = "camcmm-inspect-downloads"


class ComparePage(Inputs, Run, Section, Export, Legend):
    """Publishes the comparison through the session's trame state (``ins_*`` keys) and
    runs the slow steps in its job. One per server."""

    def __init__(self, session: Any, downloads: str | Path | None = None, display_limit: int | None = None):
        self.session = session
        self.state = session.state
        self.project = session.project
        self.host = session.host
        limit = display_limit or getattr(getattr(session, "view", None), "display_limit", None) or 500_000
        self.view = CompareView(int(limit))
        self.offered = Downloads(DOWNLOAD_ROUTE, "camcmm-inspect-", downloads)
        self.downloads, self.download_route = self.offered.folder, self.offered.route
        # the view's toolbar (state keys insv_*); screenshots go to the page's downloads
        self.tools = ViewTools(self.view, self.state, "insv", self.offered)
        self.job = Job("the comparison", state=self.state, on_progress=self._set_progress)
        # the comparison on show
        self.result: RunResult | None = None
        self.outputs: dict[str, Any] | None = None
        self.deviations: Any = None  # PointCloud with field "deviation"
        self.prepared: Prepared | None = None
        self.bands: dict[str, Any] | None = None  # the plugin's bands for the tolerance shown
        self.nominal: Any = None
        self.measured: Any = None
        self.result_id: int | None = None
        self.saved: dict[str, Any] = {}
        self._spacing: float | None = None
        self._pairs_measured: list[list[float]] = []
        self._pairs_nominal: list[list[float]] = []
        self.timing: dict[str, float] = {}
        self._spec = None
        self._init_state()
        self.refresh_inputs()
        self.restore()

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

    def _error(self, msg: Any) -> None:
        line = one_line(msg)
        self.state.ins_error = line
        self.session.error(line)

    def _spec_of(self) -> Any:
        """The manifest of the plugin that compares with CAD (found by its task)."""
        if self._spec is None:
            self._spec = self.host.provider(TASK)
        return self._spec

    # -- shutdown --------------------------------------------------------------------------
    def close(self) -> None:
        self.job.close()
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
