"""``camcmm gdt evaluate`` through its JSON (issue 27), on the synthetic block of
helpers/gdt_parts.py whose answers are known by construction:

* the bore H1's axis is offset by (0.02, −0.01) mm at z = 0 and (0.05, 0.03) mm at
  z = 30 in the A|B|C frame: position 2·max = 2·|(0.05, 0.03)| = 0.116619 mm,
  perpendicularity to A = |(0.03, 0.04)| = 0.05 mm;
* the same part delivered in a scanner's frame (30° about a skew axis, 500 mm away)
  gives the same values through the datum alignment;
* the side D tilted by 0.001 (x = 80 + 0.001·z, sampled z 1 … 29): perpendicularity to
  A = 0.001 · 28 mm; A on two levels 0.03 mm apart: flatness 0.03 mm;
* a bore of Ø10.03 against 10 −0.02/+0.02: not conform.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from helpers import gdt_parts as g
from helpers.cli import main_json, main_refused, main_run

#: The issue's JSON keys (camcmm may add more, never fewer).
FEATURE_KEYS = {"id", "type", "association", "n_points", "params", "form"}
CHARACTERISTIC_KEYS = {
    "id",
    "type",
    "feature",
    "datums",
    "value",
    "unit",
    "tolerance",
    "u",
    "verdict",
    "verdict_guarded",
}
VERDICTS = {"conform", "not conform", "undecided", "not evaluated"}
#: The block's analytic values (mm): see the module docstring.
EXACT = {"flat-A": 0.0, "pos-H1": g.POSITION_H1, "perp-H1": 0.05, "perp-D": 0.0, "dia-H1": 10.0, "dia-P1": 16.0}


def _case(folder, part, doc=None):
    return [str(p) for p in g.write_case(folder, part, doc)]


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    """The block in plan coordinates: (plan, cloud) paths."""
    return _case(tmp_path_factory.mktemp("block"), g.block())


def _by_id(doc):
    return {c["id"]: c for c in doc["characteristics"]}


def test_block_values_and_keys(capfd, block):
    doc = main_json(capfd, "gdt", "evaluate", *block, "--align", "datums", "--json")
    assert {"features", "datums", "alignment", "characteristics", "warnings"} <= set(doc)
    assert doc["warnings"] == []
    for f in doc["features"]:
        assert FEATURE_KEYS <= set(f), f
        assert f["status"] == "evaluated" and f["n_points"] >= 100
    assert {d["label"]: d["feature"] for d in doc["datums"]} == {"A": "A", "B": "B", "C": "C"}
    a = doc["alignment"]
    assert a["method"] == "datums" and a["converged"] and a["free"] == []
    assert np.allclose(a["transform"], np.eye(4), atol=1e-9)  # A, B, C are exact: the plan's frame
    chars = _by_id(doc)
    assert {cid: c["value"] for cid, c in chars.items()} == pytest.approx(EXACT, abs=1e-8)
    for c in chars.values():
        assert CHARACTERISTIC_KEYS <= set(c), c
        assert c["unit"] == "mm" and c["verdict"] in VERDICTS and c["verdict_guarded"] in VERDICTS
        assert c["U"] == pytest.approx(c["k"] * c["u"])
    assert chars["pos-H1"]["value"] == pytest.approx(g.POSITION_H1, abs=1e-8)  # 0.116619 mm
    assert g.POSITION_H1 == pytest.approx(0.1166, abs=5e-5)
    assert chars["pos-H1"]["datums"] == ["A", "B", "C"]
    assert chars["perp-H1"]["value"] == pytest.approx(0.05, abs=1e-8)
    assert chars["flat-A"]["value"] == pytest.approx(0.0, abs=1e-9)
    assert chars["perp-D"]["value"] == pytest.approx(0.0, abs=1e-9)
    dia = chars["dia-H1"]
    assert dia["value"] == pytest.approx(10.0, abs=1e-8)
    assert (dia["lower"], dia["upper"], dia["tolerance"]) == (-0.02, 0.02, None)
    assert chars["dia-P1"]["value"] == pytest.approx(16.0, abs=1e-8)
    assert all(c["verdict"] == c["verdict_guarded"] == "conform" for c in chars.values())
    assert doc["summary"] == {"conform": 6}
    # labels for the 3-D view: one per characteristic, the anchor on its feature
    labels = {lab["id"]: lab for lab in doc["labels"]}
    assert set(labels) == set(chars)
    assert np.allclose(labels["dia-H1"]["anchor"][:2], [20.035, 30.01], atol=0.5)


def test_scanner_frame_gives_the_same_values(capfd, tmp_path):
    """The part 30° about (1, 2, 3) and 500 mm away: the coarse start, then the datum frame."""
    plan, cloud = _case(tmp_path, g.block(pose=g.SCANNER_POSE))
    doc = main_json(capfd, "gdt", "evaluate", plan, cloud, "--align", "datums", "--json")
    a = doc["alignment"]
    assert [s["stage"] for s in a["stages"]][0] == "coarse start"
    # measured -> plan is the pose's inverse
    assert np.allclose(np.asarray(a["transform"]) @ g.SCANNER_POSE, np.eye(4), atol=1e-9)
    for cid, c in _by_id(doc).items():
        assert c["value"] == pytest.approx(EXACT[cid], abs=1e-8), cid
        assert c["verdict_guarded"] == "conform"


def test_tilted_plane_flatness_and_size_limits(capfd, tmp_path):
    tilt, ripple = 0.001, 0.03
    part = g.block(tilt_d=tilt, ripple_a=ripple, bore_diameter=10.03)
    chars = g.plan_document()["characteristics"] + [
        {"id": "pos-tight", "type": "position", "feature": "H1", "datums": ["A", "B", "C"], "tolerance": 0.1},
    ]
    # every second point of A raised: noise to an estimate; the plan states the points carry none
    plan, cloud = _case(tmp_path, part, g.plan_document(characteristics=chars, point_noise=0))
    c = _by_id(main_json(capfd, "gdt", "evaluate", plan, cloud, "--align", "none", "--json"))
    assert c["perp-D"]["value"] == pytest.approx(tilt * 28.0, rel=1e-9)  # the tilt over the extent z 1 … 29
    assert c["flat-A"]["value"] == pytest.approx(ripple, rel=1e-9)
    assert c["dia-H1"]["value"] == pytest.approx(10.03, abs=1e-8)
    assert c["dia-H1"]["verdict"] == c["dia-H1"]["verdict_guarded"] == "not conform"  # 0.03 over +0.02
    assert c["pos-tight"]["verdict"] == c["pos-tight"]["verdict_guarded"] == "not conform"  # 0.1166 > 0.1
    for r in c.values():  # the verdicts follow from value, tolerance and U as ISO 14253-1 says
        if r["tolerance"] is None or r["value"] is None:
            continue
        simple = "conform" if r["value"] <= r["tolerance"] else "not conform"
        assert r["verdict"] == simple, r["id"]
        if r["value"] <= r["tolerance"] - r["U"]:
            assert r["verdict_guarded"] == "conform", r["id"]
        elif r["value"] > r["tolerance"] + r["U"]:
            assert r["verdict_guarded"] == "not conform", r["id"]
        else:
            assert r["verdict_guarded"] == "undecided", r["id"]


def test_feature_without_points_is_not_evaluated(capfd, block, tmp_path):
    """A feature whose box holds no point: it and what depends on it are 'not evaluated',
    with the reason, and the rest is evaluated (exit 0, warnings)."""
    doc = g.plan_document()
    doc["features"]["S9"] = {"type": "sphere", "centre": [40, 30, 80], "diameter": 10}
    doc["characteristics"].append({"id": "dia-S9", "type": "diameter", "feature": "S9", "lower": -0.1, "upper": 0.1})
    plan, cloud = _case(tmp_path, g.block(), doc)
    out = main_json(capfd, "gdt", "evaluate", plan, block[1], "--align", "none", "--json")
    f = {x["id"]: x for x in out["features"]}["S9"]
    assert f["status"] == "not evaluated" and f["n_points"] == 0 and "band" in f["reason"]
    c = _by_id(out)
    assert c["dia-S9"]["verdict"] == c["dia-S9"]["verdict_guarded"] == "not evaluated"
    assert c["dia-S9"]["value"] is None and "S9" in c["dia-S9"]["details"]["reason"]
    assert c["pos-H1"]["value"] == pytest.approx(g.POSITION_H1, abs=1e-8)
    assert any("S9" in w for w in out["warnings"])


def test_report_and_project(capfd, block, tmp_path):
    out = main_json(
        capfd,
        "gdt",
        "evaluate",
        *block,
        "--align",
        "none",
        "--report",
        tmp_path / "rep",
        "--project",
        tmp_path / "proj",
        "--json",
    )
    html = (tmp_path / "rep" / "report.html").read_text("utf-8")
    assert (tmp_path / "rep" / "report.pdf").read_bytes().startswith(b"%PDF")
    for needle in ("pos-H1", "0.1166", "A|B|C", "⊥", "conform", "Transform measured"):
        assert needle in html, needle
    rep = json.loads((tmp_path / "rep" / "report.json").read_text("utf-8"))
    assert {c["id"] for c in rep["data"]["characteristics"]} == set(_by_id(out))
    from camcmm.project.store import Project

    with Project.open(tmp_path / "proj") as project:
        row = project.result(out["result_id"])
    assert row["plugin"] == "gdt.evaluate"


def test_text_table(capfd, block):
    rc, out, err = main_run(capfd, "gdt", "evaluate", *block, "--align", "none")
    assert rc == 0, err
    line = next(x for x in out.splitlines() if x.startswith("pos-H1"))
    assert "A|B|C" in line and "0.1166" in line and line.endswith("conform")


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda d: d["characteristics"].append({"id": "x", "type": "flatness", "feature": "Z9"}), "Z9"),
        (lambda d: d["features"]["A"].update(type="hexagon"), "features.A.type"),
        (lambda d: d.update(alignment={"sideways": 1}), "alignment.sideways"),
    ],
)
def test_bad_plan_refused_in_one_line(capfd, block, tmp_path, edit, needle):
    doc = g.plan_document()
    edit(doc)
    plan = tmp_path / "bad.yaml"
    plan.write_text(g.plan_yaml(doc), "utf-8")
    err = main_refused(capfd, "gdt", "evaluate", plan, block[1], "--align", "none", code=2)
    assert "bad.yaml" in err and needle in err


def test_refusals_name_the_file_or_option(capfd, block, tmp_path):
    mesh = tmp_path / "m.stl"
    facet = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
    mesh.write_text(f"solid m\n{facet}endsolid m\n")
    assert "m.stl" in main_refused(capfd, "gdt", "evaluate", block[0], mesh, code=2)
    assert "nothere.xyz" in main_refused(capfd, "gdt", "evaluate", block[0], tmp_path / "nothere.xyz", code=2)
    assert "--k" in main_refused(capfd, "gdt", "evaluate", *block, "--k", "0", code=2)


def _block_step(path):
    """The block with its bore (no boss) as a STEP, through OpenCascade: faces 5 (z = 0),
    2 (y = 0), 1 (x = 0) and 7 (the bore) are A, B, C and H1."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    from camcmm.cad.write import write_step

    box = BRepPrimAPI_MakeBox(80.0, 60.0, 30.0).Shape()
    bore = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(20, 30, -1), gp_Dir(0, 0, 1)), 5.0, 32.0).Shape()
    write_step(BRepAlgoAPI_Cut(box, bore).Shape(), path)
    return path


