"""Two refusals of issue 15 driven in headless Chromium on the demo project.

1. Sphere extraction with a wrong nominal radius: NIST's SPH101.xyz (a TLS scan of a
   50 mm-radius sphere, in metres) uploaded through the toolbar and, in the unit
   dialog, deliberately answered "mm" (the user's mistake). The sphere fit with
   extract on and nominal radius 50 mm must refuse in one line where the Inspect page
   shows a failed run (``run-status``), with a hint at the unit, and store no result.
   The same file imported as "m" then fits a sphere of radius ≈ 50 mm.
2. The acceptance setup's artefact rules before Start: a 200 mm measuring volume makes
   the demo's 49.944 mm ball bar shorter than 0.3 L0; the alert lists the rule, Start
   is disabled until "Start anyway" is on; 90 mm again clears the alert. The demo's
   finished test is described as finished, not running.

Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``<tmp>/refusals``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

from camcmm.errors import CamcmmError  # noqa: E402
from camcmm.gui.process import GuiProcess  # noqa: E402
from camcmm.project import Project  # noqa: E402

SHOTS = shots("refusals")
SPH101 = Path(__file__).parents[1] / "data" / "nist_spheres" / "SPH101.xyz"


def _server(folder: Path, acceptance: bool, demo_project):
    demo_project(folder, acceptance=acceptance)
    try:
        return GuiProcess(folder)
    except CamcmmError as exc:
        pytest.fail(str(exc))


@pytest.fixture
def demo(tmp_path, demo_project):
    server = _server(tmp_path / "demo", acceptance=False, demo_project=demo_project)
    yield server, tmp_path / "demo"
    server.stop()


@pytest.fixture
def demo_with_test(tmp_path, demo_project):
    server = _server(tmp_path / "demo", acceptance=True, demo_project=demo_project)
    yield server
    server.stop()


def _results(folder: Path) -> list[dict]:
    with Project.open(folder) as p:  # a second reader beside the server (WAL)
        return p.results()


def _import_as(page, path: Path, unit: str, copy: Path) -> str:
    """Upload ``path`` (as ``copy``, so each import has its own name) through the
    toolbar and answer the unit dialog with ``unit``; returns the item's name."""
    copy.write_bytes(path.read_bytes())
    page.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(copy))
    page.wait_for_selector('[data-testid="unit-dialog"]', state="visible", timeout=60_000)
    reason = page.locator('[data-testid="unit-reason"]').inner_text()
    assert f"{copy.name} has no unit" in reason, reason
    page.locator(f'[data-testid="unit-choice-{unit}"] input').click()
    page.locator('[data-testid="unit-accept"]').click()
    page.wait_for_selector(f'[data-testid="item"]:has-text("{copy.name}")', timeout=60_000)
    page.wait_for_selector('[data-testid="unit-dialog"]', state="hidden")
    return copy.name


def _sphere_form(page, item: str) -> None:
    """The sphere fit on ``item``, nominal radius 50 mm, extract on."""
    page.locator('[data-plugin-id="fit.sphere"]').click()
    page.wait_for_selector('[data-testid="param-extract"]')
    picker = page.locator('[data-testid="input-cloud"]')
    if item not in picker.inner_text():
        picker.click()
        page.locator(".v-overlay--active .v-list-item", has_text=item).first.click()
    assert item in picker.inner_text(), picker.inner_text()
    page.locator('[data-testid="param-nominal_radius"] input').fill("50")
    extract = page.locator('[data-testid="param-extract"] input')
    if not extract.is_checked():
        extract.click()
    assert extract.is_checked()


def _result_count(page) -> str:
    return page.locator('[data-testid="results"] .v-list-subheader').inner_text()


