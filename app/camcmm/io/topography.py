"""Instrument height maps through SurfaceTopography (MIT; imported only when such a
file is read, so ``import camcmm`` stays light), and the summary ``camcmm info`` shows.

SurfaceTopography opens the vendors' formats (Zygo MetroPro ``.dat`` and ``.datx``,
Wyko ``.opd``, Sensofar ``.plu``/``.plux``, Digital Surf ``.sur``, Gwyddion ``.gwy``,
Keyence ``.vk4``, ...) and states one length unit per channel, for the lateral steps
and the heights alike. Its arrays are indexed [x, y]; camcmm's are [row = y,
column = x], so they are transposed, keeping SurfaceTopography's orientation. Masked
(undefined) points become NaN. A second channel of the same grid whose name says
intensity (or amplitude, quality, light, laser) becomes the map's ``intensity``.
"""

from __future__ import annotations

import math
import re
import zipfile
from datetime import date, datetime
from pathlib import Path
from typing import Any

import numpy as np

from ..model import HeightMap
from ..units import to_mm_factor
from ._common import canonical_unit, fail
from ._maps import check_grid, check_heights, check_plausible, check_zip

#: extension -> (SurfaceTopography's format key, what it is)
VENDOR: dict[str, tuple[str, str]] = {
    ".dat": ("metropro", "Zygo MetroPro DAT"),
    ".datx": ("datx", "Zygo Mx DATX"),
    ".opd": ("opd", "Wyko/Bruker OPD"),
    ".opdx": ("opdx", "Bruker Dektak OPDx"),
    ".plu": ("plu", "Sensofar PLU"),
    ".plux": ("plux", "Sensofar PLUX"),
    ".sur": ("sur", "Digital Surf SUR"),
    ".mnt": ("mnt", "Digital Surf Mountains MNT"),
    ".gwy": ("gwy", "Gwyddion GWY"),
    ".vk3": ("vk", "Keyence VK3"),
    ".vk4": ("vk", "Keyence VK4"),
    ".vk6": ("vk", "Keyence VK6"),
    ".vk7": ("vk", "Keyence VK7"),
    ".zon": ("zon", "Keyence ZON"),
    ".al3d": ("al3d", "Alicona AL3D"),
    ".lext": ("lext", "Olympus LEXT"),
    ".frt": ("frt", "FRT MicroProf"),
    ".nms": ("nms", "NanoFocus NMS"),
    ".os3d": ("os3d", "OmniSurf3D OS3D"),
    ".tmd": ("tmd", "TrueMap TMD"),
    ".zmg": ("zmg", "KLA Zeta ZMG"),
}

_INTENSITY = re.compile(r"intens|amplitude|quality|light|laser|brightness|modulation", re.IGNORECASE)


def _jsonable(v: Any, depth: int = 0) -> Any:
    """Metadata as JSON-able values: scalars, short strings, small dicts/lists; None drops it."""
    if isinstance(v, (bool, int, str)) or v is None:
        return v if not isinstance(v, str) or len(v) <= 500 else v[:500]
    if isinstance(v, float):
        return v if np.isfinite(v) else None
    if isinstance(v, np.generic):
        return _jsonable(v.item(), depth)
    if isinstance(v, (datetime, date)):
        return v.isoformat()
    if isinstance(v, bytes):
        return _jsonable(v.decode("latin-1").strip("\x00 "), depth)
    if isinstance(v, dict) and depth < 3:
        out = {str(k): _jsonable(x, depth + 1) for k, x in v.items()}
        return {k: x for k, x in out.items() if x is not None} or None
    if isinstance(v, (list, tuple, np.ndarray)) and depth < 3 and len(v) <= 16:
        return [_jsonable(x, depth + 1) for x in v]
    return None


