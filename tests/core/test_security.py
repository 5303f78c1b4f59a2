"""Who may drive the GUI server and what it may read, without a browser.

The token, Origin and Sec-Fetch-Site checks of :mod:`camcmm.gui.security` on mocked
aiohttp requests; the confinement of :mod:`camcmm.gui.roots` (``..``, symlinks,
relative paths, plugin parameters and inputs); the options of ``camcmm serve`` that
are refused before anything starts; and a real server (the session launcher's front and
its children) probed over raw HTTP and websocket: nothing answers without the token, at
the front or under a session's ``/s/<id>/``, nor to a page of another origin; the default
``wslink-secret`` no longer authenticates; a session's child answers nobody but the
front; an invented session id is refused; the number of sessions is limited.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
import urllib.error
import urllib.request
from types import SimpleNamespace

import pytest

from camcmm.errors import CamcmmError, InputError
from camcmm.gui.roots import Roots, is_path_param, redact
from camcmm.gui.security import Guard, binding_warning, choose_token, is_loopback, new_token

SECRET = "TOPSECRET-9f3a"  # file content that must never reach a page


# -- roots --------------------------------------------------------------------------------
@pytest.fixture
def tree(tmp_path):
    proj, data, outside = tmp_path / "proj", tmp_path / "data", tmp_path / "outside"
    for d in (proj, data, outside):
        d.mkdir()
    (outside / "secret.xyz").write_text(f"{SECRET} 1 2\n")
    (data / "scan.xyz").write_text("1 2 3\n")
    return SimpleNamespace(proj=proj, data=data, outside=outside, roots=Roots(proj, [data]))


def test_roots_allow_the_project_and_the_data_roots_only(tree):
    r = tree.roots
    assert r.check(tree.data / "scan.xyz") == (tree.data / "scan.xyz").resolve()
    assert r.check(tree.proj / "new" / "folder") == (tree.proj / "new" / "folder").resolve()  # not there yet
    assert r.check("sub/out") == (tree.proj / "sub" / "out").resolve()  # relative: from the project folder
    assert r.check(str(tree.proj)) == tree.proj.resolve()
    for bad in (
        tree.outside / "secret.xyz",
        tree.proj / ".." / "outside" / "secret.xyz",
        "../outside",
        "/etc/passwd",
        "~",
        str(tree.outside) + "/",
        f'"{tree.outside}"',
    ):
        with pytest.raises(InputError) as e:
            r.check(bad)
        msg = str(e.value)
        assert "outside the folders this server may read" in msg and "--data-root" in msg
        assert SECRET not in msg and "\n" not in msg
    # a folder whose name starts like a root's is not inside it
    (tree.proj.parent / "proj2").mkdir()
    assert not r.allows(tree.proj.parent / "proj2")


def test_a_symlink_inside_a_root_that_leads_outside_is_outside(tree):
    (tree.proj / "link").symlink_to(tree.outside)
    (tree.data / "file.xyz").symlink_to(tree.outside / "secret.xyz")
    assert not tree.roots.allows(tree.proj / "link" / "secret.xyz")
    assert not tree.roots.allows(tree.data / "file.xyz")
    # and a link into a root from outside is fine: what counts is where it leads
    (tree.outside / "back").symlink_to(tree.data)
    assert tree.roots.allows(tree.outside / "back" / "scan.xyz")


def test_a_missing_data_root_is_refused(tmp_path):
    with pytest.raises(InputError, match="--data-root .*no such folder"):
        Roots(tmp_path, [tmp_path / "nowhere"])


def test_plugin_path_parameters_and_inputs_are_confined(tree):
    P = SimpleNamespace
    spec = P(
        parameters=[
            P(name="out", type="str"),
            P(name="save", type="str"),
            P(name="outliers", type="str"),
            P(name="voxel", type="float"),
            P(name="cti", type="path"),
        ],
        inputs=[P(name="cloud", type="pointcloud"), P(name="sequence", type="json"), P(name="csv", type="file")],
    )
    assert [is_path_param(p) for p in spec.parameters] == [True, True, False, False, True]
    params, inputs = tree.roots.check_run(
        spec,
        {"out": "patterns", "save": "", "outliers": "/etc/passwd", "voxel": 2},
        {"cloud": "7", "sequence": "[1, 2]", "csv": str(tree.data / "scan.xyz")},
        item_types=("pointcloud",),
    )
    assert params["out"] == str((tree.proj / "patterns").resolve())  # written into the project, not the cwd
    assert params["outliers"] == "/etc/passwd" and params["save"] == ""  # not paths: left alone
    assert inputs == {"cloud": "7", "sequence": "[1, 2]", "csv": str((tree.data / "scan.xyz").resolve())}
    for params, inputs, culprit in (
        ({"out": str(tree.outside)}, {}, "parameter 'out'"),
        ({"cti": "/usr/lib/x.cti"}, {}, "parameter 'cti'"),
        ({}, {"csv": str(tree.outside / "secret.xyz")}, "input 'csv'"),
        ({}, {"sequence": "../outside/secret.xyz"}, "input 'sequence'"),
    ):
        with pytest.raises(InputError) as e:
            tree.roots.check_run(spec, params, inputs, item_types=("pointcloud",))
        assert str(e.value).startswith(culprit) and "outside the folders" in str(e.value)


def test_redact_removes_quoted_content_and_keeps_the_name():
    msg = "secret.xyz line 1: expected 3 numeric columns separated by spaces but found 'TOPSECRET-9f3a 1 2'"
    out = redact(msg, keep=("secret.xyz",))
    assert SECRET not in out and out.startswith("secret.xyz line 1") and "'…'" in out
    assert redact('PLY: unknown keyword "root:x:0:0"') == "PLY: unknown keyword '…'"
    assert redact("'scan.xyz' is empty", keep=("scan.xyz",)) == "'scan.xyz' is empty"


# -- token and binding -----------------------------------------------------------------------
def test_token_choice(tmp_path):
    t1, t2 = choose_token("127.0.0.1", env={}), choose_token("127.0.0.1", env={})
    assert t1 != t2 and len(t1) >= 43  # 32 random bytes, fresh per launch
    assert choose_token("127.0.0.1", no_token=True, env={}) is None
    assert choose_token("::1", no_token=True, env={}) is None
    for host in ("0.0.0.0", "192.168.1.20", "lab-pc.example", "::"):
        assert not is_loopback(host)
        with pytest.raises(CamcmmError, match="--no-token: refused"):
            choose_token(host, no_token=True, env={})
    assert choose_token("0.0.0.0", env={"CAMCMM_TOKEN": " a-long-lab-password-123 "}) == "a-long-lab-password-123"
    with pytest.raises(CamcmmError, match="at least 16"):
        choose_token("0.0.0.0", env={"CAMCMM_TOKEN": "short"})
    f = tmp_path / "token"
    f.write_text("from-a-file-0123456789\n")
    assert choose_token("0.0.0.0", token_file=f, env={"CAMCMM_TOKEN": "x" * 20}) == "from-a-file-0123456789"
    with pytest.raises(CamcmmError, match="--token-file"):
        choose_token("0.0.0.0", token_file=tmp_path / "none")
    assert binding_warning("127.0.0.1", tls=False) is None and binding_warning("0.0.0.0", tls=True) is None
    w = binding_warning("0.0.0.0", tls=False)
    assert "without TLS" in w and "docs/security.md" in w and "\n" not in w


@pytest.mark.slow
def test_serve_refuses_bad_options_in_one_line(tmp_path):
    """One line on stderr and a non-zero exit, before any project or server is made."""
    env = dict(os.environ)
    env.pop("CAMCMM_TOKEN", None)
    for args, words in (
        (["--port", "0", "--host", "0.0.0.0", "--no-token"], "--no-token: refused"),
        (["--port", "0", "--data-root", str(tmp_path / "nowhere")], "no such folder"),
        (["--port", "99999"], "99999: a port is 0"),
        (["--port", "0", "--max-sessions", "0"], "--max-sessions 0: at least 1"),
        (["--port", "0", "--session-idle", "0"], "--session-idle 0: a number of seconds above 0"),
    ):
        r = subprocess.run(
            [sys.executable, "-m", "camcmm.cli.main", "serve", "--project", str(tmp_path / "p"), *args],
            capture_output=True,
            text=True,
            timeout=60,
            env=env,
        )
        assert r.returncode != 0 and words in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert not (tmp_path / "p").exists()


# -- the middleware on mocked requests -------------------------------------------------------
aiohttp = pytest.importorskip("aiohttp")
from aiohttp.test_utils import make_mocked_request  # noqa: E402

HOST = "127.0.0.1:8080"


def _check(guard, path, headers=None, method="GET"):
    req = make_mocked_request(method, path, headers={"Host": HOST, **(headers or {})})
    return asyncio.run(guard.check(req))


def test_guard_requires_the_token_everywhere():
    token = new_token()
    g = Guard(token)
    cookie = {"Cookie": f"{g.cookie_name}={token}"}
    for path in ("/", "/index.html", "/ws", "/projector", "/projector/state", "/ins-downloads/report.pdf"):
        assert _check(g, path).status == 403
        assert _check(g, path + "?token=wrong").status == 403
        assert _check(g, path, {"Cookie": f"{g.cookie_name}=wrong"}).status == 403
        assert _check(g, path, {"Authorization": "token nope"}).status == 403
    assert _check(g, "/projector/ack?v=1", method="POST").status == 403
    # the token once in the address: a cookie for the rest, the token gone from the address
    r = _check(g, "/projector?token=" + token)
    assert r.status == 302 and r.headers["Location"] == "projector"
    c = r.cookies[g.cookie_name]
    assert c.value == token and c["httponly"] and c["samesite"] == "Strict" and c["path"] == "/"
    assert _check(g, "/projector/state", cookie) is None
    assert _check(g, "/projector/ack?v=1", cookie, method="POST") is None
    assert _check(g, "/projector/state", {"Authorization": f"token {token}"}) is None
    assert _check(g, "/ws", {**cookie, "Upgrade": "websocket", "Connection": "Upgrade"}) is None
    # the app page: no secret in any address (issue 26); the page asks paraview/ for it
    r = _check(g, f"/?token={token}&ui=main")
    assert r.status == 302 and r.headers["Location"] == "index.html?ui=main"
    assert _check(g, "/index.html", cookie) is None
    assert _check(g, f"/index.html?secret={token}&ui=main", cookie).headers["Location"] == "index.html?ui=main"
    assert g.is_secret_request("/paraview/") and not g.is_secret_request("/x/paraview/")
    assert json.loads(g.page_secret().body)["secret"] == token
    assert _check(g, "/paraview/", method="POST").status == 403  # only for a page that passed the checks
    assert _check(g, "/paraview/", {**cookie, "Origin": "http://evil.example"}, method="POST").status == 403
    assert g.refused >= 25


def test_guard_refuses_other_origins_even_with_the_token():
    token = new_token()
    g = Guard(token, allowed_origins=["https://lab.example"])
    ok = {"Cookie": f"{g.cookie_name}={token}", "Upgrade": "websocket"}
    assert _check(g, "/ws", {**ok, "Origin": "http://127.0.0.1:8080"}) is None
    for origin in (
        "http://127.0.0.1:8081",
        "http://localhost:8080",
        "https://evil.example",
        "null",
        "http://127.0.0.1.evil.example:8080",
        "file://",
    ):
        r = _check(g, "/ws", {**ok, "Origin": origin})
        assert r.status == 403 and b"another origin" in r.body, origin
        assert _check(g, "/projector/ack?v=1", {**ok, "Origin": origin}, method="POST").status == 403
    assert _check(g, "/ws", {**ok, "Origin": "https://lab.example"}) is None  # --allow-origin
    # behind a TLS proxy that passes the Host on: https://HOST on port 443
    req = make_mocked_request("GET", "/ws", headers={**ok, "Host": "lab2.example", "Origin": "https://lab2.example"})
    assert asyncio.run(g.check(req)) is None
    # a subresource another site or port asked for (an <img>, a fetch) is refused; a navigation is not
    for site in ("cross-site", "same-site"):
        assert _check(g, "/projector/state", {**ok, "Sec-Fetch-Site": site, "Sec-Fetch-Mode": "no-cors"}).status == 403
    assert _check(g, "/projector/state", {**ok, "Sec-Fetch-Site": "same-origin", "Sec-Fetch-Mode": "cors"}) is None
    assert _check(g, "/projector", {**ok, "Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "navigate"}) is None
    framed = {**ok, "Sec-Fetch-Site": "same-site", "Sec-Fetch-Mode": "navigate", "Sec-Fetch-Dest": "iframe"}
    assert _check(g, "/index.html", framed).status == 403  # the app in another site's frame


def test_the_guards_of_the_front_and_of_a_session_child():
    """The front: a session's page ``/s/<id>/`` is the app page (it gets the websocket
    secret); ``/`` is not. A child: its own secret in ``Authorization``, the user's token
    as the websocket's secret, and nothing else opens it."""
    from camcmm.gui.security import SESSION_APP_PAGE

    token, child_secret = new_token(), new_token()
    front = Guard(token, app_page=SESSION_APP_PAGE)
    r = _check(front, f"/?token={token}")
    assert r.status == 302 and r.headers["Location"] == "./" and r.cookies[front.cookie_name].value == token
    cookie = {"Cookie": f"{front.cookie_name}={token}"}
    assert _check(front, "/", cookie) is None  # the launcher's own page: opens a session
    for page in ("/s/abc-_1/", "/s/abc-_1/index.html"):
        assert _check(front, page, cookie) is None  # no secret in the address (issue 26)
        assert _check(front, page + f"?secret={token}", cookie).headers["Location"] == "index.html"
    assert _check(front, "/s/abc/projector", cookie) is None
    assert _check(front, "/s/abc/", {"Cookie": f"{front.cookie_name}=wrong"}).status == 403
    child = Guard(child_secret, ws_secret=token)
    assert child.wslink_args() == [f"--authKey={token}"]
    assert _check(child, "/", {"Authorization": f"token {child_secret}"}) is None
    for headers in ({"Authorization": f"token {token}"}, {"Cookie": f"{child.cookie_name}={token}"}, {}):
        assert _check(child, "/index.html", headers).status == 403
    assert _check(child, f"/?token={token}").status == 403
    assert Guard(child_secret, ws_secret=None).wslink_args() == []  # --no-token: the client's default


