"""The plugin host: discovers plugins, reports their status, runs them.

Discovery reads each package's manifest (see :mod:`camcmm.manifest`) through the
entry-point group ``camcmm.plugins`` without importing the plugin code. A plugin's code
is imported when it is first used or checked; a failure is recorded as its status and
never stops the host. Built-in plugins are found exactly like a lab's.
"""

from __future__ import annotations

import importlib
import importlib.metadata as md
import importlib.resources
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import contracts
from .errors import CamcmmError, InputError, PluginError
from .hashing import file_hash, object_hash
from .jsonable import to_jsonable, utc_now
from .manifest import CommandSpec, PluginSpec, parse_manifest
from .params import validate

GROUP = "camcmm.plugins"

ProgressCallback = Callable[[float, str], None]


class Cancelled(CamcmmError):
    """The run was cancelled by the operator."""


class RunContext:
    """What a running plugin gets from the host.

    ``progress(fraction, message)`` reports 0..1 progress; ``warn(text)`` records a
    warning in the result; ``algorithm(id)`` gives another plugin as a callable (so a
    standard asks for "fit.sphere" and a lab can substitute its own); ``cancelled`` is
    true once the operator asked to stop (long loops should check it).
    """

    def __init__(
        self,
        host: PluginHost,
        plugin_id: str,
        progress: ProgressCallback | None = None,
        cancel: threading.Event | None = None,
    ):
        self.host = host
        self.plugin_id = plugin_id
        self.warnings: list[str] = []
        self._progress = progress
        self._cancel = cancel or threading.Event()

    def progress(self, fraction: float, message: str = "") -> None:
        if self._cancel.is_set():
            raise Cancelled(f"{self.plugin_id}: cancelled")
        if self._progress is not None:
            self._progress(min(max(float(fraction), 0.0), 1.0), message)

    def warn(self, text: str) -> None:
        self.warnings.append(" ".join(str(text).split()))

    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    def algorithm(self, plugin_id: str) -> Callable[..., dict[str, Any]]:
        return self.host.algorithm(plugin_id, parent=self)


@dataclass
class RunResult:
    """A plugin run with its provenance: plugin id and version, the validated
    parameters, the hashes of the inputs and the times (UTC, ISO 8601)."""

    plugin_id: str
    plugin_version: str
    params: dict[str, Any]
    input_hashes: dict[str, str]
    outputs: dict[str, Any]
    started: str
    finished: str
    warnings: list[str] = field(default_factory=list)

    def provenance(self) -> dict[str, Any]:
        """Who made the result and from what: the ``plugin`` block of a command's JSON."""
        return {
            "id": self.plugin_id,
            "version": self.plugin_version,
            "params": self.params,
            "input_hashes": self.input_hashes,
            "started": self.started,
            "finished": self.finished,
        }

    @classmethod
    def from_json(cls, row: dict[str, Any]) -> RunResult:
        """The run back from its stored row (:meth:`to_json`; a project's result ``run``):
        outputs as JSON, geometry as the store keeps it (files), not objects."""
        return cls(
            str(row.get("plugin") or ""),
            str(row.get("version") or ""),
            dict(row.get("params") or {}),
            dict(row.get("input_hashes") or {}),
            dict(row.get("outputs") or {}),
            str(row.get("started") or ""),
            str(row.get("finished") or ""),
            [str(w) for w in row.get("warnings") or []],
        )

    def to_json(self) -> dict[str, Any]:
        """The stored row of the run: the one record of a result (project, CLI JSON, demo)."""
        return {
            "plugin": self.plugin_id,
            "version": self.plugin_version,
            "params": self.params,
            "input_hashes": self.input_hashes,
            "outputs": to_jsonable(self.outputs),
            "started": self.started,
            "finished": self.finished,
            "warnings": self.warnings,
        }


def _import_entry(entry: str) -> Any:
    module, _, attr = entry.partition(":")
    obj = importlib.import_module(module)
    for part in attr.split(".") if attr else []:
        obj = getattr(obj, part)
    return obj


