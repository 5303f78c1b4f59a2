"""The Calibration page end to end in a real headless Chromium (Playwright).

Fills the board form (the square size required before a run, the board's drawing, the
inner corners found on the first image before calibrating: 54 of 54, and 0 of 70 for a
board counted by its squares), calibrates the left camera of OpenCV's stereo sample from
a folder on the server and sees the image list (13 images, board found in all), the selected image with the
detected corners drawn in colour, the per-view error chart, the numbers (RMS as the
plugin gives it) and the projection-uncertainty heat map; changes the working distance;
lets a new measuring system use the calibration; then calibrates the pair and sees the
baseline and the rectified pair with epipolar lines. Screenshots go to
``$CAMCMM_SCREENSHOTS`` (default ``/tmp/calibration-gui``).
"""

from __future__ import annotations

import base64
import io
import time
from pathlib import Path

import numpy as np
import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
pytest.importorskip("PIL", reason="Pillow is needed to look at the screenshots")

DATA = Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard"
SHOTS = shots("calibration-gui")


def coloured_pixels(png: bytes) -> int:
    from PIL import Image

    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV")).astype(float)
    return int(((hsv[..., 1] > 90) & (hsv[..., 2] > 60)).sum())


def _data_url_png(page, selector: str) -> bytes:
    src = page.locator(selector).get_attribute("src")
    assert src and src.startswith("data:image/"), src
    return base64.b64decode(src.split(",", 1)[1])


def _wait_text(locator, wanted: str, timeout: float = 120.0) -> str:
    deadline = time.monotonic() + timeout
    locator.wait_for(timeout=1000 * timeout)  # a loaded machine may take longer than the default 30 s
    text = ""
    while time.monotonic() < deadline:
        text = locator.inner_text()
        if wanted in text:
            return text
        time.sleep(0.25)
    raise AssertionError(f"{wanted!r} did not appear; last text {text!r}")


