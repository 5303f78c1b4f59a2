"""A calibration that rests on nothing says so: degenerate view sets, implausible
parameters, large uncertainties and a large RMS give warnings (the result's
``warnings``, the JSON ``warnings`` of ``camcmm calibrate``, the plugin run's warnings
that the Calibration page shows); good real data sets give none.

Real images: OpenCV's stereo sample (9 x 6 inner corners, tests/data) and Bouguet's
example (13 x 12, from ../shared, skipped when absent). Synthetic views are exact
projections of a board (OpenCV's model) plus 0.1 px noise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from camcmm.host import PluginHost
from camcmm_plugins.calibration import checks
from camcmm_plugins.calibration.boards import Detection, detect_all, parse_board
from camcmm_plugins.calibration.camera import calibrate_camera
from camcmm_plugins.calibration.stereo import calibrate_stereo
from camcmm_plugins.calibration.synthetic import look_at_poses, project
from helpers.cli import main_json, main_run

DATA = Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard"
LEFT = sorted(DATA.glob("left*.jpg"))
RIGHT = sorted(DATA.glob("right*.jpg"))
BOARD = "chessboard:9x6:25"
K = np.array([[800.0, 0, 330.0], [0, 800.0, 235.0], [0, 0, 1]])
D = np.array([-0.2, 0.08, 0.001, -0.0005, 0.0])
SIZE = (640, 480)


@pytest.fixture(scope="module")
def left_dets():
    return detect_all(BOARD, LEFT)


@pytest.fixture(scope="module")
def right_dets():
    return detect_all(BOARD, RIGHT)


# -- good data: no warning ----------------------------------------------------------------------


@pytest.mark.slow
def test_good_real_sets_have_no_warning(left_dets, right_dets):
    for dets in (left_dets, right_dets):
        res = calibrate_camera(dets, BOARD)
        assert len(res["per_view_rms"]) >= 12 and res["warnings"] == [], res["warnings"]
    res = calibrate_stereo(left_dets, right_dets, BOARD)
    assert len(res["pairs"]) == 13 and res["warnings"] == [], res["warnings"]


@pytest.mark.slow
def test_bouguet_example_has_no_warning(shared_data):
    folder = shared_data / "bouguet_calib_example"
    files = sorted(folder.glob("Image*.tif"), key=lambda p: int(p.stem[5:]))
    res = calibrate_camera(detect_all("chessboard:13x12:30", files), "chessboard:13x12:30")
    assert len(res["per_view_rms"]) >= 18 and res["warnings"] == [], res["warnings"]


def _synthetic(poses, seed=0, sigma=0.1, board="chessboard:11x8:20"):
    b = parse_board(board)
    rng = np.random.default_rng(seed)
    dets = []
    for i, (r, t) in enumerate(poses):
        q = project(b, K, D, r, t) + rng.normal(0, sigma, (len(b.object_points), 2))
        dets.append(
            Detection(f"v{i:02d}.png", SIZE, q.astype(np.float32), b.object_points, np.arange(len(q), dtype=np.int32))
        )
    return dets, b


def test_synthetic_tilted_views_have_no_warning():
    dets, b = _synthetic(look_at_poses(12, 420, "chessboard:11x8:20", tilt_deg=40, seed=3))
    res = calibrate_camera(dets, b)
    assert res["warnings"] == []
    assert abs(res["camera_matrix"][0, 0] - 800) < 5


# -- degenerate view sets -----------------------------------------------------------------------


def test_same_image_three_times(left_dets):
    """The issue's case: fx 906.6 / fy 828.0 px at RMS 0.16 px and no warning."""
    res = calibrate_camera([left_dets[0]] * 3, BOARD)
    w = res["warnings"]
    assert res["rms"] < 0.5  # the RMS alone says nothing is wrong
    assert any(s.startswith("views 1, 2, 3 (left01.jpg) show the board in the same pose") for s in w), w
    assert any("only 1 distinct board pose among 3 views" in s for s in w)
    assert any("large uncertainty" in s and "fx" in s for s in w)


