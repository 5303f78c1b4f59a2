"""Alignment: known transforms recovered, robust kernels, regions, point pairs, and
failure reported (never a confident wrong transform) when the clouds do not overlap.

The measured clouds are points on the nominal's surface moved by a known transform
(exact by construction); the nominal is an asymmetric polycube moved by a generic rigid
motion (see test_inspection_shapes). The cross-check for the Gauss-Newton ICP is Open3D's
own ``registration_icp`` with a point-to-plane estimation and Tukey's loss.
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import GeometryError, InputError, ParameterError, PointCloud, TriangleMesh
from camcmm_plugins.inspection.align import Nominal, align, align_point_pairs, apply, icp, similarity, umeyama
from camcmm_plugins.inspection.coverage import sample_surface
from helpers.shapes import Polycube, box_mesh, l_block, rotate, rotation


def rot_err_deg(A: np.ndarray, B: np.ndarray) -> float:
    """Angle of the rotation between the rotation parts of two similarities (stable for
    tiny angles: from the skew part, not from arccos of the trace)."""
    Ra = A[:3, :3] / np.cbrt(np.linalg.det(A[:3, :3]))
    Rb = B[:3, :3] / np.cbrt(np.linalg.det(B[:3, :3]))
    D = Ra @ Rb.T
    w = np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]]) / 2
    return float(np.degrees(np.arctan2(np.linalg.norm(w), (np.trace(D) - 1) / 2)))


def scale_of(T):
    return float(np.cbrt(np.linalg.det(T[:3, :3])))


@pytest.fixture(scope="module")
def part():
    pc = Polycube(l_block(), 10.0, 4)
    V = rotate(pc.vertices)
    nom = Nominal(TriangleMesh(V, pc.faces, name="l-block"))
    pts, _ = sample_surface(V, pc.faces, 60000, seed=3)
    return nom, pts, V, pc.faces


def moved(pts, T_true):
    """The measured cloud: nominal points moved so that T_true maps them back."""
    return apply(np.linalg.inv(T_true), pts)


def check_recovered(al, T_true, rot_deg=1e-5, trans=1e-5, scale=1e-8):
    assert al.converged, al.reason
    assert rot_err_deg(al.transform, T_true) < rot_deg
    assert np.abs(al.transform[:3, 3] - T_true[:3, 3]).max() < trans
    assert abs(scale_of(al.transform) / scale_of(T_true) - 1) < scale


def test_rigid_icp_recovers_a_known_transform(part):
    nom, pts, _, _ = part
    c = pts.mean(axis=0)
    R = rotation([2.0, -3.0, 1.5])
    T_true = similarity(1.0, R, c - R @ c + np.array([1.5, -2.0, 0.8]))
    al = icp(moved(pts, T_true), nom)
    check_recovered(al, T_true)
    assert al.overlap == 1.0 and al.rms < 1e-5 and al.scale == pytest.approx(1.0, abs=1e-12)


@pytest.mark.slow
def test_similarity_icp_recovers_scale(part):
    nom, pts, _, _ = part
    c = pts.mean(axis=0)
    R = rotation([-1.0, 2.5, -2.0])
    T_true = similarity(1.03, R, c - 1.03 * R @ c + np.array([-0.7, 1.1, 0.4]))
    al = icp(moved(pts, T_true), nom, scale=True)
    check_recovered(al, T_true)
    # rigid ICP on the same data cannot match and says so by its residual
    rig = icp(moved(pts, T_true), nom, max_iterations=20)
    assert rig.rms > 100 * al.rms


@pytest.mark.slow
def test_global_similarity_from_anywhere(part):
    """Arbitrary pose and a photogrammetric scale of 0.37: FPFH + RANSAC, then similarity ICP."""
    nom, pts, _, _ = part
    T_true = similarity(1 / 0.37, rotation([40.0, -70.0, 120.0]), np.array([150.0, -20.0, 80.0]))
    al = align(moved(pts, T_true), nom, "global+similarity")
    check_recovered(al, T_true)
    assert al.stages[0]["stage"] == "global" and al.stages[0]["ok"]


@pytest.mark.slow
def test_global_rigid_partial_scan(part):
    """Only the points seen from above (about half the surface), arbitrary pose."""
    nom, pts, V, F = part
    up = rotate(np.array([[0, 0, 1.0]])) - rotate(np.zeros((1, 3)))
    _, n, _ = nom.closest(pts)
    seen = pts[(n @ up[0]) > -0.2]
    T_true = similarity(1.0, rotation([-100.0, 35.0, 10.0]), np.array([-40.0, 300.0, 12.0]))
    al = align(moved(seen, T_true), nom, "global+icp")
    check_recovered(al, T_true)


@pytest.mark.slow
def test_noise_and_outliers_tukey(part):
    """σ = 10 µm noise along the normal and 5 % gross outliers 0.5-3 mm off: Tukey keeps
    the pose to a few µm; plain least squares is pulled off."""
    nom, pts, _, _ = part
    rng = np.random.default_rng(7)
    _, n, _ = nom.closest(pts)
    noisy = pts + rng.normal(0, 0.01, len(pts))[:, None] * n
    bad = rng.random(len(pts)) < 0.05
    noisy[bad] += rng.uniform(0.5, 3.0, bad.sum())[:, None] * n[bad]
    c = pts.mean(axis=0)
    R = rotation([1.0, 1.0, -1.0])
    T_true = similarity(1.0, R, c - R @ c + np.array([0.5, 0.3, -0.2]))
    meas = moved(noisy, T_true)
    al = icp(meas, nom, kernel="tukey")
    assert al.converged, al.reason
    # pose error where it matters: how far any point of the part ends up from where it belongs
    err = np.abs(apply(al.transform, meas[~bad]) - noisy[~bad]).max()
    assert err < 2e-3
    ls = icp(meas, nom, kernel="none")
    assert np.abs(apply(ls.transform, meas[~bad]) - noisy[~bad]).max() > 5 * err
    hub = icp(meas, nom, kernel="huber")
    assert hub.converged and np.abs(apply(hub.transform, meas[~bad]) - noisy[~bad]).max() < 0.02


@pytest.mark.slow
def test_region_ignores_a_fixture():
    """The scan also holds a clamp plate 3 mm from one face, not in the nominal. Plain
    least squares on everything is pulled towards it; restricted to a box around the
    part (nominal coordinates), the same fit is exact."""
    pc = Polycube(l_block(), 10.0, 4)  # spans [0, 40] x [0, 30] x [0, 20]
    nom = Nominal(TriangleMesh(pc.vertices, pc.faces))
    pts, _ = sample_surface(pc.vertices, pc.faces, 60000, seed=4)
    rng = np.random.default_rng(8)
    clamp = np.column_stack([np.full(20000, 43.0), rng.uniform(0, 30, 20000), rng.uniform(0, 10, 20000)])
    R = rotation([0.5, -0.5, 1.0])
    c = pts.mean(axis=0)
    T_true = similarity(1.0, R, c - R @ c + np.array([0.2, 0.1, 0.3]))
    meas = moved(np.concatenate([pts, clamp]), T_true)
    full = icp(meas, nom, kernel="none", max_distance=5.0, max_iterations=30)
    al = icp(meas, nom, kernel="none", max_distance=5.0, region=[-1, -1, -1, 41, 31, 21])
    check_recovered(al, T_true)
    assert al.n_points == len(pts)
    assert np.abs(apply(full.transform, pts) - apply(T_true, pts)).max() > 0.01


def test_three_point_pairs(part):
    nom, pts, _, _ = part
    T_true = similarity(2.5, rotation([10.0, 200.0, -30.0]), np.array([5.0, 6.0, 7.0]))
    nominal = pts[[0, 1000, 20000]]
    measured = moved(nominal, T_true)
    a = align_point_pairs(measured, nominal, scale=True)
    assert np.allclose(a.transform, T_true, atol=1e-9)
    b = align_point_pairs(measured, nominal, scale=False)
    assert b.scale == pytest.approx(1.0) and b.rms > 1.0  # a rigid fit cannot absorb the scale
    with pytest.raises(GeometryError, match="one line"):
        align_point_pairs([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(InputError, match="at least 3"):
        align_point_pairs([[0, 0, 0], [1, 0, 0]], [[0, 0, 0], [1, 0, 0]])
    # pairs as the start of ICP (the GUI's three picks, a few mm off)
    rng = np.random.default_rng(9)
    T_true = similarity(1.0, rotation([60.0, 20.0, -150.0]), np.array([-30.0, 12.0, 400.0]))
    picks = pts[[5, 15000, 40000]]
    al = align(
        moved(pts, T_true),
        nom,
        "pairs+icp",
        pairs={"measured": moved(picks, T_true) + rng.normal(0, 1.0, (3, 3)), "nominal": picks},
    )
    check_recovered(al, T_true)


def test_umeyama_matches_known_similarity():
    rng = np.random.default_rng(10)
    X = rng.normal(size=(50, 3))
    T = similarity(0.8, rotation([5.0, 50.0, 95.0]), np.array([1.0, 2.0, 3.0]))
    assert np.allclose(umeyama(X, apply(T, X), scale=True), T, atol=1e-12)


def test_no_overlap_far_apart(part):
    nom, pts, _, _ = part
    al = icp(pts + 1000.0, nom)
    assert not al.converged and "no overlap" in al.reason


@pytest.mark.slow
def test_no_overlap_disjoint_patches():
    """Nominal: one half of a bumpy surface; measured: the other half. ICP from where the
    cloud is finds no correspondence off the nominal's rim; global registration finds
    feature matches (the bumps look alike) but no alignment that holds: both fail."""
    rng = np.random.default_rng(0)
    cx, cy, amp, wid = rng.uniform(0, 100, 12), rng.uniform(0, 100, 12), rng.uniform(-4, 4, 12), rng.uniform(5, 12, 12)

    def f(x, y):
        return sum(a * np.exp(-((x - u) ** 2 + (y - v) ** 2) / (2 * w * w)) for u, v, a, w in zip(cx, cy, amp, wid))

    g = np.linspace(0, 1, 101)
    X, Y = np.meshgrid(50 * g, 100 * g, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel(), f(X, Y).ravel()])
    ids = np.arange(V.shape[0]).reshape(101, 101)
    a, b, c, d = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    nom = Nominal(TriangleMesh(V, F))
    # 10 000 measured points (4.5 per mm², 0.5 mm apart: finer than the features' and the
    # correspondences' scale) fail each method for the same reason as the former 50 000 (residuals
    # too wide; the similarity's scale running off) at a third of the cost (CPU 9.0 -> 3.0 s)
    x, y = rng.uniform(55, 100, 10000), rng.uniform(0, 100, 10000)
    meas = np.column_stack([x, y, f(x, y)])
    for method in ("icp", "global+icp", "global+similarity"):
        al = align(meas, nom, method)
        assert not al.converged, f"{method}: {al.to_dict()}"
        assert al.reason


@pytest.mark.slow
def test_no_overlap_different_object(part):
    """A sphere is not the L-block: global+icp must not report success."""
    nom, _, _, _ = part
    rng = np.random.default_rng(12)
    # 10 000 points (0.5 mm apart on the 15 mm sphere) end as the former 30 000 did (the
    # iterations do not settle), at less than half the cost (CPU 6.5 -> 2.9 s)
    u = rng.normal(size=(10000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    al = align(rotate(np.zeros((1, 3))) + 15.0 * u, nom, "global+icp")
    assert not al.converged, al.to_dict()


@pytest.mark.slow
def test_open3d_icp_agrees_on_clouds():
    """Cloud to cloud, rigid, Tukey with a fixed k: the same robust point-to-plane problem
    solved by Open3D's registration_icp and by the Gauss-Newton here."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    pc = Polycube(l_block(), 10.0, 4)
    V = rotate(pc.vertices)
    ref_pts, _ = sample_surface(V, pc.faces, 80000, seed=1)
    ref = PointCloud(ref_pts)
    nom = Nominal(ref)
    rng = np.random.default_rng(13)
    src, _ = sample_surface(V, pc.faces, 30000, seed=2)
    src = src + rng.normal(0, 0.005, src.shape)
    c = src.mean(axis=0)
    R = rotation([1.0, -1.5, 0.5])
    T_true = similarity(1.0, R, c - R @ c + np.array([0.3, -0.2, 0.1]))
    meas = moved(src, T_true)
    ours = icp(meas, nom, kernel="tukey", kernel_k=0.05, max_distance=2.0, max_points=10**6, tolerance=1e-12)
    s = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(meas))
    t = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(ref_pts))
    t.normals = o3d.utility.Vector3dVector(nom._normals)
    res = reg.registration_icp(
        s,
        t,
        2.0,
        np.eye(4),
        reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=0.05)),
        reg.ICPConvergenceCriteria(1e-12, 1e-12, 200),
    )
    T3 = np.asarray(res.transformation)
    assert ours.converged, ours.reason
    assert rot_err_deg(ours.transform, T3) < 2e-4
    assert np.abs(ours.transform[:3, 3] - T3[:3, 3]).max() < 2e-4
    # both near the truth (the reference cloud's sampling limits either)
    assert rot_err_deg(ours.transform, T_true) < 0.02