def test_without_a_token_the_origin_is_still_checked():
    g = Guard(None)
    assert _check(g, "/projector/state") is None
    assert _check(g, "/ws", {"Origin": "http://127.0.0.1:9999"}).status == 403


# -- a real server (the front and its session children) ----------------------------------------
#: The tests on ``server`` form one xdist work unit: one GUI server (front + session children) per
#: run instead of one per worker (under --dist loadgroup an ungrouped test is scheduled alone).
ON_SERVER = pytest.mark.xdist_group("security-server")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    pytest.importorskip("trame")
    from camcmm.gui.process import GuiProcess

    try:
        s = GuiProcess(tmp_path_factory.mktemp("sec") / "proj", args=("--max-sessions", "2"))
    except CamcmmError as exc:
        pytest.fail(str(exc))
    s.opened = []  # the sessions the tests opened: the limit test counts them
    yield s
    s.stop()


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


def _http(url, method="GET", headers=None, context=None):
    req = urllib.request.Request(url, method=method, headers=headers or {}, data=b"" if method == "POST" else None)
    handlers = [_NoRedirect()] + ([urllib.request.HTTPSHandler(context=context)] if context else [])
    try:
        with urllib.request.build_opener(*handlers).open(req, timeout=60) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def _open_session(server, context=None) -> str:
    """What a new tab does: ``/`` gives it a session of its own, ``s/<id>/``."""
    status, headers, body = _http(server.base, headers={"Authorization": f"token {server.token}"}, context=context)
    assert status == 302 and headers["Location"].startswith("s/"), (status, body)
    sid = headers["Location"][2:].rstrip("/")
    getattr(server, "opened", []).append(sid)
    return sid


