"""3-D points from decoded captures: camera-projector and camera-camera.

    projector_points(dec, cam, proj, axis="auto")  -> (points (n, 3) mm, flat pixel index (n,))
    stereo_points(dec1, dec2, cam1, cam2)          -> (points (n, 3) mm, fields dict)
    match_rows(left, right)                        -> sub-pixel x of each left value in the right rows

Camera-projector: each valid camera pixel's ray meets the projector stripe of its decoded
coordinate (:func:`.triangulate.intersect_stripe`; both distortions). With both fringe
directions decoded, ``axis="auto"`` uses the projector axis along which the camera is
displaced most (the better-conditioned stripe planes); ``"rays"`` triangulates the
camera ray with the projector ray of (u_p, v_p) instead.

Camera-camera (thesis ch. 5.2.4, figs. 5.4-5.5): both absolute-phase maps are rectified
(cv2.stereoRectify, bilinear remap; an invalid neighbour makes the sample invalid), so a
scene point lies on the same row of both. For every left pixel the right row is searched
for the pair of neighbouring pixels whose phases bracket the left phase, and the crossing
is interpolated linearly between them (the "two lowest phase differences" of fig. 5.5),
then refined on the cubic through the four nearest samples (the phase of a curved
surface is not linear between pixels: on a sphere 100 px in radius the linear crossing
alone biases the radius by -3 um, the cubic by -2 um, the rest being the bilinear
resampling of the rectification; both shrink with the square of the pixel size).
Matches that do not survive matching back from right to left (occlusions), or whose
other fringe direction disagrees, are dropped. The disparity then gives the point
through the rectification's Q matrix.
"""

from __future__ import annotations

import numpy as np

from camcmm.api import CameraModel, InputError

from .decode import Decoded
from .triangulate import intersect_stripe, triangulate_rays

AXES = {"vertical": 0, "horizontal": 1}


def _best_axis(dec: Decoded, cam: CameraModel, proj: CameraModel) -> str:
    have = [d for d in ("vertical", "horizontal") if dec.coords.get(d) is not None]
    if len(have) == 1:
        return have[0]
    centre = -cam.rotation.T @ cam.translation
    c_p = proj.rotation @ centre + proj.translation  # camera centre in projector coordinates
    return "vertical" if abs(c_p[0]) >= abs(c_p[1]) else "horizontal"


