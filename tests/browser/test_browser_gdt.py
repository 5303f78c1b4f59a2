"""The characteristics panel of the Compare page end to end in a headless Chromium (issue
27's Done-when for the GUI).

On the demo project: the scan of the 20 mm ball against its exact nominal (the demo's
STEP sphere); the sphere's CAD face picked with a click in the view (its type and exact
nominal — centre and diameter — come from the CAD, so nobody types them), a diameter
(±10 µm) and a profile of the surface (0.05 mm) entered, Run: the results table shows each
characteristic with its value, U and tolerance, coloured by its verdict; the view shows a
flag per characteristic in the verdict's colour; the plan exported as YAML has the
issue's keys. Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/gdt-demo``).
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
import yaml

from helpers.browsing import MARKS, choose, launch, server_tracebacks, shots, wait_view  # noqa: E402

pytestmark = MARKS

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")

SHOTS = shots("gdt-demo")
SCAN, CAD = "sphere scan (20 mm ball)", "exact sphere (STEP)"
#: the verdict colours of camcmm.tasks.gdt.VERDICT_COLOURS as the browser writes them
RGB = {"conform": "rgb(26, 152, 80)", "undecided": "rgb(249, 168, 37)", "not conform": "rgb(215, 48, 31)"}


@pytest.fixture
def demo_server(tmp_path, demo_project):
    from camcmm.gui.process import GuiProcess

    demo_project(tmp_path / "demo", acceptance=False)
    server = GuiProcess(tmp_path / "demo")
    yield server.url, server.log
    server.stop()


def test_a_plan_defined_on_the_demo_runs_with_results_coloured_by_verdict_flags_and_a_yaml_export(demo_server):
    url, log = demo_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000}, accept_downloads=True)
            page.set_default_timeout(20_000)
            page.goto(url)
            page.wait_for_selector('[data-testid="project-name"]', timeout=60_000)
            t0 = time.monotonic()
            page.locator('[data-testid="page-compare"]').click()
            page.wait_for_selector('[data-testid="inspect"]')
            choose(page, "ins-measured", SCAN)
            choose(page, "ins-nominal", CAD)
            page.locator('[data-testid="ins-right-gdt"]').click()
            panel = page.locator('[data-testid="gdt-panel"]')
            panel.wait_for()

            # a feature picked on the nominal: the view shows it alone, a click in its middle
            page.locator('[data-testid="gdt-pick"]').click()
            page.wait_for_function(
                "() => document.querySelector('[data-testid=\"ins-note\"]').textContent.includes('click the nominal')"
            )
            time.sleep(0.5)  # the view's image of the nominal alone (picking reads its depth)
            view = page.locator('[data-testid="ins-view"]')
            box = view.bounding_box()
            page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
            nominal = page.locator('[data-testid="gdt-f-nominal"]')
            nominal.wait_for()
            text = nominal.inner_text()  # the face's exact sphere, from the STEP
            assert text == "nominal: CAD face 1: Sphere, centre (0, 0, 0) mm, ⌀ 20 mm", text
            assert page.locator('[data-testid="gdt-f-picked"]').inner_text() == "CAD face 1 (Sphere)"
            page.locator('[data-testid="gdt-f-id"] input').fill("S1")
            page.locator('[data-testid="gdt-f-add"]').click()
            page.wait_for_selector('[data-testid="gdt-feature-S1"]')
            assert "CAD face 1" in page.locator('[data-testid="gdt-feature-S1"]').inner_text()

            # a diameter (the default for a sphere) with its limits, then a profile of the surface
            assert "Diameter" in page.locator('[data-testid="gdt-c-type"]').inner_text()
            page.locator('[data-testid="gdt-c-lower"] input').fill("-0.01")
            page.locator('[data-testid="gdt-c-upper"] input').fill("0.01")
            page.locator('[data-testid="gdt-c-add"]').click()
            page.wait_for_selector('[data-testid="gdt-char-diameter-S1"]')
            choose(page, "gdt-c-type", "Profile of a surface")
            page.wait_for_function(
                "() => document.querySelector('[data-testid=\"gdt-c-id\"] input').value === 'surface-profile-S1'"
            )
            page.locator('[data-testid="gdt-c-tol"] input').fill("0.05")
            page.locator('[data-testid="gdt-c-add"]').click()
            page.wait_for_selector('[data-testid="gdt-char-surface-profile-S1"]')
            assert "−0.010 / +0.010 mm" in page.locator('[data-testid="gdt-char-diameter-S1"]').inner_text()

            # Run: the table, each row in its verdict's colour
            page.locator('[data-testid="gdt-run"]').click()
            t_run = time.monotonic()
            try:
                page.wait_for_selector('[data-testid="gdt-row-surface-profile-S1"]', timeout=60_000)
            except sync_api.TimeoutError:
                page.screenshot(path=str(SHOTS / "timeout.png"))
                err = page.locator('[data-testid="ins-error"]')
                raise AssertionError(f"no results: {err.inner_text() if err.count() else 'no error shown'}") from None
            run_s = time.monotonic() - t_run  # the plugin on the demo's 60 000 points, most of the test
            for cid in ("diameter-S1", "surface-profile-S1"):
                row = page.locator(f'[data-testid="gdt-row-{cid}"]')
                verdict = row.get_attribute("data-verdict")
                assert verdict in ("conform", "undecided", "not conform", "not evaluated"), verdict
                assert page.locator(f'[data-testid="gdt-verdict-{cid}"]').inner_text().strip() == verdict
                if verdict in RGB:
                    chip = page.locator(f'[data-testid="gdt-verdict-{cid}"]')
                    assert chip.evaluate("e => getComputedStyle(e).backgroundColor") == RGB[verdict]
            # the ball's diameter: the scan's 20 mm within its noise, written in mm with its limits
            dia = page.locator('[data-testid="gdt-value-diameter-S1"]').inner_text()
            m = re.fullmatch(r"(\d+\.\d+) mm", dia.strip())
            assert m and abs(float(m.group(1)) - 20.0) < 0.005, dia
            assert page.locator('[data-testid="gdt-row-diameter-S1"]').get_attribute("data-verdict") == "conform"
            assert "µm" in page.locator('[data-testid="gdt-value-surface-profile-S1"]').inner_text()
            assert "Best fit to the nominal" in page.locator('[data-testid="gdt-result-note"]').inner_text()

            # the flags in the view: a box per characteristic in its verdict's colour (green: conform)
            png, px = wait_view(view, lambda q: q["green"] > 300, timeout=15)
            (SHOTS / "flags-view.png").write_bytes(png)
            assert px["green"] > 300, px
            page.screenshot(path=str(SHOTS / "panel.png"))

            # the plan as YAML: the keys, the sphere's fitted nominal, both characteristics
            page.locator('[data-testid="gdt-export"]').click()
            link = page.locator('[data-testid="gdt-yaml-link"]')
            link.wait_for()
            with page.expect_download() as dl:
                link.click()
            doc = yaml.safe_load(Path(dl.value.path()).read_text())
            assert list(doc) == ["unit", "band", "features", "datums", "characteristics"]
            assert doc["unit"] == "mm" and doc["features"] == {"S1": {"type": "face", "cad": 1}}
            assert doc["characteristics"] == [
                {"id": "diameter-S1", "type": "diameter", "feature": "S1", "lower": -0.01, "upper": 0.01},
                {"id": "surface-profile-S1", "type": "surface-profile", "feature": "S1", "tolerance": 0.05},
            ]
            elapsed = time.monotonic() - t0
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
    assert not [line for line in log if "camcmm GUI error" in line]
    print(f"characteristics on the demo in the browser: {elapsed:.1f} s, of which the run {run_s:.1f} s")
