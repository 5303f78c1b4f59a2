"""Outlier rules: the fast vdi2634 removes exactly the points of the naive loop; the
percent and sigma rules do what their documentation says.

The naive loop here is written independently of the plugin's rule code: it calls the
plain least-squares fit (outliers "none") on the remaining points, removes the point
with the largest absolute residual, and repeats, m = floor(3 N / 1000) times.
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import GeometryError, ParameterError
from camcmm_plugins.fitting import outliers as rules
from camcmm_plugins.fitting.api import fit, parse_rule, vdi2634_count

FAR = np.array([10_000.0, -10_000.0, 10_000.0])
PARAMS = {
    "sphere": ("center", "radius"),
    "plane": ("point", "normal"),
    "line": ("point", "direction"),
    "circle": ("center", "radius"),
    "cylinder": ("point", "axis", "radius"),
}


def naive_vdi2634(element, pts):
    """The reference: one point at a time, refit from scratch after each removal."""
    keep = np.arange(len(pts))
    removed = []
    for _ in range((3 * len(pts)) // 1000):
        res = fit(element, pts[keep])
        i = int(np.argmax(np.abs(res.residuals)))
        removed.append(int(keep[i]))
        keep = np.delete(keep, i)
    return np.array(removed), fit(element, pts[keep])


def _same_parameters(element, a, b, size):
    for k in PARAMS[element]:
        va, vb = np.atleast_1d(a.params[k]), np.atleast_1d(b.params[k])
        if k in ("normal", "axis", "direction"):
            vb = vb * np.sign(va @ vb)
            assert np.abs(va - vb).max() <= 1e-12, k
        elif k == "point" and element in ("plane", "line", "cylinder"):
            d = va - vb  # any point of the element: compare the offset across it
            n = a.params.get("normal", a.params.get("axis", a.params.get("direction")))
            across = d @ n if element == "plane" else np.linalg.norm(d - (d @ n) * n)
            assert abs(across) <= 1e-12 * size, k
        else:
            assert np.abs(va - vb).max() <= 1e-12 * size, k


def _sphere(rng, n, radius=10.0, half_angle=None, outliers=0):
    if half_angle is None:
        u = rng.normal(size=(n, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
    else:  # uniform on a cap about +z
        z = rng.uniform(np.cos(np.radians(half_angle)), 1.0, n)
        phi = rng.uniform(0, 2 * np.pi, n)
        u = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    r = radius + rng.normal(scale=0.01, size=len(u))
    if outliers:
        r[rng.choice(len(u), outliers, replace=False)] += rng.uniform(0.1, 2.0, outliers) * rng.choice(
            [-1, 1], outliers
        )
    return FAR + r[:, None] * u


def _case(element, rng):
    if element == "sphere":
        return _sphere(rng, 5000, outliers=20), 10.0
    if element == "sphere-cap":
        return _sphere(rng, 5000, half_angle=25, outliers=10), 10.0
    if element == "plane":
        p = np.column_stack([rng.uniform(-50, 50, 4000), rng.uniform(-30, 30, 4000), rng.normal(scale=0.01, size=4000)])
        p[:15, 2] += rng.uniform(-1, 1, 15)
        return p + FAR, 50.0
    if element == "line":
        t = rng.uniform(-50, 50, 3000)
        p = np.column_stack([t, rng.normal(scale=0.02, size=3000), rng.normal(scale=0.02, size=3000)])
        return p @ np.linalg.qr(rng.normal(size=(3, 3)))[0] + FAR, 50.0
    if element == "line2d":
        t = rng.uniform(-50, 50, 3000)
        return np.column_stack([t, 0.3 * t + rng.normal(scale=0.02, size=3000)]) + FAR[:2], 50.0
    if element == "circle2d":
        t = rng.uniform(0, np.pi, 3000)
        r = 20 + rng.normal(scale=0.02, size=3000)
        return np.column_stack([r * np.cos(t), r * np.sin(t)]) + FAR[:2], 20.0
    if element == "circle":
        t = rng.uniform(0, 2 * np.pi, 2000)
        r = 20 + rng.normal(scale=0.02, size=2000)
        p = np.column_stack([r * np.cos(t), r * np.sin(t), rng.normal(scale=0.02, size=2000)])
        return p + FAR, 20.0
    if element == "cylinder":
        t = rng.uniform(0, np.pi, 2000)
        z = rng.uniform(-20, 20, 2000)
        r = 8 + rng.normal(scale=0.01, size=2000)
        p = np.column_stack([r * np.cos(t), r * np.sin(t), z]) @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
        return p + FAR, 8.0
    raise AssertionError(element)


@pytest.mark.parametrize("case", ["sphere", "sphere-cap", "plane", "line", "line2d", "circle2d", "circle", "cylinder"])
def test_fast_vdi2634_equals_the_naive_loop(case):
    rng = np.random.default_rng(sum(map(ord, case)))
    pts, size = _case(case, rng)
    element = {"sphere-cap": "sphere", "line2d": "line", "circle2d": "circle"}.get(case, case)
    removed, ref = naive_vdi2634(element, pts)
    res = fit(element, pts, "vdi2634")
    assert res.n_removed == vdi2634_count(len(pts)) == len(removed) > 0
    np.testing.assert_array_equal(res.removed, removed)
    assert res.n_used == len(pts) - len(removed)
    assert not res.used[removed].any()
    _same_parameters(element, res, ref, size)
    np.testing.assert_allclose(res.residuals[res.used], ref.residuals, atol=1e-12 * size, rtol=0)


@pytest.mark.slow
def test_fast_vdi2634_on_a_larger_sphere_equals_the_plugins_naive_loop():
    """50 000 points, 150 removals: the downdated path against the reference loop."""
    rng = np.random.default_rng(5)
    pts = _sphere(rng, 50_000, outliers=40)
    fast = fit("sphere", pts, "vdi2634")
    slow = fit("sphere", pts, "vdi2634", fast=False)
    np.testing.assert_array_equal(fast.removed, slow.removed)
    _same_parameters("sphere", fast, slow, 10.0)


def test_fast_vdi2634_resolves_exact_ties_like_the_naive_loop():
    """Duplicated outliers tie exactly at every step: the lower index goes first."""
    rng = np.random.default_rng(6)
    pts = _sphere(rng, 2000)
    pts[100] = pts[1500] = FAR + np.array([0, 0, 10.7])
    pts[200] = pts[1700] = FAR + np.array([10.4, 0, 0])
    removed, ref = naive_vdi2634("sphere", pts)
    res = fit("sphere", pts, "vdi2634")
    np.testing.assert_array_equal(res.removed, removed)
    assert list(removed[:4]) == [100, 1500, 200, 1700]
    _same_parameters("sphere", res, ref, 10.0)


def test_fast_vdi2634_falls_back_when_candidates_run_out(monkeypatch):
    """With a tiny candidate pool the bound soon fails; the exact fallback must keep
    the result identical."""
    monkeypatch.setattr(rules, "_CAND_FACTOR", 0)
    monkeypatch.setattr(rules, "_CAND_EXTRA", 3)
    rng = np.random.default_rng(7)
    pts = _sphere(rng, 4000, outliers=5)
    removed, ref = naive_vdi2634("sphere", pts)
    res = fit("sphere", pts, "vdi2634")
    np.testing.assert_array_equal(res.removed, removed)
    _same_parameters("sphere", res, ref, 10.0)


def test_vdi2634_count_is_three_per_thousand_floored():
    assert [vdi2634_count(n) for n in (0, 333, 334, 999, 1000, 1667, 1_000_000)] == [0, 0, 1, 2, 3, 5, 3000]
    rng = np.random.default_rng(8)
    res = fit("sphere", _sphere(rng, 333), "vdi2634")
    assert res.n_removed == 0


def test_percent_rule_removes_the_largest_residuals_then_refits_once():
    rng = np.random.default_rng(9)
    pts = _sphere(rng, 1999, outliers=30)
    full = fit("sphere", pts)
    k = int(np.floor(5 * 1999 / 100))  # 99
    expect = np.argsort(-np.abs(full.residuals), kind="stable")[:k]
    res = fit("sphere", pts, "percent:5")
    assert res.n_removed == k == 99
    np.testing.assert_array_equal(np.sort(res.removed), np.sort(expect))
    ref = fit("sphere", np.delete(pts, expect, axis=0))
    _same_parameters("sphere", res, ref, 10.0)
    assert fit("sphere", pts, "percent:0").n_removed == 0


def test_sigma_rule_iterates_until_no_point_is_beyond_k_sigma():
    rng = np.random.default_rng(10)
    pts = _sphere(rng, 3000, outliers=60)
    res = fit("sphere", pts, "sigma:3")
    # independent loop
    keep = np.ones(len(pts), bool)
    while True:
        r = fit("sphere", pts[keep])
        s = np.sqrt(np.sum(r.residuals**2) / (keep.sum() - 4))
        out = np.abs(r.residuals) > 3 * s
        if not out.any():
            break
        keep[np.flatnonzero(keep)[out]] = False
    np.testing.assert_array_equal(res.used, keep)
    _same_parameters("sphere", res, r, 10.0)
    used = res.residuals[res.used]
    s = np.sqrt(np.sum(used**2) / (len(used) - 4))
    assert np.abs(used).max() <= 3 * s
    assert res.n_removed >= 40  # the gross outliers went


def test_rule_parsing_and_errors():
    assert str(parse_rule("none")) == "none"
    assert str(parse_rule(" VDI2634 ")) == "vdi2634"
    assert str(parse_rule("percent:5")) == "percent:5"
    assert str(parse_rule("sigma:2.5")) == "sigma:2.5"
    for bad in ("vdi", "percent", "percent:x", "percent:100", "percent:-1", "sigma:0", "sigma:nan", "iso10360"):
        with pytest.raises(ParameterError) as exc:
            parse_rule(bad)
        assert "\n" not in str(exc.value)
    rng = np.random.default_rng(11)
    with pytest.raises(GeometryError, match="too few"):
        fit("sphere", _sphere(rng, 10), "percent:70")
