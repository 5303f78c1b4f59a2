"""Page layout: trame + Vuetify 3 around a :class:`~camcmm.gui.session.Session`.

Toolbar: project name and the import button. Drawer: the project's items, the
plugins with kind/version/status, and the selected plugin's form (built from its
manifest by :func:`camcmm.params.form_schema`) with Run and a progress bar. Main
area: the 3D view (server-side rendering, trame-vtk's :class:`VtkRemoteView` on the plotter's window)
with a colour-field selector, and the result panel. Errors appear in an alert and a
snackbar. Key widgets carry ``data-testid`` attributes for the browser test.
"""

from __future__ import annotations

import asyncio
import os
import socket
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import CamcmmError
from . import setup_offscreen

# Client-side check of a number field against its declared limits (Vuetify rule).
_NUMBER_RULE = (
    "[v => (v === '' || v === null || v === undefined) || !isNaN(Number(v)) || 'not a number',"
    " v => (v === '' || v === null || v === undefined || field.min == null || Number(v) >= field.min)"
    " || ('at least ' + field.min + ' ' + (field.unit || '')),"
    " v => (v === '' || v === null || v === undefined || field.max == null || Number(v) <= field.max)"
    " || ('at most ' + field.max + ' ' + (field.unit || ''))]"
)


#: pages that fill the content area (the Inspect view beside them is hidden)
FULL_PAGES = ("compare", "uncertainty", "devices", "calibration")
#: the server's page objects that hold threads and temporary folders (closed on stop)
PAGES_TO_CLOSE = ("inspect", "uncertainty", "devices", "calibration")


def _tid(name: str) -> list[str]:
    return [f'data-testid="{name}"']


def _accept() -> str:
    """The file input's ``accept`` list: every extension camcmm.io reads."""
    try:
        from ..io import FORMATS

        return ",".join(sorted(ext for ext, f in FORMATS.items() if f.get("readable", True)))
    except Exception:  # an older io without FORMATS: let the reader judge
        return ""


def open_project(project_dir: str | Path) -> Any:
    from ..project import Project

    return Project.open_or_create(Path(project_dir))


