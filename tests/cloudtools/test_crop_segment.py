"""Crop and segment plugins against exact-by-construction cases: an integer grid 0..9 mm
on each axis (1000 points), so every box, plane and polygon has a count known by hand,
and every boundary that could be a tie is either a stated rule (faces included, the plane
included) or kept half a millimetre away from the points."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.errors import GeometryError, ParameterError
from camcmm.host import default_host
from camcmm.model import PointCloud

GRID = np.stack(np.meshgrid(*[np.arange(10.0)] * 3, indexing="ij"), -1).reshape(-1, 3)


def grid_cloud() -> PointCloud:
    """The grid with an id field, colours and normals all derived from the point's index,
    so a subset that mixed them up would show."""
    n = len(GRID)
    ids = np.arange(n)
    colors = np.column_stack([ids % 256, (ids // 256) % 256, np.full(n, 7)]).astype(np.uint8)
    normals = np.column_stack([np.cos(ids), np.sin(ids), np.zeros(n)])
    return PointCloud(GRID.copy(), colors, normals, {"id": ids.astype(float)}, {"id": ""}, name="grid")


def run(pid, cloud=None, **params):
    res = default_host().run(pid, {"cloud": grid_cloud() if cloud is None else cloud}, params)
    return res.outputs, res.warnings


def consistent(out: PointCloud) -> np.ndarray:
    """The kept ids, after checking that each kept point carries its own colour, normal and coordinates."""
    ids = out.fields["id"].astype(int)
    np.testing.assert_array_equal(out.points, GRID[ids])
    np.testing.assert_array_equal(out.colors[:, 0], ids % 256)
    np.testing.assert_array_equal(out.normals[:, 1], np.sin(ids))
    return ids


def test_box_by_corners_keeps_the_faces_and_counts_exactly():
    o, w = run("crop.box", min=[2, 2, 2], max=[5, 5, 5])
    ids = consistent(o["cloud"])
    assert o["n_kept"] == 4**3 == len(ids) and o["n_removed"] == 1000 - 64 and not w
    assert o["cloud"].name == "grid · cropped (box)"
    o, _ = run("crop.box", min=[2, 2, 2], max=[5, 5, 5], keep="outside")
    assert o["n_kept"] == 936 and set(consistent(o["cloud"])).isdisjoint(ids)
    # a slab one point thick: x = 3 only
    assert run("crop.box", min=[3, -1, -1], max=[3, 10, 10])[0]["n_kept"] == 100


def test_a_rotated_box_turns_its_own_axes():
    # size along the box's own x 6 (|q| <= 3), y 2.8 (|q| <= 1.4), z 4 (|q| <= 2), centre at
    # half-integers: no grid point on a face. Turned 90 deg about z, its x lies along world y.
    o, _ = run("crop.box", centre=[4.5, 4.5, 4.5], size=[6, 2.8, 4], rotation=[0, 0, 90])
    ids = consistent(o["cloud"])
    p = GRID[ids]
    want = (np.abs(GRID[:, 1] - 4.5) <= 3) & (np.abs(GRID[:, 0] - 4.5) <= 1.4) & (np.abs(GRID[:, 2] - 4.5) <= 2)
    assert o["n_kept"] == 6 * 2 * 4 == want.sum() and set(ids) == set(np.flatnonzero(want))
    assert np.ptp(p[:, 0]) == 1 and np.ptp(p[:, 1]) == 5
    # unturned, the same box is long in x
    assert run("crop.box", centre=[4.5, 4.5, 4.5], size=[6, 2.8, 4])[0]["n_kept"] == 48


def test_box_refusals_name_the_parameter():
    with pytest.raises(ParameterError, match="'max'.*below 'min'.* in y"):
        run("crop.box", min=[0, 5, 0], max=[9, 4, 9])
    with pytest.raises(ParameterError, match="'max' is needed"):
        run("crop.box", min=[0, 0, 0])
    with pytest.raises(ParameterError, match="not both"):
        run("crop.box", min=[0, 0, 0], max=[1, 1, 1], centre=[0, 0, 0], size=[1, 1, 1])
    with pytest.raises(ParameterError, match="give the box"):
        run("crop.box")
    with pytest.raises(GeometryError, match="keeps none of its 1000 points"):
        run("crop.box", min=[20, 20, 20], max=[30, 30, 30])
    o, w = run("crop.box", min=[-1, -1, -1], max=[10, 10, 10])
    assert o["n_removed"] == 0 and "nothing was removed" in w[0]


def test_plane_keeps_the_side_the_normal_points_to():
    # x + y >= 9: of the 100 (x, y) pairs, 45 have x + y <= 8; the 10 on the plane are kept
    o, _ = run("crop.plane", point=[4.5, 4.5, 0], normal=[1, 1, 0])
    ids = consistent(o["cloud"])
    assert o["n_kept"] == 550 and np.all(GRID[ids, 0] + GRID[ids, 1] >= 9)
    o, _ = run("crop.plane", point=[4.5, 4.5, 0], normal=[1, 1, 0], keep="negative")
    assert o["n_kept"] == 450 and o["cloud"].name == "grid · cropped (plane)"
    # a normal's length does not matter
    assert run("crop.plane", point=[0, 0, 2.5], normal=[0, 0, -1e-3])[0]["n_kept"] == 300
    with pytest.raises(ParameterError, match="'normal'"):
        run("crop.plane", point=[0, 0, 0], normal=[0, 0, 0])


def ortho_mvp(scale=0.1, shift=(-0.45, -0.3, 0.0)) -> list[float]:
    """An orthographic world -> clip matrix (x' = 0.1 x - 0.45, y' = 0.1 y - 0.3), written
    column-major as WebGL: the translation is in numbers 12..14. Different x and y shifts,
    so a transposed matrix would select elsewhere."""
    m = np.eye(4)
    m[:3, :3] *= scale
    m[:3, 3] = shift
    return m.T.ravel().tolist()


def test_lasso_selects_by_the_projection_through_all_depths():
    # square -0.2..0.2 in NDC: 0.1 x - 0.45 in [-0.2, 0.2] -> x in 2.5..6.5 -> 3..6;
    # 0.1 y - 0.3 in [-0.2, 0.2] -> y in 1..5, y = 1 and 5 fall on the square's edges: the
    # half-open rule takes the lower edge's row (y = 1) and not the upper one (y = 5)
    # -> y 1..4. All ten depths: 4 * 4 * 10.
    square = [-0.2, -0.2, 0.2, -0.2, 0.2, 0.2, -0.2, 0.2]
    o, _ = run("crop.lasso", polygon=square, mvp=ortho_mvp())
    ids = consistent(o["cloud"])
    p = GRID[ids]
    assert o["n_kept"] == 160 and set(p[:, 0]) == {3, 4, 5, 6} and set(p[:, 1]) == {1, 2, 3, 4}
    assert o["cloud"].name == "grid · selection kept"
    o, _ = run("crop.lasso", polygon=square, mvp=ortho_mvp(), keep="outside")
    assert o["n_kept"] == 840 and o["cloud"].name == "grid · selection removed"
    # a triangle (-0.001, 0), (1.001, 0), (-0.001, 1.002) seen through x' = 0.1 x,
    # y' = 0.1 y + 0.05 (rows between the grid's): inside when x' + y' <= 1.001, i.e.
    # x + y <= 9.51 -> the 55 pairs with x + y <= 9, at each of the 10 depths
    tri = [-0.001, 0.0, 1.001, 0.0, -0.001, 1.002]
    o, _ = run("crop.lasso", polygon=tri, mvp=ortho_mvp(shift=(0, 0.05, 0)))
    p = GRID[consistent(o["cloud"])]
    assert o["n_kept"] == 550 and np.all(p[:, 0] + p[:, 1] <= 9)


def perspective_mvp() -> list[float]:
    """A camera at (4.5, 4.5, 20) looking down -z (gluPerspective, 60 deg, aspect 1,
    near 1, far 100) times the view matrix; column-major."""
    f, near, far = 1 / np.tan(np.radians(30)), 1.0, 100.0
    proj = np.array(
        [[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]]
    )
    view = np.eye(4)
    view[:3, 3] = [-4.5, -4.5, -20.0]
    return (proj @ view).T.ravel().tolist()


def test_lasso_drops_points_behind_the_camera():
    # three points in front near the view's axis, two behind the camera (z > 20) whose x/w,
    # y/w (w < 0) would fall inside the square +-0.5 about the view's centre
    behind = np.array([[4.5 + 1, 4.5 + 1, 25.0], [4.5 - 0.5, 4.5 - 0.5, 23.0]])
    front = np.array([[4.5, 4.5, 0.0], [4.5, 4.5, 10.0], [4.6, 4.5, 5.0]])
    pts = np.vstack([front, behind])
    cloud = PointCloud(pts, fields={"id": np.arange(len(pts), dtype=float)}, name="rays")
    mvp = perspective_mvp()
    # the points behind project (x/w with w < 0) onto the mirror image: their would-be NDC
    m = np.asarray(mvp).reshape(4, 4).T
    c = np.c_[behind, np.ones(2)] @ m.T
    assert np.all(c[:, 3] < 0) and np.all(np.abs(c[:, :2] / c[:, 3:]) < 0.5)
    o, _ = run("crop.lasso", cloud, polygon=[-0.5, -0.5, 0.5, -0.5, 0.5, 0.5, -0.5, 0.5], mvp=mvp)
    assert sorted(o["cloud"].fields["id"].astype(int)) == [0, 1, 2]
    with pytest.raises(ParameterError, match="'polygon'"):
        run("crop.lasso", cloud, polygon=[0, 0, 1, 1], mvp=mvp)
    with pytest.raises(ParameterError, match="'mvp'"):
        run("crop.lasso", cloud, polygon=[0, 0, 1, 0, 0, 1], mvp=[0] * 16)


def blobs() -> PointCloud:
    """Two grids 1 mm apart inside, 100 mm apart from each other (125 and 64 points), and a lone point."""
    a = np.stack(np.meshgrid(*[np.arange(5.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    b = np.stack(np.meshgrid(*[np.arange(4.0)] * 3, indexing="ij"), -1).reshape(-1, 3) + [100, 0, 0]
    pts = np.vstack([b, a, [[50.0, 50.0, 50.0]]])  # the smaller first: numbering is by size, not order
    return PointCloud(pts, fields={"id": np.arange(len(pts), dtype=float)}, name="blobs")


def test_two_separated_blobs_are_two_components():
    o, _ = run("segment.components", blobs(), eps=1.5, min_points=3)
    assert o["n_components"] == 2 and o["sizes"] == [125, 64] and o["n_noise"] == 1
    assert o["n_kept"] == 125 and o["n_removed"] == 65
    assert sorted(o["cloud"].fields["id"].astype(int)) == list(range(64, 189))
    assert o["cloud"].name == "blobs · largest component"
    o, _ = run("segment.components", blobs(), eps=1.5, min_points=3, keep="component", component=2)
    assert sorted(o["cloud"].fields["id"].astype(int)) == list(range(64))
    o, _ = run("segment.components", blobs(), eps=1.5, min_points=3, keep="all")
    comp = o["cloud"].fields["component"]
    assert o["n_kept"] == 190 and list(comp[:64]) == [2] * 64 and list(comp[64:189]) == [1] * 125 and comp[189] == 0
    with pytest.raises(ParameterError, match="'component' = 3, but there are 2"):
        run("segment.components", blobs(), eps=1.5, min_points=3, keep="component", component=3)
    # eps below the spacing: every point is noise
    with pytest.raises(GeometryError, match="every point is noise"):
        run("segment.components", blobs(), eps=0.5, min_points=3)
    # eps above the gap joins them
    assert run("segment.components", blobs(), eps=200, min_points=3)[0]["n_components"] == 1


def test_polygon_rule_is_the_even_odd_rule():
    from camcmm_plugins.cloudtools.crop import inside_polygon

    # a square with a square notch (concave): 8 vertices; test points at cell centres
    poly = [[0, 0], [4, 0], [4, 4], [3, 4], [3, 1], [1, 1], [1, 4], [0, 4]]
    xs, ys = np.meshgrid(np.arange(4) + 0.5, np.arange(4) + 0.5)
    xy = np.column_stack([xs.ravel(), ys.ravel()])
    got = inside_polygon(xy, poly).reshape(4, 4)
    want = np.array([[1, 1, 1, 1], [1, 0, 0, 1], [1, 0, 0, 1], [1, 0, 0, 1]], dtype=bool)
    np.testing.assert_array_equal(got, want)
    # a self-crossing bow tie: each lobe inside, the crossing's outside regions out
    bow = [[0, 0], [2, 2], [2, 0], [0, 2]]
    assert inside_polygon(np.array([[0.2, 1.0], [1.8, 1.0], [1.0, 0.2], [1.0, 1.8]]), bow).tolist() == [
        True,
        True,
        False,
        False,
    ]


def test_the_generic_runner_crops_with_a_negative_corner(tmp_path, capfd):
    """``camcmm run crop.box CLOUD --min -1,-1,-1 --max 5,5,5 --out``: the options come from
    the declaration, a vector may start with a minus; x, y, z in 0..5 -> 6^3 points."""
    from camcmm.io import read, write
    from helpers.cli import main_json

    write(PointCloud(GRID, name="grid"), tmp_path / "grid.ply")
    out = tmp_path / "box.ply"
    doc = main_json(
        capfd, "run", "crop.box", tmp_path / "grid.ply", "--min", "-1,-1,-1", "--max", "5 5 5", "--out", out
    )
    assert doc["params"]["min"] == [-1.0, -1.0, -1.0] and doc["outputs"]["n_kept"] == 216
    back = read(out)
    assert back.n_points == 216 and back.points.min() == 0 and back.points.max() == 5
