"""Import of reconstructions made elsewhere (issue 16): COLMAP text and binary models and
Agisoft Metashape / PhotoScan exports.

References nobody here wrote: pycolmap (COLMAP's own reader, writer and projection) for
the COLMAP models; OpenCV's projectPoints against Metashape's published camera model
(user manual, "Camera models") for the Metashape conventions. The fixtures'
expectations are derived by hand (quaternions and transforms chosen so that R is exact).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from camcmm.api import InputError, default_host
from camcmm_plugins.photogrammetry.imports import read_reconstruction

DATA = Path(__file__).resolve().parents[1] / "data" / "photogrammetry"


def _views(r):
    return {v["image"]: v for v in r["views"]}


def test_colmap_text_fixture_by_hand():
    r = read_reconstruction(DATA / "colmap_text")
    assert r["source"]["format"] == "colmap-text"
    assert (r["n_points"], len(r["views"]), len(r["cameras"])) == (3, 3, 2)
    v = _views(r)
    # q = 1: identity; q = (cos 45, 0, sin 45, 0): 90 deg about y; q = (.5, .5, .5, .5): the cyclic permutation
    np.testing.assert_allclose(v["view_01.png"]["centre"], [0, 0, -10], atol=1e-12)
    np.testing.assert_allclose(v["view_02.png"]["centre"], [10, 0, 0], atol=1e-12)
    np.testing.assert_allclose(v["view_02.png"]["R"], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-12)
    np.testing.assert_array_equal(v["view_03.png"]["R"], [[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_allclose(v["view_03.png"]["centre"], [-2, -3, -1], atol=1e-12)
    assert v["view_03.png"]["camera"] == 1
    cam1, cam2 = r["cameras"]
    # COLMAP's principal point 320.5 (pixel centres at +0.5) is OpenCV's 320
    assert (cam1["fx"], cam1["fy"], cam1["cx"], cam1["cy"]) == (500, 505, 320, 240)
    assert (cam1["width"], cam1["height"]) == (640, 480)
    assert cam2["dist"][:4] == [0.01, -0.002, 0.0005, -0.0003]
    cloud = r["cloud"]
    np.testing.assert_array_equal(cloud.colors[2], [0, 128, 255])
    np.testing.assert_array_equal(cloud.points[2], [-1.5, 2.25, 4])
    np.testing.assert_array_equal(cloud.fields["reprojection_error"], [0.5, 0.25, 1.0])
    assert any("arbitrary scale" in w for w in r["warnings"])


def test_colmap_binary_fixture_equals_text():
    """The committed binary model (written by pycolmap from the text one), read by
    pycolmap, agrees with the hand reader on the text."""
    t, b = read_reconstruction(DATA / "colmap_binary"), read_reconstruction(DATA / "colmap_text")
    assert t["source"]["format"] == "colmap-binary"
    assert t["cameras"] == b["cameras"]
    for vt, vb in zip(sorted(t["views"], key=lambda v: v["image"]), b["views"], strict=True):
        assert vt["image"] == vb["image"]
        np.testing.assert_allclose(vt["R"], vb["R"], atol=1e-15)
        np.testing.assert_allclose(vt["centre"], vb["centre"], atol=1e-13)
    np.testing.assert_array_equal(t["cloud"].points, b["cloud"].points)
    np.testing.assert_array_equal(t["cloud"].colors, b["cloud"].colors)


def _pycolmap_model(rng):
    pycolmap = pytest.importorskip("pycolmap")
    rec = pycolmap.Reconstruction()
    cams = [
        ("SIMPLE_RADIAL", 640, 480, [520.0, 321.25, 239.75, -0.08]),
        ("FULL_OPENCV", 800, 600, [610.0, 612.0, 401.5, 298.5, -0.1, 0.03, 0.001, -0.002, 0.004, 0.01, -0.005, 0.002]),
    ]
    for cid, (model, w, h, params) in enumerate(cams, 1):
        cam = pycolmap.Camera.create_from_model_name(cid, model, 500.0, w, h)
        cam.params = params
        rec.add_camera_with_trivial_rig(cam)
    for iid in range(1, 4):
        q = rng.normal(size=4)
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(q / np.linalg.norm(q)), rng.normal(size=3) + [0, 0, 8])
        rec.add_image_with_trivial_frame(
            pycolmap.Image(name=f"img{iid}.jpg", camera_id=1 + iid % 2, image_id=iid), pose
        )
    for _ in range(5):
        rec.add_point3D(rng.normal(size=3), pycolmap.Track(), rng.integers(0, 256, 3).astype(np.uint8))
    return rec


@pytest.mark.parametrize("kind", ["text", "binary"])
def test_pycolmap_written_model_and_projection(tmp_path, kind):
    """A model written by pycolmap: poses, centres and colours as pycolmap has them, and
    each camera projects a point with OpenCV (our K, dist) where COLMAP does, 0.5 px apart."""
    rec = _pycolmap_model(np.random.default_rng(3))
    getattr(rec, f"write_{kind}")(str(tmp_path))
    r = read_reconstruction(tmp_path)
    assert r["source"]["format"] == f"colmap-{kind}"
    assert r["n_points"] == 5 and len(r["views"]) == 3
    v = _views(r)
    X = np.array([[0.3, -0.2, 0.5], [-0.4, 0.1, -0.3]])
    for im in rec.images.values():
        mine = v[im.name]
        pose = im.cam_from_world()
        np.testing.assert_allclose(mine["R"], pose.rotation.matrix(), atol=1e-12)
        np.testing.assert_allclose(mine["centre"], im.projection_center(), atol=1e-12)
        cam = r["cameras"][mine["camera"]]
        K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1]])
        rvec = cv2.Rodrigues(np.asarray(mine["R"]))[0]
        ours = cv2.projectPoints(X, rvec, np.asarray(mine["t"]), K, np.asarray(cam["dist"]))[0].reshape(-1, 2)
        colmap = np.array([im.project_point(x) for x in X])
        np.testing.assert_allclose(ours + 0.5, colmap, atol=1e-6)
    ids = sorted(rec.points3D)
    np.testing.assert_array_equal(r["cloud"].colors, [rec.points3D[i].color for i in ids])
    np.testing.assert_allclose(r["cloud"].points, [rec.points3D[i].xyz for i in ids], atol=1e-12)


def test_colmap_sparse_0_layout(tmp_path):
    shutil.copytree(DATA / "colmap_text", tmp_path / "project" / "sparse" / "0")
    assert read_reconstruction(tmp_path / "project")["n_points"] == 3
    assert read_reconstruction(tmp_path / "project" / "sparse" / "0" / "points3D.txt")["n_points"] == 3


def _metashape_project(X, f, cx, cy, b1, b2, k, p, w, h):
    """Metashape's frame camera model (user manual, appendix "Camera models"): pixel
    coordinates from the image's top-left corner."""
    x, y = X[:, 0] / X[:, 2], X[:, 1] / X[:, 2]
    r2 = x * x + y * y
    rad = 1 + k[0] * r2 + k[1] * r2**2 + k[2] * r2**3
    xd = x * rad + p[0] * (r2 + 2 * x * x) + 2 * p[1] * x * y
    yd = y * rad + p[1] * (r2 + 2 * y * y) + 2 * p[0] * x * y
    return np.c_[w * 0.5 + cx + xd * f + xd * b1 + yd * b2, h * 0.5 + cy + yd * f]


