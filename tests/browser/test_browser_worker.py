"""The server survives a negative-focal-length calibration through the GUI (issue 13's
"done when"), in a real headless Chromium against ``camcmm.gui`` in a child process.

The wizard's simulated fringe system measures with its calibration's focal length
multiplied by (1 + focal_error); focal_error = -2 gives fx < 0, which once crashed
OpenCV's native code and with it the server for every operator. The page has no field
for it, but a client can write any state, as an attacker's script would: here the test
does so through trame's client API. The page must show one line naming the value, the
server must keep serving (a second measurement, a fresh page load).
"""

from __future__ import annotations

import pytest

from helpers.browsing import MARKS, card, counter, launch, server_tracebacks, shots, start_with_simulated_system  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")


SHOTS = shots("worker-gui")
PARAMS = "{method: 'projector', preset: 'camera_projector'%s}"


def test_negative_focal_length_through_the_wizard_leaves_the_server_serving(gui_server):
    url, log = gui_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = start_with_simulated_system(browser, url)
            page.evaluate("window.trame.state.set('wz_source_params', %s)" % (PARAMS % ", focal_error: -2"))
            card(page, "sphere-01").locator('[data-testid="card-acquire"]').click()
            # the page's own error, in the footer (no toast floats over the page)
            alert = page.locator('[data-testid="footer-error"]', has_text="focal_error")
            alert.wait_for(timeout=120_000)
            text = " ".join(alert.inner_text().split())
            page.screenshot(path=str(SHOTS / "worker-1-negative-focal.png"))
            # refused by the declaration (a relative error <= -1 makes fx <= 0); the native crash
            # itself, with every check switched off, is tests/test_worker_gui.py's second test
            assert "focal_error" in text and "-2" in text, text
            # the same server measures the position once the calibration is sound
            page.evaluate("window.trame.state.set('wz_source_params', %s)" % (PARAMS % ""))
            card(page, "sphere-01").locator('[data-testid="card-acquire"]').click()
            page.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("1 of 10")', timeout=120_000)
            assert counter(page, "sphere").startswith("1 of 10")
            page.screenshot(path=str(SHOTS / "worker-2-next-measurement.png"))
            fresh = browser.new_page()  # a fresh page load still answers
            fresh.goto(url)
            fresh.wait_for_selector('[data-testid="page-acceptance"]')
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
