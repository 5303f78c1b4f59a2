"""The Fuse page's logic without a browser (issue 17).

A stand-in for the fusion plugin's run answers with a result exact by construction: a
coloured 20-mm square cloud, one 8 × 6 mm CSI map whose difference to the cloud is a
known ramp from −33 µm to +24 µm (the thesis's 95 % band, fig. 6.8), twelve inlier
matches related by a known similarity, the map's footprint as four corners. The page
must draw every match between the two images at their pixels, the difference map in
µm centred on 0, the Abbott-Firestone curve with the band at the 2.5/97.5 % heights,
outline the footprint on the fused cloud, store the fused cloud as an item made by the
plugin with the result row naming the input items, refuse missing or wrong inputs and
bad values in one line, show the plugin's refusal without storing anything, cancel
without storing, and show the last run again in a reopened project.
"""

from __future__ import annotations

import asyncio
import threading
import time

import numpy as np
import pytest

pytest.importorskip("trame")
pytest.importorskip("pyvista")

from camcmm import numbers  # noqa: E402
from camcmm.errors import InputError  # noqa: E402
from camcmm.host import Cancelled, RunResult  # noqa: E402
from camcmm.model import HeightMap, PointCloud  # noqa: E402

LO, HI = -0.033, 0.024  # mm: the ramp's ends (the thesis's −33/+24 µm)
ANGLE, SCALE, SHIFT = np.radians(12.0), 1.25, np.array([7.0, -3.0])  # photo px = S R csi px + t


def cloud_with_colour(n: int = 40) -> PointCloud:
    g = np.linspace(0.0, 20.0, n)
    xx, yy = np.meshgrid(g, g)
    pts = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(n * n)])
    rng = np.random.default_rng(2)
    return PointCloud(pts, colors=rng.integers(0, 255, (n * n, 3), dtype=np.uint8), name="photo")


def height_map(name: str = "map A") -> HeightMap:
    rng = np.random.default_rng(4)
    return HeightMap(rng.normal(0, 1e-3, (30, 40)), 0.2, 0.2, intensity=rng.random((30, 40)), name=name)


def ramp() -> np.ndarray:
    """(30, 40) mm: the difference map, a ramp along x from LO to HI, one cell undefined."""
    d = np.tile(np.linspace(LO, HI, 40), (30, 1))
    d[0, 0] = np.nan
    return d


def fake_views(rng: np.random.Generator) -> dict:
    csi_px = rng.uniform(5, 35, (12, 2))
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    photo_px = SCALE * csi_px @ np.array([[c, -s], [s, c]]).T + SHIFT
    d = ramp()
    v = d[np.isfinite(d)]
    edges = np.linspace(v.min(), v.max(), 21)
    counts, _ = np.histogram(v, edges)
    hs = np.sort(v)[::-1]
    return {
        "photo_image": rng.integers(0, 255, (64, 64)).tolist(),
        "csi_image": rng.integers(0, 255, (30, 40)).tolist(),
        "matches": {"photo": photo_px.tolist(), "csi": csi_px.tolist()},
        "footprint": [[2.0, 3.0, 0.0], [10.0, 3.0, 0.0], [10.0, 9.0, 0.0], [2.0, 9.0, 0.0]],
        "difference": {"grid": d, "dx": 0.2, "x0": 2.0, "y0": 3.0},
        "histogram": {"edges": edges.tolist(), "counts": counts.tolist()},
        "abbott": {
            "mr_percent": (100.0 * (np.arange(len(hs)) + 0.5) / len(hs)).tolist(),
            "height": hs.tolist(),
            "p2_5": float(np.percentile(v, 2.5)),
            "p97_5": float(np.percentile(v, 97.5)),
        },
    }


def check(cancel) -> None:
    if cancel is not None and cancel.is_set():
        raise Cancelled("fusion: cancelled")


