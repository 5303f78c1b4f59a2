"""Lytro-style light-field depth maps: a 16-bit image and its lambda range (thesis eq. 6.5).

The Lytro software exports a depth map as a 16-bit image ``I`` and two numbers
``lambda_min``, ``lambda_max`` (lambda: the refocus disparity, the shift of the virtual
focal plane from the main lens's optical focal plane). Eq. 6.5 as printed scales

    lambda = I / 2**16 * (lambda_max - lambda_min)                         (eq. 6.5)

without adding ``lambda_min`` (``convention="eq6.5"``, the default, so that intercepts are
those of the thesis's fits); ``convention="absolute"`` adds it, giving the disparity about
the focal plane itself. The gradient of depth against lambda is the same in both. The band
of unreliable values near the focal plane (ch. 6.3.2: "particularly at the lambda is equal
to zero point, in which the disparity ... is minimised") is always judged on the absolute
value, where lambda = 0 is that plane.

Values: ``lambda_min``/``lambda_max`` given by the caller, else a JSON sidecar beside the
image, ``<stem>.json`` (or ``<stem>_depth.json``), holding them under any of these keys:
``lambda_min``/``lambda_max``, ``minLambda``/``maxLambda`` (the names in Lytro's LFP
metadata), at the top level or inside ``depth`` or ``depthMap``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Image, InputError, read

FULL_SCALE = 2.0**16  # eq. 6.5 divides by 2^16 (not 65535)
IMAGE_EXTS = (".png", ".tif", ".tiff")
#: Largest depth map taken (px): a Lytro Illum's depth maps are ~4 Mpx. A view costs ~65
#: bytes a pixel (lambda maps, depth map, masks, float64; measured: a 15.9 Mpx map, 1.18 GB
#: peak), so 8 Mpx stays near 0.6 GB.
MAX_MAP_PIXELS = 8_000_000
_KEYS = (("lambda_min", "lambda_max"), ("minLambda", "maxLambda"))


def sidecar(path: Path) -> Path | None:
    """The JSON sidecar of a depth-map image, if there is one."""
    stem = path.with_suffix("")
    for c in (stem.with_suffix(".json"), Path(f"{stem}_depth.json")):
        if c.is_file():
            return c
    return None


def sidecar_range(path: Path) -> tuple[float, float]:
    """(lambda_min, lambda_max) from a sidecar JSON; InputError naming it otherwise."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a readable JSON sidecar ({exc})") from None
    for node in (
        doc,
        doc.get("depth") if isinstance(doc, dict) else None,
        doc.get("depthMap") if isinstance(doc, dict) else None,
    ):
        if not isinstance(node, dict):
            continue
        for lo, hi in _KEYS:
            if lo in node and hi in node:
                try:
                    return float(node[lo]), float(node[hi])
                except (TypeError, ValueError):
                    raise InputError(f"{path}: {lo}/{hi} are not numbers") from None
    raise InputError(f"{path}: no lambda_min/lambda_max (or minLambda/maxLambda) in the sidecar")


def read_raw(path: str | Path) -> np.ndarray:
    """The 16-bit image (H, W) uint16 of a depth-map file; one-line InputError otherwise.
    Read through camcmm's one image reader, whose pixel cap refuses a bomb from its header."""
    p = Path(path)
    if p.suffix.lower() not in IMAGE_EXTS:
        raise InputError(f"{p}: not a depth-map image; give {', '.join(IMAGE_EXTS)}")
    if not p.is_file():
        raise InputError(f"{p}: no such depth-map file")
    img = read(p)
    if not isinstance(img, Image):  # the extension was checked: an image it is
        raise InputError(f"{p}: not an image")
    im = np.asarray(img.data)
    if im.shape[0] * im.shape[1] > MAX_MAP_PIXELS:  # before the float64 lambda maps: 8 bytes a pixel each
        raise InputError(
            f"{p}: {im.shape[1]} x {im.shape[0]} px, more than the {MAX_MAP_PIXELS / 1e6:g} Mpx of a light-field "
            "depth map camcmm takes (a Lytro Illum's are ~4 Mpx)"
        )
    if im.dtype != np.uint16:
        bits = 8 * im.dtype.itemsize
        raise InputError(f"{p}: a {bits}-bit {im.dtype} image; a Lytro depth map is 16-bit (uint16)")
    if im.ndim == 3:
        if not (np.array_equal(im[..., 0], im[..., 1]) and np.array_equal(im[..., 0], im[..., 2])):
            raise InputError(f"{p}: a colour image; a Lytro depth map has one channel")
        im = im[..., 0]
    return im


