"""One GD&T plan over several parts, headless: the Series view's task. The plugin
providing ``gdt-series`` (camcmm's ``gdt.series``: the batch of ``camcmm gdt batch``,
each part evaluated by ``gdt.evaluate``) runs in a worker process; its document — the
parts with their evaluations and, per characteristic, the trend and capability (mean,
s, Cp/Cpk with confidence intervals, control limits, parts out of tolerance or
undecided) — is kept in the project as a result and under :data:`STATE_KEY`.

    request = SeriesRequest(plan="project", clouds=["3", "4", "part5.ply"], align="none")
    series = SeriesTask(host, ProjectItems(project), project)
    run = series.run(request)             # checked, run through the worker, held to CONTRACT
    record = series.store(run)            # result row, "series.current"
    shown = series.restore()              # (request, record) of the last run, None: none

The plan is the project's plan (``"project"``: the one the Compare page keeps under
``gdt.plan``), a plan document, or a YAML/JSON file on the server (inside the project
folder or a data root). A cloud is a project item (its id) or a file on the server. The
work folder of the part records is ``<project>/series`` — a second run of the same parts
and plan takes the parts already evaluated from there.

:func:`table` gives the parts × characteristics grid (value and verdict per cell) and
:func:`chart` one characteristic's run chart data (values, tolerance limits, mean,
control limits; Cp/Cpk with their intervals). Lengths in mm. No GUI, trame or VTK here.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .. import contracts, worker
from ..contracts import Need, OutputContract
from ..errors import InputError
from . import gdt
from .items import stored_record

#: The task whose plugin runs, and camcmm's own provider of it.
TASK = "gdt-series"
PLUGIN = "gdt.series"
#: Where the project keeps the last series.
STATE_KEY = "series.current"
#: The work folder of the part records, inside the project folder.
FOLDER = "series"
#: The verdict words (ISO 14253-1) and their colours: those of the Compare page's panel.
VERDICTS = gdt.VERDICTS
VERDICT_COLOURS = {**gdt.VERDICT_COLOURS, "failed": "#616161"}

CONTRACT = contracts.register(
    OutputContract(
        TASK,
        needs=(
            Need("batch", "dict", why="the series: its parts and the summary per characteristic"),
            Need("batch.parts", "list", why="the parts × characteristics table"),
            Need("batch.summary", "list", why="the chart and the capability of each characteristic"),
        ),
    )
)


@dataclass
class SeriesRequest:
    """What to run: the ``plan`` ("project", a plan document, or a file path), the
    ``clouds`` (item ids or file paths, in production order), an optional ``nominal``
    item, the ``align`` method (:data:`camcmm.tasks.gdt.ALIGNMENTS`) and the control
    chart's ``subgroup`` (1: individuals)."""

    plan: Any = "project"
    clouds: list[Any] = field(default_factory=list)
    nominal: Any = None
    align: str = "best-fit"
    subgroup: int = 1

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["clouds"] = [str(c) for c in self.clouds]
        return d

    @classmethod
    def of(cls, d: Any) -> SeriesRequest:
        if isinstance(d, SeriesRequest):
            return d
        d = dict(d or {})
        return cls(
            d.get("plan", "project"),
            list(d.get("clouds") or []),
            d.get("nominal"),
            str(d.get("align") or "best-fit"),
            int(d.get("subgroup") or 1),
        )


@dataclass
class Series:
    """A run: its ``result`` (RunResult), the request, and the names and item ids of the parts."""

    result: Any
    request: SeriesRequest
    names: list[str]
    mids: list[int]
    record: dict[str, Any] | None = None

    @property
    def batch(self) -> dict[str, Any]:
        return self.result.outputs["batch"]


def provider(host: Any) -> Any:
    """The plugin providing :data:`TASK` (PluginError, one line, when none is installed)."""
    return host.provider(TASK)


def plan_of(request: SeriesRequest, project: Any, roots: Any = None) -> dict[str, Any]:
    """The plan document of ``request``: the project's (:func:`camcmm.tasks.gdt.saved_plan`),
    the document given, or the file read (a path inside ``roots``). InputError naming what
    is missing or wrong."""
    plan = request.plan
    if plan in (None, "", "project"):
        rec = gdt.saved_plan(project) if project is not None else None
        if rec is None:
            raise InputError("plan: the project holds no plan (make one on the Compare page, or name a YAML file)")
        return gdt.check_plan(gdt.in_mm(rec["plan"], "project plan"), "project plan")
    if isinstance(plan, dict):
        return gdt.check_plan(gdt.in_mm(plan))
    path = _server_path(str(plan), "plan", roots)
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror})") from None
    return gdt.read_plan_text(text, path.name)


