"""The app shell: trame + Vuetify 3 around a :class:`~camcmm.gui.session.Session` and the
registered pages (:mod:`camcmm.gui.pages`). :func:`build` mounts the pages and lays them
out with :mod:`camcmm.gui.shell` (toolbar with one button per page (``page-<key>``, in
the pages' order), drawer, footer); the import controls (a file through the browser, a
path on the server, the unit question) live here. Each page's widgets show while the
state ``page`` is its key. Key widgets carry ``data-testid`` attributes for the browser
tests. :func:`start` serves it behind the token guard (:mod:`camcmm.gui.security`).
"""

from __future__ import annotations

import asyncio
import os
import socket
import sys
from collections.abc import Iterable
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import CamcmmError
from . import setup_offscreen
from .widgets import accepted_extensions, dyn_tid, tid


def open_project(project_dir: str | Path) -> Any:
    from ..project import Project

    return Project.open_or_create(Path(project_dir))


def build(
    server_name: str,
    project_dir: str | Path,
    project: Any = None,
    host: Any = None,
    display_limit: int | None = None,
    data_roots: Any = (),
    schedulers: Iterable[str] = (),
) -> tuple[Any, Any]:
    """Build the trame server and the session on a project folder (created if new).

    Every registered page (:func:`camcmm.gui.pages.registered`) is mounted, gets a
    toolbar button and builds its widgets; its page object is ``server.pages[key]``.
    The browser reaches only the project folder and ``data_roots`` (``session.roots``,
    a :class:`~camcmm.gui.roots.Roots`), and a plugin connects only to ``schedulers``
    (``--scheduler``); every job a page runs is confined to both in its own thread
    (:func:`camcmm.gui.jobs.confine_jobs`). Returns ``(server, session)``; nothing
    listens until :func:`start`.
    """
    setup_offscreen()
    from trame.app import get_server

    from .jobs import confine_jobs
    from .pages import registered
    from .roots import Roots
    from .session import Session
    from .shell import layout
    from .view import DISPLAY_LIMIT, SceneView

    server = get_server(server_name, client_type="vue3")
    if project is None:
        project = open_project(project_dir)
    session = Session(server, project, host=host, view=SceneView(display_limit or DISPLAY_LIMIT))
    session.roots = Roots(getattr(project, "path", project_dir), data_roots, schedulers)  # before the pages mount
    confine_jobs(server.state, session.roots)  # each run the pages start: in their job's thread, never here
    server.session = session  # for scripts and tests
    pages = registered()
    session.page_of_module = {p.package(): p.key for p in pages}  # a message belongs to its page
    server.pages = {}
    for p in pages:
        server.pages[p.key] = p.mount(server, session)
    for p in pages:  # a page beside the 3D view shows its own scene there, or none (gui/scenes.py)
        if not p.full and p.key not in session.shared.hints:
            session.shared.share(p.key, f"Nothing from the {p.title} page is shown here yet.")
    server.state.trame__title = f"camcmm — {server.state.project_name}"
    server.state.full_pages = [p.key for p in pages if p.full]
    server.state.drawer_pages = [p.key for p in pages if p.drawer is not None]
    layout(server, session, pages, import_controls=_import_controls)

    def on_server_ready(**_):
        try:
            session.bind_loop(asyncio.get_event_loop())
        except RuntimeError:
            pass

    server.controller.on_server_ready.add(on_server_ready)
    return server, session


def _import_controls(session: Any) -> None:
    """The toolbar's import: a file through the browser, or a path on the server; and the
    question asked when a file's unit is in doubt (docs/units.md)."""
    _upload_field(session)
    _path_dialog(session)
    _unit_dialog(session)


def _upload_field(session: Any) -> None:
    """A file from the browser: imported as soon as it is chosen, in the unit chosen in
    the ruler menu, else the unit the file states, else mm — asked first when its size
    is implausible as mm."""
    from trame.widgets import vuetify3 as v

    state = session.state
    if not state.has("import_unit"):
        state.import_unit = ""

    async def on_upload(upload=None, **_):
        if not upload:
            return
        unit = state.import_unit or None
        if unit is not None and unit not in {u["value"] for u in IMPORT_UNITS}:  # browser input
            session.error(f"unit {str(unit)[:20]!r} is not one of m, cm, mm, um, in")
            state.upload = None
            return
        files = session.import_upload(upload)
        for f in files:
            await session.import_file_async(f["content"], f["name"], unit)
        state.upload = None
        session.flush()

    @state.change("upload")
    def _upload_changed(upload=None, **_):
        if upload:
            return on_upload(upload)  # a coroutine: trame schedules it
        return None

    v.VFileInput(
        v_model=("upload", None),
        label="Import cloud / mesh / image",
        accept=accepted_extensions(),
        prepend_icon="mdi-file-import",
        density="compact",
        variant="outlined",
        hide_details=True,
        show_size=True,
        loading=("importing",),
        disabled=("importing",),
        style="max-width: 340px;",
        classes="mr-1",
        title="Import a point cloud, mesh or image into the project. Lengths: the unit chosen in the ruler "
        "menu, else the file's own (E57, PLY 'comment unit m' ...), else mm; a size implausible as mm is asked "
        "about first.",
        raw_attrs=tid("import-file"),
    )
    _unit_menu()


