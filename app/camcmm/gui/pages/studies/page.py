"""The "Studies" page's state and handlers (``st_*`` keys): a study file on the server in,
the study's tables and figures out (thesis ch. 6.2 and 6.3).

The study is the headless task :mod:`camcmm.tasks.studies` (the file checked, the plugin
run in a worker process, the result stored); the page runs it in a
:class:`~camcmm.gui.jobs.Job` with progress and cancel. The result goes into the project (loop
thread) and is shown again when the project reopens. "Make a virtual-lab study" writes
the virtual lab's study of the chosen kind into the project folder (so the page works
on the demo as shipped). "Export report" writes the plugin's declared report and offers
it for download. Tests call ``asyncio.run(page.run_async(...))``.
"""

from __future__ import annotations

import logging
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from ....errors import CamcmmError, one_line
from ....tasks import studies
from ...downloads import Downloads, sort_links
from ...jobs import Job
from ...runpage import RunShared
from ...widgets import declared_fields, form_values
from . import figures, tables

log = logging.getLogger("camcmm.gui.studies")
KEY = "studies"
EMPTY_HINT = (
    "Choose the kind of study and a study file on the server (inside the project folder or a --data-root), "
    "or press 'Make a virtual-lab study' to write one from the virtual lab into the project folder; then Run. "
    "Light-field scale (ch. 6.3): table 6.3, depth vs λ per view, gradient vs focal length with its fit and "
    "prediction. Speckle on/off (ch. 6.2): tables 6.1 and 6.2, coverage by area, deviation maps side by side."
)


#: warnings shown on the page (a study of many images can warn once per image; the report has them all)
MAX_WARNINGS = 4


def shortened(warnings: list[Any], n: int = MAX_WARNINGS) -> list[str]:
    """The first ``n`` distinct warnings, and how many more the report lists."""
    lines = list(dict.fromkeys(str(w) for w in warnings))
    more = len(lines) - n
    return lines[:n] + ([f"… and {more} more warning(s): see the report"] if more > 0 else [])


def check_params(spec: Any, raw: dict[str, Any] | None, roots: Any = None) -> dict[str, Any]:
    """The form's values checked against the declared parameters but the study file's
    (a required parameter of the speckle study: the task adds it from the page's file),
    paths and addresses against ``roots``."""
    raw = {k: v for k, v in dict(raw or {}).items() if k != "study"}
    return form_values(SimpleNamespace(id=spec.id, parameters=studies.form_fields(spec)), raw, roots)