def test_weak_directions_on_a_flat():
    """A flat on a flat: the in-plane shifts and the turn about the normal are not
    determined; they are kept and reported, not guessed."""
    V, F = box_mesh([0, 0, 0], [50, 50, 5], 10)
    cen = V[F].mean(axis=1)
    F = F[np.isclose(cen[:, 2], 5.0)]
    nom = Nominal(TriangleMesh(V, F))
    rng = np.random.default_rng(14)
    p = np.column_stack([rng.uniform(10, 40, 20000), rng.uniform(10, 40, 20000), np.full(20000, 5.3)])
    al = icp(p, nom)
    assert al.converged
    assert len(al.weak_directions) == 3
    assert al.translation[2] == pytest.approx(-0.3, abs=1e-9)
    assert np.abs(al.translation[:2]).max() < 1e-9


def test_bad_parameters(part):
    nom, pts, _, _ = part
    with pytest.raises(ParameterError):
        icp(pts, nom, kernel="cauchy")
    with pytest.raises(ParameterError):
        icp(pts, nom, region=[0, 0, 0, -1, 1, 1])
    with pytest.raises(ParameterError):
        icp(pts, nom, init=np.diag([1.0, 2.0, 1.0, 1.0]))
    with pytest.raises(ParameterError):
        align(pts, nom, "pairs")