@pytest.fixture(scope="module")
def sid(server):
    return _open_session(server)


@pytest.mark.slow
@ON_SERVER
def test_the_server_answers_nothing_without_its_token(server, sid):
    assert server.token and len(server.token) >= 43 and server.url == f"{server.base}?token={server.token}"
    paths = [
        "",
        "index.html",
        "projector",
        "projector/state",
        "projector/pattern.png",
        "ws",
        "wz-downloads/report.html",
    ]
    paths += ["assets/x.js", "s/invented/", f"s/{sid}/", f"s/{sid}/index.html", f"s/{sid}/ws", f"s/{sid}/assets/x.js"]
    paths += [f"s/{sid}/projector", f"s/{sid}/projector/state", f"s/{sid}/wz-downloads/report.html"]
    for path in paths:
        status, _, body = _http(server.base + path)
        assert status == 403 and b"token" in body and len(body) < 200, (path, status, body)
    assert _http(server.base + "projector/ack?v=1", "POST")[0] == 403
    assert _http(server.base + f"s/{sid}/projector/ack?v=1", "POST")[0] == 403
    status, headers, _ = _http(server.url)
    assert status == 302 and server.token in headers["Set-Cookie"] and "HttpOnly" in headers["Set-Cookie"]
    auth = {"Authorization": f"token {server.token}"}
    status, headers, body = _http(server.base + f"s/{sid}/projector/state", headers=auth)
    assert status == 200 and json.loads(body)["version"] == 0
    assert headers["X-Frame-Options"] == "SAMEORIGIN" and "frame-ancestors 'self'" in headers["Content-Security-Policy"]
    ack = server.base + f"s/{sid}/projector/ack?v=1"
    assert _http(ack, "POST", auth)[0] == 200
    assert _http(ack, "POST", {**auth, "Origin": "http://127.0.0.1:1"})[0] == 403
    # the app page of a session carries no secret in its address (issue 26): the page asks
    # paraview/ for its session's own websocket secret, which is not the user's token
    cookie = {"Cookie": f"camcmm-token-{server.base.rsplit(':', 1)[1].strip('/')}={server.token}"}
    status, headers, _ = _http(server.base + f"s/{sid}/", headers=cookie)
    assert "secret" not in headers.get("Location", "") and server.token not in headers.get("Location", "")
    own = {**cookie, "Origin": server.base.rstrip("/")}
    status, _, body = _http(server.base + f"s/{sid}/paraview/", "POST", own)
    assert status == 200 and json.loads(body)["secret"] != server.token


