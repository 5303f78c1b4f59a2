"""The characteristics panel of the "Compare with CAD" page: a GD&T plan defined on the
nominal, evaluated on the measured cloud, its results as a table coloured by verdict and
as flag labels in the 3-D view.

The operator

* defines features: "Pick on nominal" shows the nominal alone; a click on it takes the
  nominal's vertices within the region's radius of the point (or the whole nominal), or,
  on a CAD model, the face under the click; the feature's nominal parameters default to a
  least-squares fit of those points (the fitting plugin, by id) — nobody types
  coordinates — and its box to their extent grown by the band;
* names datums (a label on a feature) and enters characteristics (type, feature, datums,
  a zone tolerance or a size's lower/upper deviation);
* runs the plan (the headless task :class:`camcmm.tasks.gdt.GdtTask` in the panel's own
  job) and sees each characteristic's value, U and tolerance coloured by its ISO 14253-1
  verdict, and flags in the view (:mod:`.flags`);
* exports the plan as the YAML of ``camcmm gdt evaluate`` or imports one (an upload:
  bytes over the websocket, capped by ``--max-upload`` and read by camcmm's one YAML
  loader; no path is opened, so nothing needs confining).

The plan is kept with the project as it is edited (state ``gdt.plan``), the last
evaluation too (``gdt.current``): both come back when the project is reopened.
:class:`Characteristics` is a part of :class:`.page.ComparePage` (its ``state``,
``session``, ``view``, ``offered`` downloads); state keys ``gdt_*``; loop thread except
the run. Numbers go through the Inspect page's one formatter (:mod:`..inspect.numbers`).
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from ....errors import InputError, one_line
from ....tasks import gdt as task
from ...jobs import Job
from ..inspect import numbers as num
from .flags import flag_texts, show_flags

log = logging.getLogger("camcmm.gui.compare")

#: The characteristic a new one defaults to, by the feature's type.
DEFAULT_CHARACTERISTIC = {
    "plane": "flatness",
    "cylinder": "cylindricity",
    "sphere": "diameter",
    "circle": "roundness",
    "line": "straightness",
    "cone": "surface-profile",
    "torus": "surface-profile",
    "point": "position",
    "face": "surface-profile",
}


# ------------------------------------------------------------------------------ texts
def _length(v: Any, u: Any, size: bool) -> str:
    """A length in mm as the page writes it: a size in mm to the decimals its u resolves,
    a zone (form, orientation, location, runout) below 1 mm in µm."""
    if not num.finite(v):
        return "—"
    return num.characteristic(v, size, u)  # the number rule's, shared with the Series page


def _f(x: Any) -> float | None:
    """``x`` as a finite float, None otherwise."""
    return float(x) if num.finite(x) else None


def result_texts(c: dict[str, Any], plan: dict[str, Any] | None = None) -> dict[str, str]:
    """The texts of a characteristic's result row: value, U (with k), tolerance. A size's
    lower/upper come from the result, else from the plan's characteristic of that id;
    a value in another unit than mm (an angle) is written as it is."""
    spec: dict[str, Any] = next(
        (p for p in (plan or {}).get("characteristics") or [] if p.get("id") == c.get("id")), {}
    )
    size = c.get("type") in task.SIZES
    unit = str(c.get("unit") or "mm")
    value, u, k = _f(c.get("value")), _f(c.get("u")), _f(c.get("k")) or 2.0
    U = _f(c.get("U"))
    if U is None and u is not None:
        U = k * u
    if unit != "mm":
        vt = "—" if value is None else f"{num.significant(value, 5)} {unit}"
        Ut = "—" if U is None else f"{num.significant(U, 2)} {unit}"
    else:
        vt = _length(value, u, size)
        Ut = "—" if U is None else (f"{num.micro(U)} µm" if U < 1.0 else f"{num.mm(U)} mm")
    lo = _f(c["lower"] if c.get("lower") is not None else spec.get("lower"))
    hi = _f(c["upper"] if c.get("upper") is not None else spec.get("upper"))
    tol = _f(c["tolerance"] if c.get("tolerance") is not None else spec.get("tolerance"))
    if size and (lo is not None or hi is not None):
        tolerance = " / ".join(("+" if x >= 0 else "") + num.mm(x, None, 3) for x in (lo, hi) if x is not None) + " mm"
    elif tol is not None:
        tolerance = _length(tol, None, size)
    else:
        tolerance = "—"
    return {"value": vt, "U": "—" if Ut == "—" else f"{Ut} (k = {k:g})", "tolerance": tolerance}


def result_rows(characteristics: list[dict[str, Any]], plan: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """The results table: one row per characteristic with its texts, its verdicts and
    the colour of the one shown (the guarded verdict, else the simple one)."""
    rows = []
    for c in characteristics:
        t = result_texts(c, plan)
        verdict = task.verdict_of(c)
        rows.append(
            {
                "id": str(c.get("id")),
                "title": task.char_title(c.get("type")),
                "feature": str(c.get("feature") or ""),
                "datums": "|".join(str(d) for d in c.get("datums") or []),
                **t,
                "simple": str(c.get("verdict") or "not evaluated"),
                "verdict": verdict,
                "colour": task.VERDICT_COLOURS[verdict],
                "u_method": str(c.get("u_method") or ""),
            }
        )
    return rows


def _vec(v: Any) -> str:
    """A point or direction to 6 significant digits, its rounding noise (1e-16 of a fit)
    written as 0 (rounded to the nm first; + 0.0 makes −0 a 0)."""
    return "(" + ", ".join(num.significant(round(float(x), 6) + 0.0, 6) for x in v) + ")"


def feature_summary(f: dict[str, Any]) -> str:
    """A feature's nominal in a line: ``"centre (0, 0, 0) mm, ⌀ 20 mm"``."""
    parts = []
    for key in ("point", "centre", "apex"):
        if key in f:
            parts.append(f"{key} {_vec(f[key])} mm")
    for key in ("normal", "axis", "direction"):
        if key in f:
            parts.append(f"{key} {_vec(f[key])}")
    for key, sym in (("diameter", "⌀"), ("major_diameter", "⌀ major"), ("minor_diameter", "⌀ minor")):
        if key in f:
            parts.append(f"{sym} {num.significant(f[key], 6)} mm")
    if "length" in f:
        parts.append(f"length {num.significant(f['length'], 5)} mm")
    if "angle" in f:
        parts.append(f"angle {num.significant(f['angle'], 5)}°")
    if "cad" in f:
        parts.append(f"CAD face {f['cad']}")
    return ", ".join(parts)


