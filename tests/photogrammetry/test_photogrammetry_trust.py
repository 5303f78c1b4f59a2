"""Issue 26, "Trust, round two", for the photogrammetry import and reconstruct readers:
camera intrinsics checked on import (COLMAP text and binary, Metashape), the binary model
checked exactly as the text one (one validation), repeated ids refused, numeric XML
attributes refused in one line, binary counts held against the file's size, the series
limit (one definition: the manifest's ``max`` of the images input) and the scale's
lengths file checked in a confined run before it is opened (no oracle).

The models are the bad-input family's building blocks (tests/helpers/badcases/
photogrammetry.py): a valid model of two cameras, three images and three points, one
field changed per test.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from camcmm.api import InputError, PointCloud, default_host
from camcmm.confine import OUTSIDE, confined
from camcmm_plugins.photogrammetry.imports import read_reconstruction
from camcmm_plugins.photogrammetry.scale import check_spec, parse_spec
from helpers.badcases import photogrammetry as pg
from helpers.badinputs import png
from helpers.cli import refused

NAN, INF = float("nan"), float("inf")
FORMATS = {"txt": pg.colmap_text, "bin": pg.colmap_binary}


def _model(tmp_path: Path, files: dict[str, bytes]) -> Path:
    for name, data in files.items():
        p = tmp_path / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return tmp_path / "m"


def _refusal(tmp_path, files, path="m") -> str:
    _model(tmp_path, files)
    with pytest.raises(InputError) as exc:
        read_reconstruction(tmp_path / path)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_the_blocks_are_a_valid_model_read_alike_in_both_formats(tmp_path):
    """The reference for every refusal below: the unchanged model is read, and its text and
    binary forms give the same cameras, poses and points."""
    t = read_reconstruction(_model(tmp_path / "t", pg.colmap_text()))
    b = read_reconstruction(_model(tmp_path / "b", pg.colmap_binary()))
    assert (t["source"]["format"], b["source"]["format"]) == ("colmap-text", "colmap-binary")
    assert t["cameras"] == b["cameras"]
    assert t["cameras"][0] == {
        "model": "PINHOLE",
        "fx": 500.0,
        "fy": 505.0,
        "cx": 320.0,  # COLMAP's 320.5 from the corner is OpenCV's 320 from the first pixel's centre
        "cy": 240.0,
        "dist": [0.0, 0.0, 0.0, 0.0, 0.0],
        "width": 640,
        "height": 480,
    }
    for vt, vb in zip(t["views"], b["views"], strict=True):
        assert vt["image"] == vb["image"]
        np.testing.assert_allclose(vt["R"], vb["R"], atol=1e-12)
        np.testing.assert_allclose(vt["centre"], vb["centre"], atol=1e-12)
    # image 3: q = (0.5, 0.5, 0.5, 0.5) is the rotation taking x to y, y to z, z to x
    np.testing.assert_allclose(t["views"][2]["R"], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-12)
    np.testing.assert_allclose(t["cloud"].points, [[0, 0, 0], [1, 2, 3], [-1.5, 0.5, 2]])
    np.testing.assert_allclose(t["cloud"].points, b["cloud"].points)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(
    ("change", "value"),
    [
        ({"p0": NAN}, "parameter 1 (fx) = nan"),
        ({"p0": 0.0}, "fx = 0 px"),
        ({"p0": -500.0}, "fx = -500 px"),
        ({"w": 0}, "width = 0 px"),
        ({"w": 0, "h": 0}, "size 0 x 0 px"),
        ({"w": 2**40}, "width = 1.09951e+12 px"),
    ],
)
def test_colmap_intrinsics_are_checked_in_both_formats(tmp_path, fmt, change, value):
    msg = _refusal(tmp_path, FORMATS[fmt](cameras=pg.with_camera(0, **change)))
    assert msg.startswith(str(tmp_path / "m" / f"cameras.{fmt}")) and "camera" in msg and "1" in msg
    assert value in msg, msg


@pytest.mark.parametrize(("width", "value"), [("-640", "width = -640 px"), ("1e30", "width = 1e+30 px")])
def test_colmap_text_width_negative_or_huge(tmp_path, width, value):
    msg = _refusal(tmp_path, pg.colmap_text(cameras=pg.with_camera(0, w=width)))
    assert "cameras.txt: line 1: camera '1'" in msg and value in msg, msg


def test_colmap_binary_width_that_was_negative(tmp_path):
    """A uint64 width of 2^64 - 640 (-640 written as signed) is no camera either."""
    msg = _refusal(tmp_path, pg.colmap_binary(cameras=pg.with_camera(0, w=2**64 - 640)))
    assert "cameras.bin: record 1: camera '1': image width = 1.84467e+19 px" in msg


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(
    ("change", "value"),
    [
        ({"q": [NAN, 0.0, 0.0, 0.0]}, "quaternion (nan, 0, 0, 0)"),
        ({"q": [0.0, 0.0, 0.0, 0.0]}, "quaternion (0, 0, 0, 0)"),  # was the identity in binary
        ({"t": [0.0, INF, 0.0]}, "translation (0, inf, 0)"),  # was a null centre in binary
    ],
)
def test_colmap_poses_are_checked_alike(tmp_path, fmt, change, value):
    msg = _refusal(tmp_path, FORMATS[fmt](images=pg.with_image(1, **change)))
    assert f"images.{fmt}" in msg and "image 2" in msg and value in msg, msg


def test_a_cameras_bin_cut_by_ten_bytes_is_refused(tmp_path):
    """Before: pycolmap kept the stale values of the last camera's distortion."""
    msg = _refusal(tmp_path, pg.colmap_binary(cameras=pg.cameras_bin()[:-10]))
    assert "cameras.bin: the file ends inside camera record 2" in msg


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(
    ("table", "rows", "what"),
    [
        ("cameras", pg.with_camera(1, id=1), "camera id 1 given twice"),
        ("images", pg.with_image(2, id=1), "image id 1 given twice"),
        ("points", pg.with_point(2, id=2), "point id 2 given twice"),
    ],
)
def test_repeated_ids_are_refused(tmp_path, fmt, table, rows, what):
    """Before: the second camera 1 (fx 600 instead of 500) silently won."""
    msg = _refusal(tmp_path, FORMATS[fmt](**{table: rows}))
    assert what in msg and f".{fmt}" in msg, msg


