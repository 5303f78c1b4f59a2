"""The client-rendered 3-D view's Python side without a browser (camcmm.gui.clientview).

A pyvista scene with a coloured cloud (one NaN value), a quad mesh, a polyline, a
scalar bar, point labels and a legend box is exported; the references are independent
of the export: the counts by construction, the colours from VTK's own lookup table
(``vtkLookupTable.MapValue``) and from matplotlib's colour map of the same name, the tick
texts from the bar's C format, the buffer names from hashlib over the files' bytes, the
positions from the cloud itself through the level-of-detail permutation. The triggers
get malformed arguments (a browser can send anything) and must change nothing.
"""

from __future__ import annotations

import hashlib
import os
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
pv = pytest.importorskip("pyvista")

from camcmm.gui.clientview import (  # noqa: E402
    BufferStore,
    ClientView,
    checked_selection,
    export_scene,
    lod_order,
)
from camcmm.gui.view import SceneView  # noqa: E402
from camcmm.gui.viewtools import ViewTools  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402
from helpers.selection import selection_mask  # noqa: E402

N = 3000


def table_colour(lut, value):
    """VTK's colour of ``value``: its lookup table's entry (GetIndex -> GetTableValue) as
    the bytes VTK draws (x 255, rounded)."""
    return [int(c * 255.0 + 0.5) for c in lut.GetTableValue(lut.GetIndex(float(value)))[:3]]


def cloud(n: int = N) -> PointCloud:
    P = np.random.default_rng(3).uniform([100, -20, 5], [140, 20, 15], size=(n, 3))
    return PointCloud(P, name="part", fields={"deviation": (P[:, 2] - 10.0) / 100.0}, field_units={"deviation": "mm"})


@pytest.fixture
def plotter():
    p = pv.Plotter(off_screen=True, window_size=[600, 400])
    yield p
    p.close()


def test_export_counts_colours_legend_labels(plotter):
    rng = np.random.default_rng(1)
    P = rng.uniform(-10, 10, size=(N, 3))
    dev = P[:, 0] / 100.0
    dev[7] = np.nan
    poly = pv.PolyData(P)
    poly.point_data["deviation"] = dev
    cloud_actor = plotter.add_mesh(
        poly,
        scalars="deviation",
        cmap="coolwarm",
        clim=[-0.05, 0.05],
        nan_color="#888888",
        style="points",
        point_size=3,
        scalar_bar_args={"title": "deviation [mm]", "fmt": "%.3g", "n_labels": 5},
    )
    plane = pv.Plane(i_resolution=3, j_resolution=2)  # 6 quads -> 12 triangles
    plotter.add_mesh(plane, color="#b0b7c3", opacity=0.5)
    plotter.add_mesh(
        pv.lines_from_points(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0.0]])), color="k"
    )
    plotter.add_point_labels(np.array([[0, 0, 1.0], [1, 0, 1], [2, 0, 1]]), ["P1", "P2", "P3"], show_points=False)
    plotter.add_legend([["measured", "#ef8a17"], ["nominal", "#b0b7c3"]])

    scene = export_scene(plotter.renderer, {id(cloud_actor): "cloud"})
    kinds = {lay.id: lay for lay in scene.layers}
    pts = kinds["cloud"]
    assert pts.kind == "points" and pts.n == N and pts.point_size == 3
    mesh = next(lay for lay in scene.layers if lay.kind == "mesh")
    lines = next(lay for lay in scene.layers if lay.kind == "lines")
    assert mesh.n == 12 and mesh.indices.shape == (12, 3) and mesh.colors is None and mesh.opacity == 0.5
    assert mesh.color == [0xB0, 0xB7, 0xC3]
    assert lines.indices.tolist() == [[0, 1], [1, 2], [2, 3], [3, 4]] and lines.color == [0, 0, 0]
    # the triangles cover the plane: their areas add up to the plane's (1 x 1)
    V = mesh.positions[mesh.indices.astype(int)]
    area = 0.5 * np.linalg.norm(np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]), axis=1).sum()
    assert area == pytest.approx(1.0, abs=1e-9)

    # level-of-detail order: a permutation; positions and colours follow it
    order = pts.order
    assert sorted(order.tolist()) == list(range(N)) and order.tolist() != list(range(N))
    assert np.array_equal(pts.positions, P[order])
    lut = cloud_actor.GetMapper().GetLookupTable()
    cmap = pytest.importorskip("matplotlib").colormaps["coolwarm"]
    for k in (0, 1, 2, 100, 2999):
        i = int(order[k])
        if np.isfinite(dev[i]):  # VTK's table, and matplotlib's map of the same name (to the table's steps)
            assert pts.colors[k].tolist() == table_colour(lut, dev[i])
            ref = np.round(255 * np.asarray(cmap(np.clip((dev[i] + 0.05) / 0.1, 0, 1))[:3]))
            assert np.abs(pts.colors[k].astype(int) - ref).max() <= 4
    k_nan = int(np.nonzero(order == 7)[0][0])
    assert pts.colors[k_nan].tolist() == [0x88, 0x88, 0x88]

    legend = scene.legend
    assert legend["title"] == "deviation [mm]" and (legend["lo"], legend["hi"]) == (-0.05, 0.05)
    assert [lab["text"] for lab in legend["labels"]] == ["-0.05", "-0.025", "0", "0.025", "0.05"]
    assert len(legend["colors"]) == 32
    assert np.abs(np.subtract(legend["colors"][0], np.round(255 * np.asarray(cmap(0.5 / 32)[:3])))).max() <= 4
    assert np.abs(np.subtract(legend["colors"][-1], np.round(255 * np.asarray(cmap(31.5 / 32)[:3])))).max() <= 4
    assert [(lab["text"], lab["pos"]) for lab in scene.labels] == [
        ("P1", [0.0, 0.0, 1.0]),
        ("P2", [1.0, 0.0, 1.0]),
        ("P3", [2.0, 0.0, 1.0]),
    ]
    assert scene.entries == [
        {"text": "measured", "color": [0xEF, 0x8A, 0x17]},
        {"text": "nominal", "color": [0xB0, 0xB7, 0xC3]},
    ]
    cam = plotter.renderer.GetActiveCamera()
    assert scene.camera["position"] == list(cam.GetPosition()) and scene.camera["view_angle"] == cam.GetViewAngle()


