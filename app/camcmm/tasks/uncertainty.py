"""Measurement uncertainty, headless: the GUM budget and the Monte Carlo study of a stereo
system, as the Uncertainty page (and the tests) run them, by the plugins providing
``uncertainty-budget`` and ``monte-carlo-uncertainty``.

The budget (cheap: evaluated on every edit)::

    req = BudgetRequest("length", "um", 0.95, rows)     # the editor's rows, cells as typed
    run = evaluate(host, req)                           # RunResult, held to BUDGET_CONTRACT
    save_draft(project, req); start_budget(project)     # the edited table kept / back
    rid = store_budget(project, run, req)               # the result row
    run = restore_budget(project, rid)                  # a stored budget back

The Monte Carlo study::

    req = MonteCarloRequest(params=form_values, system=None)   # or a loaded system file
    checked = check_montecarlo(host, req)               # one-line refusal naming the field
    run = run_montecarlo(host, checked, progress, cancel)      # through camcmm.worker.run
    rid, h = store_montecarlo(project, run, checked)    # summary row + every array as JSON
    back = restore_montecarlo(project)                  # the last stored run (None: none)

:class:`UncertaintyTask` binds the steps to a host and a project, as the page holds it.
Every number is the plugins'; nothing here imports the GUI, trame or VTK.
"""

from __future__ import annotations

import json
import math
import tempfile
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import numbers, worker
from ..assets import resources_dir
from ..contracts import Need, OutputContract, check_outputs, register
from ..errors import InputError
from ..host import RunResult
from ..jsonable import to_jsonable
from ..params import validate
from ..yamlfile import load_yaml, read_yaml

BUDGET_TASK, MONTECARLO_TASK = "uncertainty-budget", "monte-carlo-uncertainty"
#: The project state key of the editor's draft budget (the budget file's form).
DRAFT_KEY = "uncertainty.budget.draft"
#: The project state key naming the last stored Monte Carlo run ({"result": id, "file": hash}).
MC_KEY = "uncertainty.montecarlo.current"
#: Monte Carlo outputs too large for the result row: they are in the stored JSON file only.
ARRAYS = ("per_point", "per_point_norm", "studies", "system", "form")
#: The run's fields of the Monte Carlo form (the others describe the system).
RUN = ("iterations", "seed", "method", "scheduler")

#: What the budget card, its chart and its exports read of the provider's outputs.
BUDGET_CONTRACT = register(
    OutputContract(
        BUDGET_TASK,
        needs=(
            Need("combined", "float", why="the combined standard uncertainty u_c"),
            Need("dof_eff", "float", why="the effective degrees of freedom"),
            Need("k", "float", why="the coverage factor"),
            Need("expanded", "float", why="the expanded uncertainty U"),
            Need("coverage_probability", "float", why="the coverage probability shown with U"),
            Need("contributions", "list", why="the rows' u, conversion and share, the chart, the CSV"),
            Need("unit", "str", optional=True, why="the unit shown"),
        ),
    )
)

#: What the Monte Carlo table, charts, volume view and exports read of the provider's outputs.
MONTECARLO_CONTRACT = register(
    OutputContract(
        MONTECARLO_TASK,
        needs=(
            Need("contributions", "dict", why="the table's rows and the contributions chart (u per factor, x y z)"),
            Need("combined", "any", why="the table's combined u (x, y, z) and the chart"),
            Need("dof_eff", "any", why="the table's effective dof"),
            Need("k", "any", why="the table's k"),
            Need("expanded", "any", why="the table's U"),
            Need("iterations", "int", why="the summary and the done message"),
            # read when present
            Need("unit", "str", optional=True, why="the unit of every length shown (default um)"),
            Need("coverage_probability", "float", optional=True, why="the U row's title"),
            Need("factor_dof", "dict", optional=True, why="the table's dof column"),
            Need("factor_distribution", "dict", optional=True, why="the table's distribution column"),
            Need("method", "str", optional=True, why="the summary"),
            Need("n_points", "int", optional=True, why="the summary and the done message"),
            Need("elapsed_s", "float", optional=True, why="the done message"),
            Need("executor", "str", optional=True, why="the done message"),
            Need("studies", "dict", optional=True, why="the convergence, sweep and spatial charts, the volume maps"),
            Need("per_point", "dict", optional=True, why="the per-point uncertainty maps in the volume view"),
            Need("per_point_norm", "dict", optional=True, why="the per-point uncertainty maps in the volume view"),
            Need("system", "dict", optional=True, why="a stored run of a loaded file shows its system again"),
        ),
    )
)


