"""The Photogrammetry page's own 3-D scene: the sparse or dense cloud with the
registered cameras drawn around it as small frusta.

A camera of the reconstruction maps a world point X to camera coordinates
``x = R X + t`` (COLMAP's convention, which the plugin reports); the camera looks along
its +z axis, image x to the right and y down, and sits at ``C = −Rᵀ t``. Its frustum
is the apex C and the four rays through the image corners ``((u − cx)/fx, (v − cy)/fy, 1)``
turned into the world by Rᵀ, cut at a depth proportional to the cameras' distance from the cloud.

:class:`PhotoScene` is a :class:`camcmm.gui.view.SceneView` (same decimation, colouring
and legend; the view tools work on it) that draws the frusta again whenever the cloud
is drawn. Loop thread only.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...view import SceneView

#: colour of the camera frusta (orange: apart from the clouds' viridis and RGB)
CAMERA_COLOUR = "#e8710a"
#: a frustum: apex + 4 corners, 8 edges
POINTS_PER_CAMERA = 5


def frustum_points(R: Any, centre: Any, camera: dict[str, Any] | None, depth: float) -> np.ndarray:
    """(5, 3) world points of one camera's frustum: the centre, then the image corners
    (0, 0), (w, 0), (w, h), (0, h) at ``depth`` along the optical axis (mm).

    ``camera``: ``{fx, fy, cx, cy}`` in px (the image size taken as 2·cx × 2·cy);
    without it a 4:3 view with a 50° horizontal angle."""
    R = np.asarray(R, dtype=float).reshape(3, 3)
    C = np.asarray(centre, dtype=float).reshape(3)
    cam = camera or {}
    try:
        fx, fy = float(cam["fx"]), float(cam.get("fy") or cam["fx"])
        cx, cy = float(cam["cx"]), float(cam["cy"])
        if not (fx > 0 and fy > 0 and cx > 0 and cy > 0):
            raise ValueError
    except (KeyError, TypeError, ValueError):
        fx = fy = 1.0 / np.tan(np.radians(25.0))
        cx, cy = 1.0, 0.75
    corners = [(0.0, 0.0), (2 * cx, 0.0), (2 * cx, 2 * cy), (0.0, 2 * cy)]
    rays = np.array([[(u - cx) / fx, (v - cy) / fy, 1.0] for u, v in corners])
    return np.vstack([C, C + depth * (rays @ R)])  # rays @ R == (Rᵀ rays)ᵀ


def frustum_depth(centres: np.ndarray, cloud_points: np.ndarray | None) -> float:
    """The frusta's depth: 15 % of the median distance from the cameras to the cloud's
    median point (what they look at; a short arc of cameras as well as a ring), else of
    the cameras' spread about their mean, else 1."""
    C = np.asarray(centres, dtype=float).reshape(-1, 3)
    if cloud_points is not None and len(cloud_points) and len(C):
        r = float(np.median(np.linalg.norm(C - np.median(np.asarray(cloud_points, dtype=float), axis=0), axis=1)))
        if r > 0:
            return 0.15 * r
    if len(C) >= 2:
        r = float(np.median(np.linalg.norm(C - C.mean(axis=0), axis=1)))
        if r > 0:
            return 0.15 * r
    return 1.0


def frusta_polydata(views: list[dict[str, Any]], camera: dict[str, Any] | None, depth: float) -> Any:
    """All frusta as one pyvista PolyData of lines (8 edges each; one actor draws them)."""
    import pyvista as pv

    pts, lines = [], []
    for k, view in enumerate(views):
        pts.append(frustum_points(view["R"], view["centre"], camera, depth))
        o = POINTS_PER_CAMERA * k
        for a, b in ((0, 1), (0, 2), (0, 3), (0, 4), (1, 2), (2, 3), (3, 4), (4, 1)):
            lines.append([2, o + a, o + b])
    if not pts:
        return None
    return pv.PolyData(np.vstack(pts), lines=np.asarray(lines, dtype=np.int64).ravel())


class PhotoScene(SceneView):
    """A SceneView that also draws the registered cameras (:meth:`set_cameras`)."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.views: list[dict[str, Any]] = []
        self.camera: dict[str, Any] | None = None
        self.camera_actor: Any = None

    def set_cameras(self, views: list[dict[str, Any]], camera: dict[str, Any] | None) -> None:
        """The registered views (``{image, R, t, centre}``) and the shared camera; drawn
        with the cloud (now, when one is shown)."""
        self.views = [v for v in views or [] if v.get("R") is not None and v.get("centre") is not None]
        self.camera = camera
        if self.shown is not None:
            self._draw()
            self._changed(reset_camera=False)

    def _draw(self) -> None:
        super()._draw()
        self._draw_cameras()

    def _draw_cameras(self) -> None:
        self.camera_actor = None
        if not self.views:
            return
        cloud = None if self.shown is None else np.asarray(self.shown.poly.points)
        depth = frustum_depth(np.array([v["centre"] for v in self.views], dtype=float), cloud)
        poly = frusta_polydata(self.views, self.camera, depth)
        if poly is not None:
            self.camera_actor = self.plotter.add_mesh(
                poly, color=CAMERA_COLOUR, line_width=2, reset_camera=False, name="cameras"
            )

    def clear(self) -> None:
        self.views, self.camera, self.camera_actor = [], None, None
        super().clear()

    def cameras_drawn(self) -> int:
        """How many camera frusta the scene holds now (counted from the drawn geometry)."""
        actor = self.camera_actor
        if actor is None or actor not in self.plotter.renderer.actors.values():
            return 0
        data = actor.GetMapper().GetInput()
        return int(data.GetNumberOfPoints()) // POINTS_PER_CAMERA if data is not None else 0
