"""QIF 3.0 model-based definitions into GD&T plans: ``camcmm gdt import-qif`` (issue 28).

References: the NIST MBE PMI test case CTC 01 as QIF (tests/data/qif3, copied from
../shared/data/qif3/samples; its SOURCE.txt: 7 cylinders, 2 planes, 2 lines, 3 plane
pairs; diameter ×7, flatness, perpendicularity, position ×2, surface profile ×2, angle)
and FTC 06 (../shared only, skipped when absent; lengths in mm, tolerances in inch). The
expected numbers are read off the QIF files by hand (the element and its value named at
each assertion), not from the importer.

The virtual "measured" CTC 01: every imported feature that carries a characteristic is
sampled on its nominal surface as the plan states it, with a known deviation — each bore
a known diameter error, datum A on two levels 0.03 mm apart (the lower one |x| < 100 mm,
so no tilted zone is thinner: flatness exactly 0.03 mm and the tangent datum exactly the
upper level), the side plane-2162 tilted by 0.001 over z −95 … −5 mm (perpendicularity
to A exactly 0.001 · 90 mm) — and ``camcmm gdt evaluate --align none`` gives them back.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from camcmm_plugins.gdt.plan import read_plan
from camcmm_plugins.gdt.qif.read import import_qif
from helpers.badcases.qif import ANGLE, mini_qif
from helpers.cli import main_json, main_text
from helpers.paths import SHARED_DATA, TEST_DATA

CTC01 = TEST_DATA / "qif3" / "nist_ctc_01_asme1_ap242.qif"
FTC06 = SHARED_DATA / "qif3" / "samples" / "nist_ftc_06_asme1_ap242.qif"

#: CTC 01's characteristics skipped, QIF id -> the reason's words.
CTC01_SKIPPED = {
    "2166": "OtherNonShape feature (a set of 2 face(s))",
    "2173": "OtherNonShape feature (a set of 6 face(s))",
    "1457": "its feature 2166 was not imported",
    "1462": "its feature 2173 was not imported",
    "1491": "an angle size",
}
#: CTC 01's diameters: characteristic nominal id -> (feature, nominal Ø, lower, upper) mm, from
#: each DiameterCharacteristicDefinition's Min/MaxValue (1484, 1487: DefinedAsLimit 34.8/35.2
#: less the TargetValue 35) and the CylinderFeatureDefinition's Diameter.
CTC01_DIAMETERS = {
    "1473": ("cylinder-2156", 35.0, -0.2, 0.0),
    "1476": ("cylinder-2157", 35.0, 0.0, 0.2),
    "1479": ("cylinder-2175", 20.0, -0.1, 0.05),
    "1482": ("cylinder-2176", 20.0, -0.05, 0.1),
    "1485": ("cylinder-2177", 35.0, -0.2, 0.2),
    "1488": ("cylinder-2178", 35.0, -0.2, 0.2),
    "1494": ("cylinder-2182", 25.0, -0.15, 0.15),
}


@pytest.fixture(scope="module")
def ctc01():
    return import_qif(CTC01)


def test_ctc01_counts_and_reasons(ctc01):
    doc, rep = ctc01
    types = [f["type"] for f in doc["features"].values()]
    # 7 cylinders, 2 planes + 3 plane pairs (6 planes), 2 lines; the 2 face sets skipped
    assert (types.count("cylinder"), types.count("plane"), types.count("line"), len(types)) == (7, 8, 2, 17)
    assert (rep["features"], rep["datums"], rep["characteristics"]) == (17, 3, 11)
    assert rep["unit"] == "mm" and doc["unit"] == "mm" and rep["unlimited"] == []
    skipped = {s["id"]: s["reason"] for s in rep["skipped"]}
    assert set(skipped) == set(CTC01_SKIPPED)
    for qid, words in CTC01_SKIPPED.items():
        assert words in skipped[qid], (qid, skipped[qid])
    # every one of the 14 characteristic nominals is imported or skipped with its reason
    chars = {i["id"] for i in rep["imported"] if i["kind"] == "characteristic"}
    assert len(chars) == 11 and len(chars | (set(skipped) - {"2166", "2173"})) == 14
    types = sorted(c["type"] for c in doc["characteristics"])
    assert types == ["diameter"] * 7 + ["flatness", "perpendicularity", "position", "position"]


def test_ctc01_values(ctc01):
    doc, _ = ctc01
    f = doc["features"]
    assert doc["datums"] == {"A": "plane-2154", "B": "cylinder-2156", "C": "cylinder-2157"}
    chars = {c["id"]: c for c in doc["characteristics"]}
    # FlatnessCharacteristicDefinition 1469: 0.2 on plane 2154; Perpendicularity 1466: 1.5 to DRF 1459 = A
    assert chars["flatness-1470"] == {"id": "flatness-1470", "type": "flatness", "feature": "plane-2154",
                                      "tolerance": 0.2, "name": "Flatness.1"}  # fmt: skip
    perp = chars["perpendicularity-1467"]
    assert (perp["feature"], perp["datums"], perp["tolerance"]) == ("plane-2162", ["A"], 1.5)
    # PositionCharacteristicDefinition 1442/1449: 0.75 to DRF 1440 = A|B|C, on the slots 2159/2161:
    # the median plane of the pair's two faces (feature and other)
    for qid, pair in (("1443", "width-2159"), ("1450", "width-2161")):
        pos = chars[f"position-{qid}"]
        assert (pos["feature"], pos["other"], pos["datums"]) == (f"{pair}-1", f"{pair}-2", ["A", "B", "C"])
        assert pos["tolerance"] == 0.75
    for qid, (fid, dia, lo, hi) in CTC01_DIAMETERS.items():
        c = chars[f"diameter-{qid}"]
        assert (c["feature"], c["lower"], c["upper"], c["nominal"]) == (fid, lo, hi, dia)  # TargetValue
        assert f[fid]["diameter"] == dia and f[fid]["internal"] is True
    # cylinder extents: the CylinderFeatureDefinition's Length from the axis point
    assert f["cylinder-2156"]["point"] == [-325.0, -175.0, 0.0] and f["cylinder-2156"]["length"] == 100.0
    assert f["cylinder-2175"]["length"] == 45.0 and f["cylinder-2182"]["length"] == 50.0
    # the plane pairs: two opposite faces at the definition's Width (2158: 85, 2160: 50)
    for pair, width in (("width-2159", 85.0), ("width-2161", 50.0)):
        a, b = f[f"{pair}-1"], f[f"{pair}-2"]
        na, nb = np.array(a["normal"]), np.array(b["normal"])
        assert na @ nb == pytest.approx(-1.0)
        assert abs((np.array(b["point"]) - a["point"]) @ na) == pytest.approx(width, abs=1e-9)
    # angled pair 2180 (TaperAngle 30 deg = the angle between the faces' normals' complement)
    na, nb = np.array(f["angled-2180-1"]["normal"]), np.array(f["angled-2180-2"]["normal"])
    assert np.degrees(np.arccos(-na @ nb)) == pytest.approx(60.0)
    # plane A's box: its PolyLine's extent (x ±400, y ±225) padded by the band (0.5) along its normal z
    assert f["plane-2154"]["box"] == [[-400.0, -225.0, -0.5], [400.0, 225.0, 0.5]]


def test_cli_json_and_plan_reads_back(tmp_path, capfd, ctc01):
    out = tmp_path / "plan.yaml"
    doc = main_json(capfd, "gdt", "import-qif", CTC01, "--out", out, "--json")
    assert (doc["features"], doc["datums"], doc["characteristics"]) == (17, 3, 11)
    assert doc["skipped"] == ctc01[1]["skipped"] and all(set(s) == {"id", "reason"} for s in doc["skipped"])
    assert len(doc["warnings"]) == 5 and doc["unit"] == "mm"
    plan = read_plan(out)
    assert len(plan.features) == 17 and len(plan.characteristics) == 11
    assert plan.datums == {"A": ("plane-2154",), "B": ("cylinder-2156",), "C": ("cylinder-2157",)}
    assert yaml.safe_load(out.read_text())["qif"]["characteristics"]["diameter-1473"] == "1473"
    text = main_text(capfd, "gdt", "import-qif", CTC01, "--out", tmp_path / "plan.json")
    assert "17 features, 3 datums, 11 characteristics" in text and "skipped 1491" in text
    assert len(read_plan(tmp_path / "plan.json").characteristics) == 11


def test_units_from_file_units(tmp_path):
    """Lengths in the primary LinearUnit; the Characteristics' in PMILinearUnit when given."""
    (tmp_path / "in.qif").write_bytes(mini_qif(unit="inch", factor="0.0254"))
    doc, rep = import_qif(tmp_path / "in.qif")
    cyl = doc["features"]["cylinder-4"]
    assert rep["unit"] == "inch"
    assert (cyl["diameter"], cyl["length"]) == (254.0, 381.0)  # 10 in, 15 in
    dia = doc["characteristics"][0]
    assert (dia["lower"], dia["upper"]) == (-0.508, 0.508)  # ±0.02 in
    (tmp_path / "pmi.qif").write_bytes(mini_qif(pmi_unit="inch"))
    doc, _ = import_qif(tmp_path / "pmi.qif")
    assert doc["features"]["cylinder-4"]["diameter"] == 10.0
    assert doc["characteristics"][0]["upper"] == 0.508 and doc["characteristics"][1]["tolerance"] == 1.27
    (tmp_path / "angle.qif").write_bytes(mini_qif(extra_chars=ANGLE))
    _, rep = import_qif(tmp_path / "angle.qif")
    assert rep["characteristics"] == 2 and rep["skipped"][0]["id"] == "14"


