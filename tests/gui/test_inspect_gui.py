"""The "Compare with CAD" page without a browser: the ComparePage behind it, on a real
project, with the inspection plugin really running.

The nominal is a CAD box (40 × 30 × 20 mm); the measured cloud is sampled on it with
5 µm noise and a 30 µm bump on the top face, then moved by a known rigid motion. Every
number the page shows is checked against an independent numpy computation on the
plugin's deviations (the plugin's own correctness has its own tests).
"""

from __future__ import annotations

import asyncio
import math
import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

cio = pytest.importorskip("camcmm.io")
pytest.importorskip("trame")
pytest.importorskip("pyvista")
pytest.importorskip("trame_plotly", reason="trame-plotly draws the page's charts")

from camcmm.gui.pages.compare import tables as ip  # noqa: E402
from camcmm.gui.pages.compare.page import STATE_KEY  # noqa: E402
from camcmm.gui.pages.compare.picking import world_to_display  # noqa: E402
from camcmm.gui.view import fmt_count  # noqa: E402
from camcmm.host import default_host  # noqa: E402
from camcmm.model import PointCloud, TriangleMesh  # noqa: E402
from helpers.compare_data import HI, LO, MOTION, NOISE, imported, surface_points  # noqa: E402
from helpers.shapes import box_mesh  # noqa: E402

if "inspect.compare" not in default_host().plugins:
    pytest.skip("the inspection plugin is not installed", allow_module_level=True)


@pytest.fixture
def app(gui_app):
    return gui_app


