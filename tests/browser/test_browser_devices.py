"""The Devices page and the projector page in a real headless Chromium.

The operator adds the browser pattern projector, loads the shipped fringe sequence,
opens the projector page (``/projector``) in a second window, adds a simulated camera
and runs the fringe sequence capture: each capture waits for the projector page to
acknowledge the pattern it shows, so the run completes only if the page keeps in step.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/devices-gui``).
"""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

from helpers.browsing import MARKS, at, choose, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")

SHOTS = shots("devices-gui")


def test_devices_page_and_projector_page_in_step(gui_server):
    url, log = gui_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1500, "height": 950})
            page.set_default_timeout(30_000)
            page.goto(url)
            page.click('[data-testid="page-devices"]')
            choose(page, "dev-add-plugin", "Pattern projector (browser window)")
            page.click('[data-testid="dev-add"]')
            page.wait_for_selector('[data-testid="dev-state-projector"]')
            page.click('[data-testid="dev-load-patterns"]')
            page.wait_for_selector('[data-testid="dev-projector-panel"] >> text=23 patterns loaded')
            # its own browser, as a window on the projector's display: both stay in the
            # foreground (a background tab's timers are throttled to 1 Hz)
            projector_browser = launch(p)
            proj = projector_browser.new_page(viewport={"width": 640, "height": 400})
            proj.goto(at(url, "/projector"))  # its own browser: the token in the address
            choose(page, "dev-add-plugin", "Simulated camera")
            page.wait_for_selector('[data-testid="dev-add-renderer"]')  # the camera's own form
            page.click('[data-testid="dev-add"]')
            page.wait_for_selector('[data-testid="dev-state-sim-camera"]')
            page.click('[data-testid="dev-grab"]')
            page.wait_for_selector('[data-testid="dev-live-image"]')
            # a click right after typing reaches the server (the field's hint folds away on blur)
            page.fill('[data-testid="dev-setting-timeout_s"] input', "3")  # a field with a hint
            page.click('[data-testid="dev-apply"]')
            page.locator(
                '[data-testid="footer-info"]', has_text="sim-camera' on simulated: settings applied"
            ).wait_for()  # the page's note, in the footer
            choose(page, "dev-seq-plugin", "Fringe sequence capture")
            page.click('[data-testid="dev-seq-start"]')
            state = page.locator('[data-testid="dev-seq-state"]')
            state.wait_for()
            deadline = time.monotonic() + 60
            while "done" not in state.inner_text() and time.monotonic() < deadline:
                if "paused" in state.inner_text():
                    break
                time.sleep(0.3)
            text = state.inner_text()
            page.screenshot(path=str(SHOTS / "devices.png"), full_page=True)
            assert "done" in text and "23 frames" in text, text
            # the projector page shows a pattern (the last one is blanked: show pattern 2)
            page.click('[data-testid="dev-item-projector"]')
            page.fill('[data-testid="dev-pattern"] input', "2")
            page.click('[data-testid="dev-show-pattern"]')
            from PIL import Image

            deadline = time.monotonic() + 10
            while True:
                png = proj.screenshot()
                grey = np.asarray(Image.open(io.BytesIO(png)).convert("L"), float)
                if grey.std() > 40 or time.monotonic() > deadline:
                    break
                time.sleep(0.3)
            proj.screenshot(path=str(SHOTS / "projector.png"))
            page.screenshot(path=str(SHOTS / "devices-show.png"), full_page=True)
            assert grey.std() > 40, "the projector page shows no fringes"
            assert "fault" not in page.locator('[data-testid="dev-state-projector"]').inner_text()
        finally:
            browser.close()
            if "projector_browser" in locals():
                projector_browser.close()
    assert not server_tracebacks(log), server_tracebacks(log)
