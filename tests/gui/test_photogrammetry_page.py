"""The Photogrammetry page's logic without a browser (issue 16).

A stand-in for the plugin's run returns a reconstruction exact by construction: eight
cameras on a ring of radius 300 mm looking at a 20-mm sphere of points at the origin,
one image left unregistered with its reason. The page must draw one frustum per
registered camera with its apex at the camera centre and its axis along the camera's
viewing direction (Rᵀ e_z, here towards the origin: an R/Rᵀ mix-up points it
elsewhere), store the clouds as items made by the plugin with the result row, flag
the unregistered image, refuse paths outside the roots and bad values in one line,
cancel without storing, restore on reopen, and send the cloud to the other pages.
The real plugin on templeRing images runs in the slow test at the end.
"""

from __future__ import annotations

import asyncio
import base64
import importlib.util
import shutil
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trame")
pytest.importorskip("pyvista")
cv2 = pytest.importorskip("cv2")

from camcmm.errors import InputError  # noqa: E402
from camcmm.host import Cancelled, RunResult  # noqa: E402
from camcmm.model import PointCloud  # noqa: E402

N_VIEWS, RING = 8, 300.0
CAMERA = {"model": "SIMPLE_RADIAL", "fx": 800.0, "fy": 800.0, "cx": 320.0, "cy": 240.0, "dist": [0.0]}


def look_at(centre: np.ndarray) -> np.ndarray:
    """R (world -> camera, rows = camera axes in the world) of a camera at ``centre``
    looking at the origin, image y pointing down (world -z)."""
    z = -centre / np.linalg.norm(centre)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.vstack([x, y, z])


def fake_reconstruction(names: list[str]) -> dict:
    rng = np.random.default_rng(1)
    views, images = [], []
    for k, name in enumerate(names):
        registered = k != len(names) - 1
        images.append(
            {
                "image": name,
                "n_features": 900 + k,
                "n_matched": 400 + k if registered else 3,
                "registered": registered,
                "reason": "" if registered else "too few matches (3) with the other views",
            }
        )
        if registered:
            a = 2 * np.pi * k / len(names)
            C = RING * np.array([np.cos(a), np.sin(a), 0.3])
            R = look_at(C)
            views.append({"image": name, "R": R.tolist(), "t": (-R @ C).tolist(), "centre": C.tolist()})
    d = rng.normal(size=(600, 3))
    pts = 20.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    rec = {
        "n_images": len(names),
        "n_registered": len(views),
        "unregistered": [{"image": i["image"], "reason": i["reason"]} for i in images if not i["registered"]],
        "reprojection_rms_px": 0.42,
        "camera": CAMERA,
        "views": views,
        "n_points_sparse": 150,
        "n_points_dense": 600,
        "scale": {"method": "none", "factor": 1.0, "u": 0.0},
        "warnings": [],
        "timings": {"features": 0.1, "mapping": 0.2},
        "images": images,
    }
    return rec, PointCloud(pts, name="dense"), PointCloud(pts[:150], name="sparse")


def check(cancel) -> None:
    if cancel is not None and cancel.is_set():
        raise Cancelled("reconstruction: cancelled")


def fake_runner(host, sources, params, calibration=None, progress=None, cancel=None):
    """The task's run as the page calls it, answering with the constructed reconstruction."""
    plugin_id = "photogrammetry.reconstruct"
    for k, stage in enumerate(("features", "matching", "mapping", "dense")):
        check(cancel)
        progress(k / 4, f"{stage}: working")
    rec, cloud, sparse = fake_reconstruction([s["name"] for s in sources])
    return RunResult(
        plugin_id, "0.1.0", dict(params), {"images": "x"}, {"cloud": cloud, "sparse": sparse, "reconstruction": rec},
        "2026-11-27T00:00:00Z", "2026-11-27T00:00:01Z", [],
    )  # fmt: skip


def write_series(folder: Path, n: int, size=(160, 120)) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(3)
    out = []
    for k in range(n):
        p = folder / f"view{k:02d}.png"
        cv2.imwrite(str(p), rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8))
        out.append(p)
    return out


