"""A fusion: the request checked, the plugin run (in the page's worker thread, through
:func:`camcmm.worker.run`), and the result stored in the project (loop thread).

The plugin is found by the task it provides (:data:`TASK`), never by its id. Its
inputs are project items: a coloured photogrammetry cloud and one or more height maps
(kind ``heightmap``), handed over as objects. What the project keeps of a run: the
result row (plugin, version, parameters, input hashes, the plugin's ``result`` JSON,
warnings; the items it used), the fused cloud as a file of that result and as an item
made by the plugin, and the page's own record (``fuse.current``: the request, the
numbers and the plugin's ``views`` of each map for the figures) so that a reopened project shows it.
"""

from __future__ import annotations

import time
from typing import Any

from .... import worker
from ....errors import InputError
from ....host import to_jsonable
from ...runpage import stored_record
from ...widgets import form_values

TASK = "csi-fusion"
CURRENT_KEY = "fuse.current"
CLOUD_KIND = "pointcloud"
MAP_KIND = "heightmap"


def check_params(spec: Any, raw: dict[str, Any] | None) -> dict[str, Any]:
    """The form's values validated against the plugin's declaration (widgets.form_values)."""
    return form_values(spec, raw)


def inputs_of(session: Any, req: dict[str, Any]) -> tuple[Any, list[Any], list[dict[str, Any]]]:
    """The cloud and the height maps of a request (item ids), loaded; and the items'
    ``{id, name, kind}``. InputError naming the item for a missing or wrong one."""
    cloud_id = str(req.get("cloud") or "").strip()
    map_ids = [str(m) for m in req.get("maps") or [] if str(m).strip()]
    if not cloud_id:
        raise InputError("no photogrammetry cloud chosen: pick a coloured point-cloud item")
    if not map_ids:
        raise InputError("no height map chosen: pick one or more CSI height-map items (import .dat/.opd/.plu/.x3p)")
    if len(set(map_ids)) != len(map_ids):
        raise InputError("a height map is chosen twice")
    used = []
    for key, want in [(cloud_id, CLOUD_KIND)] + [(m, MAP_KIND) for m in map_ids]:
        m = session.measurement(key)
        if m is None:
            raise InputError(f"no item with id {key!r} in the project")
        kind = str(m.get("kind") or "")
        name = str(m.get("name") or key)
        if kind != want:
            raise InputError(f"item {name!r} is a {kind or 'thing of no kind'}, not a {want}")
        used.append({"id": key, "name": name, "kind": kind})
    cloud = session.load(cloud_id)  # without colour the plugin matches shaded heights
    maps = [session.load(m) for m in map_ids]
    return cloud, maps, used


def fuse(host: Any, plugin_id: str, cloud: Any, maps: list[Any], params: dict[str, Any], job: Any) -> Any:
    """The plugin's RunResult (worker thread); ``job`` gets the progress and may cancel."""
    ins = {"cloud": cloud, "csi": list(maps)}
    return worker.run(host, plugin_id, ins, params, progress=job.progress, cancel=job.cancel_event)


