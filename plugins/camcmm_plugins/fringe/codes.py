"""Gray and plain binary fringe-order codes: per-pixel code words from the captured bits.

    decode_code(frames, reference, kind, want_contrast) -> (word, contrast)

Each bit is 1 where the bit frame is brighter than its reference: the inverse frame
(projected complement, robust to surface reflectance) or a threshold image (the mean of
the white and black frames, or of the phase frames, i.e. the half-white level). Gray
words are converted to the stripe index by the prefix XOR (thesis fig. 5.2: a wrong last
bit moves a Gray word by one stripe only).
"""

from __future__ import annotations

import numpy as np

from .patterns import gray_decode


def decode_code(frames, reference, kind: str, want_contrast: bool = False):
    """Stripe index of every pixel and the weakest bit contrast.

    frames    : the code's bit frames, most significant first, (H, W) each.
    reference : a list of the inverse frames (same order), or one (H, W) threshold image.
    kind      : "gray" or "binary".
    Returns word (H, W) int32 (the stripe index c) and, with ``want_contrast``, the
    smallest |bit - reference| over the bits, float32 grey levels (else None).
    """
    bits = len(frames)
    shape = np.shape(frames[0])
    word = np.zeros(shape, np.int32)
    bit = np.empty(shape, bool)
    contrast = np.full(shape, np.inf, np.float32) if want_contrast else None
    diff = np.empty(shape, np.float32) if want_contrast else None
    per_bit_ref = isinstance(reference, (list, tuple))
    for b in range(bits):
        img = np.asarray(frames[b])
        ref = np.asarray(reference[b]) if per_bit_ref else reference
        np.greater(img, ref, out=bit)
        word <<= 1
        word |= bit
        if want_contrast:
            assert diff is not None and contrast is not None  # made with want_contrast
            # float32 difference: uint8/uint16 subtraction would wrap around
            np.subtract(img, ref, out=diff, dtype=np.float32, casting="unsafe")
            np.abs(diff, out=diff)
            np.minimum(contrast, diff, out=contrast)
    if kind == "gray":
        word = gray_decode(word, bits)
    return word, contrast
