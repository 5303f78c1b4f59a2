"""Step 7 (thesis ch. 6.1, figs. 6.7-6.8): the difference CSI − photogrammetry over each
map's footprint, its statistics, histogram, a grid of it for display and the 95 % band of
the Abbott-Firestone curve (the material-ratio parameters come from inspect.material-ratio)."""

from __future__ import annotations

import numpy as np


def stats(d: np.ndarray) -> dict:
    """mean, std, p2_5, p97_5 (mm), n of the finite differences."""
    d = d[np.isfinite(d)]
    if d.size == 0:
        return {"mean": None, "std": None, "p2_5": None, "p97_5": None, "n": 0}
    p = np.percentile(d, [2.5, 97.5])
    return {
        "mean": float(d.mean()),
        "std": float(d.std(ddof=1)) if d.size > 1 else 0.0,
        "p2_5": float(p[0]),
        "p97_5": float(p[1]),
        "n": int(d.size),
    }


def grid(xy_map: np.ndarray, d: np.ndarray, hm, max_side: int = 128) -> dict:
    """Mean difference per cell of a grid over the map (≤ max_side cells on the long side),
    NaN where no point fell: rows (lists), cell size dx (mm), x0, y0 (map coordinates)."""
    w, h = hm.size_mm
    cell = max(w, h) / max_side
    nx, ny = max(1, int(np.ceil(w / cell))), max(1, int(np.ceil(h / cell)))
    j = np.clip(((xy_map[:, 0] - hm.origin[0]) / cell).astype(int), 0, nx - 1)
    i = np.clip(((xy_map[:, 1] - hm.origin[1]) / cell).astype(int), 0, ny - 1)
    ok = np.isfinite(d)
    idx = i[ok] * nx + j[ok]
    s = np.bincount(idx, d[ok], minlength=nx * ny)
    n = np.bincount(idx, minlength=nx * ny)
    with np.errstate(invalid="ignore"):
        g = (s / n).reshape(ny, nx)
    return {"grid": g.tolist(), "dx": cell, "x0": hm.origin[0], "y0": hm.origin[1]}


def histogram(d: np.ndarray, bins: int = 60) -> dict:
    d = d[np.isfinite(d)]
    counts, edges = np.histogram(d, bins=bins) if d.size else (np.zeros(0), np.zeros(1))
    return {"edges": edges.tolist(), "counts": counts.astype(int).tolist()}
