"""Sizes (gdt/size.py) exact by construction: a cylinder of elliptical section (semi-axes
a > b) has two-point sizes ranging exactly over [2b, 2a], a minimum circumscribed
diameter 2a, a maximum inscribed 2b and a minimum-zone mean diameter a + b; a sphere
with an even radial deviation has two-point sizes 2ρ; two parallel faces a width W."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import ParameterError
from camcmm_plugins.fitting.api import fit
from camcmm_plugins.gdt.features import associate
from camcmm_plugins.gdt.model import FeatureSpec
from camcmm_plugins.gdt.size import global_size, two_point_sizes, width

FAR = np.array([10_000.0, -10_000.0, 10_000.0])
A, B = 5.02, 4.98


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def _elliptic_cylinder(rot, heights, step_deg=1.0):
    t = np.radians(np.arange(0, 360, step_deg))
    T, Z = np.meshgrid(t, np.asarray(heights, float))
    local = np.column_stack([(A * np.cos(T)).ravel(), (B * np.sin(T)).ravel(), Z.ravel()])
    return local @ rot.T + FAR


def _spec(ftype, **nominal):
    nominal = {k: (np.asarray(v, float) if isinstance(v, (list, np.ndarray)) else v) for k, v in nominal.items()}
    nominal.setdefault("internal", False)
    return FeatureSpec("F", ftype, nominal, 0.5)


def test_two_point_sizes_of_an_elliptical_cylinder():
    rot = _rotation(1)
    x = _elliptic_cylinder(rot, np.linspace(0, 20, 11))
    spec = _spec("cylinder", point=FAR, axis=rot[:, 2], diameter=10.0, length=20.0)
    ls = associate(x, np.arange(len(x)), spec, "ls")
    sizes = two_point_sizes(x, ls)
    assert len(sizes) == len(x)  # every point has its sampled antipode
    assert sizes.min() == pytest.approx(2 * B, rel=1e-12)
    assert sizes.max() == pytest.approx(2 * A, rel=1e-12)
    # each size is the chord through the centre at that point's angle: 2 ρ(t)
    t = np.radians(np.tile(np.arange(0, 360, 1.0), 11))
    want = 2 * np.hypot(A * np.cos(t), B * np.sin(t))
    np.testing.assert_allclose(np.sort(sizes), np.sort(want), rtol=1e-12)
    # slabs of a thickness (1.3 mm: each holds one section) instead of the distinct heights
    np.testing.assert_allclose(np.sort(two_point_sizes(x, ls, thickness=1.3)), np.sort(want), rtol=1e-12)


def test_global_sizes_of_an_elliptical_cylinder():
    """GN = 2a (the circle on the major axis encloses the ellipse), GX = 2b, GC mean
    diameter a + b (alternation at 0°, 90°, 180°, 270°), GG the fitting plugin's."""
    rot = _rotation(2)
    x = _elliptic_cylinder(rot, np.linspace(0, 12, 5), step_deg=2.0)
    spec = _spec("cylinder", point=FAR, axis=rot[:, 2], diameter=10.0)
    ls = associate(x, np.arange(len(x)), spec, "ls")
    assert global_size(x, ls, "ls") == 2 * fit("cylinder", x).params["radius"]
    assert global_size(x, ls, "mincircumscribed") == pytest.approx(2 * A, rel=1e-11)
    assert global_size(x, ls, "maxinscribed") == pytest.approx(2 * B, rel=1e-11)
    assert global_size(x, ls, "minzone") == pytest.approx(A + B, rel=1e-11)
    with pytest.raises(ParameterError, match="unknown size criterion 'biggest'"):
        global_size(x, ls, "biggest")


def test_circle_section_and_partial_arc():
    rot = _rotation(3)
    t = np.radians(np.arange(0, 360, 1.0))
    x = FAR + (A * np.cos(t))[:, None] * rot[:, 0] + (B * np.sin(t))[:, None] * rot[:, 1]
    spec = _spec("circle", centre=FAR, normal=rot[:, 2], diameter=10.0)
    c = associate(x, np.arange(len(x)), spec, "ls")
    sizes = two_point_sizes(x, c)
    assert (sizes.min(), sizes.max()) == (pytest.approx(2 * B, rel=1e-12), pytest.approx(2 * A, rel=1e-12))
    # a 120° arc: no point has an opposite
    arc = np.flatnonzero(np.arange(360) < 120)
    c_arc = associate(x, arc, spec, "ls")
    assert len(two_point_sizes(x, c_arc)) == 0


def test_two_point_sizes_of_a_sphere():
    """Antipodal point pairs on ρ(u) = r + c (u_z² − 1/3), an even deviation: each
    pair's size is 2ρ."""
    rng = np.random.default_rng(4)
    u = rng.normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    u = np.vstack([u, -u])
    rho = 10 + 0.01 * (u[:, 2] ** 2 - 1 / 3)
    x = FAR + rho[:, None] * u
    s = associate(x, np.arange(len(x)), _spec("sphere", centre=FAR, diameter=20.0), "ls")
    np.testing.assert_allclose(np.linalg.norm(s.params["centre"] - FAR), 0, atol=1e-9)
    sizes = two_point_sizes(x, s)
    np.testing.assert_allclose(np.sort(sizes), np.sort(2 * rho), atol=1e-9)


def test_width_between_two_parallel_faces():
    rot = _rotation(5)
    rng = np.random.default_rng(5)
    w = 12.345
    p1 = rng.uniform(-20, 20, (300, 2))
    p2 = rng.uniform(-20, 20, (250, 2))
    x = np.vstack([np.column_stack([p1, np.zeros(300)]), np.column_stack([p2, np.full(250, w)])]) @ rot.T + FAR
    sides = [
        associate(x, idx, _spec("plane", point=FAR + z * rot[:, 2], normal=n * rot[:, 2]), "ls")
        for idx, z, n in ((np.arange(300), 0.0, -1.0), (np.arange(300, 550), w, 1.0))
    ]
    assert width(x, *sides) == pytest.approx(w, rel=1e-12)
    with pytest.raises(ParameterError, match="a global size is a diameter"):
        global_size(x, sides[0], "ls")