@pytest.mark.slow
def test_compare_publishes_stats_charts_legend_and_bands(app, tmp_path):
    server, session, page, truth = imported(app, tmp_path)
    s = server.state
    names = {it["id"]: it["name"] for it in s.items}
    assert names[s.ins_measured] == "scan.ply" and names[s.ins_nominal] == "box.stl"
    choices = default_host().get("inspect.compare").parameters[0].choices
    assert [o["value"] for o in s.ins_align_options] == list(choices)
    s.ins_tolerance = "0.01"
    result = asyncio.run(page.run_async())
    assert result is not None, s.ins_error
    assert s.ins_error == "" and s.ins_has_result and not s.ins_failed
    o = result.outputs
    dev = np.asarray(page.deviations.fields["deviation"], dtype=float)
    assert len(dev) == len(truth)

    # that the alignment undid the motion (the deviations are the noise and the bump) is the
    # task's: tests/tasks/test_compare_task.py; here, what the page shows of it
    assert o["converged"] and s.ins_title.endswith("alignment icp")

    # legend in µm (the colour limit is the tolerance, 10 µm), the view coloured by it
    assert s.ins_unit == "µm" and s.ins_legend_title == "deviation [µm]"
    assert page.view.scalar_bar_title == "deviation [µm]" and s.ins_mode == "colour"
    assert "±10.0 µm" in s.ins_limit_text
    bar = page.view.plotter.scalar_bars["deviation [µm]"]
    labels = bar.GetCustomLabels()
    assert bar.GetUseCustomLabels() and bar.GetLookupTable().GetRange() == (-10.0, 10.0)
    assert [labels.GetValue(i) for i in range(labels.GetNumberOfTuples())] == [-10, -5, 0, 5, 10]

    # the statistics table = numpy on the deviations
    rows = {r["key"]: r["value"] for r in s.ins_stats}
    um = lambda x, signed=True: ip.fmt_len(x, "µm", signed)  # noqa: E731
    assert rows["n"] == fmt_count(len(dev))
    assert rows["mean"] == um(dev.mean())
    assert rows["std"] == um(dev.std(ddof=1), False)
    assert rows["rms"] == um(np.sqrt(np.mean(dev**2)), False)
    assert rows["min"] == um(dev.min()) and rows["max"] == um(dev.max())
    p25, p975 = np.percentile(dev, [2.5, 97.5], method="hazen")
    assert rows["p2_5"] == um(p25) and rows["p97_5"] == um(p975)
    assert rows["interval95"] == f"{um(p975)} / {um(p25)}"
    assert rows["interval95"].startswith("+") and " / \u2212" in rows["interval95"]
    assert rows["within"] == f"{100 * np.mean(np.abs(dev) <= 0.01):.2f} %"
    assert rows["coverage"] == f"{100 * o['coverage']:.2f} %"
    assert rows["coverage_distance"] == ip.fmt_len(o["coverage_info"]["distance"], "mm")
    arows = {r["key"]: r["value"] for r in s.ins_alignment}
    assert arows["converged"] == "yes" and arows["scale"] == f"{o['scale']:.8f}"
    assert arows["rms"] == ip.fmt_len(o["rms"], "µm")

    # tolerance bands: the counts are numpy's
    bands = {b["key"]: b["count"] for b in s.ins_bands}
    assert bands["within"] == int(np.sum(np.abs(dev) <= 0.01))
    assert bands["above"] == int(np.sum(dev > 0.01)) and bands["below"] == int(np.sum(dev < -0.01))
    page.set_mode("bands")
    assert s.ins_mode == "bands" and page.view.scene == "bands"
    assert page.view.legend_labels == ["above +10.0 µm", "within ±10.0 µm", "below \u221210.0 µm"]
    # another tolerance after the run: bands and share follow, no re-run
    page.set_tolerance("0.02")
    bands = {b["key"]: b["count"] for b in s.ins_bands}
    assert bands["within"] == int(np.sum(np.abs(dev) <= 0.02))
    assert {r["key"]: r["value"] for r in s.ins_stats}["within"] == f"{100 * np.mean(np.abs(dev) <= 0.02):.2f} %"
    page.set_mode("colour")
    assert page.view.scene == "colour"

    # histogram: the plugin's bins, in µm, the 95 % interval and ±tolerance marked
    h = s.ins_fig_hist
    bar = h["data"][0]
    assert bar["type"] == "bar" and sum(bar["y"]) == len(dev)
    edges = np.asarray(o["histogram"]["edges"])
    assert np.allclose(bar["x"], 1e3 * 0.5 * (edges[1:] + edges[:-1]))
    assert "µm" in bar["hovertemplate"] and "points" in bar["hovertemplate"]
    xs = sorted({round(sh["x0"], 6) for sh in h["layout"]["shapes"] if sh["type"] == "line"})
    assert np.allclose(xs, sorted([round(1e3 * p25, 6), round(1e3 * p975, 6), -20.0, 20.0]))

    # Abbott-Firestone curve: the plugin's curve, with the construction
    af = s.ins_fig_af
    names = [t["name"] for t in af["data"]]
    for part in (
        "material-ratio curve",
        "40 % secant of least gradient",
        "equivalent straight line",
        "Spk triangle",
        "Svk triangle",
        "C1, Smr1",
        "C2, Smr2",
    ):
        assert part in names
    curve = af["data"][names.index("material-ratio curve")]
    mr = o["material_ratio"]
    assert np.allclose(curve["x"], mr["curve"]["mr_percent"])
    assert np.allclose(curve["y"], 1e3 * np.asarray(mr["curve"]["height"]))
    assert "material ratio" in curve["hovertemplate"]
    spk = af["data"][names.index("Spk triangle")]
    assert math.isclose(max(spk["y"]) - min(spk["y"]), 1e3 * mr["Spk"], rel_tol=1e-9)
    assert math.isclose(max(spk["x"]), mr["Smr1"], rel_tol=1e-9)
    assert any("95 % within" in a["text"] for a in af["layout"]["annotations"])

    # the project keeps the comparison: result, deviations file, state
    saved = session.project.get_state(STATE_KEY)
    assert saved["result"] == s.ins_result_id and saved["tolerance"] == 0.01
    assert saved["measured"] == int(s.ins_measured) and saved["nominal"] == int(s.ins_nominal)


