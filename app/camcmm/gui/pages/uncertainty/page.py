"""The "Uncertainty" page's state and handlers: a GUM budget editor and a Monte Carlo
study of a stereo system, published through the trame state (``unc_*`` keys).

Both are the headless task :mod:`camcmm.tasks.uncertainty` (the plugins that provide
``uncertainty-budget`` and ``monte-carlo-uncertainty``, found by task through the host as
the CLI finds its own, held to the task's output contracts), so the page shows the CLI's
numbers. The page holds the task (``page.task``: a
:class:`~camcmm.tasks.uncertainty.UncertaintyTask`) and shows what it gives. The budget is
evaluated as the operator types (it is cheap, on the loop thread); a draft is kept in the
project's state so an edited table survives a restart. A Monte Carlo run is the page's
one :class:`~camcmm.gui.jobs.Job` (progress, cancel); its result is stored in the project
(the summary in the result row, every array in a JSON file) and shown again on reopen.

Threading: state, store reads and VTK on the server loop; the plugin run and the file
writing in the job's worker.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ....errors import CamcmmError, InputError, one_line
from ....tasks import uncertainty as unc
from ...downloads import Downloads
from ...jobs import Job
from . import budget as bud
from . import figures as figs
from . import study
from .view import UncertaintyView, map_options

log = logging.getLogger("camcmm.gui.uncertainty")

BUDGET_TASK, MONTECARLO_TASK = unc.BUDGET_TASK, unc.MONTECARLO_TASK
DRAFT_KEY = unc.DRAFT_KEY


class UncertaintyPage:
    """The page object (``server.pages["uncertainty"]``)."""

    def __init__(self, session: Any, downloads: str | Path | None = None):
        self.session = session
        self.server: Any = None  # set by mount: the layout binds its triggers to its controller
        self.state = session.state
        self.project = session.project
        self.host = session.host
        self.task = unc.UncertaintyTask(self.host, self.project)
        self.offered = Downloads("camcmm-uncertainty-downloads", "camcmm-uncertainty-", downloads)
        self.view = UncertaintyView()
        self.job = Job("the Monte Carlo run", state=self.state, on_progress=self._show_progress, interval=0.2)
        self.budget: dict[str, Any] | None = None
        self.mc: dict[str, Any] | None = None
        self.mc_result_id: int | None = None
        self._init_state()
        self.restore()

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.unc_tab = "budget"
        s.unc_error = ""
        s.unc_b_error = ""
        s.unc_b_distributions = bud.DISTRIBUTIONS
        s.unc_b_kinds = bud.KINDS
        s.unc_b_result = None
        s.unc_b_fig = figs.empty("the budget's contributions appear here")
        s.unc_b_links = []
        try:
            groups = study.form_fields(self.host.provider(MONTECARLO_TASK))
        except CamcmmError as exc:  # no plugin for the study: the page opens, Run says why
            log.warning("%s", one_line(exc))
            groups = {"run": [], "system": [], "errors": []}
        s.unc_mc_fields_run, s.unc_mc_fields_system = groups["run"], groups["system"]
        s.unc_mc_fields_errors = groups["errors"]
        self.mc_groups = groups
        s.unc_mc_params = study.start_values(groups)
        # the "load YAML" option: a system file used instead of the fields until cleared
        self.mc_system: dict[str, Any] | None = None
        s.unc_mc_loaded = ""
        s.unc_mc_studies = ["convergence", "volume_maps"]
        s.unc_mc_study_options = [{"title": study.STUDY_TITLES[k], "value": k} for k in study.STUDIES]
        s.unc_mc_running = False
        s.unc_mc_progress = 0.0
        s.unc_mc_message = ""
        s.unc_mc_rows = []
        s.unc_mc_summary = None
        s.unc_mc_axis = "x"
        s.unc_mc_fig_contrib = figs.contributions_figure({})
        s.unc_mc_fig_conv = figs.convergence_figure({}, "um")
        s.unc_mc_fig_sweep = figs.sweep_figure({}, "um")
        s.unc_mc_fig_spatial = figs.spatial_figure({}, "um")
        s.unc_mc_maps = []
        s.unc_mc_map = None
        s.unc_mc_map_note = ""
        s.unc_mc_links = []

    def flush(self) -> None:
        self.session.flush()

    def _error(self, msg: BaseException | str) -> None:
        line = one_line(msg)
        self.state.unc_error = line
        self.session.error(line)

    # -- the budget --------------------------------------------------------------------------
    def set_budget(
        self, quantity: str, unit: str, p: Any, rows: list[dict[str, Any]], save_draft: bool = True
    ) -> dict | None:
        """Evaluate the editor's budget; the result (or the one-line reason) is shown at once."""
        s = self.state
        s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, s.unc_b_rows = quantity, unit, p, [dict(r) for r in rows]
        req = unc.BudgetRequest(quantity, unit, p, [dict(r) for r in rows])
        if save_draft:
            try:
                self.task.save_draft(req)
            except Exception as exc:  # the editor keeps working; the reason is shown
                s.unc_b_error = f"the draft could not be kept in the project: {one_line(exc)}"
        try:
            res = self.task.evaluate(req).outputs
        except Exception as exc:
            self.budget = None
            s.unc_b_result, s.unc_b_error = None, one_line(exc)
            s.unc_b_fig = figs.empty("fix the table to see the contributions")
            return None
        self.budget = res
        s.unc_b_error = ""
        s.unc_b_result = bud.shown(res)
        s.unc_b_fig = figs.budget_figure(res)
        return res

    def add_row(self) -> None:
        self.state.unc_b_rows = list(self.state.unc_b_rows or []) + [dict(bud.EMPTY_ROW)]
        self.state.unc_b_error = "a new row: give its name, how it is entered (u, a or U) and its value"

    def remove_row(self, i: int) -> None:
        rows = [r for j, r in enumerate(self.state.unc_b_rows or []) if j != int(i)]
        s = self.state
        self.set_budget(s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, rows)

    def load_budget(self, text: str | bytes, name: str = "budget.yaml") -> bool:
        """Replace the editor's budget by a YAML/JSON budget file's."""
        try:
            req = unc.read_budget(text, name)
        except InputError as exc:
            self._error(exc)
            return False
        self.set_budget(req.quantity, req.unit, req.p, req.rows)
        return True

    def save_budget(self) -> dict[str, Any] | None:
        """Store the evaluated budget as a result and offer YAML, CSV, JSON and PNG."""
        if self.budget is None:
            self._error("the budget has errors: fix the table first")
            return None
        s = self.state
        req = unc.BudgetRequest(s.unc_b_quantity, s.unc_b_unit, s.unc_b_p, list(s.unc_b_rows or []))
        doc = req.doc()
        try:
            run = self.task.evaluate(req)
            rid = self.task.store_budget(run, req)
        except Exception as exc:
            self._error(f"budget: {one_line(exc)}")
            return None
        s.unc_b_links = bud.exports(self.offered, f"budget-{rid}", doc, run.outputs)
        self.session.refresh_results()
        self.session.info(f"budget stored as result #{rid}")
        return {"result_id": rid, "links": s.unc_b_links}

    # -- the Monte Carlo study -------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        self.state.unc_mc_progress = round(100.0 * float(fraction), 1)
        self.state.unc_mc_message = message or "Monte Carlo"

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.unc_mc_message = "cancelling …"

    def load_system(self, text: str | bytes, name: str = "system.yaml") -> bool:
        """The "load YAML" option: a system file (cameras, stereo, grid, uncertainties; or a
        stereo calibration) replaces the form's system fields until :meth:`use_fields`."""
        try:
            self.mc_system = unc.load_system(text, name)
        except InputError as exc:
            self._error(exc)
            return False
        self.state.unc_mc_loaded = name
        return True

    def use_fields(self) -> None:
        """Back to the system of the form's fields."""
        self.mc_system = None
        self.state.unc_mc_loaded = ""

    async def run_montecarlo_async(self, params: dict[str, Any]) -> dict[str, Any] | None:
        """Run the study with the form's ``params`` (the system's fields, iterations, seed,
        method, scheduler as typed; studies a list of :data:`~.study.STUDIES`) — of the
        loaded system file instead of the fields if there is one; store and show it. The
        full result, or None (the reason is in ``unc_error``)."""
        s = self.state
        if self.job.running:
            self._error("a Monte Carlo run is going on; wait for it or cancel it")
            return None
        try:
            checked = self.task.check_montecarlo(unc.MonteCarloRequest(dict(params or {}), self.mc_system))
            roots = getattr(self.session, "roots", None)
            if roots is not None:  # the scheduler must be one of --scheduler: refused before any connection
                roots.check_params(checked.spec.parameters, checked.values)
        except Exception as exc:
            self._error(exc)
            return None
        cancel = self.job.begin()
        s.unc_mc_running, s.unc_mc_progress, s.unc_mc_message, s.unc_error = True, 0.0, "starting …", ""
        self.flush()
        try:
            run = await self.job.call(self.task.run_montecarlo, checked, progress=self.job.progress, cancel=cancel)
            s.unc_mc_message = "storing the result in the project …"
            self.flush()
            rid, h = await self.job.call(self.task.store_montecarlo, run, checked)
            full = await self.job.call(self.task.read, h)
        except Exception as exc:
            status, line = Job.outcome(exc)
            s.unc_mc_running, s.unc_mc_message = False, status
            self._error(line)
            return None
        finally:
            self.job.end()
            self.flush()
        s.unc_mc_running, s.unc_mc_progress = False, 100.0
        s.unc_mc_message = unc.done_message(full)
        self.show_montecarlo(full, rid)
        self.session.refresh_results()
        self.flush()
        return full

    def show_montecarlo(self, full: dict[str, Any], rid: int | None = None) -> None:
        """Publish a Monte Carlo result (fresh, or read back from the project)."""
        s = self.state
        self.mc, self.mc_result_id = full, rid
        s.unc_mc_rows = study.table_rows(full)
        s.unc_mc_summary = {
            "unit": figs.shown_unit(full.get("unit", "um")),
            "iterations": full.get("iterations"),
            "result_id": rid,
            "method": full.get("method"),
            "n_points": full.get("n_points"),
        }
        self._draw_figures()
        s.unc_mc_maps = map_options(full)
        s.unc_mc_map = s.unc_mc_maps[0]["value"] if s.unc_mc_maps else None
        self.show_map(s.unc_mc_map)
        s.unc_mc_links = study.exports(self.offered, full, rid, s.unc_mc_rows, s.unc_mc_axis or "x")

    def _draw_figures(self) -> None:
        s, full = self.state, self.mc or {}
        studies = full.get("studies") or {}
        unit = full.get("unit", "um")
        s.unc_mc_fig_contrib = figs.contributions_figure(full)
        s.unc_mc_fig_conv = figs.convergence_figure(studies.get("convergence") or {}, unit, s.unc_mc_axis or "x")
        s.unc_mc_fig_sweep = figs.sweep_figure(studies.get("sweep") or {}, unit)
        s.unc_mc_fig_spatial = figs.spatial_figure(studies.get("spatial") or {}, unit)

    def set_axis(self, axis: str) -> None:
        self.state.unc_mc_axis = axis if axis in figs.AXES else "x"
        self._draw_figures()

    def show_map(self, choice: str | None) -> None:
        s = self.state
        s.unc_mc_map = choice
        if not choice or self.mc is None:
            self.view.clear()
            s.unc_mc_map_note = (
                "tick 'volume_maps' under Studies and run to see the measuring volume" if self.mc else ""
            )
            return
        try:
            s.unc_mc_map_note = self.view.show(self.mc, choice, self.mc.get("unit", "um"))
        except Exception as exc:
            s.unc_mc_map_note = f"cannot show {choice}: {one_line(exc)}"

    # -- restore -----------------------------------------------------------------------------
    def restore(self) -> None:
        """The draft budget (or the shipped example) and the last stored Monte Carlo run."""
        s = self.state
        req = self.task.start_budget()
        self.set_budget(req.quantity, req.unit, req.p, req.rows, save_draft=False)
        try:
            back = self.task.restore_montecarlo()
            if back is not None:
                full, rid = back.full, back.result_id
                if isinstance(full.get("form"), dict):  # run from the fields: show them again
                    s.unc_mc_params = study.start_values(self.mc_groups, full["form"])
                elif isinstance(full.get("system"), dict):  # run of a loaded file
                    self.mc_system = full["system"]
                    s.unc_mc_loaded = f"the system of result #{rid}"
                s.unc_mc_message = f"result #{rid} from the project"
                self.show_montecarlo(full, rid)
        except Exception as exc:  # a damaged file must not keep the page from opening
            log.warning("cannot restore the Monte Carlo result: %s", exc)
            s.unc_mc_message = f"the stored Monte Carlo result could not be read: {one_line(exc)}"

    def close(self) -> None:
        self.job.close()
        self.offered.close()
        self.view.close()


def mount(server: Any, session: Any) -> UncertaintyPage:
    """Create the page for a session and serve its downloads (before the server starts)."""
    page = UncertaintyPage(session)
    page.server = server
    page.offered.mount(server)
    return page