def test_metashape_export():
    r = read_reconstruction(DATA / "metashape" / "points.txt")
    assert r["source"]["format"] == "metashape" and r["n_points"] == 4
    cloud = r["cloud"]
    np.testing.assert_array_equal(cloud.colors[1], [12, 34, 56])
    np.testing.assert_array_equal(cloud.normals[1], [0.6, 0.8, 0])
    cam = r["camera"]
    # f 7000, b1 0.5, cx 12.5 / cy -8.25 from the centre of 6000 x 4000, less OpenCV's half pixel
    assert (cam["fx"], cam["fy"], cam["cx"], cam["cy"]) == (7000.5, 7000, 3012, 1991.25)
    # Metashape's P1 = 1e-4 is OpenCV's p2, P2 = -2e-4 is OpenCV's p1
    assert cam["dist"] == [-0.05, 0.1, -0.0002, 0.0001, -0.01]
    # camera 2 is not aligned (no transform): left out
    assert [v["image"] for v in r["views"]] == ["DSC_0001", "DSC_0002"]
    v = _views(r)
    # chunk: X = 2 Rz(90) X_chunk + (100, 200, 300); camera centres (0, 0, -5) and (-5, 0, 0) in the chunk
    np.testing.assert_allclose(v["DSC_0001"]["centre"], [100, 200, 290], atol=1e-12)
    np.testing.assert_allclose(v["DSC_0002"]["centre"], [100, 190, 300], atol=1e-12)
    assert any("chunk transform sets a scale" in w for w in r["warnings"])


