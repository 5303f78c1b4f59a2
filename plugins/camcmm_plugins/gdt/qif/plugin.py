"""Plugin entry ``gdt.import-qif`` (provides ``qif-import``): a QIF 3.0 model-based
definition file into a GD&T plan document, as ``camcmm gdt import-qif`` reads it
(:func:`.read.import_qif`), for a page that may not import plugin code (the Compare
page's Import plan).

Outputs: ``plan`` (the plan document, lengths in mm, the YAML of docs/gdt.md) and
``report`` (``features``, ``datums``, ``characteristics`` counts, ``skipped`` [{``id``,
``reason``}], ``imported``, ``unit``, ``unlimited``, ``notes``). Each skipped item and
each feature without an extent is also a run warning (:func:`report_warnings`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camcmm.api import InputError, checked_path


def report_warnings(report: dict[str, Any]) -> list[str]:
    """The warnings an import report carries: one per skipped QIF item, one per feature
    whose points are selected over an unlimited extent."""
    out = [f"QIF {s['id']} not imported: {s['reason']}" for s in report.get("skipped") or []]
    out += [
        f"feature {f}: no extent in the QIF; its points are selected over an unlimited extent"
        for f in report.get("unlimited") or []
    ]
    return out


def import_qif(ctx: Any, qif: Any) -> dict[str, Any]:
    """gdt.import-qif: the QIF file ``qif`` (a path) read into ``plan`` and ``report``."""
    from .read import import_qif as read_qif

    if not isinstance(qif, (str, Path)):
        raise InputError(f"qif: expected the path of a QIF file, got a {type(qif).__name__}")
    src = Path(checked_path(qif, "QIF file"))  # confined runs: inside the project or data roots
    if not src.is_file():
        raise InputError(f"{src.name}: no such file (QIF file)")
    plan, report = read_qif(src)
    for w in report_warnings(report):
        ctx.warn(w)
    return {"plan": plan, "report": report}