def fake_runner(host, inputs, params, progress=None, cancel=None):
    """The task's run as the page calls it, answering with the constructed result."""
    cloud, maps, plugin_id = inputs.cloud, inputs.maps, "fusion.csi"
    for k, stage in enumerate(("grey images", "matching", "icp", "fusion")):
        check(cancel)
        progress(k / 4, f"{stage}: working")
    rng = np.random.default_rng(5)
    views = [fake_views(rng) for _ in maps]
    d = ramp()
    v = d[np.isfinite(d)]
    pts = [cloud.points] + [m.points() for m in maps]
    source = np.concatenate([np.full(len(p), k, dtype=float) for k, p in enumerate(pts)])
    fused = PointCloud(np.vstack(pts), fields={"source": source}, name="fused")
    one = {
        "n_matches": 30, "n_inliers": 12, "n_inliers_similarity": 12, "n_inliers_fundamental": 9,
        "transform2d": {"angle_deg": 12.0, "tx": 7.0, "ty": -3.0, "scale": 1.25},
        "icp": {"tz": 0.002, "rx_deg": 0.01, "ry_deg": -0.02, "rms": 0.004, "converged": True},
        "difference": {"mean": float(v.mean()), "std": float(v.std()),
                       "p2_5": float(np.percentile(v, 2.5)), "p97_5": float(np.percentile(v, 97.5))},
        "material_ratio": {"Sk": 0.03, "Spk": 0.002, "Svk": 0.003, "Smr1": 8.0, "Smr2": 91.0},
    }  # fmt: skip
    result = {
        "maps": [dict(one, file=m.name) for m in maps],
        "photogrammetry_scale": {"value": 1.25, "std": 0.0},
        "n_points_fused": fused.n_points,
        "warnings": [],
    }
    return RunResult(
        plugin_id, "0.1.0", dict(params), {"cloud": "x"}, {"fused": fused, "result": result, "views": {"maps": views}},
        "2026-11-27T00:00:00Z", "2026-11-27T00:00:01Z", [],
    )  # fmt: skip


def add_item(session, obj, name: str) -> str:
    """``obj`` as a project item, as an import would make it."""
    project = session.project
    h = project.add_object(obj, name, ext=".x3p" if isinstance(obj, HeightMap) else ".ply")
    mid = session.add_measurement(name, h, obj)
    session.refresh_items()
    return str(mid)


@pytest.fixture
def app(gui_app, tmp_path):
    """``make(project_dir=None) -> (page, session)`` with the stand-in runner."""

    def make(project_dir=None):
        server, session = gui_app(project_dir)
        page = server.pages["fuse"]
        page.runner = fake_runner
        return page, session

    return make


@pytest.fixture
def inputs(app):
    page, session = app()
    cloud = add_item(session, cloud_with_colour(), "photo cloud")
    hm = add_item(session, height_map(), "map A")
    return page, session, cloud, hm


@pytest.mark.slow
def test_opens_empty_with_the_declared_form_and_loads_the_sample_pair(app):
    """Empty: the plugin's form, a hint that offers the sample. "Load the sample pair": a
    coloured cloud and a height map with its intensity, made by the sample's plugin, chosen as
    the inputs, the form back at the declared defaults (at which the pair fuses:
    tests/fusion/test_fusion_sample.py); a second load reuses them."""
    from camcmm_plugins.fusion.sample import SAMPLE_SHAPE

    page, session = app()
    s = page.state
    assert s.fu_numbers == [] and "height map" in s.fu_empty_hint and s.fu_error == ""
    assert {"sigma_px", "reject"} <= {f["name"] for f in s.fu_fields}  # the manifest's, not a copy
    assert s.fu_params["sigma_px"] == 6.0 and s.fu_params["reject"] == "similarity"
    assert session.page_error("fuse") == ""
    page.state.fu_params = {**page.state.fu_params, "sigma_px": 1.0}  # a newcomer's stray edit
    req = page.load_sample()
    assert req is not None, page.state.fu_error
    cloud, hm = session.load(req["cloud"]), session.load(req["maps"][0])
    assert isinstance(cloud, PointCloud) and cloud.colors is not None and cloud.n_points > 100_000
    assert isinstance(hm, HeightMap) and hm.intensity is not None and hm.shape == SAMPLE_SHAPE
    s = page.state
    assert (s.fu_cloud, s.fu_maps) == (req["cloud"], req["maps"])
    assert s.fu_params["sigma_px"] == 6.0 and "press Run" in s.fu_message and s.fu_error == ""
    names = {i["name"] for i in s.items}
    assert {"coin_photogrammetry.ply", "coin_csi.x3p"} <= names
    made = session.measurement(req["maps"][0])["meta"]["made_by"]
    assert made.startswith("fusion.sample ")
    n = len(session.project.measurements())
    assert page.load_sample() == req and len(session.project.measurements()) == n
    assert "Load the sample pair" in s.fu_empty_hint