def test_frustum_of_an_identity_camera():
    """At the origin with R = I the camera looks along +z; the corners follow (u − cx)/fx."""
    from camcmm.gui.pages.photogrammetry.scene import frustum_points

    f = frustum_points(np.eye(3), [0, 0, 0], CAMERA, 2.0)
    assert np.allclose(f[0], 0) and np.allclose(f[1:, 2], 2.0)
    assert np.allclose(f[1, :2], [2.0 * -320 / 800, 2.0 * -240 / 800])  # image (0, 0): left (−x), up (−y)
    assert np.allclose(f[3, :2], [2.0 * 320 / 800, 2.0 * 240 / 800])


def test_stages_and_counts_read_from_the_plugins_words():
    from camcmm.gui.pages.photogrammetry import inputs
    from camcmm.tasks.photogrammetry import stage_of

    assert stage_of("matching: 12/28 pairs") == "matching" and stage_of("Dense 3/8") == "dense"
    assert stage_of("SIFT features") == "features" and stage_of("depth map 3/8") == "dense"
    assert stage_of("exhaustive matching") == "matching" and stage_of("registered 3 of 8 images") == "mapping"
    assert stage_of("starting") == ""
    rows = inputs.with_counts(
        inputs.rows([{"name": "a.png"}, {"name": "b.png"}, {"name": "c.png"}]),
        [
            {"image": "/x/a.png", "n_features": 5, "n_matched": 2, "registered": True, "reason": ""},
            {"image": "b.png", "n_features": 0, "n_matched": 0, "registered": False, "reason": "no features"},
        ],
    )
    assert [r["status"] for r in rows] == ["registered", "unregistered", "listed"]
    assert rows[1]["reason"] == "no features" and rows[0]["n_features"] == 5


@pytest.fixture
def app(gui_app, tmp_path):
    """``make(project_dir=None) -> (page, session, server)`` with ``tmp_path/data`` as a data root."""
    (tmp_path / "data").mkdir(exist_ok=True)

    def make(project_dir=None):
        server, session = gui_app(project_dir, data_roots=[tmp_path / "data"])
        page = server.pages["photogrammetry"]
        page.runner = fake_runner
        return page, session, server

    return make


@pytest.mark.slow
def test_opens_empty_with_the_declared_form(app):
    page, session, _ = app()
    s = page.state
    assert s.pg_images == [] and s.pg_summary == [] and "folder" in s.pg_empty_hint
    names = {f["name"] for f in s.pg_fields}
    assert {"dense", "max_image_size", "scale"} <= names  # the manifest's parameters, not a copy
    assert s.pg_params["max_image_size"] == 1600 and s.pg_params["dense"] is True
    assert session.page_error("photogrammetry") == ""


@pytest.mark.slow
def test_series_from_a_folder_as_thumbnails(app, tmp_path):
    page, _, _ = app()
    write_series(tmp_path / "data" / "s", 5)
    srcs = asyncio.run(page.list_async({"source": "folder", "folder": str(tmp_path / "data" / "s")}))
    assert [x["name"] for x in srcs] == [f"view{k:02d}.png" for k in range(5)]
    rows = page.state.pg_images
    assert len(rows) == 5 and all(r["status"] == "listed" for r in rows)
    png = base64.b64decode(rows[0]["thumb"].split(",", 1)[1])
    img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert rows[0]["thumb"].startswith("data:image/png;base64,") and img.shape[1] == 96
    # the project's image items, as the calibration page takes them
    for f in sorted((tmp_path / "data" / "s").glob("*.png"))[:3]:
        assert page.session.import_file(f) is not None
    page.pick_all_items()
    assert page.state.pg_source == "items" and len(page.state.pg_items) == 3
    srcs = asyncio.run(page.list_async())
    assert [x["name"] for x in srcs] == ["view00.png", "view01.png", "view02.png"]
    assert all(x["item"] is not None and Path(x["path"]).is_file() for x in srcs)
    assert len(page.state.pg_images) == 3 and page.state.pg_images[2]["thumb"]