def read(path: Path, name: str) -> HeightMap:
    key, what = VENDOR[path.suffix.lower()]
    _check_container(path, what, name)  # before SurfaceTopography is even imported
    from SurfaceTopography.IO import open_topography

    try:
        reader = open_topography(str(path), format=key)
    except Exception as exc:
        raise fail(name, f"not a readable {what} file ({_reason(exc)})") from exc
    try:  # the channels are computed from the header's fields (NaN ones fail in there)
        channels = reader.channels
        channel = reader.default_channel if channels else None
    except Exception as exc:
        raise fail(name, f"the {what} file's header fields are not usable numbers ({_reason(exc)})") from exc
    if channel is None:
        raise fail(name, f"the {what} file holds no height channel (none has a length unit)")
    unit_word = channel.unit
    if unit_word is None:
        raise fail(name, f"the {what} file states no length unit, so its steps and heights cannot be put in mm")
    unit = canonical_unit(str(unit_word))
    if unit is None:
        raise fail(name, f"the {what} file states the unit {unit_word!r}, which is not a length camcmm knows")
    if channel.dim != 2:
        raise fail(name, f"the {what} file holds a {channel.dim}-D profile, not a height map")
    _check_header(channel, key, what, name)
    try:
        topo = reader.topography(channel_index=channel.index)
        h = topo.heights()
    except Exception as exc:
        raise fail(name, f"cannot read the heights of the {what} file ({_reason(exc)})") from exc
    if not getattr(topo, "is_uniform", True):
        raise fail(name, f"the {what} file holds a non-uniform grid, not a height map")
    k = to_mm_factor(unit)
    # [x, y] -> [y, x]; masked (undefined) points -> NaN
    heights = _grid(h)
    if k != 1.0:
        heights *= k
    nx, ny = topo.nb_grid_pts
    sx, sy = topo.physical_sizes
    check_plausible(name, nx, ny, sx * k / nx, sy * k / ny, fields=f" ({what} lateral resolution)")
    check_heights(name, heights, f" ({what} height scale)")
    intensity, intensity_name = _intensity(reader, channel, name)
    if intensity is None and key == "metropro":
        intensity = _metropro_intensity(path, dict(topo.info).get("raw_metadata"))
        intensity_name = "intensity (MetroPro)" if intensity is not None else None
    meta: dict[str, Any] = {"format": what, "channel": channel.name}
    others = [c.name for c in reader.channels if c.index != channel.index]
    if others:
        meta["other_channels"] = others
    if intensity_name:
        meta["intensity_channel"] = intensity_name
    info = _jsonable(dict(topo.info)) or {}
    meta.update({k2: v for k2, v in info.items() if k2 != "raw_metadata"})
    raw = info.get("raw_metadata")
    if raw:
        meta["raw_metadata"] = raw
    return HeightMap(
        heights,
        sx * k / nx,
        sy * k / ny,
        intensity=intensity,
        name=name,
        source_unit=unit,
        meta=meta,
    )


#: MetroPro's header fields whose product (with the phase resolution) scales the phase
#: counts to heights (Zygo's MetroPro Reference Guide, "Data file format").
_METROPRO_Z = ("wavelength_in", "intf_scale_factor", "obliquity_factor")


def _check_container(path: Path, what: str, name: str) -> None:
    """The zip inside PLUX, VK4-7, ZON and the like, checked before SurfaceTopography
    inflates its members (:func:`camcmm.io._maps.check_zip`)."""
    if not zipfile.is_zipfile(path):
        return
    try:
        with zipfile.ZipFile(path) as zf:
            check_zip(zf, name, f"the {what} file's zip")
    except (zipfile.BadZipFile, OSError, ValueError, EOFError):
        return  # not readable as a zip: SurfaceTopography's own reader says what it is