def build(server_name: str, project_dir: str | Path, project: Any = None, host: Any = None,
          display_limit: int | None = None, data_roots: Any = ()) -> tuple[Any, Any]:
    """Build the trame server and the session on a project folder (created if new).

    The browser reaches only the project folder and ``data_roots`` (``session.roots``,
    a :class:`~camcmm.gui.roots.Roots`). Returns ``(server, session)``; nothing
    listens until :func:`start`.
    """
    setup_offscreen()
    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import html
    from trame.widgets import vuetify3 as v
    from trame.widgets.vtk import VtkRemoteView

    from .roots import Roots
    from .session import _ITEM_TYPES, Session
    from .view import DISPLAY_LIMIT, SceneView

    server = get_server(server_name, client_type="vue3")
    state, ctrl = server.state, server.controller
    if project is None:
        project = open_project(project_dir)
    view = SceneView(display_limit or DISPLAY_LIMIT)
    session = Session(server, project, host=host, view=view)
    session.roots = Roots(getattr(project, "path", project_dir), data_roots)  # before the pages mount
    from . import wizard, wizard_layout  # [wizard] the "Acceptance test" page

    wizard_page = wizard.mount(server, session)  # [wizard]
    from . import inspect_layout, inspect_panel  # [inspection] the "Compare with CAD" page

    inspect_page = inspect_panel.mount(server, session, display_limit)  # [inspection]
    from . import uncertainty_layout, uncertainty_page  # [uncertainty] the "Uncertainty" page

    uncertainty = uncertainty_page.mount(server, session)  # [uncertainty]
    from . import devices_layout, devices_page  # [devices] the "Devices" page

    devices = devices_page.mount(server, session)  # [devices]
    from . import calibration_layout, calibration_page  # [calibration] the "Calibration" page

    calibration = calibration_page.mount(server, session)  # [calibration]
    state.trame__title = f"camcmm — {state.project_name}"

    # -- handlers (thin: all logic is in the session) ---------------------------------
    async def on_upload(upload=None, **_):
        if not upload:
            return
        files = session.import_upload(upload)
        for f in files:
            await session.import_file_async(f["content"], f["name"])
        state.upload = None
        session._flush()

    @state.change("upload")
    def _upload_changed(upload=None, **_):
        if upload:
            return on_upload(upload)  # a coroutine: trame schedules it
        return None

    @state.change("color_field")
    def _field_changed(color_field=None, **_):
        session.set_color_field(color_field)

    async def on_import_path(path):
        state.path_dialog = False
        if path and str(path).strip():
            try:  # only the project folder and the data roots: refused before anything is read
                allowed = session.roots.check(path)
            except CamcmmError as exc:
                session.error(str(exc))
                return
            await session.import_file_async(str(allowed), Path(str(path).strip().strip('"')).name)

    ctrl.import_server_path = on_import_path  # for tests

    def on_select_item(key):
        session.select_item(key)

    def on_select_plugin(pid):
        session.select_plugin(pid)

    async def on_run(pid, form_values, input_values):
        if not pid:
            session.error("choose a plugin first")
            return
        try:  # a parameter or input naming a file or folder: only inside the roots (the run also
            # takes inputs from the state, which the client writes too: check those as well)
            inputs = {**dict(state.input_values or {}), **dict(input_values or {})}
            form_values, input_values = session.roots.check_run(session.host.get(pid), form_values, inputs,
                                                                _ITEM_TYPES)
        except CamcmmError as exc:
            session.error(str(exc))
            return
        await session.run_plugin_async(pid, form_values or {}, input_values or {})

    ctrl.run_plugin_form = on_run  # for tests

    def on_show_result(rid):
        session.show_result(rid)

    def on_cancel():
        session.cancel_run()

    def on_server_ready(**_):
        try:
            session.bind_loop(asyncio.get_event_loop())
        except RuntimeError:
            pass

    ctrl.on_server_ready.add(on_server_ready)

    # -- layout ---------------------------------------------------------------------------
    with SinglePageWithDrawerLayout(server, width=400, theme=("theme", "light")) as layout:
        layout.title.set_text("camcmm")
        with layout.toolbar:
            layout.toolbar.density = "compact"
            v.VIcon("mdi-folder-outline", size="small", classes="ml-4 mr-1")
            html.Span("{{ project_name }}", classes="text-subtitle-1",
                      raw_attrs=_tid("project-name"), title=("project_path",))
            wizard_layout.page_switch(v)  # [wizard] Inspect | Acceptance test
            inspect_layout.page_switch(v, layout.toolbar)  # [inspection] ... | Compare with CAD
            uncertainty_layout.page_switch(v, layout.toolbar)  # [uncertainty] ... | Uncertainty
            calibration_layout.page_switch(v, layout.toolbar)  # [calibration] ... | Calibration
            devices_layout.page_switch(v, layout.toolbar)  # [devices] ... | Devices
            v.VSpacer()
            v.VFileInput(
                v_model=("upload", None),
                label="Import cloud / mesh / image",
                accept=_accept(),
                prepend_icon="mdi-file-import",
                density="compact",
                variant="outlined",
                hide_details=True,
                show_size=True,
                loading=("importing",),
                disabled=("importing",),
                style="max-width: 380px;",
                classes="mr-4",
                raw_attrs=_tid("import-file"),
            )

            with v.VDialog(v_model=("path_dialog", False), max_width=640):
                with v.VCard(title="Import a file on the server", raw_attrs=_tid("path-dialog")):
                    with v.VCardText():
                        html.Div("For files too large to upload through the browser: give their path on the "
                                 "machine that runs camcmm.", classes="text-caption mb-2")
                        v.VTextField(v_model=("server_path", ""), label="Path", density="compact",
                                     variant="outlined", autofocus=True, raw_attrs=_tid("server-path"))
                    with v.VCardActions():
                        v.VSpacer()
                        v.VBtn("Cancel", variant="text", click="path_dialog = false")
                        v.VBtn("Import", color="primary", click=(on_import_path, "[server_path]"),
                               raw_attrs=_tid("server-path-import"))
            with v.VBtn(icon=True, click="path_dialog = true", title="Import a file on the server",
                        raw_attrs=_tid("open-path-dialog")):
                v.VIcon("mdi-folder-open-outline")

        with layout.drawer as drawer:
            drawer.raw_attrs = _tid("drawer")
            v.VAlert(
                v_if="error_message",
                text=("error_message",),
                type="error",
                density="compact",
                closable=True,
                classes="ma-2",
                click_close="error_message = ''",
                raw_attrs=_tid("error-alert"),
            )
            # items
            with v.VList(density="compact", nav=True, raw_attrs=_tid("items")):
                v.VListSubheader("Items in the project ({{ items.length }})")
                v.VListItem(
                    v_for="item in items",
                    key="item.id",
                    title=("item.name",),
                    subtitle=("item.subtitle",),
                    active=("item.id === selected_item",),
                    color="primary",
                    prepend_icon=("item.kind === 'mesh' ? 'mdi-vector-triangle' : "
                                  "(item.kind === 'image' ? 'mdi-image' : 'mdi-dots-hexagon')",),
                    click=(on_select_item, "[item.id]"),
                    classes="item-row",
                    raw_attrs=_tid("item"),
                )
                v.VListItem(v_if="!items.length", subtitle="No items yet: import a file above.")
            v.VDivider()
            # plugins
            with v.VList(density="compact", nav=True, raw_attrs=_tid("plugins")):
                v.VListSubheader("Plugins ({{ plugins.length }})")
                with v.VListItem(
                    v_for="p in plugins",
                    key="p.id",
                    active=("p.id === selected_plugin",),
                    color="primary",
                    disabled=("!p.runnable && p.ok",),
                    click=(on_select_plugin, "[p.id]"),
                    classes="plugin-row",
                    raw_attrs=_tid("plugin") + [':data-plugin-id="p.id"'],
                ):
                    v.VListItemTitle("{{ p.name }}")
                    v.VListItemSubtitle("{{ p.id }} · v{{ p.version }}")
                    with html.Div(classes="d-flex ga-1 mt-1"):
                        v.VChip("{{ p.kind }}", size="x-small", variant="tonal", color="secondary")
                        v.VChip("{{ p.ok ? 'ok' : 'failed' }}", size="x-small", variant="flat",
                                color=("p.ok ? 'success' : 'error'",))
                    html.Div("{{ p.status }}", v_if="!p.ok", classes="text-caption text-error",
                             raw_attrs=_tid("plugin-error"))
                v.VListItem(v_if="!plugins.length", subtitle="No plugins installed.")
            v.VDivider()
            # the form
            with html.Div(v_if="selected_plugin", classes="pa-3", raw_attrs=_tid("plugin-form")):
                html.Div("{{ plugin_title }}", classes="text-subtitle-2")
                html.Div("{{ plugin_summary }}", classes="text-caption mb-2")
                with html.Template(v_for="inp in form_inputs", key="inp.name"):
                    v.VSelect(
                        v_if="inp.supported",
                        v_model="input_values[inp.name]",
                        items=("inp.options",),
                        label=("inp.label",),
                        hint=("inp.help",),
                        density="compact",
                        variant="outlined",
                        classes="mb-1",
                        raw_attrs=[':data-testid="\'input-\' + inp.name"'],
                    )
                    v.VTextField(
                        v_else=True,
                        v_model="input_values[inp.name]",
                        label=("inp.label + ' — path on the server'",),
                        density="compact",
                        variant="outlined",
                        raw_attrs=[':data-testid="\'input-\' + inp.name"'],
                    )
                with html.Template(v_for="field in form_fields", key="field.name"):
                    v.VTextField(
                        v_if="field.widget === 'number'",
                        v_model="form_values[field.name]",
                        type="number",
                        label=("field.label",),
                        suffix=("field.unit",),
                        hint=("field.help",),
                        min=("field.min",),
                        max=("field.max",),
                        step="any",
                        rules=(_NUMBER_RULE,),
                        density="compact",
                        variant="outlined",
                        classes="mb-1",
                        raw_attrs=[':data-testid="\'param-\' + field.name"'],
                    )
                    v.VSwitch(
                        v_else_if="field.widget === 'switch'",
                        v_model="form_values[field.name]",
                        label=("field.label",),
                        hint=("field.help",),
                        color="primary",
                        density="compact",
                        hide_details="auto",
                        raw_attrs=[':data-testid="\'param-\' + field.name"'],
                    )
                    v.VSelect(
                        v_else_if="field.widget === 'select'",
                        v_model="form_values[field.name]",
                        items=("field.choices",),
                        label=("field.label",),
                        hint=("field.help",),
                        density="compact",
                        variant="outlined",
                        classes="mb-1",
                        raw_attrs=[':data-testid="\'param-\' + field.name"'],
                    )
                    v.VTextField(
                        v_else=True,
                        v_model="form_values[field.name]",
                        label=("field.label",),
                        suffix=("field.unit",),
                        hint=("field.help",),
                        density="compact",
                        variant="outlined",
                        classes="mb-1",
                        raw_attrs=[':data-testid="\'param-\' + field.name"'],
                    )
                with html.Div(classes="d-flex ga-2 mt-1"):
                    v.VBtn("Run", color="primary", prepend_icon="mdi-play",
                           click=(on_run, "[selected_plugin, form_values, input_values]"),
                           disabled=("running",), loading=("running",), raw_attrs=_tid("run-button"))
                    v.VBtn("Cancel", v_if="running", variant="text", click=on_cancel,
                           raw_attrs=_tid("cancel-button"))
                with v.VProgressLinear(
                    v_show="running || progress > 0",
                    model_value=("progress",),
                    indeterminate=("running && progress <= 0",),
                    height=18,
                    color=("running ? 'primary' : 'success'",),
                    classes="mt-2",
                    rounded=True,
                    raw_attrs=_tid("progress"),
                ):
                    html.Span("{{ progress_message }} {{ Math.round(progress) }} %", classes="text-caption")
            html.Div("Choose an algorithm or standard plugin above to see its form.", v_else=True,
                     classes="pa-3 text-caption")
            v.VDivider()
            with v.VList(density="compact", nav=True, raw_attrs=_tid("results")):
                v.VListSubheader("Results in the project ({{ results.length }})")
                v.VListItem(
                    v_for="r in results",
                    key="r.id",
                    title=("'#' + r.id + ' ' + r.plugin",),
                    subtitle=("r.time",),
                    click=(on_show_result, "[r.id]"),
                    classes="result-row",
                    raw_attrs=_tid("result-row"),
                )

        with layout.content:
            layout.content.classes = "d-flex"  # [wizard] the wizard's panel beside the 3D view
            wizard_layout.build_panel(wizard_page, _accept())  # [wizard]
            inspect_layout.build_panel(inspect_page)  # [inspection] its own view, charts and panel
            uncertainty_layout.build_panel(uncertainty)  # [uncertainty]
            devices_layout.build_panel(devices)  # [devices]
            calibration_layout.build_panel(calibration)  # [calibration]
            # pages with a layout of their own hide the Inspect page's view
            with html.Div(classes=(f"{list(FULL_PAGES)}.includes(page) ? 'd-none' : 'd-flex flex-column'",),
                          style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px);"):
                with html.Div(classes="d-flex align-center ga-3 px-3 py-1", style="min-height: 52px;"):
                    v.VSelect(
                        v_model=("color_field", None),
                        items=("color_fields", []),
                        item_title="title",
                        item_value="value",
                        label="Colour by",
                        density="compact",
                        variant="outlined",
                        hide_details=True,
                        disabled=("!color_fields.length",),
                        style="max-width: 300px;",
                        raw_attrs=_tid("color-field"),
                    )
                    v.VChip("legend: {{ legend_title }}", v_if="legend_title", size="small",
                            prepend_icon="mdi-palette", raw_attrs=_tid("legend-title"))
                    html.Span("{{ display_note }}", classes="text-caption", raw_attrs=_tid("display-note"))
                with html.Div(style="flex: 1 1 auto; min-height: 300px; position: relative;",
                              raw_attrs=_tid("view")):
                    # trame-vtk's view on the render window, not trame-pyvista's: that one pushes an
                    # image on every pyvista render() (about five per scene change); this one pushes
                    # once, when view_changed below calls ctrl.view_update for a complete scene.
                    rview = VtkRemoteView(view.plotter.render_window, interactive_ratio=0.5,
                                          interactive_quality=60, still_ratio=1)
                    ctrl.view_update = rview.update
                    ctrl.view_reset_camera = rview.reset_camera
                with v.VCard(v_if="result || result_warnings.length", classes="ma-2", variant="outlined",
                             style="max-height: 34vh; overflow: auto;", raw_attrs=_tid("result-panel")):
                    v.VCardTitle("{{ result_title }}", classes="text-subtitle-1")
                    with v.VCardText():
                        v.VAlert(v_for="(w, i) in result_warnings", key="i", text=("w",), type="warning",
                                 density="compact", classes="mb-1", raw_attrs=_tid("result-warning"))
                        with v.VTable(density="compact", raw_attrs=_tid("result-table")):
                            with html.Tbody():
                                with html.Tr(v_for="r in result_rows", key="r.name"):
                                    html.Td("{{ r.name }}", classes="font-weight-medium")
                                    html.Td("{{ r.value }}", classes="text-right",
                                            raw_attrs=[':data-testid="\'result-\' + r.name"'])
                                    html.Td("{{ r.unit }}")
                        with v.VExpansionPanels(classes="mt-2"):
                            with v.VExpansionPanel(title="Result JSON (as stored)"):
                                with v.VExpansionPanelText():
                                    html.Pre("{{ JSON.stringify(result, null, 2) }}",
                                             style="font-size: 11px; white-space: pre-wrap;")

        v.VSnackbar(
            v_model=("error_visible", False),
            text=("error_message",),
            color="error",
            timeout=8000,
            location="bottom",
            raw_attrs=_tid("error-snackbar"),
        )
        v.VSnackbar(
            v_model=("info_visible", False),
            text=("info_message",),
            color="success",
            timeout=3000,
            location="bottom right",
            raw_attrs=_tid("info-snackbar"),
        )

    def view_changed(reset_camera: bool) -> None:
        if reset_camera:
            view.plotter.reset_camera()
        ctrl.view_update()

    view.on_update = view_changed
    server.session = session  # for scripts and tests
    server.wizard = wizard_page  # [wizard]
    server.inspect = inspect_page  # [inspection]
    server.uncertainty = uncertainty  # [uncertainty]
    server.devices = devices  # [devices]
    server.calibration = calibration  # [calibration]
    return server, session


