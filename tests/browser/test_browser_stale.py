"""Nothing stale on screen (issue 30), in a real headless Chromium at 1366×768.

The shared 3-D view shows the page shown: an item imported on Inspect is not on the
Acceptance page's view (which says what would appear there) and is back on Inspect; a
Devices refusal to move an unhomed stage offers "Move without homing" (no code keyword)
and goes once the stage is homed, from the alert and the footer; an item hidden in a
second tab (a session of its own) leaves the first tab's view, which says why.
The logic is tested headless in tests/gui/test_stale_view.py; this checks the widgets.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/stale-gui``).
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.browsing import MARKS, choose, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("stale-gui")
SIZE = {"width": 1366, "height": 768}


def _open(browser, url: str, wait: bool = True):
    """A tab of its own (its own cookies: a session of its own); ``wait``: until it is drawn."""
    page = browser.new_context(viewport=SIZE).new_page()
    page.set_default_timeout(60_000)  # a second tab's session may have to start its process
    page.goto(url, timeout=120_000, wait_until="load" if wait else "commit")
    if wait:
        page.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
    return page


def test_the_view_and_the_messages_follow_the_page_and_the_other_tab(gui_server, tmp_path):
    from camcmm.io import write
    from camcmm.model import PointCloud

    url, log = gui_server
    rng = np.random.default_rng(3)
    ball = tmp_path / "ball.ply"
    write(PointCloud(rng.normal(size=(2000, 3))), ball)
    hint, note = '[data-testid="view-hint"]', '[data-testid="display-note"]'
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            a = _open(browser, url)
            b = _open(browser, url, wait=False)  # the second tab loads while the first one works
            a.locator(hint, has_text="No item shown").wait_for()  # an empty project's view says so
            a.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(ball))
            a.locator(note, has_text="showing all 2 000 points").wait_for(state="attached")
            assert not a.locator(hint).is_visible()

            # Acceptance: its own (empty) view, not Inspect's item; back on Inspect: the item
            a.click('[data-testid="page-acceptance"]')
            a.locator(hint, has_text="No deviations shown yet").wait_for()
            assert a.locator(note).inner_text().strip() == ""
            a.screenshot(path=str(SHOTS / "acceptance-empty-view.png"))
            a.click('[data-testid="page-inspect"]')
            a.locator(note, has_text="showing all 2 000 points").wait_for(state="attached")
            a.locator(hint).wait_for(state="detached")

            # Devices: a move before homing is refused with a button, and the refusal goes once homed
            a.click('[data-testid="page-devices"]')
            choose(a, "dev-add-plugin", "Simulated stage (in process)")
            a.click('[data-testid="dev-add"]')
            a.wait_for_selector('[data-testid="dev-state-sim-stage"]')
            a.click('[data-testid="dev-move-abs"]')
            a.locator('[data-testid="dev-error"]', has_text="not homed").wait_for()
            a.locator('[data-testid="dev-move-unhomed"]').wait_for()
            assert "allow_unhomed" not in a.locator("body").inner_text()
            a.screenshot(path=str(SHOTS / "devices-not-homed.png"))
            a.click('[data-testid="dev-home"]')
            a.locator('[data-testid="dev-error"]').wait_for(state="detached")
            assert not a.locator('[data-testid="footer-error"]').is_visible()
            assert not a.locator('[data-testid="dev-move-unhomed"]').is_visible()

            # a second tab hides the item the first one shows: it leaves the first tab's view
            a.click('[data-testid="page-inspect"]')
            b.wait_for_selector('[data-testid="project-name"]', timeout=120_000)
            b.locator('[data-testid="item"]', has_text="ball.ply").locator('[data-testid="item-menu"]').click()
            b.locator('.v-overlay--active [data-testid="item-hide"]').click()
            a.locator(hint, has_text="hidden or removed in another window").wait_for(timeout=15_000)
            assert a.locator(note).inner_text().strip() == ""
            a.screenshot(path=str(SHOTS / "inspect-item-hidden-elsewhere.png"))
        finally:
            browser.close()
    assert not server_tracebacks(log)
