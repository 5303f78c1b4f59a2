"""Depth-map fusion with a consistency check across views.

Every matched pixel of a pair's depth map becomes a world point; it is projected into the
depth maps of the other pairs whose reference view looks the same way, and each depth map
whose depth there agrees within a relative tolerance confirms it and adds its two views. A
point is kept where at least ``min_views`` distinct views agree (the pair itself counts two,
so the default 3 demands one independent confirmation), then the agreeing estimates are
averaged along each confirming view's ray and the cloud is thinned on a voxel grid. This is
the geometric-consistency filter of COLMAP's ``StereoFusion`` and of Shen 2013 reduced to
depth maps from rectified pairs; written with numpy because OpenCV has no fusion and
Open3D's TSDF integration needs a truncation scale and gives a mesh, not per-point view counts.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import Cancelled


def _points(m: dict, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points, their rectified depth and colours of a depth map's matched pixels on
    every ``m["stride"]``-th row and column (the lookups stay at full resolution): each
    surface patch is seen by many depth maps, so 2 loses little density after thinning and
    saves three quarters of the work."""
    rect, Z, s = m["rect"], m["Z"], m["stride"]
    vs, us = np.nonzero(np.isfinite(Z[::s, ::s]))
    v, u = vs * s, us * s
    z = Z[v, u].astype(np.float64)
    Y = np.c_[(u - rect.cx) * z / rect.f, (v - rect.cy) * z / rect.f, z]
    return centre + Y @ rect.Rn, z, m["colours"][vs, us]


