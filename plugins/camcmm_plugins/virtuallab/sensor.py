"""Which surface points a sensor measures: viewpoints, facing and self-occlusion.

A point is measured when enough viewpoints see it: it faces the viewpoint within
``max_incidence`` (steeper flanks give no usable fringe contrast or texture), and the
straight line to the viewpoint crosses no primitive of the scene (self-occlusion, the
other sphere of a ball bar, the bar, a stem or plate).

Two set-ups (coordinates in the measuring-volume frame, mm: origin at the volume's
centre, +z towards the sensor):

* ``stereo_fringe``: the stereo fringe-projection system of the thesis ch. 3.3.1 / 5 —
  two cameras on a 199.35 mm baseline converging at 301 mm (38.6° apart) and the
  projector between them; a point needs all three (both cameras see it, it is lit).
* ``turntable``: a single camera and a turntable (thesis ch. 4.5: thirty images over
  180° at about 45° elevation); a point needs at least two views (triangulation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scene import Primitive

#: Stereo system of the thesis ch. 3.3.1: baseline 199.35 mm, convergence at 301 mm.
BASELINE = 199.35
CONVERGENCE = 301.0


@dataclass
class Sensor:
    """Viewpoints (V, 3) in mm; a point is measured when at least ``min_views`` see it
    (``None``: all of them); ``max_incidence`` in degrees from the surface normal."""

    viewpoints: np.ndarray
    min_views: int | None = None
    max_incidence: float = 75.0
    name: str = "sensor"

    def __post_init__(self) -> None:
        self.viewpoints = np.atleast_2d(np.asarray(self.viewpoints, dtype=float))

    @property
    def primary(self) -> np.ndarray:
        """The first viewpoint (camera 1): the line of sight for depth noise."""
        return self.viewpoints[0]

    def visible(self, points: np.ndarray, normals: np.ndarray, scene: list[Primitive]) -> np.ndarray:
        """Boolean mask of the points this sensor measures."""
        need = len(self.viewpoints) if self.min_views is None else self.min_views
        cos_max = np.cos(np.radians(self.max_incidence))
        count = np.zeros(len(points), dtype=np.int32)
        for vp in self.viewpoints:
            d = vp - points
            dist = np.linalg.norm(d, axis=1)
            d /= dist[:, None]
            ok = np.einsum("ij,ij->i", d, normals) >= cos_max
            idx = np.flatnonzero(ok)
            if len(idx):
                # start a hair off the surface so a point does not hit its own primitive
                o = points[idx] + 1e-6 * normals[idx]
                for prim in scene:
                    t = prim.intersect(o, d[idx])
                    blocked = t < dist[idx]
                    ok[idx[blocked]] = False
                    idx, o = idx[~blocked], o[~blocked]
                    if not len(idx):
                        break
            count += ok
        return count >= need


def stereo_fringe(center=(0.0, 0.0, 0.0)) -> Sensor:
    """Two cameras and a projector above the volume (thesis ch. 3.3.1 geometry)."""
    c = np.asarray(center, dtype=float)
    h = float(np.sqrt(CONVERGENCE**2 - (BASELINE / 2) ** 2))
    vps = [c + [-BASELINE / 2, 0, h], c + [BASELINE / 2, 0, h], c + [0, 0, CONVERGENCE]]
    return Sensor(np.array(vps), None, 75.0, "stereo fringe projection")


def turntable(
    center=(0.0, 0.0, 0.0),
    distance: float = 150.0,
    elevation: float = 45.0,
    start_azimuth: float = 0.0,
    span: float = 180.0,
    n_views: int = 30,
) -> Sensor:
    """A camera ring over ``span`` degrees of azimuth at ``elevation`` (thesis ch. 4.5)."""
    az = np.radians(start_azimuth + np.linspace(0, span, n_views))
    el = np.radians(elevation)
    ring = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.full(n_views, np.sin(el))])
    return Sensor(np.asarray(center, float) + distance * ring, 2, 80.0, "turntable photogrammetry")


def full() -> Sensor:
    """No occlusion model: every sampled point is measured (for analytic checks)."""
    return Sensor(np.zeros((0, 3)), 0, 90.0, "full coverage")
