"""``camcmm lightfield gradient|study`` (thesis ch. 6.3; docs/studies.md)

* ``gradient --cloud CLOUD --views MODEL --depth-maps DIR [--lambda-range MIN,MAX]
  [--band L] [--region all|plane] [--scale S] [--report DIR] [--json]``: the plugin
  ``lightfield.gradient``. JSON keys: ``views`` [{``image``, ``gradient_mm_per_lambda``,
  ``intercept``, ``r2``, ``n_pixels``, + ``u_gradient``, ``n_band``, ``n_rejected`` ...}],
  ``mean``, ``std`` (sample, n-1), ``n_views``, ``warnings``, ``plugin``.
* ``study STUDY.yaml [--predict-focal MM] [--report DIR] [--json]``: ``lightfield.study``:
  ``table`` (table 6.3), ``focal`` (fig. 6.16's fit and prediction), ``truth``.
* ``simulate DIR [--focal-lengths 30,40,50] [--views N] [--sigma-lambda S]``: the virtual
  lab's set (``virtuallab.lightfield-set``): clouds, views, lambda maps, study.yaml, truth.json.

Bad input exits 2 with one line naming the file or value; ``--report`` is written only after
the run succeeded.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from camcmm.api import InputError, default_host


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{gradient,study,simulate}")
    g = sub.add_parser("gradient", help="photogrammetric depth against Lytro lambda per view (ch. 6.3)")
    g.add_argument("--cloud", required=True, help="the reconstruction's cloud (mm, or give --scale)")
    g.add_argument("--views", required=True, metavar="MODEL", help="reconstruction JSON or COLMAP model folder")
    g.add_argument("--depth-maps", required=True, metavar="DIR", help="folder of 16-bit depth maps (+ JSON sidecars)")
    g.add_argument("--lambda-range", default=None, metavar="MIN,MAX", help="lambda range of every map")
    g.add_argument("--band", type=float, default=None, metavar="L", help="leave out |lambda| < L (default 0.5)")
    g.add_argument("--region", choices=("all", "plane"), default=None, help="plane: only the flat background")
    g.add_argument("--scale", type=float, default=None, help="mm per cloud unit (default 1)")
    g.add_argument("--lambda-convention", choices=("eq6.5", "absolute"), default=None, help="eq. 6.5 as printed")
    g.add_argument("--depth-measure", choices=("distance", "z"), default=None, help="eq. 6.3 distance or Z'")
    g.add_argument(
        "--sigma-lambda", type=float, default=None, metavar="S", help="known lambda noise: undo its dilution"
    )
    s = sub.add_parser("study", help="table 6.3 and the focal-length fit of a study file")
    s.add_argument("study", help="study YAML/JSON (docs/studies.md)")
    s.add_argument("--predict-focal", type=float, default=None, metavar="MM", help="predict the gradient here")
    v = sub.add_parser("simulate", help="write a virtual light-field scale set (virtuallab.lightfield-set)")
    v.add_argument("directory", help="folder to write")
    v.add_argument("--focal-lengths", default=None, metavar="F1,F2,...", help="one set per focal length, mm")
    v.add_argument("--views", type=int, default=None, metavar="N", help="views per run (default 4)")
    v.add_argument("--sigma-lambda", type=float, default=None, metavar="S", help="lambda noise (default 0.02)")
    v.add_argument("--seed", type=int, default=None)
    v.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document")
    for sp in (g, s):
        sp.add_argument("--report", metavar="DIR", help="write report.html, report.pdf, report.json here")
        sp.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document")


def run(args: argparse.Namespace) -> dict[str, Any]:
    host = default_host()
    if args.what == "simulate":
        params: dict[str, Any] = {"directory": str(args.directory)}
        if args.focal_lengths:
            try:
                params["focal_lengths"] = [float(x) for x in args.focal_lengths.split(",")]
            except ValueError:
                raise InputError(f"--focal-lengths {args.focal_lengths!r}: give numbers, e.g. 30,40,50") from None
        for k, name in (("views", "n_views"), ("sigma_lambda", "sigma_lambda"), ("seed", "seed")):
            if getattr(args, k) is not None:
                params[name] = getattr(args, k)
        res = host.run("virtuallab.lightfield-set", {}, params)
        return {"study": res.outputs["study"], "truth": res.outputs["truth"], "files": res.outputs["files"]}
    if args.what == "gradient":
        for f in (args.cloud, args.views, args.depth_maps):
            if not Path(f).exists():
                raise InputError(f"{f}: no such file or folder")
        params = {
            k: getattr(args, k)
            for k in ("lambda_range", "band", "region", "scale", "lambda_convention", "depth_measure", "sigma_lambda")
            if getattr(args, k) is not None
        }
        res = host.run(
            "lightfield.gradient",
            {"cloud": args.cloud, "views": args.views, "depth_maps": args.depth_maps},
            params,
        )
        out = dict(res.outputs["result"])
        builder = "gradient_report"
    else:
        if not Path(args.study).is_file():
            raise InputError(f"{args.study}: no such study file")
        params = {} if args.predict_focal is None else {"predict_focal_mm": args.predict_focal}
        res = host.run("lightfield.study", {"study": args.study}, params)
        out = dict(res.outputs["result"])
        builder = "study_report"
    out["warnings"] = list(res.warnings)
    out["plugin"] = res.provenance()
    if args.report:
        from . import report

        rep = getattr(report, builder)(res.outputs, run=res)
        out["report"] = rep.write(args.report)
    return out


def text(r: dict[str, Any]) -> str:
    """Human-readable summary of :func:`run`."""
    lines = []
    if "study" in r:
        return f"wrote {len(r['files'])} run folder(s) and {r['study']}"
    if "views" in r:
        for v in r["views"]:
            lines.append(
                f"{v['image']}: {v['gradient_mm_per_lambda']:.4f} ± {v['u_gradient']:.4f} mm/λ, "
                f"intercept {v['intercept']:.3f} mm, r² {v['r2']:.4f}, {v['n_pixels']} px"
            )
        std = "—" if r["std"] is None else f"{r['std'] * 1000:.1f} µm/λ"
        lines.append(f"mean {r['mean']:.4f} mm/λ, std {std} over {r['n_views']} view(s)")
    else:
        t = r["table"]
        lines.append("artefact".ljust(16) + "".join(s.rjust(10) for s in t["sets"]))
        for a, row in zip(t["artefacts"], t["gradients"]):
            lines.append(a[:16].ljust(16) + "".join(("—" if g is None else f"{g:.4f}").rjust(10) for g in row))
        lines.append(
            "std / µm λ⁻¹".ljust(16) + "".join(("—" if s is None else f"{s * 1000:.1f}").rjust(10) for s in t["std"])
        )
        f = r.get("focal")
        if f:
            lines.append(f"gradient = {f['slope']:.5f} × f {f['intercept']:+.4f} mm/λ (r² {f['r2']:.4f}, n {f['n']})")
            p = f.get("predicted")
            if p:
                u = "—" if p["u"] is None else f"{p['u']:.4f}"
                lines.append(f"at f = {p['focal_length']:g} mm: {p['gradient_mm_per_lambda']:.4f} mm/λ, u {u}")
        for s in (r.get("truth") or {}).get("sets", []):
            lines.append(f"truth {s['set']}: {s['true']:.4f}, recovered {s['mean']:.4f} ({s['difference']:+.4f}) mm/λ")
    lines += [f"  warning: {w}" for w in r.get("warnings", [])]
    if r.get("report"):
        lines.append("  report " + ", ".join(r["report"].values()))
    return "\n".join(lines)
