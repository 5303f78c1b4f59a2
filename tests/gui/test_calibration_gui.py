"""The Calibration page's logic, without a browser, on OpenCV's stereo sample images.

The page shows the calibration plugins' own numbers (each compared with the plugin run
directly on the same files) and OpenCV's unit-test reference for the left camera within
OpenCV's tolerances; the corners are drawn where they were detected; the heat map is the
projection-uncertainty plugin's map; the rectified pair is the plugin's; the calibration
is stored (JSON, YAML, result row), offered for download, used by a measuring system and
shown again on reopen; bad input gets one-line reasons and the page keeps working.
"""

from __future__ import annotations

import asyncio
import csv
import io
import os
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trame")
pytest.importorskip("pyvista")
pytest.importorskip("trame_plotly")
cv2 = pytest.importorskip("cv2")

from camcmm.gui.pages.calibration import draw  # noqa: E402
from camcmm.gui.pages.calibration import figures as figs  # noqa: E402
from camcmm.io import read_calibration  # noqa: E402

DATA = Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard"
LEFT = sorted(DATA.glob("left*.jpg"))
RIGHT = sorted(DATA.glob("right*.jpg"))
BOARD = "chessboard:9x6:25"
# OpenCV's own unit-test reference for these left images (SOURCE.txt): K, |rms - ref| < 0.01, L1(K - K_ref) < 10
K_REF = np.array([[532.80992189, 0.0, 342.4952186], [0.0, 532.93346422, 233.8879292], [0.0, 0.0, 1.0]])
RMS_REF = 0.196334638034


@pytest.fixture
def app(gui_app, tmp_path):
    """``make(project_dir=None) -> (page, session)``: the GUI's Calibration page."""

    def make(project_dir=None):
        server, session = gui_app(project_dir, data_roots=[DATA, tmp_path])  # the folders the page may read
        return server.pages["calibration"], session

    return make


def run(page, req=None):
    """A calibration run as the server's loop runs it; the page document or None."""
    return asyncio.run(page.run_async(req))


def select(page, name):
    asyncio.run(page.select_image_async(name))


def folder_request(mode="camera", **kw):
    req = {
        "mode": mode,
        "source": "folder",
        "folder": str(DATA),
        "left_pattern": "left*",
        "right_pattern": "right*",
        "board": BOARD,
    }
    req.update(kw)
    return req


def shown(text: str) -> float:
    """A number as the page writes it (a real minus) read back."""
    return float(text.replace("\u2212", "-"))


def as_shown(text: str, value: float, unit: str = "") -> bool:
    """``text`` is ``value`` rounded to the digits it shows (in ``unit``: µm text against mm)."""
    scale = 1e-3 if unit == "µm" else 1.0
    decimals = len(text.split(".")[1]) if "." in text else 0
    return abs(shown(text) * scale - value) <= (0.5 * 10.0**-decimals + 1e-12) * scale


def decode(url: str) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(draw.url_bytes(url), np.uint8), cv2.IMREAD_COLOR)


def saturated(img: np.ndarray) -> np.ndarray:
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    return (hsv[..., 1] > 90) & (hsv[..., 2] > 60)


