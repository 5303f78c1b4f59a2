"""Step 6 (thesis ch. 6.1): the fused cloud — photogrammetry points inside each CSI
footprint replaced by the CSI points, with a per-point ``source`` field."""

from __future__ import annotations

import numpy as np


def in_footprint(xy_map: np.ndarray, hm) -> np.ndarray:
    """(n,) bool: points (map coordinates, mm) that fall on a valid cell of the map."""
    ny, nx = hm.shape
    j = np.rint((xy_map[:, 0] - hm.origin[0]) / hm.dx).astype(np.int64)
    i = np.rint((xy_map[:, 1] - hm.origin[1]) / hm.dy).astype(np.int64)
    ok = (i >= 0) & (i < ny) & (j >= 0) & (j < nx)
    out = np.zeros(len(xy_map), bool)
    out[ok] = hm.valid[i[ok], j[ok]]
    return out


def subsample_grid(hm, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Valid map points (n, 3) mm on a regular sub-grid of at most ``max_points`` cells,
    and their (i, j) indices."""
    ny, nx = hm.shape
    step = max(1, int(np.ceil(np.sqrt(ny * nx / max_points))))
    gi, gj = np.meshgrid(np.arange(0, ny, step), np.arange(0, nx, step), indexing="ij")
    i, j = gi.ravel(), gj.ravel()
    ok = hm.valid[i, j]
    i, j = i[ok], j[ok]
    pts = np.column_stack([hm.origin[0] + j * hm.dx, hm.origin[1] + i * hm.dy, hm.heights[i, j]])
    return pts, np.column_stack([i, j])


def transform(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]


def merge(photo: np.ndarray, photo_colors, keep: np.ndarray, parts: list[tuple[np.ndarray, np.ndarray]]):
    """The fused points, colours (uint8 or None) and source field (0 photogrammetry, k =
    map k). ``parts``: per map its points in the fused frame and their uint8 grey values."""
    pts = [photo[keep]]
    src = [np.zeros(int(keep.sum()), np.int32)]
    cols = [photo_colors[keep]] if photo_colors is not None else None
    for k, (p, g) in enumerate(parts, start=1):
        pts.append(p)
        src.append(np.full(len(p), k, np.int32))
        if cols is not None:
            cols.append(np.repeat(g[:, None], 3, axis=1).astype(np.uint8))
    return np.vstack(pts), (np.vstack(cols) if cols is not None else None), np.concatenate(src)
