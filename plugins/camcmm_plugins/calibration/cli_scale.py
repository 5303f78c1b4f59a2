"""``camcmm scale --interferometer FILE.csv [--calibration CAL --out NEW]`` — scale factor
of the camera system against a laser interferometer (thesis 3.2.3, eq. 3.22).

JSON keys: ``slope``, ``u_slope``, ``scale_factor`` (= 1 / slope: multiply camera lengths
by it), ``u_scale_factor``, ``runs`` [{run, slope, intercept, stderr, rms_residual, n,
travel}], ``repeatability`` (std of the slopes), ``repeatability_ppm``, ``residuals``
{run: [mm]}, ``displacement`` {run: [mm]}, ``residual_std_per_position``, ``length``,
``u_cal``, ``u_p``, ``u_length`` (mm), ``file``. CSV columns: see
camcmm_plugins.calibration.scale.
"""

from __future__ import annotations

import argparse
from typing import Any


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--interferometer",
        required=True,
        metavar="FILE.csv",
        help="CSV: run (optional), interferometer, camera (1-D) or x, y, z (mm)",
    )
    parser.add_argument(
        "--accuracy",
        type=float,
        default=5e-7,
        help="interferometer relative accuracy, half-width of a rectangular distribution "
        "(default 5e-7, the thesis' +-5e-5 %%)",
    )
    parser.add_argument(
        "--length", type=float, default=None, metavar="MM", help="length for u(length) (default: the travel)"
    )
    parser.add_argument("--calibration", default=None, metavar="CAL", help="calibration to apply the factor to ...")
    parser.add_argument("--out", default=None, metavar="NEW", help="... written here (.yaml/.json)")


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import InputError, declared_value

    from .plugin import scale

    args.accuracy = declared_value("calibration.scale", "accuracy", args.accuracy)
    args.length = declared_value("calibration.scale", "length", args.length)
    if bool(args.calibration) != bool(args.out):
        raise InputError("--calibration and --out go together")
    return scale(
        None,
        args.interferometer,
        accuracy=args.accuracy,
        length=args.length,
        calibration=args.calibration,
        save=args.out or "",
    )


def text(result: dict[str, Any]) -> str:
    lines = [
        f"{result['file']}: {result['n_runs']} run(s); slope {result['slope']:.7f} +- {result['u_slope']:.2g}, "
        f"scale factor {result['scale_factor']:.7f} +- {result['u_scale_factor']:.2g}"
    ]
    if result["n_runs"] > 1:
        lines.append(f"  repeatability of the slope {result['repeatability_ppm']:.1f} ppm")
    lines.append(
        f"  u(length) at {result['length']:g} mm = sqrt({result['u_cal'] * 1e3:.3g}^2 + "
        f"{result['u_p'] * 1e3:.3g}^2) = {result['u_length'] * 1e3:.3g} um"
    )
    for r in result["runs"]:
        lines.append(
            f"  run {r['run']}: slope {r['slope']:.7f} (se {r['stderr']:.2g}), residual RMS "
            f"{r['rms_residual'] * 1e3:.2f} um, {r['n']} positions over {r['travel']:g} mm"
        )
    if result.get("written"):
        lines.append(f"scaled calibration written to {result['written']}")
    return "\n".join(lines)
