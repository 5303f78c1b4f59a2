"""The project's measuring systems and the calibration each refers to: a system's meta
holds ``calibration`` {file, yaml, name, result, kind, board, rms}, ``file`` being the
hash of the calibration JSON in the project."""

from __future__ import annotations

from typing import Any

NEW = "new"


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


def use(project: Any, current: dict[str, Any], target: Any = NEW, name: str = "") -> int:
    """Let system ``target`` (an id, or "new" named ``name``) refer to the calibration
    ``current`` (a page document's ``current``); the rest of its meta is kept. Its id."""
    ref = {k: current.get(k) for k in ("name", "result", "kind", "board", "rms", "yaml")}
    ref["file"] = current["calibration"]
    if target in (None, "", NEW):
        label = (
            str(name or "").strip()
            or f"{'stereo system' if current['kind'] == 'stereo' else 'camera'} ({current['name']})"
        )
        return int(project.add_system(label, {"calibration": ref}))
    sid = int(target)
    meta = dict(project.system(sid).get("meta") or {})
    meta["calibration"] = ref
    project.update_system(sid, meta=meta)
    return sid
