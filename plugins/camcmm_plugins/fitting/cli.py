"""``camcmm fit ELEMENT FILE [--outliers RULE] [--method ls|minzone] [--nominal-radius R]``

Fits a line, plane, circle, sphere or cylinder to the points of FILE (any point-cloud
format camcmm reads; lengths in mm, ``--unit`` for files that do not say theirs) and
prints the result; with ``--json`` (added by the core CLI) one JSON document with the
keys ``element, method, outliers, n_points, n_used, n_removed``, the element's
parameters (sphere: ``center, radius``; plane: ``point, normal``; circle: ``center,
normal, radius``; cylinder: ``point, axis, radius``; line: ``point, direction``),
``form {range, max, min, std, rms}``, ``std_uncertainty {parameter: value}`` and
``warnings`` (when the element does not describe the points; see checks.py). A mesh
file is fitted by its vertices, with a warning (see source.py); errors name FILE.
"""

from __future__ import annotations

import argparse
from typing import Any

from camcmm.api import declared_value, read_stated, unit_decision

RULES = "none, vdi2634 (3 of every 1000 points, one at a time), percent:P, sigma:K"


def configure(parser: argparse.ArgumentParser) -> None:
    from .api import ELEMENTS

    parser.add_argument("element", choices=ELEMENTS, help="the geometric element")
    parser.add_argument("file", help="point cloud file (.xyz .csv .txt .ply .pcd .e57)")
    parser.add_argument("--outliers", default="none", metavar="RULE", help=f"outlier rule: {RULES} (default none)")
    parser.add_argument(
        "--method",
        default="ls",
        choices=("ls", "minzone"),
        help="ls: least squares (Gaussian); minzone: minimum zone (Chebyshev), plane and sphere",
    )
    parser.add_argument(
        "--nominal-radius",
        type=float,
        default=None,
        metavar="R",
        help="nominal radius in mm: reports radius_deviation; with --extract finds the sphere",
    )
    parser.add_argument(
        "--extract",
        action="store_true",
        help="sphere only: first extract the sphere from a raw scan with mount and background",
    )
    parser.add_argument(
        "--unit",
        default=None,
        help="length unit of the file (m, cm, mm, um, in) when it does not say; without it: mm, with a warning "
        "when the size is implausible as mm (docs/units.md)",
    )
    parser.add_argument(
        "--residuals", action="store_true", help="include every point's residual and the removed indices in the JSON"
    )


def run(args: argparse.Namespace) -> dict[str, Any]:
    from camcmm.api import InputError

    from . import api
    from .source import as_cloud, naming

    if args.nominal_radius is not None:
        args.nominal_radius = declared_value(f"fit.{args.element}", "nominal_radius", args.nominal_radius)
    if args.extract and args.element != "sphere":
        raise InputError("--extract works for a sphere only")
    obj, stated = read_stated(args.file, unit=args.unit)
    # the shared unit rule (a sphere's nominal diameter, when given, is the size to expect)
    expected = 2 * args.nominal_radius if args.nominal_radius and args.element == "sphere" else None
    unit_note = unit_decision(obj, stated, expected=expected, what="sphere" if expected else "part")
    cloud, note = as_cloud(obj, args.element, str(args.file))
    pts = cloud.points
    extra: dict[str, Any] = {"file": str(args.file)}
    with naming(str(args.file)):
        if args.extract:
            seg = api.extract_sphere(pts, args.nominal_radius)
            extra["n_points_raw"] = len(pts)
            pts = pts[seg.indices]
        res = api.fit(args.element, pts, args.outliers, args.method, nominal_radius=args.nominal_radius)
    out = res.to_dict(residuals=args.residuals)
    out.update(extra)
    if note:
        out["warnings"] = [note, *out["warnings"]]
    if unit_note.asks:
        out["warnings"] = [unit_note.reason, *out["warnings"]]
    return out


def _vec(v: Any) -> str:
    return "(" + ", ".join(f"{x:.6f}" for x in v) + ")"


def text(result: dict[str, Any]) -> str:
    """Human-readable output of :func:`run`."""
    lines = [
        f"{result['element']} ({result['method']}, outliers {result['outliers']}): "
        f"{result['n_used']} of {result['n_points']} points used, {result['n_removed']} removed"
    ]
    unc = result.get("std_uncertainty", {})
    for key in ("center", "point", "normal", "axis", "direction", "radius"):
        if key in result:
            v = result[key]
            u = unc.get(key)
            if isinstance(v, list):
                s = _vec(v)
                if u is not None and all(x is not None for x in u):
                    s += f"  u = {_vec(u)}"
            else:
                s = f"{v:.6f}" + (f"  u = {u:.6f}" if isinstance(u, float) else "")
            unit = "" if key in ("normal", "axis", "direction") else " mm"
            lines.append(f"  {key:10} {s}{unit}")
    if "radius_deviation" in result:
        lines.append(f"  {'radius - nominal':10} {result['radius_deviation']:.6f} mm")
    f = result["form"]
    lines.append(
        "  form       range {range:.6f}  max {max:.6f}  min {min:.6f}  std {std:.6f}  rms {rms:.6f} mm".format(
            **{k: (v if v is not None else float("nan")) for k, v in f.items()}
        )
    )
    lines += [f"warning: {w}" for w in result.get("warnings", [])]
    return "\n".join(lines)
