"""The characteristics panel of the Compare page without a browser: its texts and flag
layout (pure functions), then the panel on a real project — a sphere feature from the
whole nominal (an icosphere: its fit is the ball exactly) and from a region around a
point, a diameter and a profile, refusals in one line, Run through a stand-in provider
with the contract's outputs (helpers/gdt_recorded.py; the real plugin runs in
tests/browser/test_browser_gdt.py), the results and flags, the YAML export and import;
a face of a STEP nominal picked in the view; the characteristics in the Compare report;
the plan and results shown again when the project is reopened."""

from __future__ import annotations

import asyncio
import os

import numpy as np
import pytest
import yaml

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

pytest.importorskip("trame")
pytest.importorskip("pyvista")

from camcmm.gui.pages.compare.characteristics import feature_summary, result_rows, result_texts  # noqa: E402
from camcmm.gui.pages.compare.flags import FLAG_STEP, flag_positions, flag_texts  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402
from camcmm.report import Report  # noqa: E402
from camcmm.tasks import gdt  # noqa: E402
from helpers import gdt_recorded  # noqa: E402


# ------------------------------------------------------------------------------ texts and layout
def test_results_are_written_in_the_page_s_units_with_their_limits():
    size = {"id": "d", "type": "diameter", "value": 19.99968, "u": 0.00023, "k": 2, "unit": "mm"}
    plan = {"characteristics": [{"id": "d", "lower": -0.01, "upper": 0.01}]}
    t = result_texts(size, plan)  # decimals as u resolves them (two digits of u = 0.23 µm)
    assert t == {"value": "19.99968 mm", "U": "0.46 µm (k = 2)", "tolerance": "−0.010 / +0.010 mm"}
    zone = {"id": "p", "type": "surface-profile", "value": 0.038, "u": 0.0034, "U": 0.0068, "k": 2, "tolerance": 0.05}
    assert result_texts(zone) == {"value": "38.0 µm", "U": "6.80 µm (k = 2)", "tolerance": "50.0 µm"}
    angle = {"id": "a", "type": "angularity", "value": 30.0123, "u": 0.004, "unit": "deg", "tolerance": 0.05}
    assert result_texts(angle)["value"] == "30.012 deg"
    none = result_texts({"id": "x", "type": "flatness", "value": None, "verdict": "not evaluated"})
    assert none == {"value": "—", "U": "—", "tolerance": "—"}
    rows = result_rows([{**zone, "verdict": "conform", "verdict_guarded": "undecided"}])
    assert rows[0]["title"] == "Profile of a surface" and rows[0]["verdict"] == "undecided"
    assert rows[0]["colour"] == gdt.VERDICT_COLOURS["undecided"] and rows[0]["simple"] == "conform"
    f = {"type": "sphere", "centre": [-8.88e-16, 1e-17, 3.0], "diameter": 19.999999999999996}
    assert feature_summary(f) == "centre (0, 0, 3) mm, ⌀ 20 mm"


def test_flags_stand_in_a_column_beside_the_part_no_two_closer_than_a_step():
    anchors = np.array([[100, 300], [120, 305], [90, 100], [300, 299], [50, 900]])
    pos = flag_positions(anchors, 640, top=800)
    assert np.all(pos[:, 0] == 640) and pos[:, 1].max() <= 800
    y = np.sort(pos[:, 1])
    assert np.all(np.diff(y) >= FLAG_STEP - 1e-9)
    # as high as the anchor where there is room, in the anchors' order from the top down
    assert pos[2, 1] == 100 and list(np.argsort(-pos[:, 1])) == list(np.argsort(-anchors[:, 1], kind="stable"))
    chars = [{"id": "p", "type": "flatness", "value": 0.012, "verdict": "conform", "verdict_guarded": "conform"}]
    labels = [
        {"id": "p", "anchor": [1, 2, 3], "decisive": [[1, 2, 3]], "verdict": "conform"},
        {"id": "q", "anchor": None},  # nothing to point at: left out
    ]
    flags = flag_texts(chars, labels, lambda c: {"value": "12.0 µm"})
    assert len(flags) == 1 and flags[0]["text"] == "p · Flatness\n12.0 µm · conform"
    assert flags[0]["colour"] == gdt.VERDICT_COLOURS["conform"] and flags[0]["decisive"].shape == (1, 3)


