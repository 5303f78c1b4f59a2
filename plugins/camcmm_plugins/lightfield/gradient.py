"""One reconstruction's light-field gradients: per view, the photogrammetric depth map
(eqs. 6.2-6.4) against the Lytro lambda map (eq. 6.5), a straight line each (fig. 6.15),
and the mean and standard deviation over the views (ch. 6.3.3)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from . import depthmap, fit, lytro


def load_views(views: Any, importer: Callable[[str], dict] | None = None) -> dict[str, Any]:
    """``{cameras: [...], views: [...]}`` from a reconstruction dict, its JSON file (the
    ``--json`` of ``camcmm photogrammetry reconstruct`` or ``import``, or the virtual lab's
    ``views.json``) or a COLMAP model folder (read by ``importer``, photogrammetry.import)."""
    name = str(views) if isinstance(views, (str, Path)) else "views"
    if isinstance(views, (str, Path)):
        p = Path(views)
        if p.is_dir():
            if importer is None:
                raise InputError(f"{p}: a COLMAP model folder needs photogrammetry.import")
            doc = importer(str(p))
        elif p.is_file():
            try:
                doc = json.loads(p.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise InputError(f"{p}: not a reconstruction JSON ({exc})") from None
        else:
            raise InputError(f"{p}: no such views file or COLMAP folder")
    else:
        doc = views
    if not isinstance(doc, dict) or not isinstance(doc.get("views"), list) or not doc["views"]:
        raise InputError(f"{name}: no 'views' [{{image, R, t}}] in the reconstruction")
    cams = [dict(c) for c in (doc.get("cameras") or ([doc["camera"]] if doc.get("camera") else []))]
    if not cams:
        raise InputError(f"{name}: no 'camera' or 'cameras' in the reconstruction")
    size = doc.get("image_size")
    for j, c in enumerate(cams):
        if size and not c.get("width"):
            try:
                c.update(width=int(size[0]), height=int(size[1]))
            except (TypeError, ValueError, IndexError, OverflowError):
                raise InputError(f"{name}: image_size {size!r:.60}: give [width, height] px") from None
        try:
            depthmap.camera_matrix(c)  # its checks (fx, fy > 0, finite) named with this file
        except InputError as exc:
            raise InputError(f"{name}: cameras[{j}]: {str(exc).removeprefix('views: ')}") from None
        for k in ("width", "height"):
            v = c.get(k)
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < 1e6):
                raise InputError(f"{name}: cameras[{j}].{k} = {v!r:.60}: a whole number of px above 0")
    out = []
    for i, v in enumerate(doc["views"]):
        try:
            R, t = np.asarray(v["R"], float).reshape(3, 3), np.asarray(v["t"], float).reshape(3)
            cam = cams[int(v.get("camera", 0))]
        except (KeyError, TypeError, ValueError, IndexError, OverflowError):
            raise InputError(f"{name}: view {i} needs image, R (3 x 3), t (3) and a valid camera index") from None
        # not a rotation (or NaN): every depth of the view would be wrong without a word
        if not (np.isfinite(R).all() and np.isfinite(t).all()):
            raise InputError(f"{name}: views[{i}]: R or t holds non-finite values")
        if np.abs(R.T @ R - np.eye(3)).max() > 1e-4 or np.linalg.det(R) < 0:
            raise InputError(f"{name}: views[{i}].R is not a rotation (R^T R != I or det R < 0)")
        out.append({"image": str(v.get("image", f"view{i}")), "R": R, "t": t, "camera": cam})
    return {"views": out, "name": name}


def view_camera(cam: dict[str, Any], size: tuple[int, int], map_name: str) -> tuple[np.ndarray, np.ndarray]:
    """K and distortion for a depth map of ``size`` (w, h): a map smaller than the camera's
    images by one factor (Lytro's depth maps often are) gets K scaled; any other size is refused."""
    K, dist = depthmap.camera_matrix(cam)
    w, h = size
    cw, ch = cam.get("width"), cam.get("height")
    if not cw or not ch or (int(cw), int(ch)) == (w, h):
        return K, dist
    s = w / float(cw)
    if abs(h - s * float(ch)) > 1.0:
        raise InputError(
            f"{map_name}: {w} x {h} px does not match the view's camera ({cw} x {ch} px) nor a scaled copy"
        )
    Ks = K.copy()
    Ks[0, 0] *= s
    Ks[1, 1] *= s
    Ks[0, 2] = (K[0, 2] + 0.5) * s - 0.5  # pixel centres: OpenCV's origin is the top-left pixel's centre
    Ks[1, 2] = (K[1, 2] + 0.5) * s - 0.5
    return Ks, dist


def scatter_sample(depth: np.ndarray, lam: np.ndarray, used: np.ndarray, n: int, seed: int) -> dict[str, list]:
    """At most ``n`` pixels with both depths (random, fixed seed): lambda, depth and whether the fit used them."""
    ok = np.flatnonzero(np.isfinite(depth) & np.isfinite(lam))
    if len(ok) > n:
        ok = np.sort(np.random.default_rng(seed).choice(ok, n, replace=False))
    return {
        "lambda": lam.ravel()[ok].round(5).tolist(),
        "depth": depth.ravel()[ok].round(4).tolist(),
        "used": used.ravel()[ok].tolist(),
    }


def gradients(
    points: np.ndarray,
    views: dict[str, Any],
    maps_dir: str | Path,
    *,
    lambda_range: tuple[float, float] | None = None,
    convention: str = "eq6.5",
    band: float = 0.5,
    robust: bool = True,
    measure: str = "distance",
    tolerance: float = 0.002,
    scale: float = 1.0,
    keep: np.ndarray | None = None,
    polygon: list | None = None,
    scatter_points: int = 1000,
    min_pixels: int = 100,
    sigma_lambda: float = 0.0,
    progress: Callable[[float, str], None] | None = None,
) -> dict[str, Any]:
    """Fit every view that has a depth map in ``maps_dir``.

    Parameters
    ----------
    points : (N, 3) the cloud (multiplied by ``scale`` with the views' t, ch. 6.3.2: mm).
    views : :func:`load_views`'s dict.
    maps_dir : folder of the depth maps, one per view named after its image (lytro.find_map).
    lambda_range, convention, band, robust, measure, tolerance : see lytro, fit and depthmap.
    keep : (N,) bool, the region's points (a flat part, fig. 6.14); None: all.
    polygon : [[u, v], ...] a region in every map's pixels; None: all.

    Returns
    -------
    dict ``result`` {``views`` [{image, depth_map, gradient_mm_per_lambda, intercept, r2,
    n_pixels, u_gradient, u_intercept, n_band, n_rejected, lambda_min, lambda_max,
    lambda_source, focal_length_px}], ``mean``, ``std``, ``n_views``, ``std_ddof``,
    ``focal_length_px``, ``skipped`` {image: why}} and ``scatter`` [{image, lambda, depth,
    used, gradient_mm_per_lambda, intercept}].
    """
    folder = Path(maps_dir)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such depth-map folder")
    P = np.asarray(points, float) * float(scale)
    rows, scatter, skipped = [], [], {}
    vs = views["views"]
    for i, v in enumerate(vs):
        if progress:
            progress(0.05 + 0.9 * i / len(vs), f"view {v['image']}")
        path = lytro.find_map(folder, v["image"])
        if path is None:
            skipped[v["image"]] = "no depth map"
            continue
        lm = lytro.read_lambda_map(path, lambda_range, convention)
        h, w = lm["lam"].shape
        K, dist = view_camera(v["camera"], (w, h), str(path))
        depth, _ = depthmap.depth_map(
            P, K, dist, v["R"], v["t"] * float(scale), (w, h), measure=measure, tolerance=tolerance, keep=keep
        )
        if polygon is not None:
            depth[~depthmap.polygon_mask(polygon, (w, h))] = np.nan
        try:
            f = fit.fit_view(
                depth,
                lm["lam"],
                lm["lam_abs"],
                band=band,
                robust=robust,
                min_pixels=min_pixels,
                sigma_lambda=sigma_lambda,
            )
        except InputError as exc:
            skipped[v["image"]] = str(exc)
            continue
        used = f.pop("mask")
        rows.append(
            {
                "image": v["image"],
                "depth_map": str(path),
                **f,
                "lambda_min": lm["lambda_min"],
                "lambda_max": lm["lambda_max"],
                "lambda_source": lm["source"],
                "focal_length_px": float(v["camera"]["fx"]),  # at the camera's own image size
            }
        )
        scatter.append(
            {
                "image": v["image"],
                **scatter_sample(depth, lm["lam"], used, scatter_points, seed=i),
                "gradient_mm_per_lambda": f["gradient_mm_per_lambda"],
                "intercept": f["intercept"],
            }
        )
    if not rows:
        why = "; ".join(f"{k}: {m}" for k, m in list(skipped.items())[:3])
        raise InputError(f"{folder}: no view could be fitted ({why})")
    st = fit.set_stats([r["gradient_mm_per_lambda"] for r in rows])
    result = {
        "views": rows,
        "mean": st["mean"],
        "std": st["std"],
        "n_views": st["n"],
        "std_ddof": st["std_ddof"],
        "focal_length_px": float(np.mean([r["focal_length_px"] for r in rows])),
        "skipped": skipped,
    }
    return {"result": result, "scatter": scatter}