@pytest.fixture
def shown(tmp_path):
    view = SceneView()
    obj = cloud()
    view.show("c", obj, "deviation")
    state = SimpleNamespace()
    cv = ClientView("cv_test", view, state, BufferStore(tmp_path / "cv"), "__camcmm_cv/cv_test/")
    cv.names = lambda: {"cloud": view.actor}
    yield view, cv, obj
    view.plotter.close()


def test_buffers_named_by_content_and_only_colours_rewritten(shown, tmp_path):
    view, cv, obj = shown
    s1 = cv.publish()
    written = cv.store.take_written()
    (lay,) = s1["layers"]
    assert lay["id"] == "cloud" and lay["n"] == N and lay["kind"] == "points"
    assert sorted(written) == sorted([lay["positions"], lay["colors"]])
    folder = tmp_path / "cv"
    for name in written:  # the name is BLAKE2b-128 of the bytes, the suffix the type
        data = (folder / name).read_bytes()
        assert name == hashlib.blake2b(data, digest_size=16).hexdigest() + "." + name.split(".")[1]
    order = lod_order(N)
    pos = np.frombuffer((folder / lay["positions"]).read_bytes(), dtype="<f4").reshape(-1, 3)
    assert np.abs(pos + np.asarray(s1["origin"]) - obj.points[order]).max() < 1e-4  # float32 of ~40 mm
    rgb = np.frombuffer((folder / lay["colors"]).read_bytes(), dtype="u1").reshape(-1, 3)
    lut = view.actor.GetMapper().GetLookupTable()
    i = int(order[5])
    assert rgb[5].tolist() == table_colour(lut, obj.fields["deviation"][i])
    assert s1["legend"]["title"] == view.scalar_bar_title == "deviation [µm]"

    s2 = cv.publish()  # nothing changed: the same names, nothing written, a new rev
    assert s2["layers"] == s1["layers"] and cv.store.take_written() == [] and s2["rev"] == s1["rev"] + 1
    assert s2["camera"]["rev"] == s1["camera"]["rev"]  # the server did not move the camera

    view.set_field("z")  # a colour change: only a colour buffer is new
    s3 = cv.publish()
    new = cv.store.take_written()
    assert new == [s3["layers"][0]["colors"]] and new[0].endswith(".u8")
    assert s3["layers"][0]["positions"] == lay["positions"] and s3["legend"]["title"] == "z [mm]"
    assert sorted(p.name for p in folder.iterdir()) == sorted({*written, *new})  # only buffers

    tools = ViewTools(view, SimpleNamespace(), "vt", SimpleNamespace())
    tools.standard_view("+x")  # the server moves the camera: the browser is told to adopt it
    s4 = cv.publish()
    assert s4["camera"]["rev"] == s3["camera"]["rev"] + 1 and s4["camera"]["position"] == list(
        view.plotter.camera.position
    )


