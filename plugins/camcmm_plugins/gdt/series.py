"""Plugin entry ``gdt.series`` (provides ``gdt-series``): one plan over several parts,
the GUI's Series view, headless (camcmm.tasks.series runs it in a worker process).

It is :func:`.batch.run_batch` (each part aligned and evaluated by ``gdt.evaluate``, a
failing part recorded and the series going on, resumable from its work folder) with the
parts named as the caller shows them (``names``: the project items' names), and the
batch's document (:meth:`.batch.Batch.to_json`: ``parts``, ``summary`` per
characteristic from :func:`.capability.summarise` — mean, s, Cp/Cpk with confidence
intervals, control limits, parts out of tolerance / undecided — ``counts``,
``warnings``) as the output ``batch``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from camcmm.api import InputError

from .batch import run_batch


def series(
    ctx,
    clouds: list[Path],
    plan: Any,
    nominal: Any = None,
    folder: Any = None,
    names: Any = None,
    *,
    align: str = "best-fit",
    start: str = "auto",
    subgroup: int = 1,
) -> dict[str, Any]:
    """gdt.series: see the module docstring. ``folder`` the work folder of the part
    records (None: a temporary one, so nothing resumes)."""
    files = [Path(c) for c in clouds]
    labels = [str(n) for n in names] if names is not None else None
    if labels is not None and len(labels) != len(files):
        raise InputError(f"names: {len(labels)} names for {len(files)} clouds")
    if labels is not None and len(set(labels)) != len(labels):
        raise InputError("names: two parts have the same name")

    def run(out: Path) -> dict[str, Any]:
        batch = run_batch(
            plan, files, align=align, start=start, nominal=nominal, folder=out, progress=ctx.progress
        )  # ctx.progress raises Cancelled when the run is cancelled: between or inside parts
        if labels is not None:  # the parts as the caller names them (the summary names them too)
            for p, name in zip(batch.parts, labels, strict=True):
                p["part"] = name
        for w in batch.warnings:
            ctx.warn(w)
        return batch.to_json(subgroup=subgroup if subgroup >= 2 else None)

    if folder is not None:
        return {"batch": run(Path(folder))}
    with tempfile.TemporaryDirectory(prefix="camcmm-series-") as tmp:
        doc = run(Path(tmp))
        doc["folder"] = None
        return {"batch": doc}
