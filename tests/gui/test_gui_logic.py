"""GUI logic without a browser: the session and the Inspect page, on a real project.

Each test builds the app on its own trame server (conftest's ``gui_app``, which calls
``state.ready()`` so that state changes flush and run ``@state.change`` handlers as
they do with a client connected). A plugin runs as the Run button runs it:
``asyncio.run(page.run_plugin(...))``.
"""

from __future__ import annotations

import asyncio
import importlib.metadata as md
import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

cio = pytest.importorskip("camcmm.io")
if not hasattr(cio, "read"):
    pytest.skip("camcmm.io.read is not there yet", allow_module_level=True)
pytest.importorskip("trame")
pytest.importorskip("pyvista")

from camcmm.gui.view import DISPLAY_LIMIT, SOLID  # noqa: E402
from camcmm.host import PluginHost  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402


def sphere_cloud(n: int = 4000, radius: float = 10.0, seed: int = 0) -> PointCloud:
    """Points on a sphere with a signed ``deviation`` field in mm."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    dev = 0.01 * rng.normal(size=n)
    pts = d * (radius + dev)[:, None] + [1.0, 2.0, 3.0]
    return PointCloud(pts, fields={"deviation": dev}, field_units={"deviation": "mm"}, name="sphere")


@pytest.fixture
def app(gui_app):
    """``make(project_dir=None, **build_kw) -> (server, session, page)``: the Inspect page too."""

    def make(project_dir=None, **kw):
        server, session = gui_app(project_dir, **kw)
        return server, session, server.pages["inspect"]

    return make


def run(page, plugin_id, params=None, inputs=None):
    """The Inspect page's run, as the Run button starts it, to its end."""
    return asyncio.run(page.run_plugin(plugin_id, params, inputs))


@pytest.fixture
def cloud_file(tmp_path):
    path = tmp_path / "sphere.ply"
    cio.write(sphere_cloud(), path)
    return path


def snapshot(project):
    return ([(m["id"], m["name"], m["hash"]) for m in project.measurements()], [r["id"] for r in project.results()])


@pytest.mark.slow
def test_import_cloud_shows_it_coloured_with_legend(app, cloud_file):
    server, s, page = app()
    state = server.state
    assert state.items == [] and state.plugins, "fresh project: no items, plugins listed"
    key = s.import_file(cloud_file)
    assert key is not None, state.error_message
    assert [it["name"] for it in state.items] == ["sphere.ply"]
    assert state.selected_item == key
    assert "4 000 points" in state.items[0]["subtitle"]
    assert s.view.actor is not None and s.view.shown.n_shown == 4000
    values = [f["value"] for f in state.color_fields]
    assert {"x", "y", "z", SOLID} <= set(values)
    if "deviation" in values:  # the reader kept the field and its unit
        assert state.color_field == "deviation"
        assert state.legend_title == "deviation [µm]"  # deviations in µm (the number rule)
    assert state.legend_title in s.view.plotter.scalar_bars
    assert state.display_note == "showing all 4 000 points"
    img = s.view.screenshot()
    assert img.std() > 5 and len(np.unique(img.reshape(-1, 3), axis=0)) > 50, "view looks blank"
    # the project keeps the file
    (m,) = s.project.measurements()
    assert m["name"] == "sphere.ply" and m["kind"] == "pointcloud"


