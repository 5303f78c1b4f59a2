"""Acquiring a position from a measuring system instead of importing a file.

A measuring system the wizard can drive is any algorithm plugin whose manifest says
``acquires: pointcloud``: it takes a ``placement`` (the test, the position as the
standard lays it out, the repeat, the measuring volume and the plan's artefacts) and returns a
``cloud``. A real system measures whatever the operator has put in front of it (the
placement tells it what to expect); a simulated one (``virtuallab.fringe-system``)
puts the artefact there itself. The cloud is written to a file that then goes through
exactly the import path of any other file (:class:`~camcmm.tasks.acceptance.Wizard`).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from camcmm import worker
from camcmm.io import write
from camcmm.tasks.items import joined_name, safe_name

from .state import TestState


def acquisition_sources(host: Any) -> list[dict[str, Any]]:
    """The installed plugins that acquire a point cloud (``{"title", "value", "summary"}``)."""
    out: list[dict[str, Any]] = []
    try:
        specs = host.all()
    except Exception:  # discovery problems: no system to measure with, imports still work
        return out
    for p in specs:
        if p.kind == "algorithm" and getattr(p, "acquires", None) == "pointcloud":
            out.append({"title": p.name, "value": p.id, "summary": p.summary})
    return out


def placement(saved: TestState, test: str, position: str) -> dict[str, Any]:
    """What a measuring system is told about a position of the running test: the
    standard, the test, the position as the standard lays it out, the measuring volume
    (mm) and the plan's artefacts. Raises KeyError for an unknown position."""
    plan = saved.plan
    req = next((r for r in saved.requirements() if r["test"] == test), None)
    pos = next((p for p in (req or {}).get("positions", []) if p["id"] == position), None)
    if pos is None:
        raise KeyError(f"{test}/{position}: no such position in this test")
    return {
        "standard": (saved.state or {}).get("standard"),
        "test": test,
        "position": dict(pos),
        "measuring_volume": list((plan.get("system") or {}).get("measuring_volume") or []),
        "artefacts": dict(plan.get("artefacts") or {}),
    }


def acquire(host: Any, source: str, params: dict[str, Any], where: dict[str, Any]) -> Path:
    """Run measuring system ``source`` in a worker process on a placement; its cloud is
    written to a temporary PLY (the caller imports it, then removes file and folder)."""
    res = worker.run(host, source, {"placement": where}, params)
    cloud = res.outputs["cloud"]
    folder = Path(tempfile.mkdtemp(prefix="camcmm-acquire-"))
    # the position id often holds the test already (vdi2634: test sphere, position sphere-01)
    path = folder / safe_name(f"{joined_name(where['test'], where['position']['id'])}.ply")
    write(cloud, path)
    return path
