"""Laser speckle patterns from a random phase screen and an FFT (thesis ch. 4.2).

A diffuser gives the laser field a phase uniform in [0, 2π) at every point; the lens
pupil (a circle of radius ρ cycles/px in the spatial-frequency plane) low-passes it and
the observed intensity is |field|²:

    I = | IFFT( P(f) · exp(i 2π U(f)) ) |²,     P(f) = 1 for |f| <= ρ, else 0

Fully developed speckle (Goodman, *Speckle Phenomena in Optics*, ch. 3-5): the
intensity is exponentially distributed, p(I) = exp(-I/<I>)/<I> (contrast σ/<I> = 1),
and its normalised autocovariance is the squared Airy function of the pupil,

    c(Δ) = [2 J1(2πρΔ) / (2πρΔ)]²

whose first zero lies at Δ = 0.61/ρ. ``grain`` (px) is the diameter of that central
lobe, 1.22/ρ: the pupil radius sets the grain size. Intensity holds frequencies up to
2ρ, so grains below 4.88 px would alias at the pattern's own sampling; such patterns
are computed on a finer grid and averaged over each pixel (as a projector's or
camera's pixel integrates the light), which also lowers their contrast.
Patterns are periodic (the FFT's wrap-around).
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

#: Smallest grain (px) computed without oversampling (intensity band 2ρ <= 0.5).
MIN_GRAIN = 2.44 / 0.5


def pupil_radius(grain: float) -> float:
    """Pupil radius ρ (cycles/px) of a speckle grain (diameter of the central lobe, px)."""
    return 1.22 / grain


def speckle_intensity(shape, grain: float, seed: int = 0) -> np.ndarray:
    """Raw speckle intensity (h, w), mean ~1, for grains >= MIN_GRAIN (no oversampling)."""
    h, w = (int(shape[0]), int(shape[1]))
    rho = pupil_radius(grain)
    rng = np.random.default_rng(seed)
    fy = sfft.fftfreq(h)[:, None]
    fx = sfft.fftfreq(w)[None, :]
    pupil = (fx * fx + fy * fy) <= rho * rho
    n_in = int(pupil.sum())
    if n_in < 20:
        raise ValueError(
            f"speckle grain {grain:g} px on {w} x {h} px leaves {n_in} frequencies in the pupil; "
            "use a smaller grain or a larger pattern"
        )
    screen = np.zeros((h, w), complex)
    screen[pupil] = np.exp(2j * np.pi * rng.random(n_in))
    field = sfft.ifft2(screen, workers=-1)
    inten = field.real**2 + field.imag**2
    return inten / inten.mean()


def speckle(shape, grain: float, seed: int = 0, mean: float = 0.3) -> np.ndarray:
    """A speckle pattern image (h, w) for the projector, values 0..1: intensity scaled
    to ``mean`` and clipped at 1 (a laser speckle projector's saturated peaks).
    Grains below MIN_GRAIN are computed on a grid finer by an integer factor and
    averaged over each pixel."""
    if not grain > 0:
        raise ValueError(f"speckle grain {grain!r} must be > 0 px")
    h, w = (int(shape[0]), int(shape[1]))
    o = max(1, int(np.ceil(MIN_GRAIN / grain)))
    inten = speckle_intensity((h * o, w * o), grain * o, seed)
    if o > 1:
        inten = inten.reshape(h, o, w, o).mean(axis=(1, 3))
    return np.clip(inten * mean, 0.0, 1.0)


def autocovariance(img: np.ndarray) -> np.ndarray:
    """Normalised circular autocovariance (h, w) of an image (lag 0 at [0, 0]) by FFT."""
    x = np.asarray(img, float) - np.mean(img)
    f = sfft.fft2(x, workers=-1)
    c = sfft.ifft2(f * np.conj(f), workers=-1).real
    return c / c[0, 0]
