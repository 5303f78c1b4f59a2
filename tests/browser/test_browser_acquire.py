"""A simulated stereo fringe system acquires a VDI/VDE 2634-2 test through the wizard in a
real headless Chromium (issue #9's "done when", reduced in issue 25 to what a browser shows).

The operator sets the test up, chooses "Measure with: Simulated stereo fringe-projection
system", acquires the first sphere position with its card's Acquire button (rendered,
decoded, triangulated by camera-camera phase matching, thesis ch. 5.2.4, evaluated as an
imported file would be: PASS), then starts "Acquire all", sees it go on and stops it. The
whole test acquired to a PASS (and a baseline error to a FAIL) is the headless
tests/gui/test_wizard_acquire.py; at full size through the stereo system, the benchmark
benchmarks/bench_acquire_all.py. Screenshots: ``$CAMCMM_SCREENSHOTS`` (default
``/tmp/acquire-gui``).
"""

from __future__ import annotations

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
            # "Acquire all" goes on position after position with its progress; Stop ends it
            # after the one being acquired. The whole run to a PASS is the headless
            # tests/gui/test_wizard_acquire.py (and its size the benchmark bench_acquire_all.py)
            page.click('[data-testid="wz-acquire-all"]')
            page.wait_for_selector('[data-testid="wz-counter-sphere"]:has-text("2 of 10")', timeout=120_000)
            page.get_by_role("button", name="Stop").click()
            page.wait_for_function("window.trame.state.get('wz_acquiring_all') === false", timeout=120_000)
            page.wait_for_function(
                "!Object.values(window.trame.state.get('wz_busy') || {}).some(Boolean)", timeout=120_000
            )
            page.screenshot(path=str(SHOTS / "acquire-2-stopped.png"))
            done = counter(page, "sphere")
            assert done.startswith(("2 of 10", "3 of 10")), done
            assert counter(page, "flat").startswith("0 of 6"), counter(page, "flat")
            assert not page.locator('[data-testid="wz-goto-result"]').count()
        finally:
            browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
