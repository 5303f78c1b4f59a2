"""``camcmm gdt batch PLAN CLOUD... [--nominal FILE] [--align …] [--start …] [--k K]
[--folder DIR] [--no-resume] [--subgroup M] [--confidence C] [--project DIR] [--qif DIR]
[--csv FILE] [--report DIR] [--json]``: one plan over many parts (:func:`.batch.run_batch`), their trend
and capability (:func:`.capability.summarise`).

Each cloud is aligned and evaluated as ``camcmm gdt evaluate`` does it; its record (the
evaluation with its provenance) goes to the batch's work folder — ``--folder``, default
``<plan stem>-batch`` in the working folder, never inside the project's folder (the
project store owns it) — and a second run resumes (parts already recorded for the same file,
plan and options are not evaluated again; ``--no-resume`` evaluates all). A part whose
file does not read, whose alignment does not settle or which has a feature without points
is listed as failed with its reason; the batch goes on. ``--project`` records each part's
run and the batch's summary (result ``gdt.batch``). ``--qif DIR`` writes one QIF 3.0
Results file a part (``DIR/<part>.qif``), ``--csv FILE`` one row a part and
characteristic, ``--report DIR`` the trend report (:mod:`.trend_report`: run charts,
capability, the parts out of tolerance or undecided; HTML, PDF, JSON).

JSON (``--json``): :meth:`.batch.Batch.to_json` — ``parts`` [{``part``, ``file``,
``status``, ``reason``, ``evaluation``, ``sha256``, ``resumed``, ``record``,
``result_id``, ``provenance``}], ``summary`` (per characteristic: ``n``, ``mean``, ``s``,
``cp``, ``cp_ci``, ``cpk``, ``cpk_ci``, ``control``, ``out``, ``undecided`` …),
``counts``, ``warnings`` (one per failed part) — plus ``command`` "batch", ``qif``
(paths), ``csv`` and ``report`` (paths).

Exit codes: 0 when the batch ran (failed parts are listed, not an error); 2 bad input (a
bad plan, option or nominal, one line naming it).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from camcmm.api import (
    InputError,
    ParameterError,
    add_declared_options,
    checked_path,
    declared_values,
    default_host,
)

from .batch import PLUGIN, run_batch
from .capability import CONFIDENCE, MAX_SUBGROUP

#: Verdict marks of the text table (simple verdict / guarded verdict).
MARKS = {"conform": "ok", "not conform": "OUT", "undecided": "undecided", "not evaluated": "—"}


def configure(sub: Any) -> None:
    """Add the ``batch`` subcommand to the ``camcmm gdt`` subparsers ``sub``."""
    b = sub.add_parser("batch", help="evaluate one GD&T plan on many parts: their trend and capability")
    b.add_argument("plan", help="the plan (.yaml or .json): features, datums, characteristics")
    b.add_argument("clouds", nargs="+", metavar="CLOUD", help="the measured clouds, in production order")
    b.add_argument("--nominal", default=None, metavar="FILE", help="nominal in plan coordinates (read once)")
    add_declared_options(b, default_host().get(PLUGIN).parameters)  # --align, --start, --k, ...
    b.add_argument(
        "--folder",
        default=None,
        metavar="DIR",
        help="the batch's work folder of part records (default <plan stem>-batch; outside the project)",
    )
    b.add_argument("--no-resume", action="store_true", help="evaluate every part again, even when recorded")
    b.add_argument(
        "--subgroup",
        type=int,
        default=None,
        metavar="M",
        help=f"parts in consecutive subgroups of M (2 … {MAX_SUBGROUP}): X̄/s control chart; "
        "default individuals / moving range",
    )
    b.add_argument(
        "--confidence", type=float, default=CONFIDENCE, metavar="C", help="of the Cp/Cpk intervals (default 0.95)"
    )
    b.add_argument("--project", default=None, metavar="DIR", help="record each part's run and the batch here")
    b.add_argument("--qif", default=None, metavar="DIR", help="write one QIF 3.0 Results file a part here")
    b.add_argument("--csv", default=None, metavar="FILE", help="write one CSV row a part and characteristic")
    b.add_argument(
        "--report", default=None, metavar="DIR", help="write the trend report (report.html, .pdf, .json) here"
    )
    b.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def _folder(args: argparse.Namespace) -> Path:
    return Path(args.folder) if args.folder else Path(f"{Path(args.plan).stem}-batch")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Check the options, run the batch, write QIF/CSV; the batch's document."""
    params = declared_values(args, default_host().get(PLUGIN).parameters)  # checked first, naming the option
    if args.subgroup is not None and not 1 <= args.subgroup <= MAX_SUBGROUP:
        raise ParameterError(f"--subgroup: {args.subgroup} is not in 1 … {MAX_SUBGROUP}")
    if not 0.5 <= args.confidence < 1:
        raise ParameterError(f"--confidence: {args.confidence:g} is not in [0.5, 1)")
    if not Path(args.plan).is_file():
        raise InputError(f"{args.plan}: no such file (plan)")
    qif = None
    if args.qif:
        qif = checked_path(args.qif, "--qif")
        if qif.exists() and not qif.is_dir():
            raise InputError(f"{args.qif}: is a file (--qif expects a folder)")
        try:  # before any part: a folder that cannot be made wastes no batch
            qif.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"{args.qif}: cannot be made a folder ({exc.strerror or exc}) (--qif)") from None
    report = None
    if args.report:
        report = checked_path(args.report, "--report")
        if report.exists() and not report.is_dir():
            raise InputError(f"{args.report}: is a file (--report expects a folder)")
    csv = None
    if args.csv:
        from .csv_out import check_output

        csv = check_output(args.csv, "--csv")
    batch = run_batch(
        args.plan,
        args.clouds,
        nominal=args.nominal,
        folder=_folder(args),
        resume=not args.no_resume,
        project=args.project,
        **params,
    )
    doc = batch.to_json(confidence=args.confidence, subgroup=args.subgroup)
    doc["command"] = "batch"
    evaluated = [p for p in doc["parts"] if p["evaluation"] is not None]
    if qif is not None:
        from .plugin import load_plan
        from .qif.write import write_results

        plan = load_plan(args.plan)
        doc["qif"] = [
            str(
                write_results(
                    p["evaluation"],
                    plan,
                    qif / f"{_file_name(p['part'])}.qif",
                    part=p["part"],
                    provenance=_qif_items(p),
                )
            )
            for p in evaluated
        ]
    if csv is not None:
        from .csv_out import rows, write_csv

        doc["csv"] = str(write_csv([r for p in evaluated for r in rows(p["evaluation"], p["part"])], csv))
    if report is not None:
        from .trend_report import build_trend_report

        doc["report"] = build_trend_report(doc).write(report)
    return doc


