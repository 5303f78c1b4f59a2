"""The four additive-manufacturing test artefacts of thesis ch. 6.2 (fig. 6.9), derived
from NIST's AM test artefact: pyramid (step heights), recess, sphere and pillars, as
closed CAD triangle meshes with every triangle tagged by its face class. Lengths in mm.

The thesis gives no dimensions, only the features: (a) a recess into the surface, (b) a
sphere mounted in the centre (steep, varying slope), (c) a stepped pyramid (changing step
heights, depth of field), (d) pillars of different height and diameter (occlusions). The
defaults below are sizes of that kind on a 40 x 40 mm plate; every one is a parameter.

Face classes (``FACE_CLASSES``): ``top`` (faces looking up: plate, step tops, recess
floor, pillar tops), ``side`` (vertical walls), ``curved`` (the sphere) and ``bottom``
(the underside, which a camera above the table never sees). Area coverage is reported
per class.

Construction: every surface is a band between two "rings" of ``n`` points at the same
azimuths θ_k = 2πk/n (a circle, or a square's boundary at those azimuths, ``n`` a
multiple of 8 so the corners are among them), or a fan from a ring to its centre, so
neighbouring pieces share vertices exactly and the welded mesh is closed (no
T-junctions). Each piece's triangles are turned to face their stated side (up, down,
away from or towards an axis or centre), so the mesh is wound outwards.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

NAMES = ("am_pyramid", "am_recess", "am_sphere", "am_pillars")
FACE_CLASSES = ("top", "side", "curved", "bottom")

#: Default sizes (mm); a study file may override any key.
DEFAULTS: dict[str, dict[str, Any]] = {
    "am_pyramid": {"plate": [40.0, 4.0], "steps": [[30.0, 3.0], [22.0, 3.0], [14.0, 3.0], [6.0, 3.0]]},
    "am_recess": {"plate": [40.0, 10.0], "recess": [20.0, 6.0]},
    "am_sphere": {"plate": [40.0, 4.0], "diameter": 20.0, "centre_height": 6.0},
    "am_pillars": {
        "plate": [40.0, 4.0],
        # [diameter, height] in the four 20 mm cells of the plate
        "pillars": [[8.0, 6.0], [6.0, 10.0], [4.0, 14.0], [3.0, 8.0]],
    },
}


def _ring(shape: str, half: float, z: float, n: int, cx: float = 0.0, cy: float = 0.0) -> np.ndarray:
    th = 2 * np.pi * np.arange(n) / n
    c, s = np.cos(th), np.sin(th)
    if shape == "square":  # the square's boundary point at azimuth θ
        m = np.maximum(np.abs(c), np.abs(s))
        c, s = c / m, s / m
    return np.column_stack([cx + half * c, cy + half * s, np.full(n, z)])


class _Builder:
    def __init__(self) -> None:
        self.tris: list[np.ndarray] = []  # (k, 3, 3) corner coordinates
        self.cls: list[np.ndarray] = []

    def _add(self, t: np.ndarray, cls: str, facing) -> None:
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        want = facing(t.mean(axis=1))
        flip = np.einsum("ij,ij->i", n, want) < 0
        t[flip] = t[flip][:, [0, 2, 1]]
        self.tris.append(t)
        self.cls.append(np.full(len(t), FACE_CLASSES.index(cls)))

    def band(self, a: np.ndarray, b: np.ndarray, cls: str, facing) -> None:
        a1, b1 = np.roll(a, -1, axis=0), np.roll(b, -1, axis=0)
        t = np.concatenate([np.stack([a, a1, b1], 1), np.stack([a, b1, b], 1)])
        self._add(t, cls, facing)

    def fan(self, ring: np.ndarray, centre, cls: str, facing) -> None:
        c = np.broadcast_to(np.asarray(centre, float), ring.shape)
        self._add(np.stack([ring, np.roll(ring, -1, axis=0), c], 1).copy(), cls, facing)

    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        T = np.concatenate(self.tris)
        cls = np.concatenate(self.cls)
        area = 0.5 * np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1)
        keep = area > 1e-12  # fans and bands of coincident rings leave slivers of zero area
        T, cls = T[keep], cls[keep]
        # weld on a 1 nm grid: shared ring points are computed identically, rounding only
        # absorbs the last bits of the trigonometry
        V, inv = np.unique(np.round(T.reshape(-1, 3), 6), axis=0, return_inverse=True)
        return V, inv.reshape(-1, 3).astype(np.int64), cls


UP = lambda p: np.tile([0.0, 0.0, 1.0], (len(p), 1))  # noqa: E731
DOWN = lambda p: np.tile([0.0, 0.0, -1.0], (len(p), 1))  # noqa: E731


def _away(cx: float = 0.0, cy: float = 0.0, sign: float = 1.0):
    return lambda p: sign * np.column_stack([p[:, 0] - cx, p[:, 1] - cy, np.zeros(len(p))])


def _plate_sides_and_bottom(b: _Builder, top_ring: np.ndarray) -> None:
    bottom = top_ring.copy()
    bottom[:, 2] = 0.0
    b.band(top_ring, bottom, "side", _away())
    b.fan(bottom, (0.0, 0.0, 0.0), "bottom", DOWN)


def pyramid(plate=(40.0, 4.0), steps=((30.0, 3.0), (22.0, 3.0), (14.0, 3.0), (6.0, 3.0)), n: int = 32):
    """A square plate (side, thickness) and square steps (side, height) stacked centred."""
    side, thick = (float(x) for x in plate)
    b = _Builder()
    rings = [(side / 2, thick)]
    z = thick
    for s, h in steps:
        rings.append((float(s) / 2, z))  # the step's foot on the level below
        z += float(h)
        rings.append((float(s) / 2, z))
    sq = [_ring("square", hf, zz, n) for hf, zz in rings]
    _plate_sides_and_bottom(b, sq[0])
    for k in range(1, len(sq), 2):
        b.band(sq[k - 1], sq[k], "top", UP)  # the level's top: the annulus out to the last wall
        b.band(sq[k], sq[k + 1], "side", _away())
    b.fan(sq[-1], (0.0, 0.0, z), "top", UP)
    return b.mesh()


def recess(plate=(40.0, 10.0), recess=(20.0, 6.0), n: int = 32):
    """A square block (side, height) with a centred square recess (side, depth)."""
    side, height = (float(x) for x in plate)
    rs, depth = (float(x) for x in recess)
    b = _Builder()
    outer = _ring("square", side / 2, height, n)
    rim = _ring("square", rs / 2, height, n)
    floor = _ring("square", rs / 2, height - depth, n)
    _plate_sides_and_bottom(b, outer)
    b.band(outer, rim, "top", UP)
    b.band(rim, floor, "side", _away(sign=-1.0))  # the recess walls face its axis
    b.fan(floor, (0.0, 0.0, height - depth), "top", UP)
    return b.mesh()


def sphere(plate=(40.0, 4.0), diameter: float = 20.0, centre_height: float = 6.0, n: int = 64, n_lat: int = 24):
    """A square plate with a sphere whose centre stands ``centre_height`` above the plate's
    top, the plate cutting it in a circle."""
    side, thick = (float(x) for x in plate)
    R, h = float(diameter) / 2, float(centre_height)
    if not -R < h < R:
        raise ValueError(f"am_sphere: centre_height {h} must lie within ±{R} (the radius) of the plate")
    b = _Builder()
    outer = _ring("square", side / 2, thick, n)
    c = np.array([0.0, 0.0, thick + h])
    phi0 = np.arcsin(-h / R)  # latitude of the cut
    lat = np.linspace(phi0, np.pi / 2, n_lat + 1)[:-1]
    rings = [_ring("circle", R * np.cos(p), thick + h + R * np.sin(p), n) for p in lat]
    _plate_sides_and_bottom(b, outer)
    b.band(outer, rings[0], "top", UP)
    out = lambda p: p - c  # noqa: E731
    for r0, r1 in zip(rings[:-1], rings[1:]):
        b.band(r0, r1, "curved", out)
    b.fan(rings[-1], c + [0.0, 0.0, R], "curved", out)
    return b.mesh()


def pillars(plate=(40.0, 4.0), pillars=((8.0, 6.0), (6.0, 10.0), (4.0, 14.0), (3.0, 8.0)), n: int = 32):
    """A square plate split into a 2 x 2 grid of cells, a cylindrical pillar (diameter,
    height) standing in the centre of each (at most four; a cell without one stays flat)."""
    side, thick = (float(x) for x in plate)
    if len(pillars) > 4:
        raise ValueError(f"am_pillars: at most 4 pillars (one per quarter of the plate), got {len(pillars)}")
    b = _Builder()
    q = side / 4
    centres = [(-q, -q), (q, -q), (q, q), (-q, q)]
    for k, (cx, cy) in enumerate(centres):
        cell = _ring("square", q, thick, n, cx, cy)
        if k >= len(pillars):
            b.fan(cell, (cx, cy, thick), "top", UP)
            continue
        d, hgt = (float(x) for x in pillars[k])
        if not 0 < d < 2 * q:
            raise ValueError(f"am_pillars: pillar {k + 1} diameter {d} must lie in (0, {2 * q}) mm")
        foot = _ring("circle", d / 2, thick, n, cx, cy)
        head = _ring("circle", d / 2, thick + hgt, n, cx, cy)
        b.band(cell, foot, "top", UP)
        b.band(foot, head, "side", _away(cx, cy))
        b.fan(head, (cx, cy, thick + hgt), "top", UP)
    # the plate's rim: the cells' outer boundary points, in order around the plate
    V, F, cls = b.mesh()
    b2 = _Builder()
    b2.tris, b2.cls = [V[F]], [cls]
    rim = _rim(V, side / 2, thick)
    _plate_sides_and_bottom(b2, rim)
    return b2.mesh()


def _rim(V: np.ndarray, half: float, z: float) -> np.ndarray:
    """The vertices on the plate's top edge, ordered by azimuth."""
    on = (np.abs(V[:, 2] - z) < 1e-9) & (np.max(np.abs(V[:, :2]), axis=1) > half - 1e-9)
    P = V[on]
    return P[np.argsort(np.arctan2(P[:, 1], P[:, 0]))]


