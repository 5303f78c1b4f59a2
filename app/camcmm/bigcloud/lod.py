"""Level of detail for big clouds: a spatially uniform first paint and a view-dependent
selection that refines as the view zooms in.

:class:`LodIndex` holds the points in store order (:mod:`camcmm.bigcloud.grid`): the
occupied cells of one octree level in Morton order, the points of a cell in random order.
The first ``k_c`` points of cell ``c`` are then a random sample of that cell, so

* :meth:`LodIndex.uniform` takes ``k`` points split over the cells in proportion to their
  counts (largest remainder): a uniform subsample of the cloud, cell by cell;
* :meth:`LodIndex.select` takes only the cells the camera's view frustum reaches (each
  cell's box against the four side planes and the camera plane) and gives each visible
  cell a share in proportion to its size on the screen: ``k_c = min(n_c, floor(λ a_c))``
  with ``a_c`` the cell's projected area in pixels (its diagonal times the focal length in
  pixels over its depth, squared, at most the viewport) and ``λ`` the largest value whose
  shares add up to at most ``budget`` (water filling). The points then have about the
  same density per pixel everywhere on the screen; zooming in makes the cells in view
  bigger on the screen and fewer, so each gives more of its points, up to all of them.
  Every point returned is tested against the frustum itself (in front of the camera,
  inside the four side planes), so none lies outside the view, whatever the cells.

Both return points in an interleaved order (each cell's ``j``-th of ``k_c`` points at
``(j + 1/2) / k_c``), so any prefix of the result is itself spread over all the cells
(the browser draws a prefix while the view moves).

The camera is VTK's: ``position``, ``focal_point``, ``view_up`` (mm), ``view_angle``
(degrees, vertical), optionally ``parallel_projection`` with ``parallel_scale`` (mm, half
the viewport's height); the viewport ``(w, h)`` in pixels. :func:`view_matrix` gives the
model-view-projection matrix (world mm to clip coordinates) the client's ``cv_select``
also uses: a point is in view when ``w > 0``, ``|x| <= w`` and ``|y| <= w`` (no far plane).

Indices are rows of the store (``0 .. n-1``, store order); :meth:`LodIndex.source_index`
gives the rows of the source file (or of the array given to :meth:`LodIndex.from_points`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, ParameterError
from .grid import CELL_POINTS, Grid, cell_boxes, choose_level, largest_remainder, prefix_rows
from .store import layout, read_meta, sample_stride


def _vec(camera: Mapping[str, Any], key: str, default=None) -> np.ndarray:
    v = camera.get(key, default)
    try:
        a = np.asarray(v, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise ParameterError(f"camera {key!r} = {v!r}: expected three numbers (mm)") from None
    if not np.isfinite(a).all():
        raise ParameterError(f"camera {key!r} = {v!r}: not finite")
    return a


def view_matrix(camera: Mapping[str, Any], viewport: tuple[int, int]) -> np.ndarray:
    """4x4 model-view-projection (world mm -> clip) of a VTK-style camera dict for a
    viewport ``(w, h)`` px. Near plane at the camera (``w > 0``), no far plane."""
    w, h = (float(x) for x in viewport)
    if not (w >= 1 and h >= 1):
        raise ParameterError(f"viewport {viewport!r}: width and height must be at least 1 px")
    eye, focal = _vec(camera, "position"), _vec(camera, "focal_point")
    up = _vec(camera, "view_up", (0.0, 0.0, 1.0))
    fwd = focal - eye
    if not np.linalg.norm(fwd) > 0:
        raise ParameterError("camera: position and focal_point coincide")
    f = fwd / np.linalg.norm(fwd)
    s = np.cross(f, up)
    if not np.linalg.norm(s) > 1e-12:
        raise ParameterError("camera: view_up is parallel to the view direction")
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = s, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    proj = np.zeros((4, 4))
    aspect = w / h
    if camera.get("parallel_projection"):
        scale = float(camera.get("parallel_scale", 0.0))
        if not scale > 0:
            raise ParameterError(f"camera parallel_scale = {camera.get('parallel_scale')!r}: must be above 0 mm")
        proj[0, 0], proj[1, 1], proj[3, 3] = 1.0 / (scale * aspect), 1.0 / scale, 1.0
        proj[2, 2] = -1.0  # depth along the view; w stays 1 (everything in front and behind is "in view")
    else:
        angle = float(camera.get("view_angle", 30.0))
        if not 0 < angle < 180:
            raise ParameterError(f"camera view_angle = {angle!r}: degrees between 0 and 180")
        t = 1.0 / math.tan(math.radians(angle) / 2)
        proj[0, 0], proj[1, 1] = t / aspect, t
        proj[2, 2], proj[3, 2] = -1.0, -1.0  # w = depth in front of the camera
    return proj @ view


def in_view(mvp: np.ndarray, points: np.ndarray) -> np.ndarray:
    """True for the points (mm) in front of the camera and inside the four side planes."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]

    def row(i: int) -> np.ndarray:  # by columns: a (N, 3) @ (3, 4) product goes through BLAS threads, 30x slower here
        return x * mvp[i, 0] + y * mvp[i, 1] + z * mvp[i, 2] + mvp[i, 3]

    w = row(3)
    return (w > 0) & (np.abs(row(0)) <= w) & (np.abs(row(1)) <= w)


