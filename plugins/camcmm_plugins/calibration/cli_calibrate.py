"""``camcmm calibrate camera|stereo`` — camera and stereo calibration from board images.

* ``camera IMAGES... --board chessboard:COLSxROWS:SQUARE_MM [--out CAL.yaml]``: JSON keys
  ``camera_matrix`` (3x3), ``dist_coeffs``, ``rms``, ``std_intrinsics``, ``per_view_rms``
  ({image: px}), ``image_size``, ``rejected`` ([{image, reason}]) (+ ``std_named``,
  ``residual_sigma``, ``n_views``, ``warnings``, ``projection_uncertainty`` with ``--distance``,
  ``written``).
* ``stereo --left IMAGES... --right IMAGES... --board ... [--out CAL.yaml]``: JSON keys
  ``left``, ``right`` (as above), ``R``, ``T`` (mm), ``E``, ``F``, ``rms`` (+ ``std_rvec``,
  ``std_T``, ``baseline``, ``baseline_std``, ``spread``, ``epipolar``, ``rectified_dy``,
  ``rectification``, ``pairs``, ``rejected``, ``warnings``, ``written``).

Board specs: see camcmm_plugins.calibration.boards (chessboard, charuco, circles, acircles).
"""

from __future__ import annotations

import argparse
from typing import Any


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--board",
        required=True,
        metavar="SPEC",
        help="board: chessboard:COLSxROWS:SQUARE_MM (inner corners, e.g. chessboard:9x6:25), "
        "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICT], circles:COLSxROWS:SPACING_MM, "
        "acircles:COLSxROWS:SPACING_MM",
    )
    p.add_argument("--out", default=None, metavar="CAL.yaml", help="write the calibration (.yaml/.yml/.xml/.json)")
    p.add_argument(
        "--model",
        default="standard",
        choices=("standard", "thin-prism", "rational", "rational-thin-prism"),
        help="distortion model (default standard: k1 k2 p1 p2 k3)",
    )
    p.add_argument(
        "--detector",
        default="auto",
        choices=("auto", "classic", "sb"),
        help="chessboard detector (default auto: SB, else classic, then cornerSubPix)",
    )
    p.add_argument("--subpix-window", type=int, default=5, metavar="W", help="cornerSubPix half window, px (default 5)")
    p.add_argument(
        "--outlier-factor",
        type=float,
        default=3.0,
        metavar="F",
        help="leave out views whose RMS exceeds F x the median (default 3; 0 keeps all)",
    )
    p.add_argument(
        "--max-rms",
        type=float,
        default=1.0,
        metavar="PX",
        help="warn when the RMS reprojection error is above PX (default 1)",
    )
    # the core adds --json to the command's parser; accept it after the subcommand too
    p.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{camera,stereo}")
    c = sub.add_parser("camera", help="calibrate one camera from board images")
    c.add_argument("images", nargs="+", metavar="IMAGES", help="board images (one camera, one size)")
    c.add_argument(
        "--distance",
        type=float,
        default=None,
        metavar="MM",
        help="also give the projection uncertainty (px) over the image at this working distance",
    )
    _common(c)
    s = sub.add_parser("stereo", help="calibrate a stereo pair from board image pairs")
    s.add_argument("--left", nargs="+", required=True, metavar="IMAGES", help="left camera images")
    s.add_argument("--right", nargs="+", required=True, metavar="IMAGES", help="right camera images, in the same order")
    s.add_argument("--fix-intrinsics", action="store_true", help="keep each camera's own calibration in the stereo fit")
    _common(s)


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import declared_value, write_calibration

    from .boards import detect_all, parse_board

    pid = f"calibration.{args.what}"
    for name in ("subpix_window", "outlier_factor", "max_rms"):
        setattr(args, name, declared_value(pid, name, getattr(args, name)))
    if args.what == "camera":
        args.distance = declared_value("calibration.projection-uncertainty", "distance", args.distance)
    board = parse_board(args.board)
    if args.what == "camera":
        from .camera import calibrate_camera, calibration_dict, camera_json

        dets = detect_all(board, args.images, detector=args.detector, subpix_window=args.subpix_window)
        res = calibrate_camera(dets, board, model=args.model, outlier_factor=args.outlier_factor, max_rms=args.max_rms)
        out = camera_json(res)
        if args.distance is not None:
            from .projection import projection_uncertainty

            pu = projection_uncertainty(res, args.distance)
            out["projection_uncertainty"] = {k: pu[k] for k in ("distance", "min", "max", "centre", "unit")}
        if args.out:
            write_calibration(args.out, calibration_dict(res))
            out["written"] = args.out
        return out
    from .stereo import calibrate_stereo, calibration_dict, stereo_json

    dl = detect_all(board, args.left, detector=args.detector, subpix_window=args.subpix_window)
    dr = detect_all(board, args.right, detector=args.detector, subpix_window=args.subpix_window)
    res = calibrate_stereo(
        dl,
        dr,
        board,
        model=args.model,
        outlier_factor=args.outlier_factor,
        fix_intrinsics=args.fix_intrinsics,
        max_rms=args.max_rms,
    )
    out = stereo_json(res)
    if args.out:
        write_calibration(args.out, calibration_dict(res))
        out["written"] = args.out
    return out


def _cam_text(name: str, c: dict[str, Any]) -> list[str]:
    k = c["camera_matrix"]
    lines = [
        f"{name}: RMS {c['rms']:.4f} px over {len(c['per_view_rms'])} views, image {c['image_size'][0]}x"
        f"{c['image_size'][1]} px",
        f"  fx {k[0][0]:.3f}  fy {k[1][1]:.3f}  cx {k[0][2]:.3f}  cy {k[1][2]:.3f} px",
        "  dist " + " ".join(f"{v:.6g}" for v in c["dist_coeffs"]),
        "  std  " + " ".join(f"{v:.3g}" for v in c["std_intrinsics"]),
    ]
    lines += [f"  left out: {r['image']}: {r['reason']}" for r in c.get("rejected", [])]
    return lines


def text(result: dict[str, Any]) -> str:
    if "left" not in result:
        lines = _cam_text("camera", result)
        if "projection_uncertainty" in result:
            pu = result["projection_uncertainty"]
            lines.append(
                f"  projection uncertainty at {pu['distance']:g} mm: centre {pu['centre']:.3g} px, "
                f"max {pu['max']:.3g} px"
            )
    else:
        t = result["T"]
        lines = _cam_text("left", result["left"]) + _cam_text("right", result["right"])
        lines += [
            f"stereo: RMS {result['rms']:.4f} px, baseline {result['baseline']:.4f} +- "
            f"{result['baseline_std']:.2g} mm, T = ({t[0]:.4f}, {t[1]:.4f}, {t[2]:.4f}) mm",
            f"  epipolar distance RMS {result['epipolar']['rms']:.3f} px, max {result['epipolar']['max']:.3f} px",
        ]
        lines += [f"  pair left out: {r['left']} / {r['right']}: {r['reason']}" for r in result["rejected"]]
    lines += [f"warning: {w}" for w in result.get("warnings", [])]
    if result.get("written"):
        lines.append(f"written to {result['written']}")
    return "\n".join(lines)
