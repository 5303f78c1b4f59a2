"""Stereo calibration (thesis ch. 2.3.3, eqs. 2.3-2.7): R, T, E, F with uncertainties,
rectification and epipolar error statistics.

Each camera is first calibrated alone (:func:`camera.calibrate_camera`, with its outlier
views left out); the pairs where both cameras saw the board then go to
cv2.stereoCalibrateExtended, which refines both cameras' intrinsics and the pose of the
right camera in the left (``x_right = R x_left + T``, T in mm) unless
``fix_intrinsics``. Uncertainties come from the Jacobian of the joint problem
(:mod:`.covariance`), cross-checked by the spread of the per-view relative poses.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from camcmm.api import CameraModel, InputError

from .boards import Board, Detection, parse_board, require_found
from .camera import MIN_VIEWS, board_distance, calibrate_camera, model_flags
from .checks import MAX_RMS_PX, stereo_warnings
from .covariance import Observation, assemble, covariance, free_intrinsics, intrinsic_names


def _pairs(left: list[Detection], right: list[Detection], rejected: dict[str, str]):
    """Matched board points of the views both cameras kept (ids in common)."""
    pairs = []
    for dl, dr in zip(left, right):
        if dl.name in rejected or dr.name in rejected or not (dl.found and dr.found):
            continue
        common, il, ir = np.intersect1d(dl.ids, dr.ids, return_indices=True)
        if common.size < 6:
            continue
        pairs.append((dl.name, dr.name, dl.object_points[il], dl.image_points[il], dr.image_points[ir]))
    return pairs


def _epipolar(K1, D1, K2, D2, F, img_l, img_r) -> dict[str, float]:
    """Distances (px, undistorted images) of each point to the epipolar line of its
    partner (eq. 2.4), both ways: rms, mean, median, max."""
    import cv2

    ul = cv2.undistortPoints(img_l.reshape(-1, 1, 2), K1, D1, P=K1).reshape(-1, 2)
    ur = cv2.undistortPoints(img_r.reshape(-1, 1, 2), K2, D2, P=K2).reshape(-1, 2)
    hl = np.column_stack([ul, np.ones(len(ul))])
    hr = np.column_stack([ur, np.ones(len(ur))])
    lines_r = hl @ F.T  # l' = F x
    lines_l = hr @ F  # l = F^T x'
    d_r = np.abs(np.sum(lines_r * hr, 1)) / np.hypot(lines_r[:, 0], lines_r[:, 1])
    d_l = np.abs(np.sum(lines_l * hl, 1)) / np.hypot(lines_l[:, 0], lines_l[:, 1])
    d = np.concatenate([d_l, d_r])
    return {
        "rms": float(np.sqrt(np.mean(d**2))),
        "mean": float(d.mean()),
        "median": float(np.median(d)),
        "max": float(d.max()),
        "n": int(d_r.size),
    }


def _rectified_dy(K1, D1, K2, D2, rect, img_l, img_r) -> dict[str, float]:
    import cv2

    yl = cv2.undistortPoints(img_l.reshape(-1, 1, 2), K1, D1, R=rect["R1"], P=rect["P1"]).reshape(-1, 2)[:, 1]
    yr = cv2.undistortPoints(img_r.reshape(-1, 1, 2), K2, D2, R=rect["R2"], P=rect["P2"]).reshape(-1, 2)[:, 1]
    dy = np.abs(yl - yr)
    return {"rms": float(np.sqrt(np.mean(dy**2))), "mean": float(dy.mean()), "max": float(dy.max())}


def relative_pose_spread(single_l: dict, single_r: dict, pairs: list[tuple[str, str]]) -> dict[str, Any]:
    """R, T of the right camera in the left from each pair's board poses alone
    (R_i = R_r,i R_l,i^T, T_i = t_r,i - R_i t_l,i): their mean and the standard
    error of the mean (std / sqrt(n)) of the rotation vector (rad) and T (mm)."""
    import cv2

    vl, vr = single_l["views"], single_r["views"]
    il = {n: i for i, n in enumerate(vl["names"])}
    ir = {n: i for i, n in enumerate(vr["names"])}
    rv, tv = [], []
    for nl, nr in pairs:
        if nl not in il or nr not in ir:
            continue
        i, j = il[nl], ir[nr]
        R = cv2.Rodrigues(vr["rvecs"][j])[0] @ cv2.Rodrigues(vl["rvecs"][i])[0].T
        rv.append(cv2.Rodrigues(R)[0].ravel())
        tv.append(vr["tvecs"][j] - R @ vl["tvecs"][i])
    if len(rv) < 2:
        return {"n": len(rv)}
    rva, tva = np.array(rv), np.array(tv)
    n = len(rva)
    return {
        "n": n,
        "rvec_mean": rva.mean(0),
        "T_mean": tva.mean(0),
        "rvec_sem": rva.std(0, ddof=1) / np.sqrt(n),
        "T_sem": tva.std(0, ddof=1) / np.sqrt(n),
    }


def calibrate_stereo(
    left: Sequence[Detection],
    right: Sequence[Detection],
    board: Board | str,
    *,
    model: str = "standard",
    flags: int = 0,
    outlier_factor: float = 3.0,
    fix_intrinsics: bool = False,
    alpha: float = -1.0,
    names=("left", "right"),
    progress=None,
    max_rms: float = MAX_RMS_PX,
) -> dict[str, Any]:
    """Calibrate a stereo pair from board detections, image i of ``left`` paired with
    image i of ``right``.

    Returns ``cameras`` [left, right] (CameraModel; the right one carries R, T),
    ``R`` (3, 3), ``T`` (3,) mm, ``E``, ``F`` (x_r^T F x_l = 0, px), ``rms`` px,
    ``baseline`` mm and ``baseline_std``, ``std_rvec`` (3,) rad and ``std_T`` (3,) mm from
    the Jacobian, ``spread`` (per-view relative poses: mean and standard error),
    ``left``/``right`` per-camera results (camera_matrix, dist_coeffs, rms,
    std_intrinsics, per_view_rms, image_size, rejected), ``rectification`` (R1 R2 P1 P2 Q,
    roi1, roi2), ``epipolar`` (distances to epipolar lines, px) and ``rectified_dy``,
    ``pairs`` (image names used), ``rejected`` pairs, ``parameter_covariance`` over
    ``parameter_names`` (both cameras' intrinsics, then right.rx ... right.tz), ``single``
    (each camera's own calibration), ``warnings`` (the pairs' board poses, both cameras'
    intrinsics, the RMS against ``max_rms`` px, the baseline's uncertainty: see
    :mod:`.checks`).
    """
    import cv2

    board = parse_board(board)
    left, right = list(left), list(right)
    if len(left) != len(right):
        raise InputError(f"stereo needs pairs: {len(left)} left images but {len(right)} right images")
    require_found(board, left, "left images")
    require_found(board, right, "right images")
    if progress:
        progress(0.1, "left camera")
    single_l = calibrate_camera(left, board, model=model, flags=flags, outlier_factor=outlier_factor, name=names[0])
    if progress:
        progress(0.3, "right camera")
    single_r = calibrate_camera(right, board, model=model, flags=flags, outlier_factor=outlier_factor, name=names[1])
    if tuple(single_l["image_size"]) != tuple(single_r["image_size"]):
        raise InputError(
            f"left images are {single_l['image_size']} px but right images {single_r['image_size']} px; "
            f"OpenCV's stereo calibration needs one image size"
        )
    dropped = {r["image"]: r["reason"] for r in single_l["rejected"] + single_r["rejected"]}
    pairs = _pairs(left, right, dropped)
    rejected: list[dict[str, Any]] = [
        {
            "left": dl.name,
            "right": dr.name,
            "reason": "; ".join(f"{n}: {dropped[n]}" for n in (dl.name, dr.name) if n in dropped)
            or "fewer than 6 common points",
        }
        for dl, dr in zip(left, right)
        if (dl.name, dr.name) not in {(p[0], p[1]) for p in pairs}
    ]
    size = tuple(single_l["image_size"])
    mflags = model_flags(model, flags)
    sflags = mflags | (cv2.CALIB_FIX_INTRINSIC if fix_intrinsics else cv2.CALIB_USE_INTRINSIC_GUESS)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    while True:
        if len(pairs) < MIN_VIEWS:
            raise InputError(f"only {len(pairs)} image pairs show the board in both cameras; stereo needs {MIN_VIEWS}")
        if progress:
            progress(0.6, f"stereo on {len(pairs)} pairs")
        obj = [p[2] for p in pairs]
        il = [p[3] for p in pairs]
        ir = [p[4] for p in pairs]
        # cv2's stubs want R and T arrays; None (no initial guess) is what OpenCV takes here
        rms, K1, D1, K2, D2, R, T, E, F, rvecs, tvecs, pv = cv2.stereoCalibrateExtended(  # type: ignore[call-overload]
            obj,
            il,
            ir,
            single_l["camera_matrix"].copy(),
            single_l["dist_coeffs"].copy(),
            single_r["camera_matrix"].copy(),
            single_r["dist_coeffs"].copy(),
            size,
            None,
            None,
            flags=sflags,
            criteria=crit,
        )
        pv = pv.reshape(-1, 2)
        worst_pair = np.max(pv, 1)
        med = float(np.median(worst_pair))
        w = int(np.argmax(worst_pair))
        if outlier_factor <= 0 or len(pairs) <= MIN_VIEWS or worst_pair[w] <= outlier_factor * med:
            break
        rejected.append(
            {
                "left": pairs[w][0],
                "right": pairs[w][1],
                "reason": f"outlier: pair RMS {worst_pair[w]:.3g} px > {outlier_factor:g} x median {med:.3g} px",
                "rms": [float(v) for v in pv[w]],
            }
        )
        pairs.pop(w)
    D1, D2, T = D1.ravel(), D2.ravel(), T.ravel()
    rvec = cv2.Rodrigues(R)[0].ravel()
    # covariance of the joint problem: both intrinsics, the relative pose, every board pose
    obs = [Observation(v, k, p[2], p[3 + k]) for v, p in enumerate(pairs) for k in (0, 1)]
    masks = [free_intrinsics(mflags, D1.size), free_intrinsics(mflags, D2.size)]
    views = [(np.ravel(r), np.ravel(t)) for r, t in zip(rvecs, tvecs)]
    jtj, _, sse, rows, lay = assemble([(K1, D1), (K2, D2)], [(rvec, T)], views, obs, masks)
    cov, sigma = covariance(jtj, sse, rows)
    glob = np.concatenate([*lay["intrinsics"], *lay["relative"]])
    cov_g = cov[np.ix_(glob, glob)]
    n1, n2 = 4 + D1.size, 4 + D2.size
    std_g = np.sqrt(np.diag(cov_g))
    cov_T = cov_g[n1 + n2 + 3 :, n1 + n2 + 3 :]
    baseline = float(np.linalg.norm(T))
    u = T / baseline
    # spread check: per-view relative poses of the two single calibrations
    spread = relative_pose_spread(single_l, single_r, [(p[0], p[1]) for p in pairs])
    R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
        K1, D1, K2, D2, size, R, T.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=alpha
    )
    rect = {"R1": R1, "R2": R2, "P1": P1, "P2": P2, "Q": Q}
    all_l = np.concatenate([p[3] for p in pairs]).astype(np.float64)
    all_r = np.concatenate([p[4] for p in pairs]).astype(np.float64)
    pair_names = [(p[0], p[1]) for p in pairs]

    def per_cam(k, single, K, D, std, nd):
        npts = np.array([len(p[2]) for p in pairs])
        e = pv[:, k]
        return {
            "camera_matrix": K,
            "dist_coeffs": D,
            "rms": float(np.sqrt(np.sum(npts * e**2) / npts.sum())),
            "std_intrinsics": std,
            "std_named": dict(zip(intrinsic_names(nd), std.tolist())),
            "per_view_rms": {pn[k]: float(x) for pn, x in zip(pair_names, e)},
            "image_size": list(size),
            "rejected": single["rejected"],
            "board_distance": board_distance(single),
        }

    warnings = stereo_warnings(
        pair_names,
        [np.ravel(r) for r in rvecs],
        [np.ravel(t) for t in tvecs],
        [(K1, D1), (K2, D2)],
        [cov_g[:n1, :n1], cov_g[n1 : n1 + n2, n1 : n1 + n2]],
        size,
        float(rms),
        baseline,
        float(np.sqrt(u @ cov_T @ u)),
        board.spec,
        max_rms,
    )
    cam_l = CameraModel(K1, D1, image_size=size, name=names[0])
    cam_r = CameraModel(K2, D2, R, T, size, name=names[1])
    pnames = (
        [f"{names[0]}.{p}" for p in intrinsic_names(D1.size)]
        + [f"{names[1]}.{p}" for p in intrinsic_names(D2.size)]
        + [f"{names[1]}.{p}" for p in ("rx", "ry", "rz", "tx", "ty", "tz")]
    )
    return {
        "cameras": [cam_l, cam_r],
        "R": R,
        "T": T,
        "E": E,
        "F": F,
        "rvec": rvec,
        "rms": float(rms),
        "baseline": baseline,
        "baseline_std": float(np.sqrt(u @ cov_T @ u)),
        "std_rvec": std_g[n1 + n2 : n1 + n2 + 3],
        "std_T": std_g[n1 + n2 + 3 :],
        "spread": spread,
        "left": per_cam(0, single_l, K1, D1, std_g[:n1], D1.size),
        "right": per_cam(1, single_r, K2, D2, std_g[n1 : n1 + n2], D2.size),
        "rectification": {**rect, "roi1": list(roi1), "roi2": list(roi2)},
        "epipolar": _epipolar(K1, D1, K2, D2, F, all_l, all_r),
        "rectified_dy": _rectified_dy(K1, D1, K2, D2, rect, all_l, all_r),
        "pairs": [list(p) for p in pair_names],
        "rejected": rejected,
        "parameter_covariance": cov_g,
        "parameter_names": pnames,
        "residual_sigma": sigma,
        "flags": int(sflags),
        "board": board.spec,
        "single": {"left": single_l, "right": single_r},
        "warnings": warnings,
    }


def calibration_dict(result: dict[str, Any]) -> dict[str, Any]:
    """The calibration file dict (camcmm.api.write_calibration) of a stereo result."""
    rect = {k: v for k, v in result["rectification"].items() if k in ("R1", "R2", "P1", "P2", "Q")}
    return {
        "cameras": result["cameras"],
        "rms": result["rms"],
        "R": result["R"],
        "T": result["T"],
        "E": result["E"],
        "F": result["F"],
        "rectification": rect,
        "board": result["board"],
        "std_intrinsics": [result["left"]["std_intrinsics"], result["right"]["std_intrinsics"]],
        "std_rvec": result["std_rvec"],
        "std_T": result["std_T"],
        "baseline": result["baseline"],
        "baseline_std": result["baseline_std"],
        "parameter_covariance": result["parameter_covariance"],
        "parameter_names": result["parameter_names"],
        "epipolar": result["epipolar"],
        "pairs": result["pairs"],
        "rejected": result["rejected"],
        "flags": result["flags"],
    }


def stereo_json(result: dict[str, Any]) -> dict[str, Any]:
    """The CLI's JSON: left, right (as for one camera), R, T, E, F, rms (+ uncertainties,
    baseline, epipolar statistics, rectification, pairs, rejected, warnings)."""

    def cam(c):
        return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in c.items()}

    sp = {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in result["spread"].items()}
    return {
        "left": cam(result["left"]),
        "right": cam(result["right"]),
        "R": result["R"].tolist(),
        "T": result["T"].tolist(),
        "E": result["E"].tolist(),
        "F": result["F"].tolist(),
        "rms": result["rms"],
        "rvec": np.ravel(result["rvec"]).tolist(),
        "rotation_angle": float(np.linalg.norm(result["rvec"])),
        "std_rvec": result["std_rvec"].tolist(),
        "std_T": result["std_T"].tolist(),
        "baseline": result["baseline"],
        "baseline_std": result["baseline_std"],
        "spread": sp,
        "epipolar": result["epipolar"],
        "rectified_dy": result["rectified_dy"],
        "rectification": {k: np.asarray(v).tolist() for k, v in result["rectification"].items()},
        "pairs": result["pairs"],
        "rejected": result["rejected"],
        "warnings": list(result.get("warnings", [])),
    }


def rectify_images(
    cal: dict[str, Any], left: np.ndarray, right: np.ndarray, interpolation: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The pair resampled into the rectified frame (rows are epipolar lines), for
    showing with horizontal lines. ``cal``: a stereo result or calibration dict with
    ``cameras`` [left, right] and ``rectification`` (R1 R2 P1 P2; made with
    cv2.stereoRectify when absent)."""
    import cv2

    c1, c2 = cal["cameras"][:2]
    size = tuple(int(v) for v in c1.image_size) if c1.image_size[0] else (left.shape[1], left.shape[0])
    rect = cal.get("rectification") or {}
    if not all(k in rect for k in ("R1", "R2", "P1", "P2")):
        R = c2.rotation @ c1.rotation.T
        T = c2.translation - R @ c1.translation
        R1, R2, P1, P2, *_ = cv2.stereoRectify(
            c1.camera_matrix,
            c1.dist_coeffs,
            c2.camera_matrix,
            c2.dist_coeffs,
            size,
            R,
            T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
        )
        rect = {"R1": R1, "R2": R2, "P1": P1, "P2": P2}
    out = []
    for cam, img, r, p in ((c1, left, rect["R1"], rect["P1"]), (c2, right, rect["R2"], rect["P2"])):
        m1, m2 = cv2.initUndistortRectifyMap(
            cam.camera_matrix, cam.dist_coeffs, np.asarray(r, np.float64), np.asarray(p, np.float64), size, cv2.CV_32FC1
        )
        out.append(cv2.remap(img, m1, m2, cv2.INTER_LINEAR if interpolation is None else interpolation))
    return out[0], out[1]
