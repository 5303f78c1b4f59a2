"""Step 4 (thesis eq. 6.1): the 2-D similarity between the CSI map and the cloud's
plane, u = s·R(θ)·x + t, by least squares on the inlier matches."""

from __future__ import annotations

import numpy as np


def fit_similarity(a: np.ndarray, b: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Least-squares 2-D similarity b ≈ s·R(θ)·a + t (closed form, Umeyama 1991).

    Parameters
    ----------
    a, b : (m, 2) corresponding points (any one length unit for each side)

    Returns
    -------
    s : scale (unit of b per unit of a), theta : angle in rad (counter-clockwise),
    t : (2,) translation in b's unit
    """
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    a0, b0 = a - ca, b - cb
    # complex-number form: b0 = (s e^{iθ}) a0
    za = a0[:, 0] + 1j * a0[:, 1]
    zb = b0[:, 0] + 1j * b0[:, 1]
    k = np.vdot(za, zb) / np.vdot(za, za).real
    s, theta = float(abs(k)), float(np.angle(k))
    t = cb - s * rot(theta) @ ca
    return s, theta, t


def rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def apply(s: float, theta: float, t: np.ndarray, a: np.ndarray) -> np.ndarray:
    return s * a @ rot(theta).T + t


def robust_fit(a: np.ndarray, b: np.ndarray, threshold: float, rounds: int = 3):
    """fit_similarity, then refits without matches whose residual exceeds ``threshold``
    (b's unit): fundamental-matrix inliers may still hold matches off the plane's
    similarity (an epipolar line is a whole line)."""
    keep = np.ones(len(a), bool)
    for _ in range(rounds):
        s, th, t = fit_similarity(a[keep], b[keep])
        r = np.linalg.norm(apply(s, th, t, a) - b, axis=1)
        new = r <= threshold
        if new.sum() < 3 or np.array_equal(new, keep):
            break
        keep = new
    return s, th, t, keep


def refine_ecc(csi_img, photo_img, photo_mask, a_px: np.ndarray, t_px: np.ndarray, iterations: int = 200):
    """Refines the SIFT similarity by direct image alignment (OpenCV's enhanced correlation
    coefficient, Evangelidis & Psarakis 2008) over the whole CSI image: SIFT keypoints are
    few on a blurred image and each is localised to a fraction of a pixel only, the
    correlation of all pixels is localised far better. The ECC is invariant to the two
    images' different contrast and brightness.

    Parameters
    ----------
    a_px : (2, 2) and t_px : (2,), the initial map CSI px -> photo px

    Returns
    -------
    (2, 3) affine CSI px -> photo px, or None when the ECC fails
    """
    import cv2

    warp = np.hstack([a_px, t_px[:, None]]).astype(np.float32)
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iterations, 1e-7)
    try:
        _, warp = cv2.findTransformECC(
            csi_img.astype(np.float32),
            photo_img.astype(np.float32),
            warp,
            cv2.MOTION_AFFINE,
            crit,
            photo_mask.astype(np.uint8),
            1,
        )
    except cv2.error:
        return None
    return warp.astype(np.float64)
