"""Plugin runs in a worker process (camcmm.worker): a native crash is one line and the
next run works; results, errors, progress and cancel cross the process boundary."""

from __future__ import annotations

import asyncio
import importlib.metadata as md
import itertools
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from camcmm import worker
from camcmm.errors import InputError, ParameterError, PluginError
from camcmm.host import Cancelled, PluginHost
from camcmm.model import PointCloud

_names = itertools.count()

CRASH_YAML = """
name: crash-lab
plugins:
  - id: crash.segv
    kind: algorithm
    name: Reads a kernel address (a native crash)
    entry: {pkg}.run:segv
  - id: crash.abort
    kind: algorithm
    name: Aborts (as a failed C assertion does)
    entry: {pkg}.run:abort
  - id: crash.good
    kind: algorithm
    name: Scales a cloud and says which process it ran in
    entry: {pkg}.run:good
    inputs: [{{name: cloud, type: pointcloud, optional: true}}]
    parameters: [{{name: factor, type: float, default: 2.0, min: 0}}]
  - id: crash.bad-input
    kind: algorithm
    name: Refuses its input
    entry: {pkg}.run:bad_input
  - id: crash.slow
    kind: algorithm
    name: Counts slowly, looking at cancel
    entry: {pkg}.run:slow
  - id: crash.stubborn
    kind: algorithm
    name: Sleeps, never looking at cancel
    entry: {pkg}.run:stubborn
  - id: crash.pidfile
    kind: algorithm
    name: Writes its process id, then sleeps
    entry: {pkg}.run:pidfile
    parameters: [{{name: path, type: str}}]
  - id: crash.unpicklable
    kind: algorithm
    name: Returns a function
    entry: {pkg}.run:unpicklable
"""

CRASH_PY = """
import ctypes, os, time
from camcmm.api import InputError, PointCloud

def segv(ctx):
    ctx.progress(0.5, "about to crash")
    return {"bytes": ctypes.string_at(1 << 63, 16)}  # not a user-space address

def abort(ctx):
    os.abort()

def good(ctx, factor, cloud=None):
    ctx.progress(0.5, "half way")
    ctx.warn("a warning from the worker")
    out = None if cloud is None else PointCloud(cloud.points * factor, name="scaled")
    return {"pid": os.getpid(), "cloud": out, "factor": factor}

def bad_input(ctx):
    raise InputError("cal.yaml: camera 1 (left): focal length fx = -800 px must be positive and finite")

def slow(ctx):
    for i in range(2000):
        ctx.progress(i / 2000, f"step {i}")
        time.sleep(0.01)
    return {}

def stubborn(ctx):
    time.sleep(60)
    return {}

def pidfile(ctx, path):
    with open(path + ".tmp", "w") as f:
        f.write(str(os.getpid()))
    os.replace(path + ".tmp", path)
    time.sleep(60)
    return {}

def unpicklable(ctx):
    return {"fn": lambda: 1}
"""


def _lab(tmp_path):
    pkg = f"crash_lab_{os.getpid()}_{next(_names)}"
    root = tmp_path / "labsrc" / pkg
    root.mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "plugin.yaml").write_text(CRASH_YAML.format(pkg=pkg))
    (root / "run.py").write_text(CRASH_PY)
    return pkg


@pytest.fixture
def crash_host(tmp_path, monkeypatch):
    pkg = _lab(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path / "labsrc"))
    return PluginHost(
        entry_points=[md.EntryPoint(name="crash-lab", value=f"{pkg}:plugin.yaml", group="camcmm.plugins")]
    )


@pytest.mark.slow
def test_native_crash_is_one_line_and_the_next_run_gets_a_fresh_worker(crash_host):
    first = worker.run(crash_host, "crash.good").outputs["pid"]
    assert first != os.getpid(), "the run happened in another process"
    assert worker.run(crash_host, "crash.good").outputs["pid"] == first, "the worker is kept warm"
    seen = []
    with pytest.raises(PluginError) as err:
        worker.run(crash_host, "crash.segv", progress=lambda f, m: seen.append(m))
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith("crash.segv: the worker process died (SIGSEGV); the server keeps running"), msg
    assert seen == ["about to crash"]
    with pytest.raises(PluginError, match=r"crash.abort: the worker process died \(SIGABRT\)"):
        worker.run(crash_host, "crash.abort")
    again = worker.run(crash_host, "crash.good").outputs["pid"]
    assert again not in (first, os.getpid())