@pytest.mark.slow
def test_pick_section_export_report_and_reopen(app, tmp_path):
    server, session, page, truth = imported(app, tmp_path)
    s = server.state
    s.ins_tolerance = "0.01"
    assert asyncio.run(page.run_async()) is not None, s.ins_error
    cloud = page.deviations
    dev = cloud.fields["deviation"]

    # a pick at the screen position of a known point on the visible top face
    view = page.view
    view.plotter.view_xy()
    view.screenshot()  # renders: the depth buffer says which surface is in front
    top = np.nonzero(cloud.points[:, 2] > 19.99)[0]
    i = int(top[np.argmin(np.linalg.norm(cloud.points[top, :2] - [12.0, 9.0], axis=1))])
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    c = vtkCoordinate()
    c.SetCoordinateSystemToWorld()
    c.SetValue(*cloud.points[i])
    x, y = c.GetComputedDoubleDisplayValue(view.renderer)
    info = page.pick_display(x, y)
    assert info is not None and info["index"] == i
    assert info["deviation_mm"] == pytest.approx(float(dev[i]))
    assert s.ins_picked["deviation"] == ip.fmt_len(dev[i], "µm", True, 4)
    assert s.ins_picked["band"] == ("within" if abs(dev[i]) <= 0.01 else ("above" if dev[i] > 0 else "below"))
    W, H = view.plotter.window_size
    assert page.pick_at(x / W, 1 - y / H)["index"] == i  # the browser's fractions
    assert page.pick_display(2, 2) is None and s.ins_picked["found"] is False  # the background

    # a section across z through the middle: the box's rectangle, the measured points in the slab
    sec = page.set_section("z", 10.0)
    assert sec is not None and sec["u"] == "x" and sec["v"] == "y"
    pts = np.vstack(sec["nominal"])
    assert np.allclose(pts.min(axis=0), [0, 0], atol=1e-9) and np.allclose(pts.max(axis=0), [40, 30], atol=1e-9)
    on_edge = np.minimum.reduce([np.abs(pts[:, 0]), np.abs(pts[:, 0] - 40), np.abs(pts[:, 1]), np.abs(pts[:, 1] - 30)])
    assert on_edge.max() < 1e-9
    spacing = page.spacing()
    assert 0.05 < spacing < 1.0
    in_slab = np.abs(cloud.points[:, 2] - 10.0) <= 0.5 * spacing
    assert sec["n_in_slab"] == int(in_slab.sum()) > 10
    assert np.allclose(np.sort(sec["deviation"]), np.sort(dev[in_slab]))
    fig = s.ins_fig_section
    # the measured points as deviation whiskers along the nominal's cut (issue 15), then the cut
    names = [t["name"] for t in fig["data"]]
    assert names[:2] == ["whiskers above", "whiskers below"] and names[-1] == "nominal"
    assert names[2].startswith("deviation ×")
    assert fig["layout"]["yaxis"]["scaleanchor"] == "x"
    assert s.ins_section_axis == "z" and s.ins_section_pos == 10.0
    # another axis re-centres the plane on the part
    sec = page.set_section("x")
    assert s.ins_section_axis == "x" and abs(sec["position"] - 20.0) < 0.5 and sec["n_in_slab"] > 10

    # export: a PLY that camcmm.io reads back with the deviation field; added to the project
    n_items = len(s.items)
    out = asyncio.run(page.export_async())
    assert out is not None, s.ins_error
    back = cio.read(out["path"])
    assert back.n_points == cloud.n_points and back.field_units.get("deviation") == "mm"
    assert np.allclose(back.fields["deviation"], dev) and back.colors is not None
    assert len(s.items) == n_items + 1 and s.ins_export_links[0]["url"].endswith(".ply")
    assert session.project.file_path(out["hash"]).is_file()

    # report: the plugin's writer, HTML/PDF/JSON in the project, links offered
    rep = asyncio.run(page.report_async())
    assert rep is not None, s.ins_error
    assert sorted(rep["paths"]) == ["html", "json", "pdf"]
    for p in rep["paths"].values():
        assert Path(p).is_file() and Path(p).stat().st_size > 1000
    assert "Inspection against the nominal" in Path(rep["paths"]["html"]).read_text("utf-8")
    assert [l["kind"] for l in s.ins_report_links] == ["html", "pdf", "json"]
    for l in s.ins_report_links:
        assert (page.downloads / l["name"]).is_file()

    # reopening the project shows the last comparison
    stats = list(s.ins_stats)
    project_dir = session.project.path
    server.pages["compare"].close()
    server.session.close()
    session.project.close()
    server2, _ = app(project_dir)
    s2 = server2.state
    assert s2.ins_has_result and not s2.ins_failed and s2.ins_mode == "colour"
    assert s2.ins_stats == stats and s2.ins_unit == "µm"
    assert [l["kind"] for l in s2.ins_report_links] == ["html", "pdf", "json"]
    assert s2.ins_export_links and s2.ins_fig_af["data"] and s2.ins_fig_section["data"]
    view2 = server2.pages["compare"].view
    assert view2.scene == "colour" and view2.dev.n_total == cloud.n_points


