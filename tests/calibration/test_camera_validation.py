"""Camera models are checked when they are read or built: values no camera has (and that
crash OpenCV's native code further on, e.g. a negative focal length in
cv2.initUndistortRectifyMap) give one line naming the file, the camera and the value."""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from camcmm.api import CameraModel, InputError, read_calibration, write_calibration
from helpers.camera_pairs import K1, K2, R2, T2, _pair, _with, _write_json, _write_yaml

REFLECTION = np.diag([1.0, 1.0, -1.0]) @ R2
BAD = [  # (id, change, the words the one-line error must hold)
    ("negative-fx", {"k1": _with(K1, 0, 0, -800)}, "camera 1 (left): focal length fx = -800 px must be positive"),
    ("zero-fy", {"k2": _with(K2, 1, 1, 0)}, "camera 2 (right): focal length fy = 0 px must be positive"),
    ("nan-fx", {"k1": _with(K1, 0, 0, np.nan)}, "focal length fx = nan px"),
    ("inf-fy", {"k1": _with(K1, 1, 1, np.inf)}, "focal length fy = inf px"),
    ("nan-cx", {"k2": _with(K2, 0, 2, np.nan)}, "principal point cx = nan px must be finite"),
    ("far-cy", {"k1": _with(K1, 1, 2, 5000.0)}, "principal point cy = 5000 px lies far outside the 640 x 480"),
    ("K-last-row", {"k1": _with(K1, 2, 2, 2.0)}, "last row must be (0, 0, 1)"),
    ("nan-distortion", {"d2": [0.1, np.nan, 0, 0, 0]}, "camera 2 (right): distortion coefficient 2 = nan"),
    ("inf-distortion", {"d1": [0.1, 0, 0, 0, np.inf]}, "distortion coefficient 5 = inf"),
    ("distortion-count", {"d1": [0.1, 0.2, 0.3]}, "3 distortion coefficients"),
    ("not-a-rotation", {"r": R2 * 1.01}, "camera 2 (right): rotation is not a rotation"),
    ("reflection", {"r": REFLECTION}, "rotation is a reflection"),
    ("nan-rotation", {"r": _with(R2, 0, 1, np.nan)}, "rotation has NaN"),
    ("nan-translation", {"t": [np.nan, 0, 0]}, "translation [nan, 0.0, 0.0] mm must be finite"),
    ("zero-baseline", {"t": np.zeros(3)}, "camera 2 (right) has a zero baseline"),
    ("zero-width", {"size1": [0, 480]}, "image width = 0 px must be a whole number"),
    ("negative-height", {"size2": [640, -480]}, "image height = -480 px"),
    ("fractional-size", {"size1": [640.5, 480]}, "image width = 640.5 px"),
    ("huge-size", {"size1": [10**7, 480]}, "image width = 1e+07 px"),
]


@pytest.mark.parametrize("ext", [".yaml", ".json"])
@pytest.mark.parametrize("case,change,words", BAD, ids=[b[0] for b in BAD])
def test_bad_calibration_is_one_line_naming_file_camera_value(tmp_path, ext, case, change, words):
    path = tmp_path / f"cal{ext}"
    (_write_yaml if ext == ".yaml" else _write_json)(path, _pair(**change))
    with pytest.raises(InputError) as err:
        read_calibration(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"cal{ext}: ")
    assert words in msg, msg


@pytest.mark.parametrize("ext", [".yaml", ".json"])
def test_good_pair_reads_and_an_unknown_size_stays_unknown(tmp_path, ext):
    path = tmp_path / f"cal{ext}"
    (_write_yaml if ext == ".yaml" else _write_json)(path, _pair(size1=[0, 0]))
    cal = read_calibration(path)
    assert cal["cameras"][0].image_size == (0, 0) and cal["cameras"][1].image_size == (640, 480)
    np.testing.assert_array_equal(cal["cameras"][1].rotation, R2)
    # a rotation printed with 6 decimals (as MATLAB toolboxes write it) is still one
    (_write_yaml if ext == ".yaml" else _write_json)(path, _pair(r=np.round(R2, 6)))
    assert read_calibration(path)["cameras"][1].rotation[0, 0] == round(R2[0, 0], 6)


def test_written_calibration_of_unknown_size_reads_back(tmp_path):
    cams = [CameraModel(K1, name="cam"), CameraModel(K2, np.zeros(5), R2, T2, name="projector")]
    write_calibration(tmp_path / "c.yaml", {"cameras": cams})
    assert "image_size" not in (tmp_path / "c.yaml").read_text()
    assert [c.image_size for c in read_calibration(tmp_path / "c.yaml")["cameras"]] == [(0, 0), (0, 0)]