def _boxes_in_view(mvp: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Boxes that may reach into the view: not wholly behind one of the planes
    ``w + x >= 0, w - x >= 0, w + y >= 0, w - y >= 0, w >= 0``."""
    r0, r1, r3 = mvp[0], mvp[1], mvp[3]
    planes = np.array([r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3])
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    reach = centre @ planes[:, :3].T + planes[:, 3] + half @ np.abs(planes[:, :3]).T
    return (reach >= 0).all(axis=1)


def water_fill(counts: np.ndarray, area: np.ndarray, budget: int) -> np.ndarray:
    """Shares ``min(counts, floor(λ area))`` with the largest ``λ`` whose shares add up to
    at most ``budget`` (all counts when they fit)."""
    if int(counts.sum()) <= budget:
        return counts.copy()
    t = counts / area  # λ at which a cell gives all its points
    order = np.argsort(t)
    tn, ta = t[order], area[order]
    full = np.concatenate([[0], np.cumsum(counts[order])])  # points of the cells saturated before j
    rest = np.concatenate([np.cumsum(ta[::-1])[::-1], [0.0]])  # area of the cells from j on
    # with the first j cells saturated: λ = (budget - full[j]) / rest[j], valid if <= tn[j]
    lam_j = (budget - full[:-1]) / np.maximum(rest[:-1], 1e-300)
    ok = np.flatnonzero(lam_j <= tn)
    lam = lam_j[ok[0]] if ok.size else tn[-1]
    share = np.minimum(counts, np.floor(lam * area)).astype(np.int64)
    while share.sum() > budget:  # rounding of λ: give back from the largest shares
        share[np.argmax(share)] -= 1
    return share


class LodIndex:
    """Level-of-detail access to a big cloud (see the module docstring)."""

    def __init__(
        self,
        points: np.ndarray,
        source_rows: np.ndarray,
        cells: np.ndarray,
        grid: Grid,
        bounds: np.ndarray,
        fields: Mapping[str, np.ndarray] | None = None,
        meta: dict[str, Any] | None = None,
    ):
        self._points = points
        self._rows = source_rows
        self.cell_ijk = cells[:, :3]
        self.cell_count = cells[:, 3]
        self.cell_start = np.cumsum(self.cell_count) - self.cell_count
        self.grid = grid
        self.bounds = bounds
        self._fields = dict(fields or {})
        self.meta = meta or {}
        self._box_lo, self._box_hi = cell_boxes(grid, self.cell_ijk)

    # -- construction
    @classmethod
    def from_points(
        cls,
        points: Any,
        *,
        seed: int = 0,
        fields: Mapping[str, Any] | None = None,
        cell_points: int = CELL_POINTS,
    ) -> LodIndex:
        """An index of ``points`` ((N, 3) float, mm) held in memory (a copy in store order);
        ``fields`` name -> (N,) arrays in the order of ``points``."""
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
            raise InputError(f"big cloud: points must have shape (N, 3) with N >= 1, got {p.shape}")
        if not np.isfinite(p).all():
            raise InputError("big cloud: points hold NaN or infinite coordinates")
        lo, hi = p.min(axis=0), p.max(axis=0)
        level = choose_level(p[:: sample_stride(len(p))], len(p), lo, hi, cell_points)
        grid = Grid.of(lo, hi, level)
        order, ijk, counts = layout(p, np.arange(len(p)), grid, seed)
        fl = {}
        for k, v in (fields or {}).items():
            a = np.asarray(v)
            if a.shape != (len(p),):
                raise InputError(f"big cloud: field {k!r} has shape {a.shape}, expected ({len(p)},)")
            fl[k] = a[order]
        cells = np.column_stack([ijk, counts]).astype(np.int64)
        return cls(p[order], order, cells, grid, np.array([lo, hi]), fl, {"n": len(p), "seed": seed})

    @classmethod
    def open(cls, folder: str | Path) -> LodIndex:
        """The index of a store built by :func:`camcmm.bigcloud.build_store`, memory-mapped."""
        f = Path(folder)
        meta = read_meta(f)
        try:
            points = np.load(f / "points.npy", mmap_mode="r")
            rows = np.load(f / "source_index.npy", mmap_mode="r")
            cells = np.load(f / "cells.npy")
            fields = {
                p.stem: np.load(p, mmap_mode="r")
                for p in sorted((f / "fields").glob("*.npy"))
                if not p.name.startswith(".")
            }
        except (OSError, ValueError) as exc:
            raise InputError(
                f"{folder}: damaged store ({type(exc).__name__}: {' '.join(str(exc).split())[:100]})"
            ) from None
        if points.shape != (meta["n"], 3) or int(cells[:, 3].sum()) != meta["n"]:
            raise InputError(f"{folder}: damaged store (points.npy or cells.npy disagree with meta.json n={meta['n']})")
        return cls(points, rows, cells, Grid.from_dict(meta["grid"]), np.array(meta["bounds"]), fields, meta)

    # -- properties
    @property
    def n(self) -> int:
        """Number of points."""
        return len(self._points)

    @property
    def field_names(self) -> list[str]:
        return sorted(self._fields)

    def points(self, index: Any) -> np.ndarray:
        """(k, 3) float64 points (mm) of store rows ``index``."""
        return self._take(self._points, np.asarray(index, dtype=np.int64))

    def source_index(self, index: Any) -> np.ndarray:
        """Rows in the source file (or in the array given to ``from_points``) of store rows ``index``."""
        return self._take(self._rows, np.asarray(index, dtype=np.int64))

    def fields(self, index: Any) -> dict[str, np.ndarray]:
        """Per-point scalar fields (name -> (k,) array) of store rows ``index``."""
        idx = np.asarray(index, dtype=np.int64)
        return {k: self._take(v, idx) for k, v in sorted(self._fields.items())}

    def add_field(self, name: str, values: np.ndarray) -> None:
        """Attach a per-point field in store order (e.g. the deviations of a comparison)."""
        if np.shape(values)[:1] != (self.n,):
            raise InputError(f"big cloud: field {name!r} has {np.shape(values)[:1]} values for {self.n} points")
        self._fields[name] = values

    @staticmethod
    def _take(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
        if isinstance(a, np.memmap) and len(idx) > 1:
            # sorted reads walk the file forwards; put the values back in the asked order
            order = np.argsort(idx, kind="stable")
            out = np.empty((len(idx), *a.shape[1:]), dtype=a.dtype)
            out[order] = a[idx[order]]
            return out
        return np.asarray(a[idx])

    # -- level of detail
    def uniform_index(self, k: int) -> np.ndarray:
        """Store rows of a spatially uniform subsample of ``min(k, n)`` points, interleaved."""
        k = int(k)
        if k < 0:
            raise ParameterError(f"uniform: k = {k} must not be negative")
        take = largest_remainder(k, self.cell_count)
        rows, frac = prefix_rows(self.cell_start, take)
        return rows[np.argsort(frac, kind="stable")]

    def uniform_points(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(points, store rows) of :meth:`uniform_index`, read in file order."""
        take = largest_remainder(int(k), self.cell_count)
        rows, frac = prefix_rows(self.cell_start, take)
        order = np.argsort(frac, kind="stable")
        return np.asarray(self._points[rows])[order], rows[order]

    def uniform(self, k: int) -> np.ndarray:
        """(min(k, n), 3) float64 points (mm), a spatially uniform subsample (first paint)."""
        if int(k) < 0:
            raise ParameterError(f"uniform: k = {k} must not be negative")
        return self.uniform_points(k)[0]

    def select(
        self, camera: Mapping[str, Any], viewport: tuple[int, int], budget: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """(points (k, 3) float64 mm, store rows (k,) int64) in the view, at most ``budget``,
        denser where the view is zoomed in (see the module docstring)."""
        budget = int(budget)
        if budget < 0:
            raise ParameterError(f"select: budget = {budget} must not be negative")
        mvp = view_matrix(camera, viewport)
        vis = np.flatnonzero(_boxes_in_view(mvp, self._box_lo, self._box_hi))
        if vis.size == 0 or budget == 0:
            return np.empty((0, 3)), np.empty(0, dtype=np.int64)
        area = self._screen_area(camera, mvp, viewport, vis)
        counts, starts = self.cell_count[vis], self.cell_start[vis]
        take = water_fill(counts, area, budget)
        pts, rows, cell = self._prefixes(mvp, starts, take)
        if len(rows) < budget and np.any(take < counts):
            # Cells the frustum cuts lose the part of their prefix outside the view. Their
            # share in view f_c (estimated from the first round, (kept + 1/2) / (taken + 1))
            # scales what they hold and cover on the screen; the shares are filled again
            # and each cell gives share / f_c points of its prefix, so that about the
            # share lands in view. The interleaved order is then cut at the budget.
            kept = np.bincount(cell, minlength=len(vis))
            f = np.where(take > 0, (kept + 0.5) / (take + 1.0), 1.0)
            share = water_fill(np.floor(counts * f).astype(np.int64), area * f, budget)
            take = np.minimum(counts, np.ceil(share / f).astype(np.int64))
            pts, rows, cell = self._prefixes(mvp, starts, take)
        return pts[:budget], rows[:budget]

    def _prefixes(self, mvp: np.ndarray, starts: np.ndarray, take: np.ndarray):
        """The first ``take`` points of each cell in view, interleaved: (points, rows, cell)."""
        rows, frac = prefix_rows(starts, take)  # ascending: read in file order
        pts = np.asarray(self._points[rows])
        keep = np.flatnonzero(in_view(mvp, pts))
        order = keep[np.argsort(frac[keep], kind="stable")]  # only the points in view are ordered
        cell = np.repeat(np.arange(len(take)), take)
        return pts[order], rows[order], cell[order]

    def _screen_area(self, camera, mvp: np.ndarray, viewport, vis: np.ndarray) -> np.ndarray:
        """Projected area (px²) of the cells ``vis``: (diagonal x pixels per mm at the
        cell's depth)², at most the viewport's area."""
        w, h = (float(x) for x in viewport)
        diag = self.grid.cell * math.sqrt(3.0)
        if camera.get("parallel_projection"):
            px = h / (2.0 * float(camera["parallel_scale"]))
            side = np.full(vis.size, diag * px)
        else:
            centre = 0.5 * (self._box_lo[vis] + self._box_hi[vis])
            depth = centre @ mvp[3, :3] + mvp[3, 3]
            focal = 0.5 * h * mvp[1, 1]  # pixels per mm at depth 1 mm
            side = np.where(depth > 0.5 * diag, diag * focal / np.maximum(depth, 1e-300), np.inf)
        return np.minimum(side * side, w * h)
