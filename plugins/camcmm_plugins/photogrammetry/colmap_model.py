"""Reading a COLMAP sparse model (cameras, images, points3D) as text or binary.

The text format (colmap.github.io/format.html) is read by hand: it is three small
whitespace-separated tables, and reading it here gives a line number for every refusal
and works without pycolmap. The binary format is read with pycolmap (COLMAP's own
reader; its layout changes between COLMAP versions, so it is not re-implemented here).
Both give the same :class:`ColmapModel`; the tests hold one against the other.

COLMAP's conventions, kept here and converted in :mod:`.imports`:

* poses are world-to-camera, ``x_cam = R(q) X + t`` with the Hamilton unit quaternion
  ``q = (qw, qx, qy, qz)``;
* pixel coordinates put the centre of the top-left pixel at (0.5, 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from camcmm.api import InputError

#: Number of parameters of each COLMAP camera model (src/colmap/sensor/models.h).
N_PARAMS = {
    "SIMPLE_PINHOLE": 3,
    "PINHOLE": 4,
    "SIMPLE_RADIAL": 4,
    "RADIAL": 5,
    "OPENCV": 8,
    "OPENCV_FISHEYE": 8,
    "FULL_OPENCV": 12,
    "FOV": 5,
    "SIMPLE_RADIAL_FISHEYE": 4,
    "RADIAL_FISHEYE": 5,
    "THIN_PRISM_FISHEYE": 12,
    "RAD_TAN_THIN_PRISM_FISHEYE": 16,
}

FILES = ("cameras", "images", "points3D")


@dataclass
class ColmapModel:
    """A COLMAP sparse model in COLMAP's own conventions.

    cameras : camera_id -> (model name, width px, height px, params)
    images : list of (image_id, name, camera_id, R (3, 3), t (3,)), world-to-camera
    xyz : (N, 3) point coordinates; rgb : (N, 3) uint8; error : (N,) px; track : (N,) int
    """

    cameras: dict[int, tuple[str, int, int, np.ndarray]] = field(default_factory=dict)
    images: list[tuple[int, str, int, np.ndarray, np.ndarray]] = field(default_factory=list)
    xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    rgb: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.uint8))
    error: np.ndarray = field(default_factory=lambda: np.zeros(0))
    track: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    binary: bool = False


def quat_to_R(qw: float, qx: float, qy: float, qz: float) -> np.ndarray:
    """Rotation matrix of a Hamilton quaternion (normalised first, as COLMAP does)."""
    q = np.array([qw, qx, qy, qz], dtype=np.float64)
    n = np.linalg.norm(q)
    if not np.isfinite(n) or n < 1e-12:
        raise ValueError("zero quaternion")
    w, x, y, z = q / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def model_folder(path: Path) -> tuple[Path, str] | None:
    """(folder, "txt" | "bin") when ``path`` is a COLMAP model folder, or a folder
    holding ``sparse/0`` or ``sparse`` (COLMAP's project layout); else None."""
    for d in (path, path / "sparse" / "0", path / "sparse", path / "0"):
        for ext in ("txt", "bin"):
            if all((d / f"{name}.{ext}").is_file() for name in FILES):
                return d, ext
    return None


def read_model(folder: Path, ext: str) -> ColmapModel:
    """Read a model folder (``ext`` "txt": by hand; "bin": with pycolmap)."""
    return read_text(folder) if ext == "txt" else read_binary(folder)


def _rows(path: Path):
    """(line number, fields) of the non-comment lines, empty lines included (an image's
    second line is empty when it has no 2-D points)."""
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read ({exc})") from None
    for k, line in enumerate(text.splitlines(), 1):
        if not line.startswith("#"):
            yield k, line.split()


def read_text(folder: Path) -> ColmapModel:
    """Read cameras.txt, images.txt and points3D.txt of a COLMAP text model."""
    m = ColmapModel()
    path = folder / "cameras.txt"
    for k, f in _rows(path):
        if not f:
            continue
        try:
            cid, model, w, h = int(f[0]), f[1], int(f[2]), int(f[3])
            params = np.array([float(v) for v in f[4:]])
        except (ValueError, IndexError):
            raise InputError(f"{path}: line {k}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...") from None
        if model not in N_PARAMS:
            raise InputError(f"{path}: line {k}: unknown camera model {model!r}")
        if len(params) != N_PARAMS[model]:
            raise InputError(f"{path}: line {k}: {model} has {N_PARAMS[model]} parameters, found {len(params)}")
        m.cameras[cid] = (model, w, h, params)

    path = folder / "images.txt"
    rows = list(_rows(path))
    while rows and not rows[-1][1] and len(rows) % 2:
        rows.pop()  # a blank last line
    for i in range(0, len(rows), 2):
        k, f = rows[i]
        try:
            iid, cid = int(f[0]), int(f[8])
            q = [float(v) for v in f[1:5]]
            t = np.array([float(v) for v in f[5:8]])
            name = " ".join(f[9:])  # names may hold spaces
            R = quat_to_R(*q)
        except (ValueError, IndexError):
            raise InputError(f"{path}: line {k}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME") from None
        if not name or not np.isfinite(t).all():
            raise InputError(f"{path}: line {k}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME")
        if cid not in m.cameras:
            raise InputError(f"{path}: line {k}: image {name!r} names camera {cid}, which cameras.txt lacks")
        m.images.append((iid, name, cid, R, t))

    path = folder / "points3D.txt"
    xyz, rgb, err, track = [], [], [], []
    for k, f in _rows(path):
        if not f:
            continue
        try:
            xyz.append([float(v) for v in f[1:4]])
            rgb.append([int(v) for v in f[4:7]])
            err.append(float(f[7]))
            track.append((len(f) - 8) // 2)
        except (ValueError, IndexError):
            raise InputError(f"{path}: line {k}: expected POINT3D_ID X Y Z R G B ERROR TRACK...") from None
        if len(xyz[-1]) != 3 or len(rgb[-1]) != 3 or not all(0 <= c <= 255 for c in rgb[-1]):
            raise InputError(f"{path}: line {k}: expected POINT3D_ID X Y Z R G B (0-255) ERROR TRACK...")
    m.xyz = np.array(xyz, dtype=np.float64).reshape(-1, 3)
    m.rgb = np.array(rgb, dtype=np.uint8).reshape(-1, 3)
    m.error = np.array(err, dtype=np.float64)
    m.track = np.array(track, dtype=int)
    if not np.isfinite(m.xyz).all():
        raise InputError(f"{path}: a point has a non-finite coordinate")
    return m


def read_binary(folder: Path) -> ColmapModel:
    """Read a binary (or text) model with pycolmap: only registered images (with a pose)."""
    try:
        import pycolmap
    except ImportError:  # pragma: no cover - pycolmap is a dependency
        raise InputError(f"{folder}: reading a binary COLMAP model needs pycolmap") from None
    try:
        rec = pycolmap.Reconstruction(str(folder))
    except Exception as exc:  # pycolmap raises its own (RuntimeError, ValueError) types
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{folder}: not a readable COLMAP model ({first})") from None
    m = ColmapModel(binary=True)
    for cid, cam in rec.cameras.items():
        m.cameras[int(cid)] = (cam.model.name, int(cam.width), int(cam.height), np.asarray(cam.params, float))
    for iid in sorted(rec.images):
        im = rec.images[iid]
        if not im.has_pose:
            continue
        pose = im.cam_from_world()
        m.images.append((int(iid), im.name, int(im.camera_id), pose.rotation.matrix(), np.asarray(pose.translation)))
    pts = rec.points3D
    ids = sorted(pts)
    m.xyz = np.array([pts[i].xyz for i in ids], dtype=np.float64).reshape(-1, 3)
    m.rgb = np.array([pts[i].color for i in ids], dtype=np.uint8).reshape(-1, 3)
    m.error = np.array([pts[i].error for i in ids], dtype=np.float64)
    m.track = np.array([pts[i].track.length() for i in ids], dtype=int)
    return m
