"""Single-camera calibration (thesis ch. 2.4.2, eq. 2.17): pinhole + radial (k1-k3) and
tangential distortion, optionally thin prism (s1-s4) or the rational model (k4-k6).

:func:`calibrate_camera` runs cv2.calibrateCameraExtended on the views where the board
was found, drops outlier views (per-view RMS above ``outlier_factor`` x the median, the
worst first, recalibrating each time) and adds the parameter covariance from the
Jacobian (see :mod:`.covariance`). Views left out are listed in ``rejected`` with
the image name and the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from camcmm.api import CameraModel, InputError

from .boards import Board, Detection, parse_board, require_found
from .checks import MAX_RMS_PX, camera_warnings
from .covariance import Observation, assemble, covariance, free_intrinsics, parameter_names

MIN_VIEWS = 3


def model_flags(model: str = "standard", flags: int = 0) -> int:
    """OpenCV flags for a distortion model: "standard" (k1 k2 p1 p2 k3), "thin-prism"
    (+ s1-s4), "rational" (+ k4-k6), "rational-thin-prism"; ``flags`` are OR-ed in."""
    import cv2

    extra = {
        "standard": 0,
        "thin-prism": cv2.CALIB_THIN_PRISM_MODEL,
        "rational": cv2.CALIB_RATIONAL_MODEL,
        "rational-thin-prism": cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_THIN_PRISM_MODEL,
    }
    if model not in extra:
        raise InputError(f"distortion model {model!r}: use one of {', '.join(extra)}")
    return int(flags) | extra[model]


def _calibrate(dets: list[Detection], size, flags, K0=None, D0=None):
    import cv2

    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, np.finfo(float).eps)
    obj = [d.object_points for d in dets]
    img = [d.image_points for d in dets]
    rms, K, D, rv, tv, std_i, _std_e, per_view = cv2.calibrateCameraExtended(
        obj, img, size, K0, D0, flags=flags, criteria=crit
    )
    return float(rms), K, D.ravel(), [r.ravel() for r in rv], [t.ravel() for t in tv], std_i.ravel(), per_view.ravel()


def calibrate_camera(
    detections: Sequence[Detection],
    board: Board | str,
    *,
    model: str = "standard",
    flags: int = 0,
    outlier_factor: float = 3.0,
    name: str = "camera",
    progress=None,
    max_rms: float = MAX_RMS_PX,
) -> dict[str, Any]:
    """Calibrate one camera from board detections (see :func:`boards.detect_all`).

    Parameters
    ----------
    detections : sequence of Detection
        One per image; those where the board was not found are listed in ``rejected``.
    board : Board or str
        The board, or its spec (``"charuco:11x8:15:11"``, see :func:`boards.parse_board`).
    model : str, default "standard"
        Distortion model (:func:`model_flags`): which OpenCV coefficients are free.
    flags : int, default 0
        Further OpenCV calibration flags, or-ed with the model's.
    outlier_factor : float, default 3.0
        Views whose RMS exceeds this multiple of the median view RMS are dropped and the
        calibration repeated; <= 0 keeps every view where the board was found.
    name : str, default "camera"
        The CameraModel's name.
    progress : callable(fraction, message), optional
    max_rms : float, default MAX_RMS_PX
        px; an overall RMS above it gives a warning.

    Returns
    -------
    dict
        ``camera`` (CameraModel), ``camera_matrix`` (3, 3) px, ``dist_coeffs`` (n,),
        ``rms`` px, ``std_intrinsics`` (4 + n,) OpenCV's standard deviations of
        (fx fy cx cy dist...), ``covariance`` (4 + n, 4 + n) of the same from the Jacobian,
        ``per_view_rms`` {image: px}, ``image_size`` [w, h] px, ``rejected``
        [{image, reason}], ``views`` {names, rvecs (V, 3) rad, tvecs (V, 3) mm: board ->
        camera}, ``parameter_covariance`` and ``parameter_names`` (intrinsics, then each
        view's pose), ``residual_sigma`` px per coordinate, ``flags``, ``warnings`` (one
        line each: views in the same pose, too few or too little tilt, implausible or
        uncertain intrinsics, RMS above ``max_rms`` px; see :mod:`.checks`).

    Raises
    ------
    InputError
        The board was found in fewer than the minimum number of views.
    """
    board = parse_board(board)
    flags = model_flags(model, flags)
    dets = list(detections)
    require_found(board, dets)
    rejected: list[dict[str, Any]] = [{"image": d.name, "reason": d.reason} for d in dets if not d.found]
    used = [d for d in dets if d.found]
    if len(used) < MIN_VIEWS:
        raise InputError(
            f"board {board.spec} found in only {len(used)} image(s) "
            f"({', '.join(d.name for d in used)}); calibration needs at least {MIN_VIEWS} views"
        )
    size = used[0].image_size
    while True:
        if progress is not None:
            progress(0.5, f"calibrating on {len(used)} views")
        rms, K, D, rvecs, tvecs, std_i, per_view = _calibrate(used, size, flags)
        med = float(np.median(per_view))
        worst = int(np.argmax(per_view))
        if outlier_factor <= 0 or len(used) <= MIN_VIEWS or per_view[worst] <= outlier_factor * med:
            break
        rejected.append(
            {
                "image": used[worst].name,
                "reason": f"outlier: view RMS {per_view[worst]:.3g} px > {outlier_factor:g} x median {med:.3g} px",
                "rms": float(per_view[worst]),
            }
        )
        used.pop(worst)
    cam = CameraModel(K, D, image_size=size, name=name)
    obs = [Observation(v, 0, d.object_points, d.image_points) for v, d in enumerate(used)]
    free = free_intrinsics(flags, D.size)
    import cv2

    aspect = [K[0, 0] / K[1, 1]] if flags & cv2.CALIB_FIX_ASPECT_RATIO else None
    jtj, _, sse, rows, layout = assemble([(K, D)], [], list(zip(rvecs, tvecs)), obs, [free], aspect)
    cov, sigma = covariance(jtj, sse, rows)
    ii = layout["intrinsics"][0]
    if aspect is not None:  # fx = a fy: its variance follows fy's
        a = aspect[0]
        cov[ii[0], :] = a * cov[ii[1], :]
        cov[:, ii[0]] = a * cov[:, ii[1]]
    names = [d.name for d in used]
    out = {
        "camera": cam,
        "camera_matrix": K,
        "dist_coeffs": D,
        "rms": rms,
        "std_intrinsics": std_i[: 4 + D.size],
        "covariance": cov[np.ix_(ii, ii)],
        "per_view_rms": {n: float(e) for n, e in zip(names, per_view)},
        "image_size": [int(size[0]), int(size[1])],
        "rejected": rejected,
        "views": {"names": names, "rvecs": np.array(rvecs), "tvecs": np.array(tvecs)},
        "parameter_covariance": cov,
        "parameter_names": parameter_names([name], [D.size], len(used)),
        "residual_sigma": sigma,
        "flags": int(flags),
        "board": board.spec,
        "n_points": int(sum(len(d.ids) for d in used)),
    }
    out["warnings"] = camera_warnings(out, max_rms)
    return out


def calibration_dict(result: dict[str, Any]) -> dict[str, Any]:
    """The calibration file dict (camcmm.api.write_calibration) of a camera result."""
    keep = (
        "rms",
        "per_view_rms",
        "rejected",
        "views",
        "parameter_covariance",
        "parameter_names",
        "residual_sigma",
        "flags",
        "board",
    )
    out = {
        "cameras": [result["camera"]],
        "std_intrinsics": [result["std_intrinsics"]],
        "covariance": [result["covariance"]],
    }
    out.update({k: result[k] for k in keep if k in result})
    return out


def board_distance(result: dict[str, Any]) -> float | None:
    """The median depth (mm, along the optical axis) of the board over the views a
    calibration used: where it was made, so where its uncertainty is first worth
    looking at. None when the result holds no board poses."""
    try:
        z = np.asarray(result["views"]["tvecs"], float).reshape(-1, 3)[:, 2]
        d = float(np.median(z))
    except (KeyError, TypeError, ValueError, IndexError):
        return None
    return d if np.isfinite(d) and d > 0 else None


def camera_json(result: dict[str, Any]) -> dict[str, Any]:
    """The CLI's JSON for one camera: camera_matrix, dist_coeffs, rms, std_intrinsics,
    per_view_rms, image_size, rejected, warnings (+ std_named, residual_sigma, views used)."""
    from .covariance import intrinsic_names

    names = intrinsic_names(result["dist_coeffs"].size)
    return {
        "camera_matrix": np.asarray(result["camera_matrix"]).tolist(),
        "dist_coeffs": np.asarray(result["dist_coeffs"]).tolist(),
        "rms": result["rms"],
        "std_intrinsics": np.asarray(result["std_intrinsics"]).tolist(),
        "per_view_rms": result["per_view_rms"],
        "image_size": result["image_size"],
        "rejected": result["rejected"],
        "std_named": dict(zip(names, np.asarray(result["std_intrinsics"]).tolist())),
        "residual_sigma": result["residual_sigma"],
        "n_views": len(result["per_view_rms"]),
        "board_distance": board_distance(result),
        "warnings": list(result.get("warnings", [])),
    }