def test_pick_maps_back_through_the_permutation_and_bad_arguments_do_nothing(shown):
    view, cv, obj = shown
    cv.publish()
    got = []
    cv.on_pick = lambda layer, i, p: got.append((layer, i, p)) or i
    order = lod_order(N)
    for k in (0, 17, N - 1):
        assert cv.pick("cloud", k, [0.0, 0.0, 0.0]) == order[k]
        layer, i, p = got[-1]
        assert layer == "cloud" and i == order[k] and np.array_equal(p, obj.points[order[k]])  # the server's point
    for bad in [
        ("nope", 1, None),
        (None, 1, None),
        ("cloud", -1, None),
        ("cloud", N, None),
        ("cloud", 1.0, None),
        ("cloud", True, None),
        ("cloud", "3", None),
        ("cloud", 3, [0.0, float("nan"), 0.0]),
        ("cloud", 3, [0.0, 0.0]),
        ("cloud", 3, "xyz"),
    ]:
        assert cv.pick(*bad) is None
    assert len(got) == 3

    cam0 = list(view.plotter.camera.position)
    good = {"position": [300.0, 0.0, 10.0], "focal_point": [120.0, 0.0, 10.0], "view_up": [0, 0, 1], "view_angle": 30}
    for bad_cam, vp in [
        ({**good, "position": [float("inf"), 0, 0]}, [800, 600]),
        ({**good, "position": good["focal_point"]}, [800, 600]),
        ({**good, "view_up": [1, 0, 0]}, [800, 600]),  # along the view
        ({**good, "view_angle": 0}, [800, 600]),
        ({**good, "view_angle": "30"}, [800, 600]),
        ({k: v for k, v in good.items() if k != "view_up"}, [800, 600]),
        ("camera", [800, 600]),
        (good, [0, 600]),
        (good, [800.5, 600]),
        (good, [10**9, 600]),
        (good, [8192, 8192]),  # more pixels than an 8K screen: the server would render them
        (good, "800x600"),
    ]:
        assert cv.camera(bad_cam, vp) is False
    assert list(view.plotter.camera.position) == cam0 and cv.viewport is None
    assert cv.camera(good, [800, 600]) is True
    assert list(view.plotter.camera.position) == [300.0, 0.0, 10.0] and list(view.plotter.window_size) == [800, 600]
    assert cv.publish()["camera"]["rev"] == 1  # the browser's own camera: not sent back as a new one

    selected = []
    cv.on_select = lambda name, sel: selected.append((name, sel))
    mvp = np.eye(4).ravel().tolist()
    assert cv.select({"shape": "lasso", "polygon": [[0, 0], [1, 0], [0, 1]], "mvp": mvp, "extra": "x"})
    assert selected == [("cv_test", {"shape": "lasso", "polygon": [[0, 0], [1, 0], [0, 1]], "mvp": mvp})]
    assert cv.select({"shape": "lasso", "polygon": [[0, 0], [1, 0], [0, "1"]], "mvp": mvp}) is None
    assert len(selected) == 1