def _unit_menu() -> None:
    """The upload's unit field: a fixed-size ruler button (nothing moves when a unit is
    chosen) opening the list of units; the choice shows as the active entry and in the tooltip."""
    from trame.widgets import vuetify3 as v

    with v.VMenu(location="bottom end"):
        with v.Template(v_slot_activator="{ props }"):
            v.VBtn(
                icon="mdi-ruler",
                v_bind="props",
                size="small",
                variant="text",
                classes="mr-2",
                color=("import_unit ? 'primary' : undefined",),
                aria_label="Unit of the coordinates of the files imported",
                title=(
                    "import_unit ? 'Files imported are read in ' + import_unit + ' (click to change)' "
                    ": 'Unit of the files imported: the one in the file, else mm, asked if implausible (click to set)'",
                ),
                raw_attrs=tid("import-unit"),
            )
        with v.VList(density="compact", raw_attrs=tid("import-unit-menu")):
            v.VListItem(
                v_for="u in import_units",
                title=("u.title",),
                active=("u.value === import_unit",),
                click="import_unit = u.value",
                raw_attrs=dyn_tid("'import-unit-' + (u.value || 'auto')"),
            )


#: The unit field of the server-path import: "" = the file's own, else mm (asked when implausible).
IMPORT_UNITS = [
    {"title": "the file's own, else mm", "value": ""},
    {"title": "m", "value": "m"},
    {"title": "cm", "value": "cm"},
    {"title": "mm", "value": "mm"},
    {"title": "µm", "value": "um"},
    {"title": "inch", "value": "in"},
]


