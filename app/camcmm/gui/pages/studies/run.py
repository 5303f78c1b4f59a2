"""A study run: the study file checked against the server's roots, the plugin run (in
the page's worker thread, through :func:`camcmm.worker.run`), the result stored in the
project (loop thread), the report written.

A study is chosen by kind (:data:`KINDS`): each names the plugin (found by the task it
provides, or by id when it declares none), how the study file reaches it (an input or
a parameter) and the virtual-lab plugin that writes a demonstration study. What the
project keeps of a run: the result row (plugin, version, parameters, the JSON outputs,
warnings) and the page's record (``studies.current``: the request, the outputs for
the tables and figures, the deviation clouds decimated) so a reopened project shows it.
"""

from __future__ import annotations

import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from .... import worker
from ....errors import InputError, PluginError
from ....host import to_jsonable
from ...runpage import stored_record
from ...widgets import form_values

CURRENT_KEY = "studies.current"
#: points of each deviation cloud the page keeps for its maps (drawn as a scatter)
MAP_POINTS = 4000
KINDS: dict[str, dict[str, Any]] = {
    "lightfield": {
        "title": "Light-field scale (ch. 6.3)",
        "task": "lightfield-study",
        "port": ("input", "study"),
        "virtual": {"task": "lightfield-set-simulation", "folder": "studies/lightfield-virtual", "output": "study"},
    },
    "speckle": {
        "title": "Speckle on/off (ch. 6.2)",
        "task": "speckle-study",
        "port": ("param", "study"),
        "virtual": None,  # a study file with simulated capture settings: written by make_virtual
    },
}
#: the smallest simulated speckle study (as tests/test_studies_speckle.py's tiny one): one
#: artefact and material, speckle off and on, 12 small images through 108° (9° steps)
SPECKLE_VIRTUAL = """name: virtual lab, speckle on/off (small)
artefacts: [am_pyramid]
materials: [ti6al4v]
conditions: ['off', 'on']
capture:
  simulated: {n_images: 12, arc_deg: 108, downscale: 12, diffuser: 0.06}
reconstruct: {max_image_size: 500}
coverage: {samples: 20000}
"""


def kind_of(kind: Any) -> dict[str, Any]:
    k = KINDS.get(str(kind or ""))
    if k is None:
        raise InputError(f"study kind {kind!r}: not one of {', '.join(KINDS)}")
    return k


def spec_of(host: Any, kind: Any) -> Any:
    """The manifest of the plugin that runs studies of ``kind``."""
    # by the task its manifest provides, never by id: a lab may install its own
    return host.provider(kind_of(kind)["task"])


def form_fields(spec: Any) -> list[Any]:
    """The plugin's parameters the form shows: all but the one that takes the study file."""
    return [p for p in spec.parameters if p.name != "study"]


def check_params(spec: Any, raw: dict[str, Any] | None) -> dict[str, Any]:
    """The form's values checked against the declared parameters but the study file's
    (a required parameter of the speckle study: :func:`run_study` adds it)."""
    raw = {k: v for k, v in dict(raw or {}).items() if k != "study"}
    return form_values(SimpleNamespace(id=spec.id, parameters=form_fields(spec)), raw)


def check_file(roots: Any, text: Any) -> Path:
    """The study file typed in the page, resolved; refused in one line outside the
    project folder and the data roots (before it is looked at), or when it is no file."""
    text = str(text or "").strip().strip('"')
    if not text:
        raise InputError("study file: give the path of a study file (.yaml/.json) on the server, or make a virtual one")
    path = roots.check(text, "study file") if roots is not None else Path(text).expanduser().resolve()
    if not path.is_file():
        raise InputError(f"study file {text}: {'is not a file' if path.exists() else 'no such file'}")
    return path