def test_selection_checked_and_its_points():
    # an orthographic MVP: clip = (x/10, y/10, 0, 1) -> ndc = x/10, y/10
    mvp = np.diag([0.1, 0.1, 0.0, 1.0]).T.ravel().tolist()
    sel = checked_selection({"shape": "rect", "polygon": [[-0.5, -0.5], [0.5, 0.5]], "mvp": mvp})
    assert sel["polygon"] == [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]
    P = np.random.default_rng(2).uniform(-10, 10, size=(5000, 3))
    inside = (np.abs(P[:, 0]) < 5) & (np.abs(P[:, 1]) < 5)
    assert np.array_equal(selection_mask(P, sel), inside)
    tri = checked_selection({"shape": "lasso", "polygon": [[0, 0], [1, 0], [0, 1]], "mvp": mvp})
    assert np.array_equal(selection_mask(P, tri), (P[:, 0] > 0) & (P[:, 1] > 0) & (P[:, 0] + P[:, 1] < 10))
    behind = np.diag([0.1, 0.1, 0.0, -1.0]).T.ravel().tolist()  # w < 0: behind the camera, never selected
    assert not selection_mask(P, {**sel, "mvp": behind}).any()
    for bad in [
        None,
        {"shape": "circle", "polygon": [[0, 0], [1, 0], [0, 1]], "mvp": mvp},
        {"shape": "lasso", "polygon": [[0, 0], [1, 0]], "mvp": mvp},  # two corners only for a rectangle
        {"shape": "lasso", "polygon": [[0, 0], [1, float("nan")], [0, 1]], "mvp": mvp},
        {"shape": "lasso", "polygon": [[0, 0]] * 5000, "mvp": mvp},
        {"shape": "lasso", "polygon": [[0, 0], [1, 0], [0, 1]], "mvp": mvp[:15]},
        {"shape": "rect", "polygon": [[0, 0], [1, 1]], "mvp": [*mvp[:15], float("inf")]},
    ]:
        assert checked_selection(bad) is None


def test_pages_publish_route_picks_and_switch(gui_app, tmp_path):
    """The Inspect and Compare pages in browser mode: an imported cloud published whole
    (its buffers the only files in the served folder), a click through cv_pick named,
    a pair point on the Compare page recorded from a click, triggers with bad arguments
    ignored, the switch to the server's rendering and back (with the display limit)."""
    import camcmm.io as cio
    from camcmm.gui.clientview import CLIENT_LIMIT
    from camcmm.gui.view import DISPLAY_LIMIT

    server, session = gui_app()
    s = server.state
    reg = server.camcmm_client_views
    assert sorted(reg.views) == ["cv_compare", "cv_inspect"] and s.cv_inspect_mode == "browser"
    assert session.view.display_limit == CLIENT_LIMIT
    obj = cloud(2000)
    cio.write(obj, tmp_path / "part.ply")
    key = session.import_file(tmp_path / "part.ply")
    session.select_item(key)
    st = s.cv_inspect
    (lay,) = st["layers"]
    assert lay["n"] == 2000 and st["note"] == "showing all 2 000 points" and st["legend"]["title"] == s.legend_title
    folder = reg.folder / "cv_inspect"
    assert {p.name for p in folder.iterdir()} == {lay["positions"], lay["colors"]}

    assert reg.on_pick("cv_inspect", "cloud", 0, None) is not None
    i = int(lod_order(2000)[0])
    assert (
        s.cv_inspect_picked.startswith(f"point #{i}: (")
        and "deviation = " in s.cv_inspect_picked
        and " µm" in s.cv_inspect_picked
    )
    for args in [("cv_nope", "cloud", 0), (7, "cloud", 0), ("cv_inspect", "cloud", 2000), ()]:
        assert reg.on_pick(*args) is None
    assert reg.on_camera("cv_inspect", {"position": [0, 0, float("nan")]}, [10, 10]) is False
    assert reg.on_select("cv_inspect", {"shape": "lasso"}) is None
    assert reg.on_tool("cv_inspect", "lasso") is None and s.cv_inspect["tool"] == "lasso"

    rev = s.cv_inspect["rev"]
    s.cv_inspect_mode = "server"
    s.flush()
    assert session.view.display_limit == DISPLAY_LIMIT
    session.select_item(key)  # the remote view draws now: the client state stays as it was
    assert s.cv_inspect["rev"] == rev
    s.cv_inspect_mode = "browser"
    s.flush()
    assert session.view.display_limit == CLIENT_LIMIT and s.cv_inspect["rev"] > rev
    s.cv_inspect_mode = "<script>"
    s.flush()
    assert s.cv_inspect_mode == "browser"


