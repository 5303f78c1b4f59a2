"""The turntable prior: the table angle of each image, used to choose the image pairs to
match and to check the reconstructed cameras afterwards.

In a turntable series the object turns by known angles θ_i under a fixed camera (thesis
ch. 4.2, fig. 4.1). In the object's frame, which is the reconstruction's, that is the
camera moving on a circle about the table's axis a: with x_cam = R_i X + t_i,
R_i = R_c A(θ_i) for one fixed R_c, A(θ) the rotation by θ about a, so
R_i^T R_j = A(θ_j - θ_i) and the centres C_i = -R_i^T t_i turn by -θ_i about the axis.

* :func:`parse_angles` reads the prior (a list in input order, ``step:D``, or nothing);
* :func:`angle_pairs` keeps the pairs whose table angles differ by at most a window (views
  farther apart rarely share SIFT matches; exhaustive matching tries them all);
* :func:`check_turntable` fits the axis (from the relative rotations) and the circle of the
  centres, measures each view's angle about the axis both ways, removes the common offset
  and compares with the prior: a view off by more than a tolerance is named in a warning —
  typically a mis-registered view of a symmetric object, or a wrong prior.

Angles in degrees.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

#: image pairs whose table angles differ by more than this (deg) are not matched by default.
#: Measured on a virtual-lab series (30 views through 180 deg, docs/photogrammetry.md): pairs
#: up to ~90 deg apart still pass verification (the top of the object is seen from every
#: side) and strengthen the geometry — a 60 deg window lost them and raised the camera-centre
#: error from 0.81 % to 1.25 % of the ring radius; 90 deg kept 0.82 % with 24 % fewer pairs
DEFAULT_WINDOW = 90.0
#: a view whose angle about the fitted axis deviates more (deg) from its prior is named
DEFAULT_TOLERANCE = 2.0


def _wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles (deg) wrapped to [-180, 180)."""
    return (np.asarray(a, dtype=np.float64) + 180.0) % 360.0 - 180.0


def parse_angles(value: Any, n: int) -> np.ndarray | None:
    """The table angle (deg) of each of ``n`` images, or None for no prior.

    Parameters
    ----------
    value : None or "" (no prior); ``"step:D"`` (image i at i·D deg); a sequence of n numbers
        in input order; or its text form ``"0, 12, 24"`` / ``"[0, 12, 24]"`` (commas or spaces).
    n : number of images in the series.

    Returns
    -------
    (n,) float array in degrees, or None. Raises InputError (one line naming the value) for
    anything else.
    """
    if value is None or (isinstance(value, str) and value.strip().lower() in ("", "none")):
        return None
    if isinstance(value, str):
        text = value.strip()
        if text.lower().startswith("step:"):
            step = text[5:].strip()
            try:
                d = float(step)
            except ValueError:
                raise InputError(f"turntable_angles {text!r}: step {step!r} is not a number (deg)") from None
            if not np.isfinite(d) or d == 0:
                raise InputError(f"turntable_angles {text!r}: the step must be a finite non-zero angle (deg)")
            return d * np.arange(n, dtype=np.float64)
        items: Sequence[Any] = [t for t in re.split(r"[\s,;]+", text.strip("[]() ")) if t]
    elif isinstance(value, (list, tuple, np.ndarray)):
        items = list(np.asarray(value, dtype=object).ravel())
    else:
        raise InputError(f"turntable_angles {value!r}: give DEG,DEG,... or step:D")
    out = []
    for t in items:
        try:
            x = float(t)
        except (TypeError, ValueError):
            x = float("nan")
        if isinstance(t, bool) or not np.isfinite(x):
            raise InputError(f"turntable_angles: {t!r} is not a finite angle (deg)")
        out.append(x)
    if len(out) != n:
        shown = value if isinstance(value, str) else ", ".join(f"{x:g}" for x in out)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise InputError(f"turntable_angles {shown!r}: {len(out)} angles for {n} images (one per image)")
    return np.asarray(out, dtype=np.float64)


def angle_pairs(angles: np.ndarray, window: float = DEFAULT_WINDOW) -> list[tuple[int, int]]:
    """Index pairs (i < j) whose table angles differ by at most ``window`` deg (modulo 360:
    a full ring closes). ``window`` <= 0 or >= 180 keeps every pair."""
    a = np.asarray(angles, dtype=np.float64)
    n = len(a)
    if window <= 0 or window >= 180:
        return [(i, j) for i in range(n) for j in range(i + 1, n)]
    d = np.abs(_wrap(a[:, None] - a[None, :]))
    return [(i, j) for i in range(n) for j in range(i + 1, n) if d[i, j] <= window + 1e-9]


def write_pair_list(path: Path, files: Sequence[str], pairs: Sequence[tuple[int, int]]) -> Path:
    """COLMAP's match list (one ``name1 name2`` line per pair) for ``pycolmap.match_image_pairs``.
    COLMAP splits the line at blanks, so a file name with one is refused here."""
    blank = [f for f in files if re.search(r"\s", f)]
    if blank:
        raise InputError(f"turntable prior: image names with blanks cannot be paired ({blank[0]!r}); rename them")
    Path(path).write_text("".join(f"{files[i]} {files[j]}\n" for i, j in pairs), encoding="utf-8")
    return Path(path)


