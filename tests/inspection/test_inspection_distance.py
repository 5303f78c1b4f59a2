"""Signed point-to-mesh and cloud-to-cloud distances against exact references.

The references are analytic: the signed distance of a box (closed form) and of a union
of cubes (from its boundary rectangles, see test_inspection_shapes), never the mesh
code under test. Every solid is moved by a generic rigid motion away from the origin,
so nothing is axis-aligned and float32 rounding is that of a real part's position.

The hard cases are those where cloud-to-mesh tools go wrong: points near edges and
corners, points in the extension of a face's plane beyond an edge, faces split into
many coplanar triangles, concave edges, triangles wound the wrong way, a whole mesh
wound inward, a mesh with a small hole, and a non-manifold edge.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from camcmm import meshdistance
from camcmm.api import PointCloud, TriangleMesh
from camcmm_plugins.inspection import distance as D
from helpers.shapes import R_GENERIC, Polycube, box_mesh, box_sdf, l_block, rotate, unrotate

LO, HI = np.array([-10.0, -20.0, -5.0]), np.array([30.0, 10.0, 15.0])
#: Below this |reference| a point is on the surface within float32 rounding of the
#: closest point (~1e-6 of the part's size): its sign is not tested, its magnitude is.
ON_SURFACE = 1e-5
#: Magnitude tolerance: float32 closest points on a part of ~50 mm, 480 mm from the origin.
TOL = 2e-5


def hard_points(lo, hi, rng, n=20000):
    """Points where the sign is hard: at corners (two scales), along edges, in the
    extended face planes beyond edges, on the surface, and scattered in and out."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = np.array(np.meshgrid(*zip(lo, hi), indexing="ij")).reshape(3, -1).T
    P = [c + rng.normal(0, s, (n // 8, 3)) for c in corners for s in (0.01, 1.0)]
    # along the 12 edges, offset in the plane normal to the edge
    for a in range(3):
        u, v = [k for k in range(3) if k != a]
        for cu in (lo[u], hi[u]):
            for cv in (lo[v], hi[v]):
                q = np.empty((n // 8, 3))
                q[:, a] = rng.uniform(lo[a], hi[a], n // 8)
                q[:, u] = cu + rng.normal(0, 0.3, n // 8)
                q[:, v] = cv + rng.normal(0, 0.3, n // 8)
                P.append(q)
    # exactly in a face's plane, also beyond its edges
    q = rng.uniform(lo - 3, hi + 3, (n, 3))
    ax = rng.integers(0, 3, n)
    q[np.arange(n), ax] = np.where(rng.integers(0, 2, n), hi[ax], lo[ax])
    P.append(q)
    P.append(rng.uniform(lo - 5, hi + 5, (n, 3)))
    return np.concatenate(P)


def check(d, ref, what):
    err = np.abs(d - ref)
    wrong = (np.sign(d) != np.sign(ref)) & (np.abs(ref) > ON_SURFACE)
    assert wrong.sum() == 0, f"{what}: {wrong.sum()} wrong signs, e.g. ref {ref[wrong][:3]} got {d[wrong][:3]}"
    assert err.max() < TOL, f"{what}: largest error {err.max():.3g} mm"


@pytest.fixture(scope="module")
def box_case():
    rng = np.random.default_rng(0)
    V, F = box_mesh(LO, HI, 5)
    P = hard_points(LO, HI, rng)
    return V, F, P, box_sdf(P, LO, HI)


def test_box_edges_corners_extended_planes(box_case):
    V, F, P, ref = box_case
    md = D.MeshDistance((rotate(V), F))
    assert md.info.closed and md.info.n_welded > 0  # STL-like: every face had its own corners
    d = md.signed_distance(rotate(P))
    check(d, ref, "box")


@pytest.mark.slow
def test_nearest_triangle_normal_alone_fails_where_we_do_not():
    """A union of cubes has concave edges: the sign of (p - closest) · (normal of the
    triangle found) is wrong there for some points; the pseudo-normal sign is not."""
    pc = Polycube(l_block(), 10.0, 2)
    rng = np.random.default_rng(1)
    verts = np.unique(pc.vertices, axis=0)
    P = np.concatenate(
        [verts[rng.integers(0, len(verts), 100000)] + rng.normal(0, 0.3, (100000, 3)), rng.uniform(-3, 43, (100000, 3))]
    )
    ref = pc.sdf(P)
    md = D.MeshDistance((rotate(pc.vertices), pc.faces))
    d = md.signed_distance(rotate(P))
    check(d, ref, "polycube")
    # the same closest points, signed by the found triangle's normal only
    q, _, _, n = md.closest(rotate(P))
    naive = np.sign(np.einsum("ij,ij->i", rotate(P) - q, n))
    assert ((naive != np.sign(ref)) & (np.abs(ref) > ON_SURFACE)).sum() > 0, "the data set should be hard"


def test_many_coplanar_triangles_and_slivers():
    """Side faces split into 40 × 40 quads; the top face triangulated as a fan from one
    corner over its 160 perimeter vertices: long slivers meeting at one vertex, and
    zero-area triangles along the two edges at the fan's corner. Points just off the
    shared edges of coplanar triangles must get the face's sign."""
    V, F = box_mesh(LO, HI, 40)
    cen = V[F].mean(axis=1)
    F = F[~np.isclose(cen[:, 2], HI[2])]
    full = np.linspace(0, 1, 41)
    g, b = full[:-1], full[::-1][:-1]  # the same numbers as box_mesh's grid, so corners weld
    x0, x1, y0, y1, z = LO[0], HI[0], LO[1], HI[1], HI[2]
    ring = np.concatenate(
        [
            np.column_stack([x0 + g * (x1 - x0), np.full(40, y0)]),
            np.column_stack([np.full(40, x1), y0 + g * (y1 - y0)]),
            np.column_stack([x0 + b * (x1 - x0), np.full(40, y1)]),
            np.column_stack([np.full(40, x0), y0 + b * (y1 - y0)]),
        ]
    )
    ring = np.column_stack([ring, np.full(len(ring), z)])
    base = len(V)
    fan = np.array(
        [[base, base + i, base + i + 1] for i in range(1, len(ring) - 1)] + [[base, base + len(ring) - 1, base]]
    )[:-1]
    V = np.concatenate([V, ring])
    F = np.concatenate([F, fan])
    rng = np.random.default_rng(2)
    P = hard_points(LO, HI, rng, 10000)
    # points just above and below the top face, near the fan's shared edges and its corner
    ang = rng.uniform(0, np.pi / 2, 30000)
    r = rng.uniform(0, 60, 30000)
    xy = np.column_stack([x0 + r * np.cos(ang), y0 + r * np.sin(ang)])
    zz = z + rng.choice([-1, 1], 30000) * rng.uniform(1e-4, 0.05, 30000)
    P = np.concatenate([P, np.column_stack([xy, zz])])
    md = D.MeshDistance((rotate(V), F))
    assert md.info.closed and md.info.n_degenerate > 0
    check(md.signed_distance(rotate(P)), box_sdf(P, LO, HI), "coplanar slivers")


def test_flipped_triangles_and_inward_mesh(box_case):
    V, F, P, ref = box_case
    rng = np.random.default_rng(3)
    F2 = F.copy()
    flip = rng.random(len(F)) < 0.3
    F2[flip] = F2[flip][:, ::-1]
    md = D.MeshDistance((rotate(V), F2))
    assert not md.info.consistent_input and md.info.n_flipped == int(flip.sum())
    check(md.signed_distance(rotate(P)), ref, "30 % flipped")
    md = D.MeshDistance((rotate(V), F[:, ::-1]))
    assert md.info.n_flipped == len(F)
    check(md.signed_distance(rotate(P)), ref, "all flipped (inward)")


def test_small_hole():
    """Two triangles removed from the middle of the top face. Signs stay right for
    points whose closest box point is not in the hole; a single ray (all rays along one
    direction, as Open3D's compute_occupancy casts them) gets some of them wrong."""
    V, F = box_mesh(LO, HI, 20)
    cen = V[F].mean(axis=1)
    top = np.flatnonzero(np.isclose(cen[:, 2], HI[2]))
    mid = np.array([(LO[0] + HI[0]) / 2, (LO[1] + HI[1]) / 2])
    gone = top[np.argsort(np.linalg.norm(cen[top, :2] - mid, axis=1))[:2]]
    F3 = np.delete(F, gone, axis=0)
    hole = V[F[gone]].reshape(-1, 3)
    rng = np.random.default_rng(4)
    P = np.concatenate(
        [
            hard_points(LO, HI, rng, 10000),
            np.column_stack(
                [
                    rng.uniform(mid[0] - 4, mid[0] + 4, 20000),
                    rng.uniform(mid[1] - 4, mid[1] + 4, 20000),
                    rng.uniform(-5, 17, 20000),
                ]
            ),
        ]
    )
    ref = box_sdf(P, LO, HI)
    md = D.MeshDistance((rotate(V), F3))
    assert md.info.n_boundary_edges in (4, 6) and md.parity_ok
    d = md.signed_distance(rotate(P))
    # away from the hole: points nearer to the box than to the hole's bounding square
    lo_h, hi_h = hole.min(axis=0), hole.max(axis=0)
    to_hole = np.linalg.norm(P - np.clip(P, lo_h, hi_h), axis=1)
    keep = to_hole > np.abs(ref) + 1e-9
    assert keep.mean() > 0.9
    wrong = (np.sign(d) != np.sign(ref)) & (np.abs(ref) > ON_SURFACE) & keep
    assert wrong.sum() == 0
    assert np.abs(d - ref)[keep].max() < TOL
    # single-direction parity, cast here with Open3D, fails for points under the hole
    import open3d as o3d

    rays = np.empty((len(P), 6), np.float32)
    rays[:, :3] = rotate(P) - md.center
    rays[:, 3:] = R_GENERIC @ np.array([1.0, 1.0, 1.0])
    hits = md._scene.count_intersections(o3d.core.Tensor(rays)).numpy()
    single = np.where(hits % 2 == 1, -1.0, 1.0)
    assert ((single != np.sign(ref)) & (np.abs(ref) > ON_SURFACE) & keep).sum() > 0, "the data set should be hard"


def test_parity_alone_agrees(monkeypatch, box_case):
    """Every sign decided by the 7-ray parity vote (the fallback) is right too."""
    V, F, P, ref = box_case
    monkeypatch.setattr(meshdistance, "COS_MIN", 1.01)  # MeshDistance lives in the core since issue 27
    md = D.MeshDistance((rotate(V), F))
    d, det = md.signed_distance(rotate(P), details=True)
    assert det["n_parity"] > 0.85 * len(P)  # all but the points on the surface
    check(d, ref, "parity only")


def test_non_manifold_edge_uses_parity():
    """Two columns touching along one edge: four triangles share it, no consistent
    orientation exists, and parity decides every sign."""
    occ = np.zeros((2, 2, 2), bool)
    occ[0, 0, :] = True
    occ[1, 1, :] = True
    pc = Polycube(occ, 10.0, 2)
    rng = np.random.default_rng(5)
    P = np.concatenate(
        [
            np.array([10.0, 10.0, 0.0])
            + np.outer(rng.uniform(0, 20, 20000), [0, 0, 1])
            + rng.normal(0, 0.5, (20000, 3)),
            rng.uniform(-2, 22, (30000, 3)),
        ]
    )
    md = D.MeshDistance((rotate(pc.vertices), pc.faces))
    assert md.info.n_nonmanifold_edges > 0 and not md.info.orientable
    d, det = md.signed_distance(rotate(P), details=True)
    assert det["n_parity"] == len(P)
    check(d, pc.sdf(P), "non-manifold")


def test_open_surface_sign_follows_normals():
    """An open patch (a plane split into triangles, some flipped): positive on the side
    most of its area faces, distances to the patch exact."""
    V, F = box_mesh([0, 0, 0], [20, 20, 10], 10)
    cen = V[F].mean(axis=1)
    keep = np.isclose(cen[:, 2], 10.0)  # the top face only: normals +z
    F = F[keep]
    rng = np.random.default_rng(6)
    flip = rng.random(len(F)) < 0.2
    F[flip] = F[flip][:, ::-1]
    P = np.column_stack([rng.uniform(2, 18, 20000), rng.uniform(2, 18, 20000), rng.uniform(5, 15, 20000)])
    md = D.MeshDistance((rotate(V), F))
    assert not md.parity_ok
    check(md.signed_distance(rotate(P)), P[:, 2] - 10.0, "open patch")


def test_mesh_object_and_chunks(box_case):
    V, F, P, ref = box_case
    md = D.MeshDistance(TriangleMesh(rotate(V), F, name="box"))
    d, det = md.signed_distance(rotate(P), chunk=7777, details=True)
    check(d, ref, "chunked")
    # the closest points lie on the box surface, at the reported distance
    assert np.allclose(np.linalg.norm(rotate(P) - det["closest"], axis=1), np.abs(ref), atol=TOL)
    assert np.abs(box_sdf(unrotate(det["closest"]), LO, HI)).max() < TOL


def test_nearest_neighbour_matches_scipy():
    rng = np.random.default_rng(7)
    ref = rng.uniform(-50, 50, (20000, 3))
    q = rng.uniform(-60, 60, (5000, 3))
    d, idx = D.nearest_neighbour_distance(q, ref)
    d_ref, i_ref = cKDTree(ref).query(q)
    assert np.allclose(d, d_ref, rtol=0, atol=1e-9)
    assert (idx == i_ref).mean() > 0.999  # ties aside


def test_local_plane_distance_on_a_tilted_plane():
    """Reference: a grid on the plane z = 0.3 x - 0.2 y + 5 (normals given, pointing up);
    the local-plane distance equals the exact signed distance to the plane."""
    g = np.linspace(-20, 20, 121)
    X, Y = np.meshgrid(g, g)
    Z = 0.3 * X - 0.2 * Y + 5
    n = np.array([-0.3, 0.2, 1.0]) / np.linalg.norm([-0.3, 0.2, 1.0])
    ref = PointCloud(np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]), normals=np.tile(n, (X.size, 1)))
    rng = np.random.default_rng(8)
    xy = rng.uniform(-15, 15, (3000, 2))
    h = rng.uniform(-2, 2, 3000)
    p = np.column_stack([xy, 0.3 * xy[:, 0] - 0.2 * xy[:, 1] + 5]) + h[:, None] * n
    d, _ = D.local_plane_distance(p, ref, k=12)
    assert np.abs(d - h).max() < 1e-9
    # without normals: a height field, turned towards +z
    d2, _ = D.local_plane_distance(p, PointCloud(ref.points), k=12)
    assert np.abs(d2 - h).max() < 1e-9
