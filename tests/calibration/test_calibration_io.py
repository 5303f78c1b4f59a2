"""Calibration files: round trips (YAML and JSON), files OpenCV writes and reads, bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import CameraModel, InputError, read_calibration, write_calibration


def _rot(rx, ry, rz):
    return cv2.Rodrigues(np.array([rx, ry, rz], float))[0]


def _stereo():
    k1 = np.array([[1200.5, 0, 640.25], [0, 1201.75, 479.5], [0, 0, 1]])
    k2 = np.array([[1190.0, 0.5, 650.0], [0, 1189.0, 470.0], [0, 0, 1]])
    r, t = _rot(0.01, -0.2, 0.003), np.array([-150.0, 1.5, 12.25])
    tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
    e = tx @ r
    f = np.linalg.inv(k2).T @ e @ np.linalg.inv(k1)
    cams = [
        CameraModel(k1, [-0.1, 0.05, 1e-4, -2e-4, 0.01], image_size=(1280, 960), name="left"),
        CameraModel(k2, [-0.12, 0.06, 0, 0, 0, 0, 0, 0, 1e-3, 0, 0, 0], r, t, (1280, 960), 0.0048, "right"),
    ]
    return {
        "cameras": cams,
        "rms": 0.123,
        "R": r,
        "T": t,
        "E": e,
        "F": f,
        "std_intrinsics": [np.arange(1, 15) * 0.01, np.arange(1, 19) * 0.02],
        "covariance": [np.diag(np.arange(1, 15) * 1e-4), None],
        "rectification": {"R1": np.eye(3), "P1": np.arange(12.0).reshape(3, 4)},
        "board": "chessboard:9x6:25",
        "per_view_rms": [0.1, 0.2],
        "rejected": [{"image": "a.png", "reason": "x"}],
        # longer than FileStorage's string limit, and a big matrix
        "note": "x" * 5000,
        "parameter_covariance": np.arange(3600.0).reshape(60, 60) / 7,
        "views": {"names": ["a", "b"], "rvecs": [[0.1, 0.2, 0.3], [0.0, 0.0, 1.0]]},
    }


def _same(a, b):
    assert len(a["cameras"]) == len(b["cameras"])
    for ca, cb in zip(a["cameras"], b["cameras"]):
        assert ca.name == cb.name and ca.image_size == cb.image_size and ca.pixel_pitch == cb.pixel_pitch
        for attr in ("camera_matrix", "dist_coeffs", "rotation", "translation"):
            np.testing.assert_array_equal(getattr(ca, attr), getattr(cb, attr))
    for key in ("R", "T", "E", "F"):
        if key in a:
            np.testing.assert_array_equal(np.ravel(a[key]), np.ravel(b[key]))
    assert b["rms"] == a["rms"] and b["board"] == a["board"]
    for sa, sb in zip(a["std_intrinsics"], b["std_intrinsics"]):
        np.testing.assert_array_equal(sa, np.ravel(sb))
    assert b["covariance"][1] is None
    np.testing.assert_array_equal(a["covariance"][0], b["covariance"][0])
    for k, v in a["rectification"].items():
        np.testing.assert_array_equal(v, b["rectification"][k])
    assert b["per_view_rms"] == a["per_view_rms"] and b["rejected"] == a["rejected"]
    assert b["note"] == a["note"] and b["views"] == a["views"]
    np.testing.assert_array_equal(b["parameter_covariance"], a["parameter_covariance"])


@pytest.mark.parametrize("ext", [".yaml", ".yml", ".xml", ".json"])
def test_stereo_round_trip(tmp_path, ext):
    cal = _stereo()
    write_calibration(tmp_path / f"cal{ext}", cal)
    _same(cal, read_calibration(tmp_path / f"cal{ext}"))


@pytest.mark.parametrize("ext", [".yaml", ".json"])
def test_camera_projector_round_trip(tmp_path, ext):
    cal = _stereo()
    cal["cameras"][1].name = "projector"
    cal["cameras"][1].image_size = (1920, 1080)
    write_calibration(tmp_path / f"cp{ext}", cal)
    back = read_calibration(tmp_path / f"cp{ext}")
    assert [c.name for c in back["cameras"]] == ["left", "projector"]
    assert back["cameras"][1].image_size == (1920, 1080)
    _same(cal, back)


def test_three_cameras_and_a_camera_off_the_origin(tmp_path):
    cal = _stereo()
    cal["cameras"].append(
        CameraModel(
            np.diag([900.0, 900.0, 1.0]), np.zeros(5), _rot(0, 0.3, 0), [300.0, 0, 0], (640, 480), None, "third"
        )
    )
    cal["cameras"][0].rotation = _rot(0.1, 0, 0)
    cal["cameras"][0].translation = np.array([1.0, 2.0, 3.0])
    for ext in (".yaml", ".json"):
        write_calibration(tmp_path / f"c{ext}", cal)
        back = read_calibration(tmp_path / f"c{ext}")
        np.testing.assert_array_equal(back["cameras"][2].rotation, cal["cameras"][2].rotation)
        np.testing.assert_array_equal(back["cameras"][0].translation, [1.0, 2.0, 3.0])


def test_yaml_is_what_opencv_stereo_sample_reads(tmp_path):
    """An OpenCV program reads M1 D1 M2 D2 R T E F with cv::FileStorage."""
    cal = _stereo()
    write_calibration(tmp_path / "s.yml", cal)
    fs = cv2.FileStorage(str(tmp_path / "s.yml"), cv2.FILE_STORAGE_READ)
    np.testing.assert_array_equal(fs.getNode("M1").mat(), cal["cameras"][0].camera_matrix)
    np.testing.assert_array_equal(fs.getNode("D2").mat().ravel(), cal["cameras"][1].dist_coeffs)
    np.testing.assert_array_equal(fs.getNode("R").mat(), cal["R"])
    np.testing.assert_array_equal(fs.getNode("T").mat().ravel(), cal["T"])
    np.testing.assert_array_equal(fs.getNode("F").mat(), cal["F"])
    assert fs.getNode("rms").real() == pytest.approx(0.123)
    fs.release()
    assert (tmp_path / "s.yml").read_text().startswith("%YAML")  # OpenCV 5 writes 1.2, 4.x 1.0


def test_reads_opencv_calibration_sample_file(tmp_path):
    """Keys of OpenCV's samples/cpp/calibration.cpp output (distortion_coefficients, image_width)."""
    k = np.array([[500.0, 0, 320], [0, 501, 240], [0, 0, 1]])
    d = np.array([[0.1], [-0.2], [0.001], [0.002], [0.05]])
    fs = cv2.FileStorage(str(tmp_path / "out_camera_data.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", k)
    fs.write("distortion_coefficients", d)
    fs.write("avg_reprojection_error", 0.3)
    fs.release()
    cal = read_calibration(tmp_path / "out_camera_data.yml")
    cam = cal["cameras"][0]
    np.testing.assert_array_equal(cam.camera_matrix, k)
    np.testing.assert_array_equal(cam.dist_coeffs, d.ravel())
    assert cam.image_size == (640, 480)
    np.testing.assert_array_equal(cam.rotation, np.eye(3))


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="nope.yaml"):
        read_calibration(tmp_path / "nope.yaml")
    (tmp_path / "x.txt").write_text("1")
    with pytest.raises(InputError, match="x.txt.*unknown calibration format"):
        read_calibration(tmp_path / "x.txt")
    (tmp_path / "bad.json").write_text('{"cameras": []}')
    with pytest.raises(InputError, match="bad.json"):
        read_calibration(tmp_path / "bad.json")
    (tmp_path / "garbage.yaml").write_text("this: [is not\n  opencv")
    with pytest.raises(InputError, match="garbage.yaml"):
        read_calibration(tmp_path / "garbage.yaml")
    fs = cv2.FileStorage(str(tmp_path / "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("M1", np.eye(3))
    fs.write("M2", np.eye(3))
    fs.release()
    with pytest.raises(InputError, match="intrinsics.yml.*extrinsics"):
        read_calibration(tmp_path / "intrinsics.yml")
    with pytest.raises(InputError, match="out.yaml.*cameras"):
        write_calibration(tmp_path / "out.yaml", {"cameras": []})
    with pytest.raises(InputError, match="out.yaml.*folder"):
        write_calibration(tmp_path / "no" / "out.yaml", _stereo())


def test_json_extras_survive_any_cut_of_their_text(tmp_path):
    """The JSON of the extras goes into the YAML in 512-character pieces. OpenCV's YAML takes
    a string that starts and ends with a quote as already quoted: a piece cut from the JSON
    just before a key's quote and just after a value's closing one came back changed, or
    unreadable ("Incorrect indentation": a stored calibration was once lost so). With
    note = 499 and long = 502 characters the second piece is exactly '"long": "zz…z"'; the
    lengths around it move the cuts over the neighbouring characters."""
    cam = CameraModel(np.array([[1000.0, 0, 320], [0, 1000, 240], [0, 0, 1]]), [0.0] * 5, image_size=(640, 480))
    for n_note in range(497, 502):
        for n_long in range(500, 505):
            cal = {"cameras": [cam], "note": "z" * n_note, "long": "y" * n_long, "names": ["'q' ", ' "r"', "s  "]}
            p = tmp_path / f"c{n_note}_{n_long}.yaml"
            write_calibration(p, cal)
            back = read_calibration(p)
            assert [back[k] for k in ("note", "long", "names")] == [cal[k] for k in ("note", "long", "names")]
