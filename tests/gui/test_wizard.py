"""The acceptance wizard without a browser: the task (camcmm.tasks.acceptance.Wizard) and
its page (camcmm.gui.pages.acceptance.WizardPage) on a real project.

A part-2 test is set up, every position imported (clouds generated here with numpy:
partial spheres with noise, ball bars of two spheres at the calibrated length,
flats), counters checked, a position redone, a bad file refused for its position
only; then a NEW wizard on the same project (a restart) resumes with the same state;
the summary verdict and the report files in the project.

Each flow runs against a small fake standard implementing the typed standard protocol
(camcmm.standard: its declaration, requirements, evaluations; so the wizard's logic is
tested on its own) and against the real ``vdi2634-2`` plugin when it is installed.
"""

from __future__ import annotations

import asyncio
import json
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

cio = pytest.importorskip("camcmm.io")

from camcmm.api import ArtefactField, ArtefactKind, PositionSpec, QualityParameter, StandardDeclaration, TestDeclaration  # noqa: E402
from camcmm.errors import GeometryError, InputError  # noqa: E402
from camcmm.host import default_host  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402
from camcmm.project import Project  # noqa: E402
from camcmm.tasks.acceptance import STATE_KEY, Wizard, artefact_plan_fields, load_catalogue, plan_fields_to_artefact  # noqa: E402
from camcmm_plugins.vdi2634.pictograms import pictogram, pictograms  # noqa: E402
from helpers.acceptance_data import (  # noqa: E402
    ARTEFACTS,
    BAR_L,
    MPE,
    SPHERE_D,
    VOLUME,
    make_cloud,
    real_vdi2634_available,
    sphere_cloud,
    write_measurements,
)

# -- a fake standard speaking the protocol (independent of the real plugin) ---------------------
_POS = {
    "sphere": [
        {
            "id": f"sphere-{i + 1:02d}",
            "label": f"Sphere position {i + 1}",
            "hint": "somewhere",
            "where": [(-0.3 + 0.06 * i), 0.2 * ((-1) ** i), 0.1 * (i % 3)],
        }
        for i in range(10)
    ],
    "ball_bar": [
        {
            "id": f"ball-bar-{i + 1:02d}",
            "label": f"Ball bar orientation {i + 1}",
            "hint": "a direction",
            "where": [0, 0, 0],
            "direction": d,
        }
        for i, d in enumerate([[0, 0.5, 0.866], [1, 1, 1], [-1, 1, 1], [1, -1, 1], [-1, -1, 1], [1, 0, 0], [0, 1, 0]])
    ],
    "flat": [
        {
            "id": f"flat-{i + 1:02d}",
            "label": f"Flat orientation {i + 1}",
            "hint": "an orientation",
            "where": [0, 0, 0],
            "direction": d,
            "normal": nn,
        }
        for i, (d, nn) in enumerate(
            [
                ([1, 1, 0], [0, 0, 1]),
                ([1, -1, 0], [0, 0, 1]),
                ([1, 0, 1], [-1, 0, 1]),
                ([-1, 0, 1], [1, 0, 1]),
                ([0, 1, 1], [0, -1, 1]),
                ([0, -1, 1], [0, 1, 1]),
            ]
        )
    ],
}
_TESTS = [
    ("sphere", "Sphere positions", ["PF", "PS"], 10),
    ("ball_bar", "Ball bar orientations", ["SD"], 7),
    ("flat", "Flat orientations", ["F"], 6),
]


def _fit_sphere(p):
    a = np.column_stack([2 * p, np.ones(len(p))])
    sol = np.linalg.lstsq(a, (p**2).sum(1), rcond=None)[0]
    c = sol[:3]
    r = float(np.sqrt(sol[3] + c @ c))
    return c, r, np.linalg.norm(p - c, axis=1) - r


