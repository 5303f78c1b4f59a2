"""The Uncertainty page end to end in a real headless Chromium (Playwright).

Opens the page, edits a cell of the shipped GUM budget (thesis table 3.2, x) and sees
the combined uncertainty follow; enters a row as a rectangular half-width and sees the
conversion (u = a/√3) in the table and in u_c; every control has a tooltip. Runs a small
Monte Carlo study of the default system (the plugin's declared fields, no YAML box) with
progress, and sees the table, the contribution and convergence charts and the measuring
volume's distortion arrows in the 3D view; the exports are offered.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/uncertainty-gui``).
"""

from __future__ import annotations

import io
import math
import re
import time

import numpy as np
import pytest

from helpers.browsing import MARKS, choose, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")

SHOTS = shots("uncertainty-gui")


def coloured_pixels(png: bytes) -> int:
    from PIL import Image

    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV")).astype(float)
    return int(((hsv[..., 1] > 90) & (hsv[..., 2] > 60)).sum())


def number(text: str) -> float:
    return float(re.search(r"[-+]?\d+(\.\d+)?(e[-+]?\d+)?", text.replace("u", "", 1).split("=")[1]).group(0))


def two(x: float) -> float:
    """``x`` to two significant digits, as the page writes u_c and U (GUM 7.2.6, camcmm.numbers)."""
    return float(f"{x:.2g}")


def wait_number(locator, expect: float, seconds: float = 10) -> float:
    deadline = time.monotonic() + seconds
    while abs(number(locator.inner_text()) - expect) > 1e-9 and time.monotonic() < deadline:
        time.sleep(0.2)
    return number(locator.inner_text())


#: every control of the page without a tooltip (its own title or one on the control around it)
UNTITLED = """root => [...root.querySelectorAll('input, textarea, button, [role=button], [role=tab]')]
    .filter(e => e.offsetParent !== null && e.type !== 'hidden')
    .filter(e => !(e.closest('[title]') && root.contains(e.closest('[title]'))))
    .map(e => e.outerHTML.slice(0, 120))"""


def test_uncertainty_page_in_the_browser(gui_server):
    url, log = gui_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1500, "height": 1000})
            page.set_default_timeout(60_000)  # a loaded machine (six helpers, load ~13) needs more than 30 s
            page.goto(url)
            page.click('[data-testid="page-uncertainty"]')
            combined = page.locator('[data-testid="unc-b-combined"]')
            combined.wait_for()
            # thesis table 3.2, x: sqrt(3.1² + 1.7² + 9.1² + 1.5² + 2.1²) = 10.08 µm, written "10"
            assert number(combined.inner_text()) == two(math.sqrt(3.1**2 + 1.7**2 + 9.1**2 + 1.5**2 + 2.1**2))
            cell = page.locator('[data-testid="unc-b-value-2"] input')
            cell.fill("0")
            cell.press("Enter")
            expect = two(math.sqrt(3.1**2 + 1.7**2 + 1.5**2 + 2.1**2))  # 4.377 -> 4.4
            assert wait_number(combined, expect) == expect
            # the rotation row as a rectangular half-width a = 9.1 µm: u = 9.1/√3
            choose(page, "unc-b-kind-2", "a (half-width)")
            cell.fill("9.1")
            cell.press("Enter")
            expect = two(math.sqrt(3.1**2 + 1.7**2 + 9.1**2 / 3 + 1.5**2 + 2.1**2))  # 6.84 -> 6.8
            assert wait_number(combined, expect) == expect
            conversion = page.locator('[data-testid="unc-b-conversion-2"]').inner_text()
            assert conversion == "a = 9.1 µm, rectangular → u = a/√3 = 5.254 µm"
            assert page.locator('[data-testid="unc-b-uout-2"]').inner_text() == "5.254"
            assert "table 3.2" in page.locator('[data-testid="unc-b-source"]').inner_text()
            assert page.locator('[data-testid="uncertainty"]').evaluate(UNTITLED) == []
            page.wait_for_selector('[data-testid="unc-b-chart"] .main-svg')
            page.screenshot(path=str(SHOTS / "budget.png"), full_page=True)
            page.click('[data-testid="unc-b-store"]')
            page.wait_for_selector('[data-testid="unc-b-links"] a')

            page.click('[data-testid="unc-tab-montecarlo"]')
            assert page.locator('[data-testid="unc-mc"] textarea').count() == 0  # no YAML box
            assert page.locator('[data-testid="unc-mc-baseline"] input').input_value() == "199.35"
            assert page.locator('[data-testid="unc-mc-u_rotation"] input').input_value() == "184, 152, 71"
            assert "9.1 µm" in page.locator('[data-testid="unc-mc-source"]').inner_text()
            assert page.locator('[data-testid="unc-mc-run"]').get_attribute("data-shortcut") == "run"
            assert page.locator('[data-testid="uncertainty"]').evaluate(UNTITLED) == []
            it = page.locator('[data-testid="unc-mc-iterations"] input')
            it.fill("300")
            it.press("Control+Enter")  # the shell's run shortcut clicks the Run button (data-shortcut="run")
            page.wait_for_selector('[data-testid="unc-mc-progress"]')
            page.wait_for_selector('[data-testid="unc-mc-table"]', timeout=120_000)
            assert "done: 300 iterations" in page.locator('[data-testid="unc-mc-message"]').inner_text()
            rows = page.locator('[data-testid="unc-mc-table"] tbody tr')
            assert rows.count() >= 7  # five factors of the shipped system + u_c and U (k, ν_eff in their cells)
            page.wait_for_selector('[data-testid="unc-mc-chart"] .main-svg')
            page.wait_for_selector('[data-testid="unc-mc-convergence"] .main-svg .scatterlayer .trace')
            assert "magnified" in page.locator('[data-testid="unc-mc-map-note"]').inner_text()
            view = page.locator('[data-testid="unc-mc-view"]')
            view.scroll_into_view_if_needed()
            deadline = time.monotonic() + 20
            while True:
                png = view.screenshot()
                if coloured_pixels(png) > 500 or time.monotonic() > deadline:
                    break
                time.sleep(0.5)
            assert coloured_pixels(png) > 500, "no coloured arrows in the 3D view"
            links = page.locator('[data-testid="unc-mc-links"] a')
            assert links.count() >= 4
            page.screenshot(path=str(SHOTS / "montecarlo.png"), full_page=True)
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
