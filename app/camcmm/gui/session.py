"""GUI logic, apart from the layout: one :class:`Session` per server.

The session holds the project, the plugin host and the 3D scene, and publishes what
the page shows through the trame ``state``. Every public method catches its errors
and shows them (:meth:`Session.error`): a bad file or a failing plugin gives a
one-line reason naming the culprit, and the app keeps running. Nothing here builds
widgets, so all of it is testable without a browser.

Threading: VTK, the project store and the state are touched only from the server's
event-loop thread; file reading and plugin runs go to a worker thread in the
``*_async`` variants, whose progress is marshalled back to the loop. The plain
variants do everything in the calling thread (tests, scripts).
"""

from __future__ import annotations

import asyncio
import logging
import re
import shutil
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import worker  # plugin runs in a worker process: a native crash cannot end the server
from ..errors import CamcmmError, InputError, PluginError
from ..host import RunResult, default_host, to_jsonable
from ..params import form_schema, validate
from .view import DISPLAY_LIMIT, SceneView, color_fields, fmt_count, legend_title

log = logging.getLogger("camcmm.gui")

#: Input port types the form can fill from the project's items.
_ITEM_TYPES = {"pointcloud": ("pointcloud",), "mesh": ("mesh",), "geometry": ("pointcloud", "mesh"),
               "image": ("image",)}
_MAX_LIST = 12  # longer arrays are summarised in the result panel


def kind_of(obj: Any) -> str:
    if hasattr(obj, "faces") and hasattr(obj, "vertices"):
        return "mesh"
    if hasattr(obj, "points") and hasattr(obj, "n_points"):
        return "pointcloud"
    if hasattr(obj, "data") and hasattr(obj, "size"):
        return "image"
    return type(obj).__name__.lower()


def describe(obj: Any) -> str:
    k = kind_of(obj)
    if k == "pointcloud":
        extra = f", fields: {', '.join(obj.fields)}" if getattr(obj, "fields", None) else ""
        return f"{fmt_count(obj.n_points)} points{extra}"
    if k == "mesh":
        return f"{fmt_count(obj.n_vertices)} vertices, {fmt_count(obj.n_faces)} faces"
    if k == "image":
        w, h = obj.size
        return f"image {w} × {h} px"
    return k


def safe_name(name: str) -> str:
    """A file name safe to write in a temp folder, keeping its extension."""
    base = Path(str(name).replace("\\", "/")).name.strip() or "upload"
    return re.sub(r"[^\w.\-+ ()\[\]]", "_", base)


def _numeric_array(v: Any) -> np.ndarray | None:
    """``v`` as a numeric array if it is an array or a (nested) list of numbers."""
    if isinstance(v, np.ndarray):
        return v
    if isinstance(v, (list, tuple)) and v:
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            return None
        return a
    return None


def fmt_value(v: Any) -> str:
    """A result value as text: 6 significant digits, short arrays inline, long ones
    as shape and range."""
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.6g}" if np.isfinite(v) else "not defined"
    a = _numeric_array(v)
    if a is not None:
        if a.dtype.kind not in "iufb" or a.size == 0:
            return f"array {tuple(a.shape)}"
        if a.size <= _MAX_LIST:
            rows = a.reshape(1, -1) if a.ndim <= 1 else a.reshape(a.shape[0], -1)
            return "[" + "; ".join(", ".join(fmt_value(x.item()) for x in row) for row in rows) + "]"
        return f"array {tuple(a.shape)}, {fmt_value(float(np.nanmin(a)))} … {fmt_value(float(np.nanmax(a)))}"
    if hasattr(v, "n_points"):
        return f"point cloud '{v.name}', {fmt_count(v.n_points)} points"
    if hasattr(v, "n_faces"):
        return f"mesh '{v.name}', {fmt_count(v.n_faces)} faces"
    return str(v)


