"""Features (gdt/features.py) exact by construction: signed distances from each nominal
type, selection by band and extent counted point by point, and the associations —
least squares against the fitting plugin, minimum zone / min circumscribed / max
inscribed circles, cylinders and spheres whose contact points are placed by hand
(analytic answers, far from the origin, partial arcs down to 30°), the ISO 5459 tangent
plane of a known profile."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, ParameterError
from camcmm_plugins.fitting.api import fit
from camcmm_plugins.gdt.features import associate, extent_note, select, surface_distance
from camcmm_plugins.gdt.model import FeatureSpec

FAR = np.array([10_000.0, -10_000.0, 10_000.0])
# coordinates 1e4 mm from the origin carry ~2e-12 mm of rounding: answers are held to
# 1e-9 relative of the part's size (10 mm), i.e. 1e-8 mm, where not stated otherwise
TOL = 1e-8


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def _spec(fid, ftype, band=0.5, box=None, association="ls", **nominal):
    nominal = {k: (np.asarray(v, float) if isinstance(v, (list, tuple, np.ndarray)) else v) for k, v in nominal.items()}
    nominal.setdefault("internal", False)
    return FeatureSpec(fid, ftype, nominal, band, None if box is None else np.asarray(box, float), association)


def _all(x):
    return np.arange(len(x))


# -- signed distances -------------------------------------------------------------------


def test_surface_distance_by_construction():
    rng = np.random.default_rng(0)
    rot = _rotation(0)
    ez = rot[:, 2]
    d = rng.uniform(-0.3, 0.3, 500)
    phi = rng.uniform(0, 2 * np.pi, 500)
    z = rng.uniform(1, 20, 500)
    radial = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(500)]) @ rot.T
    axial = np.outer(z, ez)
    # plane: offsets along the normal
    p = FAR + rng.uniform(-50, 50, (500, 3)) @ (rot[:, :2] @ rot[:, :2].T) + np.outer(d, ez)
    np.testing.assert_allclose(surface_distance(p, "plane", {"point": FAR, "normal": 3 * ez}), d, atol=TOL)
    # cylinder r = 5; internal flips the sign
    cyl = {"point": FAR, "axis": ez, "diameter": 10.0}
    x = FAR + axial + (5 + d)[:, None] * radial
    np.testing.assert_allclose(surface_distance(x, "cylinder", cyl), d, atol=TOL)
    np.testing.assert_allclose(surface_distance(x, "cylinder", {**cyl, "internal": True}), -d, atol=TOL)
    # line: the distance from the axis
    np.testing.assert_allclose(surface_distance(x, "line", {"point": FAR, "direction": ez}), 5 + d, atol=TOL)
    # circle in the plane z = 0: sqrt(h² + e²) signed by e
    h = rng.uniform(-0.2, 0.2, 500)
    xc = FAR + np.outer(h, ez) + (5 + d)[:, None] * radial
    want = np.sign(d) * np.hypot(d, h)
    np.testing.assert_allclose(
        surface_distance(xc, "circle", {"centre": FAR, "normal": ez, "diameter": 10.0}), want, atol=TOL
    )
    # sphere and point
    u = rng.normal(size=(500, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    xs = FAR + (7 + d)[:, None] * u
    np.testing.assert_allclose(surface_distance(xs, "sphere", {"centre": FAR, "diameter": 14.0}), d, atol=TOL)
    np.testing.assert_allclose(surface_distance(xs, "point", {"point": FAR}), 7 + d, atol=TOL)
    # cone, half angle 20°, apex at FAR, axis ez: a point at distance d along the normal
    psi = np.radians(20)
    gen = np.cos(psi) * ez + np.sin(psi) * radial  # unit generator directions (rows)
    nrm = np.cos(psi) * radial - np.sin(psi) * ez
    xk = FAR + z[:, None] * gen + d[:, None] * nrm
    np.testing.assert_allclose(surface_distance(xk, "cone", {"apex": FAR, "axis": ez, "angle": 40.0}), d, atol=TOL)
    # beyond the apex: the distance from the apex
    behind = FAR - np.outer(z, ez)
    np.testing.assert_allclose(surface_distance(behind, "cone", {"apex": FAR, "axis": ez, "angle": 40.0}), z, atol=TOL)
    # torus R = 20, r = 3: tube angle β
    beta = rng.uniform(0, 2 * np.pi, 500)
    tube = np.cos(beta)[:, None] * radial + np.sin(beta)[:, None] * ez
    xt = FAR + 20 * radial + (3 + d)[:, None] * tube
    tor = {"centre": FAR, "axis": ez, "major_diameter": 40.0, "minor_diameter": 6.0}
    np.testing.assert_allclose(surface_distance(xt, "torus", tor), d, atol=TOL)
    with pytest.raises(ParameterError, match="no distance for a 'face'"):
        surface_distance(xt, "face", {})


# -- selection ----------------------------------------------------------------------------


def test_select_counts_band_and_box_exactly():
    """A plane's points on a grid at heights inside and outside the band (±0.2 of 0.5),
    some outside the box: exactly the points put in are selected."""
    rot = _rotation(1)
    g = np.stack(np.meshgrid(np.arange(0, 100.0), np.arange(0, 50.0)), -1).reshape(-1, 2)  # 5000 points
    heights = np.tile([0.0, 0.3, -0.49, 0.51, -0.7], len(g) // 5)
    local = np.column_stack([g, heights])
    x = local @ rot.T + FAR
    spec = _spec("A", "plane", 0.5, point=FAR, normal=rot[:, 2])
    warnings = []
    idx = select(x, spec, warnings=warnings)
    assert np.array_equal(idx, np.flatnonzero(np.abs(heights) <= 0.5)) and len(idx) == 3000
    assert len(warnings) == 1 and "extent is unlimited" in warnings[0]
    # a box in the plane's frame is a rotated box in space: use an axis-aligned frame instead
    xa = local + FAR
    boxed = _spec("A", "plane", 0.5, box=FAR + np.array([[10, 5, -1], [59, 44, 1]]), point=FAR, normal=[0, 0, 1])
    idx = select(xa, boxed, warnings=warnings)
    inside = (np.abs(heights) <= 0.5) & (g[:, 0] >= 10) & (g[:, 0] <= 59) & (g[:, 1] >= 5) & (g[:, 1] <= 44)
    assert np.array_equal(idx, np.flatnonzero(inside)) and len(idx) == 50 * 40 * 3 // 5
    assert len(warnings) == 1  # a box bounds it: no second note


def test_select_cylinder_length_and_internal():
    rot = _rotation(2)
    phi = np.radians(np.arange(0, 360, 10.0))
    z = np.arange(-5.5, 36, 1.0)  # 41 heights, 30 of them within [0, 30] (none on its ends)
    P, Z = np.meshgrid(phi, z)
    r = 5 + np.tile([0.0, 0.1, -0.15, 0.25], P.size // 4 + 1)[: P.size].reshape(P.shape)
    local = np.column_stack([(r * np.cos(P)).ravel(), (r * np.sin(P)).ravel(), Z.ravel()])
    x = local @ rot.T + FAR
    spec = _spec("H1", "cylinder", 0.2, point=FAR, axis=rot[:, 2], diameter=10.0, length=30.0, internal=True)
    idx = select(x, spec)
    want = (np.abs(r.ravel() - 5) <= 0.2) & (Z.ravel() >= 0) & (Z.ravel() <= 30)
    assert np.array_equal(idx, np.flatnonzero(want))
    assert extent_note(spec) is None
    no_length = _spec("H1", "cylinder", 0.2, point=FAR, axis=rot[:, 2], diameter=10.0)
    assert "no length or box" in extent_note(no_length)
    assert len(select(x, no_length)) == int((np.abs(r.ravel() - 5) <= 0.2).sum())


def test_select_face_needs_cad():
    spec = FeatureSpec("F1", "face", {"cad": 12, "internal": False}, 0.5)
    with pytest.raises(InputError, match=r"^features\.F1: a CAD face \(cad: 12\) needs a STEP nominal$"):
        select(np.zeros((3, 3)), spec)
    with pytest.raises(InputError, match="cannot be associated"):
        associate(np.zeros((3, 3)), [0, 1, 2], spec)


# -- circles: contact points placed by hand ------------------------------------------------


def _circle_points(rot, r0, pushes, step_deg=1.0):
    """Points every step_deg on a circle of radius r0 about FAR in the plane of rot's
    first two columns; pushes {angle_deg: radial offset}."""
    ang = np.arange(0, 360, step_deg)
    r = np.full(len(ang), r0)
    for a, e in pushes.items():
        r[int(round(a / step_deg))] += e
    t = np.radians(ang)
    return FAR + (r * np.cos(t))[:, None] * rot[:, 0] + (r * np.sin(t))[:, None] * rot[:, 1]


def test_circle_minzone_mincircumscribed_maxinscribed_exact():
    """Three points pushed out by e at 0°, 120°, 240° and three in by e at 60°, 180°,
    300°: min circumscribed r0 + e, max inscribed r0 − e, minimum zone 2e (alternation),
    all about the true centre."""
    rot = _rotation(3)
    r0, e = 5.0, 0.01
    x = _circle_points(rot, r0, {0: e, 120: e, 240: e, 60: -e, 180: -e, 300: -e})
    spec = _spec("C1", "circle", centre=FAR, normal=rot[:, 2], diameter=2 * r0)
    got = {}
    for how, diameter, rng in (
        ("mincircumscribed", 2 * (r0 + e), 2 * e),
        ("maxinscribed", 2 * (r0 - e), 2 * e),
        ("minzone", 2 * r0, 2 * e),
    ):
        a = associate(x, _all(x), spec, how)
        got[how] = a
        assert a.association == how and a.covariance is None
        assert a.params["diameter"] == pytest.approx(diameter, abs=TOL)
        assert np.linalg.norm(a.params["centre"] - FAR) <= TOL
        assert a.form["range"] == pytest.approx(rng, abs=TOL)
    assert got["mincircumscribed"].form["max"] == pytest.approx(0, abs=TOL)
    assert got["maxinscribed"].form["min"] == pytest.approx(0, abs=TOL)
    assert got["minzone"].form["max"] == pytest.approx(e, abs=TOL)
    # a hole: tangent is the max inscribed circle; residuals + outside the material (inwards)
    hole = _spec("C1", "circle", centre=FAR, normal=rot[:, 2], diameter=2 * r0, internal=True)
    a = associate(x, _all(x), hole, "tangent")
    assert a.association == "maxinscribed" and a.params["diameter"] == pytest.approx(2 * (r0 - e), abs=TOL)
    assert a.form["max"] == pytest.approx(0, abs=TOL) and a.form["min"] == pytest.approx(-2 * e, abs=TOL)


@pytest.mark.parametrize("arc", [360, 251])
def test_circle_mincircumscribed_unequal_pushes_is_the_circumcircle(arc):
    """Three points pushed out by different amounts (not within a half circle), on the
    full circle or a 251° arc: the min circumscribed circle is their circumcircle (closed
    form), provided every other point lies inside it (checked)."""
    rot = _rotation(4)
    x = _circle_points(rot, 5.0, {10: 0.02, 130: 0.035, 250: 0.01})[:arc]
    q = np.column_stack([(x - FAR) @ rot[:, 0], (x - FAR) @ rot[:, 1]])
    a_, b_, c_ = q[10], q[130], q[250]
    # circumcentre: |c − a|² = |c − b|² = |c − c_|², two linear equations
    m = 2 * np.array([b_ - a_, c_ - a_])
    rhs = np.array([b_ @ b_ - a_ @ a_, c_ @ c_ - a_ @ a_])
    cc = np.linalg.solve(m, rhs)
    rc = np.linalg.norm(a_ - cc)
    assert np.all(np.linalg.norm(q - cc, axis=1) <= rc + 1e-12)
    a = associate(x, _all(x), _spec("C1", "circle", centre=FAR, normal=rot[:, 2], diameter=10.0), "mincircumscribed")
    assert a.params["diameter"] == pytest.approx(2 * rc, abs=TOL)
    want = FAR + cc[0] * rot[:, 0] + cc[1] * rot[:, 1]
    assert np.linalg.norm(a.params["centre"] - want) <= TOL


def test_circle_minzone_on_a_60_degree_arc():
    """Four alternating contacts ±e on a 60° arc (the alternation of span{1, cos θ, sin θ}
    on an arc shorter than π): the minimum zone is 2e about the constructed circle."""
    rot = _rotation(14)
    r0, e = 40.0, 0.003
    x = _circle_points(rot, r0, {0: e, 20: -e, 40: e, 60: -e}, step_deg=0.5)[:121]
    a = associate(x, _all(x), _spec("C1", "circle", centre=FAR, normal=rot[:, 2], diameter=2 * r0), "minzone")
    assert a.form["range"] == pytest.approx(2 * e, rel=1e-9)
    assert a.params["diameter"] == pytest.approx(2 * r0, abs=TOL)
    assert np.linalg.norm(a.params["centre"] - FAR) <= TOL


# -- cylinders ------------------------------------------------------------------------------


def _cylinder_points(rot, r0, angles_deg, heights, pushes, origin=FAR):
    """Points on a cylinder of radius r0 (axis rot[:, 2] through origin) at the given
    angles and heights; pushes {(angle, height): radial offset}."""
    A, Z = np.meshgrid(np.asarray(angles_deg, float), np.asarray(heights, float))
    r = np.full(A.shape, r0)
    for (a, z), e in pushes.items():
        r[(np.abs(A - a) < 1e-9) & (np.abs(Z - z) < 1e-9)] += e
    t = np.radians(A.ravel())
    rr = r.ravel()
    return (
        origin
        + (rr * np.cos(t))[:, None] * rot[:, 0]
        + (rr * np.sin(t))[:, None] * rot[:, 1]
        + np.outer(Z.ravel(), rot[:, 2])
    )


def test_cylinder_mincircumscribed_maxinscribed_minzone_exact():
    rot = _rotation(5)
    r0, e, length = 5.0, 0.01, 20.0
    out = {(a, z): e for a in (0, 120, 240) for z in (0, length)}
    inn = {(a, z): -e for a in (60, 180, 300) for z in (0, length)}
    x = _cylinder_points(rot, r0, np.arange(0, 360, 5), np.linspace(0, length, 11), {**out, **inn})
    # the plan states the axis reversed (pointing down): the result follows the plan
    top = FAR + length * rot[:, 2]
    spec = _spec("H1", "cylinder", point=top, axis=-rot[:, 2], diameter=2 * r0, length=length)
    for how, diameter in (("mincircumscribed", 2 * (r0 + e)), ("maxinscribed", 2 * (r0 - e)), ("minzone", 2 * r0)):
        a = associate(x, _all(x), spec, how)
        assert a.params["diameter"] == pytest.approx(diameter, abs=TOL), how
        assert a.params["axis"] @ -rot[:, 2] == pytest.approx(1, abs=1e-13)
        assert np.linalg.norm(a.params["point"] - top) <= TOL  # foot at the start of the extent
        assert a.params["length"] == pytest.approx(length, abs=TOL)
        assert a.form["range"] == pytest.approx(2 * e, abs=TOL)
    tangent = associate(x, _all(x), spec, "tangent")  # a shaft: min circumscribed
    assert tangent.association == "mincircumscribed"


@pytest.mark.parametrize("arc", [30.0, 90.0])
def test_cylinder_minzone_on_a_partial_arc_far_from_the_origin(arc):
    """An arc of `arc` degrees, 1e4 mm from the origin: four alternating contacts ±e in
    each end section (+, −, +, −: the alternation that certifies a minimum zone of
    span{1, cos θ, sin θ} on an arc shorter than π, in both sections) → zone 2e, the
    constructed axis and radius."""
    rot = _rotation(6)
    r0, e, length = 25.0, 0.005, 15.0
    angles = np.linspace(-arc / 2, arc / 2, 31)
    contacts = angles[[0, 10, 20, 30]]
    pushes = {(a, z): s * e for z in (0.0, length) for a, s in zip(contacts, (1, -1, 1, -1), strict=True)}
    x = _cylinder_points(rot, r0, angles, np.linspace(0, length, 7), pushes)
    spec = _spec("H1", "cylinder", point=FAR, axis=rot[:, 2], diameter=2 * r0, length=length)
    a = associate(x, _all(x), spec, "minzone")
    assert a.form["range"] == pytest.approx(2 * e, rel=1e-9)
    assert a.params["diameter"] == pytest.approx(2 * r0, abs=TOL)
    assert np.linalg.norm(a.params["point"] - FAR) <= TOL
    assert np.linalg.norm(np.cross(a.params["axis"], rot[:, 2])) <= 1e-11
    ls = associate(x, _all(x), spec, "ls")
    assert a.form["range"] <= ls.form["range"]
    with pytest.raises(GeometryError, match=r"^features\.H1: mincircumscribed needs points around more than half"):
        associate(x, _all(x), spec, "mincircumscribed")


# -- spheres --------------------------------------------------------------------------------


def test_sphere_mincircumscribed_maxinscribed_exact():
    """Outer contacts at a regular tetrahedron's vertices on r0 + e, inner ones at the
    opposite tetrahedron on r0 − e, the rest on r0 (a Fibonacci sphere): the min
    circumscribed sphere r0 + e, the max inscribed r0 − e, about the centre."""
    rot = _rotation(7)
    r0, e = 10.0, 0.02
    n = 1500
    k = np.arange(n) + 0.5
    u = np.column_stack(
        [
            np.cos(np.pi * (1 + 5**0.5) * k) * np.sqrt(1 - (1 - 2 * k / n) ** 2),
            np.sin(np.pi * (1 + 5**0.5) * k) * np.sqrt(1 - (1 - 2 * k / n) ** 2),
            1 - 2 * k / n,
        ]
    )
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) / np.sqrt(3) @ rot.T
    x = np.vstack([FAR + r0 * u, FAR + (r0 + e) * tet, FAR - (r0 - e) * tet])
    spec = _spec("S1", "sphere", centre=FAR, diameter=2 * r0)
    for how, diameter in (("mincircumscribed", 2 * (r0 + e)), ("maxinscribed", 2 * (r0 - e))):
        a = associate(x, _all(x), spec, how)
        assert a.params["diameter"] == pytest.approx(diameter, abs=TOL)
        assert np.linalg.norm(a.params["centre"] - FAR) <= TOL
    cap = x[(x - FAR) @ rot[:, 2] > 3]
    with pytest.raises(GeometryError, match="points all around the sphere"):
        associate(cap, _all(cap), spec, "maxinscribed")


# -- planes and lines -------------------------------------------------------------------------


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_tangent_plane_of_a_tilted_profile(side):
    """Points on the plane z = s·x with dents (depth up to 0.03) inside their hull: the
    outer tangent plane (ISO 5459 minimax outside the material) is z = s·x itself; with
    the material on the other side (normal −z) it is that plane lowered by the deepest
    dent (both faces of the minimum zone)."""
    rng = np.random.default_rng(8)
    s = 0.002
    g = np.stack(np.meshgrid(np.linspace(0, 80, 41), np.linspace(0, 60, 31)), -1).reshape(-1, 2)
    z = s * g[:, 0]
    inner = (g[:, 0] > 5) & (g[:, 0] < 75) & (g[:, 1] > 5) & (g[:, 1] < 55)
    dent = np.where(inner & (rng.uniform(size=len(g)) < 0.3), -rng.uniform(0, 0.03, len(g)), 0.0)
    deepest = int(np.argmin(dent))
    dent[deepest] = -0.03
    x = np.column_stack([g, z + dent]) + FAR
    spec = _spec("A", "plane", 0.1, association="tangent", point=FAR, normal=[0, 0, side])
    a = associate(x, _all(x), spec)
    n_true = np.array([-s, 0, 1]) / np.hypot(s, 1) * side
    assert a.association == "tangent" and a.covariance is None
    assert np.linalg.norm(a.params["normal"] - n_true) <= 1e-12
    on_plane = FAR if side > 0 else x[deepest]
    assert abs((on_plane - a.params["point"]) @ a.params["normal"]) <= TOL
    assert a.form["max"] == pytest.approx(0, abs=TOL)  # no point beyond it: outside the material
    assert a.form["min"] == pytest.approx(-0.03 / np.hypot(s, 1), abs=TOL)


def test_line_minzone_is_the_thinnest_cylinder():
    """Straightness in space: points along a line with offsets e at 0°, 120°, 240° at
    both ends and smaller ones between: the zone is the cylinder of diameter 2e."""
    rot = _rotation(9)
    e = 0.004
    t = np.linspace(0, 50, 51)
    rng = np.random.default_rng(9)
    phi = rng.uniform(0, 2 * np.pi, len(t))
    rad = rng.uniform(0, 0.8 * e, len(t))
    pts = [
        FAR + ti * rot[:, 2] + ri * (np.cos(p) * rot[:, 0] + np.sin(p) * rot[:, 1])
        for ti, p, ri in zip(t, phi, rad, strict=True)
    ]
    for ti in (0.0, 50.0):
        for a in np.radians([0, 120, 240]):
            pts.append(FAR + ti * rot[:, 2] + e * (np.cos(a) * rot[:, 0] + np.sin(a) * rot[:, 1]))
    x = np.array(pts)
    spec = _spec("L1", "line", 0.1, point=FAR, direction=rot[:, 2])
    a = associate(x, _all(x), spec, "minzone")
    assert a.params["zone"] == pytest.approx(2 * e, abs=TOL)
    assert a.form["max"] == pytest.approx(e, abs=TOL)
    assert np.linalg.norm(a.params["point"] - FAR) <= TOL and a.params["length"] == pytest.approx(50, abs=TOL)


def test_refused_associations_and_fallbacks():
    x = _cylinder_points(_rotation(10), 5.0, np.arange(0, 360, 10), np.linspace(0, 10, 5), {})
    plane = _spec("A", "plane", point=FAR, normal=[0, 0, 1])
    with pytest.raises(
        ParameterError, match=r"^features\.A: association mincircumscribed is for a circle, cylinder or sphere"
    ):
        associate(x, _all(x), plane, "mincircumscribed")
    with pytest.raises(ParameterError, match=r"^features\.A: unknown association 'best'"):
        associate(x, _all(x), plane, "best")
    with pytest.raises(GeometryError, match=r"^features\.A: no points belong to it$"):
        associate(x, [], plane)
    with pytest.raises(InputError, match=r"^features\.A: point index 999 is outside the 180 points$"):
        associate(x, [0, 1, 999], plane)
    bad = x.copy()
    bad[1, 2] = np.nan
    with pytest.raises(InputError, match=r"^features\.A: its points have NaN"):
        associate(bad, _all(bad), plane)
    with pytest.raises(GeometryError, match=r"^features\.H: cylinder fit needs at least 5 points"):
        associate(x[:3], [0, 1, 2], _spec("H", "cylinder", point=FAR, axis=[0, 0, 1], diameter=10.0), "ls")


# -- least squares against the fitting plugin ---------------------------------------------------


def _noisy(kind, rng, n=1500):
    rot = _rotation(11)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    noise = rng.normal(scale=0.002, size=n)
    if kind == "sphere":
        return FAR + (6 + noise)[:, None] * u, {"centre": FAR, "diameter": 12.0}
    phi = rng.uniform(0, np.radians(120), n)
    z = rng.uniform(0, 20, n)
    radial = np.cos(phi)[:, None] * rot[:, 0] + np.sin(phi)[:, None] * rot[:, 1]
    if kind == "cylinder":
        return FAR + np.outer(z, rot[:, 2]) + (8 + noise)[:, None] * radial, {
            "point": FAR,
            "axis": rot[:, 2],
            "diameter": 16.0,
        }
    if kind == "plane":
        return FAR + rng.uniform(-20, 20, (n, 2)) @ rot[:, :2].T + np.outer(noise, rot[:, 2]), {
            "point": FAR,
            "normal": rot[:, 2],
        }
    if kind == "cone":
        psi = np.radians(25)
        gen = np.cos(psi) * rot[:, 2] + np.sin(psi) * radial
        nrm = np.cos(psi) * radial - np.sin(psi) * rot[:, 2]
        return FAR + (z + 5)[:, None] * gen + noise[:, None] * nrm, {"apex": FAR, "axis": rot[:, 2], "angle": 50.0}
    if kind == "torus":
        beta = rng.uniform(0, 2 * np.pi, n)
        tube = np.cos(beta)[:, None] * radial + np.sin(beta)[:, None] * rot[:, 2]
        return FAR + 20 * radial + (4 + noise)[:, None] * tube, {
            "centre": FAR,
            "axis": rot[:, 2],
            "major_diameter": 40.0,
            "minor_diameter": 8.0,
        }
    if kind == "line":
        w = rng.normal(scale=0.002, size=(n, 3))
        return FAR + np.outer(z * 2, rot[:, 2]) + w - np.outer(w @ rot[:, 2], rot[:, 2]), {
            "point": FAR,
            "direction": rot[:, 2],
        }
    t = rng.uniform(0, 2 * np.pi, n)
    ring = np.cos(t)[:, None] * rot[:, 0] + np.sin(t)[:, None] * rot[:, 1]
    return FAR + (7 + noise)[:, None] * ring, {"centre": FAR, "normal": rot[:, 2], "diameter": 14.0}


@pytest.mark.parametrize("kind", ["line", "plane", "circle", "cylinder", "sphere", "cone", "torus"])
def test_ls_matches_the_fitting_plugin(kind):
    """associate(ls) is fit.<element> by id: the same element and residuals; its
    covariance (recomputed in the global names) gives the plugin's standard
    uncertainties of the sizes and positions it shares."""
    rng = np.random.default_rng(12)
    x, nominal = _noisy(kind, rng, n=500 if kind == "torus" else 1500)  # a torus' start search costs 1.6 s at 1500
    spec = _spec("F", kind, 0.5, **nominal)
    a = associate(x, _all(x), spec, "ls")
    ref = fit(kind, x)
    p = ref.params
    names = list(a.covariance_names)
    sd = dict(zip(names, np.sqrt(np.diag(a.covariance)), strict=True))
    if kind in ("circle", "cylinder", "sphere"):
        assert a.params["diameter"] == pytest.approx(2 * p["radius"], rel=1e-12)
        assert sd["diameter"] == pytest.approx(2 * ref.std_uncertainty["radius"], rel=1e-5)
    if kind in ("circle", "sphere"):
        assert np.linalg.norm(a.params["centre"] - p["center"]) <= 1e-9
    if kind == "sphere":
        np.testing.assert_allclose(
            [sd["centre_x"], sd["centre_y"], sd["centre_z"]], ref.std_uncertainty["center"], rtol=1e-5
        )
    if kind == "plane":
        np.testing.assert_allclose(a.params["point"], p["point"], atol=1e-9)
        np.testing.assert_allclose(
            [sd["point_x"], sd["point_y"], sd["point_z"]], ref.std_uncertainty["point"], rtol=1e-5
        )
        np.testing.assert_allclose(
            [sd["normal_x"], sd["normal_y"], sd["normal_z"]], ref.std_uncertainty["normal"], rtol=1e-5
        )
    if kind == "line":  # the plugin's point is the centroid's foot, this one the start of the extent
        assert np.linalg.norm(np.cross(a.params["direction"], p["direction"])) <= 1e-12
        np.testing.assert_allclose(
            [sd["direction_x"], sd["direction_y"], sd["direction_z"]], ref.std_uncertainty["direction"], rtol=1e-5
        )
    if kind == "cone":
        assert a.params["angle"] == pytest.approx(p["angle"], rel=1e-12)
        assert sd["angle"] == pytest.approx(ref.std_uncertainty["angle"], rel=1e-5)
        np.testing.assert_allclose(a.params["apex"], p["apex"], atol=1e-9)
    if kind == "torus":
        assert a.params["minor_diameter"] == pytest.approx(2 * p["minor_radius"], rel=1e-12)
        assert sd["minor_diameter"] == pytest.approx(2 * ref.std_uncertainty["minor_radius"], rel=1e-5)
        assert sd["major_diameter"] == pytest.approx(2 * ref.std_uncertainty["major_radius"], rel=1e-5)
    if kind != "circle":  # a circle's residuals are radial in its plane (planar points here)
        np.testing.assert_allclose(a.residuals, ref.residuals, atol=1e-9)
    assert a.form["rms"] == pytest.approx(ref.form["rms"], rel=1e-6)
    assert a.n_points == len(x) and a.covariance.shape == (len(names), len(names))


def test_point_feature_and_tangent_fallback():
    """A point feature is its points' centroid (covariance s²/n per axis);
    a cone has no ISO 5459 tangent association: least squares, with a warning."""
    rng = np.random.default_rng(13)
    x = FAR + rng.normal(scale=0.01, size=(200, 3))
    a = associate(x, _all(x), _spec("P", "point", point=FAR), "tangent")
    np.testing.assert_allclose(a.params["point"], x.mean(axis=0), atol=1e-9)
    assert a.association == "ls" and "no tangent (ISO 5459) association for a point" in a.warnings[0]
    want = np.sum((x - x.mean(axis=0)) ** 2) / (3 * len(x) - 3) / len(x)  # s² / n, s² pooled over x, y, z
    np.testing.assert_allclose(np.diag(a.covariance), want, rtol=1e-6)
    xk, nominal = _noisy("cone", rng, n=600)
    k = associate(xk, _all(xk), _spec("K", "cone", **nominal), "tangent")
    assert k.association == "ls" and "no tangent (ISO 5459) association for a cone" in k.warnings[0]


class _FakeCad:
    """A CAD model's interface as select/resolve_face use it (faces, distance): face 1
    the plane z = 0 (outward −z: the part lies above it), face 2 a bore of radius 4 about
    the z axis (sense −1), distances to each exact surface, the nearest face wins."""

    def __init__(self):
        from types import SimpleNamespace

        self.faces = [
            SimpleNamespace(
                type="plane",
                params={"point": [0, 0, 0], "normal": [0, 0, -1]},
                bounds=np.array([[-20, -20, 0], [20, 20, 0]]),
                sense=1,
            ),
            SimpleNamespace(
                type="cylinder",
                params={"point": [0, 0, 0], "axis": [0, 0, 1], "diameter": 8.0},
                bounds=np.array([[-4, -4, 0], [4, 4, 10]]),
                sense=-1,
            ),
        ]

    def distance(self, x):
        d1 = -x[:, 2]
        d2 = 4 - np.hypot(x[:, 0], x[:, 1])
        face = np.where(np.abs(d1) <= np.abs(d2), 1, 2)
        return np.where(face == 1, d1, d2), x, face


def test_face_features_select_and_resolve():
    from camcmm_plugins.gdt.features import resolve_face

    cad = _FakeCad()
    phi = np.radians(np.arange(0, 360, 10.0))
    bore = np.array([[r * np.cos(p), r * np.sin(p), z] for p in phi for z in (2.0, 5.0, 8.0) for r in (3.9, 4.0, 4.3)])
    floor = np.array([[x, y, z] for x in (-15.0, -8.0, 8.0, 15.0) for y in (-15.0, 15.0) for z in (0.1, -0.2, 0.6)])
    pts = np.vstack([bore, floor])
    f2 = FeatureSpec("B", "face", {"cad": 2, "internal": False}, 0.2)
    idx = select(pts, f2, cad)
    assert np.array_equal(
        idx,
        np.flatnonzero(
            np.isclose(np.hypot(pts[:, 0], pts[:, 1]), 3.9) | np.isclose(np.hypot(pts[:, 0], pts[:, 1]), 4.0)
        ),
    )
    f1 = FeatureSpec("A", "face", {"cad": 1, "internal": False}, 0.5)
    assert np.array_equal(select(pts, f1, cad), len(bore) + np.flatnonzero(np.abs(floor[:, 2]) <= 0.5))
    with pytest.raises(InputError, match=r"^features\.A\.cad: face 3 does not exist \(the CAD has 2\)$"):
        select(pts, FeatureSpec("A", "face", {"cad": 3, "internal": False}, 0.5), cad)
    bore_spec = resolve_face(f2, cad)
    assert bore_spec.type == "cylinder" and bore_spec.nominal["internal"] is True  # from the face's sense
    np.testing.assert_array_equal(bore_spec.box, [[-4.2, -4.2, -0.2], [4.2, 4.2, 10.2]])
    a = associate(pts, idx, bore_spec, "tangent")  # a hole: the max inscribed cylinder touches the 3.9 ring
    assert a.association == "maxinscribed" and a.params["diameter"] == pytest.approx(7.8, abs=1e-12)
    # + outside the material (towards the axis of a hole): the 3.9 ring at 0, the 4.0 ring 0.1 into the material
    assert a.form["max"] == pytest.approx(0, abs=1e-12) and a.form["min"] == pytest.approx(-0.1, abs=1e-12)
    plane = resolve_face(f1, cad)
    np.testing.assert_array_equal(plane.nominal["normal"], [0, 0, -1])


def test_step_faces_as_features():
    """NIST CTC 01 (AP242 STEP): points sampled on the exact surfaces of a bore half
    (face 1, Ø25), a boss quarter (face 4, Ø100) and a bore (face 10, Ø50); each face
    feature selects exactly its own points, resolves to an (internal) cylinder and its
    least-squares diameter is the CAD's to 1e-9 relative."""
    pytest.importorskip("OCP")
    from camcmm.api import read_cad
    from camcmm_plugins.gdt.features import resolve_face
    from helpers.paths import TEST_DATA

    step = TEST_DATA / "nist_pmi" / "nist_ctc_01_asme1_ap242-e1.stp"  # a copy (public domain, SOURCE.txt there)
    cad = read_cad(step)
    faces = (1, 4, 10)
    clouds = [cad.sample(face=f, n=300, seed=f).points for f in faces]
    x = np.vstack(clouds)
    label = np.repeat(faces, [len(c) for c in clouds])
    for f, internal in zip(faces, (True, False, True), strict=True):
        spec = FeatureSpec(f"F{f}", "face", {"cad": f, "internal": False}, 0.05)
        idx = select(x, spec, cad)
        assert np.array_equal(idx, np.flatnonzero(label == f))
        cyl = resolve_face(spec, cad)
        assert cyl.type == "cylinder" and cyl.nominal["internal"] is internal
        a = associate(x, idx, cyl, "ls")
        assert a.params["diameter"] == pytest.approx(cyl.nominal["diameter"], rel=1e-9)
        assert a.form["range"] <= 1e-9
