"""Is a calibration believable? One-line warnings for degenerate view sets, implausible
parameters, large parameter uncertainties and a large reprojection error.

A calibration always converges to *something*: the same image three times gave
fx 906.6 / fy 828.0 px (truth ~533) at RMS 0.16 px; a board spec smaller than the board
gave RMS 9.3 px, fx 1772 px, k3 = 15 122. The checks here look at what the result rests
on (thesis ch. 2.4; Zhang 2000: each view of a planar board gives two constraints on the
intrinsics, and views whose board planes are parallel give the same two) and at whether
the result looks like a lens. Every threshold is a named constant with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: Fewer usable views than this is a warning (three are the minimum that calibrates at
#: all): with 4 intrinsics, 5 distortion coefficients and 6 pose parameters per view, a
#: handful of views leaves the distortion and the principal point poorly determined.
MIN_GOOD_VIEWS = 6
#: Two views whose board poses differ by less than this rotation AND ...
SAME_POSE_DEG = 1.0
#: ... less than this fraction of the board distance in translation show the board in the
#: same pose (a hand-held board moves more than that between shots): the second adds
#: no constraint, only weight.
SAME_POSE_FRACTION = 0.01
#: When every view's board normal is within this angle of the optical axis, the focal
#: length is ill-determined: a fronto-parallel board cannot tell a longer focal length from
#: a larger distance (Zhang recommends tilting by about 45°; 15° still separates them).
MIN_TILT_DEG = 15.0
#: When all board normals lie within this angle of each other, the board planes are
#: nearly parallel and give (nearly) the same two constraints however they are placed.
MIN_NORMAL_SPREAD_DEG = 10.0
#: RMS reprojection error above this (px) is a warning: corners are located to a few
#: tenths of a pixel, so more means a wrong board spec, a moving board or bad images.
MAX_RMS_PX = 1.0
#: |fx / fy - 1| above this: sensors have square pixels to well under 1 %, and a lens
#: without anamorphic elements does not change that.
MAX_ASPECT_DEVIATION = 0.05
#: Principal point farther from the image centre than this fraction of the image width
#: (height): lenses are centred on the sensor to a few per cent.
MAX_PP_OFFSET = 0.25
#: fx / image width outside this range: a horizontal field of view over ~136° (beyond what
#: the pinhole + polynomial model can describe) or under ~2° (a telescope).
FOCAL_TO_WIDTH = (0.2, 30.0)
#: Distortion that moves the image corner by more than this factor (either way) or that
#: folds over (the radial mapping stops increasing) inside the image is not a lens: the
#: polynomial has been fitted to something else.
MAX_DISTORTION_FACTOR = 2.0
#: Standard uncertainty of the focal length above this fraction of it, or of the principal
#: point above this fraction of the image size: the views do not determine them.
MAX_REL_SIGMA = 0.01


def _rot(rvec) -> np.ndarray:
    import cv2

    return cv2.Rodrigues(np.asarray(rvec, np.float64).reshape(3, 1))[0]


def _angle(ra: np.ndarray, rb: np.ndarray) -> float:
    """Angle (deg) of the rotation ra^T rb, as atan2(sin, cos) (arccos of the trace loses
    the small angles this is for)."""
    m = ra.T @ rb
    s = 0.5 * np.linalg.norm([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    return float(np.degrees(np.arctan2(s, 0.5 * (np.trace(m) - 1.0))))


def _list(idx: Sequence[int]) -> str:
    return ", ".join(str(i + 1) for i in idx)


def view_warnings(names: Sequence[str], rvecs, tvecs, what: str = "views") -> list[str]:
    """Warnings on the board poses (board -> camera; rvecs (V, 3), tvecs (V, 3) mm): too
    few views, views in the same pose (named, 1-based), too little tilt, parallel
    board planes. ``what`` names the views in the messages ("views", "pairs")."""
    out: list[str] = []
    n = len(names)
    rots = [_rot(r) for r in rvecs]
    t = np.asarray(tvecs, np.float64).reshape(-1, 3)
    # views in the same pose: connected groups of pairwise-close poses
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            dist = 0.5 * float(np.linalg.norm(t[i]) + np.linalg.norm(t[j]))
            if _angle(rots[i], rots[j]) < SAME_POSE_DEG and np.linalg.norm(t[i] - t[j]) < SAME_POSE_FRACTION * max(
                dist, 1e-300
            ):
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    distinct = len(groups)
    for g in groups.values():
        if len(g) > 1:
            files = sorted({names[i] for i in g})
            out.append(
                f"{what} {_list(g)} ({', '.join(files)}) show the board in the same pose "
                f"(within {SAME_POSE_DEG:g}° and {100 * SAME_POSE_FRACTION:g} % of the distance): "
                f"they add no information; move and tilt the board between views"
            )
    if distinct < MIN_GOOD_VIEWS:
        among = f" among {n} {what}" if distinct < n else ""
        out.append(
            f"only {distinct} distinct board pose{'s' if distinct != 1 else ''}{among}: the intrinsics and "
            f"the distortion are poorly determined; use at least {MIN_GOOD_VIEWS} views (10-20 is usual)"
        )
    # tilt: board normal (third column of R) against the optical axis
    normals = np.array([r[:, 2] for r in rots])
    tilt = np.degrees(np.arctan2(np.hypot(normals[:, 0], normals[:, 1]), np.abs(normals[:, 2])))
    if n and tilt.max() < MIN_TILT_DEG:
        out.append(
            f"the board faces the camera in every view (largest tilt {tilt.max():.3g}° < {MIN_TILT_DEG:g}°): "
            f"the focal length is ill-determined; tilt the board by 20-45° in some views"
        )
    elif distinct > 1:
        nz = normals * np.where(normals[:, 2:] < 0, -1.0, 1.0)
        spread = max(
            np.degrees(np.arctan2(np.linalg.norm(np.cross(nz[i], nz[j])), nz[i] @ nz[j]))
            for i in range(n)
            for j in range(i + 1, n)
        )
        if spread < MIN_NORMAL_SPREAD_DEG:
            out.append(
                f"the board planes are nearly parallel in all views (normals within {spread:.3g}° of each "
                f"other): the focal length is ill-determined; tilt the board in different directions"
            )
    return out


def _radial_factor(dist: np.ndarray, image_size, K: np.ndarray) -> tuple[float, bool]:
    """(factor, folds): the distorted over the undistorted radius (normalised coordinates)
    of the farthest image corner, and whether the distortion folds over (the distorted
    radius stops increasing) before reaching that corner, along the ray to it."""
    import cv2

    w, h = image_size
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    corners = np.array([[0, 0], [w, 0], [0, h], [w, h]], float)
    xn = np.column_stack([(corners[:, 0] - cx) / fx, (corners[:, 1] - cy) / fy])
    k = int(np.argmax(np.hypot(xn[:, 0], xn[:, 1])))
    rc = float(np.hypot(*xn[k]))
    if not rc > 0:
        return 1.0, False
    d = xn[k] / rc
    # undistorted radii out to MAX_DISTORTION_FACTOR times the corner's distorted radius
    t = np.linspace(0.0, MAX_DISTORTION_FACTOR * rc, 2001)[1:]
    obj = np.column_stack([t * d[0], t * d[1], np.ones_like(t)])
    q, _ = cv2.projectPoints(obj.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), np.eye(3), np.asarray(dist, np.float64))
    rd = np.hypot(q[:, 0, 0], q[:, 0, 1])
    reach = np.flatnonzero(rd >= rc)
    end = int(reach[0]) if reach.size else len(t)
    folds = bool(np.any(np.diff(rd[: end + 1]) <= 0)) if end > 0 else False
    if not reach.size:
        return float(rc / t[-1]), folds  # the corner lies beyond: the factor is below 1/MAX
    return float(rc / t[end]), folds


def intrinsic_warnings(K, dist, image_size, cov=None, camera: str = "") -> list[str]:
    """Warnings on one camera's intrinsics: K (3, 3) px, dist (n,) in OpenCV's order,
    image_size (w, h) px, ``cov`` the (4 + n, 4 + n) covariance of fx fy cx cy dist...
    (None: no uncertainty checks). ``camera`` prefixes the messages ("left camera: ")."""
    K = np.asarray(K, np.float64)
    dist = np.asarray(dist, np.float64).ravel()
    w, h = (float(v) for v in image_size)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    p = camera
    out: list[str] = []
    if not (fx > 0 and fy > 0 and np.all(np.isfinite(K)) and np.all(np.isfinite(dist))):
        return [f"{p}implausible intrinsics: fx {fx:.4g}, fy {fy:.4g} px, distortion {dist.tolist()}"]
    if abs(fx / fy - 1.0) > MAX_ASPECT_DEVIATION:
        out.append(
            f"{p}fx {fx:.4g} px and fy {fy:.4g} px differ by {100 * abs(fx / fy - 1):.3g} %: implausible "
            f"for a camera with square pixels (> {100 * MAX_ASPECT_DEVIATION:g} %)"
        )
    if w > 0 and h > 0:
        if abs(cx - w / 2) > MAX_PP_OFFSET * w or abs(cy - h / 2) > MAX_PP_OFFSET * h:
            where = "outside the image" if not (0 <= cx <= w and 0 <= cy <= h) else "far from the image centre"
            out.append(
                f"{p}principal point ({cx:.4g}, {cy:.4g}) px is {where} ({w:.0f} x {h:.0f} px): "
                f"implausible for a lens centred on the sensor"
            )
        lo, hi = FOCAL_TO_WIDTH
        if not lo * w <= fx <= hi * w:
            fov = np.degrees(2 * np.arctan(w / 2 / fx))
            out.append(
                f"{p}focal length {fx:.4g} px for an image {w:.0f} px wide (horizontal field of view "
                f"{fov:.3g}°) is implausible"
            )
        factor, folds = _radial_factor(dist, (w, h), K)
        if folds or not 1 / MAX_DISTORTION_FACTOR <= factor <= MAX_DISTORTION_FACTOR:
            what = (
                "folds over inside the image (the mapping is not one-to-one towards the corners)"
                if folds
                else f"moves the image corner by a factor {factor:.3g}"
            )
            out.append(
                f"{p}the distortion ({', '.join(f'{v:.4g}' for v in dist)}) {what}: implausible for a "
                f"lens; the views may not cover the image corners, or the board spec is wrong"
            )
    if cov is not None:
        sd = np.sqrt(np.clip(np.diag(np.asarray(cov, np.float64))[:4], 0.0, None))
        vals = dict(zip(("fx", "fy", "cx", "cy"), (fx, fy, cx, cy)))
        sig = dict(zip(vals, sd))
        rel = {"fx": sig["fx"] / fx, "fy": sig["fy"] / fy}
        if w > 0 and h > 0:
            rel.update({"cx": sig["cx"] / w, "cy": sig["cy"] / h})
        bad = [k for k, v in rel.items() if v > MAX_REL_SIGMA]
        if bad:
            parts = [f"{k} {vals[k]:.4g} ± {sig[k]:.3g} px" for k in bad]
            out.append(
                f"{p}large uncertainty: {', '.join(parts)} (over {100 * MAX_REL_SIGMA:g} % of the "
                f"{'focal length' if set(bad) <= {'fx', 'fy'} else 'focal length or image size'}): "
                f"the views do not determine the intrinsics"
            )
    return out


def rms_warning(rms: float, board: str = "", limit: float = MAX_RMS_PX, what: str = "") -> list[str]:
    """A warning when the RMS reprojection error (px) is above ``limit``."""
    if not float(rms) > limit:
        return []
    spec = f"the board spec {board} (COLSxROWS counts inner corners), " if board else ""
    return [
        f"{what}RMS reprojection error {float(rms):.3g} px is above {limit:g} px (corners are found to a few "
        f"tenths of a pixel): check {spec}the images with the largest errors and that the board is flat and "
        f"still"
    ]


def camera_warnings(result: dict[str, Any], max_rms: float = MAX_RMS_PX) -> list[str]:
    """Every check on a :func:`camera.calibrate_camera` result (its ``views``,
    ``camera_matrix``, ``dist_coeffs``, ``image_size``, ``covariance``, ``rms``)."""
    v = result["views"]
    return (
        view_warnings(v["names"], v["rvecs"], v["tvecs"])
        + intrinsic_warnings(
            result["camera_matrix"], result["dist_coeffs"], result["image_size"], result.get("covariance")
        )
        + rms_warning(result["rms"], result.get("board", ""), max_rms)
    )


def stereo_warnings(
    pairs: Sequence[tuple[str, str]],
    rvecs,
    tvecs,
    cameras,
    covs,
    image_size,
    rms: float,
    baseline: float,
    baseline_std: float,
    board: str = "",
    max_rms: float = MAX_RMS_PX,
) -> list[str]:
    """Every check on a stereo calibration: the board poses of the pairs (in the left
    camera), each camera's intrinsics ((K, dist) and the covariance block of its fx fy cx
    cy dist...), the joint RMS and the baseline's relative uncertainty."""
    out = view_warnings([f"{a} / {b}" for a, b in pairs], rvecs, tvecs, what="pairs")
    for side, (K, dist), cov in zip(("left", "right"), cameras, covs):
        out += intrinsic_warnings(K, dist, image_size, cov, camera=f"{side} camera: ")
    out += rms_warning(rms, board, max_rms, what="stereo: ")
    if baseline > 0 and baseline_std > MAX_REL_SIGMA * baseline:
        out.append(
            f"stereo: the baseline {baseline:.4g} ± {baseline_std:.2g} mm is uncertain by more than "
            f"{100 * MAX_REL_SIGMA:g} %: the pairs do not determine the relative pose"
        )
    return out