class PluginHost:
    """Finds and runs plugins. ``entry_points`` may be given for tests; by default
    the installed distributions' ``camcmm.plugins`` entry points are read."""

    def __init__(self, entry_points: list[md.EntryPoint] | None = None):
        self.plugins: dict[str, PluginSpec] = {}
        self.commands: dict[str, CommandSpec] = {}
        self.errors: list[PluginSpec] = []
        self._loaded: dict[str, Any] = {}
        self._lock = threading.Lock()
        # kept so that a worker process can build the same host (camcmm.worker); None: installed
        self.entry_points = None if entry_points is None else list(entry_points)
        eps = md.entry_points(group=GROUP) if self.entry_points is None else self.entry_points
        for ep in sorted(eps, key=lambda e: e.name):
            self._read(ep)

    # -- discovery -----------------------------------------------------------------
    def _read(self, ep: md.EntryPoint) -> None:
        d = getattr(ep, "dist", None)
        dist = d.name if d is not None else ep.name
        version = d.version if d is not None else "0"
        where = f"plugin package {ep.name!r} ({ep.value})"
        try:
            package, _, resource = ep.value.partition(":")
            text = importlib.resources.files(package).joinpath(resource or "plugin.yaml").read_text("utf-8")
            plugins, commands, errors = parse_manifest(text, version, dist, where)
        except Exception as exc:  # a broken package must not stop the host
            reason = str(exc) if isinstance(exc, CamcmmError) else f"{where}: {type(exc).__name__}: {exc}"
            self.errors.append(
                PluginSpec(
                    ep.name,
                    "unknown",
                    ep.name,
                    version,
                    "",
                    ep.value,
                    distribution=dist,
                    status=" ".join(reason.split()),
                )
            )
            return
        for spec in plugins:
            if spec.id in self.plugins:
                other = self.plugins[spec.id].distribution
                spec.status = f"duplicate id {spec.id!r}: already provided by {other}"
                self.errors.append(spec)
            else:
                self.plugins[spec.id] = spec
        for pid, reason in errors:
            self.errors.append(PluginSpec(pid, "unknown", pid, version, "", "", distribution=dist, status=reason))
        for cmd in commands:
            self.commands.setdefault(cmd.name, cmd)

    def all(self) -> list[PluginSpec]:
        """Every plugin, usable or not, sorted by kind then id."""
        return sorted([*self.plugins.values(), *self.errors], key=lambda s: (s.kind, s.id))

    def get(self, plugin_id: str) -> PluginSpec:
        try:
            return self.plugins[plugin_id]
        except KeyError:
            close = [p for p in self.plugins if plugin_id.split(".")[-1] in p]
            hint = f"; did you mean {', '.join(close[:3])}?" if close else "; the command camcmm plugins lists them"
            raise PluginError(f"no plugin with id {plugin_id!r}{hint}") from None

    def providing(self, task: str) -> list[PluginSpec]:
        """The usable plugins whose manifest declares ``provides: [task, ...]``, by id."""
        return sorted((s for s in self.plugins.values() if task in s.provides), key=lambda s: s.id)

    def provider(self, task: str) -> PluginSpec:
        """The plugin a page or command runs for ``task`` (e.g. ``compare-with-cad``): the
        one declaring it, or, when several do, the first by id that is not a built-in
        (a lab's own replaces camcmm's). PluginError when none is installed."""
        found = self.providing(task)
        if not found:
            raise PluginError(
                f"no plugin provides {task!r}: install one that declares it"
                " (the command camcmm plugins lists what is installed)"
            )
        # the task's output contract (camcmm.contracts), checked on the manifest: a lab's
        # plugin that would not give what the task reads is passed over, and said so
        fit = [s for s in found if not contracts.manifest_problem(s, task)]
        if not fit:
            raise PluginError(contracts.manifest_problem(found[0], task))
        own = [s for s in fit if s.distribution != "camcmm"]
        return (own or fit)[0]

    def load(self, plugin_id: str) -> Any:
        """Import a plugin's entry object; on failure set its status and raise."""
        spec = self.get(plugin_id)
        with self._lock:
            if plugin_id in self._loaded:
                return self._loaded[plugin_id]
            try:
                obj = _import_entry(spec.entry)
            except Exception as exc:
                spec.status = f"import of {spec.entry} failed: {type(exc).__name__}: {exc}".splitlines()[0]
                raise PluginError(f"plugin {plugin_id!r}: {spec.status}") from exc
            self._loaded[plugin_id] = obj
            spec.status = "ok"
            return obj

    def check(self) -> list[PluginSpec]:
        """Import every plugin once so that its status is known; returns :meth:`all`."""
        for pid in list(self.plugins):
            try:
                self.load(pid)
            except PluginError:
                pass
        return self.all()

    # -- running ---------------------------------------------------------------------
    def run(
        self,
        plugin_id: str,
        inputs: dict[str, Any] | None = None,
        params: dict[str, Any] | None = None,
        progress: ProgressCallback | None = None,
        cancel: threading.Event | None = None,
        context: RunContext | None = None,
    ) -> RunResult:
        """Run an algorithm (or standard) plugin with validated parameters.

        ``inputs`` map declared input names to objects (PointCloud, TriangleMesh, ...)
        or to file paths, which are read here with :func:`camcmm.io.read`.
        """
        spec = self.get(plugin_id)
        if spec.kind == "device":
            raise PluginError(f"plugin {plugin_id!r} is a device; devices are connected, not run")
        values = validate(spec.parameters, params or {}, owner=f"plugin {plugin_id!r}")
        notes: list[str] = []  # e.g. a file with no unit whose size is implausible as mm
        loaded, hashes = self._inputs(spec, inputs or {}, notes)
        fn = self.load(plugin_id)
        ctx = context or RunContext(self, plugin_id, progress, cancel)
        ctx.warnings.extend(notes)
        started = utc_now()
        try:
            outputs = fn(ctx, **loaded, **values)
        except CamcmmError:
            raise
        except Exception as exc:
            # A plugin bug must reach the operator as one line naming the plugin; the
            # traceback goes to the log for the plugin's author.
            last = traceback.extract_tb(exc.__traceback__)[-1]
            raise PluginError(
                f"plugin {plugin_id!r} failed: {type(exc).__name__}: {exc} ({Path(last.filename).name}:{last.lineno})"
            ) from exc
        if not isinstance(outputs, dict):
            raise PluginError(f"plugin {plugin_id!r} returned {type(outputs).__name__}, expected a dict of outputs")
        if context is None:
            ctx.progress(1.0, "done")
        return RunResult(plugin_id, spec.version, values, hashes, outputs, started, utc_now(), ctx.warnings)

    def run_task(
        self,
        task: str,
        inputs: dict[str, Any] | None = None,
        params: dict[str, Any] | None = None,
        progress: ProgressCallback | None = None,
        cancel: threading.Event | None = None,
    ) -> RunResult:
        """Run the plugin that provides ``task`` (:meth:`provider`) and hold its outputs to
        the task's contract (:func:`camcmm.contracts.check_outputs`)."""
        spec = self.provider(task)
        result = self.run(spec.id, inputs, params, progress=progress, cancel=cancel)
        contracts.check_outputs(task, spec.id, result.outputs)
        return result

    def algorithm(self, plugin_id: str, parent: RunContext | None = None) -> Callable[..., dict[str, Any]]:
        """Another plugin as a plain callable ``f(**inputs_and_params) -> outputs``."""
        spec = self.get(plugin_id)
        input_names = {p.name for p in spec.inputs}

        def call(**kwargs: Any) -> dict[str, Any]:
            inputs = {k: v for k, v in kwargs.items() if k in input_names}
            params = {k: v for k, v in kwargs.items() if k not in input_names}
            ctx = RunContext(self, plugin_id)
            result = self.run(plugin_id, inputs, params, context=ctx)
            if parent is not None:
                parent.warnings.extend(f"{plugin_id}: {w}" for w in result.warnings)
            return result.outputs

        call.__name__ = plugin_id
        call.__doc__ = spec.summary
        return call

    def device(self, plugin_id: str, config: dict[str, Any] | None = None, **objects: Any) -> Any:
        """Create a device plugin's object (not connected yet).

        ``config`` (port, address, size ...) is validated against the manifest's
        parameters like a run's parameters; values left unset are not passed, so the
        class's own defaults apply. ``objects`` (other devices, the project, callbacks)
        are passed through as they are.
        """
        spec = self.get(plugin_id)
        if spec.kind != "device":
            raise PluginError(f"plugin {plugin_id!r} is a {spec.kind}, not a device")
        values = validate(spec.parameters, config or {}, owner=f"device {plugin_id!r}")
        kwargs = {k: v for k, v in values.items() if v is not None}
        clash = sorted(set(kwargs) & set(objects))
        if clash:
            raise PluginError(f"device {plugin_id!r}: {clash[0]!r} given both as a setting and as an object")
        cls = self.load(plugin_id)
        try:
            return cls(**kwargs, **objects)
        except CamcmmError:
            raise
        except Exception as exc:
            raise PluginError(f"device {plugin_id!r} could not be created: {type(exc).__name__}: {exc}") from exc

    def _inputs(
        self, spec: PluginSpec, given: dict[str, Any], notes: list[str] | None = None
    ) -> tuple[dict[str, Any], dict[str, str]]:
        declared = {p.name: p for p in spec.inputs}
        unknown = sorted(set(given) - set(declared))
        if unknown:
            raise PluginError(
                f"plugin {spec.id!r} has no input {unknown[0]!r}; inputs: {', '.join(declared) or 'none'}"
            )
        loaded, hashes = {}, {}
        for name, port in declared.items():
            if name not in given or given[name] is None:
                if not port.optional:
                    raise PluginError(f"plugin {spec.id!r} needs input {name!r} ({port.type})")
                continue
            value = given[name]
            if port.max and isinstance(value, (list, tuple)) and len(value) > port.max:
                # before any is read: 10 000 images would take minutes only to be refused later
                raise InputError(
                    f"{spec.id} input {name!r}: {len(value)} {port.type} given; at most {port.max} make one run"
                )
            if isinstance(value, (str, Path)) and port.type not in ("file", "json"):
                read_value = read(value, notes)  # first: a missing or bad file is its one-line InputError
                hashes[name] = file_hash(value)
                value = read_value
            elif (
                isinstance(value, (list, tuple))
                and port.type in ("images", "files")
                and value
                and isinstance(value[0], (str, Path))
            ):
                read_value = [read(v) for v in value] if port.type == "images" else [_existing(v) for v in value]
                hashes[name] = object_hash([file_hash(v) for v in value])
                value = read_value
            elif isinstance(value, (str, Path)):
                path = Path(value)
                hashes[name] = file_hash(path) if path.is_file() else object_hash(str(path))
                value = path
            else:
                hashes[name] = object_hash(value)
            _check_kind(spec.id, port, value, given[name])
            loaded[name] = value
        return loaded, hashes


