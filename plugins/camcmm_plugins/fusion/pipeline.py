"""The fusion pipeline of thesis fig. 6.1, stage by stage (plain functions on the data
model; the host entry is :mod:`.plugin`)."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

from camcmm.api import InputError, PointCloud, numbers

from . import difference as dif
from .match import features, match_features
from .match import reject as reject_matches
from .merge import in_footprint, merge, subsample_grid, transform
from .prepare import csi_image as make_csi_image
from .prepare import normalised_blur, shade, stretch
from .project import cloud_grid, fit_plane, grey, mirrored, splat
from .similarity2d import apply, refine, robust_fit, rot
from .zreg import Placement, icp_3dof


def _small(img: np.ndarray, side: int = 256) -> tuple[list, float]:

    f = min(1.0, side / max(img.shape))
    if f < 1:
        img = cv2.resize(
            img, (max(1, round(img.shape[1] * f)), max(1, round(img.shape[0] * f))), interpolation=cv2.INTER_AREA
        )
    return img.tolist(), f


def photo_image(local: np.ndarray, colors, grid: int | None, sigma_px: float) -> dict:
    """Step 1-2 on the cloud's side: grey image (uint8), mask, pixel (mm), origin (mm)."""
    uv = local[:, :2]
    pixel, origin, shape = cloud_grid(uv, grid)
    if colors is not None:
        s, w = splat(uv, grey(colors), pixel, origin, shape)
        img = normalised_blur(s, w, sigma_px)
    else:  # no colour: the curvature image, as for a CSI map without intensity (prepare.shade)
        s, w = splat(uv, local[:, 2], pixel, origin, shape)
        g = shade(normalised_blur(s, w, 1.0), pixel, pixel)
        ok = np.isfinite(g) & (w > 0)
        img = normalised_blur(np.where(ok, g, 0.0), ok.astype(float), sigma_px)
    covered = normalised_blur(w, np.ones_like(w), 1.0) > 0.05 if sigma_px > 0 else w > 0
    return {"image": stretch(img, covered), "mask": covered, "pixel": pixel, "origin": origin}


#: the blurs (px of the cloud's image) tried when the one asked for leaves too few matches
TRIAL_BLURS_PX = (0.0, 1.0, 2.0, 4.0, 8.0)


def photo_images(local0: np.ndarray, colors, frames: list, grid: int | None, sigma_px: float) -> list[tuple]:
    """The cloud's grey image in each frame tried: [(frame (3, 3), local coordinates, image
    dict of :func:`photo_image`)]; the second (when two frames are given) is the plane seen
    from the other side (:func:`.project.mirrored`)."""
    images: list[tuple] = [(frames[0], local0, photo_image(local0, colors, grid, sigma_px))]
    if len(frames) == 2:
        local1 = local0[:, [1, 0, 2]] * [1.0, 1.0, -1.0]  # the mirrored frame's coordinates
        if colors is not None:  # the colour image seen from the other side is the transposed one
            ph0 = images[0][2]
            ph1 = {
                "image": ph0["image"].T.copy(),
                "mask": ph0["mask"].T.copy(),
                "pixel": ph0["pixel"],
                "transposed": True,
            }
            ph1["origin"] = ph0["origin"][::-1].copy()
        else:  # (the shading is not: the heights change sign)
            ph1 = photo_image(local1, None, grid, sigma_px)
        images.append((frames[1], local1, ph1))
    return images


