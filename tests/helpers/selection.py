"""An independent reference for the view's lasso/rectangle selection (tests only): the
projection and the even-odd rule written apart from the plugin ``crop.lasso``, edge by edge,
so a test can compare what the page kept with what the browser's polygon and matrix select."""

from __future__ import annotations

from typing import Any

import numpy as np


def selection_mask(points: np.ndarray, selection: dict[str, Any]) -> np.ndarray:
    """Which of ``points`` (n, 3) world mm lie inside a checked selection: clip =
    MVP · [x, y, z, 1] (``mvp`` column-major), in front of the camera (w > 0), and
    (x/w, y/w) inside the polygon (even-odd rule)."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    M = np.asarray(selection["mvp"], dtype=float).reshape(4, 4).T  # column-major -> rows
    clip = P @ M[:, :3].T + M[:, 3]
    w = clip[:, 3]
    front = w > 0
    ws = np.where(front, w, 1.0)
    x, y = clip[:, 0] / ws, clip[:, 1] / ws
    poly = np.asarray(selection["polygon"], dtype=float)
    inside = np.zeros(len(P), dtype=bool)
    j = len(poly) - 1
    for i in range(len(poly)):  # even-odd ray casting, vectorised over the points
        xi, yi = poly[i]
        xj, yj = poly[j]
        crosses = (yi > y) != (yj > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = (xj - xi) * (y - yi) / (yj - yi) + xi
        inside ^= crosses & (x < xc)
        j = i
    return inside & front & np.isfinite(x) & np.isfinite(y)