def test_compare_clicks_take_pairs_and_deviations(gui_app, tmp_path):
    """A click in the browser on the Compare page goes through the page's own picking: a
    pair point on the measured cloud (the drawn point, mapped back through the LOD order),
    one on the nominal mesh (its surface point nearest to the browser's), a refusal on the
    wrong object; after a run a click gives that point's deviation."""
    import asyncio

    from camcmm.host import default_host

    if "inspect.compare" not in default_host().plugins:
        pytest.skip("the inspection plugin is not installed")
    from helpers.compare_data import imported

    server, session, page, _ = imported(gui_app, tmp_path, n=3000)
    s = server.state
    reg = server.camcmm_client_views
    page.opened()  # the page shown: its inputs drawn without a push (the remote view would ask) ...
    s.page = "compare"
    s.flush()  # ... and published when the page is shown
    assert {lay["id"] for lay in s.cv_compare["layers"]} >= {"measured", "nominal"}
    page.set_align("pairs+icp")
    st = s.cv_compare
    ids = {lay["id"]: lay for lay in st["layers"]}
    assert {"measured", "nominal"} <= set(ids) and ids["nominal"]["kind"] == "mesh"
    assert [e["text"] for e in st["entries"]] == ["measured", "nominal"]
    prep = page.view._inputs["measured"]
    order = lod_order(prep.n_shown)
    reg.on_pick("cv_compare", "measured", 11, [0.0, 0.0, 0.0])
    assert page.inputs.measured_pairs == [prep.points[order[11]].tolist()]
    # a click on the measured cloud when the nominal's point is next: the nominal's surface
    # along the same line of sight (the server's cell picker), as a server-side click picks it
    cam = page.view.plotter.renderer.GetActiveCamera()
    q = prep.points[order[12]]
    reg.on_pick("cv_compare", "measured", 12, None)
    (n1,) = page.inputs.nominal_pairs
    ray = q - np.asarray(cam.GetPosition())
    off = np.subtract(n1, cam.GetPosition())
    assert np.linalg.norm(np.cross(ray / np.linalg.norm(ray), off)) < 0.2  # on the line of sight (mm)
    page.undo_pair_point()
    reg.on_pick("cv_compare", "nominal", 0, [20.0, 15.0, 20.3])
    assert np.allclose(page.inputs.nominal_pairs[0], [20.0, 15.0, 20.0], atol=1e-9)
    assert [lab["text"] for lab in s.cv_compare["labels"]] == ["M1", "N1"]
    assert page.gdt.start_picking()  # a feature of the nominal for a characteristic: the click's region
    assert reg.on_pick("cv_compare", "measured", 3, None) is None  # only the nominal is shown
    reg.on_pick("cv_compare", "nominal", 0, [20.0, 15.0, 20.3])
    assert "of the nominal within" in s.gdt_f_picked and s.gdt_f_picked.endswith(" of (20, 15, 20) mm")  # snapped

    page.clear_pairs()
    page.set_align("icp")
    assert asyncio.run(page.run_async()) is not None, s.ins_error
    st = s.cv_compare
    cloud_layer = next(lay for lay in st["layers"] if lay["id"] == "cloud")
    assert cloud_layer["colors"] and st["legend"]["title"] == page.view.scalar_bar_title
    n = cloud_layer["n"]
    k = 5
    reg.on_pick("cv_compare", "cloud", k, None)
    i = int(lod_order(n)[k])
    i = i if page.view.dev.idx is None else int(page.view.dev.idx[i])
    assert s.ins_picked["index"] == i
    assert s.ins_picked["deviation_mm"] == float(page.deviations.fields["deviation"][i])

    # a failed alignment's view: the nominal over the cloud; a click on the nominal gives the
    # deviation of the cloud's front-most point within a few pixels of that line of sight
    page.view.show_failed(page.view.dev, page.nominal, reset_camera=False)
    eye = np.asarray(page.view.plotter.renderer.GetActiveCamera().GetPosition())
    q = page.view.dev.points[7]
    reg.on_pick("cv_compare", "nominal", 0, q.tolist())
    got = np.array([s.ins_picked[c] for c in "xyz"])
    ray = (q - eye) / np.linalg.norm(q - eye)
    assert s.ins_picked["found"] and np.linalg.norm(np.cross(ray, got - eye)) < 1.5  # mm: 14 px here
    page.display.set_mode("colour")

    # a new display limit (the switch browser/server) draws the map again with it, same camera
    from camcmm.gui.clientview.hooks import redraw_compare

    cam = list(page.view.plotter.renderer.GetActiveCamera().GetPosition())
    total = page.view.dev.n_total
    page.view.display_limit = 1000
    redraw_compare(page, 1000)

    def cloud_n():
        return next(lay["n"] for lay in s.cv_compare["layers"] if lay["id"] == "cloud")

    assert page.view.dev.n_shown == 1000 and page.view.scene == "colour" and cloud_n() == 1000
    page.view.display_limit = 500_000
    redraw_compare(page, 1000)
    assert page.view.dev.n_shown == total and cloud_n() == total
    assert list(page.view.plotter.renderer.GetActiveCamera().GetPosition()) == cam


