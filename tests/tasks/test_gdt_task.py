"""The characteristics task without trame (camcmm.tasks.gdt): the plan's checks in one line
naming the key, the YAML export read back to the same document in the issue's key order,
a plan file read through the one YAML loader, nominal parameters from points picked on a
nominal (exact by construction through the fitting plugins), the plan kept with the project
across a reopen, and an evaluation run through the host (a stand-in provider with the
contract's outputs: helpers/gdt_recorded.py), stored and restored with its numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from camcmm.contracts import check_outputs, manifest_problem
from camcmm.errors import InputError, PluginError
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.report import Report
from camcmm.tasks import gdt
from camcmm.tasks.gdt import GdtRequest, GdtTask
from camcmm.tasks.items import ProjectItems
from helpers import gdt_recorded

#: The plan of the issue (its keys are the contract), with a sphere added.
ISSUE_PLAN = """\
unit: mm
band: 0.5                      # default band of a feature, in unit
features:
  A:  {type: plane, point: [0, 0, 0], normal: [0, 0, 1], box: [[0, 0, -1], [80, 60, 1]]}
  H1: {type: cylinder, point: [20, 30, 0], axis: [0, 0, 1], diameter: 10, length: 30}
  S1: {type: sphere, centre: [60, 30, 40], diameter: 20}
  B: {type: plane, point: [0, 0, 0], normal: [1, 0, 0]}
  C: {type: plane, point: [0, 0, 0], normal: [0, 1, 0]}
datums: {A: A, B: B, C: C}
characteristics:
  - {id: flat-A, type: flatness, feature: A, tolerance: 0.05}
  - {id: pos-H1, type: position, feature: H1, datums: [A, B, C], tolerance: 0.1}
  - {id: perp-H1, type: perpendicularity, feature: H1, datums: [A], tolerance: 0.05}
  - {id: dia-H1, type: diameter, feature: H1, lower: -0.02, upper: 0.02}
