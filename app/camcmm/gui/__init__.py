"""The trame GUI shell: a thin layer over the plugin host and the project store.

The pages live in :mod:`camcmm.gui.pages` (one folder each: state and handlers
testable without a browser, layout, figures); what they share in
:mod:`camcmm.gui.session` (the project's items, messages, the loop) and
:mod:`camcmm.gui.view` (the 3D scene, an off-screen pyvista plotter rendered
server-side); :mod:`camcmm.gui.app` mounts the pages in one layout and serves it
(:func:`camcmm.gui.app.serve`). Importing this package loads neither trame nor VTK.
"""

from __future__ import annotations

import os


def setup_offscreen() -> None:
    """Render with EGL off screen (no X server); must run before VTK makes a window."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True


__all__ = ["setup_offscreen"]
