"""ISO 1101 characteristics (gdt/characteristics.py), each against its analytic value on a
part built exactly: the issue's bore position, the same part in a scanner's frame, tilts,
minimum zones of known width, runout of an eccentric cylinder, coaxiality, profile,
symmetry, sizes; verdicts at and around the limits; meaningless cases warned."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.gdt import features
from camcmm_plugins.gdt import uncertainty as unc
from camcmm_plugins.gdt.characteristics import evaluate_characteristic
from camcmm_plugins.gdt.datums import datum_frame
from camcmm_plugins.gdt.model import Associated
from camcmm_plugins.gdt.plan import parse_plan
from helpers import gdt_parts as gp


def evaluate(doc: dict, points: np.ndarray, select_points: np.ndarray | None = None, sets: dict | None = None) -> dict:
    """Every characteristic of the plan ``doc`` on ``points``; features selected on
    ``select_points`` (plan coordinates; default the points) or given as index ``sets``,
    and associated on ``points``."""
    plan = parse_plan(doc, "plan.yaml")
    sel = points if select_points is None else select_points
    assoc = {}
    for fid, spec in plan.features.items():
        idx = sets[fid] if sets is not None else features.select(sel, spec)
        if len(idx):
            assoc[fid] = features.associate(points, idx, spec)
    frames = lambda labels: datum_frame(plan, assoc, labels)  # noqa: E731
    return {c.id: evaluate_characteristic(c, plan, points, assoc, frames) for c in plan.characteristics}


def block_doc(chars: list[dict]) -> dict:
    return gp.plan_document(characteristics=chars)


POS = {"id": "pos", "type": "position", "feature": "H1", "datums": ["A", "B", "C"], "tolerance": 0.2}


def test_issue_bore_position():
    """Axis offset (0.02, −0.01) at the bottom face and (0.05, 0.03) at the top in A|B|C
    → 2·|(0.05, 0.03)| = 0.116619 mm (the issue's 0.1166)."""
    res = evaluate(block_doc([POS]), gp.block().points)["pos"]
    assert res.value == pytest.approx(gp.POSITION_H1, abs=1e-9)
    assert round(res.value, 4) == 0.1166
    assert res.verdict == "conform" and res.verdict_guarded == "conform"
    assert res.u is not None and res.u < 1e-9  # exact points: the fit has no residuals
    # the bore by the covariance of its fit, the tangent datums A|B|C by Monte Carlo
    assert res.u_method.split(" + ") == [
        "covariance of the least-squares fit",
        "monte-carlo of the datum frame: 20 replicates of the datum features' points",
    ]
    # the decisive points are the bore's points nearest its top
    part = gp.block()
    assert np.all(part.surface[res.decisive] == part.names.index("H1"))
    assert np.all(part.points[res.decisive, 2] > 25)


def test_scanner_frame_gives_the_same_values():
    """The same part delivered rotated 30° about a skew axis and 500 mm away: through the
    datum frame every value is the same."""
    chars = [
        POS,
        {"id": "perp-H1", "type": "perpendicularity", "feature": "H1", "datums": ["A"], "tolerance": 0.1},
        {"id": "perp-D", "type": "perpendicularity", "feature": "D", "datums": ["A"], "tolerance": 0.1},
        {"id": "flat-A", "type": "flatness", "feature": "A", "tolerance": 0.1},
        {"id": "dia-H1", "type": "diameter", "feature": "H1", "lower": -0.02, "upper": 0.02},
    ]
    kw = {"tilt_d": 0.002, "bow_a": 0.004}
    here = evaluate(block_doc(chars), gp.block(**kw).points)
    part = gp.block(pose=gp.SCANNER_POSE, **kw)
    there = evaluate(block_doc(chars), part.points, part.plan_points())
    for cid in here:
        assert there[cid].value == pytest.approx(here[cid].value, abs=1e-9), cid


def grid(origin, u, v, nu: int = 9, nv: int = 7) -> np.ndarray:
    """Points origin + i·u/(nu−1) + j·v/(nv−1) on a regular grid (corners included)."""
    i, j = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv))
    return np.asarray(origin, float) + np.outer(i.ravel(), u) + np.outer(j.ravel(), v)