_FIELDS = {
    "sphere": (
        ArtefactField("diameter", "Diameter (calibrated)", certificate="diameter", uncertainty="uncertainty"),
        ArtefactField("uncertainty", "Its uncertainty U"),
        ArtefactField("k", "Coverage factor k", unit=""),
    ),
    "ball_bar": (
        ArtefactField("length", "Length (calibrated)", certificate="length", uncertainty="uncertainty"),
        ArtefactField("uncertainty", "Its uncertainty U"),
        ArtefactField("sphere_diameter", "Sphere"),
    ),
    "flat": (
        ArtefactField("length", "Length"),
        ArtefactField("width", "Width"),
        ArtefactField("flatness", "Flatness", certificate="flatness"),
    ),
}
_DECLARATION = StandardDeclaration(
    "fake-2",
    "Fake standard part 2",
    (
        QualityParameter("PF", "P_F", "form"),
        QualityParameter("PS", "P_S", "size", signed=True),
        QualityParameter("SD", "SD", "spacing", signed=True),
        QualityParameter("F", "F", "flatness"),
    ),
    tuple(ArtefactKind(t, t, f) for t, f in _FIELDS.items()),
    tuple(TestDeclaration(t, label, t, tuple(params), n) for t, label, params, n in _TESTS),
    tuple(PositionSpec(t, p["id"], p["label"], t, p["hint"]) for t, ps in _POS.items() for p in ps),
)


class FakeStandard:
    """The standard protocol with plain numpy fits: what the wizard relies on, nothing more."""

    def __init__(self):
        self.evaluated = 0

    def declare(self):
        return _DECLARATION

    def _plan(self, plan):
        if plan is None:
            return None
        for key in ("PF", "PS", "SD", "F"):
            if key not in (plan.get("mpe") or {}):
                raise InputError(f"plan: mpe.{key} is missing")
        for t, *_ in _TESTS:
            if t not in (plan.get("artefacts") or {}):
                raise InputError(f"plan: artefacts.{t} is missing")
        return plan

    def requirements(self, plan=None):
        self._plan(plan)
        return [
            {
                "test": t,
                "label": label,
                "parameters": params,
                "min_count": n,
                "repeats": 1,
                "required": True,
                "artefact": (plan or {}).get("artefacts", {}).get(t),
                "positions": [dict(p) for p in _POS[t]],
            }
            for t, label, params, n in _TESTS
        ]

    def evaluate_measurement(self, ctx, test, cloud, plan, file=None, position=None, repeat=None):
        plan = self._plan(plan)
        name = file or cloud.name
        p = np.asarray(cloud.points)
        if len(p) < 50:
            raise GeometryError(f"{name}: only {len(p)} points")
        self.evaluated += 1
        if test == "sphere":
            c, r, dev = _fit_sphere(p)
            d_ref = plan["artefacts"]["sphere"]["diameter"]
            if abs(2 * r - d_ref) > 0.25 * d_ref:
                raise GeometryError(f"{name}: no sphere of diameter {d_ref:g} mm in it")
            values = {"PF": float(np.ptp(dev)), "PS": float(2 * r - d_ref)}
            extra = {"center": c.tolist(), "diameter": 2 * r}
        elif test == "ball_bar":
            x = p - p.mean(0)
            axis = np.linalg.svd(x, full_matrices=False)[2][0]
            side = x @ axis > 0
            fits = [_fit_sphere(p[m]) for m in (~side, side)]
            dev = np.empty(len(p))
            dev[~side], dev[side] = fits[0][2], fits[1][2]
            length = float(np.linalg.norm(fits[1][0] - fits[0][0]))
            values = {"SD": length - plan["artefacts"]["ball_bar"]["length"]}
            extra = {"length": length}
        elif test == "flat":
            x = p - p.mean(0)
            nrm = np.linalg.svd(x, full_matrices=False)[2][2]
            dev = x @ nrm
            values = {"F": float(np.ptp(dev))}
            extra = {"normal": nrm.tolist(), "point": p.mean(0).tolist()}
        else:
            raise InputError(f"no test {test}")
        dv = PointCloud(p, fields={"deviation": dev}, field_units={"deviation": "mm"}, name=f"{name} deviations")
        return {"test": test, "values": values, "n_points": len(p), "warnings": [], "deviations": dv, **extra}

    def summarize(self, ctx, plan, per_measurement):
        plan = self._plan(plan)
        params = {}
        for t, _label, names, n in _TESTS:
            evs = [e for e in per_measurement.get(t, []) if not e.get("error")]
            for key in names:
                vals = [e["values"][key] for e in evs]
                value = max(vals, key=abs) if vals else None
                ok = len(evs) >= n
                verdict = "incomplete" if not ok else ("pass" if abs(value) <= plan["mpe"][key] else "fail")
                params[key] = {
                    "name": key,
                    "value": value,
                    "mpe": plan["mpe"][key],
                    "verdict": verdict,
                    "verdict_guarded": verdict,
                    "U": 0.0,
                    "n_evaluated": len(vals),
                    "per_measurement": [{"file": e.get("file"), "value": e["values"][key]} for e in evs],
                }
        verdicts = [p["verdict"] for p in params.values()]
        verdict = "incomplete" if "incomplete" in verdicts else ("fail" if "fail" in verdicts else "pass")
        return {
            "standard": "fake-2",
            "verdict": verdict,
            "verdict_guarded": verdict,
            "parameters": params,
            "warnings": [],
            "measurements": per_measurement,
        }

    def write_report(self, result, directory, plan=None):
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        maps = sum(1 for evs in result["measurements"].values() for e in evs if e.get("deviations") is not None)
        (d / "report.html").write_text(f"<html><body>fake report: {result['verdict']}, {maps} maps</body></html>")
        (d / "report.json").write_text(json.dumps({"verdict": result["verdict"]}))
        (d / "report.pdf").write_bytes(b"%PDF-1.4 fake\n")
        return {"html": str(d / "report.html"), "pdf": str(d / "report.pdf"), "json": str(d / "report.json")}


