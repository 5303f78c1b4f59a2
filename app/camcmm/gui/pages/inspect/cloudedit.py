"""The Inspect page's "Crop & segment" panel: crop the shown cloud by a box (prefilled
with the cloud's bounds), by a plane, by a lasso or rectangle drawn in the view; keep or
remove the selection; keep a connected component; remove outliers; undo and redo.

Every edit is the headless task :mod:`camcmm.tasks.cloudedit` (a plugin run in the worker
process, a new item with its provenance, undo = the project's soft remove); the forms are
the plugins' own declarations (plugins/camcmm_plugins/cloudtools/plugin.yaml), as on the
command line. A selection comes from the client view (:mod:`camcmm.gui.clientview`): the
Lasso and Rectangle buttons set its ``tool``; the drag's end arrives as the trigger
``cv_select`` at :meth:`CloudEditPanel.on_select` (through ``InspectPage.on_select``),
which selects with the same plugin (``crop.lasso``) the edit then runs, so what is
highlighted is what Keep or Remove keeps or removes.

State (prefix ``ce_``): ``ce_available`` (the operations the host has), ``ce_op`` (the
one whose form shows), ``ce_fields``, ``ce_values`` (its form), ``ce_tool`` ("rotate",
"lasso", "rect"), ``ce_selected`` (points in the selection), ``ce_selection`` (one line
about it), ``ce_status`` (the last edit, undo or refusal), ``ce_failed``, ``ce_running``,
``ce_can_undo``, ``ce_can_redo``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ....errors import CamcmmError, one_line
from ....tasks.cloudedit import CloudEdits, Edit
from ....tasks.items import fmt_count, kind_of
from ...jobs import Job, in_background
from ...widgets import declared_fields, param_form, tid

#: The operations with a form, and their buttons' words.
OPS = {"crop.box": "Box", "crop.plane": "Plane", "segment.components": "Components", "cloud.denoise": "Outliers"}
TIPS = {
    "crop.box": "Keep the points inside (or outside) a box",
    "crop.plane": "Keep the points on one side of a plane",
    "segment.components": "Keep a connected component (DBSCAN)",
    "cloud.denoise": "Remove statistical outliers (Open3D)",
}
#: The client view of the Inspect page (its state key; camcmm.gui.pages.inspect.layout).
VIEW = "cv_inspect"
#: The highlight of a selection in the scene, and the most points it draws.
SELECTION_ACTOR = "cloudedit-selection"
HIGHLIGHT_LIMIT = 200_000
#: The outline of the box or plane in the form, drawn while the panel is open.
PREVIEW_ACTOR = "cloudedit-preview"
#: The 12 edges of a box whose 8 corners are numbered by their bits (x, y, z: 1, 2, 4).
BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
_BITS = np.array([[(i >> k) & 1 for k in range(3)] for i in range(8)], dtype=float)


def bounds_text(lo: float, hi: float) -> tuple[str, str]:
    """A box's corner coordinates as the form shows them: to the µm, rounded outward so
    that the prefilled box holds every point."""
    return f"{math.floor(lo * 1000) / 1000:g}", f"{math.ceil(hi * 1000) / 1000:g}"


def box_corners(lo: Any, hi: Any) -> np.ndarray:
    """The 8 corners (mm) of the box ``lo``..``hi``, numbered as :data:`BOX_EDGES` expects."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return lo + _BITS * (hi - lo)


def turned_box_corners(centre: Any, size: Any, rotation: Any) -> np.ndarray:
    """The corners of the box of edge lengths ``size`` about ``centre`` turned by
    ``rotation`` (degrees about the fixed x, then y, then z axes: SciPy's extrinsic "xyz",
    R = Rz Ry Rx, the convention crop.box declares)."""
    from scipy.spatial.transform import Rotation

    r = Rotation.from_euler("xyz", np.asarray(rotation, float), degrees=True).as_matrix()
    return np.asarray(centre, float) + ((_BITS - 0.5) * np.asarray(size, float)) @ r.T