def _server_path(text: str, what: str, roots: Any) -> Path:
    """A file on the server: refused in one line outside ``roots`` (the GUI's project
    folder and data roots: relative paths from the project folder) before it is looked
    at, or when it is no file."""
    text = str(text or "").strip().strip('"')
    path = roots.check(text, what) if roots is not None else Path(text).expanduser().resolve()
    if not path.is_file():
        raise InputError(f"{what} {text}: {'is not a file' if path.exists() else 'no such file'}")
    return Path(path)


def clouds_of(
    request: SeriesRequest, items: Any, project: Any, roots: Any = None
) -> tuple[list[Path], list[str], list[int]]:
    """The clouds' files, the parts' names and the item ids among them: an item id names
    a project item (its file in the project, its name), anything else a file on the
    server. InputError for fewer than two parts, an unknown item, one chosen twice or a
    missing file."""
    if len(request.clouds) < 2:
        raise InputError("clouds: choose at least two parts (a series compares parts)")
    files, names, mids = [], [], []
    for c in request.clouds:
        key = str(c).strip()
        m = items.measurement(key) if key.isdigit() else None
        if key.isdigit() and m is None:
            raise InputError(f"clouds: no item with id {key} in the project")
        if m is not None:
            if m.get("kind") not in (None, "pointcloud"):
                raise InputError(f"clouds: {m.get('name')} is a {m.get('kind')}, not a point cloud")
            files.append(Path(project.file_path(m["hash"])))
            names.append(str(m.get("name") or f"item {key}"))
            mids.append(int(m["id"]))
        else:
            path = _server_path(key, "cloud", roots)
            files.append(path)
            names.append(path.stem)
    seen: dict[str, int] = {}
    for i, n in enumerate(names):  # the table's rows need distinct names
        if n in seen:
            seen[n] += 1
            names[i] = f"{n} ({seen[n]})"
        else:
            seen[n] = 1
    if len({str(f) for f in files}) != len(files):
        raise InputError("clouds: a part is chosen twice")
    return files, names, mids


def run(
    host: Any,
    items: Any,
    project: Any,
    request: SeriesRequest,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
    roots: Any = None,
) -> Series:
    """Check ``request``, run the provider of :data:`TASK` through :func:`camcmm.worker.run`
    on the clouds' files and hold its outputs to :data:`CONTRACT`."""
    request = SeriesRequest.of(request)
    if request.align not in gdt.ALIGNMENTS:
        raise InputError(f"align: {request.align!r} is not one of {', '.join(gdt.ALIGNMENTS)}")
    spec = provider(host)
    plan = plan_of(request, project, roots)
    files, names, mids = clouds_of(request, items, project, roots)
    inputs: dict[str, Any] = {"clouds": [str(f) for f in files], "plan": plan, "names": names}
    if request.nominal not in (None, ""):
        inputs["nominal"] = items.load(str(request.nominal))
    if project is not None and getattr(project, "path", None):
        inputs["folder"] = str(Path(project.path) / FOLDER)
    params = {"align": request.align, "subgroup": int(request.subgroup)}
    result = worker.run(host, spec.id, inputs, params, progress=progress, cancel=cancel)
    contracts.check_outputs(TASK, spec.id, result.outputs)
    request.plan = plan  # what ran, kept with the record
    return Series(result, request, names, mids)


def store(project: Any, series: Series) -> dict[str, Any]:
    """The run into ``project``: a result linked to the item clouds and the record under
    :data:`STATE_KEY` (``result``, ``request``, ``names``, ``stamp``), which is returned."""
    row = series.result.to_json()
    rid = project.add_result(row, measurement_ids=series.mids, label=f"gdt series: {len(series.names)} parts")
    rec = {
        "result": rid,
        "request": series.request.to_dict(),
        "names": list(series.names),
        "warnings": [str(w) for w in series.result.warnings],
        "stamp": time.strftime("%Y-%m-%d %H:%M"),
    }
    project.set_state(STATE_KEY, rec)
    series.record = rec
    return rec


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last series (None: none yet, or unreadable)."""
    return stored_record(project, STATE_KEY)


def restore(project: Any) -> tuple[SeriesRequest, dict[str, Any]] | None:
    """The last series' request and record, its ``batch`` read back from the result row
    (None: none stored)."""
    rec = stored(project)
    if rec is None:
        return None
    row = project.result(int(rec["result"]))
    batch = (row.get("outputs") or {}).get("batch")
    if not isinstance(batch, dict):
        raise InputError(f"project result {rec['result']}: holds no series")
    return SeriesRequest.of(rec.get("request")), {**rec, "batch": batch}


# ------------------------------------------------------------------------------ what is shown
def verdict_of(part: dict[str, Any], cid: str) -> tuple[str, dict[str, Any] | None]:
    """The verdict a cell shows for characteristic ``cid`` of ``part``: "failed" for a
    part that was not evaluated, else the guarded verdict (:func:`camcmm.tasks.gdt.verdict_of`),
    with the characteristic's row (None: the part has none)."""
    ev = part.get("evaluation") or {}
    row = next((c for c in ev.get("characteristics") or [] if c.get("id") == cid), None)
    if row is None:
        return ("failed" if part.get("status") == "failed" else "not evaluated"), None
    return gdt.verdict_of(row), row