@pytest.mark.slow
def test_paths_outside_the_roots_and_bad_values_are_one_line(app, tmp_path):
    page, session, _ = app()
    assert asyncio.run(page.list_async({"source": "folder", "folder": "/etc"})) is None
    err = session.page_error("photogrammetry")
    assert "outside the folders" in err and "/etc" in err and "\n" not in err
    write_series(tmp_path / "data" / "s", 3)
    req = {"source": "folder", "folder": str(tmp_path / "data" / "s")}
    n = len(session.project.results())
    assert asyncio.run(page.run_async({"scale": "lengths:/etc/passwd"}, req)) is None
    assert "outside the folders" in page.state.pg_error
    assert asyncio.run(page.run_async({"max_image_size": 10}, req)) is None
    assert "max_image_size" in page.state.pg_error
    assert asyncio.run(page.run_async(None, {"source": "items", "items": ["999"]})) is None
    assert "999" in page.state.pg_error
    assert len(session.project.results()) == n  # nothing half-written


@pytest.mark.slow
def test_run_stores_draws_cameras_and_flags_the_unregistered_image(app, tmp_path):
    page, session, _ = app()
    write_series(tmp_path / "data" / "s", N_VIEWS)
    seen = []
    page.job._interval = 0.0  # every message, not one per 0.2 s
    page.job._on_progress = lambda f, m: (seen.append(m), page._show_progress(f, m))
    rec = asyncio.run(page.run_async(None, {"source": "folder", "folder": str(tmp_path / "data" / "s")}))
    assert rec is not None, page.state.pg_error
    s = page.state
    assert any(m.startswith("mapping") for m in seen) and [st["state"] for st in s.pg_stages] == ["done"] * 4 + ["todo"]
    # the project: a result with both clouds as its files, two items made by the plugin
    res = session.project.result(rec["result"])
    assert set(res["files"]) == {"cloud", "sparse"}
    made = {k: session.measurement(v) for k, v in rec["items"].items()}
    assert all("result #" in m["meta"]["made_by"] for m in made.values())
    assert session.load(rec["items"]["cloud"]).n_points == 600
    # the images: counts, and the last one flagged with the plugin's reason
    rows = {r["name"]: r for r in s.pg_images}
    assert rows["view00.png"]["n_features"] == 900 and rows["view00.png"]["status"] == "registered"
    last = rows[f"view{N_VIEWS - 1:02d}.png"]
    assert last["status"] == "unregistered" and "too few matches" in last["reason"]
    assert {r["name"]: r["value"] for r in s.pg_summary}["registered"] == f"{N_VIEWS - 1} of {N_VIEWS}"
    # the scene: one frustum per registered camera, apex at the centre, axis along Rᵀ e_z
    assert s.pg_cameras == N_VIEWS - 1 == page.view.cameras_drawn()
    pts = np.asarray(page.view.camera_actor.GetMapper().GetInput().GetPoints().GetData()).reshape(-1, 5, 3)
    views = rec["reconstruction"]["views"]
    for frustum, v in zip(pts, views):
        C, R = np.asarray(v["centre"]), np.asarray(v["R"])
        assert np.allclose(frustum[0], C, atol=1e-4)
        axis = frustum[1:].mean(axis=0) - frustum[0]
        assert np.allclose(axis / np.linalg.norm(axis), R[2], atol=1e-6)  # Rᵀ e_z
        assert np.allclose(R[2], -C / np.linalg.norm(C), atol=1e-9)  # the construction looks at the origin
        # the image's top-left corner lies up (+z) and left of the axis, as the camera sees it
        assert frustum[1][2] > frustum[0][2] + axis[2]
    page.set_colour("z")
    assert s.pg_colour == "z" and page.view.cameras_drawn() == N_VIEWS - 1  # a new colouring keeps the cameras
    # the sparse cloud keeps the cameras
    page.show_cloud("sparse")
    assert s.pg_display == "sparse" and page.view.shown.n_total == 150 and page.view.cameras_drawn() == N_VIEWS - 1


