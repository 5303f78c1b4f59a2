"""`camcmm calibrate camera|stereo`, `camcmm scale`, `camcmm gauge-block` and
`camcmm run calibration.*` as a user runs them, with their JSON contracts and one-line
errors. In-process (the CLI's main with capfd: the same exit codes, stdout and stderr, native
output and warnings included); a subprocess per command only added interpreter start and
imports (~1-2 s each); the command as a process is tested in tests/core/test_cli.py."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from camcmm.api import PointCloud, read_calibration, write
from helpers.cli import main_json, main_refused, main_text

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data" / "opencv_stereo_chessboard"
LEFT = [str(p) for p in sorted(DATA.glob("left*.jpg"))]
RIGHT = [str(p) for p in sorted(DATA.glob("right*.jpg"))]


@pytest.mark.slow
def test_calibrate_camera_json_and_file(tmp_path, capfd):
    out = main_json(
        capfd,
        "calibrate",
        "camera",
        *LEFT,
        "--board",
        "chessboard:9x6:25",
        "--detector",
        "classic",
        "--out",
        tmp_path / "left.yaml",
        "--json",
    )
    for key in ("camera_matrix", "dist_coeffs", "rms", "std_intrinsics", "per_view_rms", "image_size", "rejected"):
        assert key in out
    k = np.array(out["camera_matrix"])
    assert k.shape == (3, 3) and len(out["dist_coeffs"]) == 5 and len(out["std_intrinsics"]) == 9
    assert abs(out["rms"] - 0.196334638034) < 0.01  # OpenCV's own test reference (square size is irrelevant)
    assert out["image_size"] == [640, 480] and out["rejected"] == [] and len(out["per_view_rms"]) == 13
    cal = read_calibration(tmp_path / "left.yaml")
    np.testing.assert_allclose(cal["cameras"][0].camera_matrix, k)
    fs = cv2.FileStorage(str(tmp_path / "left.yaml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(), k)
    fs.release()
    # the heat map from the written file, through the plugin host
    pu = main_json(
        capfd,
        "run",
        "calibration.projection-uncertainty",
        tmp_path / "left.yaml",
        "--distance",
        "400",
        "--columns",
        "8",
        "--rows",
        "6",
        "--json",
    )
    assert np.array(pu["outputs"]["map"]).shape == (6, 8)


@pytest.mark.slow
def test_calibrate_stereo_json(tmp_path, capfd):
    out = main_json(
        capfd,
        "calibrate",
        "stereo",
        "--left",
        *LEFT,
        "--right",
        *RIGHT,
        "--board",
        "chessboard:9x6:25",
        "--detector",
        "classic",
        "--out",
        tmp_path / "stereo.json",
        "--json",
    )
    for key in ("left", "right", "R", "T", "E", "F", "rms"):
        assert key in out
    for side in ("left", "right"):
        for key in ("camera_matrix", "dist_coeffs", "rms", "std_intrinsics", "per_view_rms", "image_size", "rejected"):
            assert key in out[side]
    T = np.array(out["T"])
    assert 60 < np.linalg.norm(T) < 110 and abs(T[0]) > 0.99 * np.linalg.norm(T)  # ~3.3 squares of 25 mm
    assert out["rms"] < 0.3 and np.array(out["R"]).shape == (3, 3)
    cal = read_calibration(tmp_path / "stereo.json")
    np.testing.assert_allclose(cal["cameras"][1].translation, T)
    text = main_text(
        capfd,
        "calibrate",
        "stereo",
        "--left",
        *LEFT[:4],
        "--right",
        *RIGHT[:4],
        "--board",
        "chessboard:9x6:25",
        "--detector",
        "classic",
    )
    assert "baseline" in text and "epipolar distance" in text


@pytest.mark.slow
def test_scale_and_gauge_block(tmp_path, capfd):
    rng = np.random.default_rng(0)
    x = np.linspace(0, 90, 10)
    rows = ["run,interferometer,camera"] + [
        f"{r},{a},{1.0001 * a + rng.normal(0, 0.003)}" for r in (1, 2, 3) for a in x
    ]
    (tmp_path / "scale.csv").write_text("\n".join(rows))
    s = main_json(capfd, "scale", "--interferometer", tmp_path / "scale.csv", "--json")
    assert abs(s["slope"] - 1.0001) < 5 * s["u_slope"] and s["n_runs"] == 3
    assert set(s["residuals"]) == {"1", "2", "3"} and s["u_length"] >= s["u_p"]
    xy = rng.uniform(-20, 20, (3000, 2))
    top = (np.abs(xy[:, 0]) < 4.5) & (np.abs(xy[:, 1]) < 15)
    pts = np.column_stack([xy, np.where(top, 5.0006, 0.0)])
    write(PointCloud(pts), tmp_path / "block.ply")
    g = main_json(capfd, "gauge-block", tmp_path / "block.ply", "--nominal", "5.0006", "--json")
    assert abs(g["error"]) < 1e-9 and g["top"]["n_points"] == int(top.sum()) and "labels" not in g
    # the options are checked by the plugins' declarations, as JSON runs and the GUI are
    err = main_refused(capfd, "scale", "--interferometer", tmp_path / "scale.csv", "--accuracy", "2", code=2)
    assert err.startswith("camcmm: error: --accuracy: parameter 'accuracy' = 2.0 is above its maximum")
    err = main_refused(
        capfd, "gauge-block", tmp_path / "block.ply", "--nominal", "5", "--ransac-threshold", "0", code=2
    )
    assert "--ransac-threshold: parameter 'ransac_threshold' = 0.0 must be above 0 mm" in err
    err = main_refused(capfd, "gauge-block", tmp_path / "block.ply", "--nominal", "5", "--up", "0", "0", "0", code=2)
    assert "up [0.0, 0.0, 0.0] must be 3 finite numbers, not all zero" in err


@pytest.mark.slow
def test_bad_input(tmp_path, capfd):
    err = main_refused(capfd, "calibrate", "camera", *LEFT[:3], "--board", "chessboard:12x11:25", code=2)
    assert "not found in any of the 3 images (left01.jpg, left02.jpg, left03.jpg)" in err
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), cv2.resize(cv2.imread(LEFT[0], cv2.IMREAD_GRAYSCALE), (320, 240)))
    err = main_refused(capfd, "calibrate", "camera", *LEFT[:3], small, "--board", "chessboard:9x6:25", code=2)
    assert "mixed sizes: small.png (320x240)" in err
    err = main_refused(capfd, "calibrate", "camera", *LEFT[:3], "--board", "chessboard:9x6", code=2)
    assert "board 'chessboard:9x6'" in err
    err = main_refused(
        capfd, "calibrate", "stereo", "--left", *LEFT[:3], "--right", *RIGHT[:2], "--board", "chessboard:9x6:25", code=2
    )
    assert "3 left images but 2 right images" in err
    for opt, val, why in (
        ("--subpix-window", "0", "below its minimum 1 px"),
        ("--outlier-factor", "nan", "not finite"),
        ("--max-rms", "-1", "below its minimum 0"),
        ("--distance", "0", "must be above 0 mm"),
    ):
        err = main_refused(capfd, "calibrate", "camera", *LEFT[:3], "--board", "chessboard:9x6:25", opt, val, code=2)
        assert err.startswith(f"camcmm: error: {opt}: parameter '{opt[2:].replace('-', '_')}'") and why in err


@pytest.mark.slow
def test_run_through_the_host(tmp_path, capfd):
    out = main_json(
        capfd,
        "run",
        "calibration.camera",
        *LEFT[:5],
        "--board",
        "chessboard:9x6:25",
        "--save",
        tmp_path / "c.json",
        "--json",
    )
    o = out["outputs"]
    assert len(o["detections"]) == 5 and all(d["found"] for d in o["detections"])
    assert len(o["detections"][0]["corners"]) == 54
    assert o["calibration"]["cameras"][0]["camera_matrix"] == o["camera_matrix"]
    assert read_calibration(tmp_path / "c.json")["cameras"][0].image_size == (640, 480)
