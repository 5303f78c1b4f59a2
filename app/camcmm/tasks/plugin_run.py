"""Run any algorithm plugin from its declared form, headless: what the Inspect page's Run
does, without trame.

    request = PluginRunRequest("fit.sphere", inputs={"cloud": "3"}, params={"radius": ""})
    checked = check(host, request, items)        # one-line refusal: a missing input, a bad value
    result = run(host, checked, progress, cancel) # through camcmm.worker.run
    stored = store(project, items, checked, result)   # result row + the clouds/meshes it made
    row = stored_row(project, stored.result_id)  # a stored result again (RunResult.to_json() form)

``items`` is anything with the GUI session's item interface (``measurement``, ``load``,
``add_measurement``): the session behind the page, or
:class:`~camcmm.tasks.items.ProjectItems` on a bare project. A form's values are text as
typed: an empty field means the plugin's default. The plugin is any: no output contract
(what the page shows is every output, by the plugin's own declaration).

Nothing here imports the GUI, trame or VTK.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import worker
from ..errors import CamcmmError, InputError, PluginError, one_line
from ..host import RunResult
from ..params import validate
from .items import kind_of

#: Input port types the form can fill from the project's items: port type -> item kinds.
ITEM_TYPES = {"pointcloud": ("pointcloud",), "mesh": ("mesh",), "geometry": ("pointcloud", "mesh"), "image": ("image",)}


# ------------------------------------------------------------------------------ the request
@dataclass
class PluginRunRequest:
    """A run of plugin ``plugin``: ``inputs`` port -> item key (an item port) or value (a
    path, a text), ``params`` the form's values by parameter name (text as typed)."""

    plugin: str
    inputs: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class Checked:
    """A request made ready: the plugin's manifest ``spec``, the validated ``values``, the
    input objects ``objs`` by port and the ids of the items used (``mids``)."""

    request: PluginRunRequest
    spec: Any
    values: dict[str, Any]
    objs: dict[str, Any]
    mids: list[Any]


@dataclass
class Made:
    """An item a run made: the output's ``label``, the item's ``name`` and ``key``, and the
    length fields it added with their display unit (``{"residual": "µm"}``)."""

    label: str
    name: str
    key: str
    fields: dict[str, str]


@dataclass
class StoredRun:
    """What :func:`store` kept: the result id (None when the row could not be added:
    ``error`` says why), the items made, and the run's warnings (plus any output that could
    not be stored)."""

    result_id: Any
    made: list[Made]
    warnings: list[str]
    error: str = ""

    @property
    def made_names(self) -> dict[str, str]:
        """``{output label: item name}`` (the report rows link them)."""
        return {m.label: m.name for m in self.made}


# ------------------------------------------------------------------------------ checks
def checked_params(spec: Any, params: dict[str, Any]) -> dict[str, Any]:
    """The parameters checked by their declaration (an empty field means the default)."""
    declared = {p.name: p for p in spec.parameters}
    raw = {}
    for k, v in params.items():
        p = declared.get(k)
        if p is not None and p.type != "str" and (v is None or (isinstance(v, str) and v.strip() == "")):
            continue
        raw[k] = v
    return validate(spec.parameters, raw, owner=f"plugin {spec.id!r}")


def run_blocker(spec: Any, params: dict[str, Any], chosen: dict[str, Any], items: list[dict[str, Any]]) -> str:
    """Why a run of ``spec`` with these form values cannot start, in one line ("" when
    it can): a missing or unknown input item, or a parameter its declaration refuses.
    ``items``: the listed items ``[{id, kind}]``. Cheap (no item is loaded): the page shows
    it next to Run as the user edits."""
    try:
        checked_params(spec, params)
    except Exception as exc:
        return one_line(exc)
    kinds_of = {str(it["id"]): it["kind"] for it in items}
    for port in spec.inputs:
        key = chosen.get(port.name)
        if port.type not in ITEM_TYPES:
            if key in (None, "") and not port.optional:
                return f"input {port.name!r} ({port.type}) is needed: type its path"
            continue
        if key in (None, ""):
            if not port.optional:
                return f"input {port.name!r} ({port.type}) is needed: import a file or choose an item"
            continue
        if str(key) not in kinds_of:
            return f"input {port.name!r}: item {key!r} is not in the project (deleted or hidden?)"
        if kinds_of[str(key)] not in ITEM_TYPES[port.type]:
            return f"input {port.name!r} must be a {port.type}, the chosen item is a {kinds_of[str(key)]}"
    return ""


