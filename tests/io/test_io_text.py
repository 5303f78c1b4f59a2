"""Text point lists (.xyz/.txt/.csv) as photogrammetry and scanner packages export them,
and the real NIST sphere scan from ../shared."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import camcmm.io as cio

SHARED = Path(__file__).resolve().parents[2] / ".." / "shared"
SPH101 = SHARED / "data" / "nist_tls_sphere_scans" / "SPH101.xyz"


def read_text(tmp_path, name, text, **kw):
    path = tmp_path / name
    path.write_text(text)
    return cio.read(path, **kw)


def test_tab_separated_without_header(tmp_path):
    c = read_text(tmp_path, "a.txt", "1.5\t2\t3\n4\t5\t6.25\n")
    np.testing.assert_array_equal(c.points, [[1.5, 2, 3], [4, 5, 6.25]])
    assert c.colors is None and c.fields == {} and c.source_unit == "mm"


def test_space_separated_with_rgb_ints_and_extra_column(tmp_path):
    c = read_text(tmp_path, "a.xyz", "0 0 0 255 0 10 0.5\n1 1 1 0 128 20 -0.25\n")
    np.testing.assert_array_equal(c.colors, [[255, 0, 10], [0, 128, 20]])
    assert list(c.fields) == ["col7"]
    np.testing.assert_array_equal(c.fields["col7"], [0.5, -0.25])


def test_rgb_as_unit_floats(tmp_path):
    c = read_text(tmp_path, "a.xyz", "0 0 0 1.0 0.5 0.0\n1 1 1 0.2 0.4 0.6\n")
    np.testing.assert_array_equal(c.colors, [[255, 128, 0], [51, 102, 153]])


def test_normals_without_header_are_found_before_or_after_colours(tmp_path):
    c = read_text(tmp_path, "a.xyz", "0 0 0 0 0 1 10 20 30\n1 1 1 0.6 -0.8 0 40 50 60\n")
    np.testing.assert_array_equal(c.normals, [[0, 0, 1], [0.6, -0.8, 0]])
    np.testing.assert_array_equal(c.colors, [[10, 20, 30], [40, 50, 60]])
    c = read_text(tmp_path, "b.xyz", "0 0 0 10 20 30 0 0 1\n1 1 1 40 50 60 0.6 -0.8 0\n")
    np.testing.assert_array_equal(c.colors, [[10, 20, 30], [40, 50, 60]])
    np.testing.assert_array_equal(c.normals, [[0, 0, 1], [0.6, -0.8, 0]])


def test_columns_that_are_neither_colours_nor_normals_become_fields(tmp_path):
    c = read_text(tmp_path, "a.xyz", "0 0 0 -1.5 300 2\n1 1 1 2.5 400 3\n")
    assert c.colors is None and c.normals is None and list(c.fields) == ["col4", "col5", "col6"]


def test_csv_header_names_columns(tmp_path):
    text = "X,Y,Z,Red,Green,Blue,Deviation,Intensity\n1,2,3,10,20,30,0.01,77\n4,5,6,40,50,60,-0.02,88\n"
    c = read_text(tmp_path, "a.csv", text)
    np.testing.assert_array_equal(c.points, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(c.colors, [[10, 20, 30], [40, 50, 60]])
    assert list(c.fields) == ["Deviation", "Intensity"]


def test_header_order_need_not_start_with_xyz(tmp_path):
    c = read_text(tmp_path, "a.csv", "id,z,y,x\n7,3,2,1\n8,6,5,4\n")
    np.testing.assert_array_equal(c.points, [[1, 2, 3], [4, 5, 6]])
    assert list(c.fields) == ["id"]


def test_cloudcompare_header_comment(tmp_path):
    c = read_text(tmp_path, "cc.txt", "//X,Y,Z,R,G,B,Nx,Ny,Nz\n1,2,3,9,8,7,0,0,1\n")
    np.testing.assert_array_equal(c.colors, [[9, 8, 7]])
    np.testing.assert_array_equal(c.normals, [[0, 0, 1]])


def test_semicolon_with_decimal_comma(tmp_path):
    c = read_text(tmp_path, "eu.csv", "x;y;z\n1,5;2,25;-3,0\n4;5;6\n")
    np.testing.assert_array_equal(c.points, [[1.5, 2.25, -3.0], [4, 5, 6]])


def test_comments_blank_lines_and_pts_count(tmp_path):
    c = read_text(tmp_path, "a.xyz", "# exported by a scanner\n\n3\n1 2 3\n\n4 5 6\n# end\n7 8 9\n")
    assert c.n_points == 3


def test_unit_comment_and_override(tmp_path):
    c = read_text(tmp_path, "m.xyz", "# units: meters\n0.001 0.002 0.003\n")
    assert c.source_unit == "m"
    np.testing.assert_allclose(c.points, [[1, 2, 3]])
    c = read_text(tmp_path, "raw.xyz", "1 2 3\n", unit="um")
    assert c.source_unit == "um"
    np.testing.assert_allclose(c.points, [[0.001, 0.002, 0.003]])


def test_large_text_file_reads_quickly(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.uniform(-100, 100, (200_000, 3))
    path = tmp_path / "big.xyz"
    np.savetxt(path, pts, fmt="%.6f")
    c = cio.read(path)
    np.testing.assert_allclose(c.points, pts, atol=5e-7)


def test_nist_sphere_scan_in_metres():
    if not SPH101.is_file():
        pytest.skip(f"{SPH101} is absent: the real-data test needs the ../shared data folder next to the repo")
    c = cio.read(SPH101, unit="m")
    assert c.n_points == 6474 and c.source_unit == "m" and c.name == "SPH101.xyz"
    first = [float(v) for v in SPH101.read_text().split("\n", 1)[0].split("\t")]
    np.testing.assert_allclose(c.points[0], np.array(first) * 1000.0)
    # a sphere a few metres from the scanner: the scan spans decimetres, not metres
    extent = c.points.max(axis=0) - c.points.min(axis=0)
    assert 10.0 < extent.max() < 1000.0
    info = cio.info(SPH101, unit="m")
    assert info["n_points"] == 6474 and info["source_unit"] == "m" and info["fields"] == []


def test_quoted_csv_and_unit_words(tmp_path):
    c = read_text(tmp_path, "q.csv", '"x","y","z"\n"1.5","2","3"\n', unit="meters")
    assert c.source_unit == "m"
    np.testing.assert_array_equal(c.points, [[1500, 2000, 3000]])
