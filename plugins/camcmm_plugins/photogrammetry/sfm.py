"""Structure from motion with pycolmap: SIFT, matching, mapping, bundle adjustment.

One shared camera for the whole series (a turntable series from one camera), either
self-calibrated or held fixed to a calibration (thesis ch. 2.3-2.5: the collinearity model
with distortion, eqs. 2.1-2.6, solved for all cameras and points at once by bundle
adjustment). pycolmap works on files, so the images are written (down-scaled to
``max_image_size``) into a work folder; the camera comes back at full image size in
OpenCV's convention (see :mod:`.cameras`).

Compared with pycolmap's defaults (exhaustive matching, one SIMPLE_RADIAL camera, the
mapper's own final bundle adjustment, the principal point held at the image centre):

* ring matching (the default) matches each image only with its most alike, found from its
  own SIFT features by visual words (:mod:`.retrieval`) — a ring's or a walk's neighbours in
  any input order; templeRing: 232 of 1081 pairs;
* the mapper is COLMAP's incremental one or, as an option, COLMAP 4's global mapper;
* the series ends with a retriangulation and a final global bundle adjustment run to
  convergence with a robust (Cauchy) loss that, self-calibrating, also refines the principal
  point (kept at the centre, with a warning, where the series does not determine it). On
  templeRing this takes the focal length from +2.0 % to +0.8 % of the gantry's and the
  camera-centre RMS from 0.25-0.28 % to 0.16 % of the ring radius (docs/photogrammetry.md,
  "Structure from motion").
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError

from .cameras import COLMAP_PARAMS, colmap_from_opencv
from .diagnose import explain_unregistered, mapper_limits
from .inputs import check_registration, check_series, per_image_counts, reason_unregistered, write_images
from .progress import Stages, in_chunks
from .retrieval import retrieval_pairs
from .sparse import SparseResult, model_result
from .turntable import DEFAULT_WINDOW, angle_pairs, parse_angles, write_pair_list

#: camera model of a self-calibrated series: COLMAP's, one focal length and k1 (a real lens has
#: distortion; SIMPLE_PINHOLE suits distortion-free optics, see docs/photogrammetry.md)
DEFAULT_MODEL = "SIMPLE_RADIAL"

#: which pairs are matched: ``ring`` (each image with its ``overlap`` most alike, found from the
#: features: :mod:`.retrieval`), ``sequential`` (each with the ``overlap`` next in input order,
#: COLMAP's sequential matcher) or ``exhaustive`` (every pair)
MATCHING = ("ring", "sequential", "exhaustive")
DEFAULT_MATCHING = "ring"
#: partners per image of ring and sequential matching
DEFAULT_OVERLAP = 8
#: ``incremental`` (COLMAP's mapper, one image at a time) or ``global`` (COLMAP 4's global
#: mapper, GLOMAP: rotation averaging, then all positions at once, then bundle adjustment)
MAPPERS = ("incremental", "global")
DEFAULT_MAPPER = "incremental"
#: the first piece of extraction and of matching (then pieces sized from the rate so far,
#: progress.in_chunks): two images keep both cores busy, eight pairs too
FIRST_IMAGES = 2
FIRST_PAIRS = 8
#: share of the matching stage's progress taken by choosing ring matching's pairs (k-means on
#: the descriptors: ~1 s of templeRing's 47 views, against ~1 min of matching)
RETRIEVAL_SHARE = 0.05


def _pycolmap():
    try:
        import pycolmap
    except ImportError as exc:  # pragma: no cover - a declared dependency
        raise InputError(f"photogrammetry needs pycolmap ({exc}); pip install pycolmap") from exc
    pycolmap.logging.minloglevel = 2  # errors only: its INFO lines would flood the CLI's stderr
    return pycolmap


#: scale (px, on the images SfM works at) of the final adjustment's Cauchy loss
#: rho(s) = c^2 ln(1 + s / c^2) of a squared residual s: residuals well within c count as in
#: least squares, a mismatched or badly located SIFT feature several c off hardly pulls
#: (Triggs et al. 2000, "Bundle adjustment - a modern synthesis", sec. 3.3). templeRing's
#: mean reprojection error is 0.29 px; with this loss its camera-centre RMS against the gantry
#: went from 0.25 % (least squares) to 0.16 % of the ring radius, after either mapper
#: (docs/photogrammetry.md, "Structure from motion")
ROBUST_SCALE_PX = 1.0


def _adjust(pycolmap, rec, fixed: bool, refine_pp: bool, refine_distortion: bool = True) -> None:
    """One global bundle adjustment run to convergence: the mapper's own stops early (its
    tolerances serve speed while images are still being added), with a robust loss
    (:data:`ROBUST_SCALE_PX`)."""
    opts = pycolmap.BundleAdjustmentOptions()
    opts.ceres.loss_function_type = pycolmap.LossFunctionType.CAUCHY
    opts.ceres.loss_function_scale = ROBUST_SCALE_PX
    opts.refine_focal_length = not fixed
    opts.refine_extra_params = refine_distortion and not fixed
    opts.refine_principal_point = refine_pp and not fixed
    opts.print_summary = False
    so = opts.ceres.solver_options
    # Ceres' own function tolerance (1e-6): with the robust loss, 1e-10 took 9x the time
    # (templeRing: 41 s against 4.4 s under load 9) for a focal length changed by 1e-5
    # relative; the step and gradient tolerances still take it to convergence
    so.function_tolerance = 1e-6
    so.gradient_tolerance = 1e-12
    so.parameter_tolerance = 1e-10
    so.max_num_iterations = 200
    # the adjuster itself rather than pycolmap.bundle_adjustment, which logs to stderr whatever
    # the log level (the CLI's stderr is one line)
    config = pycolmap.BundleAdjustmentConfig()
    for image_id in rec.reg_image_ids():
        config.add_image(image_id)
    config.fix_gauge(pycolmap.BundleAdjustmentGauge.THREE_POINTS)
    pycolmap.create_default_bundle_adjuster(opts, config, rec).solve()


#: a self-calibrated principal point farther than this share of the image size from the
#: centre is taken for a failure of the adjustment (the principal point is weakly determined)
MAX_PP_SHIFT = 0.1


#: a self-calibrated lens distortion that moves an image corner by more than this share of
#: the half-diagonal is taken for a failure too: camera lenses stay within a few per cent
#: (a 60 mm macro well below 1 %), while a narrow field of view over a low-texture part can
#: trade the focal length against k1 (a virtual nylon part: k1 = -3.7, corners moved 13 %)
MAX_CORNER_DISTORTION = 0.05


def corner_distortion(cam) -> float:
    """Largest displacement of an image corner by the camera's distortion, as a share of
    the half-diagonal (0 for a pinhole): the corner's pinhole ray projected with and
    without the distortion model (forward only, so no undistortion has to converge)."""
    corners = np.array([[0.0, 0.0], [cam.width, 0.0], [0.0, cam.height], [cam.width, cam.height]])
    rays = np.column_stack(
        [
            (corners[:, 0] - cam.principal_point_x) / cam.focal_length_x,
            (corners[:, 1] - cam.principal_point_y) / cam.focal_length_y,
            np.ones(4),
        ]
    )
    img = cam.img_from_cam(rays, False)
    return float(np.max(np.linalg.norm(img - corners, axis=1)) / (0.5 * np.hypot(cam.width, cam.height)))


def _adjust_plausible(pycolmap, rec, fixed: bool, refine_pp: bool) -> list[str]:
    """:func:`_adjust`, then, if the self-calibrated distortion moves the image corners by
    more than :data:`MAX_CORNER_DISTORTION`, the distortion set to zero and the adjustment
    repeated with it held there. Returns the warning saying so (or none)."""
    _adjust(pycolmap, rec, fixed, refine_pp)
    cam = next(iter(rec.cameras.values()))
    moved = 0.0 if fixed else corner_distortion(cam)
    if moved <= MAX_CORNER_DISTORTION:
        return []
    extra = list(cam.extra_params_idxs())
    said = ", ".join(f"{cam.params[i]:.3g}" for i in extra)
    params = np.array(cam.params)
    params[extra] = 0.0
    cam.params = params
    _adjust(pycolmap, rec, fixed, refine_pp, refine_distortion=False)
    return [
        f"the lens distortion is not determined by this series (self-calibrated {said} moves the image "
        f"corners by {100 * moved:.0f} %); it is held at zero"
    ]


def _final_refinement(pycolmap, rec, fixed: bool, refine_pp: bool):
    """The converged final adjustment; with ``refine_pp`` the principal point too (COLMAP's
    mapper holds it at the image centre). A ring of views around the object determines it
    (templeRing: 3-4 px from the gantry's, see docs/photogrammetry.md); where it runs off
    (a short arc) the adjustment without it is kept, with a warning. A lens distortion
    beyond :data:`MAX_CORNER_DISTORTION` is likewise not determined by the series: it is
    set to zero and held there, with a warning. Returns (rec, warnings)."""
    if fixed or not refine_pp:
        return rec, _adjust_plausible(pycolmap, rec, fixed, False)
    backup = pycolmap.Reconstruction(rec)
    warnings = _adjust_plausible(pycolmap, rec, fixed, True)
    cam = next(iter(rec.cameras.values()))
    shift = max(
        abs(cam.principal_point_x - cam.width / 2) / cam.width,
        abs(cam.principal_point_y - cam.height / 2) / cam.height,
    )
    if shift <= MAX_PP_SHIFT and not cam.has_bogus_params(0.1, 10.0, 1.0):
        return rec, warnings
    warnings = _adjust_plausible(pycolmap, backup, fixed, False)
    why = f"{100 * shift:.0f} % of the image from its centre" if shift > MAX_PP_SHIFT else "implausible intrinsics"
    pp = f"the principal point is not determined by this series ({why}); it is kept at the image centre"
    return backup, [*warnings, pp]


def _ring_pairs(pycolmap, db: Path, files: list[str], overlap: int, seed: int) -> list[tuple[int, int]]:
    """Ring matching's pairs (indices into ``files``): each image with its ``overlap`` most
    alike by visual words of the SIFT descriptors in the database (:mod:`.retrieval`)."""
    database = pycolmap.Database.open(str(db))
    try:
        ids = {im.name: im.image_id for im in database.read_all_images()}
        desc = [np.asarray(database.read_descriptors(ids[f]).data) if f in ids else np.zeros((0, 128)) for f in files]
    finally:
        database.close()
    return retrieval_pairs(desc, overlap, seed=seed)


def _camera_id(pycolmap, db: Path) -> int:
    """The id of the camera in the database (the series has one)."""
    database = pycolmap.Database.open(str(db))
    try:
        return int(next(iter(database.read_all_cameras())).camera_id)
    finally:
        database.close()


def _global_options(pycolmap, seed: int, fixed: bool):
    """COLMAP 4's global mapper on the CPU, seeded, the camera held with a calibration."""
    g = pycolmap.GlobalPipelineOptions()
    g.random_seed = seed
    m = g.mapper
    m.random_seed = seed
    m.rotation_averaging.random_seed = seed
    m.global_positioning.random_seed = seed
    m.retriangulation.random_seed = seed
    m.global_positioning.use_gpu = False
    m.bundle_adjustment.ceres.use_gpu = False
    m.bundle_adjustment.refine_focal_length = not fixed
    m.bundle_adjustment.refine_extra_params = not fixed
    m.bundle_adjustment.refine_principal_point = False  # as the incremental mapper: the final adjustment may
    return g


def reconstruct_sparse(
    images: Sequence[np.ndarray],
    names: Sequence[str],
    *,
    calibration: dict[str, Any] | None = None,
    max_image_size: int = 1600,
    matching: str = DEFAULT_MATCHING,
    overlap: int = DEFAULT_OVERLAP,
    mapper: str = DEFAULT_MAPPER,
    camera_model: str = DEFAULT_MODEL,
    max_features: int = 8192,
    refine: bool = True,
    refine_principal_point: bool = True,
    seed: int = 0,
    turntable_angles: Sequence[float] | np.ndarray | str | None = None,
    turntable_window: float = DEFAULT_WINDOW,
    progress: Callable[[float, str], None] | None = None,
    cancel: Callable[[], bool] | None = None,
    workdir: str | Path | None = None,
) -> SparseResult:
    """Sparse reconstruction of an image series from one camera (thesis ch. 2.5).

    Parameters
    ----------
    images : arrays (H, W) grey or (H, W, 3) RGB, all of one size (uint8; others are scaled).
    names : one name per image (used in the result and in messages).
    calibration : None to self-calibrate; else {camera_matrix (3, 3) px, dist_coeffs
        OpenCV order, image_size (w, h)} of the full-size images: held fixed.
    max_image_size : longest side (px) the images are down-scaled to for SfM.
    matching : ``ring`` (each image with its ``overlap`` most alike: a ring's or a walk's
        neighbours found from the features, :mod:`.retrieval`; no order needed), ``sequential``
        (each with the ``overlap`` next in input order) or ``exhaustive`` (every pair).
    overlap : partners per image of ring and sequential matching.
    mapper : ``incremental`` (COLMAP's incremental mapper) or ``global`` (COLMAP 4's global
        mapper: rotation averaging, global positioning, bundle adjustment).
    camera_model : COLMAP model of a self-calibrated camera (see :data:`.cameras.COLMAP_PARAMS`).
    max_features : SIFT features per image at most.
    refine : end with retriangulation and a converged global bundle adjustment.
    refine_principal_point : also self-calibrate the principal point in that adjustment.
    seed : random seed of RANSAC and the mapper (repeatable results).
    turntable_angles : table angle (deg) of each image, ``step:D`` or None (see
        :func:`.turntable.parse_angles`): only pairs within ``turntable_window`` deg are matched.
    progress : ``progress(fraction, message)``; cancel : ``cancel() -> bool``, polled.
    workdir : folder for the images, database and model (kept); default a temporary one.

    Returns
    -------
    SparseResult. Raises InputError (one line naming the images) when the series is
    unusable, :class:`camcmm.api.Cancelled` when cancelled.
    """
    check_series(images, names)
    if matching not in MATCHING:
        raise InputError(f"photogrammetry: matching {matching!r}: choose {', '.join(MATCHING)}")
    if mapper not in MAPPERS:
        raise InputError(f"photogrammetry: mapper {mapper!r}: choose {', '.join(MAPPERS)}")
    if isinstance(overlap, bool) or not isinstance(overlap, (int, np.integer)) or overlap < 1:
        raise InputError(f"photogrammetry: overlap {overlap!r}: needs a whole number of partners per image >= 1")
    if camera_model not in COLMAP_PARAMS:
        raise InputError(f"photogrammetry: camera model {camera_model!r}: choose one of {', '.join(COLMAP_PARAMS)}")
    angles = parse_angles(turntable_angles, len(images))
    pycolmap = _pycolmap()
    pycolmap.set_random_seed(int(seed))
    h, w = np.asarray(images[0]).shape[:2]
    if calibration is not None:
        size = tuple(calibration.get("image_size") or (0, 0))
        if size != (0, 0) and tuple(map(int, size)) != (w, h):
            raise InputError(
                f"photogrammetry: the calibration is for {size[0]}x{size[1]} px images, "
                f"the series ({names[0]} ...) is {w}x{h} px"
            )
    tmp: tempfile.TemporaryDirectory[str] | None = None
    if workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="camcmm-sfm-")
        root = Path(tmp.name)
    else:
        root = Path(workdir)
    st = Stages(pycolmap, progress, cancel)
    try:
        (root / "images").mkdir(parents=True, exist_ok=True)
        (root / "sparse").mkdir(exist_ok=True)
        db = root / "database.db"
        if db.exists():
            db.unlink()
        files, (sx, sy) = write_images(images, names, root / "images", max_image_size)
        nw, nh = round(w * sx), round(h * sy)
        reader = pycolmap.ImageReaderOptions()
        if calibration is not None:
            model, params = colmap_from_opencv(
                calibration["camera_matrix"], calibration.get("dist_coeffs", ()), (sx, sy)
            )
            reader.camera_params = ",".join(f"{v:.12g}" for v in params)  # a known focal length: a prior
        else:
            # no parameters: COLMAP's own start (1.2 x the longer side) WITHOUT a focal-length prior;
            # given as parameters, that guess would count as known in verification and mapping
            model = camera_model
        reader.camera_model = model
        ext = pycolmap.FeatureExtractionOptions()
        ext.sift.max_num_features = int(max_features)
        ext.use_gpu = False

        def extract_piece(piece: Sequence[str], first: bool) -> None:
            if not first:  # the series' one camera, made by the first piece (CameraMode.SINGLE)
                reader.existing_camera_id = _camera_id(pycolmap, db)
            pycolmap.extract_features(
                db,
                root / "images",
                image_names=list(piece),
                camera_mode=pycolmap.CameraMode.SINGLE,
                reader_options=reader,
                extraction_options=ext,
                device=pycolmap.Device.cpu,
                cancellation_token=st.token,
            )

        def extract() -> None:  # in pieces, so that the count of images done moves (progress.in_chunks)
            in_chunks(st, "extract", "features", "images", files, extract_piece, first=FIRST_IMAGES)

        st.run("extract", "features: SIFT", extract)
        mopts = pycolmap.FeatureMatchingOptions()
        mopts.use_gpu = False
        verify = pycolmap.TwoViewGeometryOptions()
        verify.ransac.random_seed = int(seed)
        common = dict(matching_options=mopts, verification_options=verify, device=pycolmap.Device.cpu)
        common["cancellation_token"] = st.token
        n = len(files)
        if angles is not None:  # the table angles choose the pairs (turntable.angle_pairs)
            pairs = angle_pairs(angles, turntable_window)
        elif matching == "sequential":  # each with the `overlap` next in input order (the files' order)
            pairs = [(i, j) for i in range(n) for j in range(i + 1, min(n, i + 1 + int(overlap)))]
        elif matching == "exhaustive":
            pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        else:
            pairs = []  # ring: chosen from the features once they are there

        def match_piece(piece: Sequence[tuple[int, int]], first: bool) -> None:
            listed = write_pair_list(root / "pairs.txt", files, piece)
            opts = pycolmap.ImportedPairingOptions(match_list_path=listed)
            pycolmap.match_image_pairs(db, pairing_options=opts, **common)

        def match() -> None:  # the pairs in pieces, so that the count of pairs matched moves
            start = 0.0
            if matching == "ring" and angles is None:  # each image's most alike, from its own features
                pairs.extend(_ring_pairs(pycolmap, db, files, int(overlap), int(seed)))
                start = RETRIEVAL_SHARE
            in_chunks(st, "match", "matching", "pairs", pairs, match_piece, first=FIRST_PAIRS, start=start)

        first = "matching: choosing pairs by visual words" if matching == "ring" and angles is None else "matching"
        st.run("match", first, match)
        per_image, n_pairs = per_image_counts(pycolmap, db, files, names)

        popts = pycolmap.IncrementalPipelineOptions()
        popts.random_seed = int(seed)
        popts.mapper.random_seed = int(seed)
        popts.triangulation.random_seed = int(seed)
        fixed = calibration is not None
        popts.ba_refine_focal_length = not fixed
        popts.ba_refine_extra_params = not fixed
        popts.ba_refine_principal_point = False
        popts.mapper.abs_pose_refine_focal_length = not fixed
        popts.mapper.abs_pose_refine_extra_params = not fixed
        # images in the current model and in the largest so far: a new initial pair starts a
        # further model (the series fell apart) whose count must not add to the first's
        count = {"now": 0, "best": 0}

        def registered(first: bool) -> Callable[[], None]:
            def add() -> None:
                count["now"] = 2 if first else count["now"] + 1
                count["best"] = min(max(count["best"], count["now"]), n)
                st.report("map", count["best"] / n, f"mapping: {count['best']} of {n} images registered")

            return add

        if mapper == "global":
            gopts = _global_options(pycolmap, int(seed), fixed)
            run_mapper = lambda: pycolmap.global_mapping(db, root / "images", root / "sparse", gopts)  # noqa: E731
        else:
            run_mapper = lambda: pycolmap.incremental_mapping(  # noqa: E731
                db,
                root / "images",
                root / "sparse",
                options=popts,
                initial_image_pair_callback=registered(True),
                next_image_callback=registered(False),
                cancellation_token=st.token,
            )
        recs = st.run("map", f"mapping: {mapper} mapper", run_mapper)
        rec = max(recs.values(), key=lambda r: r.num_reg_images()) if recs else None
        n_reg = rec.num_reg_images() if rec is not None else 0
        warnings = []
        if rec is not None and len(recs) > 1:
            # the mapper's further models may repeat images of the largest: only images
            # nowhere in the largest mean the series fell apart
            kept = {im.name for im in rec.images.values() if im.has_pose}
            apart = sorted({im.name for r in recs.values() for im in r.images.values() if im.has_pose} - kept)
            if apart:
                by_file = dict(zip(files, names, strict=True))
                for f, row in zip(files, per_image, strict=True):
                    if f in apart:
                        row["kind"], row["reason"] = "separate model", "in a separate model (not linked to the others)"
                warnings.append(
                    f"the series fell apart: {len(apart)} image(s) form separate models and are left out "
                    f"({', '.join(by_file.get(a, a) for a in apart[:6])}{' ...' if len(apart) > 6 else ''})"
                )
        if rec is not None and n_reg >= 2 and mapper == "incremental":
            # each image left out: its inlier matches to the model, and so the mapper's reason
            explain_unregistered(pycolmap, db, rec, per_image, files, mapper_limits(popts))
        if rec is None or n_reg < 2:
            for p in per_image:
                p["reason"] = reason_unregistered(p["n_features"], p["n_matched"])
        check_registration(per_image, n_reg, n_pairs)
        if refine:

            def refine_fn():
                # retriangulate what drift split apart, then adjust everything to convergence
                database = pycolmap.Database.open(str(db))
                try:
                    cache = pycolmap.DatabaseCache.create(database, pycolmap.DatabaseCacheOptions())
                    inc = pycolmap.IncrementalMapper(cache)
                    inc.begin_reconstruction(rec)
                    inc.retriangulate(popts.get_triangulation())
                    inc.complete_and_merge_tracks(popts.get_triangulation())
                    inc.end_reconstruction(False)
                finally:
                    database.close()
                return _final_refinement(pycolmap, rec, fixed, refine_principal_point)

            rec, more = st.run("refine", "final bundle adjustment", refine_fn)
            warnings += more
        out = model_result(rec, per_image, files, names, (sx, sy), (w, h), warnings, st.timings)
        out.options = {
            "camera_model": model,
            "calibrated": fixed,
            "max_image_size": int(max_image_size),
            "sfm_image_size": [nw, nh],
            "matching": matching if angles is None else "turntable",
            **({"overlap": int(overlap)} if angles is None and matching != "exhaustive" else {}),
            **({"pairs_listed": len(pairs)} if matching == "ring" and angles is None else {}),
            "mapper": mapper,
            **({} if angles is None else {"turntable_window_deg": float(turntable_window), "pairs_listed": len(pairs)}),
            "pairs_verified": int(n_pairs),
            "max_features": int(max_features),
            "refine": bool(refine),
            "refine_principal_point": bool(refine_principal_point),
            "seed": int(seed),
        }
        return out
    finally:
        st.close()
        if tmp is not None:
            tmp.cleanup()
