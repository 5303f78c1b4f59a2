"""Ray casting for rendering: first hit, primitive and surface normal of every ray.

The analytic primitives of ``scene.py`` (sphere, finite cylinder, rectangle) keep their
exact intersections (quadrics carry no facet error); ``Box`` (gauge blocks, platens,
plates with thickness) is intersected by the slab method here, and ``Mesh`` (any
triangle mesh: a part, a CAD model) by Open3D's RaycastingScene (Embree BVH, float32,
~1e-5 relative precision). Lengths in mm.

Rays that share an origin (a camera's or projector's centre) are culled per primitive
by its bounding sphere's cone before the exact test, so a small artefact in a large
image costs little.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .scene import INF, Cylinder, Rectangle, Sphere, _unit

#: Rays fewer than this are intersected without culling.
_CULL_MIN = 4096


@dataclass
class Box:
    """An oriented box: centre (3,), ``axes`` (3, 3) rows = unit local x, y, z, and
    ``size`` (3,) full edge lengths along them (mm)."""

    center: np.ndarray
    axes: np.ndarray
    size: np.ndarray
    label: str = "box"
    measured: bool = True

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, float)
        a = np.asarray(self.axes, float).reshape(3, 3)
        q, r = np.linalg.qr(a.T)  # orthonormalise, keep the given directions
        self.axes = (q * np.sign(np.diag(r))).T
        self.size = np.asarray(self.size, float).reshape(3)
        if np.any(self.size <= 0):
            raise ValueError(f"box {self.label!r}: edge lengths {self.size.tolist()} must be > 0")

    @property
    def area(self) -> float:
        a, b, c = self.size
        return 2 * (a * b + b * c + c * a)

    def intersect(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray:
        ol = np.column_stack([(o - self.center) @ ax for ax in self.axes])  # 3 matvecs beat (N,3)@(3,3)
        dl = np.column_stack([d @ ax for ax in self.axes])
        h = self.size / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / dl
            t1, t2 = (-h - ol) * inv, (h - ol) * inv
        # a ray parallel to a slab: inside it -> the slab does not limit t (nan -> +-inf)
        lo = np.where(np.isnan(t1), -INF, np.minimum(t1, t2))
        hi = np.where(np.isnan(t1), INF, np.maximum(t1, t2))
        par = dl == 0
        outside = par & (np.abs(ol) > h)
        lo, hi = np.where(outside, INF, lo), np.where(outside, -INF, hi)
        tn, tf = lo.max(axis=1), hi.min(axis=1)
        ok = tn <= tf
        t = np.where(tn > eps, tn, np.where(tf > eps, tf, INF))
        return np.where(ok, t, INF)

    def normal(self, p: np.ndarray) -> np.ndarray:
        c = self.axes @ self.center
        q = np.column_stack([(p @ ax - ck) / hk for ax, ck, hk in zip(self.axes, c, self.size / 2)])
        k = np.argmax(np.abs(q), axis=1)
        s = np.sign(q[np.arange(len(q)), k])
        return s[:, None] * self.axes[k]


@dataclass
class Mesh:
    """A triangle mesh (vertices (V, 3) mm, triangles (T, 3) int), cast by Open3D."""

    vertices: np.ndarray
    triangles: np.ndarray
    label: str = "mesh"
    measured: bool = True
    _scene: object = field(default=None, repr=False)

    def __post_init__(self) -> None:
        self.vertices = np.asarray(self.vertices, float).reshape(-1, 3)
        self.triangles = np.asarray(self.triangles, np.int64).reshape(-1, 3)
        if not len(self.triangles):
            raise ValueError(f"mesh {self.label!r} has no triangles")

    @property
    def area(self) -> float:
        v = self.vertices[self.triangles]
        return float(0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum())

    def _raycaster(self):
        if self._scene is None:
            import open3d as o3d  # heavy; only scenes with meshes pay for it

            m = o3d.t.geometry.TriangleMesh()
            m.vertex.positions = o3d.core.Tensor(self.vertices.astype(np.float32))
            m.triangle.indices = o3d.core.Tensor(self.triangles.astype(np.int32))
            sc = o3d.t.geometry.RaycastingScene()
            sc.add_triangles(m)
            self._scene = (o3d, sc)
        return self._scene

    def cast(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
        """Distances (INF for a miss) and unit face normals of the hits."""
        o3d, sc = self._raycaster()
        o = np.broadcast_to(o, d.shape)
        rays = np.hstack([o, d]).astype(np.float32)
        r = sc.cast_rays(o3d.core.Tensor(rays))
        t = r["t_hit"].numpy().astype(float)
        n = r["primitive_normals"].numpy().astype(float)
        return np.where(t > eps, t, INF), n

    def intersect(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray:
        return self.cast(o, d, eps)[0]


def bounding_sphere(p) -> tuple[np.ndarray, float]:
    """Centre and radius (mm) of a sphere holding the primitive."""
    if isinstance(p, Sphere):
        return p.center, p.radius
    if isinstance(p, Cylinder):
        return (p.p0 + p.p1) / 2, float(np.hypot(p.height / 2, p.radius))
    if isinstance(p, Rectangle):
        return p.center, float(np.hypot(p.length, p.width) / 2)
    if isinstance(p, Box):
        return p.center, float(np.linalg.norm(p.size) / 2)
    if isinstance(p, Mesh):
        lo, hi = p.vertices.min(axis=0), p.vertices.max(axis=0)
        c = (lo + hi) / 2
        return c, float(np.linalg.norm(p.vertices - c, axis=1).max())
    raise TypeError(f"unknown primitive {type(p).__name__}")


def surface_normal(p, x: np.ndarray) -> np.ndarray:
    """Outward unit normals (N, 3) of primitive ``p`` at its surface points ``x``."""
    if isinstance(p, Sphere):
        return (x - p.center) / p.radius
    if isinstance(p, Cylinder):
        a = _unit(p.p1 - p.p0)
        w = x - p.p0
        r = w - np.outer(w @ a, a)
        return r / np.linalg.norm(r, axis=1, keepdims=True)
    if isinstance(p, Rectangle):
        return np.broadcast_to(p.normal, x.shape).copy()
    if isinstance(p, Box):
        return p.normal(x)
    raise TypeError(f"no analytic normal for {type(p).__name__}")


def _shared_origin(p, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray | None:
    """Distances for rays from one origin ``o`` (3,): the same closed forms as the
    primitives' own ``intersect``, with every origin-only term computed once (a matrix-
    vector product per ray instead of (N, 3) temporaries: ~5x faster). None: no fast form."""
    if isinstance(p, Sphere):
        w = o - p.center
        b = d @ w
        disc = b * b - (w @ w - p.radius**2)
        s = np.sqrt(np.where(disc >= 0, disc, 0.0))
        t1, t2 = -b - s, -b + s
        t = np.where(t1 > eps, t1, np.where(t2 > eps, t2, INF))
        return np.where(disc >= 0, t, INF)
    if isinstance(p, Rectangle):
        den = d @ p.normal
        ok = np.abs(den) > 1e-15
        t = ((p.center - o) @ p.normal) / np.where(ok, den, 1.0)
        w = o - p.center
        a = w @ p.axis + t * (d @ p.axis)
        b = w @ p.v + t * (d @ p.v)
        inside = (np.abs(a) <= p.length / 2) & (np.abs(b) <= p.width / 2)
        return np.where(ok & (t > eps) & inside, t, INF)
    if isinstance(p, Box):  # slab method, one axis at a time
        ol = p.axes @ (o - p.center)
        tn = np.full(len(d), -INF)
        tf = np.full(len(d), INF)
        with np.errstate(divide="ignore", invalid="ignore"):
            for ax, olk, hk in zip(p.axes, ol, p.size / 2):
                inv = 1.0 / (d @ ax)
                t1, t2 = (-hk - olk) * inv, (hk - olk) * inv  # +-inf for rays parallel to the slab
                tn = np.fmax(tn, np.minimum(t1, t2))  # fmax/fmin skip a 0 * inf NaN
                tf = np.fmin(tf, np.maximum(t1, t2))
        t = np.where(tn > eps, tn, np.where(tf > eps, tf, INF))
        return np.where(tn <= tf, t, INF)
    if isinstance(p, Cylinder):
        a = _unit(p.p1 - p.p0)
        w = o - p.p0
        da = d @ a
        wa = w @ a
        wp = w - wa * a
        dw = d @ wp  # (d - (d.a) a) . wp = d . wp as wp is normal to a
        A = 1.0 - da * da
        B = 2 * dw
        C = wp @ wp - p.radius**2
        disc = B * B - 4 * A * C
        ok = (disc >= 0) & (A > 1e-15)
        s = np.sqrt(np.where(ok, disc, 0.0))
        A2 = np.where(ok, 2 * A, 1.0)
        out = np.full(len(d), INF)
        for t in ((-B - s) / A2, (-B + s) / A2):
            along = wa + t * da
            good = ok & (t > eps) & (along >= 0) & (along <= p.height)
            out = np.where(good, np.minimum(out, t), out)
        return out
    return None


def _candidates(p, o: np.ndarray, d: np.ndarray) -> np.ndarray | None:
    """Indices of rays that may hit ``p`` (None: all), for a common origin ``o`` (3,)."""
    if o.ndim != 1 or len(d) < _CULL_MIN or isinstance(p, Mesh):
        return None
    c, r = bounding_sphere(p)
    w = c - o
    dist = float(np.linalg.norm(w))
    if dist <= r * (1 + 1e-9):
        return None  # origin inside the bound: no cone
    cos_cone = np.sqrt(max(1.0 - (r / dist) ** 2, 0.0)) * (1 - 1e-12)
    sel = np.flatnonzero(d @ (w / dist) >= cos_cone - 1e-12)
    return None if len(sel) > 0.7 * len(d) else sel  # mostly covered: skip the gather


def cast(scene: list, o: np.ndarray, d: np.ndarray, want_normals: bool = True):
    """First hit of rays ``o + t d`` (o (3,) shared or (N, 3); d (N, 3) unit) among the
    primitives: distance t (N,) (INF for a miss), primitive index (N,) (-1 for a miss)
    and, with ``want_normals``, outward unit normals (N, 3) (zeros for a miss)."""
    o = np.asarray(o, float)
    n = len(d)
    t = np.full(n, INF)
    idx = np.full(n, -1, np.int32)
    mesh_normals: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k, p in enumerate(scene):
        sel = _candidates(p, o, d)
        if sel is not None and not len(sel):
            continue
        oo = o if (o.ndim == 1 or sel is None) else o[sel]
        dd = d if sel is None else d[sel]
        nk = None
        if isinstance(p, Mesh):
            tk, nk = p.cast(oo, dd)
        elif oo.ndim == 1 and (shared := _shared_origin(p, oo, dd)) is not None:
            tk = shared
        else:
            tk = p.intersect(np.broadcast_to(oo, dd.shape), dd)
        if sel is None:
            better = np.flatnonzero(tk < t)
            rows, tb = better, tk[better]
        else:
            better = np.flatnonzero(tk < t[sel])
            rows, tb = sel[better], tk[better]
        t[rows] = tb
        idx[rows] = k
        if nk is not None:
            mesh_normals[k] = (rows, nk[better])
    if not want_normals:
        return t, idx
    normals = np.zeros((n, 3))
    for k, p in enumerate(scene):
        rows = np.flatnonzero(idx == k)
        if not len(rows):
            continue
        if isinstance(p, Mesh):
            r_all, n_all = mesh_normals[k]
            keep = idx[r_all] == k  # rows a later primitive did not take over
            normals[r_all[keep]] = n_all[keep]
        elif isinstance(p, Rectangle):
            normals[rows] = p.normal  # constant: no hit points needed
        else:
            x = (o if o.ndim == 1 else o[rows]) + t[rows, None] * d[rows]
            normals[rows] = surface_normal(p, x)
    return t, idx, normals


#: Primitives a point on them, facing the light, cannot shadow (convex or flat).
_CONVEX = (Sphere, Box, Rectangle)


def occluded(
    scene: list, o: np.ndarray, d: np.ndarray, dist: np.ndarray, own: np.ndarray, eps: float = 1e-3
) -> np.ndarray:
    """Whether each ray from the shared origin ``o`` (3,) along unit ``d`` (N, 3) meets a
    primitive before ``dist - eps`` (N,) mm: the shadow test of surface points seen
    from a light at ``o``. ``own`` (N,) is the primitive each point lies on; a convex or
    flat one cannot shadow its own points that face the light, so it is skipped for them.
    Rays already found blocked are not tested again."""
    blocked = np.zeros(len(d), bool)
    for k, p in enumerate(scene):
        open_ = ~blocked
        if isinstance(p, _CONVEX):
            open_ &= own != k
        cand = _candidates(p, o, d)
        rows = np.flatnonzero(open_) if cand is None else cand[open_[cand]]
        if not len(rows):
            continue
        dd = d[rows]
        if isinstance(p, Mesh):
            tk = p.cast(o, dd)[0]
        else:
            shared = _shared_origin(p, o, dd)
            tk = shared if shared is not None else p.intersect(np.broadcast_to(o, dd.shape), dd)
        blocked[rows[tk < dist[rows] - eps]] = True
    return blocked
