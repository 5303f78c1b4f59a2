"""Who may drive the server: a browser holding the per-launch token, on a page of the
server's own origin.

One aiohttp middleware in front of every route of trame's web server — the app page
and its assets, the websocket ``/ws`` (which carries uploads too), the pages' served
download folders and ``/projector*`` — does three checks:

1. an ``Origin`` header (sent by browsers on websocket handshakes and POSTs) must be
   the origin the browser reached the server at (its ``Host``) or one named with
   ``--allow-origin``; a subresource request another site or port started
   (``Sec-Fetch-Site``) is refused too;
2. the token: ``?token=`` in the URL once (as Jupyter prints it), after which an
   HttpOnly, SameSite=Strict cookie carries it; or ``Authorization: token …`` for
   scripts. Compared with :func:`hmac.compare_digest`;
3. the trame client authenticates its websocket with wslink's secret (so the default
   ``wslink-secret`` no longer works). The page gets it the way trame's client asks a
   session manager: ``POST paraview/`` next to the page, answered here (JSON, never
   cached) for a request that passed the checks above, so the secret is in no address
   the browser keeps (it used to be sent as ``index.html?secret=…``; such an address is
   now redirected to the page without it).

Refusals are ``403`` with one line of text. The token is random per launch
(:func:`new_token`), or a fixed password from ``$CAMCMM_TOKEN`` or a token file.

Behind the session launcher (:mod:`camcmm.gui.launcher`) the front server runs this
guard with the user's token and the app pages ``/s/<id>/``; each session's child process
runs it with a secret of its own that only the front knows (sent as
``Authorization: token …``), while the child's websocket secret stays the user's token
(``ws_secret``); the front answers the page's ``paraview/`` with that secret.
"""

from __future__ import annotations

import hmac
import ipaddress
import os
import re
import secrets
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlencode, urlsplit

from ..errors import CamcmmError

TOKEN_ENV = "CAMCMM_TOKEN"
MIN_TOKEN_LENGTH = 16
SECURITY_DOC = "docs/security.md"
#: the paths of the app page
APP_PAGE = re.compile(r"/(index\.html)?")
#: behind the launcher: a session's app page
SESSION_APP_PAGE = re.compile(r"/s/[A-Za-z0-9_-]+/(index\.html)?")
_SAME = object()
#: on every response: no page of another origin frames the app (clicks through a
#: transparent frame), and no address with the secret leaves in a Referer
HEADERS = {
    "X-Frame-Options": "SAMEORIGIN",
    "Content-Security-Policy": "frame-ancestors 'self'",
    "Referrer-Policy": "same-origin",
}


def printable(text: str) -> str:
    """``text`` with every control character (and any other non-printable one: DEL, C1,
    U+2028 ...) written as an escape (``\\x1b``, ``\\u2028``), tabs kept: what a
    browser sent (a file name, a path, a message) must not forge log lines or drive
    the operator's terminal."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c == "\t" else _escape(c) for c in text)


def _escape(c: str) -> str:
    named = {"\n": "\\n", "\r": "\\r"}.get(c)
    return named or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")


def escape_log_records() -> None:
    """Make every log record of this process :func:`printable` (its message and text
    arguments; a traceback stays as it is): one place for every logger, wslink's and
    aiohttp's included, which quote what browsers send."""
    import logging

    if getattr(logging, "_camcmm_printable", False):
        return
    make = logging.getLogRecordFactory()

    def factory(*args: Any, **kwargs: Any) -> logging.LogRecord:
        record = make(*args, **kwargs)
        if isinstance(record.msg, str):
            record.msg = printable(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(printable(a) if isinstance(a, str) else a for a in record.args)
        return record

    logging.setLogRecordFactory(factory)
    logging._camcmm_printable = True  # type: ignore[attr-defined]


def local_location(location: str) -> str:
    """``location`` when it is a path on this server (``/x``, ``x``, ``./x``, ``x?q``);
    else ``"/"``. A redirect never leaves the origin: ``//evil.example``, ``/\\evil``,
    ``https://evil``, ``evil.example:80`` (a scheme) all become ``/``."""
    loc = str(location)
    if any(not c.isprintable() or c.isspace() for c in loc):
        return "/"
    u = urlsplit(loc)
    if u.scheme or u.netloc or loc.startswith(("//", "/\\", "\\")):
        return "/"
    head = loc.split("?", 1)[0].split("#", 1)[0]
    if ":" in head.split("/", 1)[0]:  # "a:b" would be read as a scheme by some clients
        return "/"
    return loc


def new_token() -> str:
    """A fresh random token: 32 bytes, URL-safe base64 (43 characters)."""
    return secrets.token_urlsafe(32)


def is_loopback(host: str) -> bool:
    """Does binding to ``host`` keep the server on this machine?"""
    h = str(host or "").strip().strip("[]").lower()
    if h == "localhost":
        return True
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        return False  # a name: it may resolve to any interface


def choose_token(
    host: str, no_token: bool = False, token_file: str | Path | None = None, env: dict[str, str] | None = None
) -> str | None:
    """The token for this launch: from ``token_file``, else ``$CAMCMM_TOKEN``, else a
    new random one; ``None`` with ``no_token``, which only a loopback address allows.
    Raises CamcmmError (one line) for a refused combination or a weak password."""
    environ: Mapping[str, str] = os.environ if env is None else env
    if no_token:
        if not is_loopback(host):
            raise CamcmmError(
                f"--no-token: refused for --host {host}: beyond this machine every client needs "
                f"the token (see {SECURITY_DOC})"
            )
        return None
    if token_file:
        try:
            token = Path(token_file).expanduser().read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError) as exc:
            raise CamcmmError(f"--token-file {token_file}: cannot read it ({type(exc).__name__})") from None
        source = f"--token-file {token_file}"
    elif environ.get(TOKEN_ENV, "").strip():
        token, source = environ[TOKEN_ENV].strip(), f"${TOKEN_ENV}"
    else:
        return new_token()
    if len(token) < MIN_TOKEN_LENGTH or any(c.isspace() for c in token):
        raise CamcmmError(f"{source}: the token must be at least {MIN_TOKEN_LENGTH} characters without spaces")
    return token


