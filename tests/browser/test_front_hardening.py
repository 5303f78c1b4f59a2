"""The front server and the uploads against a token holder who means harm (issue 26).

One real ``camcmm serve`` (the front and its session processes) on a fresh project:

* a session no page ever connected to is closed within seconds (``--session-unused``),
  not after 300 s: four plain ``GET /`` held every session;
* ``/s/%2F%2Fevil.example.com`` redirected to ``//evil.example.com/``: no redirect leaves
  the origin;
* what a browser sends is logged with its control characters escaped;
* the bomb uploads of the issue — three 48-byte websocket chunks declaring 3.9 GB each, a
  JPEG whose header declares 20000 x 20000 px, an X3P zip bomb (1 GB of zeros in 5 MB), a
  30 MB ``.xyz`` — leave the session process under 1 GB (its resident set, read from
  /proc) and nothing refused in the project, while another session goes on answering;
* in Chromium, the token and the websocket secret end up in no address the browser
  keeps: ``/?token=`` redirects to a clean address once the cookie is set, and the page
  gets its secret from ``POST /s/<id>/paraview/``, not from ``index.html?secret=``.

The uploads go through a small wslink client (what the page's file input sends:
``trame.state.update`` of ``upload`` with the file's name and bytes), so that a test can
also send what no honest page sends.
"""

from __future__ import annotations

import asyncio
import io
import json
import re
import struct
import time
import urllib.error
import urllib.request
import zipfile
from urllib.parse import urljoin, urlsplit

import msgpack
import numpy as np
import pytest

from helpers.badinputs import jpeg_header
from helpers.browsing import MARKS, launch

pytestmark = MARKS
aiohttp = pytest.importorskip("aiohttp")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")

UNUSED_S = 4.0
MB = 1 << 20


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    pytest.importorskip("trame")
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    try:
        s = GuiProcess(
            tmp_path_factory.mktemp("front") / "proj", args=("--max-sessions", "4", "--session-unused", str(UNUSED_S))
        )
    except CamcmmError as exc:
        pytest.fail(str(exc))
    s.cookie = {"Cookie": f"camcmm-token-{s.base.rsplit(':', 1)[1].strip('/')}={s.token}"}
    s.origin = s.base.rstrip("/")
    s.other = None
    yield s
    s.stop()


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


def http(url: str, headers: dict | None = None, method: str = "GET", data: bytes | None = None):
    req = urllib.request.Request(url, headers=headers or {}, method=method, data=data)
    try:
        with urllib.request.build_opener(_NoRedirect).open(req, timeout=60) as r:
            return r.status, dict(r.headers), r.read().decode("utf-8", "replace")
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read().decode("utf-8", "replace")


def open_session(server) -> str:
    status, headers, body = http(server.base, {"Authorization": f"token {server.token}"})
    assert status == 302, (status, body)
    m = re.fullmatch(r"s/([0-9a-f]+)/", headers["Location"])
    assert m, headers
    return m.group(1)


def session_pid(server, sid: str) -> int:
    for line in server.log:
        m = re.search(rf"session {sid[:6]}: process (\d+) started", line)
        if m:
            return int(m.group(1))
    raise AssertionError(f"no process for session {sid}")