@pytest.mark.slow
def test_mesh_and_image_items(app, tmp_path):
    import pyvista as pv

    from camcmm.model import Image, TriangleMesh

    sphere = pv.Sphere(radius=5.0, theta_resolution=30, phi_resolution=30).triangulate()
    mesh = TriangleMesh(np.asarray(sphere.points, float), np.asarray(sphere.faces).reshape(-1, 4)[:, 1:])
    cio.write(mesh, tmp_path / "ball.stl")
    img = (np.arange(64 * 48) % 251).astype(np.uint8).reshape(48, 64)
    cio.write(Image(img), tmp_path / "cam0.png")
    server, s, page = app()
    key = s.import_file(tmp_path / "ball.stl")
    assert key is not None, server.state.error_message
    assert server.state.items[0]["kind"] == "mesh" and s.view.shown.kind == "mesh"
    assert "vertices" in server.state.display_note
    assert s.view.screenshot().std() > 5
    key2 = s.import_file(tmp_path / "cam0.png")
    assert key2 is not None, server.state.error_message
    assert server.state.items[1]["kind"] == "image"
    assert "not shown in the 3D view" in server.state.display_note and s.view.shown is None
    s.select_item(key)  # back to the mesh
    assert s.view.shown.kind == "mesh"


@pytest.mark.slow
def test_colour_field_selector_through_state(app, cloud_file):
    server, s, page = app()
    s.import_file(cloud_file)
    server.state.color_field = "z"
    server.state.flush()  # as a client change would: runs the @state.change handler
    assert s.view.field == "z"
    assert server.state.legend_title == "z [mm]"
    assert list(s.view.plotter.scalar_bars.keys()) == ["z [mm]"]
    page.set_color_field(SOLID)
    assert server.state.legend_title == "" and len(s.view.plotter.scalar_bars.keys()) == 0


@pytest.mark.slow
def test_import_uploaded_bytes_keeps_the_original_name(app, cloud_file):
    server, s, page = app()
    files = s.import_upload([{"name": "scan 1.ply", "size": 1, "content": [cloud_file.read_bytes()]}])
    key = s.import_file(files[0]["content"], files[0]["name"])
    assert key is not None, server.state.error_message
    assert server.state.items[0]["name"] == "scan 1.ply"


