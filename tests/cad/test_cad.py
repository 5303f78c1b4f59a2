"""CAD nominals (camcmm.cad): STEP and IGES read with OpenCascade, faces typed and
parametrised, exact signed distances held to OpenCascade's own BRepExtrema_DistShapeShape
(the reference, computed here point by point), and the refusals in one line.

Real files: NIST CTC 01 (tests/data/nist_pmi, public domain) and FTC 06 (read from
../shared, skipped when it is absent)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from camcmm import io as cio
from camcmm.api import InputError, MeshDistance, read_cad
from camcmm.hashing import object_hash
from helpers.paths import SHARED_DATA, TEST_DATA

OCP = pytest.importorskip("OCP", reason="OpenCascade (cadquery-ocp-novtk) is not installed")

CTC01 = TEST_DATA / "nist_pmi" / "nist_ctc_01_asme1_ap242-e1.stp"
FTC06 = SHARED_DATA / "qif3" / "step" / "nist_ftc_06_asme1_ap242-e2.stp"


def brepextrema(shape, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """OpenCascade's distance and closest point of each point to ``shape`` (the reference)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Pnt

    d, q = [], []
    for p in points:
        ext = BRepExtrema_DistShapeShape(BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, p))).Vertex(), shape)
        d.append(ext.Value())
        pq = ext.PointOnShape2(1)
        q.append((pq.X(), pq.Y(), pq.Z()))
    return np.array(d), np.array(q)


def faces_of(cad):
    """The model's faces as one compound: the reference's shape. FTC 06's STEP also holds 97
    free edges (its PMI's geometry), which BRepExtrema against the whole shape measures to."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    comp = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(comp)
    for f in cad.faces:
        builder.Add(comp, f.face)
    return comp


@pytest.fixture(scope="module")
def ctc01():
    return read_cad(CTC01)


@pytest.fixture(scope="module")
def ftc06():
    if not FTC06.is_file():
        pytest.skip(f"{FTC06} is not here (../shared/data is absent on a fresh clone; CI has it)")
    return read_cad(FTC06)


# ------------------------------------------------------------------------------ reading
def test_ctc01_is_read_with_its_117_faces_in_mm(ctc01):
    assert ctc01.format == "STEP" and ctc01.source_unit == "mm" and ctc01.n_faces == 117
    types = [f.type for f in ctc01.faces]
    assert (types.count("plane"), types.count("cylinder"), types.count("cone")) == (56, 57, 4)
    assert [f.index for f in ctc01.faces] == list(range(1, 118))
    np.testing.assert_allclose(ctc01.bounds[1] - ctc01.bounds[0], [800.0, 450.0, 150.0], atol=1e-5)
    # the tessellation: closed where the B-rep is, each triangle on a face
    assert len(ctc01.triangle_face) == ctc01.mesh.n_faces and set(ctc01.triangle_face) == set(range(1, 118))
    assert ctc01.distance_engine.md.info.n_boundary_edges == 0
    # the faces' areas add up to the tessellation's within its chordal error
    assert abs(sum(f.area for f in ctc01.faces) - ctc01.mesh.area()) < 1e-4 * ctc01.mesh.area()
    # io.read gives the same model; info summarises it
    assert cio.info(CTC01)["n_faces"] == 117 and cio.FORMATS[".stp"]["kinds"] == ["cad"]


def test_face_parameters_are_those_of_the_surfaces(ctc01):
    """Points sampled on each face lie on its analytic surface as its parameters state it."""
    for f in ctc01.faces:
        pts = ctc01.sample(f.index, 40, seed=f.index).points
        p = f.params
        if f.type == "plane":
            r = (pts - p["point"]) @ p["normal"]
        elif f.type == "cylinder":
            w = pts - p["point"]
            r = np.linalg.norm(w - np.outer(w @ p["axis"], p["axis"]), axis=1) - p["diameter"] / 2
        else:  # cone: the angle between the axis and apex -> point is half the apex angle
            w = pts - p["apex"]
            ang = np.degrees(np.arccos(np.clip((w @ p["axis"]) / np.linalg.norm(w, axis=1), -1, 1)))
            r = ang - p["angle"] / 2
        assert np.abs(r).max() < 1e-9, (f.index, f.type)


def test_ftc06_has_its_spheres_and_tori(ftc06):
    types = [f.type for f in ftc06.faces]
    assert ftc06.n_faces == 187 and types.count("sphere") == 8 and types.count("torus") == 12
    for f in ftc06.faces:
        if f.type not in ("sphere", "torus"):
            continue
        pts = ftc06.sample(f.index, 30, seed=1).points
        p = f.params
        if f.type == "sphere":
            r = np.linalg.norm(pts - p["centre"], axis=1) - p["diameter"] / 2
        else:
            w = pts - p["centre"]
            h = w @ p["axis"]
            rho = np.linalg.norm(w - np.outer(h, p["axis"]), axis=1)
            r = np.hypot(rho - p["major_diameter"] / 2, h) - p["minor_diameter"] / 2
        assert np.abs(r).max() < 1e-9, (f.index, f.type)


# ------------------------------------------------------------------------------ exact distances
def test_points_offset_along_the_normal_are_recovered_exactly(ctc01):
    """400 points on the faces moved ±50 µm along the outward normal: the signed distance is
    the offset wherever OpenCascade's closest distance is (no other face nearer), to 1e-9 mm;
    the closest points agree with OpenCascade's."""
    s = ctc01.sample(None, 400, seed=7)
    off = np.random.default_rng(7).uniform(-0.05, 0.05, s.n_points)
    P = s.points + off[:, None] * s.normals
    d, q, face = ctc01.distance(P)
    ref, qref = brepextrema(faces_of(ctc01), P)
    np.testing.assert_allclose(np.abs(d), ref, atol=1e-9, rtol=0)
    np.testing.assert_allclose(q, qref, atol=1e-6)
    clean = np.abs(ref - np.abs(off)) < 1e-9  # no other face nearer than the offset's
    assert clean.mean() > 0.95
    np.testing.assert_allclose(d[clean], off[clean], atol=1e-9, rtol=0)
    assert np.all(face[clean] == s.fields["face"][clean])
    # without the refinement the facets are µm away: the test could fail
    md = MeshDistance(ctc01.mesh)
    assert np.abs(md.signed_distance(P)[clean] - off[clean]).max() > 1e-4


