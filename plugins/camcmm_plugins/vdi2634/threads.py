"""One BLAS thread per evaluation thread while a plan's measurements are evaluated in parallel.

The standard evaluates its measurements on a thread pool (one measurement per core). The
fits inside call OpenBLAS (numpy's and SciPy's copies), which starts threads of its own for
every product above a few thousand elements; with the pool's threads already on every core,
those BLAS threads only oversubscribe the cores and spin waiting for one: measured on the
6.4 M-point part-2 benchmark (2 cores), the process spent 4.9 s CPU per evaluation instead of
2.2 s, and took 3x the wall time when other programs loaded the machine. The products of a
fit (4 x N by N x 4) are memory-bound, so one thread each loses nothing.

:func:`single_blas_thread` sets every OpenBLAS loaded in the process to one thread and
restores the previous counts on exit (as threadpoolctl's ``threadpool_limits(1)`` does,
without the dependency). It changes the whole process, so it is entered around the pool
only. Where /proc/self/maps does not exist (not Linux) or no OpenBLAS is loaded, it does
nothing.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager

#: (setter, getter) symbol names: numpy's 64-bit-integer build, SciPy's, a plain OpenBLAS.
_SYMBOLS = (
    ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
    ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
    ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
    ("openblas_set_num_threads", "openblas_get_num_threads"),
)


def _openblas() -> list[tuple]:
    """(set, get) functions of each OpenBLAS loaded in this process."""
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({line.split()[-1] for line in fh if "openblas" in line.lower() and "/" in line})
    except OSError:
        return []
    out = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)  # already loaded: the same handle, nothing runs
        except OSError:
            continue
        for set_name, get_name in _SYMBOLS:
            if hasattr(lib, set_name) and hasattr(lib, get_name):
                out.append((getattr(lib, set_name), getattr(lib, get_name)))
                break
    return out


@contextmanager
def single_blas_thread(active: bool = True) -> Iterator[None]:
    """Within the block every loaded OpenBLAS uses one thread (``active`` False: unchanged)."""
    libs = _openblas() if active else []
    before = []
    for set_fn, get_fn in libs:
        before.append(int(get_fn()))
        set_fn(1)
    try:
        yield
    finally:
        for (set_fn, _), n in zip(libs, before):
            set_fn(n)
