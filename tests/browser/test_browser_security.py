"""The GUI server's security in a real headless Chromium.

* A page served from another origin (another port on the same machine: same-site for
  the browser, so even the SameSite cookie goes along) cannot open the app's websocket
  nor load its files, although the operator's browser holds the token's cookie.
* A browser without the token gets a 403 page, at the front and under a session's
  ``/s/<id>/``, and its websocket is refused.
* A path outside the project folder and the data roots is refused, with one line that
  shows nothing of the file, in each of the three places a page names one: "Import a
  file on the server", the Calibration page's server folder, and a plugin parameter
  naming an output folder.
"""

from __future__ import annotations

import http.server
import json
import socketserver
import threading
import time
from pathlib import Path

import pytest

from helpers.browsing import MARKS, launch, server_tracebacks, shots  # noqa: E402

pytestmark = MARKS
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

SHOTS = shots("security-gui")
SECRET = "TOPSECRET-5d1e"

# What another site would try: the app's websocket, an image of the app, a POST.
EVIL = """<!doctype html><html><body><h1>another site</h1><script>
const app = "%(app)s", out = {};
function done(k, v) { out[k] = v; document.getElementById("out").textContent = JSON.stringify(out); }
const ws = new WebSocket("ws://" + app + "/ws");
ws.onopen = () => done("ws", "open");
ws.onerror = () => done("ws", "error");
const img = new Image();
img.onload = () => done("img", "load");
img.onerror = () => done("img", "error");
img.src = "http://" + app + "/logo.png?nocache=" + Math.random();  // not the cached favicon
fetch("http://" + app + "/projector/state", {credentials: "include"})
  .then(r => r.text()).then(t => done("fetch", t)).catch(() => done("fetch", "error"));
</script><pre id="out"></pre>
<iframe id="frame" src="http://%(app)s/index.html" width="600" height="300"></iframe></body></html>"""


@pytest.fixture
def served(tmp_path):
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    data, outside = tmp_path / "data", tmp_path / "outside"
    data.mkdir()
    outside.mkdir()
    (outside / "secret.xyz").write_text(f"{SECRET} 1 2\n")
    for i in range(3):  # images a calibration would take, were the folder allowed
        (outside / f"left{i}.png").write_bytes(
            (Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard" / f"left0{i + 1}.jpg").read_bytes()
        )
    try:
        server = GuiProcess(tmp_path / "proj", data_roots=(data,))
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server, data, outside
    server.stop()


def _evil_site(app_netloc: str):
    """Another origin: a page on another port of this machine."""
    page = (EVIL % {"app": app_netloc}).encode()

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):  # noqa: N802
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(page)))
            self.end_headers()
            self.wfile.write(page)

        def log_message(self, *args):
            pass

    httpd = socketserver.TCPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    return httpd, f"http://127.0.0.1:{httpd.server_address[1]}/"


def _results(page, keys=("ws", "img", "fetch"), timeout=20.0) -> dict:
    deadline = time.monotonic() + timeout
    out = {}
    while time.monotonic() < deadline:
        text = page.locator("#out").inner_text()
        out = json.loads(text) if text.strip() else {}
        if all(k in out for k in keys):
            break
        time.sleep(0.2)
    return out


