"""End to end in a real headless Chromium, driven by Playwright.

The GUI server runs in a subprocess (``python -m camcmm.gui PROJECT --port 0``); the
test imports a cloud through the file input, checks that it is listed and that the
3D view really shows it (pixels, not just a DOM node), runs a plugin form and sees
the result, then uploads a bad file and sees the error while the items stay.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default: the system temp folder).
"""

from __future__ import annotations

import io
import re
import time
from pathlib import Path

import numpy as np
import pytest

from helpers.browsing import ARGS, CHROMIUM, MARKS, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")
cio = pytest.importorskip("camcmm.io")
if not hasattr(cio, "read"):
    pytest.skip("camcmm.io.read is not there yet", allow_module_level=True)

from camcmm.model import PointCloud  # noqa: E402

SHOTS = shots("camcmm-gui")


def coloured_pixels(png: bytes) -> int:
    """Pixels whose colour is clearly not grey: the colour-mapped points and legend."""
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    return int(((a.max(axis=2) - a.min(axis=2)) > 60).sum())


def make_cloud(path: Path) -> None:
    rng = np.random.default_rng(7)
    u, v = rng.uniform(0, 2 * np.pi, 20000), rng.uniform(-1, 1, 20000)
    r = 12.0 + 0.05 * rng.normal(size=u.size)
    pts = np.column_stack([r * np.sqrt(1 - v**2) * np.cos(u), r * np.sqrt(1 - v**2) * np.sin(u), r * v])
    cio.write(PointCloud(pts, fields={"deviation": r - 12.0}, field_units={"deviation": "mm"}), path)


def test_import_view_and_run_a_plugin(gui_server, tmp_path):
    url, log = gui_server
    cloud = tmp_path / "ball.ply"
    make_cloud(cloud)
    bad = tmp_path / "broken.xyz"
    bad.write_text("1 2 3\n4 nan 6\n")
    t0 = time.monotonic()
    with sync_api.sync_playwright() as p:
        ctx = p.chromium.launch_persistent_context(
            str(tmp_path / "chromium-profile"),
            executable_path=CHROMIUM,
            headless=True,
            args=ARGS,
            viewport={"width": 1400, "height": 900},
        )
        try:
            page = ctx.new_page()
            page.set_default_timeout(30_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
            page.wait_for_selector('[data-plugin-id="cloud.downsample"]')
            view = page.locator('[data-testid="view"]')
            time.sleep(1.0)
            empty = coloured_pixels(view.screenshot())
            page.screenshot(path=str(SHOTS / "camcmm-browser-0-empty.png"))

            # import a cloud through the file input
            page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(cloud))
            page.wait_for_selector('[data-testid="item"]:has-text("ball.ply")')
            page.wait_for_selector('[data-testid="display-note"]:has-text("20 000 points")', state="attached")
            legend = page.locator('[data-testid="legend-title"]')
            legend.wait_for()
            assert re.search(r"deviation \[µm\]", legend.inner_text()), legend.inner_text()  # µm: issue 30
            shot, deadline = None, time.monotonic() + 20
            while time.monotonic() < deadline:  # the first streamed image may take a moment
                shot = view.screenshot()
                if coloured_pixels(shot) > empty + 2000:
                    break
                time.sleep(0.5)
            (SHOTS / "camcmm-browser-1-view.png").write_bytes(shot)
            page.screenshot(path=str(SHOTS / "camcmm-browser-1-imported.png"))
            assert coloured_pixels(shot) > empty + 2000, "the 3D view does not show the coloured cloud"

            # colour by another field: the legend follows, with its unit
            page.locator('[data-testid="color-field"]').click()
            page.locator('.v-overlay .v-list-item:has-text("y [mm]")').click()
            page.wait_for_selector('[data-testid="legend-title"]:has-text("y [mm]")')

            # a plugin form built from the manifest: fill it, run, see the result
            page.locator('[data-plugin-id="cloud.downsample"]').click()
            field = page.locator('[data-testid="param-voxel_size"] input')
            field.wait_for()
            assert "mm" in page.locator('[data-testid="param-voxel_size"]').inner_text()
            field.fill("2")
            page.locator('[data-testid="run-button"]').click()
            page.wait_for_selector('[data-testid="report-n_points"]')  # the report's "points" row
            n = int(page.locator('[data-testid="report-n_points"]').inner_text().replace(" ", "").strip())
            assert 0 < n < 20000
            page.wait_for_selector('[data-testid="progress"]:has-text("100")')
            assert page.locator('[data-testid="item"]').count() == 2
            # the value typed in the form is the one the plugin ran with
            page.wait_for_selector('[data-testid="item"]:has-text("voxel 2 mm")')
            assert field.input_value() == "2"
            time.sleep(0.5)
            page.screenshot(path=str(SHOTS / "camcmm-browser-2-result.png"))

            # a bad file: a one-line error naming it; the items stay
            page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(bad))
            alert = page.locator('[data-testid="error-alert"]')
            alert.wait_for()
            assert "broken.xyz" in alert.inner_text()
            assert page.locator('[data-testid="item"]').count() == 2
            page.screenshot(path=str(SHOTS / "camcmm-browser-3-error.png"))
        finally:
            ctx.close()
    assert time.monotonic() - t0 < 90