def test_compound_datum_and_datum_targets(tmp_path):
    """A CompoundDatum (A-B) is the common datum "A-B" in precedence order; a datum defined by
    targets is skipped, and so is every characteristic whose frame names it."""
    base = mini_qif().decode()
    second = (
        '<DatumDefinition id="7"><DatumLabel>B</DatumLabel><FeatureNominalIds n="1"><Id>4</Id>'
        '</FeatureNominalIds></DatumDefinition><DatumDefinition id="8"><DatumLabel>T</DatumLabel>'
        '<DatumTargetIds n="1"><Id>3</Id></DatumTargetIds></DatumDefinition></DatumDefinitions>'
    )
    compound = (
        '<Datums n="1"><Datum><CompoundDatum><Datums n="2">'
        "<Datum><SimpleDatum><DatumDefinitionId>5</DatumDefinitionId></SimpleDatum></Datum>"
        "<Datum><SimpleDatum><DatumDefinitionId>7</DatumDefinitionId></SimpleDatum></Datum>"
        "</Datums></CompoundDatum><Precedence><PrecedenceEnum>PRIMARY</PrecedenceEnum></Precedence></Datum></Datums>"
        '</DatumReferenceFrame><DatumReferenceFrame id="9"><Datums n="1"><Datum><SimpleDatum>'
        "<DatumDefinitionId>8</DatumDefinitionId></SimpleDatum></Datum></Datums>"
    )
    perp = (
        '<PerpendicularityCharacteristicDefinition id="15"><ToleranceValue>0.1</ToleranceValue>'
        "<DatumReferenceFrameId>6</DatumReferenceFrameId></PerpendicularityCharacteristicDefinition>"
        '<ParallelismCharacteristicDefinition id="16"><ToleranceValue>0.1</ToleranceValue>'
        "<DatumReferenceFrameId>9</DatumReferenceFrameId></ParallelismCharacteristicDefinition>"
    )
    noms = (
        '<PerpendicularityCharacteristicNominal id="17"><CharacteristicDefinitionId>15</CharacteristicDefinitionId>'
        '<FeatureNominalIds n="1"><Id>3</Id></FeatureNominalIds></PerpendicularityCharacteristicNominal>'
        '<ParallelismCharacteristicNominal id="18"><CharacteristicDefinitionId>16</CharacteristicDefinitionId>'
        '<FeatureNominalIds n="1"><Id>3</Id></FeatureNominalIds></ParallelismCharacteristicNominal>'
    )
    text = base.replace("</DatumDefinitions>", second, 1)
    head, rest = text.split('<DatumReferenceFrame id="6">', 1)
    rest = rest[rest.index("</Datums>") + len("</Datums>") :]
    text = head + '<DatumReferenceFrame id="6">' + compound + rest
    text = text.replace("</CharacteristicDefinitions>", perp + "</CharacteristicDefinitions>")
    text = text.replace("</CharacteristicNominals>", noms + "</CharacteristicNominals>")
    (tmp_path / "c.qif").write_text(text)
    doc, rep = import_qif(tmp_path / "c.qif")
    assert doc["datums"] == {"A": "plane-3", "B": "cylinder-4"}
    chars = {c["id"]: c for c in doc["characteristics"]}
    assert chars["perpendicularity-17"]["datums"] == ["A-B"]
    skipped = {s["id"]: s["reason"] for s in rep["skipped"]}
    assert "datum targets" in skipped["8"] and "names datum 8, which was not imported" in skipped["18"]


