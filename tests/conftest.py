"""Shared test fixtures: repository paths, the ../shared data folder, a GUI server."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture
def shared_data():
    """Path of ../shared/data; skips the test where it is absent (a user's fresh clone)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"{SHARED_DATA} is absent (only CI and developers have ../shared)")
    return SHARED_DATA


@pytest.fixture
def gui_server(tmp_path):
    """Start the GUI on a fresh project; yield its URL and its output lines."""
    from camcmm.errors import CamcmmError
    from camcmm.gui.process import GuiProcess

    try:
        server = GuiProcess(tmp_path / "proj")
    except CamcmmError as exc:
        pytest.fail(str(exc))
    yield server.url, server.log
    server.stop()
