"""The algorithm entry ``photogrammetry.reconstruct``: SfM, then the dense cloud, then scale.

The stages are plain functions of their own modules (:func:`.sfm.reconstruct_sparse`,
``.dense.dense_cloud``, ``.scale.apply_scale``); this entry runs them in turn with the host's
progress, cancel and warnings, and assembles the outputs the CLI, the GUI page and the
chapter-4 system read (the keys of ``camcmm photogrammetry reconstruct --json``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, PluginError, PointCloud, RunContext, checked_path, read_calibration

from .scale import check_spec
from .sfm import DEFAULT_MAPPER, DEFAULT_MATCHING, DEFAULT_MODEL, DEFAULT_OVERLAP, reconstruct_sparse
from .sparse import SparseResult
from .turntable import DEFAULT_WINDOW, check_turntable, parse_angles


def _series(images: Any) -> tuple[list[np.ndarray], list[str]]:
    """Arrays (RGB) and names of the host's images (camcmm.api Image objects or arrays)."""
    if images is None or len(images) == 0:
        raise InputError("photogrammetry: no images given")
    arrays, names = [], []
    for i, im in enumerate(images):
        data = getattr(im, "data", im)
        meta = getattr(im, "metadata", {}) or {}
        name = str(meta.get("file") or getattr(im, "name", "") or f"image{i + 1}")
        if data is None:
            raise InputError(f"{name}: holds no image data")
        a = np.asarray(data)
        if a.ndim == 3 and a.shape[2] >= 3 and meta.get("channel_order") == "BGR":
            a = a[:, :, 2::-1]  # files come in OpenCV's BGR: SfM and the colours want RGB
        arrays.append(a)
        names.append(name)
    return arrays, names


def _calibration(calibration: Any) -> dict[str, Any] | None:
    """The first camera of a calibration (file path or dict) as sfm wants it."""
    if calibration is None or calibration == "":
        return None
    if isinstance(calibration, (str, Path)):
        # checked before it is opened: a confined run refuses a file outside its folders
        # alike whether it exists or not
        calibration = read_calibration(checked_path(calibration, "calibration"))
    cal = calibration
    if isinstance(cal, dict) and "camera_matrix" in cal:
        return cal
    cams = cal.get("cameras") if isinstance(cal, dict) else None
    if not cams:
        raise InputError("photogrammetry: the calibration holds no camera")
    c = cams[0]
    return {
        "camera_matrix": np.asarray(c.camera_matrix),
        "dist_coeffs": np.asarray(c.dist_coeffs),
        "image_size": tuple(c.image_size),
    }


class _Event:
    """The host's cancel as the ``is_set()`` object the dense stage polls."""

    def __init__(self, ctx: RunContext):
        self.ctx = ctx

    def is_set(self) -> bool:
        return bool(self.ctx.cancelled)


def _sparse_cloud(sp: SparseResult, factor: float) -> PointCloud:
    return PointCloud(
        points=sp.points * factor,
        colors=sp.colours,
        fields={"n_views": sp.track_lengths.astype(np.float64)},
        name="sparse",
    )


def reconstruction_json(sp: SparseResult, dense: Any, scale: dict[str, Any], warnings: list[str]) -> dict[str, Any]:
    """The ``--json`` document: the issue's keys, plus ``images``, ``image_size``, ``options``."""
    f = float(scale["factor"])
    views = [{"image": v["image"], "R": v["R"], "t": v["t"] * f, "centre": v["centre"] * f} for v in sp.views]
    cam = {k: sp.camera[k] for k in ("model", "fx", "fy", "cx", "cy", "dist")}
    return {
        "n_images": len(sp.images),
        "n_registered": len(sp.views),
        "unregistered": dict(sp.unregistered),
        "reprojection_rms_px": sp.reprojection_rms_px,
        "camera": cam,
        "views": views,
        "n_points_sparse": int(len(sp.points)),
        "n_points_dense": int(len(dense.points)) if dense is not None else 0,
        "scale": {
            "method": scale["method"],
            "factor": f,
            "u": float(scale["u"]),
            **({"u_rel": scale["u_rel"]} if "u_rel" in scale else {}),
            **({"details": scale["details"]} if scale.get("details") else {}),
        },
        "warnings": list(warnings),
        "timings": dict(sp.timings),
        "images": sp.images,
        "image_size": list(sp.image_size),
        "options": sp.options,
        # the size the dense stage matched at (px), [] without it
        "dense_image_size": list(getattr(dense, "image_size", ())) if dense is not None else [],
    }


