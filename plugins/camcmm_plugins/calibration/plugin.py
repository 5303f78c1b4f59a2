"""Plugin entry points (``fn(ctx, **inputs, **params) -> dict``) for the host.

Outputs are JSON-able; ``calibration`` is the calibration in the layout of camcmm's
JSON calibration file (cameras as mappings). ``save`` (a .yaml/.yml/.xml/.json path)
also writes it with camcmm.api.write_calibration. Parameters are keyword-only and
without defaults: plugin.yaml holds each default once, and the host passes every
declared parameter validated.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import (
    CameraModel,
    Image,
    InputError,
    RunContext,
    check_calibration,
    read_calibration,
    write_calibration,
)


def cal_json(cal: Mapping[str, Any]) -> dict[str, Any]:
    """A calibration dict with its CameraModels as mappings and arrays as lists."""

    def conv(v):
        if isinstance(v, CameraModel):
            return {
                "name": v.name,
                "camera_matrix": v.camera_matrix.tolist(),
                "dist_coeffs": v.dist_coeffs.tolist(),
                "rotation": v.rotation.tolist(),
                "translation": v.translation.tolist(),
                "image_size": list(v.image_size),
                "pixel_pitch": v.pixel_pitch,
            }
        if isinstance(v, np.ndarray):
            return v.tolist()
        if isinstance(v, Mapping):
            return {str(k): conv(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        if isinstance(v, np.generic):
            return v.item()
        return v

    return conv(dict(cal))


def load_calibration(value: Any) -> dict[str, Any]:
    """A calibration from a file path, a calibration dict or a calibration result."""
    if isinstance(value, (str, Path)):
        return read_calibration(value)
    if isinstance(value, Mapping):
        d = dict(value)
        if "cameras" in d and d["cameras"] and isinstance(d["cameras"][0], Mapping):
            d["cameras"] = [
                CameraModel(
                    c["camera_matrix"],
                    c.get("dist_coeffs", np.zeros(5)),
                    c.get("rotation", np.eye(3)),
                    c.get("translation", np.zeros(3)),
                    tuple(c.get("image_size", (0, 0))),
                    c.get("pixel_pitch"),
                    c.get("name", "camera"),
                )
                for c in d["cameras"]
            ]
        if "camera" in d and "cameras" not in d:
            from .camera import calibration_dict

            d = calibration_dict(d)
        return check_calibration(d, "calibration") if d.get("cameras") else d
    raise InputError(f"calibration: expected a file path or a mapping, got {type(value).__name__}")


def _write(path: str, cal: dict[str, Any]) -> str | None:
    if path:
        write_calibration(path, cal)
        return str(path)
    return None


def camera(
    ctx: RunContext,
    images,
    *,
    board: str,
    model: str,
    detector: str,
    subpix_window: int,
    outlier_factor: float,
    save: str,
    max_rms: float,
) -> dict[str, Any]:
    from .boards import detect_all
    from .camera import calibrate_camera, calibration_dict, camera_json

    dets = detect_all(
        board, images, detector=detector, subpix_window=subpix_window, progress=lambda f, m: ctx.progress(0.6 * f, m)
    )
    res = calibrate_camera(
        dets,
        board,
        model=model,
        outlier_factor=outlier_factor,
        max_rms=max_rms,
        progress=lambda f, m: ctx.progress(0.6 + 0.4 * f, m),
    )
    for r in res["rejected"]:
        ctx.warn(f"{r['image']} left out: {r['reason']}")
    for w in res["warnings"]:
        ctx.warn(w)
    cal = calibration_dict(res)
    written = _write(save, cal)
    return {
        **camera_json(res),
        "detections": [d.to_dict() for d in dets],
        "calibration": cal_json(cal),
        "written": written,
    }


def stereo(
    ctx: RunContext,
    left,
    right,
    *,
    board: str,
    model: str,
    detector: str,
    subpix_window: int,
    outlier_factor: float,
    fix_intrinsics: bool,
    alpha: float,
    save: str,
    max_rms: float,
) -> dict[str, Any]:
    from .boards import detect_all
    from .camera import calibration_dict as camera_dict
    from .stereo import calibrate_stereo, calibration_dict, stereo_json

    dl = detect_all(
        board, left, detector=detector, subpix_window=subpix_window, progress=lambda f, m: ctx.progress(0.3 * f, m)
    )
    dr = detect_all(
        board,
        right,
        detector=detector,
        subpix_window=subpix_window,
        progress=lambda f, m: ctx.progress(0.3 + 0.3 * f, m),
    )
    res = calibrate_stereo(
        dl,
        dr,
        board,
        model=model,
        outlier_factor=outlier_factor,
        fix_intrinsics=fix_intrinsics,
        alpha=alpha,
        max_rms=max_rms,
        progress=lambda f, m: ctx.progress(0.6 + 0.4 * f, m),
    )
    for r in res["rejected"]:
        ctx.warn(f"pair {r['left']} / {r['right']} left out: {r['reason']}")
    for w in res["warnings"]:
        ctx.warn(w)
    cal = calibration_dict(res)
    written = _write(save, cal)
    # each camera's own calibration keeps its board poses and their covariance, which the
    # projection-uncertainty map needs (the joint stereo covariance has no board poses)
    single = {k: cal_json(camera_dict(res["single"][k])) for k in ("left", "right")}
    return {
        **stereo_json(res),
        "detections": {"left": [d.to_dict() for d in dl], "right": [d.to_dict() for d in dr]},
        "calibration": cal_json(cal),
        "single": single,
        "written": written,
    }


def rectify(ctx: RunContext, calibration, left, right) -> dict[str, Any]:
    from .stereo import rectify_images

    cal = load_calibration(calibration)
    cams = cal.get("cameras") or []
    if len(cams) < 2:
        raise InputError(f"rectification needs a stereo calibration (two cameras), got {len(cams)} camera(s)")
    size = tuple(int(v) for v in cams[0].image_size)
    for img, cam in ((left, cams[0]), (right, cams[1])):
        w, h = img.size
        if cam.image_size[0] and (w, h) != tuple(cam.image_size):
            raise InputError(
                f"{img.name}: {w}x{h} px, but camera {cam.name!r} was calibrated at "
                f"{cam.image_size[0]}x{cam.image_size[1]} px"
            )
    rl, rr = rectify_images(cal, np.asarray(left.data), np.asarray(right.data))
    return {
        "left": Image(rl, name=f"{left.name} (rectified)"),
        "right": Image(rr, name=f"{right.name} (rectified)"),
        "image_size": list(size),
    }


def board_check(ctx: RunContext, image, *, board: str, detector: str) -> dict[str, Any]:
    """The board found (or not) in one image, as :func:`camera` finds it, with the count
    of its points: what a person checks before calibrating (is COLSxROWS right?)."""
    from .boards import board_points, detect, grey, parse_board

    b = parse_board(board)
    det = detect(b, image.name, grey(image.data), detector=detector)
    expected, points = board_points(b)
    if not det.found:  # an answer, not a failure: the page says what to check
        ctx.warn(f"{image.name}: {det.reason}")
    return {
        "found": det.found,
        "count": int(len(det.image_points)),
        "expected": expected,
        "points": points,
        "reason": det.reason,
        "corners": det.image_points.tolist(),
        "image_size": list(det.image_size),
    }


def projection_uncertainty(
    ctx: RunContext, calibration, *, distance: float, columns: int, rows: int, method: str
) -> dict[str, Any]:
    from .projection import projection_uncertainty as pu

    out = pu(load_calibration(calibration), distance, grid=(columns, rows), method=method)
    return {k: out[k] for k in ("map", "u", "v", "distance", "min", "max", "centre", "unit", "method")}


def _pixels(value: Any) -> np.ndarray:
    if isinstance(value, (str, Path)):
        p = Path(value)
        if not p.is_file():
            raise InputError(f"{p.name}: file not found ({p})")
        if p.suffix.lower() == ".npy":
            return np.load(p)
        import json

        try:
            doc = json.loads(p.read_text())
        except ValueError as exc:
            raise InputError(f"{p.name}: not valid JSON ({exc})") from None
        value = doc.get("pixels", doc) if isinstance(doc, dict) else doc
    elif isinstance(value, Mapping):
        value = value.get("pixels")
    try:
        return np.asarray(value, np.float64)
    except (TypeError, ValueError):
        raise InputError("pixels: expected a (cameras, points, 2) array of numbers") from None


def triangulate(
    ctx: RunContext, calibration, pixels, *, method: str, pixel_sigma: float, calibration_covariance: bool
) -> dict[str, Any]:
    from .triangulation import triangulate as tri

    cal = load_calibration(calibration)
    cov = None
    if calibration_covariance and cal.get("parameter_covariance") is not None:
        names = cal.get("parameter_names") or []
        if any(n.startswith("view") for n in names):
            ctx.warn("the calibration's covariance holds board poses (a single camera): not used")
        else:
            cov = np.asarray(cal["parameter_covariance"], np.float64)
    res = tri(cal["cameras"], _pixels(pixels), method=method, pixel_sigma=pixel_sigma or None, parameter_covariance=cov)
    return res


def scale(
    ctx: RunContext | None, interferometer, calibration=None, *, accuracy: float, length: float | None, save: str
) -> dict[str, Any]:
    from .scale import apply_scale, read_interferometer_csv, scale_factor

    data = read_interferometer_csv(interferometer)
    res = scale_factor(
        data["interferometer"], data["camera"], data["run"], accuracy=accuracy, length=length, source=data["file"]
    )
    res["file"] = data["file"]
    if calibration is not None:
        scaled = apply_scale(load_calibration(calibration), res["scale_factor"])
        res["written"] = _write(save, scaled)
        res["baseline"] = scaled.get("baseline")
    elif save:
        raise InputError("save: give the calibration to scale as well")
    return res


def gauge_block(
    ctx: RunContext | None, cloud, *, nominal: float, ransac_threshold: float | None, up: list | None
) -> dict[str, Any]:
    from .gauge import gauge_block as gb

    res = gb(cloud.points, nominal, up=up, ransac_threshold=ransac_threshold)
    res["n_points"] = int(len(res["labels"]))
    res["cloud"] = cloud.name
    return res
