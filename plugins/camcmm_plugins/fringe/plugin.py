"""Plugin entry points (``fn(ctx, **inputs, **params) -> dict``) of fringe.patterns,
fringe.decode and fringe.reconstruct."""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import RunContext

from .sequence import load_sequence


def patterns(ctx: RunContext, sequence: Any, dtype: str = "uint", out: str = "") -> dict[str, Any]:
    from .patterns import generate_patterns, save_patterns

    seq = load_sequence(sequence)
    arr = generate_patterns(seq, np.float32 if dtype == "float32" else None)
    files = [str(p) for p in save_patterns(seq, out)] if out else []
    return {"patterns": arr, "frames": seq.describe(), "projector_size": list(seq.projector_size), "files": files}