def _bad_files(tmp_path: Path) -> dict[str, bytes]:
    good = tmp_path / "good.ply"
    cio.write(sphere_cloud(500), good)
    whole = good.read_bytes()
    head_end = whole.index(b"end_header") + len(b"end_header\n")
    return {
        "empty.xyz": b"",
        "nan.xyz": b"1 2 3\n4 nan 6\n7 8 9\n",
        "inf.xyz": b"1 2 3\n4 5 inf\n",
        "truncated.ply": whole[: head_end + (len(whole) - head_end) // 3],
        "garbage.ply": b"\x00\x01\x02 this is not a point cloud",
    }


@pytest.mark.slow
def test_bad_files_give_a_named_error_and_lose_nothing(app, cloud_file, tmp_path):
    server, s, page = app()
    state = server.state
    assert s.import_file(cloud_file) is not None
    page.select_plugin("cloud.downsample")
    assert run(page, "cloud.downsample", {"voxel_size": 2.0}) is not None
    before = snapshot(s.project)
    items_before = [dict(it) for it in state.items]
    for name, data in _bad_files(tmp_path).items():
        path = tmp_path / name
        path.write_bytes(data)
        for source, label in ((path, name), (data, name)):  # a server path and an upload
            state.error_message = ""
            assert s.import_file(source, label if isinstance(source, bytes) else None) is None, name
            msg = state.error_message
            assert name in msg, f"error does not name the file: {msg!r}"
            assert "\n" not in msg and len(msg) < 400
            assert "camcmm-gui-" not in msg, f"error shows the temp path: {msg!r}"
            assert state.error_visible
    assert s.import_file(tmp_path / "missing.ply") is None
    assert "missing.ply" in state.error_message
    assert snapshot(s.project) == before, "a bad file changed the project"
    assert state.items == items_before
    # and the app still works
    assert s.import_file(cloud_file, "again.ply") is not None
    assert len(state.items) == len(items_before) + 1


@pytest.mark.slow
def test_plugin_form_and_run(app, cloud_file):
    server, s, page = app()
    state = server.state
    s.import_file(cloud_file)
    rows = {p["id"]: p for p in state.plugins}
    assert rows["cloud.downsample"]["ok"] and rows["cloud.downsample"]["kind"] == "algorithm"
    page.select_plugin("cloud.downsample")
    (field,) = [f for f in state.form_fields if f["name"] == "voxel_size"]
    assert field["widget"] == "number" and field["unit"] == "mm" and field["label"] == "voxel size [mm]"
    assert field["min"] is not None and state.form_values["voxel_size"] == field["default"]
    assert state.input_values == {"cloud": state.selected_item}
    seen = []
    orig = page.show_progress
    page.show_progress = lambda f, m: (seen.append(f), orig(f, m))
    n_items = len(state.items)
    # values as the browser sends them: numbers as text
    res = run(page, "cloud.downsample", {"voxel_size": "2.5"}, state.input_values)
    assert res is not None, state.error_message
    assert seen and seen[-1] == 1.0
    assert state.progress == 100.0 and not state.running
    assert state.result["plugin"] == "cloud.downsample" and state.result["params"] == {"voxel_size": 2.5}
    by_name = {r["name"]: r for r in state.result_rows}
    assert int(by_name["n_points"]["value"]) == res.outputs["n_points"] < 4000
    stored = s.project.results()
    assert [r["plugin"] for r in stored] == ["cloud.downsample"]
    assert stored[0]["params"] == {"voxel_size": 2.5}
    assert len(state.results) == 1
    # a stored result can be shown again from the project
    page.show_result(stored[0]["id"])
    assert {r["name"]: r["value"] for r in state.result_rows}["n_points"] == by_name["n_points"]["value"]
    # the output cloud became a new item and is shown
    assert len(state.items) == n_items + 1
    assert state.selected_item == state.items[-1]["id"]
    assert s.view.shown.n_total == res.outputs["n_points"]


@pytest.mark.slow
def test_bad_parameter_is_reported_and_nothing_stored(app, cloud_file):
    server, s, page = app()
    s.import_file(cloud_file)
    page.select_plugin("cloud.downsample")
    assert run(page, "cloud.downsample", {"voxel_size": "-1"}) is None
    assert "voxel_size" in server.state.error_message
    assert run(page, "cloud.downsample", {"voxel_size": "abc"}) is None
    assert "voxel_size" in server.state.error_message
    assert s.project.results() == []
    assert not server.state.running


@pytest.mark.slow
def test_run_without_input_says_what_is_missing(app):
    server, s, page = app()
    page.select_plugin("cloud.downsample")
    assert run(page, "cloud.downsample", {}) is None
    assert "cloud" in server.state.error_message and "cloud.downsample" in server.state.error_message


@pytest.mark.slow
def test_async_run_reports_progress_from_the_worker_thread(app, cloud_file):
    server, s, page = app()
    s.import_file(cloud_file)
    page.select_plugin("cloud.downsample")

    async def go():
        return await page.run_plugin("cloud.downsample", {"voxel_size": 3.0})

    res = asyncio.run(go())
    assert res is not None, server.state.error_message
    assert server.state.progress == 100.0
    assert len(s.project.results()) == 1


def test_async_import(app, cloud_file):
    server, s, page = app()

    async def go():
        s.bind_loop()
        return await s.import_file_async(cloud_file.read_bytes(), "up.ply")

    assert asyncio.run(go()) is not None
    assert server.state.items[0]["name"] == "up.ply" and not server.state.importing


def test_failed_plugins_are_listed_with_their_reason(app):
    broken = md.EntryPoint(name="brokenlab", value="no_such_lab_package:plugin.yaml", group="camcmm.plugins")
    host = PluginHost(entry_points=[*md.entry_points(group="camcmm.plugins"), broken])
    server, s, page = app(host=host)
    rows = {p["id"]: p for p in server.state.plugins}
    assert not rows["brokenlab"]["ok"]
    assert "no_such_lab_package" in rows["brokenlab"]["status"]
    page.select_plugin("brokenlab")
    assert "brokenlab" in server.state.error_message


@pytest.mark.slow
def test_reopening_the_project_lists_and_shows_its_items(app, cloud_file, tmp_path):
    _, s, page = app()
    k1 = s.import_file(cloud_file)
    s.import_file(cloud_file.read_bytes(), "second.ply")
    s.select_item(k1)
    page.set_color_field("y")
    assert not list(s._tmp.glob("upload-*")), "temp copies of uploads are removed"
    s.project.close()
    server, s2, _page2 = app(tmp_path / "proj")
    assert [it["name"] for it in server.state.items] == ["sphere.ply", "second.ply"]
    # what was shown is shown again
    assert server.state.selected_item == k1 and server.state.color_field == "y"
    assert s2.view.shown is not None and s2.view.shown.n_total == 4000
    # a data file lost behind the project's back: a named error, the app goes on
    second = server.state.items[1]
    Path(s2.project.measurements()[1]["path"]).unlink()
    s2.select_item(second["id"])
    assert "second.ply" in server.state.error_message
    assert server.state.selected_item == k1


@pytest.mark.slow
def test_two_million_points_are_decimated_for_display(app, tmp_path):
    n = 2_000_000
    rng = np.random.default_rng(3)
    pts = rng.uniform(-50, 50, size=(n, 3))
    path = tmp_path / "big.ply"
    cio.write(PointCloud(pts, fields={"deviation": pts[:, 2] * 1e-3}, field_units={"deviation": "mm"}), path)
    server, s, page = app()
    key = s.import_file(path)
    assert key is not None, server.state.error_message
    assert s.view.shown.n_total == n
    # drawn in the browser (the default): all of them (up to clientview.CLIENT_LIMIT)
    assert s.view.shown.n_shown == n and server.state.display_note == "showing all 2 000 000 points"
    server.state.cv_inspect_mode = "server"  # the server's rendering: a random subset
    server.state.flush()
    assert s.view.shown.n_shown <= DISPLAY_LIMIT
    assert server.state.display_note.startswith("showing 500 000 of 2 000 000 points")
    assert s.load(key).n_points == n  # the full data stay for computations
    page.set_color_field("x")
    assert s.view.shown.n_shown <= DISPLAY_LIMIT


# -- a lab plugin with every parameter type, progress and cancellation ----------------
LAB_YAML = """
name: gui-lab
plugins:
  - id: lab.slowstats
    kind: algorithm
    name: Slow statistics
    version: 2.1.0
    summary: Mean distance from a point, reported in steps.
    entry: {pkg}.run:stats
    inputs: [{{name: cloud, type: pointcloud}}]
    parameters:
      - {{name: origin, type: vector, length: 3, unit: mm, default: [0, 0, 0]}}
      - {{name: steps, type: int, default: 4, min: 1, max: 100}}
      - {{name: scale, type: float, unit: um, default: 1000.0, min: 0}}
      - {{name: squared, type: bool, default: false}}
      - {{name: method, type: choice, choices: [mean, median], default: mean}}
      - {{name: note, type: str, default: ""}}
    outputs:
      - {{name: distance, type: float, unit: mm}}
      - {{name: per_point, type: array, unit: mm}}
  - id: lab.device
    kind: device
    name: Lab camera
    entry: {pkg}.run:stats
"""

LAB_PY = """
import time
import numpy as np

def stats(ctx, cloud, origin, steps, scale, squared, method, note):
    d = np.linalg.norm(cloud.points - np.asarray(origin), axis=1)
    for i in range(steps):
        ctx.progress(i / steps, f"step {i + 1} of {steps}")
        time.sleep(0.12)
    if squared:
        ctx.warn("squared distances are not lengths")
    value = float(np.mean(d) if method == "mean" else np.median(d))
    return {"distance": value * scale / 1000.0, "per_point": d, "stats": {"n": len(d), "unit": "mm"}}
"""


@pytest.fixture
def lab_host(tmp_path, monkeypatch):
    pkg = f"gui_lab_{os.getpid()}_{id(tmp_path)}"
    root = tmp_path / "labsrc" / pkg
    root.mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "plugin.yaml").write_text(LAB_YAML.format(pkg=pkg))
    (root / "run.py").write_text(LAB_PY)
    monkeypatch.syspath_prepend(str(tmp_path / "labsrc"))
    ep = md.EntryPoint(name="gui-lab", value=f"{pkg}:plugin.yaml", group="camcmm.plugins")
    return PluginHost(entry_points=[ep])