@ON_SERVER
def test_the_websocket_needs_the_token_the_origin_and_the_secret(server, sid):
    async def probe():
        ws_url = server.base.replace("http", "ws", 1) + f"s/{sid}/ws"
        own = server.base.rstrip("/")
        results = {}
        async with aiohttp.ClientSession() as http:
            for name, headers in (
                ("no token", {"Origin": own}),
                ("other origin", {"Origin": "http://127.0.0.1:1", "Authorization": f"token {server.token}"}),
            ):
                try:
                    async with http.ws_connect(ws_url, headers=headers):
                        results[name] = "open"
                except aiohttp.WSServerHandshakeError as e:
                    results[name] = e.status
            # with the token and the right origin the socket opens, but the trame client's
            # default secret is refused, and so is the token: only the session's own secret,
            # which its page gets from paraview/ (issue 26), authenticates
            hdr = {"Origin": own, "Authorization": f"token {server.token}"}
            async with http.post(server.base + f"s/{sid}/paraview/", data="{}", headers=hdr) as info:
                own_secret = (await info.json())["secret"]
            for name, secret in (("default secret", "wslink-secret"), ("token", server.token), ("own", own_secret)):
                async with http.ws_connect(ws_url, headers=hdr) as ws:
                    hello = {
                        "wslink": "1.0",
                        "id": "system:c0:0",
                        "method": "wslink.hello",
                        "args": [{"secret": secret}],
                        "kwargs": {},
                    }
                    await ws.send_bytes(_wslink_frame(hello))
                    msg = await ws.receive(timeout=20)
                    results[name] = _wslink_reply(msg)
        return results

    r = asyncio.run(probe())
    assert r["no token"] == 403 and r["other origin"] == 403, r
    assert "error" in r["default secret"] and "result" not in r["default secret"], r
    assert "error" in r["token"] and "result" not in r["token"], r
    assert "result" in r["own"], r