def test_step_nominal_faces_are_the_features(capfd, tmp_path):
    """Features named as faces of a STEP nominal take their type and nominal from the CAD:
    the same values as the analytic plan of the same surfaces (H1's point and length from
    the face's ends, so its position is the issue's 2·max = 0.116619 mm), with the part in
    a small pose. (Datum features are associated
    by the ISO 5459 minimax — linear programs — so this test keeps to two characteristics.)"""
    step = _block_step(tmp_path / "block.step")
    chars = [
        {"id": "pos-H1", "type": "position", "feature": "H1", "datums": ["A", "B", "C"], "tolerance": 0.2},
        {"id": "dia-H1", "type": "diameter", "feature": "H1", "lower": -0.02, "upper": 0.02},
    ]
    faces = {"A": 5, "B": 2, "C": 1, "H1": 7}
    doc = {"unit": "mm", "datums": {"A": "A", "B": "B", "C": "C"}, "characteristics": chars}
    part = g.block(pose=g.pose((0.3, -1.0, 0.5), 0.4, (0.2, -0.15, 0.1)))
    plan, cloud = _case(
        tmp_path / "cad", part, {**doc, "features": {f: {"type": "face", "cad": i} for f, i in faces.items()}}
    )
    # best fit: inspect.align's ICP onto the CAD's tessellation (the boss the CAD lacks an outlier)
    got = main_json(capfd, "gdt", "evaluate", plan, cloud, "--nominal", step, "--json")
    assert got["alignment"]["stages"][-1]["kind"].startswith("inspect.align")
    assert [f["type"] for f in got["features"]] == ["plane", "plane", "plane", "cylinder"]
    analytic = g.plan_document()["features"]
    analytic = {f: analytic[f] for f in "ABC"} | {
        "H1": {
            "type": "cylinder",
            "point": [20, 30, 0],
            "axis": [0, 0, 1],
            "diameter": 10,
            "length": 30,
            "internal": True,
            "box": [[10, 20, -0.5], [30, 40, 30.5]],
        }
    }
    plan, cloud = _case(tmp_path / "analytic", part, {**doc, "features": analytic})
    ref = _by_id(main_json(capfd, "gdt", "evaluate", plan, cloud, "--json"))
    for cid, c in _by_id(got).items():
        assert c["value"] == pytest.approx(ref[cid]["value"], abs=1e-9), cid
    assert ref["dia-H1"]["value"] == pytest.approx(10.0, abs=1e-8)
    assert ref["pos-H1"]["value"] == pytest.approx(2 * np.hypot(0.05, 0.03), abs=1e-8)
    # a face the CAD does not have: one line naming the plan's key
    plan, cloud = _case(
        tmp_path / "bad",
        part,
        {**doc, "features": {"A": {"type": "face", "cad": 99}}, "datums": {}, "characteristics": []},
    )
    err = main_refused(capfd, "gdt", "evaluate", plan, cloud, "--nominal", step, "--align", "none", code=2)
    assert "features.A.cad" in err and "99" in err


