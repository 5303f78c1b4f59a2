"""The trame GUI shell: a thin layer over the plugin host and the project store.

The pages live in :mod:`camcmm.gui.pages` (one folder each: state and handlers
testable without a browser, layout, figures); what they share in
:mod:`camcmm.gui.session` (the project's items, messages, the loop) and
:mod:`camcmm.gui.view` (the 3D scene, an off-screen pyvista plotter rendered
server-side); :mod:`camcmm.gui.app` mounts the pages in one layout. Importing this
package loads neither trame nor VTK; :func:`serve` does.

``$CAMCMM_GUI_PRELOAD``: modules (names, or paths of ``.py`` files) separated by
``os.pathsep``, imported by :func:`serve` before the app is built, so that a page they
:func:`~camcmm.gui.pages.register` appears (a lab's own page, a browser test's; see
``GuiProcess(preload=...)``).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from pathlib import Path
from typing import Iterable

PRELOAD = "CAMCMM_GUI_PRELOAD"


def setup_offscreen() -> None:
    """Render with EGL off screen (no X server); must run before VTK makes a window."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True


def preload(entries: str | None = None) -> list[str]:
    """Import the modules of ``entries`` (default ``$CAMCMM_GUI_PRELOAD``; names or
    ``.py`` paths separated by ``os.pathsep``); returns their names. A module that
    cannot be imported raises (the server must not start without a page it was told of)."""
    text = os.environ.get(PRELOAD, "") if entries is None else entries
    names = []
    for entry in filter(None, (e.strip() for e in text.split(os.pathsep))):
        if entry.endswith(".py"):
            path = Path(entry)
            spec = importlib.util.spec_from_file_location(f"camcmm_preload_{path.stem}", path)
            if spec is None or spec.loader is None:
                raise ImportError(f"{PRELOAD}: cannot load {entry}")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            names.append(spec.name)
        else:
            names.append(importlib.import_module(entry).__name__)
    return names


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
    preload()
    server, _session = build(server_name, project_dir, data_roots=data_roots)
    from .. import worker

    worker.warm_later(_session.host)  # the plugin worker process starts while the page loads
    start(server, host=host, port=port, open_browser=open_browser, token=token, allowed_origins=allowed_origins,
          certfile=certfile, keyfile=keyfile)


__all__ = ["PRELOAD", "preload", "serve", "setup_offscreen"]
