"""Compare with CAD, headless: a measured cloud aligned onto its nominal (a CAD mesh or a
reference cloud) and its signed deviations, by the plugin providing ``compare-with-cad``.

    request = CompareRequest(measured="3", nominal="2", align="icp", tolerance=0.01)
    task = CompareTask(host, ProjectItems(project), project)
    comparison = task.run(request)           # checked, run through the worker, held to CONTRACT
    record = task.store(comparison)          # result row, deviations file, "inspection.current"
    shown = task.restore()                   # the last comparison back (None: none stored)

The steps are plain functions (``check``, ``run``, ``store``, ``stored``, ``restore``,
``write_report``, ``record_report``, ``record_export``); :class:`CompareTask` binds them to
a host, the project's items and the project, as the "Compare with CAD" page holds it.
``items`` is anything with the GUI session's item interface (``measurement``, ``load``):
the session behind a page, or :class:`~camcmm.tasks.items.ProjectItems` on a bare project.

Lengths are in mm. Nothing here imports the GUI, trame or VTK.
"""

from __future__ import annotations

import importlib
import logging
import math
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import contracts, worker
from ..contracts import Need, OutputContract
from ..errors import InputError, PluginError, one_line
from ..host import RunResult
from ..params import validate
from .items import stored_record

log = logging.getLogger("camcmm.tasks.compare")

#: The task whose plugin runs (``provides:`` in its manifest).
TASK = "compare-with-cad"
#: Where the project keeps the last comparison (the record :func:`store` returns).
STATE_KEY = "inspection.current"
#: Parameters a form shows up front; the request carries them as fields, not in ``params``.
MAIN_PARAMS = ("align", "tolerance")
N_PAIRS = 3  # a rigid (or similarity) transform needs three non-collinear pairs

#: What the page, its figures, tables and scene read of the provider's outputs.
CONTRACT = contracts.register(
    OutputContract(
        TASK,
        needs=(
            Need("deviations", "pointcloud", ("deviation",), why="the coloured cloud, picking, section, export"),
            Need("colour_limit", "float", why="the colour map saturates at ±colour_limit (mm)"),
            Need("converged", "bool", why="a failed alignment is shown as failed, not coloured"),
            Need("stats", "dict", why="the statistics table"),
            Need("stats.p2_5", "float", why="the 95 % interval on the histogram and the curve"),
            Need("stats.p97_5", "float", why="the 95 % interval on the histogram and the curve"),
            Need("histogram", "dict", why="the histogram (edges, counts)"),
            Need("material_ratio", "dict", why="the Abbott-Firestone curve (curve, C1, C2, Spk, Svk, Smr1, Smr2)"),
            # read when present
            Need("stats.n", "int", optional=True, why="the statistics table"),
            Need("stats.mean", "float", optional=True, why="the statistics table"),
            Need("stats.std", "float", optional=True, why="the statistics table"),
            Need("stats.rms", "float", optional=True, why="the statistics table"),
            Need("stats.min", "float", optional=True, why="the statistics table"),
            Need("stats.max", "float", optional=True, why="the statistics table"),
            Need("stats.tolerance", "float", optional=True, why="the tolerance of the run, when none is entered"),
            Need("stats.within_tolerance", "float", optional=True, why="the share within ±tolerance"),
            Need("coverage", "float", optional=True, why="the statistics table"),
            Need("coverage_info", "dict", optional=True, why="the coverage distance"),
            Need("alignment", "dict", optional=True, why="the alignment table and the title (method)"),
            Need("reason", "str", optional=True, why="why the alignment failed"),
            Need("rms", "float", optional=True, why="the alignment table"),
            Need("scale", "float", optional=True, why="the alignment table"),
            Need("overlap", "float", optional=True, why="the alignment table"),
            Need("translation", "any", optional=True, why="the alignment table"),
            Need("held_dofs", "list", optional=True, why="the alignment table: what the symmetry held"),
        ),
    )
)


