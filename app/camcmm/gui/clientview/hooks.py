"""The client view on the Inspect and Compare pages: where their scenes tell the page
of a change (``on_update``), the client view publishes (browser mode) or the remote view
pushes an image (server mode); a click in the browser goes to the page's own picking.

Inspect (:func:`attach_scene_view`): in browser mode the view shows up to
:data:`CLIENT_LIMIT` points whole (the server's remote view: ``DISPLAY_LIMIT``, a random
subset above it); a bigger cloud shows a random subset of that many first and refines
as the browser zooms in (:mod:`.bigview`, camcmm.bigcloud's level of detail); a click
names the point, its coordinates and the value it is coloured by (state
``<name>_picked``); a lasso or rectangle goes to the Inspect page's
``on_select(view_name, selection)`` where it has one.

Compare (:func:`attach_compare`): the same limits for what is drawn next; a click runs
the page's own ``pick_display`` (point pairs on the inputs, a deviation on the result, a
feature of the nominal for a characteristic), with the browser's pick standing in for
the server's projection picking: the point is the drawn one (through the
level-of-detail order back to the actor's point, then to the full cloud), a point on
the nominal mesh is the mesh's point nearest to the browser's (a cell locator), so the
page's logic runs unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from ...tasks.items import fmt_count
from ..view import DISPLAY_LIMIT
from .bigview import BigCloud
from .client import ClientView

#: points the Inspect page shows whole when the browser draws them
CLIENT_LIMIT = 4_000_000


def _limits(view: Any) -> Callable[[str], int]:
    """The display limit of ``view`` by mode: the server's as it was made; in the browser
    :data:`CLIENT_LIMIT` in place of the default (an explicit limit — tests,
    ``--display-limit`` — stays as given)."""
    server_limit = int(view.display_limit)
    client_limit = max(CLIENT_LIMIT, server_limit) if server_limit == DISPLAY_LIMIT else server_limit
    return lambda mode: client_limit if mode == "browser" else server_limit


def attach_scene_view(page: Any, cv: ClientView, push_remote: Callable[[], Any]) -> None:
    """Hook the Inspect page's SceneView (``page.session.view``) to ``cv``."""
    session = page.session
    view = session.view
    limit_for = _limits(view)
    server_limit, client_limit = limit_for("server"), limit_for("browser")
    view.display_limit = limit_for(cv.mode)

    big = BigCloud(view, cv, client_limit, session.state)

    def changed(reset_camera: bool) -> None:
        if reset_camera:
            view.plotter.reset_camera()
            big.shown_anew()
            if view.shown is not big.refined:  # another item (or none): the last click is not of it
                setattr(session.state, f"{cv.name}_picked", "")
        if cv.mode == "server":
            push_remote()
        else:
            cv.publish()

    def on_mode(mode: str) -> None:
        limit = limit_for(mode)
        if limit == view.display_limit:
            return
        view.display_limit = limit
        view._cache.clear()  # the shown subsets were made for the other limit
        shown = view.shown
        if shown is not None and shown.n_total > min(server_limit, client_limit):
            session.redraw_view()  # the shown page's scene drawn again at the new limit

    def on_pick(layer_id: str, i: int, point: np.ndarray) -> dict[str, Any] | None:
        return inspect_pick(view, cv, layer_id, i, point, big.source_row(i) if big.rows is not None else None)

    def on_select(name: str, selection: dict[str, Any]) -> Any:
        fn = getattr(page, "on_select", None)
        return fn(name, selection) if callable(fn) else None

    view.on_update = changed
    cv.names = lambda: {"cloud": view.actor}
    cv.on_mode = on_mode
    cv.on_pick = on_pick
    cv.on_select = on_select
    cv.on_server_view = push_remote
    cv.on_camera = lambda camera: big.refine(camera, cv.viewport)
    cv.big = big  # type: ignore[attr-defined]  # for tests and scripts
    setattr(session.state, f"{cv.name}_picked", "")


