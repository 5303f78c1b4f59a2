"""Report charts: PNG output, colour range, units, geometry and errors (camcmm.report.charts)."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys

import numpy as np
import pytest

from camcmm.errors import InputError
from camcmm.report import charts
from camcmm.report.blocks import PNG_SIGNATURE, png_size
from camcmm.report.charts import _subsample


def _cap(n: int, radius: float = 12.5, cap_deg: float = 70.0, centre=(10.0, -5.0, 30.0), seed: int = 0):
    """Points on a spherical cap about +z with a known signed radial deviation (mm)."""
    rng = np.random.default_rng(seed)
    th = np.arccos(1 - rng.uniform(0, 1 - np.cos(np.radians(cap_deg)), n))
    ph = rng.uniform(0, 2 * np.pi, n)
    u = np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    dev = 0.004 * np.sin(3 * ph) * np.sin(th) + rng.normal(0, 0.001, n)
    return np.asarray(centre) + u * (radius + dev)[:, None], dev


def _flat(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    xy = rng.uniform([-100, -20], [100, 20], (n, 2))
    dev = 0.003 * (xy[:, 0] / 100) ** 2 + rng.normal(0, 0.001, n)
    return np.column_stack([xy, 5.0 + dev]), dev


def _assert_png(png: bytes, min_px: int = 200) -> tuple[int, int]:
    assert isinstance(png, bytes) and png.startswith(PNG_SIGNATURE)
    w, h, dpi = png_size(png)
    assert w >= min_px and h >= 100 and dpi == pytest.approx(charts.DPI, abs=1)
    assert 5_000 < len(png) < 2_000_000
    return w, h


def test_sphere_map_is_a_png_with_a_symmetric_colour_range():
    p, d = _cap(3000)
    png = charts.deviation_map(p, d, kind="sphere", center=(10.0, -5.0, 30.0), title="S1")
    w, h = _assert_png(png)
    assert w == pytest.approx(82 / 25.4 * charts.DPI, abs=2)
    info = png.info
    assert info["kind"] == "sphere" and info["projection"] == "Lambert azimuthal equal-area"
    assert info["vmin"] == -info["vmax"] and info["vmax"] > 0
    # small deviations read in µm, and the range covers the largest one
    assert info["display_unit"] == "µm"
    assert info["vmax"] == pytest.approx(np.abs(d).max() * 1000)
    assert info["radius"] == pytest.approx(12.5, abs=0.01)
    assert info["view_direction"] == pytest.approx([0, 0, 1], abs=0.02)
    assert info["n_points"] == info["n_drawn"] == 3000


def test_limit_sets_the_colour_range_and_units_follow_the_size():
    p, d = _cap(2000)
    info = charts.deviation_map(p, d, center=(10.0, -5.0, 30.0), limit=0.002).info
    assert (info["vmin"], info["vmax"]) == (pytest.approx(-2.0), pytest.approx(2.0))  # µm
    assert info["limit"] == pytest.approx(2.0)
    # deviations in µm whatever their size (the number rule, as every page)
    info = charts.deviation_map(p, d * 100, center=(10.0, -5.0, 30.0)).info  # up to ~0.5 mm
    assert info["display_unit"] == "µm" and info["vmin"] == -info["vmax"]
    info = charts.deviation_map(p, d / 1000, center=(10.0, -5.0, 30.0)).info  # a few nm
    assert info["display_unit"] == "µm"
    info = charts.deviation_map(p, d * 1000, unit="µm", center=(10.0, -5.0, 30.0)).info  # given in µm
    assert info["display_unit"] == "µm" and info["vmax"] == pytest.approx(np.abs(d).max() * 1000)
    info = charts.deviation_map(p, d, center=(10.0, -5.0, 30.0), display_unit="mm").info
    assert info["display_unit"] == "mm"


def test_plane_map_and_automatic_kind():
    p, d = _flat(5000)
    png = charts.deviation_map(p, d, title="F1")
    w, h = _assert_png(png)
    assert png.info["kind"] == "plane" and png.info["vmin"] == -png.info["vmax"]
    assert w > 2 * h  # a long flat gets a wide map
    assert png.info["normal"] == pytest.approx([0, 0, 1], abs=1e-3)
    assert abs(png.info["u_axis"][0]) == pytest.approx(1, abs=1e-3)  # along the long side
    cap, dc = _cap(2000)
    assert charts.deviation_map(cap, dc).info["kind"] == "sphere"
    assert charts.deviation_map(cap, dc).info["centre"] == pytest.approx([10, -5, 30], abs=0.01)
    assert charts.deviation_map(p, d, normal=(0, 0, 2)).info["kind"] == "plane"


def test_whole_sphere_uses_a_cylindrical_map():
    rng = np.random.default_rng(3)
    u = rng.normal(size=(4000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    info = charts.deviation_map(u * 10, rng.normal(0, 0.001, 4000), center=(0, 0, 0)).info
    assert info["projection"].startswith("cylindrical")


def test_many_points_are_subsampled_keeping_the_extremes():
    rng = np.random.default_rng(5)
    d = rng.normal(size=200_000)
    idx = _subsample(d, 50_000)
    assert idx.size == 50_000 and np.unique(idx).size == 50_000
    top = np.argsort(np.abs(d))[-5000:]
    assert np.isin(top, idx).all()
    assert np.all(np.diff(np.abs(d[idx])) >= 0)  # extremes drawn last, on top
    p, dev = _cap(120_000)
    info = charts.deviation_map(p, dev, center=(10.0, -5.0, 30.0)).info
    assert info["n_points"] == 120_000 and info["n_drawn"] == charts.MAX_DRAWN


def test_same_input_same_png():
    p, d = _cap(500)
    a = charts.deviation_map(p, d, center=(10.0, -5.0, 30.0))
    b = charts.deviation_map(p, d, center=(10.0, -5.0, 30.0))
    assert hashlib.sha256(a).digest() == hashlib.sha256(b).digest()


def test_bar_chart_and_histogram():
    png = charts.bar_chart(
        [f"pos {i}" for i in range(1, 8)],
        [0.1, -0.05, 0.2, None, 0.12, 0.18, 0.01],
        limit=0.186,
        unit="mm",
        title="P_F",
        errors=[0.01] * 7,
    )
    _assert_png(png)
    assert png.info["n_missing"] == 1 and png.info["n_beyond_limit"] == 1
    png = charts.bar_chart(["a", "b"], [1.0, 2.0], limit=[1.5, 2.5])
    assert png.info["limit"] == [1.5, 2.5] and png.info["n_beyond_limit"] == 0
    _assert_png(charts.bar_chart(["only"], [0.0]))
    h = charts.histogram(np.random.default_rng(0).normal(0, 0.002, 5000), limit=0.006)
    _assert_png(h)
    assert h.info["display_unit"] == "µm" and h.info["limit"] == pytest.approx(6.0) and h.info["n"] == 5000


def test_empty_or_bad_input_is_refused_clearly():
    with pytest.raises(InputError, match="no points to draw"):
        charts.deviation_map(np.empty((0, 3)), [])
    with pytest.raises(InputError, match="no values to draw"):
        charts.bar_chart([], [])
    with pytest.raises(InputError, match="no values to draw"):
        charts.histogram([])
    with pytest.raises(InputError, match="every value is missing"):
        charts.bar_chart(["a"], [None])
    p, d = _cap(100)
    d_nan = d.copy()
    d_nan[[3, 7]] = np.nan
    with pytest.raises(InputError, match="2 of 100 values are NaN or Inf .first at index 3."):
        charts.deviation_map(p, d_nan)
    p_nan = p.copy()
    p_nan[5, 1] = np.inf
    with pytest.raises(InputError, match="1 of 100 points have NaN or Inf"):
        charts.deviation_map(p_nan, d)
    with pytest.raises(InputError, match="99 deviations for 100 points"):
        charts.deviation_map(p, d[:-1])
    with pytest.raises(InputError, match=r"shape \(N, 3\)"):
        charts.deviation_map(p[:, :2], d)
    with pytest.raises(InputError, match="kind 'cone'"):
        charts.deviation_map(p, d, kind="cone")
    with pytest.raises(InputError, match="2 labels for 3 values"):
        charts.bar_chart(["a", "b"], [1, 2, 3])
    with pytest.raises(InputError, match="unit 'inch'"):
        charts.histogram([1.0], unit="inch")


def test_charts_work_headless_without_pyplot():
    # No display, and a GUI backend requested: the charts never touch pyplot or the
    # backend, so they still work (as on a server or in a worker thread).
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MPLBACKEND"] = "TkAgg"
    code = (
        "import sys, numpy as np; from camcmm.report import charts;"
        "png = charts.histogram(np.arange(10.0));"
        "assert png[:8] == b'\\x89PNG\\r\\n\\x1a\\n';"
        "print('pyplot' if 'matplotlib.pyplot' in sys.modules else 'ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