def test_points_near_edges_are_left_to_opencascade_and_exact(ctc01, ftc06):
    """Points 2 mm off the surface in random directions: some have their closest point on an
    edge (stage 3); all distances agree with BRepExtrema to 1e-9 mm, signs with the side."""
    for cad in (ctc01, ftc06):
        s = cad.sample(None, 250, seed=3)
        P = s.points + np.random.default_rng(3).normal(0, 2.0, (s.n_points, 3))
        d, q, _ = cad.distance(P)
        assert cad.distance_engine.n_exact > 0
        ref, _ = brepextrema(faces_of(cad), P)
        np.testing.assert_allclose(np.abs(d), ref, atol=1e-9, rtol=0)
        # the sign: outside the material where the point is outside the closed solid (ray parity)
        md = cad.distance_engine.md
        sure = np.abs(d) > 0.05
        assert np.all(np.sign(d[sure]) == np.sign(md.signed_distance(P[sure])))


def test_a_bore_seen_from_the_material_is_found_although_its_chords_are_farther(tmp_path):
    """A plate with a bore, tessellated coarsely (50 µm): points in the material 0.1 mm below
    the top face and 0.098 mm from the bore's wall. The wall's chords lie in the hole, up to
    the deflection farther than the wall, so the mesh names the top face; the wall is nearer
    and must win (found as a face across the top face's boundary)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    from camcmm.cad.write import write_step

    plate = BRepPrimAPI_MakeBox(gp_Pnt(-10, -10, -5), 20.0, 20.0, 5.0).Shape()
    bore = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(0, 0, -6), gp_Dir(0, 0, 1)), 3.0, 7.0).Shape()
    write_step(BRepAlgoAPI_Cut(plate, bore).Shape(), tmp_path / "plate.step")
    cad = read_cad(tmp_path / "plate.step", deflection=0.05)
    phi = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    P = np.column_stack([3.098 * np.cos(phi), 3.098 * np.sin(phi), np.full_like(phi, -0.1)])
    d, _, face = cad.distance(P)
    np.testing.assert_allclose(d, -0.098, atol=1e-12)  # inside the material, 98 µm from the wall
    assert {cad.faces[k - 1].type for k in face} == {"cylinder"}
    mesh = MeshDistance(cad.mesh).signed_distance(P)
    assert np.abs(mesh - d).max() > 1e-3  # the tessellation alone is off


def test_a_cloud_sampled_from_ctc01_is_compared_with_no_facet_bias(ctc01):
    """3000 points on the exact surface: |deviation| < 0.1 µm through inspect.deviations with
    the CAD nominal, while the tessellation alone gives a mean |deviation| of tenths of a µm."""
    from camcmm.api import get_algorithm

    s = ctc01.sample(None, 3000, seed=11)
    out = get_algorithm("inspect.deviations")(cloud=s, nominal=ctc01, coverage_samples=1000)
    dev = out["deviations"].fields["deviation"]
    assert np.abs(dev).max() < 1e-7
    assert np.all(out["deviations"].fields["cad_face"] == s.fields["face"])
    assert out["nominal_info"]["kind"] == "cad" and out["nominal_info"]["chordal_error"] == 0.0
    mesh_dev = MeshDistance(ctc01.mesh).signed_distance(s.points)
    assert np.abs(mesh_dev).mean() > 1e-4  # the facet error the exact surface removes


# ------------------------------------------------------------------------------ units, formats, pickling
def _box(size: float):
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    return BRepPrimAPI_MakeBox(size, size / 2, size / 4).Shape()


def test_a_step_in_metres_and_an_iges_come_back_in_mm(tmp_path):
    from OCP.IGESControl import IGESControl_Writer
    from OCP.Interface import Interface_Static

    from camcmm.cad.write import write_step

    Interface_Static.SetCVal_s("write.step.unit", "M")
    try:
        from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

        w = STEPControl_Writer()
        w.Transfer(_box(40.0), STEPControl_AsIs)  # 40 mm, written as 0.04 m
        w.Write(str(tmp_path / "box_m.step"))
    finally:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
    cad = read_cad(tmp_path / "box_m.step")
    assert cad.source_unit == "m" and [f.type for f in cad.faces] == ["plane"] * 6
    np.testing.assert_allclose(cad.bounds[1] - cad.bounds[0], [40.0, 20.0, 10.0], atol=1e-6)
    ig = IGESControl_Writer("MM", 0)
    ig.AddShape(_box(40.0))
    ig.Write(str(tmp_path / "box.igs"))
    cad = read_cad(tmp_path / "box.igs")
    assert cad.format == "IGES" and cad.source_unit == "mm" and cad.n_faces == 6
    np.testing.assert_allclose(cad.bounds[1] - cad.bounds[0], [40.0, 20.0, 10.0], atol=1e-6)
    d, _, _ = cad.distance(np.array([[20.0, 10.0, 15.0], [20.0, 10.0, 5.0]]))
    np.testing.assert_allclose(d, [5.0, -5.0], atol=1e-12)  # above the top face; inside, 5 mm below it
    write_step(_box(40.0), tmp_path / "box.step")  # the writer camcmm uses (demo), in mm
    assert read_cad(tmp_path / "box.step").source_unit == "mm"


def test_a_bspline_face_is_measured_by_opencascade(tmp_path):
    """A sphere converted to NURBS (rational: still exactly the sphere): no closed form; the
    feet by OpenCascade's Newton projection from the closest triangle's (u, v), checked
    against the sphere (1 mm noise: some go on to OpenCascade); samples on the surface at
    their (u, v)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    from OCP.gp import gp_Pnt

    from camcmm.cad.write import write_step

    ball = BRepPrimAPI_MakeSphere(gp_Pnt(1.0, 2.0, 3.0), 5.0).Shape()
    write_step(BRepBuilderAPI_NurbsConvert(ball, True).Shape(), tmp_path / "nurbs.step")
    cad = read_cad(tmp_path / "nurbs.step")
    assert [f.type for f in cad.faces] == ["bspline"] and cad.faces[0].params == {}
    s = cad.sample(1, 30, seed=2)
    np.testing.assert_allclose(np.linalg.norm(s.points - [1, 2, 3], axis=1), 5.0, atol=1e-7)
    P = s.points + np.random.default_rng(2).uniform(-0.3, 0.3, (30, 1)) * s.normals
    d, _, _ = cad.distance(P)
    np.testing.assert_allclose(d, np.linalg.norm(P - [1, 2, 3], axis=1) - 5.0, atol=1e-9)
    assert cad.distance_engine.n_exact < 3  # the Newton feet held, not OpenCascade's global search
    far = s.points + np.random.default_rng(4).normal(0, 1.0, (30, 3))
    d, _, _ = cad.distance(far)
    np.testing.assert_allclose(d, np.linalg.norm(far - [1, 2, 3], axis=1) - 5.0, atol=1e-9)