@pytest.mark.slow
def test_no_overlap_is_reported_not_coloured(app, tmp_path):
    """A ball twice the box's size, 500 mm off: no alignment fits it onto the box."""
    server, session, page, _ = imported(app, tmp_path)
    u = np.random.default_rng(4).normal(size=(6000, 3))
    ball = 2 * np.linalg.norm(HI - LO) * u / np.linalg.norm(u, axis=1)[:, None] + 500.0
    cio.write(PointCloud(ball, name="ball"), tmp_path / "files" / "ball.ply")
    assert session.import_file(tmp_path / "files" / "ball.ply") is not None
    page.refresh_inputs()
    s = server.state
    s.ins_measured = next(it["id"] for it in s.items if it["name"] == "ball.ply")
    result = asyncio.run(page.run_async())
    assert result is not None and not result.outputs["converged"]
    assert s.ins_failed and s.ins_failed_reason and s.ins_failed_reason == result.outputs["reason"]
    assert "\n" not in s.ins_failed_reason
    assert s.ins_stats == [] and s.ins_bands == [] and s.ins_fig_hist["data"] == []
    assert page.view.scene == "failed" and page.view.scalar_bar_title == ""
    assert {r["key"]: r["value"] for r in s.ins_alignment}["converged"].startswith("NO")
    page.set_mode("colour")  # refused, with a reason
    assert page.view.scene == "failed" and "alignment failed" in s.ins_error
    assert page.set_section("z", 0.0) is None and "no section" in s.ins_error  # nor a section of it
    assert asyncio.run(page.export_async()) is None and "not valid" in s.ins_error
    rep = asyncio.run(page.report_async())  # the report records the failure
    html = Path(rep["paths"]["html"]).read_text("utf-8")
    assert rep is not None and "did not converge" in html and f"alignment failed: {s.ins_failed_reason}" in html
    assert "Deviation colour map" not in html and "Abbott-Firestone" not in html
    # it is still stored (a failed comparison is a result too), and restored as failed
    assert session.project.get_state(STATE_KEY)["result"] == s.ins_result_id
    project_dir = session.project.path
    server.pages["compare"].close()
    server.session.close()
    session.project.close()
    server2, _ = app(project_dir)
    assert server2.state.ins_failed and server2.state.ins_failed_reason == result.outputs["reason"]
    assert server2.pages["compare"].view.scene == "failed" and server2.state.ins_stats == []


@pytest.mark.slow
def test_run_async_reports_progress_and_can_be_cancelled(app, tmp_path):
    server, session, page, _ = imported(app, tmp_path)
    s = server.state
    seen = []
    original = page.job.progress

    def progress(fraction, message):
        seen.append(message)
        if len(seen) == 2:  # the operator presses Cancel while the plugin runs
            page.cancel()
        original(fraction, message)

    page.job.progress = progress
    assert asyncio.run(page.run_async()) is None
    assert not s.ins_running and "cancelled" in s.ins_error and s.ins_progress_message == "cancelled"
    assert not s.ins_has_result and session.project.get_state(STATE_KEY) is None
    # and a run that is not cancelled: done, shown and stored from the worker
    page.job.progress = original
    result = asyncio.run(page.run_async())
    assert result is not None and s.ins_has_result and not s.ins_running and s.ins_progress == 100.0
    assert session.project.get_state(STATE_KEY)["result"] == s.ins_result_id
    assert {"result", "drawn", "numbers"} <= set(s.ins_timing)