def reconstruct(
    ctx: RunContext,
    images: Any,
    calibration: Any = None,
    *,
    dense: bool = True,
    max_image_size: int = 1600,
    scale: str = "",
    matching: str = DEFAULT_MATCHING,
    overlap: int = DEFAULT_OVERLAP,
    mapper: str = DEFAULT_MAPPER,
    camera_model: str = DEFAULT_MODEL,
    scheduler: str = "",
    dense_max_image_size: int = 1600,
    turntable_angles: Any = "",
    turntable_window: float = DEFAULT_WINDOW,
) -> dict[str, Any]:
    """Multi-view reconstruction of an image series from one camera (thesis ch. 2.3-2.5, 4).

    Parameters
    ----------
    images : the series (camcmm.api Image objects or arrays), all of one size.
    calibration : None (self-calibrate), a calibration file or its dict: the camera is fixed.
    dense : compute the dense cloud after the sparse one.
    max_image_size : longest side (px) used for SfM.
    scale : ``spheres:R1,R2``, ``lengths:FILE``, ``bar:L`` or "" (the reconstruction's own scale).
    matching, overlap, mapper, camera_model : see :func:`.sfm.reconstruct_sparse`.
    scheduler : a Dask scheduler address for the dense stage, "" for in-process.
    dense_max_image_size : longest side (px) the dense stage matches at (0: full size); the
        images are resized with area averaging and the intrinsics scaled to match
        (:func:`.dense.scaled_camera`). 1600 px as COLMAP's "medium" patch-match stereo: SGBM's
        time grows with the cube of the side, and the dense points stay in world units.
    turntable_angles : the table angle (deg) of each image (list in input order, "DEG,DEG,...",
        ``step:D``) or "" (none): only pairs within ``turntable_window`` deg are matched and the
        cameras are checked against the angles (JSON key ``turntable``, :mod:`.turntable`).

    Returns
    -------
    dict ``cloud`` (dense, or sparse with dense off; mm once scaled), ``sparse``, ``reconstruction``.
    """
    arrays, names = _series(images)
    angles = parse_angles(turntable_angles, len(arrays))  # refused before any work
    check_spec(scale)  # likewise (it is applied only after SfM and the dense stage)
    cal = _calibration(calibration)
    share = 0.45 if dense else 0.95

    def sfm_progress(fr: float, msg: str) -> None:
        ctx.progress(share * fr, msg)

    sp = reconstruct_sparse(
        arrays,
        names,
        calibration=cal,
        max_image_size=int(max_image_size),
        matching=matching,
        overlap=int(overlap),
        mapper=mapper,
        camera_model=camera_model,
        turntable_angles=angles,
        turntable_window=float(turntable_window),
        progress=sfm_progress,
        cancel=lambda: ctx.cancelled,
    )
    for w in sp.warnings:
        ctx.warn(w)
    table: dict[str, Any] = {}
    if angles is not None:
        table, more = check_turntable(sp.views, dict(zip(names, angles.tolist(), strict=True)))
        for w in more:
            ctx.warn(w)
    d = None
    if dense:
        try:
            from .dense import dense_cloud
        except ImportError as exc:  # the dense stage is another module: say so, do not crash
            raise PluginError(f"photogrammetry: the dense stage is not available ({exc}); run with dense off") from exc
        index = {n: i for i, n in enumerate(names)}
        k = np.asarray(sp.camera["K"], dtype=np.float64)
        dist = np.zeros(5)
        dist[: min(5, len(sp.camera["dist"]))] = sp.camera["dist"][:5]
        views = [{"K": k, "dist": dist, "R": v["R"], "t": v["t"]} for v in sp.views]
        imgs = [arrays[index[v["image"]]] for v in sp.views]
        from .pairs import depth_range_from_points

        d = dense_cloud(
            imgs,
            views,
            # each view's depth range from the sparse points it sees: the disparity search
            # covers only the object (about 3x faster than the cameras' own guess, same points)
            depth_range=depth_range_from_points(sp.points, views) if len(sp.points) >= 10 else None,
            progress=lambda fr, msg: ctx.progress(share + (0.95 - share) * fr, msg),
            cancel=_Event(ctx),
            scheduler=scheduler or None,
            max_image_size=int(dense_max_image_size),
        )
        for w in getattr(d, "warnings", []) or []:
            ctx.warn(w)
        sp.timings.update({k if k.startswith("dense") else f"dense_{k}": v for k, v in (d.timings or {}).items()})
    sc: dict[str, Any] = {"method": "none", "factor": 1.0, "u": 0.0}
    if scale and scale.strip() and scale.strip().lower() != "none":
        try:
            from .scale import apply_scale
        except ImportError as exc:
            raise PluginError(f"photogrammetry: scaling is not available ({exc}); run without a scale") from exc
        ctx.progress(0.96, "scale")
        pts = d.points if d is not None else sp.points
        sc = apply_scale(pts, scale, views=sp.views, ctx=ctx)
        for w in sc.get("warnings", []) or []:
            ctx.warn(w)
    f = float(sc["factor"])
    sparse = _sparse_cloud(sp, f)
    if d is not None:
        cloud = PointCloud(
            points=np.asarray(d.points) * f,
            colors=np.asarray(d.colours),
            fields={"n_views": np.asarray(d.n_views, dtype=np.float64), "quality": np.asarray(d.quality, np.float64)},
            name="dense",
        )
    else:
        cloud = sparse
    if f != 1.0:
        ctx.warn(f"scaled to mm by {sc['method']}: factor {f:.6g} (u {float(sc['u']):.3g})")
    rec = reconstruction_json(sp, d, sc, ctx.warnings)
    if table:  # the circle's radius and centre scale with the cloud; the angles do not
        rec["turntable"] = {**table, "radius": table["radius"] * f, "axis_point": [x * f for x in table["axis_point"]]}
    ctx.progress(1.0, "done")
    return {"cloud": cloud, "sparse": sparse, "reconstruction": rec}