def to_lambda(raw: np.ndarray, lambda_min: float, lambda_max: float, convention: str = "eq6.5") -> np.ndarray:
    """Eq. 6.5: lambda of each pixel (float64); ``convention="absolute"`` adds lambda_min."""
    lam = raw.astype(np.float64) / FULL_SCALE * (lambda_max - lambda_min)
    return lam + lambda_min if convention == "absolute" else lam


def from_lambda(lam_abs: np.ndarray, lambda_min: float, lambda_max: float) -> np.ndarray:
    """The 16-bit image of absolute lambda values (the inverse of eq. 6.5 + lambda_min), rounded, clipped."""
    i = np.rint((np.asarray(lam_abs, float) - lambda_min) / (lambda_max - lambda_min) * FULL_SCALE)
    return np.clip(i, 0, 65535).astype(np.uint16)


def read_lambda_map(
    path: str | Path, lambda_range: tuple[float, float] | None = None, convention: str = "eq6.5"
) -> dict[str, Any]:
    """A depth map as lambda values.

    Parameters
    ----------
    path : the 16-bit PNG/TIFF.
    lambda_range : (lambda_min, lambda_max); None: read from the sidecar.
    convention : "eq6.5" or "absolute" (see the module).

    Returns
    -------
    dict ``lam`` (H, W) float64 in the convention asked, ``lam_abs`` (H, W) (lambda_min
    added), ``lambda_min``, ``lambda_max``, ``source`` ("given" or the sidecar's path).
    """
    p = Path(path)
    raw = read_raw(p)
    if lambda_range is None:
        sc = sidecar(p)
        if sc is None:
            raise InputError(
                f"{p}: no lambda_min, lambda_max: give --lambda-range MIN,MAX or a sidecar "
                f"{p.with_suffix('.json').name}"
            )
        lo, hi, source = *sidecar_range(sc), str(sc)
    else:
        lo, hi, source = float(lambda_range[0]), float(lambda_range[1]), "given"
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise InputError(f"{p}: lambda range {lo}, {hi}: lambda_max must be finite and above lambda_min")
    lam_abs = to_lambda(raw, lo, hi, "absolute")
    lam = lam_abs if convention == "absolute" else lam_abs - lo
    return {"lam": lam, "lam_abs": lam_abs, "lambda_min": lo, "lambda_max": hi, "source": source}


def parse_range(text: str | None) -> tuple[float, float] | None:
    """``"MIN,MAX"`` -> (min, max); empty -> None."""
    if text is None or not str(text).strip():
        return None
    try:
        lo, hi = (float(v) for v in str(text).split(","))
    except ValueError:
        raise InputError(f"lambda range {text!r}: give MIN,MAX, e.g. -6.5,9.2") from None
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise InputError(f"lambda range {text!r}: MIN and MAX must be finite numbers")
    if not hi > lo:
        raise InputError(f"lambda range {text!r}: MAX must be above MIN")
    return lo, hi


def find_map(folder: Path, image: str) -> Path | None:
    """The depth map of a view in ``folder``: ``<stem>``, ``<stem>_depth`` or ``<stem>-depth``
    with a PNG/TIFF extension, ``stem`` the view image's name without folder and extension."""
    stem = Path(str(image).replace("\\", "/")).stem
    for s in (stem, f"{stem}_depth", f"{stem}-depth"):
        for e in IMAGE_EXTS:
            c = folder / f"{s}{e}"
            if c.is_file():
                return c
    return None
