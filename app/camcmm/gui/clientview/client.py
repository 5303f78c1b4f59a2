"""One client-rendered view: a page's scene published as the trame state ``NAME`` (the
"Client view protocol" of cloudview.js) with its buffers in a served folder, and the
browser's triggers checked and routed back to the page.

:class:`ClientView` is plain Python over a state object (any object with attributes) and
a scene with a pyvista ``plotter``: testable without a browser. The trame element, the
toggle and the triggers' registration are :mod:`.widget`.

State ``NAME`` (see the protocol): ``rev`` (+1 on every publish), ``base`` (the served
folder, relative to the page), ``origin`` (mm; buffers hold positions minus it, float32),
``layers``, ``legend``, ``entries``, ``labels``, ``camera`` (its own ``rev``, +1 whenever
the server moved the camera: the browser adopts it then and otherwise keeps its own),
``note``, ``tool``. State ``NAME_mode``: "browser" or "server" (the remote view).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from .export import Layer, Scene, export_scene, finite_camera, finite_vector
from .store import BufferStore

log = logging.getLogger("camcmm.gui")

MODES = ("browser", "server")
TOOLS = ("rotate", "lasso", "rect")
#: the largest viewport a browser may send (the server's plotter takes its size: an 8K
#: screen, not a gigapixel render), and the largest selection polygon (vertices)
MAX_VIEWPORT = 8192
MAX_VIEWPORT_PIXELS = 7680 * 4320
MAX_POLYGON = 4096


def _same(a: Any, b: Any, tol: float = 1e-9) -> bool:
    """Two camera dicts equal within ``tol`` (relative to the camera's distance)."""
    if not a or not b:
        return False
    scale = max(1.0, float(np.linalg.norm(np.subtract(a["position"], a["focal_point"]))))
    for k in ("position", "focal_point", "view_up"):
        if np.max(np.abs(np.subtract(a[k], b[k]))) > tol * (scale if k != "view_up" else 1.0):
            return False
    return abs(a.get("view_angle", 30.0) - b.get("view_angle", 30.0)) <= 1e-9


def _origin_for(layers: list[Layer], old: list[float] | None) -> list[float]:
    """The origin the buffers are relative to: kept while the scene stays near it (a
    colour or a marker changing keeps every positions buffer as it is), else the centre
    of the scene's bounding box rounded to a millimetre."""
    boxes = np.asarray([lay.bounds for lay in layers if lay.n and len(lay.bounds) == 6], dtype=float)
    boxes = boxes[np.isfinite(boxes).all(axis=1)] if len(boxes) else boxes
    if not len(boxes):
        return old or [0.0, 0.0, 0.0]
    lo, hi = boxes[:, [0, 2, 4]].min(axis=0), boxes[:, [1, 3, 5]].max(axis=0)
    centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
    if old is not None and float(np.linalg.norm(centre - np.asarray(old))) <= 10.0 * max(radius, 1.0):
        return old
    return [float(round(c)) for c in centre]


class ClientView:
    """The client view ``name`` of ``scene`` (a SceneView or CompareView: ``plotter``,
    ``note``), its buffers in ``store``, published into ``state`` under ``name``.

    Page hooks (all optional): ``names()`` -> {layer id: actor} of the page's own actors;
    ``on_pick(layer_id, actor_index, point)``; ``on_select(name, selection)``;
    ``on_camera(camera)``; ``on_mode(mode)`` (before the new mode shows);
    ``on_server_view()`` (the remote view takes over: push its image)."""

    def __init__(self, name: str, scene: Any, state: Any, store: BufferStore, base: str):
        self.name, self.scene, self.state, self.store, self.base = name, scene, state, store, base
        self.rev = 0
        self.camera_rev = 0
        self._known_camera: dict[str, Any] | None = None  # the camera the browser has
        self.origin: list[float] | None = None
        self.layers: dict[str, Layer] = {}
        self.names: Callable[[], dict[str, Any]] | None = None
        self.on_pick: Callable[[str, int, np.ndarray], Any] | None = None
        self.on_select: Callable[[str, dict[str, Any]], Any] | None = None
        self.on_server_view: Callable[[], Any] | None = None
        self.on_camera: Callable[[dict[str, Any]], Any] | None = None
        self.on_mode: Callable[[str], Any] | None = None
        self.viewport: tuple[int, int] | None = None
        self.tool = "rotate"
        if getattr(state, f"{name}_mode", None) not in MODES:
            setattr(state, f"{name}_mode", "browser")
        setattr(state, name, self._empty())

    # -- mode --------------------------------------------------------------------------
    @property
    def mode(self) -> str:
        m = getattr(self.state, f"{self.name}_mode", "browser")
        return m if m in MODES else "browser"

    def set_mode(self, mode: Any) -> None:
        """ "browser" (this view) or "server" (the remote view); anything else is ignored."""
        if mode not in MODES:
            setattr(self.state, f"{self.name}_mode", self.mode)
            return
        setattr(self.state, f"{self.name}_mode", mode)
        if self.on_mode is not None:
            self.on_mode(mode)
        if mode == "browser":
            self._known_camera = None  # the remote view may have turned it: send it
            self.publish()
        elif self.on_server_view is not None:
            self.on_server_view()

    # -- publishing --------------------------------------------------------------------
    def _empty(self) -> dict[str, Any]:
        return {
            "rev": self.rev,
            "base": self.base,
            "origin": [0.0, 0.0, 0.0],
            "layers": [],
            "legend": None,
            "entries": [],
            "labels": [],
            "camera": {"rev": self.camera_rev, **(self._known_camera or {})},
            "note": "",
            "tool": self.tool,
        }

    def export(self) -> Scene:
        names = {}
        if self.names is not None:
            names = {id(actor): key for key, actor in self.names().items() if actor is not None}
        return export_scene(self.scene.plotter.renderer, names)

    def changed(self, reset_camera: bool = False) -> None:
        """The scene changed (its ``on_update``): publish in browser mode."""
        if self.mode == "browser":
            self.publish()

    def publish(self) -> dict[str, Any]:
        """Export the scene, write the buffers that are new, set state ``NAME``."""
        scene = self.export()
        self.origin = _origin_for(scene.layers, self.origin)
        o = np.asarray(self.origin)
        used: set[str] = set()
        layers = []
        for lay in scene.layers:
            pos = self.store.put(_relative(lay, o), "f32", key=(*lay.geometry_key, tuple(self.origin)))
            entry: dict[str, Any] = {
                "id": lay.id,
                "kind": lay.kind,
                "n": lay.n,
                "positions": pos,
                "colors": None,
                "color": lay.color,
                "indices": None,
                "point_size": lay.point_size,
                "opacity": lay.opacity,
                "pickable": lay.pickable,
            }
            used.add(str(pos))  # positions are never None
            if lay.make_colors is not None:
                entry["colors"] = self.store.put(_read(lay, "colors"), "u8", key=lay.colour_key)
            if lay.make_indices is not None:
                entry["indices"] = self.store.put(_read(lay, "indices"), "u32", key=(*lay.geometry_key, "i"))
            used.update(v for v in (entry["colors"], entry["indices"]) if v)
            layers.append(entry)
        self.layers = {lay.id: lay for lay in scene.layers}
        if not _same(scene.camera, self._known_camera):
            self.camera_rev += 1
            self._known_camera = scene.camera
        self.rev += 1
        out = {
            "rev": self.rev,
            "base": self.base,
            "origin": list(self.origin),
            "layers": layers,
            "legend": scene.legend,
            "entries": scene.entries,
            "labels": scene.labels,
            "camera": {"rev": self.camera_rev, **scene.camera},
            "note": str(getattr(self.scene, "note", "") or ""),
            "tool": self.tool,
        }
        setattr(self.state, self.name, out)
        self.store.commit(used)
        for lay in scene.layers:  # the buffers hold the arrays now: no second copy of a big cloud
            lay.release()
        return out

    def set_tool(self, tool: Any) -> None:
        """The browser's mouse tool: "rotate", "lasso" or "rect" (H5's panel sets it)."""
        if tool in TOOLS and tool != self.tool:
            self.tool = tool
            cur = dict(getattr(self.state, self.name, None) or self._empty())
            self.rev += 1
            cur["tool"], cur["rev"] = tool, self.rev
            setattr(self.state, self.name, cur)

    # -- the browser's triggers (arguments checked; anything wrong is ignored) ---------
    def pick(self, layer_id: Any, index: Any, point: Any = None) -> Any:
        """A click on drawn vertex ``index`` of layer ``layer_id``: the page's ``on_pick``
        with the actor's point index and the point (the server's own coordinates, not
        the browser's). None (nothing done) for an unknown layer or index."""
        lay = self.layers.get(layer_id) if isinstance(layer_id, str) else None
        if lay is None or not lay.pickable or not _index(index, lay.n):
            return None
        if point is not None and finite_vector(point, 3) is None:
            return None
        i = lay.actor_index(int(index))
        if lay.kind == "points":
            p = lay.point(int(index))
        else:  # a mesh or lines: the browser's point on it, if it is one
            v = finite_vector(point, 3)
            p = lay.point(int(index)) if v is None else np.asarray(v, dtype=float)
        if self.on_pick is None:
            return None
        return self.on_pick(lay.id, i, p)

    def camera(self, cam: Any, viewport: Any = None) -> bool:
        """The browser's camera after an interaction: the server's plotter follows (its
        screenshots and the remote view show the same), at the browser's viewport size."""
        c = finite_camera(cam)
        if c is None:
            return False
        if viewport is not None:
            vp = _viewport(viewport)
            if vp is None:
                return False
            if vp != self.viewport:
                self.viewport = vp
                self.scene.plotter.window_size = list(vp)
        touched = getattr(self.scene, "_touched", None)
        if callable(touched):  # the operator turned the view: no automatic re-framing now
            touched()
        renderer = self.scene.plotter.renderer
        cam_vtk = renderer.GetActiveCamera()
        cam_vtk.SetPosition(*c["position"])
        cam_vtk.SetFocalPoint(*c["focal_point"])
        cam_vtk.SetViewUp(*c["view_up"])
        cam_vtk.SetViewAngle(c["view_angle"])
        cam_vtk.OrthogonalizeViewUp()
        renderer.ResetCameraClippingRange()
        self._known_camera = {**c, "view_up": [float(v) for v in cam_vtk.GetViewUp()]}
        if self.on_camera is not None:
            self.on_camera(c)
        return True

    def select(self, selection: Any) -> dict[str, Any] | None:
        """A lasso or rectangle drawn in the browser, checked, to the page's ``on_select``."""
        sel = checked_selection(selection)
        if sel is None:
            return None
        if self.on_select is not None:
            self.on_select(self.name, sel)
        return sel


def _relative(lay: Layer, origin: np.ndarray) -> Callable[[], np.ndarray]:
    """The layer's positions minus ``origin``, made only when the buffer is not known yet."""
    return lambda: lay.positions - origin


def _read(lay: Layer, name: str) -> Callable[[], np.ndarray | None]:
    """The layer's array ``name``, made only when the buffer is not known yet."""
    return lambda: getattr(lay, name)


def _index(i: Any, n: int) -> bool:
    return isinstance(i, int) and not isinstance(i, bool) and 0 <= i < n


def _viewport(vp: Any) -> tuple[int, int] | None:
    v = finite_vector(vp, 2)
    if v is None or not all(1 <= x <= MAX_VIEWPORT and float(x).is_integer() for x in v):
        return None
    if v[0] * v[1] > MAX_VIEWPORT_PIXELS:
        return None
    return int(v[0]), int(v[1])


def checked_selection(selection: Any) -> dict[str, Any] | None:
    """``{"shape": "lasso" | "rect", "polygon": [[x, y], ...] (NDC, 3 to MAX_POLYGON
    vertices; a rectangle may come as its 2 corners), "mvp": 16 floats}``, every number
    finite, else None."""
    if not isinstance(selection, dict) or selection.get("shape") not in ("lasso", "rect"):
        return None
    poly = selection.get("polygon")
    if not isinstance(poly, (list, tuple)) or not (2 <= len(poly) <= MAX_POLYGON):
        return None
    pts = [finite_vector(p, 2) for p in poly]
    if any(p is None for p in pts):
        return None
    if len(pts) == 2:  # two corners of a rectangle
        if selection["shape"] != "rect":
            return None
        (x0, y0), (x1, y1) = pts  # type: ignore[misc]
        pts = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    mvp = finite_vector(selection.get("mvp"), 16)
    if mvp is None:
        return None
    return {"shape": selection["shape"], "polygon": pts, "mvp": mvp}