"""


def sphere_plan(diameter: float = 20.0) -> dict:
    return {
        "unit": "mm",
        "band": 0.5,
        "features": {"S1": {"type": "sphere", "centre": [0.0, 0.0, 0.0], "diameter": diameter}},
        "datums": {},
        "characteristics": [
            {"id": "dia-S1", "type": "diameter", "feature": "S1", "lower": -0.01, "upper": 0.01},
            {"id": "prof-S1", "type": "surface-profile", "feature": "S1", "tolerance": 0.05},
        ],
    }


def sphere_cap(n: int = 3000, radius: float = 10.0, centre=(10.0, -5.0, 40.0), noise: float = 0.002, seed: int = 1):
    """Points on the upper 120° cap of a sphere (the demo's scan, smaller), with noise."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(math.cos(math.radians(60)), 1.0, n)
    phi = rng.uniform(0, 2 * math.pi, n)
    s = np.sqrt(1 - z * z)
    d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    return np.asarray(centre) + d * (radius + rng.normal(0, noise, n))[:, None]


# ------------------------------------------------------------------------------ the plan's checks
@pytest.mark.parametrize(
    "change, words",
    [
        (lambda p: p.update(features={}), "plan: features: define at least one feature"),
        (lambda p: p.update(characteristics=[]), "plan: characteristics: enter at least one"),
        (lambda p: p["features"]["S1"].update(type="ellipsoid"), "plan: features.S1.type: 'ellipsoid' is not one"),
        (lambda p: p["features"]["S1"].update(band=-1), "plan: features.S1.band: -1 must be a positive"),
        (lambda p: p["characteristics"][0].update(feature="S9"), r"characteristics\[0\] \(dia-S1\).feature: 'S9'"),
        (lambda p: p["characteristics"][1].update(tolerance=0), r"\(prof-S1\).tolerance: 0 must be a positive"),
        (lambda p: p["characteristics"][1].update(tolerance="abc"), r"\(prof-S1\).tolerance: 'abc' is not a number"),
        (lambda p: p["characteristics"][1].pop("tolerance"), r"\(prof-S1\).tolerance: enter the tolerance"),
        (lambda p: p["characteristics"][0].update(lower=0.02), r"\(dia-S1\).lower: 0.02 is not below upper 0.01"),
        (lambda p: p["characteristics"][1].update(id="dia-S1"), r"\(dia-S1\).id: 'dia-S1' is used twice"),
        (
            lambda p: p["characteristics"][1].update(type="position"),
            r"\(prof-S1\).datums: Position needs at least one datum",
        ),
        (lambda p: p["characteristics"][1].update(datums=["A"]), r"\(prof-S1\).datums: datum 'A' is not defined"),
        (lambda p: p.update(datums={"A": "P9"}), "plan: datums.A: feature 'P9' is not defined"),
    ],
)
def test_a_plan_a_page_cannot_run_is_refused_in_one_line_naming_the_key(change, words):
    plan = sphere_plan()
    change(plan)
    with pytest.raises(InputError, match=words) as err:
        gdt.check_plan(plan)
    assert "\n" not in str(err.value)


def test_the_request_is_refused_before_the_plan_when_its_items_are_not_chosen():
    items = ProjectItems.__new__(ProjectItems)
    items.measurement = lambda key: None  # type: ignore[method-assign]
    with pytest.raises(InputError, match="choose the measured cloud first"):
        gdt.check(GdtRequest(None, None, sphere_plan()), None, items)
    with pytest.raises(InputError, match="chosen as both measured and nominal"):
        gdt.check(GdtRequest("3", "3", sphere_plan()), None, items)
    with pytest.raises(InputError, match="align: 'icp' is not one of best-fit, datums"):
        gdt.check(GdtRequest("3", "2", sphere_plan(), align="icp"), None, items)
    checked = gdt.check(GdtRequest("3", "2", sphere_plan()), None, items)
    assert checked.plan["features"]["S1"]["diameter"] == 20.0 and checked.mids == []


# ------------------------------------------------------------------------------ the YAML
def test_the_issue_plan_reads_and_its_yaml_export_reads_back_to_the_same_document_in_its_key_order():
    doc = gdt.read_plan_text(ISSUE_PLAN.encode(), "issue.yaml")
    assert set(doc) == {"unit", "band", "features", "datums", "characteristics"}
    text = gdt.plan_yaml(doc)
    assert yaml.safe_load(text) == yaml.safe_load(ISSUE_PLAN)
    keys = [line.split(":")[0] for line in text.splitlines() if not line.startswith(" ")]
    assert keys == ["unit", "band", "features", "datums", "characteristics"]
    # one feature and one characteristic a line, keys in the issue's order
    assert "  A: {type: plane, point: [0, 0, 0], normal: [0, 0, 1], box: [[0, 0, -1], [80, 60, 1]]}" in text
    assert "  - {id: dia-H1, type: diameter, feature: H1, lower: -0.02, upper: 0.02}" in text
    assert "  - {id: pos-H1, type: position, feature: H1, datums: [A, B, C], tolerance: 0.1}" in text


def test_numbers_from_numpy_are_written_plainly_and_rounded_to_a_nanometre():
    plan = sphere_plan()
    plan["features"]["S1"]["centre"] = np.array([1.0 / 3.0, 2.0, -0.0000000000004])
    plan["features"]["S1"]["diameter"] = np.float64(19.999999999999996)
    back = yaml.safe_load(gdt.plan_yaml(plan))
    assert back["features"]["S1"] == {"type": "sphere", "centre": [0.333333333, 2, 0], "diameter": 20}
    assert "!!" not in gdt.plan_yaml(plan)  # no numpy tags


@pytest.mark.parametrize(
    "text, words",
    [
        ("- 1\n- 2\n", "up.yaml: expected a mapping"),
        ("unit: furlong\nfeatures: {}\n", "up.yaml: unit: 'furlong' is not a length unit"),
        ("features: {A: {type: blob}}\n", "up.yaml: features.A.type: 'blob'"),
        ("features: {A: {type: plane}}\nfeatures: {}\n", "up.yaml"),  # a duplicate key (the one loader)
        ("features: [\n", "up.yaml: not valid YAML"),
    ],
)
def test_a_plan_file_that_cannot_be_a_plan_is_refused_in_one_line_naming_the_file(text, words):
    with pytest.raises(InputError, match=words) as err:
        gdt.read_plan_text(text, "up.yaml")
    assert "\n" not in str(err.value)


def test_a_plan_in_inches_is_read_in_mm_and_one_that_cannot_be_converted_is_refused():
    text = (
        "unit: in\nband: 0.02\nfeatures:\n  A: {type: plane, point: [1, 0, 0], normal: [0, 0, 1]}\n"
        "  H: {type: cylinder, point: [0, 0, 0], axis: [0, 0, 1], diameter: 0.5, length: 1, band: 0.01}\n"
        "datums: {A: A}\ncharacteristics:\n  - {id: f, type: flatness, feature: A, tolerance: 0.002}\n"
        "  - {id: d, type: diameter, feature: H, lower: -0.001, upper: 0.001, k: 2}\n"
    )
    doc = gdt.read_plan_text(text, "inch.yaml")
    assert doc["unit"] == "mm" and doc["band"] == pytest.approx(0.508)
    assert doc["features"]["A"] == {"type": "plane", "point": [25.4, 0.0, 0.0], "normal": [0, 0, 1]}
    assert doc["features"]["H"]["diameter"] == pytest.approx(12.7) and doc["features"]["H"]["band"] == 0.254
    assert doc["characteristics"][0]["tolerance"] == pytest.approx(0.0508)
    assert doc["characteristics"][1]["lower"] == pytest.approx(-0.0254) and doc["characteristics"][1]["k"] == 2
    with pytest.raises(InputError, match="inch.yaml: characteristics\\[0\\].nominal: not converted from in"):
        gdt.read_plan_text(text.replace("tolerance: 0.002}", "tolerance: 0.002, nominal: 3}"), "inch.yaml")
    assert gdt.read_plan_text(text.replace("unit: in", "unit: mm"), "mm.yaml")["band"] == 0.02  # mm: as it is


def test_a_plan_being_written_may_have_no_characteristics_yet():
    doc = gdt.read_plan_text("features: {P: {type: point, point: [1, 2, 3]}}\n", "p.yaml")
    assert doc["characteristics"] == [] and doc["unit"] == "mm" and doc["datums"] == {}


# ------------------------------------------------------------------------------ picked features
def test_nominal_parameters_from_points_picked_on_a_nominal_are_exact_by_construction():
    from camcmm.host import default_host

    host = default_host()
    rng = np.random.default_rng(3)
    # a sphere (exact vertices, like the demo's icosphere)
    d = rng.normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    s = gdt.nominal_from_points(host, "sphere", np.array([3.0, -2.0, 7.0]) + 10.0 * d)
    assert np.allclose(s["centre"], [3, -2, 7], atol=1e-9) and abs(s["diameter"] - 20.0) < 1e-9
    # a plane through (0, 0, 5) tilted about x
    n = np.array([0.0, -math.sin(0.2), math.cos(0.2)])
    u, v = np.array([1.0, 0, 0]), np.cross(n, [1.0, 0, 0])
    uv = rng.uniform(-20, 20, (300, 2))
    p = gdt.nominal_from_points(host, "plane", np.array([0, 0, 5.0]) + uv[:, :1] * u + uv[:, 1:] * v)
    assert abs(abs(np.dot(p["normal"], n)) - 1) < 1e-12 and abs(np.dot(np.asarray(p["point"]) - [0, 0, 5], n)) < 1e-9
    # a cylinder of diameter 8 along z from z = 2 to z = 32: foot and length from the points' extent
    t = np.linspace(0, 2 * math.pi, 60, endpoint=False)
    zs = np.linspace(2, 32, 16)
    T, Z = np.meshgrid(t, zs)
    pts = np.column_stack([20 + 4 * np.cos(T.ravel()), 30 + 4 * np.sin(T.ravel()), Z.ravel()])
    c = gdt.nominal_from_points(host, "cylinder", pts)
    assert abs(c["diameter"] - 8.0) < 1e-9 and abs(c["length"] - 30.0) < 1e-9
    assert abs(abs(c["axis"][2]) - 1) < 1e-12
    assert (
        np.allclose(c["point"][:2], [20, 30], atol=1e-9) and min(abs(c["point"][2] - 2), abs(c["point"][2] - 32)) < 1e-9
    )
    assert gdt.nominal_from_points(host, "point", pts)["point"] == pytest.approx([20, 30, 17], abs=1e-12)
    with pytest.raises(InputError, match="Sphere: 3 points picked, at least 4 needed"):
        gdt.nominal_from_points(host, "sphere", pts[:3])


def test_a_fitted_nominal_is_oriented_by_the_surface_picked_out_of_the_material():
    from camcmm.demo import _icosphere

    ball = _icosphere(10.0, subdivisions=2)
    V, F = np.asarray(ball.vertices), np.asarray(ball.faces)
    N = gdt.vertex_normals(V, F)
    assert np.min(np.sum(N * V / 10.0, axis=1)) > 0.99  # outward on a ball wound as STL is
    fit = {"centre": [0.0, 0.0, 0.0], "diameter": 20.0}
    assert gdt.orient("sphere", fit, V, N) == fit  # a ball: external (the default)
    inward = gdt.vertex_normals(V, F[:, ::-1])  # the same surface seen from inside: a socket
    assert gdt.orient("sphere", fit, V, inward) == {**fit, "internal": True}
    # a bore along z (normals towards the axis) and a plane whose fitted normal points in
    t = np.linspace(0, 2 * math.pi, 40, endpoint=False)
    P = np.column_stack([5 + 3 * np.cos(t), 2 + 3 * np.sin(t), np.linspace(0, 9, 40)])
    bore = {"point": [5.0, 2.0, 0.0], "axis": [0.0, 0.0, 1.0], "diameter": 6.0, "length": 9.0}
    towards = -np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    assert gdt.orient("cylinder", bore, P, towards)["internal"] is True
    assert "internal" not in gdt.orient("cylinder", bore, P, -towards)
    plane = {"point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, -1.0]}
    up = np.tile([0.0, 0.1, 1.0], (5, 1))
    assert gdt.orient("plane", plane, np.zeros((5, 3)), up)["normal"] == [0.0, 0.0, 1.0]
    torus = {"centre": [0.0, 0.0, 0.0], "axis": [0.0, 0.0, 1.0], "major_diameter": 20.0, "minor_diameter": 4.0}
    ring = np.array([[12.0, 0, 0], [0, 12.0, 0], [8.0, 0, 0]])  # outer and inner equator of the tube
    out = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0]])  # the tube's outward normals there
    assert "internal" not in gdt.orient("torus", torus, ring, out)
    assert gdt.orient("torus", torus, ring, -out)["internal"] is True


