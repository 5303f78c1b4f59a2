"""Temp files of killed writers are removed when the project is next opened; a running
writer's are never touched.

A child process opens the project, commits a result, then stops half-way through the
three kinds of write that leave temp files in the project — a data file being copied
in (``data/.tmp/<pid>-…``), an object being written by camcmm.io's atomic write
(``data/.tmp/.<pid>-….<pid>-<hex>.tmp.ply``) and a database being created
(``.project.sqlite.<pid>.<thread>.tmp``) — and waits to be SIGKILLed, as a kill in the
middle of a write would leave them.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from camcmm.project import DB_NAME, Project
from camcmm.project.blobs import writer_gone

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX SIGKILL")

CHILD = r"""
import os, sys, threading
from pathlib import Path
from camcmm.io._common import atomic_path
from camcmm.project import DB_NAME, Project

root, src = Path(sys.argv[1]), sys.argv[2]
p = Project.open(root)
h = p.add_file(src)
p.add_result({"plugin": "tmp.test", "version": "1", "params": {}, "outputs": {"v": 1}}, files={"f": h})
blob_tmp = p._blobs.new_tmp()                       # a copy-in, interrupted
blob_tmp.write_bytes(b"half a file")
obj_tmp = p._blobs.new_tmp(suffix=".ply")           # an object write, interrupted inside camcmm.io
ctx = atomic_path(obj_tmp)
inner = ctx.__enter__()
inner.write_bytes(b"ply\nformat ascii 1.0\n")
db_tmp = root / f".{DB_NAME}.{os.getpid()}.{threading.get_ident()}.tmp"
db_tmp.write_bytes(b"SQLite format 3\0")           # a create, interrupted
print(h, flush=True)
sys.stdin.read()                                     # wait to be killed
"""


def _temps(root: Path) -> list[Path]:
    return sorted([*(root / "data" / ".tmp").glob("*"), *root.glob(f".{DB_NAME}.*")])


def _start_writer(root: Path, src: Path) -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(root), str(src)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    if not line:
        proc.kill()
        pytest.fail(f"writer failed: {proc.communicate()[1][-2000:]}")
    return proc, line.strip()


@pytest.fixture
def project(tmp_path):
    root = tmp_path / "proj"
    Project.create(root).close()
    src = tmp_path / "cloud.xyz"
    src.write_bytes(b"1 2 3\n4 5 6\n" * 1000)
    return root, src


def test_killed_writers_temp_files_go_on_reopen_and_data_stays(project):
    root, src = project
    procs = [_start_writer(root, src) for _ in range(2)]
    pids = {str(proc.pid) for proc, _ in procs}
    left = _temps(root)
    assert len(left) == 8 and {n for f in left for n in pids if n in f.name} == pids, left
    assert any(".tmp.ply" in f.name for f in left)  # camcmm.io's atomic write inside data/.tmp

    # both writers alive: reopening touches none of their files
    with Project.open(root) as p:
        assert p._sweep_leftovers() == 0
    assert _temps(root) == left

    # kill one: its four files go, the other writer's four stay
    (dead, h), (alive, _) = procs
    dead.kill()
    dead.wait()
    with Project.open(root) as p:
        assert len(p.results()) == 2 and p.has_file(h)
    rest = _temps(root)
    assert len(rest) == 4 and all(str(alive.pid) in f.name for f in rest), rest

    alive.kill()
    alive.wait()
    with Project.open(root) as p:
        assert _temps(root) == []
        assert len(p.results()) == 2
        assert p.verify() == []  # every file's content still matches its hash
        assert p.file_path(h).read_bytes() == src.read_bytes()
    for proc, _ in procs:
        proc.stdin.close()
        proc.stdout.close()
        proc.stderr.close()


def test_this_processes_own_temp_file_stays(project):
    root, _ = project
    with Project.open(root) as p:
        mine = p._blobs.new_tmp(suffix=".ply")
        with Project.open(root) as again:
            again._sweep_leftovers()
        assert mine.exists()
        mine.unlink()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="start times from Linux /proc")
def test_a_reused_pid_does_not_protect_an_older_file(project):
    """A file named with a running pid but written before that process started is a
    dead writer's whose pid was reused (e.g. a restarted server in a container)."""
    root, _ = project
    before = root / "data" / ".tmp" / f"{os.getpid()}-reused"
    before.parent.mkdir(exist_ok=True)
    before.write_bytes(b"x")
    with open("/proc/self/stat") as fh:  # this process's start, to date the file before it
        ticks = int(fh.read().rsplit(")", 1)[1].split()[19])
    btime = next(int(line.split()[1]) for line in open("/proc/stat") if line.startswith("btime "))
    started = btime + ticks / os.sysconf("SC_CLK_TCK")
    os.utime(before, (started - 60, started - 60))
    with Project.open(root) as p:  # an age limit far beyond the file's age: only the start time removes it
        p._sweep_leftovers(max_age_s=10 * 3600 + time.time() - started)
    assert not before.exists()


def test_age_limit_removes_any_temp_and_names_without_pid(project):
    root, _ = project
    tmpdir = root / "data" / ".tmp"
    tmpdir.mkdir(exist_ok=True)
    old = tmpdir / f"{os.getpid()}-old"
    young_unknown = tmpdir / "no-pid-here"
    for f in (old, young_unknown):
        f.write_bytes(b"x")
    os.utime(old, (time.time() - 7200, time.time() - 7200))
    with Project.open(root):
        pass
    assert not old.exists() and young_unknown.exists()


def test_writer_gone_is_false_when_unsure():
    assert not writer_gone(os.getpid(), time.time())
    assert not writer_gone(0, 0.0) and not writer_gone(-1, 0.0)  # never the process group
    assert not writer_gone(10**30, 0.0)
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()  # reaped: the pid is free (until reused, which writer_gone then sees by age)
    assert writer_gone(proc.pid, time.time()) or Path(f"/proc/{proc.pid}").exists()
