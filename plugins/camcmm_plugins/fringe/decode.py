"""Decoding of a captured sequence: absolute projector coordinates per camera pixel.

    decode(sequence, images, ...) -> Decoded
    to_grey_frames(images, name)  -> list of (H, W) arrays

For each direction with phase groups: wrapped phase and modulation of every group
(eq. 5.3, :mod:`.phase`), the code word of the direction's code (:mod:`.codes`), then
coarse-to-fine unwrapping (eq. 5.4, heterodyne, boundary correction; :mod:`.unwrap`).

Masks (a pixel is valid when no rule rejects it; ``Decoded.rejected`` gives each rule's
fraction of all pixels):

``dark``          white - black contrast (or the phase frames' peak-to-peak estimate of it)
                  below ``black_threshold`` (default 5 % of full scale): no projector light.
``saturated``     any phase frame at or above ``saturation`` (clipped sinusoids bias the
                  phase; a saturated white or code frame does not matter); default: the
                  image type's top level, for uint16 the smallest 2^b - 1 >= the data,
                  b in 10, 12, 14, 16.
``low_modulation`` modulation I'' of some phase group below ``modulation_threshold``
                  (default 2 % of full scale).
``code``          a code bit closer to its reference than ``white_threshold`` (off by
                  default), or a code word or decoded coordinate outside the projector.
``order``         a coarse-to-fine step whose estimate was off by more than 1/3 period.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import InputError

from .codes import decode_code
from .phase import wrapped_phase
from .sequence import Sequence, load_sequence
from .unwrap import Level, unwrap


@dataclass
class Decoded:
    """Per-pixel decoding of one camera's captures (all maps (H, W))."""

    coords: dict[str, np.ndarray]  # "vertical" -> u, "horizontal" -> v; float32 px, NaN invalid
    mask: np.ndarray  # bool, valid pixels
    modulation: np.ndarray  # float32, smallest I'' over the phase groups, grey levels
    mean: np.ndarray  # float32, I' of the first phase group, grey levels
    rejected: dict[str, float]
    full_scale: float
    steps: dict[str, list[str]] = field(default_factory=dict)
    wrapped: dict[str, np.ndarray] = field(default_factory=dict)
    # pixels whose fringe order the checks corrected / dropped (:mod:`.orders`), all directions
    orders: dict[str, int] = field(default_factory=lambda: {"corrected": 0, "dropped": 0})

    @property
    def u(self) -> np.ndarray | None:
        return self.coords.get("vertical")

    @property
    def v(self) -> np.ndarray | None:
        return self.coords.get("horizontal")

    @property
    def valid_fraction(self) -> float:
        return float(np.count_nonzero(self.mask)) / self.mask.size

    @property
    def quality(self) -> np.ndarray:
        """Relative modulation I''/I' (0..1 for an ideal sinusoid), float32."""
        q = np.divide(self.modulation, np.maximum(self.mean, np.float32(1e-6)), dtype=np.float32)
        return np.minimum(q, np.float32(1.0), out=q)


def to_grey_frames(images: Any, name: str = "images") -> list[np.ndarray]:
    """Frames as a list of 2-D arrays (Image objects, arrays, or one (n, H, W) array).

    Colour frames (OpenCV's BGR, as camcmm reads them) are converted to grey.
    """
    if isinstance(images, np.ndarray) and images.ndim == 3 and images.shape[-1] not in (3, 4):
        return list(images)
    out = []
    for i, im in enumerate(images):
        a = np.asarray(getattr(im, "data", im))
        if a.ndim == 3 and a.shape[-1] in (3, 4):
            import cv2

            a = cv2.cvtColor(a, cv2.COLOR_BGRA2GRAY if a.shape[-1] == 4 else cv2.COLOR_BGR2GRAY)
        if a.ndim != 2:
            raise InputError(f"{name}[{i}]: expected a grey or colour image, got an array of shape {a.shape}")
        out.append(a)
    return out