def test_camera_model_refuses_what_no_camera_has():
    with pytest.raises(InputError, match=r"camera 'left': focal length fx = -800 px must be positive and finite"):
        CameraModel(_with(K1, 0, 0, -800), name="left")
    with pytest.raises(InputError, match="camera_matrix must be 3 x 3"):
        CameraModel(np.eye(2))
    with pytest.raises(InputError, match="pixel pitch = 0 mm"):
        CameraModel(K1, pixel_pitch=0.0)
    cam = CameraModel(K1, None, None, None, (640, 480))
    assert cam.dist_coeffs.shape == (5,) and np.array_equal(cam.rotation, np.eye(3))
    np.testing.assert_allclose(CameraModel(K2, np.zeros(5), R2, T2).centre, -R2.T @ T2)


def test_fringe_reconstruct_with_a_negative_focal_length_is_a_one_line_error(tmp_path):
    """Before the check this crashed in cv2.initUndistortRectifyMap with SIGSEGV (exit 139)."""
    import yaml

    from camcmm_plugins.fringe.patterns import generate_patterns

    seq = {
        "projector": {"width": 64, "height": 48},
        "frames": ["white", "black", {"type": "phase", "direction": "vertical", "steps": 4, "period": 16}],
    }
    (tmp_path / "seq.yaml").write_text(yaml.safe_dump(seq))
    frames = tmp_path / "frames"
    frames.mkdir()
    for i, f in enumerate(generate_patterns(seq)):
        cv2.imwrite(str(frames / f"img{i:02d}.png"), f)
    cal = tmp_path / "cal.yaml"
    _write_yaml(
        cal, _pair(k1=_with(K1, 0, 0, -800), size1=[64, 48], size2=[64, 48], k2=[[80.0, 0, 32], [0, 80, 24], [0, 0, 1]])
    )
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "camcmm",
            "fringe",
            "reconstruct",
            str(tmp_path / "seq.yaml"),
            "--images",
            str(frames),
            "--calibration",
            str(cal),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert proc.returncode == 2, (proc.returncode, proc.stderr)  # the CLI's code for a one-line input error
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("camcmm: error:"), proc.stderr
    assert "cal.yaml: camera 1 (left): focal length fx = -800 px must be positive and finite" in proc.stderr


def test_models_changed_after_they_were_made_are_caught_on_writing_and_by_check_calibration(tmp_path):
    from camcmm.api import check_calibration

    cams = [CameraModel(K1, name="left"), CameraModel(K2, np.zeros(5), R2, T2, (640, 480), name="right")]
    cams[1].camera_matrix = _with(K2, 0, 0, -810.0)  # as a simulated systematic error of -200 % would
    with pytest.raises(InputError, match=r"^out.yaml: camera 2 \(right\): focal length fx = -810 px"):
        write_calibration(tmp_path / "out.yaml", {"cameras": cams})
    assert not (tmp_path / "out.yaml").exists()
    cams[1].camera_matrix = K2
    cams[1].translation = np.zeros(3)
    with pytest.raises(InputError, match="^sim: camera 2 .right. has a zero baseline"):
        check_calibration({"cameras": cams}, "sim")
    cams[1].translation = T2
    assert check_calibration({"cameras": cams}, "sim")["cameras"] is cams


def test_a_fringe_text_folder_is_checked_and_named(tmp_path):
    from camcmm_plugins.fringe.calib import read_text_folder

    d = tmp_path / "CalibrationDataDistortion"
    d.mkdir()
    np.savetxt(d / "CamIntrinsicMatrixRight.txt", K1)
    np.savetxt(d / "CamDistortionCoefficientsRight.txt", np.zeros(5))
    np.savetxt(d / "ProjIntrinsicMatrix.txt", _with(K2, 1, 1, -805.0))
    np.savetxt(d / "ProjDistortionCoefficients.txt", np.zeros(5))
    np.savetxt(d / "ProjRotationMatrix.txt", np.round(R2, 6))
    np.savetxt(d / "ProjTranslationVector.txt", T2)
    with pytest.raises(InputError, match="^CalibrationDataDistortion: camera 'projector': focal length fy = -805 px"):
        read_text_folder(d)
    np.savetxt(d / "ProjIntrinsicMatrix.txt", K2)
    assert read_text_folder(d)["cameras"][1].name == "projector"