def test_a_region_is_the_points_within_its_radius_and_its_box_their_extent_grown_by_the_band():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 0], [3, 3, 3.0]])
    assert gdt.region(P, [0, 0, 0], 2.0).tolist() == [0, 1, 2]
    assert gdt.box_of(P[:3], 0.5) == [[-0.5, -0.5, -0.5], [1.5, 2.5, 0.5]]
    assert gdt.next_id(["F1", "F2", "S1"], "F") == "F3" and gdt.next_id([], "dia-S 1") == "dia-S11"


# ------------------------------------------------------------------------------ provider and contract
def test_the_provider_is_found_by_task_and_held_to_the_contract():
    host = gdt_recorded.RecordedHost()
    assert gdt.provider(host).id == gdt_recorded.PLUGIN_ID
    lacking = gdt_recorded.spec(("features", "datums", "alignment", "characteristics"))
    assert "'labels'" in manifest_problem(lacking, gdt.TASK)
    host = gdt_recorded.RecordedHost(lacking)
    if gdt.PLUGIN in host.plugins:  # passed over for camcmm's own, which declares no task but fits
        assert gdt.provider(host).id == gdt.PLUGIN
        del host.plugins[gdt.PLUGIN]
    with pytest.raises(PluginError, match="'labels'"):
        gdt.provider(host)
    with pytest.raises(PluginError, match="gave no 'alignment.method'"):
        check_outputs(
            gdt.TASK, "x", {"features": [], "datums": [], "alignment": {}, "characteristics": [], "labels": []}
        )