def test_an_alignment_that_does_not_settle_exits_3(capfd, tmp_path):
    """One Gauss-Newton step from a small pose does not settle: the document is printed
    (aligned false, the failure), one line on stderr, exit 3 — not a result to read."""
    plan, cloud = _case(tmp_path, g.block(pose=g.pose((0.3, -1.0, 0.5), 0.4, (0.2, -0.15, 0.1))))
    rc, out, err = main_run(capfd, "gdt", "evaluate", plan, cloud, "--max-iterations", "1", "--json")
    assert rc == 3 and err.strip() == "camcmm: alignment best-fit did not settle in 1 iterations", err
    doc = json.loads(out)
    assert doc["aligned"] is False and doc["alignment"]["converged"] is False
    assert any("did not settle" in w for w in doc["warnings"])


def test_plugin_outputs_for_the_gui():
    """gdt.evaluate by id with the plan as a document (as the GUI's task runs it): the
    aligned cloud's field 'feature' holds each point's feature (index into 'features'),
    -1 for the faces the plan does not name; labels carry anchors and decisive points."""
    from camcmm.api import PointCloud, get_algorithm

    part = g.block()
    out = get_algorithm("gdt.evaluate")(cloud=PointCloud(part.points), plan=g.plan_document(), align="none")
    assert {"features", "datums", "alignment", "characteristics", "labels", "aligned"} <= set(out)
    ids = [f["id"] for f in out["features"]]
    field = np.asarray(out["aligned"].fields["feature"]).astype(int)
    for name in ("A", "B", "C", "D", "T", "H1", "P1"):
        assert np.all(field[part.surface == part.names.index(name)] == ids.index(name)), name
    for name in ("E", "P1T"):  # not in the plan
        assert np.all(field[part.surface == part.names.index(name)] == -1), name
    lab = {x["id"]: x for x in out["labels"]}["flat-A"]
    assert lab["verdict"] == "conform" and 0 < len(lab["decisive"]) <= 20
    assert np.allclose(np.asarray(lab["decisive"])[:, 2], 0.0, atol=1e-9)  # on A
