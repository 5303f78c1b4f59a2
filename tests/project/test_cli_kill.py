"""Killing the `camcmm` command while it writes a result leaves the project readable
with every result that completed before."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest

from camcmm.io import write
from camcmm.model import PointCloud
from camcmm.project import Project


def _run(cloud, project):
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "camcmm",
            "run",
            "cloud.downsample",
            str(cloud),
            "--voxel-size",
            "0.5",
            "--project",
            str(project),
            "--json",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
def test_sigkill_of_camcmm_run_keeps_completed_results(tmp_path):
    rng = np.random.default_rng(7)
    cloud = tmp_path / "cloud.ply"
    write(PointCloud(rng.uniform(0, 100, (300_000, 3))), cloud)
    project = tmp_path / "proj"
    done = []
    # First a run that completes, to learn how long one takes.
    t0 = time.monotonic()
    proc = _run(cloud, project)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    done.append(json.loads(out)["result_id"])
    duration = time.monotonic() - t0
    # Then runs killed at moments spread over a run's life, the late ones while the
    # result's data file and row are being written.
    for fraction in (0.3, 0.6, 0.8, 0.9, 0.95, 1.0):
        proc = _run(cloud, project)
        time.sleep(duration * fraction)
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate(timeout=60)
        if proc.returncode == 0:
            done.append(json.loads(out)["result_id"])
        with sqlite3.connect(project / "project.sqlite") as db:
            assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        with Project.open(project) as p:
            ids = {r["id"] for r in p.results()}
            assert set(done) <= ids
            assert p.verify() == []