def projector_points(dec: Decoded, cam: CameraModel, proj: CameraModel, axis: str = "auto", to_cal=None):
    """Triangulate every valid pixel against the projector. Returns (points, flat index).

    ``to_cal(direction, x)`` maps decoded pattern px to the projector calibration's px
    (:meth:`.sequence.Sequence.to_calibration_px`); default identity.
    """
    if to_cal is None:
        def to_cal(direction, x):
            return x
    idx = np.flatnonzero(dec.mask)
    h, w = dec.mask.shape
    pix = np.column_stack([idx % w, idx // w]).astype(np.float64)
    if axis == "rays":
        if dec.u is None or dec.v is None:
            raise InputError("triangulation 'rays' needs both vertical and horizontal fringes")
        uv = np.column_stack([to_cal("vertical", dec.u.ravel()[idx].astype(np.float64)),
                              to_cal("horizontal", dec.v.ravel()[idx].astype(np.float64))])
        pts = triangulate_rays(cam, proj, pix, uv)
    else:
        d = _best_axis(dec, cam, proj) if axis == "auto" else axis
        coord = dec.coords.get(d)
        if coord is None:
            raise InputError(f"triangulation: no {d} fringes were decoded")
        pts = intersect_stripe(cam, proj, pix, to_cal(d, coord.ravel()[idx].astype(np.float64)), AXES[d])
    ok = np.isfinite(pts).all(axis=1)
    return pts[ok], idx[ok]


def match_rows(left: np.ndarray, right: np.ndarray, max_step: float | None = None) -> np.ndarray:
    """Sub-pixel right x of every left sample on the same row (NaN where none).

    left, right : (H, W) float maps increasing along x (NaN invalid).
    A right pixel pair (x, x+1) brackets values in [right[x], right[x+1]) when both are
    valid and the step is positive and at most ``max_step`` (default 8x the median step);
    the crossing is interpolated linearly. Left samples are used when their steps to both
    row neighbours pass the same test. One binary search over all rows at once: the
    rows are made one sorted key array ``row * stride + value``.
    """
    h, w = right.shape
    a, b = right[:, :-1], right[:, 1:]
    step = b - a
    good = np.isfinite(step) & (step > 0)
    if not good.any():
        return np.full(left.shape, np.nan, np.float32)
    if max_step is None:
        max_step = 8.0 * float(np.median(step[good]))
    good &= step <= max_step
    rows, xs = np.nonzero(good)
    lo = a[rows, xs].astype(np.float64)
    span = float(np.nanmax(right) - np.nanmin(right)) + 1.0
    base = float(np.nanmin(right))
    stride = 2.0 * span
    keys = rows * stride + (lo - base)
    order = None
    if keys.size > 1 and np.any(keys[1:] < keys[:-1]):  # occlusions can repeat a phase in a row
        order = np.argsort(keys, kind="stable")
        keys = keys[order]
    # a left sample whose row steps to either neighbour are not like the right's good
    # steps sits on a depth edge, where the rectification mixed two surfaces
    lstep = np.diff(left, axis=1)
    lgood = np.isfinite(lstep) & (lstep > 0) & (lstep <= max_step)
    usable = np.zeros(left.shape, bool)
    usable[:, 1:-1] = lgood[:, :-1] & lgood[:, 1:]
    qi = np.flatnonzero(usable.ravel())
    qrow = qi // w
    qval = left.ravel()[qi].astype(np.float64)
    qkey = qrow * stride + (qval - base)
    pos = np.searchsorted(keys, qkey, side="right") - 1
    ok = pos >= 0
    pos = np.where(ok, pos, 0)
    cand = order[pos] if order is not None else pos
    crow, cx = rows[cand], xs[cand]
    ok &= crow == qrow
    v0 = a[crow, cx].astype(np.float64)
    v1 = b[crow, cx].astype(np.float64)
    ok &= (qval >= v0) & (qval < v1)
    out = np.full(left.size, np.nan, np.float32)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (qval - v0) / (v1 - v0)
        t = _cubic_crossing(right, crow, cx, qval, t)
        sub = cx + t
    out[qi[ok]] = sub[ok]
    return out.reshape(left.shape)


def bilinear(img: np.ndarray, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """img sampled at (mx, my) (px, any shape) with exact bilinear weights, float32.

    NaN outside the image or next to an invalid (NaN) sample. Written out because
    cv2.remap quantises the weights to 1/32 px, which biases a steep phase map by up to
    0.04 px of projector coordinate (tens of micrometres after triangulation).
    """
    h, w = img.shape
    x0 = np.floor(mx)
    y0 = np.floor(my)
    fx = (mx - x0).astype(np.float32)
    fy = (my - y0).astype(np.float32)
    xi = x0.astype(np.int64)
    yi = y0.astype(np.int64)
    inside = (xi >= 0) & (xi < w - 1) & (yi >= 0) & (yi < h - 1)
    i = np.where(inside, yi * w + xi, 0)
    flat = np.ascontiguousarray(img, dtype=np.float32).ravel()
    a = flat[i]
    b = flat[i + 1]
    c = flat[i + w]
    d = flat[i + w + 1]
    # a + fx (b - a) + fy ((c - a) + fx (d - c - b + a)), in place
    d -= c
    d -= b
    d += a
    d *= fx
    c -= a
    c += d
    c *= fy
    b -= a
    b *= fx
    a += b
    a += c
    a[~inside] = np.nan
    return a


def _sample_at(img, maps, ys, xs):
    """img at rectified positions (xs float, ys int): the rectification map is linear
    between neighbouring columns, then img is sampled bilinearly."""
    w = maps[0].shape[1]
    x0 = np.clip(np.floor(xs).astype(np.int64), 0, w - 2)
    f = xs - x0
    mx = maps[0][ys, x0] * (1 - f) + maps[0][ys, x0 + 1] * f
    my = maps[1][ys, x0] * (1 - f) + maps[1][ys, x0 + 1] * f
    return bilinear(img, mx, my)


def _cubic_crossing(right, rows, xs, q, t):
    """Refine linear crossings t in [0, 1) on the Catmull-Rom cubic through the four
    samples x-1 .. x+2 (two Newton steps); kept linear where a neighbour is missing."""
    w = right.shape[1]
    xm, xp = np.clip(xs - 1, 0, w - 1), np.clip(xs + 2, 0, w - 1)
    p0 = right[rows, xm].astype(np.float64)
    p1 = right[rows, xs].astype(np.float64)
    p2 = right[rows, np.minimum(xs + 1, w - 1)].astype(np.float64)
    p3 = right[rows, xp].astype(np.float64)
    c1 = 0.5 * (p2 - p0)
    c2 = p0 - 2.5 * p1 + 2 * p2 - 0.5 * p3
    c3 = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3
    tt = t.copy()
    for _ in range(2):
        f = p1 + tt * (c1 + tt * (c2 + tt * c3)) - q
        df = c1 + tt * (2 * c2 + 3 * tt * c3)
        tt = tt - f / df
    ok = np.isfinite(tt) & (xs >= 1) & (xs + 2 < w) & (tt >= 0) & (tt < 1)
    return np.where(ok, tt, t)


def _pose_between(cam1: CameraModel, cam2: CameraModel):
    r = cam2.rotation @ cam1.rotation.T
    t = cam2.translation - r @ cam1.translation
    return r, t


def stereo_points(dec1: Decoded, dec2: Decoded, cam1: CameraModel, cam2: CameraModel, direction: str = "auto"):
    """Camera-camera matching of absolute phase along rectified rows, then triangulation.

    Returns (points (n, 3) mm in the world frame, fields {"modulation", "quality"}) and
    the direction matched.
    """
    import cv2

    h, w = dec1.mask.shape
    if dec2.mask.shape != (h, w):
        raise InputError(f"images2: {dec2.mask.shape[1]}x{dec2.mask.shape[0]} px, camera 1's are {w}x{h} px; "
                         "camera-camera matching needs equal sizes")
    r, t = _pose_between(cam1, cam2)
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(cam1.camera_matrix, cam1.dist_coeffs, cam2.camera_matrix,
                                                cam2.dist_coeffs, (w, h), r, t.reshape(3, 1),
                                                flags=cv2.CALIB_ZERO_DISPARITY,
                                                alpha=-1)
    if abs(p2[1, 3]) > abs(p2[0, 3]):
        raise InputError("calibration: the cameras are displaced vertically; rectified rows would be columns "
                         "(turn the images or use camera-projector triangulation)")
    m1 = cv2.initUndistortRectifyMap(cam1.camera_matrix, cam1.dist_coeffs, r1, p1, (w, h), cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(cam2.camera_matrix, cam2.dist_coeffs, r2, p2, (w, h), cv2.CV_32FC1)

    def rect(img, maps):
        return bilinear(img, maps[0], maps[1])

    have = [d for d in ("vertical", "horizontal") if dec1.coords.get(d) is not None
            and dec2.coords.get(d) is not None]
    if not have:
        raise InputError("stereo: the two cameras share no decoded fringe direction")
    left = {d: rect(dec1.coords[d], m1) for d in have}
    if direction == "auto":
        # match the coordinate that changes fastest along the rectified rows
        grad = {d: np.nanmedian(np.abs(np.diff(left[d][::16], axis=1))) for d in have}
        direction = max(have, key=lambda d: np.nan_to_num(grad[d]))
    lmap = left[direction]
    rmap = rect(dec2.coords[direction], m2)
    sign = np.sign(np.nanmedian(np.diff(lmap[::16], axis=1)))
    if sign < 0:  # the projector mirrored along the rows: make both increase
        np.negative(lmap, out=lmap)
        np.negative(rmap, out=rmap)
    xr = match_rows(lmap, rmap)
    # left-right consistency: where camera 2 does not see what camera 1 sees (occlusion)
    # a left phase can still find an equal phase on another surface of the right row;
    # matching back from the right must land on the same left pixel
    xl = match_rows(rmap, lmap)
    ys, xs = np.nonzero(np.isfinite(xr))
    xrv = xr[ys, xs].astype(np.float64)
    xi = np.clip(np.rint(xrv).astype(np.int64), 0, w - 1)
    keep = np.abs(xl[ys, xi] - (xs + (xi - xrv))) < 1.0
    other = [d for d in have if d != direction]
    if other:
        # the other fringe direction must agree too: the same projector row (column)
        lo_ = _sample_at(dec1.coords[other[0]], m1, ys, xs.astype(np.float64))
        ro_ = _sample_at(dec2.coords[other[0]], m2, ys, xrv)
        with np.errstate(invalid="ignore"):
            keep &= np.abs(lo_ - ro_) < 1.0  # projector px; decoding noise is ~0.05 px
    ys, xs, xrv = ys[keep], xs[keep], xrv[keep]
    disp = xs - xrv
    hom = np.column_stack([xs, ys, disp, np.ones_like(disp)]) @ q.T
    with np.errstate(divide="ignore", invalid="ignore"):
        pts_rect = hom[:, :3] / hom[:, 3:4]
    pts_cam1 = pts_rect @ r1  # rectified camera 1 -> camera 1 (R1^T x)
    pts = (pts_cam1 - cam1.translation) @ cam1.rotation  # camera 1 -> world
    ok = np.isfinite(pts).all(axis=1) & (pts_rect[:, 2] > 0)
    mod = _sample_at(dec1.modulation, m1, ys, xs.astype(np.float64))
    mean = _sample_at(dec1.mean, m1, ys, xs.astype(np.float64))
    quality = np.clip(mod / np.maximum(mean, 1e-6), 0, 1)
    ok &= np.isfinite(mod)
    fields = {"modulation": mod[ok].astype(np.float64), "quality": quality[ok].astype(np.float64)}
    return pts[ok], fields, direction