@pytest.mark.skipif(not FTC06.is_file(), reason="../shared/data/qif3 (NIST FTC 06) is absent")
def test_ftc06_imports(tmp_path):
    doc, rep = import_qif(FTC06)
    assert (rep["features"], rep["datums"], rep["characteristics"], len(rep["skipped"])) == (94, 4, 32, 40)
    types = [c["type"] for c in doc["characteristics"]]
    assert (types.count("diameter"), types.count("flatness"), types.count("width")) == (24, 3, 3)
    # every feature and characteristic nominal of the file is imported or skipped
    root = FTC06.read_text()
    n_feat = root.count("FeatureNominal id=")
    n_char = root.count("CharacteristicNominal id=")
    kinds = [i["kind"] for i in rep["imported"]]
    n_skip_f = sum(s["reason"].startswith("feature") for s in rep["skipped"])
    n_skip_c = sum(s["reason"].startswith("characteristic") for s in rep["skipped"])
    assert (kinds.count("feature") + n_skip_f, kinds.count("characteristic") + n_skip_c) == (n_feat, n_char)
    # FlatnessCharacteristicDefinition 2337: ToleranceValue linearUnit="inch" 0.01 -> 0.254 mm
    assert {c["tolerance"] for c in doc["characteristics"] if c["type"] == "flatness"} == {0.254}
    # a pattern (DiameterCharacteristicNominal 2401 on 2 bores): one characteristic a bore; the limits
    # ±0.008 in about the TargetValue 0.562 in, which is not the model's Ø 0.5625 in (a note says so)
    pattern = [c for c in doc["characteristics"] if c["id"].startswith("diameter-2401-")]
    assert [(c["lower"], c["upper"], c["nominal"]) for c in pattern] == [(-0.2032, 0.2032, 14.2748)] * 2
    assert len({c["feature"] for c in pattern}) == 2 and any(n.startswith("2401: target") for n in rep["notes"])
    out = tmp_path / "ftc06.yaml"
    out.write_text(yaml.safe_dump(doc))
    assert len(read_plan(out).characteristics) == 32


