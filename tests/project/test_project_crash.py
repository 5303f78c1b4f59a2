"""Nothing is lost: SIGKILL a process that is writing results, then check every result
it reported as committed is there with its data file intact.

The child opens the project and, in a tight loop, copies a fresh random file in
(add_file), records a measurement and a result naming that file, saves GUI state, and
prints ``result_id measurement_id hash`` - only after ``add_result`` returned, i.e.
after the commit. The parent kills it with SIGKILL a random few milliseconds after
the N-th line (so the kill lands in the middle of some write: copying, fsync, rename,
or a transaction), then checks the database and every reported result. Rounds reuse
the same project, so a project recovered from a kill is also written to again. The
first rounds kill the child blindly, often while it is still creating the project.
"""

from __future__ import annotations

import hashlib
import os
import random
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from camcmm.project import DB_NAME, Project

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX SIGKILL")

CHILD = r"""
import os, random, sys
from camcmm.project import Project

root, scratch, seed = sys.argv[1], sys.argv[2], int(sys.argv[3])
rng = random.Random(seed)
p = Project.open_or_create(root)
i = 0
while True:
    i += 1
    src = os.path.join(scratch, f"src-{seed}-{i % 3}.bin")
    with open(src, "wb") as fh:
        fh.write(rng.randbytes(rng.choice([16, 4096, 65536, 300_000])))
    h = p.add_file(src)
    mid = p.add_measurement(f"m {seed}/{i}", h, meta={"i": i})
    rid = p.add_result({"plugin": "crash.test", "version": "1", "params": {"seed": seed, "i": i},
                        "input_hashes": {"cloud": h}, "outputs": {"value": i / 3}},
                       measurement_ids=[mid], files={"cloud": h}, label=f"round {seed}")
    p.set_state("last", rid)
    print(rid, mid, h, flush=True)
"""


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def run_and_kill(root: Path, scratch: Path, seed: int, n_lines: int, delay: float) -> list[tuple[int, int, str]]:
    """Start the writer; SIGKILL it ``delay`` s after it reported ``n_lines`` results
    (or, for n_lines=0, ``delay`` s after start). Returns every committed triple."""
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(root), str(scratch), str(seed)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    lines: list[str] = []
    watchdog = threading.Timer(30, proc.kill)  # never hang the test suite on a stuck child
    watchdog.start()
    try:
        while len(lines) < n_lines:
            line = proc.stdout.readline()
            if not line:  # the child died on its own: show why
                pytest.fail(f"writer exited early ({proc.wait()}): {proc.stderr.read()[-2000:]}")
            lines.append(line)
        time.sleep(delay)
        os.kill(proc.pid, signal.SIGKILL)
        rest = proc.stdout.read()  # lines it printed (so committed) before it died
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL, "the writer must die by the kill, not exit"
    lines += rest.splitlines(keepends=True)
    return [(int(a), int(b), c) for a, b, c in (ln.split() for ln in lines if ln.endswith("\n"))]


def check(root: Path, committed: list[tuple[int, int, str]]) -> int:
    """The project as the kill left it: readable, intact, every committed result there."""
    # integrity_check on a plain connection first: the file exactly as the crash left it
    # (plus SQLite's own WAL recovery), before our open() touches anything.
    c = sqlite3.connect(root / DB_NAME)
    assert c.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
    c.close()
    with Project.open(root) as p:
        for rid, mid, h in committed:
            r = p.result(rid)
            assert r["files"] == {"cloud": h} and r["input_hashes"] == {"cloud": h}
            assert r["measurement_ids"] == [mid] and p.measurement(mid)["hash"] == h
            assert sha(p.file_path(h)) == h
        assert p.verify() == []  # also every row written but not yet reported: its file is intact
        results = p.results()
        ids = [r["id"] for r in results]
        assert ids == sorted(set(ids))
        if committed:
            assert p.get_state("last") >= committed[-1][0]  # saved before the id was printed
        return len(results)


@pytest.mark.slow
def test_sigkill_while_writing_loses_nothing(tmp_path):
    t0 = time.monotonic()
    root, scratch = tmp_path / "proj", tmp_path / "scratch"
    scratch.mkdir()
    rng = random.Random(20240611)
    # Two blind kills first: 10-60 ms after start the child is importing, creating the
    # project (temp database, link into place) or writing its first result.
    plan = [(0, rng.uniform(0.01, 0.06)) for _ in range(2)]
    plan += [(n, rng.uniform(0.0, 0.02)) for n in (1, 4, 9, 17, 30, 12)]
    all_committed: list[tuple[int, int, str]] = []
    for seed, (n, delay) in enumerate(plan):
        committed = run_and_kill(root, scratch, seed, n, delay)
        assert len(committed) >= n
        if not (root / DB_NAME).exists():
            assert committed == []  # killed before the project existed: nothing to check
            continue
        all_committed += committed
        total = check(root, all_committed)  # results of earlier rounds survive too
        assert total >= len(all_committed)
    assert len(all_committed) >= sum(n for n, _ in plan)
    assert time.monotonic() - t0 < 20  # ~1-3 s on a laptop; generous for slow CI disks
