"""The example lab plugin: pip-installed into the test environment, then discovered
and run like a built-in one."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from camcmm.io import write
from camcmm.model import PointCloud
from helpers.cli import cli_json

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_plugin"


def _pip(*args):
    return subprocess.run(
        [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def installed():
    # --no-deps/--no-build-isolation: camcmm and setuptools are already in this
    # environment, and the test must not need a network.
    proc = _pip("install", "--no-deps", "--no-build-isolation", str(EXAMPLE))
    assert proc.returncode == 0, proc.stderr
    yield
    _pip("uninstall", "-y", "camcmm-lab-example")


@pytest.mark.slow
def test_lab_plugin_is_discovered_and_runs(installed, tmp_path):
    plugins = {p["id"]: p for p in cli_json("plugins", "--json")["plugins"]}
    lab = plugins["lab.centroid"]
    assert (lab["kind"], lab["version"], lab["status"], lab["distribution"]) == (
        "algorithm",
        "0.3.1",
        "ok",
        "camcmm-lab-example",
    )
    pts = np.array([[0.0, 0, 0], [2, 0, 0], [2, 4, 0], [0, 4, 6]])
    write(PointCloud(pts), tmp_path / "c.ply")
    doc = cli_json("run", "lab.centroid", tmp_path / "c.ply", "--json")
    assert doc["outputs"]["centroid"] == pytest.approx([1.0, 2.0, 1.5])
    assert doc["outputs"]["extent"] == pytest.approx([2.0, 4.0, 6.0])