@ON_SERVER
def test_a_session_child_answers_nobody_but_the_front(server, sid):
    """The child listens on 127.0.0.1 with a secret only the front holds: the user's token,
    cookie or Origin get nothing from it, over HTTP or websocket."""
    import re

    ports = dict(re.findall(r"session (\S{6}): ready on 127\.0\.0\.1:(\d+)", "".join(server.log)))
    port = ports[sid[:6]]
    child = f"http://127.0.0.1:{port}/"
    cookie = {"Cookie": f"camcmm-token-{port}={server.token}"}
    for headers in ({}, {"Authorization": f"token {server.token}"}, cookie, {"Origin": f"http://127.0.0.1:{port}"}):
        for path in ("", "index.html", "projector/state", f"index.html?secret={server.token}"):
            status, _, body = _http(child + path, headers=headers)
            assert status == 403, (path, headers, status, body)
        assert _http(child + f"?token={server.token}")[0] == 403

    async def ws():
        async with aiohttp.ClientSession() as http:
            try:
                async with http.ws_connect(
                    child.replace("http", "ws") + "ws", headers={"Authorization": f"token {server.token}"}
                ):
                    return "open"
            except aiohttp.WSServerHandshakeError as e:
                return e.status

    assert asyncio.run(ws()) == 403


