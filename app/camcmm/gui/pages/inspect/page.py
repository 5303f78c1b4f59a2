"""The Inspect page's state and handlers: the plugin list, the selected plugin's form,
a run with progress and cancel, the result panel and the 3D view's colour field.

The session holds what every page shares (the project's items, messages, the 3D
view); this page reads and changes them through its public methods. A run goes
through one :class:`~camcmm.gui.jobs.Job` to :func:`camcmm.worker.run` (the plugin
computes in the worker process; a native crash does not end the server). Tests call
``asyncio.run(page.run_plugin(...))``.
"""

from __future__ import annotations

from typing import Any

from .... import worker
from ....errors import CamcmmError, one_line
from ....host import RunResult
from ...jobs import Job
from .form import ITEM_TYPES, fields_of, inputs_of, run_arguments
from .results import new_items, result_rows, summarize_json


class InspectPage:
    """The state variables it owns: ``plugins``, ``selected_plugin``, ``plugin_title``,
    ``plugin_summary``, ``form_fields``, ``form_values``, ``form_inputs``,
    ``input_values``, ``running``, ``progress`` (0..100 %), ``progress_message``,
    ``result``, ``result_title``, ``result_rows``, ``result_warnings``."""

    def __init__(self, server: Any, session: Any):
        self.server = server
        self.session = session
        self.state = session.state
        # looked up at each call, so that a test can watch the progress by replacing it
        self.job = Job("a plugin", state=self.state, on_progress=lambda f, m: self.show_progress(f, m))
        self.last_result: RunResult | None = None
        self.last_result_id: Any = None
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
            }
        )
        self._clear_result()
        session.watch_items(self.refresh_inputs)
        self.refresh_plugins()

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
            spec = self.session.host.get(plugin_id)
        except CamcmmError as exc:
            self.session.error(str(exc))
            return
        if spec.kind == "device":
            self.session.error(f"plugin {plugin_id!r} is a device; devices are connected, not run from a form")
            return
        if spec.status != "ok":
            self.session.error(f"plugin {plugin_id!r} cannot be used: {spec.status}")
            return
        s = self.state
        s.form_fields, s.form_values = fields_of(spec)
        s.selected_plugin = spec.id
        s.plugin_title = f"{spec.name} ({spec.id} {spec.version})"
        s.plugin_summary = spec.summary
        self.refresh_inputs(reset=True)

    def refresh_inputs(self, reset: bool = False) -> None:
        """The form's input selects after the items changed (``reset``: a new plugin)."""
        s = self.state
        try:
            spec = self.session.host.get(s.selected_plugin) if s.selected_plugin else None
        except CamcmmError:
            spec = None
        if spec is None:
            s.form_inputs = []
            return
        current = {} if reset else dict(s.input_values or {})
        s.form_inputs, s.input_values = inputs_of(spec, s.items or [], current, s.selected_item)

    def select_item(self, key: Any) -> None:
        self.session.select_item(key)

    # -- a run -------------------------------------------------------------------------
    async def run_form(self, pid: Any, form_values: Any, input_values: Any) -> RunResult | None:
        """The Run button (also ``ctrl.run_plugin_form``): a value naming a file or folder
        must lie inside the roots, then :meth:`run_plugin`."""
        session = self.session
        if not pid:
            session.error("choose a plugin first")
            return None
        try:  # the run also takes inputs from the state, which the client writes too: check those
            inputs = {**dict(self.state.input_values or {}), **dict(input_values or {})}
            form_values, input_values = session.roots.check_run(session.host.get(pid), form_values, inputs, ITEM_TYPES)
        except CamcmmError as exc:
            session.error(str(exc))
            return None
        return await self.run_plugin(pid, form_values or {}, input_values or {})

    async def run_plugin(
        self, plugin_id: str, params: dict[str, Any] | None = None, inputs: dict[str, Any] | None = None
    ) -> RunResult | None:
        """Run a plugin on the form's inputs (``inputs`` overrides them: port -> item key
        or value) while the page stays live. Progress and result go to the state, the
        result and its new clouds or meshes into the project. Returns the RunResult, or
        None after showing the one-line reason (a bad value, a failure, a cancel)."""
        session = self.session
        try:
            spec = session.host.get(plugin_id)
            values, objs, mids = run_arguments(
                spec,
                dict(params or {}),
                {**dict(self.state.input_values or {}), **dict(inputs or {})},
                session.load,
                session.measurement,
            )
            cancel = self.job.begin()
        except Exception as exc:  # a bad value or input, or Busy: a run is going
            session.error(one_line(exc))
            return None
        self._started(plugin_id)
        try:
            result = await self.job.call(
                worker.run, session.host, plugin_id, objs, values, progress=self.job.progress, cancel=cancel
            )
        except Exception as exc:
            self.job.end()
            self._failed(plugin_id, exc)
            return None
        self.job.end()
        return self._done(spec, result, mids, objs)

    def cancel(self) -> None:
        if self.job.cancel():
            self.state.progress_message = "cancelling …"

    def show_progress(self, fraction: float, message: str) -> None:
        """The run's progress on the page: ``fraction`` 0..1 as 0..100 %."""
        self.state.progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.progress_message = message

    def _clear_result(self) -> None:
        self.state.update({"result": None, "result_title": "", "result_rows": [], "result_warnings": []})

    def _started(self, plugin_id: str) -> None:
        s = self.state
        s.running, s.progress, s.progress_message = True, 0.0, f"running {plugin_id} …"
        self._clear_result()
        self.session.clear_error()
        self.session.flush()

    def _failed(self, plugin_id: str, exc: BaseException) -> None:
        self.state.running = False
        self.state.progress_message = "failed"
        _, msg = Job.outcome(exc)
        self.session.error(msg if plugin_id in msg else f"plugin {plugin_id!r}: {msg}")
        self.session.flush()

    def _done(self, spec: Any, result: RunResult, mids: list, objs: dict[str, Any]) -> RunResult:
        session, s = self.session, self.state
        self.last_result = result
        warnings = list(result.warnings)
        try:
            self.last_result_id = session.project.add_result(result, measurement_ids=mids, files={})
        except Exception as exc:
            session.error(f"result of {spec.id} could not be stored in the project: {one_line(exc)}")
        keys = self._store_outputs(spec, result, objs, warnings)
        s.result = summarize_json(result.to_json())
        s.result_title = f"{spec.name} — {spec.id} {result.plugin_version}"
        s.result_rows = result_rows(result.outputs, {p.name: p.unit for p in spec.outputs})
        s.result_warnings = warnings
        s.running, s.progress, s.progress_message = False, 100.0, "done"
        session.refresh_results()
        if keys:
            session.select_item(keys[-1])
        session.info(f"{spec.id} finished" + (f"; added {len(keys)} item(s)" if keys else ""))
        session.flush()
        return result

    def _store_outputs(self, spec: Any, result: RunResult, objs: dict[str, Any], warnings: list[str]) -> list[str]:
        """The new items of a run (:func:`~.results.new_items`) into the project; their keys."""
        session, keys = self.session, []
        for label, name, obj in new_items(spec, result, objs):
            try:
                h = session.project.add_object(obj, name)
                keys.append(str(session.add_measurement(name, h, obj, source=f"{spec.id} {result.plugin_version}")))
            except Exception as exc:
                warnings.append(f"output {label!r} could not be stored: {one_line(exc)}")
        if keys:
            session.refresh_items()
        return keys

    # -- the result panel and the view -----------------------------------------------------
    def show_result(self, rid: Any) -> None:
        """Show a stored result (from the project) in the result panel."""
        try:
            d = self.session.project.result(int(rid))
        except Exception as exc:
            self.session.error(f"result {rid}: {one_line(exc)}")
            return
        plugin = str(d.get("plugin", ""))
        try:
            units = {p.name: p.unit for p in self.session.host.get(plugin).outputs}
        except CamcmmError:
            units = {}
        s = self.state
        s.result = summarize_json(d)
        s.result_title = f"result #{rid}: {plugin} {d.get('version', '')} ({d.get('finished', '')})"
        s.result_rows = result_rows(d.get("outputs") or {}, units)
        s.result_warnings = list(d.get("warnings") or [])

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
        self.session.remember("gui.color_field", view.field)

    def close(self) -> None:
        self.job.close()


def mount(server: Any, session: Any) -> InspectPage:
    page = InspectPage(server, session)
    server.controller.run_plugin_form = page.run_form  # for tests

    @server.state.change("color_field")
    def _field_changed(color_field: Any = None, **_: Any) -> None:
        page.set_color_field(color_field)

    return page