@pytest.mark.slow
def test_camera_shows_the_plugins_numbers_corners_and_heat_map(app):
    page, session = app()
    s = page.state
    doc = run(page, folder_request())
    assert doc is not None, s.cal_error
    direct = session.host.run(
        "calibration.camera", inputs={"images": [str(p) for p in LEFT]}, params={"board": BOARD}
    ).outputs
    out = doc["outputs"]
    # named in words when the operator gives no name (the board, not its code)
    assert doc["current"]["name"].startswith("camera, chessboard, 9 × 6 inner corners, 25 mm squares (")
    # equal up to OpenCV's run-to-run rounding (its solver is multi-threaded: ~1e-9 relative seen)
    assert np.allclose(out["camera_matrix"], direct["camera_matrix"], rtol=1e-7, atol=0)
    # k2, k3 are ill-conditioned: the same ~1e-9 noise moves them by up to ~3e-7 relative, so
    # they are compared against their own standard deviation (std_intrinsics: fx fy cx cy, then them)
    dist_std = np.asarray(direct["std_intrinsics"])[4 : 4 + len(direct["dist_coeffs"])]
    assert np.all(np.abs(np.subtract(out["dist_coeffs"], direct["dist_coeffs"])) <= 1e-4 * dist_std)
    assert out["rms"] == pytest.approx(direct["rms"], rel=1e-7)
    assert out["per_view_rms"] == pytest.approx(direct["per_view_rms"], rel=1e-7)
    # OpenCV's unit-test reference within OpenCV's own tolerances
    assert abs(out["rms"] - RMS_REF) < 0.01
    assert np.abs(np.asarray(out["camera_matrix"]) - K_REF).sum() < 10.0
    # the image list: 13 images, all used, each with its view RMS
    assert [r["name"] for r in s.cal_rows] == [p.name for p in LEFT]
    assert all(r["status"] == "used" and r["thumb"].startswith("data:image/jpeg") for r in s.cal_rows)
    assert [r["rms"] for r in s.cal_rows] == pytest.approx([direct["per_view_rms"][p.name] for p in LEFT], rel=1e-7)
    # the chart: one bar per view at its RMS, the overall RMS as a line
    bars = s.cal_fig_views["data"]
    assert len(bars) == 1 and bars[0]["y"] == [r["rms"] for r in s.cal_rows]
    assert s.cal_fig_views["layout"]["shapes"][0]["y0"] == pytest.approx(direct["rms"])
    # the numbers with OpenCV's standard deviations
    nums = {n["name"]: n for n in s.cal_numbers}
    # (each to the digits its σ resolves: two significant digits of σ, GUM 7.2.6)
    assert as_shown(nums["fx"]["value"], direct["camera_matrix"][0][0])
    assert as_shown(nums["k1"]["std"], direct["std_named"]["k1"]) and len(nums["k1"]["std"].strip("0.")) == 2
    assert as_shown(nums["k1"]["value"], direct["dist_coeffs"][0])
    k1_decimals = len(nums["k1"]["value"].split(".")[1])
    assert k1_decimals == 1 - np.floor(np.log10(direct["std_named"]["k1"]))
    assert as_shown(nums["RMS"]["value"], direct["rms"])
    # the heat map is the projection-uncertainty plugin's map at the boards' median depth
    z = float(np.median(np.asarray(direct["calibration"]["views"]["tvecs"])[:, 2]))
    assert direct["board_distance"] == pytest.approx(z, rel=1e-12)  # the plugin says where to look first
    assert s.cal_distance == pytest.approx(z, rel=1e-2)
    pu = session.host.run(
        "calibration.projection-uncertainty",
        inputs={"calibration": direct["calibration"]},
        params={"distance": s.cal_distance, "columns": 48, "rows": 36},
    ).outputs
    heat = s.cal_fig_map["data"][0]
    assert np.allclose(heat["customdata"], pu["map"], rtol=1e-6)
    assert heat["x"] == pytest.approx(list(pu["u"])) and len(heat["y"]) == 36
    assert len(s.cal_fig_map["data"][1]["x"]) == 13 * 54  # the corners used, as dots
    asyncio.run(page.set_distance_async(800))
    assert "z = 800 mm" in s.cal_fig_map["layout"]["title"]["text"]
    far = session.host.run(
        "calibration.projection-uncertainty",
        inputs={"calibration": direct["calibration"]},
        params={"distance": 800, "columns": 48, "rows": 36},
    ).outputs
    assert np.allclose(s.cal_fig_map["data"][0]["customdata"], far["map"], rtol=1e-6)
    # the corners drawn where they were detected: saturated colour at each corner, none in the grey image
    select(page, "left12.jpg")
    assert s.cal_selected == "left12.jpg" and "54 points" in s.cal_overlay_note
    pic = decode(s.cal_overlay)
    assert pic.shape[:2] == (480, 640)
    corners = np.asarray(next(d for d in direct["detections"] if d["image"] == "left12.jpg")["corners"])
    sat = saturated(pic)
    near = [sat[int(round(y)) - 2 : int(round(y)) + 3, int(round(x)) - 2 : int(round(x)) + 3].any() for x, y in corners]
    assert all(near)
    assert not saturated(cv2.imread(str(DATA / "left12.jpg"))).any()


