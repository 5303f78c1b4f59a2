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

#: Nikon D3300: 6000 x 4000 px on 23.5 x 15.6 mm.
FULL_SIZE = (6000, 4000)
PIXEL_PITCH = 0.0039  # mm
FOCAL_LENGTH = 60.0  # mm, the macro lens


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

    def blur(self, img: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Defocus at the depth map (focused at the object distance) and diffraction."""
        out = np.asarray(img, float)
        if self.depth_of_field:
            d = np.where(np.isfinite(depth), depth, self.object_distance)  # nothing hit: dark anyway
            c = imaging.blur_diameter(d, self.focal_length, self.f_number, self.object_distance, self.pitch)
            out = imaging.defocus(out, c)
        sigma = 0.42 * self.wavelength_nm * 1e-6 * self.f_number * (1.0 + self.magnification) / self.pitch
        if sigma > 0.05:
            import cv2

            out = cv2.GaussianBlur(out, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
        return out

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