def check_calibration_page(url: str, shots: Path = SHOTS) -> None:
    """The browser part, on a GUI already serving a fresh project at ``url``."""
    shots.mkdir(parents=True, exist_ok=True)
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(30_000)
            page.goto(url)
            page.click('[data-testid="page-calibration"]')
            page.wait_for_selector('[data-testid="cal-inputs"]')
            page.click('[data-testid="cal-source-folder"]')
            page.locator('[data-testid="cal-folder"] input').fill(str(DATA))
            page.locator('[data-testid="cal-left-pattern"] input').fill("left*")
            page.screenshot(path=str(shots / "inputs.png"))
            # the board form: no square size, no run; the board looked for in the first image
            cols = page.locator('[data-testid="cal-board-cols"] input')
            rows = page.locator('[data-testid="cal-board-rows"] input')
            square = page.locator('[data-testid="cal-board-square"] input')
            assert square.input_value() == ""
            page.click('[data-testid="cal-run"]')
            err = _wait_text(page.locator('[data-testid="cal-error"]'), "square size")
            assert "\n" not in err.strip()
            check = page.locator('[data-testid="cal-board-check-text"]')
            _wait_text(check, "found 54 of 54 inner corners on left01.jpg", timeout=30)
            drawing = page.locator('[data-testid="cal-board-drawing"]')
            assert "required" in base64.b64decode(drawing.get_attribute("src").split(",", 1)[1]).decode()
            page.screenshot(path=str(shots / "board-required.png"))
            # a wrong board (the squares counted): the check says so before any run (the run's
            # refusal of it is tested headless, tests/gui/test_calibration_gui.py)
            cols.fill("10")
            rows.fill("7")
            _wait_text(check, "found 0 of 70", timeout=30)
            square.fill("25")
            _wait_text(page.locator('[data-testid="cal-board-code"]'), "chessboard:10x7:25")
            assert not page.locator('[data-testid="cal-error"]').count()  # the size given: its refusal went
            page.screenshot(path=str(shots / "bad-board.png"))
            cols.fill("9")
            rows.fill("6")
            _wait_text(check, "found 54 of 54", timeout=30)
            svg = base64.b64decode(drawing.get_attribute("src").split(",", 1)[1]).decode()
            assert 'data-points="54"' in svg and "square size 25 mm" in svg
            page.screenshot(path=str(shots / "board.png"))
            page.click('[data-testid="cal-run"]')
            _wait_text(page.locator('[data-testid="cal-message"]'), "done")
            rows = page.locator('[data-testid="cal-image-row"]')
            rows.first.wait_for()
            assert rows.count() == 13
            assert page.locator('[data-testid="cal-image-row"][data-status="used"]').count() == 13
            assert "RMS 0.19" in page.locator('[data-testid="cal-rms"]').inner_text()
            # the detected corners drawn over the image: OpenCV's coloured rows
            page.wait_for_selector('[data-testid="cal-overlay-img"]')
            assert coloured_pixels(_data_url_png(page, '[data-testid="cal-overlay-img"]')) > 500
            rows.nth(4).click()
            _wait_text(page.locator('[data-testid="cal-overlay-note"]'), "left05.jpg")
            page.wait_for_selector('[data-testid="cal-chart"] .main-svg .barlayer .trace')
            page.wait_for_selector('[data-testid="cal-map"] .main-svg')
            assert "σ" in page.locator('[data-testid="cal-map-note"]').inner_text()
            assert page.locator('[data-testid="cal-num-fx"]').count() == 1
            page.screenshot(path=str(shots / "camera.png"))
            dist = page.locator('[data-testid="cal-distance"] input')
            dist.fill("800")
            dist.press("Enter")
            _wait_text(page.locator('[data-testid="cal-map"]'), "z = 800 mm", timeout=20)
            page.locator('[data-testid="cal-heatmap"]').screenshot(path=str(shots / "heatmap-800mm.png"))
            # use it for a new measuring system
            page.locator('[data-testid="cal-system-name"] input').fill("left camera rig")
            page.click('[data-testid="cal-use"]')
            _wait_text(page.locator('[data-testid="cal-systems"]'), "left camera rig", timeout=20)
            assert page.locator('[data-testid="cal-links"] a').count() >= 5
            page.screenshot(path=str(shots / "camera-saved.png"))

            # the stereo pair
            page.click('[data-testid="cal-mode-stereo"]')
            page.locator('[data-testid="cal-right-pattern"] input').fill("right*")
            page.click('[data-testid="cal-run"]')
            _wait_text(page.locator('[data-testid="cal-baseline"]'), "mm")
            base = float(page.locator('[data-testid="cal-baseline"]').inner_text().split()[1])
            assert 75 < base < 95  # OpenCV's sample rig: about 83 mm for 25-mm squares
            page.wait_for_selector('[data-testid="cal-rectified-img"]')
            assert coloured_pixels(_data_url_png(page, '[data-testid="cal-rectified-img"]')) > 500
            assert "rectified" in page.locator('[data-testid="cal-rectified-note"]').inner_text()
            page.click('[data-testid="cal-side-right"]')
            _wait_text(page.locator('[data-testid="cal-overlay-note"]'), "right")
            _wait_text(page.locator('[data-testid="cal-map"]'), "right camera", timeout=20)
            page.screenshot(path=str(shots / "stereo.png"))
            page.set_viewport_size({"width": 1600, "height": 2700})  # the whole panel, which scrolls inside
            time.sleep(1.0)
            page.screenshot(path=str(shots / "stereo-whole.png"))
            page.set_viewport_size({"width": 1600, "height": 1000})

            # uploaded images become the project's image items, chosen for the calibration
            page.click('[data-testid="cal-mode-camera"]')
            page.click('[data-testid="cal-source-upload"]')
            page.set_input_files(
                '[data-testid="cal-upload-left"] input', [str(p) for p in sorted(DATA.glob("left0[1-4]*"))]
            )
            page.wait_for_selector('[data-testid="cal-left-items"]')
            _wait_text(page.locator('[data-testid="cal-left-items"]'), "more", timeout=30)
            page.click('[data-testid="cal-run"]')
            _wait_text(page.locator('[data-testid="cal-message"]'), "result #3")
            assert page.locator('[data-testid="cal-image-row"]').count() == 4
            page.screenshot(path=str(shots / "upload.png"))
        finally:
            browser.close()


def test_calibration_page_in_the_browser(tmp_path):
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    try:  # the board images' folder is a data root: the page may read it
        server = GuiProcess(tmp_path / "proj", data_roots=(DATA,))
    except CamcmmError as exc:
        pytest.fail(str(exc))
    try:
        check_calibration_page(server.url)
    finally:
        server.stop()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