#: what each geometry or image port accepts (class names of camcmm.model)
_PORT_KINDS = {
    "pointcloud": ("PointCloud",),
    "mesh": ("TriangleMesh",),
    "geometry": ("PointCloud", "TriangleMesh", "CadModel"),  # CadModel: a STEP/IGES nominal (camcmm.cad)
    "image": ("Image",),
}
_KIND_WORDS = {
    "PointCloud": "a point cloud",
    "TriangleMesh": "a triangle mesh",
    "Image": "an image",
    "HeightMap": "a height map",
    "CadModel": "a CAD model",
}


def _check_kind(plugin_id: str, port: Any, value: Any, given: Any) -> None:
    """A file of the wrong kind for a port (a mesh where a cloud is declared) is refused
    here in one line naming the file: inside the plugin it would fail on a missing
    attribute, far from the cause."""
    kinds = _PORT_KINDS.get(port.type)
    values = value if port.type == "images" and isinstance(value, list) else [value]
    names = given if port.type == "images" and isinstance(given, (list, tuple)) else [given]
    kinds = kinds or (("Image",) if port.type == "images" else None)
    if not kinds:
        return
    for v, g in zip(values, names):
        kind = type(v).__name__
        if kind in _KIND_WORDS and kind not in kinds:
            label = g if isinstance(g, (str, Path)) else getattr(v, "name", "")
            src = f"{label}: " if label else ""
            want = " or ".join(_KIND_WORDS[k] for k in kinds)
            raise InputError(f"{src}{plugin_id} input {port.name!r} needs {want}; this is {_KIND_WORDS[kind]}")


def _existing(path: str | Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    return path


def read(path: str | Path, notes: list[str] | None = None) -> Any:
    """Read a file; with ``notes``, add the one-line warning of camcmm.units.decide_unit
    when the file states no unit and its size is implausible as mm (docs/units.md)."""
    from .io import read_stated, unit_decision  # lazy: the file formats pull in Open3D

    obj, stated = read_stated(path)
    if notes is not None and hasattr(obj, "source_unit"):
        check = unit_decision(obj, stated)
        if check.asks:
            notes.append(check.reason)
    return obj


_default: PluginHost | None = None


def default_host() -> PluginHost:
    """The process-wide host over the installed plugins (created on first use)."""
    global _default
    if _default is None:
        _default = PluginHost()
    return _default