def inspect_pick(
    view: Any, cv: ClientView, layer_id: str, i: int, point: np.ndarray, row: int | None = None
) -> dict[str, Any] | None:
    """A click on the Inspect page's cloud: its point ``i`` (of those drawn; ``row``: the
    cloud's own row of it when known), its coordinates (mm) and the value of the field it
    is coloured by; state ``<name>_picked``."""
    shown = view.shown
    if layer_id != "cloud" or shown is None:
        return None
    info: dict[str, Any] = {"index": int(i if row is None else row), "point": [float(c) for c in point]}
    if row is not None or shown.n_shown == shown.n_total:
        which = f"#{info['index']}"
    else:
        which = f"#{i} of the {fmt_count(shown.n_shown)} shown"
    text = f"point {which}: (" + ", ".join(f"{c:.3f}" for c in point) + ") mm"
    data = shown.poly.point_data
    if view.field in data and np.asarray(data[view.field]).ndim == 1:
        value = float(np.asarray(data[view.field])[i])
        info["value"] = value
        text += f", {view.value_text(value)}"  # in the legend's unit and words (camcmm.numbers)
    info["text"] = text.replace("-", "\u2212")
    setattr(cv.state, f"{cv.name}_picked", info["text"])
    return info


# ------------------------------------------------------------------------------ Compare
def attach_compare(page: Any, cv: ClientView, push_remote: Callable[[], Any]) -> None:
    """Hook the Compare page's CompareView (``page.view``) to ``cv``. The display limit
    follows the mode for what is drawn next (the note says how many points are shown)."""
    view = page.view
    limit_for = _limits(view)
    view.display_limit = limit_for(cv.mode)

    def changed(reset_camera: bool) -> None:
        if cv.mode == "server":
            push_remote()
        else:
            cv.publish()

    view.on_update = changed
    cv.names = lambda: dict(view._actors)
    cv.on_pick = lambda layer_id, i, point: compare_pick(page, layer_id, i, point)
    cv.on_server_view = push_remote

    def on_mode(mode: str) -> None:
        limit = limit_for(mode)
        if limit == view.display_limit:
            return
        view.display_limit = limit
        redraw_compare(page, min(limit_for("server"), limit_for("browser")))

    cv.on_mode = on_mode


def redraw_compare(page: Any, smaller: int) -> None:
    """The Compare page's scene drawn again at the view's new display limit, where its
    cloud is above the smaller of the two (the deviations or the measured cloud: prepared
    anew; the camera stays)."""
    from ..pages.compare.scene import prepare_cloud

    view, scene = page.view, page.view.scene
    if scene in ("colour", "bands", "failed") and page.deviations is not None and view.dev is not None:
        if view.dev.n_total <= smaller:
            return
        dev = page.deviations
        page.prepared = prepare_cloud(dev.points, dev.fields.get("deviation"), view.display_limit)
        page.display.set_mode("colour" if scene == "failed" else scene)  # "failed" is drawn as such
    elif scene == "inputs" and view._inputs.get("measured") is not None:
        if view._inputs["measured"].n_total <= smaller:
            return
        view._inputs.pop("measured")
        page.inputs.show_inputs(reset_camera=False)


@contextmanager
def _pinned(obj: Any, **methods: Any) -> Iterator[None]:
    """``obj``'s methods replaced by ``methods`` for the block (instance attributes over
    the class's; removed afterwards)."""
    if obj is None:
        yield
        return
    for name, fn in methods.items():
        setattr(obj, name, fn)
    try:
        yield
    finally:
        for name in methods:
            obj.__dict__.pop(name, None)