@pytest.mark.slow
def test_form_of_every_parameter_type_and_progress(app, lab_host, cloud_file):
    server, s, page = app(host=lab_host)
    state = server.state
    rows = {p["id"]: p for p in state.plugins}
    assert rows["lab.slowstats"]["runnable"] and not rows["lab.device"]["runnable"]
    page.select_plugin("lab.device")
    assert "device" in state.error_message and state.selected_plugin is None
    s.import_file(cloud_file)
    page.select_plugin("lab.slowstats")
    widgets = {f["name"]: (f["widget"], f["label"]) for f in state.form_fields}
    assert widgets == {
        "origin": ("text", "origin [mm]"),
        "steps": ("number", "steps"),
        "scale": ("number", "scale [µm]"),  # the key's um written µm (issue 30)
        "squared": ("switch", "squared"),
        "method": ("select", "method"),
        "note": ("text", "note"),
    }
    assert state.form_values == {
        "origin": "0, 0, 0",
        "steps": 4,
        "scale": 1000.0,
        "squared": False,
        "method": "mean",
        "note": "",
    }
    assert [f["choices"] for f in state.form_fields if f["name"] == "method"] == [["mean", "median"]]
    seen = []
    orig = page.show_progress
    page.show_progress = lambda f, m: (seen.append((f, m)), orig(f, m))
    values = dict(state.form_values, origin="1, 2, 3", squared=True, method="median", steps="3")
    res = run(page, "lab.slowstats", values)
    assert res is not None, state.error_message
    assert [m for _, m in seen][:3] == ["step 1 of 3", "step 2 of 3", "step 3 of 3"]
    assert seen[-1][0] == 1.0
    table = {r["name"]: (r["value"], r["unit"]) for r in state.result_rows}
    assert table["distance"][1] == "mm" and abs(float(table["distance"][0]) - 10.0) < 0.1
    assert table["per_point"][0].startswith("array (4000,)")
    assert table["stats.n"] == ("4000", "mm")
    assert state.result_warnings == ["squared distances are not lengths"]
    assert state.result["outputs"]["per_point"]["array_shape"] == [4000], "long arrays are summarised"
    # the per-point output became a colour field on a copy of the cloud
    assert state.items[-1]["name"].startswith("lab.slowstats fields")
    assert state.color_field in [f["value"] for f in state.color_fields]
    page.set_color_field("per_point")
    assert state.legend_title.startswith("per point [")  # the field in words
    # bad vector
    assert run(page, "lab.slowstats", dict(values, origin="1, 2")) is None
    assert "origin" in state.error_message


@pytest.mark.slow
def test_cancel_a_running_plugin(app, lab_host, cloud_file):
    server, s, page = app(host=lab_host)
    s.import_file(cloud_file)
    page.select_plugin("lab.slowstats")

    async def go():
        task = asyncio.ensure_future(page.run_plugin("lab.slowstats", {"steps": 50}))
        # cancel once the plugin computes: a cancel while a new worker process is still
        # starting is only honoured by stopping the worker after worker.CANCEL_GRACE_S
        while not task.done() and not str(server.state.progress_message).startswith("step"):
            await asyncio.sleep(0.01)
        assert await page.run_plugin("lab.slowstats", {"steps": 1}) is None  # one run at a time
        assert "is running; wait for it or cancel it" in server.state.error_message
        await asyncio.sleep(0.3)
        page.cancel()
        return await task

    assert asyncio.run(go()) is None
    assert "cancelled" in server.state.error_message
    assert not server.state.running
    assert s.project.results() == []
