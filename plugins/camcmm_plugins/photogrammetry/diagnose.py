"""Why an image was left out of the reconstruction, said so one can act on it.

COLMAP's incremental mapper adds an image when enough of its features match features of
the images already registered that are points of the model: it estimates the image's pose
from those 2-D-3-D correspondences (absolute pose, RANSAC) and keeps it when at least
``abs_pose_min_num_inliers`` (30) of them, and ``abs_pose_min_inlier_ratio`` (25 %) of
them, agree; image pairs with fewer than ``min_num_matches`` (15) verified matches are not
used at all (Schönberger & Frahm 2016, "Structure-from-Motion Revisited", sec. 4.2; COLMAP's
IncrementalMapperOptions). So for each unregistered image :func:`image_links` reads from
COLMAP's database the verified (inlier) matches of every pair it is in — the two-view
geometries — and from the model which of the registered partners' matched features are
points of the model; :func:`reason` then says which of these holds, in this order:

1. ``texture``: fewer than :data:`.inputs.MIN_FEATURES` SIFT features;
2. ``no matches``: no verified match with any image;
3. ``not linked``: verified matches only with other unregistered images;
4. ``too few``: fewer correspondences to points of the model than the mapper's minimum;
5. ``degenerate``: enough of them, but every usable pair's geometry is a homography (a flat
   scene, or a camera that only turned: no baseline; COLMAP's PLANAR / PANORAMIC
   configurations), or they all come from one registered image;
6. ``inconsistent``: enough, from several views, but the mapper found no pose that enough of
   them agree on (wrong matches from repeated or symmetric texture, or — self-calibrating —
   a focal length and distortion not yet settled by the few images registered so far).

Each reason names the counts and what to try.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .inputs import MIN_FEATURES

#: COLMAP's two-view configurations that fit a homography: no baseline to triangulate from
HOMOGRAPHY = {"PLANAR", "PANORAMIC", "PLANAR_OR_PANORAMIC"}
#: what to try, per reason
TRY = {
    "texture": "add texture (a speckle pattern) or use a larger image size",
    "no matches": "take it with more overlap with its neighbours, or match more partners (overlap) or exhaustively",
    "not linked": "add views between these images and the others",
    "too few": "take views with more overlap, match more partners (overlap, sequential or exhaustive matching) "
    "or add texture",
    "degenerate": "add views from further apart (a wider baseline) or with more of the object's depth in view",
    "inconsistent": "add views with more overlap, hold the camera to a calibration, or leave this image out",
}


@dataclass
class Link:
    """The verified matches of an unregistered image with one ``partner`` image: ``inliers``
    (count), ``config`` (COLMAP's two-view configuration name), ``registered`` (the partner
    is in the model)."""

    partner: str
    inliers: int
    config: str
    registered: bool


@dataclass
class Links:
    """An unregistered image's links: one :class:`Link` per partner, and ``on_points``: its
    features matched (in a usable pair) to features of registered images that are points of
    the model, each feature counted once — the correspondences the mapper posed it from."""

    links: list[Link] = field(default_factory=list)
    on_points: int = 0


@dataclass(frozen=True)
class Mapper:
    """The mapper's thresholds (COLMAP's defaults; :func:`mapper_limits` reads the run's)."""

    min_inliers: int = 30  # abs_pose_min_num_inliers
    min_ratio: float = 0.25  # abs_pose_min_inlier_ratio
    min_pair: int = 15  # min_num_matches: a pair with fewer verified matches is not used


def mapper_limits(options: Any) -> Mapper:
    """The thresholds of pycolmap ``IncrementalPipelineOptions``."""
    m = options.mapper
    return Mapper(int(m.abs_pose_min_num_inliers), float(m.abs_pose_min_inlier_ratio), int(options.min_num_matches))


def _listed(names: Sequence[str], limit: int = 3) -> str:
    return ", ".join(names[:limit]) + (f" and {len(names) - limit} more" if len(names) > limit else "")