@pytest.mark.parametrize(
    ("table", "make", "numbers"),
    [
        ("cameras", lambda: pg.cameras_bin(count=2**60), ("1152921504606846976 cameras", "144 are left")),
        ("images", lambda: pg.images_bin(count=2**62), ("4611686018427387904 images",)),
        ("images", lambda: pg.images_bin(n2d=2**61), ("2305843009213693952 2-D points",)),
        ("points", lambda: pg.points_bin(count=2**58), ("288230376151711744 points",)),
        ("points", lambda: pg.points_bin(track=2**60), ("a track of 1152921504606846976",)),
    ],
)
def test_binary_counts_are_held_against_the_file_size(tmp_path, table, make, numbers):
    """Before: pycolmap allocated for the count (2.2 GB, then std::bad_alloc)."""
    t0 = time.perf_counter()
    msg = _refusal(tmp_path, pg.colmap_binary(**{table: make()}))
    assert time.perf_counter() - t0 < 1.0
    assert all(n in msg for n in numbers), msg


def test_many_points_with_tracks_of_every_length_read_exactly(tmp_path):
    """50 000 points whose tracks run from 0 to 6 pairs (so every record starts at another
    offset), written as binary and text: both give the written values, in under a second."""
    import struct

    rng = np.random.default_rng(5)
    n = 50_000
    xyz, err = rng.normal(size=(n, 3)) * 100, rng.uniform(0, 2, n)
    rgb, tracks = rng.integers(0, 256, (n, 3)), rng.integers(0, 7, n)
    ids = rng.permutation(10 * n)[:n] + 1
    head = np.dtype([("id", "<u8"), ("xyz", "<f8", 3), ("rgb", "u1", 3), ("err", "<f8"), ("n", "<u8")])
    parts, lines = [struct.pack("<Q", n)], []
    for k in range(n):
        h = np.array([(ids[k], xyz[k], rgb[k], err[k], tracks[k])], dtype=head)
        parts.append(h.tobytes() + np.arange(2 * tracks[k], dtype="<i4").tobytes())
        pairs = " ".join(f"{j} {j}" for j in range(tracks[k]))
        x, y, z = xyz[k].tolist()
        lines.append(f"{ids[k]} {x!r} {y!r} {z!r} {' '.join(map(str, rgb[k]))} {float(err[k])!r} {pairs}\n")
    _model(tmp_path / "b", pg.colmap_binary(points=b"".join(parts)))
    _model(tmp_path / "t", pg.colmap_text(points="".join(lines).encode()))
    for kind in ("b", "t"):
        t0 = time.perf_counter()
        r = read_reconstruction(tmp_path / kind / "m")
        seconds = time.perf_counter() - t0
        c = r["cloud"]
        np.testing.assert_array_equal(c.points, xyz)
        np.testing.assert_array_equal(c.colors if c.colors.dtype == np.uint8 else np.round(c.colors * 255), rgb)
        np.testing.assert_array_equal(c.fields["reprojection_error"], err)
        np.testing.assert_array_equal(c.fields["track_length"], tracks)
        assert seconds < (1.0 if kind == "b" else 3.0), (kind, seconds)