@pytest.mark.slow
def test_cancel_stores_nothing_and_failure_is_one_line(app, tmp_path):
    page, session, _ = app()
    write_series(tmp_path / "data" / "s", 3)
    req = {"source": "folder", "folder": str(tmp_path / "data" / "s")}
    started = threading.Event()

    def slow(host, sources, params, calibration=None, progress=None, cancel=None):
        started.set()
        while True:
            check(cancel)
            time.sleep(0.01)

    page.runner = slow
    n_results, n_items = len(session.project.results()), len(session.project.measurements())

    async def run_and_cancel():
        task = asyncio.ensure_future(page.run_async(None, req))
        while not started.is_set():
            await asyncio.sleep(0.01)
        page.cancel()
        return await task

    assert asyncio.run(run_and_cancel()) is None
    assert page.state.pg_message == "cancelled" and not page.state.pg_running
    assert page.state.pg_error == "" and "nothing was stored" in session.state.info_message

    def refuse(*_):
        raise InputError("image series: 2 images (view00.png, view01.png); a reconstruction needs at least 3")

    page.runner = refuse
    assert asyncio.run(page.run_async(None, req)) is None
    assert page.state.pg_error.startswith("image series: 2 images") and "\n" not in page.state.pg_error
    assert session.page_error("photogrammetry") == page.state.pg_error
    # the camera held to the project's calibration: refused without one, passed on with one
    page.state.pg_use_cal = True
    assert asyncio.run(page.run_async(None, req)) is None and "no camera calibration" in page.state.pg_error
    cal = tmp_path / "cal.json"
    cal.write_text('{"camera_matrix": [[800, 0, 80], [0, 800, 60], [0, 0, 1]], "dist_coeffs": [0, 0, 0, 0, 0]}')
    h = session.project.add_file(cal)
    session.project.set_state("calibration.current", {"kind": "camera", "calibration": h})
    page.opened()  # the page shown again offers the calibration made meanwhile
    assert page.state.pg_cal_note
    given = []
    page.runner = lambda host, sources, params, calibration, progress, cancel: given.append(calibration) or refuse()
    page.state.pg_use_cal = True
    asyncio.run(page.run_async(None, req))
    assert given == [Path(session.project.file_path(h))]
    assert len(session.project.results()) == n_results and len(session.project.measurements()) == n_items


@pytest.mark.slow
def test_restored_on_reopen_and_sent_to_the_other_pages(app, tmp_path):
    page, session, server = app()
    write_series(tmp_path / "data" / "s", N_VIEWS)
    rec = asyncio.run(page.run_async(None, {"source": "folder", "folder": str(tmp_path / "data" / "s")}))
    key = rec["items"]["cloud"]
    assert page.send_to("compare") and server.state.page == "compare"
    assert server.pages["compare"].state.ins_measured == key
    assert page.send_to("inspect") and server.state.page == "inspect" and session.state.selected_item == key
    assert not page.send_to("nowhere") and "nowhere" in page.state.pg_error
    assert page.send_to("acceptance") and server.state.page == "acceptance"
    # sparse only: the plugin's "cloud" is the sparse one, stored once
    rec2 = asyncio.run(page.run_async({"dense": False}, {"source": "folder", "folder": str(tmp_path / "data" / "s")}))
    assert set(rec2["items"]) == {"sparse"} and page.state.pg_display == "sparse"
    assert page.view.shown.n_total == 150 and page.state.pg_cameras == N_VIEWS - 1
    assert page.send_to("inspect") and session.state.selected_item == rec2["items"]["sparse"]
    # a new server on the same project shows the stored run once the page opens
    page2, _, _ = app(session.project.path)
    assert page2.state.pg_summary and page2.state.pg_items_made == rec2["items"]
    page2.opened()
    assert page2.state.pg_cameras == N_VIEWS - 1
    assert page2.state.pg_images[-1]["status"] == "unregistered" and page2.state.pg_images[0]["thumb"]


