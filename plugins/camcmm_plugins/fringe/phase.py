"""N-step phase shifting: wrapped phase (thesis eq. 5.3), mean intensity and modulation.

    wrapped_phase(frames, shifts) -> (fraction, mean, modulation)

Model (eq. 5.2): ``I_k = I' + I'' cos(phi + delta_k)``. With N steps whose shifts satisfy
sum(sin) = sum(cos) = 0 and equal quadrature weights (checked by the sequence parser),

    S = sum_k I_k sin(delta_k) = -(N/2) I'' sin(phi)
    C = sum_k I_k cos(delta_k) =  (N/2) I'' cos(phi)
    phi = atan2(-S, C)                                  (eq. 5.3)
    I'' = (2/N) sqrt(S^2 + C^2),  I' = (1/N) sum_k I_k

The phase is returned as the fraction of a period ``phi / 2 pi`` in [0, 1), float32, so a
projector coordinate is ``x = offset + period * (k + fraction)`` (eqs. 5.1, 5.4).
"""

from __future__ import annotations

import numpy as np


def as_float32(img: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """A grey frame as float32 (no copy if it already is)."""
    img = np.asarray(img)
    if img.dtype == np.float32 and out is None:
        return img
    if out is None:
        return img.astype(np.float32)
    np.copyto(out, img, casting="unsafe")
    return out


def wrapped_phase(frames, shifts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wrapped phase fraction, mean I' and modulation I'' of N phase-shifted frames.

    frames : N grey images (H, W), any real dtype, in step order.
    shifts : N phase shifts delta_k in rad (as the sequence declares them).
    Returns three (H, W) float32 arrays: phi / 2 pi in [0, 1), I' and I'' in grey levels.
    """
    n = len(frames)
    if n != len(shifts) or n < 3:
        raise ValueError(f"need N >= 3 frames and as many shifts, got {n} frames, {len(shifts)} shifts")
    shape = np.shape(frames[0])
    s = np.zeros(shape, np.float32)
    c = np.zeros(shape, np.float32)
    mean = np.zeros(shape, np.float32)
    tmp = np.empty(shape, np.float32)
    buf = np.empty(shape, np.float32)
    for img, d in zip(frames, shifts):
        img = np.asarray(img)
        f = img if img.dtype == np.float32 else as_float32(img, buf)
        mean += f
        # in place: two scaled accumulations per frame, no (N, H, W) float stack
        np.multiply(f, np.float32(np.sin(d)), out=tmp)
        s += tmp
        np.multiply(f, np.float32(np.cos(d)), out=tmp)
        c += tmp
    mean *= np.float32(1.0 / n)
    np.negative(s, out=s)
    frac = np.arctan2(s, c)
    frac *= np.float32(1.0 / (2.0 * np.pi))
    np.add(frac, np.float32(1.0), out=frac, where=frac < 0)
    # (2/N) sqrt(S^2 + C^2), built in the S and C buffers
    np.multiply(s, s, out=s)
    np.multiply(c, c, out=c)
    s += c
    np.sqrt(s, out=s)
    s *= np.float32(2.0 / n)
    return frac, mean, s