def table(batch: dict[str, Any]) -> tuple[list[str], list[dict[str, Any]]]:
    """(characteristic ids in plan order, one row per part): ``part``, ``status``,
    ``reason``, and per id a cell {``value``, ``U``, ``verdict``, ``colour``}."""
    ids = [str(s["id"]) for s in batch.get("summary") or []]
    for p in batch.get("parts") or []:  # a characteristic no evaluated part has (all failed)
        for c in (p.get("evaluation") or {}).get("characteristics") or []:
            if c.get("id") not in ids:
                ids.append(str(c["id"]))
    rows = []
    for p in batch.get("parts") or []:
        row: dict[str, Any] = {"part": p.get("part"), "status": p.get("status"), "reason": p.get("reason") or ""}
        cells = {}
        for cid in ids:
            v, c = verdict_of(p, cid)
            cells[cid] = {
                "value": None if c is None else c.get("value"),
                "U": None if c is None else c.get("U"),
                "verdict": v,
                "colour": VERDICT_COLOURS.get(v, VERDICT_COLOURS["not evaluated"]),
            }
        row["cells"] = cells
        rows.append(row)
    return ids, rows


def summary_of(batch: dict[str, Any], cid: str) -> dict[str, Any] | None:
    """The capability entry of characteristic ``cid`` (None: not in the series)."""
    return next((s for s in batch.get("summary") or [] if str(s.get("id")) == str(cid)), None)


def chart(batch: dict[str, Any], cid: str) -> dict[str, Any] | None:
    """The run chart of ``cid``: ``parts``, ``values``, ``verdicts`` (every evaluated part
    in order; None where not evaluated), ``lsl``/``usl`` (the tolerance limits: a zone's
    0 … t, a size's nominal + lower/upper), ``mean``, ``ucl``/``lcl``/``centre`` (control
    limits, ``control`` their kind), and ``cp``, ``cp_ci``, ``cpk``, ``cpk_ci``, ``n``,
    ``s``, ``out``, ``undecided``, ``notes``, ``confidence``."""
    s = summary_of(batch, cid)
    if s is None:
        return None
    lim = s.get("limits") or {}
    ctl = s.get("control") or {}
    pts = s.get("points") or []
    usl = lim.get("usl")
    lsl = lim.get("lsl") if lim.get("kind") != "zone" else None
    return {
        "id": s["id"],
        "type": s.get("type"),
        "parts": [p["part"] for p in pts],
        "values": [p.get("value") for p in pts],
        "verdicts": [gdt.verdict_of(p) for p in pts],
        "lsl": lsl,
        "usl": usl,
        "bound": lim.get("bound"),
        "mean": s.get("mean"),
        "centre": ctl.get("centre"),
        "ucl": ctl.get("ucl"),
        "lcl": ctl.get("lcl"),
        "control": ctl.get("kind"),
        **{k: s.get(k) for k in ("n", "s", "cp", "cp_ci", "cpk", "cpk_ci", "out", "undecided", "notes", "confidence")},
    }


class SeriesTask:
    """The steps above bound to a ``host``, the project's ``items``, the ``project`` and
    the server's ``roots``: what the Series page holds."""

    def __init__(self, host: Any, items: Any, project: Any, roots: Any = None):
        self.host, self.items, self.project, self.roots = host, items, project, roots

    def run(
        self,
        request: SeriesRequest,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> Series:
        return run(self.host, self.items, self.project, request, progress, cancel, self.roots)

    def store(self, series: Series) -> dict[str, Any]:
        return store(self.project, series)

    def restore(self) -> tuple[SeriesRequest, dict[str, Any]] | None:
        return restore(self.project)