PLANES = {
    "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1], "box": [[-1, -1, -1], [81, 61, 1]]},
    "D": {"type": "plane", "point": [80, 0, 0], "normal": [1, 0, 0], "box": [[79, 0.5, 0.5], [81, 59.5, 29.5]]},
    "T": {"type": "plane", "point": [0, 0, 30], "normal": [0, 0, 1], "box": [[-1, -1, 29], [81, 61, 31]]},
}


def tilted_d(t: float) -> np.ndarray:
    """A (z = 0, 80 × 60) and D: x = 80 + t·z over y 1..59, z 1..29 (grids)."""
    a = grid([0, 0, 0], [80, 0, 0], [0, 60, 0])
    d = grid([80 + t, 1, 1], [0, 58, 0], [28 * t, 0, 28])
    return np.vstack([a, d])


@pytest.mark.parametrize("t", [0.0, 0.002, -0.003])
def test_perpendicularity_of_a_tilted_plane_is_the_tilt_over_its_extent(t):
    """D tilted by t (x = 80 + t·z), perpendicular to A: the zone of two planes normal to
    A holding D is |t| times D's 28 mm extent in z (the free rotation about A's normal
    cannot narrow it: the grid holds the four corners)."""
    ch = {"id": "perp-D", "type": "perpendicularity", "feature": "D", "datums": ["A"], "tolerance": 0.05}
    doc = {"features": {k: PLANES[k] for k in "AD"}, "datums": {"A": "A"}, "characteristics": [ch]}
    pts = tilted_d(t)
    res = evaluate(doc, pts)["perp-D"]
    assert res.value == pytest.approx(abs(t) * 28, abs=1e-9)
    if t:
        assert set(np.round(pts[res.decisive, 2], 9)) == {1.0, 29.0}


def test_perpendicularity_of_an_axis():
    """The bore's axis runs from (0.02, −0.01) to (0.05, 0.03) over 30 mm: the diametral
    zone perpendicular to A holding it is |(0.03, 0.04)| = 0.05 mm."""
    ch = {"id": "perp", "type": "perpendicularity", "feature": "H1", "datums": ["A"], "tolerance": 0.05}
    res = evaluate(block_doc([ch]), gp.block().points)["perp"]
    assert res.value == pytest.approx(0.05, abs=1e-9)


def _grid_plane(a: float, n: int = 24, size: float = 40.0) -> np.ndarray:
    """z = a·cos(2πx/λ)·cos(2πy/λ) over whole periods on a symmetric grid: minimum zone
    (horizontal by symmetry) 2a."""
    u = np.linspace(0, size, n + 1)
    x, y = np.meshgrid(u, u)
    lam = size / 2
    z = a * np.cos(2 * np.pi * x / lam) * np.cos(2 * np.pi * y / lam)
    return np.c_[x.ravel(), y.ravel(), z.ravel()]


def test_flatness_minimum_zone():
    pts = _grid_plane(0.01)
    doc = {
        "features": {"P": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "band": 1}},
        "characteristics": [{"id": "flat", "type": "flatness", "feature": "P", "tolerance": 0.05}],
    }
    res = evaluate(doc, pts)["flat"]
    assert res.value == pytest.approx(0.02, abs=1e-9)
    assert res.u_method.startswith("monte-carlo")
    assert np.all(np.isclose(np.abs(pts[res.decisive, 2]), 0.01))


# ---- synthetic elements -------------------------------------------------------------------


