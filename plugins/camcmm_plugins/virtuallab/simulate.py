"""Simulate one measurement: sample the scene, keep what the sensor sees, distort, add
noise, rescale. Seeded and reproducible (numpy's PCG64 with the given seed).

Order, as in a real measurement: the true surface point x is seen (or not) by the
sensor; the system maps it to f(x) (systematic distortion of the volume); random
noise of standard deviation ``noise`` (mm) is added along the surface normal
(``noise_model="normal"``: the radial residuals are then N(0, noise²)) or along the
line of sight of camera 1 (``"ray"``: depth noise, as in triangulation); a multi-view
reconstruction of arbitrary scale multiplies everything by ``reconstruction_scale``
about the origin; ``unit="m"`` finally divides by 1000 (a file in metres).

Ground truth returned with the points: the true spheres, lengths and flat, their
images under the distortion (centres f(c), lengths |f(c1) - f(c2)|), and for each
sphere the diameter and form its noise-free distorted points imply (2·mean and range
of |f(x) - f(c)|, a first-order prediction of the fitted values); for a flat the range
of the noise-free distorted points about their least-squares plane (numpy SVD).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .distortion import VolumeDistortion
from .scene import Rectangle, Sphere
from .sensor import Sensor

MAX_ROUNDS = 30


def sample_visible(scene: list, sensor: Sensor, n: int, rng: np.random.Generator):
    """``n`` points (fewer if the sensor sees too little) uniformly over the measured
    primitives' visible surface: points (n, 3), normals (n, 3), primitive index (n,)."""
    measured = [i for i, p in enumerate(scene) if p.measured]
    if not measured or n <= 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    area = np.array([scene[i].area for i in measured])
    frac, got, tries = 0.5, [], 0
    have = 0
    while have < n and tries < MAX_ROUNDS:
        m = int(min(max((n - have) / max(frac, 0.02) * 1.15, 1000), 4_000_000))
        counts = rng.multinomial(m, area / area.sum())
        pts: list[np.ndarray] = []
        nrm: list[np.ndarray] = []
        labs: list[np.ndarray] = []
        for i, k in zip(measured, counts):
            if k:
                p, q = scene[i].sample(int(k), rng)
                pts.append(p)
                nrm.append(q)
                labs.append(np.full(int(k), i))
        p, q, lab = np.vstack(pts), np.vstack(nrm), np.concatenate(labs)
        perm = rng.permutation(len(p))  # the primitives' points interleaved, as a scan would
        p, q, lab = p[perm], q[perm], lab[perm]
        vis = sensor.visible(p, q, scene)
        frac = max(vis.mean(), 1e-3) if tries == 0 else 0.5 * (frac + max(vis.mean(), 1e-3))
        got.append((p[vis], q[vis], lab[vis]))
        have += int(vis.sum())
        tries += 1
    p = np.vstack([g[0] for g in got])[:n]
    q = np.vstack([g[1] for g in got])[:n]
    lab = np.concatenate([g[2] for g in got])[:n]
    return p, q, lab


def _plane_range(x: np.ndarray) -> float:
    if len(x) < 3:
        return float("nan")
    c = x.mean(axis=0)
    normal = np.linalg.svd(x - c, full_matrices=False)[2][-1]
    d = (x - c) @ normal
    return float(np.ptp(d))


def simulate(
    scene: list,
    truth: dict[str, Any],
    sensor: Sensor,
    n_points: int,
    noise: float = 0.0,
    noise_model: str = "normal",
    distortion: VolumeDistortion | None = None,
    reconstruction_scale: float = 1.0,
    unit: str = "mm",
    seed: int = 0,
):
    """Points (N, 3) in ``unit``, the primitive index of each point, and the truth dict
    (lengths in mm, before the reconstruction scale and the unit)."""
    rng = np.random.default_rng(seed)
    dist = distortion or VolumeDistortion()
    x, nrm, lab = sample_visible(scene, sensor, n_points, rng)
    fx = dist.apply(x) if len(x) else x
    if noise > 0 and len(x):
        if noise_model == "ray":
            los = x - sensor.primary
            direction = los / np.linalg.norm(los, axis=1, keepdims=True)
        else:
            direction = nrm
        fx = fx + rng.normal(0.0, noise, len(x))[:, None] * direction
    out = fx * reconstruction_scale
    if unit == "m":
        out = out / 1000.0
    truth = dict(truth)
    truth.update(
        {
            "n_points": int(len(x)),
            "n_points_asked": int(n_points),
            "noise": noise,
            "noise_model": noise_model,
            "sensor": sensor.name,
            "distortion": dist.to_dict(),
            "reconstruction_scale": reconstruction_scale,
            "unit": unit,
            "seed": seed,
        }
    )
    _distorted_truth(scene, truth, dist, x, lab)
    return out, lab, truth


def _distorted_truth(
    scene: list, truth: dict[str, Any], dist: VolumeDistortion, x: np.ndarray, lab: np.ndarray
) -> None:
    spheres = [(i, p) for i, p in enumerate(scene) if isinstance(p, Sphere) and p.measured]
    for (i, s), st in zip(spheres, truth.get("spheres", [])):
        fc = dist.apply(s.center)
        st["center_distorted"] = fc.tolist()
        pts = x[lab == i]
        st["n_points"] = int(len(pts))
        if len(pts):
            rho = np.linalg.norm(dist.apply(pts) - fc, axis=1)
            st["diameter_distorted"] = float(2 * rho.mean())
            st["form_distorted"] = float(np.ptp(rho))
    centres = [np.array(st["center_distorted"]) for st in truth.get("spheres", []) if "center_distorted" in st]
    if truth.get("kind") == "ball_bar" and len(centres) == 2:
        truth["length_distorted"] = float(np.linalg.norm(centres[1] - centres[0]))
    if truth.get("kind") == "ball_plate" and len(centres) == 3:
        truth["lengths_distorted"] = [float(np.linalg.norm(centres[(k + 1) % 3] - centres[k])) for k in range(3)]
    flats = [i for i, p in enumerate(scene) if isinstance(p, Rectangle) and p.measured]
    if flats:
        pts = x[lab == flats[0]]
        truth["n_points_flat"] = int(len(pts))
        truth["flatness_distorted"] = _plane_range(dist.apply(pts)) if len(pts) else float("nan")