def test_another_origin_and_a_client_without_the_token_cannot_connect(served):
    server, _, _ = served
    netloc = server.base.split("//", 1)[1].rstrip("/")
    httpd, evil_url = _evil_site(netloc)
    try:
        with sync_api.sync_playwright() as p:
            browser = launch(p)
            try:
                # the operator's browser: opened the app with its token, so it holds the cookie
                ctx = browser.new_context()
                app = ctx.new_page()
                app.set_default_timeout(30_000)
                app.goto(server.url)
                app.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
                assert "token=" not in app.url and "secret=" not in app.url  # gone from the address bar
                session = app.url.split("/s/", 1)[1].split("/", 1)[0]  # its own session behind the launcher
                assert any(c["name"].startswith("camcmm-token") and c["httpOnly"] for c in ctx.cookies())
                # ... then visits another site in another tab
                evil = ctx.new_page()
                evil.goto(evil_url)
                got = _results(evil)
                evil.screenshot(path=str(SHOTS / "another-origin.png"))
                assert got.get("ws") == "error", got
                assert got.get("img") == "error", got
                assert got.get("fetch") == "error", got  # no CORS: the page reads nothing
                # nor can it show the app in a frame to have the operator click through it
                frame = next(f for f in evil.frames if f.url.startswith(server.base))
                frame.wait_for_load_state()
                assert "refused" in frame.content() and frame.locator('[data-testid="project-name"]').count() == 0
                # the app itself keeps working, a reload too (the cookie gives the client its secret again)
                app.reload()
                app.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
                assert f"/s/{session}/" in app.url  # the same session
                app.wait_for_selector('[data-plugin-id="cloud.downsample"]')
                ctx.close()

                # a browser without the token: a 403 page, and its websocket is refused
                stranger = browser.new_page()
                for path in ("", "index.html", "projector", f"s/{session}/", f"s/{session}/projector"):
                    resp = stranger.goto(server.base + path)
                    assert resp.status == 403, (path, resp.status)
                    assert "token" in stranger.content()
                assert stranger.locator('[data-testid="project-name"]').count() == 0
                for ws_path in ("/ws", f"/s/{session}/ws"):
                    state = stranger.evaluate(
                        """(p) => new Promise(done => {
                        const ws = new WebSocket(location.origin.replace('http', 'ws') + p);
                        ws.onopen = () => done('open'); ws.onerror = () => done('error'); })""",
                        ws_path,
                    )
                    assert state == "error", ws_path
                resp = stranger.goto(server.base + "?token=not-the-token")
                assert resp.status == 403
                stranger.screenshot(path=str(SHOTS / "no-token.png"))
            finally:
                browser.close()
    finally:
        httpd.shutdown()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)


def _wait_text(locator, words: str, timeout: float = 30.0) -> str:
    deadline = time.monotonic() + timeout
    text = ""
    while time.monotonic() < deadline:
        if locator.count():
            text = locator.first.inner_text()
            if words in text:
                return text
        time.sleep(0.2)
    raise AssertionError(f"{words!r} not shown; last text: {text!r}")


def test_a_path_outside_the_roots_is_refused_in_each_of_the_three_places(served):
    server, data, outside = served
    (data / "scan.xyz").write_text("".join(f"{i} {i % 7} {i % 5}\n" for i in range(50)))
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page(viewport={"width": 1500, "height": 950})
            page.set_default_timeout(30_000)
            page.goto(server.url)
            page.wait_for_selector('[data-plugin-id="fringe.patterns"]')
            alert = page.locator('[data-testid="error-alert"]')

            # 1. import a file on the server
            def import_path(path: str) -> None:
                page.click('[data-testid="open-path-dialog"]')
                page.locator('[data-testid="server-path"] input').fill(path)
                page.click('[data-testid="server-path-import"]')

            for path in (str(outside / "secret.xyz"), "../outside/secret.xyz", "/etc/passwd"):
                import_path(path)
                text = _wait_text(alert, "outside the folders this server may read")
                assert SECRET not in text and "root:" not in text and path in text, text
                page.click('[data-testid="error-alert"] button')  # close it
            page.screenshot(path=str(SHOTS / "import-refused.png"))
            import_path(str(data / "scan.xyz"))  # a data root: imported
            page.wait_for_selector('[data-testid="item"]:has-text("scan.xyz")')

            # 2. a plugin parameter naming an output folder
            page.click('[data-plugin-id="fringe.patterns"]')
            page.locator('[data-testid="param-out"] input').fill(str(outside / "patterns"))
            page.locator('[data-testid="input-sequence"] input').fill("sequence.yaml")
            page.click('[data-testid="run-button"]')
            text = _wait_text(alert, "outside the folders this server may read")
            assert text.startswith("parameter 'out'"), text
            page.screenshot(path=str(SHOTS / "plugin-refused.png"))
            assert not (outside / "patterns").exists()

            # 3. the Calibration page's server folder
            page.click('[data-testid="page-calibration"]')
            page.wait_for_selector('[data-testid="cal-inputs"]')
            page.click('[data-testid="cal-source-folder"]')
            page.locator('[data-testid="cal-folder"] input').fill(str(outside))
            page.locator('[data-testid="cal-left-pattern"] input').fill("left*")
            page.locator('[data-testid="cal-board-square"] input').fill("25")
            page.click('[data-testid="cal-run"]')
            text = _wait_text(page.locator('[data-testid="cal-error"]'), "outside the folders this server may read")
            assert "server folder" in text and "\n" not in text.strip(), text
            page.screenshot(path=str(SHOTS / "calibration-refused.png"))
        finally:
            browser.close()
    assert not server_tracebacks(server.log), server_tracebacks(server.log)
