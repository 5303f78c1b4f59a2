"""The alignments of ``camcmm gdt evaluate`` (gdt/alignment.py): each method recovers the
exact pose of a noise-free part (helpers/gdt_parts.py) to 1e-9, from a small pose and,
with the coarse start, from a scanner's frame (30° about a skew axis, 500 mm away).

The block's faces A, B, C, D, T are exact planes; its bore H1 is offset from nominal (the
issue's (0.02, −0.01) / (0.05, 0.03) mm) unless made perfect here: a best fit over every
feature is pulled by the bore, so it is exact only on the perfect part, while the
datum, 3-2-1 and RPS alignments (on A, B, C) and a best fit restricted to A, B, C are
exact on the offset part too.
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError, TriangleMesh
from camcmm_plugins.gdt import alignment as al
from camcmm_plugins.gdt.plan import parse_plan
from helpers import gdt_parts as g

#: A small pose (0.4° about a skew axis, 0.27 mm): within the features' 0.5 mm bands.
SMALL = g.pose((0.3, -1.0, 0.5), 0.4, (0.2, -0.15, 0.1))
RPS = {
    "R1": {"feature": "A", "fixes": ["z"], "at": [10, 10, 0]},
    "R2": {"feature": "A", "fixes": ["z"], "at": [70, 10, 0]},
    "R3": {"feature": "A", "fixes": ["z"], "at": [40, 50, 0]},
    "R4": {"feature": "B", "fixes": ["y"], "at": [10, 0, 15]},
    "R5": {"feature": "B", "fixes": "y", "at": [70, 0, 15]},
    "R6": {"feature": "C", "fixes": ["x"], "at": [0, 30, 15]},
}


def _plan(**extra):
    return parse_plan(g.plan_document(**extra), "plan.yaml")


def _error(T, part):
    """How far T is from the inverse of the part's pose (max |element| of T·pose − I)."""
    return float(np.abs(T @ part.pose - np.eye(4)).max())


@pytest.fixture(scope="module")
def offset_part():
    return g.block(pose=SMALL)


@pytest.fixture(scope="module")
def perfect_part():
    return g.block(pose=SMALL, bore_bottom=(0, 0), bore_top=(0, 0))


def test_best_fit_to_the_plan_surfaces(perfect_part, offset_part):
    T, info = al.align("best-fit", _plan(), perfect_part.points)
    assert _error(T, perfect_part) < 1e-9
    assert info["converged"] and info["free"] == [] and info["rms"] < 1e-9
    assert info["method"] == "best-fit" and np.allclose(info["transform"], T)
    # the offset bore pulls an unrestricted best fit off the datum faces' pose
    T, info = al.align("best-fit", _plan(), offset_part.points)
    assert _error(T, offset_part) > 1e-4 and info["rms"] > 1e-3


def test_best_fit_restricted_to_features_and_boxes(offset_part):
    T, info = al.align("best-fit", _plan(alignment={"features": ["A", "B", "C"]}), offset_part.points)
    assert _error(T, offset_part) < 1e-9
    assert set(info["stages"][-1]["features"]) == {"A", "B", "C"}
    boxes = [[[-1, -1, -1], [81, 61, 0.5]], [[-1, -1, -1], [81, 0.5, 31]], [[-1, -1, -1], [0.5, 61, 31]]]
    T, info = al.align("best-fit", _plan(alignment={"boxes": boxes}), offset_part.points)
    assert _error(T, offset_part) < 1e-9
    assert {k for k, n in info["stages"][-1]["features"].items() if n} == {"A", "B", "C"}


def test_best_fit_free_dofs_held_and_named(offset_part):
    """A plane alone fixes 3 of the 6: the others are held where the start put them."""
    T, info = al.align("best-fit", _plan(alignment={"features": ["A"]}), offset_part.points)
    assert len(info["free"]) == 3
    assert sum(w.startswith("translation") for w in info["free"]) == 2
    assert any(
        w.startswith("rotation about (0, 0, 1)") or w.startswith("rotation about (0, 0, -1)") for w in info["free"]
    )
    X = al.apply(T, offset_part.of("A"))
    assert np.abs(X[:, 2]).max() < 1e-9  # what A fixes, it fixes exactly


def test_datum_alignment(offset_part):
    T, info = al.align("datums", _plan(), offset_part.points)
    assert _error(T, offset_part) < 1e-9
    assert info["converged"] and info["free"] == []
    assert info["stages"][-1]["datums"] == ["A", "B", "C"]  # the longest list a characteristic names
    T, info = al.align("datums", _plan(alignment={"datums": ["A"]}), offset_part.points)
    assert len(info["free"]) == 3  # a single plane datum: two translations and the turn about it