def nearest_on_actor(actor: Any, point: np.ndarray) -> tuple[np.ndarray, int] | None:
    """The point of ``actor``'s surface nearest to ``point`` (mm) and its cell."""
    from vtkmodules.vtkCommonCore import mutable
    from vtkmodules.vtkCommonDataModel import vtkCellLocator

    data = actor.GetMapper().GetInput() if actor is not None and actor.GetMapper() is not None else None
    if data is None or data.GetNumberOfCells() == 0:
        return None
    loc = vtkCellLocator()
    loc.SetDataSet(data)
    loc.BuildLocator()
    closest = [0.0, 0.0, 0.0]
    cell, sub, d2 = mutable(0), mutable(0), mutable(0.0)
    loc.FindClosestPoint([float(c) for c in point], closest, cell, sub, d2)  # type: ignore[call-overload]
    return np.asarray(closest, dtype=float), int(cell)


def along_sight(view: Any, which: str, point: np.ndarray) -> np.ndarray | None:
    """The point of ``which`` ("measured" or "nominal") on the server camera's line of
    sight through ``point`` (mm): the front-most cloud point within a few pixels of it, or
    the nominal mesh's surface there (VTK's cell picker); None when there is none."""
    from ..pages.compare.picking import pick_surface, world_to_display

    prep = view._inputs.get("measured" if which == "measured" else "nominal_cloud")
    if which == "measured" or prep is not None:
        j = None if prep is None else sight_index(view, prep.points, point)
        return None if j is None else np.asarray(prep.points[j], dtype=float).copy()
    xy, _, ok = world_to_display(view.renderer, np.asarray(point, dtype=float).reshape(1, 3))
    actor = view._actors.get("nominal")
    return None if actor is None or not ok[0] else pick_surface(view.renderer, actor, *(float(v) for v in xy[0]))


def sight_index(view: Any, points: np.ndarray, point: np.ndarray) -> int | None:
    """The index of the front-most of ``points`` drawn within a few pixels of ``point``
    (mm) for the server's camera (picking.pick_point without a depth buffer: the server
    has not rendered the browser's view)."""
    from ..pages.compare.picking import pick_point, world_to_display

    xy, _, ok = world_to_display(view.renderer, np.asarray(point, dtype=float).reshape(1, 3))
    if not ok[0]:
        return None
    return pick_point(view.renderer, points, float(xy[0, 0]), float(xy[0, 1]), zbuffer=False)


def compare_pick(page: Any, layer_id: str, i: int, point: np.ndarray) -> Any:
    """A click in the browser on the Compare page, through the page's own pick logic."""
    view = page.view

    def pick_deviation(x: float, y: float) -> int | None:
        if view.dev is None:
            return None
        j: int | None = i
        if layer_id != "cloud":  # the nominal drawn over a failed alignment: the cloud behind it
            j = sight_index(view, view.dev.points, point) if layer_id == "nominal" else None
        if j is None:
            return None
        return int(j if view.dev.idx is None else view.dev.idx[j])

    def pick_input(which: str, x: float, y: float) -> np.ndarray | None:
        if layer_id != which:  # the layers are the scene's actors: "measured", "nominal"
            # the other object drawn in front (the nominal is translucent): the one asked
            # for along the same line of sight, as the server picks it (its camera is the
            # browser's: cv_camera)
            return along_sight(view, which, point) if layer_id in ("measured", "nominal") else None
        if which == "measured":
            prep = view._inputs.get("measured")
            return None if prep is None else np.asarray(prep.points[i], dtype=float).copy()
        prep = view._inputs.get("nominal_cloud")
        if prep is not None:
            return np.asarray(prep.points[i], dtype=float).copy()
        hit = nearest_on_actor(view._actors.get("nominal"), point)
        return None if hit is None else hit[0]

    gdt = getattr(page, "gdt", None)

    def gdt_pick(x: float, y: float) -> Any:
        hit = nearest_on_actor(view._actors.get("nominal"), point) if layer_id == "nominal" else None
        if hit is None or gdt is None:
            page.state.gdt_f_picked = "no surface of the nominal there; click on it"
            return None
        return gdt.pick_point(hit[0], hit[1])

    with _pinned(view, pick_deviation=pick_deviation, pick_input=pick_input), _pinned(gdt, pick=gdt_pick):
        return page.pick_display(0.0, 0.0)
