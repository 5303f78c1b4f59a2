"""Which acceptance test is current (issue 30), without a browser.

* A new test over one with work in it asks first (the page's ``wz_supersede``: the test's
  name, its verdict, where it stays) and the old one stays findable (history, results list).
* A second session on the same project follows the first's changes (a new test, a new
  position) as the item list does, and never saves its older copy over them.
* Results are named (test, position, system, local date, verdict), not "vdi2634-2" + ISO.
* The plan options are a form from the standard's declaration; YAML is export and import.

References: the real ``vdi2634-2`` plugin's declaration (docs/standards.md "The plan").
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime

import pytest
import yaml

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

cio = pytest.importorskip("camcmm.io")

from camcmm.errors import InputError  # noqa: E402
from camcmm.host import default_host  # noqa: E402
from camcmm.project import Project  # noqa: E402
from camcmm.tasks.acceptance import HISTORY_KEY, Wizard, parse_options  # noqa: E402
from camcmm.tasks.acceptance.naming import local_time, result_row, result_title, verdict_text  # noqa: E402
from camcmm.tasks.acceptance.options import coerce, flatten, form_fields, nest, to_yaml  # noqa: E402
from helpers.acceptance_data import ARTEFACTS, MPE, VOLUME, real_vdi2634_available, write_measurements  # noqa: E402

SID = "vdi2634-2"
needs_real = pytest.mark.skipif(not real_vdi2634_available(), reason="the vdi2634-2 plugin is not installed")


def _setup(w: Wizard, name: str = "Scanner A") -> None:
    w.setup(SID, name, VOLUME, MPE, {t: dict(a) for t, a in ARTEFACTS.items()})


def _spheres(w: Wizard) -> list[dict]:
    """The sphere test's requirements only, with two positions (files for two imports)."""
    r = next(r for r in w.requirements() if r["test"] == "sphere")
    return [{**r, "positions": r["positions"][:2]}]


# -- words --------------------------------------------------------------------------------------------
def test_result_rows_are_named_in_words():
    """A summary: the standard, the system, the local date, both verdicts; a position:
    its id and test, the system from the label; never the bare plugin id + ISO stamp."""
    stamp = "2026-11-29T21:30:41.565+00:00"
    when = local_time(stamp)
    local = datetime(2026, 11, 29, 21, 30, 41, tzinfo=UTC).astimezone()
    assert when == f"{local.day} {local:%b %Y, %H:%M}"
    assert "T" not in when and "+00:00" not in when
    summary = {
        "plugin": SID,
        "label": f"{SID} acceptance test",
        "finished": stamp,
        "outputs": {
            "standard_name": "VDI/VDE 2634 part 2",
            "system": {"name": "Stereo FP"},
            "verdict": "pass",
            "verdict_guarded": "inconclusive",
        },
    }
    assert result_title(summary, "VDI/VDE 2634 part 2 (area-scanning systems)") == (
        "Acceptance test VDI/VDE 2634 part 2: passed",
        f"guarded: inconclusive · {when} · Stereo FP",
    )
    position = {
        "plugin": SID,
        "label": f"{SID} sphere-03 · Stereo FP",
        "finished": stamp,
        "outputs": {"test": "sphere", "position": "sphere-03", "repeat": 1},
    }
    assert result_title(position, "VDI/VDE 2634 part 2 (area-scanning systems)") == (
        "VDI/VDE 2634 part 2: sphere-03 (sphere)",
        f"Stereo FP · {when}",
    )
    assert verdict_text(None) == "incomplete" and verdict_text("fail") == "failed"
    row = result_row(summary, default_host() if real_vdi2634_available() else None)
    assert row["id"] == "" and row["plugin"] == SID and row["time"] == stamp  # the keys callers read stay


# -- the plan options form ------------------------------------------------------------------------------
@needs_real
def test_plan_options_form_comes_from_the_declaration(tmp_path):
    with Project.create(tmp_path / "p") as project:
        w = Wizard(project)
        declared = w.plan_options(SID)
        fields = {f["key"]: f for f in form_fields(declared)}
        assert list(fields) == ["outliers", "unit", "options.extract_sphere"]  # part 2: no repeats, no scaling
        assert fields["options.extract_sphere"]["widget"] == "switch"
        units = {i["value"]: i["title"] for i in fields["unit"]["items"]}
        assert units[""] == "(the standard's default)" and units["um"] == "µm"  # words, the plan value stays "um"
        assert all("_" not in f["label"] for f in fields.values())  # no key as a label
        part3 = {f["key"] for f in form_fields(w.plan_options("vdi2634-3"))}
        assert {"repeats", "scaling.sphere", "scaling.ball_plate"} <= part3
        # flat form values -> plan keys; blank and a switch left off: the standard's default
        flat = {"outliers": "percent:5", "unit": "", "options.extract_sphere": True}
        assert nest(coerce(flat, declared)) == {"outliers": "percent:5", "options": {"extract_sphere": True}}
        text = to_yaml(flat, declared)
        assert yaml.safe_load(text) == {"outliers": "percent:5", "options": {"extract_sphere": True}}
        # YAML import round-trips, keys the form does not declare (a rule per test) kept
        imported = parse_options("outliers: {sphere: 'percent:5'}\noptions: {extract_sphere: true}\nunit: m")
        back = flatten(imported, declared)
        assert back == {"outliers": {"sphere": "percent:5"}, "unit": "m", "options.extract_sphere": True}
        assert nest(coerce(back, declared)) == imported
        # the declared type and limits hold: a typed "3" is an int, 0 repeats refused naming the field
        d3 = w.plan_options("vdi2634-3")
        assert coerce({"repeats": "3"}, d3) == {"repeats": 3}
        with pytest.raises(InputError, match="plan option 'Repeats of every position'"):
            coerce({"repeats": "0"}, d3)
        # the plan the wizard builds carries them under the contract's keys
        plan = w.build_plan(SID, "S", VOLUME, MPE, {t: dict(a) for t, a in ARTEFACTS.items()}, flat)
        assert plan["outliers"] == "percent:5" and plan["options"] == {"extract_sphere": True}
        assert "unit" not in plan


