"""Calibration boards: the spec string, the board's points in mm and their detection.

Board spec strings (lengths in mm)::

    chessboard:COLSxROWS:SQUARE          inner corners, as OpenCV counts them: chessboard:9x6:25
    charuco:COLSxROWS:SQUARE:MARKER[:DICT]   squares (not corners), marker side, ArUco
                                         dictionary (default DICT_5X5_100): charuco:11x8:15:11
    circles:COLSxROWS:SPACING            symmetric circle grid, centre spacing: circles:7x6:20
    acircles:COLSxROWS:SPACING           asymmetric circle grid as OpenCV's calibration sample
                                         lays it out: centre (i, j) at ((2 j + i mod 2) s, i s),
                                         so circles in one row are 2 s apart: acircles:4x11:10

A detection is a :class:`Detection`: the image points (N, 2) px (float32), the board
points (N, 3) mm in the board frame (z = 0) and ``ids`` (N,), the index of each point in
the full board (a ChArUco view may show part of the board; stereo matches views by id).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import Image, InputError, ParameterError

KINDS = ("chessboard", "charuco", "circles", "acircles")
_SIZE = re.compile(r"^(\d+)\s*[x×X]\s*(\d+)$")
#: Largest board: points along a side, points in all, square side or spacing (mm).
MAX_SIDE = 200
MAX_POINTS = 10_000
MAX_LENGTH = 10_000.0


@dataclass(frozen=True)
class Board:
    """A parsed board spec. ``cols``/``rows``: inner corners (chessboard), squares
    (charuco) or circles (circle grids); ``square``: square side or circle spacing, mm."""

    kind: str
    cols: int
    rows: int
    square: float
    marker: float = 0.0
    dictionary: str = "DICT_5X5_100"

    @property
    def spec(self) -> str:
        if self.kind == "charuco":
            return f"charuco:{self.cols}x{self.rows}:{self.square:g}:{self.marker:g}:{self.dictionary}"
        return f"{self.kind}:{self.cols}x{self.rows}:{self.square:g}"

    @property
    def pattern_size(self) -> tuple[int, int]:
        """(cols, rows) as OpenCV's detectors take it (inner corners for ChArUco)."""
        if self.kind == "charuco":
            return self.cols - 1, self.rows - 1
        return self.cols, self.rows

    @property
    def object_points(self) -> np.ndarray:
        """(N, 3) float32 board points in mm, z = 0, in OpenCV's detection order."""
        c, r = self.pattern_size
        i, j = np.divmod(np.arange(c * r), c)  # i: row, j: column
        pts = np.zeros((c * r, 3), np.float32)
        if self.kind == "acircles":
            pts[:, 0] = (2 * j + i % 2) * self.square
            pts[:, 1] = i * self.square
        elif self.kind == "charuco":  # OpenCV's CharucoBoard: origin at the board's corner
            pts[:, 0] = (j + 1) * self.square
            pts[:, 1] = (i + 1) * self.square
        else:
            pts[:, 0] = j * self.square
            pts[:, 1] = i * self.square
        return pts

    def charuco(self):
        import cv2

        d = getattr(cv2.aruco, self.dictionary)
        return cv2.aruco.CharucoBoard(
            (self.cols, self.rows), self.square, self.marker, cv2.aruco.getPredefinedDictionary(d)
        )


