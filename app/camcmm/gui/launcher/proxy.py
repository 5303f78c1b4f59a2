"""Forward a request the front has let through to a session's child: HTTP (pages,
assets, downloads, the projector) and the ``/ws`` websocket (which carries uploads).

The child gets its own secret in ``Authorization``; what only the front checks
(``Origin``, ``Sec-Fetch-*``, the user's cookie and ``?token=``) is not passed on, so
the user's token never reaches a child's HTTP side. A redirect the child makes to an
absolute path is put back under the session's prefix.
"""

from __future__ import annotations

import asyncio
import os
from typing import Any
from urllib.parse import urlencode

from aiohttp import ClientError, ClientSession, ClientTimeout, WSMsgType, web

from ..security import local_location
from .sessions import Child

HOP = {
    "connection",
    "keep-alive",
    "proxy-authenticate",
    "proxy-authorization",
    "te",
    "trailer",
    "trailers",
    "transfer-encoding",
    "upgrade",
}
#: what the front alone checks or holds
FRONT_ONLY = {"host", "origin", "cookie", "authorization", "referer", "content-length"}
#: as wslink's own server (WSLINK_MAX_MSG_SIZE + overhead)
MAX_MSG = int(os.environ.get("WSLINK_MAX_MSG_SIZE", "4194304")) + int(os.environ.get("WSLINK_MSG_OVERHEAD", "4096"))
HEARTBEAT_S = 30.0


def _request_headers(request: web.Request, child: Child) -> dict[str, str]:
    out = {
        k: v
        for k, v in request.headers.items()
        if k.lower() not in HOP | FRONT_ONLY and not k.lower().startswith(("sec-fetch-", "sec-websocket-"))
    }
    out["Authorization"] = f"token {child.secret}"
    return out


def _query(request: web.Request) -> str:
    q = [(k, v) for k, v in request.query.items() if k not in ("token", "secret")]
    return f"?{urlencode(q)}" if q else ""


def _child_url(child: Child, tail: str, request: web.Request, scheme: str = "http") -> str:
    return f"{scheme}://127.0.0.1:{child.port}/{tail}{_query(request)}"


async def http(request: web.Request, child: Child, tail: str, client: ClientSession, prefix: str) -> web.StreamResponse:
    body = await request.read() if request.can_read_body else None  # bounded by the app's client_max_size
    try:
        async with client.request(
            request.method,
            _child_url(child, tail, request),
            headers=_request_headers(request, child),
            data=body,
            allow_redirects=False,
            timeout=ClientTimeout(total=None, sock_connect=10),
        ) as r:
            headers = {k: v for k, v in r.headers.items() if k.lower() not in HOP}
            if "Location" in headers:  # never off this origin; an absolute path stays in the session
                loc = local_location(headers["Location"])
                headers["Location"] = prefix + loc if loc.startswith("/") else loc
            if r.content_type == "text/html":  # a page is never reused from the cache once its session is gone
                headers["Cache-Control"] = "no-store"
            resp = web.StreamResponse(status=r.status, reason=r.reason, headers=headers)
            await resp.prepare(request)
            try:
                async for chunk in r.content.iter_chunked(1 << 16):
                    await resp.write(chunk)
                await resp.write_eof()
            except (TimeoutError, OSError, ClientError):
                pass  # the child died or the tab left mid-answer: the answer ends short, nothing to add
            return resp
    except (TimeoutError, OSError, ClientError) as exc:  # ServerDisconnectedError is a ClientError, not an OSError
        return web.Response(status=502, text=f"camcmm: this session's server does not answer ({type(exc).__name__})\n")


async def websocket(request: web.Request, child: Child, client: ClientSession, on_open: Any) -> web.StreamResponse:
    """Pump messages both ways until either side closes; ``on_open(+1/-1)`` counts the
    tab's socket (the idle clock of its session)."""
    try:
        upstream = await client.ws_connect(
            _child_url(child, "ws", request, "ws"),
            headers=_request_headers(request, child),
            max_msg_size=MAX_MSG,
            autoping=True,
            heartbeat=HEARTBEAT_S,
        )
    except Exception as exc:  # the child is gone or refused: say so in one line
        return web.Response(status=502, text=f"camcmm: this session's server does not answer ({type(exc).__name__})\n")
    ws = web.WebSocketResponse(max_msg_size=MAX_MSG, heartbeat=HEARTBEAT_S)
    await ws.prepare(request)
    on_open(+1)
    try:

        async def down() -> None:  # child -> browser
            async for msg in upstream:
                await _relay(msg, ws)
            if not ws.closed:
                await ws.close(code=4000, message=b"the session's server closed the connection")

        async def up() -> None:  # browser -> child
            async for msg in ws:
                await _relay(msg, upstream)
            await upstream.close()

        tasks = [asyncio.ensure_future(down()), asyncio.ensure_future(up())]
        done, pending = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for t in pending:
            t.cancel()
        for t in done:
            # one side went away mid-message (a tab closed, a child stopped): the end of this
            # connection, not a fault; retrieved here so asyncio logs no orphan traceback
            err = None if t.cancelled() else t.exception()
            if err is not None and not isinstance(err, (ConnectionError, ClientError)):
                raise err
    finally:
        on_open(-1)
        await upstream.close()
        if not ws.closed:
            await ws.close()
    return ws


async def _relay(msg: Any, to: Any) -> None:
    if msg.type == WSMsgType.BINARY:
        await to.send_bytes(msg.data)
    elif msg.type == WSMsgType.TEXT:
        await to.send_str(msg.data)
