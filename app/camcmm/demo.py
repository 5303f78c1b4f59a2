"""The demo project: simulated measurements a new user can open at once.

The clouds are generated here with known geometry (so every figure the demo shows can
be checked): a partially covered sphere scan with noise, a flat with a slight bow, a
ball bar, and a CAD-like sphere mesh as a nominal. Seeded, so the demo is the same
on every machine.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .model import PointCloud, TriangleMesh
from .project import Project

SEED = 2634


def _sphere_scan(rng: np.random.Generator, center, radius: float, n: int, noise: float, cap_deg: float = 120.0):
    """Points spread uniformly over the cap of a sphere a scanner sees from +z (polar
    angle 0..``cap_deg``), with normal noise of ``noise`` mm along the radius.
    Returns the points and each point's radial deviation (mm)."""
    cos_min = np.cos(np.radians(cap_deg))
    u = rng.uniform(cos_min, 1.0, n)  # uniform on the cap's area
    phi = rng.uniform(0.0, 2 * np.pi, n)
    s = np.sqrt(1.0 - u**2)
    dirs = np.column_stack([s * np.cos(phi), s * np.sin(phi), u])
    r = radius + rng.normal(0.0, noise, n)
    return np.asarray(center) + dirs * r[:, None], r - radius


def _flat(rng: np.random.Generator, length: float, width: float, n: int, noise: float, bow: float):
    x = rng.uniform(-length / 2, length / 2, n)
    y = rng.uniform(-width / 2, width / 2, n)
    z = bow * (1.0 - (2 * x / length) ** 2) + rng.normal(0.0, noise, n)
    return np.column_stack([x, y, z])


def _icosphere(radius: float, subdivisions: int = 4) -> TriangleMesh:
    """A sphere mesh by subdividing an icosahedron (exact vertices on the sphere)."""
    t = (1 + 5**0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                  [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                  [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                  [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    for _ in range(subdivisions):
        edges = np.sort(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = len(v) + inverse.reshape(3, -1).T  # midpoint index of edges 01, 12, 20
        v = np.vstack([v, v[unique].mean(axis=1)])
        a, b, c = f.T
        ab, bc, ca = mid.T
        f = np.vstack([np.column_stack(x) for x in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    v = v / np.linalg.norm(v, axis=1, keepdims=True) * radius
    return TriangleMesh(v, f, name="sphere nominal (CAD)")


def create_demo(directory: str | Path) -> dict[str, Any]:
    """Create (or re-open) the demo project in ``directory``; returns a summary dict."""
    directory = Path(directory)
    with Project.open_or_create(directory, name="camcmm demo") as project:
        if project.measurements():
            return _summary(project)
        rng = np.random.default_rng(SEED)
        pts, dev = _sphere_scan(rng, (10.0, -5.0, 40.0), 10.0, 60_000, 0.004)
        sphere = PointCloud(pts, fields={"radial_deviation": dev}, field_units={"radial_deviation": "mm"},
                            name="sphere scan (20 mm ball)")
        a, _ = _sphere_scan(rng, (-25.0, 0.0, 0.0), 10.0, 40_000, 0.005)
        b, _ = _sphere_scan(rng, (24.944, 0.0, 0.0), 10.0, 40_000, 0.005)
        ballbar = PointCloud(np.vstack([a, b]), name="ball bar (49.944 mm)")
        flat = PointCloud(_flat(rng, 150.0, 60.0, 80_000, 0.003, 0.010), name="flat (150 x 60 mm)")
        for cloud, kind in ((sphere, "pointcloud"), (ballbar, "pointcloud"), (flat, "pointcloud"),
                            (_icosphere(10.0), "mesh")):
            project.add_measurement(cloud.name, project.add_object(cloud, cloud.name), kind=kind)
        return _summary(project)


def _summary(project: Project) -> dict[str, Any]:
    return {
        "project": str(project.path),
        "name": project.name,
        "measurements": [{"id": m["id"], "name": m["name"], "kind": m["kind"]} for m in project.measurements()],
    }