def match_map(
    images: list[tuple],
    sigma_px: float,
    chosen: int | None,
    photo_features: dict[int, tuple],
    *,
    hm,
    inten,
    pixel: float,
    ratio: float,
    ransac_px: float,
    seed: int,
    reject: str,
):
    """Steps 2-3 for one map at blur ``sigma_px``: its grey image, SIFT against the cloud's
    image in each frame (only ``chosen`` once a map has fixed it), both rejections.
    ``photo_features`` caches the cloud's features by frame (for this blur).

    Returns
    -------
    n (inliers of ``reject``), frame index, pa, pb (CSI / cloud px), rejections, CSI image,
    its pixel (mm)
    """
    pc = max(min(hm.dx, hm.dy), 0.5 * pixel)
    cimg, cmask, pc = make_csi_image(hm.heights, inten, hm.dx, hm.dy, pc, sigma_px * pixel)
    best = None
    fc = features(cimg, cmask)
    for idx, (_f, _local, ph) in enumerate(images) if chosen is None else [(chosen, images[chosen])]:
        if idx == 1 and ph.get("transposed"):
            # the mirrored frame's image is the transposed one: match the transposed CSI
            # image with the features already found instead of a second SIFT of the big image
            if 0 not in photo_features:
                photo_features[0] = features(images[0][2]["image"], images[0][2]["mask"])
            pa, pb = match_features(features(cimg.T.copy(), cmask.T.copy()), photo_features[0], ratio)
            pa, pb = pa[:, ::-1].copy(), pb[:, ::-1].copy()
        else:
            if idx not in photo_features:
                photo_features[idx] = features(ph["image"], ph["mask"])
            pa, pb = match_features(fc, photo_features[idx], ratio)
        rj = reject_matches(pa, pb, ransac_px, seed)
        n = int(rj[reject].sum())
        if best is None or n > best[0]:
            best = (n, idx, pa, pb, rj)
    assert best is not None
    return (*best, cimg, pc)


def too_few(
    name: str,
    n_matches: int,
    n: int,
    need: int,
    sigma_px: float,
    trials: dict[float, int],
    named: Callable[[str], str],
    cloud: PointCloud,
    hm,
    inten,
) -> str:
    """The one line refusing a map with too few matches: what was found at the blur asked
    for, and the blur that gives enough (``trials``: blur px -> consistent matches; the one
    nearest the blur asked for among those giving twice ``need``, else the one giving most),
    or, when none does, what else to check."""
    blur = named("sigma_px")
    head = (
        f"{name}: too few matches with the cloud at {blur} = {sigma_px:g} ({n_matches} SIFT matches, {n} consistent; "
        f"at least {need} needed)"
    )
    good = {sg: k for sg, k in trials.items() if k >= need}
    if good:
        # the blur nearest the one asked for among those with a margin (twice the inliers needed):
        # it keeps most of the blur's purpose (only the shared bandwidth); else the most inliers
        ample = [sg for sg, k in good.items() if k >= 2 * need]
        if ample:
            best = min(ample, key=lambda sg: (abs(sg - sigma_px), -good[sg]))
        else:
            best = max(good, key=lambda sg: good[sg])
        return f"{head}; {blur} = {best:g} gives {good[best]} consistent matches: set {blur} to {best:g}"
    tried = ", ".join(f"{sg:g}" for sg in sorted({*trials, sigma_px}))
    what = f"{head}; no blur tried ({tried} px) gives {need}: the map may not overlap the cloud"
    if inten is None and cloud.colors is not None:
        return (
            f"{what}, or the cloud's colours do not show the relief the map is matched by "
            f"(it has no intensity channel, or {named('grey')} is shaded)"
        )
    return f"{what}, or the two grey images show different things"