@dataclass
class _Spec:
    id: str
    kind: str = "standard"
    name: str = "Fake standard part 2"
    version: str = "0.1"
    summary: str = "for tests"
    status: str = "ok"
    inputs: list = field(default_factory=list)
    parameters: list = field(default_factory=list)
    outputs: list = field(default_factory=list)


class FakeHost:
    """What the wizard asks of a host: the standards, load(id), get(id)."""

    def __init__(self):
        self.std = FakeStandard()
        self.plugins = {"fake-2": _Spec("fake-2")}

    def all(self):
        return list(self.plugins.values())

    def check(self):
        return self.all()

    def get(self, pid):
        return self.plugins[pid]

    def load(self, pid):
        return self.std

    def providing(self, task):
        return []

    def provider(self, task):  # the other pages ask for their tasks: none here
        from camcmm.errors import PluginError

        raise PluginError(f"no plugin provides {task!r}")


@pytest.fixture(params=["fake", "real"])
def kit(request):
    """(host, standard id) for the fake standard and the real vdi2634-2."""
    if request.param == "fake":
        return FakeHost(), "fake-2"
    if not real_vdi2634_available():
        pytest.skip("the vdi2634-2 plugin is not installed (yet)")
    return default_host(), "vdi2634-2"


def _setup(w: Wizard, sid: str) -> None:
    w.setup(sid, "Test scanner", VOLUME, MPE, {t: dict(a) for t, a in ARTEFACTS.items()})


def _counts(w: Wizard) -> dict[str, tuple[int, int]]:
    return {p["test"]: (p["done"], p["total"]) for p in w.progress()}