# -- which test is current ---------------------------------------------------------------------------
@needs_real
def test_a_second_session_never_saves_its_old_copy_over_a_new_test(tmp_path):
    """Two wizards on one project (two tabs): A sets up a new test; B's import into the old
    one is refused (one line) instead of bringing the old test back; B resumes A's."""
    with Project.create(tmp_path / "p") as project:
        a = Wizard(project)
        _setup(a, "Scanner A")
        b = Wizard(project)  # the second tab, opened on the same test
        assert b.identity == a.identity and b.saved.is_current()
        files = write_measurements(tmp_path / "m", _spheres(a), n=800)
        pos, path = files["sphere"][0]
        card = a.import_measurement("sphere", pos, path)
        assert card["status"] == "done"
        assert a.worth_keeping() and not b.saved.is_current()  # B's copy is older now
        question = a.supersede_question()
        assert question["name"].startswith("VDI/VDE 2634 part 2 — Scanner A, started ")
        assert question["status"] == "running" and "1 measured position(s) stay" in question["kept"]
        _setup(a, "Scanner B")  # A replaces it: the old test goes to the history
        history = project.get_state(HISTORY_KEY)
        assert [h["system"] for h in history] == ["Scanner A"] and history[0]["measurements"]["sphere"]
        pos2, path2 = files["sphere"][1]
        job = b.prepare("sphere", pos2)
        b.evaluate(job, path2)
        with pytest.raises(InputError, match="another window changed the acceptance test"):
            b.record(job)
        assert project.get_state("acceptance.current")["plan"]["system"]["name"] == "Scanner B"  # not undone
        b.resume()
        assert b.identity == a.identity and b.plan["system"]["name"] == "Scanner B"
        earlier = b.earlier_tests()
        assert len(earlier) == 1 and earlier[0]["name"].startswith("VDI/VDE 2634 part 2 — Scanner A")
        assert earlier[0]["status"] == "not finished"


class _State:
    """An attribute bag, as the trame state is to a page (hashable: a Job keys on it)."""


class _Shared:
    """The shared 3D view's scenes: nothing drawn here."""

    def clear(self, *args, **kw):
        pass

    def show_object(self, *args, **kw):
        pass


class _Session:
    """What a WizardPage asks of its session, for a tab's page without a GUI server
    (building one costs seconds): the project (a connection of its own), the host,
    messages, and the item watchers that ``refresh_items`` calls as
    :meth:`camcmm.gui.session.Session.refresh_items` does after another session's commit."""

    def __init__(self, project, host):
        self.state, self.project, self.host, self.watchers = _State(), project, host, []
        self.shared = _Shared()

    def watch_items(self, fn):
        self.watchers.append(fn)

    def info(self, msg, page=None):
        self.state.info_message = msg

    def error(self, msg, page=None):
        self.state.error_message = msg

    def flush(self):
        pass

    def refresh_items(self):
        for fn in self.watchers:
            fn()