def parse_board(spec: str | Board) -> Board:
    """Board from a spec string (see the module docstring); InputError naming the spec."""
    if isinstance(spec, Board):
        return spec
    parts = [p.strip() for p in str(spec).split(":")]
    kind = parts[0].lower()
    usage = {
        "chessboard": "chessboard:COLSxROWS:SQUARE_MM (inner corners, e.g. chessboard:9x6:25)",
        "charuco": "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT] (squares, e.g. charuco:11x8:15:11)",
        "circles": "circles:COLSxROWS:SPACING_MM (e.g. circles:7x6:20)",
        "acircles": "acircles:COLSxROWS:SPACING_MM (e.g. acircles:4x11:10)",
    }
    if kind not in KINDS:
        raise InputError(f"board {spec!r}: unknown kind {parts[0]!r}; use one of " + "; ".join(usage.values()))
    n = 4 if kind == "charuco" else 3
    if len(parts) not in ((n, n + 1) if kind == "charuco" else (n,)):
        raise InputError(f"board {spec!r}: expected {usage[kind]}")
    m = _SIZE.match(parts[1])
    if not m:
        raise InputError(f"board {spec!r}: size {parts[1]!r} must read COLSxROWS, e.g. 9x6")
    cols, rows = int(m.group(1)), int(m.group(2))
    try:
        nums = [float(v) for v in parts[2:n]]
    except ValueError:
        raise InputError(f"board {spec!r}: expected {usage[kind]}") from None
    if not all(np.isfinite(v) and v > 0 for v in nums):
        raise InputError(f"board {spec!r}: square size and spacing must be positive numbers (mm)")
    least = 3 if kind == "charuco" else 2
    if cols < least or rows < least:
        raise InputError(
            f"board {spec!r}: needs at least {least}x{least} {'squares' if kind == 'charuco' else 'points'}"
        )
    if cols > MAX_SIDE or rows > MAX_SIDE or cols * rows > MAX_POINTS:
        raise InputError(
            f"board {spec!r}: {cols}x{rows} is more than a board holds "
            f"(at most {MAX_SIDE} along a side and {MAX_POINTS} points)"
        )
    if max(nums) > MAX_LENGTH:
        raise InputError(
            f"board {spec!r}: {max(nums):g} mm is more than {MAX_LENGTH:g} mm; square size and spacing are in mm"
        )
    if kind == "charuco":
        import cv2

        dictionary = parts[4].upper() if len(parts) == 5 else "DICT_5X5_100"
        if not dictionary.startswith("DICT_") or not hasattr(cv2.aruco, dictionary):
            raise InputError(f"board {spec!r}: unknown ArUco dictionary {dictionary!r} (e.g. DICT_5X5_100)")
        m = re.match(r"^DICT_\dX\d_(\d+)$", dictionary)
        if m and cols * rows // 2 > int(m.group(1)):
            raise InputError(
                f"board {spec!r}: {cols}x{rows} squares hold {cols * rows // 2} markers; "
                f"{dictionary} has only {m.group(1)}"
            )
        if nums[1] >= nums[0]:
            raise InputError(f"board {spec!r}: the marker ({nums[1]:g} mm) must be smaller than the square")
        return Board(kind, cols, rows, nums[0], nums[1], dictionary)
    return Board(kind, cols, rows, nums[0])


def board_points(board: Board) -> tuple[int, str]:
    """(how many points the whole board has, what they are in words): inner corners of a
    chessboard or ChArUco board ((COLS - 1) x (ROWS - 1) for ChArUco), circles of a grid."""
    c, r = board.pattern_size
    return c * r, ("circles" if board.kind in ("circles", "acircles") else "inner corners")


@dataclass
class Detection:
    """The board found (or not) in one image. Points in px (image) and mm (board)."""

    name: str
    image_size: tuple[int, int]
    image_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float32))
    object_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    ids: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    reason: str = ""

    @property
    def found(self) -> bool:
        return not self.reason

    def to_dict(self) -> dict[str, Any]:
        return {
            "image": self.name,
            "found": self.found,
            "reason": self.reason,
            "image_size": list(self.image_size),
            "corners": self.image_points.tolist(),
            "ids": self.ids.tolist(),
        }


def grey(data: np.ndarray) -> np.ndarray:
    """An 8-bit single-channel copy of an image (BGR(A) or grey, any depth)."""
    import cv2

    a = np.asarray(data)
    if a.ndim == 3:
        a = cv2.cvtColor(a, cv2.COLOR_BGRA2GRAY if a.shape[2] == 4 else cv2.COLOR_BGR2GRAY)
    if a.dtype != np.uint8:
        a = a.astype(np.float64)
        lo, hi = np.nanmin(a), np.nanmax(a)
        a = np.zeros(a.shape, np.uint8) if hi <= lo else ((a - lo) * (255.0 / (hi - lo))).astype(np.uint8)
    return np.ascontiguousarray(a)


