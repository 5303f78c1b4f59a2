"""Step 1 (thesis ch. 6.1.3): the photogrammetry cloud's plane, its projection along the
normal and its colour sampled into a grey image of √N × √N pixels."""

from __future__ import annotations

import numpy as np


def fit_plane(
    points: np.ndarray, datum: dict | None = None, max_points: int = 200_000
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares plane of a cloud, or a given datum.

    Parameters
    ----------
    points : (N, 3) float, mm
    datum : {"point": [x, y, z], "normal": [nx, ny, nz]} or None
    max_points : the fit uses a regular subsample of at most this many points

    Returns
    -------
    centre : (3,) mm, a point of the plane
    frame : (3, 3), rows e1, e2, n (right-handed, n the unit normal)
    """
    if datum is not None:
        c = np.asarray(datum["point"], dtype=float).reshape(3)
        n = np.asarray(datum["normal"], dtype=float).reshape(3)
        n = n / np.linalg.norm(n)
    else:
        p = points[:: max(1, len(points) // max_points)]
        c = p.mean(axis=0)
        n = np.linalg.svd(p - c, full_matrices=False)[2][2]
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = np.cross(a, n)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return c, np.vstack([e1, e2, n])


def mirrored(frame: np.ndarray) -> np.ndarray:
    """The same plane seen from the other side (normal reversed, still right-handed):
    the cloud's image is then mirrored, which SIFT does not undo by itself."""
    return np.vstack([frame[1], frame[0], -frame[2]])


def grey(colors: np.ndarray) -> np.ndarray:
    """(N,) luma in 0..1 of (N, 3) uint8 colours (ITU-R BT.601 weights)."""
    return (np.asarray(colors, dtype=np.float64) @ np.array([0.299, 0.587, 0.114])) / 255.0


def splat(uv: np.ndarray, values: np.ndarray, pixel: float, origin: np.ndarray, shape: tuple[int, int]):
    """Bilinear splatting of scattered values onto a grid (pixel (a, b) at
    origin + (a, b)·pixel): returns the weighted sum and the weight images; their ratio after
    a blur is the normalised convolution (holes and uneven sampling do not bias it)."""
    ny, nx = shape
    f = (uv - origin) / pixel
    # one spare row and column so that no corner needs a bounds check (the cloud's image
    # covers all its points; other clouds' points outside are clipped to the border)
    f = np.clip(f, 0, [nx - 1, ny - 1])
    a0 = np.minimum(f[:, 0].astype(np.int64), nx - 1)
    b0 = np.minimum(f[:, 1].astype(np.int64), ny - 1)
    fa, fb = f[:, 0] - a0, f[:, 1] - b0
    w1 = nx + 1
    base = b0 * w1 + a0
    size = (ny + 1) * w1
    s = np.zeros(size)
    w = np.zeros(size)
    for off, wt in ((0, (1 - fa) * (1 - fb)), (1, fa * (1 - fb)), (w1, (1 - fa) * fb), (w1 + 1, fa * fb)):
        s += np.bincount(base + off, wt * values, minlength=size)
        w += np.bincount(base + off, wt, minlength=size)
    return s.reshape(ny + 1, w1)[:ny, :nx].copy(), w.reshape(ny + 1, w1)[:ny, :nx].copy()


def cloud_grid(uv: np.ndarray, grid: int | None) -> tuple[float, np.ndarray, tuple[int, int]]:
    """Pixel size (mm), origin (2,) mm and (ny, nx) of the cloud's image: the longer side
    has ``grid`` pixels (default √N, ch. 6.1.3)."""
    n = len(uv)
    g = int(grid) if grid else max(16, int(round(np.sqrt(n))))
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    pixel = float(max(hi - lo)) / (g - 1)
    nx, ny = (np.floor((hi - lo) / pixel).astype(int) + 1).tolist()
    return pixel, lo, (ny, nx)
