"""ISO 1101 characteristics (gdt/characteristics.py), each against its analytic value on a
part built exactly: the issue's bore position, the same part in a scanner's frame, tilts,
minimum zones of known width, runout of an eccentric cylinder, coaxiality, profile,
symmetry, sizes; verdicts at and around the limits; meaningless cases warned."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm_plugins.gdt import features
from camcmm_plugins.gdt.characteristics import evaluate_characteristic
from camcmm_plugins.gdt.datums import datum_frame
from camcmm_plugins.gdt.plan import parse_plan
from helpers import gdt_parts as gp


def evaluate(doc: dict, points: np.ndarray, select_points: np.ndarray | None = None) -> dict:
    """Every characteristic of the plan ``doc`` on ``points``; features selected on
    ``select_points`` (plan coordinates; default the points) and associated on ``points``."""
    plan = parse_plan(doc, "plan.yaml")
    sel = points if select_points is None else select_points
    assoc = {}
    for fid, spec in plan.features.items():
        idx = features.select(sel, spec)
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
    assert res.u_method == "covariance of the least-squares fit"
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
