"""Dense cloud on the CPU: rectified neighbouring views, semi-global matching, fusion.

pycolmap's patch-match stereo needs CUDA, which many lab PCs lack. This stage therefore
runs OpenCV: each view is paired with its nearest neighbours by triangulation angle
(:func:`~.pairs.choose_pairs`), the pair is undistorted and rectified in one remap
(:func:`~.pairs.rectify`), ``cv2.StereoSGBM`` (Hirschmüller 2008, semi-global matching with
a left-right check and a uniqueness test) gives a disparity map, hence a depth map of the
reference view, and :func:`~.fusion.fuse` keeps a point only where depth maps of other views
agree with it (thesis ch. 6.3.2: per-view depth maps from the same cameras). The pairs are
independent, so they run on a Dask cluster when a scheduler address is given; fusion runs
locally in pair order, so a Dask run and a local run give the same points.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from camcmm.api import Cancelled, InputError

from . import fusion
from .pairs import Camera, cameras, choose_pairs, depth_range_from_points, depth_ranges, rectify, scene_centre

DEFAULTS: dict[str, Any] = {
    "n_neighbours": 2,  # source views per reference view
    "min_angle": 5.0,  # triangulation angle window at the scene centre, degrees
    "max_angle": 30.0,
    "depth_range": None,  # (zmin, zmax) or (n, 2) per view, world units along the optical axes; None: estimated
    "depth_margin": 0.35,  # estimated range: scene-centre depth x (1 -/+ margin)
    "block_size": 5,  # SGBM matching window, px
    "uniqueness": 10,  # SGBM uniqueness ratio, %
    "min_intensity": 0,  # reference pixels darker than this (grey 0..255) are not matched
    "min_texture": 2.0,  # ... nor those whose 5x5 grey standard deviation is below this
    "min_views": 3,  # views (the pair included) that must agree on a point
    "depth_tolerance": 0.01,  # relative depth agreement of two depth maps
    "fusion_views": 4,  # other views (nearest by optical axis) checked per depth map
    "fusion_stride": 2,  # points from every 2nd row/column of each depth map (lookups: all)
    "voxel": None,  # thinning voxel edge, world units; None: the median pixel footprint; 0: off
    "max_pixels": 4.0,  # rectified canvas at most this x the image's pixel count
    "max_disparities": 1024,  # SGBM search at most this wide (px); the near end is cut
    "max_image_size": None,  # longest image side matched (px); larger images are down-scaled; None/0: full
    "scheduler_timeout": 30.0,  # s to connect to a Dask scheduler
}


@dataclass
class DenseResult:
    """The fused dense cloud.

    ``points`` (N,3) float64 world units; ``colours`` (N,3) uint8 RGB from the reference
    images; ``n_views`` (N,) how many distinct views agree on the point (a pair counts two);
    ``quality`` (N,) in [0, 1]: 1 - rms relative depth disagreement of the agreeing depth
    maps / ``depth_tolerance`` (1: all depth maps give the same depth, 0: at the tolerance).
    ``pairs``: per pair ``ref``, ``src``, ``valid`` (matched pixels), ``consistent``.
    ``image_size``: (width, height) px of the images matched (after ``max_image_size``).
    """

    points: np.ndarray
    colours: np.ndarray
    n_views: np.ndarray
    quality: np.ndarray
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    pairs: list[dict] = field(default_factory=list)
    image_size: tuple[int, int] = (0, 0)


def scaled_camera(K: np.ndarray, scale: tuple[float, float]) -> np.ndarray:
    """Intrinsics (3x3, px) of an image resized by ``scale`` = (sx, sy), new size over old.

    ``cv2.resize`` maps pixel centres as ``u' = (u + 0.5) sx - 0.5`` (the image's corner is
    the fixed point; OpenCV puts the top-left pixel's centre at (0, 0)), so ``fx' = sx fx``,
    ``cx' = (cx + 0.5) sx - 0.5`` (likewise y). The distortion coefficients act on normalised
    coordinates and stay as they are; the poses, hence the world units, do not change.
    """
    sx, sy = float(scale[0]), float(scale[1])
    S = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
    return S @ np.asarray(K, float).reshape(3, 3)


def downscale(images: list[np.ndarray], views: list[dict], max_image_size: int | None):
    """Images whose longest side exceeds ``max_image_size`` px resized (``cv2.INTER_AREA``,
    which averages, so no aliasing of a fine speckle) and their views' ``K`` scaled to match
    (:func:`scaled_camera`). SGBM's cost grows with pixels x disparities, i.e. with the cube of
    the image side. Returns (images, views, (width, height)); unchanged when small enough."""
    h, w = np.asarray(images[0]).shape[:2]
    if not max_image_size or max(w, h) <= int(max_image_size):
        return images, views, (w, h)
    s = int(max_image_size) / max(w, h)
    nw, nh = max(1, round(w * s)), max(1, round(h * s))
    out = [cv2.resize(np.asarray(im), (nw, nh), interpolation=cv2.INTER_AREA) for im in images]
    scale = (nw / w, nh / h)
    return out, [{**v, "K": scaled_camera(v["K"], scale)} for v in views], (nw, nh)


def _grey(img: np.ndarray) -> np.ndarray:
    return img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)


def depth_map(images: tuple, cams: tuple, zrange: tuple, opts: dict) -> dict | None:
    """Depth map of one pair in the reference view's rectified frame (runs on a worker).

    ``images`` (reference, source) uint8; ``cams`` their :class:`~.pairs.Camera`;
    ``zrange`` the reference's depth range. Returns ``dict(rect=Rectified without maps,
    Z=(H,W) float32 rectified depth, NaN where unmatched, cropped to the matched pixels,
    colours=(H/stride,W/stride,3) uint8, stride)`` or None.
    """
    h, w = images[0].shape[:2]
    rect = rectify(cams[0], cams[1], w, h, zrange, opts["max_pixels"], int(opts["max_disparities"]))
    if rect is None:
        return None
    m1x, m1y, m2x, m2y = rect.maps
    left = cv2.remap(images[0], m1x, m1y, cv2.INTER_LINEAR)
    right = cv2.remap(_grey(images[1]), m2x, m2y, cv2.INTER_LINEAR)
    # intensity and texture judged in the original image: the canvas border is no texture
    g = _grey(images[0]).astype(np.float32)
    var = (
        cv2.blur(g * g, (5, 5), borderType=cv2.BORDER_REFLECT) - cv2.blur(g, (5, 5), borderType=cv2.BORDER_REFLECT) ** 2
    )
    good = ((g >= opts["min_intensity"]) & (var >= opts["min_texture"] ** 2)).astype(np.uint8)
    good = cv2.remap(good, m1x, m1y, cv2.INTER_NEAREST) > 0
    inside = cv2.remap(np.full((h, w), 255, np.uint8), m1x, m1y, cv2.INTER_NEAREST) > 0
    gl = _grey(left)
    bs = int(opts["block_size"])
    sgbm = cv2.StereoSGBM_create(  # type: ignore[attr-defined]  # not in cv2's stubs
        minDisparity=0,
        numDisparities=rect.n_disp,
        blockSize=bs,
        P1=8 * bs * bs,
        P2=32 * bs * bs,
        disp12MaxDiff=1,  # the left-right consistency check, px
        uniquenessRatio=int(opts["uniqueness"]),
        speckleWindowSize=100,
        speckleRange=2,
        mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )
    d = sgbm.compute(gl, right).astype(np.float32) / 16.0  # fixed point, 4 fractional bits
    # a disparity at either end of the search is saturated (the true one lies outside), not a match
    ok = (d > 1) & (d < rect.n_disp - 2) & good
    # keep the window and the interpolation ramp at the image's edge off the canvas border
    ok &= cv2.erode(inside.astype(np.uint8), np.ones((bs + 4, bs + 4), np.uint8)) > 0
    Z = np.full(d.shape, np.nan, np.float32)
    Z[ok] = rect.f * rect.baseline / (d[ok] + rect.shift)
    if left.ndim == 2:
        left = np.repeat(left[..., None], 3, axis=2)
    # Memory: keep the matched pixels' bounding box (an object on a dark background fills
    # little of the canvas), shifting the principal point to match, on the fusion's stride
    # grid; colours only where fusion takes points.
    s = max(int(opts["fusion_stride"]), 1)
    rows, cols = np.flatnonzero(ok.any(1)), np.flatnonzero(ok.any(0))
    if len(rows) == 0:
        rows = cols = np.zeros(1, int)
    y0, x0 = rows[0] - rows[0] % s, cols[0] - cols[0] % s
    Z = Z[y0 : rows[-1] + 1, x0 : cols[-1] + 1].copy()
    rect.cx, rect.cy, rect.maps = rect.cx - x0, rect.cy - y0, ()
    colours = left[y0 : rows[-1] + 1 : s, x0 : cols[-1] + 1 : s].copy()
    return {"rect": rect, "Z": Z, "colours": colours, "stride": s}


def _check(images: list[np.ndarray], views: list[dict]) -> tuple[int, int]:
    if len(images) != len(views):
        raise InputError(f"{len(images)} images but {len(views)} views: one view per image")
    if len(images) < 3:
        raise InputError(f"{len(images)} images: the dense cloud needs at least 3 (a pair and a confirming view)")
    shapes = {np.asarray(im).shape[:2] for im in images}
    if len(shapes) != 1:
        raise InputError(f"images of different sizes {sorted(shapes)}: the dense stage needs one size")
    for i, im in enumerate(images):
        a = np.asarray(im)
        if a.dtype != np.uint8 or not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)):
            raise InputError(f"image {i}: needs uint8 (h,w) or (h,w,3), got {np.asarray(im).dtype} {np.shape(im)}")
    return shapes.pop()


def _run_local(tasks, progress, cancel):
    out = []
    for k, task in enumerate(tasks):
        if cancel is not None and cancel.is_set():
            raise Cancelled("dense cloud: cancelled")
        out.append(depth_map(*task))
        if progress is not None:
            progress(0.8 * (k + 1) / len(tasks), f"depth map {k + 1}/{len(tasks)}")
    return out


def _run_dask(tasks, scheduler, progress, cancel, timeout=30.0):
    # The pattern of camcmm_plugins.uncertainty.distributed.DaskExecutor (a scheduler address
    # or a Client; results gathered in submission order), copied because plugins do not
    # import each other's modules.
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask is a dependency
        raise InputError(f"scheduler needs dask[distributed]: {exc}") from None
    if isinstance(scheduler, Client):
        client, own = scheduler, False
    else:
        try:
            client, own = Client(scheduler, timeout=timeout), True
        except Exception as exc:  # noqa: BLE001 - any connection failure is the address's fault
            raise InputError(f"Dask scheduler {scheduler!r}: cannot connect ({type(exc).__name__}: {exc})") from None
    try:
        futures = [client.submit(depth_map, *t, pure=False) for t in tasks]
        for k, _ in enumerate(as_completed(futures)):
            if cancel is not None and cancel.is_set():
                client.cancel(futures)
                raise Cancelled("dense cloud: cancelled")
            if progress is not None:
                progress(0.8 * (k + 1) / len(tasks), f"depth map {k + 1}/{len(tasks)} (Dask)")
        return client.gather(futures)
    finally:
        if own:
            client.close()


def dense_cloud(
    images: list[np.ndarray],
    views: list[dict],
    *,
    progress: Callable[[float, str], None] | None = None,
    cancel: Any = None,
    scheduler: Any = None,
    **options: Any,
) -> DenseResult:
    """Dense, fused point cloud of calibrated views.

    Parameters
    ----------
    images : list of ndarray
        uint8 (h,w) or (h,w,3) RGB, all of one size.
    views : list of dict
        Per image ``K`` (3x3, px), ``dist`` (5, OpenCV k1,k2,p1,p2,k3), ``R`` (3x3), ``t`` (3,)
        with ``x_cam = R X + t`` (world to camera; thesis eq. 2.1).
    progress, cancel
        ``progress(fraction, message)``; ``cancel.is_set()`` raises :class:`camcmm.api.Cancelled`
        between pairs.
    scheduler
        None: in-process (OpenCV's own threads); a Dask scheduler address or ``Client``: the
        per-pair depth maps run on that cluster.
    **options
        See :data:`DEFAULTS`.

    Returns
    -------
    DenseResult
        Points in the views' world units.
    """
    unknown = set(options) - set(DEFAULTS)
    if unknown:
        raise InputError(f"dense_cloud: unknown options {sorted(unknown)} (known: {sorted(DEFAULTS)})")
    opts = {**DEFAULTS, **options}
    t0 = time.perf_counter()
    _check(images, views)
    if opts["max_image_size"] is not None and int(opts["max_image_size"]) < 0:
        raise InputError(f"dense_cloud: max_image_size {opts['max_image_size']} px must be >= 0 (0: full size)")
    images, views, (w, h) = downscale(images, views, opts["max_image_size"])
    cams = cameras(views, (h, w))
    try:
        centre = scene_centre(cams)
    except InputError:
        if opts["depth_range"] is None:
            raise
        # (nearly) parallel axes, e.g. a stereo rig: the mean viewing point of the given range
        zr = depth_ranges(cams, np.zeros(3), opts["depth_range"])
        centre = np.mean([c.centre + c.axis * z.mean() for c, z in zip(cams, zr, strict=True)], axis=0)
    zr = depth_ranges(cams, centre, opts["depth_range"], opts["depth_margin"])
    pairs = choose_pairs(cams, centre, opts["n_neighbours"], opts["min_angle"], opts["max_angle"])
    warnings: list[str] = []
    lonely = sorted(set(range(len(cams))) - {p[0] for p in pairs})
    if lonely:
        warnings.append(
            f"views {lonely}: no neighbour within {opts['min_angle']}-{opts['max_angle']} deg triangulation angle"
        )
    if not pairs:
        raise InputError(
            f"no view pair with a triangulation angle of {opts['min_angle']}-{opts['max_angle']} deg: no overlap"
        )
    images = [np.ascontiguousarray(im) for im in images]  # OpenCV refuses negative strides
    tasks = [((images[i], images[j]), (cams[i], cams[j]), tuple(zr[i]), opts) for i, j in pairs]
    t1 = time.perf_counter()
    if scheduler is None:
        maps = _run_local(tasks, progress, cancel)
    else:
        maps = _run_dask(tasks, scheduler, progress, cancel, float(opts["scheduler_timeout"]))
    t2 = time.perf_counter()
    if cancel is not None and cancel.is_set():
        raise Cancelled("dense cloud: cancelled")
    if progress is not None:
        progress(0.85, "fusion")
    voxel = opts["voxel"]
    if voxel is None:
        voxel = float(np.median([z0 / c.K[0, 0] for c, z0 in zip(cams, zr.mean(1), strict=True)]))
    fused, stats = fusion.fuse(
        [(i, j, m) for (i, j), m in zip(pairs, maps, strict=True)],
        [c.centre for c in cams],
        [c.axis for c in cams],
        min_views=int(opts["min_views"]),
        tol=float(opts["depth_tolerance"]),
        n_check=int(opts["fusion_views"]),
        voxel=float(voxel),
        cancel=cancel,
    )
    t3 = time.perf_counter()
    if progress is not None:
        progress(1.0, f"{len(fused['points'])} dense points")
    clipped = [p for p, m in zip(pairs, maps, strict=True) if m is not None and m["rect"].clipped]
    if clipped:
        warnings.append(
            f"pairs {clipped[:5]}{' ...' if len(clipped) > 5 else ''}: the depth range needs more than "
            f"{opts['max_disparities']} px of disparity; the near end was cut: pass a narrower depth_range"
        )
    if len(fused["points"]) == 0:
        warnings.append("no dense point is seen consistently by enough views (texture? poses? depth_range?)")
    return DenseResult(
        fused["points"],
        fused["colours"],
        fused["n_views"],
        fused["quality"],
        warnings,
        {"setup": t1 - t0, "depth_maps": t2 - t1, "fusion": t3 - t2, "total": t3 - t0},
        stats,
        (int(w), int(h)),
    )


__all__ = [
    "DEFAULTS",
    "Camera",
    "DenseResult",
    "dense_cloud",
    "depth_map",
    "depth_range_from_points",
    "downscale",
    "scaled_camera",
]
