"""Geometric tolerances of a measured cloud, headless: a plan (features on the nominal,
datums, ISO 1101 characteristics) evaluated by the plugin providing ``gdt-evaluation``
(camcmm's ``gdt.evaluate``), its results kept in the project with the plan.

    request = GdtRequest(cloud="3", nominal="2", plan=document, align="best-fit")
    task = GdtTask(host, ProjectItems(project), project)
    evaluation = task.run(request)        # checked, run through the worker, held to CONTRACT
    record = task.store(evaluation)       # result row, aligned cloud file, "gdt.current"
    task.save_plan(document, request)     # the plan as edited, "gdt.plan" (kept on reload)
    shown = task.restore()                # the last evaluation back (None: none stored)
    text = plan_yaml(document)            # the plan as the YAML of `camcmm gdt evaluate`

The plan document is the YAML mapping of ``camcmm gdt evaluate PLAN.yaml`` (issue 27):
``unit``, ``band``, ``features`` {id: {type, point, normal, axis, centre, apex,
diameter, length, angle, cad, box, association, band}}, ``datums`` {label: feature},
``characteristics`` [{id, type, feature, datums, tolerance | lower/upper, k, modifier}].
:func:`check` refuses here, in one line naming the plan key, what a page can say before
anything runs (no feature, a characteristic on an undefined feature or datum, a
tolerance that is not a positive number); the plugin parses the plan fully.

Lengths are in mm (the plan's ``unit``, default mm). Nothing here imports the GUI,
trame or VTK.
"""

from __future__ import annotations

import math
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .. import contracts, worker
from ..contracts import Need, OutputContract
from ..errors import InputError, PluginError
from ..host import RunResult
from .items import stored_record

#: The task whose plugin runs (``provides:`` in its manifest); ``PLUGIN`` is camcmm's own,
#: used when no installed plugin declares the task.
TASK = "gdt-evaluation"
PLUGIN = "gdt.evaluate"
#: Where the project keeps the last evaluation and the plan being edited.
STATE_KEY = "gdt.current"
PLAN_KEY = "gdt.plan"
#: The version of the record under :data:`PLAN_KEY` (a newer one is refused, an older migrated).
PLAN_VERSION = 1
#: The task (and camcmm's plugin) reading a QIF 3.0 file into a plan (the page may not
#: import plugin code).
QIF_TASK = "qif-import"
QIF_PLUGIN = "gdt.import-qif"

#: Feature types a plan may name (the plugin's ``model.FEATURE_TYPES``), with the words a
#: person reads; ``face`` is a face of a STEP nominal.
FEATURE_TITLES: dict[str, str] = {
    "plane": "Plane",
    "cylinder": "Cylinder",
    "sphere": "Sphere",
    "cone": "Cone",
    "circle": "Circle",
    "line": "Line",
    "point": "Point",
    "torus": "Torus",
    "face": "CAD face",
}
#: Association criteria (ISO 14405-1 / ISO 5459) and their words.
ASSOCIATION_TITLES: dict[str, str] = {
    "ls": "Least squares",
    "minzone": "Minimum zone (Chebyshev)",
    "mincircumscribed": "Minimum circumscribed",
    "maxinscribed": "Maximum inscribed",
    "tangent": "Tangent (datum, ISO 5459)",
}
#: Characteristic types (ISO 1101, ISO 14405-1) and their words, by family.
CHARACTERISTIC_TITLES: dict[str, str] = {
    "straightness": "Straightness",
    "flatness": "Flatness",
    "roundness": "Roundness",
    "cylindricity": "Cylindricity",
    "line-profile": "Profile of a line",
    "surface-profile": "Profile of a surface",
    "parallelism": "Parallelism",
    "perpendicularity": "Perpendicularity",
    "angularity": "Angularity",
    "position": "Position",
    "coaxiality": "Coaxiality",
    "concentricity": "Concentricity",
    "symmetry": "Symmetry",
    "profile": "Profile (with datums)",
    "circular-runout": "Circular runout",
    "total-runout": "Total runout",
    "diameter": "Diameter",
    "width": "Width",
    "distance": "Distance",
}
#: Size characteristics take ``lower``/``upper`` deviations (mm); the others a zone ``tolerance``.
SIZES = ("diameter", "width", "distance")
#: Characteristics that need datums.
NEED_DATUMS = (
    "parallelism",
    "perpendicularity",
    "angularity",
    "position",
    "coaxiality",
    "concentricity",
    "symmetry",
    "profile",
    "circular-runout",
    "total-runout",
)
ALIGNMENTS = ("best-fit", "datums", "rps", "3-2-1", "none")
ALIGN_TITLES = {
    "best-fit": "Best fit to the nominal",
    "datums": "Datum system (the DRF gives the part's coordinates)",
    "rps": "RPS (reference point system)",
    "3-2-1": "3-2-1 from features",
    "none": "None — the cloud is in the plan's coordinates",
}
#: The verdict words of the plugin (ISO 14253-1) and the colours a page shows them in.
VERDICTS = ("conform", "undecided", "not conform", "not evaluated")
VERDICT_COLOURS = {"conform": "#1a9850", "undecided": "#f9a825", "not conform": "#d7301f", "not evaluated": "#9e9e9e"}
#: The fitting plugin's models, for nominal parameters from picked points.
FITS = {"plane", "line", "circle", "sphere", "cylinder", "cone", "torus"}

