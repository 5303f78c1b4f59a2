"""Systematic distortion of the measuring volume (thesis ch. 3.3.1, 3.3.2, 5.4.2).

The thesis shows that systematic offsets in a stereo system's parameters distort the
measuring volume: "spatial offsets, differences in scale factor for each axis and
non-linear distortions" (figs. 3.5–3.8), seen in the interferometer comparison as "a
highly repeatable pattern in the displacement data" (fig. 3.11), and in the acceptance
test as a local scale factor that varies through the volume (ch. 5.4.2: sphere sizes
vary with position more than ball-bar lengths, which average over it).

The model maps a true point x (mm) to the measured point

    d  = x - c
    x' = c + offset + d (1 + scale + quadratic |d|²/R²) + axis_scale * d
             + amplitude * sin(2π (k_i · d) / wavelength + φ_i)   (per axis i)

c is the volume centre, R the half-diagonal of the volume. ``scale`` is a global scale
error, ``axis_scale`` the per-axis differences, ``quadratic`` a radial term (the local
scale grows by 3·quadratic at distance R), and the periodic term a repeatable pattern
whose local scale amplitude is 2π·amplitude/wavelength while its length error stays
within 2·amplitude — long lengths average it out, as the thesis observed. The k_i are
fixed unit vectors so that, e.g., the z displacement varies across a horizontal flat
(the structured flatness deviations of thesis fig. 5.6).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

_K = np.array([[1.0, 0.6, 0.2], [0.5, 1.0, -0.3], [0.7, -0.6, 0.4]])
K = _K / np.linalg.norm(_K, axis=1, keepdims=True)
PHASE = np.array([0.0, 1.1, 2.3])


@dataclass
class VolumeDistortion:
    """Parameters as in the module docstring; all zero is the identity."""

    scale: float = 0.0
    axis_scale: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quadratic: float = 0.0
    amplitude: float = 0.0
    wavelength: float = 40.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference_radius: float = 100.0

    def __post_init__(self) -> None:
        self.axis_scale = np.asarray(self.axis_scale, dtype=float).reshape(3)
        self.offset = np.asarray(self.offset, dtype=float).reshape(3)
        self.center = np.asarray(self.center, dtype=float).reshape(3)

    @property
    def is_identity(self) -> bool:
        return not (self.scale or self.quadratic or self.amplitude or self.axis_scale.any() or self.offset.any())

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Distorted copy of points (N, 3) or one point (3,), mm."""
        x = np.asarray(x, dtype=float)
        if self.is_identity:
            return x.copy()
        single = x.ndim == 1
        d = np.atleast_2d(x) - self.center
        rho2 = np.einsum("ij,ij->i", d, d) / self.reference_radius**2
        out = self.center + self.offset + d * (1 + self.scale + self.quadratic * rho2)[:, None] + d * self.axis_scale
        if self.amplitude:
            out += self.amplitude * np.sin(2 * np.pi * (d @ K.T) / self.wavelength + PHASE)
        return out[0] if single else out

    def to_dict(self) -> dict:
        return {
            "scale": self.scale,
            "axis_scale": self.axis_scale.tolist(),
            "quadratic": self.quadratic,
            "amplitude": self.amplitude,
            "wavelength": self.wavelength,
            "offset": self.offset.tolist(),
            "center": self.center.tolist(),
            "reference_radius": self.reference_radius,
        }