def test_sphere_extraction_with_a_wrong_unit_is_refused_and_the_right_unit_fits(demo, tmp_path):
    server, folder = demo
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.set_default_timeout(30_000)
            page.goto(server.url)
            page.wait_for_selector('[data-plugin-id="fit.sphere"]', timeout=120_000)

            # the user's mistake: the metre file read as mm
            name = _import_as(page, SPH101, "mm", tmp_path / "SPH101_as_mm.xyz")
            _sphere_form(page, name)
            count_before = _result_count(page)
            assert "(0)" in count_before, count_before
            page.locator('[data-testid="run-button"]').click()
            status = page.locator('[data-testid="run-status"]')
            page.wait_for_selector('[data-testid="run-status"]:has-text("no sphere of radius 50 mm")', timeout=90_000)
            line = status.inner_text()
            assert "\n" not in line.strip(), line
            assert "6474 points" in line and "metres read as mm" in line, line
            # in the error colour, the reason first (the plugin's name would fill the short line)
            assert "text-error" in (status.get_attribute("class") or ""), status.get_attribute("class")
            assert line.startswith("sphere extraction: no sphere"), line
            assert page.locator('[data-testid="progress"]').inner_text().startswith("failed"), "run not marked failed"
            page.screenshot(path=str(SHOTS / "extract-refused.png"))
            # nothing stored, nothing shown as a result
            assert _results(folder) == []
            assert _result_count(page) == count_before
            assert not page.locator('[data-testid="report-diameter"]').is_visible()

            # the same file in metres: the fit finds the 50 mm sphere
            name = _import_as(page, SPH101, "m", tmp_path / "SPH101_in_m.xyz")
            _sphere_form(page, name)
            page.locator('[data-testid="run-button"]').click()
            page.wait_for_selector('[data-testid="report-diameter"]', timeout=90_000)
            page.wait_for_selector('[data-testid="run-status"]:has-text("done")')
            (stored,) = _results(folder)
            assert stored["plugin"] == "fit.sphere" and stored["params"]["extract"] is True
            assert stored["outputs"]["radius"] == pytest.approx(50.0, abs=0.5)  # TLS scan, nominal 50 mm
            diameter = page.locator('[data-testid="report-diameter"]').inner_text()
            assert float(diameter.split("mm")[0].replace("\u2212", "-")) == pytest.approx(100.0, abs=1.0), diameter
            page.wait_for_selector('[data-testid="results"] .v-list-subheader:has-text("(1)")')
            page.screenshot(path=str(SHOTS / "extract-in-m.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)[0]


def test_acceptance_setup_shows_broken_artefact_rules_before_start(demo_with_test):
    server = demo_with_test
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.set_default_timeout(30_000)
            page.goto(server.url)
            page.wait_for_selector('[data-testid="page-acceptance"]', timeout=120_000)
            page.locator('[data-testid="page-acceptance"]').click()
            page.wait_for_selector('[data-testid="wizard"]')
            page.locator('[data-testid="wz-tab-setup"]').click()

            # the demo's test is finished and said to be
            status = page.locator('[data-testid="wz-test-status"]')
            status.wait_for()
            text = status.inner_text()
            assert "finished" in text.lower() and "running" not in text.lower(), text
            # the demo's own test passes its artefact rules
            assert not page.locator('[data-testid="wz-artefact-warnings"]').is_visible()

            page.locator('[data-testid="wz-unlock"]').click()
            page.locator('[data-testid="wz-supersede-confirm"]').click()  # over a finished test: asked first
            start = page.locator('[data-testid="wz-start"]')
            for axis in "xyz":
                page.locator(f'[data-testid="wz-volume-{axis}"] input').fill("90")
            page.wait_for_timeout(500)
            assert not page.locator('[data-testid="wz-artefact-warnings"]').is_visible()
            assert start.is_enabled()

            # a 200 mm cube: L0 = 346 mm, 0.3 L0 = 104 mm > the 49.944 mm ball bar
            for axis in "xyz":
                page.locator(f'[data-testid="wz-volume-{axis}"] input').fill("200")
            warnings = page.locator('[data-testid="wz-artefact-warnings"]')
            warnings.wait_for()
            listed = warnings.inner_text()
            assert "ball bar: length 49.94 mm is below 0.3 L0" in listed, listed
            assert start.is_disabled()
            warnings.scroll_into_view_if_needed()  # below the fold at 900 px, right above Start
            page.screenshot(path=str(SHOTS / "setup-rules-broken.png"))
            page.locator('[data-testid="wz-confirm-violations"] input').click()
            page.wait_for_function("!document.querySelector('[data-testid=\"wz-start\"]').disabled")
            assert start.is_enabled()

            # back to 90 mm: the alert goes
            for axis in "xyz":
                page.locator(f'[data-testid="wz-volume-{axis}"] input').fill("90")
            warnings.wait_for(state="hidden")
            assert start.is_enabled()
            page.screenshot(path=str(SHOTS / "setup-rules-kept.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)[0]
