"""What every page shares: one :class:`Session` per server.

The session holds the project and its items (import, load, record), the plugin
host, the 3D view and the item shown in it, the messages (one-line errors, infos)
and the server's event loop; it publishes them through the trame ``state``. The
pages (``camcmm.gui.pages``) keep their own state and handlers and use only the
public methods here. Every public method catches its errors and shows them
(:meth:`Session.error`): a bad file gives a one-line reason naming it, and the app
keeps running. Nothing here builds widgets, so all of it is testable without a
browser.

Threading: VTK, the project store and the state are touched only from the server's
event-loop thread; :meth:`Session.import_file_async` reads in a worker thread
(:class:`~camcmm.gui.jobs.Job`); :meth:`Session.import_file` reads in the calling
thread (tests, scripts).
"""

from __future__ import annotations

import asyncio
import logging
import shutil
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, one_line
from ..host import default_host
from ..tasks.items import describe, item_meta, kind_of, read_item, safe_name, size_text
from ..units import unit_label
from .jobs import Job
from .scenes import ITEM_PAGE, SharedView
from .unit_ask import UnitAsks
from .view import DISPLAY_LIMIT, SceneView

log = logging.getLogger("camcmm.gui")

#: The cause of a message raised before any tab connected (kept over a reload).
STARTUP = "startup"

#: What the Inspect page's view says when no item is selected.
ITEM_HINT = "No item shown: choose one in the list of items, or import a file (toolbar)."

#: ... and when the item it showed was hidden or removed in another tab.
ITEM_GONE = "The item shown was hidden or removed in another window: choose one in the list of items."

#: Seconds between checks for changes another session made to the shared project.
WATCH_PERIOD_S = 1.0


