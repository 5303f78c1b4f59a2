"""Measurements for VDI/VDE 2634-2 acceptance tests generated with numpy: partial spheres
with noise, ball bars of two spheres at the calibrated length, flats; one file per position."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from camcmm import io as cio
from camcmm.host import default_host
from camcmm.model import PointCloud

MPE = {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243}
VOLUME = [100.0, 100.0, 100.0]
SPHERE_D, BAR_L, BAR_D, FLAT_L, FLAT_W = 20.001, 49.944, 20.0, 150.0, 60.0
ARTEFACTS = {
    "sphere": {"diameter": SPHERE_D, "uncertainty": 0.001, "k": 2},
    "ball_bar": {"length": BAR_L, "uncertainty": 0.0008, "k": 2, "sphere_diameter": BAR_D},
    "flat": {"length": FLAT_L, "width": FLAT_W, "flatness": 0.0026},
}


# -- measurements generated here ------------------------------------------------------------------
def _cap(rng, center, radius, n, noise, cap_deg=110.0):
    """Points on the cap of a sphere seen from +z, radial noise ``noise`` mm."""
    u = rng.uniform(np.cos(np.radians(cap_deg)), 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - u**2)
    d = np.column_stack([s * np.cos(phi), s * np.sin(phi), u])
    return np.asarray(center) + d * (radius + rng.normal(0, noise, n))[:, None]


def sphere_cloud(center, n=4000, noise=0.01, seed=0, diameter=SPHERE_D):
    rng = np.random.default_rng(seed)
    return PointCloud(_cap(rng, center, diameter / 2, n, noise))


def ball_bar_cloud(center, direction, n=3000, noise=0.01, seed=0):
    rng = np.random.default_rng(seed)
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    c = np.asarray(center, float)
    pts = [_cap(rng, c + s * d * BAR_L / 2, BAR_D / 2, n, noise) for s in (-1, 1)]
    return PointCloud(np.vstack(pts))


def flat_cloud(center, direction, normal, n=6000, noise=0.01, seed=0):
    rng = np.random.default_rng(seed)
    u = np.asarray(direction, float) / np.linalg.norm(direction)
    nn = np.asarray(normal if normal is not None else (0, 0, 1), float)
    nn = nn - (nn @ u) * u
    nn /= np.linalg.norm(nn)
    w = np.cross(nn, u)
    a = rng.uniform(-FLAT_L / 2, FLAT_L / 2, n)
    b = rng.uniform(-FLAT_W / 2, FLAT_W / 2, n)
    pts = np.asarray(center) + np.outer(a, u) + np.outer(b, w) + np.outer(rng.normal(0, noise, n), nn)
    return PointCloud(pts)


def make_cloud(test: str, position: dict, seed: int = 0, n: int | None = None) -> PointCloud:
    c = np.asarray(position.get("where") or [0, 0, 0], float) * np.asarray(VOLUME)
    if test == "sphere":
        return sphere_cloud(c, n or 4000, seed=seed)
    if test == "ball_bar":
        return ball_bar_cloud(c, position.get("direction") or [1, 0, 0], n or 3000, seed=seed)
    if test == "flat":
        return flat_cloud(c, position.get("direction") or [1, 0, 0], position.get("normal"), n or 6000, seed=seed)
    raise ValueError(test)


def write_measurements(
    folder: Path, requirements: list[dict], n: int | None = None, ext: str = "ply"
) -> dict[str, list[tuple[str, Path]]]:
    """One file per position of every test: ``{test: [(position id, path), ...]}``."""
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, list[tuple[str, Path]]] = {}
    seeds = itertools.count(1)
    for r in requirements:
        for p in r["positions"]:
            path = folder / f"{p['id']}.{ext}"
            cio.write(make_cloud(r["test"], p, next(seeds), n), path)
            out.setdefault(r["test"], []).append((p["id"], path))
    return out


def real_vdi2634_available() -> bool:
    try:
        host = default_host()
        return "vdi2634-2" in host.plugins and callable(getattr(host.load("vdi2634-2"), "evaluate_measurement", None))
    except Exception:
        return False
