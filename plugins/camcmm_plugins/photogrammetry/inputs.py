"""The image series: checks before and after structure from motion, the files COLMAP reads,
the per-image counts it found.

Every refusal is an InputError of one line that names the images at fault; a partial
registration is not an error but warnings plus each unregistered image's reason.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path
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
        # grouped by kind of reason (diagnose.reason), each image's full reason on its row
        kinds: dict[str, list[str]] = {}
        for p in missing:
            kinds.setdefault(KIND_WORDS.get(p.get("kind", ""), p["reason"]), []).append(p["image"])
        warnings.append(
            f"{len(missing)} of {len(per_image)} images not registered: "
            + "; ".join(f"{why}: {_names(images)}" for why, images in kinds.items())
        )
    return warnings


#: the warning's words for each kind of reason of :func:`.diagnose.reason`
KIND_WORDS = {
    "texture": "too little texture",
    "no matches": "no verified matches",
    "not linked": "matched only with other unregistered images",
    "too few": "too few inlier matches to the registered images",
    "degenerate": "degenerate geometry",
    "inconsistent": "matches that agree on no one pose",
    "separate model": "in a separate model",
}


def reason_unregistered(n_features: int, n_matched: int) -> str:
    """Why an image was left out, in a few words."""
    if n_features < MIN_FEATURES:
        return f"{n_features} features"
    if n_matched == 0:
        return "no verified matches"
    return f"not registered by the mapper ({n_matched} matched features)"


def _as_uint8(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim == 3 and a.shape[2] == 4:
        a = a[:, :, :3]
    if a.dtype == np.uint8:
        return a
    if a.dtype == np.uint16:
        return (a >> 8).astype(np.uint8)
    f = a.astype(np.float64)
    top = 1.0 if np.nanmax(f) <= 1.0 else 255.0
    return np.clip(np.nan_to_num(f) * (255.0 / top), 0, 255).astype(np.uint8)


def write_images(
    images: Sequence[np.ndarray], names: Sequence[str], folder: Path, max_image_size: int
) -> tuple[list[str], tuple[float, float]]:
    """Write the series as PNG files (RGB arrays in, files readable by COLMAP), the longer side
    down-scaled to ``max_image_size`` (INTER_AREA). Returns the file names and (sx, sy), the
    written size over the full size."""
    import cv2

    h, w = np.asarray(images[0]).shape[:2]
    s = min(1.0, max_image_size / max(w, h))
    nw, nh = max(1, round(w * s)), max(1, round(h * s))
    files = []
    for i, (im, name) in enumerate(zip(images, names, strict=True)):
        a = _as_uint8(im)
        if (nw, nh) != (w, h):
            a = cv2.resize(a, (nw, nh), interpolation=cv2.INTER_AREA)
        if a.ndim == 3:
            a = cv2.cvtColor(a, cv2.COLOR_RGB2BGR)
        f = f"{i:05d}_{Path(name).stem}.png"
        if not cv2.imwrite(str(folder / f), a, [cv2.IMWRITE_PNG_COMPRESSION, 1]):
            raise InputError(f"photogrammetry: cannot write {name} to the work folder {folder}")
        files.append(f)
    return files, (nw / w, nh / h)


def per_image_counts(pycolmap, db_path: Path, files: list[str], names: Sequence[str]) -> tuple[list[dict], int]:
    """Per image (input order) its SIFT features and those in verified matches, read from
    COLMAP's database; and the number of verified image pairs."""
    db = pycolmap.Database.open(str(db_path))
    try:
        ids = {im.name: im.image_id for im in db.read_all_images()}
        feats = {i: db.num_keypoints_for_image(i) for i in ids.values()}
        matched: dict[int, set] = {i: set() for i in ids.values()}
        pair_ids, geoms = db.read_two_view_geometries()
        n_pairs = 0
        for pid, g in zip(pair_ids, geoms, strict=True):
            m = np.asarray(g.inlier_matches)
            if len(m) == 0:
                continue
            n_pairs += 1
            a, b = pycolmap.pair_id_to_image_pair(pid)
            matched[a].update(m[:, 0].tolist())
            matched[b].update(m[:, 1].tolist())
    finally:
        db.close()
    rows = []
    for f, n in zip(files, names, strict=True):
        i = ids.get(f)
        rows.append(
            {
                "image": n,
                "n_features": int(feats.get(i, 0)) if i is not None else 0,
                "n_matched": len(matched.get(i, ())) if i is not None else 0,
                "registered": False,
                "reason": "",
            }
        )
    return rows, n_pairs
