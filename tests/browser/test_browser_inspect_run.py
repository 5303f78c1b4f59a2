"""A click on Run never misses (issue 15), in headless Chromium on the demo project.

The issue: with the sphere fit's "extract" switch on, a hint pushed Run down; the click
that took the focus away removed the hint, Run jumped back and the click hit nothing —
no run, no message. Here: the sphere fit's form, a nominal radius typed, the switch
toggled and Run clicked at once (no wait in between). Run must not have moved, the run
must happen with what the form shows (extract on, nominal 10 mm: the stored result
says so), and the result reads as a report (diameter, u, form in µm) with the view
coloured by the fit's residuals in µm. Then a run that cannot start (a negative
nominal radius) says why next to Run, and a click stores nothing. Last the tidy: the
scan, input of the stored fit, is deleted only after a dialog listing that fit, and
Undo brings it back.

Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``<tmp>/inspect-run``).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from helpers.browsing import MARKS, launch, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

from camcmm.errors import CamcmmError  # noqa: E402
from camcmm.gui.process import GuiProcess  # noqa: E402
from camcmm.project import Project  # noqa: E402

SHOTS = shots("inspect-run")


@pytest.fixture
def demo(tmp_path, demo_project):
    """The demo project's clouds (``camcmm demo`` without its acceptance test) and the GUI on it."""
    folder = demo_project(tmp_path / "demo", acceptance=False)
    try:
        server = GuiProcess(folder)
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server, folder
    server.stop()


def _results(folder: Path) -> list[dict]:
    with Project.open(folder) as p:  # a second reader beside the server (WAL)
        return p.results()


def test_run_right_after_toggling_extract_and_a_refused_run_says_why(demo):
    server, folder = demo
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.set_default_timeout(30_000)
            page.goto(server.url)
            page.wait_for_selector('[data-plugin-id="fit.sphere"]', timeout=120_000)
            page.locator('[data-plugin-id="fit.sphere"]').click()
            page.wait_for_selector('[data-testid="param-extract"]')
            # the picker offers the cloud the user sees (the demo opens on it), not a derived one
            assert "sphere scan (20 mm ball)" in page.locator('[data-testid="input-cloud"]').inner_text()
            page.locator('[data-testid="param-nominal_radius"] input').fill("10")
            run = page.locator('[data-testid="run-button"]')
            before = run.bounding_box()

            # toggle extract and click Run at once
            page.locator('[data-testid="param-extract"] input').click()
            run.click()
            assert run.bounding_box() == before, "Run moved under the pointer"
            page.wait_for_selector('[data-testid="report-diameter"]', timeout=90_000)
            page.wait_for_selector('[data-testid="run-status"]:has-text("done")')
            (stored,) = _results(folder)
            assert stored["plugin"] == "fit.sphere"
            assert stored["params"]["extract"] is True and stored["params"]["nominal_radius"] == 10.0
            assert stored["outputs"]["n_points_raw"] == 60_000  # it extracted from the whole scan
            # the form still shows what ran
            assert page.locator('[data-testid="param-nominal_radius"] input').input_value() == "10"
            assert page.locator('[data-testid="param-extract"] input').is_checked()

            # the result as a report: diameter with u, form in µm, parameters; no internal fields
            panel = page.locator('[data-testid="result-panel"]')
            diameter = page.locator('[data-testid="report-diameter"]').inner_text()
            assert "mm" in diameter and "u = " in diameter and "µm" in diameter, diameter
            assert float(diameter.split("mm")[0].replace("\u2212", "-")) == pytest.approx(20.0, abs=0.01)
            assert "µm" in page.locator('[data-testid="report-form_range"]').inner_text()
            assert "extract on" in page.locator('[data-testid="result-params"]').inner_text()
            assert "removed_indices" not in panel.inner_text()  # only under "All outputs", folded
            # the view shows the fit's residuals, in µm
            page.wait_for_selector('[data-testid="legend-title"]:has-text("deviation [µm]")')
            page.screenshot(path=str(SHOTS / "run-after-extract.png"))

            # a run that cannot start says why, next to Run, and stores nothing
            page.locator('[data-testid="param-nominal_radius"] input').fill("-3")
            reason = page.locator('[data-testid="run-reason"]')
            reason.wait_for()
            assert "nominal_radius" in reason.inner_text(), reason.inner_text()
            run.click()
            time.sleep(1.5)  # a run that started would show progress by now
            assert reason.is_visible() and "nominal_radius" in reason.inner_text()
            assert len(_results(folder)) == 1
            page.screenshot(path=str(SHOTS / "run-refused.png"))

            # the tidy: the scan is the stored fit's input, so a delete lists the fit and asks
            scan = page.locator('[data-testid="item"]', has_text="sphere scan (20 mm ball)").first
            scan.locator('[data-testid="item-menu"]').click()
            page.locator('.v-overlay--active [data-testid="item-delete"]').click()
            dialog = page.locator('[data-testid="delete-dialog"]')
            dialog.wait_for()
            assert "#1 fit.sphere" in page.locator('[data-testid="delete-results"]').inner_text()
            page.screenshot(path=str(SHOTS / "tidy-confirm.png"))
            page.locator('[data-testid="delete-confirm"]').click()
            page.wait_for_selector('[data-testid="tidy-undo-text"]:has-text("deleted")')
            assert page.locator('[data-testid="item"]', has_text="sphere scan (20 mm ball)").count() == 1  # the fit's
            page.locator('[data-testid="tidy-undo"]').click()
            page.wait_for_selector('[data-testid="tidy-undo-text"]:has-text("undone")')
            assert page.locator('[data-testid="item"]', has_text="sphere scan (20 mm ball)").count() == 2
        finally:
            browser.close()
