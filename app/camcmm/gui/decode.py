"""Decode an imported file in a process of its own, under a memory cap.

A file's size says little about what decoding it takes: a 6.3 MB JPEG whose header
declares 20000 x 20000 pixels took a session from 601 MB to 2.8 GB, an X3P zip bomb to
3.7 GB, a 315 MB ``.xyz`` to 5.5 GB (and its parsing held the CPU). Whatever the
readers check, a session must not pay for a file it has not accepted yet. So
:func:`decode` runs :func:`camcmm.io.read_stated` in a fresh interpreter
(``python -m camcmm.gui.decode``; never ``fork`` from the threaded trame server) whose
address space is capped with ``RLIMIT_AS`` (:data:`DEFAULT_CAP`, or
``$CAMCMM_DECODE_MEMORY`` such as ``3G``) and whose run time is bounded
(:data:`TIMEOUT_S`). The child pickles ``(object, stated unit)`` to a file; the session
loads it only when the child succeeded and the result is within :func:`result_limit`
(half the cap: what a session may be asked to hold for one item). Any failure — the
reader's one-line refusal, MemoryError, a native crash under the cap, the timeout — is
one line naming the file; the session then stores nothing.

The child starts in ~0.3 s (``camcmm.io`` imports its heavy readers lazily).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from ..errors import InputError
from .uploads import parse_size, size_text

CAP_ENV = "CAMCMM_DECODE_MEMORY"
DEFAULT_CAP = 2 * 1024**3
TIMEOUT_S = 600.0
#: one thread per library: each thread's stack and malloc arena count against the cap
_ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", MALLOC_ARENA_MAX="2")
#: exit codes of the child
_REFUSED, _NO_MEMORY = 2, 3


def cap_bytes() -> int:
    value = os.environ.get(CAP_ENV, "")
    return parse_size(value, CAP_ENV) if value.strip() else DEFAULT_CAP


def result_limit(cap: int) -> int:
    return cap // 2


def decode(path: str | Path, unit: str | None, name: str, cap: int | None = None) -> tuple[Any, str | None]:
    """``camcmm.io.read_stated(path, unit)`` in a capped child process. Raises
    InputError (one line naming ``name``) when it fails or its result is too large."""
    cap = cap_bytes() if cap is None else cap
    path = Path(path)
    fd, out = tempfile.mkstemp(prefix="camcmm-decoded-", suffix=".pickle")  # never in the project's folders
    os.close(fd)
    try:
        cmd = [sys.executable, "-m", "camcmm.gui.decode", str(path), unit or "", out, str(cap), name]
        try:
            r = subprocess.run(
                cmd, capture_output=True, text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL, env=_ENV
            )
        except subprocess.TimeoutExpired:
            raise InputError(f"{name}: reading it took more than {TIMEOUT_S:g} s; refused") from None
        said = " ".join((r.stderr or "").strip().splitlines()[-1:])  # the child's one line names the file
        if r.returncode == _REFUSED and said:
            raise InputError(said)
        if r.returncode != 0:
            crashed = r.returncode not in (_NO_MEMORY, -9, -6, -11)  # not the cap's usual ends
            raise InputError(
                f"{name}: refused: reading it needs more than the {size_text(cap)} of memory an import may take"
                + (f" (the reader stopped with code {r.returncode})" if crashed else "")
            )
        size = os.path.getsize(out)
        if size > result_limit(cap):
            raise InputError(
                f"{name}: refused: its content takes {size_text(size)} decoded, more than the "
                f"{size_text(result_limit(cap))} one item may take"
            )
        with open(out, "rb") as f:
            obj, stated = pickle.load(f)
        return obj, stated
    finally:
        Path(out).unlink(missing_ok=True)


def _child(argv: list[str]) -> int:
    import resource

    path, unit, out, cap, name = argv[0], argv[1] or None, argv[2], int(argv[3]), argv[4]
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    try:
        from camcmm import io as cio
        from camcmm.errors import one_line

        obj, stated = cio.read_stated(path, unit)
        with open(out, "wb") as f:
            pickle.dump((obj, stated), f, protocol=pickle.HIGHEST_PROTOCOL)
    except MemoryError:
        return _NO_MEMORY
    except Exception as exc:  # one line for the page: the reader's refusal, or what broke
        print(one_line(exc, name, path, Path(path).parent), file=sys.stderr, flush=True)  # no temp folder named
        return _REFUSED
    return 0


if __name__ == "__main__":
    sys.exit(_child(sys.argv[1:]))