#: What the page, its table, labels and report read of the provider's outputs.
CONTRACT = contracts.register(
    OutputContract(
        TASK,
        needs=(
            Need("features", "list", why="the features table (id, type, association, n_points, params, form)"),
            Need("datums", "list", why="the datums of the results"),
            Need("alignment", "dict", why="the alignment used, part of every result"),
            Need("alignment.method", "str", why="the alignment used, part of every result"),
            Need("characteristics", "list", why="the results table and the report"),
            Need("labels", "list", why="the flag labels in the 3-D view (anchor, decisive points, verdict)"),
            Need("aligned", "pointcloud", ("feature",), optional=True, why="the cloud in plan coordinates"),
        ),
    )
)


#: What the Import plan of a QIF file reads of the provider's outputs.
QIF_CONTRACT = contracts.register(
    OutputContract(
        QIF_TASK,
        needs=(
            Need("plan", "dict", why="the plan document that replaces the one being edited"),
            Need("report", "dict", why="the import's counts and what was skipped"),
            Need("report.skipped", "list", why="what was not imported, each with its reason"),
        ),
    )
)


# ------------------------------------------------------------------------------ the request
@dataclass
class GdtRequest:
    """What to evaluate: item ids of the measured ``cloud`` and the ``nominal`` (a CAD
    model or mesh; None: the plan's nominal geometry only), the ``plan`` document and the
    alignment method ``align`` (one of :data:`ALIGNMENTS`)."""

    cloud: Any
    nominal: Any = None
    plan: dict[str, Any] = field(default_factory=dict)
    align: str = "best-fit"


@dataclass
class Checked:
    """A request checked: the plan document, the provider ``spec`` and the project ids
    of the items (None for one the project does not know)."""

    request: GdtRequest
    spec: Any
    plan: dict[str, Any]
    cloud_id: int | None
    nominal_id: int | None

    @property
    def mids(self) -> list[int]:
        return [m for m in (self.cloud_id, self.nominal_id) if m is not None]


@dataclass
class Evaluation:
    """An evaluation run (or restored): the plugin's ``result`` (outputs: features,
    datums, alignment, characteristics, labels, aligned), the plan evaluated and, once
    stored, the project's ``record``."""

    result: RunResult
    plan: dict[str, Any] = field(default_factory=dict)
    checked: Checked | None = None
    record: dict[str, Any] | None = None

    @property
    def outputs(self) -> dict[str, Any]:
        return self.result.outputs

    @property
    def characteristics(self) -> list[dict[str, Any]]:
        return list(self.result.outputs.get("characteristics") or [])

    @property
    def labels(self) -> list[dict[str, Any]]:
        return list(self.result.outputs.get("labels") or [])


def _name(items: Any, key: Any) -> str:
    m = items.measurement(key)
    return str(m.get("name") or key) if m else str(key)


def _mid(items: Any, key: Any) -> int | None:
    m = items.measurement(key) if key not in (None, "") else None
    return int(m["id"]) if m else None


def _number(value: Any, where: str, positive: bool = False) -> float:
    """``value`` as a finite float (a typed ``"0,05"`` too); InputError naming ``where``."""
    try:
        v = float(value) if isinstance(value, (int, float)) else float(str(value).replace(",", "."))
    except (TypeError, ValueError):
        raise InputError(f"{where}: {value!r} is not a number") from None
    if isinstance(value, bool) or not math.isfinite(v) or (positive and v <= 0):
        raise InputError(f"{where}: {value!r} must be a {'positive ' if positive else ''}finite number")
    return v


def empty_plan(unit: str = "mm", band: float = 0.5) -> dict[str, Any]:
    """A plan with nothing in it yet."""
    return {"unit": unit, "band": band, "features": {}, "datums": {}, "characteristics": []}


