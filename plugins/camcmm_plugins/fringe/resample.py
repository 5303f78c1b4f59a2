"""Resampling decoded maps at sub-pixel positions (for the rectification of
:mod:`.reconstruct`).

    bilinear(img, mx, my, curvature=None)  -> img at (mx, my), float32 (NaN invalid)
    second_differences(img, jump)          -> complex64 f_xx + 1j f_yy, for the curvature correction
    gradient_scale(img)                    -> median step between neighbouring pixels
    sample_at(imgs, maps, ys, xs)          -> images at rectified positions

Pixel coordinates with centres at integers (OpenCV); maps (H, W) with NaN where invalid.
"""

from __future__ import annotations

import numpy as np


def bilinear(img: np.ndarray, mx: np.ndarray, my: np.ndarray, curvature: np.ndarray | None = None) -> np.ndarray:
    """img sampled at (mx, my) (px, any shape) with exact bilinear weights, float32.

    NaN outside the image or next to an invalid (NaN) sample. Written out because
    cv2.remap quantises the weights to 1/32 px, which biases a steep phase map by up to
    0.04 px of projector coordinate (tens of micrometres after triangulation).

    With ``curvature`` (:func:`second_differences` of img) the bilinear value is corrected
    for the field's curvature: bilinear interpolation of f exceeds it by
    ``f_xx fx (1 - fx) / 2 + f_yy fy (1 - fy) / 2`` (the chord above a convex field; the
    cross term it reproduces), a bias of one sign wherever the field bends one way, such
    as the phase across a sphere. With the second differences of the nearest pixel the
    interpolation is exact for quadratic fields (error third order in the pixel size, as
    a bicubic's, from 6 samples instead of 16); NaN where those second differences are.
    """
    h, w = img.shape
    x0 = np.floor(mx)
    y0 = np.floor(my)
    fx = (mx - x0).astype(np.float32)
    fy = (my - y0).astype(np.float32)
    xi = x0.astype(np.int64)
    yi = y0.astype(np.int64)
    inside = (xi >= 0) & (xi < w - 1) & (yi >= 0) & (yi < h - 1)
    i = np.where(inside, yi * w + xi, 0)
    flat = np.ascontiguousarray(img, dtype=np.float32).ravel()
    a = flat[i]
    b = flat[i + 1]
    c = flat[i + w]
    d = flat[i + w + 1]
    # a + fx (b - a) + fy ((c - a) + fx (d - c - b + a)), in place
    d -= c
    d -= b
    d += a
    d *= fx
    c -= a
    c += d
    c *= fy
    b -= a
    b *= fx
    a += b
    a += c
    if curvature is not None:
        i += fx >= 0.5
        i += np.where(fy >= 0.5, w, 0)
        k = curvature.ravel()[i]  # (f_xx + 1j f_yy) of the nearest pixel: one gather for both
        fx *= fx - 1  # -fx (1 - fx)
        fy *= fy - 1
        fx *= k.real
        fy *= k.imag
        fx += fy
        fx *= 0.5
        a += fx
    a[~inside] = np.nan
    return a


def second_differences(img: np.ndarray, jump: float) -> np.ndarray:
    """Second differences of a map along x and y as one complex64 (H, W) array
    ``f_xx + 1j f_yy`` (units of img per px^2), for :func:`bilinear`'s curvature correction.

    NaN on the image border, next to an invalid sample, and where either exceeds ``jump``
    (units of img): there the map is not smooth (a depth edge, where the samples mix two
    surfaces), and a sample near it is dropped rather than corrected with it. (Averaging
    them over a neighbourhood would lower their noise, but biases the correction where
    the curvature itself changes fast, towards a sphere's outline: +0.6 um on the
    diameter of the virtual lab's 20 mm sphere.)
    """
    f = np.ascontiguousarray(img, dtype=np.float32)
    nan = np.complex64(complex(np.nan, np.nan))  # np.nan as complex is nan+0j
    out = np.full(f.shape, nan)
    v = out.view(np.float32).reshape(f.shape + (2,))  # (f_xx, f_yy) channels, a view into out
    re, im = v[..., 0], v[..., 1]
    re[:, 1:-1] = f[:, :-2]
    re[:, 1:-1] += f[:, 2:]
    re[:, 1:-1] -= 2 * f[:, 1:-1]
    im[1:-1] = f[:-2]
    im[1:-1] += f[2:]
    im[1:-1] -= 2 * f[1:-1]
    with np.errstate(invalid="ignore"):
        rough = ~((np.abs(re) <= jump) & (np.abs(im) <= jump))  # NaN counts as rough
    out[rough] = nan
    return out


def gradient_scale(img: np.ndarray, every: int = 16) -> float:
    """Median absolute step of a map between neighbouring pixels along its steeper image
    axis (units of img per px), from every ``every``-th row and column."""
    import warnings

    with warnings.catch_warnings(), np.errstate(invalid="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN map has no scale (0)
        steps = [
            np.nanmedian(np.abs(np.diff(img[::every], axis=1))),
            np.nanmedian(np.abs(np.diff(img[:, ::every], axis=0))),
        ]
    return float(np.nan_to_num(max(steps)))


def sample_at(imgs, maps, ys, xs):
    """Images at rectified positions (xs float, ys int rows of ``maps``): the
    rectification map is linear between neighbouring columns, the images are sampled
    bilinearly there."""
    w = maps[0].shape[1]
    x0 = np.clip(np.floor(xs).astype(np.int64), 0, w - 2)
    f = (xs - x0).astype(np.float32)
    i = ys * w + x0
    mx, my = maps[0].ravel(), maps[1].ravel()
    px = mx[i] + (mx[i + 1] - mx[i]) * f
    py = my[i] + (my[i + 1] - my[i]) * f
    return [bilinear(img, px, py) for img in imgs]