def reason(n_features: int, found: Links, limits: Mapper = Mapper()) -> tuple[str, str]:
    """``(kind, text)`` of an unregistered image (kinds and their order: module docstring).

    ``n_features``: its SIFT features; ``found``: its links (partners named as a person
    reads them)."""
    if n_features < MIN_FEATURES:
        kind, what = "texture", f"only {n_features} SIFT features (< {MIN_FEATURES}): too little texture"
        return kind, f"{what}; try: {TRY[kind]}"
    links = [k for k in found.links if k.inliers > 0]
    if not links:
        kind = "no matches"
        return kind, f"no verified matches with any image; try: {TRY[kind]}"
    reg = sorted((k for k in links if k.registered), key=lambda k: -k.inliers)
    if not reg:
        kind = "not linked"
        others = _listed([k.partner for k in links])
        return kind, f"verified matches only with other unregistered images ({others}); try: {TRY[kind]}"
    usable = [k for k in reg if k.inliers >= limits.min_pair]
    total = sum(k.inliers for k in reg)
    partners = _listed([f"{k.partner} {k.inliers}" for k in reg])
    images = f"{len(reg)} registered image{'s' if len(reg) > 1 else ''}"
    if found.on_points < limits.min_inliers:
        kind = "too few"
        what = (
            f"too few inlier matches to the registered images: {total} with {images} ({partners}), "
            f"{found.on_points} of them on points of the model where the mapper needs {limits.min_inliers}"
        )
        return kind, f"{what}; try: {TRY[kind]}"
    if usable and all(k.config in HOMOGRAPHY for k in usable):
        kind = "degenerate"
        what = (
            f"degenerate geometry: its matches with {_listed([k.partner for k in usable])} fit a homography "
            "(a flat scene, or a camera that only turned: no baseline to place it)"
        )
        return kind, f"{what}; try: {TRY[kind]}"
    if len(usable) == 1:
        kind = "degenerate"
        what = (
            f"degenerate geometry: matched with only one registered image ({usable[0].partner}, "
            f"{usable[0].inliers} inlier matches): too narrow a base to place it"
        )
        return kind, f"{what}; try: {TRY[kind]}"
    kind = "inconsistent"
    what = (
        f"its {found.on_points} matches on points of the model ({images}: {partners}) "
        f"agree on no one pose (the mapper needs {limits.min_inliers} and {limits.min_ratio:.0%} of them to agree): "
        "wrong matches (repeated or symmetric texture) or a self-calibrated camera not yet settled in a short series"
    )
    return kind, f"{what}; try: {TRY[kind]}"


def _has_point(rec: Any, image_id: int, cache: dict[int, np.ndarray]) -> np.ndarray:
    """Per feature of registered image ``image_id``: is it a point of the model."""
    if image_id not in cache:
        cache[image_id] = np.array([p.has_point3D() for p in rec.images[image_id].points2D], dtype=bool)
    return cache[image_id]


def image_links(pycolmap: Any, db_path: Path, rec: Any, limits: Mapper = Mapper()) -> dict[str, Links]:
    """Per unregistered image (by file name in the database) its :class:`Links` (partners by
    file name), from the two-view geometries in ``db_path`` and the model ``rec``."""
    registered = {int(i) for i in rec.reg_image_ids()}
    db = pycolmap.Database.open(str(db_path))
    try:
        name = {int(im.image_id): im.name for im in db.read_all_images()}
        pair_ids, geoms = db.read_two_view_geometries()
    finally:
        db.close()
    out = {name[i]: Links() for i in name if i not in registered}
    matched: dict[str, set[int]] = {f: set() for f in out}
    cache: dict[int, np.ndarray] = {}
    for pid, g in zip(pair_ids, geoms, strict=True):
        m = np.asarray(g.inlier_matches).reshape(-1, 2)
        if len(m) == 0:
            continue
        a, b = (int(x) for x in pycolmap.pair_id_to_image_pair(pid))
        config = getattr(g.config, "name", str(g.config))
        for u, r, cu, cr in ((a, b, 0, 1), (b, a, 1, 0)):
            if u in registered:
                continue
            out[name[u]].links.append(Link(name[r], len(m), config, r in registered))
            if r in registered and len(m) >= limits.min_pair:
                on = _has_point(rec, r, cache)
                idx = m[:, cr]
                ok = idx < len(on)
                ok[ok] = on[idx[ok]]
                matched[name[u]].update(m[ok, cu].tolist())
    for f, links in out.items():
        links.on_points = len(matched[f])
    return out


def explain_unregistered(
    pycolmap: Any, db_path: Path, rec: Any, rows: list[dict[str, Any]], files: Sequence[str], limits: Mapper
) -> None:
    """Each row (``{image, n_features, ...}``, one per file, input order) of an image the
    model ``rec`` does not hold and that has no reason yet gets ``kind`` and ``reason``
    (partners named by their images' names)."""
    found = image_links(pycolmap, db_path, rec, limits)
    by_file = {f: str(r["image"]) for f, r in zip(files, rows, strict=True)}
    for f, row in zip(files, rows, strict=True):
        if f not in found or row.get("reason"):
            continue
        links = found[f]
        named = Links([Link(by_file.get(k.partner, k.partner), k.inliers, k.config, k.registered) for k in links.links])
        named.on_points = links.on_points
        row["kind"], row["reason"] = reason(int(row["n_features"]), named, limits)