# ------------------------------------------------------------------------------ the panel
def _project(app, tmp_path):
    """A GUI on a project holding a cap of a 20 mm ball (2 µm noise) and an icosphere nominal."""
    from camcmm.demo import _icosphere
    from tasks.test_gdt_task import sphere_cap

    server, session = app(tmp_path / "proj", host=gdt_recorded.RecordedHost())
    for obj, name in (
        (PointCloud(sphere_cap(2000), name="cap"), "cap.ply"),
        (_icosphere(10.0, subdivisions=3), "ball.ply"),
    ):
        h = session.project.add_object(obj, name)
        session.add_measurement(name, h, obj)
    session.refresh_items()
    page = server.pages["compare"]
    page.refresh_inputs()
    return server, session, page


def test_a_plan_defined_run_shown_reported_exported_and_imported(gui_app, tmp_path):
    server, session, page = _project(gui_app, tmp_path)
    s, g = server.state, page.gdt
    names = {it["id"]: it["name"] for it in s.items}
    assert names[s.ins_measured] == "cap.ply" and names[s.ins_nominal] == "ball.ply"
    assert g.add_feature() is None and "pick the feature on the nominal first" in s.ins_error

    # the whole nominal: the icosphere's vertices lie on the ball, so its fit is the ball
    params = g.pick_whole()
    assert params["type"] == "sphere" and abs(params["diameter"] - 20.0) < 1e-9 and "box" not in params
    assert "internal" not in params  # the mesh faces outward: a ball, not a socket
    assert np.allclose(params["centre"], 0, atol=1e-9) and s.gdt_f_ready
    s.gdt_f_id = "S1"
    assert g.add_feature() == "S1" and s.gdt_feature_ids == ["S1"] and s.gdt_c_type == "diameter"
    assert s.gdt_c_id == "diameter-S1"

    # a characteristic the plan cannot take is refused in one line naming it
    s.gdt_c_lower, s.gdt_c_upper = "0.02", "0.01"
    assert g.add_characteristic() is None and "diameter-S1" in s.ins_error and "not below upper" in s.ins_error
    s.gdt_c_lower, s.gdt_c_upper = "-0,01", "0.01"  # a decimal comma as typed
    assert g.add_characteristic() == "diameter-S1"
    g.set_char("surface-profile")
    assert s.gdt_c_id == "surface-profile-S1"
    s.gdt_c_tol = "0"
    assert g.add_characteristic() is None and "must be a positive" in s.ins_error
    s.gdt_c_tol = "0.05"
    assert g.add_characteristic() == "surface-profile-S1"
    assert [c["tolerance"] for c in s.gdt_chars] == ["−0.010 / +0.010 mm", "50.0 µm"]

    # a region picked around a point of the nominal: its vertices within the radius, a box
    s.gdt_f_radius = "5"
    region = g.pick_point([0.0, 0.0, 10.0])
    P = g.vertices(g.nominal())
    inside = np.linalg.norm(P - [0, 0, 10], axis=1) <= 5
    assert "box" in region and len(g.region) == int(inside.sum()) and abs(region["diameter"] - 20) < 1e-9
    assert np.allclose(region["box"], [P[inside].min(axis=0) - 0.5, P[inside].max(axis=0) + 0.5])
    s.gdt_f_radius = "-1"
    assert g.pick_point([0.0, 0.0, 10.0]) is None and "region radius" in s.ins_error

    # Run: the results table and the flags in the view
    ev = asyncio.run(g.run_async())
    assert ev is not None, s.ins_error
    assert [r["id"] for r in s.gdt_results] == ["diameter-S1", "surface-profile-S1"]
    dia = ev.characteristics[0]
    assert s.gdt_results[0]["value"] == result_texts(dia, g.plan)["value"] and s.gdt_results[0]["verdict"] == "conform"
    assert page.view.scene == "gdt" and s.ins_mode == "gdt"
    assert sum(1 for k in page.view._actors if k.startswith("flag") and k[4:].isdigit()) == 2
    assert "Best fit to the nominal" in s.gdt_result_note

    # the report's section, added to the Compare report by its writer's extend hook
    rep = Report("Compare with CAD")
    g.report_extension()(rep)
    html = rep.render_html()
    assert "Geometric characteristics" in html and "Profile of a surface" in html and "19.99" in html

    # the plan as YAML: read back to the plan; an imported plan replaces it
    link = g.export_yaml()
    doc = yaml.safe_load((page.downloads / link["name"]).read_text("utf-8"))
    assert doc == yaml.safe_load(gdt.plan_yaml(g.plan)) and list(doc)[:3] == ["unit", "band", "features"]
    assert doc["characteristics"][0] == {
        "id": "diameter-S1",
        "type": "diameter",
        "feature": "S1",
        "lower": -0.01,
        "upper": 0.01,
    }
    assert not g.import_yaml(b"features: [\n", "bad.yaml") and "bad.yaml: not valid YAML" in s.ins_error
    more = {**g.plan, "features": {**g.plan["features"], "P": {"type": "point", "point": [1, 2, 3]}}}
    assert g.import_yaml(gdt.plan_yaml(more).encode(), "more.yaml") and s.gdt_feature_ids == ["S1", "P"]
    assert session.project.get_state(gdt.PLAN_KEY)["plan"] == g.plan  # kept with the project as edited


