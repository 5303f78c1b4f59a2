"""The acceptance test without trame (camcmm.tasks.acceptance): a whole VDI/VDE 2634-2 test
through the headless :class:`Wizard` with the real ``vdi2634-2`` plugin — setup, one import
per position (clouds generated with numpy, helpers.acceptance_data), a refused file and a
redo, the summary and the report — every stored result a :class:`RunResult` row; a second
Wizard on the same project restores the same test; and the demo's saved test is exactly
what the wizard makes of the same simulated measurements."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from camcmm.errors import InputError
from camcmm.host import RunResult, default_host
from camcmm.project import Project
from camcmm.tasks.acceptance import FORM_KEYS, STATE_KEY, TestState, Wizard
from helpers.acceptance_data import ARTEFACTS, MPE, VOLUME, real_vdi2634_available, write_measurements

pytestmark = pytest.mark.skipif(not real_vdi2634_available(), reason="needs the vdi2634-2 plugin")

#: What differs between two runs of the same test: when they ran.
_TIMES = ("created", "updated")


def _run_row(project: Project, rid: int) -> RunResult:
    row = project.result(int(rid))
    run = RunResult.from_json(row)
    assert run.to_json() == {k: row[k] for k in run.to_json()}  # the row is the run, nothing lost
    return run


@pytest.mark.slow
def test_full_part2_test_through_the_task_and_restored(tmp_path):
    host = default_host()
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        assert not w.active and w.state is None and "vdi2634-2" in [s["id"] for s in w.standards()]
        w.setup("vdi2634-2", "Test scanner", VOLUME, MPE, {t: dict(a) for t, a in ARTEFACTS.items()})
        assert project.get_state(STATE_KEY)["standard"] == "vdi2634-2"
        assert [p["text"] for p in w.progress()] == [
            "0 of 10 sphere positions",
            "0 of 7 ball bar orientations",
            "0 of 6 flat orientations",
        ]
        files = write_measurements(tmp_path / "meas", w.requirements())

        # a file that is no measurement: refused for its position only
        bad = tmp_path / "bad.ply"
        bad.write_text("not a ply file")
        card = w.import_measurement("sphere", "sphere-01", bad)
        assert card["status"] == "error" and card["error"].startswith("bad.ply")
        assert w.state["errors"]["sphere/sphere-01"] == card["error"] and w.progress()[0]["done"] == 0

        for test, done in files.items():
            for pos, path in done:
                card = w.import_measurement(test, pos, path)
                assert card["status"] == "done" and card["verdict"] == "pass", card
        assert w.complete and w.state["errors"] == {}
        assert [(p["done"], p["total"]) for p in w.progress()] == [(10, 10), (7, 7), (6, 6)]

        # each evaluation is a run record of the standard plugin, on its measurement's file
        version = host.get("vdi2634-2").version
        for test, mids in w.state["measurements"].items():
            for mid in mids:
                run = _run_row(project, w.state["evaluations"][str(mid)])
                m = project.measurement(mid)
                assert (run.plugin_id, run.plugin_version) == ("vdi2634-2", version)
                assert run.params == {"test": test, "position": m["meta"]["position"], "repeat": 1}
                assert run.input_hashes == {"cloud": m["hash"]} and run.outputs["values"]

        # a redo replaces the position's measurement; the old one leaves the list
        old = w.filled("sphere", "sphere-02")[0][1]
        card = w.redo("sphere", "sphere-02", files["sphere"][1][1])
        new = w.filled("sphere", "sphere-02")[0][1]
        assert card["status"] == "done" and new != old
        assert w.state["superseded"][-1]["measurement"] == old
        assert old not in [m["id"] for m in project.measurements()]

        summary = w.summarize()
        assert summary["verdict"] == "pass" and set(summary["parameters"]) == {"PF", "PS", "SD", "F"}
        out = w.report()
        assert set(out["paths"]) == {"html", "pdf", "json"} and all(p.is_file() for p in out["paths"].values())
        run = _run_row(project, out["summary_result"])
        assert run.plugin_id == "vdi2634-2" and run.outputs["verdict"] == "pass" and run.params == {}
        assert len(run.input_hashes) == 23  # one file hash per measurement of the summary
        assert sorted(project.result(out["summary_result"])["measurement_ids"]) == sorted(
            m for ms in w.state["measurements"].values() for m in ms
        )
        state = copy.deepcopy(w.state)
        cards = w.cards()

        # a restart: a new wizard on the same project has the same test, finished
        w2 = Wizard(project, host)
        assert w2.active and w2.complete and w2.load_error == ""
        assert w2.state == state and w2.cards() == cards
        assert w2.summarize()["verdict"] == "pass" and w2.report_paths() == w.report_paths()
        cloud = w2.deviations("flat", "flat-01")
        assert "deviation" in cloud.fields and cloud.n_points > 0


def test_the_state_of_a_project_without_a_test(tmp_path):
    """No saved test: nothing is active and asking for the plan says what to do."""
    with Project.create(tmp_path / "proj") as project:
        saved = TestState(project, Wizard(project).standards_of)
        assert not saved.resume() and not saved.active and saved.load_error == ""
        with pytest.raises(InputError, match="no acceptance test set up yet"):
            saved.plan  # noqa: B018


@pytest.mark.slow
def test_the_demo_test_is_what_the_wizard_makes_of_the_same_measurements(tmp_path, monkeypatch):
    """The demo drives the wizard: its saved test equals an operator's run by hand (setup
    from the simulator's plan, one import per position, the report) on the same simulated
    measurements, but for the times and the measurement ids (the demo's clouds come first).
    Fewer points per cloud than the demo's own, to keep it short: the flow is the same
    (the demo's full size: tests/standards/test_vdi2634_demo.py)."""
    import camcmm.demo as demo

    host = default_host()
    if "virtuallab.acceptance-set" not in host.plugins:
        pytest.skip("needs the virtual lab's acceptance-set simulator")
    small = {**demo.SIMULATION, "n_sphere": 3000, "n_ball_bar": 2000, "n_flat": 4000}
    monkeypatch.setattr(demo, "SIMULATION", small)
    made = demo.create_demo(tmp_path / "demo")
    assert made["notes"] == [] and made["acceptance"]["verdict"] in ("pass", "fail")

    gen = host.run(
        "virtuallab.acceptance-set",
        {},
        {"directory": str(tmp_path / "set"), "standard": "vdi2634-2", **small},
    )
    plan, folder = gen.outputs["plan_dict"], Path(gen.outputs["plan"]).parent
    with Project.create(tmp_path / "by-hand", name="camcmm demo") as project:
        w = Wizard(project, host)
        arts = {}
        for test, entry in plan["artefacts"].items():
            arts[test] = {**entry, "_id": f"vdi2634-2:{test}", "_name": f"{test.replace('_', ' ')} (simulated)"}
        w.setup(
            "vdi2634-2",
            plan["system"]["name"],
            plan["system"]["measuring_volume"],
            plan["mpe"],
            arts,
            options={k: v for k, v in plan.items() if k not in FORM_KEYS},
        )
        for test, names in plan["measurements"].items():
            for pos, name in zip(w.requirement(test)["positions"], names):
                assert w.import_measurement(test, pos["id"], folder / name)["status"] == "done"
        w.report()
        by_hand = _comparable(project, w.state)
    with Project.open(tmp_path / "demo") as project:
        assert _comparable(project, project.get_state(STATE_KEY)) == by_hand


def _comparable(project: Project, state: dict) -> dict:
    """A saved test with measurement, result and file ids replaced by what they stand for:
    file names, stored outputs; times left out."""
    state = copy.deepcopy(state)
    for key in _TIMES:
        state.pop(key, None)

    def name(mid):
        return None if mid is None else project.measurement(int(mid))["meta"]["file"]

    state["measurements"] = {t: [name(m) for m in ms] for t, ms in state["measurements"].items()}
    state["positions"] = {
        t: {p: [name(m) for m in slot] for p, slot in slots.items()} for t, slots in state["positions"].items()
    }
    state["evaluations"] = {
        name(mid): RunResult.from_json(project.result(int(rid))).outputs for mid, rid in state["evaluations"].items()
    }
    summary = RunResult.from_json(project.result(int(state.pop("summary_result"))))
    state["summary"] = {k: summary.outputs[k] for k in ("verdict", "verdict_guarded", "parameters")}
    state["report"] = sorted(state["report"])
    state["plan"].pop("name")  # the project's name in it
    system = project.system(int(state["system_id"]))
    state["system_id"] = (system["name"], system["meta"]["measuring_volume"], system["meta"]["standard"])
    state["artefact_ids"] = {t: project.artefact(a).to_dict() for t, a in state["artefact_ids"].items()}
    return state


@pytest.mark.slow
def test_a_position_acquired_from_the_simulated_system_through_the_task(tmp_path):
    """Measuring instead of importing, without the page: the placement a system is told,
    the simulated stereo fringe system run in a worker, its cloud imported at the position."""
    pytest.importorskip("cv2")
    host = default_host()
    if "virtuallab.fringe-system" not in host.plugins:
        pytest.skip("needs the virtual lab's fringe system")
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        assert "virtuallab.fringe-system" in [s["value"] for s in w.acquisition_sources()]
        w.setup("vdi2634-2", "Virtual stereo fringe system", VOLUME, MPE, {t: dict(a) for t, a in ARTEFACTS.items()})
        where = w.placement("sphere", "sphere-01")
        assert where["test"] == "sphere" and where["position"]["id"] == "sphere-01"
        assert where["measuring_volume"] == VOLUME and set(where["artefacts"]) == {"sphere", "ball_bar", "flat"}
        with pytest.raises(KeyError, match="sphere-99"):
            w.placement("sphere", "sphere-99")
        where["repeat"] = w.prepare("sphere", "sphere-01").repeat
        path = w.acquire("virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector"}, where)
        try:
            card = w.import_measurement("sphere", "sphere-01", path, path.name)
        finally:
            path.unlink()
            path.parent.rmdir()
        assert card["status"] == "done" and card["verdict"] == "pass", card
        assert w.progress()[0]["done"] == 1
