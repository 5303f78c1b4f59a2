"""Two browser sessions on one server, in a real headless Chromium (issue 15's "every
browser tab shares one state").

One browser, two contexts (two tabs with their own cookies) on the demo project
(``camcmm demo``): each gets a session of its own (``/s/<id>/``, its own process behind
the launcher). Switching page in one does not switch the other; an error shown in one
is not shown in the other; a measurement imported in one is seen by the other after a
reload (the project store is shared), which keeps the session and its page; nothing
already saved is lost. Then one session's process dies: its tab says so, the other goes
on, and the next load of the dead session offers a new one.
Screenshots go to ``$CAMCMM_SCREENSHOTS`` (default ``/tmp/sessions-gui``).
"""

from __future__ import annotations

import os
import re
import signal
import time

import numpy as np
import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("sessions-gui")
LOAD_MS = 180_000  # a new session may have to start its process (trame + VTK): ~10 s idle, more under load


def _on(page, key: str) -> bool:
    """Is ``key`` the page shown (its toolbar button pressed)?"""
    return "v-btn--active" in (page.locator(f'[data-testid="page-{key}"]').get_attribute("class") or "")


def _session(page) -> str:
    m = re.search(r"/s/([A-Za-z0-9_-]+)/", page.url)
    assert m, page.url
    return m.group(1)


def _open(page, url: str) -> str:
    page.goto(url, timeout=LOAD_MS)
    page.wait_for_selector('[data-testid="project-name"]:has-text("camcmm demo")', timeout=LOAD_MS)
    return _session(page)


def _items(page) -> list[str]:
    page.locator('[data-testid="item"]').first.wait_for(state="attached")
    return [t.strip() for t in page.locator('[data-testid="item"]').all_inner_texts()]


def _body(page) -> str:
    return page.locator("body").inner_text()