def test_the_compare_report_carries_the_characteristics_evaluated(gui_app, tmp_path):
    from tasks.test_gdt_task import sphere_plan

    server, _, page = _project(gui_app, tmp_path)
    s, g = server.state, page.gdt
    g.plan = sphere_plan()
    assert asyncio.run(g.run_async()) is not None, s.ins_error
    assert asyncio.run(page.run_async()) is not None, s.ins_error  # a comparison, then its report
    out = asyncio.run(page.report_async())
    assert out is not None, s.ins_error
    with open(out["paths"]["html"], encoding="utf-8") as fh:
        html = fh.read()
    assert "Inspection against the nominal" in html and "Geometric characteristics" in html
    assert s.gdt_results[1]["value"] in html and "Profile of a surface" in html
    # and the characteristics' own report (the provider's writer), kept and offered again
    links = asyncio.run(g.report_async())
    assert links is not None, s.ins_error
    assert [link["kind"] for link in links] == ["html", "pdf", "json"]
    assert (page.downloads / links[0]["name"]).read_text("utf-8").count("prof-S1") >= 1
    assert set(session_record(page)["report"]) == {"report_html", "report_pdf", "report_json"}


def session_record(page):
    return page.project.get_state(gdt.STATE_KEY)


def test_the_plan_and_the_last_results_are_shown_again_when_the_project_is_reopened(gui_app, tmp_path):
    """What the task kept (tests/tasks) is what the panel shows on opening the project."""
    from camcmm.project import Project
    from camcmm.tasks.items import ProjectItems
    from tasks.test_gdt_task import sphere_cap, sphere_plan

    project = Project.create(tmp_path / "proj")
    items = ProjectItems(project)
    cloud = PointCloud(sphere_cap(2000), name="cap")
    cid = str(items.add_measurement("cap.ply", project.add_object(cloud, "cap.ply"), cloud))
    task = gdt.GdtTask(gdt_recorded.RecordedHost(), items, project)
    request = gdt.GdtRequest(cid, None, sphere_plan(), "none")
    ev = task.run(request)
    task.store(ev)
    task.save_plan(sphere_plan(), request)
    project.close()
    server, _ = gui_app(tmp_path / "proj", host=gdt_recorded.RecordedHost())
    s, g = server.state, server.pages["compare"].gdt
    assert g.plan == sphere_plan() and s.gdt_feature_ids == ["S1"] and s.gdt_align == "none"
    assert [r["id"] for r in s.gdt_chars] == ["dia-S1", "prof-S1"]
    assert [r["value"] for r in s.gdt_results] == [result_texts(c, g.plan)["value"] for c in ev.characteristics]
    assert g.show() and server.pages["compare"].view.scene == "gdt" and s.ins_mode == "gdt"