# -- the flow ---------------------------------------------------------------------------------------
@pytest.mark.slow
def test_full_part2_test_with_redo_bad_file_restart_and_report(tmp_path, kit):
    host, sid = kit
    project = Project.create(tmp_path / "proj")
    w = Wizard(project, host)
    assert not w.active and w.state is None
    assert sid in [s["id"] for s in w.standards()]
    _setup(w, sid)
    assert project.get_state(STATE_KEY)["standard"] == sid
    texts = [p["text"] for p in w.progress()]
    assert texts == ["0 of 10 sphere positions", "0 of 7 ball bar orientations", "0 of 6 flat orientations"]

    files = write_measurements(tmp_path / "meas", w.requirements())
    # the sphere positions: the counter advances with each
    for i, (pos, path) in enumerate(files["sphere"][:7]):
        card = w.import_measurement("sphere", pos, path)
        assert card["status"] == "done", card
        assert card["verdict"] == "pass"
        assert [v["param"] for v in card["repeats"][0]["values"]] == ["PF", "PS"]
        assert _counts(w)["sphere"] == (i + 1, 10)
    assert w.progress()[0]["text"] == "7 of 10 sphere positions"
    assert w.summarize()["verdict"] == "incomplete"

    # a bad file: a message for that position only, nothing else changes
    before = (json.dumps(w.state["positions"]), len(project.measurements()), len(project.results()))
    bad = tmp_path / "broken.xyz"
    bad.write_text("1 2 3\n4 nan 6\n")
    card = w.import_measurement("sphere", "sphere-08", bad)
    assert card["status"] == "error" and "broken.xyz" in card["error"], card
    wrong = tmp_path / "a-flat.ply"  # readable, but no sphere in it
    cio.write(make_cloud("flat", {"direction": [1, 0, 0]}, 99), wrong)
    card = w.import_measurement("sphere", "sphere-09", wrong)
    assert card["status"] == "error" and "a-flat.ply" in card["error"]
    after = (json.dumps(w.state["positions"]), len(project.measurements()), len(project.results()))
    assert before == after
    others = [c for c in w.cards()[0]["cards"] if c["id"] not in ("sphere-08", "sphere-09")]
    assert all(c["error"] == "" for c in others)
    assert _counts(w)["sphere"] == (7, 10)

    # the remaining positions; the error goes once the position is measured
    for pos, path in files["sphere"][7:]:
        assert w.import_measurement("sphere", pos, path)["status"] == "done"
    assert w.card("sphere", "sphere-08")["error"] == ""
    for test in ("ball_bar", "flat"):
        for pos, path in files[test]:
            card = w.import_measurement(test, pos, path)
            assert card["status"] == "done" and card["verdict"] == "pass", card
    assert [p["text"] for p in w.progress()] == [
        "10 of 10 sphere positions",
        "7 of 7 ball bar orientations",
        "6 of 6 flat orientations",
    ]
    assert w.complete

    # redo: a new measurement replaces the evaluation of that position
    mid_old = w.state["positions"]["sphere"]["sphere-03"][0]
    pf_old = w.evaluation(mid_old)["values"]["PF"]
    noisy = tmp_path / "sphere-03-again.ply"
    cio.write(
        sphere_cloud(np.asarray(w.requirements()[0]["positions"][2]["where"]) * VOLUME, 4000, noise=0.015, seed=1234),
        noisy,
    )
    card = w.redo("sphere", "sphere-03", noisy)
    mid_new = w.state["positions"]["sphere"]["sphere-03"][0]
    assert mid_new != mid_old and card["status"] == "done"
    assert card["repeats"][0]["file"] == "sphere-03-again.ply"
    assert w.evaluation(mid_new)["values"]["PF"] != pf_old
    assert str(mid_old) not in [str(m) for m in w.state["measurements"]["sphere"]]
    assert mid_old not in [m["id"] for m in project.measurements()]  # soft-deleted, still in the store
    assert project.measurement(mid_old)["removed"]
    assert w.state["superseded"][-1]["measurement"] == mid_old
    assert _counts(w)["sphere"] == (10, 10)

    summary = w.summarize()
    assert summary["verdict"] == "pass"
    per_file = [r.get("file") for r in summary["parameters"]["PF"]["per_measurement"]]
    assert "sphere-03-again.ply" in per_file and "sphere-03.ply" not in per_file

    # a restart: a new wizard on the reopened project resumes with the same state
    cards_before = w.cards()
    state_before = json.loads(json.dumps(w.state))
    project.close()
    project2 = Project.open(tmp_path / "proj")
    w2 = Wizard(project2, host)
    assert w2.active and w2.load_error == ""
    assert w2.state["positions"] == state_before["positions"]
    assert w2.state["evaluations"] == state_before["evaluations"]
    assert w2.cards() == cards_before
    assert w2.complete
    assert w2.summarize()["verdict"] == "pass"

    # the report: one call; its files are in the project
    out = w2.report()
    assert set(out["paths"]) == {"html", "pdf", "json"}
    for _kind, path in out["paths"].items():
        assert Path(path).is_file() and Path(path).stat().st_size > 0
        assert str(path).startswith(str(project2.path))
    res = project2.result(out["summary_result"])
    assert set(res["files"]) == {"report_html", "report_pdf", "report_json"}
    assert res["outputs"]["verdict"] == "pass"
    assert len(res["measurement_ids"]) == 23
    st = project2.get_state(STATE_KEY)
    assert st["summary_result"] == out["summary_result"] and st["verdict"] == "pass"
    html = Path(out["paths"]["html"]).read_text(errors="replace")
    if sid == "fake-2":
        assert "23 maps" in html  # the colour maps got their deviation clouds back from the project
    else:
        assert "VDI/VDE 2634" in html
    # and after another restart the report is still offered
    assert set(Wizard(project2, host).report_paths()) == {"html", "pdf", "json"}
    project2.close()