@contextmanager
def _bare_argv(extra: list[str] | None = None):
    """trame parses ``sys.argv``; keep the CLI's own arguments away from it (and give
    it ``extra`` ones of its own)."""
    saved = sys.argv
    sys.argv = saved[:1] + list(extra or [])
    try:
        yield
    finally:
        sys.argv = saved


def start(server: Any, host: str = "127.0.0.1", port: int = 0, open_browser: bool = False,
          token: str | None = "auto", allowed_origins: Any = (), certfile: str | None = None,
          keyfile: str | None = None) -> None:
    """Serve until stopped; print ``camcmm GUI: http://HOST:PORT/?token=TOKEN`` once
    listening. Every request must carry ``token`` (see :mod:`camcmm.gui.security`):
    ``"auto"`` makes a random one, ``None`` (no token) is refused beyond loopback.
    ``certfile``/``keyfile``: serve HTTPS."""
    from .security import Guard, binding_warning, is_loopback, new_token

    if token == "auto":
        token = new_token()

    if token is None and not is_loopback(host):
        raise CamcmmError(f"--host {host}: refused without a token (see docs/security.md)")
    if bool(certfile) != bool(keyfile):
        raise CamcmmError("--certfile and --keyfile go together")
    tls = bool(certfile)
    warning = binding_warning(host, tls)
    if warning:
        print(warning, file=sys.stderr, flush=True)
    guard = Guard(token, allowed_origins)
    guard.install(server)
    server.guard = guard
    scheme = "https" if tls else "http"
    # a wildcard address is no address to open: show the machine's name, as Jupyter does
    shown = socket.gethostname() if host in ("0.0.0.0", "::", "") else (f"[{host}]" if ":" in host else host)

    def announce(**_):
        url = guard.url(f"{scheme}://{shown}:{server.port}/")
        print(f"camcmm GUI: {url}", flush=True)
        if open_browser:
            import webbrowser

            webbrowser.open(url)

    server.controller.on_server_ready.add(announce)
    extra = guard.wslink_args() + (["--ssl", f"{certfile},{keyfile}"] if tls else [])
    try:
        with _bare_argv(extra):
            server.start(host=host, port=int(port), open_browser=False, timeout=0, show_connection_info=False)
    except OSError as exc:  # the port is taken, the address is not this machine's ...
        raise CamcmmError(f"cannot listen on {host} port {port}: {exc.strerror or exc}") from None
    finally:
        close(server)