def test_metashape_conventions_exact_by_construction():
    """A chunk point seen by each camera: through the camera XML's own chain (inverse of
    the camera-to-chunk transform, Metashape's projection) and through the import
    (world point, x = R X + t, OpenCV projection): the same pixel, 0.5 px apart."""
    import xml.etree.ElementTree as ET

    r = read_reconstruction(DATA / "metashape" / "cameras.xml")
    assert r["n_points"] == 0 and any("cameras only" in w for w in r["warnings"])
    chunk = ET.parse(DATA / "metashape" / "cameras.xml").getroot().find("chunk")
    Rc = np.array(chunk.find("transform/rotation").text.split(), float).reshape(3, 3)
    Tc = np.array(chunk.find("transform/translation").text.split(), float)
    s = float(chunk.find("transform/scale").text)
    cam = r["camera"]
    K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1]])
    Xc = np.array([[0.3, -0.2, 4.0], [4.0, 0.5, 0.25], [-0.1, 0.2, 1.0]])  # chunk points
    for el in chunk.iter("camera"):
        if el.find("transform") is None:
            continue
        M = np.array(el.find("transform").text.split(), float).reshape(4, 4)
        xcam = (np.linalg.inv(M) @ np.c_[Xc, np.ones(3)].T).T[:, :3]
        front = xcam[:, 2] > 0
        ref = _metashape_project(xcam[front], 7000, 12.5, -8.25, 0.5, 0, (-0.05, 0.1, -0.01), (1e-4, -2e-4), 6000, 4000)
        v = _views(r)[el.get("label")]
        Xw = s * Xc @ Rc.T + Tc
        mine = Xw @ np.asarray(v["R"]).T + v["t"]
        np.testing.assert_allclose(mine, s * xcam, atol=1e-12)  # a rotation of the scaled frame
        rvec = cv2.Rodrigues(np.asarray(v["R"]))[0]
        px = cv2.projectPoints(Xw[front], rvec, np.asarray(v["t"]), K, np.asarray(cam["dist"]))[0].reshape(-1, 2)
        np.testing.assert_allclose(px + 0.5, ref, atol=1e-6)