@pytest.mark.slow
def test_outputs_warnings_progress_and_errors_cross_the_boundary(crash_host):
    pts = np.random.default_rng(1).normal(size=(5000, 3))
    seen = []
    res = worker.run(
        crash_host,
        "crash.good",
        {"cloud": PointCloud(pts, name="in")},
        {"factor": 3.0},
        progress=lambda f, m: seen.append((f, m)),
    )
    assert isinstance(res.outputs["cloud"], PointCloud) and res.outputs["cloud"].name == "scaled"
    np.testing.assert_array_equal(res.outputs["cloud"].points, pts * 3.0)
    assert res.warnings == ["a warning from the worker"] and res.params == {"factor": 3.0}
    assert res.plugin_id == "crash.good" and set(res.input_hashes) == {"cloud"}
    assert seen[0] == (0.5, "half way") and seen[-1] == (1.0, "done")
    # the same provenance as a run in this process
    assert (
        res.input_hashes
        == crash_host.run("crash.good", {"cloud": PointCloud(pts, name="in")}, {"factor": 3.0}).input_hashes
    )
    with pytest.raises(InputError, match="^cal.yaml: camera 1 .left.: focal length fx = -800 px"):
        worker.run(crash_host, "crash.bad-input")
    with pytest.raises(ParameterError, match="factor"):
        worker.run(crash_host, "crash.good", params={"factor": -1})
    with pytest.raises(PluginError, match=r"output 'fn' \(function\) cannot be passed back"):
        worker.run(crash_host, "crash.unpicklable")
    with pytest.raises(PluginError, match="an input cannot be passed to the worker process"):
        worker.run(crash_host, "crash.good", {"cloud": threading.Lock()})
    assert worker.run(crash_host, "crash.good").outputs["factor"] == 2.0


@pytest.mark.slow
def test_cancel_reaches_the_worker_and_a_stubborn_plugin_is_stopped(crash_host, monkeypatch):
    cancel = threading.Event()
    steps = []

    def progress(f, m):
        steps.append(m)
        if len(steps) == 3:
            cancel.set()

    with pytest.raises(Cancelled):
        worker.run(crash_host, "crash.slow", progress=progress, cancel=cancel)
    assert len(steps) < 100
    pid = worker.run(crash_host, "crash.good").outputs["pid"]
    monkeypatch.setattr(worker, "CANCEL_GRACE_S", 0.3)
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(Cancelled, match="its worker process was stopped"):
        worker.run(crash_host, "crash.stubborn", cancel=cancel)
    assert worker.run(crash_host, "crash.good").outputs["pid"] != pid


def test_a_host_that_cannot_be_rebuilt_runs_in_this_process(crash_host, monkeypatch):
    class Wrapped(PluginHost):
        pass

    assert worker.isolatable(crash_host) and not worker.isolatable(object())
    assert not worker.isolatable(Wrapped(entry_points=[]))
    monkeypatch.setenv("CAMCMM_ISOLATE", "0")
    assert worker.run(crash_host, "crash.good").outputs["pid"] == os.getpid()


@pytest.mark.slow
def test_session_shows_the_crash_as_one_line_and_keeps_working(crash_host, tmp_path):
    pytest.importorskip("trame")
    from camcmm.gui.app import build

    server, s = build(f"test-worker-{os.getpid()}-{next(_names)}", tmp_path / "proj", host=crash_host)
    server.state.ready()
    try:
        assert asyncio.run(server.pages["inspect"].run_plugin("crash.segv")) is None
        line = server.state.error_message
        assert "\n" not in line and "crash.segv: the worker process died (SIGSEGV)" in line, line
        assert server.state.running is False
        res = asyncio.run(server.pages["inspect"].run_plugin("crash.good", {"factor": 4.0}))
        assert res is not None, server.state.error_message
        assert res.outputs["factor"] == 4.0 and res.outputs["pid"] != os.getpid()
        assert [r["plugin"] for r in server.state.results][0] == "crash.good"
    finally:
        s.close()


@pytest.mark.slow
def test_a_worker_whose_server_was_killed_mid_run_exits(tmp_path):
    pkg = _lab(tmp_path)
    pid_file = tmp_path / "worker.pid"
    script = (
        "import sys, importlib.metadata as md\n"
        f"sys.path.insert(0, {str(tmp_path / 'labsrc')!r})\n"
        "from camcmm import worker\n"
        "from camcmm.host import PluginHost\n"
        f"host = PluginHost([md.EntryPoint('crash-lab', '{pkg}:plugin.yaml', 'camcmm.plugins')])\n"
        f"worker.run(host, 'crash.pidfile', params={{'path': {str(pid_file)!r}}})\n"
    )
    server = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 120
        while not pid_file.exists() and time.monotonic() < deadline and server.poll() is None:
            time.sleep(0.1)
        pid = int(pid_file.read_text())
        assert pid != server.pid
    finally:
        server.kill()  # SIGKILL: no atexit, as in a crash
        server.wait()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and _running(pid):
        time.sleep(0.2)
    assert not _running(pid), "the orphaned worker kept running"


def _running(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"  # a zombie has exited (its parent, init, reaps it)
