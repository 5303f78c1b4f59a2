"""The session launcher (:mod:`camcmm.gui.launcher`) without a browser.

The front server runs in a thread with small stand-in children (an aiohttp app that
speaks the child's protocol: the secrets from the environment, the ready line, its
own secret on every request), so the limits, the idle clock, a dying child, unknown
ids and the proxying can be checked in seconds. The last test starts the real GUI and
kills the front with SIGKILL: its children and their plugin workers must not outlive it.
"""

from __future__ import annotations

import asyncio
import os
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

aiohttp = pytest.importorskip("aiohttp")

from camcmm.gui.launcher.front import Front, run, session_guard  # noqa: E402
from camcmm.gui.launcher.sessions import Sessions  # noqa: E402

TOKEN = "launcher-test-token-0123456789"

FAKE_CHILD = r"""
import asyncio, os
from aiohttp import web
from camcmm.gui.launcher.child import announce, take_secrets, watch_parent

watch_parent()
secret, ws_secret = take_secrets()

async def handle(request):
    if request.headers.get("Authorization") != f"token {secret}":
        return web.Response(status=403, text="no secret")
    if request.path == "/ws":
        ws = web.WebSocketResponse()
        await ws.prepare(request)
        async for msg in ws:
            await ws.send_str(f"{msg.data} {ws_secret}")
        return ws
    if request.path == "/redirect":
        raise web.HTTPFound("/index.html")
    if request.path == "/exit":
        os._exit(7)
    h = request.headers
    return web.Response(text=f"pid={os.getpid()} path={request.path} query={sorted(request.query)} "
                             f"cookie={h.get('Cookie')} origin={h.get('Origin')}")

async def main():
    app = web.Application()
    app.router.add_route("*", "/{tail:.*}", handle)
    runner = web.AppRunner(app)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    announce(site._server.sockets[0].getsockname()[1])
    await asyncio.Event().wait()

asyncio.run(main())
"""


class Running:
    """A front with stand-in children, served from a thread."""

    def __init__(self, script: Path, **opts):
        self.log: list[str] = []
        env = dict(os.environ)
        self.sessions = Sessions([sys.executable, str(script)], env, log=self.log.append, **opts)
        self.front = Front(self.sessions, session_guard(TOKEN))
        self.port: int | None = None
        ready = threading.Event()
        self.loop = asyncio.new_event_loop()

        def go() -> None:
            def on_ready(port: int) -> None:
                self.port = port
                ready.set()

            self.task = self.loop.create_task(run(self.front, "127.0.0.1", 0, None, on_ready))
            try:
                self.loop.run_until_complete(self.task)
            except (asyncio.CancelledError, Exception):
                pass
            ready.set()

        self.thread = threading.Thread(target=go, daemon=True)
        self.thread.start()
        assert ready.wait(60) and self.port, self.log
        self.base = f"http://127.0.0.1:{self.port}/"

    def stop(self) -> None:
        self.loop.call_soon_threadsafe(self.task.cancel)
        self.thread.join(30)

    def pids(self) -> list[int]:
        children = list(self.sessions.live.values()) + ([self.sessions.spare] if self.sessions.spare else [])
        return [c.proc.pid for c in children]


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


def get(url: str, headers: dict | None = None, auth: bool = True, method: str = "GET"):
    h = {"Authorization": f"token {TOKEN}"} if auth else {}
    data = b"x" if method == "POST" else None
    req = urllib.request.Request(url, headers={**h, **(headers or {})}, method=method, data=data)
    try:
        with urllib.request.build_opener(_NoRedirect).open(req, timeout=30) as r:
            return r.status, dict(r.headers), r.read().decode()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read().decode()


def open_session(front: Running) -> str:
    status, headers, body = get(front.base)
    assert status == 302, (status, body)
    assert headers["Location"].startswith("s/") and headers["Location"].endswith("/")
    return headers["Location"][2:-1]


@pytest.fixture
def script(tmp_path):
    p = tmp_path / "fake_child.py"
    p.write_text(FAKE_CHILD)
    return p


@pytest.fixture
def front(script):
    made = []

    def make(**opts):
        f = Running(script, **opts)
        made.append(f)
        return f

    yield make
    for f in made:
        f.stop()


def gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ", 1)[1].startswith("Z")  # a zombie is dead
    except (FileNotFoundError, ProcessLookupError):
        return True


pytestmark = pytest.mark.slow  # each test starts a few Python processes


def test_each_tab_gets_its_own_session_and_a_reload_keeps_it(front):
    f = front(max_sessions=3)
    a, b = open_session(f), open_session(f)
    assert a != b
    pa = get(f.base + f"s/{a}/index.html?ui=x")[2]
    pb = get(f.base + f"s/{b}/index.html")[2]
    assert pa.startswith("pid=") and pa.split()[0] != pb.split()[0]  # two processes
    assert get(f.base + f"s/{a}/index.html")[2].split()[0] == pa.split()[0]  # a reload: the same one
    assert "query=['ui']" in pa
    # the child never sees the user's token, cookie or origin: only its own secret
    posted = get(f.base + f"s/{a}/projector/ack?v=1&token={TOKEN}", auth=False, method="POST")[2]
    assert "path=/projector/ack" in posted and "query=['v']" in posted, posted
    cookie = {"Cookie": f"{f.front.guard.cookie_name}={TOKEN}", "Origin": f.base.rstrip("/")}
    text = get(f.base + f"s/{a}/probe?x=1", cookie, auth=False)[2]
    assert "path=/probe" in text and "cookie=None" in text and "origin=None" in text
    # the app page comes with no secret in its address (issue 26); the page asks for it
    status, headers, _ = get(f.base + f"s/{a}/", cookie, auth=False)
    assert status == 200 and "Location" not in headers
    # a redirect of the child to an absolute path stays in the session
    status, headers, _ = get(f.base + f"s/{a}/redirect")
    assert status == 302 and headers["Location"] == f"/s/{a}/index.html"
    assert get(f.base + f"s/{a}")[1]["Location"] == f"{a}/"
    status, headers, _ = get(f.base + "?ui=main&secret=x")  # trame's own parameters go along, no secret
    assert status == 302 and headers["Location"].endswith("/?ui=main")


