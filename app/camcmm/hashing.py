"""Content hashes: the address of a data file in a project, and the record of a
result's inputs."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

_CHUNK = 1 << 20


def file_hash(path: str | Path) -> str:
    """SHA-256 of a file's bytes, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(_CHUNK), b""):
            h.update(chunk)
    return h.hexdigest()


def object_hash(obj: Any) -> str:
    """SHA-256 of an in-memory input: the arrays of a cloud/mesh, an array, or JSON-able
    data. Equal data give equal hashes whatever object holds them."""
    h = hashlib.sha256()
    _feed(h, obj)
    return h.hexdigest()


def _feed(h, obj: Any) -> None:
    if callable(getattr(obj, "content_hash", None)):  # a CAD model: its file's SHA-256 (camcmm.cad)
        h.update(str(obj.content_hash()).encode())
    elif isinstance(obj, np.ndarray):
        h.update(str((obj.dtype.str, obj.shape)).encode())
        h.update(np.ascontiguousarray(obj).tobytes())
    elif hasattr(obj, "__dataclass_fields__"):
        h.update(type(obj).__name__.encode())
        for name in obj.__dataclass_fields__:
            if name not in ("name", "metadata"):
                _feed(h, getattr(obj, name))
    elif isinstance(obj, dict):
        for k in sorted(obj, key=str):
            h.update(repr(k).encode())
            _feed(h, obj[k])
    elif isinstance(obj, (list, tuple)):
        for x in obj:
            _feed(h, x)
    else:
        h.update(repr(obj).encode())