# ---- the virtual measured CTC 01 ------------------------------------------------------------

#: Diameter errors of the bores (mm) built into the virtual part.
BORE_ERRORS = {"cylinder-2156": 0.01, "cylinder-2157": -0.02, "cylinder-2175": 0.03, "cylinder-2176": 0.0,
               "cylinder-2177": 0.05, "cylinder-2178": -0.01, "cylinder-2182": 0.02}  # fmt: skip
STEP_A, TILT = 0.03, 0.001  # A's two levels (mm); plane-2162's tilt (x = 400 + TILT·(z + 50))
#: The slots' faces moved along their normals' axis (mm): slot 2159 both faces +0.05 in x (its
#: median 0.05 off: position 0.1); slot 2161 the face at y = 25 by +0.04 (median 0.02 off: 0.04).
SLOT_SHIFTS = {"width-2159-1": 0.05, "width-2159-2": 0.05, "width-2161-1": 0.04, "width-2161-2": 0.0}


def _basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _virtual_ctc01(features: dict) -> np.ndarray:
    rng = np.random.default_rng(7)
    parts = []
    for fid, err in BORE_ERRORS.items():  # 240 points a bore, 5 mm from its ends (away from A's band)
        f = features[fid]
        p, a = np.array(f["point"]), np.array(f["axis"])
        e1, e2 = _basis(a)
        th, t = rng.uniform(0, 2 * np.pi, 240), rng.uniform(5, f["length"] - 5, 240)
        r = 0.5 * (f["diameter"] + err)
        parts.append(p + t[:, None] * a + r * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2))
    xy = rng.uniform([-390, -215], [390, 215], (3000, 2))
    holes = [np.array(features[k]["point"][:2]) for k in BORE_ERRORS if abs(features[k]["axis"][2]) > 0.9]
    keep = np.all([np.linalg.norm(xy - h, axis=1) > 25 for h in holes], axis=0)
    for fid in SLOT_SHIFTS:  # no point of A where a slot face's band would take it
        lo, hi = np.array(features[fid]["box"])[:, :2] + [[-2, -2], [2, 2]]
        keep &= ~np.all((xy > lo) & (xy < hi), axis=1)
    xy = xy[keep][:1500]
    parts.append(np.c_[xy, np.where(np.abs(xy[:, 0]) < 100, -STEP_A, 0.0)])
    y, z = (g.ravel() for g in np.meshgrid(np.linspace(-170, 170, 20), np.linspace(-95, -5, 20)))
    parts.append(np.c_[400 + TILT * (z + 50), y, z])
    for fid, shift in SLOT_SHIFTS.items():  # 150 points a face, on its middle 60 % (its box: the face + 10 % a side)
        f = features[fid]
        n = np.array(f["normal"])
        lo, hi = np.array(f["box"])
        u = rng.uniform(lo + 0.25 * (hi - lo), hi - 0.25 * (hi - lo), (150, 3))
        u = np.where(np.abs(n) > 0.5, f["point"], u)  # on the nominal plane
        parts.append(u + shift * np.abs(n))
    return np.vstack(parts)