class StudiesPage:
    KEY = KEY

    def __init__(self, server: Any, session: Any, downloads: str | Path | None = None):
        self.server, self.session, self.state, self.host = server, session, session.state, session.host
        self.shared = RunShared(session, KEY, "st", "study", studies)
        self.record: dict[str, Any] | None = None
        self.job = Job("the study", state=self.state, on_progress=self._show_progress, interval=0.2)
        self.runner = studies.run
        self.offered = Downloads("camcmm-studies-downloads", "camcmm-studies-", downloads)
        self.outputs: dict[str, Any] | None = None  # the last run's outputs in memory (with geometry)
        self._init_state()
        self.refresh_form()
        self.restore()

    @property
    def project(self) -> Any:
        return self.session.project

    def restore(self) -> None:
        """The last run, as the project keeps it."""
        self.shared.restore(lambda req: self._set_request(req.to_dict()), self.show_record)

    # -- state ------------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.st_kinds = [{"title": k["title"], "value": key} for key, k in studies.KINDS.items()]
        s.st_kind, s.st_file = "lightfield", ""
        s.st_fields, s.st_params = [], {}
        s.st_running, s.st_progress, s.st_message, s.st_error = False, 0.0, "", ""
        s.st_title, s.st_warnings, s.st_shown_kind = "", [], ""
        s.st_tables, s.st_numbers, s.st_links = [], [], []
        s.st_views, s.st_view = [], 0
        s.st_pairs, s.st_pair = [], None
        s.st_fig_scatter = figures.scatter_figure(None)
        s.st_fig_focal = figures.focal_figure(None)
        s.st_fig_off = s.st_fig_on = figures.empty("")
        s.st_empty_hint = EMPTY_HINT

    def spec(self) -> Any:
        """The manifest of the plugin that runs the chosen kind of study."""
        return studies.spec_of(self.host, self.state.st_kind)

    def refresh_form(self) -> None:
        """The run form from the chosen study plugin's declared parameters (not the study file's)."""
        s = self.state
        try:
            spec = self.spec()
        except CamcmmError as exc:
            s.st_fields, s.st_params = [], {}
            s.st_message = f"no plugin for this study: {one_line(exc)}"
            return
        s.st_fields, s.st_params = declared_fields(studies.form_fields(spec))

    def set_kind(self, kind: Any) -> None:
        if str(kind) not in studies.KINDS or self.job.running:
            return
        if kind != self.state.st_kind:
            self.state.st_kind, self.state.st_file = str(kind), ""
        self.refresh_form()

    def _set_request(self, req: dict[str, Any]) -> None:
        if req.get("kind") in studies.KINDS:
            self.state.st_kind = req["kind"]
            self.refresh_form()
        if req.get("file"):
            self.state.st_file = str(req["file"])

    # -- the runs ---------------------------------------------------------------------------
    def _show_progress(self, fraction: float, message: str) -> None:
        self.state.st_progress = round(100.0 * float(fraction), 1)
        self.state.st_message = message or self.state.st_message

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.st_message = "cancelling …"

    def _begin(self, message: str) -> None:
        s = self.state
        self.shared.clear_error()
        s.st_running, s.st_progress, s.st_message = True, 0.0, message
        self.session.flush()

    def _failed(self, exc: BaseException) -> None:
        status, line = Job.outcome(exc)
        s = self.state
        s.st_running, s.st_progress, s.st_message = False, 0.0, status
        self.shared.error(line)
        self.session.flush()

    async def make_virtual_async(self) -> str | None:
        """Write the virtual lab's study of the chosen kind into the project folder and
        choose its study file; the path, or None with the reason on the page."""
        if self.job.running:
            self.shared.error("a study is running; wait for it or cancel it")
            return None
        kind = self.state.st_kind
        self._begin("writing the virtual-lab study …")
        try:
            folder = Path(self.session.roots.project)
            path = await self.shared.run_in(self.job, studies.make_virtual, self.host, kind, folder)
        except Exception as exc:
            self._failed(exc)
            return None
        s = self.state
        s.st_running, s.st_progress, s.st_file = False, 100.0, path
        s.st_message = f"virtual-lab study written: {path}; press Run"
        self.session.flush()
        return path

    async def run_async(self, params: dict[str, Any] | None = None, file: str | None = None) -> dict[str, Any] | None:
        """Run the chosen study on ``file`` (else the page's) with ``params`` (else the
        form's) and store the result; the page's record, or None with the reason shown."""
        s = self.state
        if self.job.running:
            self.shared.error("a study is running; wait for it or cancel it")
            return None
        kind = str(s.st_kind)
        try:
            spec = self.spec()
            values = check_params(spec, s.st_params if params is None else params, getattr(self.session, "roots", None))
            path = studies.study_file(getattr(self.session, "roots", None), s.st_file if file is None else file)
        except Exception as exc:
            self.shared.error(exc)
            return None
        s.st_file = str(s.st_file if file is None else file)
        self._begin("starting …")
        try:
            req = studies.StudyRequest(kind, str(path))
            result = await self.shared.run_in(self.job, self.runner, self.host, req, values)
            rec = studies.store(self.project, result, req)
        except Exception as exc:
            self._failed(exc)
            return None
        self.outputs = dict(result.outputs)
        s.st_running, s.st_progress = False, 100.0
        self.show_record(rec)
        s.st_message = f"done: result #{rec['result']}"
        self.session.refresh_results()
        self.session.info(f"study stored as result #{rec['result']}", page=KEY)
        self.session.flush()
        return rec

    # -- what is shown ----------------------------------------------------------------------
    def show_record(self, rec: dict[str, Any], draw: bool = True) -> None:
        """A run's record on the page: its tables, numbers and figures."""
        s, o = self.state, rec.get("outputs") or {}
        self.record = rec
        s.st_title = f"{rec.get('name', '')} — result #{rec.get('result')} ({rec.get('plugin', '')})"
        s.st_warnings = shortened(rec.get("warnings") or [])
        s.st_shown_kind, s.st_links = rec.get("kind"), []
        if rec.get("kind") == "lightfield":
            s.st_tables = [tables.table_63(o.get("table") or {})]
            s.st_numbers = tables.focal_rows(o.get("focal"), o.get("truth"))
            s.st_fig_focal = figures.focal_figure(o.get("focal"))
            s.st_views = [
                {"title": f"{r.get('set')} · {r.get('artefact')} · {str(v.get('image', k)).rsplit('/', 1)[-1]}",
                 "value": f"{i}:{k}"}
                for i, r in enumerate(o.get("scatter") or []) for k, v in enumerate(r.get("views") or [])
            ]  # fmt: skip
            self.show_view(s.st_views[0]["value"] if s.st_views else None)
        else:
            cases = list(o.get("cases") or [])
            s.st_tables = tables.speckle_tables(cases)
            s.st_numbers = tables.summary_rows(o.get("summary") or {})
            s.st_pairs = tables.pairs(cases)
            self.show_pair(s.st_pairs[0]["value"] if s.st_pairs else None)

    def show_view(self, value: Any) -> None:
        """The depth-vs-λ scatter of view ``"<run>:<view>"``."""
        o = (self.record or {}).get("outputs") or {}
        try:
            i, k = (int(x) for x in str(value).split(":"))
            view = o["scatter"][i]["views"][k]
        except (ValueError, KeyError, IndexError, TypeError):
            view = None
        self.state.st_view = value
        self.state.st_fig_scatter = figures.scatter_figure(view)

    def show_pair(self, value: Any) -> None:
        """The deviation maps without and with speckle of an artefact × material, one colour range."""
        rec = self.record or {}
        cases, maps = (rec.get("outputs") or {}).get("cases") or [], rec.get("maps") or {}
        off, on = (maps.get(tables.case_id(cases, str(value), c) or "") for c in ("off", "on"))
        lim = figures.shared_limit(off, on)
        self.state.st_pair = value
        self.state.st_fig_off = figures.deviation_figure(off, "Without speckle", lim)
        self.state.st_fig_on = figures.deviation_figure(on, "With speckle", lim)

    # -- the report -------------------------------------------------------------------------
    async def report_async(self) -> list[dict[str, str]] | None:
        """The plugin's report of the shown run (html, pdf, json), stored in the project
        and offered for download; the links, or None with the reason on the page."""
        rec = self.record
        if rec is None:
            self.shared.error("export report: run a study first")
            return None
        if self.job.running:
            self.shared.error("export report: wait for the study to finish")
            return None
        try:
            spec = studies.spec_of(self.host, rec.get("kind"))
            outputs = self.outputs if self.outputs is not None else rec.get("outputs") or {}
            folder = self.offered.folder / f"result-{rec['result']}"
            paths = await self.job.call(studies.write_report, spec, outputs, folder, f"study-{rec['result']}")
        except Exception as exc:
            self.shared.error(f"export report: {one_line(exc)}")
            return None
        links = []
        for kind, p in paths.items():
            try:
                self.project.add_file(p)
            except Exception as exc:  # the download still works
                log.warning("cannot keep the report in the project: %s", exc)
            link = self.offered.offer(Path(p).name, src=p, kind=kind, replace=True)
            if link:
                links.append(link)
        self.state.st_links = sort_links(links)
        self.shared.clear_error()
        self.session.info(f"report of result #{rec['result']} written", page=KEY)
        self.session.flush()
        return self.state.st_links

    def close(self) -> None:
        self.job.close()
        self.offered.close()


def mount(server: Any, session: Any) -> StudiesPage:
    """Create the page for a session (before the server starts); it has no 3-D view."""
    page = StudiesPage(server, session)
    page.offered.mount(server)

    @server.state.change("page")
    def _page_changed(**changes: Any) -> None:
        if changes.get("page") == KEY and not page.state.st_fields:
            page.refresh_form()

    return page
