"""A simulated single-camera photogrammetry system: a DSLR, a turntable and a laser
speckle projector on the table (thesis ch. 4.2), measuring what a VDI/VDE 2634-3
position places in front of it — the wizard's "Acquire" for chapter 4's test.

One call, for one placement:

1. the scene: for a sphere position the probing sphere (the plan's, 10 mm) with two
   ball-plate spheres beside it, as the thesis scaled its sphere reconstructions
   (ch. 4.5.1), the camera at the position's azimuth and 45° elevation; for a
   ball-plate position the plate turned and tilted as fig. 4.4 asks, at a higher
   elevation (ch. 4.5.2); the turntable's top below them (it carries speckle too);
2. the turntable series (``turntable.TurntableSeries``: DSLR geometry and lens blur,
   objective speckle λz/D and the camera's subjective speckle, sensor noise), n images
   through 180° (thesis: 30), the speckle pattern and the noise drawn from (seed, test,
   position, repeat): a repeat is a new speckle pattern, as in ch. 4.5;
3. ``photogrammetry.reconstruct`` through the host (SfM + dense, arbitrary scale);
4. the operator's export of each sphere's points (ch. 4.5.1: "each spheres point cloud
   exported individually"): the points within 1.25 r of a sphere, located by a
   similarity from the reconstructed camera centres to the true ones. That similarity
   only *locates* the spheres; its scale is never used for the cloud;
5. the scale, as the thesis set it: the two calibrated 5 mm spheres' radii
   (s = mean r_c / r_fit, table 4.1) for a sphere position; the calibrated lengths
   (s = mean L_c,i / L_r,i; the standard then applies eqs. 4.10-4.12 itself) for a ball
   plate. Its standard uncertainty (the calibration's and the fits') is returned.

The cloud is in mm, rotated into the table's frame (+z up the axis). Lengths in mm,
angles in degrees.
"""

from __future__ import annotations

import hashlib
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import GeometryError, InputError, PluginError, PointCloud

from . import artefacts
from .capture import _transform
from .lab import move_primitive
from .scene import Cylinder, Rectangle, Sphere

#: Camera elevations (deg): ch. 4.5.1 "approximately 45°"; ch. 4.5.2 "slightly higher".
SPHERE_ELEVATION, PLATE_ELEVATION = 45.0, 55.0
#: Points kept around each sphere (radii from its centre) as the operator's export.
CROP = 1.25
#: Smallest speckle grain (px of the rendered image) when the grain is automatic: SIFT
#: finds and matches grains of a few pixels; at 1.8 px (λz/D at 750 px) SfM failed.
MIN_GRAIN_PX = 4.0


def _lowest(p) -> float:
    """Lowest z (mm) of a primitive, for the table top below the artefact."""
    if isinstance(p, Sphere):
        return float(p.center[2] - p.radius)
    if isinstance(p, Cylinder):
        return float(min(p.p0[2], p.p1[2]) - p.radius)
    if isinstance(p, Rectangle):
        half = np.abs(p.axis[2]) * p.length / 2 + np.abs(p.v[2]) * p.width / 2
        return float(p.center[2] - half)
    return 0.0


def placed_scene(placement: dict[str, Any]) -> tuple[list, dict[str, Any], float, list[float]]:
    """(primitives, truth, elevation, calibrated scale references) for a placement;
    the references are the scale spheres' radii (sphere) or the plate's lengths."""
    try:
        test = str(placement["test"])
        pos = dict(placement.get("position") or {})
        arts = dict(placement.get("artefacts") or {})
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"placement: expected test, position and artefacts ({exc})") from None
    plate = dict(arts.get("ball_plate") or {})
    if test == "sphere":
        if "diameter" not in (arts.get("sphere") or {}):
            raise InputError("placement: the plan's sphere has no diameter")
        if "sphere_diameter" not in plate:
            raise InputError(
                "placement: the photogrammetry system scales the sphere by the ball plate's spheres "
                "(thesis ch. 4.5.1); the plan needs artefacts.ball_plate.sphere_diameter"
            )
        d, ds = float(arts["sphere"]["diameter"]), float(plate["sphere_diameter"])
        prims, truth = artefacts.sphere_with_scale((0.0, 0.0, 0.0), d, ds)
        cam = dict(pos.get("camera") or {})
        az, el = float(cam.get("azimuth", 0.0)), float(cam.get("elevation", SPHERE_ELEVATION))
        refs = [ds / 2, ds / 2]
    elif test == "ball_plate":
        lengths = plate.get("lengths")
        if not isinstance(lengths, list) or len(lengths) != 3 or "sphere_diameter" not in plate:
            raise InputError("placement: the plan's ball plate needs sphere_diameter and three lengths")
        refs = [float(x) for x in lengths]
        prims, truth = artefacts.ball_plate(
            (0.0, 0.0, 0.0),
            refs,
            float(plate["sphere_diameter"]),
            float(pos.get("rotation", 0.0)),
            float(pos.get("tilt", 0.0)),
        )
        az, el = 0.0, PLATE_ELEVATION
    else:
        raise InputError(
            f"placement: the simulated photogrammetry system measures spheres and ball plates, not {test!r}"
        )
    # the camera at azimuth a is the artefact turned by -a under a camera at azimuth 0
    a = math.radians(-az)
    R = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    prims = [move_primitive(p, R, np.zeros(3)) for p in prims]
    truth = _transform(truth, R, np.zeros(3))
    z = min(_lowest(p) for p in prims) - 0.5
    span = 8.0 * max(s["diameter"] for s in truth["spheres"]) + 20.0
    prims.append(
        Rectangle(
            np.array([0.0, 0.0, z]),
            np.array([1.0, 0, 0]),
            np.array([0, 0, 1.0]),
            span,
            span,
            "turntable",
            measured=False,
        )
    )
    return prims, truth, el, refs