def run(
    cloud: PointCloud,
    maps: list,
    names: list[str],
    datum: dict | None = None,
    sigma_px: float = 6.0,
    reject: str = "similarity",
    grey: str = "auto",
    grid: int | None = None,
    ransac_px: float = 3.0,
    min_inliers: int = 8,
    ratio: float = 0.8,
    icp_iterations: int = 50,
    icp_max_distance: float | None = None,
    icp_points: int = 20000,
    max_points: int = 2_000_000,
    seed: int = 0,
    material_ratio: Callable[[np.ndarray], dict] | None = None,
    progress: Callable[[float, str], None] | None = None,
    named: Callable[[str], str] = lambda key: key.replace("_", " "),
) -> dict[str, Any]:
    """Fuse CSI height maps with a photogrammetry cloud; returns fused, result, views
    (see plugin.yaml). Raises InputError naming the map for too few matches (with the blur
    that would give enough, :func:`too_few`), no overlap or an implausible scale (a wrong
    unit). ``named(key)``: a parameter as the form labels it, for the messages."""
    say = progress or (lambda f, m: None)
    timings: dict[str, float] = {}
    warnings: list[str] = []

    def tick(stage: str, t0: float) -> float:
        timings[stage] = timings.get(stage, 0.0) + time.perf_counter() - t0
        return time.perf_counter()

    t = time.perf_counter()
    say(0.02, "plane and grey image of the cloud")
    pts = cloud.points
    if len(pts) < 100:
        raise InputError(f"{cloud.name}: {len(pts)} points, too few for a fusion")
    if grey == "intensity" and cloud.colors is None:
        raise InputError(
            f"{cloud.name}: the cloud has no colours, so it is matched by its relief, which a map's intensity "
            f"does not show: set {named('grey')} to shaded (or auto)"
        )
    centre, frame0 = fit_plane(pts, datum)
    frames = [frame0] if datum is not None else [frame0, mirrored(frame0)]
    local0 = (pts - centre) @ frame0.T
    images = photo_images(local0, cloud.colors, frames, grid, sigma_px)
    t = tick("project", t)

    per_map: list[dict] = []
    chosen = None
    photo_features: dict[int, tuple] = {}
    for k, (hm, name) in enumerate(zip(maps, names), start=1):
        say(0.1 + 0.5 * (k - 1) / len(maps), f"matching {name}")
        pixel = images[0][2]["pixel"]
        extent = float(np.ptp(images[0][1][:, :2], axis=0).max())
        w_mm = max(hm.size_mm)
        if w_mm > 2 * extent or w_mm < 8 * pixel:
            raise InputError(
                f"{name}: the map is {numbers.length(w_mm)} wide, the cloud {numbers.length(extent)} "
                f"(its image pixel {numbers.length(pixel, unit='µm')}): "
                f"a wrong length unit in the map ({hm.source_unit}) or in the cloud ({cloud.source_unit})?"
            )
        if grey == "intensity" and hm.intensity is None:
            raise InputError(f"{name}: the map has no intensity channel: set {named('grey')} to shaded or auto")
        # a cloud without colours is drawn by its relief: the map must be too (auto), whatever channels it has
        inten = None if grey == "shaded" or cloud.colors is None else hm.intensity
        match = functools.partial(
            match_map, hm=hm, inten=inten, pixel=pixel, ratio=ratio, ransac_px=ransac_px, seed=seed, reject=reject
        )
        n, idx, pa, pb, rj, cimg, pc = match(images, sigma_px, chosen, photo_features)
        if n < min_inliers:
            trials = {}
            for sg in TRIAL_BLURS_PX:
                if sg != sigma_px:
                    say(0.1 + 0.5 * (k - 1) / len(maps), f"{name}: {n} consistent matches, trying a blur of {sg:g} px")
                    trial = photo_images(local0, cloud.colors, frames, grid, sg)
                    trials[sg] = match(trial, sg, chosen, {})[0]
            raise InputError(too_few(name, len(pa), n, min_inliers, sigma_px, trials, named, cloud, hm, inten))
        t = tick("match", t)
        chosen = idx
        f, local, ph = images[idx]
        a_mm = pa * pc + np.asarray(hm.origin)
        b_mm = pb * ph["pixel"] + ph["origin"]
        inl = rj[reject]
        s, th, tr, keep = robust_fit(a_mm[inl], b_mm[inl], ransac_px * ph["pixel"])
        s, th, tr, refined = refine(cimg, ph, hm, pc, s, th, tr, ransac_px, sigma_px * ph["pixel"] / pc)
        if not refined:
            warnings.append(f"{name}: the image correlation did not refine the SIFT registration; kept SIFT's")
        if not 0.5 <= s <= 2.0:
            raise InputError(
                f"{name}: the map is {numbers.plain(s, 4)} times the cloud's size (expected near 1): "
                f"a wrong length unit in the map ({hm.source_unit}) or in the cloud ({cloud.source_unit})?"
            )
        t = tick("similarity", t)
        per_map.append(
            {
                "hm": hm,
                "file": name,
                "s": s,
                "theta": th,
                "t": tr,
                "pa": pa[inl][keep],
                "pb": pb[inl][keep],
                "n_matches": len(pa),
                "n_sim": int(rj["similarity"].sum()),
                "n_fun": int(rj["fundamental"].sum()),
                "n_inliers": int(keep.sum()),
                "cimg": cimg,
                "inten": inten,
                "pc": pc,
            }
        )

    scales = np.array([m["s"] for m in per_map])
    s_mean = float(scales.mean())
    s_std = float(scales.std(ddof=1)) if len(scales) > 1 else None
    assert chosen is not None  # set by the first map
    f, local, ph = images[chosen]
    q = local / s_mean  # the cloud in the fused frame: plane coordinates, scale fixed by the CSI
    keep_photo = np.ones(len(q), bool)
    parts, out_maps, views = [], [], []
    spacing = ph["pixel"] / s_mean
    for k, m in enumerate(per_map, start=1):
        say(0.6 + 0.3 * (k - 1) / len(per_map), f"z registration and ICP of {m['file']}")
        hm, s, th, tr = m["hm"], m["s"], m["theta"], m["t"]
        xy_map = (q[:, :2] * s_mean - tr) @ rot(th) / s  # inverse of eq. 6.1
        foot = in_footprint(xy_map, hm)
        if foot.sum() < 10:
            raise InputError(f"{m['file']}: no overlap with the cloud ({int(foot.sum())} cloud points on the map)")
        pm = hm.points()
        cmap = pm[:, :2].mean(axis=0)
        zc = float(pm[:, 2].mean())
        place = Placement(th, cmap, zc, apply(s, th, tr, cmap[None])[0] / s_mean)
        # z registration by mean heights, over the same places on both sides
        from scipy.ndimage import map_coordinates

        hh = map_coordinates(
            hm.heights,
            [(xy_map[foot, 1] - hm.origin[1]) / hm.dy, (xy_map[foot, 0] - hm.origin[0]) / hm.dx],
            order=1,
            cval=np.nan,
        )
        okz = np.isfinite(hh)
        place.tz = float(q[foot, 2][okz].mean() - hh[okz].mean() + zc)
        t = tick("zreg", t)
        qf = q[foot]
        icp = icp_3dof(place, qf[:: max(1, len(qf) // icp_points)], hm, icp_max_distance or 5 * spacing, icp_iterations)
        if not icp["converged"]:
            warnings.append(
                f"{m['file']}: the 3-DOF ICP did not converge in {icp['iterations']} iterations "
                f"(raise {named('icp_iterations')}, or {named('icp_max_distance')} when the map starts far off)"
            )
        t = tick("icp", t)
        mat = place.matrix()
        keep_photo &= ~foot
        sub, ij = subsample_grid(hm, max_points)
        # the CSI points keep the raw intensity (or shading), not the blurred matching image
        raw = m["inten"] if m["inten"] is not None else shade(hm.heights, hm.dx, hm.dy)
        gv = stretch(raw[ij[:, 0], ij[:, 1]][None, :])[0]
        parts.append((transform(mat, sub), gv))
        t = tick("merge", t)
        from .zreg import residuals

        gy, gx = np.gradient(hm.heights, hm.dy, hm.dx)
        d = -residuals(mat, q[foot], hm.heights, gx, gy, hm.origin[0], hm.origin[1], hm.dx, hm.dy)
        st = dif.stats(d)
        mr = material_ratio(d[np.isfinite(d)]) if material_ratio is not None and st["n"] > 10 else {}
        t = tick("difference", t)
        tpx = (tr - ph["origin"]) / ph["pixel"]
        out_maps.append(
            {
                "file": m["file"],
                "n_matches": m["n_matches"],
                "n_inliers": m["n_inliers"],
                "n_inliers_similarity": m["n_sim"],
                "n_inliers_fundamental": m["n_fun"],
                "transform2d": {
                    "angle_deg": float(np.degrees(th)),
                    "tx": float(tpx[0]),
                    "ty": float(tpx[1]),
                    "scale": s,
                },
                "icp": {k2: icp[k2] for k2 in ("tz", "rx_deg", "ry_deg", "rms", "converged", "iterations", "n_used")},
                "difference": st,
                "material_ratio": {k2: mr.get(k2) for k2 in ("Sk", "Spk", "Svk", "Smr1", "Smr2")},
                "transform": _to_cloud(f, centre) @ mat,
                "n_points_replaced": int(foot.sum()),
                "grey": "shaded" if m["inten"] is None else "intensity",
            }
        )
        ci, cs = _small(m["cimg"])
        pi, ps = _small(ph["image"])
        w, h = hm.size_mm
        corners = np.array([[0, 0, zc], [w, 0, zc], [w, h, zc], [0, h, zc]]) + [hm.origin[0], hm.origin[1], 0]
        views.append(
            {
                "file": m["file"],
                "photo_image": pi,
                "photo_scale": ps,
                "csi_image": ci,
                "csi_scale": cs,
                "matches": {"photo": (m["pb"] * ps).tolist(), "csi": (m["pa"] * cs).tolist()},
                "footprint": transform(_to_cloud(f, centre) @ mat, corners).tolist(),
                "difference": dif.grid(xy_map[foot], d, hm),
                "histogram": dif.histogram(d),
                "abbott": {
                    "mr_percent": _curve(mr, "mr_percent"),
                    "height": _curve(mr, "height"),
                    "p2_5": st["p2_5"],
                    "p97_5": st["p97_5"],
                },
            }
        )

    say(0.92, "fused cloud")
    # the photogrammetry points straight in the cloud's coordinates (c + (p − c)/s), the maps' through their transforms
    photo_out = centre + (pts - centre) / s_mean
    parts = [(transform(_to_cloud(f, centre), p), g) for p, g in parts]
    fused_pts, cols, src = merge(photo_out, cloud.colors, keep_photo, parts)
    fused = PointCloud(
        fused_pts, colors=cols, fields={"source": src}, field_units={"source": ""}, name=f"{cloud.name} fused"
    )
    t = tick("merge", t)
    for m in out_maps:
        m["transform"] = m["transform"].tolist()
    result = {
        "maps": out_maps,
        "photogrammetry_scale": {"value": s_mean, "std": s_std},
        "n_points_fused": int(len(fused_pts)),
        "warnings": warnings,
        "timings": timings,
        "plane": {"point": centre.tolist(), "normal": f[2].tolist()},
        "grid": list(ph["image"].shape[::-1]),
        "pixel_mm": ph["pixel"],
        "reject": reject,
    }
    return {"fused": fused, "result": result, "views": {"maps": views}}


def _curve(mr: dict, key: str) -> list | None:
    """The material-ratio curve's column as a list, thinned to ≤ 512 points (for the views)."""
    c = (mr.get("curve") or {}).get(key)
    if c is None:
        return None
    c = np.asarray(c, dtype=float)
    return c[:: max(1, len(c) // 512)].tolist()


def _to_cloud(f: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """4×4: fused frame (plane coordinates) -> the cloud's coordinates (scaled about the
    plane's centre by 1/scale, which the fused frame already holds)."""
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = f.T, centre
    return m