def load_images(images: Iterable[Any]) -> list[tuple[str, np.ndarray]]:
    """(name, grey uint8 array) for each path, :class:`Image` or (name, array) pair."""
    from camcmm.api import read

    out = []
    for i, item in enumerate(images):
        if isinstance(item, Image):
            out.append((item.name, grey(item.data)))
        elif isinstance(item, tuple) and len(item) == 2:
            out.append((str(item[0]), grey(item[1])))
        elif isinstance(item, np.ndarray):
            out.append((f"image{i + 1}", grey(item)))
        else:
            img = read(item)
            if not isinstance(img, Image):
                raise InputError(f"{item}: not an image file")
            out.append((img.name, grey(img.data)))
    if not out:
        raise InputError("no images given")
    return out


def detect(
    board: Board | str, name: str, image: np.ndarray, *, detector: str = "auto", subpix_window: int = 5
) -> Detection:
    """Find ``board`` in one grey image.

    Chessboard: ``detector`` "classic" is cv2.findChessboardCorners followed by
    cv2.cornerSubPix with a (2 w + 1)-px window, w = ``subpix_window`` (what OpenCV's own
    test does, w = 5); "sb" is cv2.findChessboardCornersSB alone; "auto" (default) is SB,
    else classic, then cornerSubPix. Why auto: on Bouguet's example the classic detector
    misplaces corners by up to 13 px (RMS 1.2 px) where SB + cornerSubPix gives 0.18 px;
    on OpenCV's samples SB alone misses 3 of 13 views and cornerSubPix lowers its RMS
    from 0.25 to 0.19 px. Circle grids: cv2.findCirclesGrid (dark circles, then light).
    ChArUco: cv2.aruco.CharucoDetector; views with fewer than 6 corners count as not found.
    """
    import cv2

    board = parse_board(board)
    if isinstance(subpix_window, bool) or not isinstance(subpix_window, (int, np.integer)) or subpix_window < 1:
        raise ParameterError(f"subpix window {subpix_window!r} must be a whole number of px, at least 1")
    img = grey(image)
    size = (int(img.shape[1]), int(img.shape[0]))
    det = Detection(name, size)
    objp = board.object_points
    if board.kind == "chessboard":
        if detector not in ("auto", "classic", "sb"):
            raise InputError(f"detector {detector!r}: use auto, classic or sb")
        corners = None
        term = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.1)
        if detector in ("auto", "sb"):
            # the quick pass first; the exhaustive one finds a few more boards at twice the time
            for flags in (cv2.CALIB_CB_NORMALIZE_IMAGE, cv2.CALIB_CB_EXHAUSTIVE):
                ok, c = cv2.findChessboardCornersSB(img, board.pattern_size, flags=flags)
                if ok:
                    corners = c
                    break
        if corners is None and detector in ("auto", "classic"):
            ok, c = cv2.findChessboardCorners(
                img, board.pattern_size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
            )
            corners = c if ok else None
        if corners is not None and detector != "sb":
            if 2 * subpix_window + 5 > min(size):  # cornerSubPix's own limit (it asserts)
                raise ParameterError(
                    f"{name}: subpix window {subpix_window} px is too large for a "
                    f"{size[0]}x{size[1]} px image (at most {(min(size) - 5) // 2} px)"
                )
            corners = cv2.cornerSubPix(img, corners, (subpix_window, subpix_window), (-1, -1), term)
        if corners is None:
            det.reason = f"chessboard {board.cols}x{board.rows} not found"
            return det
        ids = np.arange(len(objp), dtype=np.int32)
        pts = _canonical_order(img, corners.reshape(-1, 2), board)
    elif board.kind in ("circles", "acircles"):
        flag = cv2.CALIB_CB_SYMMETRIC_GRID if board.kind == "circles" else cv2.CALIB_CB_ASYMMETRIC_GRID
        ok, c = cv2.findCirclesGrid(img, board.pattern_size, flags=flag)
        if not ok:  # light circles on a dark ground
            ok, c = cv2.findCirclesGrid(255 - img, board.pattern_size, flags=flag)
        if not ok:
            det.reason = f"{board.kind} grid {board.cols}x{board.rows} not found"
            return det
        ids = np.arange(len(objp), dtype=np.int32)
        pts = c.reshape(-1, 2)
    else:
        cb = board.charuco()
        corners, cids, _, _ = cv2.aruco.CharucoDetector(cb).detectBoard(img)
        if cids is None or len(cids) < 6:
            det.reason = f"ChArUco board {board.cols}x{board.rows} not found (fewer than 6 corners)"
            return det
        ids = cids.ravel().astype(np.int32)
        pts = corners.reshape(-1, 2)
        objp = np.asarray(cb.getChessboardCorners(), np.float32)
    det.image_points = np.ascontiguousarray(pts, np.float32)
    det.object_points = np.ascontiguousarray(objp[ids], np.float32)
    det.ids = ids
    return det