def test_resume_half_done_test_and_continue(tmp_path, kit):
    host, sid = kit
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        _setup(w, sid)
        files = write_measurements(tmp_path / "meas", w.requirements(), n=1500)
        for pos, path in files["sphere"][:5]:
            w.import_measurement("sphere", pos, path)
    with Project.open(tmp_path / "proj") as project:
        w = Wizard(project, host)
        assert w.progress()[0]["text"] == "5 of 10 sphere positions"
        statuses = [c["status"] for c in w.cards()[0]["cards"]]
        assert statuses == ["done"] * 5 + ["pending"] * 5
        pos, path = files["sphere"][5]
        assert w.import_measurement("sphere", pos, path)["status"] == "done"
        assert w.progress()[0]["text"] == "6 of 10 sphere positions"
        assert w.summarize()["verdict"] == "incomplete"


def test_setup_errors_name_the_field(tmp_path):
    host = FakeHost()
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        with pytest.raises(InputError, match="measuring system"):
            w.setup("fake-2", "", VOLUME, MPE, ARTEFACTS)
        with pytest.raises(InputError, match="measuring volume"):
            w.setup("fake-2", "S", [100, 0, 100], MPE, ARTEFACTS)
        with pytest.raises(InputError, match="MPE P_F.*abc"):
            w.setup("fake-2", "S", VOLUME, {**MPE, "PF": "abc"}, ARTEFACTS)
        with pytest.raises(InputError, match="MPE SD is empty"):
            w.setup("fake-2", "S", VOLUME, {k: v for k, v in MPE.items() if k != "SD"}, ARTEFACTS)
        with pytest.raises(InputError, match="ball bar"):
            w.setup("fake-2", "S", VOLUME, MPE, {**ARTEFACTS, "ball_bar": {**ARTEFACTS["ball_bar"], "length": "x"}})
        assert project.get_state(STATE_KEY) is None  # nothing saved by a refused setup
        with pytest.raises(InputError, match="set up"):
            w.prepare("sphere", "sphere-01")
        _setup(w, "fake-2")
        with pytest.raises(InputError, match="no position 'sphere-99'"):
            w.import_measurement("sphere", "sphere-99", tmp_path / "x.ply")
        missing = w.import_measurement("sphere", "sphere-01", tmp_path / "nope.ply")
        assert missing["status"] == "error" and "nope.ply: no such file" in missing["error"]


def test_new_setup_keeps_the_previous_test_in_the_history(tmp_path):
    host = FakeHost()
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        _setup(w, "fake-2")
        files = write_measurements(tmp_path / "meas", w.requirements(), n=800)
        w.import_measurement("sphere", *files["sphere"][0])
        _setup(w, "fake-2")
        assert _counts(w)["sphere"] == (0, 10)
        history = project.get_state("acceptance.history")
        assert len(history) == 1 and history[0]["measurements"]["sphere"]


def test_catalogue_round_trip_and_own_artefacts(tmp_path):
    cat = load_catalogue()
    kinds = {a["kind"] for a in cat}
    assert {"sphere", "ball_bar", "flat"} <= kinds
    sphere = next(a for a in cat if a["id"] == "sphere-20")
    f = artefact_plan_fields(sphere)
    assert f["diameter"] == 20.001 and f["uncertainty"] == 0.001 and f["k"] == 2
    flat = artefact_plan_fields(next(a for a in cat if a["kind"] == "flat"))
    assert flat["length"] == 150.0 and flat["flatness_uncertainty"] == 0.0005
    back = plan_fields_to_artefact(
        "ball_bar",
        {"length": 49.9, "uncertainty": 0.001, "k": 2, "sphere_diameter": 20},
        "bb-own",
        "own bar",
        _DECLARATION.artefact("ball_bar"),
    )
    assert back["certificates"]["length"]["value"] == 49.9 and back["nominal"]["sphere_diameter"] == 20
    host = FakeHost()
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        w.setup(
            "fake-2", "S", VOLUME, MPE, {t: {**a, "_id": f"{t}-lab", "_name": f"lab {t}"} for t, a in ARTEFACTS.items()}
        )
        own = {a["id"]: a for a in w.catalogue() if a.get("source") == "project"}
        assert {"sphere-lab", "ball_bar-lab", "flat-lab"} <= set(own)
        assert artefact_plan_fields(own["sphere-lab"])["diameter"] == SPHERE_D


