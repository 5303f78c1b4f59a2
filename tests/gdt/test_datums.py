"""Datum reference frames (gdt/datums.py), exact by construction: ISO 5459 / ASME Y14.5 §4
precedence, free degrees of freedom held at the nominal, common datums, and the transform
N·M⁻¹ that lands the measured datums on their nominals."""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import InputError
from camcmm_plugins.gdt import features
from camcmm_plugins.gdt.datums import datum_frame, nominal_frame
from camcmm_plugins.gdt.model import Associated
from camcmm_plugins.gdt.plan import parse_plan
from helpers import gdt_parts as gp


def _assoc(fid: str, etype: str, **params) -> Associated:
    p = {k: (np.asarray(v, float) if isinstance(v, list | tuple) else v) for k, v in params.items()}
    return Associated(fid, etype, "ls", np.zeros(0, np.int64), p, np.zeros(0), {})


def _plan(features_doc: dict, datums: dict) -> object:
    return parse_plan({"features": features_doc, "datums": datums, "characteristics": []}, "plan.yaml")


def _apply(t: np.ndarray, p) -> np.ndarray:
    return np.asarray(p, float) @ t[:3, :3].T + t[:3, 3]


def _block_associated(part: gp.Part, plan) -> dict[str, Associated]:
    """Features of a (possibly posed) block: points selected in plan coordinates (the
    selection is not under test), associated where they are."""
    plan_pts = part.plan_points()
    out = {}
    for fid in ("A", "B", "C", "H1"):
        spec = plan.features[fid]
        out[fid] = features.associate(part.points, features.select(plan_pts, spec), spec)
    return out


def test_abc_frame_undoes_the_scanner_pose():
    """A|B|C of a block delivered rotated 30° and 500 mm away: the transform is the
    inverse of the pose (the datum faces are perfect, so exactly)."""
    plan = parse_plan(gp.plan_document(), "plan.yaml")
    part = gp.block(pose=gp.SCANNER_POSE)
    frame = datum_frame(plan, _block_associated(part, plan), ("A", "B", "C"))
    assert frame.free == []
    np.testing.assert_allclose(frame.transform, np.linalg.inv(gp.SCANNER_POSE), atol=1e-9)


