"""``camcmm fit ELEMENT FILE [--outliers RULE] [--method ls|minzone] [--nominal-radius R]``

Fits a line, plane, circle, sphere, cylinder, cone or torus to the points of FILE (any point-cloud
format camcmm reads; lengths in mm, ``--unit`` for files that do not say theirs) and
prints the result; with ``--json`` (added by the core CLI) one JSON document with the
keys ``element, method, outliers, n_points, n_used, n_removed``, the element's
parameters (sphere: ``center, radius``; plane: ``point, normal``; circle: ``center,
normal, radius``; cylinder: ``point, axis, radius``; cone: ``apex, axis, angle`` (full
apex angle, degrees); torus: ``center, axis, major_radius, minor_radius``; line:
``point, direction``),
``form {range, max, min, std, rms}``, ``std_uncertainty {parameter: value}`` and
``warnings`` (when the element does not describe the points; see checks.py), and
``plugin`` (the run's provenance: ``id`` fit.ELEMENT, ``version``, ``params``,
``input_hashes``, ``started``, ``finished``). A mesh file is fitted by its vertices, with
a warning (see source.py); errors name FILE.

The fit runs through the host as the plugin ``fit.ELEMENT``. The options are the
parameters the fit plugins declare (help, limits, default from their manifest; ``camcmm
fit --help``); each element's plugin takes its own, and a value for one it does not
declare is refused in one line (``--nominal-radius: fit.plane has no nominal radius``),
except that declaration's default (``--method ls`` for a line: what every line fit does).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from camcmm.api import Param, add_declared_options, declared_values, default_host, read_stated, unit_decision

from .elements import ELEMENTS  # each ELEMENT is fitted by the plugin fit.ELEMENT

#: The flags that were ``store_true`` before their parameter was declared.
SWITCHES = ("extract",)


def parameters() -> list[Param]:
    """Every parameter some ``fit.ELEMENT`` plugin declares, once, in first-declared order
    (``camcmm fit``'s options; each element's plugin takes only its own). The help of one
    that not every element takes says which do."""
    host = default_host()
    seen: dict[str, Param] = {}
    takers: dict[str, list[str]] = {}
    for element in ELEMENTS:
        for p in host.get(f"fit.{element}").parameters:
            seen.setdefault(p.name, p)
            takers.setdefault(p.name, []).append(element)
    return [
        p
        if len(takers[name]) == len(ELEMENTS)
        else replace(p, help=f"{p.help} (for {', '.join(takers[name])})".strip())
        for name, p in seen.items()
    ]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("element", choices=ELEMENTS, help="the geometric element (plugin fit.ELEMENT)")
    parser.add_argument("file", help="point cloud file (.xyz .csv .txt .ply .pcd .e57)")
    # --outliers, --method, --nominal-radius, --extract: the fit plugins' declarations
    add_declared_options(parser, parameters(), switches=SWITCHES)
    parser.add_argument(
        "--unit",
        default=None,
        help="length unit of the file (m, cm, mm, um, in) when it does not say; without it: mm, with a warning "
        "when the size is implausible as mm (docs/units.md)",
    )
    parser.add_argument(
        "--residuals", action="store_true", help="include every point's residual and the removed indices in the JSON"
    )


#: Outputs of the fit plugins that are not part of the command's JSON (a cloud; index
#: arrays, given with --residuals only).
_NOT_JSON = ("deviations", "removed_indices", "extracted_indices")


def run(args: argparse.Namespace) -> dict[str, Any]:
    from .source import as_cloud, naming

    host = default_host()
    spec = host.get(f"fit.{args.element}")
    # each value by the element's own declaration; one it does not take is refused
    params = declared_values(args, parameters(), plugin=spec)
    nominal = params.get("nominal_radius")
    obj, stated = read_stated(args.file, unit=args.unit)
    # the shared unit rule (a sphere's nominal diameter, when given, is the size to expect)
    expected = 2 * nominal if nominal and args.element == "sphere" else None
    unit_note = unit_decision(obj, stated, expected=expected, what="sphere" if expected else "part")
    cloud, note = as_cloud(obj, args.element, str(args.file))
    with naming(str(args.file)):
        res = host.run(spec.id, {"cloud": cloud}, params)
    o = res.outputs
    out = {k: v for k, v in o.items() if k not in _NOT_JSON and k != "n_points_raw"}
    out["warnings"] = [*([unit_note.reason] if unit_note.asks else []), *([note] if note else []), *res.warnings]
    if args.residuals:
        dev = o.get("deviations")
        out["residuals"] = [] if dev is None else dev.fields["deviation"].tolist()
        out["removed_indices"] = [int(i) for i in o.get("removed_indices", [])]
    out["file"] = str(args.file)
    if "n_points_raw" in o:
        out["n_points_raw"] = o["n_points_raw"]
    out["plugin"] = res.provenance()
    return out


def _vec(v: Any) -> str:
    return "(" + ", ".join(f"{x:.6f}" for x in v) + ")"


def text(result: dict[str, Any]) -> str:
    """Human-readable output of :func:`run`."""
    lines = [
        f"{result['element']} ({result['method']}, outliers {result['outliers']}): "
        f"{result['n_used']} of {result['n_points']} points used, {result['n_removed']} removed by the outlier rule"
    ]
    if "n_extracted_away" in result:  # --extract: what the extraction took away comes first in the scan's story
        lines.insert(
            0,
            f"extracted the sphere: {result['n_points']} of {result['n_points_raw']} points of the scan, "
            f"{result['n_extracted_away']} removed as not on the sphere",
        )
    unc = result.get("std_uncertainty", {})
    keys = ("center", "point", "apex", "normal", "axis", "direction", "radius", "major_radius", "minor_radius", "angle")
    for key in keys:
        if key in result:
            v = result[key]
            u = unc.get(key)
            if isinstance(v, list):
                s = _vec(v)
                if u is not None and all(x is not None for x in u):
                    s += f"  u = {_vec(u)}"
            else:
                s = f"{v:.6f}" + (f"  u = {u:.6f}" if isinstance(u, float) else "")
            unit = "" if key in ("normal", "axis", "direction") else " deg" if key == "angle" else " mm"
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