def _path_dialog(session: Any) -> None:
    """A file on the server (too large to upload): only inside the project folder and the data roots."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_import_path(path, unit=None):
        session.state.path_dialog = False
        if path and str(path).strip():
            try:  # refused before anything is read
                allowed = session.roots.check(path)
            except CamcmmError as exc:
                session.error(str(exc))
                return
            offered = {u["value"] for u in IMPORT_UNITS}
            if unit not in offered and unit is not None:  # browser input: only what is offered
                session.error(f"unit {str(unit)[:20]!r} is not one of m, cm, mm, um, in")
                return
            name = Path(str(path).strip().strip('"')).name
            await session.import_file_async(str(allowed), name, unit or None)

    session.ctrl.import_server_path = on_import_path  # for tests
    with v.VDialog(v_model=("path_dialog", False), max_width=640):
        with v.VCard(title="Import a file on the server", raw_attrs=tid("path-dialog")):
            with v.VCardText():
                html.Div(
                    "For files too large to upload through the browser: give their path on the "
                    "machine that runs camcmm.",
                    classes="text-caption mb-2",
                )
                # Vuetify puts a field's title on its <input> only: the wrapper's title
                # covers the label, the chosen value and the hint too.
                tip = "The file's path on the machine that runs camcmm (inside the project or a data root)"
                with html.Div(title=tip):
                    v.VTextField(
                        v_model=("server_path", ""),
                        label="Path",
                        density="compact",
                        variant="outlined",
                        autofocus=True,
                        title=tip,
                        raw_attrs=tid("server-path"),
                    )
                tip = "The length unit of the coordinates in the file; camcmm converts to mm"
                with html.Div(title=tip):
                    v.VSelect(
                        v_model=("server_path_unit", ""),
                        items=("import_units", IMPORT_UNITS),
                        label="Unit of the file's coordinates",
                        density="compact",
                        variant="outlined",
                        hint="Without one: the file's own unit (E57, a unit comment), else mm — asked when implausible",
                        persistent_hint=True,
                        title=tip,
                        raw_attrs=tid("server-path-unit"),
                    )
            with v.VCardActions():
                v.VSpacer()
                v.VBtn("Cancel", variant="text", click="path_dialog = false", title="Close without importing")
                v.VBtn(
                    "Import",
                    color="primary",
                    click=(on_import_path, "[server_path, server_path_unit]"),
                    title="Read the file and add it to the project",
                    raw_attrs=tid("server-path-import"),
                )
    with v.VBtn(
        icon=True, click="path_dialog = true", title="Import a file on the server", raw_attrs=tid("open-path-dialog")
    ):
        v.VIcon("mdi-folder-open-outline")


def _unit_dialog(session: Any) -> None:
    """The question of camcmm.units when a file's unit is in doubt: the reason, one
    choice per candidate unit with the size it gives (plausible ones marked), the
    suggestion preselected; nothing is stored until it is answered (gui/unit_ask.py)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    if not session.state.has("unit_ask"):
        session.state.unit_ask = None

    def on_answer(unit=None):
        session.answer_unit(unit)
        session.flush()

    def on_cancel():
        session.cancel_unit()
        session.flush()

    with v.VDialog(v_model=("unit_ask_visible", False), persistent=True, max_width=680):
        with v.VCard(v_if="unit_ask", raw_attrs=tid("unit-dialog")):
            v.VCardTitle("In what unit is {{ unit_ask.file }}?", classes="text-subtitle-1")
            with v.VCardText():
                html.Div("{{ unit_ask.reason }}", classes="text-body-2 mb-2", raw_attrs=tid("unit-reason"))
                with v.VRadioGroup(v_model=("unit_choice", "mm"), density="compact", hide_details=True):
                    html.Div("Read the file's numbers as:", classes="text-caption")
                    tip = ("`Read the coordinates as ${c.value} and convert them to mm`",)
                    with html.Div(v_for="c in unit_ask.choices", title=tip):  # the label too, not only the circle
                        v.VRadio(
                            value=("c.value",),
                            label=("c.title + (c.plausible ? '  — a plausible size' : '')",),
                            title=tip,
                            raw_attrs=dyn_tid("'unit-choice-' + c.value"),
                        )
                html.Div(
                    "{{ unit_ask.waiting > 1 ? (unit_ask.waiting - 1) + ' more file(s) wait for their unit' : '' }}",
                    classes="text-caption mt-1",
                    style="min-height: 1.25em;",
                )
            with v.VCardActions():
                v.VSpacer()
                v.VBtn(
                    "Don't import",
                    variant="text",
                    click=on_cancel,
                    title="Drop this file; nothing is stored",
                    raw_attrs=tid("unit-cancel"),
                )
                v.VBtn(
                    "Import in {{ unit_choice === 'um' ? 'µm' : unit_choice }}",
                    color="primary",
                    click=(on_answer, "[unit_choice]"),
                    title="Convert the coordinates from this unit to mm and store the file with it",
                    raw_attrs=tid("unit-accept"),
                )


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


def start(
    server: Any,
    host: str = "127.0.0.1",
    port: int = 0,
    open_browser: bool = False,
    token: str | None = "auto",
    allowed_origins: Any = (),
    certfile: str | None = None,
    keyfile: str | None = None,
    ws_secret: Any = "token",
    announce: Any = None,
    max_upload: int | None = None,
) -> None:
    """Serve until stopped; print ``camcmm GUI: http://HOST:PORT/?token=TOKEN`` once
    listening. Every request must carry ``token`` (see :mod:`camcmm.gui.security`):
    ``"auto"`` makes a random one, ``None`` (no token) is refused beyond loopback.
    ``certfile``/``keyfile``: serve HTTPS. A session child (:mod:`camcmm.gui.launcher`)
    gives its websocket's own ``ws_secret`` and ``announce(port)`` instead of the URL.
    ``max_upload``: bytes a browser may upload at once (default ``$CAMCMM_MAX_UPLOAD``,
    else 2 GB; :mod:`camcmm.gui.uploads`)."""
    from .security import Guard, binding_warning, escape_log_records, is_loopback, new_token
    from .uploads import install, limit_from_env

    escape_log_records()

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
    guard = Guard(token, allowed_origins) if ws_secret == "token" else Guard(token, allowed_origins, ws_secret)
    guard.install(server)
    server.guard = guard

    def upload_refused(text: str) -> None:
        session = getattr(server, "session", None)
        if session is not None:
            session.error(text)
            session.flush()

    install(limit_from_env() if max_upload is None else max_upload, upload_refused)
    scheme = "https" if tls else "http"
    # a wildcard address is no address to open: show the machine's name, as Jupyter does
    shown = socket.gethostname() if host in ("0.0.0.0", "::", "") else (f"[{host}]" if ":" in host else host)

    def ready(**_):
        if announce is not None:
            announce(server.port)
            return
        url = guard.url(f"{scheme}://{shown}:{server.port}/")
        print(f"camcmm GUI: {url}", flush=True)
        if open_browser:
            import webbrowser

            webbrowser.open(url)

    server.controller.on_server_ready.add(ready)
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
    for page in getattr(server, "pages", {}).values():
        if callable(getattr(page, "close", None)):
            page.close()
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


