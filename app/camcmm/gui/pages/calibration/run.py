"""A calibration run, in the page's worker thread: read the board images, calibrate,
the projection-uncertainty maps and thumbnails, and store it all in the project.

The plugins are found by the task they declare (``provides`` in their manifest), as the
CLI finds them, so the page shows the CLI's numbers. The result is the *page document*
(JSON): the request, the image sources, the plugin's outputs and warnings, a heat map
and thumbnails per camera, and ``current`` (where the project keeps it), which the page
shows again when the project is reopened.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from .... import worker
from ....host import to_jsonable
from . import draw, inputs
from . import results as res

CAMERA, STEREO, PROJECTION, RECTIFY = (
    "camera-calibration",
    "stereo-calibration",
    "projection-uncertainty",
    "rectification",
)
CURRENT_KEY, INPUTS_KEY = "calibration.current", "calibration.inputs"
#: (columns, rows) of the projection-uncertainty map
MAP_GRID = (48, 36)


def plugin(host: Any, task: str) -> str:
    """The id of the plugin the page runs for ``task`` (PluginError when none is installed)."""
    return host.provider(task).id


def projection_map(host: Any, cam: dict[str, Any], distance: float) -> dict[str, Any] | None:
    """The projection-uncertainty plugin's map (σ px over a (rows, columns) grid, u, v,
    min, max, centre) of one camera at ``distance`` mm; None without a calibration with
    board poses."""
    cal = cam.get("map_calibration")
    if not cal:
        return None
    out = worker.run(
        host,
        plugin(host, PROJECTION),
        {"calibration": cal},
        {"distance": float(distance), "columns": MAP_GRID[0], "rows": MAP_GRID[1]},
    ).outputs
    return to_jsonable({k: out[k] for k in ("map", "u", "v", "distance", "min", "max", "centre", "method")})


def calibrate(
    host: Any, project: Any, req: dict[str, Any], src: dict[str, list[dict[str, Any]]], job: Any
) -> tuple[dict[str, Any], dict[str, list[Any]]]:
    """(page document, the images read per side) of a checked request; ``job`` (a
    :class:`~camcmm.gui.jobs.Job`) gets the progress and may cancel."""
    mode = req["mode"]
    total = sum(len(v) for v in src.values())
    images: dict[str, list[Any]] = {}
    k = 0
    for side, lst in src.items():
        images[side] = []
        for s in lst:
            job.check()
            images[side].append(inputs.read_source(s, project))
            k += 1
            job.progress(0.1 * k / total, f"reading {s['name']}")
    tmp = Path(tempfile.mkdtemp(prefix="camcmm-cal-"))
    try:
        params = {
            "board": req["board"],
            "model": req["model"],
            "outlier_factor": req["outlier_factor"],
            "save": str(tmp / "calibration.json"),
        }
        ins = {"left": images["left"], "right": images["right"]} if mode == "stereo" else {"images": images["left"]}
        run = worker.run(
            host,
            plugin(host, STEREO if mode == "stereo" else CAMERA),
            ins,
            params,
            progress=lambda f, m: job.progress(0.1 + 0.7 * f, m),
            cancel=job.cancel_event,
        )
        run.outputs.pop("written", None)
        outputs = to_jsonable(run.outputs)
        doc = {
            "version": 1,
            "request": req,
            "sources": src,
            "outputs": outputs,
            "warnings": list(run.warnings),
            "plugin": run.plugin_id,
            "plugin_version": run.plugin_version,
            "maps": {},
            "thumbs": {},
        }
        _, layout = inputs.board_layout(req["board"])
        for side in res.sides(mode):
            job.progress(0.82, f"projection uncertainty, {res.side_title(mode, side)}")
            cam = res.camera_part(outputs, mode, side)
            doc["maps"][side] = projection_map(host, cam, res.default_distance(cam))
            rows = {r["name"]: r for r in res.view_rows(cam)}
            thumbs = {}
            for img, d in zip(images[side], cam["detections"]):
                job.check()
                thumbs[d["image"]] = draw.thumbnail(img.data, d.get("corners"), layout, rows[d["image"]]["status"])
            doc["thumbs"][side] = thumbs
        job.progress(0.9, "storing the calibration in the project")
        store(project, doc, run, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return doc, images


def store(project: Any, doc: dict[str, Any], run: Any, tmp: Path) -> None:
    """The calibration JSON (as the plugin wrote it to ``tmp``) and OpenCV YAML, the page
    document and a result row go into the project, which remembers them as the current
    calibration; ``doc["current"]`` says where they are."""
    from ....io import read_calibration, write_calibration

    req = doc["request"]
    name = (
        str(req.get("name") or "").strip()
        or f"{'stereo pair' if req['mode'] == 'stereo' else 'camera'} {req['board']} "
        f"({time.strftime('%Y-%m-%d %H:%M')})"
    )
    write_calibration(tmp / "calibration.yaml", read_calibration(tmp / "calibration.json"))
    (tmp / "calibration-page.json").write_text(json.dumps(doc), encoding="utf-8")
    files = {
        "calibration": project.add_file(tmp / "calibration.json"),
        "calibration_yaml": project.add_file(tmp / "calibration.yaml"),
        "page": project.add_file(tmp / "calibration-page.json"),
    }
    mids = [s["item"] for lst in doc["sources"].values() for s in lst if s.get("item") is not None]
    rid = project.add_result(run, measurement_ids=mids, files=files, label=f"calibration: {name}")
    doc["current"] = {
        "result": rid,
        "file": files["page"],
        "calibration": files["calibration"],
        "yaml": files["calibration_yaml"],
        "name": name,
        "kind": req["mode"],
        "board": req["board"],
        "rms": doc["outputs"].get("rms"),
    }
    project.set_state(CURRENT_KEY, doc["current"])
    project.set_state(INPUTS_KEY, req)


def stored_inputs(project: Any) -> dict[str, Any] | None:
    """The request of the last run, as the project keeps it (None: none yet)."""
    req = project.get_state(INPUTS_KEY)
    return req if isinstance(req, dict) else None


def stored_doc(project: Any) -> dict[str, Any] | None:
    """The current calibration's page document, as the project keeps it (None: none yet)."""
    cur = project.get_state(CURRENT_KEY)
    if not (isinstance(cur, dict) and cur.get("file") and project.has_file(str(cur["file"]))):
        return None
    doc = json.loads(project.file_path(str(cur["file"])).read_text("utf-8"))
    doc["current"] = cur
    return doc