def test_pictograms_are_svg_for_every_position():
    host = FakeHost()
    reqs = host.std.requirements(None)
    plan = {"system": {"measuring_volume": VOLUME}, "artefacts": ARTEFACTS}
    svgs = pictograms(reqs, plan)
    assert len(svgs) == 23
    for _key, svg in svgs.items():
        root = ET.fromstring(svg)
        assert root.tag.endswith("svg") and root.get("viewBox")
        assert any(el.tag.endswith(("circle", "polygon")) for el in root.iter())
    # a sphere's ball sits where the standard wants it: higher position -> smaller y on screen
    low = pictogram("sphere", {"id": "a", "where": [0, 0, -0.3]}, VOLUME, ARTEFACTS["sphere"])
    high = pictogram("sphere", {"id": "b", "where": [0, 0, 0.3]}, VOLUME, ARTEFACTS["sphere"])

    def ball_y(svg):
        circles = [c for c in ET.fromstring(svg).iter() if c.tag.endswith("circle") and "url(" in (c.get("fill") or "")]
        return float(circles[0].get("cy"))

    assert ball_y(high) < ball_y(low)
    if real_vdi2634_available():
        for sid in ("vdi2634-2", "vdi2634-3"):
            std = default_host().load(sid)
            for _key, svg in pictograms(std.requirements(None), plan).items():
                ET.fromstring(svg)


# -- the page (trame state) -------------------------------------------------------------------------
pytest.importorskip("trame")


@pytest.fixture
def gui(gui_app):
    def make(project_dir, host=None):
        server, session = gui_app(project_dir, host=host)
        return server, session, server.pages["acceptance"]

    return make


@pytest.mark.slow
def test_page_setup_import_view_and_report(tmp_path, gui, kit):
    host, sid = kit
    server, session, page = gui(tmp_path / "proj", host=host)
    session.shared.enter("acceptance")  # the page is shown: its colour maps draw in the 3D view
    state = server.state
    assert state.wz_active is False and state.wz_step == "setup"
    assert sid in [s["value"] for s in state.wz_standards]
    page.choose_standard(sid, state.wz_form)
    form = json.loads(json.dumps(state.wz_form))
    assert set(form["artefacts"]) == {"sphere", "ball_bar", "flat"}
    assert form["artefacts"]["sphere"]["_choice"]  # a catalogue artefact is preselected
    assert not page.start(form) and "measuring system" in state.wz_setup_error
    form["system_name"] = "Scanner"
    assert not page.start(form) and "MPE" in state.wz_setup_error
    form["mpe"] = {k: str(v) for k, v in MPE.items()}
    page.pick_artefact("sphere", "sphere-20", form)
    form = json.loads(json.dumps(state.wz_form))
    form["system_name"], form["mpe"] = "Scanner", {k: str(v) for k, v in MPE.items()}
    assert form["artefacts"]["sphere"]["diameter"] == 20.001
    assert state.wz_artefact_warnings == []  # the default 90 mm cube: the catalogue's artefacts meet the rules
    assert page.start(form), state.wz_setup_error
    assert state.wz_active and state.wz_step == "positions" and state.wz_locked
    assert state.wz_test_status == "running"
    assert len(state.wz_svgs) == 23 and all(s.startswith("<svg") for s in state.wz_svgs.values())
    assert state.wz_progress[0]["text"] == "0 of 10 sphere positions"

    files = write_measurements(tmp_path / "meas", page.wizard.requirements(), n=1500)
    pos, path = files["sphere"][0]
    asyncio.run(page.import_async("sphere", pos, path.read_bytes(), path.name))  # an upload, in the worker
    assert state.wz_progress[0]["text"] == "1 of 10 sphere positions"
    card = state.wz_blocks[0]["cards"][0]
    assert card["status"] == "done" and card["verdict"] == "pass" and not card["busy"]
    assert session.view.scalar_bar_title == "deviation [µm]"  # the colour map is in the 3D view
    assert state.legend_title == "deviation [µm]"
    assert state.wz_detail["title"] == pos and state.wz_detail["rows"]
    assert any(it["name"].startswith(pos) for it in state.items)  # the Inspect page lists it too

    # a bad upload: the card says why, the error line too; the rest stays
    asyncio.run(page.import_async("sphere", "sphere-02", b"1 2 3\n4 nan 6\n", "bad.xyz"))
    card2 = state.wz_blocks[0]["cards"][1]
    assert card2["status"] == "error" and "bad.xyz" in card2["error"]
    assert "bad.xyz" in state.error_message
    assert state.wz_progress[0]["text"] == "1 of 10 sphere positions"

    for test in ("sphere", "ball_bar", "flat"):
        for pos, path in files[test]:
            if (test, pos) != ("sphere", "sphere-01"):
                asyncio.run(page.import_async(test, pos, path))
    assert state.wz_complete and state.wz_verdict == "pass"
    assert state.wz_test_status == "every position measured, no report yet"
    assert [r["key"] for r in state.wz_parameters] == ["PF", "PS", "SD", "F"]
    assert all(r["verdict"] == "pass" for r in state.wz_parameters)
    page.redo("flat", "flat-02")
    assert state.wz_redo == "flat/flat-02"
    page.show("ball_bar", "ball-bar-03")
    assert state.wz_detail["title"] == "ball-bar-03" and session.view.scalar_bar_title == "deviation [µm]"

    out = asyncio.run(page.report_async())
    assert out is not None, state.error_message
    kinds = [link["kind"] for link in state.wz_report_links]
    assert kinds == ["html", "pdf", "json"]
    for link in state.wz_report_links:
        assert link["url"].startswith("camcmm-downloads/")
        assert (page.downloads / link["name"]).is_file()
    assert any(r["id"] == str(out["summary_result"]) for r in state.results)
    assert state.wz_test_status.startswith("finished: passed; passed with the test uncertainty")  # not "running"

    # a restart of the server: the page opens on the result, the report still offered
    server.pages["acceptance"].close()
    server.session.close()
    server.session.project.close()
    server2, _s2, page2 = gui(tmp_path / "proj", host=host)
    assert server2.state.wz_step == "result" and server2.state.wz_verdict == "pass"
    assert [link["kind"] for link in server2.state.wz_report_links] == ["html", "pdf", "json"]
    assert server2.state.wz_form["system_name"] == "Scanner"
    assert server2.state.wz_test_status.startswith("finished: passed")