def _size_arg(text: str) -> int:
    """argparse type of ``--max-upload``."""
    import argparse

    from .uploads import parse_size

    try:
        return parse_size(text)
    except CamcmmError as exc:
        raise argparse.ArgumentTypeError(str(exc).split(" ", 1)[1]) from None


def add_serve_arguments(ap: Any) -> None:
    """The options ``camcmm serve`` and ``python -m camcmm.gui`` share (besides the
    project and the port): data roots, token, origins, TLS, sessions."""
    import argparse

    ap.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to bind (default 127.0.0.1: this machine only; see docs/security.md)",
    )
    ap.add_argument(
        "--data-root",
        action="append",
        default=[],
        metavar="DIR",
        help="a folder the browser may read and write besides the project folder (repeatable)",
    )
    ap.add_argument(
        "--scheduler",
        action="append",
        default=[],
        metavar="ADDRESS",
        help="a Dask scheduler (tcp://host:8786) a run may connect to; no other is accepted (repeatable)",
    )
    ap.add_argument(
        "--token-file",
        metavar="FILE",
        help="a fixed token (password) read from FILE instead of a random one per launch (also: $CAMCMM_TOKEN)",
    )
    ap.add_argument(
        "--no-token",
        action="store_true",
        help="no token (only with a loopback --host): any local program may drive the app",
    )
    ap.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="URL",
        help="another origin the browser may use, e.g. a reverse proxy's https://lab.example (repeatable)",
    )
    ap.add_argument("--certfile", help="TLS certificate (PEM): serve HTTPS")
    ap.add_argument("--keyfile", help="TLS private key (PEM) of --certfile")
    from .launcher import DEFAULT_IDLE_S, DEFAULT_MAX_SESSIONS

    ap.add_argument(
        "--max-sessions",
        type=int,
        default=DEFAULT_MAX_SESSIONS,
        metavar="N",
        help=f"browser sessions (tabs), each its own process of ~0.6 GB, open at once (default {DEFAULT_MAX_SESSIONS})",
    )
    ap.add_argument(
        "--session-idle",
        type=float,
        default=DEFAULT_IDLE_S,
        metavar="S",
        help=f"stop a session's process S seconds after its last tab closed (default {DEFAULT_IDLE_S:g})",
    )
    ap.add_argument(
        "--max-upload",
        type=_size_arg,
        default=None,
        metavar="SIZE",
        help="the most a browser may upload at once, per session, e.g. 500M or 4G (default 2G)",
    )
    ap.add_argument(
        "--session-unused",
        type=float,
        default=None,
        metavar="S",
        help="stop a session no page has connected to S seconds after its last request (default 30)",
    )
    ap.add_argument(
        "--single-session",
        action="store_true",
        help="one process for every tab, as before: tabs share their page state (for debugging)",
    )
    ap.add_argument("--session-child", action="store_true", help=argparse.SUPPRESS)  # started by the launcher only