def check_plan(plan: Any, name: str = "plan", complete: bool = True) -> dict[str, Any]:
    """The plan document checked as far as a page can say before anything runs; returns
    it. InputError, one line naming ``name`` and the key, for: not a mapping, no feature
    or no characteristic (both allowed when not ``complete``: a plan being written), an
    unknown feature or characteristic type, a characteristic on an undefined feature or
    datum, a datum on an undefined feature, a tolerance (or a size's lower/upper) that is
    not a number, a zone tolerance ≤ 0, lower ≥ upper."""
    if not isinstance(plan, dict):
        raise InputError(f"{name}: expected a mapping with features and characteristics")
    features = plan.get("features")
    if not isinstance(features, dict) or (complete and not features):
        raise InputError(f"{name}: features: define at least one feature (pick one on the nominal)")
    for fid, f in features.items():
        if not isinstance(f, dict) or f.get("type") not in FEATURE_TITLES:
            kind = f.get("type") if isinstance(f, dict) else f
            raise InputError(f"{name}: features.{fid}.type: {kind!r} is not one of {', '.join(FEATURE_TITLES)}")
        if "band" in f and f["band"] is not None:
            _number(f["band"], f"{name}: features.{fid}.band", positive=True)
    if "band" in plan and plan["band"] is not None:
        _number(plan["band"], f"{name}: band", positive=True)
    datums = plan.get("datums") or {}
    if not isinstance(datums, dict):
        raise InputError(f"{name}: datums: expected a mapping label -> feature")
    for label, fid in datums.items():
        for one in fid if isinstance(fid, list) else [fid]:
            if one not in features:
                raise InputError(f"{name}: datums.{label}: feature {one!r} is not defined")
    chars = plan.get("characteristics")
    if not isinstance(chars, list) or (complete and not chars):
        raise InputError(f"{name}: characteristics: enter at least one characteristic")
    seen: set[str] = set()
    for i, c in enumerate(chars):
        where = f"{name}: characteristics[{i}]"
        if not isinstance(c, dict):
            raise InputError(f"{where}: expected a mapping with id, type, feature")
        cid = str(c.get("id") or "")
        where = f"{where} ({cid})" if cid else where
        if not cid:
            raise InputError(f"{where}.id: give the characteristic an id")
        if cid in seen:
            raise InputError(f"{where}.id: {cid!r} is used twice")
        seen.add(cid)
        if c.get("type") not in CHARACTERISTIC_TITLES:
            raise InputError(f"{where}.type: {c.get('type')!r} is not one of {', '.join(CHARACTERISTIC_TITLES)}")
        if c.get("feature") not in features:
            raise InputError(f"{where}.feature: {c.get('feature')!r} is not defined")
        for label in c.get("datums") or []:
            for part in str(label).split("-"):
                if str(label) not in datums and part not in datums:
                    raise InputError(f"{where}.datums: datum {label!r} is not defined")
        if c["type"] in NEED_DATUMS and not c.get("datums") and c["type"] != "profile":
            raise InputError(f"{where}.datums: {CHARACTERISTIC_TITLES[c['type']]} needs at least one datum")
        if c["type"] in SIZES:
            lo, hi = c.get("lower"), c.get("upper")
            if lo is None and hi is None and c.get("tolerance") is None:
                raise InputError(f"{where}: give lower and upper (deviations from the nominal size, mm)")
            if lo is not None and hi is not None:
                if _number(lo, f"{where}.lower") >= _number(hi, f"{where}.upper"):
                    raise InputError(f"{where}.lower: {lo} is not below upper {hi}")
        elif c.get("tolerance") is None:
            raise InputError(f"{where}.tolerance: enter the tolerance (mm)")
        if c.get("tolerance") is not None:
            _number(c["tolerance"], f"{where}.tolerance", positive=True)
        if c.get("k") is not None:
            _number(c["k"], f"{where}.k", positive=True)
    return plan


def provider(host: Any, task: str = TASK, plugin: str = PLUGIN) -> Any:
    """The plugin that performs ``task`` (default: evaluates a plan): the one providing it,
    else camcmm's ``plugin`` held to the same contract. PluginError (one line) when there
    is none."""
    try:
        return host.provider(task)
    except PluginError as first:
        plugins = getattr(host, "plugins", {}) or {}
        if plugin not in plugins:
            raise first from None
        spec = host.get(plugin)
        problem = contracts.manifest_problem(spec, task)
        if problem:
            raise PluginError(problem) from None
        return spec


def check(request: GdtRequest, spec: Any, items: Any) -> Checked:
    """The request made ready: a measured cloud chosen (and not also the nominal), the
    alignment one of :data:`ALIGNMENTS`, the plan checked (:func:`check_plan`). InputError,
    one line, otherwise."""
    if request.cloud in (None, ""):
        raise InputError("choose the measured cloud first (import one with the Import field)")
    if request.nominal not in (None, "") and str(request.nominal) == str(request.cloud):
        raise InputError(f"{_name(items, request.cloud)} is chosen as both measured and nominal; choose two items")
    if request.align not in ALIGNMENTS:
        raise InputError(f"align: {request.align!r} is not one of {', '.join(ALIGNMENTS)}")
    if request.align in ("best-fit",) and request.nominal in (None, "") and not _has_nominals(request.plan):
        raise InputError("align: a best fit needs the nominal (choose it) or the features' nominal geometry")
    plan = check_plan(request.plan)
    return Checked(request, spec, plan, _mid(items, request.cloud), _mid(items, request.nominal))


def _has_nominals(plan: Any) -> bool:
    feats = plan.get("features") if isinstance(plan, dict) else None
    if not isinstance(feats, dict):
        return False
    return any(isinstance(f, dict) and f.get("type") != "face" for f in feats.values())


