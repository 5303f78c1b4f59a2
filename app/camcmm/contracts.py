"""What a task needs of the plugin that provides it: the output contract.

A page or command runs a task (``compare-with-cad``, ``csi-fusion`` ...) through whichever
plugin provides it, a lab's own replacing the built-in one. What the task then reads of the
outputs (``colour_limit``, ``stats.tolerance``, ``converged``, the ``deviation`` field of the
``deviations`` cloud ...) is declared where the task is (:mod:`camcmm.tasks`), as an
:class:`OutputContract` registered here, below the host, so that the host can hold every
provider to it without knowing the tasks:

- statically, from the manifest (no import): a provider whose declared ``outputs`` lack a
  required one is refused by :meth:`PluginHost.provider` with a one-line reason;
- at run time, on the outputs themselves (:func:`check_outputs`): a missing key, a key path
  into a JSON output, a field of a cloud output, or a value of the wrong kind is a
  :class:`PluginError` naming the plugin and the key, never a KeyError deep in a page.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

from .errors import PluginError

#: what a contracted value must be: its kind name -> the check on the value
_KINDS: dict[str, Any] = {
    "float": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "bool": lambda v: isinstance(v, bool) or type(v).__name__ == "bool_",
    "json": lambda v: isinstance(v, (dict, list)),
    "dict": lambda v: isinstance(v, dict),
    "list": lambda v: isinstance(v, (list, tuple)),
    "str": lambda v: isinstance(v, str),
    "pointcloud": lambda v: hasattr(v, "n_points") and hasattr(v, "points"),
    "mesh": lambda v: hasattr(v, "n_faces"),
    "any": lambda v: True,
}


@dataclass(frozen=True)
class Need:
    """One thing a task reads: ``key`` is an output name or a dotted path into a JSON output
    (``stats.tolerance``); ``kind`` one of float, int, bool, json, dict, list, str,
    pointcloud, mesh, any; ``fields`` the point fields a cloud output must carry;
    ``optional``: read when present (checked for its kind then); ``why`` what uses it."""

    key: str
    kind: str = "any"
    fields: tuple[str, ...] = ()
    optional: bool = False
    why: str = ""

    @property
    def output(self) -> str:
        return self.key.split(".", 1)[0]


@dataclass(frozen=True)
class OutputContract:
    """What ``task`` reads of its provider's outputs (see the module's doc)."""

    task: str
    needs: tuple[Need, ...] = field(default_factory=tuple)

    def required_outputs(self) -> list[str]:
        """The top-level outputs a provider's manifest must declare."""
        return sorted({n.output for n in self.needs if not n.optional})


_lock = threading.Lock()
_contracts: dict[str, OutputContract] = {}


def register(contract: OutputContract) -> OutputContract:
    """Declare ``contract`` for its task (a task module does this at import); returns it."""
    for need in contract.needs:
        if need.kind not in _KINDS:
            raise ValueError(f"contract of {contract.task!r}: unknown kind {need.kind!r} for {need.key!r}")
    with _lock:
        _contracts[contract.task] = contract
    return contract


def contract(task: str) -> OutputContract | None:
    """The registered contract of ``task`` (None: the task reads nothing it must be sure of)."""
    with _lock:
        return _contracts.get(task)


def manifest_problem(spec: Any, task: str) -> str:
    """Why the plugin ``spec`` (its manifest) cannot provide ``task`` under its contract
    ("" when it can): a required output it does not declare."""
    c = contract(task)
    if c is None:
        return ""
    declared = {p.name for p in getattr(spec, "outputs", [])}
    missing = [o for o in c.required_outputs() if o not in declared]
    if not missing:
        return ""
    return (
        f"plugin {spec.id!r} provides {task!r} but its manifest declares no output "
        f"{', '.join(repr(m) for m in missing)}, which the task reads"
    )


def _lookup(outputs: dict[str, Any], key: str) -> tuple[bool, Any]:
    value: Any = outputs
    for part in key.split("."):
        if not isinstance(value, dict) or part not in value:
            return False, None
        value = value[part]
    return True, value


def check_outputs(task: str, plugin_id: str, outputs: dict[str, Any]) -> None:
    """Hold a run's ``outputs`` to the contract of ``task``: PluginError, one line naming the
    plugin, the task and the key, for a missing or mistyped value or a missing cloud field."""
    c = contract(task)
    if c is None:
        return
    for need in c.needs:
        found, value = _lookup(outputs, need.key)
        if not found or value is None:
            if need.optional:
                continue
            raise PluginError(
                f"plugin {plugin_id!r} ran for {task!r} but gave no {need.key!r} ({need.why or 'read by the task'})"
            )
        if not _KINDS[need.kind](value):
            raise PluginError(
                f"plugin {plugin_id!r} ran for {task!r}: {need.key!r} is a {type(value).__name__}, not a {need.kind}"
            )
        if need.fields:
            have = set(getattr(value, "fields", {}) or {})
            lost = [f for f in need.fields if f not in have]
            if lost:
                raise PluginError(
                    f"plugin {plugin_id!r} ran for {task!r}: its {need.key!r} cloud has no field "
                    f"{', '.join(repr(f) for f in lost)}"
                )
