"""Checks of an image series before and after structure from motion.

Every refusal is an InputError of one line that names the images at fault; a partial
registration is not an error but warnings plus each unregistered image's reason.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from camcmm.api import InputError

MIN_IMAGES = 3
#: below this many SIFT features an image is "without texture" for the reasons given
MIN_FEATURES = 100


def _names(items: Sequence[str], limit: int = 6) -> str:
    s = ", ".join(items[:limit])
    return s + (f" and {len(items) - limit} more" if len(items) > limit else "")


def check_series(images: Sequence[Any], names: Sequence[str]) -> None:
    """Refuse a series SfM cannot use: fewer than 3 images, non-image arrays, mixed sizes.

    Parameters
    ----------
    images : arrays (H, W) or (H, W, 3|4), any integer or float dtype.
    names : one name per image (file names), used in the messages.
    """
    if len(images) != len(names):
        raise InputError(f"photogrammetry: {len(images)} images but {len(names)} names")
    if len(images) < MIN_IMAGES:
        given = _names(list(names)) if names else "none"
        raise InputError(
            f"photogrammetry: {len(images)} image(s) ({given}); structure from motion needs at least {MIN_IMAGES}"
        )
    dup = [n for n, c in Counter(names).items() if c > 1]
    if dup:
        raise InputError(f"photogrammetry: image names given twice: {_names(dup)}")
    bad = []
    for im, n in zip(images, names, strict=True):
        a = np.asarray(im) if im is not None else None
        if a is None or a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (1, 3, 4)) or min(a.shape[:2]) < 16:
            bad.append(f"{n} ({'nothing' if a is None else 'shape ' + 'x'.join(map(str, a.shape))})")
    if bad:
        raise InputError(f"photogrammetry: not images (H x W or H x W x 3, at least 16 px): {_names(bad)}")
    sizes = [(int(np.asarray(im).shape[1]), int(np.asarray(im).shape[0])) for im in images]
    common, _ = Counter(sizes).most_common(1)[0]
    odd = [f"{n} {w}x{h}" for n, (w, h) in zip(names, sizes, strict=True) if (w, h) != common]
    if odd:
        raise InputError(
            f"photogrammetry: images of different sizes (one camera, one size: most are {common[0]}x{common[1]}): "
            + _names(odd)
        )


def check_registration(per_image: list[dict[str, Any]], n_registered: int, n_verified_pairs: int) -> list[str]:
    """After SfM: an InputError when nothing usable came out, else the warnings.

    Parameters
    ----------
    per_image : [{image, n_features, n_matched, registered, reason}] for the whole series.
    n_registered : images in the reconstruction (0 when the mapper found none).
    n_verified_pairs : image pairs that passed geometric verification.
    """
    poor = [p for p in per_image if p["n_features"] < MIN_FEATURES]
    if n_registered < 2:
        if len(poor) * 2 >= len(per_image):
            listed = _names([f"{p['image']} {p['n_features']} features" for p in poor])
            raise InputError(
                f"photogrammetry: no texture: too few SIFT features (< {MIN_FEATURES}) in {listed}; "
                "project a speckle pattern or add texture"
            )
        if n_verified_pairs == 0:
            raise InputError(
                "photogrammetry: no overlap: no two images share verified matches ("
                + _names([p["image"] for p in per_image])
                + "); take images with more overlap"
            )
        raise InputError(
            f"photogrammetry: nothing registered: the mapper found no initial pair among {len(per_image)} images "
            f"({n_verified_pairs} verified pairs); take images with more overlap or texture"
        )
    warnings = []
    missing = [p for p in per_image if not p["registered"]]
    if missing:
        warnings.append(
            f"{len(missing)} of {len(per_image)} images not registered: "
            + _names([f"{p['image']} ({p['reason']})" for p in missing])
        )
    return warnings


def reason_unregistered(n_features: int, n_matched: int) -> str:
    """Why an image was left out, in a few words."""
    if n_features < MIN_FEATURES:
        return f"{n_features} features"
    if n_matched == 0:
        return "no verified matches"
    return f"not registered by the mapper ({n_matched} matched features)"