# ------------------------------------------------------------------------------ the budget
def _text(x: Any) -> str:
    return "" if x is None else str(x)


#: How a row's value may be stated with each distribution (the plugin converts: GUM 4.3.3-4.3.9).
DISTRIBUTIONS = {
    "u": ["normal", "rectangular", "triangular", "u-shaped", "student-t"],
    "a": ["rectangular", "triangular", "u-shaped"],
    "U": ["normal", "student-t"],
}


#: Infinite degrees of freedom (a type-B input known exactly) as the editor writes it; the
#: budget file and the plugin keep "inf", and the editor reads either.
INFINITE = "∞"


def _infinite(dof: Any) -> bool:
    if isinstance(dof, float):
        return math.isinf(dof)
    return str(dof).strip().lower() in (INFINITE, "inf", "infinity", "infinite")


def rows_from_doc(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Editor rows (strings, as typed) from a budget document. An entry's ``u``,
    ``half_width`` (``a``) or ``expanded`` (``U``) gives the row's kind and value; a
    half-width with a normal distribution is an expanded U with its k (as the plugin reads it)."""
    rows = []
    for c in doc.get("contributions") or []:
        if not isinstance(c, dict):
            continue
        dof = c.get("dof", "inf")
        dist = str(c.get("distribution") or "normal")
        k = c.get("k", c.get("k_a"))
        if c.get("half_width", c.get("a")) is not None:
            kind, value = "a", c.get("half_width", c.get("a"))
            if dist in DISTRIBUTIONS["U"]:
                kind, k = "U", 2 if k is None else k
        elif c.get("expanded", c.get("U")) is not None:
            kind, value = "U", c.get("expanded", c.get("U"))
        else:
            kind, value = "u", c.get("u")
        rows.append(
            {
                "name": str(c.get("name", "")),
                "kind": kind,
                "value": _text(value),
                "distribution": dist,
                "k": _text(k) if kind == "U" else "",
                "c": str(c.get("c", 1)),
                "dof": INFINITE if dof is None or _infinite(dof) else str(dof),
                "unit": _text(c.get("unit")),  # the input's own unit (kept; the conversion shows it)
            }
        )
    return rows


def budget_doc(quantity: str, unit: str, p: Any, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The budget file's form (the contract of ``camcmm uncertainty budget``) from the editor:
    each row as ``u``, ``half_width`` + ``distribution`` or ``expanded`` + ``k``."""
    contributions = []
    for r in rows:
        kind = str(r.get("kind")) if r.get("kind") in ("u", "a", "U") else "u"
        value = r.get("value", r.get("u"))  # rows of an older page held "u"
        c: dict[str, Any] = {"name": str(r.get("name") or "").strip()}
        c[{"u": "u", "a": "half_width", "U": "expanded"}[kind]] = value
        if kind == "U" and _text(r.get("k")).strip():
            c["k"] = r.get("k")
        dof = str(r.get("dof") or "").strip()
        c["dof"] = "inf" if not dof or _infinite(dof) else r.get("dof")  # the file and the plugin spell it inf
        c["distribution"] = r.get("distribution") or ("rectangular" if kind == "a" else "normal")
        if str(r.get("c", "")).strip() not in ("", "1"):
            c["c"] = r.get("c")
        if _text(r.get("unit")).strip():
            c["unit"] = str(r["unit"]).strip()
        contributions.append(c)
    return {"quantity": quantity, "unit": unit, "coverage_probability": p, "contributions": contributions}


@dataclass
class BudgetRequest:
    """A budget as the editor holds it: the quantity, its unit, the coverage probability
    ``p`` and the rows (``name, kind (u|a|U), value, distribution, k, c, dof, unit``; text
    as typed — the plugin checks them)."""

    quantity: str = ""
    unit: str = ""
    p: Any = 0.95
    rows: list[dict[str, Any]] = field(default_factory=list)

    def doc(self) -> dict[str, Any]:
        """The budget file's form (what the plugin and ``camcmm uncertainty budget`` read)."""
        return budget_doc(self.quantity, self.unit, self.p, self.rows)

    @classmethod
    def of_doc(cls, doc: dict[str, Any]) -> BudgetRequest:
        """The editor's request from a budget document (a file, a draft)."""
        return cls(
            str(doc.get("quantity", "")),
            str(doc.get("unit", "")),
            doc.get("coverage_probability", 0.95),
            rows_from_doc(doc),
        )


def read_budget(text: str | bytes, name: str = "budget.yaml") -> BudgetRequest:
    """A YAML/JSON budget file as the editor's request; one-line InputError naming the file."""
    doc = load_yaml(text, name=name)
    if not isinstance(doc, dict) or not isinstance(doc.get("contributions"), list):
        raise InputError(f"{name}: expected a mapping with a 'contributions' list")
    return BudgetRequest.of_doc(doc)


def evaluate(host: Any, req: BudgetRequest | dict[str, Any]) -> RunResult:
    """The budget evaluated by the provider of ``uncertainty-budget`` (in this thread: it is
    cheap) and held to :data:`BUDGET_CONTRACT`; a one-line error naming the bad entry."""
    doc = req.doc() if isinstance(req, BudgetRequest) else req
    spec = host.provider(BUDGET_TASK)
    run = host.run(spec.id, inputs={"spec": doc})
    check_outputs(BUDGET_TASK, spec.id, run.outputs)
    return run


def save_draft(project: Any, req: BudgetRequest) -> None:
    """The editor's table kept in the project (an edited table survives a restart)."""
    project.set_state(DRAFT_KEY, req.doc())


def start_budget(project: Any) -> BudgetRequest:
    """The budget the editor opens with: the project's draft, else the shipped example
    (thesis table 3.2), else an empty one."""
    try:
        draft = project.get_state(DRAFT_KEY)
    except Exception:
        draft = None
    if not isinstance(draft, dict):
        try:
            draft = read_yaml(resources_dir() / "uncertainty" / "budget.yaml")
        except InputError:
            draft = {"quantity": "", "unit": "µm", "coverage_probability": 0.95, "contributions": []}
    return BudgetRequest.of_doc(draft)


def store_budget(project: Any, run: RunResult, req: BudgetRequest | dict[str, Any]) -> int:
    """The evaluated budget as a result row (``RunResult.to_json()``); its id."""
    doc = req.doc() if isinstance(req, BudgetRequest) else req
    return int(project.add_result(run, label=f"GUM budget: {doc.get('quantity', '')}"))


def restore_budget(project: Any, rid: Any) -> RunResult:
    """A stored budget back as its run (the numbers as stored)."""
    return RunResult.from_json(project.result(int(rid)))


# ------------------------------------------------------------------------------ Monte Carlo
@dataclass
class MonteCarloRequest:
    """A Monte Carlo study: the form's ``params`` (the system's fields, iterations, seed,
    method, scheduler as typed; ``studies`` a list such as ``["convergence"]``) and the
    ``system`` of a loaded file (None: the fields are the system; with a file only the
    run's fields are used)."""

    params: dict[str, Any] = field(default_factory=dict)
    system: dict[str, Any] | None = None


@dataclass
class CheckedMonteCarlo:
    """A request checked against the provider ``spec``: the plugin's ``inputs``, the
    validated ``values`` and the ``form`` kept with the result (the fields' values; None
    for a run of a loaded file)."""

    request: MonteCarloRequest
    spec: Any
    inputs: dict[str, Any]
    values: dict[str, Any]
    form: dict[str, Any] | None


@dataclass
class MonteCarloRun:
    """A stored Monte Carlo run as the page shows it: the full result (every array, the
    system, the form) and its result id."""

    full: dict[str, Any]
    result_id: Any
    file: str = ""


def load_system(text: str | bytes, name: str) -> dict[str, Any]:
    """A system file (YAML/JSON) read for the form's "load YAML" option (one line if bad)."""
    doc = load_yaml(text or "", name=name)
    if not isinstance(doc, dict):
        raise InputError(f"{name}: expected a mapping (cameras, stereo, grid, uncertainties)")
    return doc


def inputs(form: dict[str, Any], plugin: Any, system: Any = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The plugin's inputs (``{"spec": system}`` for a loaded file, else none: the fields are
    the system) and the form's values checked against ``plugin``'s declared parameters;
    a one-line :class:`InputError` / ParameterError naming what is wrong. With a loaded
    file only the run's fields are sent (the file is the system)."""
    if system is not None and not isinstance(system, dict):
        raise InputError("system description: expected a mapping (cameras, stereo, grid, uncertainties)")
    declared = {p.name for p in plugin.parameters}
    given = {k: v for k, v in form.items() if k in declared and k != "studies"}
    if system is not None:
        given = {k: v for k, v in given.items() if k in RUN}
    given["scheduler"] = str(given.get("scheduler") or "").strip() or None
    given["studies"] = ",".join(str(x) for x in (form.get("studies") or []))
    values = validate(plugin.parameters, given, owner=f"plugin {plugin.id!r}")
    if system is not None:
        values = {k: v for k, v in values.items() if k in RUN or k == "studies"}
    return ({"spec": system} if system is not None else {}), {k: v for k, v in values.items() if v is not None}


def check_montecarlo(host: Any, req: MonteCarloRequest) -> CheckedMonteCarlo:
    """``req`` made ready for the provider of ``monte-carlo-uncertainty``; one-line
    InputError / ParameterError naming the field otherwise."""
    spec = host.provider(MONTECARLO_TASK)
    given, values = inputs(dict(req.params or {}), spec, req.system)
    form = None if req.system is not None else {k: v for k, v in values.items() if k != "studies"}
    return CheckedMonteCarlo(req, spec, given, values, form)


def run_montecarlo(
    host: Any,
    checked: CheckedMonteCarlo,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> RunResult:
    """The study (in a worker process when the host allows; ``cancel`` set stops it with
    :class:`~camcmm.host.Cancelled`), held to :data:`MONTECARLO_CONTRACT`."""
    spec = checked.spec
    run = worker.run(host, spec.id, checked.inputs, checked.values, progress=progress, cancel=cancel)
    check_outputs(MONTECARLO_TASK, spec.id, run.outputs)
    return run


def full_result(run: RunResult, doc: dict[str, Any] | None, form: dict[str, Any] | None = None) -> dict[str, Any]:
    """Everything of a run as stored in its JSON file: the outputs, the system simulated
    (a loaded file's) and the form's values when it came from the fields."""
    return to_jsonable({**({"system": doc} if doc is not None else {}), **run.outputs, "form": form})


def store_montecarlo(
    project: Any, run: RunResult, checked: CheckedMonteCarlo | dict[str, Any] | None, form: dict[str, Any] | None = None
) -> tuple[int, str]:
    """The summary as the result row, everything (arrays too, the system simulated and
    the form's values when it came from the fields) as a JSON file; the project remembers
    it as the page's current run (:data:`MC_KEY`). ``checked`` is the run's checked request
    (or the loaded system's document, with ``form``). Returns (result id, file hash)."""
    if isinstance(checked, CheckedMonteCarlo):
        doc, form = checked.inputs.get("spec"), checked.form
    else:
        doc = checked
    full = full_result(run, doc, form)
    folder = Path(tempfile.mkdtemp(prefix="camcmm-mc-"))
    try:
        path = folder / "montecarlo.json"
        path.write_text(json.dumps(full), encoding="utf-8")
        h = project.add_file(path)
    finally:
        for p in folder.iterdir():
            p.unlink()
        folder.rmdir()
    summary = dict(run.to_json())
    summary["outputs"] = {k: v for k, v in full.items() if k not in ARRAYS}
    rid = project.add_result(summary, files={"montecarlo": h}, label="Monte Carlo of a stereo system")
    project.set_state(MC_KEY, {"result": rid, "file": h})
    return int(rid), h


def read(project: Any, h: str) -> dict[str, Any]:
    """A stored run's full result (the JSON file of :func:`store_montecarlo`)."""
    return json.loads(project.file_path(h).read_text("utf-8"))


def stored_montecarlo(project: Any) -> dict[str, Any] | None:
    """The project's note of the last stored run (``{"result", "file"}``; None: none, or its
    file is gone)."""
    try:
        cur = project.get_state(MC_KEY)
    except Exception:
        return None
    if not isinstance(cur, dict) or not project.has_file(str(cur.get("file"))):
        return None
    return cur


def restore_montecarlo(project: Any) -> MonteCarloRun | None:
    """The last stored run back (None: none stored); an error when its file cannot be read."""
    cur = stored_montecarlo(project)
    if cur is None:
        return None
    return MonteCarloRun(read(project, str(cur["file"])), cur.get("result"), str(cur["file"]))


def done_message(full: dict[str, Any]) -> str:
    """How a finished run is said: iterations × points, time and executor."""
    elapsed = full.get("elapsed_s")
    return (
        f"done: {numbers.count(full.get('iterations') or 0)} iterations"
        f" × {numbers.count(full.get('n_points') or 0)} points"
        + (f" in {numbers.time(elapsed)}" if isinstance(elapsed, (int, float)) else "")
        + (f" ({full.get('executor')})" if full.get("executor") else "")
    )


# ------------------------------------------------------------------------------ the task object
class UncertaintyTask:
    """The steps above bound to a ``host`` and a ``project``: what the Uncertainty page holds."""

    def __init__(self, host: Any, project: Any):
        self.host, self.project = host, project

    # the budget
    def evaluate(self, req: BudgetRequest | dict[str, Any]) -> RunResult:
        return evaluate(self.host, req)

    def save_draft(self, req: BudgetRequest) -> None:
        save_draft(self.project, req)

    def start_budget(self) -> BudgetRequest:
        return start_budget(self.project)

    def store_budget(self, run: RunResult, req: BudgetRequest | dict[str, Any]) -> int:
        return store_budget(self.project, run, req)

    def restore_budget(self, rid: Any) -> RunResult:
        return restore_budget(self.project, rid)

    # the Monte Carlo study
    def check_montecarlo(self, req: MonteCarloRequest) -> CheckedMonteCarlo:
        return check_montecarlo(self.host, req)

    def run_montecarlo(
        self,
        checked: CheckedMonteCarlo,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> RunResult:
        return run_montecarlo(self.host, checked, progress=progress, cancel=cancel)

    def store_montecarlo(self, run: RunResult, checked: CheckedMonteCarlo) -> tuple[int, str]:
        return store_montecarlo(self.project, run, checked)

    def read(self, h: str) -> dict[str, Any]:
        return read(self.project, h)

    def restore_montecarlo(self) -> MonteCarloRun | None:
        return restore_montecarlo(self.project)
