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


_gui_names = __import__("itertools").count()


@pytest.fixture
def gui_app(tmp_path):
    """Build GUI servers in-process (no browser, no port): ``make(project_dir=None, **build_kw)``
    returns ``(server, session)``; the page objects are ``server.pages[key]``. Every server
    made is closed after the test."""
    from camcmm.gui.app import build, close

    made = []

    def make(project_dir=None, **kw):
        server, session = build(f"test-gui-{os.getpid()}-{next(_gui_names)}", project_dir or tmp_path / "proj", **kw)
        server.state.ready()
        made.append(server)
        return server, session

    yield make
    for server in made:
        close(server)


def run_camcmm(*args, ok=True, timeout=300, **kw):
    """``python -m camcmm ARGS`` in a subprocess; asserts exit 0 when ``ok``; returns the
    CompletedProcess (text). Import it from conftest in a test module."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "camcmm", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, **kw)
    if ok:
        assert proc.returncode == 0, proc.stderr
    return proc
