"""The trame GUI shell: a thin layer over the plugin host and the project store.

Logic lives in :mod:`camcmm.gui.session` (testable without a browser), the 3D scene
in :mod:`camcmm.gui.view` (an off-screen pyvista plotter rendered server-side) and the
page layout in :mod:`camcmm.gui.app`. Importing this package loads neither trame nor
VTK; :func:`serve` does.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable


def setup_offscreen() -> None:
    """Render with EGL off screen (no X server); must run before VTK makes a window."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True


def serve(project_dir: str | Path, host: str = "127.0.0.1", port: int = 0, open_browser: bool = False,
          server_name: str = "camcmm", *, data_roots: Iterable[str | Path] = (), no_token: bool = False,
          token_file: str | Path | None = None, allowed_origins: Iterable[str] = (),
          certfile: str | None = None, keyfile: str | None = None) -> None:
    """Open (or create) the project in ``project_dir`` and serve the GUI until stopped.

    Prints ``camcmm GUI: http://HOST:PORT/?token=TOKEN`` once the server listens
    (``port=0`` picks a free port). The token is random per launch, or read from
    ``token_file`` / ``$CAMCMM_TOKEN``; ``no_token`` only on a loopback ``host``. The
    browser reaches only the project folder and ``data_roots``. Bad options raise a
    one-line :class:`~camcmm.errors.CamcmmError` before anything starts.
    """
    from .app import build, start
    from .roots import Roots
    from .security import choose_token

    token = choose_token(host, no_token=no_token, token_file=token_file)
    Roots(project_dir, data_roots)  # a missing --data-root is refused before the project is made
    server, _session = build(server_name, project_dir, data_roots=data_roots)
    from .. import worker

    worker.warm_later(_session.host)  # the plugin worker process starts while the page loads
    start(server, host=host, port=port, open_browser=open_browser, token=token, allowed_origins=allowed_origins,
          certfile=certfile, keyfile=keyfile)


__all__ = ["serve", "setup_offscreen"]