def summarize_json(x: Any, limit: int = _MAX_LIST) -> Any:
    """``to_jsonable`` with long lists cut (the panel must not carry 2 million numbers)."""
    if isinstance(x, dict):
        return {k: summarize_json(v, limit) for k, v in x.items()}
    if isinstance(x, (np.ndarray, list, tuple)):
        a = x if isinstance(x, np.ndarray) else None
        n = a.size if a is not None else len(x)
        if n > limit:
            shape = list(a.shape) if a is not None else [len(x)]
            return {"array_shape": shape, "first": to_jsonable(list(np.ravel(x)[:3]) if a is not None else list(x[:3]))}
        return [summarize_json(v, limit) for v in (x.tolist() if a is not None else x)]
    return to_jsonable(x)


def result_rows(outputs: dict[str, Any], units: dict[str, str]) -> list[dict[str, str]]:
    """Rows ``{name, value, unit}`` for the result table. Units come from the plugin's
    declared outputs, or from a ``units`` mapping (or ``unit`` text) inside the outputs;
    one level of nested dicts is shown with dotted names."""
    extra = outputs.get("units") if isinstance(outputs.get("units"), dict) else {}
    rows = []
    for name, value in outputs.items():
        if name == "units":
            continue
        unit = str(units.get(name) or extra.get(name, "") or "")
        if isinstance(value, dict):
            sub_units = value.get("units") if isinstance(value.get("units"), dict) else {}
            for k, v in value.items():
                if k in ("units", "unit"):
                    continue
                u = sub_units.get(k) or (value.get("unit") if isinstance(value.get("unit"), str) else "") or unit
                rows.append({"name": f"{name}.{k}", "value": fmt_value(v), "unit": str(u or "")})
        else:
            rows.append({"name": name, "value": fmt_value(value), "unit": unit})
    return rows