def test_a_face_of_a_step_nominal_picked_is_the_issue_s_face_feature(gui_app, tmp_path):
    """A click on a STEP sphere's tessellation names its face (``{type: face, cad: 1}``); the
    summary gives the face's exact sphere; the characteristic offered is a sphere's."""
    pytest.importorskip("OCP", reason="OpenCascade (cadquery-ocp) reads STEP")
    from camcmm.cad.write import sphere_step

    server, session, page = _project(gui_app, tmp_path)
    h = session.project.add_file(sphere_step(tmp_path / "ball.step", 10.0))
    mid = session.project.add_measurement("ball.step", h, kind="cad", meta={})
    session.refresh_items()
    s, g = server.state, page.gdt
    s.ins_nominal = str(mid)
    cad = g.nominal()
    assert type(cad).__name__ == "CadModel"
    assert g.start_picking() and page.view.scene == "inputs"  # its tessellation shown alone
    cell = 7
    point = cad.mesh.vertices[cad.mesh.faces[cell]].mean(axis=0)
    feature = g.pick_point(point, cell)
    assert feature == {"type": "face", "cad": 1} and s.gdt_f_picked == "CAD face 1 (Sphere)"
    assert s.gdt_f_nominal == "CAD face 1: Sphere, centre (0, 0, 0) mm, ⌀ 20 mm"
    s.gdt_f_id = "B"
    assert g.add_feature() == "B" and g.plan["features"]["B"] == {"type": "face", "cad": 1}
    assert s.gdt_c_type == "diameter" and s.gdt_features[-1]["nominal"] == "CAD face 1"
    # picking on the view: the click at the projection of that triangle's centre finds the face
    page.view.screenshot()
    from camcmm.gui.pages.compare.picking import world_to_display

    g.start_picking()
    page.view.screenshot()
    xy, _, _ = world_to_display(page.view.renderer, point[None, :])
    assert page.pick_display(*xy[0]) == {"type": "face", "cad": 1}


def test_import_plan_takes_a_qif_file_through_the_qif_import_provider(gui_app, tmp_path):
    """NIST CTC 01's QIF uploaded: the plan of ``camcmm gdt import-qif`` (17 features, 11
    characteristics; tests/tasks/test_gdt_qif_import.py compares it with the command) fills
    the panel and is kept as gdt.plan; a file that is not QIF is refused in one line."""
    from helpers.paths import TEST_DATA

    server, session, page = _project(gui_app, tmp_path)
    s, g = server.state, page.gdt
    data = (TEST_DATA / "qif3" / "nist_ctc_01_asme1_ap242.qif").read_bytes()
    assert g.import_yaml(data, "ctc01.QIF"), s.ins_error
    assert len(s.gdt_feature_ids) == 17 and len(s.gdt_chars) == 11 and s.gdt_datum_labels == ["A", "B", "C"]
    assert sorted(c["title"] for c in s.gdt_chars)[:2] == ["Diameter", "Diameter"]
    assert s.info_message.startswith("ctc01.QIF: imported 17 features, 11 characteristics; skipped 5: 2166: ")
    kept = session.project.get_state(gdt.PLAN_KEY)
    assert kept["version"] == gdt.PLAN_VERSION and kept["plan"] == g.plan and g.plan["qif"]["file"] == "ctc01.QIF"
    before = dict(g.plan)
    assert not g.import_yaml(b"<?xml version='1.0'?><plan/>", "other.qif")
    assert s.ins_error.startswith("other.qif: not a QIF 3.0 document") and "\n" not in s.ins_error
    assert g.plan == before and session.project.get_state(gdt.PLAN_KEY)["plan"] == before  # left as it was
