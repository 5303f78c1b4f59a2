"""Calibration files: read and write camera, stereo and camera+projector calibrations.

    read_calibration(path)        -> dict
    write_calibration(path, cal)  -> None

The format follows the extension: ``.yaml``/``.yml``/``.xml`` are OpenCV FileStorage
files (readable by any OpenCV program with ``cv::FileStorage``), ``.json`` is plain JSON.

The calibration dict (lengths in mm, image quantities in px)
-----------------------------------------------------------
``cameras``        list of :class:`camcmm.model.CameraModel`. The first camera is the
                   world frame (``rotation`` = I, ``translation`` = 0); every other camera
                   carries its pose ``x_cam = R x_world + t`` (t in mm). A projector is a
                   camera named ``"projector"`` (an inverse camera, thesis ch. 2.4).
``rms``            float, overall RMS reprojection error in px.
``std_intrinsics`` list (one per camera) of 1-D arrays, standard deviations of
                   (fx, fy, cx, cy, k1, k2, p1, p2, k3, ...) in OpenCV's order (px, -).
``covariance``     optional list (one per camera) of (n, n) covariances of the same
                   intrinsics, or None for a camera without one.
``R``, ``T``,      stereo only: pose of camera 2 in camera 1 (``x2 = R x1 + T``, T in mm),
``E``, ``F``       essential and fundamental matrix (OpenCV's convention x2^T F x1 = 0).
``rectification``  optional dict with OpenCV's stereoRectify outputs R1 R2 P1 P2 Q.
``board``          optional board spec string, e.g. ``"chessboard:9x6:25"``.
any other key      kept if it is JSON-able (numbers, strings, lists, dicts, numpy arrays).

OpenCV YAML keys
----------------
One camera: ``camera_matrix``, ``dist_coeffs``, ``image_size`` (1x2: width, height),
``image_width``, ``image_height`` (as OpenCV's calibration sample writes), ``camera_name``,
``std_intrinsics``, ``covariance``. Several cameras (OpenCV's stereo_calib sample):
``M1 D1 M2 D2 ...``, ``image_size1 image_size2 ...``, ``camera_name1 ...``,
``std_intrinsics1 ...``, ``covariance1 ...``, and ``R T E F`` for camera 2 in camera 1's
frame; a third or later camera k has ``R<k>`` ``T<k>`` (its pose in camera 1's frame).
``rms``, ``board``, ``R1 R2 P1 P2 Q`` (rectification); every other numeric 1-D/2-D array is
written as a matrix under its own key (listed in ``camcmm_arrays``; a 1-D array comes back
1-D), everything else as JSON text in the string sequence ``camcmm_json`` (pieces between
two "x"; files of earlier versions: ``camcmm_extra``, read too). ``dist_coeffs``
is also read as ``distortion_coefficients``,
``image_size`` also from ``image_width``/``image_height``; a camera of unknown size has none
(an ``image_size`` of [0, 0] also means unknown).

Reading refuses, with one line naming the file, the camera and the value, what no camera
has and what crashes native code further on: focal lengths that are not positive and
finite, a non-finite principal point or distortion, a rotation that is not one (or a
reflection), partial, negative or fractional image sizes, a second camera with no baseline
to the first, non-finite E, F or rectification matrices (see ``model.camera_problem``).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CamcmmError, InputError
from ..jsonable import to_jsonable
from ..model import ROTATION_TOL, CameraModel, camera_problem
from ._common import atomic_path

_YAML_EXTS = (".yaml", ".yml", ".xml")
_ARRAY_KEYS = ("R", "T", "E", "F")
_RECT_KEYS = ("R1", "R2", "P1", "P2", "Q")
_PIECE = 512
_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_OWN_KEYS = {"cameras", "rms", "std_intrinsics", "covariance", "R", "T", "E", "F", "rectification", "board"}


def _kind(path: Path) -> str:
    ext = path.suffix.lower()
    if ext in _YAML_EXTS:
        return "yaml"
    if ext == ".json":
        return "json"
    raise InputError(
        f"{path.name}: unknown calibration format (extension {path.suffix!r}); "
        f"use .yaml, .yml, .xml (OpenCV FileStorage) or .json"
    )


def _camera_to_json(cam: CameraModel) -> dict[str, Any]:
    return {
        "name": cam.name,
        "camera_matrix": cam.camera_matrix.tolist(),
        "dist_coeffs": cam.dist_coeffs.tolist(),
        "rotation": cam.rotation.tolist(),
        "translation": cam.translation.tolist(),
        "image_size": list(cam.image_size),
        "pixel_pitch": cam.pixel_pitch,
    }


def _check(cal: dict[str, Any], name: str) -> list[CameraModel]:
    cams = cal.get("cameras") if isinstance(cal, dict) else None
    if not cams or not all(isinstance(c, CameraModel) for c in cams):
        raise InputError(f"{name}: a calibration needs 'cameras', a non-empty list of CameraModel")
    for c in cams:
        if not (np.all(np.isfinite(c.camera_matrix)) and np.all(np.isfinite(c.dist_coeffs))):
            raise InputError(f"{name}: camera {c.name!r} has non-finite intrinsics")
    return list(cams)


def _camera(fname: str, k: int, K: Any, dist: Any, R: Any, t: Any, size: Any, pitch: Any, name: str) -> CameraModel:
    """CameraModel ``k`` (1-based) of file ``fname``; InputError naming the file, the camera
    and the value when it cannot describe a camera (see model.camera_problem)."""
    if K is None:
        raise InputError(f"{fname}: camera {k} ({name}) has no camera matrix")
    why = camera_problem(K, dist, R, t, size, pitch)
    if why is not None:
        raise InputError(f"{fname}: camera {k} ({name}): {why}")
    return CameraModel(K, dist, R, t, size, pitch, name)


def _finite_matrix(fname: str, key: str, a: Any) -> np.ndarray:
    try:
        m = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{fname}: {key} is not a matrix of numbers") from None
    if not np.all(np.isfinite(m)):
        raise InputError(f"{fname}: {key} has NaN or infinite entries")
    return m


def check_calibration(cal: dict[str, Any], fname: str = "calibration") -> dict[str, Any]:
    """``cal`` itself after checking it as :func:`read_calibration` does; InputError
    starting with ``fname`` otherwise. For calibrations built or changed in code (a
    simulation's systematic errors, a dict from JSON): every camera a camera (see
    model.camera_problem), every camera away from camera 1's centre (a stereo pair or a
    camera+projector needs a baseline), R a rotation and T finite and non-zero, E, F, the
    rectification and the RMS finite."""
    cams = cal.get("cameras") if isinstance(cal, dict) else None
    if not cams or not all(isinstance(c, CameraModel) for c in cams):
        raise InputError(f"{fname}: a calibration needs 'cameras', a non-empty list of CameraModel")
    for k, cam in enumerate(cams, start=1):
        why = camera_problem(
            cam.camera_matrix, cam.dist_coeffs, cam.rotation, cam.translation, cam.image_size, cam.pixel_pitch
        )
        if why is not None:
            raise InputError(f"{fname}: camera {k} ({cam.name}): {why}")
    c1 = cams[0].centre
    for k, cam in enumerate(cams[1:], start=2):
        b = float(np.linalg.norm(cam.centre - c1))
        if not b > 1e-6:
            raise InputError(
                f"{fname}: camera {k} ({cam.name}) has a zero baseline: its centre coincides with "
                f"camera 1's (distance {b:.3g} mm); a stereo or camera-projector pair needs one"
            )
    if cal.get("R") is not None:
        R = _finite_matrix(fname, "R", cal["R"])
        if R.size != 9:
            raise InputError(f"{fname}: R must be 3 x 3, got {R.size} numbers")
        R = R.reshape(3, 3)
        off, det = float(np.abs(R @ R.T - np.eye(3)).max()), float(np.linalg.det(R))
        if off > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
            raise InputError(
                f"{fname}: R is {'a reflection' if det < 0 else 'not a rotation'} "
                f"(max |R R^T - I| = {off:.2g}, det R = {det:.6g}; need det +1)"
            )
    if cal.get("T") is not None:
        T = _finite_matrix(fname, "T", cal["T"]).ravel()
        if T.size != 3:
            raise InputError(f"{fname}: T must have 3 numbers (mm), got {T.size}")
        if not float(np.linalg.norm(T)) > 1e-6:
            raise InputError(f"{fname}: T = {T.tolist()} mm: a zero baseline between the cameras")
    for key in ("E", "F"):
        if cal.get(key) is not None:
            _finite_matrix(fname, key, cal[key])
    for key, v in (cal.get("rectification") or {}).items():
        _finite_matrix(fname, key, v)
    rms = cal.get("rms")
    if rms is not None and not (isinstance(rms, (int, float, np.number)) and np.isfinite(rms) and rms >= 0):
        raise InputError(f"{fname}: rms = {rms!r} px must be a finite number >= 0")
    return cal


def write_calibration(path: str | Path, cal: dict[str, Any]) -> None:
    """Write the calibration dict ``cal`` (see the module docstring) to ``path``.

    The format follows the extension (.yaml/.yml/.xml: OpenCV FileStorage, .json: JSON).
    The file is written under a temporary name and renamed, never half-written.
    """
    p = Path(path)
    kind = _kind(p)
    cams = _check(cal, p.name)
    check_calibration(cal, p.name)
    if not p.parent.is_dir():
        raise InputError(f"{p.name}: cannot write, the folder {p.parent} does not exist")
    try:
        with atomic_path(p) as tmp:
            if kind == "json":
                doc = {
                    "format": "camcmm-calibration",
                    "version": 1,
                    "unit": "mm",
                    **{k: to_jsonable(v, keep_nan=True) for k, v in cal.items() if k != "cameras"},
                    "cameras": [_camera_to_json(c) for c in cams],
                }
                tmp.write_text(json.dumps(doc, indent=1, allow_nan=True))
            else:
                _write_yaml(tmp, cal, cams)
    except CamcmmError:
        raise
    except Exception as exc:
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"{p.name}: cannot write calibration ({reason})") from exc


def _write_yaml(tmp: Path, cal: dict[str, Any], cams: list[CameraModel]) -> None:
    import cv2

    fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
    if not fs.isOpened():
        raise InputError(f"{tmp.name}: OpenCV cannot open the file for writing")
    try:
        one = len(cams) == 1
        std = cal.get("std_intrinsics") or [None] * len(cams)
        cov = cal.get("covariance") or [None] * len(cams)

        def mat(v):
            return np.atleast_2d(np.asarray(v, dtype=np.float64))

        for k, cam in enumerate(cams, start=1):
            sfx = "" if one else str(k)
            fs.write("camera_matrix" if one else f"M{k}", cam.camera_matrix)
            fs.write("dist_coeffs" if one else f"D{k}", mat(cam.dist_coeffs))
            if cam.image_size != (0, 0):  # unknown: left out, as a reader expects
                fs.write(f"image_size{sfx}", np.array([cam.image_size], dtype=np.int32))
            if one and cam.image_size != (0, 0):
                fs.write("image_width", int(cam.image_size[0]))
                fs.write("image_height", int(cam.image_size[1]))
            fs.write(f"camera_name{sfx}", cam.name)
            if cam.pixel_pitch is not None:
                fs.write(f"pixel_pitch{sfx}", float(cam.pixel_pitch))
            if k - 1 < len(std) and std[k - 1] is not None:
                fs.write(f"std_intrinsics{sfx}", mat(std[k - 1]))
            if k - 1 < len(cov) and cov[k - 1] is not None:
                fs.write(f"covariance{sfx}", mat(cov[k - 1]))
            if k == 1:
                if not (np.allclose(cam.rotation, np.eye(3)) and np.allclose(cam.translation, 0)):
                    fs.write("R_world", cam.rotation)  # a camera 1 not at the world origin
                    fs.write("T_world", cam.translation[:, None])
            elif k == 2:
                fs.write("R", cam.rotation)
                fs.write("T", cam.translation[:, None])
            else:
                fs.write(f"R{k}", cam.rotation)
                fs.write(f"T{k}", cam.translation[:, None])
        for key in ("E", "F"):
            if cal.get(key) is not None:
                fs.write(key, mat(cal[key]))
        for key, v in (cal.get("rectification") or {}).items():
            fs.write(key, mat(v))
        if cal.get("rms") is not None:
            fs.write("rms", float(cal["rms"]))
        if cal.get("board") is not None:
            fs.write("board", str(cal["board"]))
        extra: dict[str, Any] = {}
        arrays: list[str] = []
        for key, v in cal.items():
            if key in _OWN_KEYS:
                continue
            a = np.asarray(v) if isinstance(v, np.ndarray) else None
            if a is not None and a.dtype.kind in "fiu" and 1 <= a.ndim <= 2 and a.size and _KEY.match(key):
                fs.write(key, np.atleast_2d(a.astype(np.float64)))  # numeric arrays stay matrices
                arrays.append(key)
            else:
                extra[key] = to_jsonable(v, keep_nan=True)
        if arrays:
            fs.write("camcmm_arrays", ",".join(arrays))
        if extra:
            # FileStorage refuses long strings: the JSON goes as a sequence of pieces, each
            # between two "x": OpenCV's YAML strips a piece's trailing spaces and cannot read
            # back one that starts or ends with a quote (a calibration was unreadable when a
            # 512-character cut fell there), so no piece may start or end with JSON's own text
            text = json.dumps(extra)
            fs.startWriteStruct("camcmm_json", cv2.FileNode_SEQ)
            for i in range(0, len(text), _PIECE):
                fs.write("", "x" + text[i : i + _PIECE] + "x")
            fs.endWriteStruct()
    finally:
        fs.release()


def read_calibration(path: str | Path) -> dict[str, Any]:
    """Read a calibration file into the dict described in the module docstring.

    Reads what :func:`write_calibration` writes and OpenCV's own sample files
    (``camera_matrix``/``distortion_coefficients``, or ``M1 D1 M2 D2`` with ``R T``).
    Raises InputError naming the file.
    """
    p = Path(path)
    kind = _kind(p)
    if not p.is_file():
        raise InputError(f"{p.name}: calibration file not found ({p})")
    try:
        return check_calibration(_read_json(p) if kind == "json" else _read_yaml(p), p.name)
    except CamcmmError:
        raise
    except Exception as exc:
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"{p.name}: cannot read calibration ({reason})") from exc


def _read_json(p: Path) -> dict[str, Any]:
    doc = json.loads(p.read_text())
    if not isinstance(doc, dict) or not isinstance(doc.get("cameras"), list) or not doc["cameras"]:
        raise InputError(f"{p.name}: not a calibration file (no 'cameras' list)")
    cams = []
    for i, c in enumerate(doc["cameras"]):
        if not isinstance(c, dict) or "camera_matrix" not in c:
            raise InputError(f"{p.name}: camera {i + 1} has no camera_matrix")
        size = c.get("image_size")
        cams.append(
            _camera(
                p.name,
                i + 1,
                c["camera_matrix"],
                c.get("dist_coeffs", np.zeros(5)),
                c.get("rotation", np.eye(3)),
                c.get("translation", np.zeros(3)),
                (0, 0) if size is None else size,
                c.get("pixel_pitch"),
                str(c.get("name", f"camera{i + 1}")),
            )
        )
    cal = {k: v for k, v in doc.items() if k not in ("format", "version", "unit", "cameras")}
    cal["cameras"] = cams
    for key in _ARRAY_KEYS:
        if cal.get(key) is not None:
            cal[key] = np.asarray(cal[key], dtype=np.float64)
    for key in ("std_intrinsics", "covariance"):
        if cal.get(key) is not None:
            cal[key] = [None if v is None else np.asarray(v, dtype=np.float64) for v in cal[key]]
    if cal.get("rectification"):
        cal["rectification"] = {k: np.asarray(v, dtype=np.float64) for k, v in cal["rectification"].items()}
    return cal


def _read_yaml(p: Path) -> dict[str, Any]:
    import cv2

    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise InputError(f"{p.name}: OpenCV cannot open it as a FileStorage (YAML/XML) file")
    try:

        def node(key):
            n = fs.getNode(key)
            return None if n.empty() or n.isNone() else n

        def mat(key):
            n = node(key)
            return None if n is None else np.asarray(n.mat(), dtype=np.float64)

        def size(sfx):
            s = mat(f"image_size{sfx}")
            if s is not None:
                return tuple(float(v) for v in s.ravel())
            w, h = node(f"image_width{sfx}"), node(f"image_height{sfx}")
            return (w.real(), h.real()) if w is not None and h is not None else (0, 0)

        def text(key, default):
            n = node(key)
            return default if n is None else n.string()

        def real(key):
            n = node(key)
            return None if n is None else float(n.real())

        cams, std, cov = [], [], []
        if node("camera_matrix") is not None:
            dist = mat("dist_coeffs")
            dist = mat("distortion_coefficients") if dist is None else dist
            pose = (mat("R_world"), mat("T_world"))
            cams.append(
                _camera(
                    p.name,
                    1,
                    mat("camera_matrix"),
                    np.zeros(5) if dist is None else dist,
                    np.eye(3) if pose[0] is None else pose[0],
                    np.zeros(3) if pose[1] is None else pose[1],
                    size(""),
                    real("pixel_pitch"),
                    text("camera_name", "camera"),
                )
            )
            std.append(mat("std_intrinsics"))
            cov.append(mat("covariance"))
        else:
            k = 1
            while node(f"M{k}") is not None:
                if k == 1:
                    r, t = mat("R_world"), mat("T_world")
                elif k == 2:
                    r, t = mat("R"), mat("T")
                else:
                    r, t = mat(f"R{k}"), mat(f"T{k}")
                if r is None or t is None:
                    if k == 1:
                        r, t = np.eye(3), np.zeros(3)
                    else:
                        raise InputError(
                            f"{p.name}: camera {k} (M{k}) has no pose "
                            f"({'R, T' if k == 2 else f'R{k}, T{k}'} missing; OpenCV's stereo_calib "
                            f"sample writes them to a separate extrinsics.yml)"
                        )
                d = mat(f"D{k}")
                cams.append(
                    _camera(
                        p.name,
                        k,
                        mat(f"M{k}"),
                        np.zeros(5) if d is None else d,
                        r,
                        t,
                        size(str(k)),
                        real(f"pixel_pitch{k}"),
                        text(f"camera_name{k}", "left" if k == 1 else "right" if k == 2 else f"camera{k}"),
                    )
                )
                std.append(mat(f"std_intrinsics{k}"))
                cov.append(mat(f"covariance{k}"))
                k += 1
        if not cams:
            raise InputError(f"{p.name}: no camera in the file (neither camera_matrix nor M1)")
        cal: dict[str, Any] = {"cameras": cams}
        wrapped = node("camcmm_json")  # pieces between two "x" (see _write_yaml)
        extra = node("camcmm_extra")  # files written before: the pieces bare
        if wrapped is not None:
            cal.update(json.loads("".join(wrapped.at(i).string()[1:-1] for i in range(wrapped.size()))))
        elif extra is not None:
            doc = extra.string() if extra.isString() else "".join(extra.at(i).string() for i in range(extra.size()))
            cal.update(json.loads(doc))
        names = node("camcmm_arrays")
        for key in [] if names is None else names.string().split(","):
            a = mat(key)
            if a is not None:
                cal[key] = a.ravel() if a.shape[0] == 1 else a
        if real("rms") is not None:
            cal["rms"] = real("rms")
        if any(s is not None for s in std):
            cal["std_intrinsics"] = [None if s is None else s.ravel() for s in std]
        if any(c is not None for c in cov):
            cal["covariance"] = cov
        if len(cams) >= 2:
            cal["R"], cal["T"] = cams[1].rotation.copy(), cams[1].translation.copy()
        for key in ("E", "F"):
            if mat(key) is not None:
                cal[key] = mat(key)
        rect = {key: mat(key) for key in _RECT_KEYS if mat(key) is not None}
        if rect:
            cal["rectification"] = rect
        if node("board") is not None:
            cal["board"] = text("board", "")
        return cal
    finally:
        fs.release()


__all__ = ["check_calibration", "read_calibration", "write_calibration"]