def test_a_model_pickles_as_its_file_and_hashes_as_it(ctc01):
    again = pickle.loads(pickle.dumps(ctc01))
    assert again.n_faces == 117 and again.sha256 == ctc01.sha256
    assert object_hash(again) == object_hash(ctc01)


# ------------------------------------------------------------------------------ refusals
@pytest.mark.parametrize(
    "name, data, words",
    [
        ("part.step", b"solid cube\n facet normal 0 0 1\n", "not a STEP file"),
        ("part.stp", b"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\nENDSEC;\nEND-ISO-10303-21;\n", "no shape"),
        ("part.iges", b"this is not an IGES file at all\n", "not an IGES file"),
        ("part.step", b"", "empty"),
        ("part.step", b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('x'),'2;1');\nDATA;\n#1=FOO(;\n", "part.step"),
    ],
)
def test_refusals_are_one_line_naming_the_file(tmp_path, name, data, words):
    path = tmp_path / name
    path.write_bytes(data)
    for reader in (read_cad, cio.read):
        with pytest.raises(InputError) as exc:
            reader(path)
        msg = str(exc.value)
        assert msg.startswith(name) and "\n" not in msg and words in msg, msg


def test_a_model_is_not_written_as_a_mesh(ctc01, tmp_path):
    with pytest.raises(InputError, match="x.ply: camcmm does not write CAD models"):
        cio.write(ctc01, tmp_path / "x.ply")