def run(
    host: Any,
    items: Any,
    request: GdtRequest | Checked,
    progress: Callable[[float, str], None] | None = None,
    cancel: threading.Event | None = None,
) -> Evaluation:
    """Check ``request`` (unless it is :class:`Checked` already), load its items, run the
    provider through :func:`camcmm.worker.run` (a worker process when the host can be
    rebuilt there) and hold its outputs to :data:`CONTRACT`."""
    checked = request if isinstance(request, Checked) else check(request, provider(host), items)
    req = checked.request
    cloud = items.load(str(req.cloud))
    if not hasattr(cloud, "points") or hasattr(cloud, "faces"):
        raise InputError(f"{_name(items, req.cloud)}: the measured item must be a point cloud")
    inputs: dict[str, Any] = {"cloud": cloud, "plan": checked.plan}
    if req.nominal not in (None, ""):
        inputs["nominal"] = items.load(str(req.nominal))
    spec = checked.spec
    result = worker.run(host, spec.id, inputs, {"align": req.align}, progress=progress, cancel=cancel)
    contracts.check_outputs(TASK, spec.id, result.outputs)
    return Evaluation(result, checked.plan, checked)


# ------------------------------------------------------------------------------ the project
def store(project: Any, evaluation: Evaluation) -> dict[str, Any]:
    """Keep ``evaluation`` in ``project``: the aligned cloud (if any) as a file, the run as
    a result linked to the items, and the record under :data:`STATE_KEY` (``result``,
    ``cloud``, ``nominal``, ``align``, ``plan``, ``aligned`` (file hash), ``report``),
    which is returned."""
    result = evaluation.result
    checked = evaluation.checked
    files: dict[str, str] = {}
    aligned = result.outputs.get("aligned")
    if aligned is not None and hasattr(aligned, "points"):
        files["aligned"] = project.add_object(aligned, "gdt aligned.ply")
    row = result.to_json()
    row["outputs"].pop("aligned", None)  # kept as its file, not as JSON
    rid = project.add_result(
        row, measurement_ids=checked.mids if checked else [], files=files, label="gdt: characteristics"
    )
    record = {
        "result": rid,
        "cloud": checked.cloud_id if checked else None,
        "nominal": checked.nominal_id if checked else None,
        "align": result.params.get("align"),
        "plan": evaluation.plan,
        "aligned": files.get("aligned"),
        "report": None,
    }
    project.set_state(STATE_KEY, record)
    evaluation.record = record
    return record


def stored(project: Any) -> dict[str, Any] | None:
    """The record of the last evaluation kept in ``project`` (None: there is none)."""
    return stored_record(project, STATE_KEY)


def restore(project: Any) -> Evaluation | None:
    """The last evaluation kept in ``project`` as it was run (outputs as stored, the
    aligned cloud read back from its file). None when none is kept; an error (one line)
    when it is kept but cannot be read."""
    record = stored(project)
    if record is None:
        return None
    row = project.result(int(record["result"]))
    result = RunResult.from_json(row)
    h = (row.get("files") or {}).get("aligned") or record.get("aligned")
    if h:
        from .. import io as cio  # the file formats pull in Open3D: only when there is one to read

        result.outputs["aligned"] = cio.read(project.file_path(h))
    return Evaluation(result, dict(record.get("plan") or {}), record=record)


def save_plan(project: Any, plan: dict[str, Any], request: GdtRequest | None = None) -> dict[str, Any]:
    """The plan being edited kept in ``project`` under :data:`PLAN_KEY` (with the items and
    the alignment chosen), so that it is there after a reload; returns the record."""
    record: dict[str, Any] = {"version": PLAN_VERSION, "plan": plan}
    if request is not None:
        record.update(cloud=request.cloud, nominal=request.nominal, align=request.align)
    project.set_state(PLAN_KEY, record)
    return record


def saved_plan(project: Any) -> dict[str, Any] | None:
    """The plan record kept in ``project`` (``{"version", "plan", "cloud", "nominal",
    "align"}``), None when there is none. A record of a newer version is refused in one
    line; a bare plan document (no version) is taken as version 1."""
    try:
        rec = project.get_state(PLAN_KEY)
    except Exception:
        return None
    if not isinstance(rec, dict):
        return None
    if "version" not in rec:  # a bare document
        rec = {"version": PLAN_VERSION, "plan": rec}
    if int(rec.get("version") or 0) > PLAN_VERSION:
        raise InputError(
            f"project state {PLAN_KEY}: version {rec['version']} is newer than this camcmm reads ({PLAN_VERSION})"
        )
    if not isinstance(rec.get("plan"), dict):
        return None
    return rec


# ------------------------------------------------------------------------------ features picked
def region(points: Any, centre: Any, radius: float) -> Any:
    """Indices of ``points`` (N, 3) mm within ``radius`` (mm) of ``centre``: the region
    picked around a clicked point of the nominal."""
    import numpy as np

    P = np.asarray(points, dtype=float).reshape(-1, 3)
    c = np.asarray(centre, dtype=float).ravel()[:3]
    return np.nonzero(np.sum((P - c) ** 2, axis=1) <= float(radius) ** 2)[0]


def box_of(points: Any, pad: float) -> list[list[float]]:
    """The box [[min], [max]] (mm) of ``points`` grown by ``pad`` on every side: a
    feature's extent."""
    import numpy as np

    P = np.asarray(points, dtype=float).reshape(-1, 3)
    return [(P.min(axis=0) - pad).tolist(), (P.max(axis=0) + pad).tolist()]


def _unit(v: Any) -> list[float]:
    import numpy as np

    a = np.asarray(v, dtype=float).ravel()[:3]
    n = float(np.linalg.norm(a))
    return (a / n).tolist() if n > 0 else a.tolist()