@pytest.mark.slow
def test_a_fusion_shows_matches_difference_curve_footprint_and_is_stored(inputs):
    page, session, cloud, hm = inputs
    n_results = len(session.project.results())
    rec = asyncio.run(page.run_async(None, {"cloud": cloud, "maps": [hm]}))
    assert rec is not None, page.state.fu_error
    s = page.state
    # the matches: every inlier drawn from its photo pixel to its CSI pixel, the CSI image offset to the right
    data = s.fu_fig_matches["data"]
    xs, ys = data[0]["x"], data[0]["y"]
    assert len(xs) == 3 * 12 and xs[2::3] == [None] * 12
    m = rec["views"][0]["matches"]
    off = s.fu_fig_matches["layout"]["images"][1]["x"] + 0.5
    assert off >= 64  # right of the 64-px photo image
    assert np.allclose(xs[0::3], np.asarray(m["photo"])[:, 0]) and np.allclose(ys[1::3], np.asarray(m["csi"])[:, 1])
    assert np.allclose(np.asarray(xs[1::3]) - off, np.asarray(m["csi"])[:, 0])
    imgs = s.fu_fig_matches["layout"]["images"]
    assert [i["sizex"] for i in imgs] == [64, 40] and [i["sizey"] for i in imgs] == [64, 30]
    assert all(i["source"].startswith("data:image/png;base64,") for i in imgs)
    # the difference map in µm, undefined cell kept undefined, centred on 0
    hm_trace = s.fu_fig_diff["data"][0]
    z = np.array([[np.nan if v is None else v for v in row] for row in hm_trace["z"]], dtype=float)
    assert np.isnan(z[0, 0]) and np.allclose(z[1], 1e3 * np.linspace(LO, HI, 40), atol=1e-3)
    assert hm_trace["zmid"] == 0 and np.isclose(hm_trace["x"][1] - hm_trace["x"][0], 0.2)
    # the Abbott-Firestone curve falls from the highest to the lowest difference; the band at the percentiles
    ab = s.fu_fig_abbott["data"][0]
    assert np.isclose(ab["y"][0], 1e3 * HI) and np.isclose(ab["y"][-1], 1e3 * LO) and np.all(np.diff(ab["y"]) <= 0)
    band = s.fu_fig_abbott["layout"]["shapes"][0]
    v = ramp()[np.isfinite(ramp())]
    assert np.isclose(band["y0"], 1e3 * np.percentile(v, 2.5)) and np.isclose(band["y1"], 1e3 * np.percentile(v, 97.5))
    assert "95 %" in s.fu_fig_abbott["layout"]["annotations"][0]["text"]
    assert len(s.fu_fig_hist["data"][0]["y"]) == 20
    # the numbers
    num = {r["name"]: r["value"] for r in s.fu_numbers}
    assert num["matches"] == "30 / 12" and num["inliers_models"] == "12 / 9" and "map A" in num["file"]
    assert "12.00°" in num["transform2d"] and "× 1.25" in num["transform2d"] and "1.25" in num["scale"]
    assert num["band"] == f"{numbers.deviation(np.percentile(v, 2.5))} … {numbers.deviation(np.percentile(v, 97.5))}"
    assert num["band"] == "−31.5 µm … +22.6 µm"  # the number rule: µm, three digits, a real minus
    # the fused cloud, coloured by source, with one footprint outlined
    assert page.view.field == "source" and s.fu_outlines == 1 == page.view.outlines_drawn()
    # stored: the fused cloud as an item made by the plugin; the result row names both inputs
    assert len(session.project.results()) == n_results + 1
    item = session.measurement(rec["items"]["fused"])
    assert item["kind"] == "pointcloud" and f"result #{rec['result']}" in item["meta"]["made_by"]
    row = session.project.result(rec["result"])
    assert sorted(int(x) for x in row["measurement_ids"]) == sorted([int(cloud), int(hm)])
    assert row["outputs"]["result"]["maps"][0]["n_inliers"] == 12 and "fused" in row["files"]
    assert "photo_image" not in str(row["outputs"])[:100000]  # the figures' arrays stay out of the row
    assert session.page_error("fuse") == ""