def rss_mb(pid: int, key: str = "VmRSS") -> float:
    for line in open(f"/proc/{pid}/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    raise AssertionError(key)


# -- a small wslink client -------------------------------------------------------------------------
class Tab:
    """One session's websocket, as the page uses it: the secret from ``paraview/``, the
    ``wslink.hello``, then RPCs; every message the session pushes is kept (as text)."""

    def __init__(self, server, sid: str):
        self.server, self.sid = server, sid
        self.heard: list[str] = []
        self.n = 0

    async def __aenter__(self) -> Tab:
        from wslink.chunking import UnChunker

        s = self.server
        headers = {**s.cookie, "Origin": s.origin}
        self.http = aiohttp.ClientSession()
        async with self.http.post(f"{s.base}s/{self.sid}/paraview/", data="{}", headers=headers) as r:
            assert r.status == 200, await r.text()
            self.secret = (await r.json())["secret"]
        assert self.secret != s.token  # the session's own secret, not the user's token
        self.ws = await self.http.ws_connect(
            f"{s.base.replace('http', 'ws')}s/{self.sid}/ws", headers=headers, max_msg_size=0
        )
        self.unchunker = UnChunker()
        self.unchunker.set_max_message_size(1 << 30)
        self.reader = asyncio.ensure_future(self._read())
        hello = {"wslink": "1.0", "id": "system:c0:0", "method": "wslink.hello", "args": [{"secret": self.secret}]}
        await self.send(hello)
        await self.heard_that(lambda t: "clientID" in t, 30)
        self.client = re.search(r"'clientID': '(c\w+)'", "".join(self.heard)).group(1)
        return self

    async def __aexit__(self, *exc) -> None:
        self.reader.cancel()
        await self.ws.close()
        await self.http.close()

    async def _read(self) -> None:
        async for msg in self.ws:
            if msg.type == aiohttp.WSMsgType.BINARY:
                full = self.unchunker.process_chunk(msg.data)
                if full is not None:
                    self.heard.append(repr(full))

    async def send(self, message: dict) -> None:
        from wslink.chunking import generate_chunks

        for chunk in generate_chunks(msgpack.packb(message), 4 * MB):
            await self.ws.send_bytes(chunk)

    async def upload(self, name: str, content: bytes) -> None:
        self.n += 1
        value = {"name": name, "size": len(content), "content": content}
        await self.send(
            {
                "wslink": "1.0",
                "id": f"rpc:{self.client}:{self.n}",
                "method": "trame.state.update",
                "args": [[{"key": "upload", "value": value}]],
            }
        )

    async def heard_that(self, pred, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        seen = 0
        while time.monotonic() < deadline:
            for text in self.heard[seen:]:
                if pred(text):
                    return text
            seen = len(self.heard)
            await asyncio.sleep(0.1)
        raise AssertionError(f"not heard within {timeout} s; last: {self.heard[-3:]}")


def x3p_bomb(inflated: int = 1024 * MB) -> bytes:
    """A valid X3P's main.xml (a 4 x 4 grid) with a data member of ``inflated`` zero
    bytes deflated to ~0.5 % of that."""
    import tempfile
    from pathlib import Path

    from camcmm.io import write
    from camcmm.model import HeightMap

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.x3p"
        write(HeightMap(np.zeros((4, 4)), 0.001, 0.001, name="s"), p)
        xml = zipfile.ZipFile(p).read("main.xml")
    buf, zeros = io.BytesIO(), bytes(MB)
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        zf.writestr("main.xml", xml)
        with zf.open("bindata/data.bin", "w", force_zip64=True) as f:
            for _ in range(inflated // MB):
                f.write(zeros)
    return buf.getvalue()


def xyz(n_points: int) -> bytes:
    """A plausible part in mm (a 100 mm cube of points), about 27 bytes a point: a block
    of 10 000 points repeated (formatting a million points would take seconds)."""
    rng = np.random.default_rng(3)
    out = io.StringIO()
    np.savetxt(out, rng.uniform(0, 100, (10_000, 3)), fmt="%.5f")
    return out.getvalue().encode() * (n_points // 10_000)


def measurements(server) -> list[str]:
    from camcmm.project import Project

    project = Project.open_or_create(server.proc.args[3])
    try:
        return [m["name"] for m in project.measurements()]
    finally:
        project.close()


# -- tests ---------------------------------------------------------------------------------------
def test_a_session_no_page_connected_to_is_closed_within_seconds(server):
    sid = open_session(server)
    time.sleep(UNUSED_S + 3)  # the reaper looks every UNUSED_S / 4 s; no request for it meanwhile
    status, _, body = http(f"{server.base}s/{sid}/", {"Authorization": f"token {server.token}"})
    assert status == 410 and f"no page connected to it within {UNUSED_S:g} s" in body, (status, body)


def test_no_redirect_leaves_the_origin(server):
    auth = {"Authorization": f"token {server.token}"}
    for path in (
        "s/%2F%2Fevil.example.com",
        "s/%5C%5Cevil.example.com",
        "s/%2F%5Cevil.example.com",
        "s/http:%2F%2Fevil.example.com",
    ):
        status, headers, body = http(server.base + path, auth)
        loc = headers.get("Location", "")
        assert "evil" not in loc, (path, status, loc)
        assert status == 404 and body.count("\n") == 1, (path, status, body)
    # the token's redirect keeps to a path of this server, whatever the path looks like
    for path in ("evil.example.com:80", "%2F%2Fevil.example.com", "a/javascript:alert(1)"):
        url = f"{server.base}{path}?token={server.token}"
        status, headers, _ = http(url)
        loc = headers.get("Location", "")
        there = urlsplit(urljoin(url, loc))
        assert status == 302 and there.scheme == "http" and there.netloc == urlsplit(server.base).netloc, (path, loc)
        assert "token" not in loc and "javascript:" not in loc, (path, loc)


def test_what_a_browser_sends_is_logged_with_its_control_characters_escaped(server):
    sid = server.other = open_session(server)  # the next test's other session (a new one takes 10-30 s)

    async def talk():
        async with Tab(server, sid) as tab:
            await tab.ws.send_str("\x1b[2J\x1b[31mEVIL\r\ncamcmm GUI: http://evil.example/?token=x")
            await asyncio.sleep(1.0)

    asyncio.run(talk())
    deadline = time.monotonic() + 10
    while not any("EVIL" in line for line in server.log) and time.monotonic() < deadline:
        time.sleep(0.2)
    logged = [line for line in server.log if "EVIL" in line]
    assert logged, server.log[-10:]
    assert not any("\x1b" in line or "\r" in line for line in server.log)
    assert "\\x1b[2J" in logged[0] and "\\r\\ncamcmm GUI" in logged[0], logged
    assert not any(line.startswith("camcmm GUI: http://evil") for line in server.log)


def test_bomb_uploads_leave_the_session_under_1_gb_and_the_other_answering(server):
    jpeg = jpeg_header(20000, 20000) + bytes(6 * MB)  # 6 MB, as the 6.3 MB JPEG
    bomb = x3p_bomb()
    cloud = xyz(1_100_000)
    assert len(cloud) > 28 * MB and len(bomb) < 8 * MB
    a = open_session(server)  # connected to at once: within --session-unused
    b = server.other or open_session(server)
    pid = session_pid(server, a)
    answers: list[float] = []

    async def other_session_answers() -> None:
        async with aiohttp.ClientSession() as h:
            while True:
                t = time.monotonic()
                async with h.get(f"{server.base}s/{b}/", headers={**server.cookie}) as r:
                    assert r.status == 200
                answers.append(time.monotonic() - t)
                await asyncio.sleep(0.5)

    async def attack() -> None:
        async with Tab(server, a) as tab:
            base = rss_mb(pid)
            watch = asyncio.ensure_future(other_session_answers())
            for mid in (11, 12, 13):  # three 48-byte chunks declaring 3.9 GB each
                await tab.ws.send_bytes(struct.pack("<III", mid, 0, 3_900_000_000) + b"x" * 36)
            await tab.heard_that(lambda t: "--max-upload" in t, 20)
            await tab.upload("bomb.jpg", jpeg)
            await tab.heard_that(lambda t: "bomb.jpg" in t and "20000" in t, 30)
            await tab.upload("bomb.x3p", bomb)
            await tab.heard_that(lambda t: "bomb.x3p:" in t, 30)
            await tab.upload("big.xyz", cloud)
            await tab.heard_that(lambda t: "imported big.xyz" in t, 60)
            await asyncio.sleep(1.0)
            watch.cancel()
            after, peak = rss_mb(pid), rss_mb(pid, "VmHWM")
            print(f"session {a[:6]}: {base:.0f} MB before, {after:.0f} MB after, peak {peak:.0f} MB")

    asyncio.run(attack())
    refusals = [line for line in server.log if "--max-upload" in line and "camcmm GUI error" in line]
    assert len(refusals) == 3, refusals
    assert rss_mb(pid) < 1024, f"the session holds {rss_mb(pid):.0f} MB"
    assert rss_mb(pid, "VmHWM") < 1024, f"the session peaked at {rss_mb(pid, 'VmHWM'):.0f} MB"
    assert measurements(server) == ["big.xyz"]  # the refused ones are not in the project
    assert len(answers) >= 3 and max(answers) < 3.0, answers  # the other tab never stalled


def test_the_token_and_the_secret_stay_out_of_the_addresses_a_browser_keeps(server):
    with sync_api.sync_playwright() as p:
        browser = launch(p)
        try:
            page = browser.new_page()
            page.set_default_timeout(120_000)
            visited: list[str] = []
            page.on("framenavigated", lambda f: visited.append(f.url) if f == page.main_frame else None)
            requests: list[str] = []
            page.on("request", lambda r: requests.append(r.url) if r.is_navigation_request() else None)
            sockets: list[str] = []
            page.on("websocket", lambda ws: sockets.append(ws.url))
            page.goto(server.url)
            page.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
            page.reload()
            page.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
        finally:
            browser.close()
    assert requests[0] == server.url and "token=" in requests[0]
    kept = requests[1:] + visited + sockets
    assert kept and all("token=" not in u and "secret=" not in u for u in kept), kept
    assert len(sockets) == 2 and all(re.search(r"/s/[0-9a-f]+/ws$", u) for u in sockets), sockets
    # the page's secret: only for a page of this origin with the cookie
    sid = re.search(r"/s/([0-9a-f]+)/", sockets[0]).group(1)
    url = f"{server.base}s/{sid}/paraview/"
    assert http(url, method="POST", data=b"{}")[0] == 403
    assert http(url, {**server.cookie, "Origin": "http://evil.example"}, "POST", b"{}")[0] == 403
    status, headers, body = http(url, {**server.cookie, "Origin": server.origin}, "POST", b"{}")
    info = json.loads(body)
    assert status == 200 and "no-store" in headers["Cache-Control"] and info["secret"] != server.token
    assert info["sessionURL"] == f"ws://use_host/s/{sid}/ws"
    # an old address with the secret in it goes to the same page without it
    status, headers, _ = http(f"{server.base}s/{sid}/index.html?secret=x&ui=main", server.cookie)
    assert status == 302 and headers["Location"] == "index.html?ui=main"


def test_one_process_for_every_tab_keeps_the_secret_out_of_addresses_too(tmp_path):
    """``--single-session`` (no front): the page gets the websocket secret from the
    server's own ``paraview/``; no address after the first holds the token or a secret."""
    from camcmm.gui.process import GuiProcess

    server = GuiProcess(tmp_path / "proj", args=("--single-session",))
    try:
        with sync_api.sync_playwright() as p:
            browser = launch(p)
            try:
                page = browser.new_page()
                page.set_default_timeout(120_000)
                requests: list[str] = []
                page.on("request", lambda r: requests.append(r.url) if r.is_navigation_request() else None)
                sockets: list[str] = []
                page.on("websocket", lambda ws: sockets.append(ws.url))
                page.goto(server.url)
                page.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
                page.reload()
                page.wait_for_selector('[data-testid="project-name"]:has-text("proj")')
                address = page.url
            finally:
                browser.close()
    finally:
        server.stop()
    kept = requests[1:] + sockets + [address]
    assert all("token=" not in u and "secret=" not in u for u in kept), kept
    assert len(sockets) == 2 and all(u.endswith("/ws") for u in sockets), sockets
