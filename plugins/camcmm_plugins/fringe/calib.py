"""Calibrations for fringe reconstruction: which cameras and which projector.

    load_calibration(source) -> dict with "cameras" (list of CameraModel) ...
    read_text_folder(folder) -> the same dict from a CalibrationDataDistortion-style folder
    pick_devices(cal)        -> (cameras without the projector, projector or None)
    check_image_size(cam, shape, what)

``source`` is a calibration dict (``camcmm.api.read_calibration``'s form: cameras[0]
is the world frame, a projector is a CameraModel named "projector"), a calibration file,
or a folder of plain-text matrices as the MATLAB/OpenCV projector-camera calibration of
github.com/kimthyung/3D_Reconstruction_with_Fringe_pattern writes them
(whitespace-separated numbers, OpenCV conventions, x_proj = R x_cam + T, T in mm):

    CamIntrinsicMatrixRight.txt (3x3)   CamDistortionCoefficientsRight.txt (k1 k2 p1 p2 k3)
    ProjIntrinsicMatrix.txt (3x3)       ProjDistortionCoefficients.txt
    ProjRotationMatrix.txt (3x3)        ProjTranslationVector.txt (3)
    CamRotationMatrixRight.txt, CamTranslationVectorRight.txt (optional, camera pose)

That layout does not state the image sizes; they are taken from the captures.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import CameraModel, InputError, check_calibration


def _matrix(folder: Path, name: str, shape: tuple[int, ...], required: bool = True):
    p = folder / name
    if not p.is_file():
        if required:
            raise InputError(f"{folder.name}: {name} is missing (needed for the camera-projector calibration)")
        return None
    try:
        a = np.loadtxt(p, dtype=np.float64)
    except ValueError as exc:
        raise InputError(f"{p.name}: not a matrix of numbers ({' '.join(str(exc).split())[:120]})") from None
    if a.size != int(np.prod(shape)):
        raise InputError(f"{p.name}: expected {int(np.prod(shape))} numbers {shape}, found {a.size}")
    return a.reshape(shape)


def read_text_folder(folder: str | Path) -> dict[str, Any]:
    """Camera + projector calibration from a folder of text matrices (see the module docstring)."""
    d = Path(folder)
    k_cam = _matrix(d, "CamIntrinsicMatrixRight.txt", (3, 3))
    dist_cam = _matrix(d, "CamDistortionCoefficientsRight.txt", (5,))
    r_cam = _matrix(d, "CamRotationMatrixRight.txt", (3, 3), required=False)
    t_cam = _matrix(d, "CamTranslationVectorRight.txt", (3,), required=False)
    k_p = _matrix(d, "ProjIntrinsicMatrix.txt", (3, 3))
    dist_p = _matrix(d, "ProjDistortionCoefficients.txt", (5,))
    r_p = _matrix(d, "ProjRotationMatrix.txt", (3, 3))
    t_p = _matrix(d, "ProjTranslationVector.txt", (3,))
    for name, r in (("ProjRotationMatrix.txt", r_p), ("CamRotationMatrixRight.txt", r_cam)):
        if r is not None and (abs(np.linalg.det(r) - 1) > 1e-3 or np.abs(r @ r.T - np.eye(3)).max() > 1e-3):
            raise InputError(f"{name}: not a rotation matrix (R R^T != I or det != 1)")
    try:
        cam = CameraModel(
            k_cam,
            dist_cam,
            np.eye(3) if r_cam is None else r_cam,
            np.zeros(3) if t_cam is None else t_cam,
            name="camera",
        )
        proj = CameraModel(k_p, dist_p, r_p, t_p, name="projector")
        moved = (r_cam is not None and not np.allclose(r_cam, np.eye(3))) or (t_cam is not None and np.any(t_cam))
        if moved:
            # the projector's pose is stated in the camera's frame: chain it to the world
            proj = CameraModel(k_p, dist_p, r_p @ r_cam, r_p @ t_cam + t_p, name="projector")
    except InputError as exc:  # the same checks as a calibration file's, named by the folder
        raise InputError(f"{d.name}: {exc}") from None
    return check_calibration({"cameras": [cam, proj], "source": str(d)}, d.name)


def load_calibration(source: Any) -> dict[str, Any]:
    """A calibration dict from a dict, a calibration file or a text-matrix folder."""
    if isinstance(source, Mapping):
        cams = source.get("cameras")
        if not cams or not all(isinstance(c, CameraModel) for c in cams):
            raise InputError("calibration: needs 'cameras', a non-empty list of CameraModel")
        return check_calibration(dict(source), "calibration")  # its models may have been changed since
    if isinstance(source, (str, Path)):
        p = Path(source)
        if p.is_dir():
            return read_text_folder(p)
        from camcmm.api import read_calibration

        return read_calibration(p)
    raise InputError(f"calibration: expected a file, a folder or a dict, got {type(source).__name__}")


def pick_devices(cal: dict[str, Any]) -> tuple[list[CameraModel], CameraModel | None]:
    """The cameras (in calibration order) and the projector (a camera named 'projector')."""
    cams = [c for c in cal["cameras"] if c.name.lower() != "projector"]
    projs = [c for c in cal["cameras"] if c.name.lower() == "projector"]
    return cams, projs[0] if projs else None


def check_image_size(cam: CameraModel, shape: tuple[int, ...], what: str) -> CameraModel:
    """The camera with its image size; InputError when the calibration's size differs."""
    h, w = shape[:2]
    if cam.image_size == (0, 0):
        return CameraModel(
            cam.camera_matrix, cam.dist_coeffs, cam.rotation, cam.translation, (w, h), cam.pixel_pitch, cam.name
        )
    if tuple(cam.image_size) != (w, h):
        raise InputError(
            f"calibration: camera {cam.name!r} is calibrated for {cam.image_size[0]}x"
            f"{cam.image_size[1]} px but {what} are {w}x{h} px"
        )
    return cam
