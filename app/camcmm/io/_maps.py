"""Checks every height-map reader applies (x3p, sdf, topography): the grid's memory
before it is read, zip members read no further than the grid they should hold, and
the plausibility of the steps, the size and the heights once they are in mm.

A header field that scales the data (a step, a height increment, a wavelength) is the
one place a damaged or hostile file gives a silently wrong map: an increment of 0 makes
every height 0.0, one of 1e300 a map 1e304 mm wide. So a map is refused, naming the
file and the field, when

* a step or a height factor is not a positive finite number (:func:`factor`);
* a lateral step is below :data:`MIN_STEP_MM` or a height factor below
  :data:`MIN_Z_FACTOR_MM`: finer than any instrument samples, so the field is wrong;
* the map is wider or longer than :data:`MAX_EXTENT_MM`, its heights span more, or a
  coordinate (origin, height) lies farther than :data:`MAX_COORD_MM` from zero.

Lengths in mm.
"""

from __future__ import annotations

import math
import zipfile
import zlib
from typing import Any

import numpy as np

from ..limits import check_budget
from ..units import PLAUSIBLE_SPAN_MM
from ._common import fail

#: The largest part close-range metrology measures with margin (camcmm.units'
#: plausibility rule, whose upper bound this is): no height-map instrument (an
#: interferometer, a confocal microscope, a profilometer, even stitched) covers more.
#: Its lower bound (0.5 mm) does not fit height maps: a 100x objective sees 0.17 mm.
MAX_EXTENT_MM: float = PLAUSIBLE_SPAN_MM[1]
#: Origins and heights are stage coordinates at most: ten times the largest part.
MAX_COORD_MM: float = 10 * MAX_EXTENT_MM
#: 10 pm: ten times below an atomic-force microscope's finest pixel (~0.1 nm), so a
#: smaller lateral step is a wrong field, not a measurement.
MIN_STEP_MM: float = 1e-8
#: 1 fm per count: a thousand times below the finest height resolution instruments
#: state (~1 pm); a smaller height factor flattens every map to 0.
MIN_Z_FACTOR_MM: float = 1e-12
#: Bytes read from a zip member at a time (a bounded read holds at most this beyond the grid).
CHUNK = 1 << 20
#: Measured heights carry noise and deflate by a few times at most (a map with large
#: invalid regions perhaps by twenty); zeros deflate by a thousand. A member that
#: inflates more than :data:`MAX_RATIO` times and to more than :data:`RATIO_FLOOR` bytes
#: is a zip bomb (a 3 MB file declaring 3 GB), refused before it is inflated even when
#: the grid it claims to hold would fit the memory limit. The floor spares a map of
#: constant values (a synthetic intensity channel: 4096² float64 is 128 MB).
MAX_RATIO = 100
RATIO_FLOOR = 256 << 20