def test_three_two_one(offset_part):
    T, info = al.align("3-2-1", _plan(), offset_part.points)
    assert _error(T, offset_part) < 1e-9
    assert info["stages"][-1]["features"] == ["A", "B", "C"]
    with pytest.raises(InputError, match="primary H1 must be a plane"):
        al.align("3-2-1", _plan(alignment={"features": ["H1", "A", "B"]}), offset_part.points)
    with pytest.raises(InputError, match="T is parallel to the primary A's normal"):
        al.align("3-2-1", _plan(alignment={"features": ["A", "T", "B"]}), offset_part.points)
    with pytest.raises(InputError, match="after the hole H1, the tertiary B must be a hole"):
        al.align("3-2-1", _plan(alignment={"features": ["A", "H1", "B"]}), offset_part.points)


def test_plane_hole_slot(perfect_part, offset_part):
    """3-2-1 as plane A, bore H1 (its place in A: 2), boss P1 (the turn towards it: 1)."""
    plan = _plan(alignment={"features": ["A", "H1", "P1"]})
    T, info = al.align("3-2-1", plan, perfect_part.points)
    assert _error(T, perfect_part) < 1e-9 and "a hole" in info["stages"][-1]["kind"]
    # the offset bore: its true axis' point nearest (20, 30, 0) is at (20, 30) in A; the
    # boss' axis lies on y = 30
    T, info = al.align("3-2-1", plan, offset_part.points)
    D = T @ offset_part.pose
    ends = al.apply(D, np.array([[20.02, 29.99, 0.0], [20.05, 30.03, 30.0]]))
    d = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    foot = ends[0] + ((np.array([20.0, 30.0, 0.0]) - ends[0]) @ d) * d
    assert np.allclose(foot[:2], [20.0, 30.0], atol=1e-9)
    assert np.allclose(al.apply(D, np.array([[60.0, 30.0, 30.0], [60.0, 30.0, 40.0]]))[:, 1], 30.0, atol=1e-8)
    assert np.allclose(D[:3, :3] @ [0, 0, 1.0], [0, 0, 1], atol=1e-12)  # A stays A


def test_rps(offset_part):
    T, info = al.align("rps", _plan(rps=RPS), offset_part.points)
    assert _error(T, offset_part) < 1e-9 and info["free"] == []
    points = info["stages"][-1]["points"]
    assert points["R4"]["fixes"] == ["y"] and np.allclose(points["R6"]["deviation"], 0, atol=1e-9)
    # a bore's axis as the first reference point, with its real offset (0.02, -0.01) at
    # z = 0: H fixes x and y there, B's point at x = 10 y, A's three z: six fixes, met
    # exactly — the part turns about z by 0.01 mm over the 10 mm from R4 to H
    rps = {"H": {"feature": "H1", "fixes": ["x", "y"]}, **{k: RPS[k] for k in ("R1", "R2", "R3", "R4")}}
    T, info = al.align("rps", _plan(rps=rps), offset_part.points)
    assert info["free"] == []
    assert np.allclose([p["deviation"] for p in info["stages"][-1]["points"].values()], 0, atol=1e-9)
    # checked on the part's true geometry moved by what the RPS did beyond undoing the pose
    D = T @ offset_part.pose
    ends = al.apply(D, np.array([[20.02, 29.99, 0.0], [20.05, 30.03, 30.0]]))  # the bore's true axis
    d = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    foot = ends[0] + ((np.array([20.0, 30.0, 0.0]) - ends[0]) @ d) * d
    assert np.allclose(foot[:2], [20.0, 30.0], atol=1e-9)
    for normal, at, k in [((0, 0, 1), RPS[r]["at"], 2) for r in ("R1", "R2", "R3")] + [((0, 1, 0), RPS["R4"]["at"], 1)]:
        n, p0 = D[:3, :3] @ np.asarray(normal, float), D[:3, 3]  # the true face y = 0 or z = 0, moved
        x = np.asarray(at, float)
        x[k] = 0.0
        assert abs(n @ (x - p0) / n[k]) < 1e-9  # the moved face passes through `at`
    assert abs(np.arctan2(D[1, 0], D[0, 0]) - 0.001) < 1e-5  # ~0.01 mm over the 10 mm from R4 to H
    three = {k: RPS[k] for k in ("R1", "R2", "R3")}
    T, info = al.align("rps", _plan(rps=three), offset_part.points)
    assert len(info["free"]) == 3