def _file_name(part: str) -> str:
    """A part's name as a file name (a path given for a repeated stem: its separators)."""
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in part).strip(".") or "part"


def _qif_items(part: dict[str, Any]) -> dict[str, Any]:
    """The part's provenance for the QIF measurement's attributes: file and its SHA-256,
    the batch status."""
    items = {"file": part["file"], "sha256": part["sha256"], "status": part["status"]}
    if part.get("reason"):
        items["reason"] = part["reason"]
    return items


def _cell(c: dict[str, Any] | None) -> str:
    if c is None or c.get("value") is None:
        return "—"
    mark = MARKS.get(c["verdict"], c["verdict"])
    if c["verdict_guarded"] != c["verdict"]:
        mark += "/" + MARKS.get(c["verdict_guarded"], c["verdict_guarded"])
    return f"{c['value']:.4f} {mark}"


def _num(x: float | None, digits: int = 4) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def _ci(ci: list[float] | None) -> str:
    return "" if ci is None else f" [{ci[0]:.3f}, {ci[1]:.3f}]"


def text(r: dict[str, Any]) -> str:
    """The parts × characteristics table with verdicts, then the capability lines."""
    c = r["counts"]
    lines = [
        f"{r['plan']}: {c['parts']} parts, {c['evaluated']} evaluated, {c['failed']} failed "
        f"({c['resumed']} resumed from {r['folder']})"
    ]
    ids = [s["id"] for s in r["summary"]]
    cells = []
    for p in r["parts"]:
        by_id = {x["id"]: x for x in (p.get("evaluation") or {}).get("characteristics", [])}
        cells.append([_cell(by_id.get(i)) for i in ids] if by_id else [])
    widths = [max([len(i), *(len(row[j]) for row in cells if row)]) + 3 for j, i in enumerate(ids)]
    pw = max([8, *(len(p["part"]) + 2 for p in r["parts"])])
    lines += ["", f"{'part':{pw}}" + "".join(f"{i:>{w}}" for i, w in zip(ids, widths, strict=True))]
    for p, row in zip(r["parts"], cells, strict=True):
        text_row = f"{p['part']:{pw}}" + "".join(f"{x:>{w}}" for x, w in zip(row, widths, strict=False))
        if p["status"] != "evaluated":
            text_row += f"  FAILED: {p['reason']}"
        lines.append(text_row.rstrip())
    lines.append("(value mm, simple verdict / ISO 14253-1 guarded verdict where they differ)")
    pct = f"{r['summary'][0]['confidence'] * 100:g} %" if r["summary"] else ""
    for s in r["summary"]:
        lim = s["limits"]
        lines.append("")
        if lim["kind"] == "zone":
            spec = f"tolerance {lim['usl']:g}"
        elif lim["kind"] == "size":
            spec = f"limits {_num(lim['lsl'])} … {_num(lim['usl'])}"
        else:
            spec = "no limits"
        lines.append(
            f"{s['id']} ({s['type']}, {spec} {s['unit']}): n {s['n']}, mean {_num(s['mean'])}, s {_num(s['s'], 5)}"
        )
        cp = "Cp —" if s["cp"] is None else f"Cp {s['cp']:.3f}{_ci(s['cp_ci'])}"
        cpk = "Cpk —" if s["cpk"] is None else f"Cpk {s['cpk']:.3f}{_ci(s['cpk_ci'])}"
        lines.append(f"  {cp}, {cpk} ({pct} intervals)")
        ctl = s.get("control")
        if ctl:
            what = "individuals/MR" if ctl["kind"] == "individuals" else f"X̄/s of subgroups of {ctl['m']}"
            beyond = ", ".join(map(str, ctl["beyond"])) or "none"
            lines.append(
                f"  control ({what}): centre {_num(ctl['centre'])}, UCL {_num(ctl['ucl'])}, "
                f"LCL {_num(ctl['lcl'])}; beyond: {beyond}"
            )
        lines.append(
            f"  out of tolerance: {', '.join(s['out']) or 'none'}; undecided: {', '.join(s['undecided']) or 'none'}"
        )
        for note in s["notes"]:
            lines.append(f"  note: {note}")
    for w in r.get("warnings", []):
        lines.append(f"warning: {w}")
    if r.get("qif"):
        lines.append(f"QIF Results: {len(r['qif'])} files in {Path(r['qif'][0]).parent}")
    if r.get("csv"):
        lines.append(f"CSV: {r['csv']}")
    if r.get("report"):
        lines.append("report " + ", ".join(r["report"].values()))
    if r.get("result_id") is not None:
        lines.append(f"batch recorded as result {r['result_id']} in {r['project']}")
    return "\n".join(lines)