def test_delimited_clouds(tmp_path):
    r = read_reconstruction(DATA / "points_tab.xyz")
    assert r["n_points"] == 3 and r["cameras"] == [] and r["cloud"].normals is None
    np.testing.assert_array_equal(r["cloud"].colors[0], [255, 128, 0])
    p = tmp_path / "c.csv"
    p.write_text("x,y,z,intensity\n1,2,3,0.5\n4,5,6,0.25\n")
    r = read_reconstruction(p)
    assert r["cloud"].colors is None and r["n_points"] == 2
    np.testing.assert_array_equal(r["cloud"].fields["intensity"], [0.5, 0.25])


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("points3D.txt", "1 0 0 0 255 0 0 0.5 1 0\n2 1 2 x 10 20 30 0.25\n", "points3D.txt: line 2"),
        ("points3D.txt", "1 0 0 0 300 0 0 0.5\n", "points3D.txt: line 1"),
        ("cameras.txt", "1 PINHOLE 640 480 500 505 320.5\n", "cameras.txt: line 1: PINHOLE has 4 parameters"),
        ("cameras.txt", "1 WEIRD 640 480 500\n", "unknown camera model 'WEIRD'"),
        ("images.txt", "1 1 0 0 0 0 0 10 9 a.png\n\n", "names camera 9"),
        ("images.txt", "1 1 0 0 0 0 0 ten 1 a.png\n\n", "images.txt: line 1"),
    ],
)
def test_bad_colmap_files(tmp_path, name, text, message):
    shutil.copytree(DATA / "colmap_text", tmp_path / "m")
    (tmp_path / "m" / name).write_text(text)
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        read_reconstruction(tmp_path / "m")


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("a.txt", "1 2 3 4 5 6\n1 2 3\n", r"a.txt line 2: expected 6 numeric columns"),
        ("a.txt", "1 2\n", r"a.txt line 1: expected 3 or more numeric columns"),
        ("a.txt", "x y z\n1 2 3\nfoo 2 3\n", r"a.txt line 3: expected 3 numeric columns"),
        ("a.xml", "<document><nochunk/></document>", r"a.xml: no <chunk>"),
        (
            "a.xml",
            "<document><chunk><cameras><camera id='0' sensor_id='0' label='A'><transform>1 0 0</transform>"
            "</camera></cameras></chunk></document>",
            r"a.xml: camera 'A' names sensor '0', which is absent",
        ),
        (
            "a.xml",
            "<document><chunk><sensors><sensor id='0'><calibration><resolution width='9' height='9'/><f>5</f>"
            "</calibration></sensor></sensors><cameras><camera id='0' sensor_id='0' label='A'>"
            "<transform>1 0 0</transform></camera></cameras></chunk></document>",
            r"a.xml: camera 'A' <transform>: expected 16 numbers",
        ),
        ("a.xml", "<document><chunk", r"a.xml: not a readable camera XML"),
        ("a.las", "las", r"a.las: not a COLMAP model or Metashape export"),
        ("a.ply", "ply", r"a.ply"),
    ],
)
def test_bad_exports(tmp_path, name, text, message):
    (tmp_path / name).write_text(text)
    with pytest.raises(InputError, match=message):
        read_reconstruction(tmp_path / name)


def test_missing_and_empty(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_reconstruction(tmp_path / "nothing")
    with pytest.raises(InputError, match="not a COLMAP model folder"):
        read_reconstruction(tmp_path)


def test_plugin_entry():
    out = default_host().run("photogrammetry.import", {"path": str(DATA / "colmap_binary")}, {})
    assert out.outputs["cloud"].n_points == 3
    assert out.outputs["reconstruction"]["n_views"] == 3
    assert any("arbitrary scale" in w for w in out.warnings)


def test_ply_cloud_with_its_camera_xml(tmp_path):
    from camcmm.api import PointCloud, write

    shutil.copy(DATA / "metashape" / "cameras.xml", tmp_path / "scan.xml")
    pts = np.array([[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]])
    write(PointCloud(pts, np.array([[1, 2, 3], [4, 5, 6]], np.uint8)), tmp_path / "scan.ply")
    r = read_reconstruction(tmp_path / "scan.ply")
    assert r["n_points"] == 2 and len(r["views"]) == 2
    np.testing.assert_array_equal(r["cloud"].colors[1], [4, 5, 6])
    r = read_reconstruction(tmp_path / "scan.xml")  # the cloud of the same name comes along
    assert r["n_points"] == 2


def test_metashape_components_and_adjusted_calibration():
    """Metashape 1.6+ writes the transform per component and may keep the initial
    calibration before the adjusted one: the same cameras and views as the chunk-style file."""
    new = read_reconstruction(DATA / "metashape_v2" / "cameras.xml")
    old = read_reconstruction(DATA / "metashape" / "cameras.xml")
    assert new["cameras"] == old["cameras"]
    assert new["views"] == old["views"]
    assert any("chunk transform sets a scale" in w for w in new["warnings"])


def test_colmap_dense_workspace(tmp_path):
    """dense/0 of a COLMAP workspace: the cameras from dense/0/sparse, the cloud from fused.ply."""
    from camcmm.api import PointCloud, write

    ws = tmp_path / "dense" / "0"
    shutil.copytree(DATA / "colmap_binary", ws / "sparse")
    write(PointCloud(np.arange(12.0).reshape(4, 3)), ws / "fused.ply")
    for path in (ws, ws / "sparse"):
        r = read_reconstruction(path)
        assert (r["n_points"], r["n_points_sparse"], len(r["views"])) == (4, 3, 3)
        assert r["source"]["cloud"] == str(ws / "fused.ply")
        np.testing.assert_array_equal(r["cloud"].points[3], [9, 10, 11])
