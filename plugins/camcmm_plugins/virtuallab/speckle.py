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


# --- objective and subjective speckle of a laser speckle projector (thesis ch. 4.2, 6.2)
#
# Objective speckle: a diffuser lit over a spot of diameter D throws a far-field
# pattern whose grains subtend ~ λ/D; on an object at distance z they measure
#
#     d_obj ≈ λ z / D                                   (mm; Goodman ch. 4.5, order of magnitude)
#
# The projector on the turntable is therefore a pinhole whose pattern holds grains of
# λ/D radians: its image is made by ``speckle`` with the grain in projector pixels.
#
# Subjective speckle: the camera lens images the rough, laser-lit surface into its own
# speckle in the image plane (it changes with the viewpoint, so it is noise for SfM).
# Its grain is the Airy disc of the lens's exit pupil at the image distance,
#
#     d_subj ≈ 2.44 λ F (1 + M)                         (sensor mm; F the f-number, M the magnification)
#
# and a pixel of area A_px integrating grains of area A_c = π d_subj²/4 sees the
# contrast (Goodman, Speckle Phenomena in Optics, ch. 4: integrated speckle, with the
# number of speckles per pixel approximated by 1 + A_px / A_c)
#
#     C = 1 / sqrt(1 + A_px / A_c)    → sqrt(A_c / A_px) for small grains, → 1 for large.
#
# A lower f-number (F/8, ch. 4.2) gives smaller grains and less contrast; F/11 (ch. 6.2)
# more. A binned (down-scaled) image has bigger pixels and so less contrast.


def objective_grain(wavelength_nm: float, distance_mm: float, diffuser_mm: float) -> float:
    """Objective speckle grain on the object (mm): λ z / D, λ in nm, z and D in mm."""
    if not (wavelength_nm > 0 and distance_mm > 0 and diffuser_mm > 0):
        raise ValueError(
            f"speckle: wavelength {wavelength_nm} nm, distance {distance_mm} mm and diffuser spot "
            f"{diffuser_mm} mm must all be > 0"
        )
    return wavelength_nm * 1e-6 * distance_mm / diffuser_mm


def subjective_grain(wavelength_nm: float, f_number: float, magnification: float) -> float:
    """Subjective speckle grain on the sensor (mm): 2.44 λ F (1 + M)."""
    return 2.44 * wavelength_nm * 1e-6 * f_number * (1.0 + magnification)


def subjective_contrast(grain_mm: float, pixel_mm: float) -> float:
    """Contrast σ/<I> of subjective speckle of grain ``grain_mm`` integrated over a square
    pixel of side ``pixel_mm`` (both on the sensor): 1/sqrt(1 + A_px/A_c), at most 1."""
    a_c = np.pi * grain_mm**2 / 4.0
    if not a_c > 0:
        return 0.0
    return float(1.0 / np.sqrt(1.0 + pixel_mm**2 / a_c))


def subjective_field(shape, grain_px: float, contrast: float, seed: int) -> np.ndarray:
    """A multiplicative subjective-speckle field (h, w) of mean 1 and contrast ``contrast``.

    Grains of at least MIN_GRAIN px are an FFT speckle field of that grain; smaller ones
    are drawn independent per pixel (their correlation length is below ~2 px), from the
    exponential law of fully developed speckle. Either is scaled to the contrast the
    pixel integration leaves: 1 + C (S - 1)."""
    h, w = (int(shape[0]), int(shape[1]))
    if contrast <= 0:
        return np.ones((h, w))
    if grain_px >= MIN_GRAIN:
        s = speckle_intensity((h, w), grain_px, seed)
        s = 1.0 + (s - s.mean()) / s.std()  # unit contrast exactly, whatever the sample
    else:
        s = np.random.default_rng(seed).exponential(1.0, (h, w))
    return np.clip(1.0 + contrast * (s - 1.0), 0.0, None)