def close(server: Any) -> None:
    """Stop the pages' workers and remove their temporary folders, then the session
    (after a server stops; tests call it for servers they built without starting)."""
    for page in ("wizard", *PAGES_TO_CLOSE):
        if getattr(server, page, None) is not None:
            getattr(server, page).close()
    session = getattr(server, "session", None)
    if session is not None:
        session.close()


def port_number(text: str) -> int:
    """argparse type of ``--port``: 0 (a free port) to 65535."""
    import argparse

    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number (0 to 65535)") from None
    if not 0 <= n <= 65535:
        raise argparse.ArgumentTypeError(f"{n}: a port is 0 (a free one) to 65535")
    return n


def add_serve_arguments(ap: Any) -> None:
    """The options ``camcmm serve`` and ``python -m camcmm.gui`` share (besides the
    project and the port): data roots, token, origins, TLS."""
    ap.add_argument("--host", default="127.0.0.1",
                    help="address to bind (default 127.0.0.1: this machine only; see docs/security.md)")
    ap.add_argument("--data-root", action="append", default=[], metavar="DIR",
                    help="a folder the browser may read and write besides the project folder (repeatable)")
    ap.add_argument("--token-file", metavar="FILE",
                    help="a fixed token (password) read from FILE instead of a random one per launch "
                         "(also: $CAMCMM_TOKEN)")
    ap.add_argument("--no-token", action="store_true",
                    help="no token (only with a loopback --host): any local program may drive the app")
    ap.add_argument("--allow-origin", action="append", default=[], metavar="URL",
                    help="another origin the browser may use, e.g. a reverse proxy's https://lab.example (repeatable)")
    ap.add_argument("--certfile", help="TLS certificate (PEM): serve HTTPS")
    ap.add_argument("--keyfile", help="TLS private key (PEM) of --certfile")


def serve_from_args(project: str | Path, args: Any, port: int, open_browser: bool = False) -> None:
    """:func:`camcmm.gui.serve` with the options of :func:`add_serve_arguments`."""
    from . import serve

    serve(project, host=args.host, port=port, open_browser=open_browser, data_roots=args.data_root,
          no_token=args.no_token, token_file=args.token_file, allowed_origins=args.allow_origin,
          certfile=args.certfile, keyfile=args.keyfile)


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m camcmm.gui", description="Serve the camcmm GUI on a project folder.")
    ap.add_argument("project", help="project folder (created if missing)")
    ap.add_argument("--port", type=port_number, default=0, help="0 picks a free port")
    ap.add_argument("--open", action="store_true", help="open the system browser")
    add_serve_arguments(ap)
    args = ap.parse_args(argv)
    os.environ.setdefault("TRAME_DISABLE_V3_WARNING", "1")
    try:
        serve_from_args(args.project, args, port=args.port, open_browser=args.open)
    except CamcmmError as exc:
        print(f"camcmm: error: {exc}", file=sys.stderr, flush=True)
        return 2
    return 0