def test_repeated_view_among_good_ones_is_named(left_dets):
    dets = left_dets[:8] + [left_dets[2]]
    res = calibrate_camera(dets, BOARD, outlier_factor=0)
    same = [s for s in res["warnings"] if "same pose" in s]
    assert len(same) == 1 and same[0].startswith("views 3, 9 (left03.jpg)")


def test_too_few_views(left_dets):
    res = calibrate_camera(left_dets[:4], BOARD)
    assert any("only 4 distinct board poses" in s and "at least 6" in s for s in res["warnings"])


def test_board_facing_the_camera():
    """Fronto-parallel views (tilt <= 5°): the focal length trades against the distance."""
    dets, b = _synthetic(look_at_poses(12, 420, "chessboard:11x8:20", tilt_deg=5, seed=4))
    w = calibrate_camera(dets, b)["warnings"]
    assert any("faces the camera in every view" in s for s in w), w


def test_parallel_board_planes():
    """Every view tilted by the same 35° about the same axis, moved around: the board
    planes are parallel (Zhang's degenerate configuration)."""
    import cv2

    b = parse_board("chessboard:11x8:20")
    rvec = np.array([np.radians(35.0), 0.0, 0.0])
    R = cv2.Rodrigues(rvec)[0]
    centre = b.object_points.mean(0)
    poses = [
        (rvec, np.array([dx, dy, dz]) - R @ centre)
        for dx, dy, dz in (
            (-40, -30, 400),
            (40, -30, 430),
            (-40, 30, 460),
            (40, 30, 390),
            (0, 0, 420),
            (20, -10, 480),
            (-20, 10, 440),
        )
    ]
    w = checks.view_warnings([f"v{i}" for i in range(len(poses))], [p[0] for p in poses], [p[1] for p in poses])
    assert len(w) == 1 and "board planes are nearly parallel" in w[0], w
    # calibrated, the poses come out however the nonsense intrinsics need them: those warn
    dets, _ = _synthetic(poses, seed=5)
    w = calibrate_camera(dets, b)["warnings"]
    assert any("large uncertainty" in s for s in w) and any("implausible" in s for s in w), w


# -- implausible parameters, large RMS ----------------------------------------------------------


@pytest.mark.slow
def test_wrong_board_size(left_dets):
    """A 5 x 4 spec on the 9 x 6 board is found inside it, at a different place in each
    image: OpenCV converges (exit 0) to nonsense."""
    dets = detect_all("chessboard:5x4:25", LEFT)
    res = calibrate_camera(dets, "chessboard:5x4:25")
    w = " | ".join(res["warnings"])
    assert res["rms"] > 1.0
    assert "RMS reprojection error" in w and "chessboard:5x4:25" in w
    assert "large uncertainty" in w
    assert "implausible" in w


def test_intrinsic_plausibility_checks():
    good = checks.intrinsic_warnings(K, D, SIZE)
    assert good == []
    K2 = K.copy()
    K2[0, 0] = 1.2 * K[1, 1]
    assert any("differ by 20 %" in s for s in checks.intrinsic_warnings(K2, D, SIZE))
    K3 = K.copy()
    K3[0, 2] = 900.0
    assert any("outside the image" in s for s in checks.intrinsic_warnings(K3, D, SIZE))
    K4 = np.diag([60.0, 60.0, 1.0])
    K4[:2, 2] = 320, 240
    assert any("field of view" in s for s in checks.intrinsic_warnings(K4, np.zeros(5), SIZE))
    # the k3 = -363573 (with OpenCV's sample camera): the distortion folds over
    k = np.array([[532.8, 0, 342.5], [0, 532.9, 233.9], [0, 0, 1]])
    assert any("folds over" in s for s in checks.intrinsic_warnings(k, [-0.28, 0.03, 0, 0, -363573.0], SIZE))
    assert checks.intrinsic_warnings(k, [-0.281, 0.029, 0.0012, -0.00014, 0.155], SIZE) == []  # its real one
    k5 = np.array([[3834.0, 0, 320], [0, 3834.0, 240], [0, 0, 1]])  # and the fx 3834 px
    assert any("folds over" in s for s in checks.intrinsic_warnings(k5, [0, 0, 0, 0, -363573.0], SIZE))
    # uncertainty: 2 % of fx
    cov = np.diag([16.0**2, 1.0, 1.0, 1.0] + [0.0] * 5)
    assert any("large uncertainty: fx 800 ± 16 px" in s for s in checks.intrinsic_warnings(K, D, SIZE, cov))
    assert checks.rms_warning(0.9) == [] and checks.rms_warning(1.5, "chessboard:9x6:25")


