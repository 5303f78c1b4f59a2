"""``camcmm inspect CLOUD --nominal FILE [--align none|icp|similarity|global+icp|...]
[--tolerance T] [--json] [--out coloured.ply] [--report DIR]``

Aligns the measured cloud onto the nominal (a CAD model .step/.stp/.iges/.igs, whose
exact surface the deviations are measured to, a CAD mesh .stl/.obj/.ply or a reference
cloud), computes the signed deviations, their statistics, the coverage of the nominal
area and the material-ratio parameters, and prints them; ``--out`` writes the cloud in
nominal coordinates with the field ``deviation`` and deviation colours, ``--report`` an
HTML/PDF/JSON report. Runs the plugin that provides ``compare-with-cad`` (camcmm's
``inspect.compare``) through the host, so the result carries the plugin's provenance
(``plugin``). Its declared parameters are the command's options, help, limits and
defaults from its manifest (``camcmm inspect --help``): ``--align``, ``--kernel``,
``--kernel-k``, ``--max-distance``, ``--inlier-distance``, ``--min-overlap``, ``--region``
(six numbers), ``--max-iterations``, ``--max-points``, ``--seed``, ``--tolerance``,
``--distance``, ``--neighbours``, ``--coverage-distance``, ``--coverage-samples``,
``--bins``; a refused value is one line naming the option.

JSON (``--json``; lengths in mm): ``transform`` (4×4, measured -> nominal, scale
included), ``scale`` (the factor applied to the measured cloud), ``rms``, ``overlap``,
``converged``, ``reason``, ``stats`` {``mean std rms min max p2_5 p97_5`` ...},
``coverage`` (covered share 0..1 of the nominal area) and ``coverage_info``,
``material_ratio`` {``Sk Spk Svk Smr1 Smr2`` ...; Smr in %}, ``histogram``,
``alignment`` (every stage), ``held_dofs`` (degrees of freedom the part's symmetry left
undetermined and the alignment held, in words), ``warnings``, and ``written`` /
``report`` file paths. ``aligned`` is true when the alignment converged; when it did not,
``aligned`` is false, ``failure`` gives the reason, and the statistics of the comparison
as it stands (``stats``, ``coverage``, ``coverage_info``, ``material_ratio``,
``histogram``) are not results: they are null at the top level and kept under
``unaligned`` for diagnosis. A failed alignment exits with code 3 (not 0: a script
that checks only the exit code must not take the document for a comparison) and prints
``camcmm: alignment failed: <reason>`` on stderr; the JSON (or the text) is still printed
on stdout, and ``--out``/``--report`` still write (the report says the alignment failed
and shows no deviation figures). Exit 2 is bad input, 1 an internal error.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from camcmm.api import (
    InputError,
    PointCloud,
    Report,
    add_declared_options,
    declared_values,
    default_host,
    numbers,
    read,
    write,
)

#: The task ``camcmm inspect`` runs: its provider's parameters are the command's options.
TASK = "compare-with-cad"
#: What ``--region`` takes: the box as six numbers, as before the parameter was declared.
REGION = ("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("cloud", help="measured point cloud (.ply .pcd .xyz .csv .txt .e57)")
    parser.add_argument(
        "--nominal",
        required=True,
        metavar="FILE",
        help="nominal: CAD model (.step .stp .iges .igs; exact surface), CAD mesh (.stl .obj .ply) or reference cloud",
    )
    parser.add_argument(
        "--pairs",
        default=None,
        metavar="FILE",
        help='JSON {"measured": [[x,y,z],...], "nominal": [[x,y,z],...]}: at least 3 point pairs',
    )
    # --align, --tolerance, --kernel, --max-distance ...: every declared parameter of the
    # comparison, with the manifest's help, unit, limits and default
    add_declared_options(parser, default_host().provider(TASK).parameters, spread={"region": REGION})
    parser.add_argument("--out", default=None, metavar="FILE", help="write the coloured cloud with field 'deviation'")
    parser.add_argument("--report", default=None, metavar="DIR", help="write report.html, report.pdf, report.json here")
    Report.customer_options(parser)  # --customer, --part-number ...: the report's head
    parser.add_argument("--unit", default=None, help="length unit of the cloud file when it does not say (default mm)")
    parser.add_argument("--nominal-unit", default=None, help="length unit of the nominal file when it does not say")
    parser.add_argument("--curve", action="store_true", help="include the material-ratio curve in the JSON")


def _read(path: str, unit: str | None, what: str):
    obj = read(path, unit=unit) if unit else read(path)
    if what == "cloud" and not isinstance(obj, PointCloud):
        raise InputError(f"{path}: holds a {type(obj).__name__}, not a point cloud")
    if what == "nominal" and not hasattr(obj, "n_faces") and not isinstance(obj, PointCloud):
        raise InputError(f"{path}: holds a {type(obj).__name__}, not a mesh or a point cloud")
    return obj


def run(args: argparse.Namespace) -> dict[str, Any]:
    host = default_host()
    spec = host.provider(TASK)
    params = declared_values(args, spec.parameters)  # checked first: a bad value reads no file
    customer = Report.customer_fields(None, args)
    for what, f in (("cloud", args.cloud), ("nominal", args.nominal), ("pairs", args.pairs)):
        if f is not None and not Path(f).is_file():
            raise InputError(f"{f}: no such file ({what})")
    cloud = _read(args.cloud, args.unit, "cloud") if args.unit else args.cloud
    nominal = _read(args.nominal, args.nominal_unit, "nominal") if args.nominal_unit else args.nominal
    # files without a unit override go to the host as paths, so it records their SHA-256
    inputs: dict[str, Any] = {"cloud": cloud, "nominal": nominal}
    align = params.get("align", next((p.default for p in spec.parameters if p.name == "align"), None))
    if args.pairs:
        inputs["pairs"] = args.pairs
    elif isinstance(align, str) and align.startswith("pairs"):
        raise InputError(f"--align {align} needs --pairs FILE with at least 3 point pairs")
    res = host.run_task(TASK, inputs, params)
    tolerance = res.params.get("tolerance")
    o = res.outputs
    mr = {k: v for k, v in o["material_ratio"].items() if k != "curve" or args.curve}
    cov = o["coverage_info"]
    out: dict[str, Any] = {
        "cloud": str(args.cloud),
        "nominal": str(args.nominal),
        "align": res.params.get("align", align),
        "n_points": o["deviations"].n_points,
        "transform": o["transform"],
        "scale": o["scale"],
        "rms": o["rms"],
        "overlap": o["overlap"],
        "converged": o["converged"],
        "reason": o["reason"],
        "stats": o["stats"],
        "tolerance": tolerance,
        "colour_limit": o["colour_limit"],
        "coverage": o["coverage"],
        "coverage_info": cov,
        "material_ratio": mr,
        "histogram": o["histogram"],
        "distance_method": o["distance_method"],
        "nominal_info": o["nominal_info"],
        "alignment": o["alignment"],
        "warnings": res.warnings,
        "plugin": res.provenance(),
    }
    out["held_dofs"] = list(o.get("held_dofs", []))
    out["aligned"] = bool(o["converged"])
    if not o["converged"]:
        out["failure"] = f"alignment failed: {o['reason']}"
        keys = ("stats", "coverage", "coverage_info", "material_ratio", "histogram")
        out["unaligned"] = {
            "note": "statistics of the unaligned comparison (the cloud where the failed alignment left it); "
            "for diagnosis only, not results",
            **{k: out[k] for k in keys},
        }
        for k in keys:
            out[k] = None
    if args.out:
        write(o["deviations"], args.out)
        out["written"] = {"deviations": str(args.out)}
    if args.report:
        from .report import build_report

        rep = build_report(
            o, cloud_file=args.cloud, nominal_file=args.nominal, run=res, tolerance=tolerance, customer=customer
        )
        out["report"] = rep.write(args.report)
    return out


def failure(r: dict[str, Any]) -> str | None:
    """The one line for stderr when the alignment failed (the CLI then exits 3), else None."""
    if r.get("aligned") is not False:
        return None
    return r.get("failure") or "alignment failed"


def _um(x: float | None, signed: bool = True) -> str:
    if x is None or x != x:
        return "—"
    # the number rule: µm below 1 mm (0.01 µm, three significant digits), 0 for what rounds to zero
    return numbers.deviation(x, signed) if abs(x) < 1 else numbers.length(x, signed=signed)


def text(r: dict[str, Any]) -> str:
    """Human-readable summary of :func:`run`."""
    a = r["alignment"]
    lines = [f"{r['cloud']} against {r['nominal']}: {r['n_points']} points, alignment {r['align']}"]
    state = "converged" if r["converged"] else "NOT CONVERGED"
    lines.append(f"  alignment  {state}" + (f" ({r['reason']})" if r["reason"] else ""))
    lines.append(
        f"             scale {r['scale']:.8f}  rotation {a['rotation_angle_deg']:.4f}°  translation "
        + "("
        + ", ".join(f"{v:.4f}" for v in a["translation"])
        + ") mm"
    )
    for h in r.get("held_dofs") or []:  # what the part's symmetry left undetermined
        lines.append(f"             held: {h}")
    ov = r["overlap"]
    lines.append(
        f"             rms {_um(r['rms'], False)}  overlap {100 * ov:.1f} %"
        if ov is not None and ov == ov
        else f"             rms {_um(r['rms'], False)}"
    )
    if r["stats"] is None:
        lines.append(f"  no deviations: {r.get('failure', 'alignment failed')}")
        lines += [f"  warning: {w}" for w in r.get("warnings", [])]
        if r.get("written"):
            lines.append(f"  wrote {r['written']['deviations']} (unaligned)")
        return "\n".join(lines)
    s, mr = r["stats"], r["material_ratio"]
    lines.append(f"  deviation  mean {_um(s['mean'])}  std {_um(s['std'], False)}  rms {_um(s['rms'], False)}")
    lines.append(f"             min {_um(s['min'])}  max {_um(s['max'])}")
    lines.append(f"             95 % within {_um(s['p97_5'])} / {_um(s['p2_5'])}")
    if r.get("tolerance") is not None:
        lines.append(f"             within ±{r['tolerance']} mm: {100 * s['within_tolerance']:.2f} %")
    c = r["coverage_info"]
    lines.append(
        f"  coverage   {c['percent']:.2f} % of the nominal area (±{100 * c['std_error']:.2f} %, points within "
        f"{c['distance']:.4g} mm)"
    )
    lines.append(
        f"  material   Sk {_um(mr['Sk'], False)}  Spk {_um(mr['Spk'], False)}  Svk {_um(mr['Svk'], False)}  "
        f"Smr1 {mr['Smr1']:.2f} %  Smr2 {mr['Smr2']:.2f} %"
    )
    for w in r.get("warnings", []):
        lines.append(f"  warning: {w}")
    if r.get("written"):
        lines.append(f"  wrote {r['written']['deviations']}")
    if r.get("report"):
        lines.append("  report " + ", ".join(r["report"].values()))
    return "\n".join(lines)