def _seed(seed: int, placement: dict[str, Any]) -> int:
    key = (
        f"{seed}/{placement.get('test')}/{(placement.get('position') or {}).get('id', '')}/{placement.get('repeat', 1)}"
    )
    return int(hashlib.sha256(key.encode()).hexdigest()[:8], 16)


def render(placement: dict[str, Any], out: Path, opts: dict[str, Any], progress=None) -> dict[str, Any]:
    """Render the placement's turntable series into ``out``; returns files, the true
    camera centres by image name, the spheres' truth and the calibrated references."""
    from camcmm.api import Image, write

    from . import turntable
    from .dslr import Dslr
    from .speckle import objective_grain

    prims, truth, elevation, refs = placed_scene(placement)
    seed = _seed(int(opts.get("seed", 0)), placement)
    grain = float(opts.get("grain") or 0.0)
    if grain <= 0:  # λ z / D, but at least MIN_GRAIN_PX of the down-scaled image
        pitch = Dslr(float(opts["downscale"]), float(opts["f_number"]), float(opts["magnification"])).pitch
        grain = max(objective_grain(532.0, 80.0, 0.25), MIN_GRAIN_PX * pitch / float(opts["magnification"]))
    spec = turntable.SeriesSpec(
        artefact="ball_plate" if placement.get("test") == "ball_plate" else "sphere_with_scale",
        n_images=int(opts["n_images"]),
        arc_deg=float(opts["arc"]),
        elevation_deg=elevation,
        downscale=float(opts["downscale"]),
        f_number=float(opts["f_number"]),
        magnification=float(opts["magnification"]),
        speckle=bool(opts["speckle"]),
        grain_mm=grain,
        supersample=int(opts["supersample"]),
        seed=seed % (1 << 31),
    )
    series = turntable.TurntableSeries(spec)
    # the placed artefact instead of the catalogue's: the series' own target and projector
    series.prims = prims
    series.albedo = np.array([turntable.ALBEDO_CARBIDE if p.measured else turntable.ALBEDO_HOLDER for p in prims])
    series.artefact_truth = truth
    series.target, radius = turntable._extent(truth)
    series.projector, series.pattern = series._projector(radius)
    files, centres = [], {}
    for k in range(spec.n_images):
        if progress:
            progress(0.4 * k / spec.n_images, f"rendering view {k + 1}/{spec.n_images}")
        name = f"image{k:03d}.png"
        write(Image(series.image(k), name=name), out / name)
        files.append(str(out / name))
        centres[name] = series.view_truth(k, name)["centre"]
    return {
        "camera": series.camera(0),
        "files": files,
        "centres": centres,
        "truth": truth,
        "refs": refs,
        "seed": seed,
        "spec": spec,
        "grain_mm": grain,
        "angles": series.angles.tolist(),  # the table angle of each image (deg)
    }


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R, t) minimising |dst - (s R src + t)|² (Umeyama 1991, eqs. 40-42); by hand:
    a dozen lines, and the photogrammetry plugin's own is not ours to import."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - ms, dst - md
    U, S, Vt = np.linalg.svd(b.T @ a / len(src))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / (a**2).sum() * len(src))
    return s, R, md - s * R @ ms


def _fit(ctx, points: np.ndarray, what: str) -> dict[str, Any]:
    try:
        return ctx.algorithm("fit.sphere")(cloud=PointCloud(points), outliers="percent:5")
    except GeometryError as exc:
        raise GeometryError(f"{what}: no sphere fit ({exc})") from None


def _scale(ctx, X: np.ndarray, groups: list[np.ndarray], test: str, refs: list[float], u_ref: float):
    """(factor mm per reconstruction unit, its standard uncertainty, details) from the
    scale spheres' radii (sphere test) or the plate's three lengths."""
    fits = [_fit(ctx, X[g], f"sphere {k + 1}") for k, g in enumerate(groups)]
    if test == "sphere":
        sc = fits[1:]
        ratios = np.array([r / f["radius"] for r, f in zip(refs, sc)])
        rel = [math.hypot(u_ref / r, f["std_uncertainty"]["radius"] / f["radius"]) for r, f in zip(refs, sc)]
        details = {"radii_fitted": [f["radius"] for f in sc], "radii_calibrated": refs}
    else:
        c = np.array([f["center"] for f in fits])
        l_rec = np.array([np.linalg.norm(c[(k + 1) % 3] - c[k]) for k in range(3)])
        ratios = np.asarray(refs) / l_rec
        u_c = [math.hypot(*(np.asarray(f["std_uncertainty"]["center"]))) for f in fits]
        rel = [
            math.hypot(u_ref / L, math.hypot(u_c[k], u_c[(k + 1) % 3]) / lr)
            for k, (L, lr) in enumerate(zip(refs, l_rec))
        ]
        details = {"lengths_reconstructed": l_rec.tolist(), "lengths_calibrated": refs}
    s = float(ratios.mean())
    # no credit for averaging: the references' calibrations are likely correlated
    u = s * float(np.mean(rel))
    return s, u, details


