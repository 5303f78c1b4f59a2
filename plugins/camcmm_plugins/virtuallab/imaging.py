"""From radiance to a digital image: defocus blur, sensor noise, quantisation.

Defocus (thin lens): a point at depth Z (mm) seen through a lens of focal length f
focused at s_f with f-number N is spread into a blur circle of diameter

    c = f² |Z - s_f| / (N Z (s_f - f))          (on the sensor, mm; / pixel pitch -> px)

The PSF is a disc of that diameter or a Gaussian of the same second moment
(σ = c / 4). The blur varies with depth, so the image is blurred at a few levels of c
(0.5 px apart) and each pixel interpolates between the two levels its own depth
falls between — exact where the depth is locally constant, an approximation across
depth steps (the silhouette of an artefact against a far background).

Sensor: the radiance (1.0 = full well) times ``exposure`` gives electrons
e = exposure · L · full_well; shot noise is Poisson(e), read noise normal with σ
``read_noise`` (electrons); the digital number is round(e (2^bits − 1) / full_well +
black_level), clipped to 0 .. 2^bits − 1 (saturation). ``shot_noise`` False keeps
the mean photon count (read noise alone).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: Spacing (px) of the blur levels.
LEVEL_STEP = 0.5


@dataclass
class Lens:
    """Depth of field of a camera: ``f_number`` None means a pinhole (no defocus);
    ``focus_distance`` (mm along the optical axis); ``psf`` 'gaussian' or 'disc';
    ``blur`` an extra constant Gaussian σ (px) of the optics."""

    f_number: float | None = None
    focus_distance: float | None = None
    psf: str = "gaussian"
    blur: float = 0.0


@dataclass
class Sensor:
    bits: int = 8
    full_well: float = 20000.0  # electrons at 1.0 radiance
    read_noise: float = 10.0  # electrons (standard deviation)
    shot_noise: bool = True
    exposure: float = 1.0
    black_level: float = 0.0  # DN

    @property
    def max_dn(self) -> int:
        return (1 << int(self.bits)) - 1


def blur_diameter(
    depth: np.ndarray, focal_length: float, f_number: float, focus_distance: float, pixel_pitch: float
) -> np.ndarray:
    """Blur circle diameter (px) at camera depths ``depth`` (mm) (thin lens, see above)."""
    f, sf = focal_length, focus_distance
    with np.errstate(invalid="ignore", divide="ignore"):
        c = f * f * np.abs(depth - sf) / (f_number * depth * (sf - f))
    return np.where(np.isfinite(c), c, 0.0) / pixel_pitch


def _kernel(diameter: float, psf: str) -> np.ndarray | None:
    if diameter <= 1e-6:
        return None
    if psf == "gaussian":
        return None
    r = diameter / 2
    n = int(np.ceil(r + 1))
    o = 8  # 8 x 8 samples per kernel pixel: a smooth disc edge
    g = (np.arange(-n * o, (n + 1) * o) + 0.5) / o - 0.5
    X, Y = np.meshgrid(g, g)
    fine = (X * X + Y * Y <= r * r).astype(float)
    k = fine.reshape(2 * n + 1, o, 2 * n + 1, o).sum(axis=(1, 3))
    return k / k.sum()


def _blur(img: np.ndarray, diameter: float, psf: str) -> np.ndarray:
    if diameter <= 1e-6:
        return img
    if psf == "gaussian":
        return cv2.GaussianBlur(img, (0, 0), diameter / 4.0, borderType=cv2.BORDER_REPLICATE)
    kernel = _kernel(diameter, psf)
    assert kernel is not None  # None only for the cases returned above
    return cv2.filter2D(img, -1, kernel, borderType=cv2.BORDER_REPLICATE)


def defocus(img: np.ndarray, diameter: np.ndarray | float, psf: str = "gaussian") -> np.ndarray:
    """Blur ``img`` (h, w) by a per-pixel blur diameter (px, array (h, w) or scalar)."""
    img = np.asarray(img, np.float64)
    if np.isscalar(diameter) or np.ndim(diameter) == 0:
        return _blur(img, float(diameter), psf)
    c = np.asarray(diameter, float)
    cmax = float(np.nanmax(c)) if np.isfinite(c).any() else 0.0
    if cmax <= 1e-6:
        return img.copy()
    n = int(np.ceil(cmax / LEVEL_STEP))
    levels = np.linspace(0.0, n * LEVEL_STEP, n + 1)
    c = np.clip(np.nan_to_num(c, nan=0.0), 0, levels[-1])
    k = np.minimum((c / LEVEL_STEP).astype(int), n - 1)
    a = (c - levels[k]) / LEVEL_STEP
    out = np.zeros_like(img)
    for i, lv in enumerate(levels):
        wgt = np.where(k == i, 1 - a, 0.0) + np.where(k + 1 == i, a, 0.0)
        if np.any(wgt > 0):
            out += wgt * _blur(img, lv, psf)
    return out


def optics(img: np.ndarray, depth: np.ndarray, camera, lens: Lens) -> np.ndarray:
    """Apply the lens's defocus for the view's depth map and its extra blur."""
    out = img
    if lens.f_number:
        if not camera.pixel_pitch:
            raise ValueError(f"camera {camera.name!r}: defocus needs its pixel_pitch (mm)")
        f = camera.camera_matrix[0, 0] * camera.pixel_pitch
        sf = lens.focus_distance or float(np.nanmedian(depth))
        d = np.where(np.isfinite(depth), depth, sf)  # nothing hit: as if in focus (it is dark)
        out = defocus(out, blur_diameter(d, f, lens.f_number, sf, camera.pixel_pitch), lens.psf)
    if lens.blur > 0:
        out = cv2.GaussianBlur(out, (0, 0), lens.blur, borderType=cv2.BORDER_REPLICATE)
    return out


def expose(radiance: np.ndarray, sensor: Sensor, rng: np.random.Generator | None) -> np.ndarray:
    """Digital image (uint8 for <= 8 bits, else uint16) of a radiance image; ``rng``
    None: no noise (the expected signal, rounded)."""
    e = np.clip(radiance, 0, None) * sensor.exposure
    fw = float(sensor.full_well)
    if not fw > 0:
        raise ValueError(f"sensor full_well {fw!r} must be > 0 electrons")
    if rng is not None and sensor.shot_noise:
        e = rng.poisson(e * fw) / fw
    if rng is not None and sensor.read_noise > 0:
        e = e + rng.normal(0.0, sensor.read_noise / fw, e.shape)
    dn = np.rint(e * sensor.max_dn + sensor.black_level)
    dt = np.uint8 if sensor.bits <= 8 else np.uint16
    return np.clip(dn, 0, sensor.max_dn).astype(dt)
