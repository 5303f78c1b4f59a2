"""The acceptance-test wizard: logic apart from the page, testable without a browser.

The operator picks a standard (any installed plugin of kind ``standard`` that speaks the
standard protocol of docs/standards.md), the measuring system and the artefacts, then
imports one measurement per position the standard asks for. Each is evaluated at once
(fit, quality parameters, deviation colour map) and saved in the project as it
happens; a restart resumes where the test stopped. At the end the report is one click
away.

Two layers:

* :class:`Wizard` — the test on a project: setup, positions, import/redo, counters,
  summary, report. Plain Python on the project store and the standard protocol; no
  trame, no VTK. Importing a measurement is split into ``prepare`` (server loop) →
  ``evaluate`` (any thread: reads the file, runs the standard; touches no store) →
  ``record`` (server loop: stores file, measurement, deviations, result, state), so
  the GUI can run the slow middle in a worker; :meth:`Wizard.import_measurement` does
  all three in the calling thread.
* :class:`WizardPage` — publishes the wizard through the trame ``state`` (keys
  ``wz_*``) for :mod:`camcmm.gui.wizard_layout`, runs evaluations and the report in a
  worker thread, shows each deviation cloud in the session's 3D view and offers the
  report files for download.

Saved state (project state key ``acceptance.current``, the key the demo writes too)::

    {"standard": "vdi2634-2", "plan": {...the plan contract...},
     "measurements": {test: [measurement ids in position order]},
     "evaluations": {"<measurement id>": result id},
     "summary_result": result id or None, "report": {"report_html": hash, ...} or None,
     "verdict": ..., "verdict_guarded": ...,
     # written by the wizard (derived from measurement meta when absent, as in the demo):
     "positions": {test: {position id: [measurement id or None per repeat]}},
     "errors": {"test/position": one-line reason of the last failed import},
     "superseded": [{"test", "position", "repeat", "measurement", "result", "replaced"}],
     "tests": [tests in this run], "system_id": id, "artefact_ids": {test: id}}

A redo stores the new measurement and result and soft-deletes the replaced measurement
(nothing is deleted: results are immutable, the superseded list names them).
"""

from __future__ import annotations

import asyncio
import copy
import logging
import math
import shutil
import tempfile
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CamcmmError, InputError
from ..host import RunContext, default_host, to_jsonable

log = logging.getLogger("camcmm.gui.wizard")

STATE_KEY = "acceptance.current"
HISTORY_KEY = "acceptance.history"
#: Points of a deviations cloud handed to the report's colour maps.
REPORT_POINTS = 30_000

SYMBOLS = {"PF": "P_F", "PS": "P_S", "SD": "SD", "F": "F"}
SIGNED = ("PS", "SD")

#: The plan fields of each artefact kind (docs/standards.md), as the setup form shows
#: them: (key, label, unit, kind of value). Unknown kinds fall back to the catalogue's
#: own numbers.
ARTEFACT_FIELDS: dict[str, list[tuple[str, str, str, str]]] = {
    "sphere": [("diameter", "Diameter (calibrated)", "mm", "number"),
               ("uncertainty", "Its uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number")],
    "ball_bar": [("length", "Length (calibrated)", "mm", "number"),
                 ("uncertainty", "Its uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number"),
                 ("sphere_diameter", "Sphere diameter", "mm", "number")],
    "flat": [("length", "Length", "mm", "number"), ("width", "Width", "mm", "number"),
             ("flatness", "Flatness (calibrated)", "mm", "number"),
             ("flatness_uncertainty", "Its uncertainty U", "mm", "number")],
    "ball_plate": [("sphere_diameter", "Sphere diameter", "mm", "number"),
                   ("lengths", "Lengths L1, L2, L3 (calibrated)", "mm", "vector"),
                   ("uncertainty", "Their uncertainty U", "mm", "number"), ("k", "Coverage factor k", "", "number")],
}


# -- the artefact catalogue -------------------------------------------------------------------
def resources_dir() -> Path:
    """The repository's ``resources/`` folder (artefact catalogue, UI assets)."""
    import camcmm

    return Path(camcmm.__file__).resolve().parents[2] / "resources"


def load_catalogue(path: str | Path | None = None) -> list[dict[str, Any]]:
    """The shipped artefact catalogue (``resources/artefacts.yaml``) as Artefact dicts;
    an empty list (logged) when it is missing or unreadable."""
    import yaml

    path = Path(path) if path is not None else resources_dir() / "artefacts.yaml"
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    except (OSError, yaml.YAMLError) as exc:
        log.warning("artefact catalogue %s: %s", path, exc)
        return []
    out = []
    for a in doc.get("artefacts") or []:
        if isinstance(a, dict) and a.get("id") and a.get("kind"):
            out.append({"id": str(a["id"]), "kind": str(a["kind"]), "name": str(a.get("name") or a["id"]),
                        "nominal": dict(a.get("nominal") or {}), "certificates": dict(a.get("certificates") or {}),
                        "source": "catalogue"})
    return out


def artefact_plan_fields(artefact: dict[str, Any]) -> dict[str, Any]:
    """An Artefact dict (catalogue or project) as the plan's artefact entry: nominal
    values, each certificate's value under its name, the first certificate's U and k as
    ``uncertainty``/``k`` and every certificate's U as ``<name>_uncertainty``."""
    out: dict[str, Any] = {k: v for k, v in (artefact.get("nominal") or {}).items() if k not in ("id", "name")}
    certs = artefact.get("certificates") or {}
    for i, (name, c) in enumerate(certs.items()):
        if not isinstance(c, dict) or "value" not in c:
            continue
        out[name] = c["value"]
        u = c.get("uncertainty")
        if u is not None:
            out[f"{name}_uncertainty"] = u
        if i == 0:
            if u is not None:
                out["uncertainty"] = u
            out["k"] = c.get("k", 2)
    return out


def _u_key(kind: str, key: str) -> str:
    """The plan key of a calibrated value's uncertainty (docs/standards.md)."""
    return "uncertainty" if (kind, key) in (("sphere", "diameter"), ("ball_bar", "length")) else f"{key}_uncertainty"