@pytest.mark.slow
def test_missing_or_wrong_inputs_and_bad_values_are_one_line(inputs):
    page, session, cloud, hm = inputs
    n = len(session.project.results())
    cases = [
        ({"cloud": None, "maps": [hm]}, None, "no photogrammetry cloud"),
        ({"cloud": cloud, "maps": []}, None, "no height map"),
        ({"cloud": cloud, "maps": [cloud]}, None, "'photo cloud' is a pointcloud, not a heightmap"),
        ({"cloud": hm, "maps": [hm]}, None, "'map A' is a heightmap, not a pointcloud"),
        ({"cloud": cloud, "maps": ["999"]}, None, "999"),
        ({"cloud": cloud, "maps": [hm]}, {"sigma_px": 1000}, "sigma_px"),
        ({"cloud": cloud, "maps": [hm]}, {"reject": "magic"}, "reject"),
    ]
    for req, params, words in cases:
        assert asyncio.run(page.run_async(params, req)) is None
        err = page.state.fu_error
        assert words in err and "\n" not in err, (words, err)
        assert session.page_error("fuse") == err
    assert len(session.project.results()) == n


@pytest.mark.slow
def test_the_plugins_refusal_is_shown_and_nothing_is_stored(inputs):
    page, session, cloud, hm = inputs

    def refuse(host, inputs, params, progress=None, cancel=None):
        raise InputError("map A: no overlap with the cloud's grey image (3 matches, 8 needed)")

    page.runner = refuse
    n, items = len(session.project.results()), len(session.state.items)
    assert asyncio.run(page.run_async(None, {"cloud": cloud, "maps": [hm]})) is None
    assert page.state.fu_error.startswith("map A: no overlap") and page.state.fu_message == "failed"
    assert len(session.project.results()) == n and len(session.state.items) == items
    assert not page.state.fu_running and page.state.fu_numbers == []


@pytest.mark.slow
def test_cancel_stores_nothing(inputs):
    page, session, cloud, hm = inputs
    started = threading.Event()

    def slow(host, inputs, params, progress=None, cancel=None):
        started.set()
        for _ in range(200):
            check(cancel)
            time.sleep(0.02)
        raise AssertionError("not cancelled")

    page.runner = slow

    async def go():
        task = asyncio.ensure_future(page.run_async(None, {"cloud": cloud, "maps": [hm]}))
        while not started.is_set():
            await asyncio.sleep(0.01)
        page.cancel()
        return await task

    n = len(session.project.results())
    assert asyncio.run(go()) is None
    assert page.state.fu_message == "cancelled" and len(session.project.results()) == n


@pytest.mark.slow
def test_two_maps_one_at_a_time_and_the_run_restored(inputs, app, tmp_path):
    page, session, cloud, hm = inputs
    hm2 = add_item(session, height_map("map B"), "map B")
    rec = asyncio.run(page.run_async(None, {"cloud": cloud, "maps": [hm, hm2], "name": "coin"}))
    assert rec is not None and rec["name"] == "coin"
    assert [m["title"] for m in page.state.fu_map_names] == ["1: map A", "2: map B"]
    page.show_map(1)
    assert page.state.fu_map == 1 and "map B" in page.state.fu_numbers[0]["value"]
    assert page.state.fu_outlines == 2
    # a reopened project shows the run again; the scene is drawn when the page opens
    again, _ = app(session.project.path)
    assert again.state.fu_cloud == cloud and again.state.fu_maps == [hm, hm2]
    assert again.state.fu_numbers and "from the project" in again.state.fu_message
    again.opened()
    assert again.view.shown is not None and again.state.fu_outlines == 2


def test_a_footprint_outline_is_lifted_off_its_plane_towards_plus_z():
    """Drawn in the plane of the points the outline would hide among them: it stands
    LIFT × its diagonal off its plane, on the +z side, whichever way its corners run."""
    from camcmm.gui.pages.fuse.scene import LIFT, lifted

    c = np.array([[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [4.0, 3.0, 1.0], [0.0, 3.0, 1.0]])
    for corners in (c, c[::-1]):
        up = lifted(corners)
        assert np.allclose(up[:, :2], corners[:, :2]) and np.allclose(up[:, 2], 1.0 + LIFT * 5.0)
