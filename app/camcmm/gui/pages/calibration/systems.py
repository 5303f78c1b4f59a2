"""The project's measuring systems and the calibration each refers to: a system's meta
holds ``calibration`` {file, yaml, name, result, kind, board, rms}, ``file`` being the
hash of the calibration JSON in the project; the task's
:func:`camcmm.tasks.calibration.use_for_system` lets a system refer to one."""

from __future__ import annotations

from typing import Any

from ....tasks.calibration import NEW


def rows(project: Any, current: dict[str, Any] | None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """(table rows, choices of the "use for" field): each system with the name of its
    calibration, the file hash's first 12 characters and whether it is ``current``."""
    cur = current or {}
    out = []
    for sy in project.systems():
        c = (sy.get("meta") or {}).get("calibration") or {}
        out.append(
            {
                "id": sy["id"],
                "name": sy["name"],
                "calibration": c.get("name", "") if c else "",
                "file": str(c.get("file", ""))[:12],
                "current": bool(c) and c.get("file") == cur.get("calibration"),
            }
        )
    return out, [{"title": f"#{r['id']} {r['name']}", "value": r["id"]} for r in out] + [new_option()]


def new_option() -> dict[str, str]:
    return {"title": "a new measuring system", "value": NEW}