def test_virtual_ctc01_gives_the_constructed_values(tmp_path, capfd, ctc01):
    doc, _ = ctc01
    plan = tmp_path / "ctc01.yaml"
    main_json(capfd, "gdt", "import-qif", CTC01, "--out", plan, "--json")
    cloud = tmp_path / "ctc01.xyz"
    np.savetxt(cloud, _virtual_ctc01(doc["features"]), fmt="%.10f")
    res = main_json(capfd, "gdt", "evaluate", plan, cloud, "--align", "none", "--json")
    got = {c["id"]: c for c in res["characteristics"]}
    assert len(got) == 11
    for qid, (fid, dia, lo, hi) in CTC01_DIAMETERS.items():
        c = got[f"diameter-{qid}"]
        err = BORE_ERRORS[fid]
        assert c["value"] == pytest.approx(dia + err, abs=1e-6), qid
        assert c["verdict"] == ("conform" if lo <= err <= hi else "not conform"), qid
    # 2156: +0.01 against -0.2/0, 2157: -0.02 against 0/+0.2 -> out; the rest in
    assert [got[f"diameter-{q}"]["verdict"] for q in ("1473", "1476")] == ["not conform"] * 2
    assert got["flatness-1470"]["value"] == pytest.approx(STEP_A, abs=1e-9)
    assert got["perpendicularity-1467"]["value"] == pytest.approx(TILT * 90.0, abs=1e-7)
    assert got["position-1443"]["value"] == pytest.approx(0.1, abs=1e-7)
    assert got["position-1450"]["value"] == pytest.approx(0.04, abs=1e-7)
    # the features no point was sampled on are named, not silently empty
    empty = {w.split()[1] for w in res["warnings"] if w.startswith("feature ") and "not evaluated" in w}
    assert {"line-2184", "line-2185", "angled-2180-1"} <= empty


