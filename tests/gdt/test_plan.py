"""The GD&T plan (gdt/plan.py): the issue's example read and converted to mm, written
back and read again unchanged, and each refusal one line naming the file and key."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from camcmm.api import InputError
from camcmm_plugins.gdt.plan import DEFAULT_BAND_MM, parse_plan, plan_document, read_plan

PLAN = """\
unit: mm
band: 0.5
features:
  A:  {type: plane, point: [0, 0, 0], normal: [0, 0, 2], box: [[0, 0, -1], [80, 60, 1]]}
  B:  {type: plane, point: [0, 0, 0], normal: [0, -1, 0]}
  C:  {type: plane, point: [0, 0, 0], normal: [-1, 0, 0], association: ls}
  H1: {type: cylinder, point: [20, 30, 0], axis: [0, 0, 1], diameter: 10, length: 30, internal: true, band: 0.2}
  S1: {type: sphere, centre: [60, 30, 40], diameter: 20}
  K1: {type: cone, apex: [1, 2, 3], axis: [0, 0, -1], angle: 30}
  F1: {type: face, cad: 12}
  L1: {type: line, point: [0, 0, 0], direction: [1, 0, 0]}
  T1: {type: torus, centre: [0, 0, 0], axis: [0, 0, 1], major_diameter: 40, minor_diameter: 6}
datums: {A: A, B: B, C: C, AB: [A, B]}
characteristics:
  - {id: flat-A, type: flatness, feature: A, tolerance: 0.05}
  - {id: pos-H1, type: position, feature: H1, datums: [A, B, C], tolerance: 0.1, modifier: mmc, k: 3}
  - {id: perp-H1, type: perpendicularity, feature: H1, datums: "A-B", tolerance: 0.05}
  - {id: dia-H1, type: diameter, feature: H1, lower: -0.02, upper: 0.02}
  - {id: dist, type: distance, feature: S1, to: K1, nominal: 12.5, note: kept}
