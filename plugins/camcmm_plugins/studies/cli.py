"""``camcmm study speckle STUDY.yaml [--report DIR] [--json] [--fresh]``

Runs ``studies.speckle`` through the host: every artefact × material of the study file
with and without laser speckle (thesis ch. 6.2), resuming from the finished cases of the
study's work folder. JSON keys: ``cases`` [{``id``, ``artefact``, ``material``,
``condition``, ``std_um``, ``n_points``, ``coverage_area_fraction``, ``coverage_by_face``
{top, side, curved, bottom}, + ``mean_um``, ``alignment``, ``timings`` ...}], ``summary``
{material: {``std_um_change``, ``n_points_change``, ``coverage_area_fraction_change``
...}}, ``computed``, ``reused``, ``failed``, ``warnings`` (+ ``report``).

Exit codes: 0 with a result (failed cases, if some, in ``failed`` and the warnings), 2 for
a study file refused (one line naming the file, the key and the value), 3 when every case
failed: the document is printed, the failures listed on stdout and named on stderr.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from camcmm.api import InputError, default_host


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="what", required=True, metavar="{speckle}")
    s = sub.add_parser("speckle", help="laser speckle on/off on AM artefacts (thesis ch. 6.2)")
    s.add_argument("study", metavar="STUDY.yaml", help="the study file (docs/studies.md)")
    s.add_argument("--report", metavar="DIR", help="write report.html, report.pdf, report.json here")
    s.add_argument("--fresh", action="store_true", help="recompute every case (default: resume)")
    s.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> dict[str, Any]:
    if not Path(args.study).is_file():
        raise InputError(f"{args.study}: no such study file")
    res = default_host().run("studies.speckle", {}, {"study": args.study, "fresh": bool(args.fresh)})
    o = res.outputs
    out = {k: o[k] for k in ("cases", "summary", "computed", "reused", "failed", "study")}
    out["warnings"] = list(res.warnings)
    if args.report:
        from .report import build_report

        out["report"] = build_report(o, run=res).write(args.report)
    return out


def failure(r: dict[str, Any]) -> str | None:
    """The one line for stderr when every case of the study failed (the CLI then exits 3,
    as for any command whose run produced no result), else None; a study with some
    failed cases is a result, its failures in ``failed`` and ``warnings``."""
    failed = [c for c in r["cases"] if "error" in c]
    if not r["cases"] or len(failed) < len(r["cases"]):
        return None
    ids = ", ".join(c["id"] for c in failed)
    first = " ".join(str(failed[0]["error"]).split())  # one line, whatever the case's error held
    return f"{Path(r['study']['file']).name}: every case failed ({ids}); the first: {first}"


def text(r: dict[str, Any]) -> str:
    lines = [f"study {r['study']['name']}: {len(r['computed'])} case(s) computed, {len(r['reused'])} reused"]
    for c in r["cases"]:
        if "error" in c:
            lines.append(f"  {c['id']}: FAILED {c['error']}")
            continue
        f = c["coverage_by_face"]
        per = ", ".join(f"{k} {100 * v:.0f} %" for k, v in f.items() if v is not None and k != "bottom")
        lines.append(
            f"  {c['id']}: std {c['std_um']:.0f} µm, {c['n_points']} points, "
            f"area coverage {100 * c['coverage_area_fraction']:.1f} % ({per})"
        )
    for m, s in r["summary"].items():
        if s.get("n_artefacts"):
            lines.append(
                f"  {m}: speckle changes std by {s['std_um_change']:+.0f} µm, points by {s['n_points_change']:+.0f}, "
                f"coverage by {100 * s['coverage_area_fraction_change']:+.1f} % (mean of {s['n_artefacts']})"
            )
    lines += [f"  warning: {w}" for w in r.get("warnings", [])]
    if r.get("report"):
        lines.append("  report " + ", ".join(r["report"].values()))
    return "\n".join(lines)
