"""The served folder of the client view's buffers: immutable files named by the hash of
their bytes (``<blake2b-128 hex>.f32|.u8|.u32``), so the browser caches by name and
fetches only what is new, and a buffer that did not change is neither written nor
sent again. The folder holds nothing else (no names of items, no paths).

Each :meth:`BufferStore.commit` names the buffers the current state uses; files no
longer used by the last :data:`KEEP_STATES` states are removed (a browser still
fetching the previous state finds its files).
"""

from __future__ import annotations

import hashlib
import logging
import shutil
import tempfile
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

log = logging.getLogger("camcmm.gui")

#: little-endian dtype and file suffix of each kind of buffer
KINDS: dict[str, np.dtype[Any]] = {"f32": np.dtype("<f4"), "u8": np.dtype("u1"), "u32": np.dtype("<u4")}
#: states whose buffers stay on disk
KEEP_STATES = 3


def buffer_name(data: bytes, suffix: str) -> str:
    """``<hash>.<suffix>``: BLAKE2b (RFC 7693) with a 16-byte digest of ``data``."""
    return f"{hashlib.blake2b(data, digest_size=16).hexdigest()}.{suffix}"


class BufferStore:
    """Writes buffers once into ``folder`` (a fresh temporary folder by default)."""

    def __init__(self, folder: str | Path | None = None):
        self.folder = Path(folder) if folder else Path(tempfile.mkdtemp(prefix="camcmm-cv-"))
        self.folder.mkdir(parents=True, exist_ok=True)
        self._memo: dict[Any, str] = {}  # what a buffer was made from -> its name
        self._used: deque[set[str]] = deque(maxlen=KEEP_STATES)
        self.written: list[str] = []  # names written since the last take_written()

    def put(self, array: np.ndarray | Callable[[], np.ndarray | None], suffix: str, key: Any = None) -> str | None:
        """The name of ``array`` (or of what the callable returns; None when it returns
        None) as a ``suffix`` buffer, written when new. ``key``: what the array was made
        from; a key seen before gives its name without making, converting or hashing the
        array again."""
        if key is not None and key in self._memo and (self.folder / self._memo[key]).exists():
            return self._memo[key]
        made = array() if callable(array) else array
        if made is None:
            return None
        data = np.ascontiguousarray(made, dtype=KINDS[suffix]).tobytes()
        name = buffer_name(data, suffix)
        path = self.folder / name
        if not path.exists():
            tmp = path.with_suffix(".part")
            tmp.write_bytes(data)
            tmp.replace(path)
            self.written.append(name)
        if key is not None:
            self._memo[key] = name
        return name

    def take_written(self) -> list[str]:
        """The names written since the last call."""
        out, self.written = self.written, []
        return out

    def commit(self, used: set[str]) -> None:
        """The buffers of the state just published: remove files no recent state uses."""
        self._used.append(set(used))
        keep = set().union(*self._used)
        self._memo = {k: v for k, v in self._memo.items() if v in keep}
        for path in self.folder.iterdir():
            if path.name not in keep:
                try:
                    path.unlink()
                except OSError as exc:  # a file in use elsewhere: next time
                    log.debug("cannot remove %s: %s", path, exc)

    def close(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)