def plan_fields_to_artefact(kind: str, fields: dict[str, Any], aid: str, name: str) -> dict[str, Any]:
    """The inverse for the project store: the plan's artefact entry as an Artefact dict
    (values with an uncertainty, and the calibrated main value, as certificates; the
    rest nominal)."""
    k = float(fields.get("k") or 2.0)
    certs: dict[str, Any] = {}
    nominal: dict[str, Any] = {}
    main = {"sphere": "diameter", "ball_bar": "length", "flat": "flatness"}.get(kind)
    for key, v in fields.items():
        if key in ("k", "uncertainty") or key.endswith("_uncertainty") or v is None:
            continue
        if kind == "ball_plate" and key == "lengths" and isinstance(v, list):
            nominal[key] = v
            for i, x in enumerate(v):
                certs[f"length_{i + 1}"] = {"value": float(x), "uncertainty": float(fields.get("uncertainty") or 0.0),
                                            "k": k}
        elif key == main or _u_key(kind, key) in fields:
            certs[key] = {"value": float(v), "uncertainty": float(fields.get(_u_key(kind, key)) or 0.0), "k": k}
        else:
            nominal[key] = v
    return {"id": aid, "kind": kind, "name": name, "nominal": nominal, "certificates": certs}


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool):
        raise InputError(f"{what}: {value!r} is not a number")
    if isinstance(value, (int, float)):
        v = float(value)
    else:
        text = str(value if value is not None else "").strip().replace(",", ".")
        if not text:
            raise InputError(f"{what} is empty; enter a number")
        try:
            v = float(text)
        except ValueError:
            raise InputError(f"{what}: {value!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"{what}: {value!r} is not a finite number")
    return v


def _vector(value: Any, what: str, n: int = 3) -> list[float]:
    if isinstance(value, str):
        parts = [p for p in value.replace(";", " ").replace(",", " ").split() if p]
    elif isinstance(value, (list, tuple)):
        parts = list(value)
    else:
        parts = [value]
    if len(parts) != n:
        raise InputError(f"{what}: give {n} numbers, got {value!r}")
    return [_number(p, f"{what}[{i}]") for i, p in enumerate(parts)]


#: Plan keys the setup form owns; the advanced options may not replace them.
_FORM_KEYS = ("standard", "system", "mpe", "artefacts", "measurements")


def parse_options(options: Any) -> dict[str, Any]:
    """More plan keys from the setup's advanced field: a dict or YAML text."""
    import yaml

    if options is None or (isinstance(options, str) and not options.strip()):
        return {}
    if isinstance(options, str):
        try:
            options = yaml.safe_load(options)
        except yaml.YAMLError as exc:
            raise InputError(f"plan options: not valid YAML ({' '.join(str(exc).split())})") from None
    if not isinstance(options, dict):
        raise InputError(f"plan options: give keys and values (e.g. 'outliers: vdi2634'), got {options!r}")
    taken = [k for k in options if k in _FORM_KEYS]
    if taken:
        raise InputError(f"plan options: {taken[0]!r} is set by the form above, not here")
    return dict(options)


def _same_value(a: Any, b: Any) -> bool:
    """Equal as numbers when both read as numbers (the browser sends 20.0 back as 20)."""
    def nums(x: Any) -> list[float]:
        if isinstance(x, (list, tuple)):
            return [float(v) for v in x]
        return [float(p) for p in str(x).replace(",", " ").replace(";", " ").split()]

    try:
        return nums(a) == nums(b)
    except (TypeError, ValueError):
        return str(a).strip() == str(b).strip()


def fmt_mm(v: Any, signed: bool = False) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{float(v):+.4f} mm" if signed else f"{float(v):.4f} mm"


def _verdict(value: Any, mpe: float | None) -> str:
    from ..conformity import combine, simple_verdict

    if mpe is None:
        return "incomplete"
    if isinstance(value, list):
        return combine(simple_verdict(v, mpe) for v in value)
    return simple_verdict(value, mpe)


def _run_dict(plugin: str, version: str, params: dict, hashes: dict, outputs: dict, started: str,
              warnings: list[str]) -> dict[str, Any]:
    from ..project.store import utcnow

    return {"plugin": plugin, "version": version, "params": params, "input_hashes": hashes,
            "outputs": to_jsonable(outputs), "started": started, "finished": utcnow(),
            "warnings": [str(w) for w in warnings]}


def _one_line(exc: BaseException, name: str = "") -> str:
    msg = str(exc) if isinstance(exc, CamcmmError) else f"{type(exc).__name__}: {exc}"
    msg = " ".join(msg.split()) or type(exc).__name__
    if name and name not in msg:
        msg = f"{name}: {msg}"
    return msg


@dataclass
class Job:
    """One import for one position: what ``prepare`` decided, ``evaluate`` computed."""

    test: str
    position: str
    repeat: int
    name: str = ""
    path: Path | None = None
    temp: Path | None = None  # a temp folder to remove after recording
    cloud: Any = None
    evaluation: dict[str, Any] | None = None
    started: str = ""
    error: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def key(self) -> str:
        return f"{self.test}/{self.position}"


class Wizard:
    """An acceptance test on a project, saved under :data:`STATE_KEY` as it happens."""

    def __init__(self, project: Any, host: Any = None):
        self.project = project
        self.host = host if host is not None else default_host()
        self.state: dict[str, Any] | None = None
        self._std: Any = None
        self._reqs: list[dict[str, Any]] | None = None
        self._outputs: dict[int, dict[str, Any]] = {}  # result id -> stored evaluation
        self._lock = threading.RLock()
        self.load_error = ""
        self.resume()

    # -- standards and catalogue ---------------------------------------------------------
    def standards(self) -> list[dict[str, Any]]:
        """Installed standard plugins that load: ``{"id", "name", "version", "summary"}``."""
        out = []
        for spec in self.host.all():
            if spec.kind != "standard":
                continue
            if spec.status != "ok":
                try:
                    self.host.load(spec.id)
                except CamcmmError:
                    continue
            out.append({"id": spec.id, "name": spec.name, "version": spec.version, "summary": spec.summary})
        return out

    def standard(self, sid: str | None = None) -> Any:
        """The standard object (``host.load``) of ``sid`` or of the running test."""
        sid = sid or (self.state or {}).get("standard")
        if not sid:
            raise InputError("no standard chosen yet")
        if sid == (self.state or {}).get("standard") and self._std is not None:
            return self._std
        obj = self.host.load(sid)
        for attr in ("requirements", "evaluate_measurement", "summarize", "write_report"):
            if not callable(getattr(obj, attr, None)):
                raise InputError(f"standard plugin {sid!r} lacks {attr}(); it does not speak the standard protocol "
                                 "of docs/standards.md")
        return obj

    def catalogue(self) -> list[dict[str, Any]]:
        """Artefacts to choose from: the shipped catalogue, then the project's own
        (entered earlier; those replace a shipped one of the same id)."""
        items = {a["id"]: a for a in load_catalogue()}
        try:
            own = [a.to_dict() for a in self.project.artefacts()]
        except Exception:  # an older store without artefacts: the catalogue suffices
            own = []
        for a in own:
            items[a["id"]] = {**a, "source": "project"}
        return list(items.values())

    def setup_tests(self, sid: str) -> list[dict[str, Any]]:
        """The tests of standard ``sid`` before a plan exists: test, label, parameters,
        required, positions count."""
        std = self.standard(sid)
        return [{"test": r["test"], "label": r.get("label") or r["test"], "parameters": list(r.get("parameters") or []),
                 "required": bool(r.get("required", True)), "min_count": int(r.get("min_count") or 0),
                 "repeats": int(r.get("repeats") or 1), "n_positions": len(r.get("positions") or [])}
                for r in std.requirements(None)]

    # -- setup ---------------------------------------------------------------------------
    def build_plan(self, standard: str, system_name: str, measuring_volume: Any, mpe: dict[str, Any],
                   artefacts: dict[str, dict[str, Any]], options: Any = None) -> dict[str, Any]:
        """The plan dict from the setup form; values are checked here (one line naming
        the field) and by the standard (``requirements(plan)``). ``options``: more plan
        keys (a dict or YAML text: outliers, scaling, repeats, unit, options ...)."""
        name = str(system_name or "").strip()
        if not name:
            raise InputError("measuring system: give it a name")
        vol = _vector(measuring_volume, "measuring volume")
        if min(vol) <= 0:
            raise InputError(f"measuring volume: every edge must be > 0 mm, got {vol}")
        mpes = {}
        for key, v in (mpe or {}).items():
            if v is None or (isinstance(v, str) and not v.strip()):
                continue
            mpes[key] = _number(v, f"MPE {SYMBOLS.get(key, key)}")
        arts: dict[str, dict[str, Any]] = {}
        for test, fields_ in (artefacts or {}).items():
            spec = ARTEFACT_FIELDS.get(test)
            values = {k: v for k, v in (fields_ or {}).items() if not k.startswith("_")}
            if spec is None:
                arts[test] = values
                continue
            entry: dict[str, Any] = {}
            for key, label, _unit, kind in spec:
                v = values.get(key)
                if v is None or (isinstance(v, str) and not v.strip()):
                    continue
                what = f"artefact {test.replace('_', ' ')}: {label.lower()}"
                entry[key] = _vector(v, what) if kind == "vector" else _number(v, what)
            for key, v in values.items():  # extra calibrated values from the catalogue
                if key not in entry and isinstance(v, (int, float)) and not isinstance(v, bool):
                    entry[key] = float(v)
            for meta in ("id", "name"):
                if (fields_ or {}).get(f"_{meta}"):
                    entry[meta] = str(fields_[f"_{meta}"])
            arts[test] = entry
        plan = {"standard": standard, "system": {"name": name, "measuring_volume": vol}, "mpe": mpes,
                "artefacts": arts, "measurements": {},
                "name": f"{getattr(self.project, 'name', 'project')} (acceptance-test wizard)"}
        plan.update(parse_options(options))
        self.standard(standard).requirements(copy.deepcopy(plan))  # the standard checks the plan
        return plan

    def setup(self, standard: str, system_name: str, measuring_volume: Any, mpe: dict[str, Any],
              artefacts: dict[str, dict[str, Any]], tests: list[str] | None = None, options: Any = None
              ) -> dict[str, Any]:
        """Start a new test (the running one, if any, goes to the history: its results
        stay in the project). Returns the new state."""
        from ..project.store import utcnow

        std = self.standard(standard)
        available = {r["test"]: r for r in std.requirements(None)}
        chosen = [t for t, r in available.items() if r.get("required", True) or t in (tests or [])]
        for t in chosen:
            for param in available[t].get("parameters") or []:
                v = (mpe or {}).get(param)
                if v is None or (isinstance(v, str) and not v.strip()):
                    raise InputError(f"MPE {SYMBOLS.get(param, param)} is empty; enter it from the measuring "
                                     "system's specification")
        plan = self.build_plan(standard, system_name, measuring_volume, mpe,
                               {t: a for t, a in (artefacts or {}).items() if t in chosen}, options)
        missing = [t for t in chosen if t not in plan["artefacts"]]
        if missing:
            raise InputError(f"artefact {missing[0].replace('_', ' ')} is missing; the test needs it")
        with self._lock:
            self._archive()
            sid = self.project.add_system(plan["system"]["name"], {"measuring_volume": plan["system"]["measuring_volume"],
                                                                  "standard": standard})
            art_ids = {}
            for test, entry in plan["artefacts"].items():
                aid = str((artefacts.get(test) or {}).get("_id") or "") or f"{test}-own"
                name = str((artefacts.get(test) or {}).get("_name") or "") or f"own {test.replace('_', ' ')}"
                try:
                    art_ids[test] = self.project.add_artefact(plan_fields_to_artefact(test, entry, aid, name))
                except CamcmmError as exc:
                    log.warning("artefact %s not saved in the project: %s", aid, exc)
            state = {"standard": standard, "plan": plan, "measurements": {}, "evaluations": {}, "positions": {},
                     "errors": {}, "superseded": [], "tests": chosen, "system_id": sid, "artefact_ids": art_ids,
                     "summary_result": None, "report": None, "verdict": None, "verdict_guarded": None,
                     "created": utcnow()}
            self.state = state
            self._std = std
            self._reqs = None
            self._outputs = {}
            self._save()
        return state

    def _archive(self) -> None:
        if not self.state:
            return
        try:
            history = list(self.project.get_state(HISTORY_KEY, []) or [])
            history.append({k: self.state.get(k) for k in ("standard", "created", "summary_result", "verdict",
                                                            "verdict_guarded", "measurements", "evaluations")})
            self.project.set_state(HISTORY_KEY, history)
        except CamcmmError as exc:
            log.warning("could not keep the previous test in the history: %s", exc)

    # -- resume --------------------------------------------------------------------------
    def resume(self) -> bool:
        """Read the saved test (``acceptance.current``); True if there is one to go on
        with. A test whose standard is not installed is kept, with :attr:`load_error`."""
        self.load_error = ""
        try:
            state = self.project.get_state(STATE_KEY)
        except CamcmmError as exc:
            self.load_error = f"cannot read the saved acceptance test: {exc}"
            return False
        if not isinstance(state, dict) or not state.get("standard") or not isinstance(state.get("plan"), dict):
            self.state = None
            return False
        state.setdefault("measurements", {})
        state.setdefault("evaluations", {})
        state.setdefault("errors", {})
        state.setdefault("superseded", [])
        self.state = state
        self._std = None
        self._reqs = None
        self._outputs = {}
        try:
            self._std = self.standard(state["standard"])
        except CamcmmError as exc:
            self.load_error = (f"the acceptance test in this project uses standard {state['standard']!r}, "
                               f"which cannot be loaded: {exc}")
            return False
        if not isinstance(state.get("positions"), dict) or not state["positions"]:
            state["positions"] = self._derive_positions()
        return True

    def _derive_positions(self) -> dict[str, dict[str, list]]:
        """Positions of a state written without them (the demo): from each measurement's
        meta ``position``/``repeat``, else from its place in the list."""
        out: dict[str, dict[str, list]] = {}
        reqs = {r["test"]: r for r in self.requirements()}
        for test, mids in (self.state or {}).get("measurements", {}).items():
            r = reqs.get(test)
            if r is None:
                continue
            reps = r["repeats"]
            ids = [p["id"] for p in r["positions"]]
            slots = {pid: [None] * reps for pid in ids}
            for i, mid in enumerate(mids):
                try:
                    meta = self.project.measurement(int(mid)).get("meta") or {}
                except CamcmmError:
                    meta = {}
                pos = meta.get("position")
                rep = int(meta.get("repeat") or 1)
                if pos not in slots:
                    if i // reps >= len(ids):
                        continue
                    pos, rep = ids[i // reps], i % reps + 1
                if 1 <= rep <= reps:
                    slots[pos][rep - 1] = int(mid)
            out[test] = slots
        return out

    # -- the running test ----------------------------------------------------------------
    @property
    def active(self) -> bool:
        return bool(self.state) and not self.load_error

    @property
    def plan(self) -> dict[str, Any]:
        if not self.state:
            raise InputError("no acceptance test set up yet")
        return self.state["plan"]

    def requirements(self) -> list[dict[str, Any]]:
        """Per test of this run: test, label, parameters, min_count, repeats, positions
        (from ``std.requirements(plan)``; an optional test the operator added but has no
        measurement yet comes from the standard's own list)."""
        if self._reqs is not None:
            return self._reqs
        std = self.standard()
        plan = copy.deepcopy(self.plan)
        got = {r["test"]: r for r in std.requirements(plan)}
        wanted = list((self.state or {}).get("tests") or got)
        if any(t not in got for t in wanted):
            for r in std.requirements(None):
                if r["test"] in wanted and r["test"] not in got:
                    got[r["test"]] = r
        order = [t for t in wanted if t in got] + [t for t in got if t not in wanted]
        reqs = []
        for t in order:
            r = got[t]
            reqs.append({"test": t, "label": r.get("label") or t, "parameters": list(r.get("parameters") or []),
                         "min_count": int(r.get("min_count") or len(r.get("positions") or [])),
                         "repeats": max(1, int(r.get("repeats") or 1)), "required": bool(r.get("required", True)),
                         "positions": list(r.get("positions") or []), "artefact": r.get("artefact")})
        self._reqs = reqs
        return reqs

    def _req(self, test: str) -> dict[str, Any]:
        for r in self.requirements():
            if r["test"] == test:
                return r
        raise InputError(f"this test has no {test.replace('_', ' ')} measurements; its tests: "
                         f"{', '.join(r['test'] for r in self.requirements())}")

    def _slots(self, test: str) -> dict[str, list]:
        r = self._req(test)
        positions = self.state.setdefault("positions", {}).setdefault(test, {})
        for p in r["positions"]:
            slot = positions.setdefault(p["id"], [None] * r["repeats"])
            if len(slot) < r["repeats"]:
                slot.extend([None] * (r["repeats"] - len(slot)))
        return positions

    def evaluation(self, mid: int | None) -> dict[str, Any] | None:
        """The stored evaluation (result outputs) of a measurement of this test."""
        if mid is None:
            return None
        rid = (self.state or {}).get("evaluations", {}).get(str(mid))
        if rid is None:
            return None
        rid = int(rid)
        if rid not in self._outputs:
            try:
                self._outputs[rid] = dict(self.project.result(rid).get("outputs") or {})
            except CamcmmError as exc:
                return {"error": f"its stored result {rid} cannot be read: {exc}"}
        return self._outputs[rid]

    def progress(self) -> list[dict[str, Any]]:
        """Counters per test: ``{"test", "label", "done", "total", "required", "text",
        "complete"}`` — text like "7 of 10 sphere positions"."""
        out = []
        for r in self.requirements():
            slots = self._slots(r["test"])
            done = sum(1 for p in r["positions"] for mid in slots[p["id"]]
                       if mid is not None and not (self.evaluation(mid) or {}).get("error"))
            total = len(r["positions"]) * r["repeats"]
            required = r["min_count"] * r["repeats"]
            label = r["label"][:1].lower() + r["label"][1:]
            text = f"{done} of {total} {label}"
            if r["repeats"] > 1:
                text = f"{done} of {total} measurements of {label} ({len(r['positions'])} × {r['repeats']} repeats)"
            out.append({"test": r["test"], "label": r["label"], "done": done, "total": total, "required": required,
                        "text": text, "complete": done >= required})
        return out

    @property
    def complete(self) -> bool:
        return self.active and all(p["complete"] for p in self.progress())

    def cards(self) -> list[dict[str, Any]]:
        """Per test its position cards: id, label, hint, status (pending | done |
        error), the values with unit and per-position verdict, the error, the fit."""
        mpe = self.plan.get("mpe") or {}
        errors = (self.state or {}).get("errors") or {}
        blocks = []
        prog = {p["test"]: p for p in self.progress()}
        for r in self.requirements():
            slots = self._slots(r["test"])
            cards = []
            for p in r["positions"]:
                key = f"{r['test']}/{p['id']}"
                reps = []
                for i, mid in enumerate(slots[p["id"]]):
                    ev = self.evaluation(mid)
                    reps.append(self._repeat_view(r["test"], i + 1, mid, ev, mpe))
                done = [x for x in reps if x["status"] == "done"]
                status = "done" if len(done) == len(reps) else ("partial" if done else "pending")
                if status != "done" and errors.get(key):
                    status = "error"
                from ..conformity import combine

                cards.append({"key": key, "test": r["test"], "id": p["id"], "label": p.get("label") or p["id"],
                              "hint": p.get("hint") or "", "status": status, "error": errors.get(key, ""),
                              "repeats": reps, "n_repeats": r["repeats"],
                              "verdict": combine(x["verdict"] for x in reps) if done else "",
                              "next_repeat": next((x["repeat"] for x in reps if x["status"] != "done"), None)})
            blocks.append({"test": r["test"], "label": r["label"], "progress": prog[r["test"]], "cards": cards})
        return blocks

    def _repeat_view(self, test: str, repeat: int, mid: Any, ev: dict | None, mpe: dict) -> dict[str, Any]:
        if mid is None or ev is None:
            return {"repeat": repeat, "status": "pending", "values": [], "verdict": "", "measurement": None,
                    "file": "", "fit": "", "warnings": []}
        if ev.get("error"):
            return {"repeat": repeat, "status": "error", "values": [], "verdict": "", "measurement": int(mid),
                    "file": ev.get("file") or "", "fit": ev["error"], "warnings": []}
        values = []
        from ..conformity import combine

        verdicts = []
        for param, v in (ev.get("values") or {}).items():
            verdict = _verdict(v, mpe.get(param))
            verdicts.append(verdict)
            shown = ", ".join(fmt_mm(x, param in SIGNED) for x in v) if isinstance(v, list) else fmt_mm(v, param in SIGNED)
            values.append({"param": param, "symbol": SYMBOLS.get(param, param), "text": shown, "verdict": verdict,
                           "mpe": mpe.get(param)})
        return {"repeat": repeat, "status": "done", "values": values, "verdict": combine(verdicts),
                "measurement": int(mid), "file": ev.get("file") or "", "fit": fit_text(ev),
                "warnings": list(ev.get("warnings") or [])}

    # -- import: prepare (loop) -> evaluate (any thread) -> record (loop) --------------------
    def prepare(self, test: str, position: str, repeat: int | None = None) -> Job:
        """Check the position and pick its repeat slot: ``repeat`` (a redo) or the first
        empty one; a position whose slots are all filled is redone at its last repeat."""
        from ..project.store import utcnow

        if not self.active:
            raise InputError(self.load_error or "set up the acceptance test first")
        r = self._req(test)
        ids = [p["id"] for p in r["positions"]]
        if position not in ids:
            raise InputError(f"{test.replace('_', ' ')} has no position {position!r}; its positions: "
                             f"{', '.join(ids)}")
        slots = self._slots(test)[position]
        if repeat is None:
            repeat = next((i + 1 for i, mid in enumerate(slots) if mid is None), len(slots))
        if not 1 <= int(repeat) <= len(slots):
            raise InputError(f"{position}: repeat {repeat} is outside 1..{len(slots)}")
        return Job(test, position, int(repeat), started=utcnow())

    def evaluate(self, job: Job, source: str | Path | bytes, name: str | None = None) -> Job:
        """Read the file and evaluate it with the standard. Thread-safe: touches neither
        the store nor the wizard's state. Raises a one-line CamcmmError naming the file."""
        from .. import io as cio

        if isinstance(source, (bytes, bytearray, memoryview)):
            from .session import safe_name

            job.name = safe_name(name or "upload")
            job.temp = Path(tempfile.mkdtemp(prefix="camcmm-wizard-"))
            job.path = job.temp / job.name
            job.path.write_bytes(bytes(source))
        else:
            job.path = Path(source)
            job.name = name or job.path.name
            if not job.path.is_file():
                raise InputError(f"{job.name}: no such file" if not job.path.exists() else f"{job.name}: is not a file")
        try:
            cloud = cio.read(job.path, unit=(self.state or {}).get("plan", {}).get("unit"))
        except Exception as exc:
            raise InputError(_one_line(exc, job.name).replace(str(job.path), job.name)) from exc
        if not hasattr(cloud, "n_points"):
            raise InputError(f"{job.name}: holds a {type(cloud).__name__.lower()}, not a point cloud")
        if cloud.n_points == 0:
            raise InputError(f"{job.name}: the file holds no points")
        with self._lock:  # the loop may be recording another position meanwhile
            plan = copy.deepcopy(self.plan)
            sid = self.state["standard"]
        std = self.standard(sid)
        ctx = RunContext(self.host, sid)
        try:
            ev = std.evaluate_measurement(ctx, job.test, cloud, plan, file=job.name,
                                          position=job.position, repeat=job.repeat)
        except CamcmmError as exc:
            raise type(exc)(_one_line(exc, job.name)) from exc
        except Exception as exc:  # a plugin bug: one line naming the file and the standard
            raise InputError(f"{job.name}: {sid} failed: {_one_line(exc)}") from exc
        if not isinstance(ev, dict):
            raise InputError(f"{job.name}: {sid} returned {type(ev).__name__}, not a dict")
        ev = dict(ev)
        ev.setdefault("test", job.test)
        ev["file"], ev["position"], ev["repeat"] = job.name, job.position, job.repeat
        for w in ctx.warnings:
            ev.setdefault("warnings", [])
            if w not in ev["warnings"]:
                ev["warnings"].append(w)
        job.cloud, job.evaluation = cloud, ev
        return job

    def record(self, job: Job) -> dict[str, Any]:
        """Store an evaluated job: its file, measurement, deviations and result; the
        replaced measurement (a redo) is soft-deleted; the state is saved. Returns the
        position's card."""
        from ..project.store import utcnow

        assert job.evaluation is not None and job.path is not None
        with self._lock:
            std_id = self.state["standard"]
            version = self.host.get(std_id).version
            ev = dict(job.evaluation)
            deviations = ev.pop("deviations", None)
            h = self.project.add_file(job.path)
            ev["sha256"] = h
            meta = {"standard": std_id, "test": job.test, "position": job.position, "repeat": job.repeat,
                    "file": job.name, "summary": f"{getattr(job.cloud, 'n_points', 0)} points"}
            mid = self.project.add_measurement(f"{job.position} ({job.name})", h, kind="pointcloud",
                                               system_id=self.state.get("system_id"),
                                               artefact_id=(self.state.get("artefact_ids") or {}).get(job.test),
                                               meta=meta)
            files = {}
            if deviations is not None and hasattr(deviations, "n_points"):
                files["deviations"] = self.project.add_object(deviations, f"{job.position} deviations")
            params = {"test": job.test, "position": job.position, "repeat": job.repeat}
            rid = self.project.add_result(_run_dict(std_id, version, params, {"cloud": h}, ev, job.started,
                                                    list(ev.get("warnings") or [])),
                                          [mid], files, label=f"{std_id} {job.position}")
            slots = self._slots(job.test)[job.position]
            old = slots[job.repeat - 1]
            if old is not None:
                self.state["superseded"].append({"test": job.test, "position": job.position, "repeat": job.repeat,
                                                 "measurement": old,
                                                 "result": self.state["evaluations"].get(str(old)),
                                                 "replaced": utcnow()})
            slots[job.repeat - 1] = mid
            self.state["evaluations"][str(mid)] = rid
            self.state["errors"].pop(job.key, None)
            self._outputs[rid] = to_jsonable(ev)
            self._stale_summary()
            self._sync_measurements()
            self._save()
            if old is not None:
                try:
                    self.project.remove_measurement(int(old))
                except CamcmmError as exc:
                    log.warning("replaced measurement %s stays listed: %s", old, exc)
        job.extra.update(measurement=mid, result=rid, deviations=deviations)
        self._cleanup(job)
        return self.card(job.test, job.position)

    def fail(self, job: Job, exc: BaseException) -> str:
        """Remember why an import failed, for that position only; returns the message."""
        msg = _one_line(exc, job.name)
        job.error = msg
        with self._lock:
            if self.state is not None:
                self.state.setdefault("errors", {})[job.key] = msg
                try:
                    self._save()
                except CamcmmError as e:
                    log.warning("could not save the error of %s: %s", job.key, e)
        self._cleanup(job)
        return msg

    @staticmethod
    def _cleanup(job: Job) -> None:
        if job.temp is not None:
            shutil.rmtree(job.temp, ignore_errors=True)
            job.temp = None

    def import_measurement(self, test: str, position: str, source: str | Path | bytes, name: str | None = None,
                           repeat: int | None = None) -> dict[str, Any]:
        """Import, evaluate and store one measurement in the calling thread. Returns the
        position's card; a bad file gives the card with ``status`` "error" and the
        reason (nothing else changes)."""
        job = self.prepare(test, position, repeat)
        try:
            self.evaluate(job, source, name)
        except Exception as exc:
            self.fail(job, exc)
            return self.card(test, position)
        return self.record(job)

    def redo(self, test: str, position: str, source: str | Path | bytes, name: str | None = None,
             repeat: int | None = None) -> dict[str, Any]:
        """Measure a position again: the new evaluation replaces the old one (of
        ``repeat``, default the last filled repeat)."""
        if repeat is None:
            slots = self._slots(test).get(position) or []
            filled = [i + 1 for i, mid in enumerate(slots) if mid is not None]
            repeat = filled[-1] if filled else None
        return self.import_measurement(test, position, source, name, repeat)

    def card(self, test: str, position: str) -> dict[str, Any]:
        for block in self.cards():
            for c in block["cards"]:
                if c["test"] == test and c["id"] == position:
                    return c
        raise InputError(f"no position {position!r} in {test}")

    def _sync_measurements(self) -> None:
        """``measurements`` (position order) and the plan's measurement list follow the slots."""
        ms: dict[str, list[int]] = {}
        plan_ms: dict[str, list[dict[str, Any]]] = {}
        for r in self.requirements():
            slots = self._slots(r["test"])
            for p in r["positions"]:
                for i, mid in enumerate(slots[p["id"]]):
                    if mid is None:
                        continue
                    ms.setdefault(r["test"], []).append(int(mid))
                    ev = self.evaluation(mid) or {}
                    plan_ms.setdefault(r["test"], []).append({"file": ev.get("file") or f"measurement-{mid}",
                                                               "position": p["id"], "repeat": i + 1})
        self.state["measurements"] = ms
        self.state["plan"]["measurements"] = plan_ms
        self._reqs = None

    def _stale_summary(self) -> None:
        """A changed measurement makes a written report stale (it stays in the project)."""
        if self.state.get("summary_result") is not None:
            self.state.setdefault("reports", []).append({"summary_result": self.state["summary_result"],
                                                         "report": self.state.get("report")})
        self.state.update({"summary_result": None, "report": None, "verdict": None, "verdict_guarded": None})

    def _save(self) -> None:
        from ..project.store import utcnow

        self.state["updated"] = utcnow()
        self.project.set_state(STATE_KEY, self.state)

    # -- summary and report ----------------------------------------------------------------
    def per_measurement(self, with_deviations: bool = False) -> dict[str, list[dict[str, Any]]]:
        """The stored evaluations per test, in position order (the summary's input)."""
        per: dict[str, list[dict[str, Any]]] = {}
        for r in self.requirements():
            slots = self._slots(r["test"])
            evs = per.setdefault(r["test"], [])
            for p in r["positions"]:
                for mid in slots[p["id"]]:
                    ev = self.evaluation(mid)
                    if ev is None:
                        continue
                    ev = copy.deepcopy(ev)
                    if with_deviations:
                        ev["_deviations_path"] = self._deviations_path(mid)
                    evs.append(ev)
        return per

    def _deviations_path(self, mid: Any) -> str | None:
        rid = (self.state or {}).get("evaluations", {}).get(str(mid))
        if rid is None:
            return None
        try:
            h = (self.project.result(int(rid)).get("files") or {}).get("deviations")
            return str(self.project.file_path(h)) if h else None
        except CamcmmError:
            return None

    def summarize(self, per: dict[str, list[dict[str, Any]]] | None = None) -> dict[str, Any]:
        """The standard's full result from the stored evaluations (any time: an
        unfinished test is ``incomplete``)."""
        with self._lock:
            plan = copy.deepcopy(self.plan)
            sid = self.state["standard"]
        ctx = RunContext(self.host, sid)
        return self.standard(sid).summarize(ctx, plan, per if per is not None else self.per_measurement())

    def make_report(self, directory: str | Path, per: dict[str, list[dict[str, Any]]] | None = None
                    ) -> tuple[dict[str, Any], dict[str, str]]:
        """Summarise and write the report files into ``directory`` (any thread; give
        ``per`` from :meth:`per_measurement` taken on the loop). Returns (summary, paths)."""
        from .. import io as cio

        per = copy.deepcopy(per) if per is not None else self.per_measurement(with_deviations=True)
        for evs in per.values():
            for ev in evs:
                path = ev.pop("_deviations_path", None)
                if path:
                    try:
                        dev = cio.read(path)
                        if dev.n_points > REPORT_POINTS:
                            dev = dev.subset(slice(None, None, -(-dev.n_points // REPORT_POINTS)))
                        ev["deviations"] = dev
                    except CamcmmError as exc:
                        log.warning("no colour map for %s: %s", ev.get("file"), exc)
        summary = self.summarize(per)
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        with self._lock:
            plan = copy.deepcopy(self.plan)
        paths = self.standard().write_report(summary, directory, plan)
        return summary, {k: str(v) for k, v in paths.items()}

    def record_report(self, summary: dict[str, Any], paths: dict[str, str], started: str = "") -> dict[str, Any]:
        """Store the summary as a result with the report files; the state names it."""
        from ..project.store import utcnow

        with self._lock:
            std_id = self.state["standard"]
            version = self.host.get(std_id).version
            files = {f"report_{k}": self.project.add_file(p) for k, p in paths.items()}
            mids = [m for ms in self.state["measurements"].values() for m in ms]
            hashes = {}
            for evs in (summary.get("measurements") or {}).values():
                for e in evs:
                    if e.get("file") and e.get("sha256"):
                        hashes[str(e["file"])] = e["sha256"]
            outputs = {k: v for k, v in summary.items()}
            rid = self.project.add_result(_run_dict(std_id, version, {}, hashes, outputs, started or utcnow(),
                                                    list(summary.get("warnings") or [])),
                                          mids, files, label=f"{std_id} acceptance test")
            self.state.update({"summary_result": rid, "report": files, "verdict": summary.get("verdict"),
                               "verdict_guarded": summary.get("verdict_guarded")})
            self._save()
        return {"summary_result": rid, "files": files}

    def report(self, directory: str | Path | None = None) -> dict[str, Any]:
        """Summary + report in the calling thread; returns ``{"summary_result", "files"
        ({"report_html": hash, ...}), "paths" (the files in the project)}``."""
        from ..project.store import utcnow

        started = utcnow()
        tmp = None
        if directory is None:
            tmp = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
            directory = tmp
        try:
            summary, paths = self.make_report(directory)
            out = self.record_report(summary, paths, started)
        finally:
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)
        out["paths"] = self.report_paths()
        out["summary"] = summary
        return out

    def report_paths(self) -> dict[str, Path]:
        """The current report's files in the project (``{"html": path, ...}``)."""
        out = {}
        for name, h in ((self.state or {}).get("report") or {}).items():
            try:
                out[name.removeprefix("report_")] = self.project.file_path(h)
            except CamcmmError as exc:
                log.warning("report file %s: %s", name, exc)
        return out

    def deviations(self, test: str, position: str, repeat: int | None = None) -> Any:
        """The deviations cloud (field ``deviation``, mm) of a done position, from the project."""
        from .. import io as cio

        slots = self._slots(test).get(position) or []
        filled = [(i + 1, mid) for i, mid in enumerate(slots) if mid is not None]
        if not filled:
            raise InputError(f"{position}: nothing measured yet")
        mid = dict(filled).get(repeat) if repeat else filled[-1][1]
        path = self._deviations_path(mid)
        if not path:
            raise InputError(f"{position}: its evaluation has no deviation map")
        cloud = cio.read(path)
        cloud.name = f"{position} deviations"
        return cloud


def fit_text(ev: dict[str, Any]) -> str:
    """One line on the fit of an evaluation: what was fitted, points used/removed."""
    parts = []
    if ev.get("diameter") is not None:
        parts.append(f"Ø {ev['diameter']:.4f} mm")
    if ev.get("length") is not None:
        parts.append(f"L {ev['length']:.4f} mm")
    if isinstance(ev.get("lengths"), list):
        parts.append("L " + ", ".join(f"{x:.4f}" for x in ev["lengths"]) + " mm")
    form = ev.get("form") if isinstance(ev.get("form"), dict) else None
    if form and form.get("std") is not None:
        parts.append(f"σ {1000 * form['std']:.1f} µm")
    if ev.get("n_points") is not None:
        used = ev.get("n_used")
        pts = f"{ev['n_points']} pts" if used is None else f"{used} of {ev['n_points']} pts"
        parts.append(pts)
    if ev.get("n_removed"):
        parts.append(f"{ev['n_removed']} removed")
    return " · ".join(parts)


def fit_rows(ev: dict[str, Any]) -> list[dict[str, str]]:
    """Rows ``{name, value}`` describing an evaluation's fit for the detail panel."""
    rows: list[dict[str, str]] = []

    def add(name: str, value: str) -> None:
        rows.append({"name": name, "value": value})

    def xyz(v: Any, digits: int = 3) -> str:
        return "(" + ", ".join(f"{float(x):.{digits}f}" for x in v) + ") mm"

    for param, v in (ev.get("values") or {}).items():
        add(SYMBOLS.get(param, param), ", ".join(fmt_mm(x, param in SIGNED) for x in v) if isinstance(v, list)
            else fmt_mm(v, param in SIGNED))
    if ev.get("center") is not None:
        add("centre", xyz(ev["center"]))
    if ev.get("diameter") is not None:
        cal = ev.get("diameter_calibrated")
        add("Ø", fmt_mm(ev["diameter"]) + (f" (calibrated {float(cal):.4f})" if cal is not None else ""))
    if ev.get("length") is not None:
        cal = ev.get("length_calibrated")
        add("length", fmt_mm(ev["length"]) + (f" (calibrated {float(cal):.4f})" if cal is not None else ""))
    for i, sph in enumerate(ev.get("spheres") or []):
        if isinstance(sph, dict) and sph.get("center") is not None:
            add(f"sphere {i + 1}", xyz(sph["center"]) + (f", Ø {float(sph['diameter']):.4f} mm"
                                                          if sph.get("diameter") is not None else ""))
    if ev.get("normal") is not None:
        add("normal", "(" + ", ".join(f"{float(x):.4f}" for x in ev["normal"]) + ")")
    form = ev.get("form") if isinstance(ev.get("form"), dict) else {}
    if form.get("std") is not None:
        add("form σ", f"{1000 * float(form['std']):.1f} µm")
    n, used, removed = ev.get("n_points"), ev.get("n_used"), ev.get("n_removed")
    if n is not None:
        text = f"{used} of {n} used" if used is not None else f"{n}"
        if removed:
            text += f", {removed} removed"
        if ev.get("outliers"):
            text += f" (rule {ev['outliers']})"
        add("points", text)
    if isinstance(ev.get("scale"), (int, float)) and ev["scale"] != 1:
        add("scale", f"{float(ev['scale']):.6g}")
    return rows


def view_direction(ev: dict[str, Any]) -> tuple[list[float], list[float]] | None:
    """(direction from the object to the camera, view-up) that shows an evaluation's
    colour map well: a flat face-on (along its normal, from the sensor's side); a ball
    bar or plate across its length, from above; a sphere from the front and above, as
    the sensor saw it. None when the evaluation says nothing about its geometry."""
    z = np.array([0.0, 0.0, 1.0])
    if ev.get("normal") is not None:
        n = np.asarray(ev["normal"], float)
        n = n / (np.linalg.norm(n) or 1.0)
        if n @ z < 0:
            n = -n
        up = np.array([0.0, 1.0, 0.0]) if abs(n @ z) > 0.9 else z
        return n.tolist(), up.tolist()
    centres = [s.get("center") for s in ev.get("spheres") or [] if isinstance(s, dict) and s.get("center")]
    if len(centres) >= 2:
        c = np.asarray(centres, float)
        d = c[1] - c[0]
        d = d / (np.linalg.norm(d) or 1.0)
        if len(c) >= 3:  # a plate: face-on
            n = np.cross(c[1] - c[0], c[2] - c[0])
            n = n / (np.linalg.norm(n) or 1.0)
            v = n if n @ z >= 0 else -n
        else:
            v = z - (z @ d) * d
            if np.linalg.norm(v) < 0.2:  # a (nearly) vertical bar: from the front
                v = np.array([0.0, -1.0, 0.0]) - d * d[1] * -1.0
            v = v / (np.linalg.norm(v) or 1.0)
            side = np.cross(d, v)
            v = v + 0.4 * side
        up = z if abs((v / np.linalg.norm(v)) @ z) < 0.9 else np.array([0.0, 1.0, 0.0])
        return (v / np.linalg.norm(v)).tolist(), up.tolist()
    if ev.get("center") is not None:
        return [0.3, -0.6, 1.0], [0.0, 0.0, 1.0]
    return None


# -- the page -----------------------------------------------------------------------------------
class WizardPage:
    """Publishes a :class:`Wizard` through the session's trame state (``wz_*`` keys)
    and runs its slow steps in a worker thread. One per server."""

    def __init__(self, session: Any, wizard: Wizard | None = None, downloads: str | Path | None = None):
        self.session = session
        self.state = session.state
        self.wizard = wizard if wizard is not None else Wizard(session.project, session.host)
        self.downloads = Path(downloads) if downloads else Path(tempfile.mkdtemp(prefix="camcmm-downloads-"))
        self.downloads.mkdir(parents=True, exist_ok=True)
        self.download_route = "camcmm-downloads"
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="camcmm-wizard")
        self._busy: set[str] = set()
        self.last_card: dict[str, Any] | None = None
        self._init_state()
        self.refresh(setup_form=True)
        w = self.wizard
        if w.active:  # resume where the test stopped
            done = w.complete and (w.state or {}).get("summary_result") is not None
            self.state.wz_step = "result" if done else "positions"

    # -- state ---------------------------------------------------------------------------
    def _init_state(self) -> None:
        s = self.state
        s.page = s.page if getattr(s, "page", None) else "inspect"
        s.wz_step = "setup"
        s.wz_active = False
        s.wz_error = ""
        s.wz_setup_error = ""
        s.wz_standards = []
        s.wz_form = {}
        s.wz_form_tests = []
        s.wz_catalogue = {}
        s.wz_mpe_fields = []
        s.wz_locked = False
        s.wz_title = ""
        s.wz_blocks = []
        s.wz_svgs = {}
        s.wz_progress = []
        s.wz_progress_text = ""
        s.wz_busy = {}
        s.wz_redo = None
        s.wz_detail = None
        s.wz_parameters = []
        s.wz_verdict = ""
        s.wz_verdict_guarded = ""
        s.wz_complete = False
        s.wz_summary_warnings = []
        s.wz_reporting = False
        s.wz_report_links = []

    def _flush(self) -> None:
        self.session._flush()

    def refresh(self, setup_form: bool = False) -> None:
        """Publish everything the page shows."""
        s = self.state
        w = self.wizard
        s.wz_error = w.load_error
        try:
            s.wz_standards = [{"title": f"{x['name']} ({x['id']})", "value": x["id"], "summary": x["summary"]}
                              for x in w.standards()]
        except Exception as exc:  # discovery problems are shown, the page stays
            s.wz_standards = []
            s.wz_error = _one_line(exc)
        s.wz_active = w.active
        if setup_form:
            self._setup_form()
        if not w.active:
            s.wz_locked = False
            s.wz_blocks, s.wz_progress, s.wz_parameters = [], [], []
            s.wz_title, s.wz_progress_text = "", ""
            s.wz_verdict = s.wz_verdict_guarded = ""
            s.wz_report_links = []
            return
        s.wz_locked = True
        try:
            self._publish_positions()
            self._publish_summary()
        except Exception as exc:
            log.exception("wizard refresh failed")
            s.wz_error = _one_line(exc)

    def _setup_form(self, standard: str | None = None, keep: dict[str, Any] | None = None) -> None:
        """The setup form: from the running test, else defaults of ``standard``."""
        s = self.state
        w = self.wizard
        cat = w.catalogue()
        ids = [x["value"] for x in s.wz_standards]
        if w.active and standard is None:
            plan = w.plan
            standard = w.state["standard"]
            form = {"standard": standard, "system_name": plan["system"].get("name", ""),
                    "volume": [float(x) for x in plan["system"]["measuring_volume"]],
                    "mpe": {k: v for k, v in (plan.get("mpe") or {}).items()},
                    "artefacts": {}, "include": list(w.state.get("tests") or []),
                    "options": _options_text(plan)}
            for test, a in (plan.get("artefacts") or {}).items():
                aid = (w.state.get("artefact_ids") or {}).get(test) or ""
                form["artefacts"][test] = {"_choice": aid, **{k: (", ".join(map(str, v)) if isinstance(v, list) else v)
                                                              for k, v in a.items() if k not in ("id", "name")}}
        else:
            standard = standard or (keep or {}).get("standard") or (ids[0] if ids else None)
            form = {"standard": standard, "system_name": (keep or {}).get("system_name", ""),
                    "volume": (keep or {}).get("volume") or [100.0, 100.0, 100.0],
                    "mpe": dict((keep or {}).get("mpe") or {}), "artefacts": {}, "include": [],
                    "options": (keep or {}).get("options", "")}
        tests = []
        catalogue: dict[str, list[dict[str, Any]]] = {}
        if standard:
            try:
                tests = w.setup_tests(standard)
            except Exception as exc:
                s.wz_setup_error = _one_line(exc)
        params = []
        for t in tests:
            kind = t["test"]
            options = [{"title": f"{a['name']}" + (" (project)" if a.get("source") == "project" else ""),
                        "value": a["id"]} for a in cat if a["kind"] == kind]
            catalogue[kind] = options
            spec = ARTEFACT_FIELDS.get(kind) or []
            t["fields"] = [{"key": k, "label": label, "unit": unit, "kind": fk} for k, label, unit, fk in spec]
            t["options"] = options
            if kind not in form["artefacts"]:
                first = next((a for a in cat if a["kind"] == kind), None)
                form["artefacts"][kind] = self._artefact_values(first) if first else {"_choice": ""}
            for p in t["parameters"]:
                if p not in params:
                    params.append(p)
        for p in params:
            form["mpe"].setdefault(p, "")
        s.wz_form = form
        s.wz_form_tests = tests
        s.wz_catalogue = catalogue
        s.wz_mpe_fields = [{"key": p, "label": f"MPE {SYMBOLS.get(p, p)}"} for p in params]

    @staticmethod
    def _artefact_values(a: dict[str, Any]) -> dict[str, Any]:
        vals = artefact_plan_fields(a)
        out: dict[str, Any] = {"_choice": a["id"], "_id": a["id"], "_name": a.get("name", a["id"])}
        for k, v in vals.items():
            out[k] = ", ".join(f"{x:g}" for x in v) if isinstance(v, list) else v
        return out

    def _publish_positions(self) -> None:
        from .wizard_layout import pictograms

        s = self.state
        w = self.wizard
        blocks = w.cards()
        busy = set(self._busy)
        for b in blocks:
            for c in b["cards"]:
                c["busy"] = c["key"] in busy
        s.wz_blocks = blocks
        prog = w.progress()
        s.wz_progress = prog
        s.wz_progress_text = " · ".join(p["text"] for p in prog)
        s.wz_complete = all(p["complete"] for p in prog)
        if not s.wz_svgs or set(s.wz_svgs) != {c["key"] for b in blocks for c in b["cards"]}:
            s.wz_svgs = pictograms(w.requirements(), w.plan)
        plan = w.plan
        s.wz_title = (f"{w.state['standard']} — {plan['system'].get('name', '')}, measuring volume "
                      + " × ".join(f"{x:g}" for x in plan["system"]["measuring_volume"]) + " mm")

    def _publish_summary(self) -> None:
        s = self.state
        w = self.wizard
        try:
            summary = w.summarize()
        except Exception as exc:
            s.wz_parameters = []
            s.wz_verdict = s.wz_verdict_guarded = ""
            s.wz_summary_warnings = [f"no summary: {_one_line(exc)}"]
            return
        rows = []
        for key, p in (summary.get("parameters") or {}).items():
            rows.append({"key": key, "symbol": SYMBOLS.get(key, key), "name": p.get("name") or key,
                         "value": fmt_mm(p.get("value"), key in SIGNED), "mpe": fmt_mm(p.get("mpe")),
                         "U": fmt_mm(p.get("U")), "verdict": p.get("verdict") or "incomplete",
                         "verdict_guarded": p.get("verdict_guarded") or "incomplete",
                         "n": p.get("n_evaluated", ""), "note": "; ".join(p.get("incomplete_reasons") or [])})
        s.wz_parameters = rows
        s.wz_verdict = summary.get("verdict") or "incomplete"
        s.wz_verdict_guarded = summary.get("verdict_guarded") or ""
        s.wz_summary_warnings = [str(x) for x in (summary.get("warnings") or [])][:20]
        s.wz_report_links = self._links()

    def _links(self) -> list[dict[str, str]]:
        rid = (self.wizard.state or {}).get("summary_result")
        out = []
        for kind, path in self.wizard.report_paths().items():
            name = f"acceptance-test-{rid}.{kind}"
            dest = self.downloads / name
            try:
                if not dest.exists():
                    shutil.copyfile(path, dest)
            except OSError as exc:
                log.warning("cannot offer %s for download: %s", path, exc)
                continue
            out.append({"kind": kind, "name": name, "url": f"{self.download_route}/{name}",
                        "title": {"html": "Open report (HTML)", "pdf": "Download PDF", "json": "Download JSON"}
                        .get(kind, kind)})
        order = {"html": 0, "pdf": 1, "json": 2}
        return sorted(out, key=lambda x: order.get(x["kind"], 9))

    # -- handlers: setup -------------------------------------------------------------------
    def choose_standard(self, standard: str, form: dict[str, Any] | None = None) -> None:
        if self.wizard.active and self.state.wz_locked:
            return
        self.state.wz_setup_error = ""
        self._setup_form(standard, keep=form)

    def pick_artefact(self, test: str, choice: str, form: dict[str, Any] | None = None) -> None:
        """Fill an artefact's fields from the catalogue (or the project's own)."""
        form = copy.deepcopy(form if form is not None else self.state.wz_form)
        entry = next((a for a in self.wizard.catalogue() if a["id"] == choice), None)
        if entry is None:
            return
        form.setdefault("artefacts", {})[test] = self._artefact_values(entry)
        self.state.wz_form = form

    def start(self, form: dict[str, Any] | None = None) -> bool:
        """Set up the test from the form; go to the positions."""
        form = form if form is not None else self.state.wz_form
        s = self.state
        s.wz_setup_error = ""
        try:
            arts = {}
            for test, a in (form.get("artefacts") or {}).items():
                a = dict(a or {})
                choice = a.pop("_choice", "")
                entry = next((x for x in self.wizard.catalogue() if x["id"] == choice), None) if choice else None
                if entry is not None:
                    same = self._artefact_values(entry)
                    edited = any(not _same_value(same.get(k), v) for k, v in a.items() if not k.startswith("_"))
                    if edited:
                        a["_id"], a["_name"] = f"{choice}-own", f"{entry.get('name', choice)} (own values)"
                    else:
                        a["_id"], a["_name"] = entry["id"], entry.get("name", entry["id"])
                arts[test] = a
            self.wizard.setup(form.get("standard"), form.get("system_name"), form.get("volume"), form.get("mpe") or {},
                              arts, tests=form.get("include") or [], options=form.get("options"))
        except Exception as exc:
            s.wz_setup_error = _one_line(exc)
            return False
        s.wz_svgs = {}
        self._busy.clear()
        self.refresh(setup_form=True)
        s.wz_step = "positions"
        self.session.refresh_items()
        self.session.info(f"acceptance test set up: {self.wizard.state['standard']}")
        return True

    def unlock(self) -> None:
        """Allow a new test to be set up (the running one stays until Start)."""
        self.state.wz_locked = False

    # -- handlers: positions -----------------------------------------------------------------
    def _set_busy(self, key: str, on: bool) -> None:
        (self._busy.add if on else self._busy.discard)(key)
        self.state.wz_busy = {k: True for k in self._busy}

    async def upload_async(self, test: str, position: str, upload: Any, repeat: int | None = None) -> None:
        """A file chosen in a card's file input: evaluate in the worker, record on the loop."""
        files = self.session.import_upload(upload) if upload else []
        if not files:
            return
        f = files[0]
        await self.import_async(test, position, f["content"], f["name"], repeat)

    async def import_async(self, test: str, position: str, source: str | Path | bytes, name: str | None = None,
                           repeat: int | None = None) -> dict[str, Any] | None:
        key = f"{test}/{position}"
        if key in self._busy:
            self.session.error(f"{position}: a measurement is being evaluated; wait for it")
            return None
        if self.session._loop is None:
            self.session.bind_loop()
        try:
            job = self.wizard.prepare(test, position, repeat)
        except Exception as exc:
            self.session.error(_one_line(exc))
            return None
        self._set_busy(key, True)
        self.refresh_cards()
        self._flush()
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(self._executor, self.wizard.evaluate, job, source, name)
        except Exception as exc:
            msg = self.wizard.fail(job, exc)
            self._set_busy(key, False)
            self.state.wz_redo = None
            self.refresh()
            self.session.error(msg)
            self._flush()
            return None
        try:
            card = self.wizard.record(job)
        except Exception as exc:
            msg = self.wizard.fail(job, exc)
            self._set_busy(key, False)
            self.refresh()
            self.session.error(f"{position}: could not be saved in the project: {msg}")
            self._flush()
            return None
        self._set_busy(key, False)
        self.state.wz_redo = None
        self.refresh()
        self._after_record(job, card)
        self._flush()
        return card

    def import_file(self, test: str, position: str, source: str | Path | bytes, name: str | None = None,
                    repeat: int | None = None) -> dict[str, Any]:
        """As :meth:`import_async` in the calling thread (tests, scripts)."""
        job = self.wizard.prepare(test, position, repeat)
        try:
            self.wizard.evaluate(job, source, name)
        except Exception as exc:
            msg = self.wizard.fail(job, exc)
            self.refresh()
            self.session.error(msg)
            return self.wizard.card(test, position)
        card = self.wizard.record(job)
        self.state.wz_redo = None
        self.refresh()
        self._after_record(job, card)
        return card

    def _after_record(self, job: Job, card: dict[str, Any]) -> None:
        self.last_card = card
        self.session.refresh_items()
        rep = next((r for r in card["repeats"] if r["repeat"] == job.repeat), None)
        self._detail(job.test, job.position, job.repeat, job.evaluation or {})
        dev = job.extra.get("deviations")
        if dev is not None:
            self.show_cloud(f"wizard:{job.extra.get('result')}", dev, job.evaluation)
        verdict = (rep or {}).get("verdict") or ""
        values = ", ".join(f"{v['symbol']} {v['text']}" for v in (rep or {}).get("values", []))
        prog = next((p["text"] for p in self.state.wz_progress if p["test"] == job.test), "")
        self.session.info(f"{job.position}: {values} — {verdict}; {prog}")

    def refresh_cards(self) -> None:
        blocks = copy.deepcopy(self.state.wz_blocks or [])
        for b in blocks:
            for c in b["cards"]:
                c["busy"] = c["key"] in self._busy
        self.state.wz_blocks = blocks

    def _detail(self, test: str, position: str, repeat: int, ev: dict[str, Any]) -> None:
        self.state.wz_detail = {"title": f"{position} (repeat {repeat})" if self._repeats(test) > 1 else position,
                                "file": ev.get("file") or "", "rows": fit_rows(ev),
                                "warnings": [str(x) for x in ev.get("warnings") or []]}

    def _repeats(self, test: str) -> int:
        try:
            return self.wizard._req(test)["repeats"]
        except CamcmmError:
            return 1

    def show(self, test: str, position: str, repeat: int | None = None) -> None:
        """Show a done position's deviation colour map in the 3D view and its fit."""
        try:
            cloud = self.wizard.deviations(test, position, repeat)
        except Exception as exc:
            self.session.error(_one_line(exc))
            return
        slots = self.wizard._slots(test).get(position) or []
        filled = [(i + 1, mid) for i, mid in enumerate(slots) if mid is not None]
        rep, mid = (repeat, dict(filled).get(repeat)) if repeat else filled[-1]
        self._detail(test, position, rep, self.wizard.evaluation(mid) or {})
        self.show_cloud(f"wizard:{self.wizard.state['evaluations'].get(str(mid))}", cloud,
                        self.wizard.evaluation(mid))

    def show_cloud(self, key: str, cloud: Any, evaluation: dict[str, Any] | None = None) -> None:
        """Show a deviations cloud coloured by ``deviation`` (legend in mm) in the
        session's 3D view, looking at it as :func:`view_direction` suggests; the Inspect
        page's colour selector follows."""
        from .view import color_fields

        sess = self.session
        field_name = "deviation" if "deviation" in (getattr(cloud, "fields", {}) or {}) else None
        try:
            sess.view.show(key, cloud, field_name)
            look = view_direction(evaluation or {})
            if look is not None:
                sess.view.plotter.view_vector(look[0], viewup=look[1])
                sess.view.plotter.reset_camera()
                sess.view._changed(reset_camera=True)
        except Exception as exc:
            sess.error(f"cannot show {getattr(cloud, 'name', key)}: {_one_line(exc)}")
            return
        s = self.state
        s.selected_item = None
        s.color_fields = color_fields(cloud)
        s.color_field = sess.view.field
        s.legend_title = sess.view.scalar_bar_title
        s.display_note = f"{getattr(cloud, 'name', key)}: {sess.view.note}"

    def redo(self, test: str, position: str) -> None:
        """Offer the file input again on a done card (the import then replaces it)."""
        self.state.wz_redo = f"{test}/{position}"

    # -- handlers: report ------------------------------------------------------------------
    async def report_async(self) -> dict[str, Any] | None:
        from ..project.store import utcnow

        if self.state.wz_reporting:
            return None
        if self.session._loop is None:
            self.session.bind_loop()
        s = self.state
        s.wz_reporting = True
        self._flush()
        started = utcnow()
        folder = Path(tempfile.mkdtemp(prefix="camcmm-report-"))
        try:
            per = self.wizard.per_measurement(with_deviations=True)
            loop = asyncio.get_running_loop()
            summary, paths = await loop.run_in_executor(self._executor, self.wizard.make_report, folder, per)
            out = self.wizard.record_report(summary, paths, started)
        except Exception as exc:
            self.session.error(f"report: {_one_line(exc)}")
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)
            s.wz_reporting = False
        self.refresh()
        self.session.refresh_results()
        self.session.info(f"report written (result #{out['summary_result']}): verdict {s.wz_verdict}")
        self._flush()
        return out

    def report(self) -> dict[str, Any] | None:
        try:
            out = self.wizard.report()
        except Exception as exc:
            self.session.error(f"report: {_one_line(exc)}")
            return None
        self.refresh()
        self.session.refresh_results()
        return out

    def close(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)
        shutil.rmtree(self.downloads, ignore_errors=True)


def _options_text(plan: dict[str, Any]) -> str:
    import yaml

    extra = {k: v for k, v in plan.items() if k not in _FORM_KEYS and k != "name"}
    return yaml.safe_dump(extra, sort_keys=False, default_flow_style=None).strip() if extra else ""


def mount(server: Any, session: Any) -> WizardPage:
    """Create the page for a session and serve its downloads folder (call before the
    server starts)."""
    page = WizardPage(session)
    server.enable_module({"serve": {page.download_route: str(page.downloads)}})
    return page
