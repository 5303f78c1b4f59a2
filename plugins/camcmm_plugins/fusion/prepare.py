"""Step 2 (thesis ch. 6.1): both grey images — the CSI's intensity (or a shaded height
image when the file has none) — contrast-stretched and blurred with a Gaussian so that only
the bandwidth both data sets share remains (σ = 6 px of the cloud's image in the thesis)."""

from __future__ import annotations

import cv2
import numpy as np


def normalised_blur(values: np.ndarray, weight: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian normalised convolution (values are weighted sums): holes are filled from
    their neighbours, NaN where nothing is within ~3σ."""
    if sigma > 0:
        k = int(2 * np.ceil(3 * sigma) + 1)
        values = cv2.GaussianBlur(values, (k, k), sigma, borderType=cv2.BORDER_CONSTANT)
        weight = cv2.GaussianBlur(weight, (k, k), sigma, borderType=cv2.BORDER_CONSTANT)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = values / weight
    out[weight < 1e-3 * max(float(weight.max()), 1e-300)] = np.nan
    return out


def stretch(img: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """Contrast stretch to uint8 between the 0.5 and 99.5 % percentiles of the valid pixels
    (0 elsewhere)."""
    ok = np.isfinite(img) if valid is None else valid & np.isfinite(img)
    if not ok.any():
        return np.zeros(img.shape, np.uint8)
    lo, hi = np.percentile(img[ok], [0.5, 99.5])
    out = np.clip((img - lo) / max(hi - lo, 1e-12) * 255.0, 0, 255)
    out[~ok] = 0
    return out.astype(np.uint8)


def shade(heights: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """The grey image of a height grid without intensity: its curvature (the Laplacian of the
    heights). Unlike a relief shaded by a light from one side it does not change when the map
    is turned in its plane or tilted, so the cloud's and the map's agree in any pose. NaN
    stays NaN."""
    gy, gx = np.gradient(heights, dy, dx)
    return np.gradient(gx, dx, axis=1) + np.gradient(gy, dy, axis=0)


def csi_image(
    heights: np.ndarray,
    intensity: np.ndarray | None,
    dx: float,
    dy: float,
    pixel: float,
    sigma_mm: float,
) -> tuple[np.ndarray, np.ndarray, float]:
    """The CSI map's grey image resampled to ``pixel`` mm and blurred by ``sigma_mm``.

    Parameters
    ----------
    heights : (ny, nx) mm, NaN invalid
    intensity : (ny, nx) or None (then a shaded height image)
    dx, dy : lateral steps, mm
    pixel : the working pixel (mm) of the returned image: pixel (j, i) lies at map
        position (j·pixel, i·pixel) from heights[0, 0]
    sigma_mm : the Gaussian blur, mm

    Returns
    -------
    image : uint8 grey, valid : bool mask, pixel (mm)
    """
    valid = np.isfinite(heights)
    if intensity is not None:
        g = np.where(valid & np.isfinite(intensity), intensity, np.nan)
    else:
        g = shade(heights, dx, dy)
    ok = np.isfinite(g)
    src: np.ndarray = np.where(ok, g, 0.0)
    w: np.ndarray = ok.astype(np.float64)
    # an anti-alias blur on the full grid before resampling, the rest after
    pre = 0.5 * pixel / min(dx, dy)
    if pre > 0.5:
        k = int(2 * np.ceil(3 * pre) + 1)
        src = cv2.GaussianBlur(src, (k, k), pre, borderType=cv2.BORDER_CONSTANT)
        w = cv2.GaussianBlur(w, (k, k), pre, borderType=cv2.BORDER_CONSTANT)
    ny, nx = heights.shape
    mx = int(np.floor((nx - 1) * dx / pixel)) + 1
    my = int(np.floor((ny - 1) * dy / pixel)) + 1
    jj, ii = np.meshgrid(np.arange(mx) * pixel / dx, np.arange(my) * pixel / dy)
    maps = (jj.astype(np.float32), ii.astype(np.float32))
    src = cv2.remap(src, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    w = cv2.remap(w, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    vmask = cv2.remap(ok.astype(np.float32), *maps, cv2.INTER_NEAREST) > 0.5
    rest = np.sqrt(max(sigma_mm**2 - (0.5 * pixel) ** 2 * (pre > 0.5), 0.0)) / pixel
    img = normalised_blur(src, w, rest)
    return stretch(img, vmask), vmask, pixel
