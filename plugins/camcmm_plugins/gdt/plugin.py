"""Plugin entry ``gdt.evaluate``: the plan (file or document) and the cloud through
:func:`.evaluate.evaluate`, its outputs as the manifest declares them (plugin.yaml).

Outputs for a GUI: ``characteristics`` (the issue's keys per characteristic, plus
lower/upper/U/k/u_method/n_decisive/warnings/details), ``labels`` (per characteristic an
anchor, up to 20 decisive points and the guarded verdict, plan coordinates),
``aligned`` (the cloud in plan coordinates with the field ``feature``: the index of the
feature in ``features`` each point belongs to, -1 none).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, PointCloud

from .evaluate import evaluate as run_evaluation
from .model import Plan


def load_plan(plan: Any) -> Plan:
    """A plan from a file path (YAML or JSON), a document (dict) or a Plan."""
    from .plan import parse_plan, read_plan

    if isinstance(plan, Plan):
        return plan
    if isinstance(plan, (str, Path)):
        return read_plan(plan)
    if isinstance(plan, dict):
        return parse_plan(plan, source="plan")
    raise InputError(f"plan: expected a plan file or document, got a {type(plan).__name__}")


def evaluate(
    ctx,
    cloud: PointCloud,
    plan: Any,
    nominal: Any = None,
    *,
    align: str = "best-fit",
    start: str = "auto",
    k: float | None = None,
    max_iterations: int = 50,
    seed: int = 0,
) -> dict[str, Any]:
    """gdt.evaluate: see :mod:`.evaluate`."""
    if not isinstance(cloud, PointCloud):
        raise InputError(f"cloud: expected a point cloud, got a {type(cloud).__name__}")
    if cloud.n_points == 0:
        raise InputError(f"{cloud.name}: the cloud holds no points")
    p = load_plan(plan)
    ctx.progress(0.1, f"aligning ({align})")
    ev = run_evaluation(
        p, cloud.points, nominal, align=align, k=k, start=start, seed=seed, max_iterations=max_iterations
    )
    for w in ev.warnings:
        ctx.warn(w)
    ctx.progress(0.9, "outputs")
    aligned = PointCloud(
        ev.points,
        cloud.colors,
        None if cloud.normals is None else cloud.normals @ ev.transform[:3, :3].T,
        {**cloud.fields, "feature": ev.feature_field().astype(np.float64)},
        {**cloud.field_units, "feature": ""},
        f"{cloud.name} in plan coordinates",
        cloud.source_unit,
    )
    return {
        "features": ev.features_json(),
        "datums": ev.datums_json(),
        "alignment": ev.alignment_json(),
        "characteristics": ev.characteristics_json(),
        "labels": ev.labels(),
        "aligned": aligned,
    }
