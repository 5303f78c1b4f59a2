"""The Inspect page's 3-D view drawn in the browser (issue 29), in headless Chromium on the
real app: a cloud with a signed field is imported, the client view (cloudview.js, state
``cv_inspect`` from camcmm.gui.clientview) draws it — the canvas shows the diverging
map's reds and blues, its legend's title is the server's — and the toggle switches to
the server's rendering: the remote view's image replaces the canvas, coloured alike.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``<tmp>/clientview``).
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.browsing import MARKS, hue_pixels, launch, shots, wait_view  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")
cio = pytest.importorskip("camcmm.io")

from camcmm.model import PointCloud  # noqa: E402

SHOTS = shots("clientview")


def test_inspect_view_in_the_browser_and_on_the_server(gui_server, tmp_path):
    url, log = gui_server
    P = np.random.default_rng(4).uniform([0, 0, 0], [60, 40, 10], size=(20000, 3))
    cloud = PointCloud(P, name="plate", fields={"deviation": (P[:, 0] - 30.0) / 300.0}, field_units={"deviation": "mm"})
    path = tmp_path / "plate.ply"
    cio.write(cloud, path)
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 850})
            page.set_default_timeout(30_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
            page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(path))
            page.wait_for_selector('[data-testid="item"]:has-text("plate.ply")')
            page.wait_for_selector('[data-testid="legend-title"]:has-text("deviation")')
            page.wait_for_function("() => window.camcmmCloudView && window.camcmmCloudView.ready('cv_inspect')")
            stats = page.evaluate("() => window.camcmmCloudView.views.cv_inspect.stats()")
            assert stats["points_total"] == 20000 and stats["points_drawn"] == 20000, stats

            canvas = page.locator('[data-cv="cv_inspect"] canvas').first
            png = canvas.screenshot()
            (SHOTS / "clientview-browser.png").write_bytes(png)
            px = hue_pixels(png)
            assert px["red"] > 500 and px["blue"] > 500, f"the cloud is not drawn in its colours: {px}"
            server_title = page.locator('[data-testid="legend-title"]').inner_text().replace("legend:", "").strip()
            legend = page.locator('[data-cv="cv_inspect"] .cmm-cv-legend-title').inner_text().strip()
            assert legend == server_title == "deviation [µm]"  # deviations in µm (issue 30)

            page.locator('[data-testid="cv_inspect-mode-server"]').click()
            page.wait_for_selector('[data-cv="cv_inspect"]', state="detached")
            view = page.locator('[data-testid="view"]')
            png, px = wait_view(view, lambda q: q["red"] > 500 and q["blue"] > 500)
            (SHOTS / "clientview-server.png").write_bytes(png)
            assert px["red"] > 500 and px["blue"] > 500, f"the remote view shows no colour map: {px}"
        finally:
            browser.close()
