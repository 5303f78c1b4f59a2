"""Synthetic calibration data with known truth: board images rendered through a known
camera (for detection and calibration tests, demos and the virtual lab) and exact
projections of board points.

:func:`render_view` draws the board's texture into the image the way the camera model
forms it: each pixel (``supersample`` x ``supersample`` sub-pixels) is undistorted to a
ray (cv2.undistortPoints), the ray meets the board plane (the inverse homography of
[r1 r2 t]) and the board's texture is sampled there; the sub-pixels are averaged.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .boards import Board, parse_board


def board_texture(board: Board | str, px_per_mm: float) -> tuple[np.ndarray, tuple[float, float]]:
    """(texture uint8 (H, W), (x0, y0) mm of its top-left corner in the board frame)."""
    import cv2

    board = parse_board(board)
    s = board.square
    if board.kind == "charuco":
        w_mm, h_mm = board.cols * s, board.rows * s
        size = (int(round(w_mm * px_per_mm)), int(round(h_mm * px_per_mm)))
        inner = board.charuco().generateImage(size, marginSize=0, borderBits=1)
        m = int(round(s * px_per_mm))
        tex = cv2.copyMakeBorder(inner, m, m, m, m, cv2.BORDER_CONSTANT, value=255)
        return tex, (-s, -s)
    pts = board.object_points[:, :2].astype(np.float64)
    lo, hi = pts.min(0) - 2 * s, pts.max(0) + 2 * s
    w, h = (int(np.ceil((hi - lo)[0] * px_per_mm)), int(np.ceil((hi - lo)[1] * px_per_mm)))
    ys, xs = np.mgrid[0:h, 0:w]
    x = lo[0] + (xs + 0.5) / px_per_mm
    y = lo[1] + (ys + 0.5) / px_per_mm
    tex = np.full((h, w), 255, np.uint8)
    if board.kind == "chessboard":
        inside = (x > -s) & (x < board.cols * s) & (y > -s) & (y < board.rows * s)
        black = (np.floor(x / s) + np.floor(y / s)) % 2 == 0
        tex[inside & black] = 0
    else:
        r = (0.3 if board.kind == "circles" else 0.35) * s
        for cx, cy in pts:
            tex[(x - cx) ** 2 + (y - cy) ** 2 < r * r] = 0
    return tex, (float(lo[0]), float(lo[1]))


@lru_cache(maxsize=4)
def _rays(K: tuple, dist: tuple, size: tuple[int, int], ss: int) -> np.ndarray:
    import cv2

    w, h = size
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys, xs = np.mgrid[0 : h * ss, 0 : w * ss].astype(np.float64)
    u = np.floor(xs / ss) + off[(xs % ss).astype(int)]
    v = np.floor(ys / ss) + off[(ys % ss).astype(int)]
    pts = np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2)
    n = cv2.undistortPoints(
        pts,
        np.array(K).reshape(3, 3),
        np.array(dist),
        criteria=(cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 50, 1e-12),
    )
    return n.reshape(h * ss, w * ss, 2)


def render_view(
    board: Board | str,
    camera_matrix,
    dist_coeffs,
    rvec,
    tvec,
    image_size: tuple[int, int],
    *,
    supersample: int = 4,
    blur: float = 0.0,
    noise: float = 0.0,
    background: int = 128,
    seed: int | None = None,
    px_per_mm: float | None = None,
) -> np.ndarray:
    """A grey uint8 (H, W) image of ``board`` at pose (rvec, tvec: board -> camera, mm)
    seen by the camera (K, dist); ``blur``: Gaussian sigma px; ``noise``: grey-level sigma."""
    import cv2

    board = parse_board(board)
    K = np.asarray(camera_matrix, np.float64)
    dist = np.asarray(dist_coeffs, np.float64).ravel()
    w, h = int(image_size[0]), int(image_size[1])
    rays = _rays(tuple(K.ravel()), tuple(dist), (w, h), int(supersample))
    R = cv2.Rodrigues(np.asarray(rvec, np.float64).ravel())[0]
    H = np.column_stack([R[:, 0], R[:, 1], np.asarray(tvec, np.float64).ravel()])
    Hi = np.linalg.inv(H)
    x, y = rays[..., 0], rays[..., 1]
    a = Hi[0, 0] * x + Hi[0, 1] * y + Hi[0, 2]
    b = Hi[1, 0] * x + Hi[1, 1] * y + Hi[1, 2]
    c = Hi[2, 0] * x + Hi[2, 1] * y + Hi[2, 2]
    if px_per_mm is None:
        px_per_mm = 12.0 / board.square * 4
    tex, (x0, y0) = board_texture(board, px_per_mm)
    with np.errstate(divide="ignore", invalid="ignore"):
        mx = ((a / c - x0) * px_per_mm - 0.5).astype(np.float32)
        my = ((b / c - y0) * px_per_mm - 0.5).astype(np.float32)
    behind = ~(c > 0)
    mx[behind] = -1e6
    my[behind] = -1e6
    big = cv2.remap(tex, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=background)
    img = cv2.resize(big.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    if blur > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise > 0:
        img = img + np.random.default_rng(seed).normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def look_at_poses(
    n: int, distance: float, board: Board | str, *, tilt_deg: float = 30.0, seed: int = 0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` board poses (rvec, tvec) with the board centre about ``distance`` mm in
    front of the camera, tilted up to ``tilt_deg`` about random in-plane axes."""
    import cv2

    board = parse_board(board)
    rng = np.random.default_rng(seed)
    centre = board.object_points.mean(0).astype(np.float64)
    span = np.ptp(board.object_points[:, :2], axis=0).max()
    out = []
    for _ in range(n):
        axis = rng.normal(size=3)
        axis[2] *= 0.3
        axis /= np.linalg.norm(axis)
        rvec = axis * np.deg2rad(rng.uniform(0.3, 1.0) * tilt_deg)
        R = cv2.Rodrigues(rvec)[0]
        shift = np.array([*rng.uniform(-0.25, 0.25, 2) * span, distance * rng.uniform(0.9, 1.1)])
        out.append((rvec, shift - R @ centre))
    return out


def project(board: Board | str, camera_matrix, dist_coeffs, rvec, tvec) -> np.ndarray:
    """(N, 2) exact pixel projections of the board's points (OpenCV's model)."""
    import cv2

    board = parse_board(board)
    q, _ = cv2.projectPoints(
        board.object_points.astype(np.float64),
        np.asarray(rvec, float).ravel(),
        np.asarray(tvec, float).ravel(),
        np.asarray(camera_matrix, float),
        np.asarray(dist_coeffs, float).ravel(),
    )
    return q.reshape(-1, 2)
