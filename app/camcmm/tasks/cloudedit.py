"""Editing a cloud item: crop (box, plane, lasso), segment (components), remove outliers —
each a new item with its provenance, undoable. Headless: the Inspect page's "Crop &
segment" panel holds a :class:`CloudEdits` and only shows it.

    edits = CloudEdits(host, items, project)
    edit = edits.apply("3", "crop.box", {"min": "0, 0, 0", "max": "10, 10, 5"})
    edit.item, edit.name, edit.n_kept       # "7", "scan · cropped (box)", 12345
    edits.undo()                           # the newest edit's item removed (soft); edit.parent is shown again
    edits.redo()                           # and back

An edit runs its plugin (declared in plugins/camcmm_plugins/cloudtools/plugin.yaml: one
declaration gives the form, ``camcmm run crop.box CLOUD --min .. --max ..`` and the checks)
through :mod:`camcmm.tasks.plugin_run` — the worker process, the parameters checked by the
declaration — and stores:

* the new cloud as a project file and a new item named ``"<parent> · <what>"``
  (``meta.made_by`` = plugin and version, as every derived item; the parent's display
  units kept, so a deviation map stays in µm);
* the run as a result row linked to the parent item (its input) and to the new item's file
  (output ``cloud``): plugin id, version, parameters, counts — :func:`provenance` reads it
  back for any item;
* the edit in the project's state (:data:`HISTORY_KEY`), so Undo works after reopening.

Undo is the project's soft remove (:meth:`~camcmm.project.Project.remove_measurement`:
nothing is lost, ``measurements(include_removed=True)`` still lists it); Redo restores it.
A new edit clears what could be redone. ``items``: the GUI session or
:class:`~camcmm.tasks.items.ProjectItems` (``measurement``, ``load``, ``add_measurement``).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from ..errors import CamcmmError, InputError, one_line
from . import plugin_run
from .items import fmt_count, kind_of

#: The operations a cloud edit runs, and what the new item's name says it did.
OPERATIONS: dict[str, str] = {
    "crop.box": "cropped (box)",
    "crop.plane": "cropped (plane)",
    "crop.lasso": "selection",
    "segment.components": "components",
    "cloud.denoise": "outliers removed",
}
#: Project state key of the edit history: ``{"done": [Edit...], "undone": [Edit...]}``.
HISTORY_KEY = "cloudedit.history"


@dataclass
class Edit:
    """One edit: ``plugin`` run with the checked ``params`` on item ``parent`` gave item
    ``item`` (named ``name``; its file ``hash``), stored as result ``result_id``;
    ``n_kept``/``n_removed`` points; the run's ``warnings``."""

    plugin: str
    params: dict[str, Any]
    parent: str
    item: str
    name: str
    hash: str
    result_id: int | None
    n_kept: int
    n_removed: int
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Edit:
        rid = d.get("result_id")
        return cls(
            str(d["plugin"]),
            dict(d.get("params") or {}),
            str(d["parent"]),
            str(d["item"]),
            str(d.get("name") or ""),
            str(d.get("hash") or ""),
            None if rid is None else int(rid),
            int(d.get("n_kept") or 0),
            int(d.get("n_removed") or 0),
            [str(w) for w in d.get("warnings") or []],
        )

    @property
    def line(self) -> str:
        """One line for the page: what was made and the counts."""
        return f"'{self.name}': kept {fmt_count(self.n_kept)} points, removed {fmt_count(self.n_removed)}"


def label_of(plugin: str, values: dict[str, Any]) -> str:
    """What the new item's name says: ``cropped (box)``, ``selection kept`` ..."""
    if plugin == "crop.lasso":
        return "selection kept" if values.get("keep", "inside") == "inside" else "selection removed"
    if plugin == "segment.components":
        keep = values.get("keep", "largest")
        return {"largest": "largest component", "all": "components"}.get(keep, f"component {values.get('component')}")
    return OPERATIONS[plugin]


def counts(result: Any, before: int) -> tuple[int, int]:
    """``(kept, removed)`` of a run on a cloud of ``before`` points (cloud.denoise reports only what it removed)."""
    out = result.outputs
    kept = int(out["n_kept"]) if "n_kept" in out else int(out["cloud"].n_points)
    return kept, before - kept


def provenance(project: Any, key: Any) -> dict[str, Any] | None:
    """How item ``key`` was made, from the result whose output file is its file:
    ``{result_id, plugin, version, params, parents (item ids), finished}``; None for an
    item no stored run made (an import)."""
    try:
        m = project.measurement(int(str(key)))
    except (CamcmmError, TypeError, ValueError):
        return None
    for r in reversed(project.results()):
        if m["hash"] in (r.get("files") or {}).values():
            return {
                "result_id": r["id"],
                "plugin": r["plugin"],
                "version": r["version"],
                "params": r["params"],
                "parents": [str(i) for i in r.get("measurement_ids") or []],
                "finished": r.get("finished"),
            }
    return None