def plane_corners(point: Any, normal: Any, half: float) -> np.ndarray:
    """A square of half-side ``half`` (mm) in the plane through ``point`` with ``normal``, corners in order."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    return np.asarray(point, float) + half * np.array([u + w, u - w, -u - w, -u + w])


class CloudEditPanel:
    """The panel's state and handlers, on the Inspect ``page``."""

    def __init__(self, page: Any):
        self.page, self.session, self.state = page, page.session, page.session.state
        self.edits = CloudEdits(self.session.host, self.session, self.session.project)
        self.job = Job("a cloud edit", state=self.state, on_progress=lambda f, m: self._progress(f, m))
        self.selection: dict[str, Any] | None = None  # {"key", "polygon", "mvp", "n"}
        self._item: Any = None
        # the operations whose plugin the host has (a lab's host may lack cloudtools: the
        # panel then offers what is there, or hides itself)
        self.available = [op for op in OPS if op in self.session.host.plugins]
        self.state.update(
            {
                "ce_available": self.available,
                "ce_lasso": "crop.lasso" in self.session.host.plugins,
                "ce_op": self.available[0] if self.available else "",
                "ce_fields": [],
                "ce_values": {},
                "ce_tool": "rotate",
                "ce_selected": 0,
                "ce_selection": "",
                "ce_status": "",
                "ce_failed": False,
                "ce_running": False,
                "ce_can_undo": False,
                "ce_can_redo": False,
                "ce_open": None,
            }
        )
        if self.available:
            self.set_op(self.available[0])
        self.session.watch_items(self._items_changed)

        @page.server.state.change("ce_values", "ce_open")
        def _form_changed(**_: Any) -> None:  # the outline follows the form as it is typed
            self.preview()

    # -- the item and the form ----------------------------------------------------------
    def cloud(self) -> tuple[str, Any] | None:
        """``(key, cloud)`` of the shown item if it is a point cloud, else None."""
        key = self.state.selected_item
        if not key or self.session.measurement(key) is None:
            return None
        obj = self.session.loaded(key)
        return (str(key), obj) if obj is not None and kind_of(obj) == "pointcloud" else None

    def _items_changed(self) -> None:
        """Another item shown (or the list changed): a new box, no selection."""
        self._history()
        key = self.state.selected_item
        if key != self._item:
            self._item = key
            self.clear_selection()
            self.prefill()

    def _history(self) -> None:
        self.state.ce_can_undo = self.edits.can_undo()
        self.state.ce_can_redo = self.edits.can_redo()

    def set_op(self, op: Any) -> None:
        """Show the form of operation ``op`` (one of :data:`OPS`) from its declaration."""
        if op not in self.available:
            return
        spec = self.session.host.get(op)
        self.state.ce_fields, self.state.ce_values = declared_fields(spec.parameters)
        self.state.ce_op = op
        self.prefill()

    def prefill(self) -> None:
        """Start the form from the shown cloud: the box's corners at its bounds (rounded
        outward to the µm, so the box holds every point), the plane through the centre of
        its bounds, horizontal (normal +z), so that a user moves one value, not types six."""
        shown = self.cloud()
        op = self.state.ce_op
        if shown is None or shown[1].n_points == 0 or op not in ("crop.box", "crop.plane"):
            return
        lo, hi = shown[1].bounds
        values = dict(self.state.ce_values or {})
        if op == "crop.box":
            pairs = [bounds_text(a, b) for a, b in zip(lo, hi, strict=True)]
            values["min"] = ", ".join(p[0] for p in pairs)
            values["max"] = ", ".join(p[1] for p in pairs)
        else:
            values["point"] = ", ".join(f"{round(0.5 * (a + b), 3):g}" for a, b in zip(lo, hi, strict=True))
            values["normal"] = "0, 0, 1"
        self.state.ce_values = values
        self.preview()

    # -- the outline of the box or plane --------------------------------------------------
    def outline(self) -> tuple[np.ndarray, list[tuple[int, int]]] | None:
        """``(corners, edges)`` of the box or plane the form holds now (mm), while the panel
        is open; None when it is closed, another operation is chosen or a value is refused."""
        from ....tasks.plugin_run import checked_params

        op = self.state.ce_op
        if self.state.ce_open != "ce" or op not in ("crop.box", "crop.plane"):
            return None
        try:
            values = checked_params(self.session.host.get(op), dict(self.state.ce_values or {}))
        except CamcmmError:
            return None
        if op == "crop.plane":
            point, normal = values.get("point"), values.get("normal")
            if point is None or normal is None or not np.any(normal):
                return None
            shown = self.cloud()
            half = 0.5 * float(np.linalg.norm(np.ptp(shown[1].bounds, axis=0))) if shown else 10.0
            return plane_corners(point, normal, max(half, 1e-3)), [(0, 1), (1, 2), (2, 3), (3, 0)]
        if values.get("min") is not None and values.get("max") is not None:
            return box_corners(values["min"], values["max"]), BOX_EDGES
        if values.get("centre") is not None and values.get("size") is not None:
            return turned_box_corners(values["centre"], values["size"], values.get("rotation") or [0, 0, 0]), BOX_EDGES
        return None

    def preview(self) -> None:
        """Draw :meth:`outline` in the view (magenta lines), or take it away."""
        view = self.session.view
        shape = self.outline()
        had = view.plotter.remove_actor(PREVIEW_ACTOR, render=False)
        if shape is not None:
            import pyvista as pv

            corners, edges = shape
            lines = np.array([[2, a, b] for a, b in edges]).ravel()
            view.plotter.add_mesh(
                pv.PolyData(corners, lines=lines),
                color="#d81b60",
                line_width=2,
                name=PREVIEW_ACTOR,
                reset_camera=False,
                pickable=False,
            )
        if (had or shape is not None) and view.on_update is not None:
            view.on_update(False)

    # -- the selection ------------------------------------------------------------------
    def _client_view(self) -> Any:
        views = getattr(self.page.server, "camcmm_client_views", None)
        return None if views is None else views.views.get(VIEW)

    def set_tool(self, tool: Any) -> None:
        """The view's mouse tool: "rotate" (turn the view), "lasso" or "rect" (select)."""
        if tool not in ("rotate", "lasso", "rect"):
            return
        self.state.ce_tool = tool
        cv = self._client_view()
        if cv is not None:
            cv.set_tool(tool)

    def on_select(self, view_name: Any, selection: dict[str, Any]) -> int | None:
        """A lasso or rectangle drawn in the view ``view_name`` (the client view's checked
        ``{"shape", "polygon": [[x, y] NDC ...], "mvp": 16 floats column-major}``): the
        points of the shown cloud inside it (all depths, in front of the camera) become the
        selection, highlighted. Returns how many; None when it is not this page's view or
        no cloud is shown."""
        if view_name != VIEW:
            return None
        shown = self.cloud()
        if shown is None:
            self._say("show a point cloud first: the selection is made on the shown cloud", failed=True)
            return None
        key, cloud = shown
        try:
            polygon = [float(c) for xy in selection["polygon"] for c in xy]
            mvp = [float(c) for c in selection["mvp"]]
            params = {"polygon": polygon, "mvp": mvp, "keep": "inside"}
            out = self.session.host.run("crop.lasso", {"cloud": cloud}, params).outputs
        except (CamcmmError, KeyError, TypeError, ValueError) as exc:
            if "keeps none" in str(exc):
                self.clear_selection()
                self.state.ce_selection = "no point of the shown cloud inside what was drawn"
                return 0
            self._say(one_line(exc), failed=True)
            return None
        n = int(out["n_kept"])
        self.selection = {"key": key, "polygon": polygon, "mvp": mvp, "n": n}
        self.state.ce_selected = n
        shape = "rectangle" if selection.get("shape") == "rect" else "lasso"
        self.state.ce_selection = f"{fmt_count(n)} of {fmt_count(cloud.n_points)} points selected ({shape})"
        self._highlight(out["cloud"].points)
        return n

    def _highlight(self, points: np.ndarray | None) -> None:
        """Draw the selected points over the cloud (orange, larger), or remove the highlight."""
        view = self.session.view
        plotter = view.plotter
        plotter.remove_actor(SELECTION_ACTOR, render=False)
        if points is not None and len(points):
            import pyvista as pv

            step = max(1, math.ceil(len(points) / HIGHLIGHT_LIMIT))
            size = (view.point_size or view.auto_point_size()) + 2
            plotter.add_mesh(
                pv.PolyData(np.asarray(points[::step], dtype=float)),
                color="#ff6d00",
                style="points",
                point_size=size,
                name=SELECTION_ACTOR,
                reset_camera=False,
                pickable=False,
            )
        if view.on_update is not None:
            view.on_update(False)

    def clear_selection(self) -> None:
        had = self.selection is not None
        self.selection = None
        self.state.ce_selected = 0
        self.state.ce_selection = ""
        if had:
            self._highlight(None)

    # -- an edit ------------------------------------------------------------------------
    def _say(self, line: str, failed: bool = False) -> None:
        self.state.ce_status, self.state.ce_failed = line, failed
        if failed:
            self.session.error(line, page="inspect")

    def _progress(self, fraction: float, message: str) -> None:
        if message:
            self.state.ce_status = f"{message} {round(100 * fraction)} %"

    def apply_clicked(self, op: Any, values: Any) -> None:
        """Apply (the operation's form): :meth:`apply` in the background."""
        in_background(self.apply(op, values), self.state)

    def keep_clicked(self, keep: Any) -> None:
        """Keep selection (``"inside"``) / Remove selection (``"outside"``) in the background."""
        in_background(self.apply_selection(keep), self.state)

    async def apply_selection(self, keep: Any) -> Edit | None:
        """Keep (``keep="inside"``) or remove (``"outside"``) the selection: ``crop.lasso``
        with the drawn polygon and view matrix, on the item they were drawn on."""
        sel = self.selection
        if sel is None or sel["key"] != self.state.selected_item:
            self._say("draw a selection first: Lasso or Rectangle, then drag in the view", failed=True)
            return None
        if keep not in ("inside", "outside"):
            return None
        return await self.apply("crop.lasso", {"polygon": sel["polygon"], "mvp": sel["mvp"], "keep": keep})

    async def apply(self, op: Any, values: Any) -> Edit | None:
        """Run operation ``op`` with the form's ``values`` on the shown cloud while the page
        stays live; the new item is shown. None after showing why it could not be done."""
        shown = self.cloud()
        if shown is None:
            self._say("show a point cloud first (click it in the project's items)", failed=True)
            return None
        try:
            checked = self.edits.check(shown[0], str(op), dict(values or {}))
            cancel = self.job.begin()
        except Exception as exc:  # a refused value, or an edit going
            self._say(one_line(exc), failed=True)
            return None
        self.state.ce_running = True
        self._say(f"running {op} …")
        self.session.flush()
        try:
            result = await self.job.call(self.edits.run, checked, progress=self.job.progress, cancel=cancel)
            taken = {it["name"] for it in [*(self.state.items or []), *(self.state.hidden_items or [])]}
            edit = self.edits.store(checked, result, taken)
        except Exception as exc:
            self._say(Job.outcome(exc, str(op))[1], failed=True)
            return None
        finally:
            self.job.end()
            self.state.ce_running = False
        self.session.clear_error(page="inspect")
        self.clear_selection()
        self.session.refresh_items()
        self.session.refresh_results()  # the drawer lists the edit's result row
        labelled = edit.plugin == "segment.components" and edit.params.get("keep") == "all"
        self.session.select_item(edit.item, chosen=True, field="component" if labelled else None)
        warn = f" — {edit.warnings[0]}" if edit.warnings else ""
        self._say(f"made {edit.line}{warn}")
        self._history()
        self.session.flush()
        return edit

    def undo(self) -> Edit | None:
        """Remove the newest edit's item (soft) and show its parent again."""
        try:
            edit = self.edits.undo()
        except Exception as exc:
            self._say(one_line(exc), failed=True)
            return None
        if edit is None:
            self._say("nothing to undo")
            self._history()
            return None
        self.clear_selection()
        self.session.refresh_items()
        if self.session.measurement(edit.parent) is not None:
            self.session.select_item(edit.parent, chosen=True)
        elif self.state.selected_item == edit.item:
            self.session.unselect_item()
        self._say(f"undone: '{edit.name}' removed (Redo brings it back)")
        self._history()
        return edit

    def redo(self) -> Edit | None:
        """List the last undone edit's item again and show it."""
        try:
            edit = self.edits.redo()
        except Exception as exc:
            self._say(one_line(exc), failed=True)
            return None
        if edit is None:
            self._say("nothing to redo")
            return None
        self.session.refresh_items()
        self.session.select_item(edit.item, chosen=True)
        self._say(f"redone: '{edit.name}'")
        self._history()
        return edit

    def close(self) -> None:
        self.job.close()