class Session:
    """Everything the page does, as plain methods on plain state."""

    def __init__(self, server: Any, project: Any, host: Any = None, view: SceneView | None = None,
                 display_limit: int = DISPLAY_LIMIT):
        self.server = server
        self.state = server.state
        self.ctrl = server.controller
        self.project = project
        self.host = host if host is not None else default_host()
        self.view = view if view is not None else SceneView(display_limit)
        self._objects: dict[str, Any] = {}      # item key -> loaded model object
        self._measurements: dict[str, dict] = {}  # item key -> project measurement record
        self._summary: dict[str, str] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: int | None = None
        self._executor = ThreadPoolExecutor(max_workers=2, thread_name_prefix="camcmm-gui")
        self._cancel: threading.Event | None = None
        self._last_progress = 0.0
        self._tmp = Path(tempfile.mkdtemp(prefix="camcmm-gui-"))
        self.last_result: RunResult | None = None
        self.last_result_id: Any = None
        self.errors: list[str] = []
        self._init_state()
        self.refresh_items()
        self.refresh_plugins()
        self.refresh_results()
        self.restore()

    # -- state -------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.project_name = str(getattr(self.project, "name", "") or "project")
        s.project_path = str(getattr(self.project, "path", getattr(self.project, "root", "")) or "")
        s.items = []
        s.selected_item = None
        s.color_fields = []
        s.color_field = None
        s.legend_title = ""
        s.display_note = ""
        s.plugins = []
        s.selected_plugin = None
        s.plugin_title = ""
        s.plugin_summary = ""
        s.form_fields = []
        s.form_values = {}
        s.form_inputs = []
        s.input_values = {}
        s.running = False
        s.progress = 0.0
        s.progress_message = ""
        s.result = None
        s.result_title = ""
        s.result_rows = []
        s.result_warnings = []
        s.results = []
        s.error_message = ""
        s.error_visible = False
        s.info_message = ""
        s.info_visible = False
        s.importing = False

    def flush(self) -> None:
        try:
            self.state.flush()
        except Exception:  # a client vanishing mid-update must not break the logic
            log.exception("state flush failed")

    def bind_loop(self, loop: asyncio.AbstractEventLoop | None = None) -> None:
        """Remember the server's event loop (called from inside it)."""
        self._loop = loop or asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()

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
    def error(self, msg: str) -> None:
        """Show a one-line error; the app keeps running."""
        line = " ".join(str(msg).split()) or "unknown error"
        self.errors.append(line)
        log.warning("%s", line)
        print(f"camcmm GUI error: {line}", file=sys.stderr, flush=True)
        self.state.error_message = line
        self.state.error_visible = True
        self.state.info_visible = False

    def info(self, msg: str) -> None:
        self.state.info_message = " ".join(str(msg).split())
        self.state.info_visible = True

    def clear_error(self) -> None:
        self.state.error_message = ""
        self.state.error_visible = False

    @staticmethod
    def _reason(exc: BaseException, name: str, *paths: Any) -> str:
        msg = str(exc) if isinstance(exc, CamcmmError) else f"{type(exc).__name__}: {exc}"
        msg = " ".join(msg.split())
        for p in paths:  # the temp copy of an upload is named as the operator knows it
            if p:
                msg = msg.replace(str(p), name)
        if name and name not in msg:
            msg = f"{name}: {msg}"
        return msg

    # -- items (the project's measurements) -------------------------------------------
    def refresh_items(self) -> None:
        try:
            records = list(self.project.measurements())
        except Exception as exc:
            self.error(f"project {self.state.project_name}: cannot list measurements: {exc}")
            records = []
        items = []
        self._measurements = {}
        for m in records:
            key = str(m["id"])
            self._measurements[key] = m
            kind = str(m.get("kind") or "")
            meta = m.get("meta") if isinstance(m.get("meta"), dict) else {}
            sub = self._summary.get(key) or (f"{kind} · {meta['summary']}" if meta.get("summary") else kind)
            items.append({"id": key, "name": str(m.get("name") or key), "kind": kind, "subtitle": sub})
        self.state.items = items
        self._refresh_form_inputs()

    def load(self, key: str) -> Any:
        if key in self._objects:
            return self._objects[key]
        m = self._measurements.get(key)
        if m is None:
            raise InputError(f"no item with id {key!r} in project {self.state.project_name}")
        try:
            obj = self.project.load_measurement(m["id"])
        except CamcmmError:
            raise
        except Exception as exc:
            raise InputError(f"{m.get('name', key)}: cannot load from the project: {type(exc).__name__}: {exc}") from exc
        self._objects[key] = obj
        self._summary[key] = f"{kind_of(obj)} · {describe(obj)}"
        return obj

    def read_file(self, source: str | Path | bytes, name: str | None = None) -> tuple[Path, Any, str]:
        """Read a file (a path, or uploaded bytes with their original ``name``) through
        :func:`camcmm.io.read`. Thread-safe; touches neither project nor state."""
        from .. import io as cio

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
            obj = cio.read(path)
        except Exception as exc:
            raise InputError(self._reason(exc, name, path, path.parent)) from exc
        k = kind_of(obj)
        if k == "pointcloud" and obj.n_points == 0:
            raise InputError(f"{name}: the file holds no points")
        if k == "pointcloud":  # the model checks this; say it again in case a reader did not
            if not np.isfinite(np.asarray(obj.points)).all():
                raise InputError(f"{name}: points with NaN or Inf coordinates")
        return path, obj, name

    def _register(self, path: Path, obj: Any, name: str) -> str:
        """Store a read file in the project and show it. Loop thread only."""
        h = self.project.add_file(path)
        mid = self.add_measurement(name, h, obj)
        key = str(mid)
        self._objects[key] = obj
        self._summary[key] = f"{kind_of(obj)} · {describe(obj)}"
        self.refresh_items()
        self.select_item(key)
        self.info(f"imported {name}: {describe(obj)}")
        return key

    def add_measurement(self, name: str, h: str, obj: Any, source: str = "") -> Any:
        """Record ``obj`` (stored as file hash ``h``) as a new item; it stays loaded.
        Returns the measurement id (its item key is ``str(id)``)."""
        meta = {"summary": describe(obj)}
        if source:
            meta["made_by"] = source
        try:
            mid = self.project.add_measurement(name, h, kind_of(obj), meta=meta)
        except TypeError:  # a store without meta
            mid = self.project.add_measurement(name, h, kind_of(obj))
        self._objects[str(mid)] = obj
        return mid

    def measurement(self, key: Any) -> dict[str, Any] | None:
        """The project's record of item ``key`` (``id``, ``name``, ``kind`` ...), or None."""
        return None if key is None else self._measurements.get(str(key))

    def import_file(self, source: str | Path | bytes, name: str | None = None) -> str | None:
        """Import a file into the project and show it. Returns the new item's id, or
        None after showing the reason it could not be imported."""
        label = name or (Path(source).name if isinstance(source, (str, Path)) else "upload")
        self.state.importing = True
        path = None
        try:
            path, obj, label = self.read_file(source, name)
            return self._register(path, obj, label)
        except Exception as exc:
            self.error(self._import_reason(exc, label, source))
            return None
        finally:
            self.state.importing = False
            self.drop_upload(source)

    async def import_file_async(self, source: str | Path | bytes, name: str | None = None) -> str | None:
        """As :meth:`import_file`, reading in a worker thread so the page stays live."""
        label = name or (Path(source).name if isinstance(source, (str, Path)) else "upload")
        if self._loop is None:
            self.bind_loop()
        self.state.importing = True
        self.clear_error()
        self.info(f"reading {label} …")
        self.flush()
        try:
            path, obj, label = await asyncio.get_running_loop().run_in_executor(
                self._executor, self.read_file, source, name)
            return self._register(path, obj, label)
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
        msg = self._reason(exc, label)
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

    def select_item(self, key: str | None) -> None:
        """Show an item in the 3D view, keeping the chosen colouring when it exists."""
        if key is None:
            return
        key = str(key)
        try:
            obj = self.load(key)
        except Exception as exc:
            name = self._measurements.get(key, {}).get("name", key)
            self.error(self._reason(exc, str(name)))
            return
        self.state.selected_item = key
        self._remember("gui.selected_item", key)
        k = kind_of(obj)
        if k not in ("pointcloud", "mesh"):
            self.view.clear()
            self.state.color_fields = []
            self.state.color_field = None
            self.state.legend_title = ""
            self.state.display_note = f"{describe(obj)} (not shown in the 3D view)"
        else:
            fields = color_fields(obj)
            keep = self.state.color_field
            wanted = keep if keep in {f["value"] for f in fields} else None
            try:
                self.view.show(key, obj, wanted)
            except Exception as exc:
                self.error(self._reason(exc, getattr(obj, "name", key)))
                return
            self.state.color_fields = fields
            self.state.color_field = self.view.field
            self.state.legend_title = self.view.scalar_bar_title
            self.state.display_note = self.view.note
        self.refresh_items()

    def set_color_field(self, name: str | None) -> None:
        if not name or self.view.shown is None or name == self.view.field and self.state.color_field == name:
            return
        try:
            self.view.set_field(name)
        except Exception as exc:
            self.error(f"colouring by {name!r} failed: {exc}")
            return
        self.state.color_field = self.view.field
        self.state.legend_title = self.view.scalar_bar_title
        self._remember("gui.color_field", self.view.field)

    def _remember(self, key: str, value: Any) -> None:
        """Keep a view setting in the project so that reopening it shows the same."""
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
            self.select_item(str(key))

    # -- plugins -----------------------------------------------------------------------
    def refresh_plugins(self) -> None:
        try:
            specs = self.host.check()
        except Exception as exc:
            self.error(f"plugin discovery failed: {exc}")
            specs = []
        rows = []
        for s in specs:
            ok = s.status == "ok"
            rows.append({"id": s.id, "name": s.name, "kind": s.kind, "version": s.version, "status": s.status,
                         "ok": ok, "summary": s.summary, "runnable": ok and s.kind in ("algorithm", "standard")})
        self.state.plugins = rows

    def select_plugin(self, plugin_id: str | None) -> None:
        """Build the form of an algorithm or standard plugin from its manifest."""
        if not plugin_id:
            self.state.selected_plugin = None
            return
        try:
            spec = self.host.get(plugin_id)
        except CamcmmError as exc:
            self.error(str(exc))
            return
        if spec.kind == "device":
            self.error(f"plugin {plugin_id!r} is a device; devices are connected, not run from a form")
            return
        if spec.status != "ok":
            self.error(f"plugin {plugin_id!r} cannot be used: {spec.status}")
            return
        fields, values = [], {}
        for f in form_schema(spec.parameters):
            d = {k: to_jsonable(v) for k, v in f.items()}
            d["unit"] = f.get("unit", "")
            d["min"] = f.get("min")
            d["max"] = f.get("max")
            d["choices"] = list(f.get("choices") or [])
            d["help"] = f.get("help", "")
            default = f.get("default")
            if f["widget"] == "switch":
                values[f["name"]] = bool(default)
            elif default is None:
                values[f["name"]] = ""
            elif f["type"] == "vector":
                values[f["name"]] = ", ".join(fmt_value(x) for x in default)
            else:
                values[f["name"]] = to_jsonable(default)
            d["label"] = f["label"] if f.get("required") is not True else f["label"] + " *"
            fields.append(d)
        self.state.selected_plugin = spec.id
        self.state.plugin_title = f"{spec.name} ({spec.id} {spec.version})"
        self.state.plugin_summary = spec.summary
        self.state.form_fields = fields
        self.state.form_values = values
        self._refresh_form_inputs(reset=True)

    def _refresh_form_inputs(self, reset: bool = False) -> None:
        pid = self.state.selected_plugin
        if not pid:
            self.state.form_inputs = []
            return
        try:
            spec = self.host.get(pid)
        except CamcmmError:
            self.state.form_inputs = []
            return
        items = self.state.items or []
        current = {} if reset else dict(self.state.input_values or {})
        inputs, values = [], {}
        for port in spec.inputs:
            kinds = _ITEM_TYPES.get(port.type)
            entry = {"name": port.name, "type": port.type, "optional": port.optional,
                     "label": f"{port.name} ({port.type})" + ("" if port.optional else " *"),
                     "help": port.help, "supported": kinds is not None, "options": []}
            if kinds is not None:
                opts = [{"title": it["name"], "value": it["id"]} for it in items if it["kind"] in kinds]
                entry["options"] = opts
                ids = [o["value"] for o in opts]
                chosen = current.get(port.name)
                if chosen not in ids:
                    sel = self.state.selected_item
                    chosen = sel if sel in ids else (ids[-1] if ids and not port.optional else None)
                values[port.name] = chosen
            else:
                values[port.name] = current.get(port.name, "")
            inputs.append(entry)
        self.state.form_inputs = inputs
        self.state.input_values = values

    def _prepare_run(self, plugin_id: str, params: dict[str, Any] | None,
                     inputs: dict[str, Any] | None) -> tuple[Any, dict, dict, list]:
        spec = self.host.get(plugin_id)
        if spec.kind == "device":
            raise PluginError(f"plugin {plugin_id!r} is a device; devices are connected, not run")
        declared = {p.name: p for p in spec.parameters}
        raw = {}
        for k, v in (params or {}).items():
            p = declared.get(k)
            if p is not None and p.type != "str" and (v is None or (isinstance(v, str) and v.strip() == "")):
                continue  # an empty field means "use the default"
            raw[k] = v
        values = validate(spec.parameters, raw, owner=f"plugin {plugin_id!r}")
        chosen = dict(self.state.input_values or {})
        chosen.update(inputs or {})
        objs, mids = {}, []
        for port in spec.inputs:
            key = chosen.get(port.name)
            if port.type in _ITEM_TYPES:
                if key in (None, ""):
                    if port.optional:
                        continue
                    raise PluginError(f"plugin {plugin_id!r} needs input {port.name!r} ({port.type}): "
                                      "import a file or choose an item")
                obj = self.load(str(key))
                if kind_of(obj) not in _ITEM_TYPES[port.type]:
                    raise PluginError(f"plugin {plugin_id!r}: input {port.name!r} must be a {port.type}, "
                                      f"item {getattr(obj, 'name', key)!r} is a {kind_of(obj)}")
                objs[port.name] = obj
                mids.append(self._measurements[str(key)]["id"])
            elif key not in (None, ""):
                objs[port.name] = key
            elif not port.optional:
                raise PluginError(f"plugin {plugin_id!r} needs input {port.name!r} ({port.type}), "
                                  "which this form cannot provide yet; use the CLI")
        return spec, values, objs, mids

    def _begin_run(self, plugin_id: str) -> threading.Event:
        self._cancel = threading.Event()
        self._last_progress = 0.0
        s = self.state
        s.running = True
        s.progress = 0.0
        s.progress_message = f"running {plugin_id} …"
        s.result = None
        s.result_rows = []
        s.result_warnings = []
        s.result_title = ""
        self.clear_error()
        return self._cancel

    def _set_progress(self, fraction: float, message: str) -> None:
        self.state.progress = round(100.0 * float(fraction), 1)
        if message:
            self.state.progress_message = message

    def _progress_cb(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last_progress < 0.1:
            return  # at most ten updates a second reach the page
        self._last_progress = now
        self.post(self._set_progress, fraction, message)

    def cancel_run(self) -> None:
        if self._cancel is not None:
            self._cancel.set()
            self.state.progress_message = "cancelling …"

    def run_plugin(self, plugin_id: str, params: dict[str, Any] | None = None,
                   inputs: dict[str, Any] | None = None) -> RunResult | None:
        """Run a plugin in the calling thread; progress and result go to the state and
        the result into the project. Returns the RunResult, or None after an error."""
        try:
            spec, values, objs, mids = self._prepare_run(plugin_id, params, inputs)
        except Exception as exc:
            self.error(self._reason(exc, ""))
            return None
        cancel = self._begin_run(plugin_id)
        try:
            result = worker.run(self.host, plugin_id, objs, values, progress=self._progress_cb, cancel=cancel)
        except Exception as exc:
            self._run_failed(plugin_id, exc)
            return None
        return self._run_done(spec, result, mids, objs)

    async def run_plugin_async(self, plugin_id: str, params: dict[str, Any] | None = None,
                               inputs: dict[str, Any] | None = None) -> RunResult | None:
        """As :meth:`run_plugin`, computing in a worker thread while the page stays live."""
        if self._loop is None:
            self.bind_loop()
        if self.state.running:
            self.error("a plugin is already running; wait for it or cancel it")
            return None
        try:
            spec, values, objs, mids = self._prepare_run(plugin_id, params, inputs)
        except Exception as exc:
            self.error(self._reason(exc, ""))
            return None
        cancel = self._begin_run(plugin_id)
        self.flush()
        loop = asyncio.get_running_loop()
        try:
            result = await loop.run_in_executor(
                self._executor,
                lambda: worker.run(self.host, plugin_id, objs, values, progress=self._progress_cb, cancel=cancel))
        except Exception as exc:
            self._run_failed(plugin_id, exc)
            self.flush()
            return None
        out = self._run_done(spec, result, mids, objs)
        self.flush()
        return out

    def _run_failed(self, plugin_id: str, exc: BaseException) -> None:
        self.state.running = False
        self.state.progress_message = "failed"
        msg = self._reason(exc, "")
        if plugin_id not in msg:
            msg = f"plugin {plugin_id!r}: {msg}"
        self.error(msg)

    def _run_done(self, spec: Any, result: RunResult, mids: list, objs: dict[str, Any]) -> RunResult:
        s = self.state
        self.last_result = result
        warnings = list(result.warnings)
        try:
            self.last_result_id = self.project.add_result(result, measurement_ids=mids, files={})
        except Exception as exc:
            self.error(f"result of {spec.id} could not be stored in the project: {self._reason(exc, '')}")
        new_keys = self._store_outputs(spec, result, objs, warnings)
        rows = result_rows(result.outputs, {p.name: p.unit for p in spec.outputs})
        s.result = summarize_json(result.to_json())
        s.result_title = f"{spec.name} — {spec.id} {result.plugin_version}"
        s.result_rows = rows
        s.result_warnings = warnings
        s.running = False
        s.progress = 100.0
        s.progress_message = "done"
        self.refresh_results()
        if new_keys:
            self.select_item(new_keys[-1])
        self.info(f"{spec.id} finished" + (f"; added {len(new_keys)} item(s)" if new_keys else ""))
        return result

    def _store_outputs(self, spec: Any, result: RunResult, objs: dict[str, Any], warnings: list[str]) -> list[str]:
        """Clouds and meshes among the outputs become new items; per-point arrays of a
        cloud input become a coloured copy of that cloud (a deviation map)."""
        from ..model import PointCloud

        found: list[tuple[str, Any]] = []
        for name, value in result.outputs.items():
            if kind_of(value) in ("pointcloud", "mesh"):
                found.append((name, value))
            elif isinstance(value, dict):
                found += [(f"{name}.{k}", v) for k, v in value.items() if kind_of(v) in ("pointcloud", "mesh")]
        base = next((o for o in objs.values() if kind_of(o) == "pointcloud"), None)
        if not found and base is not None:
            units = {p.name: p.unit for p in spec.outputs}
            fields, field_units = dict(base.fields), dict(base.field_units)
            for name, value in result.outputs.items():
                if isinstance(value, np.ndarray) and value.ndim == 1 and len(value) == base.n_points \
                        and value.dtype.kind in "iuf":
                    fields[name] = value.astype(float)
                    field_units[name] = units.get(name, "")
            if len(fields) > len(base.fields):
                found.append(("fields", PointCloud(base.points, base.colors, base.normals, fields, field_units,
                                                   base.name, base.source_unit)))
        keys = []
        in_name = next((getattr(o, "name", "") for o in objs.values() if getattr(o, "name", "")), "")
        for label, obj in found:
            own = str(getattr(obj, "name", "") or "")
            name = own if own and own != in_name and own not in ("cloud", "mesh") else \
                f"{spec.id} {label}" + (f" of {in_name}" if in_name else "")
            try:
                h = self.project.add_object(obj, name)
                mid = self.add_measurement(name, h, obj, source=f"{spec.id} {result.plugin_version}")
            except Exception as exc:
                warnings.append(f"output {label!r} could not be stored: {self._reason(exc, '')}")
                continue
            key = str(mid)
            self._objects[key] = obj
            self._summary[key] = f"{kind_of(obj)} · {describe(obj)}"
            keys.append(key)
        if keys:
            self.refresh_items()
        return keys

    def refresh_results(self) -> None:
        try:
            rows = list(self.project.results())
        except Exception as exc:
            self.error(f"project {self.state.project_name}: cannot list results: {exc}")
            rows = []
        out = []
        for r in rows[-50:]:
            d = r if isinstance(r, dict) else {}
            out.append({"id": str(d.get("id", "")), "plugin": str(d.get("plugin", d.get("plugin_id", ""))),
                        "time": str(d.get("finished", d.get("created", "")))})
        self.state.results = list(reversed(out))

    def show_result(self, rid: Any) -> None:
        """Show a stored result (from the project) in the result panel."""
        try:
            d = self.project.result(int(rid))
        except Exception as exc:
            self.error(f"result {rid}: {self._reason(exc, '')}")
            return
        plugin = str(d.get("plugin", ""))
        units: dict[str, str] = {}
        try:
            units = {p.name: p.unit for p in self.host.get(plugin).outputs}
        except CamcmmError:
            pass
        outputs = d.get("outputs") or {}
        self.state.result = summarize_json(d)
        self.state.result_title = f"result #{rid}: {plugin} {d.get('version', '')} ({d.get('finished', '')})"
        self.state.result_rows = result_rows(outputs, units)
        self.state.result_warnings = list(d.get("warnings") or [])

    # -- shutdown -----------------------------------------------------------------------
    def close(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)
        shutil.rmtree(self._tmp, ignore_errors=True)
        try:
            self.view.plotter.close()
        except Exception:
            pass
