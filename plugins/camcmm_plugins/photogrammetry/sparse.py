"""The outcome of structure from motion: :class:`SparseResult`, read from a pycolmap model."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .cameras import opencv_from_colmap
from .inputs import check_registration, reason_unregistered


@dataclass
class SparseResult:
    """What :func:`reconstruct_sparse` found.

    ``camera`` {model, fx, fy, cx, cy, dist, K} in px at full image size, OpenCV's pixel
    origin; ``views`` [{image, R, t, centre}] of the registered images in input order, with
    x_cam = R X + t and centre = -R^T t (the reconstruction's arbitrary units and frame);
    ``points`` (N, 3), ``colours`` (N, 3) uint8 RGB, ``track_lengths`` (N,) images per point;
    ``images`` [{image, n_features, n_matched, registered, reason}] for every input image;
    ``unregistered`` {name: reason}; ``reprojection_rms_px`` (full-size px);
    ``timings`` seconds per stage.
    """

    camera: dict[str, Any]
    views: list[dict[str, Any]]
    points: np.ndarray
    colours: np.ndarray
    track_lengths: np.ndarray
    images: list[dict[str, Any]]
    unregistered: dict[str, str]
    reprojection_rms_px: float
    image_size: tuple[int, int]
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)


def _reprojection_rms(rec, scale: float) -> float:
    """RMS of all observations' reprojection errors, in full-size px (COLMAP reports the mean)."""
    sq, n = 0.0, 0
    for im in rec.images.values():
        if not im.has_pose:  # a property
            continue
        obs = [(p.xy, p.point3D_id) for p in im.points2D if p.has_point3D()]
        if not obs:
            continue
        xy = np.array([o[0] for o in obs])
        xyz = np.array([rec.points3D[o[1]].xyz for o in obs])
        pose = im.cam_from_world() if callable(im.cam_from_world) else im.cam_from_world
        cam = xyz @ pose.rotation.matrix().T + pose.translation
        proj = im.camera.img_from_cam(cam, check_cheirality=False)
        sq += float(((proj - xy) ** 2).sum())
        n += len(xy)
    return float(np.sqrt(sq / n) / scale) if n else float("nan")


def model_result(rec, per_image, files, names, scale, size, warnings, timings) -> SparseResult:
    """The SparseResult of pycolmap model ``rec``: views in input order, the camera back at full
    size in OpenCV's convention (``scale`` = written size / full size), per-image rows completed."""
    by_file = {im.name: im for im in rec.images.values() if im.has_pose}
    views = []
    for f, n, row in zip(files, names, per_image, strict=True):
        im = by_file.get(f)
        if im is None:
            row["registered"] = False
            row["reason"] = row["reason"] or reason_unregistered(row["n_features"], row["n_matched"])
            continue
        row["registered"] = True
        pose = im.cam_from_world() if callable(im.cam_from_world) else im.cam_from_world
        r = np.asarray(pose.rotation.matrix(), dtype=np.float64)
        t = np.asarray(pose.translation, dtype=np.float64)
        views.append({"image": n, "R": r, "t": t, "centre": -r.T @ t})
    unreg = {row["image"]: row["reason"] for row in per_image if not row["registered"]}
    cam = next(iter(rec.cameras.values()))
    camera = opencv_from_colmap(cam.model_name if hasattr(cam, "model_name") else str(cam.model), cam.params, scale)
    pts = rec.points3D
    ids = list(pts.keys()) if hasattr(pts, "keys") else list(pts)
    xyz = np.array([pts[i].xyz for i in ids], dtype=np.float64).reshape(-1, 3)
    rgb = np.array([pts[i].color for i in ids], dtype=np.uint8).reshape(-1, 3)
    tl = np.array([pts[i].track.length() for i in ids], dtype=np.int32)
    rms = _reprojection_rms(rec, float(np.mean(scale)))
    if len(views) < len(files):
        warnings = [*warnings, *check_registration(per_image, len(views), 1)]
    return SparseResult(
        camera=camera,
        views=views,
        points=xyz,
        colours=rgb,
        track_lengths=tl,
        images=per_image,
        unregistered=unreg,
        reprojection_rms_px=rms,
        image_size=size,
        warnings=warnings,
        timings={k: round(v, 3) for k, v in timings.items()},
    )
