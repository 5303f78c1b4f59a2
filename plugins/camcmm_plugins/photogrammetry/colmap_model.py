"""Reading a COLMAP sparse model (cameras, images, points3D) as text or binary.

Both formats (colmap.github.io/format.html; the binary one is COLMAP's
``src/colmap/scene/reconstruction_io.cc``, little-endian, unchanged from COLMAP 3.0 to
pycolmap 4 for these three files) are read by hand: each reader only turns its file into
rows, and every row goes through the same checks (:class:`_Builder`), so a value the text
refuses the binary refuses too, naming the file, the line (text) or record (binary), the
id and the value:

* cameras: a known model with its parameter count, finite parameters, intrinsics a
  camera (``camcmm.api.CameraModel``'s checks, as the calibration readers: positive
  finite focal lengths, whole image sides from 1 px, the principal point near the image);
* images: a finite, non-zero quaternion, a finite translation, a name, a known camera;
* points: finite coordinates, colours 0-255, a finite error;
* every camera, image and point id once (a repeated id would silently replace the first,
  as a repeated YAML key would).

A binary file's counts are checked against the bytes left in the file before anything is
allocated (a header claiming 2^60 records is refused in one line), a file that ends
inside a record or goes on after the last is refused, and pycolmap is not needed to read.

COLMAP's conventions, kept here and converted in :mod:`.imports`:

* poses are world-to-camera, ``x_cam = R(q) X + t`` with the Hamilton unit quaternion
  ``q = (qw, qx, qy, qz)``;
* pixel coordinates put the centre of the top-left pixel at (0.5, 0.5).
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from .cameras import COLMAP_PARAMS, check_intrinsics

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

#: COLMAP's model ids in the binary format (the order of CameraModelId in models.h)
MODEL_IDS = tuple(N_PARAMS)

#: The models whose parameters start fx fy cx cy; the others start f cx cy (one focal length).
TWO_FOCAL = ("PINHOLE", "OPENCV", "OPENCV_FISHEYE", "FULL_OPENCV", "THIN_PRISM_FISHEYE", "RAD_TAN_THIN_PRISM_FISHEYE")

FILES = ("cameras", "images", "points3D")

#: A points3D.bin record before its track: id, X Y Z, R G B, error, track length (packed).
POINT_RECORD = np.dtype([("id", "<u8"), ("xyz", "<f8", 3), ("rgb", "u1", 3), ("error", "<f8"), ("track", "<u8")])


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
    if not np.isfinite(q).all() or not np.isfinite(n) or n < 1e-12:
        raise ValueError(f"quaternion {_fmt(q)} is zero or not finite")
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


def _fmt(v: Any) -> str:
    """Numbers as the refusals quote them (``nan``, ``-500``, ``1e+30``)."""
    return "(" + ", ".join(f"{float(x):g}" for x in np.ravel(v)) + ")" if np.ndim(v) else f"{float(v):g}"


def read_model(folder: Path, ext: str) -> ColmapModel:
    """Read a model folder: ``ext`` "txt" (cameras.txt ...) or "bin" (cameras.bin ...)."""
    return read_text(folder) if ext == "txt" else read_binary(folder)


class _Builder:
    """The checks both formats share: each ``camera``/``image``/``point`` call takes one
    row as its reader found it (``where``: "FILE: line K" or "FILE: record K") and
    refuses it in one line naming ``where``, the id and the value."""

    def __init__(self, binary: bool):
        self.m = ColmapModel(binary=binary)
        self.image_ids: set[int] = set()

    def camera(self, where: str, cid: int, model: str, w: float, h: float, params: np.ndarray) -> None:
        if cid in self.m.cameras:
            raise InputError(f"{where}: camera id {cid} given twice")
        if model not in N_PARAMS:
            raise InputError(f"{where}: camera {cid}: unknown camera model {model!r}")
        if len(params) != N_PARAMS[model]:
            raise InputError(f"{where}: {model} has {N_PARAMS[model]} parameters, found {len(params)}")
        bad = np.flatnonzero(~np.isfinite(params))
        if bad.size:
            k = int(bad[0])
            label = f" ({COLMAP_PARAMS[model][k]})" if model in COLMAP_PARAMS else ""
            raise InputError(f"{where}: camera {cid}: parameter {k + 1}{label} = {_fmt(params[k])} must be finite")
        fx, fy, cx, cy = params[:4] if model in TWO_FOCAL else (params[0], params[0], params[1], params[2])
        check_intrinsics(where, cid, fx, fy, cx - 0.5, cy - 0.5, (w, h))  # OpenCV's pixel origin
        self.m.cameras[cid] = (model, int(w), int(h), params)

    def image(self, where: str, iid: int, q: Any, t: Any, cid: int, name: str) -> None:
        if iid in self.image_ids:
            raise InputError(f"{where}: image id {iid} given twice")
        try:
            R = quat_to_R(*q)
        except ValueError as exc:
            raise InputError(f"{where}: image {iid}: {exc}") from None
        t = np.asarray(t, dtype=np.float64)
        if not np.isfinite(t).all():
            raise InputError(f"{where}: image {iid}: translation {_fmt(t)} must be finite")
        if not name:
            raise InputError(f"{where}: image {iid} has no name")
        if cid not in self.m.cameras:
            raise InputError(f"{where}: image {name!r} names camera {cid}, which the cameras file lacks")
        self.image_ids.add(iid)
        self.m.images.append((iid, name, cid, R, t))

    def points(self, where: Callable[[int], str], ids: Any, xyz: Any, rgb: Any, error: Any, track: Any) -> None:
        """All points at once, as arrays (a model holds 10^5 to 10^6: checked in bulk, the
        first row at fault named by ``where(k)``, k counted from 0 in file order)."""
        ids = np.asarray(ids, dtype=np.uint64).reshape(-1)
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        error = np.asarray(error, dtype=np.float64).reshape(-1)
        order = np.argsort(ids, kind="stable")
        again = order[1:][ids[order][1:] == ids[order][:-1]]  # each repeat, after its first
        if again.size:
            k = int(again.min())
            raise InputError(f"{where(k)}: point id {ids[k]} given twice")
        for bad, what in (
            (~np.isfinite(xyz).all(axis=1), lambda k: f"coordinates {_fmt(xyz[k])}"),
            (~np.isfinite(error), lambda k: f"error {_fmt(error[k])} px"),
        ):
            if bad.any():
                k = int(np.argmax(bad))
                raise InputError(f"{where(k)}: point {ids[k]}: {what(k)} must be finite")
        m = self.m
        m.xyz, m.error = xyz, error
        m.rgb = np.asarray(rgb, dtype=np.uint8).reshape(-1, 3)  # 0-255: u8 in binary, checked in text
        m.track = np.asarray(track, dtype=int).reshape(-1)


# -- text -------------------------------------------------------------------------------
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


def _number(text: str, where: str, what: str, integer: bool = False) -> Any:
    """One field as a number (``integer``: an id, a whole number), or a refusal naming it."""
    try:
        return int(text) if integer else float(text)
    except ValueError:
        raise InputError(f"{where}: {what} {text!r} is not {'an integer' if integer else 'a number'}") from None


def read_text(folder: Path) -> ColmapModel:
    """Read cameras.txt, images.txt and points3D.txt of a COLMAP text model."""
    b = _Builder(binary=False)
    path = folder / "cameras.txt"
    for k, f in _rows(path):
        if not f:
            continue
        where = f"{path}: line {k}"
        if len(f) < 4:
            raise InputError(f"{where}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...")
        cid = _number(f[0], where, "camera id", integer=True)
        w, h = _number(f[2], where, "width", False), _number(f[3], where, "height", False)
        params = np.array([_number(v, where, f"camera {cid} parameter", False) for v in f[4:]])
        b.camera(where, cid, f[1], w, h, params)

    path = folder / "images.txt"
    rows = list(_rows(path))
    while rows and not rows[-1][1] and len(rows) % 2:
        rows.pop()  # a blank last line
    for i in range(0, len(rows), 2):
        k, f = rows[i]
        where = f"{path}: line {k}"
        if len(f) < 10:
            raise InputError(f"{where}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME")
        iid = _number(f[0], where, "image id", integer=True)
        q = [_number(v, where, f"image {iid} quaternion", False) for v in f[1:5]]
        t = [_number(v, where, f"image {iid} translation", False) for v in f[5:8]]
        cid = _number(f[8], where, f"image {iid} camera id", integer=True)
        b.image(where, iid, q, t, cid, " ".join(f[9:]))  # names may hold spaces

    path = folder / "points3D.txt"
    lines, ids, xyz, rgb, err, track = [], [], [], [], [], []
    for k, f in _rows(path):
        if not f:
            continue
        where = f"{path}: line {k}"
        if len(f) < 8:
            raise InputError(f"{where}: expected POINT3D_ID X Y Z R G B ERROR TRACK...")
        pid = _number(f[0], where, "point id", integer=True)
        if not 0 <= pid < 2**64:  # COLMAP's point ids are uint64
            raise InputError(f"{where}: point id {pid} outside 0 .. 2^64 - 1")
        colour = [_number(v, where, f"point {pid} colour", integer=True) for v in f[4:7]]
        if not all(0 <= c <= 255 for c in colour):  # the binary's u8 cannot say otherwise
            raise InputError(f"{where}: point {pid}: colour {tuple(colour)} outside 0-255")
        lines.append(k)
        ids.append(pid)
        xyz.append([_number(v, where, f"point {pid} coordinate", False) for v in f[1:4]])
        rgb.append(colour)
        err.append(_number(f[7], where, f"point {pid} error", False))
        track.append((len(f) - 8) // 2)
    b.points(lambda k: f"{path}: line {lines[k]}", ids, xyz, rgb, err, track)
    return b.m


# -- binary -----------------------------------------------------------------------------
class _Bytes:
    """A binary model file read in order, every read checked against what is left."""

    def __init__(self, path: Path):
        self.path, self.pos = path, 0
        try:
            with open(path, "rb") as fh:
                size = fh.seek(0, 2)
                # mapped, not read: the file's size costs no memory until a record is read
                self.data: Any = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) if size else b""
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read ({exc})") from None

    @property
    def left(self) -> int:
        return len(self.data) - self.pos

    def take(self, fmt: str, what: str) -> tuple:
        n = struct.calcsize("<" + fmt)
        if n > self.left:
            raise InputError(f"{self.path}: the file ends inside {what} (byte {self.pos}; {self.left} left of {n})")
        out = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += n
        return out

    def count(self, what: str, least: int) -> int:
        """A uint64 count of records of at least ``least`` bytes each, refused when the
        rest of the file cannot hold them (before anything is allocated for them)."""
        (n,) = self.take("Q", f"the {what} count")
        if n * least > self.left:
            raise InputError(
                f"{self.path}: {n} {what} at {least} bytes or more each need {n * least} bytes; "
                f"{self.left} are left in the file (byte {self.pos})"
            )
        return n

    def name(self, what: str) -> str:
        end = self.data.find(b"\0", self.pos)
        if end < 0:
            raise InputError(f"{self.path}: the file ends inside {what}'s name (byte {self.pos}; no terminating NUL)")
        raw = bytes(self.data[self.pos : end])
        self.pos = end + 1
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(f"{self.path}: {what}'s name {raw[:40]!r} is not UTF-8") from None

    def skip(self, n: int, what: str) -> None:
        if n > self.left:
            raise InputError(f"{self.path}: the file ends inside {what} ({n} bytes declared, {self.left} left)")
        self.pos += n

    def end(self) -> None:
        if self.left:
            raise InputError(f"{self.path}: {self.left} bytes after the last record (byte {self.pos}): a wrong count?")


def read_binary(folder: Path) -> ColmapModel:
    """Read cameras.bin, images.bin and points3D.bin of a COLMAP binary model (COLMAP
    writes only registered images there)."""
    b = _Builder(binary=True)
    f = _Bytes(folder / "cameras.bin")
    for k in range(1, f.count("cameras", 24) + 1):
        what = f"camera record {k}"
        cid, mid, w, h = f.take("iiQQ", what)
        if not 0 <= mid < len(MODEL_IDS):
            raise InputError(f"{f.path}: {what}: camera {cid}: unknown camera model id {mid}")
        model = MODEL_IDS[mid]
        params = np.array(f.take(f"{N_PARAMS[model]}d", what))
        b.camera(f"{f.path}: record {k}", cid, model, w, h, params)
    f.end()

    f = _Bytes(folder / "images.bin")
    for k in range(1, f.count("images", 73) + 1):  # id, q, t, camera, a 1-char name + NUL, count
        what = f"image record {k}"
        iid, *qt, cid = f.take("I7dI", what)
        name = f.name(what)
        (n2d,) = f.take("Q", what)
        if n2d > f.left // 24:
            raise InputError(f"{f.path}: {what}: {n2d} 2-D points need {24 * n2d} bytes; {f.left} are left")
        f.skip(24 * n2d, what)  # x, y, point3D_id each: not needed here
        b.image(f"{f.path}: record {k}", iid, qt[:4], qt[4:], cid, name)
    f.end()

    f = _Bytes(folder / "points3D.bin")
    n = f.count("points", POINT_RECORD.itemsize)
    # only the track lengths are read record by record (they give the next record's
    # offset); the records themselves are gathered into one array and checked in bulk
    starts = np.empty(n, dtype=np.int64)
    for k in range(n):
        if f.left < POINT_RECORD.itemsize:
            raise InputError(f"{f.path}: the file ends inside point record {k + 1} (byte {f.pos}; {f.left} left)")
        (t,) = struct.unpack_from("<Q", f.data, f.pos + POINT_RECORD.itemsize - 8)
        if t > (f.left - POINT_RECORD.itemsize) // 8:
            raise InputError(f"{f.path}: point record {k + 1}: a track of {t} needs {8 * t} bytes; {f.left} are left")
        starts[k] = f.pos
        f.pos += POINT_RECORD.itemsize + 8 * t  # then the (image_id, point2D_idx) pairs
    f.end()
    rec = np.empty(n, dtype=POINT_RECORD)
    raw, data = rec.view(np.uint8).reshape(n, POINT_RECORD.itemsize), np.frombuffer(f.data, dtype=np.uint8)
    for i in range(0, n, 1 << 16):  # in blocks: the byte index is 8 x the block's bytes
        raw[i : i + (1 << 16)] = data[starts[i : i + (1 << 16), None] + np.arange(POINT_RECORD.itemsize)]
    b.points(lambda k: f"{f.path}: record {k + 1}", rec["id"], rec["xyz"], rec["rgb"], rec["error"], rec["track"])
    return b.m
