"""Any plugin run from its form without trame (camcmm.tasks.plugin_run), as the Inspect
page runs it: fit.sphere on a generated sphere through the worker, its deviations cloud
stored as a new item and the run as a result row, the row read back; the form's
refusals in one line (no plugin, a device, a missing input, a bad value, a wrong kind)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from camcmm.errors import CamcmmError, InputError
from camcmm.host import RunResult, default_host
from camcmm.model import PointCloud
from camcmm.project import Project
from camcmm.tasks import plugin_run
from camcmm.tasks.items import ProjectItems

CENTRE, RADIUS = np.array([10.0, -5.0, 3.0]), 12.5


def sphere_cloud(n: int = 400, seed: int = 0) -> PointCloud:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return PointCloud(CENTRE + RADIUS * d, name="ball")


def add_item(items: ProjectItems, obj, name: str) -> str:
    h = items.project.add_object(obj, name + ".ply")
    return str(items.add_measurement(name, h, obj))


@pytest.fixture
def items(tmp_path):
    project = Project.create(tmp_path / "proj")
    yield ProjectItems(project)
    project.close()


@pytest.mark.slow  # a worker process may start first
def test_a_fit_runs_is_stored_with_its_made_cloud_and_read_back(items):
    host = default_host()
    task = plugin_run.PluginRunTask(host, items, items.project)
    ball = add_item(items, sphere_cloud(), "ball")
    req = plugin_run.PluginRunRequest("fit.sphere", {"cloud": ball}, {"nominal_radius": "12.5", "outliers": "none"})
    checked = task.check(req)
    assert checked.values["nominal_radius"] == 12.5 and checked.mids == [int(ball)]
    seen: list[float] = []
    result = task.run(checked, progress=lambda f, m: seen.append(f), cancel=threading.Event())
    assert result.plugin_id == "fit.sphere"
    assert np.allclose(result.outputs["center"], CENTRE, atol=1e-9)
    assert result.outputs["radius"] == pytest.approx(RADIUS, abs=1e-9)
    kept = task.store(checked, result)
    assert kept.error == "" and kept.result_id is not None
    # the deviations cloud became a new item, named after the input, its residual field in µm
    assert [m.label for m in kept.made] == ["deviations"]
    made = kept.made[0]
    assert kept.made_names == {"deviations": made.name} and made.name != "ball"
    assert made.fields == {"deviation": "µm"}
    row = items.project.measurement(int(made.key))
    assert row["kind"] == "pointcloud" and row["meta"]["made_by"].startswith("fit.sphere ")
    assert items.load(made.key).n_points == 400
    # the stored row is RunResult.to_json(); restored as a run it has the same numbers
    stored = task.stored(kept.result_id)
    assert stored["plugin"] == "fit.sphere" and [int(ball)] == [int(m) for m in stored["measurement_ids"]]
    back = task.restore(kept.result_id)
    assert isinstance(back, RunResult) and back.plugin_version == result.plugin_version
    assert back.outputs["radius"] == pytest.approx(RADIUS, abs=1e-9)
    assert back.params["nominal_radius"] == 12.5
    # a second run of the same fit gets a new name, not the same one
    again = task.store(checked, result)
    assert again.made[0].name == f"{made.name} (2)"


@pytest.mark.slow  # Open3D and the plugins load
def test_a_downsampled_cloud_is_stored_without_a_worker(items):
    """cloud.downsample's made cloud as an item (a host that cannot be rebuilt in a worker
    runs in the calling thread: the task does not care)."""
    host = default_host()
    dense = PointCloud(np.random.default_rng(1).random((2000, 3)) * 10.0, name="dense")
    key = add_item(items, dense, "dense")
    checked = plugin_run.check(
        host, plugin_run.PluginRunRequest("cloud.downsample", {"cloud": key}, {"voxel_size": "2"}), items
    )
    result = host.run("cloud.downsample", checked.objs, checked.values)
    kept = plugin_run.store(items.project, items, checked, result)
    assert len(kept.made) == 1 and kept.made[0].label == "cloud"
    small = items.load(kept.made[0].key)
    assert 0 < small.n_points <= 6**3 < dense.n_points  # ≤ one point per 2 mm voxel
    assert items.project.result(kept.result_id)["outputs"]["n_points"] == small.n_points


@pytest.mark.slow  # the plugins load
def test_refusals_are_one_line_as_the_page_shows_them(items):
    host = default_host()
    ball = add_item(items, sphere_cloud(50), "ball")
    cases = [
        (plugin_run.PluginRunRequest(""), "choose a plugin first"),
        (plugin_run.PluginRunRequest("fit.sphere", {}, {}), "input 'cloud' (geometry) is needed"),
        (plugin_run.PluginRunRequest("fit.sphere", {"cloud": "999"}), "item '999' is not in the project"),
        (plugin_run.PluginRunRequest("fit.sphere", {"cloud": ball}, {"nominal_radius": "-3"}), "nominal_radius"),
        (plugin_run.PluginRunRequest("fit.sphere", {"cloud": ball}, {"method": "best"}), "method"),
        (plugin_run.PluginRunRequest("no.such.plugin", {"cloud": ball}), "no.such.plugin"),
    ]
    for req, words in cases:
        with pytest.raises(CamcmmError) as err:
            plugin_run.check(host, req, items)
        assert words in str(err.value) and "\n" not in str(err.value), (words, err.value)
    device = next((s.id for s in host.check() if s.kind == "device"), None)
    if device is not None:
        with pytest.raises(CamcmmError, match="is a device"):
            plugin_run.check(host, plugin_run.PluginRunRequest(device), items)
    # the page's live reason (the form's listed items) says the same as the task
    spec = host.get("fit.sphere")
    assert plugin_run.run_blocker(spec, {}, {"cloud": None}, []) == (
        "input 'cloud' (geometry) is needed: import a file or choose an item"
    )
    with pytest.raises(InputError, match="not a result id"):
        plugin_run.stored_row(items.project, "abc")
    with pytest.raises(CamcmmError, match="no result with id 41"):
        plugin_run.stored_row(items.project, 41)
