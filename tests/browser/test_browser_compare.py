"""The demo's Compare-with-CAD pair end to end in a headless Chromium (issue 15's Done-when).

On the demo project (``camcmm demo``), the Compare page with ``sphere scan (20 mm ball)``
against ``sphere nominal (CAD)``: the default alignment (ICP, which starts from the
centroids because the scan lies ≈ 42 mm away) converges, the ball's rotations are
reported held in words, the view shows a deviation colour map, the histogram and the
Abbott-Firestone curve are drawn, rms ≈ 7–8 µm (the demo's 4 µm noise plus the 5120-facet
tessellation of a 10 mm ball); the same with "Automatic (features + RANSAC), then ICP".
The view's screenshot is a PNG download through the page's downloads route, which a
browser without the token does not get. Screenshots go to ``$CAMCMM_SCREENSHOTS``
(default ``/tmp/compare-demo``).
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import pytest

from helpers.browsing import MARKS, at, choose, launch, server_tracebacks, shots, wait_view  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")
pytest.importorskip("trame_plotly", reason="trame-plotly draws the page's charts")


SHOTS = shots("compare-demo")
SCAN, CAD = "sphere scan (20 mm ball)", "sphere nominal (CAD)"


@pytest.fixture
def demo_server(tmp_path, demo_project):
    from camcmm.gui.process import GuiProcess

    demo_project(tmp_path / "demo")
    server = GuiProcess(tmp_path / "demo")
    yield server.url, server.log
    server.stop()


def um(text: str) -> float:
    m = re.fullmatch(r"([\d.]+) µm", text.strip())
    assert m, text
    return float(m.group(1))


def run_and_check(page, view, align: str, method: str, shot: str) -> None:
    """Choose ``align``, run, and check the converged result (alignment ``method``) with its figures."""
    page.locator('[data-testid="ins-align"]').click()
    page.get_by_role("option", name=align, exact=True).click()
    run = page.locator('[data-testid="ins-run"]')
    run.wait_for()
    page.wait_for_function(
        "() => !document.querySelector('[data-testid=\"ins-run\"]').disabled"
        " && !document.querySelector('.v-overlay--active .v-list-item')"
    )
    run.click()
    try:  # this run's result: its method in the alignment table, and done (a rerun leaves the last "done")
        page.wait_for_function(
            "m => { const e = document.querySelector('[data-testid=\"ins-align-method\"]');"
            " const r = document.querySelector('[data-testid=\"ins-run\"]');"
            " return e && e.textContent.trim() === m && r && !r.classList.contains('v-btn--loading'); }",
            arg=method,
            timeout=180_000,
        )
        page.wait_for_selector('[data-testid="ins-progress"]:has-text("done")', timeout=30_000)
    except sync_api.TimeoutError:
        page.screenshot(path=str(SHOTS / f"{shot}-timeout.png"))
        err = page.locator('[data-testid="ins-error"]')
        raise AssertionError(f"no result: {err.inner_text() if err.count() else 'no error shown'}") from None
    page.wait_for_selector('[data-testid="ins-stats"]')
    assert page.locator('[data-testid="ins-align-converged"]').inner_text().strip().startswith("yes")
    held = page.locator('[data-testid="ins-align-held"]').inner_text()
    assert "rotation about any axis through" in held and "mm" in held, held
    rms = um(page.locator('[data-testid="ins-stat-rms"]').inner_text())
    assert 7.0 <= rms <= 8.0, rms
    assert 7.0 <= um(page.locator('[data-testid="ins-align-rms"]').inner_text()) <= 8.0
    assert "deviation [µm]" in page.locator('[data-testid="ins-legend"]').inner_text()
    assert not page.locator('[data-testid="ins-failed"]').count()
    png, px = wait_view(view, lambda q: q["red"] > 1500 and q["blue"] > 1500 and q["orange"] < 500, timeout=30)
    (SHOTS / f"{shot}-view.png").write_bytes(png)
    assert px["red"] > 1500 and px["blue"] > 1500 and px["orange"] < 500, f"no deviation colour map: {px}"
    page.wait_for_selector('[data-testid="ins-histogram"] .bars .point', state="attached")
    assert page.locator('[data-testid="ins-histogram"] .bars .point').count() > 10
    assert "deviation [µm]" in page.locator('[data-testid="ins-histogram"] .xtitle').text_content()
    page.wait_for_selector('[data-testid="ins-af"] .scatterlayer .trace')
    assert page.locator('[data-testid="ins-af"] .scatterlayer .trace').count() >= 7
    assert "material ratio [%]" in page.locator('[data-testid="ins-af"] .xtitle').text_content()
    page.screenshot(path=str(SHOTS / f"{shot}-page.png"))


def test_demo_pair_converges_with_colour_map_charts_and_screenshot(demo_server):
    url, log = demo_server
    t0 = time.monotonic()
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000}, accept_downloads=True)
            page.set_default_timeout(30_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
            page.locator('[data-testid="page-compare"]').click()
            page.wait_for_selector('[data-testid="inspect"]')
            choose(page, "ins-measured", SCAN)
            choose(page, "ins-nominal", CAD)
            assert SCAN in page.locator('[data-testid="ins-measured"]').inner_text()
            assert CAD in page.locator('[data-testid="ins-nominal"]').inner_text()
            # the default alignment is ICP: with the scan 42 mm off it starts from the centroids
            assert "ICP — rigid" in page.locator('[data-testid="ins-align"]').inner_text()
            view = page.locator('[data-testid="ins-view"]')
            run_and_check(page, view, "ICP — rigid, from where the cloud is", "icp", "1-icp")

            # the view's tools: a standard view, then a screenshot as a PNG download
            for testid in ("insv-view-+z", "insv-view-iso", "insv-view-reset"):
                btn = page.locator(f'[data-testid="{testid}"]')
                assert btn.get_attribute("title") and btn.get_attribute("data-shortcut-key")
            page.locator('[data-testid="insv-view-+z"]').click()
            page.locator('[data-testid="insv-screenshot"]').click()
            link = page.locator('[data-testid="insv-screenshot-link"]')
            link.wait_for()
            with page.expect_download() as dl:
                link.click()
            data = Path(dl.value.path()).read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
            (SHOTS / "2-screenshot-download.png").write_bytes(data)
            href = link.get_attribute("href")
            assert page.request.get(at(url, href)).ok
            u = urlsplit(url)  # the same route without the token: refused
            stranger = browser.new_context()
            try:
                r = stranger.request.get(urlunsplit((u.scheme, u.netloc, "/" + href.lstrip("/"), "", "")))
                assert r.status in (401, 403), r.status
            finally:
                stranger.close()

            run_and_check(page, view, "Automatic (features + RANSAC), then ICP", "global+icp", "3-global")
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
    assert not [line for line in log if "camcmm GUI error" in line]
    print(f"demo comparison in the browser: {time.monotonic() - t0:.0f} s")
