"""Cameras and projector of a virtual measuring system: from a scene file's entries or
a named preset around the measuring volume.

World frame: the measuring volume's, origin at its centre, +z towards the sensor, +y
to the back (shown at the top of the images). Lengths in mm, angles in degrees.

Presets (all entries can be overridden in the scene file's ``rig``):

* ``stereo_fringe`` — the stereo fringe-projection system of thesis ch. 3.3.1 / 5: two
  cameras 199.35 mm apart whose optical axes meet at 301 mm (38.64° apart), 16.74 and
  16.66 mm lenses with the thesis's radial distortion (k1, k2 = -0.135, 0.24 and
  -0.13, 0.17), a sensor 7.44 mm wide (the thesis's 4024 x 1.85 µm) at any pixel count,
  f/8 focused at 301 mm; a projector (1280 x 800 px) midway between them at 301 mm
  from the volume centre, its image 1.2 x the cameras' field.
* ``camera_projector`` — one camera (the first of the above) and the projector
  (classic fringe projection).

A device entry (camera or projector)::

    name: camera1
    image_size: [1280, 960]                  # px (width, height)
    focal_length: 16.74                      # mm, with pixel_pitch (mm) ...
    pixel_pitch: 0.0058125
    camera_matrix: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]   # ... or K directly (px)
    principal_point: [639.5, 479.5]          # px, default the image centre
    dist_coeffs: [k1, k2, p1, p2, k3]        # OpenCV order, 4 to 12 terms
    position: [-99.7, 0, 284.0]              # projection centre (mm) ...
    look_at: [0, 0, 0]                       # ... the point on the optical axis
    up: [0, 1, 0]                            # world direction shown upwards
    rotation: [[...]]                        # or R, t (x_cam = R x_world + t)
    translation: [...]
    f_number: 8                              # defocus (None: pinhole); a projector's blurs its pattern
    focus_distance: 301                      # mm along the optical axis
    psf: gaussian                            # or disc
    blur: 0.0                                # extra Gaussian sigma (px)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import CameraModel

from . import optics
from .imaging import Lens
from .sensor import BASELINE, CONVERGENCE

#: Thesis ch. 3.3.1: 4024 px of 1.85 µm; the virtual cameras keep the sensor width.
SENSOR_WIDTH = 4024 * 0.00185
THESIS_LENSES = [(16.74, [-0.135, 0.24, 0.0, 0.0, 0.0]), (16.66, [-0.13, 0.17, 0.0, 0.0, 0.0])]
ANGLE = 38.64


@dataclass
class Device:
    """A camera or projector: its model (the truth) and its lens's depth of field."""

    model: CameraModel
    lens: Lens = field(default_factory=Lens)

    @property
    def name(self) -> str:
        return self.model.name


def _vec(v, n: int, what: str) -> np.ndarray:
    a = np.asarray(v, float).ravel()
    if a.size != n or not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: expected {n} finite numbers, got {v!r}")
    return a


def device_from_dict(d: Mapping[str, Any], default_name: str) -> Device:
    """A Device from a scene file entry (see the module docstring); ValueError names the
    entry and field on bad input."""
    name = str(d.get("name", default_name))
    where = f"{name}"
    if "image_size" not in d:
        raise ValueError(f"{where}: image_size [width, height] is missing")
    w, h = (int(x) for x in _vec(d["image_size"], 2, f"{where}.image_size"))
    size = (w, h)
    if min(size) < 2:
        raise ValueError(f"{where}.image_size {list(size)} must be at least 2 x 2 px")
    pitch = d.get("pixel_pitch")
    if "camera_matrix" in d:
        K = np.asarray(d["camera_matrix"], float).reshape(3, 3)
    elif d.get("focal_length") is not None and pitch:
        K = optics.intrinsics(float(d["focal_length"]), float(pitch), size, d.get("principal_point"))
    else:
        raise ValueError(f"{where}: give camera_matrix, or focal_length with pixel_pitch (mm)")
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        raise ValueError(f"{where}: focal lengths must be > 0")
    if "rotation" in d or "translation" in d:
        R = np.asarray(d.get("rotation", np.eye(3)), float).reshape(3, 3)
        t = _vec(d.get("translation", [0, 0, 0]), 3, f"{where}.translation")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise ValueError(f"{where}.rotation is not a rotation matrix")
    elif "position" in d:
        R, t = optics.look_at(
            _vec(d["position"], 3, f"{where}.position"),
            _vec(d.get("look_at", [0, 0, 0]), 3, f"{where}.look_at"),
            _vec(d.get("up", [0, 1, 0]), 3, f"{where}.up"),
        )
    else:
        raise ValueError(f"{where}: give position (and look_at) or rotation and translation")
    dist = np.asarray(d.get("dist_coeffs", [0, 0, 0, 0, 0]), float).ravel()
    model = CameraModel(K, dist, R, t, size, float(pitch) if pitch else None, name)
    optics._coeffs(model)  # validates the distortion terms
    psf = str(d.get("psf", "gaussian"))
    if psf not in ("gaussian", "disc"):
        raise ValueError(f"{where}.psf {psf!r}: use gaussian or disc")
    fn = d.get("f_number")
    if fn is not None and not float(fn) > 0:
        raise ValueError(f"{where}.f_number {fn!r} must be > 0")
    if fn is not None and not pitch:
        raise ValueError(f"{where}: defocus (f_number) needs pixel_pitch (mm)")
    lens = Lens(
        float(fn) if fn is not None else None,
        float(d["focus_distance"]) if d.get("focus_distance") is not None else None,
        psf,
        float(d.get("blur", 0.0)),
    )
    return Device(model, lens)