def test_the_websocket_is_forwarded_and_counts_as_the_tab(front):
    f = front(max_sessions=2, idle=0.6)
    sid = open_session(f)
    child = f.sessions.live[sid]

    async def talk():
        async with aiohttp.ClientSession() as http:
            async with http.ws_connect(
                f.base.replace("http", "ws") + f"s/{sid}/ws", headers={"Authorization": f"token {TOKEN}"}
            ) as ws:
                await ws.send_str("hello")
                echo = (await ws.receive(timeout=10)).data
                await asyncio.sleep(1.5)  # longer than idle: an open tab keeps its session
                return echo, child.sockets, sid in f.sessions.live

    echo, sockets, alive = asyncio.run(talk())
    assert echo == f"hello {child.ws_secret}" and sockets == 1 and alive
    assert child.ws_secret != TOKEN
    deadline = time.monotonic() + 10
    while sid in f.sessions.live and time.monotonic() < deadline:
        time.sleep(0.1)
    assert sid not in f.sessions.live  # closed after its last tab went
    status, _, body = get(f.base + f"s/{sid}/")
    assert status == 410 and "closed 0.6 s after its last tab" in body and 'href="../../"' in body
    deadline = time.monotonic() + 10
    while not gone(child.proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert gone(child.proc.pid)


def test_the_limit_a_dying_child_and_unknown_ids(front):
    f = front(max_sessions=2)
    a, b = open_session(f), open_session(f)
    assert len(f.pids()) == 2  # no spare beyond the limit
    status, _, body = get(f.base)
    assert status == 503 and body.count("\n") == 1 and "--max-sessions" in body and "2 sessions" in body
    # a child that dies: a clear page on the next load, and room for a new session
    get(f.base + f"s/{a}/exit")
    deadline = time.monotonic() + 10
    while a in f.sessions.live and time.monotonic() < deadline:
        time.sleep(0.1)
    status, _, body = get(f.base + f"s/{a}/")
    assert status == 410 and "exit code 7" in body and "Open a new session" in body
    assert "Traceback" not in body
    c = open_session(f)
    assert c not in (a, b)
    # an invented id: a page for a person, one line for anything else
    status, _, body = get(f.base + "s/invented-id/")
    assert status == 404 and "no such session" in body and "Open a new session" in body
    status, _, body = get(f.base + "s/invented-id/assets/x.js")
    assert status == 404 and body.count("\n") == 1
    assert get(f.base + "s/invented-id/", auth=False)[0] == 403  # the guard comes first
    assert get(f.base + f"s/{b}/index.html", auth=False)[0] == 403


def test_paths_outside_a_session_go_to_its_session(front):
    f = front(max_sessions=3)
    status, _, body = get(f.base + "projector")
    assert status == 404 and "no session is open" in body
    a = open_session(f)
    status, headers, _ = get(f.base + "projector?v=2")
    assert status == 307 and headers["Location"] == f"/s/{a}/projector?v=2"  # the only one
    b = open_session(f)
    status, _, body = get(f.base + "ins-downloads/report.pdf")
    assert status == 404 and "2 sessions are open" in body
    referer = {"Referer": f.base + f"s/{b}/index.html"}
    assert get(f.base + "ins-downloads/report.pdf", referer)[1]["Location"] == f"/s/{b}/ins-downloads/report.pdf"


def test_stopping_the_front_stops_every_child(front):
    f = front(max_sessions=3)
    open_session(f)
    open_session(f)
    deadline = time.monotonic() + 30
    while len(f.pids()) < 3 and time.monotonic() < deadline:  # the new spare starts after the tab's redirect
        time.sleep(0.1)
    pids = f.pids()
    assert len(pids) == 3  # two sessions and the spare
    f.stop()
    assert all(gone(p) for p in pids)
    assert any("ended: the server stopped" in line for line in f.log)


def _descendants(pid: int) -> set[int]:
    parents: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                parents[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parents.items() if pp == p]
        out.update(kids)
        todo.extend(kids)
    return out


def test_no_orphans_when_the_front_is_killed(tmp_path):
    """SIGKILL on the real front: no handler runs, yet every session process and its plugin
    worker stops (the child watches its stdin pipe from the front)."""
    pytest.importorskip("trame")
    from camcmm.gui.process import GuiProcess

    g = GuiProcess(tmp_path / "proj", timeout=120, args=("--max-sessions", "2"))
    try:
        status, headers, _ = get(g.base, {"Authorization": f"token {g.token}"}, auth=False)
        assert status == 302
        deadline = time.monotonic() + 120  # the session and the new spare, each with its worker
        while len(_descendants(g.proc.pid)) < 3 and time.monotonic() < deadline:
            time.sleep(0.5)
        kids = _descendants(g.proc.pid)
        assert len(kids) >= 2, kids
    finally:
        g.kill()
    deadline = time.monotonic() + 60
    while not all(gone(p) for p in kids) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert all(gone(p) for p in kids), [p for p in kids if not gone(p)]
