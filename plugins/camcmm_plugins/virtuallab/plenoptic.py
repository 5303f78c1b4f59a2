"""A virtual plenoptic (Lytro-style) camera and a light-field scale set (thesis ch. 6.3).

Depth model. The Lytro's lambda is the refocus disparity: zero at the main lens's focal
plane, growing with the distance from it. Over a part's depth range the thesis finds depth
linear in lambda (fig. 6.15), so the model is exactly that:

    D = D0 + g * lambda_abs,    lambda_abs = 0 at the focus distance D0,

with D the depth of eq. 6.3 (distance from the projection centre; or Z', ``measure="z"``)
and ``g`` (mm per lambda) the gradient the study recovers. Per focal length f the gradient
follows a known first-order law ``g = a + b f`` (fig. 6.16), so the focal-length fit is
checked too. The camera focuses at ``D0 = magnification * f`` (a fixed field of view).

Noise: lambda gets Gaussian noise ``sigma_lambda``; inside the band ``|lambda_abs| < band``
(the focal plane, where "the disparity in the light field images is minimised", ch. 6.3.2)
the estimate is poor: values are pulled towards 0 by ``band_shrink`` and get
``band_sigma`` of noise instead. The map is stored as eq. 6.5's 16-bit image with a JSON
sidecar ``{"lambda_min", "lambda_max"}`` (the range of the view, rounded out).

Scene: a flat textured turntable sheet (z = 0, a disc) with a sphere on it (fig. 6.14's
rear-surface case); the "photogrammetric" cloud samples both surfaces evenly (the sphere's
rear half too) with Gaussian noise ``sigma_cloud``. Depth is ray-cast exactly (sphere and
plane intersections), so the truth is analytic.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

LAMBDA_FULL_SCALE = 2.0**16


def look_at(centre: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R, t (x_cam = R X + t) of a camera at ``centre`` looking at ``target``, z up in the image's -v."""
    z = target - centre
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.vstack([x, y, z])
    return R, -R @ centre


def ring_views(n: int, distance: float, elevation_deg: float, target_z: float = 0.0) -> list[tuple]:
    """Poses of ``n`` views through 360° around the z axis at an elevation (turntable series)."""
    e = np.radians(elevation_deg)
    out = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        c = distance * np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        out.append(look_at(c + [0, 0, target_z], np.array([0.0, 0.0, target_z])))
    return out


def raycast(
    K: np.ndarray, R: np.ndarray, t: np.ndarray, size: tuple[int, int], sphere_r: float, dist: np.ndarray | None = None
) -> np.ndarray:
    """Per pixel (H, W, 3) the camera-frame point its centre's ray meets first: a sphere of
    radius ``sphere_r`` resting on the plane z = 0 at the origin, else the plane. With
    ``dist`` (OpenCV's coefficients; only k1 is used) each pixel's ray is the undistorted one."""
    w, h = size
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    if dist is not None and np.any(dist):
        # radial k1 only: invert x_d = x (1 + k1 r^2) by fixed-point iteration to machine precision
        # (cv2.undistortPoints stops after 5 iterations, not exact enough for a truth)
        xd, yd = (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]
        x, y = xd.copy(), yd.copy()
        for _ in range(100):
            f = 1.0 + float(dist[0]) * (x * x + y * y)
            x, y = xd / f, yd / f
        rays = np.stack([x, y, np.ones_like(u)], -1)
    else:
        rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    d = rays @ R  # world directions (R^T r)
    c = -R.T @ t  # camera centre in the world
    s = np.full(u.shape, np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        sp = s.copy()
        if sphere_r > 0:
            oc = c - [0, 0, sphere_r]
            b = d @ oc
            a = (d * d).sum(-1)
            disc = b * b - a * (oc @ oc - sphere_r**2)
            root = (-b - np.sqrt(disc)) / a
            sp = np.where((disc >= 0) & (root > 0), root, np.inf)
        pl = np.where(d[..., 2] < 0, -c[2] / d[..., 2], np.inf)
    s = np.minimum(sp, pl)
    if not np.isfinite(s).all():
        raise InputError("virtual light-field camera: some pixels see no surface; lower the elevation or field")
    return rays * s[..., None]  # camera frame: ray (z = 1) times its parameter


def scene_cloud(rng: np.random.Generator, disc_r: float, sphere_r: float, density: float, sigma: float) -> np.ndarray:
    """Even samples (``density`` per mm²) of the sheet and of the whole sphere, + Gaussian noise."""
    n_disc = int(density * np.pi * disc_r**2)
    r = disc_r * np.sqrt(rng.random(n_disc))
    a = 2 * np.pi * rng.random(n_disc)
    disc = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros(n_disc)])
    parts = [disc]
    if sphere_r > 0:
        n_s = int(density * 4 * np.pi * sphere_r**2)
        p = rng.normal(size=(n_s, 3))
        parts.append(p / np.linalg.norm(p, axis=1, keepdims=True) * sphere_r + [0, 0, sphere_r])
    pts = np.vstack(parts)
    return pts + rng.normal(scale=sigma, size=pts.shape) if sigma > 0 else pts