@pytest.mark.slow
def test_point_pairs_picked_in_the_view_align_a_turned_part(app, tmp_path):
    server, session, page, truth = imported(app, tmp_path)
    s = server.state
    # turned by 90 degrees and moved far: plain ICP cannot, three pairs can
    measured = page.load(s.ins_measured, "measured")
    T = np.array([[0, -1, 0, 100.0], [1, 0, 0, 50.0], [0, 0, 1, -30.0], [0, 0, 0, 1]])
    moved = PointCloud(measured.points @ T[:3, :3].T + T[:3, 3], name="turned")
    cio.write(moved, tmp_path / "turned.ply")
    key = session.import_file(tmp_path / "turned.ply")
    page.set_inputs(measured=key)
    page.set_align("pairs+icp")
    assert s.ins_mode == "inputs" and page.view.scene == "inputs" and "measured" in s.ins_pick_hint
    # pick: the measured point drawn at a screen position, then the nominal surface
    view = page.view
    view.plotter.view_isometric()
    view.screenshot()
    prep = view._inputs["measured"]
    xy, dist, ok = world_to_display(view.renderer, prep.points)
    j = int(np.argmin(dist))  # the point nearest to the camera is surely visible
    got = page.pick_display(*xy[j])
    assert got["which"] == "measured" and np.allclose(got["point"], prep.points[j])
    assert "nominal" in s.ins_pick_hint
    assert page.pick_display(2, 2) is None and "no point" in s.ins_pick_hint
    # then the nominal mesh: the point of its surface under the click (the cloud in front is not in the way)
    from vtkmodules.vtkRenderingCore import vtkCoordinate

    c = vtkCoordinate()
    c.SetCoordinateSystemToWorld()
    c.SetValue(20.0, 15.0, 20.0)
    got = page.pick_display(*c.GetComputedDoubleDisplayValue(view.renderer))
    assert got["which"] == "nominal"
    assert abs(got["point"][2] - 20.0) < 1e-6 and np.linalg.norm(np.subtract(got["point"], [20, 15, 20])) < 0.5
    assert len(s.ins_pairs) == 1 and s.ins_pairs[0]["complete"] and "pair 2" in s.ins_pick_hint
    page.undo_pair_point()
    page.undo_pair_point()
    assert s.ins_pairs == []
    # three pairs: measured corners of the turned box and the CAD corners
    corners = np.array([[0, 0, 20.0], [40, 0, 20.0], [0, 30, 20.0]])
    for c in corners:
        page.add_pair_point("measured", (MOTION[:3, :3] @ c + MOTION[:3, 3]) @ T[:3, :3].T + T[:3, 3])
        page.add_pair_point("nominal", c)
    assert len(s.ins_pairs) == 3 and all(p["complete"] for p in s.ins_pairs)
    assert "three pairs" in s.ins_pick_hint
    result = asyncio.run(page.run_async())
    assert result is not None, s.ins_error
    assert result.outputs["converged"], result.outputs["reason"]
    assert abs(np.std(page.deviations.fields["deviation"]) - NOISE) < 0.002
    assert session.project.get_state(STATE_KEY)["pairs"]["nominal"] == corners.tolist()