def _check_header(channel: Any, key: str, what: str, name: str) -> None:
    """Before the heights are read: the grid within the memory limit (the heights, their
    float64 copy and a mask), a lateral size stated, and a height scale that is a
    non-zero finite number (MetroPro: a wavelength of 0 makes every height 0.0)."""
    try:
        nx, ny = (int(v) for v in channel.nb_grid_pts)
    except (TypeError, ValueError):
        raise fail(name, f"the {what} file states no grid size") from None
    check_grid(name, nx, ny, 8 + 8 + 8 + 1, f"{what} grid")
    if channel.physical_sizes is None:
        raise fail(name, f"the {what} file states no lateral resolution (0 or missing), so the map has no size in mm")
    hsf = getattr(channel, "height_scale_factor", None)
    if hsf is None:
        return
    try:
        bad = not math.isfinite(float(hsf)) or float(hsf) == 0
    except (TypeError, ValueError):
        bad = True
    if not bad:
        return
    fields = ""
    raw = (getattr(channel, "info", None) or {}).get("raw_metadata")
    if key == "metropro" and isinstance(raw, dict):
        fields = " (" + ", ".join(f"{f} {raw.get(f)!r}" for f in _METROPRO_Z if f in raw) + ")"
    raise fail(name, f"the {what} file's height scale factor is {hsf!r}{fields}: every height would be 0 or undefined")


def _grid(a: Any) -> np.ndarray:
    """SurfaceTopography's [x, y] (masked) array as a C-ordered [y, x] float64 array with
    NaN where masked, in one copy (np.ma's own filling copies twice: 0.25 s at 4 M points)."""
    out = np.ascontiguousarray(np.asarray(np.ma.getdata(a), dtype=np.float64).T)
    mask = np.ma.getmask(a)
    if mask is not np.ma.nomask and mask.any():
        out[mask.T] = np.nan
    return out


def _intensity(reader: Any, height: Any, name: str) -> tuple[np.ndarray | None, str | None]:
    for c in reader.channels:
        if c.index == height.index or not _INTENSITY.search(c.name or ""):
            continue
        if c.nb_grid_pts != height.nb_grid_pts:
            continue
        try:
            data = reader.topography(channel_index=c.index).heights()
        except Exception:  # an extra channel that does not load leaves the heights usable
            continue
        return _grid(data), c.name
    return None, None


def _metropro_intensity(path: Path, head: Any) -> np.ndarray | None:
    """The intensity frame of a MetroPro file, which SurfaceTopography skips: big-endian
    uint16, right after the header, before the phase data (Zygo's MetroPro Reference
    Guide, "Data file format"); values above ``ac_range`` are invalid. Only when the
    intensity grid is the height grid (same origin and size); else None."""
    if not isinstance(head, dict):
        return None
    try:
        w, h, n = int(head["ac_org_width"]), int(head["ac_org_height"]), int(head["ac_n_buckets"])
        same = (head["ac_org_x"], head["ac_org_y"], w, h) == (
            head["cn_org_x"],
            head["cn_org_y"],
            head["cn_org_width"],
            head["cn_org_height"],
        )
        if not same or n < 1 or int(head["ac_n_bytes"]) != 2 * w * h * n:
            return None
        a = np.fromfile(path, dtype=">u2", count=w * h, offset=int(head["header_size"])).reshape(h, w)
    except (KeyError, TypeError, ValueError):
        return None
    out = a.astype(np.float64)
    out[a > int(head.get("ac_range", 65535))] = np.nan
    return out


def _reason(exc: Exception) -> str:
    return " ".join(str(exc).split())[:160] or type(exc).__name__


def summary(hm: HeightMap) -> dict[str, Any]:
    """What ``camcmm info`` shows of a height map: grid, steps and size in mm, height
    range in mm, the file's unit, the valid fraction and the instrument."""
    ny, nx = hm.shape
    n = nx * ny
    valid = hm.n_valid
    lo = float(np.nanmin(hm.heights)) if valid else None
    hi = float(np.nanmax(hm.heights)) if valid else None
    inst = hm.meta.get("instrument")
    if isinstance(inst, dict):
        inst = (
            inst.get("name")
            or " ".join(str(inst[k]) for k in ("vendor", "manufacturer", "model") if inst.get(k))
            or None
        )
    return {
        "grid": [nx, ny],
        "steps_mm": [hm.dx, hm.dy],
        "size_mm": list(hm.size_mm),
        "origin_mm": list(hm.origin),
        "height_range_mm": [lo, hi],
        "unit": "mm",
        "source_unit": hm.source_unit,
        "valid_fraction": valid / n,
        "has_intensity": hm.intensity is not None,
        "instrument": inst,
        "format_detail": hm.meta.get("format"),
    }
