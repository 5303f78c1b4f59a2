"""The trame GUI shell: a thin layer over the plugin host and the project store.

Logic lives in :mod:`camcmm.gui.session` (testable without a browser), the 3D scene
in :mod:`camcmm.gui.view` (an off-screen pyvista plotter rendered server-side) and the
page layout in :mod:`camcmm.gui.app`. Importing this package loads neither trame nor
VTK; :func:`serve` does.
"""

from __future__ import annotations

import os
from pathlib import Path


def setup_offscreen() -> None:
    """Render with EGL off screen (no X server); must run before VTK makes a window."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True


def serve(project_dir: str | Path, host: str = "127.0.0.1", port: int = 0, open_browser: bool = False,
          server_name: str = "camcmm") -> None:
    """Open (or create) the project in ``project_dir`` and serve the GUI until stopped.

    Prints ``camcmm GUI: http://HOST:PORT/`` once the server listens (``port=0`` picks
    a free port).
    """
    from .app import build, start

    server, _session = build(server_name, project_dir)
    start(server, host=host, port=port, open_browser=open_browser)


__all__ = ["serve", "setup_offscreen"]
