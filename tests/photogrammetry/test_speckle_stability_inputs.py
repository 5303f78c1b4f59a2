"""``camcmm speckle stability``'s inputs (issue 26): its images through camcmm's one
reader (the pixel cap, refusing what it cannot size), ``--plot`` checked before any image
is read, and the motion still right on a series of small images."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from camcmm.api import InputError
from camcmm.cli.main import main
from camcmm_plugins.photogrammetry.stability import load_images
from helpers.badinputs import jpeg_header, png
from helpers.cli import refused


def _speckle(tmp_path, shifts=(0, 2)):
    """A blurred-noise image and copies shifted right by whole pixels (exact motion)."""
    img = (np.random.default_rng(0).random((128, 128)) * 255).astype(np.uint8)
    img = cv2.GaussianBlur(img, (3, 3), 0)
    files = []
    for i, s in enumerate(shifts):
        p = tmp_path / f"s{i}.png"
        cv2.imwrite(str(p), np.roll(img, s, axis=1))
        files.append(p)
    return files


def test_a_bomb_in_the_series_is_refused_before_decoding(tmp_path, capsys, monkeypatch):
    a, _ = _speckle(tmp_path)
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(png(20000, 20000))
    line = refused(capsys, ["speckle", "stability", a, bomb], "bomb.png")
    assert "20000 x 20000 px" in line
    # a stray byte before SOF0 no longer hides the size
    h = jpeg_header(20000, 20000)
    j = tmp_path / "j.jpg"
    j.write_bytes(h[:2] + b"\xff\xe0\x00\x04ab" + b"\x00" + h[2:])
    assert "20000 x 20000 px" in refused(capsys, ["speckle", "stability", a, j], "j.jpg")
    # a 65535 x 65535 header: one line, also past OpenCV's own limit
    huge = tmp_path / "huge.png"
    huge.write_bytes(png(65535, 65535, idat=b"x"))
    refused(capsys, ["speckle", "stability", a, huge], "huge.png")
    monkeypatch.setenv("CAMCMM_MAX_IMAGE_PIXELS", str(10**10))
    refused(capsys, ["speckle", "stability", a, huge], "huge.png")


def test_files_that_are_not_images_are_refused_before_any_is_decoded(tmp_path, monkeypatch):
    a, b = _speckle(tmp_path)
    (tmp_path / "c.ply").write_text("ply\n")
    (tmp_path / "d.png").mkdir()
    calls = []
    import camcmm_plugins.photogrammetry.stability as st

    monkeypatch.setattr(st, "read", lambda p: calls.append(p))
    with pytest.raises(InputError, match=r"c\.ply: not an image file"):
        load_images([a, b, tmp_path / "c.ply"])
    with pytest.raises(InputError, match=r"d\.png: a folder"):
        load_images([a, tmp_path / "d.png"])
    assert calls == []


@pytest.mark.parametrize(
    "target, why",
    [
        ("p.txt", ".txt is not a plot format"),
        ("d", "a folder"),
        ("plot", "no extension"),
        ("no/p.png", "does not exist"),
    ],
)
def test_a_bad_plot_target_is_refused_before_the_images_are_read(tmp_path, capsys, monkeypatch, target, why):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d").mkdir()
    # the images do not even exist: --plot is refused first
    line = refused(capsys, ["speckle", "stability", "x.png", "y.png", "--plot", target], "--plot")
    assert why in line and target in line


def test_the_plot_is_written_where_reported_and_the_motion_is_right(tmp_path, capsys):
    files = _speckle(tmp_path, (0, 2, 0))
    out = tmp_path / "motion.svg"
    assert main(["speckle", "stability", *map(str, files), "--plot", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["plot"] == str(out) and out.read_bytes().lstrip().startswith(b"<?xml")
    assert res["mean_motion_px"] == pytest.approx([0.0, 2.0, 0.0], abs=0.02)  # whole-pixel shifts
    assert res["verdict"] == "pass"


def test_one_image_is_refused_naming_it(tmp_path, capsys):
    (a,) = _speckle(tmp_path, (0,))
    assert "s0.png" in refused(capsys, ["speckle", "stability", a], "at least 2 images")


def test_large_frames_are_analysed_in_tiles_with_the_same_motion(tmp_path, monkeypatch):
    """SIFT on tiles (an 81 Mpx frame took 19 GB whole; ~215 bytes a pixel): with tiles
    of 4096 px a 128 x 128 series is cut in 4 and still gives its whole-pixel shifts."""
    import camcmm_plugins.photogrammetry.stability as st

    files = _speckle(tmp_path, (0, 2, -1))
    whole = st.stability(st.ImageSeries(files), [p.name for p in files])
    monkeypatch.setattr(st, "TILE_PIXELS", 4096)
    assert len(st._tiles(128, 128)) == 4
    tiled = st.stability(st.ImageSeries(files), [p.name for p in files])
    assert tiled["mean_motion_px"] == pytest.approx([0.0, 2.0, 1.0], abs=0.02)
    assert whole["mean_motion_px"] == pytest.approx([0.0, 2.0, 1.0], abs=0.02)


def test_a_uniform_frame_is_refused_without_running_sift(tmp_path, monkeypatch):
    import camcmm_plugins.photogrammetry.stability as st

    flat = tmp_path / "flat.png"
    flat.write_bytes(png(3000, 3000))
    monkeypatch.setattr(cv2, "SIFT_create", lambda **k: pytest.fail("SIFT ran on a uniform frame"))
    with pytest.raises(InputError, match=r"flat\.png: only 0 SIFT features"):
        st.stability(st.ImageSeries([flat, flat]), ["flat.png", "flat.png"])
