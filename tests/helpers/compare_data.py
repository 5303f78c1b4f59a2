"""The Compare-with-CAD case the GUI tests share: a CAD box (40 x 30 x 20 mm) and a cloud sampled on
it with 5 um noise and a 30 um bump on the top face, moved by a known rigid motion."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from camcmm import io as cio
from camcmm.model import PointCloud, TriangleMesh
from helpers.shapes import box_mesh

LO, HI = np.array([0.0, 0.0, 0.0]), np.array([40.0, 30.0, 20.0])
NOISE, BUMP = 0.005, 0.03
ANGLE = math.radians(2.0)
MOTION = np.array(
    [
        [math.cos(ANGLE), -math.sin(ANGLE), 0, 0.3],
        [math.sin(ANGLE), math.cos(ANGLE), 0, -0.2],
        [0, 0, 1, 0.1],
        [0, 0, 0, 1.0],
    ]
)


def surface_points(V, F, n, rng):
    tri = V[F]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    k = rng.choice(len(F), n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    t = tri[k]
    return (1 - s)[:, None] * t[:, 0] + (s * (1 - r2))[:, None] * t[:, 1] + (s * r2)[:, None] * t[:, 2]


def make_pair(folder: Path, n: int = 12000, offset=(0.0, 0.0, 0.0)) -> tuple[Path, Path, np.ndarray]:
    """box.stl and scan.ply (moved by MOTION, and by ``offset`` on top); returns the paths
    and the cloud's points in nominal coordinates (before the motion)."""
    V, F = box_mesh(LO, HI, n=4)
    rng = np.random.default_rng(3)
    P = surface_points(V, F, n, rng)
    top = P[:, 2] > HI[2] - 1e-9
    P[top, 2] += BUMP * np.exp(-((P[top, 0] - 20) ** 2 + (P[top, 1] - 15) ** 2) / 20)
    P += NOISE * rng.normal(size=P.shape)
    moved = P @ MOTION[:3, :3].T + MOTION[:3, 3] + np.asarray(offset)
    folder.mkdir(parents=True, exist_ok=True)
    cio.write(TriangleMesh(V, F, name="box"), folder / "box.stl")
    cio.write(PointCloud(moved, name="scan"), folder / "scan.ply")
    return folder / "box.stl", folder / "scan.ply", P


def imported(app, tmp_path, **kw):
    stl, ply, truth = make_pair(tmp_path / "files", **kw)
    server, session = app()
    for f in (stl, ply):
        assert session.import_file(f) is not None, server.state.error_message
    page = server.pages["compare"]
    page.refresh_inputs()
    return server, session, page, truth
