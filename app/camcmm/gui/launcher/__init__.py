"""One app process per browser session, behind one front server (``camcmm serve``).

trame keeps one state per server process and sends it to every connected tab, so two
tabs of one server would switch each other's pages. The front (:mod:`.front`) owns the
public port and runs the token/Origin guard; each tab that opens ``/`` gets a session
``/s/<id>/`` served by a child process of its own (:mod:`.sessions`, :mod:`.child`),
reverse-proxied (:mod:`.proxy`) from 127.0.0.1. The project store is shared: SQLite in
WAL mode with content-addressed data files is safe for several processes. Limits:
``max_sessions`` children, each stopped ``idle`` seconds after its last tab closed, or
``unused`` seconds after it was opened when no tab ever connected (a plain ``GET /``
must not hold a session for long); ``max_upload`` bytes uploaded at once per session.
``--single-session`` serves one process as before (docs/security.md).
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import ssl
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

from ...errors import CamcmmError

DEFAULT_MAX_SESSIONS = 4
DEFAULT_IDLE_S = 300.0
DEFAULT_UNUSED_S = 30.0


def serve_sessions(
    project_dir: str | Path,
    *,
    host: str,
    port: int,
    token: str | None,
    data_roots: Iterable[str | Path] = (),
    allowed_origins: Iterable[str] = (),
    certfile: str | None = None,
    keyfile: str | None = None,
    max_sessions: int = DEFAULT_MAX_SESSIONS,
    idle: float = DEFAULT_IDLE_S,
    unused: float = DEFAULT_UNUSED_S,
    max_upload: int | None = None,
    open_browser: bool = False,
    announce: Callable[[str], None] | None = None,
) -> None:
    """Serve until SIGINT/SIGTERM; print ``camcmm GUI: URL`` once the first session child
    is ready. Options are checked (one-line :class:`CamcmmError`) before anything starts."""
    from ...project import Project
    from ..security import escape_log_records
    from ..uploads import DEFAULT_MAX_UPLOAD, MAX_UPLOAD_ENV
    from .front import Front, run, session_guard
    from .sessions import Sessions, child_command

    if max_sessions < 1:
        raise CamcmmError(f"--max-sessions {max_sessions}: at least 1")
    if idle <= 0:
        raise CamcmmError(f"--session-idle {idle:g}: a number of seconds above 0")
    if not unused > 0:
        raise CamcmmError(f"--session-unused {unused:g}: a number of seconds above 0")
    ssl_context = None
    if certfile or keyfile:
        if not (certfile and keyfile):
            raise CamcmmError("--certfile and --keyfile go together")
        ssl_context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
        try:
            ssl_context.load_cert_chain(certfile, keyfile)
        except (OSError, ssl.SSLError) as exc:
            raise CamcmmError(f"--certfile/--keyfile: cannot load them ({exc})") from None
    project = Path(project_dir).expanduser().resolve()
    Project.open_or_create(project).close()  # made or migrated once, before any child opens it
    escape_log_records()  # the front's own log, as each child's
    guard = session_guard(token, allowed_origins)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("CAMCMM_TOKEN", None)
    env[MAX_UPLOAD_ENV] = str(DEFAULT_MAX_UPLOAD if max_upload is None else int(max_upload))
    sessions = Sessions(
        child_command(str(project), [str(d) for d in data_roots]),
        env,
        max_sessions=max_sessions,
        idle=idle,
        unused=unused,
    )
    scheme = "https" if ssl_context else "http"
    shown = socket.gethostname() if host in ("0.0.0.0", "::", "") else (f"[{host}]" if ":" in host else host)
    say = announce or (lambda line: print(line, flush=True))

    def ready(bound: int) -> None:
        guard.cookie_name = f"camcmm-token-{bound}"  # one cookie per port, as the single server's
        url = guard.url(f"{scheme}://{shown}:{bound}/")
        say(f"camcmm GUI: {url}")
        say(
            f"camcmm: one process per browser session: at most {max_sessions}, "
            f"each closed {idle:g} s after its last tab"
        )
        if open_browser:
            import webbrowser

            webbrowser.open(url)

    loop = asyncio.new_event_loop()
    task = loop.create_task(run(Front(sessions, guard), host, port, ssl_context, ready))
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, task.cancel)
        except (NotImplementedError, RuntimeError):  # not on this platform / thread
            pass
    try:
        loop.run_until_complete(task)
    except asyncio.CancelledError:
        pass
    except OSError as exc:
        raise CamcmmError(f"cannot listen on {host} port {port}: {exc.strerror or exc}") from None
    except RuntimeError as exc:
        raise CamcmmError(str(exc)) from None
    finally:
        loop.close()
        sys.stdout.flush()