def test_single_plane_leaves_rotation_and_translations_free_at_the_nominal():
    """A alone fixes z and the two tilts; the measured plane z = 0.3 + 0.01·x is brought
    onto z = 0 by the least rotation (about y) and shift, x/y stay where they were."""
    plan = _plan({"A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}}, {"A": "A"})
    n = np.array([-0.01, 0.0, 1.0]) / np.hypot(0.01, 1.0)
    frame = datum_frame(plan, {"A": _assoc("A", "plane", point=[0, 0, 0.3], normal=n)}, ("A",))
    assert frame.free == ["rotation z", "translation x", "translation y"]
    pts = np.array([[0, 0, 0.3], [10, 0, 0.4], [0, 10, 0.3], [10, 10, 0.4]])
    out = _apply(frame.transform, pts)
    np.testing.assert_allclose(out[:, 2], 0.0, atol=1e-12)
    # no rotation about z: the y axis of the part stays the y axis
    np.testing.assert_allclose(frame.transform[:3, :3] @ [0, 1, 0], [0, 1, 0], atol=1e-12)


def test_secondary_only_constrains_what_the_primary_left():
    """A (z = 0) primary, B (nominal y = 0) measured tilted 0.01 rad towards z and
    C (x = 0): z is A's normal exactly, B only clocks — B's tilt does not tilt the frame."""
    plan = _plan(
        {
            "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]},
            "B": {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
            "C": {"type": "plane", "point": [0, 0, 0], "normal": [1, 0, 0]},
        },
        {"A": "A", "B": "B", "C": "C"},
    )
    nb = np.array([0.0, 1.0, 0.01]) / np.hypot(1.0, 0.01)
    assoc = {
        "A": _assoc("A", "plane", point=[0, 0, 0], normal=[0, 0, 1]),
        "B": _assoc("B", "plane", point=[0, 0, 0], normal=nb),
        "C": _assoc("C", "plane", point=[0, 0, 0], normal=[1, 0, 0]),
    }
    frame = datum_frame(plan, assoc, ("A", "B", "C"))
    np.testing.assert_allclose(frame.transform, np.eye(4), atol=1e-12)


def test_plane_and_perpendicular_bore():
    """A|H1: the bore fixes x, y where its axis meets A; rotation about z stays free. The
    measured axis through (20.1, 29.9) tilted 0.001 in x: its foot on A lands on (20, 30)."""
    plan = _plan(
        {
            "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]},
            "H1": {"type": "cylinder", "point": [20, 30, 0], "axis": [0, 0, 1], "diameter": 10, "length": 30},
        },
        {"A": "A", "B": "H1"},
    )
    axis = np.array([0.001, 0.0, 1.0]) / np.hypot(0.001, 1.0)
    assoc = {
        "A": _assoc("A", "plane", point=[0, 0, 0], normal=[0, 0, 1]),
        "H1": _assoc("H1", "cylinder", point=[20.1, 29.9, 0], axis=axis, diameter=10.0, length=30.0),
    }
    frame = datum_frame(plan, assoc, ("A", "B"))
    assert frame.free == ["rotation z"]
    np.testing.assert_allclose(_apply(frame.transform, [20.1, 29.9, 0]), [20, 30, 0], atol=1e-12)
    origin, free = nominal_frame(plan, ("A", "B"))
    np.testing.assert_allclose(origin[:3, 3], [20, 30, 0], atol=1e-12)


def test_common_axis_of_two_coaxial_cylinders():
    """A-B: two journals whose axes' middles are (0.1, 0, 5) and (0.3, 0, 45): the common
    axis through them is the datum; both middles land on the nominal z axis."""
    plan = _plan(
        {
            "A": {"type": "cylinder", "point": [0, 0, 0], "axis": [0, 0, 1], "diameter": 10, "length": 10},
            "B": {"type": "cylinder", "point": [0, 0, 40], "axis": [0, 0, 1], "diameter": 10, "length": 10},
        },
        {"AB": ["A", "B"]},
    )
    assoc = {
        "A": _assoc("A", "cylinder", point=[0.1, 0, 0], axis=[0, 0, 1], diameter=10.0, length=10.0),
        "B": _assoc("B", "cylinder", point=[0.3, 0, 40], axis=[0, 0, 1], diameter=10.0, length=10.0),
    }
    frame = datum_frame(plan, assoc, ("AB",))
    assert frame.free == ["rotation z", "translation z"]
    for mid in ([0.1, 0, 5], [0.3, 0, 45]):
        out = _apply(frame.transform, mid)
        assert np.hypot(out[0], out[1]) < 1e-12


def test_common_plane_of_two_coplanar_planes():
    plan = _plan(
        {
            "A1": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]},
            "A2": {"type": "plane", "point": [50, 0, 0], "normal": [0, 0, 1]},
        },
        {"A": ["A1", "A2"]},
    )
    assoc = {
        "A1": _assoc("A1", "plane", point=[0, 0, 0.2], normal=[0, 0, 1]),
        "A2": _assoc("A2", "plane", point=[50, 0, 0.4], normal=[0, 0, 1]),
    }
    frame = datum_frame(plan, assoc, ("A",))
    np.testing.assert_allclose(_apply(frame.transform, [[0, 0, 0.3], [50, 0, 0.3]])[:, 2], 0.0, atol=1e-12)


def test_a_point_datum_clocks_the_frame():
    """A|B|C with B and C two bores perpendicular to A: B fixes the origin, C (nominal at
    x = 40 from B) the rotation about z — measured at (40, 0.4) from B, the frame turns by
    atan(0.4/40) so C lands on the nominal x axis."""
    cyl = {"type": "cylinder", "axis": [0, 0, 1], "diameter": 6, "length": 10}
    plan = _plan(
        {
            "A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]},
            "B": {**cyl, "point": [0, 0, 0]},
            "C": {**cyl, "point": [40, 0, 0]},
        },
        {"A": "A", "B": "B", "C": "C"},
    )
    assoc = {
        "A": _assoc("A", "plane", point=[0, 0, 0], normal=[0, 0, 1]),
        "B": _assoc("B", "cylinder", point=[0, 0, 0], axis=[0, 0, 1], diameter=6.0, length=10.0),
        "C": _assoc("C", "cylinder", point=[40, 0.4, 0], axis=[0, 0, 1], diameter=6.0, length=10.0),
    }
    frame = datum_frame(plan, assoc, ("A", "B", "C"))
    assert frame.free == []
    out = _apply(frame.transform, [40, 0.4, 5])
    np.testing.assert_allclose(out, [np.hypot(40, 0.4), 0, 5], atol=1e-12)


def test_unknown_datum_is_one_line():
    plan = _plan({"A": {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}}, {"A": "A"})
    with pytest.raises(InputError) as exc:
        datum_frame(plan, {}, ("A",))
    assert "\n" not in str(exc.value) and "plan.yaml" in str(exc.value) and "A" in str(exc.value)
    with pytest.raises(InputError, match="no datum Z"):
        datum_frame(plan, {}, ("Z",))
