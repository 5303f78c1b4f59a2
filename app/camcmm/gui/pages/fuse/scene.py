"""The Fuse page's own 3-D scene: the fused cloud (coloured by source by default) with
each CSI map's aligned footprint drawn as a closed outline.

The plugin reports a footprint as the map's four corners in the fused cloud's frame
(mm); :class:`FuseScene` is a :class:`camcmm.gui.view.SceneView` (same decimation,
colouring and legend; the view tools work on it) that draws the outlines again
whenever the cloud is drawn. Loop thread only.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...view import SceneView

#: colour of the footprint outlines (orange: apart from the clouds' viridis and RGB)
FOOTPRINT_COLOUR = "#e8710a"


def footprint_corners(view: dict[str, Any]) -> np.ndarray | None:
    """(4, 3) corners of one map's footprint (mm), or None when the view has none."""
    try:
        c = np.asarray(view.get("footprint"), dtype=float)
    except (TypeError, ValueError):
        return None
    return c if c.shape == (4, 3) and np.all(np.isfinite(c)) else None


#: the outline is lifted off the surface by this share of the footprint's diagonal, along its
#: normal (the side facing +z): drawn in the plane of the points, the points would hide it
LIFT = 0.01


def lifted(corners: np.ndarray) -> np.ndarray:
    """The footprint's corners moved LIFT × its diagonal along its normal (n_z ≥ 0)."""
    c = np.asarray(corners, dtype=float)
    n = np.cross(c[1] - c[0], c[3] - c[0])
    norm = float(np.linalg.norm(n))
    if norm == 0:
        return c
    n = n / norm if n[2] >= 0 else -n / norm
    return c + LIFT * float(np.linalg.norm(c[2] - c[0])) * n


def outlines_polydata(footprints: list[np.ndarray]) -> Any:
    """All footprints as one pyvista PolyData of closed outlines (4 edges each), lifted (:func:`lifted`)."""
    import pyvista as pv

    if not footprints:
        return None
    pts = np.vstack([lifted(c) for c in footprints])
    lines = []
    for k in range(len(footprints)):
        o = 4 * k
        lines += [[2, o + a, o + (a + 1) % 4] for a in range(4)]
    return pv.PolyData(pts, lines=np.asarray(lines, dtype=np.int64).ravel())


class FuseScene(SceneView):
    """A SceneView that also draws the CSI footprints (:attr:`footprints`)."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.footprints: list[np.ndarray] = []
        self.outline_actor: Any = None

    def set_footprints(self, views: list[dict[str, Any]]) -> None:
        """The maps' footprints from the plugin's ``views``; drawn with the cloud."""
        self.footprints = [c for c in (footprint_corners(v) for v in views or []) if c is not None]

    def _draw(self) -> None:
        super()._draw()
        self.outline_actor = None
        poly = outlines_polydata(self.footprints)
        if poly is not None:
            self.outline_actor = self.plotter.add_mesh(
                poly, color=FOOTPRINT_COLOUR, line_width=4, reset_camera=False, name="footprints"
            )

    def clear(self) -> None:
        self.footprints, self.outline_actor = [], None
        super().clear()

    def outlines_drawn(self) -> int:
        """How many footprint outlines the scene holds now (counted from the drawn geometry)."""
        actor = self.outline_actor
        if actor is None or actor not in self.plotter.renderer.actors.values():
            return 0
        data = actor.GetMapper().GetInput()
        return int(data.GetNumberOfPoints()) // 4 if data is not None else 0
