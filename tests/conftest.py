"""Shared test fixtures: the ../shared data folder, GUI servers; the marks by folder; and the
session-end check that no process a test started is still alive.

Marks: every test under tests/browser/ is ``browser`` and ``slow``; other slow tests carry
``@pytest.mark.slow`` themselves (a test taking more than about a second). Helpers shared by
several test modules live in tests/helpers/ (``from helpers.cli import run_camcmm``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from helpers.paths import SHARED_DATA  # noqa: E402  (tests/ is on the path: pyproject's pythonpath)


@pytest.fixture
def shared_data():
    """Path of ../shared/data; skips the test where it is absent (a user's fresh clone)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"{SHARED_DATA} is absent (only CI and developers have ../shared)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def demo_project(tmp_path_factory):
    """``make(dest, acceptance=True) -> dest``: a copy of the demo project (``camcmm demo``) at
    ``dest``. The demo is built once per test process and kind (with or without its finished
    acceptance test: 12-30 s each) and copied for every test, so that each test still gets a
    project of its own to change."""
    import shutil

    from camcmm.demo import create_demo

    built: dict[bool, Path] = {}

    def make(dest, acceptance: bool = True) -> Path:
        if acceptance not in built:
            folder = tmp_path_factory.mktemp("demo-cache") / "demo"
            create_demo(folder, acceptance=acceptance)
            built[acceptance] = folder
        dest = Path(dest)
        shutil.copytree(built[acceptance], dest)
        return dest

    return make


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


def pytest_collection_modifyitems(config, items):
    """tests/browser/ -> browser + slow (the folder is the rule; no list of ids to keep)."""
    for item in items:
        if item.path.parent.name == "browser":
            item.add_marker(pytest.mark.browser)
            item.add_marker(pytest.mark.slow)


# -- nothing left running -------------------------------------------------------------------------
# A test that starts a process (a GUI server, a stage simulator, a worker) stops it in its own
# teardown. At the end of the session this checks that it did: any descendant of this pytest
# process still alive then is reported, killed, and fails the run (exit 3), so a leak is seen
# in CI and not by the next person whose machine fills with simulators.


def _descendants(pid: int) -> list[int]:
    """Every live descendant of ``pid`` (Linux /proc; empty elsewhere)."""
    children: dict[int, list[int]] = {}
    proc = Path("/proc")
    if not proc.is_dir():
        return []
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        # "pid (comm) state ppid ...": comm may hold spaces and parentheses, so split after the last ")"
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] == "Z":
            continue
        children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def _command(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return "?"


def _leftovers(timeout: float = 10.0) -> list[tuple[int, str]]:
    """Descendants still alive after ``timeout`` s of grace (a process being stopped as the
    last test ends gets its moment), without the ones pytest-xdist itself runs."""
    import time

    deadline = time.monotonic() + timeout
    while True:
        pids = [p for p in _descendants(os.getpid()) if "chrome_crashpad_handler" not in _command(p)]
        if not pids or time.monotonic() > deadline:
            return [(p, _command(p)) for p in pids]
        time.sleep(0.2)


_leaks: list[str] = []  # the controller's: what the xdist workers reported (pytest_testnodedown)


def pytest_testnodedown(node, error):
    _leaks.extend(getattr(node, "workeroutput", {}).get("camcmm_leftovers", []))


def pytest_sessionfinish(session, exitstatus):
    import signal
    import sys

    # the warm plugin workers are a pool by design (camcmm.worker), stopped at the interpreter's
    # exit: stop them here as the exit would, so that what remains is a real leak
    if "camcmm.worker" in sys.modules:
        sys.modules["camcmm.worker"].shutdown()
    left = _leftovers()
    for pid, _ in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    lines = [f"pid {pid}: {cmd[:200]}" for pid, cmd in left]
    workeroutput = getattr(session.config, "workeroutput", None)
    if workeroutput is not None:  # an xdist worker: the controller fails the run
        workeroutput["camcmm_leftovers"] = lines
        return
    lines += _leaks
    if not lines:
        return
    listing = "\n".join(f"  {line}" for line in lines)
    print(f"\nconftest: {len(lines)} process(es) started during the run were still alive at its end (killed):")
    print(listing)
    session.exitstatus = pytest.ExitCode.TESTS_FAILED
