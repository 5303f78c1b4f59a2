"""The 3-D view's tools without a browser: standard views (camera positions), point size,
screenshot, picked labels that stay, the stepped legend's band edges, and the section's
deviation whiskers. Exact by construction: the cameras and band edges are arithmetic on
known bounds and limits; the whiskers' feet lie on a known outline."""

from __future__ import annotations

import asyncio
import os
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
pytest.importorskip("pyvista")

from camcmm.gui.downloads import Downloads  # noqa: E402
from camcmm.gui.view import SceneView  # noqa: E402
from camcmm.gui.viewtools import (  # noqa: E402
    ABOVE_COLOUR,
    MAX_LABELS,
    VIEWS,
    ViewTools,
    camera_for,
    label_text,
    legend_spec,
    stepped_edges,
)
from camcmm.model import PointCloud  # noqa: E402
from camcmm_plugins.inspection.display import outline_feet, section  # noqa: E402


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


@pytest.fixture
def scene(tmp_path):
    view = SceneView()
    pts = np.random.default_rng(0).uniform([10, 20, 30], [50, 40, 35], size=(2000, 3))
    view.show("c", PointCloud(pts, name="box"), "z")
    tools = ViewTools(view, SimpleNamespace(), "vt", Downloads("camcmm-test-view", folder=tmp_path / "dl"))
    yield view, tools
    view.plotter.close()


def test_camera_for_is_exact():
    b = [[0, 0, 0], [40, 30, 20]]
    for name, (d, up, tip, key) in VIEWS.items():
        cam = camera_for(name, b)
        assert cam["focal_point"] == [20.0, 15.0, 10.0] and cam["view_up"] == list(up)
        off = np.subtract(cam["position"], cam["focal_point"])
        assert np.allclose(unit(off), unit(d), atol=1e-15)
        assert np.linalg.norm(off) == pytest.approx(0.5 * np.linalg.norm([40, 30, 20]) / np.sin(np.radians(15)))
        assert len(key) == 1 and tip
    assert [VIEWS[n][3] for n in ("+x", "-x", "+y", "-y", "+z", "-z", "iso")] == list("123456i")


def test_standard_views_turn_the_camera(scene):
    view, tools = scene
    bounds = np.asarray(view.plotter.renderer.ComputeVisiblePropBounds()).reshape(3, 2).T
    centre = bounds.mean(axis=0)
    for name in VIEWS:
        cam = tools.standard_view(name)
        off = np.subtract(cam["position"], cam["focal_point"])
        assert np.allclose(unit(off), unit(VIEWS[name][0]), atol=1e-9), name
        assert np.allclose(cam["view_up"], VIEWS[name][1], atol=1e-9), name
        assert np.allclose(cam["focal_point"], centre, atol=1e-9), name
    tools.standard_view("-y")
    view.plotter.camera.zoom(3.0)
    before = np.subtract(view.plotter.camera.position, view.plotter.camera.focal_point)
    cam = tools.standard_view("reset")  # frames everything again, keeps the direction
    assert np.allclose(unit(np.subtract(cam["position"], cam["focal_point"])), unit(before), atol=1e-9)


def test_point_size_and_screenshot(scene, tmp_path):
    view, tools = scene
    assert tools.set_point_size(6) == 6 and view.point_actors()[0].GetProperty().GetPointSize() == 6
    view.set_field("x")  # a redraw keeps it
    assert view.point_actors()[0].GetProperty().GetPointSize() == 6
    assert tools.set_point_size("7") == 0 and tools.state.vt_point_size == 0  # not offered: automatic
    assert view.point_actors()[0].GetProperty().GetPointSize() == view.auto_point_size()
    link = tools.screenshot()
    assert link == tools.state.vt_shot and link["url"].startswith("camcmm-test-view/") and link["kind"] == "png"
    data = (tmp_path / "dl" / link["name"]).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 1000


def test_labels_text_number_and_clear(scene):
    _, tools = scene
    assert label_text(1, [12.3456, -6.789, 0.1234], 0.0076, "µm") == "#1 (12.346, \u22126.789, 0.123) mm\n+7.6 µm"
    assert label_text(2, [0, 0, 0], -0.0123, "mm") == "#2 (0.000, 0.000, 0.000) mm\n\u22120.0123 mm"
    assert label_text(3, [1, 2, 3], None, "µm") == "#3 (1.000, 2.000, 3.000) mm"
    for i in range(MAX_LABELS + 2):
        tools.add_label([i, 0, 0], 0.001 * i, "µm")
    labels = tools.state.vt_labels
    assert len(labels) == MAX_LABELS and labels[0]["number"] == 3 and labels[-1]["number"] == MAX_LABELS + 2
    tools.clear_labels()
    assert tools.state.vt_labels == [] and tools.markers() == []


def test_stepped_legend_edges_are_exact():
    assert stepped_edges(0.01, 4) == [-0.01, -0.005, 0.0, 0.005, 0.01]
    e = stepped_edges(0.03, 6)
    assert len(e) == 7 and e[0] == -0.03 and e[-1] == 0.03 and e[3] == 0.0
    with pytest.raises(ValueError):
        stepped_edges(1.0, 1)
    spec = legend_spec("tolerance", 8, 0.05, 0.02)
    assert spec["clim"] == [-0.02, 0.02] and spec["n_colors"] == 8 and spec["above"] == ABOVE_COLOUR
    assert spec["edges"] == stepped_edges(0.02, 8)
    assert legend_spec("tolerance", 8, 0.05, None)["above"] is None  # no tolerance: stepped
    assert legend_spec("continuous", 8, 0.05, 0.02)["edges"] == []