def lambda_map(
    Xc: np.ndarray,
    D0: float,
    gradient: float,
    rng: np.random.Generator,
    *,
    measure: str = "distance",
    sigma_lambda: float = 0.02,
    band: float = 0.5,
    band_shrink: float = 0.5,
    band_sigma: float = 0.2,
) -> tuple[np.ndarray, np.ndarray]:
    """True and measured absolute lambda (H, W) of the camera-frame points ``Xc`` (H, W, 3)."""
    D = np.linalg.norm(Xc, axis=-1) if measure == "distance" else Xc[..., 2]
    lam = (D - D0) / gradient
    meas = lam + rng.normal(scale=sigma_lambda, size=lam.shape)
    inb = np.abs(lam) < band
    meas[inb] = lam[inb] * (1 - band_shrink) + rng.normal(scale=band_sigma, size=int(inb.sum()))
    return lam, meas


def lightfield_set(
    directory: str | Path,
    *,
    focal_lengths: Sequence[float] = (30.0, 40.0, 50.0),
    gradient_law: tuple[float, float] = (-1.0, 0.15),
    sphere_radii: Sequence[float] = (15.0, 10.0),
    n_views: int = 4,
    size: tuple[int, int] = (240, 168),
    pixel_pitch: float = 0.05,
    magnification: float = 10.0,
    elevation_deg: float = 45.0,
    disc_r: float = 60.0,
    density: float = 16.0,
    sigma_cloud: float = 0.02,
    sigma_lambda: float = 0.02,
    band: float = 0.5,
    band_shrink: float = 0.5,
    band_sigma: float = 0.2,
    measure: str = "distance",
    k1: float = 0.0,
    seed: int = 63,
) -> dict[str, Any]:
    """Write a light-field scale set: per focal length (a "set", table 6.3's column) and
    sphere (an "artefact", its row) a folder with ``cloud.ply`` (mm), ``views.json``
    (reconstruction JSON: camera, views [{image, R, t, centre}], image_size) and
    ``depth/<image>.png`` (16-bit, eq. 6.5) + ``.json`` sidecars; ``study.yaml`` listing
    the runs for ``lightfield.study``; ``truth.json`` (the gradient per set, the law).
    ``k1``: radial distortion of the camera (OpenCV's k1), so the chain's distortion path is checked.

    Returns
    -------
    dict ``study`` (path of study.yaml), ``study_dict``, ``truth``, ``files``.
    """
    import cv2

    from camcmm.api import PointCloud, write

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    w, h = int(size[0]), int(size[1])
    a, b = float(gradient_law[0]), float(gradient_law[1])
    dist = np.array([float(k1), 0.0, 0.0, 0.0, 0.0])
    runs, truth_sets, files = [], [], []
    for si, f in enumerate(focal_lengths):
        g = a + b * float(f)
        if g <= 0:
            raise InputError(f"gradient law {a} + {b} f gives {g} mm/lambda at f = {f} mm; it must be positive")
        fx = float(f) / pixel_pitch
        K = np.array([[fx, 0, (w - 1) / 2], [0, fx, (h - 1) / 2], [0, 0, 1.0]])
        D0 = magnification * float(f)
        set_name = f"Set {si + 1}"
        truth_sets.append({"set": set_name, "focal_length_mm": float(f), "gradient_mm_per_lambda": g, "D0_mm": D0})
        for r in sphere_radii:
            art = f"Sphere R{r:g}"
            run_dir = out / f"set{si + 1}_sphere{r:g}"
            (run_dir / "depth").mkdir(parents=True, exist_ok=True)
            cloud = scene_cloud(rng, disc_r, float(r), density, sigma_cloud)
            write(PointCloud(cloud, name=f"{art} {set_name}"), run_dir / "cloud.ply")
            views = []
            for vi, (R, t) in enumerate(ring_views(n_views, D0, elevation_deg, target_z=0.0)):
                name = f"view_{vi:03d}.png"
                Xc = raycast(K, R, t, (w, h), float(r), dist)
                _, lam = lambda_map(
                    Xc, D0, g, rng, measure=measure, sigma_lambda=sigma_lambda,
                    band=band, band_shrink=band_shrink, band_sigma=band_sigma,
                )  # fmt: skip
                lo, hi = np.floor(lam.min()) - 1.0, np.ceil(lam.max()) + 1.0
                img = np.clip(np.rint((lam - lo) / (hi - lo) * LAMBDA_FULL_SCALE), 0, 65535).astype(np.uint16)
                cv2.imwrite(str(run_dir / "depth" / name), img)
                (run_dir / "depth" / f"view_{vi:03d}.json").write_text(
                    json.dumps({"lambda_min": float(lo), "lambda_max": float(hi)}), encoding="utf-8"
                )
                views.append({"image": name, "R": R.tolist(), "t": t.tolist(), "centre": (-R.T @ t).tolist()})
            cam = {
                "model": "PINHOLE",
                "fx": fx,
                "fy": fx,
                "cx": K[0, 2],
                "cy": K[1, 2],
                "dist": dist.tolist() if k1 else [],
                "width": w,
                "height": h,
            }
            doc = {
                "camera": cam,
                "views": views,
                "image_size": [w, h],
                "source": {"format": "virtuallab.lightfield-set"},
            }
            (run_dir / "views.json").write_text(json.dumps(doc, indent=1), encoding="utf-8")
            runs.append(
                {
                    "set": set_name,
                    "artefact": art,
                    "focal_length_mm": float(f),
                    "cloud": f"{run_dir.name}/cloud.ply",
                    "views": f"{run_dir.name}/views.json",
                    "depth_maps": f"{run_dir.name}/depth",
                }
            )
            files.append(str(run_dir))
    truth = {
        "gradient_law": {"intercept": a, "slope": b, "unit": "mm per lambda, f in mm"},
        "sets": truth_sets,
        "measure": measure,
        "noise": {"sigma_cloud_mm": sigma_cloud, "sigma_lambda": sigma_lambda},
        "band": {"half_width": band, "shrink": band_shrink, "sigma": band_sigma},
        "pixel_pitch_mm": pixel_pitch,
    }
    study = {"name": "virtual light-field scale set", "runs": runs, "truth": truth}
    import yaml

    (out / "study.yaml").write_text(yaml.safe_dump(study, sort_keys=False), encoding="utf-8")
    (out / "truth.json").write_text(json.dumps(truth, indent=1), encoding="utf-8")
    return {"study": str(out / "study.yaml"), "study_dict": study, "truth": truth, "files": files}


def lightfield_set_entry(ctx, directory: str, **params: Any) -> dict[str, Any]:
    """Host entry of ``virtuallab.lightfield-set`` (plugin.yaml)."""
    ctx.progress(0.05, "rendering the light-field set")
    kw = dict(params)
    for k in ("focal_lengths", "sphere_radii"):
        if kw.get(k) is not None:
            kw[k] = [float(v) for v in kw[k]]
        else:
            kw.pop(k, None)
    if kw.get("gradient_law") is not None:
        kw["gradient_law"] = tuple(float(v) for v in kw["gradient_law"])
    else:
        kw.pop("gradient_law", None)
    if kw.get("size") is not None:
        kw["size"] = (int(kw["size"][0]), int(kw["size"][1]))
    else:
        kw.pop("size", None)
    return lightfield_set(directory, **kw)