@ON_SERVER
def test_an_invented_session_id_is_refused(server):
    auth = {"Authorization": f"token {server.token}"}
    status, headers, body = _http(server.base + "s/AAAAAAAAAAAAAAAA/", headers=auth)
    assert status == 404 and b"no such session" in body and b"Open a new session" in body
    assert b"Traceback" not in body and headers["X-Frame-Options"] == "SAMEORIGIN"
    for path in ("s/AAAAAAAAAAAAAAAA/ws", "s/AAAAAAAAAAAAAAAA/projector/state", "s/../etc/passwd", "s/%2e%2e/x"):
        status, _, body = _http(server.base + path, headers=auth)
        assert status in (400, 404) and body.count(b"\n") <= 1 and b"Traceback" not in body, (path, status, body)


@ON_SERVER
def test_the_number_of_sessions_is_limited(server, sid):
    """--max-sessions 2: the third tab gets a one-line 503; nothing else is started."""
    while len(server.opened) < 2:
        _open_session(server)
    status, _, body = _http(server.base, headers={"Authorization": f"token {server.token}"})
    assert status == 503 and body.count(b"\n") == 1 and b"--max-sessions" in body, (status, body)
    assert b"2 sessions are open" in body


def _wslink_frame(obj) -> bytes:
    """One wslink 2 message: msgpack in a single chunk (header: id, offset, size)."""
    import struct

    import msgpack

    body = msgpack.packb(obj)
    return struct.pack("<III", 0, 0, len(body)) + body


def _wslink_reply(msg) -> dict:
    import msgpack

    data = msg.data if isinstance(msg.data, bytes) else bytes(msg.data or b"")
    return msgpack.unpackb(data[12:]) if len(data) > 12 else {"error": f"closed ({msg.type})"}


