"""Step 3 (thesis ch. 6.1): SIFT matching of the two grey images and the rejection of
false matches — the thesis's fundamental-matrix RANSAC, and the RANSAC 2-D similarity
(the geometrically correct model for two views of one plane), both counted."""

from __future__ import annotations

import cv2
import numpy as np


def features(img: np.ndarray, mask: np.ndarray):
    """SIFT keypoints (k, 2) px (x along columns) and descriptors of a uint8 image."""
    sift = cv2.SIFT_create()  # type: ignore[attr-defined]  # not in cv2's stubs
    kp, desc = sift.detectAndCompute(img, mask.astype(np.uint8) * 255)
    return np.array([k.pt for k in kp], dtype=np.float64).reshape(-1, 2), desc


def match_features(fa, fb, ratio: float = 0.8):
    """Matches of two feature sets after Lowe's ratio test: pa, pb (m, 2) px."""
    (ka, da), (kb, db) = fa, fb
    if da is None or db is None or len(ka) < 2 or len(kb) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    knn = cv2.BFMatcher(cv2.NORM_L2).knnMatch(da, db, k=2)
    good = [m[0] for m in knn if len(m) == 2 and m[0].distance < ratio * m[1].distance]
    return ka[[m.queryIdx for m in good]].reshape(-1, 2), kb[[m.trainIdx for m in good]].reshape(-1, 2)


def sift_matches(img_a: np.ndarray, mask_a: np.ndarray, img_b: np.ndarray, mask_b: np.ndarray, ratio: float = 0.8):
    """SIFT keypoints of two uint8 images and their matches after Lowe's ratio test.

    Returns
    -------
    pa, pb : (m, 2) float px (x along columns, y along rows) of the matched keypoints
    """
    return match_features(features(img_a, mask_a), features(img_b, mask_b), ratio)


def reject(src: np.ndarray, dst: np.ndarray, threshold: float, seed: int = 0) -> dict:
    """Both RANSAC rejections of matches src -> dst (px; threshold in dst px).

    Returns
    -------
    dict with ``similarity`` and ``fundamental``: (m,) bool inlier masks (all False when
    too few matches for the model).
    """
    m = len(src)
    out = {"similarity": np.zeros(m, bool), "fundamental": np.zeros(m, bool)}
    if m >= 3:
        cv2.setRNGSeed(int(seed))
        a, inl = cv2.estimateAffinePartial2D(
            src.astype(np.float32),
            dst.astype(np.float32),
            method=cv2.RANSAC,
            ransacReprojThreshold=float(threshold),
            maxIters=5000,
            confidence=0.999,
        )
        if a is not None:
            out["similarity"] = inl.ravel().astype(bool)
    if m >= 8:
        cv2.setRNGSeed(int(seed))
        f, inl = cv2.findFundamentalMat(src, dst, cv2.FM_RANSAC, float(threshold), 0.999)
        if f is not None and inl is not None:
            out["fundamental"] = inl.ravel().astype(bool)
    return out
