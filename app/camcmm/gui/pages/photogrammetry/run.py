"""A reconstruction: the request checked, the plugin run (in the page's worker thread,
through :func:`camcmm.worker.run`: a crash in native code ends the worker, not the
server), and the result stored in the project (loop thread).

The plugin is found by the task it provides (``photogrammetry``), never by its id. What
the project keeps of a run: the result row (plugin, version, parameters, input hashes,
the reconstruction's JSON, warnings; the image items it used), the cloud and the
sparse cloud as files of that result and as items made by the plugin, and the page's
own record (``photogrammetry.current``: the request, the image sources, the result
and item ids) so that a reopened project shows it again.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from .... import worker
from ....errors import InputError
from ....host import to_jsonable
from ...runpage import stored_record
from ...widgets import form_values
from . import inputs

TASK = "photogrammetry"
CURRENT_KEY = "photogrammetry.current"
#: the plugin's stages, in order, as its progress messages begin
STAGES = ("features", "matching", "mapping", "dense", "scale")


#: other words the plugin's messages begin with -> the stage they belong to
WORDS = {
    "sift": "features",
    "extract": "features",
    "extraction": "features",
    "registered": "mapping",
    "bundle": "mapping",
    "depth": "dense",
    "fusion": "dense",
    "stereo": "dense",
}


def stage_of(message: str) -> str:
    """The stage a progress message is in ("" when it names none of :data:`STAGES`)."""
    words = str(message or "").lower().replace(":", " ").split()[:3]
    return next((w for w in words if w in STAGES), "") or next((WORDS[w] for w in words if w in WORDS), "")


def check_params(spec: Any, raw: dict[str, Any] | None, roots: Any) -> dict[str, Any]:
    """The form's values validated against the plugin's declaration; ``scale``'s
    ``lengths:FILE`` names a file, which must lie inside the roots (made absolute)."""
    values = form_values(spec, raw)
    scale = str(values.get("scale") or "").strip()
    if scale.lower().startswith("lengths:") and roots is not None:
        values["scale"] = "lengths:" + str(roots.check(scale.split(":", 1)[1], "scale lengths file"))
    return values


def calibration_file(project: Any) -> Path | None:
    """The project's current camera calibration (JSON, from the Calibration page), or None."""
    try:
        cur = project.get_state("calibration.current")
    except Exception:
        return None
    if not (isinstance(cur, dict) and cur.get("kind") == "camera" and cur.get("calibration")):
        return None
    try:
        return Path(project.file_path(str(cur["calibration"]))) if project.has_file(str(cur["calibration"])) else None
    except Exception:
        return None


def reconstruct(
    host: Any,
    plugin_id: str,
    sources: list[dict[str, Any]],
    params: dict[str, Any],
    calibration: Path | None,
    job: Any,
) -> Any:
    """The plugin's RunResult (worker thread): the images go as paths, read in the
    worker process; ``job`` gets the progress and may cancel."""
    if len(sources) < 2:
        raise InputError(f"image series: {len(sources)} image; a reconstruction needs several overlapping views")
    ins: dict[str, Any] = {"images": [s["path"] for s in sources]}
    if calibration is not None:
        ins["calibration"] = str(calibration)
    return worker.run(host, plugin_id, ins, params, progress=job.progress, cancel=job.cancel_event)


def summary(rec: dict[str, Any]) -> list[dict[str, str]]:
    """The reconstruction's figures as rows ``{name, label, value}`` for the page."""

    def num(x: Any, digits: int = 3) -> str:
        try:
            return f"{float(x):.{digits}g}"
        except (TypeError, ValueError):
            return "—"

    cam = rec.get("camera") or {}
    scale = rec.get("scale") or {}
    out = [
        ("registered", "Registered images", f"{rec.get('n_registered', '—')} of {rec.get('n_images', '—')}"),
        ("rms", "Reprojection RMS", f"{num(rec.get('reprojection_rms_px'))} px"),
        ("sparse", "Sparse points", str(rec.get("n_points_sparse", "—"))),
        ("dense", "Dense points", str(rec.get("n_points_dense", "—")) if rec.get("n_points_dense") else "— (off)"),
        (
            "camera",
            "Camera",
            f"{cam.get('model', '?')}: f = {num(cam.get('fx'), 5)} / {num(cam.get('fy'), 5)} px, "
            f"c = ({num(cam.get('cx'), 5)}, {num(cam.get('cy'), 5)}) px"
            if cam
            else "—",
        ),
    ]
    if scale:
        u = scale.get("u")
        out.append(
            (
                "scale",
                "Scale",
                f"{scale.get('method', '?')}: × {num(scale.get('factor'), 6)}" + (f" (u {num(u, 2)})" if u else ""),
            )
        )
    timings = rec.get("timings") or {}
    if isinstance(timings, dict) and timings:
        out.append(("timings", "Time", ", ".join(f"{k} {num(v, 2)} s" for k, v in timings.items())))
    return [{"name": n, "label": label, "value": v} for n, label, v in out]


def store(session: Any, spec: Any, result: Any, req: dict[str, Any], sources: list[dict[str, Any]]) -> dict[str, Any]:
    """The run into the project (loop thread): the clouds as files and items made by
    the plugin, the result row referring to them and to the image items; returns the
    page's record (also kept as ``photogrammetry.current``)."""
    project = session.project
    out = result.outputs
    stamp = time.strftime("%Y-%m-%d %H:%M")
    base = str(req.get("name") or "").strip() or f"photogrammetry {len(sources)} images ({stamp})"
    # with dense off the plugin's "cloud" is the sparse cloud: one item, not the same points twice
    dense = bool(getattr(result, "params", {}).get("dense", True))
    sparse = out.get("sparse") if out.get("sparse") is not None else out.get("cloud")
    clouds = [("cloud", out.get("cloud")), ("sparse", sparse)] if dense else [("sparse", sparse)]
    clouds = [(k, obj) for k, obj in clouds if getattr(obj, "n_points", 0)]
    if not clouds:
        raise InputError("the reconstruction returned no points: nothing was stored")
    hashes = {k: project.add_object(obj, f"{base} {k}") for k, obj in clouds}
    mids = [s["item"] for s in sources if s.get("item") is not None]
    rid = project.add_result(result, measurement_ids=mids, files=hashes, label=f"photogrammetry: {base}")
    made_by = f"{spec.id} {result.plugin_version} (result #{rid})"
    items = {}
    for k, obj in clouds:
        name = base if k == "cloud" else f"{base} (sparse)"
        items[k] = str(session.add_measurement(name, hashes[k], obj, source=made_by))
    rec = {
        "result": rid,
        "items": items,
        "name": base,
        "request": req,
        "sources": [{"name": s["name"], "path": s["path"], "item": s.get("item")} for s in sources],
        "reconstruction": to_jsonable(out.get("reconstruction") or {}),
        "warnings": list(result.warnings),
        "plugin": f"{spec.id} {result.plugin_version}",
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The page's record of the last run, as the project keeps it (None: none yet)."""
    return stored_record(project, CURRENT_KEY)


def sources_of(req: dict[str, Any], project: Any, roots: Any) -> list[dict[str, Any]]:
    """The image sources of a request (``source``: folder or items)."""
    if req.get("source") == "items":
        return inputs.item_sources(project, req.get("items") or [])
    return inputs.folder_sources(req.get("folder"), req.get("pattern") or "*", roots=roots)
