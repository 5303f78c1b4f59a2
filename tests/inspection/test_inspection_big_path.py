"""The path of the 10⁷-point benchmark (benchmarks/bench_big_compare.py) on 10⁴ points:
``camcmm inspect CLOUD.ply --nominal MESH.ply --align none`` — one pass of signed
distances that also gives the alignment's rms and overlap, one sort shared by the
statistics, the histogram and the material-ratio curve, coverage on one k-d tree (on a
subsample above ``max_points``) — checked against computations that share no code with it:
Open3D's unsigned distances signed by the convex mesh's half-spaces, numpy's percentiles
and histogram, brute-force coverage, the analytic covered share of the cap.
"""

from __future__ import annotations

import numpy as np
import pytest

from camcmm.api import TriangleMesh, write
from camcmm_plugins.inspection import coverage as cov
from camcmm_plugins.inspection.align import Nominal, align, apply, icp, similarity
from helpers.cli import main_json

R, CAP, NOISE = 50.0, -0.4, 0.02


def cap_cloud(n: int, seed: int = 0) -> np.ndarray:
    """n points uniform by area on the sphere cap z > CAP R, radial noise NOISE (mm)."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(CAP, 1.0, n)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    rho = np.sqrt(1.0 - z * z)
    u = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    return u * (R + rng.normal(0.0, NOISE, n))[:, None]


@pytest.fixture(scope="module")
def sphere():
    import open3d as o3d

    m = o3d.geometry.TriangleMesh.create_sphere(radius=R, resolution=40)
    return np.asarray(m.vertices), np.asarray(m.triangles)


def reference_signed(V: np.ndarray, F: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Open3D's unsigned distance, negative where p is inside every face's half-space
    (the mesh is convex): no pseudo-normals, no parity, no camcmm code."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(V.astype(np.float32)), o3d.core.Tensor(F.astype(np.uint32)))
    d = scene.compute_distance(o3d.core.Tensor(p.astype(np.float32))).numpy().astype(float)
    tri = V[F]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n *= np.sign(np.einsum("ij,ij->i", n, tri[:, 0]))[:, None]  # outward: the centre is at 0
    inside = np.all((p @ n.T) - np.einsum("ij,ij->i", n, tri[:, 0]) <= 0, axis=1)
    return np.where(inside, -d, d)


def test_inspect_align_none_big_path_matches_independent_numbers(tmp_path, capfd, sphere):
    V, F = sphere
    p = cap_cloud(10_000)
    write(TriangleMesh(V, F, name="sphere"), tmp_path / "sphere.ply")
    header = f"ply\nformat binary_little_endian 1.0\nelement vertex {len(p)}\n"
    header += "property float x\nproperty float y\nproperty float z\nend_header\n"
    with open(tmp_path / "cloud.ply", "wb") as fh:  # float32, as a scanner writes it
        fh.write(header.encode())
        p.astype("<f4").tofile(fh)
    p = p.astype(np.float32).astype(float)
    r = main_json(
        capfd,
        "inspect", tmp_path / "cloud.ply", "--nominal", tmp_path / "sphere.ply", "--align", "none",
        "--coverage-samples", "4000", "--curve", "--json",
    )  # fmt: skip
    ref = reference_signed(V, F, p)
    st = r["stats"]
    pct = np.percentile(ref, [0.5, 2.5, 50, 97.5, 99.5], method="hazen")
    got = [st[k] for k in ("p0_5", "p2_5", "p50", "p97_5", "p99_5")]
    assert got == pytest.approx(pct, abs=2e-6)  # Embree's float32 closest points
    assert st["mean"] == pytest.approx(ref.mean(), abs=1e-6)
    assert st["std"] == pytest.approx(ref.std(ddof=1), abs=1e-6)
    assert st["min"] == pytest.approx(ref.min(), abs=2e-6) and st["max"] == pytest.approx(ref.max(), abs=2e-6)
    # the alignment "none" evaluated from the same distances: what align() computes apart
    nom = Nominal(TriangleMesh(V, F, name="sphere"))
    ev = align(p, nom, "none")
    assert r["rms"] == pytest.approx(ev.rms, rel=1e-9) and r["overlap"] == ev.overlap
    # histogram: numpy's counts on the reference (a value within 2 µm of an edge may move)
    h = r["histogram"]
    counts, _ = np.histogram(ref, bins=np.asarray(h["edges"]))
    assert sum(h["counts"]) == len(p)
    assert np.abs(np.asarray(h["counts"]) - counts).sum() <= 4
    # material ratio: Smc(mr) is the (1 - mr) percentile (Hazen); Gaussian heights give
    # Sk = 2.622 sigma (material_ratio's docstring), here to the sampling error of 10^4
    mr = r["material_ratio"]
    assert mr["Smc"]["2.5"] == pytest.approx(np.percentile(ref, 97.5, method="hazen"), abs=2e-6)
    assert mr["Sk"] == pytest.approx(2.622 * ref.std(), rel=0.05)
    # coverage: the cap's share of the sphere (0.7) plus the band the distance reaches past it
    c = r["coverage_info"]
    band = 2 * np.pi * R * np.sqrt(1 - CAP**2) * c["distance"] / (4 * np.pi * R**2)
    assert c["n_points_used"] == len(p) and c["note"] == ""
    assert r["coverage"] == pytest.approx(0.7 + band, abs=4 * c["std_error"] + 0.01)


def test_coverage_subsample_matches_brute_force(sphere):
    """Above max_points: a seeded subsample, distance three of its spacings; the covered
    share equals a brute-force count on that subsample with that distance."""
    V, F = sphere
    p = cap_cloud(6000, seed=1)
    out = cov.coverage(p, V, F, n_samples=1500, return_samples=True, max_points=2000)
    assert out["n_points_used"] == 2000 and "subsample of 2000 of the 6000" in out["note"]
    sub = p[np.sort(np.random.default_rng(0).choice(len(p), 2000, replace=False))]
    d2 = ((out["samples"][:, None, :] - sub[None, :, :]) ** 2).sum(axis=2)
    brute = np.sqrt(d2.min(axis=1)) <= out["distance"]
    assert np.array_equal(out["covered"], brute)
    # the subsample's spacing: sqrt(N / m) times the full cloud's, so about sqrt(3) x
    full = cov.coverage(p, V, F, n_samples=1500)
    assert out["distance"] / full["distance"] == pytest.approx(np.sqrt(3.0), rel=0.15)
    assert abs(out["fraction"] - full["fraction"]) < 0.03


def test_icp_final_evaluation_is_that_of_the_returned_transform():
    """ICP ends on a query at the returned transform (the last step, below 1e-3 σ, is not
    taken): its rms and overlap equal a fresh evaluation of that transform."""
    import open3d as o3d

    from camcmm_plugins.inspection.coverage import sample_surface

    box = o3d.geometry.TriangleMesh.create_box(60.0, 40.0, 20.0).subdivide_midpoint(3)
    V, F = np.asarray(box.vertices), np.asarray(box.triangles)
    nom = Nominal(TriangleMesh(V, F, name="box"))
    pts, tid = sample_surface(V, F, 30_000, seed=2)
    pts = pts + np.random.default_rng(1).normal(0, 0.01, len(pts))[:, None] * nom.mesh.fn[tid]
    c = pts.mean(axis=0)
    a = np.radians(1.5)
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    T_true = similarity(1.0, Rz, c - Rz @ c + np.array([0.5, -0.3, 0.2]))
    meas = apply(np.linalg.inv(T_true), pts)
    al = icp(meas, nom)
    assert al.converged, al.reason
    assert np.abs(apply(al.transform, meas) - pts).max() < 1e-3  # mm: at the noise's 1/10
    ev = align(meas, nom, "none", init=al.transform)
    assert al.rms == pytest.approx(ev.rms, rel=1e-12) and al.overlap == ev.overlap
    assert al.n_inliers == ev.n_inliers