def measure(placement: dict[str, Any], opts: dict[str, Any], ctx) -> dict[str, Any]:
    """Render, reconstruct, export the spheres and scale one placement (see the module
    docstring); ``{"cloud", "scale", "n_images", "n_registered", "timings", ...}``."""
    try:
        reconstruct = ctx.algorithm("photogrammetry.reconstruct")
    except Exception as exc:
        raise PluginError(
            f"the simulated photogrammetry system needs the algorithm photogrammetry.reconstruct ({exc})"
        ) from None
    t0 = time.perf_counter()
    test = str(placement.get("test"))
    name = (placement.get("position") or {}).get("id") or f"{test}-x"  # the id names its test already
    with tempfile.TemporaryDirectory(prefix="camcmm-photo-system-") as tmp:
        series = render(placement, Path(tmp), opts, ctx.progress)
        t1 = time.perf_counter()
        ctx.progress(0.4, "reconstructing (SfM + dense)")
        kw: dict[str, Any] = {}
        if opts.get("calibrated"):
            cam = series["camera"]
            kw["calibration"] = {
                "camera_matrix": np.asarray(cam.camera_matrix).tolist(),
                "dist_coeffs": [0.0] * 5,
                "image_size": list(cam.image_size),
            }
        rec = reconstruct(
            images=series["files"],
            dense=bool(opts.get("dense", True)),
            max_image_size=int(opts["max_image_size"]),
            # the table's known angles check the cameras; every pair is still matched (a few
            # views: the long-baseline pairs cost little, and a window cost accuracy in tests)
            turntable_angles=",".join(f"{a:.9g}" for a in series["angles"]),
            turntable_window=0.0,
            **kw,
        )
    t2 = time.perf_counter()
    info = rec.get("reconstruction") or {}
    views = info.get("views") or []
    names = [Path(str(v["image"])).name for v in views]
    if len(views) < 3:
        raise GeometryError(f"{name}: only {len(views)} of {len(series['files'])} views registered")
    src = np.array([v["centre"] for v in views], float)
    dst = np.array([series["centres"][n] for n in names], float)
    s_cam, R, t = similarity(src, dst)
    cloud = rec["cloud"]
    X = np.asarray(cloud.points, float)
    W = s_cam * X @ R.T + t  # only to find the spheres (the operator's export)
    groups = []
    for k, sph in enumerate(series["truth"]["spheres"]):
        r = sph["diameter"] / 2
        g = np.flatnonzero(np.linalg.norm(W - np.asarray(sph["center"]), axis=1) <= CROP * r)
        if len(g) < 30:
            raise GeometryError(
                f"{name}: the reconstruction has {len(g)} points on sphere {k + 1} (needs 30); "
                "more views, larger images or the speckle on"
            )
        groups.append(g)
    arts = placement.get("artefacts") or {}
    plate = arts.get("ball_plate") or {}
    k_cov = float(plate.get("k") or 2.0)
    if test == "sphere":
        u_ref = float(plate.get("sphere_diameter_uncertainty") or 0.0) / k_cov / 2
    else:
        u_ref = float(plate.get("uncertainty") or 0.0) / k_cov
    s, u, details = _scale(ctx, X, groups, test, series["refs"], u_ref)
    keep = np.concatenate(groups)
    m = W[keep].mean(axis=0)
    pts = (s / s_cam) * (W[keep] - m) + m  # the similarity's rotation, the spheres' scale
    fields = {k: np.asarray(v)[keep] for k, v in (cloud.fields or {}).items()}
    out_cloud = PointCloud(pts, fields=fields, name=name)
    t3 = time.perf_counter()
    resid = np.linalg.norm(s_cam * src @ R.T + t - dst, axis=1)
    return {
        "cloud": out_cloud,
        "n_points": int(len(keep)),
        "n_images": len(series["files"]),
        "n_registered": len(views),
        "scale": {
            "method": "spheres" if test == "sphere" else "lengths",
            "factor": s,
            "u": u,
            "relative_u": u / s,
            "details": details,
            # the virtual lab knows the truth: the scale's error against the true cameras
            "error_vs_truth": s / s_cam - 1.0,
        },
        "camera_centre_rms_mm": float(np.sqrt(np.mean(resid**2))),
        "seed": series["seed"],
        "timings": {"render_s": t1 - t0, "reconstruct_s": t2 - t1, "scale_s": t3 - t2},
    }