class CloudEdits:
    """The edits of a project's clouds with their undo/redo history (kept in the project)."""

    def __init__(self, host: Any, items: Any, project: Any):
        self.host, self.items, self.project = host, items, project

    # -- history ----------------------------------------------------------------------
    def _history(self) -> tuple[list[Edit], list[Edit]]:
        try:
            rec = self.project.get_state(HISTORY_KEY) or {}
            return [Edit.from_dict(d) for d in rec.get("done", [])], [Edit.from_dict(d) for d in rec.get("undone", [])]
        except Exception:  # a damaged record must not keep the page from opening: no history
            return [], []

    def _save(self, done: list[Edit], undone: list[Edit]) -> None:
        self.project.set_state(HISTORY_KEY, {"done": [asdict(e) for e in done], "undone": [asdict(e) for e in undone]})

    def _present(self, edit: Edit) -> bool:
        try:
            return not self.project.measurement(int(edit.item)).get("removed")
        except (CamcmmError, ValueError):
            return False

    def can_undo(self) -> bool:
        return any(self._present(e) for e in self._history()[0])

    def can_redo(self) -> bool:
        return bool(self._history()[1])

    # -- an edit ----------------------------------------------------------------------
    def check(self, key: Any, plugin: str, params: dict[str, Any] | None) -> plugin_run.Checked:
        """The edit made ready: an operation of :data:`OPERATIONS`, the item a cloud of
        the project, the parameters valid by the plugin's declaration (text as typed; an
        empty field is the default). One-line CamcmmError otherwise."""
        if plugin not in OPERATIONS:
            raise InputError(f"cloud edit: {plugin!r} is not one of {', '.join(OPERATIONS)}")
        m = self.items.measurement(str(key)) if key not in (None, "") else None
        if m is None:
            raise InputError(
                "cloud edit: choose a cloud item first" if key in (None, "") else f"no item {key!r} in the project"
            )
        if str(m.get("kind")) != "pointcloud":
            raise InputError(f"cloud edit: item {m.get('name')!r} is a {m.get('kind')}, not a point cloud")
        request = plugin_run.PluginRunRequest(plugin, {"cloud": str(key)}, dict(params or {}))
        return plugin_run.check(self.host, request, self.items, [{"id": str(key), "kind": "pointcloud"}])

    def run(
        self,
        checked: plugin_run.Checked,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> Any:
        """The plugin's run (in the worker process; Cancelled when ``cancel`` is set)."""
        return plugin_run.run(self.host, checked, progress, cancel)

    def store(self, checked: plugin_run.Checked, result: Any, taken: set[str] | None = None) -> Edit:
        """The run's cloud as a new item with its result row (see the module docstring),
        pushed on the history (clearing redo). Raises a one-line CamcmmError when the
        project refuses it (nothing half-stored is listed)."""
        key = str(checked.request.inputs["cloud"])
        parent = self.items.measurement(key) or {}
        cloud = result.outputs.get("cloud")
        if kind_of(cloud) != "pointcloud":
            raise InputError(f"{checked.spec.id} gave no cloud to store")
        before = checked.objs["cloud"].n_points
        kept, removed = counts(result, before)
        pname = str(parent.get("name") or key)
        names = taken if taken is not None else {str(m.get("name")) for m in self.project.measurements()}
        own = f"{pname} · {label_of(checked.spec.id, checked.values)}"
        name = plugin_run.derived_name(own, pname, own, set(names))
        cloud.name = name
        meta: dict[str, Any] = parent["meta"] if isinstance(parent.get("meta"), dict) else {}
        try:
            h = self.project.add_object(cloud, name)
            rid = self.project.add_result(result, measurement_ids=checked.mids, files={"cloud": h})
            mid = self.items.add_measurement(
                name, h, cloud, source=f"{checked.spec.id} {result.plugin_version}", display=meta.get("display_units")
            )
        except CamcmmError:
            raise
        except Exception as exc:
            raise InputError(one_line(exc, f"{checked.spec.id} on {pname!r}: cannot store the new item")) from exc
        edit = Edit(
            checked.spec.id, dict(result.params), key, str(mid), name, h, rid, kept, removed, list(result.warnings)
        )
        done, _ = self._history()
        self._save([*done, edit], [])
        return edit

    def apply(
        self,
        key: Any,
        plugin: str,
        params: dict[str, Any] | None = None,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> Edit:
        """:meth:`check`, :meth:`run` and :meth:`store` in one call (headless use)."""
        checked = self.check(key, plugin, params)
        return self.store(checked, self.run(checked, progress, cancel))

    # -- undo / redo --------------------------------------------------------------------
    def undo(self) -> Edit | None:
        """Remove (soft) the newest edit's item; the caller shows ``edit.parent`` again.
        An edit whose item is already gone (deleted from the tidy) is passed over. None
        when there is nothing to undo."""
        done, undone = self._history()
        while done:
            edit = done.pop()
            if self._present(edit):
                self.project.remove_measurement(int(edit.item))
                self._save(done, [*undone, edit])
                return edit
        self._save(done, undone)
        return None

    def redo(self) -> Edit | None:
        """List the last undone edit's item again; None when there is nothing to redo."""
        done, undone = self._history()
        if not undone:
            return None
        edit = undone.pop()
        self.project.restore_measurement(int(edit.item))
        self._save([*done, edit], undone)
        return edit