def test_none_and_the_scanner_frame():
    part = g.block(pose=g.SCANNER_POSE, bore_bottom=(0, 0), bore_top=(0, 0))
    T, info = al.align("none", _plan(), part.points)
    assert np.array_equal(T, np.eye(4)) and info["stages"] == []
    T, info = al.align("best-fit", _plan(), part.points)
    assert _error(T, part) < 1e-9
    assert info["stages"][0]["stage"] == "coarse start" and info["stages"][0]["why"].startswith("0 of 7")


def test_a_fit_caught_in_a_wrong_minimum_gets_a_coarse_start():
    """Turned 20° about z and shifted 1 mm, the block still has points in most bands, and a
    best fit from there ends 1 mm off with 36 % of its points in the bands: doubted, the
    coarse start runs (that fit one of its candidates, refitted in widening bands), and
    its winner is exact."""
    part = g.block(pose=g.pose((0, 0, 1), 20.0, (1.0, -0.5, 0.2)), bore_bottom=(0, 0), bore_top=(0, 0))
    T, info = al.align("best-fit", _plan(), part.points)
    assert _error(T, part) < 1e-9
    first = info["stages"][0]
    assert first["stage"] == "coarse start" and "holds 36 % of the points" in first["why"]
    assert first["candidates"]["as delivered"] <= max(first["candidates"].values())  # weighed with the others


def _box_mesh() -> TriangleMesh:
    V = np.array([[x, y, z] for x in (0, 80) for y in (0, 60) for z in (0, 30)], float)
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    F = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return TriangleMesh(V, F, name="block")


def test_best_fit_to_a_nominal_mesh():
    """With a nominal, best fit is inspect.align's ICP onto it (the block's six faces)."""
    part = g.block(pose=SMALL)
    keep = np.isin(part.surface, [part.names.index(n) for n in "ABCDTE"])
    T, info = al.align("best-fit", _plan(), part.points[keep], nominal=_box_mesh())
    assert _error(T, part) < 1e-6
    assert info["stages"][-1]["kind"].startswith("inspect.align")


@pytest.mark.parametrize(
    "extra, needle",
    [
        ({"alignment": {"sideways": 1}}, "alignment.sideways"),
        ({"alignment": {"features": ["Q"]}}, "unknown feature 'Q'"),
        ({"alignment": {"boxes": [[0, 0, 0]]}}, "alignment.boxes"),
        ({"rps": {"R1": {"feature": "A", "fixes": ["z"]}}}, "rps.R1.at"),
        ({"rps": {"R1": {"feature": "H1", "fixes": ["w"]}}}, "rps.R1.fixes"),
        ({"rps": {"R1": {"feature": "Q", "fixes": ["x"]}}}, "rps.R1.feature"),
        ({}, "rps: the RPS alignment needs reference points"),
    ],
)
def test_refusals_name_the_key(offset_part, extra, needle):
    with pytest.raises(InputError, match="plan.yaml") as exc:
        al.align("rps", _plan(**extra), offset_part.points)
    assert needle in str(exc.value)


def test_best_fit_to_a_step_has_no_facet_bias(tmp_path):
    """A cap of a Ø20 sphere, shifted by (0.05, -0.03, 0.02) mm, best-fitted to the sphere
    read from a STEP: the shift back to 1e-9 mm — inspect.align pairs the points with the
    exact surface, not with the tessellation (whose facets lie up to its deflection inside)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    from OCP.gp import gp_Pnt

    from camcmm.api import read_cad
    from camcmm.cad.write import write_step

    write_step(BRepPrimAPI_MakeSphere(gp_Pnt(0, 0, 0), 10.0).Shape(), tmp_path / "ball.step")
    cad = read_cad(tmp_path / "ball.step")
    v = np.random.default_rng(0).normal(size=(2000, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    shift = np.array([0.05, -0.03, 0.02])
    points = 10.0 * v[v[:, 2] > -0.5] + shift
    plan = parse_plan({"features": {"S1": {"type": "face", "cad": 1}}}, "plan.yaml")
    T, info = al.align("best-fit", plan, points, nominal=cad)
    assert np.allclose(T[:3, 3], -shift, atol=1e-9) and info["rms"] < 1e-9
    assert info["free"] and "rotation about any axis" in info["free"][0]  # a ball's turn: held