"""


def _doc():
    return yaml.safe_load(PLAN)


def test_issue_plan_read(tmp_path):
    path = tmp_path / "plan.yaml"
    path.write_text(PLAN)
    plan = read_plan(path)
    assert plan.unit == "mm" and plan.band == 0.5 and plan.source == str(path)
    a = plan.features["A"]
    np.testing.assert_array_equal(a.nominal["normal"], [0, 0, 1])  # normalised
    np.testing.assert_array_equal(a.box, [[0, 0, -1], [80, 60, 1]])
    # datum features take the ISO 5459 default (tangent) unless the plan states one
    assert (a.association, plan.features["B"].association, plan.features["C"].association) == ("tangent",) * 2 + ("ls",)
    h1 = plan.features["H1"]
    assert h1.association == "ls" and h1.band == 0.2 and h1.nominal["internal"] is True
    assert h1.nominal["diameter"] == 10 and h1.nominal["length"] == 30
    assert plan.features["S1"].nominal["internal"] is False
    assert plan.features["K1"].nominal["angle"] == 30
    assert plan.features["F1"].nominal["cad"] == 12
    assert "length" not in plan.features["L1"].nominal  # unlimited extent
    assert plan.datums["AB"] == ("A", "B") and plan.datums["A"] == ("A",)
    assert plan.datums["A-B"] == ("A", "B")  # named by perp-H1, declared on the fly
    pos = plan.characteristics[1]
    assert pos.datums == ("A", "B", "C") and pos.modifier == "MMC" and pos.k == 3 and pos.tolerance == 0.1
    assert plan.characteristics[2].datums == ("A-B",)
    dia = plan.characteristics[3]
    assert (dia.lower, dia.upper, dia.tolerance, dia.k) == (-0.02, 0.02, None, 2.0)
    assert plan.characteristics[4].options == {"to": "K1", "nominal": 12.5, "note": "kept"}


def test_units_converted_and_round_trip():
    doc = _doc()
    doc["unit"] = "in"
    plan = parse_plan(doc, "plan.yaml")
    assert plan.band == pytest.approx(0.5 * 25.4, rel=1e-15)
    assert plan.features["H1"].nominal["diameter"] == pytest.approx(254.0, rel=1e-15)
    np.testing.assert_allclose(plan.features["S1"].nominal["centre"], np.array([60, 30, 40]) * 25.4, rtol=1e-15)
    assert plan.features["K1"].nominal["angle"] == 30  # degrees stay degrees
    assert plan.characteristics[1].tolerance == pytest.approx(2.54, rel=1e-15)
    assert plan.characteristics[4].options["nominal"] == pytest.approx(12.5 * 25.4, rel=1e-15)
    back = plan_document(plan)
    json.dumps(back)  # plain values
    assert back["unit"] == "in" and back["features"]["H1"]["diameter"] == pytest.approx(10, rel=1e-15)
    again = parse_plan(yaml.safe_load(yaml.safe_dump(back)), "plan.yaml")
    _same(plan, again)


def test_round_trip_mm_exact():
    plan = parse_plan(_doc(), "plan.yaml")
    back = plan_document(plan)
    again = parse_plan(back, "plan.yaml")
    _same(plan, again, exact=True)
    assert plan_document(again) == back


def _same(p, q, exact=False):
    tol = 0 if exact else 1e-14
    assert (p.unit, p.band, p.datums) == (q.unit, pytest.approx(q.band, rel=tol), q.datums)
    assert p.features.keys() == q.features.keys()
    for fid, a in p.features.items():
        b = q.features[fid]
        assert (a.type, a.association, a.band) == (b.type, b.association, pytest.approx(b.band, rel=tol))
        assert a.nominal.keys() == b.nominal.keys()
        for k, v in a.nominal.items():
            np.testing.assert_allclose(v, b.nominal[k], rtol=tol, atol=0)
        assert (a.box is None) == (b.box is None)
        if a.box is not None:
            np.testing.assert_allclose(a.box, b.box, rtol=tol)
    for c, d in zip(p.characteristics, q.characteristics, strict=True):
        assert (c.id, c.type, c.feature, c.datums, c.modifier, c.k) == (
            d.id,
            d.type,
            d.feature,
            d.datums,
            d.modifier,
            d.k,
        )
        for name in ("tolerance", "lower", "upper"):
            x, y = getattr(c, name), getattr(d, name)
            assert (x is None and y is None) or x == pytest.approx(y, rel=tol)
        assert c.options.keys() == d.options.keys()


def test_defaults():
    plan = parse_plan({"features": {"P": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}}})
    assert plan.unit == "mm" and plan.band == DEFAULT_BAND_MM and plan.characteristics == [] and plan.datums == {}
    assert plan.features["P"].association == "ls" and plan.features["P"].box is None


def _set(doc, path, value):
    node = doc
    keys = path.split(".")
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node[k]
    if value is _DELETE:
        del node[keys[-1]]
    elif isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value


_DELETE = object()


@pytest.mark.parametrize(
    "path, value, expected",
    [
        ("features.H1.axis", [0, 1], "features.H1.axis: expected 3 numbers"),
        ("features.A.normal", [0, 0, 0], "features.A.normal: a direction of zero length"),
        ("features.H1.point", [0, "x", 0], "features.H1.point[1]: expected a number"),
        ("features.H1.diameter", -1, "features.H1.diameter: must be > 0"),
        ("features.H1.diameter", _DELETE, "features.H1.diameter: missing"),
        ("features.H1.diamter", 10, "features.H1.diamter: unknown key for a cylinder"),
        ("features.H1.type", "hexagon", "features.H1.type: unknown type 'hexagon'"),
        ("features.H1.association", "best", "features.H1.association: unknown association 'best'"),
        ("features.H1.internal", "yes", "features.H1.internal: expected true or false"),
        ("features.H1.band", 0, "features.H1.band: must be > 0"),
        ("features.A.box", [[0, 0, 1], [80, 60, -1]], "features.A.box: the first corner must be the minimum"),
        ("features.K1.angle", 180, "features.K1.angle: a cone's full apex angle must lie in (0, 180)"),
        ("features.F1.cad", 0, "features.F1.cad: expected a face number"),
        ("features.S1.centre", [1, 2, float("nan")], "features.S1.centre[2]: expected a finite number"),
        ("unit", "furlong", "unit: unknown length unit 'furlong'"),
        ("band", -0.1, "band: must be > 0"),
        ("features", {}, "features: empty"),
        ("datums.B", "Z", "datums.B: unknown feature 'Z'"),
        ("datums.AB", ["A"], "datums.AB: a common datum names two or more features"),
        ("characteristics.0.type", "wobble", "characteristics[0].type: unknown characteristic 'wobble'"),
        ("characteristics.0.feature", "Q", "characteristics[0].feature: unknown feature 'Q'"),
        ("characteristics.0.tolerance", 0, "characteristics[0].tolerance: must be > 0"),
        ("characteristics.0.tolerance", -0.05, "characteristics[0].tolerance: must be > 0"),
        ("characteristics.1.datums", ["A", "D"], "characteristics[1].datums[1]: unknown datum 'D'"),
        ("characteristics.1.datums", ["A", "A"], "characteristics[1].datums: a datum is named twice"),
        ("characteristics.1.modifier", "XYZ", "characteristics[1].modifier: unknown modifier 'XYZ'"),
        ("characteristics.1.k", 0, "characteristics[1].k: must be > 0"),
        ("characteristics.2.datums", None, "characteristics[2].datums: a perpendicularity is relative to a datum"),
        ("characteristics.3.lower", 0.05, "characteristics[3].lower: 0.05 is above upper 0.02"),
        ("characteristics.0.lower", 0.0, "characteristics[0].lower: lower/upper limits are for sizes"),
        ("characteristics.3.id", "flat-A", "characteristics[3].id: 'flat-A' is used twice"),
        ("characteristics.4.to", "Nope", "characteristics[4].to: unknown feature 'Nope'"),
        ("characteristics.4.nominal", "x", "characteristics[4].nominal: expected a number"),
        ("characteristics.0.id", _DELETE, "characteristics[0].id: missing"),
        ("characteristics", {"a": 1}, "characteristics: expected a list"),
    ],
)
def test_refusals_one_line_naming_file_and_key(path, value, expected):
    doc = _doc()
    _set(doc, path, value)
    with pytest.raises(InputError) as exc:
        parse_plan(doc, "/some/folder/plan.yaml")
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith("plan.yaml: " + expected), msg


def test_duplicate_ids_after_conversion():
    doc = {"features": {1: {"type": "point", "point": [0, 0, 0]}, "1": {"type": "point", "point": [1, 0, 0]}}}
    with pytest.raises(InputError, match=r"^plan\.yaml: features\.1: '1' is used twice"):
        parse_plan(doc, "plan.yaml")
    doc = _doc()
    doc["datums"][7] = "A"
    doc["datums"]["7"] = "B"
    with pytest.raises(InputError, match=r"^plan\.yaml: datums\.7: '7' is used twice"):
        parse_plan(doc, "plan.yaml")


def test_file_refusals(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("features: [1, 2\n")
    with pytest.raises(InputError, match=r"^bad\.yaml: not valid YAML"):
        read_plan(bad)
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    with pytest.raises(InputError, match=r"^empty\.yaml: empty document"):
        read_plan(empty)
    with pytest.raises(InputError, match=r"^plan: expected a mapping"):
        parse_plan([1, 2])
