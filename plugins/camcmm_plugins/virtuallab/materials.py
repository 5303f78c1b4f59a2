"""Surface materials of the AM artefacts (thesis ch. 6.2): what texture a camera sees.

Each material is a mean albedo, a solid texture (a factor on the albedo evaluated at the
world point, so it stays fixed on the part as the table turns) and a subsurface blur of
the projected light (translucency):

* ``nylon12`` — polymer powder bed fusion: white, translucent, little texture (value
  noise of 0.6 mm cells, ±15 %, std ~4 %: with ±3 % SfM found no model without speckle,
  with ±15 % it registers all 30 views, as the thesis's nylon parts were reconstructed
  without speckle); light entering the surface spreads ~0.3 mm below it, which blurs the
  projected speckle (``subsurface_mm``: Gaussian σ of that spread);
* ``abs`` — material extrusion: visible layer tracks: 0.2 mm layers on the walls and
  0.45 mm raster tracks on the top faces (periodic shading, ±12 %) over a weaker random
  texture (irregular deposits: value noise of 0.8 mm cells, ±30 %, std ~11 %). The periodic
  tracks alone give SfM nothing to match (tried: with ±4 % random texture only 2 of 30
  views registered, with ±30 % all 30);
* ``ti6al4v`` — metal powder bed fusion: grey, strong random texture from partly melted
  powder and spatter (fractal value noise, ±35 %, 0.15 .. 1.6 mm).

The texture scales are physical (mm): at a reduced image size the finer ones average out
within a pixel, as they would on a binned sensor. The values are modelling choices
(the thesis describes the surfaces only in words), stated so a study can change them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NAMES = ("nylon12", "abs", "ti6al4v")


def value_noise(p: np.ndarray, cell: float, seed: int) -> np.ndarray:
    """Smooth random field in [-1, 1] at points ``p`` (N, 3) mm: random values on a cubic
    lattice of spacing ``cell`` mm, blended with a smoothstep (Perlin's value noise). By
    hand: a dozen numpy lines; no library here evaluates a 3-D noise at given points."""
    q = np.asarray(p, float) / cell
    i0 = np.floor(q).astype(np.int64)
    f = q - i0
    f = f * f * (3 - 2 * f)
    out = np.zeros(len(q))
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                k = i0 + (dx, dy, dz)
                # a hash of the lattice point (large odd multipliers, xor-shift) -> [-1, 1]
                h = (k[:, 0] * 73856093) ^ (k[:, 1] * 19349663) ^ (k[:, 2] * 83492791) ^ (seed * 2654435761)
                h = (h ^ (h >> 13)) * 1274126177
                v = ((h ^ (h >> 16)) & 0xFFFF) / 32767.5 - 1.0
                wx, wy, wz = (f[:, j] if on else 1 - f[:, j] for j, on in enumerate((dx, dy, dz)))
                w = wx * wy * wz
                out += w * v
    return out


def fbm(p: np.ndarray, coarse: float, fine: float, seed: int) -> np.ndarray:
    """Sum of value-noise octaves from ``coarse`` down to ``fine`` mm (halving), each
    octave's amplitude proportional to its cell (a fractal, rough-surface-like field),
    normalised to about unit peak."""
    out, norm, cell, k = np.zeros(len(p)), 0.0, coarse, 0
    while cell >= fine * 0.999:
        out = out + cell * value_noise(p, cell, seed + 17 * k)
        norm += cell
        cell /= 2
        k += 1
    return out / norm


@dataclass
class Material:
    name: str
    albedo: float
    subsurface_mm: float  # σ of the projected light's spread under the surface
    description: str

    def texture(self, p: np.ndarray, normal: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
        """Albedo factor (N,) at world points ``p`` (N, 3) mm."""
        if self.name == "nylon12":
            return 1.0 + 0.15 * value_noise(p, 0.6, seed)
        if self.name == "abs":
            up = np.abs(normal[:, 2]) > 0.7 if normal is not None else np.ones(len(p), bool)
            layers = np.cos(2 * np.pi * p[:, 2] / 0.2)
            tracks = np.cos(2 * np.pi * (p[:, 0] + p[:, 1]) / (0.45 * np.sqrt(2)))
            return 1.0 + 0.12 * np.where(up, tracks, layers) + 0.3 * value_noise(p, 0.8, seed)
        return np.clip(1.0 + 0.35 * 2.2 * fbm(p, 1.6, 0.15, seed), 0.2, 1.8)


MATERIALS = {
    "nylon12": Material("nylon12", 0.75, 0.3, "nylon-12 powder bed fusion: translucent, low texture"),
    "abs": Material("abs", 0.5, 0.0, "ABS material extrusion: visible layer tracks, weak texture"),
    "ti6al4v": Material("ti6al4v", 0.35, 0.0, "Ti-6Al-4V powder bed fusion: strong random texture"),
}


def get(name: str) -> Material:
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(f"material {name!r}: use one of {', '.join(NAMES)}") from None