def _wait_text(page, words: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while words not in _body(page):
        assert time.monotonic() < deadline, f"{words!r} not shown"
        time.sleep(0.2)


def test_two_sessions_have_their_own_pages_and_share_the_project(tmp_path, demo_project):
    from camcmm.gui.process import GuiProcess
    from camcmm.io import write
    from camcmm.model import PointCloud
    from camcmm.project import Project

    demo = tmp_path / "demo"
    demo_project(demo)
    with Project.open(demo) as p:
        saved = [m["name"] for m in p.measurements()]
        n_results = len(list(p.results()))
    extra = tmp_path / "extra-scan.ply"
    rng = np.random.default_rng(3)
    write(PointCloud(rng.uniform(-5, 5, (500, 3))), extra)
    later = tmp_path / "later-scan.ply"
    write(PointCloud(rng.uniform(-5, 5, (400, 3))), later)
    server = GuiProcess(demo, timeout=180)
    try:
        with sync_api.sync_playwright() as pw:
            browser = launch(pw)
            try:
                a = browser.new_context(viewport={"width": 1500, "height": 950}).new_page()
                b = browser.new_context(viewport={"width": 1500, "height": 950}).new_page()
                for page in (a, b):
                    page.set_default_timeout(60_000)
                sid_a, sid_b = _open(a, server.url), _open(b, server.url)
                assert sid_a != sid_b
                assert _on(a, "inspect") and _on(b, "inspect")

                # 1. switching page in one does not switch the other
                a.click('[data-testid="page-calibration"]')
                a.wait_for_selector('[data-testid="cal-inputs"]', state="visible")
                b.click('[data-testid="page-uncertainty"]')
                b.wait_for_selector('[data-testid="unc-budget"]', state="visible")
                a.wait_for_timeout(1000)  # time for a shared state to have reached the other tab
                assert _on(a, "calibration") and not _on(a, "uncertainty"), "B's switch moved A"
                assert _on(b, "uncertainty") and not _on(b, "calibration"), "A's switch moved B"
                assert not b.locator('[data-testid="cal-inputs"]').is_visible()
                a.screenshot(path=str(SHOTS / "a-calibration.png"))
                b.screenshot(path=str(SHOTS / "b-uncertainty.png"))

                # 2. an error shown in one is not shown in the other
                a.click('[data-testid="page-inspect"]')
                a.click('[data-testid="open-path-dialog"]')
                a.locator('[data-testid="server-path"] input').fill("/etc/camcmm-no-such-scan.xyz")
                a.click('[data-testid="server-path-import"]')
                _wait_text(a, "outside the folders this server may read")
                b.click('[data-testid="page-inspect"]')  # a round trip of B's own after A's error
                b.wait_for_selector('[data-testid="view"]', state="visible")
                b.wait_for_timeout(1000)
                assert "outside the folders" not in _body(b) and "camcmm-no-such-scan" not in _body(b)
                a.screenshot(path=str(SHOTS / "a-error.png"))
                b.screenshot(path=str(SHOTS / "b-no-error.png"))
                b.click('[data-testid="page-uncertainty"]')
                b.wait_for_selector('[data-testid="unc-budget"]', state="visible")

                # 3. a measurement imported in A reaches B after a reload (the store is shared)
                a.keyboard.press("Escape")
                a.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(extra))
                a.wait_for_selector('[data-testid="item"]:has-text("extra-scan.ply")')
                # B's tab sends its page switch to its session asynchronously: under CI's load a
                # reload two seconds later could overtake it (the reloaded tab then showed Inspect).
                # Reload once B's session has answered since: it has listed A's new item (it
                # polls the shared store about once a second and pushes the list to its tab)
                b.wait_for_selector('[data-testid="item"]:has-text("extra-scan.ply")', state="attached", timeout=60_000)
                b.reload(timeout=LOAD_MS)
                # the reloaded tab rebuilds its page from its session's state: under CI's load that
                # round trip took more than the 60 s default once (baseline run of issue 25)
                b.wait_for_selector('[data-testid="unc-budget"]', state="visible", timeout=LOAD_MS)
                assert _session(b) == sid_b and _on(b, "uncertainty")  # a reload keeps the session and its page
                b.click('[data-testid="page-inspect"]')
                b.wait_for_selector('[data-testid="item"]:has-text("extra-scan.ply")', state="attached")
                names_b = _items(b)
                for name in saved:  # nothing already saved is lost, in either tab
                    assert any(name in t for t in names_b), (name, names_b)
                    assert any(name in t for t in _items(a)), name
                b.screenshot(path=str(SHOTS / "b-after-reload.png"))

                # 3b. ... and without a reload: B's session checks the store on a timer (~1 s)
                a.locator('[data-testid="import-file"] input[type="file"]').set_input_files(str(later))
                a.wait_for_selector('[data-testid="item"]:has-text("later-scan.ply")')
                b.wait_for_selector('[data-testid="item"]:has-text("later-scan.ply")', state="attached", timeout=10_000)
                b.screenshot(path=str(SHOTS / "b-sees-without-reload.png"))

                # 4. a session whose process dies: its tab says so, the other goes on
                started = re.search(rf"session {re.escape(sid_a[:6])}: process (\d+) started", "".join(server.log))
                os.kill(int(started.group(1)), signal.SIGKILL)
                a.wait_for_selector('[data-testid="session-ended"]', timeout=60_000)
                a.screenshot(path=str(SHOTS / "a-ended.png"))
                b.click('[data-testid="page-calibration"]')
                b.wait_for_selector('[data-testid="cal-inputs"]', state="visible")
                resp = a.goto(a.url.split("?")[0], timeout=LOAD_MS)
                assert resp.status == 410
                assert "has ended" in _body(a) and "Traceback" not in _body(a)
                a.screenshot(path=str(SHOTS / "a-ended-reload.png"))
                a.click('[data-testid="new-session"]')
                a.wait_for_selector('[data-testid="project-name"]:has-text("camcmm demo")', timeout=LOAD_MS)
                assert _session(a) not in (sid_a, sid_b)
                a.wait_for_selector('[data-testid="item"]:has-text("extra-scan.ply")', state="attached")
            finally:
                browser.close()
    finally:
        server.stop()
        print("".join(server.log[-120:]))  # shown when the test fails
    with Project.open(demo) as p:
        names = [m["name"] for m in p.measurements()]
        assert names[: len(saved)] == saved and "extra-scan.ply" in names[len(saved) :]
        assert len(list(p.results())) >= n_results
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