def _extent(points: Any, origin: Any, direction: Any) -> tuple[list[float], float]:
    """The foot on the line (``origin``, unit ``direction``) of the first point along it,
    and the points' extent along it (mm): a cylinder's or a line's ``point`` and ``length``."""
    import numpy as np

    P = np.asarray(points, dtype=float).reshape(-1, 3)
    o, d = np.asarray(origin, dtype=float), np.asarray(_unit(direction))
    t = (P - o) @ d
    return (o + float(t.min()) * d).tolist(), float(np.ptp(t))


def nominal_from_points(host: Any, kind: str, points: Any) -> dict[str, Any]:
    """A feature's nominal parameters (the plan's keys, mm, degrees) from ``points``
    picked on the nominal: the least-squares element of the fitting plugin ``fit.<kind>``
    (reached by id), so that an operator does not type coordinates. A ``point`` is the
    points' centroid. InputError (one line) when there are too few points or the fit
    refuses them."""
    import numpy as np

    from ..model import PointCloud

    P = np.asarray(points, dtype=float).reshape(-1, 3)
    need = {"point": 1, "line": 2, "plane": 3, "circle": 3, "sphere": 4, "cylinder": 5, "cone": 6, "torus": 7}
    if kind not in need:
        raise InputError(f"feature type {kind!r}: its nominal comes from the CAD or is typed, not fitted")
    if len(P) < need[kind]:
        raise InputError(
            f"{FEATURE_TITLES[kind]}: {len(P)} points picked, at least {need[kind]} needed; pick a larger region"
        )
    if kind == "point":
        return {"point": P.mean(axis=0).tolist()}
    try:
        o = host.algorithm(f"fit.{kind}")(cloud=PointCloud(P, name="picked region"))
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"{FEATURE_TITLES[kind]} from the picked region: {exc}".splitlines()[0]) from None
    if kind == "plane":
        return {"point": np.asarray(o["point"], float).tolist(), "normal": _unit(o["normal"])}
    if kind == "sphere":
        return {"centre": np.asarray(o["center"], float).tolist(), "diameter": 2.0 * float(o["radius"])}
    if kind == "circle":
        return {
            "centre": np.asarray(o["center"], float).tolist(),
            "normal": _unit(o["normal"]),
            "diameter": 2.0 * float(o["radius"]),
        }
    if kind in ("cylinder", "line"):
        d = o["axis"] if kind == "cylinder" else o["direction"]
        foot, length = _extent(P, o["point"], d)
        out = {"point": foot, ("axis" if kind == "cylinder" else "direction"): _unit(d), "length": length}
        if kind == "cylinder":
            out["diameter"] = 2.0 * float(o["radius"])
        return out
    if kind == "cone":
        return {"apex": np.asarray(o["apex"], float).tolist(), "axis": _unit(o["axis"]), "angle": float(o["angle"])}
    return {
        "centre": np.asarray(o["center"], float).tolist(),
        "axis": _unit(o["axis"]),
        "major_diameter": 2.0 * float(o["major_radius"]),
        "minor_diameter": 2.0 * float(o["minor_radius"]),
    }


def vertex_normals(vertices: Any, faces: Any) -> Any:
    """Area-weighted unit normals (n, 3) of a mesh's vertices, from its triangles' winding
    (outward for a closed mesh wound counter-clockwise seen from outside, as STL and a
    STEP tessellation are)."""
    import numpy as np

    V = np.asarray(vertices, dtype=float).reshape(-1, 3)
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # length: twice the area
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    n = np.linalg.norm(N, axis=1)
    return N / np.where(n > 0, n, 1.0)[:, None]


def orient(kind: str, params: dict[str, Any], points: Any, normals: Any) -> dict[str, Any]:
    """A fitted nominal oriented by the picked surface's outward ``normals`` (n, 3) at
    ``points`` (n, 3): a plane's normal out of the material, and ``internal: true`` for a
    sphere, cylinder, cone or torus whose surface faces its axis (a bore, a socket) — what
    a fit of points alone cannot tell."""
    import numpy as np

    P = np.asarray(points, dtype=float).reshape(-1, 3)
    N = np.asarray(normals, dtype=float).reshape(-1, 3)
    if not len(P) or len(N) != len(P):
        return params
    out = dict(params)
    if kind == "plane":
        if float(np.mean(N @ np.asarray(out["normal"], dtype=float))) < 0:
            out["normal"] = [-float(c) for c in out["normal"]]
        return out
    if kind == "sphere":
        radial = P - np.asarray(out["centre"], dtype=float)
    elif kind in ("cylinder", "cone", "torus"):
        a = np.asarray(out["axis"], dtype=float)
        origin = np.asarray(out.get("point", out.get("apex", out.get("centre"))), dtype=float)
        q = P - origin
        radial = q - np.outer(q @ a, a)
        if kind == "torus":  # from the tube's centre circle
            rho = np.linalg.norm(radial, axis=1)
            ring = 0.5 * float(out["major_diameter"]) * radial / np.where(rho > 0, rho, 1.0)[:, None]
            radial = q - ring
    else:
        return out
    if float(np.mean(np.sum(radial * N, axis=1))) < 0:
        out["internal"] = True
    return out