def _full_scale(frames: list[np.ndarray]) -> float:
    dt = frames[0].dtype
    if dt == np.uint8:
        return 255.0
    if dt.kind in "ui":
        top = max(int(f.max()) for f in frames)
        for bits in (10, 12, 14, 16):
            if top <= (1 << bits) - 1:
                return float((1 << bits) - 1)
        return float(np.iinfo(dt).max)
    peak = max(float(np.nanmax(f)) for f in frames)
    return 1.0 if peak <= 1.0 else peak


def check_frames(seq: Sequence, frames: list[np.ndarray], name: str = "images") -> None:
    if len(frames) != seq.n_frames:
        few = "too few" if len(frames) < seq.n_frames else "too many"
        raise InputError(
            f"{name}: {len(frames)} frames given, {few} for the sequence {seq.name!r} which declares {seq.n_frames}"
        )
    shape = frames[0].shape
    for i, f in enumerate(frames):
        if f.shape != shape:
            raise InputError(
                f"{name}[{i}]: frame of {f.shape[1]}x{f.shape[0]} px, frame 0 has "
                f"{shape[1]}x{shape[0]} px (all frames must be the same size)"
            )
        if f.dtype != frames[0].dtype:
            raise InputError(f"{name}[{i}]: {f.dtype} frame among {frames[0].dtype} frames")


def decode(
    sequence: Any,
    images: Any,
    *,
    black_threshold: float = 0.0,
    modulation_threshold: float = 0.0,
    white_threshold: float = 0.0,
    saturation: float = 0.0,
    boundary_correction: str = "auto",
    keep_wrapped: bool = False,
    warn: Callable[[str], None] | None = None,
    name: str = "images",
) -> Decoded:
    """Decode one camera's captured frames (sequence order) into projector coordinates.

    Thresholds are in the images' grey levels; 0 selects the defaults listed in the
    module docstring. ``warn`` receives one-line warnings (e.g. ``ctx.warn``).
    Raises InputError for a frame count or size that does not fit the sequence, or when
    no pixel decodes.
    """
    seq = load_sequence(sequence)
    frames = to_grey_frames(images, name)
    check_frames(seq, frames, name)
    full = _full_scale(frames)
    shape = frames[0].shape
    n_px = frames[0].size
    sat_level = saturation if saturation > 0 else (full if frames[0].dtype.kind in "ui" else np.inf)
    black_thr = black_threshold if black_threshold > 0 else 0.05 * full
    mod_thr = modulation_threshold if modulation_threshold > 0 else 0.02 * full

    rejected: dict[str, np.ndarray] = {}
    phase_frames = [i for g in seq.phase_groups for i in g.frames]
    brightest = frames[phase_frames[0]].copy()
    for i in phase_frames[1:]:
        np.maximum(brightest, frames[i], out=brightest)
    rejected["saturated"] = brightest >= sat_level
    del brightest

    whites, blacks = seq.indices("white"), seq.indices("black")
    white = _mean_of([frames[i] for i in whites]) if whites else None
    black = _mean_of([frames[i] for i in blacks]) if blacks else None

    lo, hi = seq.levels
    levels: dict[str, list[Level]] = {d: [] for d in seq.directions}
    modulation = mean = None
    low_mod = np.zeros(shape, bool)
    contrast_est = None
    wrapped = {}
    dir_mean: dict[str, np.ndarray] = {}
    for gi, g in enumerate(seq.phase_groups):
        frac, m, mod = wrapped_phase([frames[i] for i in g.frames], g.shifts)
        low_mod |= mod < mod_thr
        dir_mean.setdefault(g.direction, m)
        if modulation is None:
            modulation, mean = mod, m
            # peak-to-peak sinusoid / its drive fraction = white - black (linear response)
            contrast_est = mod * np.float32(2.0 / (2.0 * g.amplitude * (hi - lo)))
        else:
            np.minimum(modulation, mod, out=modulation)
        name_g = f"{g.direction[0]}{gi}"
        levels[g.direction].append(Level(g.period, g.offset, frac, f"phase {name_g}"))
        if keep_wrapped:
            wrapped[f"phase_{name_g}"] = frac
    if modulation is None or mean is None or contrast_est is None:
        raise InputError(f"{name}: the sequence has no phase group to decode")
    rejected["low_modulation"] = low_mod
    if white is not None and black is not None:
        rejected["dark"] = (white - black) < black_thr
    else:
        rejected["dark"] = contrast_est < black_thr
    threshold = (white + black) * np.float32(0.5) if white is not None and black is not None else None

    code_bad = np.zeros(shape, bool)
    order_bad = np.zeros(shape, bool)
    orders = {"corrected": 0, "dropped": 0}
    pre_valid = ~(rejected["saturated"] | rejected["dark"] | rejected["low_modulation"])
    coords, steps = {}, {}
    for d in seq.directions:
        span = seq.span(d)
        codes = [c for c in seq.code_groups if c.direction == d]
        code_est, cg, code_half = None, None, None
        if codes:
            cg = min(codes, key=lambda c: c.period)
            ref: list[np.ndarray] | np.ndarray
            if cg.inverse_frames:
                ref = [frames[i] for i in cg.inverse_frames]
            elif threshold is not None:
                ref = threshold
            else:
                ref = dir_mean[d]  # the sinusoids' mean is the half-white level
            word, contrast = decode_code([frames[i] for i in cg.frames], ref, cg.kind, white_threshold > 0)
            if contrast is not None:
                code_bad |= contrast < white_threshold
            code_bad |= (word * cg.period + cg.offset) >= span
            code_est, code_half = stripe_centres(word, cg.period, cg.offset)
            del word
        x, unreliable, st, stats = unwrap(
            levels[d],
            span,
            code_est,
            cg.period if cg else 0.0,
            cg.offset if cg else 0.0,
            valid=pre_valid & ~code_bad,
            correction=boundary_correction,
            direction=d,
            code_half=code_half,
            modulation=modulation,
        )
        order_bad |= unreliable
        for k in orders:
            orders[k] += stats[k]
        with np.errstate(invalid="ignore"):
            code_bad |= (x < -0.5) | (x > span - 0.5)  # beyond the projector's pixels
        coords[d], steps[d] = x, st
    rejected["code"] = code_bad
    rejected["order"] = order_bad
    mask = pre_valid & ~code_bad & ~order_bad
    for x in coords.values():
        x[~mask] = np.nan
    fractions = {k: float(np.count_nonzero(v)) / n_px for k, v in rejected.items()}
    if warn is not None:
        if fractions["saturated"] > 0.001:
            warn(f"{name}: {100 * fractions['saturated']:.2f} % of the pixels are saturated (>= {sat_level:g})")
        if fractions["dark"] > 0.5:
            warn(f"{name}: {100 * fractions['dark']:.1f} % of the pixels are dark (white - black < {black_thr:g})")
    if not mask.any():
        worst = max(fractions, key=lambda k: fractions[k])
        raise InputError(
            f"{name}: no pixel decodes ({worst}: {100 * fractions[worst]:.1f} % of the pixels); "
            "check exposure, the thresholds and that the frames follow the sequence"
        )
    return Decoded(coords, mask, modulation, mean, fractions, full, steps, wrapped, orders)