def _options(titles: dict[str, str]) -> list[dict[str, str]]:
    return [{"title": t, "value": k} for k, t in titles.items()]


class Characteristics:
    """The characteristics panel of ``page`` (a ComparePage)."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state
        self.session = page.session
        self.view = page.view
        self.task = task.GdtTask(page.host, page.session, page.project)
        self.job = Job("the characteristics", state=self.state, on_progress=self._progress)
        self.plan: dict[str, Any] = task.empty_plan()
        self.picking = False
        self.region: np.ndarray | None = None  # picked points of the nominal (mm)
        self.region_normals: np.ndarray | None = None  # their outward normals (a mesh's), None: unknown
        self.region_face: int | None = None  # the CAD face picked
        self._nominal: dict[str, Any] | None = None  # the nominal of the feature being defined
        self._face_type = ""  # the analytic type of the CAD face picked ("" none)
        self.evaluation: task.Evaluation | None = None
        self._init_state()
        self.load_saved()

    # -- state -----------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.ins_right = "charts"
        s.gdt_feature_types = _options({k: v for k, v in task.FEATURE_TITLES.items() if k != "face"})
        s.gdt_associations = _options(task.ASSOCIATION_TITLES)
        s.gdt_char_types = _options(task.CHARACTERISTIC_TITLES)
        s.gdt_align_options = _options(task.ALIGN_TITLES)
        s.gdt_sizes = list(task.SIZES)
        s.gdt_align = "best-fit"
        s.gdt_f_id = "F1"
        s.gdt_f_type = "sphere"
        s.gdt_f_assoc = "ls"
        s.gdt_f_radius = ""
        s.gdt_f_picked = ""
        s.gdt_f_nominal = ""
        s.gdt_f_ready = False
        s.gdt_picking = False
        s.gdt_d_label = "A"
        s.gdt_d_feature = None
        s.gdt_c_id = ""
        s.gdt_c_type = "diameter"
        s.gdt_c_feature = None
        s.gdt_c_datums = []
        s.gdt_c_tol = ""
        s.gdt_c_lower = ""
        s.gdt_c_upper = ""
        s.gdt_features = []
        s.gdt_datums = []
        s.gdt_chars = []
        s.gdt_feature_ids = []
        s.gdt_datum_labels = []
        s.gdt_running = False
        s.gdt_progress = ""
        s.gdt_results = []
        s.gdt_result_note = ""
        s.gdt_warnings = []
        s.gdt_links = []
        s.gdt_report_links = []
        s.gdt_file = None

    def _progress(self, fraction: float, message: str) -> None:
        self.state.gdt_progress = f"{message or 'evaluating'} {round(100 * fraction)} %"

    def error(self, msg: Any) -> None:
        self.page.error(msg)

    def _publish_plan(self, save: bool = True) -> None:
        """The plan's tables (and the choices they offer) in the state; kept in the project."""
        s, p = self.state, self.plan
        feats = p.get("features") or {}
        s.gdt_features = [
            {
                "id": fid,
                "type": task.FEATURE_TITLES.get(f.get("type"), str(f.get("type"))),
                "association": task.ASSOCIATION_TITLES.get(f.get("association", "ls"), ""),
                "nominal": feature_summary(f),
            }
            for fid, f in feats.items()
        ]
        s.gdt_feature_ids = list(feats)
        s.gdt_datums = [
            {"label": k, "feature": "-".join(v) if isinstance(v, list) else str(v)}
            for k, v in (p.get("datums") or {}).items()
        ]
        s.gdt_datum_labels = list(p.get("datums") or {})
        chars = []
        for c in p.get("characteristics") or []:
            t = result_texts({**c, "value": None}, p)["tolerance"]
            chars.append(
                {
                    "id": c["id"],
                    "title": task.char_title(c.get("type")),
                    "feature": c.get("feature"),
                    "datums": "|".join(c.get("datums") or []),
                    "tolerance": t,
                }
            )
        s.gdt_chars = chars
        if s.gdt_c_feature not in feats:
            s.gdt_c_feature = next(iter(feats), None)
        if s.gdt_d_feature not in feats:
            s.gdt_d_feature = next(iter(feats), None)
        s.gdt_f_id = task.next_id(feats, "F")
        s.gdt_d_label = next((c for c in "ABCDEFGHJKLMNPRSTUVWXYZ" if c not in (p.get("datums") or {})), "A")
        if save:
            try:
                self.task.save_plan(self.plan, self.request())
            except Exception as exc:  # shown, the plan stays in the page
                self.error(f"the plan could not be kept in the project: {one_line(exc)}")

    def load_saved(self) -> None:
        """The plan kept in the project (and its last evaluation), shown again."""
        try:
            rec = self.task.saved_plan()
        except Exception as exc:
            self.state.ins_error = one_line(exc)
            rec = None
        if rec is not None:
            self.plan = dict(rec["plan"])
            for key in ("features", "datums", "characteristics"):
                self.plan.setdefault(key, {} if key != "characteristics" else [])
            if rec.get("align") in task.ALIGNMENTS:
                self.state.gdt_align = rec["align"]
        self._publish_plan(save=False)
        try:
            ev = self.task.restore()
        except Exception as exc:
            self.state.ins_error = f"the last characteristics cannot be shown: {one_line(exc)}"
            ev = None
        if ev is not None:
            self.evaluation = ev
            self._publish_results(ev)
            self.state.gdt_report_links = self.report_links((ev.record or {}).get("report") or {})

    def request(self) -> task.GdtRequest:
        s = self.state
        return task.GdtRequest(s.ins_measured, s.ins_nominal, self.plan, str(s.gdt_align or "best-fit"))

    # -- features picked on the nominal ------------------------------------------------------
    def nominal(self) -> Any:
        key = self.state.ins_nominal
        if key in (None, ""):
            raise InputError("choose the nominal first: features are picked on it")
        return self.session.load(str(key))

    @staticmethod
    def normals(nominal: Any) -> np.ndarray | None:
        """The nominal's outward vertex normals (a mesh's or a CAD model's tessellation's);
        None for a cloud."""
        mesh = getattr(nominal, "mesh", nominal)
        if not hasattr(mesh, "vertices") or not hasattr(mesh, "faces"):
            return None
        return np.asarray(task.vertex_normals(mesh.vertices, mesh.faces))

    @staticmethod
    def vertices(nominal: Any) -> np.ndarray:
        """The nominal's points: a mesh's (or a CAD model's tessellation's) vertices, a cloud's points."""
        mesh = getattr(nominal, "mesh", nominal)
        if hasattr(mesh, "vertices"):
            return np.asarray(mesh.vertices, dtype=float)
        return np.asarray(mesh.points, dtype=float)

    def start_picking(self) -> bool:
        """Show the nominal alone: the next click in the view picks a region of it."""
        try:
            nominal = self.nominal()
        except Exception as exc:
            self.error(exc)
            return False
        self.picking = True
        self.state.gdt_picking = True
        self.view.show_inputs(None, getattr(nominal, "mesh", nominal), [], reset_camera=True)
        self.state.ins_mode = "inputs"
        self.state.ins_note = "click the nominal where the feature is; drag to turn"
        return True

    def stop_picking(self) -> None:
        self.picking = False
        self.state.gdt_picking = False

    def radius(self, nominal: Any) -> float:
        """The region's radius (mm): the field's, else a quarter of the nominal's diagonal."""
        text = str(self.state.gdt_f_radius or "").strip().replace(",", ".")
        if text:
            try:
                r = float(text)
            except ValueError:
                raise InputError(f"region radius: {text!r} is not a number (mm)") from None
            if not (math.isfinite(r) and r > 0):
                raise InputError(f"region radius: {text!r} must be a positive number (mm)")
            return r
        P = self.vertices(nominal)
        return 0.25 * float(np.linalg.norm(np.ptp(P, axis=0))) if len(P) else 1.0

    def pick(self, x: float, y: float) -> dict[str, Any] | None:
        """A click in the view while picking: the region of the nominal around the point
        under it (display pixels, y up)."""
        from .picking import pick_cell

        actor = self.view._actors.get("nominal")
        hit = pick_cell(self.view.renderer, actor, x, y) if actor is not None else None
        if hit is None:
            self.state.gdt_f_picked = "no surface of the nominal there; click on it"
            return None
        point, cell = hit
        return self.pick_point(point, cell)

    def pick_point(self, point: Any, cell: int | None = None) -> dict[str, Any] | None:
        """The region of the nominal around ``point`` (mm; ``cell`` the triangle picked): the
        CAD face of that triangle on a CAD model, else the vertices within the radius."""
        try:
            nominal = self.nominal()
            P = self.vertices(nominal)
            faces = getattr(nominal, "triangle_face", None)
            if faces is not None and cell is not None and 0 <= cell < len(faces):
                return self._pick_face(nominal, int(np.asarray(faces)[cell]))
            r = self.radius(nominal)
            idx = task.region(P, point, r)
        except Exception as exc:
            self.error(exc)
            return None
        p = [float(c) for c in np.asarray(point, dtype=float).ravel()[:3]]
        self.region, self.region_face, self._face_type = P[idx], None, ""
        N = self.normals(nominal)
        self.region_normals = None if N is None else N[idx]
        self.state.gdt_f_picked = (
            f"{num.count(len(idx))} points of the nominal within {num.significant(r, 3)} mm of {_vec(p)} mm"
        )
        self.view.set_markers([{"point": p, "label": "picked", "colour": "#6a1b9a"}])
        return self.fit()

    def pick_whole(self) -> dict[str, Any] | None:
        """The whole nominal as the region (a part that is one feature: the demo's ball)."""
        try:
            nominal = self.nominal()
            P = self.vertices(nominal)
        except Exception as exc:
            self.error(exc)
            return None
        self.region, self.region_face, self._face_type = P, None, ""
        self.region_normals = self.normals(nominal)
        self.state.gdt_f_picked = f"the whole nominal ({num.count(len(P))} points)"
        return self.fit()

    def _pick_face(self, nominal: Any, face: int) -> dict[str, Any] | None:
        """A face of a CAD model as the feature (``{type: face, cad: N}``, as the issue's
        plan writes it: the plugin takes its type and exact nominal from the CAD); the
        summary shows them, and the characteristic offered follows the face's type."""
        f = next((x for x in nominal.faces if int(x.index) == face), None)
        if f is None:
            raise InputError(f"CAD face {face}: not in the model")
        self.region, self.region_face = None, face
        kind = str(f.type)
        title = task.FEATURE_TITLES.get(kind, kind)
        self.state.gdt_f_picked = f"CAD face {face} ({title})"
        self._nominal = {"type": "face", "cad": face}
        exact = {k: np.asarray(v).tolist() for k, v in dict(f.params or {}).items()}
        self._face_type = kind
        self.state.gdt_f_nominal = f"CAD face {face}: {title}" + (f", {feature_summary(exact)}" if exact else "")
        self.state.gdt_f_ready = True
        return self._nominal

    def set_type(self, kind: str) -> dict[str, Any] | None:
        """A new type for the feature being defined: its nominal fitted again."""
        self.state.gdt_f_type = kind
        if self.region is not None:
            return self.fit()
        return None

    def fit(self) -> dict[str, Any] | None:
        """The nominal of the feature being defined from the region (a fit by the fitting
        plugin, :func:`camcmm.tasks.gdt.nominal_from_points`)."""
        s = self.state
        s.gdt_f_ready = False
        if self.region is None:
            return None
        try:
            fitted = task.nominal_from_points(self.page.host, s.gdt_f_type, self.region)
            if self.region_normals is not None:  # out of the material; a bore is internal
                fitted = task.orient(s.gdt_f_type, fitted, self.region, self.region_normals)
            params = {"type": s.gdt_f_type, **fitted}
        except Exception as exc:
            s.gdt_f_nominal = ""
            self.error(f"feature {s.gdt_f_id}: {one_line(exc)}")
            return None
        band = float(self.plan.get("band") or 0.5)
        if self.region is not None and len(self.region) < len(self.vertices(self.nominal())):
            params["box"] = task.box_of(self.region, band)
        self._nominal = params
        s.gdt_f_nominal = feature_summary(params)
        s.gdt_f_ready = True
        return params

    def add_feature(self) -> str | None:
        """The feature being defined added to the plan (its id as typed)."""
        s = self.state
        fid = str(s.gdt_f_id or "").strip()
        params = self._nominal
        if not s.gdt_f_ready or not params:
            self.error("pick the feature on the nominal first (Pick on nominal, or Whole nominal)")
            return None
        if not fid or not all(ch.isalnum() or ch in "-_" for ch in fid):
            self.error(f"feature id {fid!r}: letters, digits, - and _ only")
            return None
        f = dict(params)
        if s.gdt_f_assoc and s.gdt_f_assoc != "ls":
            f["association"] = s.gdt_f_assoc
        self.plan.setdefault("features", {})[fid] = f
        s.gdt_f_ready = False
        s.gdt_f_nominal = ""
        s.gdt_f_picked = ""
        self.region, self.region_normals, self._nominal = None, None, None
        self.stop_picking()
        s.gdt_c_feature = fid
        kind = self._face_type if f.get("type") == "face" else str(f.get("type"))
        s.gdt_c_type = DEFAULT_CHARACTERISTIC.get(kind, "surface-profile")
        self._face_type = ""
        self._publish_plan()
        s.gdt_c_id = self._char_id()
        return fid

    def remove_feature(self, fid: str) -> None:
        """A feature out of the plan, with its datums and characteristics."""
        p = self.plan
        (p.get("features") or {}).pop(fid, None)
        p["datums"] = {k: v for k, v in (p.get("datums") or {}).items() if v != fid and fid not in (v or [])}
        labels = set(p["datums"])
        p["characteristics"] = [
            c
            for c in p.get("characteristics") or []
            if c.get("feature") != fid and all(str(d) in labels for d in c.get("datums") or [])
        ]
        self._publish_plan()

    # -- datums and characteristics ---------------------------------------------------------
    def add_datum(self) -> str | None:
        s = self.state
        label = str(s.gdt_d_label or "").strip()
        if not label or not label.replace("-", "").isalnum():
            self.error(f"datum label {label!r}: letters and digits (A, B, C …)")
            return None
        if s.gdt_d_feature not in (self.plan.get("features") or {}):
            self.error("datum: choose the feature it is built on")
            return None
        self.plan.setdefault("datums", {})[label] = s.gdt_d_feature
        self._publish_plan()
        return label

    def remove_datum(self, label: str) -> None:
        (self.plan.get("datums") or {}).pop(label, None)
        self.plan["characteristics"] = [
            c for c in self.plan.get("characteristics") or [] if label not in (c.get("datums") or [])
        ]
        self._publish_plan()

    def _char_id(self) -> str:
        s = self.state
        stem = f"{s.gdt_c_type}-{s.gdt_c_feature}" if s.gdt_c_feature else str(s.gdt_c_type)
        taken = {c.get("id") for c in self.plan.get("characteristics") or []}
        return stem if stem not in taken else task.next_id(taken, stem + "-")

    def set_char(self, kind: Any = None, feature: Any = None) -> None:
        """A new type or feature of the characteristic being entered: its id follows."""
        s = self.state
        if kind:
            s.gdt_c_type = kind
        if feature:
            s.gdt_c_feature = feature
        s.gdt_c_id = self._char_id()

    def add_characteristic(self) -> str | None:
        """The characteristic in the fields added to the plan (checked with the plan)."""
        s = self.state
        c: dict[str, Any] = {
            "id": str(s.gdt_c_id or "").strip() or self._char_id(),
            "type": s.gdt_c_type,
            "feature": s.gdt_c_feature,
        }
        if s.gdt_c_datums:
            c["datums"] = list(s.gdt_c_datums)
        try:
            if s.gdt_c_type in task.SIZES:
                for key, text in (("lower", s.gdt_c_lower), ("upper", s.gdt_c_upper)):
                    if str(text or "").strip():
                        c[key] = task._number(text, f"{c['id']}: {key}")
            elif str(s.gdt_c_tol or "").strip():
                c["tolerance"] = task._number(s.gdt_c_tol, f"{c['id']}: tolerance", positive=True)
            trial = dict(self.plan, characteristics=[*(self.plan.get("characteristics") or []), c])
            task.check_plan(trial)
        except InputError as exc:
            self.error(exc)
            return None
        self.plan["characteristics"] = trial["characteristics"]
        self._publish_plan()
        s.gdt_c_id = self._char_id()
        return str(c["id"])

    def remove_characteristic(self, cid: str) -> None:
        self.plan["characteristics"] = [c for c in self.plan.get("characteristics") or [] if c.get("id") != cid]
        self._publish_plan()

    # -- YAML ----------------------------------------------------------------------------------
    def export_yaml(self) -> dict[str, str] | None:
        """The plan as YAML (``camcmm gdt evaluate``'s), offered for download."""
        text = task.plan_yaml(self.plan)
        link = self.page.offered.offer("plan.yaml", data=text.encode("utf-8"), kind="yaml", replace=True)
        if link:
            link["title"] = "plan.yaml (camcmm gdt evaluate)"
            self.state.gdt_links = [link]
        return link

    def import_yaml(self, content: Any, name: str = "plan.yaml") -> bool:
        """A plan file (uploaded bytes: YAML, JSON, or a QIF 3.0 file by its .qif name)
        replacing the plan being edited (kept in the project as gdt.plan)."""
        try:
            data = content if isinstance(content, (bytes, str)) else bytes(content)
            if str(name).lower().endswith(".qif"):  # read by the qif-import provider
                imported = self.task.import_qif(data, str(name))
                doc, note = imported.plan, imported.message()
            else:
                doc = task.read_plan_text(data, str(name))
                note = f"plan {name}: {len(doc['features'])} features, {len(doc['characteristics'])} characteristics"
        except Exception as exc:
            self.error(exc)
            return False
        self.plan = doc
        self._publish_plan()
        self.session.info(note)
        return True

    # -- running -------------------------------------------------------------------------------
    async def run_async(self) -> task.Evaluation | None:
        """Check the plan, evaluate it in the panel's job, show and store the result."""
        s = self.state
        if self.job.running:
            self.error("the characteristics are being evaluated; wait for it")
            return None
        try:
            checked = self.task.check(self.request())
        except Exception as exc:
            self.error(exc)
            return None
        s.gdt_running = True
        s.gdt_progress = "evaluating …"
        s.ins_error = ""
        self.page.flush()
        self.job.begin()
        try:
            ev = await self.job.call(self.task.run, checked, self.job.progress, self.job.cancel_event)
        except Exception as exc:
            s.gdt_running = False
            s.gdt_progress = "failed"
            self.error(one_line(exc, "" if isinstance(exc, InputError) else self.task.spec.id))
            self.page.flush()
            return None
        finally:
            self.job.end()
        self.evaluation = ev
        self._publish_results(ev)
        s.gdt_report_links = []
        s.gdt_running = False
        s.gdt_progress = "done"
        self.show()
        self.page.flush()
        try:
            record = await self.job.call(self.task.store, ev)
        except Exception as exc:
            self.error(f"the characteristics could not be stored in the project: {one_line(exc)}")
            return ev
        self.session.refresh_results()
        self.session.info(f"characteristics stored as result #{record['result']}")
        return ev

    def _publish_results(self, ev: task.Evaluation) -> None:
        s = self.state
        s.gdt_results = result_rows(ev.characteristics, ev.plan or self.plan)
        al = ev.outputs.get("alignment") or {}
        counts = {v: sum(1 for r in s.gdt_results if r["verdict"] == v) for v in task.VERDICTS}
        said = ", ".join(f"{n} {v}" for v, n in counts.items() if n)
        s.gdt_result_note = (
            f"alignment: {task.ALIGN_TITLES.get(str(al.get('method')), al.get('method'))}; {said}".rstrip("; ")
        )
        s.gdt_warnings = [str(w) for w in (ev.result.warnings or [])][:12]

    def flags(self) -> list[dict[str, Any]]:
        ev = self.evaluation
        if ev is None:
            return []
        plan = ev.plan or self.plan
        return flag_texts(ev.characteristics, ev.labels, lambda c: result_texts(c, plan))

    def show(self) -> bool:
        """The evaluation in the view: the aligned cloud, the nominal, the flags."""
        if self.evaluation is None:
            self.error("characteristics: run the plan first")
            return False
        self.stop_picking()
        nominal = None
        try:
            if self.state.ins_nominal:
                nominal = self.nominal()
        except Exception:
            nominal = None  # the flags are the result; the nominal is context
        show_flags(self.view, self.evaluation.outputs.get("aligned"), nominal, self.flags())
        self.state.ins_mode = "gdt"
        self.state.ins_note = self.view.note
        return True

    # -- report --------------------------------------------------------------------------------
    def _report_files(self, folder: Any) -> dict[str, str]:
        """Worker thread: the plugin's report in ``folder``, recorded in the project."""
        assert self.evaluation is not None
        return self.task.record_report(self.evaluation, self.task.write_report(self.evaluation, folder))

    async def report_async(self) -> list[dict[str, str]] | None:
        """The evaluation's own report (the plugin's writer: HTML, PDF, JSON) in the panel's
        job, added to the project and offered; None with the reason shown."""
        import shutil
        import tempfile
        from pathlib import Path

        if self.evaluation is None or self.job.running:
            self.error("characteristics report: run the plan first" if self.evaluation is None else "wait for the run")
            return None
        folder = Path(tempfile.mkdtemp(prefix="camcmm-gdt-report-"))
        try:
            files = await self.job.run(self._report_files, folder)
        except Exception as exc:
            self.error(f"characteristics report: {one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        self.state.gdt_report_links = self.report_links(files)
        self.session.refresh_results()
        self.page.flush()
        return self.state.gdt_report_links

    def report_links(self, files: dict[str, str]) -> list[dict[str, str]]:
        """Download links of the report's project files ``{report_<format>: hash}``."""
        from ...downloads import REPORT_TITLES, sort_links

        rid = (self.evaluation.record or {}).get("result") if self.evaluation is not None else None
        out = []
        for name, h in (files or {}).items():
            kind = name.removeprefix("report_")
            try:
                src = self.page.project.file_path(h)
            except Exception as exc:  # a file gone from the project: the others are offered
                log.warning("characteristics report %s: %s", name, exc)
                continue
            link = self.page.offered.offer(f"gdt-{rid}.{kind}", src, kind=kind, title=REPORT_TITLES.get(kind))
            if link:
                out.append(link)
        return sort_links(out)

    def report_extension(self) -> Any:
        """What the page's report adds for the characteristics (None: nothing evaluated)."""
        ev = self.evaluation
        if ev is None:
            return None
        plan = ev.plan or self.plan
        return lambda rep: task.report_section(rep, ev, lambda c: result_texts(c, plan))

    def close(self) -> None:
        self.job.close()
