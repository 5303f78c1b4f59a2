"""The Studies page in a headless Chromium on the demo project (issue 18).

The demo as shipped has no study: the page opens without an error and says what to do.
A study file outside the project folder and the data roots is refused in one line.
"Make a virtual-lab study" writes the virtual lab's light-field study into the project
folder and chooses it; Run computes it: table 6.3 with its three sets and the sample
standard deviations, the fit's numbers with the prediction at 45 mm near the virtual
lab's law (-1 + 0.15 f = 5.75 mm/λ), the depth-vs-λ scatter with its line and the
gradient-vs-focal-length plot appear; Export report offers the HTML, PDF and JSON.
Choosing the speckle study shows its form.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/studies-gui``).
"""

from __future__ import annotations

import re

import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots, text_of  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("studies-gui")


@pytest.fixture
def demo_server(tmp_path, demo_project):
    from camcmm.gui.process import GuiProcess

    demo_project(tmp_path / "demo")
    server = GuiProcess(tmp_path / "demo", timeout=180)
    yield server
    server.stop()


def _text(page, testid: str, pattern: str, timeout: float = 60.0) -> str:
    return text_of(page, testid, pattern, timeout, SHOTS)


def test_studies_page_runs_the_virtual_light_field_study(demo_server, tmp_path):
    server = demo_server
    outside = tmp_path / "outside.yaml"
    outside.write_text("runs: []\n")
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-studies"]', timeout=180_000)
            assert "virtual-lab study" in page.locator('[data-testid="st-empty"]').inner_text()
            assert page.locator('[data-testid="st-error"]').count() == 0
            assert page.locator('[data-testid="st-param-predict_focal_mm"]').count() == 1  # the plugin's form

            # a file outside the project folder: one line, nothing run
            page.locator('[data-testid="st-file"] input').fill(str(outside))
            page.click('[data-testid="st-run"]')
            err = _text(page, "st-error", r"outside the folders")
            assert "\n" not in err.strip() and page.locator('[data-testid="st-table-t63"]').count() == 0

            page.click('[data-testid="st-virtual"]')
            _text(page, "st-message", r"virtual-lab study written", timeout=90)
            assert page.locator('[data-testid="st-file"] input').input_value().endswith("study.yaml")
            page.locator('[data-testid="st-param-predict_focal_mm"] input').fill("45")
            page.click('[data-testid="st-run"]')
            _text(page, "st-message", r"^done", timeout=120)

            table = page.locator('[data-testid="st-table-t63"]').inner_text()
            assert "Set 1" in table and "Set 3" in table and "Standard deviation" in table
            pred = _text(page, "st-num-predicted", r"mm λ⁻¹")
            assert abs(float(pred.split()[0]) - 5.75) < 0.02, pred
            for testid, title in (("st-scatter", "Depth vs λ"), ("st-focal", "Gradient vs focal length")):
                page.wait_for_selector(f'[data-testid="{testid}"] .gtitle:has-text("{title}")')
            assert page.locator('[data-testid="st-focal"] .errorbar').count() >= 3
            page.screenshot(path=str(SHOTS / "lightfield.png"), full_page=True)

            page.click('[data-testid="st-report"]')
            links = _text(page, "st-links", r"(?i)\.pdf", timeout=90).lower()  # buttons write upper case
            assert ".html" in links and ".json" in links
            assert page.locator('[data-testid="st-error"]').count() == 0

            # the other kind: the speckle study's own form; the shown run stays until another is run
            page.click('[data-testid="st-kind"]')
            page.locator(".v-overlay--active .v-list-item", has_text="Speckle").first.click()
            page.wait_for_selector('[data-testid="st-param-fresh"]')
            assert page.locator('[data-testid="st-param-predict_focal_mm"]').count() == 0
            assert page.locator('[data-testid="st-table-t63"]').count() == 1
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)


def test_studies_page_runs_the_virtual_speckle_study(demo_server):
    """The speckle on/off study end to end in the browser: the virtual lab's small study
    (one AM artefact, one material, speckle off and on) written into the project, run, and
    tables 6.1 and 6.2, the area coverage and both deviation maps shown from the run."""
    server = demo_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-studies"]', timeout=180_000)
            page.click('[data-testid="st-kind"]')
            page.locator(".v-overlay--active .v-list-item", has_text="Speckle").first.click()
            page.wait_for_selector('[data-testid="st-param-fresh"]')
            page.click('[data-testid="st-virtual"]')
            _text(page, "st-message", r"virtual-lab study written", timeout=90)
            page.click('[data-testid="st-run"]')
            _text(page, "st-message", r"^done", timeout=1200)  # two reconstructions: ~80 s idle
            t61 = page.locator('[data-testid="st-table-std_um"]').inner_text()
            t62 = page.locator('[data-testid="st-table-n_points"]').inner_text()
            cov = page.locator('[data-testid="st-table-coverage"]').inner_text()
            # values from the run: a std in µm and a point count for each condition, coverage in %
            assert "non-speckle" in t61 and "speckle" in t61 and "failed" not in t61, t61
            assert len(re.findall(r"\b\d{1,3}(?:[ \u2009\u202f]\d{3})+\b", t62)) >= 2, t62  # "143 413"
            assert len(re.findall(r"\b\d{1,3}\.\d\b", cov)) >= 2, cov
            for testid in ("st-map-off", "st-map-on"):
                page.wait_for_selector(f'[data-testid="{testid}"] .main-svg')
            page.screenshot(path=str(SHOTS / "speckle.png"))
            assert page.locator('[data-testid="st-error"]').count() == 0
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