def _step_faces(f: dict, cad) -> list:
    """The faces of the CAD model ``cad`` that the plan feature ``f`` lies on: same plane and
    outward normal; same axis and diameter; same apex, axis and angle; same centre and
    diameter(s) — to 1e-4 mm in location and size (FTC 06's inch values carry about 2e-5 mm of
    rounding), 1e-9 in the directions' cosines, 1e-6 degree in a cone's angle."""
    out = []
    for cf in cad.faces:
        p = cf.params
        if cf.type != f["type"]:
            continue
        if f["type"] == "plane":
            on = abs((np.array(f["point"]) - p["point"]) @ p["normal"]) < 1e-4 and p["normal"] @ f["normal"] > 1 - 1e-9
        elif f["type"] == "cylinder":
            w, a = np.array(f["point"]) - p["point"], p["axis"]
            on = np.linalg.norm(w - (w @ a) * a) < 1e-4 and abs(a @ f["axis"]) > 1 - 1e-9
            on = on and abs(p["diameter"] - f["diameter"]) < 1e-4
        elif f["type"] == "cone":
            on = np.linalg.norm(np.array(f["apex"]) - p["apex"]) < 1e-4 and p["axis"] @ f["axis"] > 1 - 1e-9
            on = on and abs(p["angle"] - f["angle"]) < 1e-6
        elif f["type"] == "sphere":
            on = (
                np.linalg.norm(np.array(f["centre"]) - p["centre"]) < 1e-4 and abs(p["diameter"] - f["diameter"]) < 1e-4
            )
        else:  # torus
            on = np.linalg.norm(np.array(f["centre"]) - p["centre"]) < 1e-4 and abs(p["axis"] @ f["axis"]) > 1 - 1e-9
            on = on and all(abs(p[k] - f[k]) < 1e-4 for k in ("major_diameter", "minor_diameter"))
        if on:
            out.append(cf)
    return out


def test_ctc01_features_are_faces_of_its_step(ctc01):
    """The QIF and the STEP AP242 of CTC 01 (tests/data/nist_pmi) are one part in one frame:
    each imported plane and cylinder lies on a face of the STEP (:func:`_step_faces`), and
    its extent covers that face's: a plane's box holds the face's bounds, a cylinder's
    point … point + length·axis spans them."""
    from camcmm.api import read_cad

    cad = read_cad(TEST_DATA / "nist_pmi" / "nist_ctc_01_asme1_ap242-e1.stp")
    doc, _ = ctc01
    matched = 0
    for fid, f in doc["features"].items():
        if f["type"] not in ("plane", "cylinder"):
            continue
        faces = _step_faces(f, cad)
        assert faces, fid
        lo = np.min([cf.bounds[0] for cf in faces], axis=0)
        hi = np.max([cf.bounds[1] for cf in faces], axis=0)
        if f["type"] == "plane":
            assert np.all(np.array(f["box"][0]) <= lo + 1e-9) and np.all(hi - 1e-9 <= np.array(f["box"][1])), fid
        else:  # CTC 01's axes are along x, y or z: the bounds' projections are the face's ends
            a, p0 = np.array(f["axis"]), np.array(f["point"])
            t = sorted([(lo - p0) @ a, (hi - p0) @ a])
            assert t[0] == pytest.approx(0.0, abs=1e-6) and t[1] == pytest.approx(f["length"], abs=1e-6), fid
        matched += 1
    assert matched == 15  # 7 cylinders, 2 planes, 6 planes of the 3 pairs


@pytest.mark.skipif(not FTC06.is_file(), reason="../shared/data/qif3 (NIST FTC 06) is absent")
def test_ftc06_surfaces_are_faces_of_its_step():
    """FTC 06's 86 imported surface features (planes, cylinders, cones — apex on the side the
    Small/LargeEndDistance say —, spheres, tori) each lie on a face of its STEP AP242."""
    from camcmm.api import read_cad

    cad = read_cad(SHARED_DATA / "qif3" / "step" / "nist_ftc_06_asme1_ap242-e2.stp")
    doc, _ = import_qif(FTC06)
    surfaces = {k: f for k, f in doc["features"].items() if f["type"] not in ("circle", "line", "point")}
    assert len(surfaces) == 86 and {f["type"] for f in surfaces.values()} == {
        "plane",
        "cylinder",
        "cone",
        "sphere",
        "torus",
    }
    assert [k for k, f in surfaces.items() if not _step_faces(f, cad)] == []
