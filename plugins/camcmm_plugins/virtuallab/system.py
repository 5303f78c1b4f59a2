"""A simulated stereo fringe-projection system that measures an artefact where an
acceptance test places it: the wizard's "Acquire" for a virtual system (issue #9).

One call renders the fringe sequence of the placed artefact through the rig's cameras
(:mod:`.capture`: distortion, defocus, noise, quantisation), decodes and triangulates
it with the fringe plugin (``fringe.reconstruct`` by id: camera-camera phase matching
for ``stereo``, camera-projector for ``projector``), and crops the outline pixels, as
the thesis extracted "the central flat section" (ch. 5.3): a pixel on an artefact's
silhouette or a shadow's edge mixes two surfaces and its depth is off by up to
~0.2 mm. The cloud is returned in camera 1's frame (mm); the systematic errors of the
scene file (``errors``: a miscalibrated baseline, focal length ...) go into the
calibration the reconstruction uses, so their effect shows in the verdict.

``placement`` (what the wizard knows of a position): ``test`` (sphere | ball_bar |
flat), ``position`` ({id, where (fractions of the volume), direction, normal}),
``measuring_volume`` [x, y, z] mm and ``artefacts`` (the plan's, by test).
"""

from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, PointCloud, get_algorithm

DEFAULT_SEQUENCE = {
    "projector": {"width": 1280, "height": 800},
    "bit_depth": 8,
    "frames": [
        "white",
        "black",
        {"type": "phase", "direction": "vertical", "steps": 4, "period": 16},
        {"type": "gray", "direction": "vertical", "period": 8},
    ],
}


def placed_artefact(placement: dict[str, Any]) -> dict[str, Any]:
    """The scene-file artefact for a wizard position (centre = where × volume, mm)."""
    try:
        test = str(placement["test"])
        pos = dict(placement.get("position") or {})
        vol = np.asarray(placement.get("measuring_volume") or [100.0, 100.0, 100.0], float).reshape(3)
        art = dict((placement.get("artefacts") or {}).get(test) or {})
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"placement: expected test, position, measuring_volume and artefacts ({exc})") from None
    centre = (np.asarray(pos.get("where", [0, 0, 0]), float) * vol).tolist()
    if test == "sphere":
        if "diameter" not in art:
            raise InputError("placement: the plan's sphere has no diameter")
        return {"type": "sphere", "center": centre, "diameter": float(art["diameter"]), "stem": False}
    if test == "ball_bar":
        return {
            "type": "ball_bar",
            "center": centre,
            "direction": pos.get("direction", [1, 0, 0]),
            "length": float(art["length"]),
            "sphere_diameter": float(art["sphere_diameter"]),
        }
    if test == "flat":
        return {
            "type": "flat",
            "center": centre,
            "direction": pos.get("direction", [1, 0, 0]),
            "normal": pos.get("normal", [0, 0, 1]),
            "length": float(art["length"]),
            "width": float(art["width"]),
        }
    raise InputError(f"placement: the simulated fringe system measures spheres, ball bars and flats, not {test!r}")


def interior(points: np.ndarray, camera: Any, erode: int = 2) -> np.ndarray:
    """(N,) bool: points whose camera-1 pixel lies ``erode`` px inside the measured
    region (camera-projector and stereo points both reproject onto camera 1)."""
    import cv2

    p, _ = cv2.projectPoints(
        points, cv2.Rodrigues(camera.rotation)[0], camera.translation, camera.camera_matrix, camera.dist_coeffs
    )
    ij = np.rint(p.reshape(-1, 2)).astype(int)
    w, h = camera.image_size
    ok = (ij[:, 0] >= 0) & (ij[:, 0] < w) & (ij[:, 1] >= 0) & (ij[:, 1] < h)
    m = np.zeros((h, w), np.uint8)
    m[ij[ok, 1], ij[ok, 0]] = 1
    m = cv2.erode(m, np.ones((2 * erode + 1, 2 * erode + 1), np.uint8))
    keep = np.zeros(len(points), bool)
    keep[ok] = m[ij[ok, 1], ij[ok, 0]] > 0
    return keep


def measure(
    placement: dict[str, Any],
    preset: str = "stereo_fringe",
    method: str = "stereo",
    image_size=(640, 480),
    seed: int = 0,
    errors: dict[str, Any] | None = None,
    sequence: dict[str, Any] | None = None,
    erode: int = 2,
    ctx=None,
) -> dict[str, Any]:
    """Render, decode, triangulate and crop one placement; ``{"cloud", "n_frames", "truth"}``."""
    import yaml

    from camcmm.api import read_calibration

    from .capture import capture
    from .scene_file import scene_from_dict

    art = placed_artefact(placement)
    # a reproducible, different noise stream per position
    key = f"{placement.get('test')}/{(placement.get('position') or {}).get('id', '')}"
    pos_seed = int(seed) * 1000 + int(hashlib.sha256(key.encode()).hexdigest()[:6], 16) % 1000
    doc = {
        "seed": pos_seed,
        "artefacts": [art],
        "rig": {"preset": preset, "image_size": list(image_size)},
        "sequence": sequence or DEFAULT_SEQUENCE,
        "errors": errors or {},
    }
    with tempfile.TemporaryDirectory(prefix="camcmm-fringe-system-") as tmp:
        d = Path(tmp)
        (d / "scene.yaml").write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
        scene = scene_from_dict(doc, d)
        cap = capture(scene, d / "out", ctx)
        out = d / "out"
        frames = [str(f) for f in sorted((out / "camera1").glob("frame*.png"))]
        frames2 = [str(f) for f in sorted((out / "camera2").glob("frame*.png"))] if method == "stereo" else None
        rec = get_algorithm("fringe.reconstruct")(
            sequence=str(out / "sequence.yaml"),
            images=frames,
            images2=frames2,
            calibration=str(out / "calibration.yaml"),
            method=method,
        )
        cloud = rec["cloud"]
        cam = read_calibration(out / "calibration.yaml")["cameras"][0]
        keep = np.flatnonzero(interior(cloud.points, cam, erode))
        if len(keep) < 100:
            raise InputError(
                f"{key}: the simulated system saw only {len(keep)} points of the artefact; "
                "is it inside the cameras' and projector's common field?"
            )
        cloud = cloud.subset(keep)
        # a position's id names its test already ("sphere-01", "ball-bar-01"): not "sphere-sphere-01"
        name = (placement.get("position") or {}).get("id") or f"{placement.get('test')}-x"
        cloud = PointCloud(cloud.points, name=name)
        return {"cloud": cloud, "n_frames": cap["n_frames"], "n_points": int(len(keep))}
