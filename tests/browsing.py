"""What the browser tests share: Debian's Chromium with the launch flags that work on
these machines (never ``playwright install``: it downloads), the markers that skip a
test when there is no Chromium, where screenshots go, and picking from a Vuetify menu."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

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
MARKS = [
    pytest.mark.browser,
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
