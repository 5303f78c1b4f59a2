"""The Inspect page's state and handlers: the plugin list, the selected plugin's form,
a run with progress and cancel, the result panel and the 3D view's colour field.

The session holds what every page shares (the project's items, messages, the 3D
view); this page reads and changes them through its public methods. A run goes
through one :class:`~camcmm.gui.jobs.Job` to the headless task
:mod:`camcmm.tasks.plugin_run` (checked, run through :func:`camcmm.worker.run` — the plugin
computes in the worker process; a native crash does not end the server — and stored); the
page holds the task (``page.task``) and shows what it gives. Tests call
``asyncio.run(page.run_plugin(...))``.
"""

from __future__ import annotations

from typing import Any

from ....errors import CamcmmError, one_line
from ....host import RunResult
from ....tasks import plugin_run
from ...jobs import Job, in_background
from .cloudedit import CloudEditPanel
from .form import ITEM_TYPES, fields_of, inputs_of, run_blocker
from .report import parameters_line, report_rows
from .results import result_rows, summarize_json
from .tidy import Tidy


class InspectPage:
    """The state variables it owns: ``plugins``, ``selected_plugin``, ``plugin_title``,
    ``plugin_summary``, ``form_fields``, ``form_values``, ``form_inputs``,
    ``input_values``, ``running``, ``progress`` (0..100 %), ``progress_message``,
    ``run_reason`` (why Run cannot start, "" when it can), ``run_status`` (how the last
    run ended), ``result``, ``result_title``, ``report_rows`` (:mod:`.report`),
    ``result_params``, ``result_rows`` (every output), ``result_warnings``; the
    tidy's (:mod:`.tidy`)."""

    def __init__(self, server: Any, session: Any):
        self.server = server
        self.session = session
        self.state = session.state
        # looked up at each call, so that a test can watch the progress by replacing it
        self.job = Job("a plugin", state=self.state, on_progress=lambda f, m: self.show_progress(f, m))
        self.task = plugin_run.PluginRunTask(session.host, session, session.project)
        self.last_result: RunResult | None = None
        self.last_result_id: Any = None
        # the items the result shown is about (its inputs, what it made): the panel keeps it
        # while one of them is selected and otherwise shows the selected item's newest result
        self.result_items: set[str] = set()
        self.result_newest = False  # the result shown is the selected item's newest (follows new ones)
        self.result_id: Any = None  # the stored id of the result shown
        s = self.state
        s.update(
            {
                "plugins": [],
                "selected_plugin": None,
                "plugin_title": "",
                "plugin_summary": "",
                "form_fields": [],
                "form_values": {},
                "form_inputs": [],
                "input_values": {},
                "running": False,
                "progress": 0.0,
                "progress_message": "",
                "run_reason": "choose a plugin first",
                "run_status": "",
            }
        )
        self._clear_result()
        self.tidy = Tidy(session)
        self.cloudedit = CloudEditPanel(self)  # "Crop & segment" (.cloudedit)
        session.watch_items(self.refresh_inputs)
        session.watch_selection(self.follow_item)
        session.watch_project(self.follow_project)
        self.refresh_plugins()
        self.follow_item(self.state.selected_item)  # the item restored at start, with its result

    # -- plugins and the form ----------------------------------------------------------
    def refresh_plugins(self) -> None:
        """List the installed plugins with kind, version and status (a failed one says why)."""
        try:
            specs = self.session.host.check()
        except Exception as exc:
            self.session.error(f"plugin discovery failed: {exc}")
            specs = []
        self.state.plugins = [
            {
                "id": s.id,
                "name": s.name,
                "kind": s.kind,
                "version": s.version,
                "status": s.status,
                "ok": s.status == "ok",
                "summary": s.summary,
                "runnable": s.status == "ok" and s.kind in ("algorithm", "standard"),
            }
            for s in specs
        ]

    def select_plugin(self, plugin_id: str | None) -> None:
        """Build the form of an algorithm or standard plugin from its manifest."""
        if not plugin_id:
            self.state.selected_plugin = None
            return
        try:
            spec = plugin_run.runnable(self.session.host, plugin_id)
        except CamcmmError as exc:
            self.session.error(str(exc))
            return
        s = self.state
        s.form_fields, s.form_values = fields_of(spec)
        s.selected_plugin = spec.id
        s.plugin_title = f"{spec.name} (v{spec.version})"  # the name in words; the id is the CLI's (issue 30)
        s.plugin_summary = spec.summary
        s.run_status = ""
        self.refresh_inputs(reset=True)

    def refresh_inputs(self, reset: bool = False) -> None:
        """The form's input selects after the items changed (``reset``: a new plugin)."""
        s = self.state
        spec = self._spec()
        if spec is None:
            s.form_inputs = []
        else:
            current = {} if reset else dict(s.input_values or {})
            shown = next((it["id"] for it in s.items or [] if it["id"] == s.selected_item and not it["derived"]), None)
            s.form_inputs, s.input_values = inputs_of(spec, s.items or [], current, s.picked_item or shown)
        self.check_run()

    def _spec(self) -> Any:
        try:
            return self.session.host.get(self.state.selected_plugin) if self.state.selected_plugin else None
        except CamcmmError:
            return None

    def check_run(self) -> str:
        """Why Run cannot start now (state ``run_reason``, shown next to Run), "" if it can."""
        s, spec = self.state, self._spec()
        if self.job.running:
            reason = f"a run is going ({s.progress_message or 'running'}): wait for it or cancel it"
        elif spec is None:
            reason = "choose a plugin first" if not s.selected_plugin else f"plugin {s.selected_plugin!r} is not there"
        else:
            reason = run_blocker(spec, dict(s.form_values or {}), dict(s.input_values or {}), s.items or [])
        s.run_reason = reason
        return reason

    def select_item(self, key: Any) -> None:
        self.session.select_item(key)

    # -- a run -------------------------------------------------------------------------
    def _refuse(self, reason: str) -> None:
        """A run that cannot start: the reason next to Run, and as the page's error."""
        self.state.run_reason = reason
        self.session.error(reason)
        self.session.flush()

    def run_clicked(self, pid: Any, form_values: Any, input_values: Any) -> None:
        """The Run button: :meth:`run_form` in the background, returning at once (an
        awaited run would hold back this tab's Cancel until it was over)."""
        in_background(self.run_form(pid, form_values, input_values), self.state)

    async def run_form(self, pid: Any, form_values: Any, input_values: Any) -> RunResult | None:
        """The Run button (also ``ctrl.run_plugin_form``): a run that cannot start says
        why (no plugin, a run going, a missing input, a refused value); a value naming a
        file or folder must lie inside the roots; then :meth:`run_plugin`."""
        session = self.session
        if not pid or not isinstance(pid, str):
            self._refuse("choose a plugin first")
            return None
        if self.job.running:
            self._refuse(f"a run is going ({self.state.progress_message}): wait for it or cancel it")
            return None
        try:  # the run also takes inputs from the state, which the client writes too: check those
            inputs = {**dict(self.state.input_values or {}), **dict(input_values or {})}
            spec = session.host.get(pid)
            form_values, input_values = session.roots.check_run(spec, form_values, inputs, ITEM_TYPES)
        except (CamcmmError, TypeError, ValueError) as exc:
            self._refuse(one_line(exc))
            return None
        reason = run_blocker(spec, dict(form_values or {}), dict(input_values or {}), self.state.items or [])
        if reason:
            self._refuse(reason)
            return None
        return await self.run_plugin(pid, form_values or {}, input_values or {})

    async def run_plugin(
        self, plugin_id: str, params: dict[str, Any] | None = None, inputs: dict[str, Any] | None = None
    ) -> RunResult | None:
        """Run a plugin on the form's inputs (``inputs`` overrides them: port -> item key
        or value) while the page stays live. Progress and result go to the state, the
        result and its new clouds or meshes into the project. Returns the RunResult, or
        None after showing the one-line reason (a bad value, a failure, a cancel)."""
        request = plugin_run.PluginRunRequest(
            plugin_id, {**dict(self.state.input_values or {}), **dict(inputs or {})}, dict(params or {})
        )
        try:
            checked = self.task.check(request, screen=False)  # run_form screened it
            cancel = self.job.begin()
        except Exception as exc:  # a bad value or input, or Busy: a run is going
            self._refuse(one_line(exc))
            return None
        self._started(plugin_id)
        try:
            result = await self.job.call(self.task.run, checked, progress=self.job.progress, cancel=cancel)
        except Exception as exc:
            self.job.end()
            self._failed(plugin_id, exc)
            return None
        self.job.end()
        return self._done(checked, result)

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.progress_message = "cancelling …"

    def show_progress(self, fraction: float, message: str) -> None:
        """The run's progress on the page: ``fraction`` 0..1 as 0..100 %."""
        self.state.progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.progress_message = message

    def _clear_result(self) -> None:
        self.result_items, self.result_newest, self.result_id = set(), False, None
        self.state.update(
            {
                "result": None,
                "result_title": "",
                "result_rows": [],
                "result_warnings": [],
                "report_rows": [],
                "result_params": "",
            }
        )

    def _started(self, plugin_id: str) -> None:
        s = self.state
        s.running, s.progress, s.progress_message = True, 0.0, f"running {plugin_id} …"
        s.run_status = ""
        self.check_run()
        self._clear_result()
        self.session.clear_error()
        self.session.flush()

    def _failed(self, plugin_id: str, exc: BaseException) -> None:
        self.state.running = False
        self.check_run()
        _, msg = Job.outcome(exc)
        line = msg if plugin_id in msg else f"plugin {plugin_id!r}: {msg}"
        self.state.progress_message = "failed"
        # next to this plugin's own Run the name would fill the short line: the reason first
        self.state.run_status = msg
        self.session.error(line)
        self.session.flush()

    def _show(self, spec: Any, d: dict[str, Any], made: dict[str, str], warnings: list[str]) -> None:
        """A result (``RunResult.to_json()`` or a stored one) in the result panel: the
        report rows from the plugin's declared outputs, every output in the raw table."""
        s, outputs = self.state, d.get("outputs") or {}
        ports = list(spec.outputs) if spec is not None else []
        s.result = summarize_json(d)
        s.report_rows = report_rows(outputs, ports, made)
        s.result_rows = result_rows(outputs, {p.name: p.unit for p in ports})
        s.result_params = parameters_line(dict(d.get("params") or {}), list(spec.parameters) if spec else [])
        s.result_warnings = warnings

    def _done(self, checked: plugin_run.Checked, result: RunResult) -> RunResult:
        """A finished run stored by the task (its row, the items it made) and shown."""
        session, s, spec = self.session, self.state, checked.spec
        self.last_result = result
        taken = {it["name"] for it in [*(s.items or []), *(s.hidden_items or [])]}
        kept = self.task.store(checked, result, taken)
        if kept.error:
            session.error(kept.error)
        self.last_result_id = kept.result_id
        if kept.made:
            session.refresh_items()
        self._show(spec, result.to_json(), kept.made_names, kept.warnings)
        self.result_items = {str(m) for m in checked.mids} | {m.key for m in kept.made}
        self.result_newest, self.result_id = True, kept.result_id
        number = f" #{self.last_result_id}" if self.last_result_id is not None else ""
        s.result_title = f"{spec.name}{number} — v{result.plugin_version}"
        s.running, s.progress, s.progress_message = False, 100.0, "done"
        made = kept.made
        s.run_status = f"done{number}" + (f"; added {len(made)} item(s)" if made else "")
        session.refresh_results()
        if made:  # show the output, coloured by what the run added (a fit's residuals)
            last = made[-1]
            session.select_item(last.key, chosen=False, field=next(iter(last.fields), None))
        self.check_run()
        session.flush()
        return result

    # -- the result panel and the view -----------------------------------------------------
    def show_result(self, rid: Any) -> None:
        """Show a stored result (from the project) in the result panel."""
        try:
            d = self.task.stored(rid)
        except Exception as exc:
            self.session.error(f"result {rid}: {one_line(exc)}")
            return
        plugin = str(d.get("plugin", ""))
        spec = plugin_run.spec_of(self.session.host, plugin)
        self._show(spec, d, {}, list(d.get("warnings") or []))
        from camcmm.tasks.acceptance.naming import result_row  # named as the results list names it

        row = result_row(d, self.session.host)
        self.state.result_title = f"result #{rid}: {row['title']} ({row['subtitle']}; v{d.get('version', '')})"
        self.result_items = {str(m) for m in d.get("measurement_ids") or []}
        self.result_newest, self.result_id = False, rid

    def newest_result(self, key: Any) -> Any:
        """The id of the newest stored result about item ``key`` (None: none): one that
        used it, or, for an item a run made, that run — the newest result of the plugin and
        version it names (``meta["made_by"]``) stored before the item (a run stores its row,
        then the items it made)."""
        try:
            rows = self.session.project.results()
        except Exception:  # a store without results: nothing to follow
            return None
        found = [r["id"] for r in rows if str(key) in {str(m) for m in r.get("measurement_ids") or []}]
        m = self.session.measurement(key) or {}
        made_by = str((m.get("meta") or {}).get("made_by") or "") if isinstance(m.get("meta"), dict) else ""
        if made_by and m.get("created"):
            made = [
                r["id"]
                for r in rows
                if f"{r.get('plugin')} {r.get('version')}" == made_by and str(r.get("created")) <= str(m["created"])
            ]
            found += made[-1:]
        return max(found) if found else None

    def follow_item(self, key: Any) -> None:
        """The item selected changed: the panel keeps the result shown while it is about
        that item (an input of it, or made by it), else shows the item's newest result, else
        nothing — never "Sphere fit #26" beside a height map it did not measure."""
        if key is not None and str(key) in self.result_items:
            return
        rid = None if key is None else self.newest_result(key)
        if rid is None:
            self._clear_result()
            return
        self.show_result(rid)
        self.result_newest = True

    def follow_project(self) -> None:
        """Another tab changed the project: a panel showing the selected item's newest
        result shows the newest again (a fit run there on the same item)."""
        key = self.state.selected_item
        if key is None or self.job.running or not (self.result_newest or not self.state.result):
            return
        rid = self.newest_result(key)
        if rid is not None and str(rid) != str(self.result_id):
            self.show_result(rid)
            self.result_newest = True

    def set_color_field(self, name: str | None) -> None:
        """Colour the shown item by the field ``name`` (kept in the project for next time)."""
        view, s = self.session.view, self.state
        if not name or view.shown is None or name == view.field and s.color_field == name:
            return
        try:
            view.set_field(name)
        except Exception as exc:
            self.session.error(f"colouring by {name!r} failed: {exc}")
            return
        s.color_field = view.field
        s.legend_title = view.scalar_bar_title
        self.session.shared.colour(view.field)  # the page shown keeps it when it is shown again
        self.session.remember("gui.color_field", view.field)

    def on_select(self, view_name: Any, selection: dict[str, Any]) -> int | None:
        """A lasso or rectangle drawn in the client view (its ``cv_select``): the crop
        panel's selection (:meth:`.cloudedit.CloudEditPanel.on_select`)."""
        return self.cloudedit.on_select(view_name, selection)

    def close(self) -> None:
        self.job.close()
        self.cloudedit.close()


def mount(server: Any, session: Any) -> InspectPage:
    page = InspectPage(server, session)
    server.controller.run_plugin_form = page.run_form  # for tests

    @server.state.change("color_field")
    def _field_changed(color_field: Any = None, **_: Any) -> None:
        page.set_color_field(color_field)

    @server.state.change("form_values", "input_values")
    def _form_changed(**_: Any) -> None:  # the reason next to Run follows the form as it is edited
        page.check_run()

    return page