# ------------------------------------------------------------------------------ the YAML
#: Key order of the issue's YAML (the rest follows in the document's own order).
_PLAN_ORDER = ("unit", "band", "features", "datums", "characteristics")
_FEATURE_ORDER = (
    "type",
    "point",
    "centre",
    "apex",
    "normal",
    "axis",
    "direction",
    "diameter",
    "major_diameter",
    "minor_diameter",
    "length",
    "angle",
    "cad",
    "box",
    "association",
    "band",
)
_CHAR_ORDER = ("id", "type", "feature", "datums", "tolerance", "lower", "upper", "modifier", "k")


def _ordered(d: dict[str, Any], order: tuple[str, ...]) -> dict[str, Any]:
    out = {k: d[k] for k in order if k in d and d[k] is not None}
    out.update({k: v for k, v in d.items() if k not in out and v is not None})
    return out


def _plain(value: Any) -> Any:
    """numpy values and tuples as plain YAML scalars and lists (floats rounded to 1e-9 of a
    unit: printing noise is not a nominal)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)) or type(value).__name__ == "ndarray":
        return [_plain(v) for v in list(value)]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, int) or type(value).__name__.startswith("int"):
        return int(value)
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    r = round(v, 9)
    return int(r) if r == int(r) and abs(r) < 1e15 else r


def plan_yaml(plan: dict[str, Any]) -> str:
    """The plan document as the YAML ``camcmm gdt evaluate`` reads, in the issue's key
    order (unit, band, features, datums, characteristics); features and characteristics
    one per line (flow style), as the issue writes them."""
    import yaml

    doc = _plain(_ordered(plan, _PLAN_ORDER))
    lines = []
    for key, value in doc.items():
        if key == "features" and isinstance(value, dict):
            lines.append("features:" if value else "features: {}")
            for fid, f in value.items():
                body = yaml.safe_dump(_ordered(f, _FEATURE_ORDER), default_flow_style=True, sort_keys=False, width=4096)
                lines.append(f"  {_key(fid)}: {body.strip()}")
        elif key == "characteristics" and isinstance(value, list):
            lines.append("characteristics:" if value else "characteristics: []")
            for c in value:
                body = yaml.safe_dump(_ordered(c, _CHAR_ORDER), default_flow_style=True, sort_keys=False, width=4096)
                lines.append(f"  - {body.strip()}")
        else:
            body = yaml.safe_dump({key: value}, default_flow_style=True, sort_keys=False, width=4096).strip()
            lines.append(body[1:-1].strip())  # {key: value} -> key: value
    return "\n".join(lines) + "\n"


def _key(text: Any) -> str:
    """A mapping key as YAML writes it (quoted when it would not read back as itself)."""
    import yaml

    return yaml.safe_dump(str(text), default_flow_style=True).strip().removesuffix("\n...").strip()


def read_plan_text(text: str | bytes, name: str = "plan.yaml") -> dict[str, Any]:
    """A plan file's text (an upload) as the plan document, through camcmm's one YAML
    loader (size, aliases, depth, duplicate keys) and :func:`check_plan`'s structure
    checks, empty lists allowed (a plan being written). One-line InputError naming
    ``name`` and the key."""
    from ..yamlfile import load_yaml

    return _plan_document(load_yaml(text, name=name), name)


def _plan_document(doc: Any, name: str) -> dict[str, Any]:
    """A plan document read from a file (YAML, JSON or QIF) in mm and checked as a plan
    being written (:func:`in_mm`, :func:`check_plan` with empty lists allowed)."""
    from ..units import to_mm_factor

    if not isinstance(doc, dict):
        raise InputError(f"{name}: expected a mapping with features and characteristics")
    doc = dict(doc)
    doc.setdefault("unit", "mm")
    try:
        to_mm_factor(str(doc["unit"]))
    except Exception:
        raise InputError(f"{name}: unit: {doc['unit']!r} is not a length unit camcmm reads") from None
    doc.setdefault("features", {})
    doc.setdefault("datums", {})
    doc.setdefault("characteristics", [])
    return check_plan(in_mm(doc, name), name, complete=False)


def import_qif_upload(host: Any, project: Any, content: bytes | str, name: str = "plan.qif") -> QifImport:
    """An uploaded QIF 3.0 file (its bytes ``content``, its name ``name``) as a plan
    document, by the plugin providing :data:`QIF_TASK` (camcmm's :data:`QIF_PLUGIN`,
    ``camcmm gdt import-qif``'s reader), run in this process (a parse of a file of at
    most 64 MB). The bytes are written under their own name in a temporary folder inside
    ``project``'s folder (the plugin takes a path, and a confined server reads only
    there), removed afterwards. The plan goes through :func:`read_plan_text`'s checks
    (:func:`in_mm`, :func:`check_plan`). One-line InputError naming the file."""
    import tempfile
    from pathlib import Path

    base = Path(str(name or "")).name.strip() or "plan.qif"
    data = content.encode("utf-8") if isinstance(content, str) else bytes(content)
    spec = provider(host, QIF_TASK, QIF_PLUGIN)
    root = getattr(project, "path", None)
    with tempfile.TemporaryDirectory(prefix=".qif-import-", dir=str(root) if root else None) as tmp:
        path = Path(tmp) / base  # the reader names the file in its messages and in plan.qif.file
        path.write_bytes(data)
        result = host.run(spec.id, {"qif": path})
    contracts.check_outputs(QIF_TASK, spec.id, result.outputs)
    plan = _plan_document(result.outputs["plan"], base)
    return QifImport(plan, dict(result.outputs["report"]), list(result.warnings or []), base)


@dataclass
class QifImport:
    """A QIF file imported: the checked ``plan`` (mm), the plugin's ``report`` (counts,
    ``skipped`` [{id, reason}], ``imported``, ``unit``), its run ``warnings`` and the
    file's ``name``."""

    plan: dict[str, Any]
    report: dict[str, Any]
    warnings: list[str]
    name: str

    @property
    def skipped(self) -> list[dict[str, Any]]:
        return list(self.report.get("skipped") or [])

    def message(self, reasons: int = 2) -> str:
        """ "<file>: imported N features, M characteristics; skipped K: <first reasons>"."""
        text = (
            f"{self.name}: imported {len(self.plan.get('features') or {})} features, "
            f"{len(self.plan.get('characteristics') or [])} characteristics"
        )
        skipped = self.skipped
        if skipped:
            first = "; ".join(f"{s.get('id')}: {s.get('reason')}" for s in skipped[:reasons])
            text += f"; skipped {len(skipped)}: {first}" + (" …" if len(skipped) > reasons else "")
        return text


