"""Analytic scene primitives for the virtual lab: sphere, finite cylinder, rectangle.

Each primitive samples points uniformly over its surface (with outward unit normals)
and intersects rays exactly. Lengths in mm.

Why not Open3D's RaycastingScene: it casts against triangle meshes, and a tessellated
sphere carries a facet error (sagitta) into every simulated point. The simulator is
the ground truth of the acceptance-test checks, so its surfaces must be exact; the
three closed-form intersections below are a few vectorised lines each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

INF = np.inf


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ValueError(f"direction {v.tolist()} has zero length")
    return v / n


def orthonormal(axis) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``axis`` to a right-handed orthonormal frame."""
    a = _unit(axis)
    helper = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(a, u)


def _first_positive(t1: np.ndarray, t2: np.ndarray, eps: float) -> np.ndarray:
    """Smallest root > eps of each pair (INF when none)."""
    t1 = np.where(t1 > eps, t1, INF)
    t2 = np.where(t2 > eps, t2, INF)
    return np.minimum(t1, t2)


@dataclass
class Sphere:
    """A sphere; ``measured`` False makes it an occluder only (no points sampled)."""

    center: np.ndarray
    radius: float
    label: str = "sphere"
    measured: bool = True

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)

    @property
    def area(self) -> float:
        return 4 * np.pi * self.radius**2

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)  # Gaussian directions: uniform on the sphere
        return self.center + self.radius * d, d

    def intersect(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray:
        """Distance along unit rays ``o + t d`` to the first hit (INF for a miss)."""
        w = o - self.center
        b = np.einsum("ij,ij->i", d, w)
        c = np.einsum("ij,ij->i", w, w) - self.radius**2
        disc = b * b - c
        hit = disc >= 0
        s = np.sqrt(np.where(hit, disc, 0.0))
        t = _first_positive(-b - s, -b + s, eps)
        return np.where(hit, t, INF)


@dataclass
class Cylinder:
    """The lateral surface of a finite cylinder from ``p0`` to ``p1`` (a ball bar's bar,
    a sphere's stem)."""

    p0: np.ndarray
    p1: np.ndarray
    radius: float
    label: str = "cylinder"
    measured: bool = True

    def __post_init__(self) -> None:
        self.p0 = np.asarray(self.p0, dtype=float)
        self.p1 = np.asarray(self.p1, dtype=float)

    @property
    def height(self) -> float:
        return float(np.linalg.norm(self.p1 - self.p0))

    @property
    def area(self) -> float:
        return 2 * np.pi * self.radius * self.height

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        a = _unit(self.p1 - self.p0)
        u, v = orthonormal(a)
        phi = rng.uniform(0, 2 * np.pi, n)
        h = rng.uniform(0, self.height, n)
        nrm = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
        return self.p0 + h[:, None] * a + self.radius * nrm, nrm

    def intersect(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray:
        a = _unit(self.p1 - self.p0)
        w = o - self.p0
        dp = d - np.outer(d @ a, a)
        wp = w - np.outer(w @ a, a)
        A = np.einsum("ij,ij->i", dp, dp)
        B = 2 * np.einsum("ij,ij->i", dp, wp)
        C = np.einsum("ij,ij->i", wp, wp) - self.radius**2
        disc = B * B - 4 * A * C
        ok = (disc >= 0) & (A > 1e-15)
        s = np.sqrt(np.where(ok, disc, 0.0))
        A2 = np.where(ok, 2 * A, 1.0)
        out = np.full(len(o), INF)
        for t in ((-B - s) / A2, (-B + s) / A2):  # each root counts only within the height
            along = (w @ a) + t * (d @ a)
            good = ok & (t > eps) & (along >= 0) & (along <= self.height)
            out = np.where(good, np.minimum(out, t), out)
        return out


@dataclass
class Rectangle:
    """A flat rectangle: centre, long axis ``u`` (length), short axis in-plane
    (width), normal ``n`` (the side a sensor should see)."""

    center: np.ndarray
    axis: np.ndarray
    normal: np.ndarray
    length: float
    width: float
    label: str = "flat"
    measured: bool = True

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)
        n = _unit(self.normal)
        u = np.asarray(self.axis, dtype=float)
        u = _unit(u - (u @ n) * n)  # make the long axis exactly perpendicular to the normal
        self.axis, self.normal = u, n

    @property
    def area(self) -> float:
        return self.length * self.width

    @property
    def v(self) -> np.ndarray:
        return np.cross(self.normal, self.axis)

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        s = rng.uniform(-0.5, 0.5, (n, 2)) * [self.length, self.width]
        pts = self.center + s[:, :1] * self.axis + s[:, 1:] * self.v
        return pts, np.broadcast_to(self.normal, pts.shape).copy()

    def intersect(self, o: np.ndarray, d: np.ndarray, eps: float = 1e-9) -> np.ndarray:
        den = d @ self.normal
        safe = np.where(np.abs(den) > 1e-15, den, 1.0)
        t = ((self.center - o) @ self.normal) / safe
        p = o + t[:, None] * d - self.center
        inside = (np.abs(p @ self.axis) <= self.length / 2) & (np.abs(p @ self.v) <= self.width / 2)
        return np.where((np.abs(den) > 1e-15) & (t > eps) & inside, t, INF)


Primitive = Sphere | Cylinder | Rectangle
