"""The Inspect page's "Crop & segment" panel without a browser, on a real project: a grid
of 10 x 10 x 10 points 1 mm apart, so every count is known by hand — the box form
prefilled with its bounds, a box crop (4 x 4 x 4 = 64) shown as a new item, undo back to
the grid and redo, a lasso drawn through an orthographic view (4 x 4 columns of 10 = 160)
highlighted and removed (840 left), refusals in one line."""

from __future__ import annotations

import asyncio
import os

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
pytest.importorskip("trame")
pytest.importorskip("pyvista")

from camcmm.errors import GeometryError  # noqa: E402
from camcmm.gui.pages.inspect.cloudedit import (  # noqa: E402
    PREVIEW_ACTOR,
    SELECTION_ACTOR,
    VIEW,
    bounds_text,
    box_corners,
    plane_corners,
    turned_box_corners,
)
from camcmm.host import default_host  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402
from camcmm.tasks.cloudedit import provenance  # noqa: E402

GRID = np.stack(np.meshgrid(*[np.arange(10.0)] * 3, indexing="ij"), -1).reshape(-1, 3)


def ortho_selection(shape: str = "lasso") -> dict:
    """A square -0.2..0.2 in NDC through x' = 0.1 x - 0.45, y' = 0.1 y - 0.3 (column-major
    matrix): columns x 3..6, y 1..4 (the half-open rule keeps y = 1, drops y = 5)."""
    m = np.eye(4)
    m[:3, :3] *= 0.1
    m[:3, 3] = (-0.45, -0.3, 0.0)
    square = [[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]
    return {"shape": shape, "polygon": square, "mvp": m.T.ravel().tolist()}


@pytest.fixture
def opened(gui_app, tmp_path):
    from camcmm import io as cio

    f = tmp_path / "grid.ply"
    cio.write(PointCloud(GRID + [0.0, 0.0, 100.0004], name="grid"), f)
    server, session = gui_app()
    key = session.import_file(f)
    return server, session, server.pages["inspect"], key


def names(state) -> list[str]:
    return [it["name"] for it in state.items]


def test_box_crop_undo_redo(opened):
    server, session, page, key = opened
    s, panel = server.state, page.cloudedit
    # the box form is the plugin's declaration, its corners the grid's bounds rounded outward
    assert s.ce_op == "crop.box" and [f["name"] for f in s.ce_fields][:2] == ["min", "max"]
    assert s.ce_values["min"] == "0, 0, 100" and s.ce_values["max"] == "9, 9, 109.001"
    assert bounds_text(-1.00001, 2.00001) == ("-1.001", "2.001")
    assert not s.ce_can_undo
    values = {**s.ce_values, "min": "2, 2, 102", "max": "5, 5, 105.5"}
    # the open panel outlines the form's box in the view; a refused value takes it away
    s.ce_open, s.ce_values = "ce", values
    panel.preview()
    drawn = np.asarray(session.view.plotter.actors[PREVIEW_ACTOR].GetMapper().GetInput().GetPoints().GetData())
    np.testing.assert_array_equal(drawn, box_corners([2, 2, 102], [5, 5, 105.5]))
    s.ce_values = {**values, "max": "5, x, 5"}
    panel.preview()
    assert PREVIEW_ACTOR not in session.view.plotter.actors
    edit = asyncio.run(panel.apply("crop.box", values))
    assert edit is not None, s.ce_status
    assert edit.n_kept == 64 and s.selected_item == edit.item and not s.ce_failed
    assert names(s) == ["grid.ply", "grid.ply · cropped (box)"] and "kept 64 points, removed 936" in s.ce_status
    assert session.view.shown.n_total == 64 and s.ce_can_undo and not s.ce_can_redo
    assert s.ce_values["min"] == "2, 2, 102" and s.ce_values["max"] == "5, 5, 105.001"  # the new item's bounds
    assert [r["plugin"] for r in s.results] == ["crop.box"]
    prov = provenance(session.project, edit.item)
    assert prov["plugin"] == "crop.box" and prov["parents"] == [key] and prov["params"]["max"] == [5.0, 5.0, 105.5]
    # undo: the crop leaves the list (soft), the grid is shown again; redo brings it back
    assert panel.undo().item == edit.item
    assert names(s) == ["grid.ply"] and s.selected_item == key and session.view.shown.n_total == 1000
    assert s.ce_can_redo and not s.ce_can_undo and "undone" in s.ce_status
    assert panel.redo().item == edit.item and s.selected_item == edit.item and names(s)[-1] == edit.name
    # refusals: one line, nothing stored
    n = len(session.project.measurements(include_removed=True))
    assert asyncio.run(panel.apply("crop.box", {"min": "0, 0, 0", "max": "1, x, 1"})) is None
    assert s.ce_failed and "'max'" in s.ce_status and "\n" not in s.ce_status
    assert asyncio.run(panel.apply("crop.plane", {"point": "0, 0, 0", "normal": "0, 0, 0"})) is None
    assert "'normal'" in s.ce_status and len(session.project.measurements(include_removed=True)) == n


def test_lasso_selection_is_highlighted_kept_or_removed(opened):
    server, session, page, key = opened
    s, panel = server.state, page.cloudedit
    # GRID is shifted by 100.0004 in z: an orthographic view does not care
    assert page.on_select("cv_compare", ortho_selection()) is None  # another page's view
    assert page.on_select(VIEW, ortho_selection()) == 160
    assert s.ce_selected == 160 and s.ce_selection == "160 of 1 000 points selected (lasso)"
    hl = session.view.plotter.actors[SELECTION_ACTOR]
    pts = np.asarray(hl.GetMapper().GetInput().GetPoints().GetData())
    assert len(pts) == 160 and set(pts[:, 0]) == {3, 4, 5, 6} and set(pts[:, 1]) == {1, 2, 3, 4}
    # the client view's own path: the tool set in its state, the trigger cv_select -> the page
    cv = server.camcmm_client_views
    panel.set_tool("rect")
    assert cv.views[VIEW].tool == "rect" and s[VIEW]["tool"] == "rect" and s.ce_tool == "rect"
    sel = ortho_selection("rect")
    sel["polygon"] = [sel["polygon"][0], sel["polygon"][2]]  # a rectangle may come as two corners
    cv.on_select(VIEW, sel)
    assert s.ce_selection.endswith("(rectangle)") and s.ce_selected == 160
    edit = asyncio.run(panel.apply_selection("outside"))
    assert edit is not None, s.ce_status
    assert edit.n_kept == 840 and edit.name == "grid.ply · selection removed" and s.selected_item == edit.item
    assert s.ce_selected == 0 and SELECTION_ACTOR not in session.view.plotter.actors
    back = session.project.load_measurement(int(edit.item))
    inside = (np.isin(back.points[:, 0], [3, 4, 5, 6])) & (np.isin(back.points[:, 1], [1, 2, 3, 4]))
    assert back.n_points == 840 and not inside.any()
    # no selection on this item now: Keep says what to do
    assert asyncio.run(panel.apply_selection("inside")) is None and "draw a selection first" in s.ce_status
    # components: one grid, one component; outliers through cloud.denoise
    panel.set_op("segment.components")
    assert [f["name"] for f in s.ce_fields] == ["eps", "min_points", "keep", "component"]
    comp = asyncio.run(panel.apply("segment.components", {"eps": "1.5", "min_points": "3"}))
    assert comp is not None and comp.n_kept == 840 and comp.name.endswith("· largest component")
    # the hole the lasso cut (x 3..6, y 1..4, every z) leaves one piece; keep all: labelled, coloured by it
    every = asyncio.run(panel.apply("segment.components", {"eps": "1.5", "min_points": "3", "keep": "all"}))
    assert every is not None and s.color_field == "component" and every.name.endswith("· components")
    # the plane form starts through the centre of the shown cloud's bounds, horizontal
    panel.set_op("crop.plane")
    assert s.ce_values["point"] == "4.5, 4.5, 104.5" and s.ce_values["normal"] == "0, 0, 1"
    half = asyncio.run(panel.apply("crop.plane", s.ce_values))
    assert half is not None and half.n_kept == 840 // 2


def test_the_outlines_follow_the_plugins_conventions():
    """The turned box's outline (SciPy's extrinsic x-y-z rotation) has its corners on the
    faces of the box crop.box keeps (its own R = Rz Ry Rx): a hair larger holds all 8, a
    hair smaller none; the plane's square lies in the plane, its side 2 x half."""
    centre, size, rotation = [1.0, -2.0, 3.0], [4.0, 6.0, 10.0], [20.0, -35.0, 110.0]
    corners = turned_box_corners(centre, size, rotation)
    host = default_host()

    def kept(scale: float) -> int:
        params = {"centre": centre, "size": [scale * x for x in size], "rotation": rotation}
        try:
            return host.run("crop.box", {"cloud": PointCloud(corners)}, params).outputs["n_kept"]
        except GeometryError:
            return 0  # keeps none: refused

    assert kept(1 + 1e-9) == 8 and kept(1 - 1e-9) == 0
    square = plane_corners([1.0, 2.0, 3.0], [0.0, 3.0, 4.0], 5.0)
    np.testing.assert_allclose((square - [1, 2, 3]) @ np.array([0, 0.6, 0.8]), 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(np.diff(square, axis=0, append=square[:1]), axis=1), 10.0)
