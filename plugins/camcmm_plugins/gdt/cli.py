"""``camcmm gdt evaluate PLAN.yaml CLOUD [--nominal CAD.step|mesh] [--align best-fit|datums|rps|3-2-1|none]
[--start auto|coarse|none] [--k K] [--report DIR] [--project DIR] [--qif FILE [--qif-points]] [--csv FILE] [--json]``

Evaluates the plan (YAML or JSON: features, datums, characteristics; docs/gdt.md) on the
measured cloud through the host as the plugin ``gdt.evaluate``, so the result carries its
provenance. The options ``--align``, ``--start``, ``--k``, ``--max-iterations``,
``--seed`` are the plugin's declared parameters (help, limits, defaults from
plugin.yaml; ``camcmm gdt evaluate --help``); a refused value is one line naming the
option, as is a bad plan (naming the file and the key) or a file that is not a cloud.

JSON (``--json``; lengths in mm): ``features`` [{``id``, ``type``, ``association``,
``n_points``, ``params``, ``form``, ``status``, + ``reason``}], ``datums`` [{``label``,
``feature``}], ``alignment`` {``method``, ``transform`` (4×4 measured -> plan), ``rms``,
``iterations``, ``converged``, ``free``, ``stages`` ...}, ``characteristics`` [{``id``,
``type``, ``feature``, ``datums``, ``value``, ``unit``, ``tolerance``, ``u``, ``verdict``,
``verdict_guarded``, + ``lower``, ``upper``, ``U``, ``k``, ``u_method``, ``n_decisive``,
``warnings``, ``details``}], ``labels``, ``warnings``, ``summary`` (counts by guarded
verdict), ``plan``, ``cloud``, ``nominal``, ``plugin`` (provenance), + ``report`` (paths),
``qif`` and ``csv`` (the files ``--qif``/``--csv`` wrote) and ``result_id`` (``--project``).

Exit codes: 0 when the plan was evaluated (whatever the verdicts: "not conform" is a
result); 3 when the alignment did not settle (the document is printed, with
``aligned: false`` and ``failure``; its numbers rest on an unsettled pose); 2 bad input.
``--report`` and ``--project`` are written only after the evaluation succeeded.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from camcmm.api import InputError, Report, add_declared_options, declared_values, default_host, record_result

#: The plugin ``camcmm gdt evaluate`` runs.
PLUGIN = "gdt.evaluate"


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{evaluate,import-qif,batch}")
    from .qif import command as qif_command  # camcmm gdt import-qif (issue 28)

    qif_command.configure(sub)
    from . import batch_command  # camcmm gdt batch (issue 28)

    batch_command.configure(sub)
    e = sub.add_parser("evaluate", help="evaluate a GD&T plan on a measured cloud")
    e.add_argument("plan", help="the plan (.yaml or .json): features, datums, characteristics")
    e.add_argument("cloud", help="the measured cloud (.ply .pcd .xyz .csv .txt .e57)")
    e.add_argument(
        "--nominal", default=None, metavar="FILE", help="nominal in plan coordinates: STEP/IGES, mesh or cloud"
    )
    # --align, --start, --k, --max-iterations, --seed: the plugin's declared parameters
    add_declared_options(e, default_host().get(PLUGIN).parameters)
    e.add_argument("--report", default=None, metavar="DIR", help="write report.html, report.pdf, report.json here")
    Report.customer_options(e)  # --customer, --part-number ...: the report's head (over the plan's report:)
    e.add_argument("--project", default=None, metavar="DIR", help="record the result in this project folder")
    e.add_argument("--qif", default=None, metavar="FILE", help="write the QIF 3.0 Results here (docs/gdt.md)")
    e.add_argument("--qif-points", action="store_true", help="with --qif: the features' measured points too")
    e.add_argument("--csv", default=None, metavar="FILE", help="write the characteristics as CSV rows here")
    e.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> dict[str, Any]:
    if args.what == "batch":
        from . import batch_command

        return batch_command.run(args)
    if args.what == "import-qif":
        from .qif import command as qif_command

        return qif_command.run(args)
    host = default_host()
    spec = host.get(PLUGIN)
    params = declared_values(args, spec.parameters)  # checked first: a bad value reads no file
    for what, f in (("plan", args.plan), ("cloud", args.cloud), ("nominal", args.nominal)):
        if f is not None and not Path(f).is_file():
            raise InputError(f"{f}: no such file ({what})")
    from .alignment import options, rps_points
    from .batch import evaluation_json
    from .csv_out import check_output
    from .plan import read_plan

    outputs = {f: check_output(v, f"--{f}") for f, v in (("qif", args.qif), ("csv", args.csv)) if v is not None}

    plan = read_plan(args.plan)  # a bad plan is refused before the cloud is read
    customer = Report.customer_fields(plan.options.get("report"), args, where=f"{args.plan}: report")
    options(plan)
    if params.get("align") == "rps":
        rps_points(plan)
    inputs: dict[str, Any] = {"cloud": args.cloud, "plan": Path(args.plan)}
    if args.nominal:
        inputs["nominal"] = args.nominal
    res = host.run(PLUGIN, inputs, params)
    o = res.outputs
    out = evaluation_json(res, plan=args.plan, cloud=args.cloud, nominal=args.nominal)  # one JSON with gdt batch
    if args.report:  # rendered in memory first: a failure writes nothing
        from .report import build_report

        rep = build_report(
            o,
            plan=plan,
            plan_file=args.plan,
            cloud_file=args.cloud,
            nominal_file=args.nominal,
            run=res,
            customer=customer,
        )
        out["report"] = rep.write(args.report)
    if "qif" in outputs:  # the part named after its cloud file
        from .qif.write import feature_points, write_results

        al = o["aligned"]
        pts = feature_points(al.points, al.fields["feature"], plan) if args.qif_points else None
        out["qif"] = str(write_results(out, plan, outputs["qif"], part=Path(args.cloud).stem, points=pts))
    if "csv" in outputs:
        from .csv_out import rows, write_csv

        out["csv"] = str(write_csv(rows(out, Path(args.cloud).stem), outputs["csv"]))
    if args.project:
        out["result_id"] = record_result(args.project, res)
    return out


def failure(r: dict[str, Any]) -> str | None:
    """The one line for stderr when the alignment did not settle (exit 3), else None."""
    return r.get("failure") if r.get("aligned") is False else None


def _num(x: Any, digits: int = 4) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def _limits(c: dict[str, Any]) -> str:
    if c.get("tolerance") is not None:
        return f"{c['tolerance']:g}"
    lo, hi = c.get("lower"), c.get("upper")
    return f"{'' if lo is None else f'{lo:+g}'}/{'' if hi is None else f'{hi:+g}'}"


def text(r: dict[str, Any]) -> str:
    """A readable table of :func:`run`'s result."""
    if r.get("command") == "batch":
        from . import batch_command

        return batch_command.text(r)
    if r.get("command") == "import-qif":
        from .qif import command as qif_command

        return qif_command.text(r)
    a = r["alignment"]
    lines = [f"{r['plan']} on {r['cloud']}: {r['n_points']} points"]
    state = "settled" if a.get("converged", True) else "NOT SETTLED"
    rms = a.get("rms")
    lines.append(
        f"alignment {a['method']} {state}: {a.get('iterations', 0)} iterations, rms "
        f"{'—' if rms is None else f'{rms * 1000:.2f} µm'}, rotation {a.get('rotation_angle_deg', 0):.4f}°, "
        "translation (" + ", ".join(f"{v:.4f}" for v in a.get("translation", [0, 0, 0])) + ") mm"
    )
    for f in a.get("free") or []:
        lines.append(f"  free: {f}")
    lines.append("")
    lines.append(f"{'feature':10} {'type':10} {'assoc.':9} {'points':>7} {'form mm':>9}")
    for f in r["features"]:
        form = f["form"]["range"] if f.get("form") else None
        tail = "" if f["status"] == "evaluated" else f"  not evaluated: {f.get('reason', '')}"
        lines.append(f"{f['id']:10} {f['type']:10} {f['association']:9} {f['n_points']:7d} {_num(form):>9}{tail}")
    lines.append("")
    head = f"{'characteristic':16} {'type':17} {'datums':8} {'tol. mm':>11} {'value mm':>10} {'U mm':>8}  verdict"
    lines.append(head)
    for c in r["characteristics"]:
        verdict = c["verdict"] if c["verdict"] == c["verdict_guarded"] else f"{c['verdict']} / {c['verdict_guarded']}"
        lines.append(
            f"{c['id']:16} {c['type']:17} {'|'.join(c['datums']) or '—':8} {_limits(c):>11} "
            f"{_num(c['value']):>10} {_num(c['U']):>8}  {verdict}"
        )
    if r.get("summary"):
        lines.append("")
        lines.append("verdicts (ISO 14253-1, guarded): " + ", ".join(f"{k} {v}" for k, v in r["summary"].items()))
    for w in r.get("warnings", []):
        lines.append(f"warning: {w}")
    if r.get("report"):
        lines.append("report " + ", ".join(r["report"].values()))
    if r.get("result_id") is not None:
        lines.append(f"recorded as result {r['result_id']}")
    return "\n".join(lines)