def ring(centre, radius, n: int = 72, lobes: int = 0, amp: float = 0.0, normal=(0, 0, 1)) -> np.ndarray:
    """n points of a circle about ``centre`` normal to ``normal``, radius + amp·cos(lobes·θ)."""
    a = np.asarray(normal, float) / np.linalg.norm(normal)
    e1 = np.cross(a, [0.0, 1.0, 0.0]) if abs(a[1]) < 0.9 else np.cross(a, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    th = 2 * np.pi * np.arange(n) / n
    r = radius + amp * np.cos(lobes * th)
    return np.asarray(centre, float) + np.outer(r * np.cos(th), e1) + np.outer(r * np.sin(th), e2)


def cloud(**parts: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """All parts stacked, with each part's indices."""
    pts, sets, start = [], {}, 0
    for name, p in parts.items():
        pts.append(p)
        sets[name] = np.arange(start, start + len(p))
        start += len(p)
    return np.vstack(pts), sets


def run(features_doc: dict, chars: list[dict], datums: dict | None = None, **parts: np.ndarray) -> dict:
    pts, sets = cloud(**parts)
    doc = {"features": features_doc, "datums": datums or {}, "characteristics": chars}
    return evaluate(doc, pts, sets=sets)


CIRCLE = {"type": "circle", "centre": [0, 0, 0], "normal": [0, 0, 1], "diameter": 20}
CYL_Z = {"type": "cylinder", "point": [0, 0, 0], "axis": [0, 0, 1], "diameter": 20, "length": 30}


def test_roundness_of_a_three_lobed_circle():
    """r = 10 + a·cos 3θ: the minimum-zone circles are centred (symmetry), 2a apart."""
    ch = [{"id": "r", "type": "roundness", "feature": "C", "tolerance": 0.01}]
    res = run({"C": CIRCLE}, ch, C=ring([0, 0, 0], 10, lobes=3, amp=0.002))["r"]
    assert res.value == pytest.approx(0.004, abs=1e-9)
    assert len(res.decisive) >= 4


def test_roundness_of_a_cylinder_is_its_worst_section():
    amps = [0.001, 0.004, 0.002, 0.003]
    rings = np.vstack([ring([0, 0, z], 10, lobes=3, amp=a) for z, a in zip([0, 10, 20, 30], amps, strict=True)])
    ch = [{"id": "r", "type": "roundness", "feature": "Z", "tolerance": 0.01, "sections": 4}]
    res = run({"Z": CYL_Z}, ch, Z=rings)["r"]
    assert res.value == pytest.approx(2 * max(amps), abs=1e-9)
    assert np.all(np.isclose(rings[res.decisive, 2], 10.0))


def test_cylindricity_of_a_lobed_cylinder():
    rings = np.vstack([ring([0, 0, z], 10, lobes=3, amp=0.0025) for z in (0, 10, 20, 30)])
    ch = [{"id": "cyl", "type": "cylindricity", "feature": "Z", "tolerance": 0.01}]
    res = run({"Z": CYL_Z}, ch, Z=rings)["cyl"]
    assert res.value == pytest.approx(0.005, abs=1e-9)


def test_straightness_is_the_thinnest_cylinder():
    """The same triangle of circumradius a about the x axis at x = 0, 25, 50 and points
    inside it between: the thinnest cylinder holding them has diameter 2a."""
    a = 0.003
    th = np.radians([90, 210, 330])
    tri = np.c_[np.zeros(3), a * np.cos(th), a * np.sin(th)]
    ends = [tri + [x, 0, 0] for x in (0, 25, 50)]
    k = np.arange(40)
    inner = np.c_[1 + k * 1.2, 0.4 * a * np.cos(k), 0.4 * a * np.sin(k)]
    line = {"type": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "length": 50}
    ch = [{"id": "s", "type": "straightness", "feature": "L", "tolerance": 0.01}]
    res = run({"L": line}, ch, L=np.vstack([*ends, inner]))["s"]
    assert res.value == pytest.approx(2 * a, abs=1e-9)
    assert len(res.decisive) == 9


DATUM_CYL = {"type": "cylinder", "point": [0, 0, 0], "axis": [0, 0, 1], "diameter": 20, "length": 10}
SHAFT = {"type": "cylinder", "point": [0, 0, 20], "axis": [0, 0, 1], "diameter": 10, "length": 20}


def shaft(bottom, top, zs=(20, 25, 30, 35, 40)) -> np.ndarray:
    """A cylinder of radius 5 whose axis runs from ``bottom`` (x, y at z = 20) to ``top``
    (at z = 40): rings normal to that axis about its points at heights ``zs``."""
    b, t = np.array([*bottom, 20.0]), np.array([*top, 40.0])
    return np.vstack([ring(b + (t - b) * (z - 20) / 20, 5, normal=t - b) for z in zs])


def datum_journal() -> np.ndarray:
    return np.vstack([ring([0, 0, z], 10) for z in (0, 5, 10)])


def test_runout_of_an_eccentric_cylinder_is_twice_the_eccentricity():
    e = 0.01
    ch = [
        {"id": "cr", "type": "circular-runout", "feature": "F", "datums": ["D"], "tolerance": 0.05, "sections": 5},
        {"id": "tr", "type": "total-runout", "feature": "F", "datums": ["D"], "tolerance": 0.05},
    ]
    res = run({"D": DATUM_CYL, "F": SHAFT}, ch, {"D": "D"}, D=datum_journal(), F=shaft([e, 0], [e, 0]))
    assert res["cr"].value == pytest.approx(2 * e, abs=1e-9)
    assert res["tr"].value == pytest.approx(2 * e, abs=1e-9)


def test_axial_runout_of_a_tilted_face():
    """A face z = 50 + t·x, rings of radius 3 and 5 about the datum axis: the axial
    runout of the outer ring is 2·t·5 (circular, by annular sections) and so the total."""
    t = 0.001
    face = np.vstack([ring([0, 0, 50], r, n=48) for r in (3, 5)])
    face[:, 2] += t * face[:, 0]
    plane = {"type": "plane", "point": [0, 0, 50], "normal": [0, 0, 1]}
    ch = [
        {"id": "cr", "type": "circular-runout", "feature": "P", "datums": ["D"], "tolerance": 0.05, "sections": 2},
        {"id": "tr", "type": "total-runout", "feature": "P", "datums": ["D"], "tolerance": 0.05},
    ]
    res = run({"D": DATUM_CYL, "P": plane}, ch, {"D": "D"}, D=datum_journal(), P=face)
    assert res["cr"].value == pytest.approx(2 * t * 5, abs=1e-9)
    assert res["tr"].value == pytest.approx(2 * t * 5, abs=1e-9)


def test_coaxiality_and_concentricity():
    """The shaft's axis from (0.01, 0) at z = 20 to (0.03, 0.04) at z = 40 about the datum
    axis: coaxiality 2·0.05, parallelism |(0.02, 0.04)|; a circle centred 0.02, 0.01 off
    the axis: concentricity 2·|(0.02, 0.01)|."""
    circle = {"type": "circle", "centre": [0, 0, 60], "normal": [0, 0, 1], "diameter": 8}
    ch = [
        {"id": "coax", "type": "coaxiality", "feature": "F", "datums": ["D"], "tolerance": 0.2},
        {"id": "conc", "type": "concentricity", "feature": "K", "datums": ["D"], "tolerance": 0.2},
        {"id": "par", "type": "parallelism", "feature": "F", "datums": ["D"], "tolerance": 0.2},
    ]
    res = run(
        {"D": DATUM_CYL, "F": SHAFT, "K": circle},
        ch,
        {"D": "D"},
        D=datum_journal(),
        F=shaft([0.01, 0], [0.03, 0.04]),
        K=ring([0.02, 0.01, 60], 4),
    )
    assert res["coax"].value == pytest.approx(0.1, abs=1e-9)
    assert res["conc"].value == pytest.approx(2 * np.hypot(0.02, 0.01), abs=1e-9)
    # the axis turns by (0.02, 0.04) over its 20 mm: a cylinder parallel to D holding it
    assert res["par"].value == pytest.approx(np.hypot(0.02, 0.04), abs=1e-9)


ABC = {
    "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1]},
    "B": {"type": "plane", "point": [0, 0, 0], "normal": [0, -1, 0]},
    "C": {"type": "plane", "point": [0, 0, 0], "normal": [-1, 0, 0]},
}


def abc_faces() -> dict[str, np.ndarray]:
    return {
        "A": grid([0, 0, 0], [80, 0, 0], [0, 60, 0]),
        "B": grid([0, 0, 1], [80, 0, 0], [0, 0, 28]),
        "C": grid([0, 1, 1], [0, 58, 0], [0, 0, 28]),
    }


def sphere_points(centre, radius: float) -> np.ndarray:
    """A Fibonacci sphere with the six poles."""
    k = np.arange(200) + 0.5
    phi = np.arccos(1 - 2 * k / 200)
    th = np.pi * (1 + 5**0.5) * k
    u = np.c_[np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)]
    u = np.vstack([u, np.eye(3), -np.eye(3)])
    return np.asarray(centre, float) + radius * u


def test_position_of_a_centre_and_of_a_plane_and_profile_with_datums():
    """In A|B|C: a sphere centred (0.01, 0.02, −0.02) off its nominal → position 2·0.03 and
    profile 2·max|d| = 2·0.03 (at the poles along the offset... the pole deviations are
    ±the offset's components, so 2·0.02 on the z poles... the largest |d| is |δ| only
    where a point lies along δ); a top face at z = 30.01 + 0.0005·x → 2·(0.01 + 0.04)."""
    delta = np.array([0.0, 0.0, 0.03])
    sphere = {"type": "sphere", "centre": [30, 20, 50], "diameter": 20}
    top = {"type": "plane", "point": [0, 0, 30], "normal": [0, 0, 1]}
    ch = [
        {"id": "pos-S", "type": "position", "feature": "S", "datums": ["A", "B", "C"], "tolerance": 0.1},
        {"id": "prof-S", "type": "profile", "feature": "S", "datums": ["A", "B", "C"], "tolerance": 0.1},
        {"id": "float-S", "type": "surface-profile", "feature": "S", "tolerance": 0.1},
        {"id": "pos-T", "type": "position", "feature": "T", "datums": ["A", "B", "C"], "tolerance": 0.2},
    ]
    t_face = grid([0, 0, 30], [80, 0, 0], [0, 60, 0])
    t_face[:, 2] += 0.01 + 0.0005 * t_face[:, 0]
    res = run(
        {**ABC, "S": sphere, "T": top},
        ch,
        {"A": "A", "B": "B", "C": "C"},
        **abc_faces(),
        S=sphere_points(np.array([30, 20, 50]) + delta, 10),
        T=t_face,
    )
    assert res["pos-S"].value == pytest.approx(2 * 0.03, abs=1e-9)
    assert res["prof-S"].value == pytest.approx(2 * 0.03, abs=1e-9)
    assert res["float-S"].value == pytest.approx(0.0, abs=1e-9)  # floated: a displaced sphere fits
    assert res["pos-T"].value == pytest.approx(2 * 0.05, abs=1e-9)


def test_parallelism_and_angularity_of_planes():
    """T: z = 30 + t·x over x 0..80 → parallelism to A = 80·t. K: inclined 30° to A,
    measured at 30° + ε over 20 mm of slope → angularity 20·sin ε."""
    t, eps = 0.0002, 0.001
    t_face = grid([0, 0, 30], [80, 0, 0], [0, 60, 0])
    t_face[:, 2] += t * t_face[:, 0]
    a = np.radians(30) + eps
    k_face = grid([100, 0, 0], [20 * np.cos(a), 0, 20 * np.sin(a)], [0, 60, 0])
    n30 = [-np.sin(np.radians(30)), 0, np.cos(np.radians(30))]
    planes = {
        "A": ABC["A"],
        "T": {"type": "plane", "point": [0, 0, 30], "normal": [0, 0, 1]},
        "K": {"type": "plane", "point": [100, 0, 0], "normal": n30},
    }
    ch = [
        {"id": "par", "type": "parallelism", "feature": "T", "datums": ["A"], "tolerance": 0.05},
        {"id": "ang", "type": "angularity", "feature": "K", "datums": ["A"], "tolerance": 0.05, "angle": 30},
    ]
    res = run(planes, ch, {"A": "A"}, A=abc_faces()["A"], T=t_face, K=k_face)
    assert res["par"].value == pytest.approx(80 * t, abs=1e-9)
    assert res["ang"].value == pytest.approx(20 * np.sin(eps), abs=1e-9)


def test_symmetry_of_a_slot():
    """Slot walls at x = ±5 + s about the median plane of the outer faces x = ±20:
    symmetry 2·s."""
    s = 0.02

    def wall(x: float) -> np.ndarray:
        return grid([x, 0, 0], [0, 40, 0], [0, 0, 10], 5, 4)

    planes = {
        "Q1": {"type": "plane", "point": [-20, 0, 0], "normal": [-1, 0, 0]},
        "Q2": {"type": "plane", "point": [20, 0, 0], "normal": [1, 0, 0]},
        "P1": {"type": "plane", "point": [-5, 0, 0], "normal": [1, 0, 0]},
        "P2": {"type": "plane", "point": [5, 0, 0], "normal": [-1, 0, 0]},
    }
    ch = [{"id": "sym", "type": "symmetry", "feature": "P1", "other": "P2", "datums": ["M"], "tolerance": 0.1}]
    res = run(planes, ch, {"M": ["Q1", "Q2"]}, Q1=wall(-20), Q2=wall(20), P1=wall(-5 + s), P2=wall(5 + s))
    assert res["sym"].value == pytest.approx(2 * s, abs=1e-9)


def test_sizes_diameter_width_distance():
    part = gp.block(bore_bottom=(0, 0), bore_top=(0, 0), bore_diameter=10.004)
    chars = [
        {"id": "dia", "type": "diameter", "feature": "H1", "lower": -0.002, "upper": 0.002},
        {"id": "dia-mc", "type": "diameter", "feature": "H1", "criterion": "maxinscribed", "lower": 0, "upper": 0.01},
        {"id": "w", "type": "width", "feature": "C", "other": "D", "lower": -0.1, "upper": 0.1},
        {"id": "d-axes", "type": "distance", "feature": "H1", "other": "P1", "lower": -0.1, "upper": 0.1},
        {"id": "d-planes", "type": "distance", "feature": "A", "other": "T", "lower": -0.1, "upper": 0.1},
    ]
    doc = gp.plan_document(characteristics=chars, bore_diameter=10.0)
    res = evaluate(doc, part.points)
    dia = res["dia"]
    assert dia.value == pytest.approx(10.004, abs=1e-9)
    assert dia.details["deviation"] == pytest.approx(0.004, abs=1e-9)
    assert dia.verdict == "not conform"
    assert dia.details["two_point_min"] == pytest.approx(10.004, abs=1e-6)
    assert res["dia-mc"].value == pytest.approx(10.004, abs=1e-9)
    assert res["dia-mc"].u_method.startswith("monte-carlo")
    assert res["dia-mc"].verdict == "conform"
    assert res["w"].value == pytest.approx(80.0, abs=1e-9)
    assert res["d-axes"].value == pytest.approx(40.0, abs=1e-9)
    assert res["d-axes"].details["nominal"] == pytest.approx(40.0, abs=1e-12)
    assert res["d-planes"].value == pytest.approx(30.0, abs=1e-9)


@pytest.mark.parametrize(
    ("value", "simple", "guarded"),
    [
        (0.090, "conform", "conform"),  # ≤ t − U = 0.092
        (0.092, "conform", "conform"),
        (0.095, "conform", "undecided"),
        (0.100, "conform", "undecided"),  # at the limit
        (0.105, "not conform", "undecided"),
        (0.108, "not conform", "undecided"),  # t + U: not proven
        (0.110, "not conform", "not conform"),
    ],
)
def test_zone_verdicts_at_and_around_the_limit(value, simple, guarded):
    """Tolerance 0.1, u = 0.004, k = 2 (U = 0.008): ISO 14253-1 guard bands."""
    assert unc.zone_verdicts(value, 0.1, 0.004, 2.0) == (simple, guarded)


@pytest.mark.parametrize(
    ("dev", "simple", "guarded"),
    [
        (0.0, "conform", "conform"),
        (0.018, "conform", "conform"),
        (0.019, "conform", "undecided"),
        (-0.021, "not conform", "undecided"),
        (-0.023, "not conform", "not conform"),
        (0.03, "not conform", "not conform"),
    ],
)
def test_size_verdicts_on_an_asymmetric_interval(dev, simple, guarded):
    """Limits −0.02 / +0.02 mm, u = 0.001, k = 2."""
    assert unc.size_verdicts(dev, -0.02, 0.02, 0.001, 2.0) == (simple, guarded)
    # an interval not centred on the nominal: −0.01 .. +0.03 is the same shifted by 0.01
    assert unc.size_verdicts(dev + 0.01, -0.01, 0.03, 0.001, 2.0) == (simple, guarded)


def test_verdicts_through_a_characteristic():
    """The issue's bore with noise: a tolerance just above the value is undecided once
    its uncertainty is counted, one well above conforms, one below fails."""
    part = gp.block(noise=0.002, density=0.05)
    first = evaluate(block_doc([POS]), part.points)["pos"]
    v, big_u = first.value, first.U
    assert big_u > 0
    chars = [
        {**POS, "id": "tight", "tolerance": v + 0.5 * big_u},
        {**POS, "id": "loose", "tolerance": v + 2 * big_u},
        {**POS, "id": "under", "tolerance": v - 2 * big_u},
    ]
    res = evaluate(block_doc(chars), part.points)
    assert (res["tight"].verdict, res["tight"].verdict_guarded) == ("conform", "undecided")
    assert (res["loose"].verdict, res["loose"].verdict_guarded) == ("conform", "conform")
    assert (res["under"].verdict, res["under"].verdict_guarded) == ("not conform", "not conform")


def test_meaningless_results_are_warned_not_given():
    """Too few points for a cylinder, an axis of no extent (one ring: built by hand, a
    fit refuses it), no tolerance: value None or no verdict, and a warning saying why."""
    chars = [
        {"id": "few", "type": "position", "feature": "F", "datums": ["D"], "tolerance": 0.1},
        {"id": "flat", "type": "perpendicularity", "feature": "R", "datums": ["D"], "tolerance": 0.1},
        {"id": "notol", "type": "roundness", "feature": "K"},
    ]
    one_ring = {"type": "cylinder", "point": [0, 0, 60], "axis": [0, 0, 1], "diameter": 10}
    circle = {"type": "circle", "centre": [0, 0, 80], "normal": [0, 0, 1], "diameter": 8}
    feats = {"D": DATUM_CYL, "F": SHAFT, "R": one_ring, "K": circle}
    pts, sets = cloud(
        D=datum_journal(),
        F=shaft([0, 0], [0, 0])[[0, 20, 40, 60, 80]],
        R=ring([0, 0, 60], 5),
        K=ring([0, 0, 80], 4, lobes=3, amp=0.001),
    )
    plan = parse_plan({"features": feats, "datums": {"D": "D"}, "characteristics": chars}, "plan.yaml")
    assoc = {f: features.associate(pts, sets[f], plan.features[f]) for f in "DFK"}
    params = {"point": np.array([0.0, 0, 60]), "axis": np.array([0.0, 0, 1]), "diameter": 10.0, "length": 0.0}
    assoc["R"] = Associated("R", "cylinder", "ls", sets["R"], params, np.zeros(len(sets["R"])), {})
    frames = lambda labels: datum_frame(plan, assoc, labels)  # noqa: E731
    res = {c.id: evaluate_characteristic(c, plan, pts, assoc, frames) for c in plan.characteristics}
    for cid in ("few", "flat"):
        assert res[cid].value is None and res[cid].verdict == "not evaluated", cid
        assert len(res[cid].warnings) == 1 and res[cid].details["reason"] in res[cid].warnings[0]
    assert "5 points, at least 6" in res["few"].warnings[0]
    assert "no extent" in res["flat"].warnings[0]
    assert res["notol"].value == pytest.approx(0.002, abs=1e-9)
    assert res["notol"].verdict == "not evaluated" and "no tolerance" in res["notol"].warnings[0]


def test_stated_point_noise_replaces_the_estimate():
    """A bottom face A with every second point raised 0.03 mm: from the points alone that
    is noise (the tangent datum's Monte Carlo makes the 0.1166 position against 0.1
    undecided); a plan stating ``point_noise: 0`` says the points carry none (not
    conform); a bad value is one line naming the key."""
    part = gp.block(ripple_a=0.03)
    tight = [{**POS, "tolerance": 0.1}]
    est = evaluate(block_doc(tight), part.points)["pos"]
    assert est.value == pytest.approx(gp.POSITION_H1, abs=1e-9)
    assert est.details["u_parts"]["datums monte-carlo"] > 0.005
    assert (est.verdict, est.verdict_guarded) == ("not conform", "undecided")
    stated = evaluate(gp.plan_document(characteristics=tight, point_noise=0), part.points)["pos"]
    assert stated.u < 1e-9 and stated.verdict_guarded == "not conform"
    with pytest.raises(InputError, match="point_noise") as exc:
        evaluate(gp.plan_document(characteristics=tight, point_noise="x"), part.points)
    assert "\n" not in str(exc.value)


def test_angularity_of_an_axis():
    """An axis nominally at 30° to the plane A (60° from its normal), measured 60° + ε
    from it in the same plane: the diametral zone at 30° to A holding the axis between
    the planes normal to the nominal through its 20 mm ends is 20·tan ε."""
    eps = 0.0005
    a = np.radians(60) + eps
    d = np.array([np.sin(a), 0, np.cos(a)])
    bore = np.vstack([ring(d * s, 4, n=24, normal=d) for s in (2, 8, 14, 20)])
    nominal = [np.sin(np.radians(60)), 0, np.cos(np.radians(60))]
    cyl = {"type": "cylinder", "point": [0, 0, 0], "axis": nominal, "diameter": 8, "length": 20}
    ch = [{"id": "ang", "type": "angularity", "feature": "K", "datums": ["A"], "tolerance": 0.05, "angle": 30}]
    res = run({"A": ABC["A"], "K": cyl}, ch, {"A": "A"}, A=abc_faces()["A"], K=bore)
    assert res["ang"].value == pytest.approx(20 * np.tan(eps), abs=1e-9)


def test_runout_and_coaxiality_need_a_datum_axis():
    """Runout about a plane datum would be about its normal through an arbitrary point:
    refused in one line naming the key."""
    ch = [{"id": "cr", "type": "circular-runout", "feature": "F", "datums": ["A"], "tolerance": 0.05}]
    with pytest.raises(InputError, match="datums: circular-runout needs a datum axis") as exc:
        run({"A": ABC["A"], "F": SHAFT}, ch, {"A": "A"}, A=abc_faces()["A"], F=shaft([0, 0], [0, 0]))
    assert "\n" not in str(exc.value) and "plan.yaml" in str(exc.value)
