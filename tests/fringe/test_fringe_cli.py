"""``camcmm fringe patterns|reconstruct`` as a user calls them: files in, one JSON
document out, one-line errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from camcmm.api import CameraModel, read, write_calibration
from camcmm_plugins.fringe.patterns import generate_patterns
from camcmm_plugins.fringe.synthetic import render_captures
from camcmm_plugins.fringe.triangulate import camera_rays, project
from helpers.cli import main_json, main_refused, main_text

SEQ = {
    "projector": {"width": 320, "height": 240},
    "frames": [
        "white",
        "black",
        {"type": "phase", "direction": "vertical", "steps": 4, "period": 16},
        {"type": "gray", "direction": "vertical", "period": 8, "inverse": "interleaved"},
        # two frequencies, no code: the 241.5 px beat covers the 240 rows
        {"type": "phase", "direction": "horizontal", "steps": 3, "period": 21, "shifts_deg": [-120, 0, 120]},
        {"type": "phase", "direction": "horizontal", "steps": 3, "period": 23, "shifts_deg": [-120, 0, 120]},
    ],
}
W, H = 200, 150


@pytest.fixture
def seq_file(tmp_path):
    p = tmp_path / "sequence.yaml"
    p.write_text(yaml.safe_dump(SEQ))
    return p


@pytest.mark.slow
def test_patterns_are_written_at_the_projector_resolution(seq_file, tmp_path, capfd):
    out = tmp_path / "pats"
    doc = main_json(capfd, "fringe", "patterns", seq_file, "--out", out, "--json")
    assert doc["n_frames"] == 2 + 4 + 2 * 6 + 3 + 3 and doc["projector_size"] == [320, 240]
    assert len(doc["files"]) == doc["n_frames"] and (out / "pat00.png").is_file()
    expected = generate_patterns(SEQ)
    for i, f in enumerate(doc["files"]):
        img = cv2.imread(f, cv2.IMREAD_UNCHANGED)
        assert img.shape == (240, 320) and img.dtype == np.uint8
        assert np.array_equal(img, expected[i])
    assert [f["kind"] for f in doc["frames"][:3]] == ["white", "black", "phase"]


def rig():
    k = np.array([[420.0, 0, W / 2 - 0.5], [0, 420.0, H / 2 - 0.5], [0, 0, 1]])
    cam = CameraModel(k, [-0.05, 0.02, 0, 0, 0], image_size=(W, H), name="cam")
    r, _ = cv2.Rodrigues(np.array([0.0, -0.1, 0.0]))
    proj = CameraModel(
        [[600.0, 0, 160], [0, 600.0, 120], [0, 0, 1]],
        [0.01, 0, 0, 0, 0],
        r,
        -r @ np.array([40.0, 0, 0]),
        (320, 240),
        name="projector",
    )
    return cam, proj


@pytest.fixture
def capture_dir(tmp_path):
    """A camera looking at the plane z = 200 mm, lit by the projector."""
    cam, proj = rig()
    yy, xx = np.mgrid[0:H, 0:W]
    o, d = camera_rays(cam, np.c_[xx.ravel(), yy.ravel()].astype(float))
    x = o + ((200.0 - o[2]) / d[:, 2])[:, None] * d
    uv = project(proj, x)
    u, v = uv[:, 0].reshape(H, W), uv[:, 1].reshape(H, W)
    lit = (u > 0) & (u < 319) & (v > 0) & (v < 239)
    frames = render_captures(
        SEQ,
        u=np.where(lit, u, 0),
        v=np.where(lit, v, 0),
        mean=np.where(lit, 90.0, 3.0),
        modulation=np.where(lit, 70.0, 0.0),
        noise=0.5,
    )
    folder = tmp_path / "captures"
    folder.mkdir()
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"img{i}.png"), f)  # img2 before img10: natural order
    cal = tmp_path / "cal.yaml"
    write_calibration(cal, {"cameras": [cam, proj]})
    return folder, cal, lit.mean()


def test_reconstruct_json_and_cloud(seq_file, capture_dir, tmp_path, capfd):
    folder, cal, lit = capture_dir
    out = tmp_path / "cloud.ply"
    doc = main_json(
        capfd, "fringe", "reconstruct", seq_file, "--images", folder, "--calibration", cal, "--json", "--out", out
    )
    assert {"n_points", "valid_fraction", "bbox"} <= set(doc)
    assert doc["valid_fraction"] == pytest.approx(lit, abs=0.02)
    assert doc["n_points"] > 0.9 * lit * W * H
    (lo, hi) = np.asarray(doc["bbox"])
    # noise 0.5 grey on 70: sigma_u = 0.013 projector px -> 0.022 mm in depth here
    assert lo[2] == pytest.approx(200.0, abs=0.15) and hi[2] == pytest.approx(200.0, abs=0.15)
    cloud = read(out)
    assert cloud.n_points == doc["n_points"]
    assert abs(np.mean(cloud.points[:, 2]) - 200.0) < 0.002 and np.std(cloud.points[:, 2]) < 0.03


@pytest.mark.slow
def test_reconstruct_bad_input_is_one_line(seq_file, capture_dir, tmp_path, capfd):
    folder, cal, _ = capture_dir
    (folder / "img23.png").unlink()
    err = main_refused(capfd, "fringe", "reconstruct", seq_file, "--images", folder, "--calibration", cal)
    assert "23 frames given, too few for the sequence 'sequence.yaml' which declares 24" in err
    cam, proj = rig()
    other = tmp_path / "other.yaml"
    write_calibration(other, {"cameras": [CameraModel(cam.camera_matrix, image_size=(640, 480), name="cam"), proj]})
    cv2.imwrite(str(folder / "img23.png"), cv2.imread(str(folder / "img0.png"), cv2.IMREAD_UNCHANGED))
    err = main_refused(capfd, "fringe", "reconstruct", seq_file, "--images", folder, "--calibration", other)
    assert "calibrated for 640x480 px but the images are 200x150 px" in err
    err = main_refused(capfd, "fringe", "patterns", tmp_path / "missing.yaml", "--out", tmp_path / "x")
    assert "missing.yaml: no such sequence file" in err


def test_no_decoded_pixel_names_the_thresholds_given(seq_file, capture_dir, capsys):
    from camcmm.cli.main import main

    folder, cal, _ = capture_dir
    args = ["fringe", "reconstruct", str(seq_file), "--images", str(folder), "--calibration", str(cal)]
    assert main(args + ["--modulation-threshold", "300", "--saturation", "0"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no pixel decodes (low_modulation" in lines[0]
    assert "(given: --modulation-threshold 300, --saturation 0 (0: the image type's maximum))" in lines[0]


@pytest.mark.slow
def test_saturated_captures_are_reported_with_their_fraction(seq_file, capture_dir, capfd):
    folder, cal, _ = capture_dir
    img = cv2.imread(str(folder / "img2.png"), cv2.IMREAD_UNCHANGED)  # the first phase frame
    img[:30, :50] = 255
    cv2.imwrite(str(folder / "img2.png"), img)
    doc = main_json(capfd, "fringe", "reconstruct", seq_file, "--images", folder, "--calibration", cal, "--json")
    assert any(f"{100 * 30 * 50 / (W * H):.2f} % of the pixels are saturated" in w for w in doc["warnings"])
    text = main_text(capfd, "fringe", "reconstruct", seq_file, "--images", folder, "--calibration", cal)
    assert "points (" in text and "warning: images: 5.00 % of the pixels are saturated" in text
