"""What the browser tests share: Debian's Chromium with the launch flags that work on
these machines (never ``playwright install``: it downloads), the markers that skip a
test when there is no Chromium, where screenshots go, and picking from a Vuetify menu."""

from __future__ import annotations

import io
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = "/usr/bin/chromium"
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
#: every browser test: marked, skipped without Chromium, and in one xdist group, so that under
#: ``pytest -n 2 --dist loadgroup`` the browser tests run one after another on one worker (two
#: Chromiums and their GUI servers at once overload two cores into timeouts) while the other
#: worker takes the headless tests
MARKS = [
    pytest.mark.browser,
    pytest.mark.xdist_group("browser"),
    pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=f"{CHROMIUM} is absent: no browser to drive"),
]


def shots(name: str) -> Path:
    """The screenshot folder: ``$CAMCMM_SCREENSHOTS`` or ``<tmp>/<name>`` (made)."""
    folder = Path(os.environ.get("CAMCMM_SCREENSHOTS", Path(tempfile.gettempdir()) / name))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def launch(playwright):
    return playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)


def at(url: str, path: str) -> str:
    """``path`` on the server of ``url`` (as the GUI printed it, ``http://H:P/?token=T``),
    keeping the token: ``at(url, "/projector")`` -> ``http://H:P/projector?token=T``."""
    from urllib.parse import urlsplit, urlunsplit

    u = urlsplit(url)
    return urlunsplit((u.scheme, u.netloc, "/" + path.lstrip("/"), u.query, ""))


def choose(page, testid: str, option: str) -> None:
    """Open the select ``testid`` and click the option with that text (in the open menu
    only: closed menus stay in the DOM)."""
    page.click(f'[data-testid="{testid}"]')
    page.locator(".v-overlay--active .v-list-item", has_text=option).first.click()
    # the select shows the choice once the server's state came back (not at the click)
    page.locator(f'[data-testid="{testid}"]', has_text=option).first.wait_for(timeout=15_000)


def server_tracebacks(log: list[str]) -> list[str]:
    """The tracebacks in a GUI server's output that pass through camcmm's code. A
    traceback only in wslink/aiohttp is the server pushing an update to a browser that
    has just closed (a race at the end of every test), not a fault of the app; so is one
    that ends in "Cannot write to closing transport" after passing the token guard's
    middleware (behind the session launcher the front closes a session's websocket)."""
    text = "".join(log)
    blocks = text.split("Traceback (most recent call last):")[1:]
    ours = ("/app/camcmm/", "/camcmm_plugins/", "site-packages/camcmm/")
    closed = "Cannot write to closing transport"
    return [b[:2000] for b in blocks if any(o in b.split("\n\n")[0] for o in ours) and closed not in b.split("\n\n")[0]]


def text_of(page, testid: str, pattern: str, timeout: float, shots_dir: Path) -> str:
    """The text of ``[data-testid=testid]`` once it matches the regular expression
    ``pattern``; else a screenshot ``timeout-<testid>.png`` in ``shots_dir`` and a failure
    naming the last text seen."""
    import re
    import time

    loc = page.locator(f'[data-testid="{testid}"]')
    deadline, text = time.monotonic() + timeout, ""
    while time.monotonic() < deadline:
        if loc.count():
            text = loc.first.inner_text()
            if re.search(pattern, text):
                return text
        time.sleep(0.25)
    page.screenshot(path=str(shots_dir / f"timeout-{testid}.png"))
    raise AssertionError(f"{testid}: {pattern!r} did not appear; last text {text!r}")


# -- the acceptance wizard's cards and counters --------------------------------------------------
def card(page, pos: str):
    return page.locator(f'[data-testid="card-{pos}"]')


def import_file(page, test: str, pos: str, path: Path, expect: str = "done") -> None:
    page.locator(f'[data-testid="card-{pos}"] [data-testid="card-file"] input[type="file"]').set_input_files(str(path))
    page.wait_for_selector(f'[data-testid="card-{pos}"][data-status="{expect}"]')


def counter(page, test: str) -> str:
    return page.locator(f'[data-testid="wz-counter-{test}"]').inner_text().strip()


def open_wizard(page, url: str) -> None:
    page.goto(url)
    page.wait_for_selector('[data-testid="page-acceptance"]')
    page.locator('[data-testid="page-acceptance"]').click()
    page.wait_for_selector('[data-testid="wizard"]')


def start_with_simulated_system(browser, url):
    """A page on the wizard with a part-2 test of the virtual stereo fringe system started
    and that system chosen as the source of the measurements."""
    page = browser.new_page(viewport={"width": 1400, "height": 950})
    page.set_default_timeout(30_000)
    open_wizard(page, url)
    page.wait_for_selector('[data-testid="wz-artefact-sphere"]')
    page.locator('[data-testid="wz-system-name"] input').fill("Virtual stereo fringe system")
    from helpers.acceptance_data import MPE

    for key, value in MPE.items():
        page.locator(f'[data-testid="wz-mpe-{key}"] input').fill(str(value))
    page.locator('[data-testid="wz-start"]').click()
    page.wait_for_selector('[data-testid="wz-positions"]')
    choose(page, "wz-source", "Simulated stereo fringe")
    # the server answers the choice with the system's settings form (its declared defaults):
    # a test that sets parameters itself must do so after that answer, not race it
    page.wait_for_selector('[data-testid="wz-sys-panel"]')
    return page


# -- what the 3-D view shows -----------------------------------------------------------------------
def hue_pixels(png: bytes) -> dict[str, int]:
    """Vivid pixels by hue: the colour map's reds and blues, the bands' green, the
    measured cloud's orange."""
    from PIL import Image

    hsv = np.asarray(Image.open(io.BytesIO(png)).convert("RGB").convert("HSV")).astype(float)
    h, s, v = hsv[..., 0] * 360 / 255, hsv[..., 1] / 255, hsv[..., 2] / 255
    vivid = (s > 0.35) & (v > 0.25)
    return {
        "red": int((vivid & ((h < 22) | (h > 335))).sum()),
        "blue": int((vivid & (h > 190) & (h < 260)).sum()),
        "green": int((vivid & (h > 100) & (h < 170)).sum()),
        "orange": int((vivid & (h > 26) & (h < 40)).sum()),
    }


def wait_view(view, test, timeout: float = 20.0) -> tuple[bytes, dict[str, int]]:
    """Screenshots of the view until ``test(pixels)`` holds (a streamed image takes a moment)."""
    deadline = time.monotonic() + timeout
    while True:
        png = view.screenshot()
        px = hue_pixels(png)
        if test(px) or time.monotonic() > deadline:
            return png, px
        time.sleep(0.4)