@pytest.mark.slow
def test_the_real_plugin_on_templering(app, tmp_path, shared_data):
    """Eight templeRing views at 320 px, sparse only, through the installed plugin."""
    src = shared_data / "middlebury_mvs_templering"
    files = sorted(src.glob("*.png"))[:8]
    if len(files) < 8:
        pytest.skip(f"{src}: no templeRing images")
    for f in files:
        shutil.copy(f, tmp_path / "data" / f.name)
    page, session, _ = app()
    from camcmm.tasks import photogrammetry

    page.runner = photogrammetry.run
    if importlib.util.find_spec("camcmm_plugins.photogrammetry.plugin") is None:
        pytest.skip("the photogrammetry plugin's module is not there yet")
    params = {"dense": False, "max_image_size": 320, "scale": ""}
    rec = asyncio.run(page.run_async(params, {"source": "folder", "folder": str(tmp_path / "data")}))
    assert rec is not None, page.state.pg_error
    rc = rec["reconstruction"]
    # how many of eight neighbouring views the mapper registers is the plugin's matter (5 of
    # templeR0001-8 at 320 px here); the page shows exactly what it returned
    assert rc["n_images"] == 8 and rc["n_registered"] >= 3
    assert page.state.pg_cameras == rc["n_registered"] == len(rc["views"]) == page.view.cameras_drawn()
    rows = page.state.pg_images
    assert len(rows) == 8 and all(r["n_features"] > 0 for r in rows)
    unreg = [r for r in rows if r["status"] == "unregistered"]
    assert len(unreg) == 8 - rc["n_registered"] and all(r["reason"] for r in unreg)
    assert {r["name"] for r in unreg} == set(rc["unregistered"])


@pytest.mark.slow
def test_a_new_run_clears_the_previous_result_while_it_runs(app, tmp_path):
    """Issue 30: the page kept the previous run's figures and warnings during a new run.
    While the second run works nothing of the first is shown (figures, warnings, counts,
    cloud and cameras); cancelled, it stored nothing and the first comes back, said so."""
    page, session, _ = app()
    write_series(tmp_path / "data" / "s", N_VIEWS)
    req = {"source": "folder", "folder": str(tmp_path / "data" / "s")}

    def warned(*args, **kw):
        result = fake_runner(*args, **kw)
        result.warnings.append("1 of 8 images not registered: too few inlier matches")
        return result

    page.runner = warned
    assert asyncio.run(page.list_async(req))  # thumbnails, kept through the runs
    first = asyncio.run(page.run_async(None, req))
    s = page.state
    assert first is not None and s.pg_warnings and s.pg_summary and page.view.cameras_drawn() == N_VIEWS - 1
    started, seen = threading.Event(), {}

    def slow(host, sources, params, calibration=None, progress=None, cancel=None):
        started.set()
        while True:
            check(cancel)
            time.sleep(0.01)

    page.runner = slow

    async def run_and_look():
        task = asyncio.ensure_future(page.run_async(None, req))
        while not started.is_set():
            await asyncio.sleep(0.01)
        seen.update(
            summary=list(s.pg_summary), warnings=list(s.pg_warnings), title=s.pg_title, made=dict(s.pg_items_made),
            status={r["status"] for r in s.pg_images}, thumbs=all(r["thumb"] for r in s.pg_images),
            shown=page.view.shown, cameras=page.view.cameras_drawn(), record=page.record,
        )  # fmt: skip
        page.cancel()
        return await task

    assert asyncio.run(run_and_look()) is None
    assert seen == {
        "summary": [], "warnings": [], "title": "", "made": {}, "status": {"listed"}, "thumbs": True,
        "shown": None, "cameras": 0, "record": None,
    }  # fmt: skip
    # nothing stored: the project's last result is shown again, and the message says it is the previous one
    assert s.pg_message == f"cancelled; the previous result #{first['result']} is shown"
    assert s.pg_warnings == ["1 of 8 images not registered: too few inlier matches"]
    assert page.view.cameras_drawn() == N_VIEWS - 1 and page.record["result"] == first["result"]