# ------------------------------------------------------------------------------ the request
@dataclass
class CompareRequest:
    """What to compare: item ids of the ``measured`` cloud and the ``nominal`` (a mesh or a
    cloud), the alignment method ``align`` (one the provider declares; the ``pairs``
    methods need ``pairs``: ``{"measured": [[x, y, z] ×3], "nominal": [...]}`` in mm), the
    ``tolerance`` (mm, None: none) and the provider's other ``params`` as a form gives them
    (text; empty ones are left to the plugin's defaults)."""

    measured: Any
    nominal: Any
    align: str = "icp"
    tolerance: float | None = None
    params: dict[str, Any] = field(default_factory=dict)
    pairs: dict[str, list[list[float]]] | None = None


@dataclass
class Checked:
    """A request checked against the provider ``spec``: validated ``values``, the plugin's
    extra ``inputs`` (pairs, for a pairs method), the complete ``pairs`` picked (None: none)
    and the project ids of the items (None for one the project does not know)."""

    request: CompareRequest
    spec: Any
    values: dict[str, Any]
    inputs: dict[str, Any]
    pairs: dict[str, list[list[float]]] | None
    measured_id: int | None
    nominal_id: int | None

    @property
    def mids(self) -> list[int]:
        """The items the result is linked to."""
        return [m for m in (self.measured_id, self.nominal_id) if m is not None]


@dataclass
class Comparison:
    """A comparison run (or restored): the plugin's ``result`` (its outputs hold the
    ``deviations`` cloud with the field ``deviation``, mm), the objects compared and, once
    stored, the project's ``record`` of it."""

    result: RunResult
    measured: Any = None
    nominal: Any = None
    checked: Checked | None = None
    record: dict[str, Any] | None = None

    @property
    def outputs(self) -> dict[str, Any]:
        return self.result.outputs

    @property
    def converged(self) -> bool:
        return bool(self.result.outputs.get("converged"))

    @property
    def deviations(self) -> Any:
        return self.result.outputs["deviations"]


def parse_tolerance(text: Any, quiet: bool = False) -> float | None:
    """A tolerance (mm) as typed: ``"0,01"`` -> 0.01; None for empty or 0. InputError for
    anything else not a number ≥ 0 (None instead with ``quiet``)."""
    if text is None or (isinstance(text, str) and not text.strip()):
        return None
    try:
        v = float(text) if isinstance(text, (int, float)) else float(str(text).replace(",", "."))
    except ValueError:
        if not quiet:
            raise InputError(f"tolerance: {text!r} is not a number") from None
        return None
    if not math.isfinite(v) or v < 0:
        if not quiet:
            raise InputError(f"tolerance: {text!r} must be a number ≥ 0 (mm)")
        return None
    return v or None


def _name(items: Any, key: Any) -> str:
    m = items.measurement(key)
    return str(m.get("name") or key) if m else str(key)


def _mid(items: Any, key: Any) -> int | None:
    m = items.measurement(key)
    return int(m["id"]) if m else None


