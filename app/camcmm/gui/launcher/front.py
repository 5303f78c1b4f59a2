"""The front server: the one public port. The guard (:mod:`camcmm.gui.security`) checks
every request first; then

* ``/`` (and ``/index.html``) opens a new session and redirects the tab to ``s/<id>/``
  (503, one line, when ``max_sessions`` are open);
* ``/s/<id>/…`` is forwarded to that session's child (:mod:`.proxy`); an unknown or
  ended id gets a one-line page with a link to a new session;
* ``POST /s/<id>/paraview/`` answers the trame client's "session manager" request with
  the session's websocket address and secret (JSON, never cached): so the secret is
  never in an address the browser keeps in its history (the page used to be sent to
  ``index.html?secret=…``). Only a page of this origin holding the cookie gets it
  (the guard's checks; no CORS), and it is the session's own random secret, not the
  user's token;
* any other path (``/projector``, a download link opened from outside the page) goes
  to the session it belongs to: the one of the page it came from (``Referer``), or the
  only open one; with several and no hint, a one-line page says so.
"""

from __future__ import annotations

import asyncio
import html
import re
import time
from typing import Any
from urllib.parse import urlencode, urlsplit

from aiohttp import ClientSession, web

from ..security import SESSION_APP_PAGE, Guard, local_location
from . import proxy
from .sessions import Sessions

_SESSION_ID = r"[A-Za-z0-9_-]+"
_SESSION_PATH = re.compile(rf"/s/({_SESSION_ID})/")
#: a request body through the front (uploads go through the websocket, in chunks)
MAX_BODY = 1 << 20


def session_guard(token: str | None, allowed_origins: Any = ()) -> Guard:
    # no websocket secret in the guard: the page asks for its session's (paraview/)
    return Guard(token, allowed_origins, ws_secret=None, app_page=SESSION_APP_PAGE)


def _redirect(location: str, **headers: str) -> web.HTTPFound:
    """A redirect that never leaves this origin (:func:`local_location`)."""
    return web.HTTPFound(local_location(location), headers=headers or None)


def _line(status: int, text: str) -> web.Response:
    # the text may echo the requested path: never to be sniffed into HTML
    return web.Response(
        status=status,
        text=f"camcmm: {text}\n",
        content_type="text/plain",
        headers={"X-Content-Type-Options": "nosniff"},
    )


def _page(status: int, text: str, link: str = "", label: str = "") -> web.Response:
    """One line of text for a person (and a link), as a small HTML page."""
    a = f' <a href="{html.escape(link)}" data-testid="new-session">{html.escape(label)}</a>' if link else ""
    body = (
        '<!doctype html><html><head><meta charset="utf-8"><title>camcmm</title></head>'
        f'<body style="font-family:sans-serif;margin:2em"><p data-testid="launcher-message">camcmm: '
        f"{html.escape(text)}{a}</p></body></html>\n"
    )
    return web.Response(status=status, text=body, content_type="text/html", headers={"Cache-Control": "no-store"})


