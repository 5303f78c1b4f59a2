"""The GUI in a child process: start it, learn its URL, stop or kill it.

Used by the browser tests and benchmarks (and open to a lab's own end-to-end tests):
``python -m camcmm.gui PROJECT --port 0`` picks a free port and prints
``camcmm GUI: http://...``, which is read here.
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

from ..errors import CamcmmError


class GuiProcess:
    """``python -m camcmm.gui PROJECT --port 0`` in a subprocess; ``url`` once it listens,
    ``log`` every line it printed."""

    def __init__(self, project: str | Path, timeout: float = 60.0):
        env = dict(os.environ, PYTHONUNBUFFERED="1", VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
        self.proc = subprocess.Popen([sys.executable, "-m", "camcmm.gui", str(project), "--port", "0"],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
        self.log: list[str] = []
        lines: queue.Queue[str] = queue.Queue()

        def pump() -> None:  # keep reading, or the child blocks on a full pipe
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
            m = re.search(r"camcmm GUI: (http://\S+)", line)
            if m:
                self.url = m.group(1)
        if self.url is None:
            self.kill()
            raise CamcmmError("the GUI server did not print its URL: " + " | ".join(self.log[-20:]))

    def kill(self) -> None:
        """SIGKILL: no shutdown handler runs, as in a crash or a pulled plug."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=10)

    def stop(self, timeout: float = 10.0) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.kill()