def test_pairs_similarity_holds_the_scale_until_the_pose_settles():
    """A virtual nylon pyramid's reconstruction (tests/data/virtual_nylon/SOURCE.txt) from
    its camera-centre start: a free scale slides the stepped pyramid onto its next step
    (scale 0.74 x, each step 0.73 x the one below; the scale check refuses it), while
    pairs+similarity, which first settles the pose with the pairs' scale held, lands
    within 1 % of the pairs' scale with a robust residual spread of ~0.2 mm."""
    from pathlib import Path

    from camcmm_plugins.virtuallab.am_artefacts import build

    d = np.load(Path(__file__).parents[1] / "data" / "virtual_nylon" / "pyramid_off.npz")
    V, F, _, _ = build("am_pyramid")
    nom = Nominal(TriangleMesh(V, F, name="am_pyramid"))
    P = d["points"].astype(float)
    start = align_point_pairs(d["measured"], d["nominal"], scale=True)
    free = icp(P, nom, init=start.transform, scale=True, inlier_distance=2.5)
    assert not free.converged and "scale moved" in free.reason
    assert free.scale / start.scale == pytest.approx(22.0 / 30.0, abs=0.02)  # the next step
    al = align(
        P, nom, "pairs+similarity", pairs={"measured": d["measured"], "nominal": d["nominal"]}, inlier_distance=2.5
    )
    assert al.converged, al.reason
    assert al.scale / start.scale == pytest.approx(1.0, abs=0.01)
    assert al.sigma < 0.3
    assert any(st["stage"] == "icp (pairs' scale held)" for st in al.stages)