def store(session: Any, spec: Any, result: Any, req: dict[str, Any], used: list[dict[str, Any]]) -> dict[str, Any]:
    """The run into the project (loop thread): the fused cloud as a file and an item
    made by the plugin, the result row referring to it and to the input items; returns
    the page's record (also kept as ``fuse.current``)."""
    project = session.project
    out = result.outputs
    fused = out.get("fused")
    if not getattr(fused, "n_points", 0):
        raise InputError("the fusion returned no fused cloud: nothing was stored")
    summary = to_jsonable(out.get("result") or {})
    views = out.get("views") or {}
    views = to_jsonable(views.get("maps") if isinstance(views, dict) else views) or []
    stamp = time.strftime("%Y-%m-%d %H:%M")
    maps = [u["name"] for u in used[1:]]
    base = str(req.get("name") or "").strip() or f"fused {used[0]['name']} + {len(maps)} CSI ({stamp})"
    h = project.add_object(fused, base)
    # the row keeps the numbers; the geometry is the file, the figures' arrays the page's record
    row = result.to_json()
    row["outputs"] = {"result": summary, "fused": to_jsonable(fused)}
    rid = project.add_result(
        row, measurement_ids=[int(u["id"]) for u in used if str(u["id"]).isdigit()], files={"fused": h},
        label=f"fusion: {base}",
    )  # fmt: skip
    made_by = f"{spec.id} {result.plugin_version} (result #{rid})"
    item = str(session.add_measurement(base, h, fused, source=made_by))
    rec = {
        "result": rid,
        "items": {"fused": item},
        "name": base,
        "request": {"cloud": used[0]["id"], "maps": [u["id"] for u in used[1:]], "name": req.get("name") or ""},
        "inputs": used,
        "summary": summary,
        "views": views,
        "warnings": [str(w) for w in result.warnings],
        "plugin": f"{spec.id} {result.plugin_version}",
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The page's record of the last run, as the project keeps it (None: none yet)."""
    return stored_record(project, CURRENT_KEY)


def _num(x: Any, digits: int = 4) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return "—"
    return f"{v:.{digits}g}" if v == v else "—"


def _um(x: Any) -> str:
    """A length in mm written in µm (the differences are µm-sized)."""
    try:
        return f"{1e3 * float(x):+.3g} µm"
    except (TypeError, ValueError):
        return "—"


def numbers(summary: dict[str, Any], k: int) -> list[dict[str, str]]:
    """Map ``k``'s figures and the run's (scale, fused points) as rows ``{name, label, value}``."""
    maps = summary.get("maps") or []
    m = maps[k] if 0 <= k < len(maps) else {}
    t, icp = m.get("transform2d") or {}, m.get("icp") or {}
    d, mr = m.get("difference") or {}, m.get("material_ratio") or {}
    sc = summary.get("photogrammetry_scale") or {}
    rows = [
        ("file", "Height map", str(m.get("file") or "—")),
        ("matches", "Matches / inliers", f"{m.get('n_matches', '—')} / {m.get('n_inliers', '—')}"),
        (
            "inliers_models",
            "Inliers: similarity / fundamental",
            f"{m.get('n_inliers_similarity', '—')} / {m.get('n_inliers_fundamental', '—')}",
        ),
        (
            "transform2d",
            "2-D similarity (eq. 6.1)",
            f"{_num(t.get('angle_deg'))}°, t = ({_num(t.get('tx'))}, {_num(t.get('ty'))}) px, "
            f"× {_num(t.get('scale'), 6)}",
        ),
        (
            "icp",
            "ICP (tz, rx, ry)",
            f"tz {_um(icp.get('tz'))}, rx {_num(icp.get('rx_deg'))}°, ry {_num(icp.get('ry_deg'))}°; "
            f"rms {_um(icp.get('rms'))}" + ("" if icp.get("converged", True) else " (not converged)"),
        ),
        ("difference", "CSI − photogrammetry", f"mean {_um(d.get('mean'))}, std {_um(d.get('std'))}"),
        ("band", "95 % band", f"{_um(d.get('p2_5'))} … {_um(d.get('p97_5'))}"),
        (
            "material_ratio",
            "Sk / Spk / Svk",
            f"{_um(mr.get('Sk'))} / {_um(mr.get('Spk'))} / {_um(mr.get('Svk'))}; "
            f"Smr1 {_num(mr.get('Smr1'), 3)} %, Smr2 {_num(mr.get('Smr2'), 3)} %",
        ),
        ("scale", "Photogrammetry scale", f"{_num(sc.get('value'), 7)} ± {_num(sc.get('std'), 2)}"),
        ("fused", "Fused points", str(summary.get("n_points_fused", "—"))),
    ]
    return [{"name": n, "label": label, "value": v} for n, label, v in rows]
