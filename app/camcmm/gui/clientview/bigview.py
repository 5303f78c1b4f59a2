"""Clouds above the client view's limit on the Inspect page: a level of detail that
refines as the browser zooms in (:class:`camcmm.bigcloud.LodIndex`).

First paint: the SceneView's own fixed random subset of ``limit`` points (uniform over
the cloud, as any random subset). When the browser reports its camera (``cv_camera``,
at the end of an interaction) and the view no longer holds the whole cloud, the points
shown become :meth:`LodIndex.select` of that camera and viewport (at most ``limit``
points, only those in view, denser the nearer: zoomed far enough in, every point of the
region) — read from the item itself, with its fields and colours, coloured on the same
limits as the whole cloud. Zoomed out again (the whole cloud in view) the first paint
comes back. The index is built once per item, off the server loop (``from_points`` of
10⁷ points takes seconds); the selection too; VTK is touched on the loop only.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

import numpy as np

from ...tasks.items import fmt_count
from ..view import COORDS, Shown
from .client import ClientView

log = logging.getLogger("camcmm.gui")

#: added to the first paint's note of a cloud above the limit
ZOOM_NOTE = "; zoom in: the view then shows every point of the region"


class BigCloud:
    """The level of detail of the Inspect page's big clouds (``view``: its SceneView)."""

    def __init__(self, view: Any, cv: ClientView, limit: int, state: Any = None):
        self.view, self.cv, self.limit, self.state = view, cv, int(limit), state
        self._obj: Any = None  # the cloud the index is of
        self._lod: Any = None
        self.base: Shown | None = None  # the first paint (the SceneView's own subset)
        self.base_note = ""
        self.rows: np.ndarray | None = None  # the cloud's rows of the points shown when refined
        self.refined: Shown | None = None
        self._bounds: tuple[Any, np.ndarray] | None = None  # (cloud, its (2, 3) bounds)
        self._gen = 0  # the newest camera: an older refinement still running is dropped

    # -- when ------------------------------------------------------------------------
    def applies(self) -> bool:
        shown = self.view.shown
        src = getattr(self.view, "source", None)
        return (
            self.cv.mode == "browser"
            and shown is not None
            and shown.kind == "pointcloud"
            and shown.n_total > self.limit
            and src is not None
            and getattr(src, "n_points", -1) == shown.n_total
        )

    def shown_anew(self) -> None:
        """The scene was drawn anew: a new item (or the same again) is its first paint;
        the refinement shown just turned (a standard view) stays."""
        if self.view.shown is not None and self.view.shown is self.refined:
            return
        if self.applies() and ZOOM_NOTE not in self.view.note:
            self.view.note += ZOOM_NOTE
        self.base, self.base_note, self.rows, self.refined = self.view.shown, self.view.note, None, None
        self._gen += 1

    # -- refinement --------------------------------------------------------------------
    def index(self, obj: Any) -> Any:
        if self._obj is not obj:
            from ...bigcloud import LodIndex

            self._lod, self._obj = LodIndex.from_points(np.asarray(obj.points, dtype=float)), obj
        return self._lod

    def whole_in_view(self, camera: dict[str, Any], viewport: tuple[int, int]) -> bool:
        """All eight corners of the cloud's bounding box in the view."""
        from ...bigcloud import in_view, view_matrix

        obj = self.view.source
        if self._bounds is None or self._bounds[0] is not obj:
            P = np.asarray(obj.points)
            self._bounds = (obj, np.array([P.min(axis=0), P.max(axis=0)]))
        lo, hi = self._bounds[1]
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return bool(in_view(view_matrix(camera, viewport), corners).all())

    def select(self, obj: Any, camera: dict[str, Any], viewport: tuple[int, int]) -> tuple[np.ndarray, Any] | None:
        """The cloud's rows in view (sorted) and their pyvista points, or None for the
        first paint. Pure numpy and pyvista data: runs off the loop."""
        if self.whole_in_view(camera, viewport):
            return None
        lod = self.index(obj)
        _, store_rows = lod.select(camera, viewport, self.limit)
        rows = np.sort(np.asarray(lod.source_index(store_rows), dtype=np.int64))
        poly = obj.subset(rows).to_pyvista()
        pts = np.asarray(poly.points)
        for name, axis in COORDS.items():
            if name not in poly.point_data:
                poly.point_data[name] = pts[:, axis] if len(pts) else np.zeros(0)
        return rows, poly

    def show(self, picked: tuple[np.ndarray, Any] | None) -> None:
        """Draw the selection (None: the first paint) and publish. Loop only."""
        view, base = self.view, self.base
        if base is None or view.shown is None:
            return
        if picked is None:
            if self.rows is None:
                return  # the first paint is shown already
            view.shown, self.rows, self.refined = base, None, None
            view.note = self.base_note
        else:
            rows, poly = picked
            view.shown = Shown(base.key, poly, "pointcloud", base.n_total, len(rows), base.units, base.ranges)
            self.rows, self.refined = rows, view.shown
            view.note = (
                f"showing {fmt_count(len(rows))} of {fmt_count(base.n_total)} points: those in view, "
                "denser where zoomed in (level of detail; computations use all points)"
            )
        view._draw()
        if self.state is not None:
            self.state.display_note = view.note
        self.cv.publish()

    def refine(self, camera: dict[str, Any], viewport: tuple[int, int] | None) -> None:
        """The browser's camera after an interaction: select (off the loop when one runs)
        and show."""
        if viewport is None or not self.applies():
            return
        if self.base is None or self.base.key != self.view.shown.key:
            self.shown_anew()
        self._gen += 1
        gen, obj = self._gen, self.view.source
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no loop (scripts, tests): at once
            self.show(self.select(obj, camera, viewport))
            return
        loop.create_task(self._refine_async(loop, gen, obj, camera, viewport))

    async def _refine_async(self, loop: Any, gen: int, obj: Any, camera: dict[str, Any], viewport: Any) -> None:
        try:
            picked = await loop.run_in_executor(None, self.select, obj, camera, viewport)
        except Exception as exc:  # a failed refinement leaves the view as it is
            log.warning("level of detail: %s", str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            return
        if gen != self._gen or self.view.source is not obj or not self.applies():
            return  # the camera moved on, or another item is shown
        if self.state is not None and hasattr(self.state, "__enter__"):
            with self.state:  # pushed at the end of the block (outside a trame call)
                self.show(picked)
        else:
            self.show(picked)

    def source_row(self, i: int) -> int | None:
        """The cloud's row of point ``i`` shown when refined (None: not refined)."""
        return None if self.rows is None else int(self.rows[i])
