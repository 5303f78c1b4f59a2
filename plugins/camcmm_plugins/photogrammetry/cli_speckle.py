"""``camcmm speckle stability IMAGES... [--limit PX] [--std-limit PX] [--plot FILE.png] [--json]``

The laser speckle stability test of thesis ch. 4.2 (see ``stability``): SIFT features of
each image matched to the first; JSON keys ``mean_motion_px`` and ``std_px_per_image``
(per image, 0 for the first), ``std_px`` (the largest per-image spread), ``verdict``
("pass"/"fail"), ``reasons``, ``n_features``, ``warnings`` (+ ``plot`` with --plot).
Exit code 0 either way; the verdict is in the answer.
"""

from __future__ import annotations

import argparse
from typing import Any

PLUGIN = "speckle.stability"


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{stability}")
    st = sub.add_parser("stability", help="how far the speckle moves over a series taken over time (ch. 4.2)")
    st.add_argument("images", nargs="+", metavar="IMAGE", help="the series, first image = the reference")
    st.add_argument(
        "--limit",
        type=float,
        default=3.0,
        metavar="PX",
        help="largest mean motion allowed (default 3 px, thesis ch. 4.2)",
    )
    st.add_argument(
        "--std-limit",
        type=float,
        default=1.0,
        metavar="PX",
        help="largest spread of the motion in an image (default 1 px)",
    )
    st.add_argument("--plot", metavar="FILE.png", help="write mean ± std against image index (.png, .pdf or .svg)")
    st.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document")


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import InputError, declared_value

    from .stability import ImageSeries, plot, plot_target, stability

    limit = declared_value(PLUGIN, "limit", args.limit)
    std_limit = declared_value(PLUGIN, "std_limit", args.std_limit)
    if len(args.images) < 2:  # before any image is decoded
        raise InputError(f"speckle stability needs at least 2 images, got 1: {args.images[0]}")
    if args.plot is not None:
        plot_target(args.plot)  # a folder or an unknown format is refused before the images are read
    series = ImageSeries(args.images)  # every path checked now; each image read when its turn comes
    res = stability(series, series.names, limit, std_limit)
    if args.plot is not None:
        res["plot"] = plot(res, args.plot)
    return res


def text(result: dict[str, Any]) -> str:
    rows = [
        f"  {n}: {'?' if m is None else f'{m:.2f}'} px ± {'?' if s is None else f'{s:.2f}'} px ({k} features)"
        for n, m, s, k in zip(
            result["images"], result["mean_motion_px"], result["std_px_per_image"], result["n_features"]
        )
    ]
    tail = "".join(f"\n  {r}" for r in result["reasons"]) + "".join(f"\n  warning: {w}" for w in result["warnings"])
    lim = f"limit {result['limit_px']:g} px, spread {result['std_limit_px']:g} px"
    head = f"speckle stability: {result['verdict']} ({lim})"
    return "\n".join([head, *rows]) + tail + (f"\n  plot: {result['plot']}" if result.get("plot") else "")