def test_big_cloud_refines_on_zoom_and_comes_back(gui_app, tmp_path):
    """A cloud above the client view's limit (here an explicit limit of 1000 points for a
    cloud of 6000): first the random subset; zoomed in, only points in the view, several
    times as many there as the first paint had, on the whole cloud's colour limits; a click
    names the cloud's own row; zoomed out, the first paint again. The reference for "in
    the view" is VTK's own camera projection at the browser's viewport."""
    import camcmm.io as cio
    from camcmm.gui.pages.compare.picking import world_to_display

    server, session = gui_app(display_limit=1000)
    s = server.state
    cv = server.camcmm_client_views.views["cv_inspect"]
    P = np.random.default_rng(5).uniform([0, 0, 0], [60, 40, 2], size=(6000, 3))
    obj = PointCloud(P, name="big", fields={"deviation": (P[:, 0] - 30) / 300}, field_units={"deviation": "mm"})
    cio.write(obj, tmp_path / "big.ply")
    session.select_item(session.import_file(tmp_path / "big.ply"))
    view = session.view
    first = s.cv_inspect
    assert view.shown.n_shown == 1000 and first["layers"][0]["n"] == 1000 and "1 000 of 6 000" in first["note"]
    assert first["note"].endswith("; zoom in: the view then shows every point of the region")
    assert s.display_note == first["note"]
    assert (first["legend"]["lo"], first["legend"]["hi"]) == pytest.approx((-0.1, 0.1), abs=2e-3)  # the whole cloud's

    W, H = 800, 600
    zoom = {"position": [15.0, 10.0, 25.0], "focal_point": [15.0, 10.0, 1.0], "view_up": [0, 1, 0], "view_angle": 30}
    assert cv.camera(zoom, [W, H])
    rows = cv.big.rows
    xy, _, ok = world_to_display(view.plotter.renderer, P)  # VTK's projection at the browser's size
    inside = ok & (xy[:, 0] > 1) & (xy[:, 0] < W - 1) & (xy[:, 1] > 1) & (xy[:, 1] < H - 1)
    near = ok & (xy[:, 0] > -1) & (xy[:, 0] < W + 1) & (xy[:, 1] > -1) & (xy[:, 1] < H + 1)
    assert 300 < inside.sum() < 1000
    assert set(rows.tolist()) <= set(np.nonzero(near)[0])  # nothing outside the view is sent
    base_rows = np.nonzero(np.isin(P[:, 0], np.asarray(cv.big.base.poly.points)[:, 0]))[0]
    assert inside[rows].sum() > 3 * inside[base_rows].sum()  # denser where zoomed in
    st = s.cv_inspect
    assert st["layers"][0]["n"] == len(rows) and "those in view" in st["note"] and s.display_note == st["note"]
    assert (st["legend"]["lo"], st["legend"]["hi"]) == (first["legend"]["lo"], first["legend"]["hi"])
    cv.pick("cloud", 0, None)
    row = int(rows[lod_order(len(rows))[0]])
    assert s.cv_inspect_picked.startswith(f"point #{row}: (")

    far = {"position": [30.0, 20.0, 400.0], "focal_point": [30.0, 20.0, 1.0], "view_up": [0, 1, 0], "view_angle": 30}
    assert cv.camera(far, [W, H])
    assert cv.big.rows is None and view.shown.n_shown == 1000 and s.cv_inspect["note"] == first["note"]