#: The plan keys that are lengths (converted by :func:`in_mm`) and those that are not.
_LENGTHS = {
    "feature": {"point", "centre", "apex", "diameter", "length", "major_diameter", "minor_diameter", "box", "band"},
    "characteristic": {"tolerance", "lower", "upper"},
    "plan": {"band"},
}
_NOT_LENGTHS = {
    "feature": {"type", "normal", "axis", "direction", "angle", "cad", "association", "internal"},
    "characteristic": {"id", "type", "feature", "datums", "modifier", "k"},
    "plan": {"unit", "features", "datums", "characteristics", "report"},  # report: the customer fields
}


def in_mm(plan: dict[str, Any], name: str = "plan") -> dict[str, Any]:
    """The plan document with its lengths in mm (``unit: mm``), so that the features the
    page adds (mm) and the ones read from the file are in one unit. A plan in mm comes back
    as it is; one in another unit that holds a key not known to be a length or not
    (:data:`_LENGTHS`) is refused in one line naming it, rather than half converted."""
    import numpy as np

    from ..units import to_mm_factor

    unit = str(plan.get("unit") or "mm")
    f = to_mm_factor(unit)
    if f == 1.0:
        return dict(plan, unit="mm")

    def scaled(d: dict[str, Any], kind: str, where: str) -> dict[str, Any]:
        out = {}
        for k, v in d.items():
            if k in _LENGTHS[kind]:
                out[k] = (np.asarray(v, dtype=float) * f).tolist() if v is not None else None
            elif k in _NOT_LENGTHS[kind]:
                out[k] = v
            else:
                raise InputError(f"{name}: {where}{k}: not converted from {unit} (write the plan in mm)")
        return out

    doc = scaled(plan, "plan", "")
    feats = plan.get("features") or {}
    if not isinstance(feats, dict) or not isinstance(plan.get("characteristics") or [], list):
        return doc  # check_plan says what is wrong
    doc["features"] = {
        fid: scaled(ft, "feature", f"features.{fid}.") for fid, ft in feats.items() if isinstance(ft, dict)
    }
    doc["characteristics"] = [
        scaled(c, "characteristic", f"characteristics[{i}].") if isinstance(c, dict) else c
        for i, c in enumerate(plan.get("characteristics") or [])
    ]
    doc["unit"] = "mm"
    return doc


# ------------------------------------------------------------------------------ results
def char_title(kind: Any) -> str:
    """A characteristic's type as a person reads it (``"surface-profile"`` -> ``"Profile of a surface"``)."""
    return CHARACTERISTIC_TITLES.get(str(kind), str(kind).replace("-", " ").capitalize())


def verdict_of(row: dict[str, Any]) -> str:
    """The verdict shown for a characteristic: the guarded one (ISO 14253-1), else the
    simple one, else "not evaluated"."""
    for key in ("verdict_guarded", "verdict"):
        v = row.get(key)
        if v in VERDICTS:
            return str(v)
    return "not evaluated"


def next_id(taken: Any, prefix: str) -> str:
    """The first ``prefix<n>`` (n = 1, 2, …) not in ``taken``."""
    taken = {str(t) for t in taken}
    base = re.sub(r"[^\w\-]", "", str(prefix)) or "F"
    n = 1
    while f"{base}{n}" in taken:
        n += 1
    return f"{base}{n}"