@pytest.mark.slow
def test_a_reference_cloud_as_the_nominal(app, tmp_path):
    server, session, page, _ = imported(app, tmp_path)
    s = server.state
    V, F = box_mesh(LO, HI, n=4)
    ref = PointCloud(surface_points(V, F, 30000, np.random.default_rng(9)), name="reference")
    cio.write(ref, tmp_path / "reference.ply")
    key = session.import_file(tmp_path / "reference.ply")
    page.set_inputs(nominal=key)
    assert page.view.scene == "inputs" and "nominal_cloud" in page.view._inputs
    # a pair point on the nominal cloud is one of its points
    page.set_align("pairs")
    page.add_pair_point("measured", [1.0, 2.0, 20.0])
    view = page.view
    view.plotter.view_isometric()
    view.screenshot()
    prep = view._inputs["nominal_cloud"]
    xy, dist, ok = world_to_display(view.renderer, prep.points)
    j = int(np.argmin(dist))
    got = page.pick_display(*xy[j])
    assert got["which"] == "nominal" and np.allclose(got["point"], prep.points[j])
    page.clear_pairs()
    page.set_align("icp")
    s.ins_tolerance = "0.02"
    # a larger inlier distance through "More parameters": inspect.align judges a match
    # against a reference cloud by point-to-point distances, which the cloud's spacing
    # widens (reported to the plugin's author)
    s.ins_params = dict(s.ins_params, inlier_distance="2")
    result = asyncio.run(page.run_async())
    assert result is not None and result.outputs["converged"], result.outputs["reason"]
    assert result.params["inlier_distance"] == 2.0
    assert "local plane" in result.outputs["distance_method"]
    sec = page.set_section("z", 10.0)
    assert sec["nominal"] == [] and len(sec["nominal_points"]) > 10
    assert np.all(np.abs(sec["nominal_points"]).max(axis=0) <= [40 + 1e-9, 30 + 1e-9])
    assert [t["name"] for t in s.ins_fig_section["data"]] == ["measured", "nominal"]


@pytest.mark.slow
def test_bad_input_gets_one_line_reasons(app, tmp_path):
    server, session, page, _ = imported(app, tmp_path)
    s = server.state
    page.state.ins_nominal = page.state.ins_measured
    assert asyncio.run(page.run_async()) is None and "both measured and nominal" in s.ins_error
    page.refresh_inputs()
    s.ins_nominal = next(it["id"] for it in s.items if it["kind"] == "mesh")
    s.ins_tolerance = "abc"
    assert asyncio.run(page.run_async()) is None and "tolerance" in s.ins_error and "not a number" in s.ins_error
    s.ins_tolerance = "-1"
    assert asyncio.run(page.run_async()) is None and "tolerance" in s.ins_error
    s.ins_tolerance = ""
    page.set_align("pairs")
    assert asyncio.run(page.run_async()) is None and "3 point pairs, 0 picked" in s.ins_error
    page.set_align("icp")
    s.ins_params = dict(s.ins_params, max_iterations="0")
    assert asyncio.run(page.run_async()) is None and "max_iterations" in s.ins_error
    for msg in session.errors:
        assert "\n" not in msg
    assert asyncio.run(page.export_async()) is None and "run a comparison first" in s.ins_error
    assert asyncio.run(page.report_async()) is None and "run a comparison first" in s.ins_error
    # bands without a tolerance are refused
    s.ins_params = {k: v for k, v in s.ins_params.items() if k != "max_iterations"}
    assert asyncio.run(page.run_async()) is not None
    page.set_mode("bands")
    assert s.ins_mode == "colour" and "tolerance" in s.ins_error


