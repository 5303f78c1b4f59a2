"""Crop & segment through the Inspect page in headless Chromium (issue 29).

A grid of 10 x 10 x 10 points 1 mm apart: the box form opens with its bounds; the box
2..5 mm keeps 4 x 4 x 4 = 64 points, stored as a new item with its result; Undo removes it
(soft) and shows the grid again. Then a lasso dragged in the client view selects points;
Keep selection stores exactly them — the count checked against the client view's own
selection code (:func:`helpers.selection.selection_mask`, written apart from the
plugin's) applied to the polygon and view matrix the browser sent.

Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``<tmp>/cloudedit``).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

from camcmm.errors import CamcmmError  # noqa: E402
from camcmm.gui.process import GuiProcess  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402
from camcmm.project import Project  # noqa: E402

SHOTS = shots("cloudedit")
GRID = np.stack(np.meshgrid(*[np.arange(10.0)] * 3, indexing="ij"), -1).reshape(-1, 3)


@pytest.fixture
def grid_gui(tmp_path):
    folder = tmp_path / "proj"
    with Project.create(folder) as p:
        h = p.add_object(PointCloud(GRID, name="grid"), "grid.ply")
        p.add_measurement("grid.ply", h, "pointcloud", meta={"summary": "1 000 points"})
        p.set_state("gui.selected_item", "1")  # the page opens showing it
    try:
        server = GuiProcess(folder)
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server, folder
    server.stop()


def _listed(folder) -> list[dict]:
    with Project.open(folder) as p:  # a second reader beside the server (WAL)
        return p.measurements()


def _field(page, name: str):
    return page.locator(f'[data-testid="ce-param-{name}"] input')


def test_box_crop_undo_and_a_lasso_in_the_view(grid_gui):
    server, folder = grid_gui
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 900})
            page.set_default_timeout(30_000)
            page.goto(server.url)
            page.wait_for_selector('[data-testid="ce-open"]', timeout=120_000)
            page.wait_for_selector('[data-testid="display-note"]:has-text("1 000")', state="attached")
            page.locator('[data-testid="ce-open"]').click()
            # the box form opens with the grid's bounds
            _field(page, "min").wait_for()
            assert _field(page, "min").input_value() == "0, 0, 0" and _field(page, "max").input_value() == "9, 9, 9"
            # the open panel outlines the box in the client view (8 corners), and the outline
            # follows the form: a new positions buffer once the corners are typed
            lines = "(window.trame.state.get('cv_inspect').layers || []).find(l => l.kind === 'lines' && l.n === 8)"
            page.wait_for_function(f"() => !!{lines}")
            first = page.evaluate(f"() => {lines}.positions")
            _field(page, "min").fill("2, 2, 2")
            _field(page, "max").fill("5, 5, 5")
            page.wait_for_function(f"(first) => {{ const l = {lines}; return l && l.positions !== first; }}", arg=first)
            time.sleep(0.5)  # the client draws the new buffer
            page.screenshot(path=str(SHOTS / "box-outline.png"))
            page.locator('[data-testid="ce-apply"]').click()
            page.wait_for_selector('[data-testid="ce-status"]:has-text("kept 64 points, removed 936")')
            page.wait_for_selector('[data-testid="display-note"]:has-text("showing all 64 points")', state="attached")
            page.screenshot(path=str(SHOTS / "box-crop.png"))
            items = _listed(folder)
            assert [m["name"] for m in items] == ["grid.ply", "grid.ply · cropped (box)"]
            assert items[1]["meta"]["made_by"].startswith("crop.box ")

            page.locator('[data-testid="ce-undo"]').click()
            page.wait_for_selector('[data-testid="ce-status"]:has-text("undone")')
            page.wait_for_selector('[data-testid="display-note"]:has-text("1 000")', state="attached")
            assert [m["name"] for m in _listed(folder)] == ["grid.ply"]

            # a lasso in the client view (drawn in the browser)
            canvas = page.locator('[data-cv="cv_inspect"] canvas')
            canvas.wait_for()
            page.wait_for_function("() => window.camcmmCloudView && window.camcmmCloudView.ready('cv_inspect')")
            page.locator('[data-testid="ce-tool-lasso"]').click()
            page.wait_for_function("() => window.trame.state.get('cv_inspect').tool === 'lasso'")
            box = canvas.bounding_box()
            cx, cy, r = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2, min(box["width"], box["height"]) / 8
            page.mouse.move(cx - r, cy - r)
            page.mouse.down()
            for x, y in ((cx + r, cy - r), (cx + r, cy + r), (cx - r, cy + r), (cx - r, cy - r + 1)):
                page.mouse.move(x, y, steps=4)
            page.mouse.up()
            sel = page.locator('[data-testid="ce-selection"]')
            page.wait_for_selector('[data-testid="ce-selection"]:has-text("points selected (lasso)")')
            n = int(sel.inner_text().split(" of ")[0].replace(" ", ""))
            assert 0 < n < 1000
            page.screenshot(path=str(SHOTS / "lasso.png"))
            page.locator('[data-testid="ce-keep"]').click()
            page.wait_for_selector('[data-testid="ce-status"]:has-text("selection kept")')
            with Project.open(folder) as proj:
                (row,) = [r for r in proj.results() if r["plugin"] == "crop.lasso"]
                kept = proj.load_measurement(int(_listed(folder)[-1]["id"]))
            from helpers.selection import selection_mask

            polygon = np.asarray(row["params"]["polygon"]).reshape(-1, 2).tolist()
            mask = selection_mask(GRID, {"polygon": polygon, "mvp": row["params"]["mvp"]})
            assert kept.n_points == n == int(mask.sum()) == row["outputs"]["n_kept"]
            np.testing.assert_array_equal(np.sort(kept.points, axis=0), np.sort(GRID[mask], axis=0))
            page.screenshot(path=str(SHOTS / "lasso-kept.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log)