def test_page_holds_start_while_the_setup_breaks_artefact_rules(tmp_path, gui):
    """The standard's own rules run on the form before Start (vdi2634-2: ball bar length
    >= 0.3 L0, L0 the volume diagonal); a broken rule is listed and Start waits for
    "start anyway", which a different list of broken rules takes back."""
    if not real_vdi2634_available():
        pytest.skip("the vdi2634-2 plugin is not installed (yet)")
    server, _session, page = gui(tmp_path / "proj")
    state = server.state
    page.choose_standard("vdi2634-2", state.wz_form)
    form = json.loads(json.dumps(state.wz_form))
    assert form["volume"] == [90.0, 90.0, 90.0] and form["artefacts"]["ball_bar"]["length"] == BAR_L
    # no MPEs yet: the plan cannot be built, the page says the rules wait for it
    assert page.check_artefacts(form) == [] and "mpe.PF is missing" in state.wz_artefact_note
    form["system_name"], form["mpe"] = "Scanner", {k: str(v) for k, v in MPE.items()}
    assert page.check_artefacts(form) == [] and state.wz_artefact_note == ""  # L0 = 155.9 mm: 46.77 <= 49.944
    # a 100 mm cube: L0 = 100 sqrt(3) = 173.2 mm, 0.3 L0 = 51.96 mm > 49.944 mm
    form["volume"] = list(VOLUME)
    bar = "ball bar: length 49.94 mm is below 0.3 L0 (L0 = 173.2 mm) = 51.96 mm; the evaluation runs, the test "
    bar += "deviates from VDI/VDE 2634"
    state.wz_form = json.loads(json.dumps(form))
    state.flush()  # a change of the form (as the browser sends it) runs the rules
    assert state.wz_artefact_warnings == [bar]
    assert page.check_artefacts(form) == [bar] and state.wz_artefact_warnings == [bar]
    assert not page.start(form) and "start anyway" in state.wz_setup_error and not state.wz_active
    state.wz_confirm_violations = True
    form["artefacts"]["ball_bar"]["length"] = "40"  # shorter still: a new list, the confirmation is taken back
    assert page.check_artefacts(form)[0].startswith("ball bar: length 40 mm is below 0.3 L0")
    assert state.wz_confirm_violations is False
    assert not page.start(form) and not state.wz_active
    state.wz_confirm_violations = True
    assert page.start(form), state.wz_setup_error
    assert state.wz_active and state.wz_step == "positions"
    assert page.wizard.plan["artefacts"]["ball_bar"]["length"] == 40.0
    assert any(w.startswith("ball bar: length 40 mm") for w in state.wz_summary_warnings)  # and in the report