def build(name: str, sizes: dict[str, Any] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """(vertices (V, 3) mm, triangles (T, 3), face class index (T,) into FACE_CLASSES,
    the sizes used) of artefact ``name``; ``sizes`` overrides ``DEFAULTS[name]``."""
    if name not in DEFAULTS:
        raise ValueError(f"artefact {name!r}: use one of {', '.join(NAMES)}")
    s = {**DEFAULTS[name], **(sizes or {})}
    unknown = set(s) - set(DEFAULTS[name])
    if unknown:
        raise ValueError(f"{name}: unknown size {sorted(unknown)[0]!r} (sizes: {', '.join(DEFAULTS[name])})")
    builders: dict[str, Callable[..., tuple[np.ndarray, np.ndarray, np.ndarray]]] = {
        "am_pyramid": pyramid,
        "am_recess": recess,
        "am_sphere": sphere,
        "am_pillars": pillars,
    }
    fn = builders[name]
    V, F, cls = fn(**s)
    return V, F, cls, s


def class_areas(V: np.ndarray, F: np.ndarray, cls: np.ndarray) -> dict[str, float]:
    """Area (mm²) of each face class."""
    t = V[F]
    a = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    return {c: float(a[cls == i].sum()) for i, c in enumerate(FACE_CLASSES)}
