"""The GUI in a child process: start it, learn its URL, stop or kill it.

Used by the browser tests and benchmarks (and open to a lab's own end-to-end tests):
``python -m camcmm.gui PROJECT --port 0`` picks a free port and prints
``camcmm GUI: http://HOST:PORT/?token=TOKEN``, which is read here. That is the session
launcher's front (:mod:`camcmm.gui.launcher`), printed once its first session process is
ready: every page opened at ``url`` gets a session (a process) of its own under
``/s/<id>/``; ``args=("--single-session",)`` serves all pages from one process.
"""

from __future__ import annotations

import os
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import parse_qs, urlencode, urlsplit

from ..errors import CamcmmError


class GuiProcess:
    """``python -m camcmm.gui PROJECT --port 0`` in a subprocess. Once it listens:
    ``url`` as printed (with ``?token=``: open it in the browser), ``base``
    (``http://HOST:PORT/``), ``token``; ``log`` every line it printed.
    ``data_roots``: folders the browser may reach besides the project; ``args``: more
    options of ``python -m camcmm.gui``; ``preload``: modules (names or ``.py`` paths)
    the server imports before it builds the app, e.g. one that registers a page of a
    test (``$CAMCMM_GUI_PRELOAD``, see :func:`camcmm.gui.pages.preload`)."""

    def __init__(
        self, project: str | Path, timeout: float = 60.0, data_roots: tuple = (), args: tuple = (), preload: tuple = ()
    ):
        env = dict(os.environ, PYTHONUNBUFFERED="1", VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
        env.pop("CAMCMM_TOKEN", None)  # a fresh random token per launch, whatever the caller's shell holds
        env["CAMCMM_GUI_PRELOAD"] = os.pathsep.join(str(m) for m in preload)  # never the caller's
        cmd = [sys.executable, "-m", "camcmm.gui", str(project), "--port", "0"]
        for d in data_roots:
            cmd += ["--data-root", str(d)]
        self.proc = subprocess.Popen(
            cmd + [str(a) for a in args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
        )
        self.log: list[str] = []
        lines: queue.Queue[str] = queue.Queue()

        def pump() -> None:  # keep reading, or the child blocks on a full pipe
            assert self.proc.stdout is not None  # stdout=PIPE above
            for line in self.proc.stdout:
                self.log.append(line)
                lines.put(line)

        threading.Thread(target=pump, daemon=True).start()
        self.url: str | None = None
        deadline = time.monotonic() + timeout
        while self.url is None and time.monotonic() < deadline:
            try:
                line = lines.get(timeout=0.5)
            except queue.Empty:
                if self.proc.poll() is not None:
                    break
                continue
            m = re.search(r"camcmm GUI: (https?://\S+)", line)
            if m:
                self.url = m.group(1)
        if self.url is None:
            self.kill()
            raise CamcmmError("the GUI server did not print its URL: " + " | ".join(self.log[-20:]))
        u = urlsplit(self.url)
        self.base = f"{u.scheme}://{u.netloc}/"
        self.token: str | None = parse_qs(u.query).get("token", [None])[0]

    def at(self, path: str, token: bool = True) -> str:
        """The address of ``path`` on the server (``/projector``), with the token. A path
        outside ``/s/<id>/`` reaches the only open session (docs/security.md, Sessions)."""
        url = self.base.rstrip("/") + "/" + path.lstrip("/")
        return f"{url}?{urlencode({'token': self.token})}" if token and self.token else url

    def kill(self) -> None:
        """SIGKILL: no shutdown handler runs, as in a crash or a pulled plug."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=10)

    def stop(self, timeout: float = 20.0) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.kill()