# -- the three places a page names a path on the server ----------------------------------------
@pytest.mark.slow
def test_the_page_reaches_only_the_roots_in_each_of_the_three_places(tree):
    """Import by path, the Calibration page's server folder and a plugin parameter
    naming an output folder: outside the roots each is refused with one line that names
    the path and shows nothing of the file; inside they work."""
    pytest.importorskip("pyvista")
    from camcmm.gui.app import build, close

    server, session = build(f"test-sec-{os.getpid()}", tree.proj, data_roots=[tree.data])
    server.state.ready()
    state, ctrl = server.state, server.controller
    try:

        async def steps():
            out = {}
            for name, path in (
                ("outside", tree.outside / "secret.xyz"),
                ("dotdot", "../outside/secret.xyz"),
                ("passwd", "/etc/passwd"),
            ):
                state.error_message = ""
                await ctrl.import_server_path(str(path))
                out[name] = state.error_message
            n_items = len(state.items)
            await ctrl.import_server_path(str(tree.data / "scan.xyz"))  # a data root: imported
            out["imported"] = len(state.items) - n_items
            # inside a root but not a cloud: the reason names the file, not its content
            (tree.data / "notes.xyz").write_text(f"{SECRET} and more\n")
            state.error_message = ""
            await ctrl.import_server_path(str(tree.data / "notes.xyz"))
            out["bad file"] = state.error_message
            # a plugin form: an output folder outside is refused before the plugin runs
            state.error_message = ""
            n_results = len(state.results)
            await ctrl.run_plugin_form(
                "fringe.patterns", {"out": str(tree.outside / "patterns")}, {"sequence": "seq.yaml"}
            )
            out["plugin"], out["ran"] = state.error_message, len(state.results) - n_results
            return out

        out = asyncio.run(steps())
        for name in ("outside", "dotdot", "passwd"):
            assert "outside the folders this server may read" in out[name], (name, out[name])
            assert SECRET not in out[name] and "root:" not in out[name] and "\n" not in out[name]
        assert out["imported"] == 1
        assert "notes.xyz" in out["bad file"] and SECRET not in out["bad file"], out["bad file"]
        assert out["plugin"].startswith("parameter 'out'") and "outside the folders" in out["plugin"], out["plugin"]
        assert out["ran"] == 0 and not (tree.outside / "patterns").exists()

        # the Calibration page's folder on the server
        page = server.pages["calibration"]
        req = {
            "mode": "camera",
            "source": "folder",
            "folder": str(tree.outside),
            "left_pattern": "*",
            "board": "chessboard:9x6:25",
        }
        assert asyncio.run(page.run_async(req)) is None
        assert "server folder" in state.cal_error and "outside the folders" in state.cal_error, state.cal_error
        (tree.proj / "boards").symlink_to(tree.outside)  # a link in the project to a folder elsewhere
        assert asyncio.run(page.run_async({**req, "folder": str(tree.proj / "boards")})) is None
        assert "outside the folders" in state.cal_error
        # allowed, but holds no board images
        assert asyncio.run(page.run_async({**req, "folder": str(tree.data)})) is None
        assert "no image files" in state.cal_error and "outside" not in state.cal_error

        # and a device that reads a file (the CSV interferometer): the same folders
        secret = {"path": str(tree.outside / "secret.xyz")}
        assert server.pages["devices"].add("devices.interferometer.csv", secret) is None
        assert "parameter 'path'" in state.dev_error and "outside the folders" in state.dev_error, state.dev_error
        assert SECRET not in state.dev_error
    finally:
        close(server)


@pytest.mark.slow
def test_https_with_certfile_and_keyfile(tmp_path):
    """``--certfile/--keyfile``: the server prints an https URL and answers over TLS."""
    import shutil
    import ssl

    pytest.importorskip("trame")
    if not shutil.which("openssl"):
        pytest.skip("openssl is absent: no certificate to make")
    cert, key = tmp_path / "c.pem", tmp_path / "k.pem"
    subprocess.run(
        [
            "openssl",
            "req",
            "-x509",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-keyout",
            str(key),
            "-out",
            str(cert),
            "-days",
            "1",
            "-subj",
            "/CN=127.0.0.1",
        ],
        check=True,
        capture_output=True,
        timeout=60,
    )
    from camcmm.gui.process import GuiProcess

    s = GuiProcess(tmp_path / "proj", args=("--certfile", cert, "--keyfile", key))
    try:
        assert s.url.startswith("https://127.0.0.1:") and s.token
        ctx = ssl.create_default_context(cafile=str(cert))
        ctx.check_hostname = False
        sid = _open_session(s, context=ctx)
        state = s.base + f"s/{sid}/projector/state"
        assert _http(state, headers={"Authorization": f"token {s.token}"}, context=ctx)[0] == 200
        assert _http(state, context=ctx)[0] == 403
    finally:
        s.stop()


@pytest.mark.slow
def test_a_token_beginning_with_a_dash_reaches_wslink():
    """token_urlsafe begins with '-' once in 64 launches; trame's argparse must still take it
    as the websocket secret (it once read '--authKey -x…' as a missing value and the server
    did not start)."""
    from trame.app import get_server

    from camcmm.gui.security import Guard

    token = "-" + "x" * 42
    args, _ = get_server("test-dash-token", client_type="vue3").cli.parse_known_args(Guard(token).wslink_args())
    assert args.authKey == token
