"""Light-field scale inputs (thesis ch. 6.3): photogrammetric depth maps with the z-buffer
(eqs. 6.2-6.4, fig. 6.14) on exact-by-construction clouds, and Lytro 16-bit lambda maps
(eq. 6.5) with their sidecars and one-line refusals."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.lightfield import depthmap, gradient, lytro

W, H = 64, 48
K = np.array([[100.0, 0, (W - 1) / 2], [0, 100.0, (H - 1) / 2], [0, 0, 1]])
NO_DIST = np.zeros(5)


def grid_plane(z: float, n: int = 4, half: float = 20.0) -> np.ndarray:
    """A camera-facing square at depth z, ``n`` × ``n`` samples per pixel footprint (dense)."""
    step = z / K[0, 0] / n
    x = np.arange(-half, half, step)
    X, Y = np.meshgrid(x, x)
    return np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])


def test_projection_and_depth_of_a_known_point():
    R, t = np.eye(3), np.array([0.0, 0.0, 0.0])
    uv, d, front = depthmap.project(np.array([[3.0, -4.0, 100.0], [0, 0, -5.0]]), K, NO_DIST, R, t)
    assert front.tolist() == [True, False]
    assert uv[0] == pytest.approx([K[0, 2] + 3.0, K[1, 2] - 4.0])
    assert d[0] == pytest.approx(np.sqrt(9 + 16 + 100**2))  # eq. 6.3
    _, dz, _ = depthmap.project(np.array([[3.0, -4.0, 100.0]]), K, NO_DIST, R, t, measure="z")
    assert dz[0] == 100.0


def test_zbuffer_keeps_the_front_surface_and_a_region_is_not_shadowed():
    front = grid_plane(100.0, half=5.0)  # covers the image's centre only
    rear = grid_plane(150.0, half=60.0)  # the far side: behind the front everywhere
    pts = np.vstack([front, rear])
    R, t = np.eye(3), np.zeros(3)
    depth, count = depthmap.depth_map(pts, K, NO_DIST, R, t, (W, H), measure="z", edge=0)
    c = depth[H // 2, W // 2]
    assert c == pytest.approx(100.0, abs=1e-9)  # not the rear's 150, nor a mix
    assert depth[2, 2] == pytest.approx(150.0, abs=1e-9)
    # without the z-buffer (everything within 100 % of the nearest kept) the centre mixes both surfaces
    mixed, _ = depthmap.depth_map(pts, K, NO_DIST, R, t, (W, H), measure="z", tolerance=1.0, edge=0)
    assert 101.0 < mixed[H // 2, W // 2] < 149.0
    # keep only the rear plane: the front's pixels become empty, not the rear's depth leaking through
    keep = np.r_[np.zeros(len(front), bool), np.ones(len(rear), bool)]
    dk, _ = depthmap.depth_map(pts, K, NO_DIST, R, t, (W, H), measure="z", keep=keep, edge=0)
    assert np.isnan(dk[H // 2, W // 2]) and dk[2, 2] == pytest.approx(150.0)


def test_edge_pixels_of_the_coverage_are_dropped():
    pts = grid_plane(100.0, half=5.0)
    d0, _ = depthmap.depth_map(pts, K, NO_DIST, np.eye(3), np.zeros(3), (W, H), edge=0)
    d1, _ = depthmap.depth_map(pts, K, NO_DIST, np.eye(3), np.zeros(3), (W, H), edge=1)
    n0, n1 = np.isfinite(d0).sum(), np.isfinite(d1).sum()
    side = int(np.sqrt(n0))
    assert side * side == n0 and n1 == (side - 2) ** 2


def test_distortion_is_opencvs():
    rng = np.random.default_rng(0)
    P = rng.uniform([-20, -15, 80], [20, 15, 120], size=(200, 3))
    dist = np.array([-0.1, 0.02, 0.001, -0.0005, 0.0])
    R = cv2.Rodrigues(np.array([0.05, -0.1, 0.02]))[0]
    t = np.array([1.0, -2.0, 5.0])
    uv, _, _ = depthmap.project(P, K, dist, R, t)
    ref, _ = cv2.projectPoints(P, cv2.Rodrigues(R)[0], t, K, dist)
    assert uv == pytest.approx(ref.reshape(-1, 2), abs=1e-9)
    Kc, dc = depthmap.camera_matrix({"fx": 100, "fy": 100, "cx": 1, "cy": 2, "dist": [-0.1]})
    assert dc.tolist() == [-0.1, 0, 0, 0]


def test_eq_6_5_and_the_absolute_convention(tmp_path):
    raw = np.array([[0, 16384, 32768, 65535]], np.uint16)
    p = tmp_path / "v1.png"
    cv2.imwrite(str(p), raw)
    (tmp_path / "v1.json").write_text(json.dumps({"depth": {"minLambda": -4.0, "maxLambda": 12.0}}))
    m = lytro.read_lambda_map(p)
    # eq. 6.5 as printed: I / 2^16 (lambda_max - lambda_min), lambda_min not added
    assert m["lam"][0].tolist() == pytest.approx([0.0, 4.0, 8.0, 65535 / 65536 * 16])
    assert m["lam_abs"][0].tolist() == pytest.approx([-4.0, 0.0, 4.0, 65535 / 65536 * 16 - 4])
    assert m["source"].endswith("v1.json")
    g = lytro.read_lambda_map(p, (0.0, 1.0), convention="absolute")
    assert g["lam"][0][2] == pytest.approx(0.5) and g["source"] == "given"
    assert lytro.from_lambda(m["lam_abs"], -4.0, 12.0).tolist() == raw.tolist()


def test_bad_maps_are_refused_in_one_line_naming_the_file(tmp_path):
    p8 = tmp_path / "v8.png"
    cv2.imwrite(str(p8), np.zeros((4, 4), np.uint8))
    with pytest.raises(InputError, match=r"v8\.png: a 8-bit uint8 image; a Lytro depth map is 16-bit"):
        lytro.read_lambda_map(p8, (0, 1))
    p16 = tmp_path / "v16.png"
    cv2.imwrite(str(p16), np.zeros((4, 4), np.uint16))
    with pytest.raises(InputError, match=r"v16\.png: no lambda_min, lambda_max: give --lambda-range"):
        lytro.read_lambda_map(p16)
    (tmp_path / "v16.json").write_text(json.dumps({"lambda_min": 1.0}))
    with pytest.raises(InputError, match=r"v16\.json: no lambda_min/lambda_max"):
        lytro.read_lambda_map(p16)
    with pytest.raises(InputError, match="MAX must be above MIN"):
        lytro.parse_range("3,1")
    with pytest.raises(InputError, match=r"nothing\.png: no such depth-map file"):
        lytro.read_lambda_map(tmp_path / "nothing.png", (0, 1))
    cam = {"fx": 100.0, "fy": 100.0, "cx": 31.5, "cy": 23.5, "dist": [], "width": 64, "height": 48}
    with pytest.raises(InputError, match=r"v16\.png: 50 x 48 px does not match the view's camera \(64 x 48 px\)"):
        gradient.view_camera(cam, (50, 48), str(p16))
    Ks, _ = gradient.view_camera(cam, (32, 24), "half.png")  # a map half the images' size: K halved
    assert Ks[0, 0] == 50.0 and Ks[0, 2] == pytest.approx(15.5)


def test_views_from_a_reconstruction_json(tmp_path):
    doc = {
        "camera": {"model": "PINHOLE", "fx": 100, "fy": 100, "cx": 31.5, "cy": 23.5, "dist": []},
        "image_size": [64, 48],
        "views": [{"image": "a/IMG_1.JPG", "R": np.eye(3).tolist(), "t": [0, 0, 0]}],
    }
    f = tmp_path / "rec.json"
    f.write_text(json.dumps(doc))
    v = gradient.load_views(str(f))
    assert v["views"][0]["camera"]["width"] == 64
    (tmp_path / "IMG_1_depth.tif").write_bytes(b"")
    assert lytro.find_map(tmp_path, "a/IMG_1.JPG").name == "IMG_1_depth.tif"
    f.write_text(json.dumps({"views": []}))
    with pytest.raises(InputError, match=r"rec\.json: no 'views'"):
        gradient.load_views(str(f))


def test_polygon_region():
    m = depthmap.polygon_mask([[10, 5], [29, 5], [29, 14], [10, 14]], (W, H))
    assert m.shape == (H, W) and m.sum() == 20 * 10 and m[5, 10] and not m[4, 10]
    with pytest.raises(InputError, match="at least three"):
        depthmap.polygon_mask([[0, 0], [1, 1]], (W, H))
    from camcmm_plugins.lightfield.plugin import _polygon

    with pytest.raises(InputError, match=r"polygon '\[\[1,2\]': give JSON"):
        _polygon("[[1,2]")


def test_tiff_maps_and_a_flat_lambda_view(tmp_path):
    from camcmm_plugins.lightfield import fit

    p = tmp_path / "v.tif"
    cv2.imwrite(str(p), np.full((3, 5), 32768, np.uint16))
    m = lytro.read_lambda_map(p, (-2.0, 2.0))
    assert m["lam"].shape == (3, 5) and np.all(m["lam"] == 2.0) and np.all(m["lam_abs"] == 0.0)
    with pytest.raises(InputError, match="lambda is the same"):
        fit.fit_view(np.full((3, 5), 300.0), m["lam"], min_pixels=3)
