"""Setting up a test: which standards are installed, the plan from the setup form
(checked field by field, then by the standard) and the start of a new run, which sends
the running one to the history."""

from __future__ import annotations

import copy
from typing import Any

from camcmm.errors import CamcmmError, InputError
from camcmm.project.store import utcnow
from camcmm.yamlfile import load_yaml

from .catalogue import load_catalogue, plan_fields_to_artefact
from .declared import artefact_fields, artefact_kind, parameter
from .options import coerce, flatten, nest
from .standards import Standards
from .state import HISTORY_KEY, TestState
from .values import _blank, _number, _vector, log

#: Plan keys the setup form owns; the advanced options may not replace them.
FORM_KEYS = ("standard", "system", "mpe", "artefacts", "measurements")


def parse_options(options: Any) -> dict[str, Any]:
    """More plan keys from the setup's "more plan options": a dict (the form's flat values,
    dotted keys nested: :func:`.options.nest`) or YAML text (an import)."""
    if _blank(options):
        return {}
    if isinstance(options, str):
        options = load_yaml(options, name="plan options")
    if not isinstance(options, dict):
        raise InputError(f"plan options: give keys and values (e.g. 'unit: mm'), got {options!r}")
    options = nest(options)
    taken = [k for k in options if k in FORM_KEYS]
    if taken:
        raise InputError(f"plan options: {taken[0]!r} is set by the form above, not here")
    return dict(options)