@pytest.mark.slow
def test_stored_downloaded_used_by_a_system_and_restored(app):
    page, session = app()
    s = page.state
    run(page, folder_request(name="left camera, May"))
    # what is stored (files, result row, the systems' meta) is checked headless in
    # tests/tasks/test_calibration_task.py; here what the page shows and offers
    cur = page.doc["current"]
    K = np.asarray(page.doc["outputs"]["camera_matrix"])
    # downloads: YAML, JSON, the per-view CSV, the charts as PNG
    rid = cur["result"]
    names = {x["name"] for x in s.cal_links}
    assert names == {f"calibration-{rid}{x}" for x in (".yaml", ".json", "-views.csv", "-errors.png", "-heatmap.png")}
    folder = page.offered.folder
    assert np.allclose(read_calibration(folder / f"calibration-{rid}.yaml")["cameras"][0].camera_matrix, K)
    rows = list(csv.reader(io.StringIO((folder / f"calibration-{rid}-views.csv").read_text())))
    assert rows[0][:4] == ["camera", "image", "status", "rms_px"] and len(rows) == 14
    assert float(rows[1][3]) == pytest.approx(page.doc["outputs"]["per_view_rms"]["left01.jpg"], rel=1e-5)
    for png in ("errors", "heatmap"):
        assert (folder / f"calibration-{rid}-{png}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # "use this calibration": a new system, and an existing one keeping the rest of its meta
    sid_new = page.use_calibration("new", "rig A")
    sid_old = session.project.add_system("rig B", {"measuring_volume": [500, 400, 300]})
    page.refresh_systems()
    assert page.use_calibration(sid_old) == sid_old
    for sid in (sid_new, sid_old):
        assert session.project.system(sid)["meta"]["calibration"]["file"] == cur["calibration"]
    assert [(x["name"], x["calibration"], x["current"]) for x in s.cal_systems] == [
        ("rig A", "left camera, May", True),
        ("rig B", "left camera, May", True),
    ]
    # reopened: the same calibration, list, numbers, chart and heat map; the systems
    select(page, "left03.jpg")
    page2, _ = app(session.project.path)
    s2 = page2.state
    assert s2.cal_summary["result"] == rid and s2.cal_numbers == s.cal_numbers
    assert [(r["name"], r["status"], r["rms"], r["thumb"]) for r in s2.cal_rows] == [
        (r["name"], r["status"], r["rms"], r["thumb"]) for r in s.cal_rows
    ]
    assert s2.cal_fig_views == s.cal_fig_views
    assert s2.cal_fig_map["data"][0]["customdata"] == s.cal_fig_map["data"][0]["customdata"]
    assert s2.cal_overlay.startswith("data:image/jpeg") and s2.cal_selected == "left01.jpg"
    assert s2.cal_folder == str(DATA) and s2.cal_left_pattern == "left*" and s2.cal_name == "left camera, May"
    assert [x["current"] for x in s2.cal_systems] == [True, True]


@pytest.mark.slow
def test_stereo_pair_pose_epipolar_and_rectified_pair(app):
    from camcmm_plugins.calibration.plugin import load_calibration
    from camcmm_plugins.calibration.stereo import rectify_images

    page, session = app()
    s = page.state
    doc = run(page, folder_request("stereo"))
    assert doc is not None, s.cal_error
    direct = session.host.run(
        "calibration.stereo",
        inputs={"left": [str(p) for p in LEFT], "right": [str(p) for p in RIGHT]},
        params={"board": BOARD},
    ).outputs
    out = doc["outputs"]
    assert out["pairs"] == direct["pairs"]
    for key in ("R", "T", "rms", "baseline", "baseline_std", "std_T"):
        assert np.allclose(out[key], direct[key], rtol=1e-7, atol=1e-12), key
    assert out["epipolar"] == pytest.approx(direct["epipolar"], rel=1e-7)
    assert 75 < out["baseline"] < 95  # the sample rig: about 83 mm for 25-mm squares
    rows = {r["name"]: r for r in s.cal_stereo_rows}
    assert as_shown(rows["baseline |T|"]["value"], direct["baseline"])
    # σ of a length below 1 mm in µm (the number rule), two significant digits
    assert rows["Tx"]["std_unit"] == "µm" and as_shown(rows["Tx"]["std"], direct["std_T"][0], "µm")
    assert as_shown(rows["Tx"]["value"], direct["T"][0])
    assert as_shown(rows["epipolar distance rms"]["value"], direct["epipolar"]["rms"])
    # the pose as the plugin's Rodrigues vector, in degrees
    assert direct["rotation_angle"] == pytest.approx(np.linalg.norm(cv2.Rodrigues(np.asarray(direct["R"]))[0]))
    assert as_shown(rows["rotation angle"]["value"], np.degrees(direct["rotation_angle"]))
    assert as_shown(rows["rotation ry (Rodrigues)"]["value"], np.degrees(direct["rvec"][1]))
    assert s.cal_summary["views"] == "13 of 13 pairs"
    # each camera's own calibration in 'single' is the camera plugin's on that camera's images
    cam_r = session.host.run(
        "calibration.camera", inputs={"images": [str(p) for p in RIGHT]}, params={"board": BOARD}
    ).outputs
    assert np.allclose(out["single"]["right"]["cameras"][0]["camera_matrix"], cam_r["camera_matrix"], rtol=1e-7)
    # the right camera's list, numbers (refined jointly) and heat map
    page.show_side("right")
    assert [r["name"] for r in s.cal_rows] == [p.name for p in RIGHT]
    assert as_shown({n["name"]: n for n in s.cal_numbers}["fx"]["value"], direct["right"]["camera_matrix"][0][0])
    pu = session.host.run(
        "calibration.projection-uncertainty",
        inputs={"calibration": cam_r["calibration"]},
        params={"distance": s.cal_distance, "columns": 48, "rows": 36},
    ).outputs
    assert np.allclose(s.cal_fig_map["data"][0]["customdata"], pu["map"], rtol=1e-6)
    assert "right01.jpg" in s.cal_overlay_note
    # the rectified pair: the plugin's images equal rectify_images called directly
    cal = direct["calibration"]
    rect = session.host.run(
        "calibration.rectify", inputs={"calibration": cal, "left": str(LEFT[2]), "right": str(RIGHT[2])}
    ).outputs
    l_img, r_img = cv2.imread(str(LEFT[2]), cv2.IMREAD_UNCHANGED), cv2.imread(str(RIGHT[2]), cv2.IMREAD_UNCHANGED)
    ref_l, ref_r = rectify_images(load_calibration(cal), l_img, r_img)
    assert np.array_equal(rect["left"].data, ref_l) and np.array_equal(rect["right"].data, ref_r)
    asyncio.run(page.show_pair_async(2))
    assert s.cal_pair == 2 and "left03.jpg / right03.jpg" in s.cal_rectified_note
    pic = decode(s.cal_rectified)
    assert pic.shape[1] <= 1400 and pic.shape[0] == pytest.approx(480 * pic.shape[1] / (1280 + 6), abs=2)
    assert saturated(pic).any(axis=1).sum() >= 16  # the epipolar lines
    assert {x["name"].split("-", 2)[-1] for x in s.cal_links} >= {
        "errors-left.png",
        "errors-right.png",
        "heatmap-left.png",
        "heatmap-right.png",
    }
    with pytest.raises(Exception, match="two cameras"):
        session.host.run(
            "calibration.rectify",
            inputs={"calibration": cam_r["calibration"], "left": str(LEFT[0]), "right": str(RIGHT[0])},
        )


@pytest.mark.slow
def test_images_from_an_upload_and_from_the_project_items(app):
    page, session = app()
    s = page.state
    upload = [{"name": p.name, "content": p.read_bytes()} for p in LEFT[:4]]
    keys = page.add_uploads(upload, "left")
    assert len(keys) == 4 and s.cal_left_items == keys and s.cal_source == "items"
    assert [it["name"] for it in s.items if it["kind"] == "image"] == [p.name for p in LEFT[:4]]
    doc = run(page, {"mode": "camera", "source": "items", "left": keys, "board": BOARD})
    assert doc is not None, s.cal_error
    assert [r["name"] for r in s.cal_rows] == [p.name for p in LEFT[:4]]
    direct = session.host.run(
        "calibration.camera", inputs={"images": [str(p) for p in LEFT[:4]]}, params={"board": BOARD}
    ).outputs
    assert np.allclose(doc["outputs"]["camera_matrix"], direct["camera_matrix"], rtol=1e-7)
    row = session.project.result(doc["current"]["result"])
    assert sorted(row["measurement_ids"]) == sorted(int(k) for k in keys)
    # pairs by name among the items
    page.add_uploads([{"name": p.name, "content": p.read_bytes()} for p in RIGHT[:4]], "right")
    s.cal_mode = "stereo"
    page.pick_by_name()
    names = {it["id"]: it["name"] for it in s.items}
    assert [names[k] for k in s.cal_left_items] == [p.name for p in LEFT[:4]]
    assert [names[k] for k in s.cal_right_items] == [p.name for p in RIGHT[:4]]
    assert run(page) is not None, s.cal_error
    assert s.cal_summary["views"] == "4 of 4 pairs"


@pytest.mark.slow
def test_bad_input_gives_one_line_and_the_page_keeps_working(app, tmp_path):
    page, _ = app()
    s = page.state

    def fails(req, *words):
        assert run(page, req) is None
        line = s.cal_error
        assert "\n" not in line and s.cal_running is False, line
        for w in words:
            assert w in line, line
        return line

    fails({"mode": "camera", "source": "items", "left": [], "board": BOARD}, "choose the board images")
    fails(folder_request(folder=str(tmp_path / "nowhere")), "nowhere", "no such folder")
    fails(folder_request(left_pattern="*.tif"), "no image files", "*.tif")
    fails(folder_request(board="chessboard:10x7:25"), "chessboard:10x7:25", "not found in any of the 13 images")
    fails(folder_request(board="chessboard:9x6"), "'chessboard:9x6'")
    fails(folder_request(board=""), "board")
    fails(folder_request(outlier_factor="many"), "outlier factor")
    odd = tmp_path / "odd"
    odd.mkdir()
    for p in LEFT[:3]:
        shutil.copy(p, odd / p.name)
    cv2.imwrite(str(odd / "small.png"), cv2.resize(cv2.imread(str(LEFT[3])), (320, 240)))
    fails(folder_request(folder=str(odd), left_pattern="*"), "mixed sizes", "small.png (320x240)")
    fails(
        folder_request("stereo", left_pattern="left0[1-3]*", right_pattern="right0[1-2]*"),
        "3 left images but 2 right images",
    )
    assert s.cal_summary is None  # nothing shown yet, nothing broken
    # cancelled: the run stops, the page says so
    begin = page.job.begin

    def cancelled_begin():
        ev = begin()
        ev.set()
        return ev

    page.job.begin = cancelled_begin
    assert run(page, folder_request()) is None and s.cal_message == "cancelled"
    del page.job.begin
    # a blank image (no board) is listed with the reason; outliers are left out with their RMS
    (odd / "small.png").unlink()
    cv2.imwrite(str(odd / "blank.png"), np.full((480, 640), 200, np.uint8))
    for p in LEFT[3:8]:
        shutil.copy(p, odd / p.name)
    doc = run(page, folder_request(folder=str(odd), left_pattern="*", outlier_factor=1.1))
    assert doc is not None, s.cal_error
    status = {r["name"]: r for r in s.cal_rows}
    assert status["blank.png"]["status"] == "not found" and "not found" in status["blank.png"]["reason"]
    out = [r for r in s.cal_rows if r["status"] == "left out"]
    assert out and all(r["reason"].startswith("outlier") and r["rms"] > 0 for r in out)
    for r in out:  # the RMS shown is the one the reason quotes
        assert f"view RMS {r['rms']:.3g} px" in r["reason"]
    traces = {t["name"]: t for t in s.cal_fig_views["data"]}
    assert set(traces["left out"]["x"]) == {r["name"] for r in out}
    assert traces["no board / not used"]["x"] == ["blank.png"]
    select(page, "blank.png")
    assert "not found" in s.cal_overlay_note and s.cal_overlay.startswith("data:image/jpeg")
    assert any("blank.png left out" in w for w in s.cal_warnings)
    # an image gone from its folder: the list and numbers stay, the picture says why
    os.remove(odd / "left05.jpg")
    select(page, "left05.jpg")
    assert s.cal_overlay == "" and "no longer at" in s.cal_overlay_note
    asyncio.run(page.set_distance_async("far"))
    assert "working distance" in s.cal_error


@pytest.mark.slow
def test_figures_and_pngs():
    rows = [
        {"name": "a", "status": "used", "reason": "", "rms": 0.2, "n": 54},
        {"name": "b", "status": "left out", "reason": "outlier", "rms": 0.9, "n": 54},
        {"name": "c", "status": "not found", "reason": "chessboard 9x6 not found", "rms": None, "n": 0},
    ]
    fig = figs.views_figure(rows, 0.21, "t")
    assert [t["name"] for t in fig["data"]] == ["used", "left out", "no board / not used"]
    assert fig["layout"]["xaxis"]["categoryarray"] == ["a", "b", "c"]
    assert figs.views_png(rows, 0.21, "t")[:4] == b"\x89PNG"
    u, v = np.linspace(0, 639, 8), np.linspace(0, 479, 6)
    uu, vv = np.meshgrid(u, v)
    sigma = 0.05 * np.exp(((uu - 320) ** 2 + (vv - 240) ** 2) / 40000.0)  # spans > 20x: log colour
    pu = {"map": sigma.tolist(), "u": u.tolist(), "v": v.tolist(), "min": sigma.min(), "max": sigma.max()}
    heat = figs.heatmap_figure(pu, np.array([[100.0, 100.0]]), [640, 480], "t")
    assert np.allclose(heat["data"][0]["z"], np.log10(sigma)) and heat["data"][0]["customdata"] == sigma.tolist()
    ticks = heat["data"][0]["colorbar"]["ticktext"]
    assert ticks[0] == "0.05" or float(ticks[0]) >= sigma.min()
    assert heat["layout"]["yaxis"]["range"] == [480, 0]
    png = figs.heatmap_png(pu, None, [640, 480], "t")
    assert png[:4] == b"\x89PNG" and len(png) > 5000
    flat = figs.heatmap_figure(
        {"map": [[1.0, 1.2], [1.1, 1.3]], "u": [0, 9], "v": [0, 9], "min": 1.0, "max": 1.3}, None, [10, 10], "t"
    )
    assert flat["data"][0]["z"] == [[1.0, 1.2], [1.1, 1.3]] and "tickvals" not in flat["data"][0]["colorbar"]


@pytest.mark.slow
def test_worker_run_with_progress(app):
    """The async run: the worker calibrates while the loop stays free; progress reaches the page."""
    page, _ = app()
    seen = []
    orig = page.job.progress
    page.job.progress = lambda f, m="": (seen.append((threading.current_thread().name, f)), orig(f, m))
    doc = run(page, folder_request(left_pattern="left0[1-5]*"))
    assert doc is not None, page.state.cal_error
    assert page.state.cal_running is False and page.state.cal_progress == 100.0
    assert seen and all(name.startswith("camcmm-calibration") for name, _ in seen)
    assert max(f for _, f in seen) >= 0.9


def test_numbers_follow_their_standard_deviation():
    """The page's value ± σ (the number rule, camcmm.numbers): σ with two significant
    digits, the value to σ's last decimal, a real minus, no exponent; the issue's
    "p2 −0.000112674 ± 0.000139" becomes "−0.00011 ± 0.00014"."""
    from camcmm.gui.pages.calibration.results import stereo_rows, with_std

    assert with_std(-0.000112674, 0.000139) == ("\u22120.00011", "0.00014")
    assert with_std(532.80992, 0.52) == ("532.81", "0.52")
    assert with_std(532.80992, 2.3) == ("532.8", "2.3")
    assert with_std(3e-9, 0.01) == ("0", "0.010")
    assert with_std(1.5e-7, None) == ("0.00000015", "")
    rows = {r["name"]: r for r in stereo_rows({"T": [-83.1234, 0.5, 1.2], "std_T": [0.047, 0.2, 1.5],
                                                "baseline": 83.18, "baseline_std": 0.35})}  # fmt: skip
    assert (rows["Tx"]["value"], rows["Tx"]["std"], rows["Tx"]["std_unit"]) == ("\u221283.123", "47", "µm")
    assert (rows["Tz"]["value"], rows["Tz"]["std"], rows["Tz"]["std_unit"]) == ("1.2", "1.5", "mm")
    assert (rows["baseline |T|"]["value"], rows["baseline |T|"]["std"]) == ("83.18", "350")
    assert all("e" not in r["value"] and "e" not in r["std"] for r in rows.values())
