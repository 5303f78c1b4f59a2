"""A session's child process, its own side: the secrets it gets from the front, the line
that tells the front its port, what the page shows when the connection ends, and the
watch that stops it when the front is gone (no orphan, even after a SIGKILL)."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import MutableMapping
from typing import Any

from ...errors import CamcmmError

#: the child's own secret: every request must carry it (``Authorization: token …``)
SECRET_ENV = "CAMCMM_SESSION_SECRET"
#: the websocket's secret: the user's token, which the browser holds (empty: none)
WS_SECRET_ENV = "CAMCMM_SESSION_WS_SECRET"
#: the line the front waits for (no secret in it: the front forwards the child's output)
READY = "camcmm session ready: port "
#: shown in the page (trame's error template) when its websocket closes
ENDED_TEMPLATE = (
    '<div class="pa-8 text-h6" data-testid="session-ended">'
    "camcmm: the connection to this session was lost (its server stopped or closed it). "
    '<a href="./">Reload</a> to go on, or <a href="../../">open a new session</a>: '
    "everything saved is in the project.</div>"
)


def take_secrets(env: MutableMapping[str, str] | None = None) -> tuple[str, str | None]:
    """The child's secret and the websocket's, removed from the environment (the plugin
    worker need not inherit them)."""
    env = os.environ if env is None else env
    secret = env.pop(SECRET_ENV, "")
    ws_secret = env.pop(WS_SECRET_ENV, "") or None
    if len(secret) < 16:
        raise CamcmmError("--session-child: started without its secret (only the session launcher starts children)")
    return secret, ws_secret


def announce(port: int) -> None:
    print(f"{READY}{port}", flush=True)


def prepare(server: Any, session: Any) -> None:
    """A clear message in the page when the connection ends, and the project's items
    listed again whenever a tab connects (a child started in advance, a reload, or items
    another session stored meanwhile)."""
    server.state.trame__template_error = ENDED_TEMPLATE

    def connected(**_: Any) -> None:
        with server.state:
            session.refresh_items()
            session.refresh_results()

    server.controller.on_client_connected.add(connected)


def watch_parent(fd: int = 0, grace: float = 15.0) -> threading.Thread:
    """Stop this process when its stdin (a pipe from the front) ends: the front stopped
    or was killed. A SIGTERM first (the normal shutdown removes the temporary folders),
    then an exit if that did not end it within ``grace`` seconds. Reads the bare file
    descriptor: a daemon thread blocked in Python's buffered stdin would hold its lock
    at interpreter exit."""

    def watch() -> None:
        try:
            while os.read(fd, 4096):
                pass
        except OSError:
            pass
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(grace)
        os._exit(3)

    t = threading.Thread(target=watch, daemon=True, name="camcmm-session-parent")
    t.start()
    return t