def run_arguments(
    spec: Any,
    params: dict[str, Any],
    chosen: dict[str, Any],
    load: Callable[[str], Any],
    record: Callable[[str], dict | None],
) -> tuple[dict[str, Any], dict[str, Any], list]:
    """``(values, inputs, measurement_ids)`` of a run: the parameters checked by their
    declaration (an empty field means the default), the input objects (items loaded
    with ``load(key)``, other ports as given) and the ids of the items used
    (``record(key)["id"]``). Raises a one-line :class:`~camcmm.errors.CamcmmError`."""
    pid = spec.id
    if spec.kind == "device":
        raise PluginError(f"plugin {pid!r} is a device; devices are connected, not run")
    values = checked_params(spec, params)
    objs, mids = {}, []
    for port in spec.inputs:
        key = chosen.get(port.name)
        if port.type in ITEM_TYPES:
            if key in (None, ""):
                if port.optional:
                    continue
                raise PluginError(
                    f"plugin {pid!r} needs input {port.name!r} ({port.type}): import a file or choose an item"
                )
            obj = load(str(key))
            if kind_of(obj) not in ITEM_TYPES[port.type]:
                raise PluginError(
                    f"plugin {pid!r}: input {port.name!r} must be a {port.type}, "
                    f"item {getattr(obj, 'name', key)!r} is a {kind_of(obj)}"
                )
            objs[port.name] = obj
            mids.append((record(str(key)) or {}).get("id", key))
        elif key not in (None, ""):
            objs[port.name] = key
        elif not port.optional:
            raise PluginError(
                f"plugin {pid!r} needs input {port.name!r} ({port.type}), "
                "which this form cannot provide yet; use the CLI"
            )
    return values, objs, mids


def runnable(host: Any, plugin_id: Any) -> Any:
    """The manifest of ``plugin_id`` if a form can run it; a one-line CamcmmError otherwise
    (none chosen, not installed, a device, a plugin that failed to load)."""
    if not plugin_id or not isinstance(plugin_id, str):
        raise InputError("choose a plugin first")
    spec = host.get(plugin_id)
    if spec.kind == "device":
        raise PluginError(f"plugin {plugin_id!r} is a device; devices are connected, not run from a form")
    if spec.status != "ok":
        raise PluginError(f"plugin {plugin_id!r} cannot be used: {spec.status}")
    return spec


def listed_items(items: Any, chosen: dict[str, Any]) -> list[dict[str, Any]]:
    """``[{id, kind}]`` of the chosen items ``items`` knows (what a form lists)."""
    out = []
    for key in chosen.values():
        if key in (None, "") or not isinstance(key, (str, int)):
            continue
        m = items.measurement(str(key))
        if m is not None:
            out.append({"id": str(key), "kind": str(m.get("kind") or "")})
    return out


def check(
    host: Any,
    request: PluginRunRequest,
    items: Any,
    listed: list[dict[str, Any]] | None = None,
    screen: bool = True,
) -> Checked:
    """``request`` made ready to run: the plugin runnable, its parameters valid, every
    needed input chosen, in the project and of its kind (``listed``: the items the form
    lists, ``[{id, kind}]``; by default the chosen ones ``items`` knows), the items loaded.
    A one-line :class:`~camcmm.errors.CamcmmError` — the refusal the page shows — otherwise.
    ``screen=False``: the form's screening (:func:`runnable`, :func:`run_blocker`) is taken
    as done, only the run's arguments are made (what a caller that screened already does)."""
    params, chosen = dict(request.params or {}), dict(request.inputs or {})
    if screen:
        spec = runnable(host, request.plugin)
        reason = run_blocker(spec, params, chosen, listed_items(items, chosen) if listed is None else listed)
        if reason:
            raise InputError(reason)
    else:
        spec = host.get(request.plugin)
    values, objs, mids = run_arguments(spec, params, chosen, items.load, items.measurement)
    return Checked(request, spec, values, objs, mids)


