"""Camera models: OpenCV's (camcmm's calibrations) to COLMAP's and back.

OpenCV and COLMAP describe the same pinhole camera with the same radial/tangential
distortion polynomial (thesis eqs. 2.1-2.6; COLMAP's ``OPENCV`` model is OpenCV's
k1 k2 p1 p2, ``FULL_OPENCV`` adds k3..k6 of the rational model, ``SIMPLE_RADIAL``/``RADIAL``
are k1 / k1 k2 with one focal length). They differ in where pixel coordinates start:
OpenCV puts the centre of the top-left pixel at (0, 0), COLMAP at (0.5, 0.5) (the image's
corner is COLMAP's origin), so ``c_colmap = c_opencv + 0.5``. In corner-origin coordinates a
resized image's coordinates scale exactly by the size ratio (cv2.resize's mapping), so the
down-scaled camera is ``f * s`` and ``c_colmap * s``; distortion coefficients act on
normalised coordinates and do not change.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import CameraModel, InputError

#: COLMAP model name -> the names of its parameters, in COLMAP's order
COLMAP_PARAMS: dict[str, tuple[str, ...]] = {
    "SIMPLE_PINHOLE": ("f", "cx", "cy"),
    "PINHOLE": ("fx", "fy", "cx", "cy"),
    "SIMPLE_RADIAL": ("f", "cx", "cy", "k1"),
    "RADIAL": ("f", "cx", "cy", "k1", "k2"),
    "OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"),
    "FULL_OPENCV": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
}


def check_intrinsics(where: str, camera: Any, fx: float, fy: float, cx: float, cy: float, size: Any) -> None:
    """Refuse, in one line starting with ``where`` and naming ``camera`` and the value,
    intrinsics that cannot describe a camera: the calibration readers' checks
    (``camcmm.api.CameraModel``: positive finite focal lengths, px; a finite principal point
    near the image, OpenCV's pixel origin; whole image sides from 1 to 65536 px; the
    distortion is checked by the caller, whose models differ), with a size of 0 x 0
    refused too (an imported camera always states its size; ``CameraModel`` reads 0 x 0
    as "unknown")."""
    w, h = size
    if w == 0 and h == 0:
        raise InputError(f"{where}: camera {str(camera)!r}: image size 0 x 0 px; width and height must be 1 px or more")
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]], dtype=np.float64)
    try:
        CameraModel(K, np.zeros(0), image_size=(w, h), name=str(camera))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def colmap_from_opencv(
    camera_matrix: Any, dist: Any = (), scale: tuple[float, float] = (1.0, 1.0)
) -> tuple[str, list[float]]:
    """COLMAP model name and parameters for an OpenCV camera, at an image scaled by ``scale``.

    Parameters
    ----------
    camera_matrix : (3, 3) K in px (OpenCV: top-left pixel centre at (0, 0)); no skew.
    dist : OpenCV distortion (k1, k2, p1, p2[, k3[, k4, k5, k6]]), or empty.
    scale : (sx, sy), the written image's size over the calibrated one.

    Returns
    -------
    (model, params): ``OPENCV`` when k3..k6 are zero, else ``FULL_OPENCV``.
    """
    k = np.asarray(camera_matrix, dtype=np.float64).reshape(3, 3)
    d = np.zeros(8)
    dd = np.asarray(dist, dtype=np.float64).ravel()
    if len(dd) > 8 and np.any(dd[8:] != 0):
        raise InputError(
            f"calibration: thin-prism or tilt distortion ({len(dd)} coefficients) has no COLMAP model; "
            "calibrate with k1 k2 p1 p2 [k3 [k4 k5 k6]]"
        )
    d[: min(len(dd), 8)] = dd[:8]
    if abs(k[0, 1]) > 1e-9 * abs(k[0, 0]):
        raise InputError(f"calibration: a skewed camera matrix (K[0,1] = {k[0, 1]:g}) has no COLMAP model")
    sx, sy = scale
    fx, fy = k[0, 0] * sx, k[1, 1] * sy
    cx, cy = (k[0, 2] + 0.5) * sx, (k[1, 2] + 0.5) * sy
    if np.any(d[4:] != 0):
        return "FULL_OPENCV", [fx, fy, cx, cy, *d[:4], *d[4:]]
    return "OPENCV", [fx, fy, cx, cy, *d[:4]]


def opencv_from_colmap(model: str, params: Any, scale: tuple[float, float] = (1.0, 1.0)) -> dict[str, Any]:
    """The OpenCV description of a COLMAP camera, taken back to full image size.

    Parameters
    ----------
    model : a COLMAP model name of :data:`COLMAP_PARAMS`.
    params : its parameters (COLMAP's order, at the scaled image).
    scale : (sx, sy) the scaled image's size over the full one (as given to
        :func:`colmap_from_opencv`).

    Returns
    -------
    dict ``model`` (COLMAP's name), ``fx fy cx cy`` (px, full size, OpenCV pixel origin),
    ``dist`` [k1, k2, p1, p2, k3] (or 8 values when k4..k6 are used), ``K`` (3, 3).
    """
    if model not in COLMAP_PARAMS:
        raise InputError(f"camera model {model!r} has no OpenCV equivalent here ({', '.join(COLMAP_PARAMS)})")
    names = COLMAP_PARAMS[model]
    p = dict(zip(names, np.asarray(params, dtype=np.float64).ravel(), strict=True))
    fx = p["fx"] if "fx" in p else p["f"]  # every COLMAP model has fx or f
    fy = p["fy"] if "fy" in p else p["f"]
    sx, sy = scale
    d = [p.get(n, 0.0) for n in ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")]
    dist = d if any(d[5:]) else d[:5]
    out = {
        "model": model,
        "fx": float(fx / sx),
        "fy": float(fy / sy),
        "cx": float(p["cx"] / sx - 0.5),
        "cy": float(p["cy"] / sy - 0.5),
        "dist": [float(v) for v in dist],
    }
    out["K"] = [[out["fx"], 0.0, out["cx"]], [0.0, out["fy"], out["cy"]], [0.0, 0.0, 1.0]]
    return out