# -- stereo, and where the warnings go ----------------------------------------------------------


def test_stereo_same_pair_three_times(left_dets, right_dets):
    res = calibrate_stereo([left_dets[0]] * 3, [right_dets[0]] * 3, BOARD)
    w = res["warnings"]
    assert any(s.startswith("pairs 1, 2, 3 (left01.jpg / right01.jpg) show the board in the same pose") for s in w)
    assert any(s.startswith("stereo: the baseline") for s in w)


@pytest.mark.slow
def test_plugin_run_warnings_reach_the_gui(left_dets):
    """The Calibration page shows the run's warnings (its run stores run.warnings in the
    page document and show.Results puts them in the one alert)."""
    host = PluginHost()
    run = host.run("calibration.camera", {"images": [str(LEFT[0])] * 3}, {"board": BOARD})
    assert any("show the board in the same pose" in w for w in run.warnings)
    assert run.to_json()["warnings"] == run.warnings
    run = host.run("calibration.camera", {"images": [str(p) for p in LEFT]}, {"board": BOARD, "max_rms": 0.1})
    assert len(run.warnings) == 1 and "above 0.1 px" in run.warnings[0]


@pytest.mark.slow
def test_cli_json_and_text_carry_the_warnings(capfd):
    # the CLI in-process (main_json/main_run: its main with capfd), not the `camcmm` entry point
    # in a subprocess: only the output counts here (tests/core/test_cli.py runs the entry point)
    out = main_json(capfd, "calibrate", "camera", *[LEFT[0]] * 3, "--board", BOARD, "--json")
    assert any(s.startswith("views 1, 2, 3") for s in out["warnings"])
    rc, text, _ = main_run(capfd, "calibrate", "camera", *LEFT, "--board", BOARD)
    assert rc == 0 and "warning:" not in text
    rc, text, _ = main_run(capfd, "calibrate", "camera", *LEFT[:4], "--board", BOARD)
    assert rc == 0 and "warning: only 4 distinct board poses" in text
    out = main_json(capfd, "calibrate", "camera", *LEFT, "--board", BOARD, "--max-rms", "0.1", "--json")
    assert [w for w in out["warnings"] if "RMS reprojection error" in w and "above 0.1 px" in w]


@pytest.mark.slow
def test_calibration_page_shows_the_warnings(gui_app, tmp_path):
    """The page's alert (state cal_warnings): the same image under three names warns and
    names the views; OpenCV's 13 good views give an empty alert."""
    import asyncio
    import shutil

    pytest.importorskip("trame")
    pytest.importorskip("pyvista")

    for name in ("a.jpg", "b.jpg", "c.jpg"):
        shutil.copy(LEFT[0], tmp_path / name)
    server, _ = gui_app(tmp_path / "proj", data_roots=[DATA, tmp_path])
    page, s = server.pages["calibration"], server.state
    req = {
        "mode": "camera",
        "source": "folder",
        "folder": str(tmp_path),
        "left_pattern": "*.jpg",
        "right_pattern": "",
        "board": BOARD,
    }
    assert asyncio.run(page.run_async(req)) is not None, s.cal_error
    assert any(
        w.startswith("views 1, 2, 3 (a.jpg, b.jpg, c.jpg) show the board in the same pose") for w in s.cal_warnings
    ), s.cal_warnings
    assert asyncio.run(page.run_async({**req, "folder": str(DATA), "left_pattern": "left*"})) is not None, s.cal_error
    assert list(s.cal_warnings) == []
