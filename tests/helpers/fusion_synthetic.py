"""Exact-by-construction data for the fusion tests and benchmark (issue 17): a coin-like
relief (mm of form, µm texture) coloured by a smooth texture, sampled as a scaled, moved
photogrammetry cloud and as a rotated, shifted, tilted CSI height map."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from camcmm.api import HeightMap, PointCloud

RNG_BLOBS = np.random.default_rng(17).uniform([-10, -10, 0.4], [10, 10, 0.9], (60, 3))
BLOB_SIGN = np.where(np.random.default_rng(18).random(60) < 0.5, -1.0, 1.0)


def surface(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height (mm) of the coin: a 1.5 mm dome, 0.2 mm relief blobs, 2 µm texture."""
    r2 = (x * x + y * y) / 100.0
    z = 1.5 * (1 - r2) + 0.002 * np.sin(2 * np.pi * x / 0.05) * np.sin(2 * np.pi * y / 0.07)
    for (bx, by, bs), sg in zip(RNG_BLOBS[:12], BLOB_SIGN[:12]):
        z = z + sg * 0.2 * np.exp(-((x - bx) ** 2 + (y - by) ** 2) / (2 * (3 * bs) ** 2))
    return z


def texture(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A smooth 0..1 colour pattern both data sets see: 48 plane waves of 0.4-1.5 mm
    wavelength (a band-limited random texture)."""
    t = np.zeros_like(x)
    for kx, ky, ph in WAVES:
        t += np.cos(kx * x + ky * y + ph)
    return 1 / (1 + np.exp(-0.6 * t))


_w = np.random.default_rng(19)
_lam = _w.uniform(0.4, 1.5, 48)
_dir = _w.uniform(0, np.pi, 48)
WAVES = np.column_stack(
    [2 * np.pi / _lam * np.cos(_dir), 2 * np.pi / _lam * np.sin(_dir), _w.uniform(0, 2 * np.pi, 48)]
)


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def affine(r, t):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = r, t
    return m


def photo_cloud(spacing=0.02, half=4.5, scale=1.02, pose=None, seed=0):
    """The 'photogrammetry' cloud: the coin on a jittered grid, then x -> scale·M·x + T."""
    m = pose if pose is not None else affine(rz(np.radians(30)) @ rx(np.radians(10)), [5.0, -3.0, 12.0])
    g = np.arange(-half, half + 1e-9, spacing)
    x, y = np.meshgrid(g, g)
    rng = np.random.default_rng(seed)
    x = x.ravel() + rng.uniform(-0.3, 0.3, x.size) * spacing
    y = y.ravel() + rng.uniform(-0.3, 0.3, y.size) * spacing
    obj = np.column_stack([x, y, surface(x, y)])
    pts = scale * obj @ m[:3, :3].T + m[:3, 3]
    grey = np.round(texture(x, y) * 255).astype(np.uint8)
    cloud = PointCloud(pts, colors=np.repeat(grey[:, None], 3, axis=1), name="photo.ply")
    return cloud, scale, m


def csi_map(
    theta_deg=25.0, tilt_deg=(0.3, -0.2), centre=(0.8, -0.6), z0=0.1, shape=(480, 640), step=0.008, name="csi_1"
):
    """A 'CSI' map: its frame x -> A x (object frame), A = Rx·Ry·Rz(θ) and a shift, the
    heights solved so that every grid point lies exactly on the coin (Newton)."""
    ny, nx = shape
    rot = rx(np.radians(tilt_deg[0])) @ ry(np.radians(tilt_deg[1])) @ rz(np.radians(theta_deg))
    mid = np.array([(nx - 1) * step / 2, (ny - 1) * step / 2, 0.0])
    t = np.array([centre[0], centre[1], z0]) - rot @ mid
    a = affine(rot, t)
    xx, yy = np.meshgrid(np.arange(nx) * step, np.arange(ny) * step)
    b = np.stack([xx, yy, np.zeros_like(xx)], -1) @ rot.T + t
    col = rot[:, 2]
    z = np.zeros_like(xx)
    for _ in range(4):
        p = b + z[..., None] * col
        e = 1e-6
        fx = (surface(p[..., 0] + e, p[..., 1]) - surface(p[..., 0] - e, p[..., 1])) / (2 * e)
        fy = (surface(p[..., 0], p[..., 1] + e) - surface(p[..., 0], p[..., 1] - e)) / (2 * e)
        g = p[..., 2] - surface(p[..., 0], p[..., 1])
        z = z - g / (col[2] - fx * col[0] - fy * col[1])
    p = b + z[..., None] * col
    hm = HeightMap(z, step, step, intensity=texture(p[..., 0], p[..., 1]), name=name)
    return hm, a


# -- a real height map as both sides (tests/fusion/test_fusion_real.py, the fuse browser test) --
FILES = {"test_1.dat": "shaded", "test_1.opd": "auto", "test_2.opd": "auto", "test_1.plu": "auto"}
SCALE = 1.03
POSE = affine(rz(np.radians(20)) @ rx(np.radians(5)), [1.0, 2.0, 3.0])


def make_case(path: Path, grey: str):
    from camcmm.api import read
    from camcmm_plugins.fusion.prepare import shade

    hm = read(path)
    ny, nx = hm.shape
    g = hm.intensity if (hm.intensity is not None and grey != "shaded") else shade(hm.heights, hm.dx, hm.dy)
    i, j = np.mgrid[0:ny:2, 0:nx:2]
    i, j = i.ravel(), j.ravel()
    ok = hm.valid[i, j] & np.isfinite(g[i, j])
    i, j = i[ok], j[ok]
    p = np.column_stack([hm.origin[0] + j * hm.dx, hm.origin[1] + i * hm.dy, hm.heights[i, j]])
    lo, hi = np.percentile(g[i, j], [1, 99])
    gv = np.clip((g[i, j] - lo) / (hi - lo) * 255, 0, 255).astype(np.uint8)
    cloud = PointCloud(
        SCALE * p @ POSE[:3, :3].T + POSE[:3, 3], colors=np.repeat(gv[:, None], 3, 1), name=f"{path.name}.ply"
    )
    a, b = ny // 5, nx // 5
    crop = HeightMap(
        hm.heights[a : ny - a, b : nx - b],
        hm.dx,
        hm.dy,
        intensity=None if hm.intensity is None else hm.intensity[a : ny - a, b : nx - b],
        origin=(hm.origin[0] + b * hm.dx, hm.origin[1] + a * hm.dy),
        name=path.name,
    )
    return cloud, crop
