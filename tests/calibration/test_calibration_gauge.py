"""Gauge block on a platen (thesis 3.2.4): clouds built with a known height, tilted and
moved, with and without noise, side-wall points and a block face that is not parallel."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, ParameterError
from camcmm_plugins.calibration.gauge import gauge_block

L = 5.0006  # the thesis' calibrated 5 mm block


def _cloud(rng, noise=0.0, walls=0, face_tilt=0.0, n_platen=6000, n_top=1500):
    xy = rng.uniform([-30, -20], [30, 20], (n_platen, 2))
    xy = xy[~((np.abs(xy[:, 0]) < 4.5) & (np.abs(xy[:, 1]) < 17.5))]
    platen = np.column_stack([xy, np.zeros(len(xy))])
    uv = rng.uniform([-4.5, -17.5], [4.5, 17.5], (n_top, 2))
    top = np.column_stack([uv, L + np.tan(face_tilt) * uv[:, 1]])
    parts = [platen, top]
    if walls:  # laser points down one side face of the block
        parts.append(np.column_stack([np.full(walls, 4.5), rng.uniform(-17.5, 17.5, walls), rng.uniform(0, L, walls)]))
    pts = np.vstack(parts)
    R = cv2.Rodrigues(np.array([0.3, -0.2, 0.5]))[0]
    pts = pts @ R.T + [10.0, 20.0, 300.0]
    return pts + rng.normal(0, noise, pts.shape), R


def test_exact_cloud():
    pts, R = _cloud(np.random.default_rng(0))
    res = gauge_block(pts, 5.0)
    assert res["height"] == pytest.approx(L, abs=1e-10)
    assert res["error"] == pytest.approx(L - 5.0, abs=1e-10)
    assert res["platen"]["flatness"] < 1e-10 and res["top"]["flatness"] < 1e-10
    assert res["top"]["n_points"] == 1500 and res["parallelism"] < 1e-8
    assert abs(np.dot(res["platen"]["normal"], R[:, 2])) == pytest.approx(1.0)
    assert np.dot(res["platen"]["normal"], R[:, 2]) > 0  # points from the platen to the face


def test_parallelism_resolves_tiny_angles():
    """The angle between two normals, against exact-by-construction pairs: arccos of the
    dot product would give 0 or 8.5e-7 deg for all of these."""
    from camcmm_plugins.calibration.gauge import _angle_deg

    for t in (1e-15, 1e-12, 1e-9, 1e-6, 0.3):  # rad
        a, b = np.array([1.0, 0.0, 0.0]), np.array([np.cos(t), np.sin(t), 0.0])
        assert _angle_deg(a, b) == pytest.approx(np.degrees(t), rel=1e-12)
        assert _angle_deg(a, -b) == pytest.approx(np.degrees(t), rel=1e-12)  # a normal's sign is arbitrary


def test_noise_walls_and_the_platen_rule():
    rng = np.random.default_rng(1)
    pts, R = _cloud(rng, noise=0.03, walls=300)
    res = gauge_block(pts, 5.0)
    n_top = res["top"]["n_points"]
    se = 0.03 * np.sqrt(1 / n_top + 1 / res["platen"]["n_points"])  # height = difference of two means
    assert abs(res["height"] - L) < 5 * se
    assert res["top"]["std"] == pytest.approx(0.03, rel=0.1) and res["platen"]["std"] == pytest.approx(0.03, rel=0.1)
    assert res["top"]["flatness"] > 4 * 0.03  # peak-to-valley of noise
    assert np.sum(res["labels"] == -1) >= 250  # the side-wall points are left out
    # the small face is "top" by extent; the same with 'up' given, and 'up' reversed swaps them
    assert gauge_block(pts, 5.0, up=R[:, 2])["height"] == pytest.approx(res["height"])
    flipped = gauge_block(pts, 5.0, up=-R[:, 2])
    assert flipped["top"]["n_points"] == res["platen"]["n_points"]


def test_face_not_parallel():
    """Height is measured at the face's centroid, along the platen normal."""
    pts, _ = _cloud(np.random.default_rng(2), face_tilt=np.radians(0.05))
    res = gauge_block(pts, 5.0)
    assert res["parallelism"] == pytest.approx(0.05, abs=1e-6)
    # the face's centroid is at v = mean(uv[:,1]) ~ 0; height there: L + tan(t) * mean(v)
    assert abs(res["height"] - L) < np.tan(np.radians(0.05)) * 17.5


def test_bad_input():
    rng = np.random.default_rng(3)
    flat = np.column_stack([rng.uniform(-10, 10, (200, 2)), np.zeros(200)])
    with pytest.raises(GeometryError, match="only one surface"):
        gauge_block(flat, 5.0)
    with pytest.raises(InputError, match="nominal"):
        gauge_block(flat, -5.0)
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        gauge_block(flat[:, :2], 5.0)
    with pytest.raises(GeometryError, match="at least 20"):
        gauge_block(flat[:5], 5.0)


def test_ransac_threshold_and_up_are_checked():
    """A threshold of 0 used to mean 'the default' silently and a negative or NaN one
    gave a NaN plane; an up of zeros or NaN chose the face as the platen (the swapped
    split went out without a word); an up along the surfaces decides nothing."""
    pts, R = _cloud(np.random.default_rng(4))
    for thr in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ParameterError, match="ransac threshold"):
            gauge_block(pts, 5.0, ransac_threshold=thr)
    for up in ([0, 0, 0], [np.nan, 0, 1], [1, 0], "up"):
        with pytest.raises(ParameterError, match="up .* 3 finite numbers, not all zero"):
            gauge_block(pts, 5.0, up=up)
    with pytest.raises(GeometryError, match="90 deg from the surfaces' normal"):
        gauge_block(pts, 5.0, up=R[:, 0])
    ref = gauge_block(pts, 5.0)
    # a rough up (45 deg off, tiny or huge) still says which side; a threshold given is used
    for up in (R[:, 2] + R[:, 0], 1e-300 * R[:, 2], 1e300 * R[:, 2]):
        res = gauge_block(pts, 5.0, up=up)
        assert res["height"] == pytest.approx(L, abs=1e-10) and res["top"]["n_points"] == ref["top"]["n_points"]
    assert gauge_block(pts, 5.0, ransac_threshold=0.2)["height"] == pytest.approx(L, abs=1e-10)