def run_study(host: Any, spec: Any, kind: str, path: str, params: dict[str, Any], job: Any) -> Any:
    """The plugin's RunResult (worker thread); ``job`` gets the progress and may cancel."""
    where, name = kind_of(kind)["port"]
    inputs, params = ({name: str(path)}, dict(params)) if where == "input" else ({}, {**params, name: str(path)})
    return worker.run(host, spec.id, inputs, params, progress=job.progress, cancel=job.cancel_event)


def make_virtual(host: Any, kind: str, project_dir: Path, job: Any) -> str:
    """Write the virtual lab's study of ``kind`` into the project folder; its study file's path."""
    k = kind_of(kind)
    if kind == "speckle":
        folder = Path(project_dir) / "studies" / "speckle-virtual"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "study.yaml"
        path.write_text(SPECKLE_VIRTUAL, encoding="utf-8")
        return str(path)
    v = k["virtual"]
    spec = host.provider(v["task"])
    out = worker.run(
        host, spec.id, {}, {"directory": str(Path(project_dir) / v["folder"])},
        progress=job.progress, cancel=job.cancel_event,
    )  # fmt: skip
    study = out.outputs.get(v["output"])
    if not study or not Path(study).is_file():
        raise PluginError(f"plugin {spec.id!r} wrote no study file")
    return str(study)


def _decimate(cloud: Any, n: int = MAP_POINTS) -> dict[str, Any] | None:
    """x, y, z (mm) and the deviation (mm) of up to ``n`` points of a deviation cloud."""
    pts = np.asarray(getattr(cloud, "points", np.empty((0, 3))), float)
    fields = getattr(cloud, "fields", {}) or {}
    if not len(pts) or "deviation" not in fields:
        return None
    d = np.asarray(fields["deviation"], float)
    keep = np.random.default_rng(0).choice(len(pts), n, replace=False) if len(pts) > n else np.arange(len(pts))
    p = pts[keep]
    return {"x": p[:, 0].tolist(), "y": p[:, 1].tolist(), "z": p[:, 2].tolist(), "d": d[keep].tolist()}


def json_outputs(outputs: dict[str, Any]) -> dict[str, Any]:
    """The outputs without the geometry (the deviation clouds)."""
    return to_jsonable({k: v for k, v in outputs.items() if k != "deviation_clouds"})


def store(session: Any, spec: Any, result: Any, kind: str, path: str) -> dict[str, Any]:
    """The run into the project (loop thread): the result row and the page's record
    (also kept as ``studies.current``); returns the record."""
    project = session.project
    outs = json_outputs(result.outputs)
    maps = {str(k): m for k, c in (result.outputs.get("deviation_clouds") or {}).items() if (m := _decimate(c))}
    row = result.to_json()
    row["outputs"] = outs
    name = Path(path).parent.name + "/" + Path(path).name
    rid = project.add_result(row, label=f"{KINDS[kind]['title']}: {name}")
    rec = {
        "result": rid,
        "kind": kind,
        "name": name,
        "request": {"kind": kind, "file": str(path)},
        "outputs": outs,
        "maps": maps,
        "warnings": [str(w) for w in result.warnings],
        "plugin": f"{spec.id} {result.plugin_version}",
        "stamp": time.strftime("%Y-%m-%d %H:%M"),
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The page's record of the last run, as the project keeps it (None: none yet)."""
    return stored_record(project, CURRENT_KEY)


def write_report(spec: Any, outputs: dict[str, Any], folder: Path, basename: str) -> dict[str, str]:
    """The plugin's declared report builder (``report: module:function``) on the outputs,
    written as html/pdf/json into ``folder``; the paths by kind."""
    import importlib

    declared = getattr(spec, "report", None)
    if not declared:
        raise PluginError(f"plugin {spec.id!r} declares no report builder ('report: module:function')")
    module, _, fn = str(declared).partition(":")
    try:
        build = getattr(importlib.import_module(module), fn)
    except (ImportError, AttributeError) as exc:
        raise PluginError(f"plugin {spec.id!r}: its report builder {declared!r} cannot be loaded: {exc}") from None
    return build(outputs).write(folder, basename=basename)