def test_outline_feet_and_whisker_normals_are_exact():
    """A 10 × 10 square outline; points off its edges by known amounts."""
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], dtype=float)
    pts = np.array([[5.0, -0.02], [10.03, 4.0], [3.0, 9.99], [0.01, 7.0]])
    dev = np.array([0.02, 0.03, -0.01, -0.01])  # outside the square: positive
    foot, normal = outline_feet(pts, dev, [square])
    assert np.allclose(foot, [[5, 0], [10, 4], [3, 10], [0, 7]], atol=1e-12)
    # positive deviation along the outward normal; the whisker tip = foot + dev × normal
    assert np.allclose(normal, [[0, -1], [1, 0], [0, 1], [-1, 0]], atol=1e-12)
    assert np.allclose(foot + dev[:, None] * normal, pts, atol=1e-12)


def test_section_gives_feet_on_a_mesh_cut():
    from camcmm.model import TriangleMesh
    from helpers.shapes import box_mesh

    V, F = box_mesh(np.zeros(3), np.array([40.0, 30.0, 20.0]), n=2)
    P = np.array([[20.0, -0.01, 10.0], [40.02, 15.0, 10.0], [20.0, 15.0, 50.0]])
    sec = section("z", 10.0, P, np.array([0.01, 0.02, 0.0]), 0.5, TriangleMesh(V, F))
    assert sec["foot"].shape == (2, 2) and np.allclose(sec["foot"], [[20, 0], [40, 15]], atol=1e-12)
    assert np.allclose(sec["normal"], [[0, -1], [1, 0]], atol=1e-12)


@pytest.mark.slow
def test_compare_page_labels_stay_and_the_stepped_legend(gui_app, tmp_path):
    from helpers.compare_data import imported

    server, session, page, _ = imported(gui_app, tmp_path)
    s = server.state
    s.ins_tolerance = "0.01"
    assert asyncio.run(page.run_async()) is not None, s.ins_error
    dev = page.deviations
    page.pick_index(10)
    page.pick_index(20)
    assert [lab["number"] for lab in s.insv_labels] == [1, 2]
    p = dev.points[20]
    assert s.insv_labels[1]["text"] == label_text(2, p, float(dev.fields["deviation"][20]), "µm")
    assert [m["label"] for m in page.view.labels] == [lab["text"] for lab in s.insv_labels]
    page.set_mode("bands")  # the labels stay over another display
    assert "marker_labels" in page.view._actors and len(page.view.labels) == 2
    page.set_mode("colour")
    page.set_legend("stepped", 8)
    bar = page.view.plotter.scalar_bars["deviation [µm]"]
    lut = bar.GetLookupTable()
    labels = bar.GetCustomLabels()
    assert lut.GetNumberOfTableValues() == 8 and lut.GetRange() == (-10.0, 10.0)
    assert [labels.GetValue(i) for i in range(labels.GetNumberOfTuples())] == [
        round(e * 1e3, 9) for e in stepped_edges(0.01, 8)
    ]
    assert s.ins_limit_text == "8 bands of 2.50 µm over ±10.0 µm"
    page.set_legend("tolerance", 4)
    lut = page.view.plotter.scalar_bars["deviation [µm]"].GetLookupTable()
    assert lut.GetNumberOfTableValues() == 4 and lut.GetUseAboveRangeColor() and lut.GetUseBelowRangeColor()
    assert "out of tolerance" in s.ins_limit_text
    page.set_legend(None, 99)
    assert "outside 2…32" in s.ins_error and s.ins_legend_n == 4
    page.tools.clear_labels()
    assert s.insv_labels == [] and "marker_labels" not in page.view._actors
    # the section: whiskers from the nominal outline
    fig = s.ins_fig_section
    assert any(t.get("name", "").startswith("deviation ×") for t in fig["data"])
    link = page.tools.screenshot()
    assert (page.offered.folder / link["name"]).read_bytes()[:4] == b"\x89PNG"


def test_the_inspect_view_gets_the_same_tools(gui_app, tmp_path):
    """mount_view_tools on the session's own scene (the Inspect page's): views, point size and a
    screenshot offered on its own guarded route."""
    from camcmm.gui.viewtools import mount_view_tools

    server, session = gui_app()
    pts = np.random.default_rng(1).uniform(0, 10, size=(500, 3))
    session.view.show("c", PointCloud(pts, name="cube"), "z")
    tools = mount_view_tools(server, session.view, "vt")
    cam = tools.standard_view("-x")
    assert np.allclose(unit(np.subtract(cam["position"], cam["focal_point"])), [-1, 0, 0], atol=1e-9)
    assert tools.set_point_size(2) == 2 and session.view.point_actors()[0].GetProperty().GetPointSize() == 2
    link = tools.screenshot()
    assert link["url"].startswith("camcmm-vt-view/") and server.state.vt_shot == link
    assert (tools.downloads.folder / link["name"]).read_bytes()[:4] == b"\x89PNG"
    tools.downloads.close()
