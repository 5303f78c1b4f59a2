"""A simulated stereo fringe system acquires a full VDI/VDE 2634-2 test through the
wizard in a real headless Chromium (issue #9's "done when").

The operator sets the test up, chooses "Measure with: Simulated stereo fringe-projection
system", acquires the first sphere position with its card's Acquire button and the
other 22 with "Acquire all"; each position is rendered, decoded and triangulated by
camera-camera phase matching (thesis ch. 5.2.4) and evaluated as an imported file
would be. The verdict is PASS. Screenshots: ``$CAMCMM_SCREENSHOTS`` (default
``/tmp/acquire-gui``).
"""

from __future__ import annotations

import time

import pytest

from helpers.browsing import MARKS, card, counter, launch, server_tracebacks, shots, start_with_simulated_system  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")


SHOTS = shots("acquire-gui")


def test_simulated_fringe_system_acquires_a_part2_test_through_the_wizard(gui_server):
    url, log = gui_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = start_with_simulated_system(browser, url)
            card(page, "sphere-01").locator('[data-testid="card-acquire"]').click()
            page.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("1 of 10")', timeout=60_000)
            assert (
                card(page, "sphere-01").locator('[data-testid="card-verdict"]').inner_text().strip().lower() == "pass"
            )
            page.screenshot(path=str(SHOTS / "acquire-1-first.png"))
            page.click('[data-testid="wz-acquire-all"]')
            deadline = time.monotonic() + 300
            while time.monotonic() < deadline:
                if page.locator('[data-testid="wz-goto-result"]').count():
                    break
                time.sleep(1.0)
            page.screenshot(path=str(SHOTS / "acquire-2-all.png"))
            for test, n in (("sphere", 10), ("ball_bar", 7), ("flat", 6)):
                assert counter(page, test).startswith(f"{n} of {n} "), counter(page, test)
            page.click('[data-testid="wz-goto-result"]')
            verdict = page.locator('[data-testid="wz-verdict"]')
            verdict.wait_for()
            page.screenshot(path=str(SHOTS / "acquire-3-result.png"))
            assert verdict.inner_text().strip() == "PASS"
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