def test_units_bands_and_picking_maths():
    # deviations read in µm whatever their size (the number rule: as the Series page and the reports)
    assert ip.display_unit(0.01) == ("µm", 1e3) and ip.display_unit(0.05) == ("µm", 1e3)
    assert ip.display_unit(0.1) == ("µm", 1e3) and ip.display_unit(2.0) == ("µm", 1e3)
    assert ip.fmt_len(0.024, "µm", True) == "+24.0 µm" and ip.fmt_len(-0.033, "µm", True) == "\u221233.0 µm"
    assert ip.interval_text({"p2_5": -0.033, "p97_5": 0.024}, "µm") == "+24.0 µm / \u221233.0 µm"
    assert ip.fmt_len(float("nan"), "mm") == "—"
    assert ip.nice_ticks(10.0) == [-10, -5, 0, 5, 10] and ip.nice_ticks(19.7) == [-15, -10, -5, 0, 5, 10, 15]
    assert ip.nice_ticks(0.25) == [-0.2, -0.1, 0, 0.1, 0.2] and ip.nice_ticks(45) == [-40, -20, 0, 20, 40]
    assert ip.nice_ticks(0.0) == [0.0]
    d = np.array([-0.2, -0.1, 0.0, 0.1, 0.2, np.nan])
    # the bands come from the plugin providing "tolerance-bands"
    host = default_host()
    cloud = PointCloud(np.zeros((len(d), 3)), fields={"deviation": d}, name="d")
    bands = host.run(host.provider("tolerance-bands").id, {"deviations": cloud}, {"tolerance": 0.1}).outputs
    assert np.asarray(bands["codes"]).tolist() == [-1, 0, 0, 0, 1, 2]
    assert bands["counts"] == {"below": 1, "within": 3, "above": 1, "invalid": 1} and bands["within"] == 0.6
    rows = ip.band_legend(bands["counts"], 0.1, "mm")
    assert [r["key"] for r in rows] == ["above", "within", "below", "invalid"]
    assert rows[1]["label"] == "within ±0.1000 mm"
    assert ip.band_legend(bands["counts"], 0.1, "µm")[1]["label"] == "within ±100 µm"
    # a point spacing on a regular grid is the grid's step
    g = np.stack(np.meshgrid(np.arange(200) * 0.5, np.arange(200) * 0.5, indexing="ij"), -1).reshape(-1, 2)
    grid = np.column_stack([g, np.zeros(len(g))])
    from camcmm_plugins.inspection.display import point_spacing

    assert point_spacing(grid) == pytest.approx(0.5)
    assert point_spacing(grid, queries=500) == pytest.approx(0.5)


def test_the_section_plugin_cuts_a_mesh_into_closed_polylines():
    """The cut the page draws comes from the plugin providing "deviation-section": a
    cylinder cut across its axis is one closed polygon on its surface."""
    import pyvista as pv

    host = default_host()
    cyl = pv.Cylinder(radius=5.0, height=20.0, direction=(0, 0, 1), resolution=64, capping=True).triangulate()
    faces = np.asarray(cyl.faces).reshape(-1, 4)[:, 1:]
    mesh = TriangleMesh(np.asarray(cyl.points, dtype=float), faces, name="cylinder")
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-5, 5, 2000), rng.uniform(-5, 5, 2000), rng.uniform(-10, 10, 2000)])
    cloud = PointCloud(pts, fields={"deviation": pts[:, 2] * 1e-3}, name="slab")
    out = host.run(
        host.provider("deviation-section").id,
        {"deviations": cloud, "nominal": mesh},
        {"axis": "z", "position": 3.0, "half_width": 0.5},
    ).outputs
    sec = out["section"]
    assert out["spacing"] is None and sec["u"] == "x" and sec["v"] == "y"
    assert len(sec["nominal"]) == 1
    ring = sec["nominal"][0]
    assert np.allclose(ring[0], ring[-1]) and len(ring) >= 65  # the quads' diagonals cross too
    r = np.hypot(ring[:, 0], ring[:, 1])
    assert r.max() <= 5.0 + 1e-6 and r.min() >= 5.0 * math.cos(math.pi / 64) - 1e-6  # float32 vertices
    in_slab = np.abs(pts[:, 2] - 3.0) <= 0.5
    assert sec["n_in_slab"] == int(in_slab.sum())
    assert np.allclose(np.sort(sec["deviation"]), np.sort(pts[in_slab, 2] * 1e-3))
    # without a half width the slab is half the cloud's median point spacing
    out = host.run(host.provider("deviation-section").id, {"deviations": cloud}, {"axis": "x"}).outputs
    assert out["spacing"] > 0 and out["section"]["half_width"] == pytest.approx(0.5 * out["spacing"])
    assert out["section"]["nominal"] == [] and abs(out["section"]["position"]) < 5
