"""Exact-by-construction test solids for the inspection tests, and checks of the solids.

- :func:`box_mesh`: an axis-aligned box whose faces are split into a grid of coplanar
  triangles, every face with its own vertices (as an STL file stores them).
- :func:`polycube`: the boundary of a union of cubes on a grid (an L, a step ... with
  concave edges and corners), each cube face split into coplanar triangles. Its exact
  signed distance comes from its boundary *rectangles*, independent of the triangles:
  the distance to an axis-aligned rectangle is that to the clamped point, and a point is
  inside when its grid cell is filled.
- :func:`rotate`: a generic rigid motion, applied to meshes and query points alike
  (distances are invariant), so nothing in a test stays axis-aligned.
"""

from __future__ import annotations

import numpy as np


def box_mesh(lo, hi, n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and outward-wound faces of the box [lo, hi], n×n quads per face."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    V, F, nv = [], [], 0
    g = np.linspace(0.0, 1.0, n + 1)
    U, W = np.meshgrid(g, g, indexing="ij")
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side in (0, 1):
            P = np.zeros(U.shape + (3,))
            P[..., axis] = hi[axis] if side else lo[axis]
            P[..., u] = lo[u] + U * (hi[u] - lo[u])
            P[..., v] = lo[v] + W * (hi[v] - lo[v])
            ids = np.arange(U.size).reshape(U.shape) + nv
            a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
            t = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
            if np.cross(np.eye(3)[u], np.eye(3)[v])[axis] != (1 if side else -1):
                t = t[:, ::-1]
            V.append(P.reshape(-1, 3))
            F.append(t)
            nv += U.size
    return np.concatenate(V), np.concatenate(F)


def box_sdf(p, lo, hi) -> np.ndarray:
    """Exact signed distance to the box [lo, hi] (negative inside)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    q = np.abs(p - (lo + hi) / 2) - (hi - lo) / 2
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


class Polycube:
    """Union of cubes of edge ``cell`` where ``occ`` is True (grid from the origin)."""

    def __init__(self, occ: np.ndarray, cell: float = 10.0, sub: int = 2):
        self.occ = np.asarray(occ, bool)
        self.cell = float(cell)
        pad = np.pad(self.occ, 1)
        V, F, rects, nv = [], [], [], 0
        g = np.linspace(0.0, cell, sub + 1)
        U, W = np.meshgrid(g, g, indexing="ij")
        for axis in range(3):
            u, v = [k for k in range(3) if k != axis]
            jump = np.diff(pad.astype(int), axis=axis)  # +1 empty -> full, -1 full -> empty
            for idx in zip(*np.nonzero(jump)):
                origin = (np.array(idx, float) - 1) * cell
                origin[axis] = idx[axis] * cell
                P = np.repeat(origin[None], U.size, 0)
                P[:, u] += U.ravel()
                P[:, v] += W.ravel()
                ids = np.arange(U.size).reshape(U.shape) + nv
                a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
                t = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
                outward = -1 if jump[idx] > 0 else 1
                if np.cross(np.eye(3)[u], np.eye(3)[v])[axis] != outward:
                    t = t[:, ::-1]
                V.append(P)
                F.append(t)
                nv += U.size
                hi = origin.copy()
                hi[u] += cell
                hi[v] += cell
                rects.append((origin, hi))
        self.vertices = np.concatenate(V)
        self.faces = np.concatenate(F)
        self.rects = rects

    def sdf(self, p: np.ndarray) -> np.ndarray:
        d = np.full(len(p), np.inf)
        for lo, hi in self.rects:
            d = np.minimum(d, np.linalg.norm(p - np.clip(p, lo, hi), axis=1))
        ijk = np.floor(p / self.cell).astype(int)
        ok = np.all((ijk >= 0) & (ijk < self.occ.shape), axis=1)
        inside = np.zeros(len(p), bool)
        inside[ok] = self.occ[tuple(ijk[ok].T)]
        return np.where(inside, -d, d)

    @property
    def area(self) -> float:
        return len(self.rects) * self.cell**2


def l_block() -> np.ndarray:
    """An asymmetric polycube: floor, a wall along x, a wall along y, a step and a notch."""
    occ = np.zeros((4, 3, 2), bool)
    occ[:, 0, :] = True
    occ[0, :, :] = True
    occ[:, :, 0] = True
    occ[3, 2, 0] = False
    occ[2, 1, 1] = True
    return occ


def rotation(angles_deg) -> np.ndarray:
    a, b, c = np.radians(angles_deg)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


#: A generic rigid motion: no axis stays aligned, and the part sits away from the origin.
R_GENERIC = rotation([23.0, -41.0, 67.0])
T_GENERIC = np.array([310.0, -125.0, 480.0])


def rotate(p: np.ndarray) -> np.ndarray:
    return p @ R_GENERIC.T + T_GENERIC


def unrotate(p: np.ndarray) -> np.ndarray:
    return (p - T_GENERIC) @ R_GENERIC


# --------------------------------------------------------------------------- checks
