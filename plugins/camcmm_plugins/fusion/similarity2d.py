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

    warp: np.ndarray = np.hstack([a_px, t_px[:, None]]).astype(np.float32)
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


def refine(cimg, ph, hm, pc, s, th, tr, ransac_px, sigma_c):
    """ECC refinement of the similarity (mm form, eq. 6.1), accepted when it stays within
    the RANSAC threshold of SIFT's at the map's corners."""
    p, o_ph, o_map = ph["pixel"], ph["origin"], np.asarray(hm.origin)
    a_px = s * pc / p * rot(th)
    t_px = (s * rot(th) @ o_map + tr - o_ph) / p
    # (OpenCV's ECC masks the photo image; the CSI image's holes are filled by step 2)
    import cv2

    mask = cv2.erode(ph["mask"].astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    # the CSI image's border (about 3σ wide) is blurred from its inside only, which pulls
    # its pattern inwards (a scale bias of ~1 % over the whole image): correlate without it
    m = int(np.ceil(3 * sigma_c))
    if min(cimg.shape) - 2 * m < 32:
        return s, th, tr, False
    warp = refine_ecc(cimg[m:-m, m:-m], ph["image"], mask, a_px, t_px + a_px @ [m, m])
    if warp is None:
        return s, th, tr, False
    warp[:, 2] -= warp[:, :2] @ [m, m]
    jj, ii = np.meshgrid(np.arange(m, cimg.shape[1] - m, 4), np.arange(m, cimg.shape[0] - m, 4))
    src = np.column_stack([jj.ravel(), ii.ravel()]).astype(float)
    dst = src @ warp[:, :2].T + warp[:, 2]
    s2, th2, tr2 = fit_similarity(src * pc + o_map, dst * p + o_ph)
    corners = np.array([[0, 0], [cimg.shape[1], 0], [0, cimg.shape[0]], cimg.shape[::-1]], float) * pc + o_map
    moved = np.linalg.norm(apply(s2, th2, tr2, corners) - apply(s, th, tr, corners), axis=1).max() / p
    if moved > ransac_px:
        return s, th, tr, False
    return s2, th2, tr2, True
