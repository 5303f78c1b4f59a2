"""The Fuse page in a headless Chromium on the demo project (issue 17).

The demo as shipped has no height maps: the page opens without an error and says what
to do. The real Zygo map and a cloud made from it (as tests/test_fusion_real.py makes
them) are written into the server's data root as a photogrammetry cloud (.ply) and a CSI
height map (.x3p, camcmm.api.write), with a second map of another surface (random
relief) that the cloud does not contain. Both maps and the cloud are imported through the toolbar;
the foreign map is refused in one line naming it, and the app keeps working; the coin's
map is fused: the matches figure, the difference map, its Abbott-Firestone curve with
the 95 % band and the numbers appear, and the fused cloud is drawn with one footprint.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/fuse-gui``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots, text_of  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("fuse-gui")


@pytest.fixture
def data(tmp_path, shared_data):
    """``tmp/data`` (the server's data root): coin.ply, coin_csi.x3p, foreign_csi.x3p.

    The real Zygo map (../shared; skipped where absent) as tests/test_fusion_real.py makes
    its case: the 'photogrammetry' cloud is the map's own points, every second one, scaled
    by 1.03, turned and tilted, coloured by its shaded heights; the CSI map is the central
    60 % of the file, written as .x3p (which keeps no intensity: the plugin shades it). The
    foreign map is random relief of the same grid."""
    from camcmm.api import HeightMap, write
    from helpers.fusion_synthetic import make_case

    zygo = shared_data / "csi_height_maps_surfalize" / "test_1.dat"
    if not zygo.is_file():
        pytest.skip(f"{zygo} is absent")
    folder = tmp_path / "data"
    folder.mkdir()
    cloud, crop = make_case(zygo, "shaded")
    write(cloud, folder / "coin.ply")
    write(HeightMap(crop.heights, crop.dx, crop.dy, origin=crop.origin, name="coin_csi"), folder / "coin_csi.x3p")
    rng = np.random.default_rng(9)
    foreign = HeightMap(rng.normal(0.0, 0.001, crop.shape), crop.dx, crop.dy, name="foreign_csi")
    write(foreign, folder / "foreign_csi.x3p")
    return folder


@pytest.fixture
def demo_server(tmp_path, data, demo_project):
    from camcmm.gui.process import GuiProcess

    demo_project(tmp_path / "demo")
    server = GuiProcess(tmp_path / "demo", timeout=180, data_roots=(data,))
    yield server, data
    server.stop()


@pytest.fixture
def sample_server(tmp_path, demo_project):
    """The demo served as shipped: no height maps, no data roots (the sample is the plugin's)."""
    from camcmm.gui.process import GuiProcess

    demo_project(tmp_path / "demo")
    server = GuiProcess(tmp_path / "demo", timeout=180)
    yield server
    server.stop()


def _text(page, testid: str, pattern: str, timeout: float = 60.0) -> str:
    return text_of(page, testid, pattern, timeout, SHOTS)


def import_file(page, path: Path) -> None:
    page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(path))
    page.wait_for_selector(f'[data-testid="item"]:has-text("{path.name}")', state="attached", timeout=60_000)


def _pick(page, testid: str, names: list[str]) -> None:
    """Open the select ``testid`` and click each option named (a multiple select toggles)."""
    page.click(f'[data-testid="{testid}"]')
    for name in names:
        page.locator(".v-overlay--active .v-list-item", has_text=name).first.click()
    page.keyboard.press("Escape")
    page.wait_for_selector(".v-overlay--active .v-list-item", state="detached")


def test_fuse_page_on_the_demo(demo_server):
    server, data = demo_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-fuse"]', timeout=180_000)
            # the demo has no height maps: an empty state that says what to do, no error
            assert "height map" in page.locator('[data-testid="fu-empty"]').inner_text()
            assert page.locator('[data-testid="fu-error"]').count() == 0
            assert page.locator('[data-testid="footer-error"]').count() == 0
            assert page.locator('[data-testid="fu-param-sigma_px"]').count() == 1  # the plugin's form
            page.screenshot(path=str(SHOTS / "empty.png"))

            for name in ("coin.ply", "coin_csi.x3p", "foreign_csi.x3p"):
                import_file(page, data / name)
            page.click('[data-testid="page-fuse"]')
            _pick(page, "fu-cloud", ["coin.ply"])
            # the cloud's points are 2 µm apart: the plugin's blur of 6 px would leave nothing to match
            page.locator('[data-testid="fu-param-sigma_px"] input').fill("1")

            # a map of another surface: refused in one line naming it; the app keeps working
            _pick(page, "fu-maps", ["foreign_csi"])
            page.click('[data-testid="fu-run"]')
            err = _text(page, "fu-error", r"foreign_csi", timeout=90)
            assert "\n" not in err.strip() and page.locator('[data-testid="fu-numbers"]').count() == 0
            page.screenshot(path=str(SHOTS / "refused.png"))

            # the coin's own map
            page.click('[data-testid="fu-maps"] .v-chip__close')
            page.wait_for_selector('[data-testid="fu-maps"] .v-chip', state="detached")
            _pick(page, "fu-maps", ["coin_csi"])
            page.wait_for_selector('[data-testid="fu-maps"] .v-chip:has-text("coin_csi")')
            page.click('[data-testid="fu-run"]')
            _text(page, "fu-message", r"^done", timeout=120)
            inliers = _text(page, "fu-num-matches", r"\d+ / \d+")
            assert int(inliers.split("/")[1]) >= 8
            # the scale the cloud was made with, 1.03, recovered (the plugin's figure, shown as it is)
            scale = page.locator('[data-testid="fu-num-scale"]').inner_text()
            assert abs(float(scale.split()[0]) - 1.03) < 1e-3, scale
            assert re.search(r"µm", page.locator('[data-testid="fu-num-band"]').inner_text())
            for testid, title in (
                ("fu-matches", "inlier matches"),
                ("fu-difference", "Difference"),
                ("fu-abbott", "Abbott-Firestone"),
            ):
                page.wait_for_selector(f'[data-testid="{testid}"] .gtitle:has-text("{title}")')
            page.screenshot(path=str(SHOTS / "fused.png"))
            # the two grey images under the matches, the map as an image, the band over the curve
            assert page.locator('[data-testid="fu-matches"] svg image').count() == 2
            assert page.locator('[data-testid="fu-difference"] svg image').count() == 1
            assert page.locator('[data-testid="fu-abbott"] .shapelayer path').count() >= 1
            assert page.locator('[data-testid="fu-note"]').get_attribute("data-outlines") == "1"
            assert page.locator('[data-testid="fu-error"]').count() == 0
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)