def _twist_deg(r: np.ndarray, axis: np.ndarray) -> float:
    """Signed angle (deg) of the part of rotation ``r`` about ``axis`` (swing-twist split of
    its quaternion): exact for a rotation about the axis, robust to a small swing."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(r).as_quat()
    return float(np.degrees(2.0 * np.arctan2(np.dot([x, y, z], axis), w)))


def _axis_from_rotations(rs: np.ndarray) -> np.ndarray:
    """Unit axis common to all relative rotations R_i^T R_j: the principal eigenvector of
    Σ v vᵀ over their rotation vectors v (sign-free; larger turns weigh more)."""
    from scipy.spatial.transform import Rotation

    s = np.zeros((3, 3))
    for i in range(len(rs)):
        for j in range(i + 1, len(rs)):
            v = Rotation.from_matrix(rs[i].T @ rs[j]).as_rotvec()
            s += np.outer(v, v)
    w, u = np.linalg.eigh(s)
    return u[:, -1]


def _offset_removed(measured: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """Deviations measured - prior (deg) after removing their common offset: the median of
    the wrapped differences, so one wrong view does not shift the others."""
    d = _wrap(measured - prior)
    ref = np.degrees(np.angle(np.exp(1j * np.radians(d)).mean()))
    c = ref + np.median(_wrap(d - ref))
    return _wrap(d - c)


def check_turntable(
    views: Sequence[dict[str, Any]],
    prior: dict[str, float],
    tolerance: float = DEFAULT_TOLERANCE,
) -> tuple[dict[str, Any], list[str]]:
    """Compare the registered cameras with the table angles of the prior.

    Parameters
    ----------
    views : [{image, R (3, 3), centre (3,)}] with x_cam = R X + t (any frame and scale).
    prior : {image name: table angle (deg)}; views without an angle are left out.
    tolerance : largest deviation (deg) of a view's angle before it is named in a warning.

    Returns
    -------
    (report, warnings). ``report``: ``axis`` (unit, reconstruction frame, oriented so the
    table turns by +θ about it), ``axis_point`` and ``radius`` (the centres' circle, the
    reconstruction's units), ``axis_tilt_deg`` (rotation axis vs the circle's normal),
    ``angle_rms_deg`` / ``angle_max_deg`` (angles from the rotations), ``centre_angle_rms_deg``
    / ``centre_angle_max_deg`` (angles of the centres on the circle), ``tolerance_deg``,
    ``views`` [{image, prior_deg, measured_deg, deviation_deg, centre_deviation_deg}].
    Fewer than 3 views with angles: ``{}`` and a warning.
    """
    vs = [v for v in views if v["image"] in prior]
    if len(vs) < 3:
        return {}, [f"turntable prior: {len(vs)} registered view(s) with an angle; the check needs 3"]
    rs = np.array([np.asarray(v["R"], dtype=np.float64) for v in vs])
    cs = np.array([np.asarray(v["centre"], dtype=np.float64) for v in vs])
    theta = np.array([float(prior[v["image"]]) for v in vs])
    axis = _axis_from_rotations(rs)
    psi = np.array([_twist_deg(rs[0].T @ r, axis) for r in rs])
    # the axis's sign: the one about which the cameras turn as the prior says (+θ)
    if np.abs(_offset_removed(-psi, theta)).sum() < np.abs(_offset_removed(psi, theta)).sum():
        axis, psi = -axis, -psi
    dev = _offset_removed(psi, theta)
    # the centres' circle in the plane normal to the axis (Kåsa 1976: algebraic, exact on a circle)
    e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    xy = np.column_stack([cs @ e1, cs @ e2])
    sol, *_ = np.linalg.lstsq(np.column_stack([2 * xy, np.ones(len(xy))]), (xy**2).sum(1), rcond=None)
    radius = float(np.sqrt(max(sol[2] + sol[0] ** 2 + sol[1] ** 2, 0.0)))
    phi = np.degrees(np.arctan2(xy[:, 1] - sol[1], xy[:, 0] - sol[0]))
    cdev = _offset_removed(-phi, theta)  # the centres turn by -θ about the axis
    p = cs - cs.mean(0)
    normal = np.linalg.svd(p)[2][2]
    tilt = float(np.degrees(np.arccos(min(1.0, abs(float(normal @ axis))))))
    point = sol[0] * e1 + sol[1] * e2 + float(np.mean(cs @ axis)) * axis
    rows = [
        {
            "image": v["image"],
            "prior_deg": float(t),
            "measured_deg": float(t + d),
            "deviation_deg": float(d),
            "centre_deviation_deg": float(cd),
        }
        for v, t, d, cd in zip(vs, theta, dev, cdev, strict=True)
    ]
    report = {
        "axis": axis.tolist(),
        "axis_point": point.tolist(),
        "radius": radius,
        "axis_tilt_deg": tilt,
        "angle_rms_deg": float(np.sqrt(np.mean(dev**2))),
        "angle_max_deg": float(np.abs(dev).max()),
        "centre_angle_rms_deg": float(np.sqrt(np.mean(cdev**2))),
        "centre_angle_max_deg": float(np.abs(cdev).max()),
        "tolerance_deg": float(tolerance),
        "n_views": len(vs),
        "views": rows,
    }
    off = [r for r in rows if max(abs(r["deviation_deg"]), abs(r["centre_deviation_deg"])) > tolerance]
    warnings = []
    if off:
        listed = ", ".join(
            f"{r['image']} ({max(r['deviation_deg'], r['centre_deviation_deg'], key=abs):+.1f} deg)" for r in off[:6]
        )
        warnings.append(
            f"turntable prior: {len(off)} view(s) off their table angle by more than {tolerance:g} deg: "
            f"{listed}{' ...' if len(off) > 6 else ''}; mis-registered (a symmetric object?) or a wrong angle"
        )
    return report, warnings
