"""``camcmm gdt import-qif FILE.qif --out plan.yaml [--json]``: a QIF 3.0 model-based
definition into a GD&T plan (:func:`.read.import_qif`), written as YAML (or JSON when
``--out`` ends in .json) that ``camcmm gdt evaluate`` reads.

JSON (``--json``): ``features``, ``datums``, ``characteristics`` (counts of what the plan
holds), ``skipped`` [{``id`` (QIF id), ``reason``}], ``imported`` [{``id``, ``kind``,
``qif``, ``as``}], ``unit`` (the file's length unit; the plan is in mm), ``unlimited``
(features without an extent), ``notes``, ``warnings`` (one per skipped item and per
unlimited feature), ``plan`` (the file written). The plan is checked by reading it back
(:func:`..plan.read_plan`) before the command reports success.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Any

from camcmm.api import InputError, checked_path

#: A JSON number in exponent form without a fraction (``1e-05``): YAML 1.1, through which
#: camcmm reads plans (JSON too), takes it for a string; ``1.0e-05`` is a number to both.
_BARE_EXPONENT = re.compile(r"(?<=[\s\[,:])(-?\d+)e([-+]?\d+)(?=[\s,\]}])")


def _yaml_safe_json(doc: dict[str, Any]) -> str:
    return _BARE_EXPONENT.sub(r"\1.0e\2", json.dumps(doc, indent=1))


def configure(sub: Any) -> None:
    """Add the ``import-qif`` subcommand to the ``camcmm gdt`` subparsers ``sub``."""
    q = sub.add_parser("import-qif", help="a QIF 3.0 model-based definition into a GD&T plan (YAML)")
    q.add_argument("qif", help="the QIF 3.0 file (.qif): features, datums, characteristics")
    q.add_argument("--out", required=True, metavar="PLAN", help="the plan to write (.yaml, or .json)")
    q.add_argument("--json", action="store_true", default=argparse.SUPPRESS, help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> dict[str, Any]:
    import yaml

    from ..plan import read_plan
    from .plugin import report_warnings
    from .read import import_qif

    src = checked_path(args.qif, "QIF file")
    if not Path(src).is_file():
        raise InputError(f"{args.qif}: no such file (QIF file)")
    out = Path(checked_path(args.out, "plan"))
    if out.suffix.lower() not in (".yaml", ".yml", ".json"):
        raise InputError(f"--out: {args.out}: a plan is written as .yaml, .yml or .json")
    if not out.parent.is_dir():
        raise InputError(f"--out: {args.out}: no such folder {out.parent}")
    doc, report = import_qif(src)
    text = (
        _yaml_safe_json(doc)
        if out.suffix.lower() == ".json"
        else yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=120)
    )
    tmp = out.with_name(out.name + ".part")
    tmp.write_text(text, encoding="utf-8")
    try:
        read_plan(tmp)  # what evaluate will read: refused here rather than there
    except InputError:
        tmp.unlink(missing_ok=True)
        raise
    tmp.replace(out)
    warnings = report_warnings(report)
    return {"command": "import-qif", "qif": str(args.qif), "plan": str(out), **report, "warnings": warnings}


def text(r: dict[str, Any]) -> str:
    """A readable summary of :func:`run`'s result."""
    lines = [
        f"{r['qif']} -> {r['plan']}: {r['features']} features, {r['datums']} datums, "
        f"{r['characteristics']} characteristics (file unit {r['unit']}; the plan in mm)"
    ]
    for item in r["imported"]:
        lines.append(f"  imported {item['kind']} {item['id']} ({item['qif']}) as {item['as']}")
    for s in r["skipped"]:
        lines.append(f"  skipped {s['id']}: {s['reason']}")
    for n in r.get("notes", []):
        lines.append(f"  note: {n}")
    return "\n".join(lines)