def _pos(v, what: str) -> float:
    """A finite number > 0, or ValueError naming it (a length, a field of view)."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{what} {v!r} is not a number") from None
    if not (np.isfinite(x) and x > 0):
        raise ValueError(f"{what} {v!r} must be a finite number > 0")
    return x


def _size(v, what: str) -> list[int]:
    """[width, height] px, whole numbers >= 2, or ValueError naming it."""
    try:
        a = _vec(v, 2, what) if isinstance(v, (list, tuple)) else None
    except (TypeError, ValueError):
        a = None
    if a is None or np.any(a != np.round(a)) or np.any(a < 2):
        raise ValueError(f"{what} {v!r} must be [width, height], whole numbers >= 2 px")
    return [int(x) for x in a]


def preset(name: str, options: Mapping[str, Any] | None = None) -> tuple[list[dict], dict]:
    """Device entries (cameras, projector) of a named preset; ``options`` override:
    image_size, baseline, distance, angle (deg, derived from baseline and distance
    when not given), focal_length / focal_lengths, dist_coeffs (one list per camera or
    one for both), f_number, focus_distance, psf, field_of_view (mm at ``distance``),
    projector_size, projector_field (mm), projector_dist_coeffs, projector_f_number and
    projector_focus_distance (the projector's depth of field; default: pinhole), target."""
    o = dict(options or {})
    if name not in ("stereo_fringe", "camera_projector"):
        raise ValueError(f"rig.preset {name!r}: use stereo_fringe or camera_projector")
    size = _size(o.get("image_size", [1280, 960]), "rig.image_size")
    b = _pos(o.get("baseline", BASELINE), "rig.baseline")
    dist = _pos(o.get("distance", CONVERGENCE), "rig.distance")
    target = np.asarray(o.get("target", [0.0, 0.0, 0.0]), float)
    h = float(np.sqrt(max(dist**2 - (b / 2) ** 2, 1e-9)))
    fls = o.get("focal_lengths") or ([o["focal_length"]] * 2 if "focal_length" in o else [f for f, _ in THESIS_LENSES])
    if not isinstance(fls, (list, tuple)) or len(fls) != 2:
        raise ValueError(f"rig.focal_lengths {fls!r}: expected two focal lengths (mm)")
    fls = [_pos(f, "rig.focal_length") for f in fls]
    for key in ("field_of_view", "projector_field"):
        if o.get(key) is not None:
            _pos(o[key], f"rig.{key}")
    dc = o.get("dist_coeffs")
    if dc is None:
        dcs = [k for _, k in THESIS_LENSES]
    elif np.ndim(dc) == 2:
        dcs = [list(x) for x in dc]
    else:
        dcs = [list(dc)] * 2
    # the sensor width keeps the thesis's field of view unless field_of_view is asked
    fov = o.get("field_of_view")
    cams = []
    for i, sx in enumerate((-1.0, 1.0)):
        f = float(fls[i])
        width = SENSOR_WIDTH if fov is None else float(fov) * f / dist
        cams.append(
            {
                "name": f"camera{i + 1}",
                "image_size": size,
                "focal_length": f,
                "pixel_pitch": width / size[0],
                "dist_coeffs": dcs[i],
                "position": (target + [sx * b / 2, 0.0, h]).tolist(),
                "look_at": target.tolist(),
                "up": [0, 1, 0],
                "f_number": o.get("f_number", 8.0),
                "focus_distance": o.get("focus_distance", dist),
                "psf": o.get("psf", "gaussian"),
            }
        )
    psize = _size(o.get("projector_size", [1280, 800]), "rig.projector_size")
    field_mm = float(o.get("projector_field", 1.2 * (fov if fov is not None else SENSOR_WIDTH * dist / fls[0])))
    pf = 10.0  # projector lens (mm); only the ratio matters
    proj = {
        "name": "projector",
        "image_size": psize,
        "focal_length": pf,
        "pixel_pitch": field_mm * pf / dist / psize[0],
        "dist_coeffs": o.get("projector_dist_coeffs", [0, 0, 0, 0, 0]),
        "position": (target + [0.0, 0.0, dist]).tolist(),
        "look_at": target.tolist(),
        "up": [0, 1, 0],
    }
    if o.get("projector_f_number") is not None:
        proj["f_number"] = o["projector_f_number"]
        proj["focus_distance"] = o.get("projector_focus_distance", dist)
    if name == "camera_projector":
        cams = cams[:1]
    return cams, proj


def relative_to(first: CameraModel, cam: CameraModel, name: str | None = None) -> CameraModel:
    """``cam`` re-expressed with ``first``'s camera frame as the world frame (the
    calibration file's convention: camera 1 = world)."""
    R = cam.rotation @ first.rotation.T
    t = cam.translation - R @ first.translation
    return CameraModel(
        cam.camera_matrix.copy(), cam.dist_coeffs.copy(), R, t, cam.image_size, cam.pixel_pitch, name or cam.name
    )
