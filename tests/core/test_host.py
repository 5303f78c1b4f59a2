"""The plugin host: discovery from manifests, status of broken plugins, runs."""

from __future__ import annotations

import importlib.metadata as md
import sys
import textwrap
import threading

import numpy as np
import pytest

from camcmm.errors import ParameterError, PluginError
from camcmm.host import Cancelled, PluginHost
from camcmm.model import PointCloud

GOOD = """
name: good
plugins:
  - id: t.scale
    kind: algorithm
    name: Scale
    summary: Multiply the points by a factor.
    entry: {pkg}.impl:scale
    inputs: [{{name: cloud, type: pointcloud}}]
    parameters:
      - {{name: factor, type: float, default: 2.0, min: 0, max: 10, unit: "1"}}
      - {{name: mode, type: choice, choices: [a, b], default: a}}
  - id: t.uses-other
    kind: algorithm
    name: Uses another
    entry: {pkg}.impl:uses_other
    inputs: [{{name: cloud, type: pointcloud}}]
  - id: t.broken-import
    kind: algorithm
    name: Broken
    entry: {pkg}.missing_module:run
  - id: t.bad kind
    kind: algorithm
    name: Bad id
    entry: x:y
commands:
  - {{name: tcmd, summary: A command, entry: {pkg}.impl}}
"""

IMPL = """
def scale(ctx, cloud, factor, mode):
    ctx.progress(0.5, "half")
    ctx.warn("a warning")
    return {"max": float((cloud.points * factor).max()), "mode": mode}

def uses_other(ctx, cloud):
    out = ctx.algorithm("t.scale")(cloud=cloud, factor=3)
    return {"max": out["max"]}

def slow(ctx, cloud):
    for i in range(1000):
        ctx.progress(i / 1000)
    return {}
"""


def _package(tmp_path, name, manifest, impl=IMPL):
    pkg = tmp_path / name
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "plugin.yaml").write_text(textwrap.dedent(manifest.format(pkg=name)))
    (pkg / "impl.py").write_text(impl)
    return md.EntryPoint(name=name, value=f"{name}:plugin.yaml", group="camcmm.plugins")


@pytest.fixture
def host(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    eps = [
        _package(tmp_path, "pkg_good", GOOD),
        _package(tmp_path, "pkg_yaml", "plugins: [unclosed"),
        md.EntryPoint(name="pkg_absent", value="no_such_package:plugin.yaml", group="camcmm.plugins"),
    ]
    yield PluginHost(eps)
    for mod in [m for m in sys.modules if m.startswith("pkg_")]:
        del sys.modules[mod]


def test_manifests_are_read_without_importing(host):
    assert "t.scale" in host.plugins
    assert "pkg_good.impl" not in sys.modules
    assert host.plugins["t.scale"].parameters[0].unit == "1"
    assert "tcmd" in host.commands


def test_broken_plugins_are_listed_with_their_error(host):
    status = {s.id: s.status for s in host.check()}
    assert status["t.scale"] == "ok"
    assert "missing_module" in status["t.broken-import"]
    assert "must be lower-case" in status["t.bad kind"]
    assert "not valid YAML" in status["pkg_yaml"]
    assert "No module named 'no_such_package'" in status["pkg_absent"]
    assert all("\n" not in s for s in status.values())


def test_run_validates_parameters_and_records_provenance(host):
    cloud = PointCloud(np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 1.0]]))
    seen = []
    res = host.run("t.scale", {"cloud": cloud}, {"factor": "4"}, progress=lambda f, m: seen.append(f))
    assert res.outputs == {"max": 12.0, "mode": "a"}
    assert res.params == {"factor": 4.0, "mode": "a"}
    assert res.warnings == ["a warning"] and seen == [0.5, 1.0]
    assert len(res.input_hashes["cloud"]) == 64
    with pytest.raises(ParameterError, match="above its maximum 10"):
        host.run("t.scale", {"cloud": cloud}, {"factor": 11})
    with pytest.raises(ParameterError, match="unknown parameter 'factr'"):
        host.run("t.scale", {"cloud": cloud}, {"factr": 1})
    with pytest.raises(ParameterError, match="expected one of a, b"):
        host.run("t.scale", {"cloud": cloud}, {"mode": "c"})
    with pytest.raises(PluginError, match="needs input 'cloud'"):
        host.run("t.scale", {}, {})
    with pytest.raises(PluginError, match="no plugin with id 't.nope'"):
        host.run("t.nope")


def test_a_plugin_asks_the_host_for_another(host):
    cloud = PointCloud(np.array([[1.0, 2.0, 3.0]]))
    res = host.run("t.uses-other", {"cloud": cloud})
    assert res.outputs == {"max": 9.0}
    assert res.warnings == ["t.scale: a warning"]


def test_cancel_stops_a_run(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    manifest = """
plugins:
  - {{id: t.slow, kind: algorithm, name: Slow, entry: "{pkg}.impl:slow", inputs: [{{name: cloud, type: pointcloud}}]}}
"""
    host = PluginHost([_package(tmp_path, "pkg_slow", manifest)])
    cancel = threading.Event()
    cancel.set()
    with pytest.raises(Cancelled):
        host.run("t.slow", {"cloud": PointCloud(np.zeros((1, 3)))}, cancel=cancel)


def test_installed_builtins_are_discovered_like_external_ones():
    host = PluginHost()
    ids = {s.id for s in host.check() if s.status == "ok"}
    assert {"cloud.downsample", "cloud.denoise", "cloud.normals"} <= ids


def test_a_file_of_the_wrong_kind_is_refused_naming_it(tmp_path):
    """A mesh where a point cloud is declared: one line naming the file, before the plugin
    fails on a missing attribute far from the cause (issue 13)."""
    import numpy as np

    from camcmm.api import InputError, TriangleMesh, write
    from camcmm.host import PluginHost

    mesh = TriangleMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    write(mesh, tmp_path / "m.stl")
    with pytest.raises(
        InputError,
        match=r"m\.stl: cloud\.downsample input 'cloud' needs a point cloud; "
        r"this is a triangle mesh",
    ):
        PluginHost().run("cloud.downsample", {"cloud": str(tmp_path / "m.stl")}, {"voxel_size": 1.0})