# ------------------------------------------------------------------------------ widgets
def _btn(text: str, icon: str, click: Any, testid: str, tip: str, **kw: Any) -> None:
    from trame.widgets import vuetify3 as v

    v.VBtn(text, prepend_icon=icon, size="small", variant="tonal", click=click, title=tip, raw_attrs=tid(testid), **kw)


def cloudedit_panel(page: Any) -> None:
    """The panel, folded by default above the view: a row of operations (their form below),
    a row of selection tools, and Undo/Redo with the last edit's line."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    p: CloudEditPanel = page.cloudedit
    with v.VExpansionPanels(
        v_model=("ce_open", None),
        v_show="page === 'inspect' && ce_available.length",
        classes="px-2 pt-1",
        raw_attrs=tid("ce-panel"),
    ):
        with v.VExpansionPanel(value="ce", raw_attrs=tid("ce-panel-inner")):
            v.VExpansionPanelTitle("Crop & segment", raw_attrs=tid("ce-open"))
            with v.VExpansionPanelText():
                with html.Div(classes="d-flex align-center flex-wrap ga-2 mb-2"):
                    with v.VBtnToggle(
                        model_value=("ce_op",),
                        mandatory=True,
                        density="compact",
                        variant="outlined",
                        divided=True,
                        color="primary",
                        update_modelValue=(p.set_op, "[$event]"),
                        raw_attrs=tid("ce-ops"),
                    ):
                        for op, word in OPS.items():
                            v.VBtn(
                                word,
                                value=op,
                                v_if=f"ce_available.includes('{op}')",
                                size="small",
                                title=TIPS[op],
                                raw_attrs=tid(f"ce-op-{op}"),
                            )
                    v.VBtn(
                        "Apply",
                        color="primary",
                        size="small",
                        prepend_icon="mdi-content-cut",
                        click=(p.apply_clicked, "[ce_op, ce_values]"),
                        loading=("ce_running",),
                        disabled=("ce_running || !selected_item",),
                        title="Run the operation on the shown cloud: a new item, the cloud itself stays",
                        raw_attrs=tid("ce-apply"),
                    )
                with html.Div(  # the fields side by side: the view keeps its height
                    style="max-height: 30vh; overflow-y: auto; display: grid; column-gap: 8px;"
                    " grid-template-columns: repeat(auto-fill, minmax(190px, 1fr));",
                    classes="pt-2",
                ):
                    param_form("ce_fields", "ce_values", "ce-param", sync=True, hide_details=True)
                with html.Div(classes="d-flex align-center flex-wrap ga-2 mb-2"):
                    with v.VBtnToggle(
                        model_value=("ce_tool",),
                        mandatory=True,
                        density="compact",
                        variant="outlined",
                        divided=True,
                        update_modelValue=(p.set_tool, "[$event]"),
                        # a lasso is drawn by the browser's view; the server's images take none
                        disabled=(f"{VIEW}_mode === 'server' || !ce_lasso",),
                        title="Select by drawing in the view (rendering in the browser)",
                        raw_attrs=tid("ce-tools"),
                    ):
                        for tool, icon, tip in (
                            ("rotate", "mdi-rotate-3d-variant", "Drag turns the view"),
                            ("lasso", "mdi-lasso", "Drag draws a lasso: the points inside it are selected"),
                            ("rect", "mdi-selection", "Drag draws a rectangle: the points inside it are selected"),
                        ):
                            with v.VBtn(value=tool, size="small", title=tip, raw_attrs=tid(f"ce-tool-{tool}")):
                                v.VIcon(icon, size="small")
                    _btn(
                        "Keep selection",
                        "mdi-selection-ellipse-arrow-inside",
                        (p.keep_clicked, "['inside']"),
                        "ce-keep",
                        "A new item of the selected points only",
                        disabled=("!ce_selected || ce_running",),
                    )
                    _btn(
                        "Remove selection",
                        "mdi-selection-remove",
                        (p.keep_clicked, "['outside']"),
                        "ce-remove",
                        "A new item without the selected points",
                        disabled=("!ce_selected || ce_running",),
                    )
                    html.Span("{{ ce_selection }}", classes="text-caption", raw_attrs=tid("ce-selection"))
                with html.Div(classes="d-flex align-center ga-2"):
                    _btn(
                        "Undo",
                        "mdi-undo",
                        p.undo,
                        "ce-undo",
                        "Remove the newest edit's item and show the cloud it came from",
                        disabled=("!ce_can_undo || ce_running",),
                    )
                    _btn(
                        "Redo",
                        "mdi-redo",
                        p.redo,
                        "ce-redo",
                        "Bring back the last undone edit",
                        disabled=("!ce_can_redo || ce_running",),
                    )
                    html.Span(
                        "{{ ce_status }}",
                        classes=("ce_failed ? 'text-caption text-error' : 'text-caption'",),
                        style="min-width: 0; overflow: hidden; text-overflow: ellipsis; white-space: nowrap;",
                        title=("ce_status",),
                        raw_attrs=tid("ce-status"),
                    )


__all__ = ["OPS", "VIEW", "CloudEditPanel", "cloudedit_panel"]