def test_a_file_that_goes_on_after_its_records_is_refused(tmp_path):
    msg = _refusal(tmp_path, pg.colmap_binary(points=pg.points_bin() + b"\x01"))
    assert "points3D.bin: 1 bytes after the last record" in msg


# -- Metashape -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "value"),
    [
        ({"f": "<f>-7000</f>"}, "fx = -7000 px"),
        ({"f": "<f>0</f>"}, "fx = 0 px"),
        ({"width": "-6000", "height": "0"}, "width = -6000 px"),
        ({"width": "0", "height": "0"}, "size 0 x 0 px"),
        ({"width": "abc"}, "<resolution width='abc'>: not a whole number"),  # was a ValueError
        ({"height": "4.5"}, "<resolution height='4.5'>: not a whole number"),
        ({"width": None}, "<resolution> lacks width"),
        ({"f": "<f>nan</f>"}, "<f>: nan is not a finite number"),
    ],
)
def test_metashape_sensor_is_checked(tmp_path, args, value):
    msg = _refusal(tmp_path, {"c.xml": pg.metashape_xml(**args)}, path="c.xml")
    assert msg.startswith(str(tmp_path / "c.xml")) and value in msg, msg
    if "px" in value:
        assert "camera 'cam'" in msg  # the sensor's label


def test_metashape_valid_block_is_read(tmp_path):
    r = read_reconstruction(_model(tmp_path, {"c.xml": pg.metashape_xml()}).parent / "c.xml")
    cam = r["cameras"][0]
    # cx from the image centre and the corner: 640 / 2 + 1.5 - 0.5
    assert (cam["fx"], cam["cx"], cam["cy"], cam["width"], cam["height"]) == (500.0, 321.0, 237.5, 640, 480)


def test_cli_names_the_file_camera_and_value(tmp_path, capsys, monkeypatch):
    _model(tmp_path, pg.colmap_text(cameras=pg.with_camera(0, p0=-500.0)))
    monkeypatch.chdir(tmp_path)
    line = refused(capsys, ["photogrammetry", "import", "m"], "fx = -500 px")
    assert "m/cameras.txt: line 1: camera '1'" in line


# -- the series limit: one definition ---------------------------------------------------------
def test_series_limit_is_the_manifests_and_the_gui_reads_it():
    from camcmm.tasks import photogrammetry as task

    spec = default_host().provider("photogrammetry")
    (port,) = [p for p in spec.inputs if p.name == "images"]
    assert port.max == 400
    assert task.max_images() == port.max
    assert not hasattr(task, "MAX_IMAGES")  # no second copy of the number


@pytest.mark.parametrize(
    ("port", "ok"),
    [
        ({"name": "i", "type": "images", "max": 3}, True),
        ({"name": "i", "type": "files", "max": 0}, True),
        ({"name": "i", "type": "images", "max": -1}, False),
        ({"name": "i", "type": "images", "max": "many"}, False),
        ({"name": "i", "type": "images", "max": True}, False),
        ({"name": "c", "type": "pointcloud", "max": 3}, False),
    ],
)
def test_manifest_max_of_an_input(port, ok):
    from camcmm.api import PluginError
    from camcmm.manifest import parse_plugin

    entry = {"id": "lab.x", "kind": "algorithm", "name": "X", "entry": "m:f", "inputs": [port]}
    if ok:
        assert parse_plugin(entry, "1", "d", "w").inputs[0].max == port["max"]
    else:
        with pytest.raises(PluginError, match=f"input '{port['name']}': max"):
            parse_plugin(entry, "1", "d", "w")


