"""The "Compare with CAD" page end to end in a real headless Chromium (Playwright).

The GUI server runs in a subprocess (``python -m camcmm.gui PROJECT --port 0``). The
test imports a CAD box (STL) and a measured cloud of it (PLY, moved, with noise and a
bump) through the file input, opens the page, sees both inputs in the page's 3D view,
picks a point-pair point on the measured cloud, runs the comparison with a tolerance,
and checks: the colour map in the view (pixels), the legend in µm, the statistics,
the histogram and the Abbott-Firestone curve as plotly charts (with a hover label),
the tolerance bands (green pixels, legend), a click in the view giving a point's
deviation, Export and Report with their links. Screenshots go to
``$CAMCMM_SCREENSHOTS`` (default ``/tmp/inspect-gui``).
"""

from __future__ import annotations

import re
import time

import pytest

from helpers.browsing import MARKS, at, launch, shots, wait_view  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")
pytest.importorskip("trame_plotly", reason="trame-plotly draws the page's charts")
cio = pytest.importorskip("camcmm.io")

from helpers.compare_data import make_pair  # noqa: E402

SHOTS = shots("inspect-gui")


def test_compare_with_cad_in_the_browser(gui_server, tmp_path):
    url, log = gui_server
    stl, ply, _ = make_pair(tmp_path / "files", n=8000)
    t0 = time.monotonic()
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900}, accept_downloads=True)
            page.set_default_timeout(30_000)
            page.goto(url)
            # the first load parses the client's bundles: slow on a busy machine
            page.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
            for f in (stl, ply):
                page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(f))
                page.wait_for_selector(f'[data-testid="item"]:has-text("{f.name}")')

            # the page: its own view shows both inputs
            page.locator('[data-testid="page-compare"]').click()
            page.wait_for_selector('[data-testid="inspect"]')
            page.wait_for_function(
                "() => document.querySelector('[data-testid=\"items\"]').getBoundingClientRect().right <= 0"
            )  # the drawer belongs to Inspect
            assert "scan.ply" in page.locator('[data-testid="ins-measured"]').inner_text()
            assert "box.stl" in page.locator('[data-testid="ins-nominal"]').inner_text()
            view = page.locator('[data-testid="ins-view"]')
            png, px = wait_view(view, lambda q: q["orange"] > 3000)
            time.sleep(1.0)  # the first image may still be the one made before the view had its size
            png = view.screenshot()
            (SHOTS / "inspect-1-inputs.png").write_bytes(png)
            assert px["orange"] > 3000, f"the inputs are not shown: {px}"

            # a point pair: choose a pairs method, click the measured cloud
            page.locator('[data-testid="ins-align"]').click()
            page.get_by_role("option", name="Three point pairs, then ICP", exact=True).click()
            page.wait_for_selector('[data-testid="ins-pick-hint"]:has-text("measured cloud")')
            box = view.bounding_box()
            page.mouse.click(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
            page.wait_for_selector('[data-testid="ins-pair"]:has-text("M (")')
            page.wait_for_selector('[data-testid="ins-pick-hint"]:has-text("nominal")')
            time.sleep(1.0)  # the view's next image (with the marker) follows the list
            page.screenshot(path=str(SHOTS / "inspect-2-pair.png"))
            page.locator('[data-testid="ins-pairs-clear"]').click()
            page.locator('[data-testid="ins-align"]').click()
            page.get_by_role("option", name="ICP — rigid, from where the cloud is", exact=True).click()

            # run with a tolerance of 10 µm
            tol = page.locator('[data-testid="ins-tolerance"] input')
            tol.fill("0.01")
            tol.press("Enter")
            page.locator('[data-testid="ins-run"]').click()
            page.wait_for_selector('[data-testid="ins-stats"]', timeout=60_000)
            page.wait_for_selector('[data-testid="ins-progress"]:has-text("done")')
            legend = page.locator('[data-testid="ins-legend"]').inner_text()
            assert "deviation [µm]" in legend and "±10.0 µm" in legend
            interval = page.locator('[data-testid="ins-stat-interval95"]').inner_text()
            assert re.fullmatch(r"\+[\d.]+ µm / \u2212[\d.]+ µm", interval.strip()), interval
            assert "%" in page.locator('[data-testid="ins-stat-within"]').inner_text()
            assert page.locator('[data-testid="ins-align-converged"]').inner_text().strip() == "yes"
            png, px = wait_view(view, lambda q: q["red"] > 2000 and q["blue"] > 2000 and q["orange"] < 500)
            (SHOTS / "inspect-3-colour-map.png").write_bytes(png)
            assert px["red"] > 2000 and px["blue"] > 2000 and px["orange"] < 500, f"no colour map: {px}"

            # the charts: histogram bars, the curve, a hover label with values
            page.wait_for_selector('[data-testid="ins-histogram"] .main-svg')
            assert page.locator('[data-testid="ins-histogram"] .bars .point').count() > 10
            assert "deviation [µm]" in page.locator('[data-testid="ins-histogram"] .xtitle').text_content()
            page.wait_for_selector('[data-testid="ins-af"] .scatterlayer .trace')
            assert page.locator('[data-testid="ins-af"] .scatterlayer .trace').count() >= 7
            assert "material ratio [%]" in page.locator('[data-testid="ins-af"] .xtitle').text_content()
            drag = page.locator('[data-testid="ins-af"] .nsewdrag').first
            drag.scroll_into_view_if_needed()  # the charts column scrolls (its toggle sits above them)
            dbox = drag.bounding_box()
            hover = page.locator('[data-testid="ins-af"] .hoverlayer .hovertext')
            # the curve's height in the plot depends on the deviations' range: sweep across it
            spots = [(fx, fy) for fy in (0.5, 0.6, 0.4, 0.7, 0.3) for fx in (0.5, 0.3, 0.7)]
            for fx, fy in spots:
                page.mouse.move(dbox["x"] + fx * dbox["width"], dbox["y"] + fy * dbox["height"])
                try:
                    hover.first.wait_for(timeout=1000)
                    break
                except sync_api.TimeoutError:
                    continue
            assert hover.count() and "%" in hover.first.text_content()
            page.wait_for_selector('[data-testid="ins-section"] .scatterlayer .trace')
            page.screenshot(path=str(SHOTS / "inspect-4-result.png"))
            # the section across x, then at a quarter of the slider
            page.locator('[data-testid="ins-section-x"]').click()
            page.wait_for_selector('[data-testid="ins-section"] .gtitle:has-text("Section x =")')
            title = page.locator('[data-testid="ins-section"] .gtitle').text_content()
            track = page.locator('[data-testid="ins-section-pos"] .v-slider-track').bounding_box()
            page.mouse.click(track["x"] + 0.25 * track["width"], track["y"] + 0.5 * track["height"])
            page.wait_for_function(
                "t => { const e = document.querySelector('[data-testid=\"ins-section\"] .gtitle');"
                " return e && e.textContent !== t; }",
                arg=title,
            )
            x = float(
                re.search(
                    r"Section x = ([\d.]+) mm", page.locator('[data-testid="ins-section"] .gtitle').text_content()
                ).group(1)
            )
            assert 5 < x < 15, x  # a quarter of the way along 0 … 40 mm

            # tolerance bands
            page.locator('[data-testid="ins-mode-bands"]').click()
            page.wait_for_selector('[data-testid="ins-band-within"]:has-text("within ±10.0 µm")')
            png, px = wait_view(view, lambda q: q["green"] > 5000)
            (SHOTS / "inspect-5-bands.png").write_bytes(png)
            assert px["green"] > 5000, f"no tolerance bands: {px}"

            # a click on the part: its deviation
            box = view.bounding_box()
            for fx, fy in ((0.5, 0.45), (0.5, 0.55), (0.45, 0.5), (0.55, 0.5)):
                page.mouse.click(box["x"] + fx * box["width"], box["y"] + fy * box["height"])
                try:
                    page.wait_for_selector('[data-testid="ins-picked-deviation"]', timeout=5000)
                    break
                except sync_api.TimeoutError:
                    continue
            picked = page.locator('[data-testid="ins-picked-text"]').inner_text()
            assert "deviation" in picked and "µm" in picked, picked
            page.screenshot(path=str(SHOTS / "inspect-6-picked.png"))

            # export and report
            page.locator('[data-testid="ins-export"]').click()
            page.wait_for_selector('[data-testid="ins-export-ply"]')
            page.wait_for_selector('[data-testid="item"]:has-text("tolerance bands.ply")', state="attached")
            page.locator('[data-testid="ins-report"]').click()
            page.wait_for_selector('[data-testid="ins-report-pdf"]', timeout=60_000)
            for kind in ("html", "pdf", "json"):
                href = page.locator(f'[data-testid="ins-report-{kind}"]').get_attribute("href")
                r = page.request.get(at(url, href))
                assert r.ok and len(r.body()) > 1000, (kind, r.status)
            assert (
                b"Inspection against the nominal"
                in page.request.get(
                    at(url, page.locator('[data-testid="ins-report-html"]').get_attribute("href"))
                ).body()
            )
            page.screenshot(path=str(SHOTS / "inspect-7-report.png"))

            # back on the Inspect page: its drawer and its own view again, the export among the items
            page.locator('[data-testid="page-inspect"]').click()
            page.wait_for_selector('[data-testid="view"]', state="visible")
            page.wait_for_function(
                "() => { const e = document.querySelector('[data-testid=\"items\"]');"
                " return e && e.getBoundingClientRect().left >= 0; }"
            )  # the drawer slid back
            assert not page.locator('[data-testid="inspect"]').count()
            page.wait_for_selector('[data-testid="item"]:has-text("tolerance bands.ply")')
        finally:
            browser.close()
    errors = [line for line in log if "camcmm GUI error" in line]
    assert not errors, errors
    assert time.monotonic() - t0 < 90