def _projector(m: dict, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A, b`` (float32) with ``[u z, v z, z] = X A^T + b`` in the map's rectified image."""
    rect = m["rect"]
    K = np.array([[rect.f, 0, rect.cx], [0, rect.f, rect.cy], [0, 0, 1]])
    A = K @ rect.Rn
    return A.T.astype(np.float32), (-A @ centre).astype(np.float32)


def _lookup(m: dict, proj: tuple, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth of X (float32) as seen by depth map ``m`` (its rectified frame) and the map's
    depth there (NaN outside or unmatched)."""
    uvw = X @ proj[0] + proj[1]
    z = uvw[:, 2]
    H, W = m["Z"].shape
    with np.errstate(divide="ignore", invalid="ignore"):
        iu = np.floor(uvw[:, 0] / z + 0.5)
        iv = np.floor(uvw[:, 1] / z + 0.5)
    ok = (z > 0) & (iu >= 0) & (iu < W) & (iv >= 0) & (iv < H)
    idx = np.where(ok, iv * W + iu, 0).astype(np.intp)
    zq = np.where(ok, m["Z"].ravel()[idx], np.nan)
    return z, zq


def _near_views(axes: np.ndarray, n_check: int) -> np.ndarray:
    """For each view, itself and its ``n_check`` nearest views by optical-axis angle."""
    cos = axes @ axes.T
    return np.argsort(-cos, axis=1)[:, : n_check + 1]


def fuse(
    maps: list[tuple[int, int, dict | None]],
    centres: list[np.ndarray],
    axes: list[np.ndarray],
    *,
    min_views: int = 3,
    tol: float = 0.01,
    n_check: int = 8,
    voxel: float = 0.0,
    cancel: Any = None,
) -> tuple[dict[str, np.ndarray], list[dict]]:
    """Fuse per-pair depth maps into one cloud.

    Parameters
    ----------
    maps : list of (ref, src, depth map)
        As :func:`~.dense.depth_map` returns (None: the pair failed).
    centres, axes : list of (3,)
        Camera centres (world units) and optical axes of all views.
    min_views : int
        Distinct views that must agree on a point (the pair counts two).
    tol : float
        Relative depth agreement ``|z_q - z| <= tol z``.
    n_check : int
        Depth maps of the reference view and its ``n_check`` nearest views (by optical axis)
        are checked.
    voxel : float
        Edge of the thinning grid, world units (0: no thinning).

    Returns
    -------
    dict, list of dict
        ``points`` (N,3), ``colours`` (N,3) uint8, ``n_views`` (N,), ``quality`` (N,) in
        [0, 1] (1 - rms relative depth disagreement / ``tol``); per pair ``ref``, ``src``,
        ``valid``, ``consistent``.
    """
    C = np.asarray(centres, float)
    n = len(C)
    near = _near_views(np.asarray(axes, float), n_check)
    by_ref: dict[int, list[int]] = {}
    for q, (k, _, m) in enumerate(maps):
        if m is not None:
            by_ref.setdefault(k, []).append(q)
    projs = {q: _projector(m, C[k]) for q, (k, _, m) in enumerate(maps) if m is not None}
    out: dict[str, list] = {"points": [], "colours": [], "n_views": [], "quality": []}
    stats = []
    for p, (i, j, m) in enumerate(maps):
        if cancel is not None and cancel.is_set():
            raise Cancelled("dense cloud: cancelled")
        if m is None:
            stats.append({"ref": i, "src": j, "valid": 0, "consistent": 0})
            continue
        X, z, col = _points(m, C[i])
        seen = np.zeros((len(X), n), bool)
        seen[:, [i, j]] = True
        X32 = X.astype(np.float32)
        acc = X.copy()
        count = np.ones(len(X))
        sq = np.zeros(len(X))
        for k in near[i]:
            for q in by_ref.get(int(k), []):
                if q == p:
                    continue
                mq = maps[q][2]
                assert mq is not None  # by_ref holds only the views with a depth map
                zk, zq = _lookup(mq, projs[q], X32)
                with np.errstate(invalid="ignore"):
                    rel = (zq - zk) / zk
                    agree = np.flatnonzero(np.abs(rel) <= tol)
                # along the confirming view's ray: no lateral quantisation to its pixel grid
                ratio = 1.0 + rel[agree].astype(np.float64)
                acc[agree] += C[k] + (X[agree] - C[k]) * ratio[:, None]
                count[agree] += 1
                sq[agree] += ratio**2 - 2 * ratio + 1
                seen[agree, k] = True
                seen[agree, maps[q][1]] = True
        nv = seen.sum(1)
        keep = nv >= min_views
        stats.append({"ref": i, "src": j, "valid": len(X), "consistent": int(keep.sum())})
        out["points"].append(acc[keep] / count[keep, None])
        out["colours"].append(col[keep])
        out["n_views"].append(nv[keep])
        rms = np.sqrt(sq[keep] / np.maximum(count[keep] - 1, 1))
        out["quality"].append(np.clip(1 - rms / tol, 0, 1))
    if not out["points"]:
        return _empty(), stats
    P = np.concatenate(out["points"])
    cols = np.concatenate(out["colours"]).astype(np.float64)
    nv = np.concatenate(out["n_views"])
    qual = np.concatenate(out["quality"])
    if voxel > 0 and len(P):
        P, cols, nv, qual = thin(P, cols, nv, qual, voxel)
    return {
        "points": P,
        "colours": np.clip(np.rint(cols), 0, 255).astype(np.uint8),
        "n_views": nv.astype(int),
        "quality": qual,
    }, stats


def thin(P: np.ndarray, cols: np.ndarray, nv: np.ndarray, qual: np.ndarray, voxel: float):
    """One point per occupied voxel of edge ``voxel``: the mean position, colour and quality,
    the largest view count."""
    key = np.floor((P - P.min(0)) / voxel).astype(np.int64)
    dims = key.max(0) + 1
    flat = key[:, 0] + dims[0] * (key[:, 1] + dims[1] * key[:, 2])  # one int64: 1-D unique is fast
    _, inv, cnt = np.unique(flat, return_inverse=True, return_counts=True)

    def mean(a):
        return np.stack([np.bincount(inv, a[:, c]) / cnt for c in range(a.shape[1])], 1)

    big = np.zeros(len(cnt), nv.dtype)
    np.maximum.at(big, inv, nv)
    return mean(P), mean(cols), big, np.bincount(inv, qual) / cnt


def _empty() -> dict[str, np.ndarray]:
    return {
        "points": np.zeros((0, 3)),
        "colours": np.zeros((0, 3), np.uint8),
        "n_views": np.zeros(0, int),
        "quality": np.zeros(0),
    }
