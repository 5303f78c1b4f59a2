"""The text reader parses a large plain table from the file, not from a list of lines
(issue 26: a 315 MB .xyz took 5.5 GB in a session)."""

from __future__ import annotations

import tracemalloc

import numpy as np

from camcmm import io as cio


def test_a_plain_xyz_is_read_in_about_the_memory_of_its_points(tmp_path):
    pts = np.random.default_rng(3).normal(size=(200_000, 3)) * 50.0
    path = tmp_path / "scan.xyz"
    np.savetxt(path, pts, fmt="%.6f", header="unit mm")
    points_bytes = pts.nbytes  # 4.8 MB of float64
    tracemalloc.start()
    try:
        cloud = cio.read(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    np.testing.assert_allclose(cloud.points, pts, atol=1e-6)  # %.6f keeps 1e-6 mm
    # one list of Python strings per line alone costs ~10x the file (7.6 MB here); numpy's
    # chunked parser holds the growing table and one chunk
    assert peak < 5 * points_bytes, f"peak {peak / 1e6:.1f} MB for {points_bytes / 1e6:.1f} MB of points"


def test_a_bad_line_deep_in_a_large_file_is_still_named(tmp_path):
    lines = [f"{i} {i + 1} {i + 2}" for i in range(50_000)]
    lines[41_234] = "1 2 three"
    path = tmp_path / "scan.xyz"
    path.write_text("# unit mm\n" + "\n".join(lines) + "\n")
    try:
        cio.read(path)
    except cio.InputError as exc:
        assert "line 41236" in str(exc) and "three" in str(exc)
    else:
        raise AssertionError("a non-numeric line was read")