def factor(name: str, what: str, value: Any, minimum: float) -> float:
    """``value`` (mm) as a float, refused unless finite and at least ``minimum``;
    ``what`` names the header field (and its value as the file gives it)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise fail(name, f"{what} is not a number") from None
    if not math.isfinite(v) or v <= 0:
        raise fail(name, f"{what} must be a positive finite number (it scales the data), got {v:g} mm")
    if v < minimum:
        raise fail(name, f"{what} = {v:g} mm is below {minimum:g} mm, finer than any instrument: a wrong header")
    return v


def check_grid(name: str, nx: int, ny: int, bytes_per_point: float, what: str = "grid") -> None:
    """Refuse an empty grid, and one whose reading would need more memory than the
    limit (:func:`camcmm.limits.check_budget`), before anything is read."""
    if nx < 1 or ny < 1:
        raise fail(name, f"{what} of {nx} x {ny} points is empty")
    check_budget(f"{name}: {what} of {nx} x {ny} points", float(nx) * ny * bytes_per_point)


def check_plausible(name: str, nx: int, ny: int, dx: float, dy: float, origin=(0.0, 0.0), fields: str = "") -> None:
    """Refuse a map whose size (nx dx by ny dy) or origin is implausible (module
    docstring); ``fields`` names the header fields the steps come from."""
    for axis, n, d in (("x", nx, dx), ("y", ny, dy)):
        factor(name, f"lateral step d{axis}{fields}", d, MIN_STEP_MM)
        if n * d > MAX_EXTENT_MM:
            raise fail(
                name,
                f"the map is {n * d:.6g} mm long in {axis} ({n} points of {d:g} mm{fields}); "
                f"no height map spans more than {MAX_EXTENT_MM:g} mm: a wrong header",
            )
    o = [float(v) for v in origin]
    if not all(math.isfinite(v) and abs(v) <= MAX_COORD_MM for v in o):
        raise fail(name, f"origin ({o[0]:g}, {o[1]:g}) mm lies beyond ±{MAX_COORD_MM:g} mm: a wrong header")


def check_heights(name: str, z: np.ndarray, fields: str = "") -> None:
    """Refuse heights (mm, NaN = invalid) beyond ±:data:`MAX_COORD_MM` or spanning more
    than :data:`MAX_EXTENT_MM`: a height factor or offset (``fields``) is wrong."""
    if not z.size or np.isnan(z).all():
        return
    lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise fail(name, f"heights overflow to infinity{fields}: a wrong height factor")
    if hi - lo > MAX_EXTENT_MM or max(abs(lo), abs(hi)) > MAX_COORD_MM:
        raise fail(name, f"heights run from {lo:.6g} to {hi:.6g} mm{fields}; implausible for a height map")


def check_zip(zf: zipfile.ZipFile, name: str, what: str) -> None:
    """Refuse a zip whose members together declare more than the memory limit, or one
    member inflating like a bomb (:data:`MAX_RATIO`); zipfile never inflates a member
    past its declared size, so the declared sizes bound what any reader of it gets."""
    infos = zf.infolist()
    check_budget(f"{name}: {what} of {len(infos)} members", float(sum(i.file_size for i in infos)))
    for i in infos:
        if i.file_size > RATIO_FLOOR and i.file_size > MAX_RATIO * max(i.compress_size, 1):
            raise fail(
                name,
                f"{what} member {i.filename[:80]!r} inflates {i.compress_size} bytes to {i.file_size} "
                f"({i.file_size // max(i.compress_size, 1)}:1): a zip bomb, not measured data",
            )


def read_member(zf: zipfile.ZipFile, member: str, name: str, size: int, what: str, slack: int = 0) -> bytearray:
    """The first ``size`` bytes of zip member ``member``, read in bounded chunks: refused
    (before reading) when the member's declared size is below ``size`` or above
    ``size + slack``, and (while reading) when it inflates to more or fewer bytes than
    declared, so a member never takes more memory than the grid it should hold."""
    try:
        info = zf.getinfo(member)
    except KeyError:
        raise fail(name, f"{what} {member!r} is missing from the zip") from None
    if info.file_size < size or info.file_size > size + slack:
        raise fail(name, f"{what} {member!r} declares {info.file_size} bytes; the grid needs {size}")
    out = bytearray(size)
    view = memoryview(out)
    got = 0
    try:
        with zf.open(info) as fh:
            while got < size:
                chunk = fh.read(min(CHUNK, size - got))
                if not chunk:
                    break
                view[got : got + len(chunk)] = chunk
                got += len(chunk)
            # zipfile stops at the declared size; one more byte tells a member longer than that
            extra = fh.read(1) if info.file_size == size else b""
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, NotImplementedError, RuntimeError) as exc:
        raise fail(name, f"{what} {member!r} cannot be read ({' '.join(str(exc).split())[:120]})") from None
    if got < size:
        raise fail(name, f"{what} {member!r} holds {got} bytes; the grid needs {size}")
    if extra:
        raise fail(name, f"{what} {member!r} holds more than the {size} bytes it declares")
    return out
