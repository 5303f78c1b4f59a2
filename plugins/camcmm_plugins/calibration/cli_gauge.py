"""``camcmm gauge-block CLOUD --nominal L`` — height of a gauge block wrung on a platen
(thesis 3.2.4): JSON keys ``height``, ``error`` (height - nominal), ``nominal``, ``platen``
and ``top`` ({point, normal, n_points, flatness, std}), ``parallelism`` (deg),
``n_points``, ``cloud``; lengths in mm.
"""

from __future__ import annotations

import argparse
from typing import Any


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("cloud", metavar="CLOUD", help="point cloud of the block's face and the platen (mm)")
    parser.add_argument("--nominal", type=float, required=True, metavar="L", help="calibrated length, mm")
    parser.add_argument(
        "--unit",
        default=None,
        help="length unit of the cloud file (m, cm, mm, um, in) when it does not say; without it: the file's "
        "own, else mm, with a warning when the cloud's size does not fit --nominal (docs/units.md)",
    )
    parser.add_argument(
        "--ransac-threshold",
        type=float,
        default=None,
        metavar="MM",
        help="inlier band of the first plane (default nominal / 10)",
    )
    parser.add_argument(
        "--up",
        type=float,
        nargs=3,
        default=None,
        metavar=("X", "Y", "Z"),
        help="direction from the platen to the block's face (default: the platen is the larger surface)",
    )


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import CamcmmError, PointCloud, declared_value, read_stated, unit_decision

    from .plugin import gauge_block

    for name in ("nominal", "ransac_threshold", "up"):
        setattr(args, name, declared_value("calibration.gauge-block", name, getattr(args, name)))
    cloud, stated = read_stated(args.cloud, unit=args.unit)
    if not isinstance(cloud, PointCloud):
        from camcmm.api import InputError

        raise InputError(f"{args.cloud}: not a point cloud")
    # the shared unit rule, with the calibrated length as the size to expect
    check = unit_decision(cloud, stated, expected=args.nominal, what="gauge block")
    try:
        res = gauge_block(None, cloud, nominal=args.nominal, ransac_threshold=args.ransac_threshold, up=args.up)
    except CamcmmError as exc:  # a wrong unit is the likelier cause: say so in the same line
        if check.asks:
            raise type(exc)(f"{exc}; {check.reason}") from None
        raise
    res.pop("labels")
    if check.asks:
        res["warnings"] = [check.reason, *res.get("warnings", [])]
    return res


def text(result: dict[str, Any]) -> str:
    p, t = result["platen"], result["top"]
    return "\n".join(
        [
            f"{result['cloud']}: height {result['height']:.4f} mm, nominal {result['nominal']:.4f} mm, "
            f"error {result['error'] * 1e3:+.1f} um",
            f"  platen: {p['n_points']} points, std {p['std'] * 1e3:.1f} um, flatness {p['flatness'] * 1e3:.1f} um",
            f"  top:    {t['n_points']} points, std {t['std'] * 1e3:.1f} um, flatness {t['flatness'] * 1e3:.1f} um",
            f"  parallelism {result['parallelism']:.4f} deg",
            *(f"warning: {w}" for w in result.get("warnings", [])),
        ]
    )
