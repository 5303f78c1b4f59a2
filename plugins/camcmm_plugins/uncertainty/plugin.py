"""Plugin entry points (``fn(ctx, spec, **params) -> dict``) for the host.

``spec`` is what the manifest declares as a ``json`` input: a mapping, or the path of a
YAML/JSON file (the host passes paths through as :class:`pathlib.Path`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from camcmm.api import InputError, RunContext, read_yaml


def load_spec(spec: Any) -> tuple[dict[str, Any], Path | None]:
    """The input document and the folder relative paths in it refer to."""
    if isinstance(spec, Mapping):
        return dict(spec), None
    if isinstance(spec, (str, Path)):
        path = Path(spec)
        if not path.is_file():
            raise InputError(f"{path}: no such file")
        doc = read_yaml(path)
        if not isinstance(doc, dict):
            raise InputError(f"{path}: expected a mapping at the top level, got {type(doc).__name__}")
        return doc, path.parent
    raise InputError(f"spec: expected a file path or a mapping, got {type(spec).__name__}")


def budget(
    ctx: RunContext, spec: Any, coverage_probability: float | None = None, dof_rounding: str = "truncate"
) -> dict[str, Any]:
    from .gum import budget_from_dict

    doc, _ = load_spec(spec)
    if coverage_probability is not None:
        doc["coverage_probability"] = coverage_probability
    doc.setdefault("dof_rounding", dof_rounding)
    out = budget_from_dict(doc).to_dict()
    for w in out.pop("warnings"):
        ctx.warn(w)
    return out


def iso15530_3(ctx: RunContext, spec: Any, k: float | None = None) -> dict[str, Any]:
    from .iso15530 import from_dict

    doc, base = load_spec(spec)
    if k is not None:
        doc["k"] = k
    out = from_dict(doc, base)
    if "note" in out:
        ctx.warn(out["note"])
    return out


def montecarlo(
    ctx: RunContext,
    spec: Any = None,
    iterations: int | None = None,
    seed: int | None = None,
    method: str | None = None,
    scheduler: str | None = None,
    studies: str = "",
    **system: Any,
) -> dict[str, Any]:
    """The study of ``spec``, or without one of the system the declared parameters
    (``system``: focal_length, baseline, u_rotation … see :mod:`.declared_system`) describe."""
    from .declared_system import NAMES, system_document
    from .montecarlo import run_study

    unknown = sorted(set(system) - set(NAMES))
    if unknown:
        raise InputError(f"parameter {unknown[0]!r}: not a parameter of the stereo system")
    doc = load_spec(spec)[0] if spec is not None else system_document(system)
    out = run_study(
        doc,
        iterations=iterations,
        seed=seed,
        method=method,
        scheduler=scheduler or None,
        studies=[s.strip() for s in (studies or "").split(",") if s.strip()],
        progress=ctx.progress,
        warn=ctx.warn,
    )
    out.setdefault("system", doc)
    return out