@pytest.mark.slow
def test_demo_project_opens_with_a_finished_test(tmp_path):
    if not real_vdi2634_available() or "virtuallab.acceptance-set" not in default_host().plugins:
        pytest.skip("the demo's acceptance test needs the vdi2634-2 and virtual-lab plugins")
    from camcmm.demo import create_demo

    summary = create_demo(tmp_path / "demo")
    assert summary.get("acceptance"), summary.get("notes")
    with Project.open(tmp_path / "demo") as project:
        w = Wizard(project)
        assert w.active and w.complete
        assert [p["text"] for p in w.progress()] == [
            "10 of 10 sphere positions",
            "7 of 7 ball bar orientations",
            "6 of 6 flat orientations",
        ]
        assert all(c["status"] == "done" for b in w.cards() for c in b["cards"])
        assert w.summarize()["verdict"] == summary["acceptance"]["verdict"]
        assert set(w.report_paths()) == {"html", "pdf", "json"}
        cloud = w.deviations("sphere", "sphere-01")
        assert "deviation" in cloud.fields and cloud.n_points > 0


@pytest.mark.slow
def test_part3_repeats_and_plan_options(tmp_path):
    """vdi2634-3 through the same wizard: positions × repeats, plan options (scaling,
    outliers, repeats) from the setup's advanced field, partial positions."""
    host = default_host()
    needed = ("vdi2634-3", "virtuallab.acceptance-set")
    if not real_vdi2634_available() or any(pid not in host.plugins for pid in needed):
        pytest.skip("needs the vdi2634-3 and virtual-lab plugins")
    gen = host.run(
        "virtuallab.acceptance-set",
        {},
        {
            "directory": str(tmp_path / "set"),
            "standard": "vdi2634-3",
            "n_sphere": 2000,
            "n_ball_plate": 2000,
            "random_scale": True,
        },
    )
    plan = gen.outputs["plan_dict"]
    options = "scaling: {sphere: radii, ball_plate: lengths}\noutliers: {sphere: 'percent:5', ball_plate: 'percent:5'}"
    with Project.create(tmp_path / "proj") as project:
        w = Wizard(project, host)
        with pytest.raises(InputError, match="'mpe' is set by the form"):
            w.setup(
                "vdi2634-3",
                "Turntable",
                plan["system"]["measuring_volume"],
                plan["mpe"],
                plan["artefacts"],
                options="mpe: {PF: 1}",
            )
        w.setup(
            "vdi2634-3",
            "Turntable",
            plan["system"]["measuring_volume"],
            plan["mpe"],
            plan["artefacts"],
            options=options,
        )
        assert w.plan["scaling"] == {"sphere": "radii", "ball_plate": "lengths"}
        assert [p["text"] for p in w.progress()] == [
            "0 of 15 measurements of sphere positions (5 × 3 repeats)",
            "0 of 21 measurements of ball plate orientations (7 × 3 repeats)",
        ]
        folder = tmp_path / "set"
        for r, name in enumerate(plan["measurements"]["sphere"][0]):
            card = w.import_measurement("sphere", "sphere-01", folder / name)
            assert card["status"] == ("done" if r == 2 else "partial"), card
            assert card["repeats"][r]["status"] == "done"
        assert card["verdict"] == "pass"
        card = w.import_measurement("ball_plate", "ball-plate-01", folder / plan["measurements"]["ball_plate"][0][0])
        assert card["status"] == "partial" and card["next_repeat"] == 2
        assert [v["param"] for v in card["repeats"][0]["values"]] == ["SD"]
        # a redo of a full position replaces its last repeat
        mids = list(w.state["positions"]["sphere"]["sphere-01"])
        w.redo("sphere", "sphere-01", folder / plan["measurements"]["sphere"][0][0])
        assert w.state["positions"]["sphere"]["sphere-01"][:2] == mids[:2]
        assert w.state["positions"]["sphere"]["sphere-01"][2] != mids[2]
        assert w.progress()[0]["done"] == 3
        assert w.summarize()["verdict"] == "incomplete"
    with Project.open(tmp_path / "proj") as project:
        w = Wizard(project, host)
        assert w.progress()[0]["done"] == 3 and w.progress()[1]["done"] == 1
