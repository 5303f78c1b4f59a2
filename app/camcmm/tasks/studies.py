"""The case-study tasks (thesis ch. 6.2 and 6.3): a study file on the server in, the study's
numbers out — headless, as the Studies page and the tests run them.

A study is chosen by kind (:data:`KINDS`): each names the task its plugin provides (found
by that task, never by id: a lab may install its own), how the study file reaches it (an
input or a parameter) and the virtual-lab plugin that writes a demonstration study.

- :class:`StudyRequest` is the kind and the study file; :func:`study_file` checks the file
  (with ``roots``, an object with ``check(path, what)`` as the GUI's: refused outside them
  before it is looked at);
- :func:`run` runs the provider through :func:`camcmm.worker.run` (``progress(fraction,
  message)``, ``cancel``: a :class:`threading.Event`) and holds its outputs to the kind's
  contract (:data:`CONTRACTS`); :func:`make_virtual` writes the virtual lab's study;
- :func:`store` keeps the result row (``RunResult.to_json()`` with the JSON outputs, no
  geometry) and the page's record (the outputs for the tables and figures, the deviation
  clouds decimated) under :data:`CURRENT_KEY`; :func:`stored` / :func:`restore` give it back;
- :func:`write_report` writes the plugin's declared report.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import worker
from ..contracts import Need, OutputContract, check_outputs, register
from ..errors import InputError, PluginError
from ..jsonable import to_jsonable
from .items import stored_record

CURRENT_KEY = "studies.current"
#: points of each deviation cloud the record keeps for the page's maps (drawn as a scatter)
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
#: the smallest simulated speckle study (as tests/studies' tiny one): one artefact and
#: material, speckle off and on, 12 small images through 108° (9° steps)
SPECKLE_VIRTUAL = """name: virtual lab, speckle on/off (small)
artefacts: [am_pyramid]
materials: [ti6al4v]
conditions: ['off', 'on']
capture:
  simulated: {n_images: 12, arc_deg: 108, downscale: 12, diffuser: 0.06}
reconstruct: {max_image_size: 500}
coverage: {samples: 20000}
"""

#: what the Studies page (tables, numbers, figures) reads of each kind's provider
CONTRACTS = {
    "lightfield": register(
        OutputContract(
            "lightfield-study",
            needs=(
                Need("table", "dict", why="table 6.3"),
                Need("focal", "dict", optional=True, why="fig. 6.16 and the fit's rows (null: one focal length)"),
                Need("truth", "dict", optional=True, why="the truth rows of a virtual-lab study"),
                Need("scatter", "list", optional=True, why="the depth-vs-λ scatter of each view"),
            ),
        )
    ),
    "speckle": register(
        OutputContract(
            "speckle-study",
            needs=(
                Need("cases", "list", why="tables 6.1, 6.2 and the coverage per case"),
                Need("summary", "dict", optional=True, why="the change per material"),
                Need("deviation_clouds", "dict", optional=True, why="the deviation maps without/with speckle"),
            ),
        )
    ),
}


@dataclass
class StudyRequest:
    """A study of ``kind`` (a key of :data:`KINDS`) on the study file ``file``."""

    kind: str = "lightfield"
    file: str = ""

    @classmethod
    def of(cls, raw: dict[str, Any] | StudyRequest | None) -> StudyRequest:
        if isinstance(raw, StudyRequest):
            return raw
        raw = dict(raw or {})
        return cls(str(raw.get("kind") or "lightfield"), str(raw.get("file") or ""))

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def kind_of(kind: Any) -> dict[str, Any]:
    k = KINDS.get(str(kind or ""))
    if k is None:
        raise InputError(f"study kind {kind!r}: not one of {', '.join(KINDS)}")
    return k


def spec_of(host: Any, kind: Any) -> Any:
    """The manifest of the plugin that runs studies of ``kind`` (by the task it provides)."""
    return host.provider(kind_of(kind)["task"])


def form_fields(spec: Any) -> list[Any]:
    """The plugin's parameters a form shows: all but the one that takes the study file."""
    return [p for p in spec.parameters if p.name != "study"]


def study_file(roots: Any, text: Any) -> Path:
    """The study file ``text``, resolved; refused in one line outside ``roots`` (before it
    is looked at), or when it is no file."""
    text = str(text or "").strip().strip('"')
    if not text:
        raise InputError("study file: give the path of a study file (.yaml/.json) on the server, or make a virtual one")
    path = roots.check(text, "study file") if roots is not None else Path(text).expanduser().resolve()
    if not path.is_file():
        raise InputError(f"study file {text}: {'is not a file' if path.exists() else 'no such file'}")
    return path


def run(
    host: Any,
    req: StudyRequest | dict[str, Any],
    params: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Any:
    """The provider's :class:`~camcmm.host.RunResult` for the study ``req`` (the file as
    checked by :func:`study_file`), held to the kind's contract."""
    req = StudyRequest.of(req)
    k = kind_of(req.kind)
    spec = spec_of(host, req.kind)
    where, name = k["port"]
    params = dict(params or {})
    inputs, params = ({name: req.file}, params) if where == "input" else ({}, {**params, name: req.file})
    result = worker.run(host, spec.id, inputs, params, progress=progress, cancel=cancel)
    check_outputs(k["task"], spec.id, result.outputs)
    return result


def make_virtual(
    host: Any,
    kind: str,
    project_dir: Path | str,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> str:
    """Write the virtual lab's study of ``kind`` into ``project_dir``; its study file's path."""
    k = kind_of(kind)
    if kind == "speckle":
        folder = Path(project_dir) / "studies" / "speckle-virtual"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "study.yaml"
        path.write_text(SPECKLE_VIRTUAL, encoding="utf-8")
        return str(path)
    v = k["virtual"]
    spec = host.provider(v["task"])
    params = {"directory": str(Path(project_dir) / v["folder"])}
    out = worker.run(host, spec.id, {}, params, progress=progress, cancel=cancel)
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


def store(project: Any, result: Any, req: StudyRequest | dict[str, Any]) -> dict[str, Any]:
    """The run into ``project``: the result row and the page's record (also kept as
    :data:`CURRENT_KEY`); returns the record. A study makes no items."""
    req = StudyRequest.of(req)
    outs = json_outputs(result.outputs)
    maps = {str(k): m for k, c in (result.outputs.get("deviation_clouds") or {}).items() if (m := _decimate(c))}
    row = dataclasses.replace(result, outputs=outs).to_json()
    name = Path(req.file).parent.name + "/" + Path(req.file).name
    rid = project.add_result(row, label=f"{kind_of(req.kind)['title']}: {name}")
    rec = {
        "result": rid,
        "kind": req.kind,
        "name": name,
        "request": req.to_dict(),
        "outputs": outs,
        "maps": maps,
        "warnings": [str(w) for w in result.warnings],
        "plugin": f"{result.plugin_id} {result.plugin_version}",
        "stamp": time.strftime("%Y-%m-%d %H:%M"),
    }
    project.set_state(CURRENT_KEY, rec)
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last run, as the project keeps it (None: none yet, or unreadable)."""
    return stored_record(project, CURRENT_KEY)


def restore(project: Any) -> tuple[StudyRequest, dict[str, Any]] | None:
    """The last run's request and record (None: none stored)."""
    rec = stored(project)
    return None if rec is None else (StudyRequest.of(rec.get("request")), rec)


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
