"""The setup form on the page: filled from the running test or a standard's defaults,
artefacts picked from the catalogue, and Start, which tells a catalogue artefact kept as
it is from one whose values the operator edited. The plan itself, its checks and the
new run are the task's (:class:`camcmm.tasks.acceptance.Wizard`)."""

from __future__ import annotations

import copy
from typing import Any

from camcmm.errors import one_line
from camcmm.tasks.acceptance import (
    FORM_KEYS,
    artefact_fields,
    artefact_kind,
    artefact_plan_fields,
    parameter,
    parse_options,
)
from camcmm.tasks.acceptance.options import flatten, form_fields, to_yaml
from camcmm.yamlfile import load_yaml

#: The new form's measuring volume (mm): the demo's 90 mm cube, in which the shipped
#: catalogue's first artefacts (20 mm sphere, 49.944 mm ball bar, 150 x 60 mm flat) meet the
#: artefact rules of VDI/VDE 2634-2 (L0 = 155.9 mm, 0.3 L0 = 46.77 mm). In a 100 mm cube
#: the ball bar is shorter than 0.3 L0 = 51.96 mm. The operator enters the system's own.
DEFAULT_VOLUME = [90.0, 90.0, 90.0]


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


def _plan_options(w: Any, plan: dict[str, Any], standard: str) -> dict[str, Any]:
    """The running plan's extra keys as the options form's flat values (:func:`flatten`)."""
    extra = {k: v for k, v in plan.items() if k not in FORM_KEYS and k != "name"}
    return flatten(extra, w.plan_options(standard))


def _running_form(w: Any, standard: str) -> dict[str, Any]:
    """The form filled from the running test's plan (artefacts with their catalogue choice)."""
    plan = w.plan
    form = {
        "standard": standard,
        "system_name": plan["system"].get("name", ""),
        "volume": [float(x) for x in plan["system"]["measuring_volume"]],
        "mpe": {k: v for k, v in (plan.get("mpe") or {}).items()},
        "artefacts": {},
        "include": list(w.state.get("tests") or []),
        "options": _plan_options(w, plan, standard),
    }
    for test, a in (plan.get("artefacts") or {}).items():
        aid = (w.state.get("artefact_ids") or {}).get(test) or ""
        form["artefacts"][test] = {
            "_choice": aid,
            **{
                k: (", ".join(map(str, v)) if isinstance(v, list) else v)
                for k, v in a.items()
                if k not in ("id", "name")
            },
        }
    return form


def _default_form(standard: str | None, keep: dict[str, Any] | None) -> dict[str, Any]:
    """A new form for ``standard``, keeping the system, MPEs and options of ``keep``."""
    return {
        "standard": standard,
        "system_name": (keep or {}).get("system_name", ""),
        "volume": (keep or {}).get("volume") or list(DEFAULT_VOLUME),
        "mpe": dict((keep or {}).get("mpe") or {}),
        "artefacts": {},
        "include": [],
        "options": dict((keep or {}).get("options") or {}) if isinstance((keep or {}).get("options"), dict) else {},
    }


