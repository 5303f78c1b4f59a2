"""The Photogrammetry page in a headless Chromium on the demo project (issue 16).

The demo has no images: the page opens without an error and says what to do (the
demo's clouds only: its acceptance test, which this page never reads, would add ~30 s).
A folder of two templeRing views (a --data-root of the server) is refused in one line
naming the images, and the app keeps working; eight consecutive templeRing views
(Middlebury, ../shared; skipped where absent) reconstructed sparse-only at 320 px show
the feature and match counts per image and one camera frustum per registered image
(counted by the page from the drawn scene, not from pixels), the others flagged with the
reason, the stages passed marked; a cancelled run stores nothing; the cloud goes to
Inspect. Issue 30: during a run of six views the page counts the images done and the pairs
matched (``matching: 8 of 15 pairs``) and the count moves forwards. Both tests share one served
demo (module fixtures). Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/photogrammetry-gui``).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots, text_of  # noqa: E402
from helpers.paths import SHARED_DATA  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("photogrammetry-gui")
STAGES = ("features", "matching", "mapping", "dense", "scale")


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """``tmp/data`` (the server's data root) with ``ring`` (8 templeRing views) and ``two`` (2 views)."""
    src = sorted((SHARED_DATA / "middlebury_mvs_templering").glob("templeR00*.png"))[:8]
    if len(src) < 8:
        pytest.skip("the templeRing images are absent")
    data = tmp_path_factory.mktemp("pg") / "data"
    for sub, files in (("ring", src), ("two", src[:2])):
        (data / sub).mkdir(parents=True)
        for f in files:
            shutil.copy(f, data / sub / f.name)
    return data


@pytest.fixture(scope="module")
def demo_server(tmp_path_factory, series, demo_project):
    """One served demo for the module's tests (its start costs ~25 s)."""
    from camcmm.gui.process import GuiProcess

    folder = tmp_path_factory.mktemp("pg") / "demo"
    demo_project(folder, acceptance=False)  # its clouds; the finished acceptance test costs ~30 s
    server = GuiProcess(folder, timeout=180, data_roots=(series,))
    yield server, series
    server.stop()


def _text(page, testid: str, pattern: str, timeout: float = 60.0) -> str:
    return text_of(page, testid, pattern, timeout, SHOTS)


def _show(page, folder: Path, n: int) -> None:
    page.locator('[data-testid="pg-folder"] input').fill(str(folder))
    page.click('[data-testid="pg-list"]')
    _text(page, "pg-list-note", rf"^{n} images")
    page.wait_for_function(f"() => document.querySelectorAll('[data-testid=\"pg-image\"] img').length === {n}")


def test_photogrammetry_page_on_the_demo(demo_server):
    server, data = demo_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-photogrammetry"]', timeout=180_000)
            # the demo has no images: an empty state that says what to do, no error
            assert "folder" in page.locator('[data-testid="pg-empty"]').inner_text()
            assert page.locator('[data-testid="pg-error"]').count() == 0
            assert page.locator('[data-testid="footer-error"]').count() == 0
            page.screenshot(path=str(SHOTS / "empty.png"))

            page.locator('[data-testid="pg-param-dense"] input').uncheck()
            page.locator('[data-testid="pg-param-max_image_size"] input').fill("320")
            # two images: refused in one line naming them; the app keeps working
            _show(page, data / "two", 2)
            page.click('[data-testid="pg-run"]')
            err = _text(page, "pg-error", r"templeR0001")
            assert "templeR0002" in err and "\n" not in err.strip()
            assert page.locator('[data-testid="pg-image"][data-status="registered"]').count() == 0
            page.screenshot(path=str(SHOTS / "refused.png"))

            # Cancel: the run stops, says so, and stores nothing
            _show(page, data / "ring", 8)
            page.click('[data-testid="pg-run"]')
            page.click('[data-testid="pg-cancel"]')
            _text(page, "pg-message", r"^cancelled", timeout=60)
            assert page.locator('[data-testid="pg-result"]').count() == 0
            assert page.locator('[data-testid="pg-image"][data-status="registered"]').count() == 0

            # eight views, sparse only, at 320 px
            page.keyboard.press("Control+Enter")  # the page's Run (data-shortcut="run")
            _text(page, "pg-message", r"^done", timeout=150)
            registered = _text(page, "pg-num-registered", r"\d+ of 8")
            n = int(registered.split()[0])
            assert 3 <= n <= 8  # how many the mapper registers is the plugin's matter (5 here at 320 px)
            counts = page.locator('[data-testid="pg-image-counts"]')
            assert counts.count() == 8 and all(
                int(re.match(r"(\d+) features", counts.nth(i).inner_text()).group(1)) > 0 for i in range(8)
            )
            assert page.locator('[data-testid="pg-image"][data-status="registered"]').count() == n
            reasons = page.locator('[data-testid="pg-image-reason"]')
            assert reasons.count() == 8 - n and all(
                "not registered" in reasons.nth(i).inner_text() for i in range(8 - n)
            )
            assert page.locator('[data-testid="pg-note"]').get_attribute("data-cameras") == str(n)
            assert page.locator('[data-testid="pg-error"]').count() == 0
            states = [page.get_attribute(f'[data-testid="pg-stage-{k}"]', "data-state") for k in STAGES]
            assert states == ["done", "done", "done", "todo", "todo"]  # sparse only, no scale
            page.screenshot(path=str(SHOTS / "reconstructed.png"))

            # the cloud to Inspect
            page.click('[data-testid="pg-send-inspect"]')
            page.wait_for_selector('[data-testid="page-inspect"].v-btn--active')
            page.wait_for_selector('[data-testid="display-note"]:has-text("points")', state="attached")
            page.screenshot(path=str(SHOTS / "sent-to-inspect.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)


#: every text the page's progress message and bar show, recorded in the browser as it changes
RECORD = """() => {
  window.__pg_seen = [];
  const look = () => {
    const m = document.querySelector('[data-testid="pg-message"]');
    const p = document.querySelector('[data-testid="pg-progress"]');
    const row = [m ? m.innerText.trim() : '', p ? p.innerText.trim() : ''];
    const last = window.__pg_seen[window.__pg_seen.length - 1];
    if (!last || last[0] !== row[0] || last[1] !== row[1]) window.__pg_seen.push(row);
  };
  new MutationObserver(look).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def test_progress_moves_during_matching(demo_server):
    """Issue 30: matching sat at 11 % for minutes. Six templeRing views at full size (15
    pairs, ~2 s of matching): the page counts the images done and the pairs matched up to
    the totals, the pair count passes through values between 0 and 15, never goes back, and
    the percentage moves with it."""
    server, data = demo_server
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.set_default_timeout(60_000)
            page.goto(server.url)
            page.click('[data-testid="page-photogrammetry"]', timeout=180_000)
            page.locator('[data-testid="pg-param-dense"] input').uncheck()
            page.locator('[data-testid="pg-param-max_image_size"] input').fill("640")
            page.locator('[data-testid="pg-pattern"] input').fill("templeR000[1-6].png")
            _show(page, data / "ring", 6)
            page.evaluate(RECORD)
            page.click('[data-testid="pg-run"]')
            _text(page, "pg-message", r"^done", timeout=120)
            seen = page.evaluate("window.__pg_seen")
            page.screenshot(path=str(SHOTS / "progress-done.png"))
        finally:
            browser.close()
    steps = [(re.match(r"^(\w+): (\d+) of (\d+) (\w+)", m), pct) for m, pct in seen]
    pairs = [(int(m[2]), int(m[3]), pct) for m, pct in steps if m and m[1] == "matching"]
    images = [(int(m[2]), int(m[3])) for m, _ in steps if m and m[1] == "features"]
    assert images and all(total == 6 for _, total in images), seen
    assert pairs and all(total == 15 for _, total, _ in pairs), seen
    done = [k for k, _, _ in pairs]
    assert done == sorted(done) and any(0 < k < 15 for k in done), seen  # it moved, forwards
    percents = [int(pct.split()[0]) for _, _, pct in pairs if pct.split()[0].isdigit()]
    assert percents == sorted(percents) and percents[-1] > percents[0], seen
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
