"""Plugin entry points (``fn(ctx, **inputs, **params) -> dict``) of fringe.patterns,
fringe.decode and fringe.reconstruct. The parameters' defaults are in plugin.yaml only
(the host passes every declared parameter, validated), so they are keyword-only here."""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import RunContext

from .sequence import load_sequence


def patterns(ctx: RunContext, sequence: Any, *, dtype: str, out: str) -> dict[str, Any]:
    from .patterns import generate_patterns, save_patterns

    seq = load_sequence(sequence)
    arr = generate_patterns(seq, np.float32 if dtype == "float32" else None)
    files = [str(p) for p in save_patterns(seq, out)] if out else []
    return {"patterns": arr, "frames": seq.describe(), "projector_size": list(seq.projector_size), "files": files}


def _decode_kw(black_threshold, modulation_threshold, white_threshold, saturation, boundary_correction):
    return dict(
        black_threshold=black_threshold,
        modulation_threshold=modulation_threshold,
        white_threshold=white_threshold,
        saturation=saturation,
        boundary_correction=boundary_correction,
    )


def decode(
    ctx: RunContext,
    sequence: Any,
    images: Any,
    *,
    black_threshold: float,
    modulation_threshold: float,
    white_threshold: float,
    saturation: float,
    boundary_correction: str,
) -> dict[str, Any]:
    from .decode import decode as run_decode

    ctx.progress(0.05, "decoding")
    dec = run_decode(
        sequence,
        images,
        warn=ctx.warn,
        **_decode_kw(black_threshold, modulation_threshold, white_threshold, saturation, boundary_correction),
    )
    _warn_orders(ctx, dec, "images")
    return {
        "u": dec.u,
        "v": dec.v,
        "modulation": dec.modulation,
        "mask": dec.mask,
        "valid_fraction": dec.valid_fraction,
        "masks": dec.rejected,
        "order_errors_corrected": dec.orders["corrected"],
        "order_errors_dropped": dec.orders["dropped"],
    }


def _warn_orders(ctx: RunContext, dec, name: str) -> None:
    """A warning when the order checks dropped more than 1 % of the decoded pixels."""
    kept = int(np.count_nonzero(dec.mask))
    n = dec.orders["dropped"]
    if n > 0.01 * max(kept, 1):
        ctx.warn(
            f"{name}: {n} pixels ({100 * n / max(kept + n, 1):.1f} %) dropped whose fringe order neither the "
            "code nor their neighbours settle; a complementary Gray code (stripes of half the period) avoids this"
        )


def reconstruct(
    ctx: RunContext,
    sequence: Any,
    images: Any,
    calibration: Any,
    images2: Any = None,
    *,
    black_threshold: float,
    modulation_threshold: float,
    white_threshold: float,
    saturation: float,
    boundary_correction: str,
    method: str,
    keep_phase: bool,
    triangulation: str,
) -> dict[str, Any]:
    from camcmm.api import InputError, PointCloud

    from .calib import check_image_size, load_calibration, pick_devices
    from .decode import decode as run_decode
    from .reconstruct import projector_points, stereo_points

    seq = load_sequence(sequence)
    cal = load_calibration(calibration)
    cams, proj = pick_devices(cal)
    if method == "auto":
        method = "stereo" if images2 is not None else "projector"
    kw = _decode_kw(black_threshold, modulation_threshold, white_threshold, saturation, boundary_correction)
    if method == "stereo" and images2 is None:
        raise InputError("method 'stereo' needs the second camera's images (images2)")
    if method == "stereo" and len(cams) < 2:
        raise InputError(f"calibration: camera-camera matching needs two cameras, the calibration has {len(cams)}")
    if method == "projector" and proj is None:
        raise InputError("calibration: camera-projector triangulation needs a camera named 'projector'")
    if not cams:
        raise InputError("calibration: no camera besides the projector")
    ctx.progress(0.05, "decoding camera 1")
    dec1 = run_decode(seq, images, warn=ctx.warn, name="images", **kw)
    _warn_orders(ctx, dec1, "images")
    cam1 = check_image_size(cams[0], dec1.mask.shape, "the images")
    out: dict[str, Any] = {}
    if method == "stereo":
        ctx.progress(0.4, "decoding camera 2")
        dec2 = run_decode(seq, images2, warn=ctx.warn, name="images2", **kw)
        _warn_orders(ctx, dec2, "images2")
        cam2 = check_image_size(cams[1], dec2.mask.shape, "images2")
        ctx.progress(0.75, "matching phases along rectified rows")
        pts, fields, direction = stereo_points(dec1, dec2, cam1, cam2)
        valid = min(dec1.valid_fraction, dec2.valid_fraction)
        out["method"] = f"stereo ({direction} fringes)"
        if keep_phase:
            out.update({"u2": dec2.u, "v2": dec2.v})
    else:
        assert proj is not None  # the projector method was refused above without one
        cal_size = tuple(round(s * n) for s, n in zip(seq.calibration_scale, seq.projector_size))
        if proj.image_size != (0, 0) and tuple(proj.image_size) != cal_size:
            raise InputError(
                f"calibration: the projector is calibrated for {proj.image_size[0]}x"
                f"{proj.image_size[1]} px but the sequence declares {cal_size[0]}x{cal_size[1]} px"
            )
        ctx.progress(0.6, "triangulating against the projector")
        pts, idx = projector_points(dec1, cam1, proj, triangulation, seq.to_calibration_px)
        w = dec1.mask.shape[1]
        fields = {
            "modulation": dec1.modulation.ravel()[idx].astype(np.float64),
            "quality": dec1.quality.ravel()[idx].astype(np.float64),
            "x_px": (idx % w).astype(np.float64),
            "y_px": (idx // w).astype(np.float64),
        }
        valid = dec1.valid_fraction
        out["method"] = "camera-projector"
    if len(pts) == 0:
        raise InputError("no 3-D point: no valid pixel triangulates (check the calibration against the set-up)")
    decoded = int(np.count_nonzero(dec1.mask))
    share = len(pts) / max(decoded, 1)
    if share < (0.2 if method == "stereo" else 0.5):
        why = "no match on the rectified rows" if method == "stereo" else "rays along the stripes or behind a device"
        ctx.warn(
            f"only {100 * share:.1f} % of camera 1's {decoded} decoded pixels gave a 3-D point ({why}); "
            "check that the calibration belongs to these images"
        )
    cloud = PointCloud(
        pts,
        fields=fields,
        field_units={"modulation": "grey levels", "quality": "", "x_px": "px", "y_px": "px"},
        name="fringe",
    )
    out.update({"cloud": cloud, "n_points": cloud.n_points, "valid_fraction": valid, "bbox": cloud.bounds.tolist()})
    decs = [dec1] + ([dec2] if method == "stereo" else [])
    out["order_errors_corrected"] = sum(d.orders["corrected"] for d in decs)
    out["order_errors_dropped"] = sum(d.orders["dropped"] for d in decs)
    if keep_phase:
        out.update({"u": dec1.u, "v": dec1.v})
    return out
