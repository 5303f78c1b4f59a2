"""Limits checked before work starts: memory and disk estimates, and counts read from files.

    memory_limit() -> int                        bytes a single piece of work may hold
    check_budget(what, bytes_needed, limit=None) ParameterError when the estimate exceeds it
    check_disk(what, bytes_needed, folder)       ParameterError when the folder's disk is too small
    check_count(what, n, maximum)                ParameterError when a count exceeds its limit
    human_bytes(n) -> "37.3 GB"

A size or count that comes from a file (a projector of 200000 x 200000 px, 10^12
iterations, ten million frames) must be refused in one line *before* the allocation
or the writing starts: a MemoryError half-way, or half a million files on the disk,
is no answer. Each caller estimates what its work needs (an upper bound of the large
arrays it holds at once) and names the value at fault in ``what``, e.g.
``check_budget("sequence.yaml: projector 200000 x 200000 px", 4e10)`` gives
``sequence.yaml: projector 200000 x 200000 px needs ~40 GB of memory; the limit is 8 GB
(CAMCMM_MAX_MEMORY_MB)``.

The memory limit is ``CAMCMM_MAX_MEMORY_MB`` (environment) or else the smaller of
8 GiB and 60 % of the physical memory; the disk limit is the free space of the target
folder (and ``CAMCMM_MAX_DISK_MB`` when set).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from .errors import ParameterError
from .numbers import significant

#: Default memory cap (bytes) when the environment sets none: 8 GiB ...
DEFAULT_MEMORY = 8 << 30
#: ... or this fraction of the physical memory, whichever is smaller.
MEMORY_FRACTION = 0.6
ENV_MEMORY = "CAMCMM_MAX_MEMORY_MB"
ENV_DISK = "CAMCMM_MAX_DISK_MB"


def human_bytes(n: float) -> str:
    """``n`` bytes as text with a decimal unit (B, kB, MB, GB, TB, PB)."""
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000:
            return f"{n:.0f} {unit}" if unit == "B" else f"{significant(n, 3)} {unit}"
        n /= 1000
    return f"{significant(n, 3)} PB"  # never an exponent (camcmm.numbers)


def _physical_memory() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # not a POSIX system
        return None


def _env_mb(name: str) -> int | None:
    text = os.environ.get(name, "").strip()
    if not text:
        return None
    try:
        mb = float(text)
    except ValueError:
        raise ParameterError(f"{name}={text!r}: expected a number of megabytes") from None
    if not mb > 0:
        raise ParameterError(f"{name}={text!r}: must be > 0 MB")
    return int(mb * (1 << 20))


def memory_limit() -> int:
    """Bytes one piece of work may hold (see the module docstring)."""
    env = _env_mb(ENV_MEMORY)
    if env is not None:
        return env
    phys = _physical_memory()
    return DEFAULT_MEMORY if not phys else min(DEFAULT_MEMORY, int(MEMORY_FRACTION * phys))


def check_budget(what: str, bytes_needed: float, limit: float | None = None) -> None:
    """Refuse work whose memory estimate ``bytes_needed`` exceeds ``limit`` (default
    :func:`memory_limit`); ``what`` names the file and the value the estimate comes from."""
    cap = memory_limit() if limit is None else limit
    if bytes_needed > cap:
        src = f" ({ENV_MEMORY})" if limit is None else ""
        raise ParameterError(
            f"{what} needs ~{human_bytes(bytes_needed)} of memory; the limit is {human_bytes(cap)}{src}"
        )


def _existing(folder: Path) -> Path:
    p = folder.absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_disk(what: str, bytes_needed: float, folder: str | Path) -> None:
    """Refuse to write ``bytes_needed`` (an estimate) into ``folder`` (created later is
    fine: its nearest existing parent is asked) when its disk has not that much free,
    or when it exceeds ``CAMCMM_MAX_DISK_MB``."""
    cap = _env_mb(ENV_DISK)
    if cap is not None and bytes_needed > cap:
        raise ParameterError(
            f"{what} needs ~{human_bytes(bytes_needed)} on disk; the limit is {human_bytes(cap)} ({ENV_DISK})"
        )
    try:
        free = shutil.disk_usage(_existing(Path(folder))).free
    except OSError:
        return  # the write itself will then say why
    if bytes_needed > free:
        raise ParameterError(
            f"{what} needs ~{human_bytes(bytes_needed)} on disk; only {human_bytes(free)} free for {folder}"
        )


def check_count(what: str, n: float, maximum: float) -> None:
    """Refuse a count (frames, iterations, grid points ...) above its declared limit."""
    if n > maximum:
        raise ParameterError(f"{what} = {_count(n)} is more than the limit of {_count(maximum)}")


def _count(x: float) -> str:
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"