def check(request: CompareRequest, spec: Any, items: Any) -> Checked:
    """The request made ready for ``spec`` (the provider's manifest): both items chosen and
    different, the parameters validated, three complete pairs for a pairs method.
    InputError / ParameterError, one line, otherwise."""
    if request.measured in (None, ""):
        raise InputError("choose the measured cloud first (import one with the Import field)")
    if request.nominal in (None, ""):
        raise InputError("choose the nominal (a CAD mesh or a reference cloud) first")
    if str(request.measured) == str(request.nominal):
        raise InputError(
            f"{_name(items, request.measured)} is chosen as both measured and nominal; choose two different items"
        )
    declared = {p.name: p for p in spec.parameters}
    raw: dict[str, Any] = {}
    for k, v in (request.params or {}).items():
        p = declared.get(k)
        if p is None or k in MAIN_PARAMS:
            continue
        if p.type != "str" and (v is None or (isinstance(v, str) and v.strip() == "")):
            continue  # left empty: the plugin's default
        raw[k] = v
    raw["align"] = request.align
    if request.tolerance is not None:
        raw["tolerance"] = request.tolerance
    values = validate(spec.parameters, raw, owner=f"plugin {spec.id!r}")
    given = request.pairs or {}
    n = min(len(given.get("measured") or []), len(given.get("nominal") or []))
    pairs = {"measured": list(given["measured"][:n]), "nominal": list(given["nominal"][:n])} if n else None
    inputs: dict[str, Any] = {}
    if str(values["align"]).startswith("pairs"):
        if n < N_PAIRS:
            raise InputError(
                f"alignment {values['align']!r} needs {N_PAIRS} point pairs, {n} picked: click a "
                "point on the measured cloud, then the same point on the nominal, three times"
            )
        inputs["pairs"] = pairs
    return Checked(request, spec, values, inputs, pairs, _mid(items, request.measured), _mid(items, request.nominal))


def load_inputs(items: Any, request: CompareRequest) -> tuple[Any, Any]:
    """The measured cloud and the nominal of ``request`` from ``items``; InputError naming
    the item when one is not of its kind."""
    cloud = items.load(str(request.measured))
    nominal = items.load(str(request.nominal))
    if not hasattr(cloud, "points") or hasattr(cloud, "faces"):
        raise InputError(f"{_name(items, request.measured)}: the measured item must be a point cloud")
    if not hasattr(nominal, "points") and not hasattr(nominal, "faces"):
        raise InputError(f"{_name(items, request.nominal)}: the nominal must be a mesh or a point cloud")
    return cloud, nominal