# ------------------------------------------------------------------------------ run, store, restore
@pytest.fixture
def case(tmp_path):
    """A bare project with the sphere cap as an item and the stand-in provider."""
    project = Project.create(tmp_path / "proj")
    items = ProjectItems(project)
    cloud = PointCloud(sphere_cap(), name="cap")
    h = project.add_object(cloud, "cap.ply")
    cid = str(items.add_measurement("cap.ply", h, cloud))
    yield GdtTask(gdt_recorded.RecordedHost(), items, project), project, cid
    project.close()


def test_an_evaluation_is_run_stored_and_restored_with_its_numbers_and_the_plan(case, tmp_path):
    task, project, cid = case
    ev = task.run(GdtRequest(cid, None, sphere_plan(), "best-fit"))
    dia, prof = ev.characteristics
    # the stand-in's numbers are real: the diameter within noise of 20 mm (2 µm noise)
    assert abs(dia["value"] - 20.0) < 5e-4 and dia["verdict"] == "conform" and 0 < prof["value"] < 0.03
    record = task.store(ev)
    assert record["cloud"] == int(cid) and record["nominal"] is None and record["align"] == "best-fit"
    assert project.result(record["result"])["files"]["aligned"] == record["aligned"]
    project.close()
    again = Project.open(tmp_path / "proj")
    try:
        back = GdtTask(gdt_recorded.RecordedHost(), ProjectItems(again), again).restore()
        assert back is not None and back.plan == sphere_plan()
        assert [c["value"] for c in back.characteristics] == [dia["value"], prof["value"]]
        assert [lab["anchor"] for lab in back.labels] == [lab["anchor"] for lab in ev.labels]
        assert np.array_equal(back.outputs["aligned"].points, ev.outputs["aligned"].points)
        assert back.outputs["alignment"]["method"] == "best-fit"
    finally:
        again.close()