def serve(
    project_dir: str | Path,
    host: str = "127.0.0.1",
    port: int = 0,
    open_browser: bool = False,
    server_name: str = "camcmm",
    *,
    data_roots: Iterable[str | Path] = (),
    no_token: bool = False,
    token_file: str | Path | None = None,
    allowed_origins: Iterable[str] = (),
    certfile: str | None = None,
    keyfile: str | None = None,
    single_session: bool = False,
    max_sessions: int | None = None,
    session_idle: float | None = None,
    session_child: bool = False,
    max_upload: int | None = None,
    session_unused: float | None = None,
    schedulers: Iterable[str] = (),
) -> None:
    """Open (or create) the project in ``project_dir`` and serve the GUI until stopped.

    Prints ``camcmm GUI: http://HOST:PORT/?token=TOKEN`` once the server listens
    (``port=0`` picks a free port). The token is random per launch, or read from
    ``token_file`` / ``$CAMCMM_TOKEN``; ``no_token`` only on a loopback ``host``. The
    browser reaches only the project folder and ``data_roots``, and a run connects only to
    ``schedulers`` (Dask scheduler addresses, ``--scheduler``). Bad options raise a
    one-line :class:`~camcmm.errors.CamcmmError` before anything starts.

    By default each browser session gets a process of its own behind a front server
    (:mod:`camcmm.gui.launcher`: ``max_sessions``, ``session_idle`` seconds);
    ``single_session`` serves every tab from one process (one shared page state).
    ``session_child``: this process is one session, started by the launcher.
    """
    from .security import binding_warning, choose_token

    schedulers = scheduler_list(schedulers)
    if session_child:
        return _serve_child(project_dir, server_name, data_roots, schedulers)
    from .uploads import DEFAULT_MAX_UPLOAD

    token = choose_token(host, no_token=no_token, token_file=token_file)
    from .roots import Roots

    Roots(project_dir, data_roots)  # a missing --data-root is refused before the project is made
    if not single_session:
        from .launcher import DEFAULT_IDLE_S, DEFAULT_MAX_SESSIONS, DEFAULT_UNUSED_S, serve_sessions

        warning = binding_warning(host, bool(certfile))
        if warning:
            print(warning, file=sys.stderr, flush=True)
        os.environ[SCHEDULERS_ENV] = " ".join(schedulers)  # the session processes inherit it
        return serve_sessions(
            project_dir,
            host=host,
            port=port,
            token=token,
            data_roots=data_roots,
            allowed_origins=allowed_origins,
            certfile=certfile,
            keyfile=keyfile,
            max_sessions=DEFAULT_MAX_SESSIONS if max_sessions is None else max_sessions,
            idle=DEFAULT_IDLE_S if session_idle is None else session_idle,
            unused=DEFAULT_UNUSED_S if session_unused is None else session_unused,
            max_upload=DEFAULT_MAX_UPLOAD if max_upload is None else max_upload,
            open_browser=open_browser,
        )
    from .. import worker
    from .pages import preload

    preload()  # pages registered by the modules of $CAMCMM_GUI_PRELOAD
    server, session = build(server_name, project_dir, data_roots=data_roots, schedulers=schedulers)
    worker.warm_later(session.host)  # the plugin worker process starts while the page loads
    start(
        server,
        host=host,
        port=port,
        open_browser=open_browser,
        token=token,
        allowed_origins=allowed_origins,
        certfile=certfile,
        keyfile=keyfile,
        max_upload=max_upload,
    )


#: the front hands its ``--scheduler`` addresses to its session processes in this variable
SCHEDULERS_ENV = "CAMCMM_SESSION_SCHEDULERS"


def scheduler_list(addresses: Iterable[str] | None) -> list[str]:
    """The ``--scheduler`` addresses, checked: each one word (``tcp://host:8786``)."""
    out = []
    for a in addresses or ():
        text = str(a).strip()
        if not text or any(c.isspace() or not c.isprintable() for c in text):
            raise CamcmmError(f"--scheduler {str(a)!r}: an address is one word, e.g. tcp://10.0.0.5:8786")
        out.append(text)
    return out


def _serve_child(
    project_dir: str | Path, server_name: str, data_roots: Iterable[str | Path], schedulers: Iterable[str] = ()
) -> None:
    """One session behind the launcher: 127.0.0.1, a free port, the launcher's secret; the
    front's schedulers from :data:`SCHEDULERS_ENV`."""
    from .. import worker
    from .launcher import child
    from .pages import preload

    secret, ws_secret = child.take_secrets()
    preload()
    schedulers = [*schedulers, *scheduler_list(os.environ.get(SCHEDULERS_ENV, "").split())]
    server, session = build(server_name, project_dir, data_roots=data_roots, schedulers=schedulers)
    worker.warm_later(session.host)
    child.prepare(server, session)
    start(server, host="127.0.0.1", port=0, token=secret, ws_secret=ws_secret, announce=child.announce)


def serve_from_args(project: str | Path, args: Any, port: int, open_browser: bool = False) -> None:
    """:func:`serve` with the options of :func:`add_serve_arguments`."""
    serve(
        project,
        host=args.host,
        port=port,
        open_browser=open_browser,
        data_roots=args.data_root,
        no_token=args.no_token,
        token_file=args.token_file,
        allowed_origins=args.allow_origin,
        certfile=args.certfile,
        keyfile=args.keyfile,
        single_session=args.single_session,
        max_sessions=args.max_sessions,
        session_idle=args.session_idle,
        session_child=args.session_child,
        max_upload=getattr(args, "max_upload", None),
        session_unused=getattr(args, "session_unused", None),
        schedulers=getattr(args, "scheduler", None) or (),
    )


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