def run(
    host: Any,
    items: Any,
    request: CompareRequest | Checked,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Comparison:
    """Check ``request`` (unless it is :class:`Checked` already), load its items, run the
    provider of ``compare-with-cad`` through :func:`camcmm.worker.run` (a worker process
    when the host can be rebuilt there) and hold its outputs to :data:`CONTRACT`.

    A run whose alignment did not converge is returned all the same (``converged`` False,
    the plugin's ``reason``): it is a result, shown and stored as failed."""
    checked = request if isinstance(request, Checked) else check(request, host.provider(TASK), items)
    measured, nominal = load_inputs(items, checked.request)
    spec = checked.spec
    result = worker.run(
        host,
        spec.id,
        {"cloud": measured, "nominal": nominal, **checked.inputs},
        checked.values,
        progress=progress,
        cancel=cancel,
    )
    contracts.check_outputs(TASK, spec.id, result.outputs)
    return Comparison(result, measured, nominal, checked)


# ------------------------------------------------------------------------------ the project
def _file_name(name: str) -> str:
    """``name`` as the original name of a project file (as camcmm.gui.downloads writes it)."""
    return (re.sub(r"[^\w.\-+() ]", "_", str(name)).strip(" .") or "inspection")[:80]


def store(project: Any, comparison: Comparison) -> dict[str, Any]:
    """Keep ``comparison`` in ``project``: its deviations cloud as a file, the run as a
    result linked to the items compared, and the record under :data:`STATE_KEY`
    (``result``, ``measured``, ``nominal``, ``align``, ``tolerance``, ``pairs``,
    ``deviations`` (file hash), ``report``, ``export``), which is returned."""
    result = comparison.result
    dev = result.outputs["deviations"]
    checked = comparison.checked
    mids = checked.mids if checked else []
    h = project.add_object(dev, _file_name(dev.name) + ".ply")
    rid = project.add_result(
        result, measurement_ids=mids, files={"deviations": h}, label="inspection: compare with CAD"
    )
    record = {
        "result": rid,
        "measured": checked.measured_id if checked else None,
        "nominal": checked.nominal_id if checked else None,
        "align": result.params.get("align"),
        "tolerance": result.params.get("tolerance"),
        "pairs": checked.pairs if checked else None,
        "deviations": h,
        "report": None,
        "export": None,
    }
    project.set_state(STATE_KEY, record)
    comparison.record = record
    return record


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last comparison kept in ``project`` (None: there is none)."""
    return stored_record(project, STATE_KEY)


def restore(project: Any, items: Any = None) -> Comparison | None:
    """The last comparison kept in ``project`` as it was run: its result (outputs as
    stored, the deviations cloud read back from its file), its record and, with
    ``items``, the objects compared when they are still there. None when none is kept;
    an error (one line) when it is kept but cannot be read."""
    record = stored(project)
    if record is None:
        return None
    from .. import io as cio  # the file formats pull in Open3D: only when there is one to read

    row = project.result(int(record["result"]))
    h = (row.get("files") or {}).get("deviations") or record.get("deviations")
    result = RunResult.from_json(row)
    result.outputs["deviations"] = cio.read(project.file_path(h))
    comparison = Comparison(result, record=record)
    if items is not None:
        for key, attr in (("measured", "measured"), ("nominal", "nominal")):
            if record.get(key) is not None and items.measurement(record[key]) is not None:
                try:
                    setattr(comparison, attr, items.load(str(record[key])))
                except Exception:
                    pass  # shown without it: the deviations are the result
    return comparison


def refuse_failed(comparison: Comparison, what: str, instead: str) -> None:
    """InputError (``what: ...; instead``) when the alignment of ``comparison`` failed: its
    deviations are distances from an unaligned cloud, not deviations, and nothing is made
    of them (a colour map, a section, an export); the report still records the failure."""
    if not comparison.converged:
        raise InputError(f"{what}: the alignment failed, so the deviations are not valid; {instead}")


def write_export(project: Any, cloud: Any, folder: Path, name: str) -> tuple[Path, str]:
    """``cloud`` written as ``folder/name`` (PLY, its fields kept) and added to ``project``:
    ``(path, file hash)``."""
    from .. import io as cio

    path = Path(folder) / name
    cio.write(cloud, path)
    return path, project.add_file(path)


def save_record(project: Any, record: dict[str, Any]) -> None:
    """The record (changed: a report, an export) kept again under :data:`STATE_KEY`."""
    project.set_state(STATE_KEY, record)


def record_export(project: Any, record: dict[str, Any] | None, file_hash: str) -> None:
    """An export (the coloured PLY, already added to the project as ``file_hash``) noted in
    the record, so that reopening the project offers it again."""
    if record:
        record["export"] = file_hash
        save_record(project, record)


def report_writer(spec: Any) -> Callable[..., Any]:
    """The report writer the provider's manifest declares (``report: module:function``)."""
    declared = spec.report
    if not declared:
        raise PluginError(f"plugin {spec.id!r} declares no report writer ('report: module:function')")
    module, _, name = str(declared).partition(":")
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as exc:
        raise PluginError(
            f"plugin {spec.id!r}: its report writer {declared!r} cannot be loaded: {one_line(exc)}"
        ) from None


def write_report(
    spec: Any,
    comparison: Comparison,
    items: Any,
    folder: Path,
    measured: Any,
    nominal: Any,
    tolerance: float | None = None,
    project_path: str = "",
    extend: Callable[[Any], None] | None = None,
) -> dict[str, str]:
    """The provider's report of ``comparison`` (html, pdf, json ...) written in ``folder``:
    ``{format: path}``. ``measured`` and ``nominal`` are the items' ids (their names and
    file hashes go in; the provenance names ``project_path``); ``tolerance`` (mm) falls back
    on the run's own; ``extend(report)`` adds sections before it is written (the
    characteristics of :mod:`camcmm.tasks.gdt`)."""
    build = report_writer(spec)
    o = dict(comparison.outputs)
    if tolerance is None:
        tolerance = (o.get("stats") or {}).get("tolerance")
    rid = (comparison.record or {}).get("result")
    rep = build(
        o,
        cloud_file=_name(items, measured),
        nominal_file=_name(items, nominal),
        run=comparison.result,
        tolerance=tolerance,
    )
    inputs = []
    for key, role in ((measured, "measured cloud"), (nominal, "nominal")):
        m = items.measurement(key)
        if m and m.get("hash"):
            inputs.append({"file": str(m.get("name")), "sha256": m["hash"], "role": role})
    if inputs:
        rep.provenance(inputs=inputs, extra={"project": project_path, "result": rid})
    if extend is not None:
        extend(rep)
    return rep.write(folder, basename=f"inspection-{rid or 'new'}")


def report_run(result: RunResult, result_id: Any, formats: list[str]) -> dict[str, Any]:
    """The run record of a report of result ``result_id``: the comparison's provenance,
    its outputs what was written (the project's result row, ``RunResult.to_json()``)."""
    return RunResult(
        result.plugin_id,
        result.plugin_version,
        result.params,
        result.input_hashes,
        {"report_of": result_id, "formats": sorted(formats)},
        result.started,
        result.finished,
        [],
    ).to_json()


def record_report(project: Any, comparison: Comparison, paths: dict[str, str]) -> dict[str, str]:
    """The report files (``{format: path}``) added to ``project``, the report as a result
    linked to the items compared, and noted in the record; returns ``{report_<format>:
    hash}``. The files are kept (and noted) even when the result row cannot be added."""
    files = {f"report_{k}": project.add_file(p) for k, p in paths.items()}
    record = comparison.record
    rid = (record or {}).get("result")
    mids = [m for m in ((record or {}).get("measured"), (record or {}).get("nominal")) if m is not None]
    try:
        project.add_result(
            report_run(comparison.result, rid, list(paths)),
            measurement_ids=mids,
            files=files,
            label=f"inspection report of result #{rid}",
        )
    except Exception as exc:  # the files are kept and offered all the same
        log.warning("report result: %s", exc)
    if record is not None:
        record["report"] = files
        save_record(project, record)
    return files


# ------------------------------------------------------------------------------ the task object
class CompareTask:
    """The steps above bound to a ``host`` (its provider of ``compare-with-cad`` found
    once), the project's ``items`` and the ``project``; what a page holds."""

    def __init__(self, host: Any, items: Any, project: Any):
        self.host = host
        self.items = items
        self.project = project
        self._spec: Any = None

    @property
    def spec(self) -> Any:
        """The provider's manifest (PluginError when none provides the task)."""
        if self._spec is None:
            self._spec = self.host.provider(TASK)
        return self._spec

    def check(self, request: CompareRequest) -> Checked:
        return check(request, self.spec, self.items)

    def run(
        self,
        request: CompareRequest | Checked,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> Comparison:
        if not isinstance(request, Checked):
            request = self.check(request)
        return run(self.host, self.items, request, progress=progress, cancel=cancel)

    def store(self, comparison: Comparison) -> dict[str, Any]:
        return store(self.project, comparison)

    def stored(self) -> dict[str, Any] | None:
        return stored(self.project)

    def restore(self) -> Comparison | None:
        return restore(self.project, self.items)

    def write_report(
        self,
        comparison: Comparison,
        folder: Path,
        measured: Any,
        nominal: Any,
        tolerance: float | None = None,
        extend: Callable[[Any], None] | None = None,
    ) -> dict[str, str]:
        where = str(getattr(self.project, "path", ""))
        return write_report(self.spec, comparison, self.items, folder, measured, nominal, tolerance, where, extend)

    def record_report(self, comparison: Comparison, paths: dict[str, str]) -> dict[str, str]:
        return record_report(self.project, comparison, paths)

    def record_export(self, comparison: Comparison, file_hash: str) -> None:
        record_export(self.project, comparison.record, file_hash)
