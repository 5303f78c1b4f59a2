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
(cv2.stereoRectify's rotations, each camera's image kept whole at its resolution, exact
bilinear sampling corrected for the phase's curvature with the nearest pixel's second
differences; an invalid neighbour or a depth edge makes the sample invalid), so a scene
point lies on the same row of both. For every left pixel the right row is searched for
the pair of neighbouring pixels whose phases bracket the left phase, and the crossing is
interpolated linearly between them (the "two lowest phase differences" of fig. 5.5),
then refined on the cubic through the four nearest samples. The phase across a curved
surface is curved, and linear interpolation pulls it towards the chord, so both steps
are second order (exact for a phase quadratic between pixels): on a sphere 100 px in
radius plain bilinear rectification biased the fitted radius by -2.9 um (-7.5 um on the
diameter of a 20 mm sphere at 640 x 480 px in the virtual lab), the linear crossing
alone by -0.5 um; with both it is -0.01 um (tests). The price is noise: the corrected
samples average the decoding noise less than bilinear ones, and the points scatter
20-30 % more (form and flatness ranges grow alike). Wider schemes (a bicubic, the
curvature interpolated or averaged over neighbours) scatter less but bias the diameter
by +0.3 to +0.6 um there, where the curvature changes fast towards the outline.
Matches that do not survive matching back from right to left (occlusions), or whose
other fringe direction disagrees (when both are decoded), are dropped. The disparity then
gives the point through the rectification's Q matrix.
"""

from __future__ import annotations

import os

import numpy as np

from camcmm.api import CameraModel, InputError

from .decode import Decoded
from .resample import bilinear, gradient_scale, sample_at, second_differences
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
        uv = np.column_stack(
            [
                to_cal("vertical", dec.u.ravel()[idx].astype(np.float64)),
                to_cal("horizontal", dec.v.ravel()[idx].astype(np.float64)),
            ]
        )
        pts = triangulate_rays(cam, proj, pix, uv)
    else:
        d = _best_axis(dec, cam, proj) if axis == "auto" else axis
        coord = dec.coords.get(d)
        if coord is None:
            raise InputError(f"triangulation: no {d} fringes were decoded")
        pts = intersect_stripe(cam, proj, pix, to_cal(d, coord.ravel()[idx].astype(np.float64)), AXES[d])
    ok = np.isfinite(pts).all(axis=1)
    return pts[ok], idx[ok]


def match_rows(left: np.ndarray, right: np.ndarray, max_step: float | None = None, refine: bool = True) -> np.ndarray:
    """Sub-pixel right x of every left sample on the same row (NaN where none).

    left, right : (H, W) float32 maps increasing along x (NaN invalid).
    A right pixel pair (x, x+1) brackets values in [right[x], right[x+1]) when both are
    valid and the step is positive and at most ``max_step`` (default 8x the median step);
    the crossing is interpolated linearly (and with ``refine`` on the cubic through
    the four nearest samples). Left samples are used when their steps to both row
    neighbours pass the same test. One binary search over all rows at once: the rows are
    made one sorted key array ``row * stride + value``.
    """
    h, w = right.shape
    rf = np.ascontiguousarray(right, dtype=np.float32).ravel()
    lf = np.ascontiguousarray(left, dtype=np.float32).ravel()
    out = np.full(h * w, np.nan, np.float32)
    step = np.diff(right, axis=1)
    with np.errstate(invalid="ignore"):
        if max_step is None:
            pos_steps = step[step > 0]
            if not pos_steps.size:
                return out.reshape(h, w)
            max_step = 8.0 * float(np.median(pos_steps))
        good = (step > 0) & (step <= max_step)  # NaN compares False
        gi = np.flatnonzero(good)
        if not gi.size:
            return out.reshape(h, w)
        rows = gi // (w - 1)
        ridx = gi + rows  # index of the pair's left sample in the (h, w) right map
        lo = rf[ridx]
        base = float(lo.min())
        stride = 2.0 * (float(lo.max()) - base + max_step + 1.0)
        keys = rows * stride + (lo - base)
        order = None
        if keys.size > 1 and np.any(keys[1:] < keys[:-1]):  # occlusions can repeat a phase in a row
            order = np.argsort(keys, kind="stable")
            keys = keys[order]
        # a left sample whose row steps to either neighbour are not like the right's good
        # steps sits on a depth edge, where the rectification mixed two surfaces
        lstep = np.diff(left, axis=1)
        lgood = (lstep > 0) & (lstep <= max_step)
    qi = np.flatnonzero(lgood[:, :-1] & lgood[:, 1:])
    if not qi.size:
        return out.reshape(h, w)
    qrow = qi // (w - 2)
    lidx = qi + 2 * qrow + 1  # (row, x + 1) in the (h, w) left map
    qval = lf[lidx]
    pos = np.searchsorted(keys, qrow * stride + (qval - base), side="right") - 1
    np.maximum(pos, 0, out=pos)
    cand = order[pos] if order is not None else pos
    cidx = ridx[cand]
    v0 = rf[cidx]
    v1 = rf[cidx + 1]
    ok = (rows[cand] == qrow) & (qval >= v0) & (qval < v1)
    cidx, qval, v0, v1, lidx = cidx[ok], qval[ok], v0[ok], v1[ok], lidx[ok]
    t = (qval - v0) / (v1 - v0)
    cx = (cidx % w).astype(np.float32)
    if refine:
        t = _cubic_crossing(rf, cidx, cx, w, qval, v0, v1, t)
    out[lidx] = cx + t
    return out.reshape(h, w)


def _cubic_crossing(rf, cidx, cx, w, q, p1, p2, t):
    """Refine linear crossings t in [0, 1) on the Catmull-Rom cubic through the four
    samples x-1 .. x+2 (one Newton step from the linear estimate, whose error is already
    small); kept linear where a neighbour is missing or the step leaves [0, 1)."""
    inner = (cx >= 1) & (cx < w - 2)
    i = np.where(inner, cidx, 1)
    p0 = rf[i - 1]
    p3 = rf[i + 2]
    c1 = 0.5 * (p2 - p0)
    c2 = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3
    c3 = 0.5 * (p3 - p0) + 1.5 * (p1 - p2)
    f = p1 - q + t * (c1 + t * (c2 + t * c3))
    df = c1 + t * (2.0 * c2 + 3.0 * t * c3)
    with np.errstate(invalid="ignore", divide="ignore"):
        tt = t - f / df
    ok = inner & (tt >= 0) & (tt < 1)  # NaN (a missing neighbour) fails too
    return np.where(ok, tt, t)


def rectification(cam1: CameraModel, cam2: CameraModel, size: tuple[int, int], max_growth: float = 4.0):
    """Rectifying rotations R1, R2, projections P1, P2, Q and the rectified image size.

    cv2.stereoRectify gives the rotations; the projections are then chosen so that each
    camera's whole image lands inside the rectified one at about its own resolution:
    focal length the mean of camera 1's, a common principal row, and each camera its own
    principal column (a convergent pair's views are far apart in a common frame, and
    CALIB_ZERO_DISPARITY at the image size would keep no overlap). The rectified image is
    at most ``max_growth`` times the original pixels (the focal length shrinks to fit).
    Q maps (x, y, x - x2, 1) to homogeneous camera-1-rectified coordinates.
    """
    import cv2

    w, h = size
    r, t = _pose_between(cam1, cam2)
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(
        cam1.camera_matrix, cam1.dist_coeffs, cam2.camera_matrix, cam2.dist_coeffs, (w, h), r, t.reshape(3, 1), alpha=-1
    )
    if abs(p2[1, 3]) > abs(p2[0, 3]):
        raise InputError(
            "calibration: the cameras are displaced vertically; rectified rows would be columns "
            "(turn the images or use camera-projector triangulation)"
        )
    baseline = p2[0, 3] / p2[0, 0]  # Tx in mm: x2_rect = x1_rect + Tx (rectified frame)
    # the outline of each image in normalised rectified coordinates
    n = 256
    edge = np.concatenate(
        [
            np.c_[np.linspace(0, w - 1, n), np.zeros(n)],
            np.c_[np.linspace(0, w - 1, n), np.full(n, h - 1.0)],
            np.c_[np.zeros(n), np.linspace(0, h - 1, n)],
            np.c_[np.full(n, w - 1.0), np.linspace(0, h - 1, n)],
        ]
    )
    boxes = []
    for cam, rr in ((cam1, r1), (cam2, r2)):
        xy = cv2.undistortPoints(edge.reshape(-1, 1, 2), cam.camera_matrix, cam.dist_coeffs, R=rr).reshape(-1, 2)
        boxes.append((xy.min(axis=0), xy.max(axis=0)))
    f = 0.5 * (cam1.camera_matrix[0, 0] + cam1.camera_matrix[1, 1])
    y_lo = min(b[0][1] for b in boxes)
    y_hi = max(b[1][1] for b in boxes)
    x_span = max(b[1][0] - b[0][0] for b in boxes)
    growth = (f * x_span + 1) * (f * (y_hi - y_lo) + 1) / (w * h)
    if growth > max_growth:
        f /= np.sqrt(growth / max_growth)
    wr, hr = int(np.ceil(f * x_span)) + 1, int(np.ceil(f * (y_hi - y_lo))) + 1
    cy = -f * y_lo
    cx1, cx2 = -f * boxes[0][0][0], -f * boxes[1][0][0]
    p1 = np.array([[f, 0, cx1, 0], [0, f, cy, 0], [0, 0, 1, 0]])
    p2 = np.array([[f, 0, cx2, f * baseline], [0, f, cy, 0], [0, 0, 1, 0]])
    # x1 - x2 = f (X / Z) + cx1 - (f (X + Tx) / Z + cx2) = -f Tx / Z + cx1 - cx2
    q = np.array([[1, 0, 0, -cx1], [0, 1, 0, -cy], [0, 0, 0, f], [0, 0, -1 / baseline, (cx1 - cx2) / baseline]])
    return r1, r2, p1, p2, q, (wr, hr)


def _pose_between(cam1: CameraModel, cam2: CameraModel):
    r = cam2.rotation @ cam1.rotation.T
    t = cam2.translation - r @ cam1.translation
    return r, t


def stereo_points(
    dec1: Decoded, dec2: Decoded, cam1: CameraModel, cam2: CameraModel, direction: str = "auto", block_rows: int = 64
):
    """Camera-camera matching of absolute phase along rectified rows, then triangulation.

    Works through blocks of ``block_rows`` rectified rows, on threads, so that each
    block's arrays stay in the processor's cache. Returns (points (n, 3) mm in the world frame, fields
    {"modulation", "quality", "x_px", "y_px"} (the camera-1 pixel of each point)) and the
    direction matched.
    """
    import cv2

    h, w = dec1.mask.shape
    if dec2.mask.shape != (h, w):
        raise InputError(
            f"images2: {dec2.mask.shape[1]}x{dec2.mask.shape[0]} px, camera 1's are {w}x{h} px; "
            "camera-camera matching needs equal sizes"
        )
    r, t = _pose_between(cam1, cam2)
    r1, r2, p1, p2, q, size = rectification(cam1, cam2, (w, h))
    m1 = cv2.initUndistortRectifyMap(cam1.camera_matrix, cam1.dist_coeffs, r1, p1, size, cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(cam2.camera_matrix, cam2.dist_coeffs, r2, p2, size, cv2.CV_32FC1)
    hr, wr = size[1], size[0]
    have = [d for d in ("vertical", "horizontal") if dec1.coords.get(d) is not None and dec2.coords.get(d) is not None]
    if not have:
        raise InputError("stereo: the two cameras share no decoded fringe direction")

    def median_step(img, maps):
        rows = bilinear(img, maps[0][::16], maps[1][::16])
        return float(np.nan_to_num(np.nanmedian(np.diff(rows, axis=1))))

    if direction == "auto":
        # match the coordinate that changes fastest along the rectified rows
        direction = max(have, key=lambda d: abs(median_step(dec1.coords[d], m1)))
    sign = np.float32(-1.0 if median_step(dec1.coords[direction], m1) < 0 else 1.0)
    step2 = abs(median_step(dec2.coords[direction], m2))
    max_step = 8.0 * step2 if step2 > 0 else None
    other = [d for d in have if d != direction]

    def curvature(img):
        # for the curvature correction of the phase resampling (without it a sphere's
        # radius comes out short: -7.5 um on 20 mm at 640 x 480 px); a second difference
        # as large as the typical phase step per pixel is no curvature but a depth edge
        return second_differences(img, gradient_scale(img))

    # rectified camera 1 -> camera 1 (R1^T x) -> world (R^T (x - t)), as one affine map
    to_world = r1 @ cam1.rotation
    offset = -cam1.translation @ cam1.rotation

    def block(y0):
        sl = slice(y0, min(hr, y0 + block_rows))
        b1, b2 = (m1[0][sl], m1[1][sl]), (m2[0][sl], m2[1][sl])
        lmap = bilinear(dec1.coords[direction], *b1, curvature=curv[0])
        rmap = bilinear(dec2.coords[direction], *b2, curvature=curv[1])
        if sign < 0:  # the projector mirrored along the rows: make both increase
            lmap *= sign
            rmap *= sign
        xr = match_rows(lmap, rmap, max_step).ravel()
        fi = np.flatnonzero(np.isfinite(xr))
        if not fi.size:
            return None
        ys = fi // wr
        xs = fi - ys * wr
        xrv = xr[fi].astype(np.float64)
        # left-right consistency: where camera 2 does not see what camera 1 sees
        # (occlusion) a left phase can still find an equal phase on another surface of
        # the right row; matching back from the right must land on the same pixel
        xl = match_rows(rmap, lmap, max_step, refine=False).ravel()
        xi = np.clip(np.rint(xrv).astype(np.int64), 0, wr - 1)
        keep = np.abs(xl[ys * wr + xi] - (xs + (xi - xrv))) < 1.0
        if other:
            # the other fringe direction must agree too: the same projector row (column)
            lo_ = sample_at([dec1.coords[other[0]]], b1, ys, xs)[0]
            ro_ = sample_at([dec2.coords[other[0]]], b2, ys, xrv)[0]
            with np.errstate(invalid="ignore"):
                keep &= np.abs(lo_ - ro_) < 1.0  # projector px; decoding noise is ~0.05 px
        ys, xs, xrv = ys[keep], xs[keep], xrv[keep]
        # (X, Y, Z, W) = Q (x, y, d, 1) with the Q of :func:`rectification`
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / (q[3, 2] * (xs - xrv) + q[3, 3])
        rect = ((xs + q[0, 3]) * inv, (ys + (y0 + q[1, 3])) * inv, q[2, 3] * inv)
        # rectified camera 1 -> world, one column at a time (faster than (n, 3) @ (3, 3))
        pts = np.empty((len(xs), 3))
        for k in range(3):
            pts[:, k] = rect[0] * to_world[0, k] + rect[1] * to_world[1, k] + rect[2] * to_world[2, k] + offset[k]
        mod, mean = sample_at([dec1.modulation, dec1.mean], b1, ys, xs)
        ok = np.isfinite(pts).all(axis=1) & (rect[2] > 0) & np.isfinite(mod)
        lin = ys * wr + xs
        return pts[ok], mod[ok], mean[ok], b1[0].ravel()[lin][ok], b1[1].ravel()[lin][ok]

    # numpy releases the GIL in its loops: work on two threads uses both cores
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        curv = list(pool.map(curvature, (dec1.coords[direction], dec2.coords[direction])))
        parts = [p for p in pool.map(block, range(0, hr, block_rows)) if p is not None]
    if not parts:
        return np.zeros((0, 3)), {k: np.zeros(0) for k in ("modulation", "quality", "x_px", "y_px")}, direction
    pts, mod, mean, xp, yp = (np.concatenate(c) for c in zip(*parts))
    quality = np.clip(mod / np.maximum(mean, 1e-6), 0, 1)
    fields = {
        "modulation": mod.astype(np.float64),
        "quality": quality.astype(np.float64),
        # where the point is in camera 1's (distorted) image
        "x_px": xp.astype(np.float64),
        "y_px": yp.astype(np.float64),
    }
    return pts, fields, direction
