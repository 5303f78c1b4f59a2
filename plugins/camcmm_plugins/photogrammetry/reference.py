"""The templeRing reference (Middlebury multi-view stereo, Seitz et al., CVPR 2006): the Stanford
gantry's calibrated cameras, the images in the orientation those cameras describe, and the
comparison of a structure-from-motion result with them. Used by the tests and the benchmark.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Image, InputError, read

from .similarity import circle_radius, rotation_angle_deg, similarity


def read_gantry(folder: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """{name: (K, R, t)} of templeR_par.txt (K in px, t in metres; x_cam = R X + t)."""
    lines = (Path(folder) / "templeR_par.txt").read_text().split("\n")
    out = {}
    for ln in lines[1 : 1 + int(lines[0])]:
        p = ln.split()
        v = np.array([float(x) for x in p[1:]])
        out[p[0]] = (v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:21])
    return out


def read_series(folder: str | Path) -> tuple[list[np.ndarray], list[str]]:
    """The images (RGB, sorted by name) in the orientation their gantry cameras describe.

    The gantry took the positive-latitude views in its other configuration, rotated 180 degrees
    in the image plane (README.txt there), and their R says so; the shared copy holds those
    turned upright like the others (SfM's rotations differ from the gantry's by 180 degrees
    about the optical axis for exactly these views), so they are turned back here.
    """
    import cv2

    folder = Path(folder)
    lat = {}
    for ln in (folder / "templeR_ang.txt").read_text().split("\n"):
        if ln.strip():
            a, _, name = ln.split()
            lat[name] = float(a)
    names = sorted(lat)
    ims = []
    for n in names:
        img = read(folder / n)  # camcmm's one image reader: BGR(A) or grey, capped
        if not isinstance(img, Image):
            raise InputError(f"{folder / n}: not an image")
        raw = np.asarray(img.data)
        if raw.ndim == 2:
            im = cv2.cvtColor(raw, cv2.COLOR_GRAY2RGB)
        else:
            im = cv2.cvtColor(raw, cv2.COLOR_BGRA2RGB if raw.shape[2] == 4 else cv2.COLOR_BGR2RGB)
        ims.append(cv2.rotate(im, cv2.ROTATE_180) if lat[n] > 0 else im)
    return ims, names


def compare(views: list[dict[str, Any]], gantry: dict) -> dict[str, float]:
    """SfM views against the gantry's cameras after the 7-parameter similarity of the centres.

    Returns ``centre_rms_pct`` (centre RMS, % of the ring radius), ``centre_rms_mm``,
    ``ring_radius_mm`` (circle through the gantry's centres), ``max_angle_deg`` and
    ``rms_angle_deg`` (orientation errors).
    """
    names = [v["image"] for v in views]
    c_sfm = np.array([v["centre"] for v in views])
    c_ref = np.array([-gantry[n][1].T @ gantry[n][2] for n in names])
    sim = similarity(c_sfm, c_ref)
    radius = circle_radius(np.array([-R.T @ t for _, R, t in gantry.values()]))
    # x_cam = R_sfm X_sfm + t and X_ref = s Q X_sfm + c  =>  R_ref = R_sfm Q^T
    ang = np.array([rotation_angle_deg(np.asarray(v["R"]) @ sim["R"].T, gantry[v["image"]][1]) for v in views])
    return {
        "centre_rms_pct": 100 * sim["rms"] / radius,
        "centre_rms_mm": 1000 * sim["rms"],
        "ring_radius_mm": 1000 * radius,
        "max_angle_deg": float(ang.max()),
        "rms_angle_deg": float(np.sqrt((ang**2).mean())),
    }
