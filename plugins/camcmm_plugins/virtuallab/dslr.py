"""A DSLR-like camera for the turntable series (thesis ch. 4.2: Nikon D3300, 24 MP,
3.9 µm pixels, 60 mm macro lens): geometry, lens blur and sensor.

Geometry (thin lens focused on the turntable's target at magnification M): the object
distance is u = f (1 + 1/M) and the image distance (the pinhole model's principal
distance) v = f (1 + M), so the camera matrix holds v / pitch px. ``downscale`` s renders
an image s times smaller in each direction with pixels s times larger — what binning
the full frame would give — so a 0.3 MP test image sees the same scene as the 24 MP one.

Lens blur: defocus by the thin-lens blur circle (``imaging.blur_diameter`` with the
lens's own focal length f, not v) at the view's depth, plus diffraction, the Airy
disc's Gaussian equivalent σ ≈ 0.42 λ F (1 + M) on the sensor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from camcmm.api import CameraModel

from . import imaging, optics

#: Blur levels: 0.5 px apart up to 2 px, then this ratio apart.
LEVEL_RATIO = 1.2

#: Nikon D3300: 6000 x 4000 px on 23.5 x 15.6 mm.
FULL_SIZE = (6000, 4000)
PIXEL_PITCH = 0.0039  # mm
FOCAL_LENGTH = 60.0  # mm, the macro lens


def defocus(stack: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Blur images ``stack`` (h, w, n) float32 by the per-pixel blur circle ``c`` (h, w) px
    (Gaussian PSF of σ = c/4, as ``imaging.defocus``).

    Written here rather than calling ``imaging.defocus``: that spaces its blur levels
    0.5 px apart over the whole image, and a macro lens at 6 MP has blur circles of ~60 px
    at the sphere's rim — ~120 full-image blurs per frame. Here levels are 0.5 px apart up
    to 2 px and LEVEL_RATIO apart above (σ interpolated within 10 %), and each level is
    blurred only over the box of pixels that use it (plus 3 σ)."""
    import cv2

    cmax = float(np.max(c)) if c.size else 0.0
    if cmax <= 1e-3:
        return stack
    levels = list(np.arange(0.0, min(cmax, 2.0) + 0.5, 0.5))
    while levels[-1] < cmax:
        levels.append(levels[-1] * LEVEL_RATIO)
    lv = np.array(levels)
    k = np.clip(np.searchsorted(lv, c, side="right") - 1, 0, len(lv) - 2)
    a = ((c - lv[k]) / (lv[k + 1] - lv[k])).astype(np.float32)
    out = np.zeros_like(stack)
    h, w = c.shape
    for i, level in enumerate(lv):
        wgt = np.where(k == i, 1 - a, 0).astype(np.float32) + np.where(k + 1 == i, a, 0).astype(np.float32)
        rows, cols = np.flatnonzero(wgt.any(axis=1)), np.flatnonzero(wgt.any(axis=0))
        if not len(rows):
            continue
        pad = int(np.ceil(3 * level / 4)) + 2
        r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, h)
        c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, w)
        sub = stack[r0:r1, c0:c1]
        if level > 1e-6:
            sub = cv2.GaussianBlur(sub, (0, 0), level / 4, borderType=cv2.BORDER_REPLICATE).reshape(sub.shape)
        out[r0:r1, c0:c1] += wgt[r0:r1, c0:c1, None] * sub
    return out


@dataclass
class Dslr:
    """The camera settings; lengths in mm."""

    downscale: float = 1.0
    f_number: float = 8.0
    magnification: float = 0.8
    wavelength_nm: float = 532.0
    focal_length: float = FOCAL_LENGTH
    depth_of_field: bool = True

    def __post_init__(self) -> None:
        if not self.downscale >= 1.0:
            raise ValueError(f"downscale {self.downscale!r} must be >= 1")
        if not 0 < self.magnification <= 5:
            raise ValueError(f"magnification {self.magnification!r} must be in (0, 5]")

    @property
    def size(self) -> tuple[int, int]:
        return (max(16, round(FULL_SIZE[0] / self.downscale)), max(16, round(FULL_SIZE[1] / self.downscale)))

    @property
    def pitch(self) -> float:
        """Pixel pitch (mm) of the rendered (binned) image."""
        return PIXEL_PITCH * FULL_SIZE[0] / self.size[0]

    @property
    def object_distance(self) -> float:
        return self.focal_length * (1.0 + 1.0 / self.magnification)

    @property
    def principal_distance(self) -> float:
        return self.focal_length * (1.0 + self.magnification)

    def camera(self, position, target, name: str = "dslr", up=(0.0, 0.0, 1.0)) -> CameraModel:
        """The pinhole camera at ``position`` looking at ``target`` (world mm)."""
        R, t = optics.look_at(position, target, up)
        K = optics.intrinsics(self.principal_distance, self.pitch, self.size)
        return CameraModel(K, np.zeros(5), R, t, self.size, self.pitch, name)

    def blur(self, imgs, depth: np.ndarray) -> list[np.ndarray]:
        """Defocus at the depth map (focused at the object distance) and diffraction, of
        one or several radiance images (h, w) of the same view."""
        import cv2

        stack: np.ndarray = np.dstack([np.asarray(i, np.float32) for i in (imgs if isinstance(imgs, list) else [imgs])])
        if self.depth_of_field:
            d = np.where(np.isfinite(depth), depth, self.object_distance)  # nothing hit: dark anyway
            c = imaging.blur_diameter(d, self.focal_length, self.f_number, self.object_distance, self.pitch)
            stack = defocus(stack, c)
        sigma = 0.42 * self.wavelength_nm * 1e-6 * self.f_number * (1.0 + self.magnification) / self.pitch
        if sigma > 0.05:
            stack = cv2.GaussianBlur(stack, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
        stack = stack.reshape(*stack.shape[:2], -1)
        return [stack[..., i].astype(np.float64) for i in range(stack.shape[2])]

    def describe(self) -> dict:
        w, h = self.size
        return {
            "model": "DSLR (Nikon D3300 class)",
            "full_size": list(FULL_SIZE),
            "full_pixel_pitch": PIXEL_PITCH,
            "downscale": float(self.downscale),
            "width": w,
            "height": h,
            "pixel_pitch": self.pitch,
            "focal_length": self.focal_length,
            "principal_distance": self.principal_distance,
            "object_distance": self.object_distance,
            "magnification": self.magnification,
            "f_number": self.f_number,
        }