def report_section(rep: Any, evaluation: Evaluation, fmt: Callable[[dict[str, Any]], dict[str, str]]) -> None:
    """The characteristics of ``evaluation`` as a section of report ``rep`` (a
    camcmm.report Report): the alignment used, one row per characteristic (type, feature,
    datums, value, U, tolerance, verdicts; ``fmt(row)`` gives the texts) and the plugin's
    warnings."""
    o = evaluation.outputs
    sec = rep.section("Geometric characteristics (ISO 1101, ISO 14253-1)")
    al = o.get("alignment") or {}
    sec.paragraph(f"Alignment: {ALIGN_TITLES.get(str(al.get('method')), str(al.get('method') or 'not stated'))}.")
    rows = []
    for c in evaluation.characteristics:
        t = fmt(c)
        rows.append(
            [
                str(c.get("id")),
                char_title(c.get("type")),
                str(c.get("feature") or ""),
                "|".join(str(d) for d in c.get("datums") or []) or "—",
                t["value"],
                t["U"],
                t["tolerance"],
                str(c.get("verdict") or "not evaluated"),
                verdict_of(c),
            ]
        )
    sec.table(
        ["Id", "Characteristic", "Feature", "Datums", "Value", "U (k)", "Tolerance", "Simple", "ISO 14253-1"],
        rows,
        caption="Each value with its expanded uncertainty U = k·u and the ISO 14253-1 verdict with U as guard band",
        align=["left", "left", "left", "left", "right", "right", "right", "left", "left"],
    )
    for w in list(evaluation.result.warnings or [])[:20]:
        sec.warning(str(w))


def write_report(spec: Any, evaluation: Evaluation, items: Any, folder: Any, project_path: str = "") -> dict[str, str]:
    """The provider's own report of ``evaluation`` (its manifest's ``report:`` writer: HTML,
    PDF, JSON) written in ``folder``: ``{format: path}``; the items' names and file hashes
    go into its provenance."""
    from pathlib import Path

    from .compare import report_writer

    build = report_writer(spec)
    record = evaluation.record or {}
    names = {}
    inputs = []
    for key, role in (("cloud", "measured cloud"), ("nominal", "nominal")):
        m = items.measurement(record[key]) if record.get(key) is not None else None
        names[key] = str(m.get("name")) if m else None
        if m and m.get("hash"):
            inputs.append({"file": str(m.get("name")), "sha256": m["hash"], "role": role})
    rep = build(
        dict(evaluation.outputs),
        plan=evaluation.plan,
        plan_file="the plan of the Compare page",
        cloud_file=names["cloud"],
        nominal_file=names["nominal"],
        run=evaluation.result,
    )
    if inputs:
        rep.provenance(inputs=inputs, extra={"project": project_path, "result": record.get("result")})
    return rep.write(Path(folder), basename=f"gdt-{record.get('result') or 'new'}")


def record_report(project: Any, evaluation: Evaluation, paths: dict[str, str]) -> dict[str, str]:
    """The report files (``{format: path}``) added to ``project`` and noted in the record
    under :data:`STATE_KEY` (offered again when the project is reopened); returns
    ``{report_<format>: hash}``."""
    files = {f"report_{k}": project.add_file(p) for k, p in paths.items()}
    if evaluation.record is not None:
        evaluation.record["report"] = files
        project.set_state(STATE_KEY, evaluation.record)
    return files


# ------------------------------------------------------------------------------ the task object
class GdtTask:
    """The steps above bound to a ``host``, the project's ``items`` and the ``project``;
    what the Compare page's characteristics panel holds."""

    def __init__(self, host: Any, items: Any, project: Any):
        self.host = host
        self.items = items
        self.project = project
        self._spec: Any = None

    @property
    def spec(self) -> Any:
        """The provider's manifest (PluginError when none is installed)."""
        if self._spec is None:
            self._spec = provider(self.host)
        return self._spec

    def check(self, request: GdtRequest) -> Checked:
        return check(request, self.spec, self.items)

    def run(
        self,
        request: GdtRequest | Checked,
        progress: Callable[[float, str], None] | None = None,
        cancel: threading.Event | None = None,
    ) -> Evaluation:
        if not isinstance(request, Checked):
            request = self.check(request)
        return run(self.host, self.items, request, progress=progress, cancel=cancel)

    def store(self, evaluation: Evaluation) -> dict[str, Any]:
        return store(self.project, evaluation)

    def stored(self) -> dict[str, Any] | None:
        return stored(self.project)

    def restore(self) -> Evaluation | None:
        return restore(self.project)

    def save_plan(self, plan: dict[str, Any], request: GdtRequest | None = None) -> dict[str, Any]:
        return save_plan(self.project, plan, request)

    def saved_plan(self) -> dict[str, Any] | None:
        return saved_plan(self.project)

    def import_qif(self, content: bytes | str, name: str = "plan.qif") -> QifImport:
        return import_qif_upload(self.host, self.project, content, name)

    def write_report(self, evaluation: Evaluation, folder: Any) -> dict[str, str]:
        return write_report(self.spec, evaluation, self.items, folder, str(getattr(self.project, "path", "")))

    def record_report(self, evaluation: Evaluation, paths: dict[str, str]) -> dict[str, str]:
        return record_report(self.project, evaluation, paths)