def test_the_plan_is_kept_with_the_project_and_a_newer_record_is_refused(case, tmp_path):
    task, project, cid = case
    assert task.saved_plan() is None and task.restore() is None
    task.save_plan(sphere_plan(19.0), GdtRequest(cid, "7", align="none"))
    project.close()
    again = Project.open(tmp_path / "proj")
    try:
        rec = gdt.saved_plan(again)
        assert rec == {"version": 1, "plan": sphere_plan(19.0), "cloud": cid, "nominal": "7", "align": "none"}
        again.set_state(gdt.PLAN_KEY, sphere_plan())  # a bare document (no version): taken as version 1
        assert gdt.saved_plan(again)["plan"] == sphere_plan()
        again.set_state(gdt.PLAN_KEY, {"version": 2, "plan": {}})
        with pytest.raises(InputError, match="project state gdt.plan: version 2 is newer"):
            gdt.saved_plan(again)
    finally:
        again.close()


def test_the_characteristics_go_into_a_report_as_a_table_with_their_verdicts(case):
    task, _, cid = case
    ev = task.run(GdtRequest(cid, None, sphere_plan(), "best-fit"))
    rep = Report("Compare with CAD")
    gdt.report_section(rep, ev, lambda c: {"value": f"{c['value']:.4f}", "U": "u", "tolerance": "t"})
    html = rep.render_html()
    assert "Geometric characteristics" in html and "Profile of a surface" in html and "Diameter" in html
    assert "Best fit to the nominal" in html and f"{ev.characteristics[0]['value']:.4f}" in html
    assert gdt.char_title("surface-profile") == "Profile of a surface" and gdt.verdict_of({}) == "not evaluated"
