"""The Calibration page's tables, from the outputs of the camera- and stereo-calibration
plugins (see ``camcmm_plugins.calibration``), as JSON-able rows: formatting and
bookkeeping only, every number is the plugin's. Numbers follow the one number rule
(:mod:`camcmm.numbers`): a value to the decimal of its standard deviation's second
significant digit, the deviation with two (GUM, JCGM 100:2008 §7.2.6); no exponents; a
real minus; uncertainties of lengths below 1 mm in µm.

One camera's outputs hold ``camera_matrix``, ``dist_coeffs``, ``rms``, ``std_named``,
``per_view_rms`` {image: px}, ``rejected`` [{image, reason[, rms]}], ``detections`` and
``calibration`` (with the board poses and covariance). A pair's outputs hold the same
per camera under ``left``/``right``, the detections under ``detections.left/right``,
each camera's own calibration under ``single`` and the pairs left out under
``rejected`` [{left, right, reason[, rms]}].
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .... import numbers
from ....tasks.calibration import camera_part, default_distance, side_title, sides

__all__ = [
    "camera_part", "default_distance", "fmt", "number_rows", "side_title", "sides", "stereo_rows", "summary",
    "used_corners", "used_pairs", "view_rows", "views_csv_rows", "with_std",
]  # fmt: skip


def view_rows(cam: dict[str, Any]) -> list[dict[str, Any]]:
    """Per image, in the order given: status (used / left out / not found), the
    reason, and the view's RMS reprojection error in px (also for an outlier, the RMS
    it had when it was left out)."""
    per_view = cam.get("per_view_rms") or {}
    single = {r.get("image"): r for r in cam.get("rejected") or []}
    pairs = cam.get("pair_rejected") or {}
    rows = []
    for d in cam.get("detections") or []:
        name = d.get("image")
        row = {"name": name, "status": "used", "reason": "", "rms": None, "n": len(d.get("corners") or [])}
        if not d.get("found"):
            row.update(status="not found", reason=d.get("reason") or "board not found")
        elif name in per_view:
            row["rms"] = float(per_view[name])
        elif name in single:
            row.update(status="left out", reason=single[name].get("reason", ""), rms=single[name].get("rms"))
        elif name in pairs:
            row.update(status="left out", reason=pairs[name]["reason"], rms=pairs[name]["rms"])
        else:
            row.update(status="left out", reason="not used by the calibration")
        rows.append(row)
    return rows


def fmt(x: Any, digits: int = 3) -> str:
    """A number without an uncertainty (px, a ratio): ``digits`` significant digits,
    fixed-point; "—" when there is none."""
    if x is None or not numbers.finite(x):
        return "—"
    return numbers.plain(x, digits)


def with_std(v: Any, u: Any, digits: int = 6) -> tuple[str, str]:
    """(value, standard deviation) as text: the deviation with two significant digits and
    the value to its last decimal (``-0.000112674, 0.000139`` -> ``("−0.00011",
    "0.00014")``); without a deviation the value with ``digits`` significant digits."""
    if not numbers.finite(v):
        return "—", ""
    if not (numbers.finite(u) and float(u) > 0):
        return numbers.significant(v, digits), ""
    decimals = 1 - math.floor(math.log10(float(u)))  # the decimal of u's second digit
    mag = math.floor(math.log10(abs(float(v)))) if float(v) else -decimals - 1
    shown = mag + 1 + decimals  # significant digits of the value down to that decimal
    if shown < 1:  # the value is below the deviation's resolution
        rounded = round(float(v), decimals)
        return ("0" if rounded == 0 else numbers.plain(rounded, 1)), numbers.plain(u, 2)
    return numbers.plain(v, shown), numbers.plain(u, 2)


def _row(name: str, v: Any, u: Any = None, unit: str = "", digits: int = 6) -> dict[str, str]:
    value, std = with_std(v, u, digits)
    return {"name": name, "value": value, "std": std, "unit": unit, "std_unit": unit}


def number_rows(cam: dict[str, Any]) -> list[dict[str, str]]:
    """fx fy cx cy and the distortion coefficients with OpenCV's standard deviations
    (from the Jacobian of the calibration), then the RMS reprojection error."""
    K = np.asarray(cam.get("camera_matrix") or np.eye(3), float)
    D = np.asarray(cam.get("dist_coeffs") or [], float).ravel()
    values = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *D]
    std = cam.get("std_named") or {}
    names = list(std) if len(std) == len(values) else (["fx", "fy", "cx", "cy"] + [f"d{i}" for i in range(D.size)])
    rows = [_row(n, v, std.get(n), "px" if i < 4 else "") for i, (n, v) in enumerate(zip(names, values))]
    rows.append(_row("RMS", cam.get("rms"), unit="px", digits=3))
    return rows


def stereo_rows(outputs: dict[str, Any]) -> list[dict[str, str]]:
    """The right camera's pose in the left (x_r = R x_l + T) with standard deviations,
    the baseline, and the epipolar error statistics, as the stereo plugin gives them
    (rotation as its Rodrigues vector, shown in degrees)."""
    nan3 = [math.nan] * 3
    rvec = np.degrees(np.asarray(outputs.get("rvec") or nan3, float))
    srv = np.degrees(np.asarray(outputs.get("std_rvec") or nan3, float))
    T = np.asarray(outputs.get("T") or nan3, float)
    sT = np.asarray(outputs.get("std_T") or nan3, float)
    angle = outputs.get("rotation_angle")
    rows = [_row(f"rotation r{a} (Rodrigues)", v, s, "°", 5) for a, v, s in zip("xyz", rvec, srv)]
    rows.append(_row("rotation angle", None if angle is None else math.degrees(angle), None, "°", 5))
    rows += [_length_row(f"T{a}", v, s) for a, v, s in zip("xyz", T, sT)]
    rows.append(_length_row("baseline |T|", outputs.get("baseline"), outputs.get("baseline_std")))
    rows.append(_row("stereo RMS", outputs.get("rms"), unit="px", digits=3))
    ep = outputs.get("epipolar") or {}
    for k in ("rms", "mean", "median", "max"):
        rows.append(_row(f"epipolar distance {k}", ep.get(k), unit="px", digits=3))
    dy = outputs.get("rectified_dy") or {}
    for k in ("rms", "max"):
        rows.append(_row(f"rectified row difference {k}", dy.get(k), unit="px", digits=3))
    return rows


def _length_row(name: str, v_mm: Any, u_mm: Any) -> dict[str, str]:
    """A length (mm) to the decimals its standard deviation resolves; the deviation in µm
    below 1 mm (the number rule)."""
    if not numbers.finite(v_mm):
        return {"name": name, "value": "—", "std": "", "unit": "mm", "std_unit": ""}
    value = numbers.length(v_mm, u_mm).removesuffix(" mm")
    std, std_unit = numbers.uncertainty_parts(u_mm) if numbers.finite(u_mm) else ("", "")
    return {"name": name, "value": value, "std": std, "unit": "mm", "std_unit": std_unit}


def used_pairs(outputs: dict[str, Any]) -> list[dict[str, Any]]:
    """The pairs the stereo calibration used, as options for the rectified view."""
    return [{"title": f"{p[0]} / {p[1]}", "value": i} for i, p in enumerate(outputs.get("pairs") or [])]


def used_corners(cam: dict[str, Any]) -> np.ndarray:
    """(N, 2) px: the corners of every view the calibration used (its coverage)."""
    used = set((cam.get("per_view_rms") or {}).keys())
    pts = [
        np.asarray(d["corners"], float).reshape(-1, 2)
        for d in cam.get("detections") or []
        if d.get("found") and d.get("image") in used and d.get("corners")
    ]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def summary(outputs: dict[str, Any], mode: str) -> dict[str, Any]:
    """The one-line facts above the results."""
    out = {"mode": mode, "rms": fmt(outputs.get("rms"), 3)}
    if mode == "stereo":
        n = len((outputs.get("detections") or {}).get("left") or [])
        out["views"] = f"{len(outputs.get('pairs') or [])} of {n} pairs"
        out["image_size"] = " × ".join(str(v) for v in (outputs.get("left") or {}).get("image_size") or [])
        b, u = outputs.get("baseline"), outputs.get("baseline_std")
        out["baseline"] = numbers.measured(b, u) if numbers.finite(u) else numbers.length(b)
    else:
        out["views"] = f"{len(outputs.get('per_view_rms') or {})} of {len(outputs.get('detections') or [])} images"
        out["image_size"] = " × ".join(str(v) for v in outputs.get("image_size") or [])
        out["baseline"] = ""
    return out


def views_csv_rows(outputs: dict[str, Any], mode: str) -> list[list[Any]]:
    """camera, image, status, RMS (px), corners, reason: every image of every camera."""
    rows = []
    for side in sides(mode):
        for r in view_rows(camera_part(outputs, mode, side)):
            rows.append([side_title(mode, side), r["name"], r["status"], r["rms"], r["n"], r["reason"]])
    return rows