def _catalogue_options(cat: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    """The catalogue's artefacts of ``kind`` as select items (the project's own marked)."""
    return [
        {"title": f"{a['name']}" + (" (project)" if a.get("source") == "project" else ""), "value": a["id"]}
        for a in cat
        if a["kind"] == kind
    ]


def artefact_values(a: dict[str, Any]) -> dict[str, Any]:
    """A catalogue (or project) artefact as the form's fields, with its choice, id and name."""
    vals = artefact_plan_fields(a)
    out: dict[str, Any] = {"_choice": a["id"], "_id": a["id"], "_name": a.get("name", a["id"])}
    for k, v in vals.items():
        out[k] = ", ".join(f"{x:g}" for x in v) if isinstance(v, list) else v
    return out


class SetupForm:
    """The setup step of a :class:`~camcmm.gui.pages.acceptance.WizardPage`: publishes
    the form (``wz_form``, ``wz_form_tests``, ``wz_catalogue``, ``wz_mpe_fields``, the
    artefact rules) and starts the test on the page's wizard."""

    def __init__(self, page: Any):
        self.page = page
        self.state = page.state

    @property
    def wizard(self) -> Any:
        return self.page.wizard

    def fill(self, standard: str | None = None, keep: dict[str, Any] | None = None) -> None:
        """The setup form: from the running test, else defaults of ``standard``."""
        s = self.state
        w = self.wizard
        cat = w.catalogue()
        ids = [x["value"] for x in s.wz_standards]
        if w.active and standard is None:
            standard = w.state["standard"]
            form = _running_form(w, standard)
        else:
            standard = standard or (keep or {}).get("standard") or (ids[0] if ids else None)
            form = _default_form(standard, keep)
        tests, decl = self._standard_tests(standard)
        catalogue, params = self._fill_tests(tests, decl, cat, form)
        for p in params:
            form["mpe"].setdefault(p, "")
        try:
            option_fields = form_fields(w.plan_options(standard)) if standard else []
        except Exception as exc:  # a bad declaration: the form says so, YAML still works
            option_fields = []
            s.wz_setup_error = one_line(exc)
        for f in option_fields:  # unset: a select reads "(the standard's default)", a switch off
            form["options"].setdefault(f["key"], False if f["widget"] == "switch" else "")
        s.wz_option_fields = option_fields
        s.wz_form = form
        s.wz_form_tests = tests
        s.wz_catalogue = catalogue
        s.wz_mpe_fields = [
            {"key": p, "label": f"MPE {parameter(decl, p).symbol}", "unit": parameter(decl, p).unit} for p in params
        ]
        self.check_artefacts(form)

    def check_artefacts(self, form: dict[str, Any] | None = None) -> list[str]:
        """Run the standard's artefact rules on the setup form (through the plugin,
        :meth:`Wizard.artefact_checks`); publish the broken ones (``wz_artefact_warnings``,
        shown above Start) and why none could be checked yet (``wz_artefact_note``).
        A changed list of broken rules takes back an earlier "start anyway"."""
        s = self.state
        form = form if form is not None else s.wz_form
        broken: list[str] = []
        note = ""
        if form and form.get("standard"):
            try:
                checks = self.wizard.artefact_checks(
                    form.get("standard"),
                    form.get("system_name"),
                    form.get("volume"),
                    form.get("mpe") or {},
                    form.get("artefacts") or {},
                    tests=form.get("include") or [],
                    options=form.get("options"),
                )
                broken = [str(c.get("text") or c.get("rule")) for c in checks if not c.get("ok", True)]
            except Exception as exc:  # an incomplete form: Start names the field
                note = f"the artefact rules are checked once the setup is complete ({one_line(exc)})"
        if broken != list(getattr(s, "wz_artefact_warnings", None) or []):
            s.wz_confirm_violations = False
        s.wz_options_yaml = self.options_yaml(form)
        s.wz_artefact_warnings = broken
        s.wz_artefact_note = note
        return broken

    def _standard_tests(self, standard: str | None) -> tuple[list[dict[str, Any]], Any]:
        """The tests and the declaration of ``standard`` (none and ``wz_setup_error`` if it fails)."""
        tests: list[dict[str, Any]] = []
        decl = None
        if standard:
            try:
                tests = self.wizard.setup_tests(standard)
                decl = self.wizard.declaration(standard)
            except Exception as exc:
                self.state.wz_setup_error = one_line(exc)
        return tests, decl

    def _fill_tests(
        self, tests: list[dict[str, Any]], decl: Any, cat: list[dict[str, Any]], form: dict[str, Any]
    ) -> tuple[dict[str, list[dict[str, Any]]], list[str]]:
        """Per test: its catalogue options and declared fields (into ``tests``), the first
        artefact of its kind where ``form`` has none; the catalogue options per test and the
        parameters of all tests."""
        params: list[str] = []
        catalogue: dict[str, list[dict[str, Any]]] = {}
        for t in tests:
            test = t["test"]
            kind = artefact_kind(decl, test) if decl is not None else test
            options = _catalogue_options(cat, kind)
            catalogue[test] = options
            spec = artefact_fields(decl, test) if decl is not None else []
            t["fields"] = [
                {"key": f.key, "label": f.label, "unit": f.unit, "kind": f.kind, "help": f.help} for f in spec
            ]
            t["options"] = options
            if test not in form["artefacts"]:
                first = next((a for a in cat if a["kind"] == kind), None)
                form["artefacts"][test] = artefact_values(first) if first else {"_choice": ""}
            for p in t["parameters"]:
                if p not in params:
                    params.append(p)
        return catalogue, params

    # -- the plan options: a form from the declaration, YAML as export and import ----------------
    def options_yaml(self, form: dict[str, Any] | None) -> str:
        """The form's plan options as plan YAML (the export); "" when none is set or one
        does not read (Start names it)."""
        form = form or {}
        try:
            return to_yaml(dict(form.get("options") or {}), self.wizard.plan_options(form.get("standard")))
        except Exception:
            return ""

    def import_options(self, text: str, form: dict[str, Any] | None = None) -> bool:
        """Fill the plan options from YAML (a plan's extra keys, or a whole plan: the keys
        the form above owns are left out, and ``wz_options_note`` names them);
        ``wz_options_error`` says what does not read."""
        form = copy.deepcopy(form if form is not None else self.state.wz_form)
        s = self.state
        s.wz_options_error = s.wz_options_note = ""
        try:
            doc = load_yaml(text or "", name="plan options") or {}
            if not isinstance(doc, dict):
                raise ValueError(f"give keys and values (e.g. 'unit: mm'), got {str(text)[:40]!r}")
            extra = parse_options({k: v for k, v in doc.items() if k not in FORM_KEYS and k != "name"})
            declared = self.wizard.plan_options(form.get("standard"))
            to_yaml(flatten(extra, declared), declared)  # checked now, not at Start
        except Exception as exc:
            s.wz_options_error = f"plan options (YAML): {one_line(exc)}"
            return False
        owned = [k for k in doc if k in FORM_KEYS or k == "name"]
        if owned:  # never dropped without a word
            s.wz_options_note = f"left out of the YAML (the form above sets them): {', '.join(map(str, owned))}"
        form["options"] = flatten(extra, declared)
        for f in form_fields(declared):  # the ones the YAML leaves out: the standard's default
            form["options"].setdefault(f["key"], False if f["widget"] == "switch" else "")
        s.wz_form = form
        self.check_artefacts(form)
        return True

    # -- handlers: setup -------------------------------------------------------------------
    def choose_standard(self, standard: str, form: dict[str, Any] | None = None) -> None:
        if self.wizard.active and self.state.wz_locked:
            return
        self.state.wz_setup_error = ""
        self.fill(standard, keep=form)

    def pick_artefact(self, test: str, choice: str, form: dict[str, Any] | None = None) -> None:
        """Fill an artefact's fields from the catalogue (or the project's own)."""
        form = copy.deepcopy(form if form is not None else self.state.wz_form)
        entry = next((a for a in self.wizard.catalogue() if a["id"] == choice), None)
        if entry is None:
            return
        form.setdefault("artefacts", {})[test] = artefact_values(entry)
        self.state.wz_form = form
        self.check_artefacts(form)

    def start(self, form: dict[str, Any] | None = None) -> bool:
        """Set up the test from the form; go to the positions. Refused (``wz_setup_error``)
        while the form breaks an artefact rule of the standard and "start anyway"
        (``wz_confirm_violations``) is not set."""
        form = form if form is not None else self.state.wz_form
        s = self.state
        s.wz_setup_error = ""
        broken = self.check_artefacts(form)
        if broken and not s.wz_confirm_violations:
            s.wz_setup_error = (
                f"the setup breaks {len(broken)} artefact rule(s) of {form.get('standard')} (listed above Start); "
                "set 'start anyway' to run a test that deviates from the standard"
            )
            return False
        w = self.wizard
        page = self.page
        if w.worth_keeping() and page.confirmed != w.identity:  # never replace a test without a word
            s.wz_supersede = {**w.supersede_question(), "action": "start"}
            return False
        try:
            arts = {}
            for test, a in (form.get("artefacts") or {}).items():
                a = dict(a or {})
                choice = a.pop("_choice", "")
                entry = next((x for x in self.wizard.catalogue() if x["id"] == choice), None) if choice else None
                if entry is not None:
                    same = artefact_values(entry)
                    edited = any(not _same_value(same.get(k), v) for k, v in a.items() if not k.startswith("_"))
                    if edited:
                        a["_id"], a["_name"] = f"{choice}-own", f"{entry.get('name', choice)} (own values)"
                    else:
                        a["_id"], a["_name"] = entry["id"], entry.get("name", entry["id"])
                arts[test] = a
            self.wizard.setup(
                form.get("standard"),
                form.get("system_name"),
                form.get("volume"),
                form.get("mpe") or {},
                arts,
                tests=form.get("include") or [],
                options=form.get("options"),
            )
        except Exception as exc:
            s.wz_setup_error = one_line(exc)
            return False
        page.confirmed = ""
        s.wz_svgs = {}
        s.wz_detail, s.wz_redo, page.last_card = None, None, None  # the old test's "Last shown" is not this one's
        page.session.shared.clear("acceptance")  # nor its colour map in the 3D view
        page.busy.clear()
        page.refresh(setup_form=True)
        s.wz_step = "positions"
        page.session.refresh_items()
        page.session.info(f"acceptance test set up: {self.wizard.name()}")
        return True

    def unlock(self) -> None:
        """Allow a new test to be set up (the running one stays until Start)."""
        self.state.wz_locked = False