def test_the_sample_pair_fuses_at_the_defaults(sample_server):
    """A newcomer's first fusion (issue 30): "Load the sample pair", Run, nothing changed in
    the form: the synthetic coin's cloud is fused with its map and the scale it was made
    with, 1.02, comes back (plugins/camcmm_plugins/fusion/sample.py)."""
    server = sample_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-fuse"]', timeout=180_000)
            assert "Load the sample pair" in page.locator('[data-testid="fu-empty"]').inner_text()
            page.click('[data-testid="fu-sample"]')
            _text(page, "fu-message", r"sample pair is chosen")
            assert "coin_photogrammetry.ply" in page.locator('[data-testid="fu-cloud"]').inner_text()
            assert "coin_csi.x3p" in page.locator('[data-testid="fu-maps"]').inner_text()
            assert page.locator('[data-testid="fu-param-sigma_px"] input').input_value() == "6"  # the default
            page.click('[data-testid="fu-run"]')
            _text(page, "fu-message", r"^done", timeout=120)
            inliers = _text(page, "fu-num-matches", r"\d+ / \d+")
            assert int(inliers.split("/")[1]) >= 8
            scale = page.locator('[data-testid="fu-num-scale"]').inner_text()
            assert abs(float(scale.split()[0]) - 1.02) < 1e-3, scale
            page.wait_for_selector('[data-testid="fu-matches"] .gtitle:has-text("inlier matches")')
            assert page.locator('[data-testid="fu-note"]').get_attribute("data-outlines") == "1"
            assert page.locator('[data-testid="fu-error"]').count() == 0
            page.screenshot(path=str(SHOTS / "sample.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
