"""Exact-by-construction captures: what an ideal camera records of a sequence when its
pixels see known projector coordinates (for tests and benchmarks).

    render_captures(seq, u=None, v=None, mean=100, modulation=80, noise=0, ...) -> list of frames

Each pixel is ``I = mean + modulation * s`` with ``s`` the frame's drive level mapped to
[-1, 1] (eq. 5.2 for the sinusoids: ``s = cos(2 pi (x - offset)/period + delta_k)``;
+-1 for code bits, white and black), evaluated analytically at the pixel's projector
coordinate (no resampling of pattern images). ``code_shift`` moves the code boundaries
by that many projector px relative to the sinusoids, as a blurred or misregistered
capture does; ``noise`` adds Gaussian noise (grey levels), then frames are rounded and
clipped to ``dtype``.
"""

from __future__ import annotations

import numpy as np

from .patterns import code_word, gray_encode, projector_phase
from .sequence import load_sequence


def render_captures(
    sequence,
    u=None,
    v=None,
    mean=100.0,
    modulation=80.0,
    noise: float = 0.0,
    dtype=np.uint8,
    code_shift: float = 0.0,
    seed: int = 0,
) -> list[np.ndarray]:
    """Frames (sequence order) for camera pixels seeing projector coordinates u (column)
    and v (row), (H, W) float arrays in px. ``mean`` / ``modulation`` scalars or maps."""
    seq = load_sequence(sequence)
    coords = {
        "vertical": None if u is None else np.asarray(u, dtype=np.float64),
        "horizontal": None if v is None else np.asarray(v, dtype=np.float64),
    }
    shape = next(c.shape for c in coords.values() if c is not None)
    rng = np.random.default_rng(seed)
    a = np.broadcast_to(np.asarray(mean, dtype=np.float64), shape)
    b = np.broadcast_to(np.asarray(modulation, dtype=np.float64), shape)
    frames = []
    for f in seq.frames:
        if f.kind in ("white", "black", "ignore"):
            s = np.full(shape, 1.0 if f.kind == "white" else -1.0)
        else:
            x = coords[f.direction]
            if x is None:
                raise ValueError(f"frame {f.name} needs the {f.direction} coordinate map")
            if f.kind == "phase":
                g = seq.phase_groups[f.group]
                s = (2 * g.mean - 1) + 2 * g.amplitude * np.cos(
                    projector_phase(x, g.period, g.offset) + g.shifts[f.index]
                )
            else:
                cg = seq.code_groups[f.group]
                c = np.clip(code_word(x + code_shift, cg.period, cg.offset), 0, cg.n_words - 1)
                word = gray_encode(c) if cg.kind == "gray" else c
                bit = (word >> (cg.bits - 1 - f.index)) & 1
                s = np.where((bit == 1) != f.inverse, 1.0, -1.0)
        img = a + b * s
        if noise > 0:
            img = img + rng.normal(0.0, noise, shape)
        if np.dtype(dtype).kind in "ui":
            info = np.iinfo(dtype)
            img = np.clip(np.rint(img), info.min, info.max)
        frames.append(img.astype(dtype))
    return frames