class Setup:
    """Setting up a test on a project: the installed standards and the artefact
    catalogue to choose from, the plan from the form, and the start of a run (the
    running one goes to the history under :data:`HISTORY_KEY`)."""

    def __init__(self, saved: TestState, standards: Standards):
        self.saved = saved
        self.standards = standards
        self.project = saved.project

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
        std = self.standards.load(sid)
        return [
            {
                "test": r["test"],
                "label": r.get("label") or r["test"],
                "parameters": list(r.get("parameters") or []),
                "required": bool(r.get("required", True)),
                "min_count": int(r.get("min_count") or 0),
                "repeats": int(r.get("repeats") or 1),
                "n_positions": len(r.get("positions") or []),
            }
            for r in std.requirements(None)
        ]

    # -- setup ---------------------------------------------------------------------------
    def build_plan(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        options: Any = None,
    ) -> dict[str, Any]:
        """The plan dict from the setup form; values are checked here (one line naming
        the field) and by the standard (``requirements(plan)``). ``options``: more plan
        keys (a dict or YAML text: outliers, scaling, repeats, unit, options ...)."""
        name = str(system_name or "").strip()
        if not name:
            raise InputError("measuring system: give it a name")
        vol = _vector(measuring_volume, "measuring volume")
        if min(vol) <= 0:
            raise InputError(f"measuring volume: every edge must be > 0 mm, got {vol}")
        decl = self.standards.declaration(standard)
        mpes = {}
        for key, v in (mpe or {}).items():
            if _blank(v):
                continue
            mpes[key] = _number(v, f"MPE {parameter(decl, key).symbol}")
        arts: dict[str, dict[str, Any]] = {}
        for test, fields_ in (artefacts or {}).items():
            spec = artefact_fields(decl, test)
            values = {k: v for k, v in (fields_ or {}).items() if not k.startswith("_")}
            if not spec:
                arts[test] = values
                continue
            entry: dict[str, Any] = {}
            for f in spec:
                v = values.get(f.key)
                if _blank(v):
                    continue
                what = f"artefact {test.replace('_', ' ')}: {f.label.lower()}"
                entry[f.key] = _vector(v, what, f.size) if f.kind == "vector" else _number(v, what)
                for x in entry[f.key] if f.kind == "vector" else [entry[f.key]]:
                    if (f.min is not None and x < f.min) or (f.max is not None and x > f.max):
                        lo, hi = ("" if f.min is None else f"{f.min:g}"), ("" if f.max is None else f"{f.max:g}")
                        raise InputError(f"{what}: {x:g} is outside the declared range {lo}..{hi} {f.unit}")
            for key, v in values.items():  # extra calibrated values from the catalogue
                if key not in entry and isinstance(v, (int, float)) and not isinstance(v, bool):
                    entry[key] = float(v)
            for meta in ("id", "name"):
                if (fields_ or {}).get(f"_{meta}"):
                    entry[meta] = str(fields_[f"_{meta}"])
            arts[test] = entry
        plan = {
            "standard": standard,
            "system": {"name": name, "measuring_volume": vol},
            "mpe": mpes,
            "artefacts": arts,
            "measurements": {},
            "name": f"{getattr(self.project, 'name', 'project')} (acceptance-test wizard)",
        }
        declared = self.standards.plan_options(standard)
        plan.update(nest(coerce(flatten(parse_options(options), declared), declared)))
        self.standards.load(standard).requirements(copy.deepcopy(plan))  # the standard checks the plan
        return plan

    def artefact_checks(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        tests: list[str] | None = None,
        options: Any = None,
    ) -> list[dict[str, Any]]:
        """The standard's own artefact rules on a setup before Start:
        ``[{artefact, rule, value, limit, ok, text}]`` (docs/standards.md), lengths in mm.

        The rules are the standard plugin's, not the page's: its ``summarize`` of the plan
        with no measurements returns them (``artefact_checks``); a standard that states
        none gives ``[]``. A form the plan cannot be built from yet raises (InputError
        naming the field). A blank system name does not matter to the rules."""
        std = self.standards.load(standard)
        available = {r["test"]: r for r in std.requirements(None)}
        chosen = [t for t, r in available.items() if r.get("required", True) or t in (tests or [])]
        plan = self.build_plan(
            standard,
            str(system_name or "").strip() or "(not named yet)",
            measuring_volume,
            mpe,
            {t: a for t, a in (artefacts or {}).items() if t in chosen},
            options,
        )
        summary = std.summarize(None, plan, {}) or {}
        return [dict(c) for c in summary.get("artefact_checks") or [] if isinstance(c, dict)]

    def start(
        self,
        standard: str,
        system_name: str,
        measuring_volume: Any,
        mpe: dict[str, Any],
        artefacts: dict[str, dict[str, Any]],
        tests: list[str] | None = None,
        options: Any = None,
        system_meta: dict[str, Any] | None = None,
    ) -> dict[str, Any]:
        """Start a new test (the running one, if any, goes to the history: its results
        stay in the project). ``artefacts``: per test the form's fields, ``_id`` and
        ``_name`` naming the artefact stored in the project; ``system_meta``: more about
        the measuring system for its project entry (e.g. what simulates it). Returns the
        new state."""
        std = self.standards.load(standard)
        decl = self.standards.declaration(standard)
        available = {r["test"]: r for r in std.requirements(None)}
        chosen = [t for t, r in available.items() if r.get("required", True) or t in (tests or [])]
        for t in chosen:
            for param in available[t].get("parameters") or []:
                v = (mpe or {}).get(param)
                if _blank(v):
                    raise InputError(
                        f"MPE {parameter(decl, param).symbol} is empty; enter it from the measuring "
                        "system's specification"
                    )
        plan = self.build_plan(
            standard,
            system_name,
            measuring_volume,
            mpe,
            {t: a for t, a in (artefacts or {}).items() if t in chosen},
            options,
        )
        missing = [t for t in chosen if t not in plan["artefacts"]]
        if missing:
            raise InputError(f"artefact {missing[0].replace('_', ' ')} is missing; the test needs it")
        with self.saved.lock:
            if not self.saved.is_current():  # archive the project's test, not this session's older copy
                self.saved.resume()
            self._archive()
            system = plan["system"]
            sid = self.project.add_system(
                system["name"],
                {"measuring_volume": system["measuring_volume"], "standard": standard, **(system_meta or {})},
            )
            art_ids = {}
            for test, entry in plan["artefacts"].items():
                aid = str((artefacts.get(test) or {}).get("_id") or "") or f"{test}-own"
                name = str((artefacts.get(test) or {}).get("_name") or "") or f"own {test.replace('_', ' ')}"
                try:
                    kind = artefact_kind(decl, test)
                    art_ids[test] = self.project.add_artefact(
                        plan_fields_to_artefact(kind, entry, aid, name, decl.artefact(kind))
                    )
                except CamcmmError as exc:
                    log.warning("artefact %s not saved in the project: %s", aid, exc)
            state = {
                "standard": standard,
                "plan": plan,
                "measurements": {},
                "evaluations": {},
                "positions": {},
                "errors": {},
                "superseded": [],
                "tests": chosen,
                "system_id": sid,
                "artefact_ids": art_ids,
                "summary_result": None,
                "report": None,
                "verdict": None,
                "verdict_guarded": None,
                "created": utcnow(),
            }
            self.saved.start(state)
        return state

    def _archive(self) -> None:
        old = self.saved.state
        if not old:
            return
        try:
            history = list(self.project.get_state(HISTORY_KEY, []) or [])
            history.append(
                {
                    k: old.get(k)
                    for k in (
                        "standard",
                        "created",
                        "summary_result",
                        "verdict",
                        "verdict_guarded",
                        "measurements",
                        "evaluations",
                        "report",
                        "updated",
                    )
                }
                # who was tested, for the list of earlier tests (the plan itself is not kept)
                | {"system": str(((old.get("plan") or {}).get("system") or {}).get("name") or "")}
            )
            self.project.set_state(HISTORY_KEY, history)
        except CamcmmError as exc:
            log.warning("could not keep the previous test in the history: %s", exc)