class Session:
    """The project, its items, the 3D view, the messages and the loop, shared by the pages."""

    #: the folders the pages may read and write (:class:`~camcmm.gui.roots.Roots`), set by
    #: :func:`camcmm.gui.app.build` before the pages mount
    roots: Any = None

    def __init__(
        self,
        server: Any,
        project: Any,
        host: Any = None,
        view: SceneView | None = None,
        display_limit: int = DISPLAY_LIMIT,
    ):
        self.server = server
        self.state = server.state
        self.ctrl = server.controller
        self.project = project
        self.host = host if host is not None else default_host()
        self.view = view if view is not None else SceneView(display_limit)
        self._objects: dict[str, Any] = {}  # item key -> loaded model object
        self._measurements: dict[str, dict] = {}  # item key -> project measurement record
        self._summary: dict[str, str] = {}
        self._item_watchers: list[Callable[[], Any]] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: int | None = None
        self._reader = Job("import", state=self.state, workers=2)
        self._unit_asks = UnitAsks(self)  # imports waiting for the user's unit (import_file)
        self._tmp = Path(tempfile.mkdtemp(prefix="camcmm-gui-"))
        self.errors: list[str] = []
        self._causes: dict[str, str] = {}  # page -> cause key of the message it shows
        self._info_item = ""  # the item the status bar's note is about ("": none)
        self._connected = False  # a tab has connected (client_connected)
        self._reload_watchers: list[Callable[[], Any]] = []
        self._selection_watchers: list[Callable[[str | None], Any]] = []
        self._project_watchers: list[Callable[[], Any]] = []
        self._watch: asyncio.TimerHandle | None = None  # the check for other sessions' changes
        self._watching = True  # until close()
        self._project_token = self._change_token()  # before listing: a commit in between shows next tick
        self._init_state()
        self.shared = SharedView(self)  # what each page shows in the 3D view (.scenes)
        self.shared.share(ITEM_PAGE, ITEM_HINT)
        self.state.change("page")(self._page_changed)
        self.ctrl.on_client_connected.add(self.client_connected)
        self.refresh_items()
        self.refresh_results()
        self.restore()

    # -- state -------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.project_name = str(getattr(self.project, "name", "") or "project")
        s.project_path = str(getattr(self.project, "path", getattr(self.project, "root", "")) or "")
        s.update(
            {
                "items": [],
                "hidden_items": [],
                "selected_item": None,
                "picked_item": None,
                "color_fields": [],
                "color_field": None,
                "legend_title": "",
                "display_note": "",
                "results": [],
                "error_message": "",
                "error_page": "",
                "error_visible": False,
                "page_messages": {},
                "info_message": "",
                "info_page": "",
                "info_visible": False,
                "importing": False,
            }
        )

    def flush(self) -> None:
        try:
            self.state.flush()
        except Exception:  # a client vanishing mid-update must not break the logic
            log.exception("state flush failed")

    def bind_loop(self, loop: asyncio.AbstractEventLoop | None = None) -> None:
        """Remember the server's event loop (called from inside it)."""
        self._loop = loop or asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()
        if self._watch is None and self._watching:  # the loop is where the check runs
            self._watch = self._loop.call_later(WATCH_PERIOD_S, self._watch_tick)

    def post(self, fn: Callable[..., None], *args: Any) -> None:
        """Run ``fn`` on the loop thread (now, if we are on it or there is no loop)."""
        if self._loop is not None and threading.get_ident() != self._loop_thread and not self._loop.is_closed():

            def call() -> None:
                with self.state:
                    fn(*args)

            self._loop.call_soon_threadsafe(call)
        else:
            fn(*args)

    # -- messages ----------------------------------------------------------------------
    # A message belongs to the page that raised it (state ``page_messages``: page key ->
    # line): the page's alert shows its own, never another page's. ``error_message`` is the
    # newest error of any page, for scripts and tests (each page shows only its own: page_messages)
    page_of_module: dict[str, str] = {}
    """Module prefix -> page key (set by the shell for the pages it mounts), to find the
    page that raised a message from its caller's module."""

    def page_of_caller(self, depth: int = 2) -> str:
        """The page whose code called (first page module up the stack), else the page shown."""
        frame: Any = sys._getframe(depth)
        while frame is not None:
            module = str(frame.f_globals.get("__name__", ""))
            for prefix, key in self.page_of_module.items():
                if module == prefix or module.startswith(prefix + "."):
                    return key
            frame = frame.f_back
        return str(getattr(self.state, "page", "") or "")

    def _set_page_message(self, page: str, line: str) -> None:
        self.state.page_messages = {**(self.state.page_messages or {}), page: line}

    def error(self, msg: str, page: str | None = None, cause: str = "") -> None:
        """Show a one-line error on ``page`` (default: the page whose code called); the app
        keeps running. ``cause``: what the message is about (``"device d1: motion"``): it goes
        when that is resolved (:meth:`resolve`), besides when it is dismissed, replaced,
        or the page is loaded again (:meth:`client_connected`)."""
        line = " ".join(str(msg).split()) or "unknown error"
        key = page if page is not None else self.page_of_caller()
        self.errors.append(line)
        log.warning("%s", line)
        print(f"camcmm GUI error: {line}", file=sys.stderr, flush=True)
        self._set_page_message(key, line)
        # a message before any tab connected is about the server's start, not an action: kept
        self._causes[key] = str(cause or ("" if self._connected else STARTUP))
        self.state.error_message = line
        self.state.error_page = key
        self.state.error_visible = True
        self.state.info_visible = False

    def resolve(self, cause: str) -> list[str]:
        """``cause`` is resolved (the stage was homed, a move went through): every page's
        message about it goes. Returns the pages whose message went."""
        cleared = [page for page, c in self._causes.items() if cause and c == cause]
        for page in cleared:
            self.clear_error(page=page)
        return cleared

    def client_connected(self, **_: Any) -> None:
        """A tab connected (a reload, or a new tab on this session): the messages of the
        actions done in the page before go, as a page loaded afresh shows none; a cause
        still there says so again at the next action."""
        first, self._connected = not self._connected, True
        if first:  # the page's first load: nothing was done in it yet
            return
        with self.state:
            for page in [p for p, line in (self.state.page_messages or {}).items() if line]:
                if self._causes.get(page) != STARTUP:
                    self.clear_error(page=page)
            self.state.info_message, self.state.info_visible = "", False
            for fn in self._reload_watchers:
                fn()

    def watch_reload(self, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` when a tab connects (a page dropping its own message lines)."""
        self._reload_watchers.append(fn)

    def info(self, msg: str, page: str | None = None, item: str = "") -> None:
        """A one-line note in the status bar (``info_message``, ``info_page``); about
        ``item`` (an item id), it goes when that item is hidden or removed (another tab)."""
        self._info_item = str(item or "")
        self.state.info_message = " ".join(str(msg).split())
        self.state.info_page = page if page is not None else self.page_of_caller()
        self.state.info_visible = True

    def clear_error(self, page: str | None = None) -> None:
        """Clear ``page``'s error (default: the calling page's); the others stay."""
        key = page if page is not None else self.page_of_caller()
        self._causes.pop(key, None)
        if (self.state.page_messages or {}).get(key):
            self._set_page_message(key, "")
        if self.state.error_page == key:
            self.state.error_message = ""
            self.state.error_visible = False

    def page_error(self, page: str) -> str:
        """The error line ``page`` shows ("" when none)."""
        return str((self.state.page_messages or {}).get(page) or "")

    # -- items (the project's measurements) -------------------------------------------
    def _maker(self, made_by: str) -> str:
        """Who made an item, in words: ``"fit.sphere 0.1.0"`` (its ``made_by``) -> the plugin's
        name, "Sphere fit" (issue 30: no plugin ids where a person reads); a plugin no longer
        installed keeps what was stored."""
        pid = made_by.split(" ", 1)[0]
        try:
            return str(self.host.get(pid).name or made_by)
        except Exception:
            return made_by

    def refresh_items(self) -> None:
        """List the project's items: state ``items`` (the ones the pickers offer) and
        ``hidden_items`` (hidden by the tidy; still loadable). Each ``{id, name, kind,
        subtitle, derived, hidden}``; ``derived``: made by a plugin run, not imported."""
        try:
            records = list(self.project.measurements())
        except Exception as exc:
            self.error(f"project {self.state.project_name}: cannot list measurements: {exc}")
            records = []
        items: list[dict[str, Any]] = []
        hidden: list[dict[str, Any]] = []
        self._measurements = {}
        for m in records:
            key = str(m["id"])
            self._measurements[key] = m
            kind = str(m.get("kind") or "")
            meta = m.get("meta") if isinstance(m.get("meta"), dict) else {}
            sub = self._summary.get(key) or (f"{kind} · {meta['summary']}" if meta.get("summary") else kind)
            made_by = str(meta.get("made_by") or "")  # "<plugin id> <version>": a key, said in words below
            row = {
                "id": key,
                "name": str(m.get("name") or key),
                "kind": kind,
                "subtitle": sub + (f" · made by {self._maker(made_by)}" if made_by else ""),
                "derived": bool(made_by),
                "hidden": bool(m.get("hidden")),
            }
            (hidden if row["hidden"] else items).append(row)
        self.state.items = items
        self.state.hidden_items = hidden
        if self._info_item and self._info_item not in {row["id"] for row in items}:
            # the note was about an item another tab hid or removed: not left on screen
            self._info_item, self.state.info_message, self.state.info_visible = "", "", False
        for fn in self._item_watchers:
            fn()

    def watch_items(self, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` each time the items were listed again (a page's input selects)."""
        self._item_watchers.append(fn)

    def load(self, key: str) -> Any:
        if key in self._objects:
            return self._objects[key]
        m = self._measurements.get(key)
        if m is None:
            raise InputError(f"no item with id {key!r} in project {self.state.project_name}")
        obj = self._read_item(m)
        self._objects[key] = obj
        unit = (m.get("meta") or {}).get("unit") if isinstance(m.get("meta"), dict) else None
        sized = f" · {size_text(obj)}" if unit and kind_of(obj) in ("pointcloud", "mesh") else ""  # an import's size
        self._summary[key] = f"{kind_of(obj)} · {describe(obj)}{sized}"
        return obj

    def _read_item(self, m: dict[str, Any]) -> Any:
        """Item ``m``'s geometry from its project file, decoded in a capped worker process
        (:mod:`camcmm.gui.decode`) as an upload is: an item stored before the uploads were
        capped (a JPEG declaring 20000 x 20000 px made every session start at 1.76 GB,
        the last item shown being shown again at start) costs that process, not the session.
        A store without files (a test's stand-in) reads as before."""
        file_path = getattr(self.project, "file_path", None)
        if not callable(file_path) or not m.get("hash"):
            return read_item(self.project, m)
        from .decode import decode

        name = str(m.get("name") or m.get("id"))
        unit = (m.get("meta") or {}).get("unit") if isinstance(m.get("meta"), dict) else None
        try:
            obj, _ = decode(file_path(m["hash"]), str(unit) if unit else None, name)
        except InputError as exc:
            raise InputError(f"{exc} (item {m.get('id')} of the project)") from None
        if hasattr(obj, "name"):
            try:
                obj.name = m["name"]
            except AttributeError:
                pass
        return obj

    def read_file(
        self, source: str | Path | bytes, name: str | None = None, unit: str | None = None
    ) -> tuple[Path, Any, str]:
        """Read a file (a path, or uploaded bytes with their original ``name``) through
        :func:`camcmm.io.read`, in ``unit`` when given. Thread-safe; touches neither
        project nor state."""
        path, obj, name, _ = self._read_stated(source, name, unit)
        return path, obj, name

    def _read_stated(
        self, source: str | Path | bytes, name: str | None, unit: str | None
    ) -> tuple[Path, Any, str, str | None]:
        """As :meth:`read_file`, with the unit the caller or the file states (or None).
        The file is decoded in a process of its own under a memory cap
        (:mod:`camcmm.gui.decode`): a bomb costs that process, never this session."""
        from .decode import decode

        if isinstance(source, (bytes, bytearray, memoryview)):
            name = safe_name(name or "upload")
            folder = Path(tempfile.mkdtemp(prefix="upload-", dir=self._tmp))
            path = folder / name
            path.write_bytes(bytes(source))
        else:
            path = Path(source)
            name = name or path.name
            if not path.is_file():
                raise InputError(f"{name}: no such file" if not path.exists() else f"{name}: is not a file")
        try:
            obj, stated = decode(path, unit or None, name)
        except Exception as exc:
            raise InputError(one_line(exc, name, path, path.parent)) from exc
        k = kind_of(obj)
        if k == "pointcloud" and obj.n_points == 0:
            raise InputError(f"{name}: the file holds no points")
        if k == "pointcloud":  # the model checks this; say it again in case a reader did not
            if not np.isfinite(np.asarray(obj.points)).all():
                raise InputError(f"{name}: points with NaN or Inf coordinates")
        return path, obj, name, stated

    def _register(self, path: Path, obj: Any, name: str) -> str:
        """Store a read file in the project and show it. Loop thread only. The item
        records the unit its file was read in (``meta["unit"]``), so it loads the same."""
        h = self.project.add_file(path)
        unit = str(getattr(obj, "source_unit", "") or "")
        key = str(self.add_measurement(name, h, obj, unit=unit))
        self.refresh_items()
        self.select_item(key)
        note = f" (read in {unit_label(unit)})" if unit and unit != "mm" else ""
        self.info(f"imported {name}: {describe(obj)}, {size_text(obj)}{note}", item=key)
        return key

    def _imported(self, path: Path, obj: Any, label: str, stated: str | None, source: Any) -> str | None:
        """Register a read file, or hold it and ask its unit when camcmm.units says so."""
        if kind_of(obj) in ("pointcloud", "mesh"):
            from .. import io as cio

            check = cio.unit_decision(obj, stated)
            if check.asks:
                self._ask_unit(path, obj, label, check, source)
                return None
        return self._register(path, obj, label)

    def _ask_unit(self, path: Path, obj: Any, label: str, check: Any, source: Any) -> None:
        """Hold an import whose unit is in doubt and show the question (state ``unit_ask``)."""
        self._unit_asks.hold(path, obj, label, check, source)

    def answer_unit(self, unit: Any) -> str | None:
        """The user's unit for the import being asked about (one of camcmm.units'
        CANDIDATE_UNITS): convert, store, show. Returns the new item's id, or None."""
        return self._unit_asks.answer(unit)

    def cancel_unit(self) -> None:
        """Drop the import being asked about (nothing is stored)."""
        self._unit_asks.cancel()

    def add_measurement(
        self, name: str, h: str, obj: Any, source: str = "", unit: str = "", display: dict | None = None
    ) -> Any:
        """Record ``obj`` (stored as file hash ``h``) as a new item; it stays loaded.
        ``unit``: the length unit the file is read in (an import's). ``display``: field
        -> unit the view shows it in (``{"deviation": "µm"}``; the data stay in mm).
        Returns the measurement id (its item key is ``str(id)``)."""
        meta = item_meta(obj, source, unit, display)
        try:
            mid = self.project.add_measurement(name, h, kind_of(obj), meta=meta)
        except TypeError:  # a store without meta
            mid = self.project.add_measurement(name, h, kind_of(obj))
        self._objects[str(mid)] = obj
        self._summary[str(mid)] = f"{kind_of(obj)} · {meta['summary']}"
        return mid

    def loaded(self, key: Any) -> Any | None:
        """Item ``key``'s object if it is loaded (no reading), else None."""
        return None if key is None else self._objects.get(str(key))

    def measurement(self, key: Any) -> dict[str, Any] | None:
        """The project's record of item ``key`` (``id``, ``name``, ``kind`` ...), or None."""
        return None if key is None else self._measurements.get(str(key))

    def import_file(self, source: str | Path | bytes, name: str | None = None, unit: str | None = None) -> str | None:
        """Import a file into the project and show it, in ``unit`` when given (else the
        file's own, else mm — or, when its size is implausible as mm, hold it and ask:
        state ``unit_ask``, answered by :meth:`answer_unit`). Returns the new item's id,
        or None after showing the reason it could not be imported (or while asking)."""
        label = name or (Path(source).name if isinstance(source, (str, Path)) else "upload")
        self.state.importing = True
        try:
            path, obj, label, stated = self._read_stated(source, name, unit)
            return self._imported(path, obj, label, stated, source)
        except Exception as exc:
            self.error(self._import_reason(exc, label, source))
            return None
        finally:
            self.state.importing = False
            self.drop_upload(source)

    async def import_file_async(
        self, source: str | Path | bytes, name: str | None = None, unit: str | None = None
    ) -> str | None:
        """As :meth:`import_file`, reading in a worker thread so the page stays live."""
        label = name or (Path(source).name if isinstance(source, (str, Path)) else "upload")
        if self._loop is None:
            self.bind_loop()
        self.state.importing = True
        self.clear_error()
        self.info(f"reading {label} …")
        self.flush()
        try:
            path, obj, label, stated = await self._reader.call(self._read_stated, source, name, unit)
            return self._imported(path, obj, label, stated, source)
        except Exception as exc:
            self.error(self._import_reason(exc, label, source))
            return None
        finally:
            self.state.importing = False
            self.drop_upload(source)
            self.flush()

    def _import_reason(self, exc: BaseException, label: str, source: Any) -> str:
        """The one-line reason; for a file read on the server, without the bytes a
        reader quotes from it (the page shows what failed, not what the file holds)."""
        msg = one_line(exc, label)
        if isinstance(source, (str, Path)):
            from .roots import redact

            msg = redact(msg, keep=(label, str(source)))
        return msg

    def drop_upload(self, source: Any) -> None:
        """Delete the temp copies of uploads (the project keeps its own copy)."""
        if isinstance(source, (bytes, bytearray, memoryview)):
            for folder in self._tmp.glob("upload-*"):
                shutil.rmtree(folder, ignore_errors=True)

    def import_upload(self, upload: Any) -> list[dict[str, Any]]:
        """Normalise a trame file-input value (a dict or a list of dicts with ``name``
        and ``content``) to ``[{"name", "content": bytes}]``."""
        files = upload if isinstance(upload, list) else [upload]
        out = []
        for f in files:
            if not isinstance(f, dict):
                continue
            content = f.get("content")
            if isinstance(content, list):
                content = b"".join(bytes(c) for c in content)
            out.append({"name": str(f.get("name") or "upload"), "content": bytes(content or b"")})
        return out

    def select_item(self, key: str | None, chosen: bool = True, field: str | None = None) -> None:
        """Select an item: the Inspect page's scene (:mod:`camcmm.gui.scenes`), drawn in the
        3D view while that page is shown, keeping the chosen colouring when it exists
        (``field``: colour by that field instead). ``chosen``: the user picked it (a click,
        an import), so the plugin form offers it first; a run showing its output passes
        False. Fields the item's ``meta["display_units"]`` names are shown in that unit."""
        if key is None:
            return
        key = str(key)
        try:
            self.load(key)
        except Exception as exc:
            name = self._measurements.get(key, {}).get("name", key)
            self.error(one_line(exc, str(name)))
            return
        self.state.selected_item = key
        if chosen:
            self.state.picked_item = key
        self.remember("gui.selected_item", key)
        prev = self.shared.scene(ITEM_PAGE)
        here = self.shared.owner == ITEM_PAGE
        keep = field or (prev.field if prev is not None else None) or (self.state.color_field if here else None)
        self.shared.show_item(ITEM_PAGE, key, keep)
        self.refresh_items()
        for fn in self._selection_watchers:
            fn(key)

    def unselect_item(self, hint: str | None = None) -> None:
        """No item selected (it was hidden or removed): the Inspect page's view is empty,
        saying ``hint`` (default: its own)."""
        self.state.selected_item = None
        self.shared.clear(ITEM_PAGE, hint)
        for fn in self._selection_watchers:
            fn(None)

    def watch_selection(self, fn: Callable[[str | None], Any]) -> None:
        """Call ``fn(key)`` after each selection (None: none), e.g. a result panel following it."""
        self._selection_watchers.append(fn)

    def page_entered(self, page: Any) -> None:
        """Page ``page`` is shown: the shared view shows that page's scene (a page that
        fills the area hides the view and leaves it as it is)."""
        self.shared.enter(page)

    def _page_changed(self, page: Any = None, **_: Any) -> None:
        self.page_entered(page)

    def redraw_view(self) -> None:
        """Draw the shown page's scene again (e.g. at another display limit)."""
        self.shared.draw()

    def remember(self, key: str, value: Any) -> None:
        """Keep a view setting (``gui.<name>``) in the project so that reopening it shows the same."""
        try:
            self.project.set_state(key, value)
        except Exception:  # a read-only or older store: the setting is a convenience
            log.debug("could not remember %s", key, exc_info=True)

    def restore(self) -> None:
        """Show what was shown when the project was last open; a project opened for the
        first time shows its first item, so the operator never faces an empty view."""
        try:
            key = self.project.get_state("gui.selected_item")
            field_name = self.project.get_state("gui.color_field")
        except Exception:
            return
        if (key is None or str(key) not in self._measurements) and self._measurements:
            key, field_name = next(iter(self._measurements)), None
        if key is not None and str(key) in self._measurements:
            if field_name:
                self.state.color_field = field_name
            meta = self._measurements[str(key)].get("meta") or {}
            self.select_item(str(key), chosen=not (isinstance(meta, dict) and meta.get("made_by")))

    # -- results (the project's) ---------------------------------------------------------
    def refresh_results(self) -> None:
        """List the project's newest 50 results (state ``results``); a page calls it after storing one."""
        try:
            rows = list(self.project.results())
        except Exception as exc:
            self.error(f"project {self.state.project_name}: cannot list results: {exc}")
            rows = []
        from ..tasks.acceptance.naming import result_row  # rows named in words (issue 30)

        out = [result_row(r, self.host) for r in rows[-50:]]
        self.state.results = list(reversed(out))

    # -- other sessions' changes (one process per browser session, one shared store) ---------
    def _change_token(self) -> Any:
        token_of = getattr(self.project, "change_token", None)
        try:
            return token_of() if callable(token_of) else None
        except Exception:  # a store without tokens, or one gone: nothing to compare
            return None

    def check_project(self) -> bool:
        """List the items and results again when another session (or the CLI) committed
        to the project since the last check; True when it did. Loop thread only. Costs
        one pragma when nothing changed; a busy or closed store is skipped (None token)."""
        token = self._change_token()
        if token is None or token == self._project_token:
            return False
        self._project_token = token
        with self.state:  # pushed now: the timer runs outside any client request
            shown = self.state.selected_item
            was_listed = any(it["id"] == shown for it in self.state.items or [])
            self.refresh_items()
            self.refresh_results()
            if shown is not None and was_listed and not any(it["id"] == shown for it in self.state.items or []):
                # hidden or removed in another tab: not left on screen as if it were still listed
                self.unselect_item(ITEM_GONE)
            for fn in self._project_watchers:
                fn()
        return True

    def watch_project(self, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` after another session (a tab, the CLI) changed the project."""
        self._project_watchers.append(fn)

    def _watch_tick(self) -> None:
        """The timer on the loop (started by :meth:`bind_loop`): never raises into it."""
        try:
            if self._watching:
                self.check_project()
        except Exception:
            log.debug("checking the project for other sessions' changes failed", exc_info=True)
        finally:
            loop = self._loop
            if self._watching and loop is not None and not loop.is_closed():
                self._watch = loop.call_later(WATCH_PERIOD_S, self._watch_tick)

    # -- shutdown -----------------------------------------------------------------------
    def close(self) -> None:
        self._watching = False
        watch, self._watch = self._watch, None
        if watch is not None and self._loop is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(watch.cancel)
            except RuntimeError:  # the loop closed meanwhile: the timer is gone with it
                pass
        self._reader.close()
        shutil.rmtree(self._tmp, ignore_errors=True)
        try:
            self.view.plotter.close()
        except Exception:
            pass