def stripe_centres(word: np.ndarray, period: float, offset: float):
    """Centre of each pixel's code stripe, px (float32 (H, W)), and the largest
    half-width of a stripe, px.

    Projector pixel u (centre at u, covering u - 1/2 .. u + 1/2) shows the word
    floor((u - offset) / period), so stripe c covers ceil(offset + c period) - 1/2 to
    ceil(offset + (c + 1) period) - 1/2: its edges lie between projector pixels, half a
    pixel before the phase wraps at offset + c period.
    """
    lo = word.astype(np.float32)
    lo *= np.float32(period)
    lo += np.float32(offset)
    hi = lo + np.float32(period)
    # an edge at an integer (a float32 product a hair above it) is that integer
    lo -= np.float32(1e-3)
    hi -= np.float32(1e-3)
    np.ceil(lo, out=lo)
    np.ceil(hi, out=hi)
    lo += hi
    lo *= np.float32(0.5)
    lo -= np.float32(0.5)
    return lo, 0.5 * math.ceil(period - 1e-9)


def _mean_of(frames: list[np.ndarray]) -> np.ndarray:
    acc = frames[0].astype(np.float32)
    for f in frames[1:]:
        acc += f
    if len(frames) > 1:
        acc *= np.float32(1.0 / len(frames))
    return acc