def test_cli_refuses_a_series_beyond_the_limit_before_reading_it(tmp_path, capsys):
    """401 files that are not even images: refused by their count, in well under a second
    (before: 10 000 tiny images ran past 400 s)."""
    d = tmp_path / "s"
    d.mkdir()
    for k in range(401):
        (d / f"i{k:03d}.png").write_bytes(b"not read")
    t0 = time.perf_counter()
    line = refused(capsys, ["photogrammetry", "reconstruct", d], "401 images given; at most 400")
    assert time.perf_counter() - t0 < 2.0, line


def test_gui_folder_refusal_states_the_same_limit(tmp_path):
    from camcmm.tasks.photogrammetry import folder_sources

    for k in range(401):
        (tmp_path / f"i{k:03d}.png").write_bytes(png(4, 4))
    with pytest.raises(InputError, match="401 images match .*at most 400"):
        folder_sources(tmp_path)


# -- paths in a confined run: no oracle -------------------------------------------------------
@pytest.mark.parametrize("how", ["parse", "plugin"])
def test_lengths_file_outside_the_roots_is_refused_alike(tmp_path, how):
    cloud = PointCloud(np.random.default_rng(0).normal(size=(50, 3)))
    msgs = []
    for target in ("/etc/shadow", "/etc/passwd", "/nonexistent"):
        with confined([tmp_path]), pytest.raises(InputError) as exc:
            if how == "parse":
                parse_spec(f"lengths:{target}")
            else:
                default_host().run("photogrammetry.scale", {"cloud": cloud}, {"scale": f"lengths:{target}"})
        msgs.append(str(exc.value).replace(target, "PATH"))
    assert msgs[0] == msgs[1] == msgs[2], msgs
    assert "scale lengths: PATH: outside the folders" in msgs[0]


def test_lengths_file_inside_the_roots_is_read(tmp_path):
    (tmp_path / "L.csv").write_text("1,2,5\n")
    (tmp_path / "bad.csv").write_text("1,2,x\n")
    with confined([tmp_path]):
        assert parse_spec("lengths:L.csv")["file"] == (tmp_path / "L.csv").resolve()
        with pytest.raises(InputError, match="bad.csv: line 1: 'x' is not a number"):
            check_spec("lengths:bad.csv")


def test_calibration_outside_the_roots_is_refused_alike(tmp_path):
    from camcmm_plugins.photogrammetry.plugin import _calibration

    msgs = []
    for target in ("/etc/passwd", "/nonexistent.yaml"):
        with confined([tmp_path]), pytest.raises(InputError) as exc:
            _calibration(target)
        msgs.append(str(exc.value).replace(target, "PATH"))
    assert msgs[0] == msgs[1] == "calibration: PATH: " + OUTSIDE


def test_import_outside_the_roots_is_refused_alike(tmp_path):
    root = tmp_path / "root"
    root.mkdir()
    msgs = []
    for target in ("/etc/passwd", "/etc", "/nonexistent/m"):
        with confined([root]), pytest.raises(InputError) as exc:
            read_reconstruction(target)
        msgs.append(str(exc.value).replace(target, "PATH"))
    assert msgs[0] == msgs[1] == msgs[2] and "outside the folders" in msgs[0], msgs


def test_a_model_link_or_dense_cloud_outside_the_roots_is_not_followed(tmp_path):
    outside, root = tmp_path / "outside", tmp_path / "root"
    _model(outside, pg.colmap_text(folder="sparse"))
    root.mkdir()
    (root / "p").mkdir()
    (root / "p" / "sparse").symlink_to(outside / "sparse")
    with confined([root]), pytest.raises(InputError, match="COLMAP model: .*outside the folders"):
        read_reconstruction(root / "p")
    # a model folder that is a root itself: its parent's fused.ply is not looked at
    _model(root, pg.colmap_text(folder="m"))
    (root / "fused.ply").write_bytes(b"ply\n")  # would be refused as a cloud if it were read
    with confined([root / "m"]):
        r = read_reconstruction(root / "m")
    assert r["source"].get("cloud") is None and r["n_points"] == 3


def test_family_size():
    assert len(pg.cases()) >= 90
    assert all(c.id.startswith("pg-") for c in pg.cases())
