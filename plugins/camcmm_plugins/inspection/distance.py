"""Signed distances of measured points to a nominal: a triangle mesh or a reference cloud.

Point to mesh: :class:`camcmm.api.MeshDistance` (the core's camcmm.meshdistance, where its
method is described: closest point by Open3D's RaycastingScene, pseudo-normal sign, ray parity
where unsure).

Cloud to cloud
--------------
:func:`nearest_neighbour_distance` (Open3D ``core.nns``), and :func:`local_plane_distance`:
the distance to the least-squares plane of the k reference points around the nearest
one (CloudCompare's "local model"), signed by the reference's normals.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from camcmm.api import InputError, MeshDistance, PointCloud, spatial_order

#: MeshDistance and spatial_order are re-exported: align, coverage, tests and benchmarks take them from here
__all__ = [
    "MeshDistance",
    "knn",
    "local_plane_distance",
    "nearest_neighbour_distance",
    "oriented_reference_normals",
    "spatial_order",
]


def _o3d():
    import open3d as o3d

    return o3d


# ---------------------------------------------------------------------- cloud to cloud
def _nns(ref: np.ndarray):
    o3d = _o3d()
    nns = o3d.core.nns.NearestNeighborSearch(o3d.core.Tensor(np.ascontiguousarray(ref, dtype=np.float64)))
    nns.knn_index()
    return nns


def knn(ref: np.ndarray, query: np.ndarray, k: int = 1, nns=None) -> tuple[np.ndarray, np.ndarray]:
    """Indices (N, k) and distances (N, k) of the k nearest reference points (Open3D)."""
    o3d = _o3d()
    nns = nns or _nns(ref)
    idx, d2 = nns.knn_search(o3d.core.Tensor(np.ascontiguousarray(query, dtype=np.float64)), k)
    return idx.numpy().astype(np.int64), np.sqrt(d2.numpy())


def nearest_neighbour_distance(points: Any, ref_points: Any) -> tuple[np.ndarray, np.ndarray]:
    """Unsigned distance of each point to its nearest reference point, and that point's index."""
    idx, d = knn(np.asarray(ref_points, dtype=float), np.asarray(points, dtype=float), 1)
    return d[:, 0], idx[:, 0]


def oriented_reference_normals(ref: PointCloud, k: int = 16, n_orient: int = 4000) -> tuple[np.ndarray, str]:
    """Unit normals of a reference cloud and how their sign was chosen.

    The cloud's own normals when it has them; else PCA normals of k neighbours (Open3D
    ``estimate_normals``) turned to one side: a height-field-like cloud (all normals
    within 90° of the cloud's thinnest axis) towards that axis' positive side; otherwise
    ``orient_normals_consistent_tangent_plane`` on a subsample of ``n_orient`` points
    (its cost grows with the square of the points: 7 s for 20 000), each normal turned
    like its nearest subsample point's, and all of them away from the centroid on the
    whole. Walls thinner than the subsample's spacing can come out turned wrongly: give
    such references normals.
    """
    if ref.normals is not None:
        n = ref.normals / np.maximum(np.linalg.norm(ref.normals, axis=1), 1e-300)[:, None]
        return n, "given"
    o3d = _o3d()
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(ref.points))
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(k))
    n = np.asarray(pc.normals).copy()
    c = ref.points.mean(axis=0)
    _, _, vt = np.linalg.svd(ref.points - c, full_matrices=False)
    axis = vt[2] if vt[2][np.argmax(np.abs(vt[2]))] > 0 else -vt[2]
    s = n @ axis
    if np.all(np.abs(s) > 1e-3):
        return n * np.sign(s)[:, None], "height field: towards +" + "xyz"[int(np.argmax(np.abs(axis)))]
    if len(n) > n_orient:
        pick = np.random.default_rng(0).choice(len(n), n_orient, replace=False)
    else:
        pick = np.arange(len(n))
    sub = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(ref.points[pick]))
    sub.normals = o3d.utility.Vector3dVector(n[pick])
    sub.orient_normals_consistent_tangent_plane(k)
    ns = np.asarray(sub.normals)
    idx, _ = knn(ref.points[pick], ref.points, 1)
    n = n * np.where(np.einsum("ij,ij->i", n, ns[idx[:, 0]]) < 0, -1.0, 1.0)[:, None]
    if np.sum(np.einsum("ij,ij->i", ref.points - c, n)) < 0:
        n = -n
    return n, "consistent tangent planes (subsample), outward"


def local_plane_distance(
    points: Any, ref: PointCloud, k: int = 12, normals: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance to the least-squares plane of the k reference points nearest to
    each point's nearest reference point; the sign follows the reference normals.

    Returns (distance, nearest reference index). The plane passes through the centroid
    of the k neighbours and its normal is their smallest principal axis (turned to the
    side of the reference normal at the nearest point).
    """
    p = np.asarray(points, dtype=float)
    R = ref.points
    if len(R) < 3:
        raise InputError(f"{ref.name}: a reference cloud needs at least 3 points")
    k = int(min(max(k, 3), len(R)))
    if normals is None:
        normals, _ = oriented_reference_normals(ref)
    nns = _nns(R)
    nearest, _ = knn(R, p, 1, nns)
    nearest = nearest[:, 0]
    used, inv = np.unique(nearest, return_inverse=True)
    nb, _ = knn(R, R[used], k, nns)
    X = R[nb]  # (U, k, 3)
    cen = X.mean(axis=1)
    D = X - cen[:, None, :]
    C = np.einsum("uki,ukj->uij", D, D)
    _, vecs = np.linalg.eigh(C)
    pn = vecs[:, :, 0]
    pn *= np.where(np.einsum("ij,ij->i", pn, normals[used]) < 0, -1.0, 1.0)[:, None]
    d = np.einsum("ij,ij->i", p - cen[inv], pn[inv])
    return d, nearest
