"""``camcmm uncertainty budget|iso15530-3|montecarlo FILE.yaml [--json]``

* ``budget FILE``: a GUM budget. JSON keys ``combined, dof_eff, k, expanded,
  coverage_probability, contributions`` (+ ``quantity, unit, dof_eff_infinite, warnings``;
  per contribution + ``entered_as, entered_value, divisor, coverage_factor, conversion``);
  an infinite dof is written as ``null``. An entry gives u, or half_width + distribution,
  or expanded + k (see :mod:`.distributions`).
* ``iso15530-3 FILE``: ISO 15530-3 with a calibrated workpiece. JSON keys ``mean, bias,
  u_cal, u_p, u_b, u_w, k, U, n`` (+ ``U_uncorrected_bias, combined, shares``).
* ``montecarlo FILE [--iterations N] [--seed S] [--method linear|optimal]
  [--scheduler ADDRESS] [--studies convergence,sweep,volume_maps,spatial] [--out DIR]``:
  JSON keys ``contributions {factor: [ux, uy, uz]}, combined [x, y, z], dof_eff, k,
  expanded, iterations`` (+ ``unit``, ``studies``); ``--out`` also writes
  ``montecarlo.json`` and ``.npz`` arrays there.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from camcmm.api import InputError


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{budget,iso15530-3,montecarlo}")
    b = sub.add_parser("budget", help="GUM budget from a YAML file")
    b.add_argument("file", help="budget file (YAML): quantity, unit, coverage_probability, contributions")
    b.add_argument(
        "--coverage-probability",
        type=float,
        default=None,
        metavar="P",
        help="coverage probability (overrides the file; default 0.95)",
    )
    b.add_argument(
        "--dof-rounding",
        choices=("truncate", "none"),
        default="truncate",
        help="truncate the effective dof to an integer before the t quantile (GUM G.4.1; default)",
    )
    i = sub.add_parser("iso15530-3", help="ISO 15530-3 uncertainty with a calibrated workpiece")
    i.add_argument("file", help="input file (YAML): calibrated_value, u_cal, measurements, u_w, k")
    i.add_argument("--project", help="take the repeated results from this project folder ...")
    i.add_argument("--result", type=int, help="... from this stored result ...")
    i.add_argument("--path", help="... at this path, e.g. parameters.PS.per_measurement[].value")
    i.add_argument("--k", type=float, default=None, help="coverage factor (overrides the file; default 2)")
    m = sub.add_parser("montecarlo", help="Monte Carlo uncertainty of a stereo camera system")
    m.add_argument("file", help="system file (YAML): cameras, uncertainties, grid")
    m.add_argument("--iterations", type=int, default=None, metavar="N", help="trials per factor (default 10000)")
    m.add_argument("--seed", type=int, default=None, help="random seed (default: the file's, else 0)")
    m.add_argument("--method", choices=("linear", "optimal"), default=None, help="triangulation method")
    m.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="Dask scheduler address (e.g. tcp://10.0.0.5:8786); default: this machine, vectorised",
    )
    m.add_argument(
        "--studies",
        default="",
        metavar="LIST",
        help="extra studies, comma-separated: convergence, sweep, volume_maps, spatial (or all)",
    )
    m.add_argument("--out", default=None, metavar="DIR", help="write montecarlo.json and montecarlo.npz here")
    for sp in (b, i, m):
        # the core adds --json to the command's parser; accept it after the subcommand's
        # arguments too (SUPPRESS: an absent flag here does not reset the parent's)
        sp.add_argument(
            "--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout"
        )


def run(args: argparse.Namespace) -> dict[str, Any]:
    from .plugin import load_spec

    if args.what == "budget":
        from .gum import budget_from_dict

        doc, _ = load_spec(args.file)
        if args.coverage_probability is not None:
            doc["coverage_probability"] = args.coverage_probability
        doc.setdefault("dof_rounding", args.dof_rounding)
        return budget_from_dict(doc).to_dict()
    if args.what == "iso15530-3":
        from .iso15530 import from_dict

        doc, base = load_spec(args.file)
        if args.k is not None:
            doc["k"] = args.k
        given = [args.project, args.result, args.path]
        if any(v is not None for v in given):
            if any(v is None for v in given):
                raise InputError("--project, --result and --path go together")
            doc.pop("measurements", None)
            doc.pop("measurements_file", None)
            doc["measurements_from"] = {
                "project": str(Path(args.project).resolve()),
                "result": args.result,
                "path": args.path,
            }
        return from_dict(doc, base)
    from camcmm.api import CamcmmError, declared_value

    from .montecarlo import check_out_dir, run_study, write_outputs

    args.iterations = declared_value("uncertainty.montecarlo", "iterations", args.iterations)
    args.seed = declared_value("uncertainty.montecarlo", "seed", args.seed)
    doc, base = load_spec(args.file)
    if args.out:
        check_out_dir(args.out, create=False)
    studies = [s.strip() for s in args.studies.split(",") if s.strip()]
    try:
        res = run_study(
            doc,
            iterations=args.iterations,
            seed=args.seed,
            method=args.method,
            scheduler=args.scheduler,
            studies=studies,
        )
    except CamcmmError as exc:  # the rest comes from the file: name it
        raise type(exc)(f"{Path(args.file).name}: {exc}") from None
    if args.out:
        res["files"] = write_outputs(res, args.out)
    return res


def _g(x: Any, fmt: str = ".4g") -> str:
    return "inf" if x is None or (isinstance(x, float) and math.isinf(x)) else format(x, fmt)


def text(result: dict[str, Any]) -> str:
    if "contributions" in result and isinstance(result["contributions"], list):  # budget
        unit = result.get("unit", "")
        lines = [
            f"{result.get('quantity') or 'budget'}: u_c = {_g(result['combined'])} {unit}, "
            f"nu_eff = {_g(result['dof_eff'])}, k = {result['k']:.3f} "
            f"(p = {result['coverage_probability']:g}), U = {_g(result['expanded'])} {unit}"
        ]
        for c in result["contributions"]:
            lines.append(
                f"  {c['name']:28} u={_g(c['u'])} c={_g(c['c'])} |c|u={_g(c['contribution'])} "
                f"dof={_g(c['dof'])} {c['distribution']:11} share {100 * c['share']:.1f} %"
            )
            if c.get("entered_as", "u") != "u":
                lines.append(f"  {'':28} entered as {c['conversion']}")
        lines += [f"warning: {w}" for w in result.get("warnings", [])]
        return "\n".join(lines)
    if "u_cal" in result:  # iso15530-3
        unit = result.get("unit", "")
        s = (
            f"{result.get('measurand') or 'measurand'}: n = {result['n']}, mean = {result['mean']:.6g} {unit}, "
            f"bias = {result['bias']:.3g} {unit}\n"
            f"  u_cal = {result['u_cal']:.3g}  u_p = {result['u_p']:.3g}  u_b = {result['u_b']:.3g}  "
            f"u_w = {result['u_w']:.3g} {unit}\n"
            f"  U = {result['U']:.3g} {unit} (k = {result['k']:g}); bias uncorrected: "
            f"{result['U_uncorrected_bias']:.3g} {unit}"
        )
        return s + (f"\n  note: {result['note']}" if result.get("note") else "")
    unit = result.get("unit", "um")
    lines = [
        f"Monte Carlo, {result['iterations']} iterations x {result.get('n_points', '?')} points "
        f"({result.get('method', '')}):",
        f"  {'factor':24} {'x':>8} {'y':>8} {'z':>8}  [{unit}]",
    ]
    for name, v in result["contributions"].items():
        lines.append(f"  {name:24} " + " ".join(f"{x:8.3f}" for x in v))
    lines.append(f"  {'combined':24} " + " ".join(f"{x:8.3f}" for x in result["combined"]))
    lines.append(f"  {'dof_eff':24} " + " ".join(f"{_g(x, '8.1f'):>8}" for x in result["dof_eff"]))
    lines.append(f"  {'k':24} " + " ".join(f"{x:8.3f}" for x in result["k"]))
    lines.append(f"  {'U':24} " + " ".join(f"{x:8.3f}" for x in result["expanded"]))
    return "\n".join(lines)
