"""The fusion's sample pair, exact by construction (issue 17, issue 30): the synthetic coin —
a 1.5 mm dome with 0.2 mm relief blobs and a 2 µm texture, coloured by a smooth band-limited
pattern — sampled as a 'photogrammetry' cloud 2 % too large in a known pose and as a 'CSI'
height map with a known rotation, shift and tilt, every map point solved onto the surface.

The same construction serves the tests (tests/helpers/fusion_synthetic.py re-exports it),
``camcmm fuse sample DIR`` and the Fuse page's "Load the sample pair" (plugin
``fusion.sample``). Everything is deterministic (fixed seeds): the same pair on every host.

Lengths in mm. The truth of the construction: object -> cloud ``x -> SCALE·M·x`` (M = ``POSE``
of :func:`photo_cloud`), map -> object ``A`` (:func:`csi_map`), so a fusion must give the
photogrammetry scale SCALE and put the map's points at ``M·A·p`` (scaled by 1/SCALE about the
plane's centre, :func:`truth_in_fused_frame`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import HeightMap, PointCloud

RNG_BLOBS = np.random.default_rng(17).uniform([-10, -10, 0.4], [10, 10, 0.9], (60, 3))
BLOB_SIGN = np.where(np.random.default_rng(18).random(60) < 0.5, -1.0, 1.0)
_w = np.random.default_rng(19)
_lam = _w.uniform(0.4, 1.5, 48)
_dir = _w.uniform(0, np.pi, 48)
#: 48 plane waves (kx, ky in rad/mm, phase): the texture both data sets see
WAVES = np.column_stack(
    [2 * np.pi / _lam * np.cos(_dir), 2 * np.pi / _lam * np.sin(_dir), _w.uniform(0, 2 * np.pi, 48)]
)

#: the sample pair's sizes: a 130 000-point cloud (0.025 mm apart over 9 × 9 mm) and a
#: 180 × 240 map of 26.6 µm steps (4.8 × 6.4 mm) fuse at the declared defaults with some
#: 25 inliers at blur 6 px (min 8) in about half a second
SAMPLE_SPACING, SAMPLE_SHAPE, SAMPLE_STEP = 0.025, (180, 240), 0.0266
SCALE = 1.02
#: the files ``camcmm fuse sample`` writes and the Fuse page imports
CLOUD_FILE, MAP_FILE = "coin_photogrammetry.ply", "coin_csi.x3p"


def surface(x: np.ndarray, y: np.ndarray, relief_mm: float = 0.0) -> np.ndarray:
    """Height (mm) of the coin: a 1.5 mm dome, 0.2 mm relief blobs, 2 µm texture; plus
    ``relief_mm`` × the colour pattern (a coin whose pattern is relief, for colourless clouds)."""
    r2 = (x * x + y * y) / 100.0
    z = 1.5 * (1 - r2) + 0.002 * np.sin(2 * np.pi * x / 0.05) * np.sin(2 * np.pi * y / 0.07)
    for (bx, by, bs), sg in zip(RNG_BLOBS[:12], BLOB_SIGN[:12]):
        z = z + sg * 0.2 * np.exp(-((x - bx) ** 2 + (y - by) ** 2) / (2 * (3 * bs) ** 2))
    if relief_mm:
        z = z + relief_mm * texture(x, y)
    return z


def texture(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A smooth 0..1 colour pattern both data sets see: 48 plane waves of 0.4-1.5 mm
    wavelength (a band-limited random texture)."""
    t = np.zeros_like(x)
    for kx, ky, ph in WAVES:
        t += np.cos(kx * x + ky * y + ph)
    return 1 / (1 + np.exp(-0.6 * t))


def rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def affine(r: np.ndarray, t: Any) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = r, t
    return m


#: the cloud's pose: turned 30° about z, tilted 10° about x, moved (mm)
POSE = affine(rz(np.radians(30)) @ rx(np.radians(10)), [5.0, -3.0, 12.0])


def photo_cloud(spacing=0.02, half=4.5, scale=SCALE, pose=None, seed=0, colour=True, relief_mm=0.0):
    """The 'photogrammetry' cloud: the coin on a jittered grid, then x -> scale·M·x + T
    (M = ``pose``, default :data:`POSE`); ``colour`` false: no colours. Returns (cloud, scale, M)."""
    m = pose if pose is not None else POSE
    g = np.arange(-half, half + 1e-9, spacing)
    x, y = np.meshgrid(g, g)
    rng = np.random.default_rng(seed)
    x = x.ravel() + rng.uniform(-0.3, 0.3, x.size) * spacing
    y = y.ravel() + rng.uniform(-0.3, 0.3, y.size) * spacing
    obj = np.column_stack([x, y, surface(x, y, relief_mm)])
    pts = scale * obj @ m[:3, :3].T + m[:3, 3]
    grey = np.round(texture(x, y) * 255).astype(np.uint8)
    colors = np.repeat(grey[:, None], 3, axis=1) if colour else None
    return PointCloud(pts, colors=colors, name="photo.ply"), scale, m


def csi_map(
    theta_deg=25.0,
    tilt_deg=(0.3, -0.2),
    centre=(0.8, -0.6),
    z0=0.1,
    shape=(480, 640),
    step=0.008,
    name="csi_1",
    relief_mm=0.0,
):
    """A 'CSI' map: its frame x -> A x (object frame), A = Rx·Ry·Rz(θ) and a shift, the
    heights solved so that every grid point lies exactly on the coin (Newton); its
    intensity channel is the colour pattern. Returns (map, A)."""
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
        fx = (surface(p[..., 0] + e, p[..., 1], relief_mm) - surface(p[..., 0] - e, p[..., 1], relief_mm)) / (2 * e)
        fy = (surface(p[..., 0], p[..., 1] + e, relief_mm) - surface(p[..., 0], p[..., 1] - e, relief_mm)) / (2 * e)
        g = p[..., 2] - surface(p[..., 0], p[..., 1], relief_mm)
        z = z - g / (col[2] - fx * col[0] - fy * col[1])
    p = b + z[..., None] * col
    hm = HeightMap(z, step, step, intensity=texture(p[..., 0], p[..., 1]), name=name)
    return hm, a


def truth_in_fused_frame(m: np.ndarray, a: np.ndarray, scale: float, centre: Any) -> np.ndarray:
    """4×4 map -> fused cloud as the construction has it: map -> object (A) -> cloud (scale·M)
    -> fused frame (the cloud scaled by 1/scale about the fitted plane's ``centre``)."""
    c = np.asarray(centre, dtype=float)
    return affine(m[:3, :3] @ a[:3, :3], (scale * (m[:3, :3] @ a[:3, 3]) + m[:3, 3] - c) / scale + c)


def pair() -> tuple[PointCloud, HeightMap, dict[str, Any]]:
    """The sample pair (cloud, map) and its truth {scale, pose (4×4 M), map_to_object (4×4 A)}."""
    cloud, s, m = photo_cloud(spacing=SAMPLE_SPACING)
    cloud.name = CLOUD_FILE
    hm, a = csi_map(shape=SAMPLE_SHAPE, step=SAMPLE_STEP, name=MAP_FILE)
    return cloud, hm, {"scale": s, "pose": m.tolist(), "map_to_object": a.tolist()}


def sample_pair(ctx: Any = None) -> dict[str, Any]:
    """fusion.sample (plugin.yaml): the sample pair as outputs ``cloud``, ``csi``, ``truth``."""
    cloud, hm, truth = pair()
    return {"cloud": cloud, "csi": hm, "truth": truth}