def binding_warning(host: str, tls: bool) -> str | None:
    """A one-line warning for a server reachable from the network without TLS."""
    if is_loopback(host) or tls:
        return None
    return (
        f"camcmm: warning: serving on {host} without TLS: the token and all data cross the network in "
        f"clear text; run behind a TLS reverse proxy or give --certfile/--keyfile (see {SECURITY_DOC})"
    )


def _netloc(scheme: str, netloc: str) -> tuple[str, int | None] | None:
    """(host, port) with the scheme's default port dropped; None when unreadable."""
    try:
        u = urlsplit(f"//{netloc}")
        host, port = (u.hostname or "").lower(), u.port
    except ValueError:
        return None
    if not host:
        return None
    if port == {"http": 80, "https": 443, "ws": 80, "wss": 443}.get(scheme):
        port = None
    return host, port


def _equal(supplied: str | None, secret: str) -> bool:
    return supplied is not None and hmac.compare_digest(
        str(supplied).encode("utf-8", "replace"), secret.encode("utf-8")
    )


class Guard:
    """The checks above, for one server. ``token=None`` checks the origin only
    (``--no-token`` on a loopback address). ``ws_secret``: the websocket's secret when
    it is not the token (a session child's); ``app_page``: the paths that are the app
    page (a regular expression matched in full)."""

    def __init__(
        self,
        token: str | None,
        allowed_origins: Iterable[str] = (),
        ws_secret: Any = _SAME,
        app_page: re.Pattern[str] = APP_PAGE,
    ):
        self.token = token
        self.ws_secret: str | None = token if ws_secret is _SAME else ws_secret
        self.allowed_origins = frozenset(o.rstrip("/").lower() for o in allowed_origins if o)
        self.app_page = app_page
        self.cookie_name = "camcmm-token"
        self.refused = 0  # count, for tests and the log

    def is_app_page(self, path: str) -> bool:
        return self.app_page.fullmatch(path) is not None

    def is_secret_request(self, path: str) -> bool:
        """The trame client's session-manager request: ``paraview/`` next to the app page."""
        return path.endswith("/paraview/") and self.is_app_page(path[: -len("paraview/")])

    def page_secret(self) -> Any:
        """Where the page's websocket is and its secret (``use_host``: the client puts the
        address it reached the page at; ``ws:`` becomes ``wss:`` on an https page)."""
        from aiohttp import web

        info = {"sessionURL": "ws://use_host/ws", "secret": self.ws_secret}
        return web.json_response(info, headers={"Cache-Control": "no-store", **HEADERS})

    # -- wiring ----------------------------------------------------------------------------
    def install(self, server: Any) -> None:
        """Put the middleware in front of every route when trame's web server is made
        (before its routes freeze)."""

        def bind(wslink_server: Any) -> None:
            wslink_server.app.middlewares.append(self.middleware)

        def ready(**_: Any) -> None:  # one cookie per port: two servers on one host keep theirs
            self.cookie_name = f"camcmm-token-{server.port}"

        server.controller.on_server_bind.add(bind)
        server.controller.on_server_ready.add(ready)

    def url(self, base: str) -> str:
        """``base`` (``http://HOST:PORT/``) with ``?token=`` when there is one."""
        return f"{base}?{urlencode({'token': self.token})}" if self.token else base

    def wslink_args(self) -> list[str]:
        """trame's command-line arguments that make the websocket's secret the token."""
        # "--authKey=VALUE": a token may begin with "-" (token_urlsafe gives one in 64), which
        # argparse would take for an option after a separate "--authKey"
        return [f"--authKey={self.ws_secret}"] if self.ws_secret else []

    # -- checks ----------------------------------------------------------------------------
    def origin_ok(self, origin: str, request: Any) -> bool:
        o = origin.strip().rstrip("/").lower()
        if o in self.allowed_origins:
            return True
        try:
            u = urlsplit(o)
        except ValueError:
            return False
        if u.scheme not in ("http", "https") or not u.netloc:
            return False  # "null" (a sandboxed frame, a file:// page) and the like
        mine = _netloc(u.scheme, request.headers.get("Host", ""))
        return mine is not None and _netloc(u.scheme, u.netloc) == mine

    def token_ok(self, supplied: str | None) -> bool:
        return self.token is not None and bool(self.token) and _equal(supplied, self.token)

    def _header_token(self, request: Any) -> str | None:
        auth = request.headers.get("Authorization", "")
        for scheme in ("token ", "bearer "):
            if auth.lower().startswith(scheme):
                return auth[len(scheme) :].strip()
        return None

    def _refuse(self, why: str) -> Any:
        from aiohttp import web

        self.refused += 1
        return web.Response(status=403, text=f"camcmm: {why}\n", content_type="text/plain")

    def _redirect(self, request: Any, query: dict[str, str], set_cookie: bool) -> Any:
        """To the same page (a relative address: right behind a proxy's path prefix
        too) with ``query``; setting the cookie on the way."""
        from aiohttp import web

        if self.is_app_page(request.path):
            name = "index.html"
        else:
            name = request.path.rsplit("/", 1)[-1] or "./"
        resp = web.Response(
            status=302,
            headers={
                "Location": local_location(name + (f"?{urlencode(query)}" if query else "")),
                "Cache-Control": "no-store",
                "Referrer-Policy": "no-referrer",
            },
        )
        if set_cookie:
            secure = request.secure or request.headers.get("X-Forwarded-Proto", "").lower() == "https"
            resp.set_cookie(self.cookie_name, self.token, httponly=True, samesite="Strict", path="/", secure=secure)
        return resp

    async def check(self, request: Any) -> Any | None:
        """None when ``request`` may go on; else the response that refuses or redirects it."""
        origin = request.headers.get("Origin")
        if origin is not None and not self.origin_ok(origin, request):
            return self._refuse("refused: a page from another origin may not use this server")
        site = request.headers.get("Sec-Fetch-Site", "")
        top_level = (
            request.headers.get("Sec-Fetch-Mode", "") == "navigate"
            and request.headers.get("Sec-Fetch-Dest", "document") == "document"
        )
        if site in ("cross-site", "same-site") and not top_level:  # an <img>, a fetch, a frame
            return self._refuse("refused: a request started by another site")
        if not self.token:
            return None
        upgrade = request.headers.get("Upgrade", "").lower() == "websocket"
        query = dict(request.query)
        if "token" in query:
            if not self.token_ok(query.pop("token")):
                return self._refuse("wrong token: open the address camcmm serve printed")
            if request.method == "GET" and not upgrade:
                query.pop("secret", None)
                return self._redirect(request, query, set_cookie=True)
            return None
        if self.token_ok(self._header_token(request)):
            return None
        if self.token_ok(request.cookies.get(self.cookie_name)):
            if request.method == "GET" and "secret" in query and self.is_app_page(request.path) and not upgrade:
                query.pop("secret")  # an old address with the secret in it: the same page without it
                return self._redirect(request, query, set_cookie=False)
            return None
        return self._refuse(
            "this server needs its token: open the address camcmm serve printed (it ends in ?token=...)"
        )

    @property
    def middleware(self) -> Any:
        from aiohttp import web

        guard = self

        @web.middleware
        async def camcmm_guard(request: Any, handler: Any) -> Any:
            refusal = await guard.check(request)
            if refusal is not None:
                return refusal
            if request.method == "POST" and guard.ws_secret and guard.is_secret_request(request.path):
                return guard.page_secret()
            response = await handler(request)
            if not getattr(response, "prepared", True):  # a websocket is already under way
                for key, value in HEADERS.items():
                    response.headers.setdefault(key, value)
            return response

        return camcmm_guard
