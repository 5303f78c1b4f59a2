"""Projector patterns of a sequence: arrays and PNG files at the projector's resolution.

    pattern_profile(seq, i)            -> (span,) float64 in [0, 1], the frame's 1-D profile
    generate_patterns(seq, dtype=None) -> (n_frames, height, width) uint8/uint16 (or float32 in [0, 1])
    save_patterns(seq, out_dir)        -> list of written paths (pat00.png, ...)
    gray_encode(c) / gray_decode(g)    -> Gray code of integer arrays and back

Every pattern is constant across the fringes, so a frame is a 1-D profile along u
(vertical fringes) or v (horizontal fringes) broadcast to the projector's size.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from camcmm.api import InputError, check_budget, check_disk, human_bytes

from .sequence import Sequence, load_sequence


def gray_encode(c: np.ndarray) -> np.ndarray:
    """Binary-reflected Gray code of non-negative integers (thesis fig. 5.2)."""
    c = np.asarray(c)
    return c ^ (c >> 1)


def gray_decode(g: np.ndarray, bits: int) -> np.ndarray:
    """Inverse of :func:`gray_encode` for codes of ``bits`` bits (prefix XOR, log2(bits) shifts)."""
    c = np.array(g, copy=True)
    shift = 1
    while shift < bits:
        c ^= c >> shift
        shift <<= 1
    return c


def projector_phase(x: np.ndarray, period: float, offset: float = 0.0) -> np.ndarray:
    """Absolute projector phase of coordinate x in px, eq. 5.1: 2 pi (x - offset) / period."""
    return (2.0 * np.pi / period) * (np.asarray(x, dtype=np.float64) - offset)


def code_word(x: np.ndarray, period: float, offset: float = 0.0) -> np.ndarray:
    """Stripe index floor((x - offset) / period) of projector coordinate x (px), int64."""
    return np.floor((np.asarray(x, dtype=np.float64) - offset) / period).astype(np.int64)


def pattern_profile(seq: Sequence, i: int) -> np.ndarray:
    """Frame i's drive level in [0, 1] along its coding axis (before quantisation).

    White/black/ignore frames return a constant profile along u.
    """
    f = seq.frames[i]
    lo, hi = seq.levels
    if f.kind in ("white", "black", "ignore"):
        value = hi if f.kind == "white" else lo
        return np.full(seq.width, value, dtype=np.float64)
    x = np.arange(seq.span(f.direction), dtype=np.float64)
    if f.kind == "phase":
        g = seq.phase_groups[f.group]
        s = g.mean + g.amplitude * np.cos(projector_phase(x, g.period, g.offset) + g.shifts[f.index])
        s = np.clip(s, 0.0, 1.0) ** (1.0 / seq.gamma)
        return lo + (hi - lo) * s
    cg = seq.code_groups[f.group]
    c = np.clip(code_word(x, cg.period, cg.offset), 0, cg.n_words - 1)
    word = gray_encode(c) if cg.kind == "gray" else c
    bit = (word >> (cg.bits - 1 - f.index)) & 1
    if f.inverse:
        bit = 1 - bit
    return np.where(bit == 1, hi, lo).astype(np.float64)


def _broadcast(seq: Sequence, i: int, profile: np.ndarray) -> np.ndarray:
    f = seq.frames[i]
    if f.direction == "horizontal":
        return np.broadcast_to(profile[:, None], (seq.height, seq.width))
    return np.broadcast_to(profile[None, :], (seq.height, seq.width))


def generate_patterns(sequence, dtype=None) -> np.ndarray:
    """All frames of a sequence as an (n_frames, height, width) array.

    ``dtype`` None gives uint8 or uint16 after the sequence's ``bit_depth`` (rounded
    drive levels); ``np.float32`` gives the unquantised drive levels in [0, 1] (what a
    renderer wants).
    """
    seq = load_sequence(sequence)
    if dtype is None:
        dtype = np.uint8 if seq.bit_depth == 8 else np.uint16
    dtype = np.dtype(dtype)
    check_budget(
        f"{seq.name}: {seq.n_frames} frames of {seq.width} x {seq.height} px ({dtype.name})",
        float(seq.n_frames) * seq.width * seq.height * dtype.itemsize,
    )
    out = np.empty((seq.n_frames, seq.height, seq.width), dtype=dtype)
    for i in range(seq.n_frames):
        p = pattern_profile(seq, i)
        if dtype.kind != "f":
            p = np.rint(p * seq.max_value)
        out[i] = _broadcast(seq, i, p.astype(dtype))
    return out


def save_patterns(sequence, out_dir, prefix: str = "pat") -> list[Path]:
    """Write every frame as an 8/16-bit grey PNG ``{prefix}{i:02d}.png`` in ``out_dir``."""
    import cv2

    seq = load_sequence(sequence)
    out = Path(out_dir)
    check_disk(f"{seq.name}: {seq.n_frames} PNG frames", 4096.0 * seq.n_frames, out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{out}: cannot create the output folder ({exc.strerror})") from None
    width = max(2, len(str(seq.n_frames - 1)))
    paths = []
    dtype = np.uint8 if seq.bit_depth == 8 else np.uint16
    for i in range(seq.n_frames):
        p = np.rint(pattern_profile(seq, i) * seq.max_value).astype(dtype)
        img = np.ascontiguousarray(_broadcast(seq, i, p))
        path = out / f"{prefix}{i:0{width}d}.png"
        ok, buf = cv2.imencode(".png", img)
        if not ok:
            raise InputError(f"{path}: OpenCV could not encode the pattern")
        if i == 0:
            # the first frame's PNG, twice over (code frames compress less than white),
            # estimates the whole sequence before anything is written
            each = 2.0 * buf.nbytes + 4096
            check_disk(f"{seq.name}: {seq.n_frames} PNG frames of ~{human_bytes(each)}", each * seq.n_frames, out)
        buf.tofile(path)
        paths.append(path)
    return paths