def _canonical_order(img: np.ndarray, pts: np.ndarray, board: Board) -> np.ndarray:
    """Chessboard corners ordered so that the square diagonally outside corner 0 is
    black (the board frame of :attr:`Board.object_points`).

    OpenCV's detectors return either of the two 180-degree-rotated orders; stereo
    calibration needs the same order in both images. Where COLS + ROWS is even the board
    looks the same turned by 180 degrees and the order stays as detected.
    """
    import cv2

    c, r = board.pattern_size
    if (c + r) % 2 == 0 or c < 2 or r < 2:
        return pts

    def outside(k0, k1):  # centre of the square diagonally beyond corner k0 (away from k1)
        p = pts[k0] + 0.5 * (pts[k0] - pts[k1])
        if not (0 <= p[0] < img.shape[1] - 1 and 0 <= p[1] < img.shape[0] - 1):
            return None
        return float(cv2.getRectSubPix(img, (3, 3), (float(p[0]), float(p[1]))).mean())

    first, last = outside(0, c + 1), outside(len(pts) - 1, len(pts) - c - 2)
    if first is not None and last is not None and first > last:
        return np.ascontiguousarray(pts[::-1])
    return pts


def detect_all(
    board: Board | str, images: Iterable[Any], *, detector: str = "auto", subpix_window: int = 5, progress=None
) -> list[Detection]:
    """Detect the board in every image; InputError naming the images when their sizes
    differ (a calibration holds for one sensor format)."""
    board = parse_board(board)
    loaded = load_images(images)
    sizes: dict[tuple[int, int], list[str]] = {}
    for name, img in loaded:
        sizes.setdefault((img.shape[1], img.shape[0]), []).append(name)
    if len(sizes) > 1:
        common = max(sizes, key=lambda s: len(sizes[s]))
        odd = [f"{n} ({w}x{h})" for (w, h), names in sizes.items() if (w, h) != common for n in names]
        raise InputError(
            f"images of mixed sizes: {', '.join(odd[:8])}{' ...' if len(odd) > 8 else ''} "
            f"differ from {common[0]}x{common[1]} px of the others"
        )
    out = []
    for k, (name, img) in enumerate(loaded):
        out.append(detect(board, name, img, detector=detector, subpix_window=subpix_window))
        if progress is not None:
            progress((k + 1) / len(loaded), f"board in {name}")
    return out


def require_found(board: Board, detections: list[Detection], what: str = "images") -> None:
    """InputError naming the images when the board was found in none of them."""
    if any(d.found for d in detections):
        return
    names = [d.name for d in detections]
    shown = ", ".join(names[:6]) + (" ..." if len(names) > 6 else "")
    hint = " (COLSxROWS counts inner corners)" if board.kind == "chessboard" else ""
    raise InputError(
        f"board {board.spec} not found in any of the {len(names)} {what} ({shown}); check the board size{hint}"
    )