class Front:
    def __init__(self, sessions: Sessions, guard: Guard):
        self.sessions, self.guard = sessions, guard
        self.client: ClientSession | None = None
        self.app = web.Application(middlewares=[guard.middleware], client_max_size=MAX_BODY)
        self.app.router.add_get("/", self.new_session)
        self.app.router.add_get("/index.html", self.new_session)
        self.app.router.add_post("/s/{sid}/paraview/", self.connection_info)
        self.app.router.add_route("*", "/s/{sid}", self.add_slash)
        self.app.router.add_route("*", "/s/{sid}/{tail:.*}", self.forward)
        self.app.router.add_route("*", "/{tail:.*}", self.elsewhere)
        self.app.on_startup.append(self._start)
        self.app.on_cleanup.append(self._cleanup)

    async def _start(self, _: Any) -> None:
        # no connection pooling limits of note: one tab makes a handful of requests
        self.client = ClientSession(auto_decompress=False)

    async def _cleanup(self, _: Any) -> None:
        if self.client is not None:
            await self.client.close()

    # -- routes --------------------------------------------------------------------------
    async def new_session(self, request: web.Request) -> web.StreamResponse:
        s = self.sessions
        try:
            child = await s.open()
        except RuntimeError as exc:
            return _line(503, str(exc))
        if child is None:
            return _line(
                503,
                f"{s.max_sessions} sessions are open, the most this server allows (--max-sessions); "
                f"a session closes {s.idle:g} s after its last tab: close one and reload",
            )
        query = urlencode([(k, v) for k, v in request.query.items() if k not in ("token", "secret")])  # e.g. ui=
        raise _redirect(f"s/{child.id}/" + (f"?{query}" if query else ""), **{"Cache-Control": "no-store"})

    async def add_slash(self, request: web.Request) -> web.StreamResponse:
        sid = request.match_info["sid"]
        if not re.fullmatch(_SESSION_ID, sid):  # "/s/%2F%2Fevil.example" must not become "//evil.example/"
            return _line(404, "no such session on this server")
        raise _redirect(f"{sid}/")

    async def _child(self, sid: str) -> Any:
        """The started child of session ``sid`` (waiting for one still starting), or None;
        a request for it restarts its unused clock."""
        starting = self.sessions.live.get(sid)
        if starting is not None and starting.port is None:  # opened a moment ago, still starting
            await asyncio.wait([asyncio.ensure_future(starting.ready.wait())], timeout=self.sessions.start_timeout)
        child = self.sessions.get(sid)
        if child is not None:
            child.touched = time.monotonic()
        return child

    async def connection_info(self, request: web.Request) -> web.StreamResponse:
        """The trame client's session-manager request: where the websocket is, and its secret."""
        sid = request.match_info["sid"]
        child = await self._child(sid)
        if child is None:
            return self._gone(request, sid, "paraview/")
        info = {"sessionURL": f"ws://use_host/s/{sid}/ws", "secret": child.ws_secret}  # ws: becomes wss: on https
        return web.json_response(info, headers={"Cache-Control": "no-store"})

    async def forward(self, request: web.Request) -> web.StreamResponse:
        sid, tail = request.match_info["sid"], request.match_info["tail"]
        child = await self._child(sid)
        if child is None:
            return self._gone(request, sid, tail)
        if "secret" in request.query and request.method == "GET" and self.guard.is_app_page(request.path):
            # an old address with the secret in it: to the same page without it
            query = urlencode([(k, v) for k, v in request.query.items() if k != "secret"])
            raise _redirect("index.html" + (f"?{query}" if query else ""), **{"Cache-Control": "no-store"})
        assert self.client is not None
        if tail == "ws" and request.headers.get("Upgrade", "").lower() == "websocket":
            return await proxy.websocket(request, child, self.client, lambda d: self.sessions.connected(child, d))
        return await proxy.http(request, child, tail, self.client, prefix=f"/s/{sid}")

    def _gone(self, request: web.Request, sid: str, tail: str) -> web.Response:
        why = self.sessions.why_ended(sid)
        text = (
            f"session {sid[:6]}… has ended: {why}."
            if why
            else "no such session on this server (it may have restarted)."
        )
        if request.method == "GET" and tail in ("", "index.html", "projector"):
            return _page(404 if why is None else 410, text, link="../../", label="Open a new session")
        return _line(404 if why is None else 410, text)

    async def elsewhere(self, request: web.Request) -> web.StreamResponse:
        """A path outside any session: to the session of the page it came from, or the only one."""
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return _line(404, "the websocket of a session is under /s/<id>/ws")
        live = {sid: c for sid, c in self.sessions.live.items() if c.port is not None}  # started ones
        m = _SESSION_PATH.match(urlsplit(request.headers.get("Referer", "")).path or "")
        if m and m.group(1) in live:
            sid = m.group(1)
        elif len(live) == 1:
            sid = next(iter(live))
        elif not live:
            return _line(404, f"{request.path}: no session is open: open the app first (its address ends in /s/<id>/)")
        else:
            return _line(
                404, f"{request.path}: {len(live)} sessions are open: open it from the app of one of them (/s/<id>/…)"
            )
        raise web.HTTPTemporaryRedirect(local_location(f"/s/{sid}{request.path_qs}"))


async def run(front: Front, host: str, port: int, ssl_context: Any, ready: Any) -> None:
    """Listen, keep the spare child, reap idle sessions; ``ready(port)`` once the first
    child is up (the URL is printed then: a tab opened at once does not wait). Runs
    until cancelled; every child is stopped on the way out."""
    runner = web.AppRunner(front.app, access_log=None, handle_signals=False)
    await runner.setup()
    reaper = None
    try:
        site = web.TCPSite(runner, host, port, ssl_context=ssl_context)
        await site.start()
        server = getattr(site, "_server", None)
        bound = server.sockets[0].getsockname()[1] if server and server.sockets else port
        await front.sessions.keep_spare()
        if front.sessions.spare is None and front.sessions.spare_failures:
            raise RuntimeError("the first session server did not start (its output is above)")
        reaper = asyncio.ensure_future(front.sessions.run_reaper())
        ready(bound)
        await asyncio.Event().wait()  # until cancelled
    finally:
        if reaper is not None:
            reaper.cancel()
        await front.sessions.stop_all()
        await runner.cleanup()