@needs_real
def test_page_asks_before_replacing_and_the_other_tab_follows(tmp_path):
    """Set up a new test / Start over a test with work in it opens the question (named,
    with where the old one stays); Keep leaves everything; going on makes the new test
    current, and the other tab's page shows it once the item list is refreshed (what the
    session does after another session's commit): both name the same test and verdict."""
    pytest.importorskip("trame")
    from camcmm.gui.pages.acceptance import WizardPage

    host = default_host()
    project_a = Project.create(tmp_path / "proj")
    session_a = _Session(project_a, host)
    page_a = WizardPage(session_a, downloads=tmp_path / "dl-a")
    sa = session_a.state
    page_a.choose_standard(SID, sa.wz_form)
    form = json.loads(json.dumps(sa.wz_form))
    form["system_name"], form["mpe"] = "Scanner A", {k: str(v) for k, v in MPE.items()}
    assert page_a.start(form), sa.wz_setup_error
    files = write_measurements(tmp_path / "m", _spheres(page_a.wizard), n=800)
    (pos, path), (pos2, path2) = files["sphere"]
    assert page_a.wizard.import_measurement("sphere", pos, path)["status"] == "done"
    session_a.refresh_items()  # A's own commit: nothing to follow
    assert sa.wz_test_name.startswith("VDI/VDE 2634 part 2 — Scanner A")

    with Project.open(tmp_path / "proj") as project_b:
        session_b = _Session(project_b, session_a.host)
        page_b = WizardPage(session_b, downloads=tmp_path / "dl-b")  # the second tab
        sb = session_b.state
        try:
            assert sb.wz_test_name == sa.wz_test_name and "Scanner A" in sb.wz_test_name
            page_b.ask_new_test()  # a position is measured: the question; the form stays locked
            assert sb.wz_supersede["action"] == "unlock" and sb.wz_locked
            assert sb.wz_supersede["name"] == sb.wz_test_name and sb.wz_supersede["status"] == "running"
            page_b.cancel_supersede()
            assert sb.wz_supersede is None and sb.wz_locked
            page_b.ask_new_test()
            page_b.confirm_supersede(sb.wz_supersede["id"])
            assert not sb.wz_locked and sb.wz_supersede is None
            # plan options read from YAML: the form's own keys left out, a bad one refused in one line
            assert not page_b.import_options("unit: [", sb.wz_form)
            assert sb.wz_options_error.startswith("plan options (YAML): ") and "\n" not in sb.wz_options_error
            assert page_b.import_options("unit: mm\nmpe: {PF: 1}\noptions: {extract_sphere: true}", sb.wz_form)
            assert sb.wz_options_error == "" and sb.wz_form["options"]["unit"] == "mm"
            assert sb.wz_options_note == "left out of the YAML (the form above sets them): mpe"
            assert sb.wz_form["options"]["options.extract_sphere"] is True and "mpe" not in sb.wz_form["options"]
            assert sb.wz_form["options"]["outliers"] == ""  # not in the YAML: the standard's default
            assert yaml.safe_load(sb.wz_options_yaml) == {"unit": "mm", "options": {"extract_sphere": True}}
            form_b = json.loads(json.dumps(sb.wz_form))
            form_b["system_name"] = "Scanner B"
            assert page_b.start(form_b), sb.wz_setup_error  # agreed above: no second question
            plan_b = page_b.wizard.plan
            assert plan_b["unit"] == "mm" and plan_b["options"] == {"extract_sphere": True}
            assert plan_b["mpe"]["PF"] == MPE["PF"]  # the YAML's mpe did not replace the form's
            assert "Scanner B" in sb.wz_test_name and sb.wz_test_status == "running"
            assert sb.wz_earlier[0]["name"].startswith("VDI/VDE 2634 part 2 — Scanner A")

            assert "Scanner A" in sa.wz_test_name  # A has not looked yet
            session_a.refresh_items()  # after B's commit (the session's change check); the page follows
            assert "Scanner B" in sa.wz_test_name and sa.wz_test_status == sb.wz_test_status
            assert sa.wz_verdict == sb.wz_verdict and sa.wz_earlier == sb.wz_earlier
            assert page_a.follow_project() is False  # nothing new since: nothing published

            # A's Start over B's test once it holds a position asks too, naming B's test
            assert page_b.wizard.import_measurement("sphere", pos2, path2)["status"] == "done"
            page_b.refresh()  # as the page's import does after recording
            session_a.refresh_items()
            assert (
                sa.wz_progress_text
                == sb.wz_progress_text
                == "1 of 10 sphere positions · 0 of 7 ball bar orientations · 0 of 6 flat orientations"
            )
            page_a.unlock()
            form_a = json.loads(json.dumps(sa.wz_form))
            assert page_a.start(form_a) is False and sa.wz_supersede["action"] == "start"
            assert "Scanner B" in sa.wz_supersede["name"]
            assert page_a.confirm_supersede(sa.wz_supersede["id"], form_a), sa.wz_setup_error
            assert len(page_a.wizard.earlier_tests()) == 2
            session_b.refresh_items()  # B follows A's new test as well
            assert sb.wz_test_name == sa.wz_test_name

            # a form being filled in stays as typed when another tab starts a test meanwhile,
            # and its Start asks again, naming the test that is current now
            page_a.wizard.import_measurement("sphere", pos, path)
            session_b.refresh_items()
            page_b.ask_new_test()
            page_b.confirm_supersede(sb.wz_supersede["id"])
            typed = {**json.loads(json.dumps(sb.wz_form)), "system_name": "Scanner C"}
            sb.wz_form = typed
            form_a = {**json.loads(json.dumps(sa.wz_form)), "system_name": "Scanner D"}
            page_a.unlock()
            page_a.start(form_a)
            page_a.confirm_supersede(sa.wz_supersede["id"], form_a)
            page_a.wizard.import_measurement("sphere", pos, path)  # work in it: a new Start must ask
            session_b.refresh_items()
            assert "Scanner D" in sb.wz_test_name and not sb.wz_locked and sb.wz_form["system_name"] == "Scanner C"
            assert page_b.start(typed) is False and "Scanner D" in sb.wz_supersede["name"]
        finally:
            page_b.close()
            page_a.close()
            project_a.close()