# ------------------------------------------------------------------------------ the run
def run(
    host: Any,
    checked: Checked,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> RunResult:
    """The plugin's run (in a worker process when the host allows); ``cancel`` set stops it
    with :class:`~camcmm.host.Cancelled`."""
    return worker.run(host, checked.spec.id, checked.objs, checked.values, progress=progress, cancel=cancel)


# ------------------------------------------------------------------------------ new items
def _with_fields(spec: Any, result: RunResult, base: Any) -> Any | None:
    """A copy of the cloud ``base`` with each per-point numeric output (length
    ``base.n_points``) as a colour field in its declared unit; None if there is none."""
    from ..model import PointCloud

    units = {p.name: p.unit for p in spec.outputs}
    fields, field_units = dict(base.fields), dict(base.field_units)
    for name, value in result.outputs.items():
        if (
            isinstance(value, np.ndarray)
            and value.ndim == 1
            and len(value) == base.n_points
            and value.dtype.kind in "iuf"
        ):
            fields[name] = value.astype(float)
            field_units[name] = units.get(name, "")
    if len(fields) == len(base.fields):
        return None
    return PointCloud(base.points, base.colors, base.normals, fields, field_units, base.name, base.source_unit)


def derived_name(own: str, in_name: str, fallback: str, taken: set[str]) -> str:
    """The name of an item a run made: the output's own name unless it only repeats the
    input's, with a word the input's name already ends in said once ("ball deviations"
    fitted again gives "ball deviations", not "ball deviations deviations"), and a
    number when the project already has that name ("ball deviations (2)")."""
    name = own if own and own != in_name and own not in ("cloud", "mesh") else fallback
    name = re.sub(r"\b(\w+)(?: \1\b)+", r"\1", " ".join(name.split()))
    base, n = name, 2
    while name in taken:
        name, n = f"{base} ({n})", n + 1
    return name


def new_items(
    spec: Any, result: RunResult, inputs: dict[str, Any], taken: set[str] | None = None
) -> list[tuple[str, str, Any]]:
    """``[(output label, item name, object)]``: the clouds and meshes among the outputs (one level
    into dicts), or else a coloured copy of the input cloud (a deviation map). ``taken``:
    the names the project's items have (a new name does not repeat one)."""
    found: list[tuple[str, Any]] = []
    for name, value in result.outputs.items():
        if kind_of(value) in ("pointcloud", "mesh"):
            found.append((name, value))
        elif isinstance(value, dict):
            found += [(f"{name}.{k}", v) for k, v in value.items() if kind_of(v) in ("pointcloud", "mesh")]
    base = next((o for o in inputs.values() if kind_of(o) == "pointcloud"), None)
    if not found and base is not None:
        coloured = _with_fields(spec, result, base)
        if coloured is not None:
            found.append(("fields", coloured))
    in_name = next((getattr(o, "name", "") for o in inputs.values() if getattr(o, "name", "")), "")
    out, names = [], set(taken or ())
    for label, obj in found:
        fallback = f"{spec.id} {label}" + (f" of {in_name}" if in_name else "")
        name = derived_name(str(getattr(obj, "name", "") or ""), in_name, fallback, names)
        names.add(name)
        out.append((label, name, obj))
    return out


def residual_fields(obj: Any, inputs: dict[str, Any]) -> dict[str, str]:
    """The length fields (unit mm) a run added to a cloud, i.e. not on its input cloud
    (a fit's residuals, a comparison's deviations), each with the unit the view shows
    it in: µm when every value lies within ±1 mm, else mm. First the one to colour by."""
    if not hasattr(obj, "fields"):
        return {}
    had = set()
    for o in inputs.values():
        had |= set(getattr(o, "fields", {}) or {})
    out = {}
    for name, values in obj.fields.items():
        if name in had or (obj.field_units or {}).get(name) != "mm":
            continue
        a = np.asarray(values, dtype=float)
        finite = a[np.isfinite(a)]
        out[name] = "µm" if finite.size and float(np.abs(finite).max()) < 1.0 else "mm"
    return out


# ------------------------------------------------------------------------------ the project
def _taken(project: Any) -> set[str]:
    try:
        return {str(m.get("name")) for m in project.measurements()}
    except Exception:
        return set()


def store(project: Any, items: Any, checked: Checked, result: RunResult, taken: set[str] | None = None) -> StoredRun:
    """The run into ``project``: its row (``RunResult.to_json()``) linked to the items used,
    and each cloud or mesh it made (:func:`new_items`) as a file and a new item of ``items``
    named after the plugin's version. ``taken``: the item names in use (default: the
    project's). A row or an output that cannot be stored is said (``error``, ``warnings``),
    not raised: the run is done and shown all the same."""
    spec, warnings = checked.spec, list(result.warnings)
    rid, error = None, ""
    try:
        rid = project.add_result(result, measurement_ids=checked.mids, files={})
    except Exception as exc:
        error = f"result of {spec.id} could not be stored in the project: {one_line(exc)}"
    made: list[Made] = []
    names = _taken(project) if taken is None else taken
    for label, name, obj in new_items(spec, result, checked.objs, names):
        fields = residual_fields(obj, checked.objs)
        try:
            h = project.add_object(obj, name)
            source = f"{spec.id} {result.plugin_version}"
            key = str(items.add_measurement(name, h, obj, source=source, display=fields))
            made.append(Made(label, name, key, fields))
        except Exception as exc:
            warnings.append(f"output {label!r} could not be stored: {one_line(exc)}")
    return StoredRun(rid, made, warnings, error)


def stored_row(project: Any, rid: Any) -> dict[str, Any]:
    """Result ``rid`` as the project keeps it (``RunResult.to_json()`` plus its id, links and
    files); a one-line error when there is none."""
    try:
        return project.result(int(rid))
    except CamcmmError:
        raise
    except (TypeError, ValueError) as exc:
        raise InputError(f"result {rid!r}: not a result id") from exc


def restore(project: Any, rid: Any) -> RunResult:
    """Result ``rid`` back as a run (outputs as JSON; geometry as the files it made)."""
    return RunResult.from_json(stored_row(project, rid))


def spec_of(host: Any, plugin_id: str) -> Any:
    """The manifest of the plugin that made a stored result (None: no longer installed)."""
    try:
        return host.get(plugin_id)
    except CamcmmError:
        return None


# ------------------------------------------------------------------------------ the task object
class PluginRunTask:
    """The steps above bound to a ``host``, the project's ``items`` and the ``project``:
    what the Inspect page holds."""

    def __init__(self, host: Any, items: Any, project: Any):
        self.host, self.items, self.project = host, items, project

    def check(
        self, request: PluginRunRequest, listed: list[dict[str, Any]] | None = None, screen: bool = True
    ) -> Checked:
        return check(self.host, request, self.items, listed, screen)

    def run(
        self,
        checked: Checked,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> RunResult:
        return run(self.host, checked, progress=progress, cancel=cancel)

    def store(self, checked: Checked, result: RunResult, taken: set[str] | None = None) -> StoredRun:
        return store(self.project, self.items, checked, result, taken)

    def stored(self, rid: Any) -> dict[str, Any]:
        return stored_row(self.project, rid)

    def restore(self, rid: Any) -> RunResult:
        return restore(self.project, rid)
