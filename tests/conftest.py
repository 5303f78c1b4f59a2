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


# -- marks by rule ---------------------------------------------------------------------------------
# `pytest -m "not slow"` is the quick run (under two minutes on the 2-core reference machine).
# The browser tests are marked here by their file name; the other slow ones (measured > ~5 s with
# `pytest --durations=0` under load) by their node id below, so that the list lives in one place.
SLOW_TESTS: frozenset[str] = frozenset()


def pytest_collection_modifyitems(config, items):
    """tests/test_browser_*.py -> browser + slow; the node ids in SLOW_TESTS -> slow."""
    for item in items:
        if item.path.name.startswith("test_browser"):
            item.add_marker(pytest.mark.browser)
            item.add_marker(pytest.mark.slow)
        elif item.nodeid.split("[")[0] in SLOW_TESTS or item.nodeid in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)


def cli_json(*args, **kw):
    """``run_camcmm(*args)`` that must succeed; its stdout parsed as the one JSON document."""
    import json

    return json.loads(run_camcmm(*args, **kw).stdout)


def cli_refused(*args, code=None, **kw) -> str:
    """``run_camcmm(*args)`` that must be refused: a non-zero exit (``code`` if given) and one
    stderr line ``camcmm: error: …``, returned."""
    proc = run_camcmm(*args, ok=False, **kw)
    assert proc.returncode != 0 if code is None else proc.returncode == code, (proc.returncode, proc.stderr)
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("camcmm: error:"), proc.stderr
    return proc.stderr