def test_a_face_that_is_not_there_is_refused(ctc01):
    with pytest.raises(InputError, match="no face 118; faces are numbered 1 to 117"):
        ctc01.face(118)
    with pytest.raises(InputError, match="at least one point"):
        ctc01.sample(3, 0)


# ------------------------------------------------------------------------------ the command
def test_camcmm_inspect_takes_a_step_nominal(tmp_path, capsys):
    """``camcmm inspect scan.ply --nominal ball.step``: a cap of a 10 mm ball (no noise) moved
    by 0.2 mm is aligned on the exact surface to |deviation| < 1 nm (on the tessellation's
    chords ICP would leave µm); the same cap 3 µm outside, not moved and not aligned, shows
    every deviation as the 3 µm (no facet bias)."""
    from camcmm.api import PointCloud, write
    from camcmm.cad.write import sphere_step
    from helpers.cli import main_json

    sphere_step(tmp_path / "ball.step", 10.0)
    rng = np.random.default_rng(5)
    u = rng.uniform(-0.3, 1.0, 4000)
    phi = rng.uniform(0, 2 * np.pi, 4000)
    dirs = np.column_stack([np.sqrt(1 - u**2) * np.cos(phi), np.sqrt(1 - u**2) * np.sin(phi), u])
    write(PointCloud(dirs * 10.0 + [0.2, -0.1, 0.15]), tmp_path / "moved.ply")
    write(PointCloud(dirs * 10.003), tmp_path / "big.ply")
    ball = tmp_path / "ball.step"
    doc = main_json(capsys, "inspect", tmp_path / "moved.ply", "--nominal", ball, "--tolerance", "0.01", "--json")
    assert doc["converged"] and doc["nominal_info"]["kind"] == "cad" and doc["nominal_info"]["chordal_error"] == 0.0
    assert doc["stats"]["max_abs"] < 1e-6, doc["stats"]
    assert "exact B-rep surface" in doc["distance_method"]
    doc = main_json(capsys, "inspect", tmp_path / "big.ply", "--nominal", ball, "--align", "none", "--json")
    assert abs(doc["stats"]["min"] - 0.003) < 1e-9 and abs(doc["stats"]["max"] - 0.003) < 1e-9
