"""Alignment of a measured cloud onto a nominal (CAD mesh or reference cloud).

Conventions: every transform maps *measured* coordinates to *nominal* coordinates,
``x_nominal = s R x_measured + t``, as a 4×4 matrix ``[[s R, t], [0, 0, 0, 1]]`` (the
convention of Open3D's scaled point-to-point estimation). ``scale`` is ``s``, the factor
applied to the measured cloud; it is 1 for a rigid alignment. Lengths in mm.

Stages
------
- **Coarse**: :func:`global_registration` — FPFH features and RANSAC on feature matches
  (Open3D ``compute_fpfh_feature`` and ``registration_ransac_based_on_feature_matching``);
  with ``scale=True`` the measured cloud is first brought to the nominal's size by the
  ratio of their RMS radii and RANSAC estimates the rest of the scale. Or
  :func:`align_point_pairs` — three (or more) point pairs picked in the GUI, solved in
  closed form (Umeyama 1991, with or without scale).
- **Fine**: :func:`icp` — point-to-plane ICP, solved by Gauss-Newton with iteratively
  reweighted least squares for a robust kernel (Tukey's biweight or Huber), optionally
  with one uniform scale (7 parameters: similarity), optionally on the points inside a
  box only. Correspondences come from Open3D: against a mesh, the exact closest point on
  the triangles and that triangle's normal (``RaycastingScene``); against a cloud, the
  nearest reference point and its normal (``core.nns``).

Why not ``open3d.pipelines.registration.registration_icp``: it matches against points
only (a CAD mesh would have to be sampled, and near edges a sampled neighbour across
the edge gives a wrong plane), and its point-to-plane estimation has no scale. The
Gauss-Newton step written here is small (a 7×7 normal system per iteration); the tests
check it against ``registration_icp`` with ``TukeyLoss`` on cloud-to-cloud data.

The similarity step linearises ``x' = c + e^σ R(ω) (x - c) + τ`` about the weighted
centroid ``c`` of the current points (which decouples the scale from the translation)
and minimises ``Σ w_i (n_i · (x'_i - q_i))²``: the residual's derivative is
``[(x - c) × n, n, n · (x - c)]`` for ``(ω, τ, σ)``. The robust weights are recomputed
from the residuals at each iteration with the kernel's scale ``k`` = 4.685 σ̂ (Tukey) or
1.345 σ̂ (Huber), σ̂ = 1.4826 median |residual| (about zero, so that a common offset
counts), unless ``kernel_k`` fixes it.
Degrees of freedom the part's shape leaves undetermined (a sphere: the three rotations
about its centre; a cylinder: the turn about and the slide along its axis; a plane: two
slides and the turn about its normal) are found at every iteration from the eigenvalues
of the normalised 6×6 (7×7) normal matrix: a direction whose eigenvalue is below
``HOLD_COND`` × the largest is held at its start value, the step is solved in the
determined subspace only, and the held directions are reported in words in
``held_dofs`` (and per axis in ``weak_directions``). Open3D's ICP has no such locking
(it solves the full 6×6 system, and on a sphere the free rotations wander and the
iterations never settle), so the step is written here. The analysis uses the nominal's
smooth normals (vertex normals interpolated on the triangle, where they stay within
20° of the facet's): the facets of a tessellated sphere would otherwise "determine" its
rotations by their corners (λ/λmax ≈ 1e-4 for the 5120-facet demo ball), which pins the
part on the tessellation, not on its shape.

When the measured cloud does not overlap the nominal at the start (fewer than
``COARSE_SHARE`` of the points within ``max_distance``), :func:`align` first moves its
centroid onto the nominal's area centroid and runs a wide ICP pass, then the normal
one (stages ``coarse`` and ``icp wide``). Principal axes are not used: a partial scan's
axes differ from the whole nominal's, so a rotation from them would be wrong whenever
the scan covers part of the surface; a part that needs turning takes ``global+icp``.
The centroid shift is tried however far off the cloud lies: after it, the problem no
longer depends on where the cloud started (a shift is translation-invariant), and a
wrong match is caught by the success checks below, not by a distance limit.

Failure is reported, never hidden: ``converged`` is False with a ``reason`` when there
are too few correspondences within ``max_distance`` (no overlap), when fewer than
``min_overlap`` of the measured points end within ``inlier_distance`` of the nominal
(default 1 % of the nominal's size; points whose closest nominal point is on the rim of
an open nominal never count), when the residuals' robust standard deviation σ is more
than 1/4 of ``inlier_distance`` (two smooth surfaces slid over each other match loosely
everywhere; a part that really deviates that much needs a larger ``inlier_distance``),
when a similarity's scale drifts from its start, when RANSAC finds no consistent
feature matches, or when the iterations do not settle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camcmm.api import CadModel, GeometryError, InputError, ParameterError, PointCloud, TriangleMesh

from .distance import MeshDistance, _nns, knn, spatial_order

KERNELS = ("tukey", "huber", "none")
#: A match must hold ±BAND robust standard deviations of its residuals within the
#: inlier distance; wider residuals are what two surfaces slid over each other leave.
BAND = 4.0
#: Relative eigenvalue (of the normal matrix, rotations scaled by half the nominal's
#: diagonal) below which a direction counts as undetermined and is held. λ/λmax is the
#: squared ratio of how strongly the point-to-plane residuals respond to a unit motion
#: along that direction versus along the best-determined one: 1e-4 = a 1 % response.
#: A true symmetry with smooth normals, noise of ~1e-3 of the size and normals accurate
#: to ~1e-3 rad stays near 1e-6 (2e-6 measured on the demo ball with 7.6 µm noise);
#: a real feature that fixes a direction (a notch, keyway or flat covering >= ~1 % of
#: the area at a lever arm of the part's size) gives >= 1e-3. Between the two, 1e-4.
HOLD_COND = 1e-4
#: Share of the measured points within ``max_distance`` of the nominal at the start
#: below which :func:`align` starts from a coarse (centroid) alignment.
COARSE_SHARE = 0.1
#: ICP's first iterations run on this many of the points (a subset of the ``max_points``
#: one): they only have to bring the cloud near the optimum, and a closest-point query
#: costs in proportion to the points asked.
COARSE_POINTS = 10_000
#: Most Gauss-Newton steps on the tangent planes of one closest-point query.
INNER_STEPS = 10
#: The held directions are judged on the smooth normals of about this many points.
SMOOTH_POINTS = 10_000
_TUKEY_C, _HUBER_C = 4.685, 1.345


# --------------------------------------------------------------------------- results
@dataclass
class Alignment:
    """The result of an alignment (all lengths mm)."""

    transform: np.ndarray
    converged: bool
    method: str
    reason: str = ""
    rms: float = float("nan")
    rms_all: float = float("nan")
    overlap: float = float("nan")
    inlier_distance: float = float("nan")
    n_points: int = 0
    n_inliers: int = 0
    sigma: float = float("nan")
    iterations: int = 0
    weak_directions: list[str] = field(default_factory=list)
    held_dofs: list[str] = field(default_factory=list)
    stages: list[dict[str, Any]] = field(default_factory=list)

    @property
    def scale(self) -> float:
        return float(np.cbrt(np.linalg.det(self.transform[:3, :3])))

    @property
    def rotation(self) -> np.ndarray:
        return self.transform[:3, :3] / self.scale

    @property
    def translation(self) -> np.ndarray:
        return self.transform[:3, 3].copy()

    def apply(self, points: np.ndarray) -> np.ndarray:
        return apply(self.transform, points)

    def to_dict(self) -> dict[str, Any]:
        R = self.rotation
        # atan2(sin, cos) from the skew and trace parts: arccos of the trace alone cannot
        # resolve a rotation below ~1e-6 deg
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        angle = float(np.degrees(np.arctan2(np.linalg.norm(w) / 2, (np.trace(R) - 1) / 2)))
        return {
            "transform": self.transform.tolist(),
            "scale": self.scale,
            "rotation": R.tolist(),
            "rotation_angle_deg": angle,
            "translation": self.translation.tolist(),
            "converged": bool(self.converged),
            "reason": self.reason,
            "method": self.method,
            "rms": self.rms,
            "rms_all": self.rms_all,
            "overlap": self.overlap,
            "inlier_distance": self.inlier_distance,
            "n_points": self.n_points,
            "n_inliers": self.n_inliers,
            "sigma": self.sigma,
            "iterations": self.iterations,
            "weak_directions": list(self.weak_directions),
            "held_dofs": list(self.held_dofs),
            "stages": self.stages,
        }


def apply(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points`` (N, 3) mapped by the 4×4 ``T``.

    Written out per column: numpy's ``(N, 3) @ (3, 3)`` does not reach BLAS and was six
    times slower on 200 000 points.
    """
    p = np.asarray(points, dtype=float)
    A = T[:3, :3]
    return p[:, :1] * A[:, 0] + p[:, 1:2] * A[:, 1] + p[:, 2:3] * A[:, 2] + T[:3, 3]


def similarity(s: float, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = s * R
    T[:3, 3] = t
    return T


def _rodrigues(w: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(w))
    if th < 1e-300:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def _check_transform(T: Any, what: str = "initial transform") -> np.ndarray:
    M = np.asarray(T, dtype=float)
    if M.shape != (4, 4) or not np.isfinite(M).all():
        raise ParameterError(f"{what} must be a finite 4×4 matrix, got shape {M.shape}")
    A = M[:3, :3]
    det = np.linalg.det(A)
    if not det > 0:
        raise ParameterError(f"{what}: the 3×3 part must be a (scaled) rotation with positive determinant")
    s = np.cbrt(det)
    if np.abs(A.T @ A / s**2 - np.eye(3)).max() > 1e-6:
        raise ParameterError(f"{what}: the 3×3 part is not a scaled rotation (shear or unequal scales)")
    return M


# --------------------------------------------------------------------------- nominal
class Nominal:
    """The nominal geometry as the aligner and the deviation code need it.

    ``closest(points)`` gives the corresponding nominal points and unit normals;
    ``sample(n)`` points (with normals) spread over the nominal for global registration.
    A CAD model (``cad``) keeps its tessellation as ``mesh`` (sampling, bounds, the mesh
    queries) but gives its correspondences on the exact surface: ICP on the chords of a
    convex part would pull the cloud towards them by up to the tessellation's deflection.
    """

    def __init__(self, geometry: TriangleMesh | PointCloud | MeshDistance | CadModel, normals_k: int = 16):
        self.mesh: MeshDistance | None = None
        self.cloud: PointCloud | None = None
        self.cad: CadModel | None = None
        self.given = geometry  # as given: a mesh's chordal error is judged on it (chordal.py)
        if isinstance(geometry, CadModel):
            self.cad = geometry
            self.mesh = geometry.distance_engine.md
        elif isinstance(geometry, MeshDistance):
            self.mesh = geometry
        elif isinstance(geometry, TriangleMesh):
            self.mesh = MeshDistance(geometry)
        elif isinstance(geometry, PointCloud):
            if geometry.n_points < 10:
                raise InputError(f"{geometry.name}: a reference cloud needs at least 10 points")
            self.cloud = geometry
            self._normals = self._cloud_normals(geometry, normals_k)
            self._index = _nns(geometry.points)
        else:
            raise InputError(f"nominal: expected a mesh, a CAD model or a point cloud, got {type(geometry).__name__}")
        self._vn: np.ndarray | None = None
        self._vnf: np.ndarray | None = None
        if self.mesh is not None:
            self._vn = self._vertex_normals(self.mesh.V, self.mesh.F)
        lo, hi = self.bounds
        self.diag = float(np.linalg.norm(hi - lo))
        self.name = self.cad.name if self.cad else self.mesh.name if self.mesh else self.ref_cloud.name

    @property
    def ref_cloud(self) -> PointCloud:
        """The reference cloud, for a nominal that is not a mesh."""
        assert self.cloud is not None  # a nominal is a mesh or a cloud (__init__)
        return self.cloud

    @staticmethod
    def _cloud_normals(cloud: PointCloud, k: int) -> np.ndarray:
        if cloud.normals is not None:
            n = np.asarray(cloud.normals, dtype=float)
            return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        import open3d as o3d

        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(cloud.points))
        pc.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(k))
        return np.asarray(pc.normals).copy()

    @staticmethod
    def _vertex_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
        """Area-weighted vertex normals (unit; zero where a vertex has no area)."""
        fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        vn = np.column_stack(
            [np.bincount(F.ravel(), weights=np.repeat(fn[:, k], 3), minlength=len(V)) for k in range(3)]
        )
        return vn / np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]

    def closest_smooth(
        self, points: np.ndarray, every: int = 1
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`closest`, plus smooth unit normals (of every ``every``-th point) for the
        analysis of the undetermined directions: the vertex normals interpolated with the
        closest point's barycentric coordinates, or the facet's normal where they differ
        from it by more than 20° (a sharp edge, which must stay sharp). For a reference
        cloud its normals."""
        if self.mesh is None or self.cad is not None:  # a cloud's normals; a CAD's exact (smooth) ones
            q, n, rim = self.closest(points)
            return q, n, n[::every], rim
        q, f, b, n = self.mesh.closest(points)
        assert self._vn is not None  # made with the mesh
        if self._vnf is None:  # the corners' vertex normals per triangle, gathered once
            self._vnf = self._vn[self.mesh.F]
        fe, be, ne = f[::every], b[::every], n[::every]
        ns = np.einsum("ij,ijk->ik", be, self._vnf[fe])
        ns /= np.maximum(np.linalg.norm(ns, axis=1), 1e-300)[:, None]
        sharp = np.einsum("ij,ij->i", ns, ne) < np.cos(np.radians(20.0))
        ns[sharp] = ne[sharp]
        return q, n, ns, self.mesh.on_boundary(f, b)

    @property
    def bounds(self) -> np.ndarray:
        if self.mesh is not None:
            V = self.mesh.V + self.mesh.center
            return np.vstack([V.min(axis=0), V.max(axis=0)])
        return self.ref_cloud.bounds

    def closest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Corresponding nominal points, their unit normals, and whether each lies on the
        nominal's boundary (the rim of an open mesh or of a hole; never for a cloud)."""
        if self.cad is not None:
            _, q, _, n, rim = self.cad.closest(points)
            return q, n, rim
        if self.mesh is not None:
            q, f, b, n = self.mesh.closest(points)
            return q, n, self.mesh.on_boundary(f, b)
        idx, _ = knn(self.ref_cloud.points, points, 1, self._index)
        idx = idx[:, 0]
        return self.ref_cloud.points[idx], self._normals[idx], np.zeros(len(idx), dtype=bool)

    def sample(self, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
        if self.mesh is not None:
            from .coverage import sample_surface

            pts, tid = sample_surface(self.mesh.V + self.mesh.center, self.mesh.F, n, seed)
            return pts, self.mesh.fn[tid]
        P = self.ref_cloud.points
        if len(P) > n:
            idx = np.random.default_rng(seed).choice(len(P), n, replace=False)
            return P[idx], self._normals[idx]
        return P, self._normals


# --------------------------------------------------------------------------- point pairs
def umeyama(src: np.ndarray, dst: np.ndarray, scale: bool = False, weights: np.ndarray | None = None) -> np.ndarray:
    """Closed-form least-squares rigid or similarity transform src -> dst (Umeyama 1991)."""
    X = np.asarray(src, dtype=float)
    Y = np.asarray(dst, dtype=float)
    w = np.ones(len(X)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    mx, my = w @ X, w @ Y
    Xc, Yc = X - mx, Y - my
    S = (Yc * w[:, None]).T @ Xc
    U, D, Vt = np.linalg.svd(S)
    E = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        E[2, 2] = -1
    R = U @ E @ Vt
    s = float(np.trace(np.diag(D) @ E) / (w @ np.einsum("ij,ij->i", Xc, Xc))) if scale else 1.0
    return similarity(s, R, my - s * R @ mx)


def align_point_pairs(measured: Any, nominal: Any, scale: bool = False) -> Alignment:
    """The transform that brings picked measured points onto their nominal partners.

    ``measured`` and ``nominal``: (n, 3) with n >= 3 corresponding points (mm), not all
    on one line. Solved in closed form (Umeyama); ``rms`` is the RMS of the pairs'
    residual distances, ``stages[0]["residuals"]`` lists them.
    """
    A = np.asarray(measured, dtype=float)
    B = np.asarray(nominal, dtype=float)
    if A.shape != B.shape or A.ndim != 2 or A.shape[1] != 3:
        raise InputError(f"point pairs: measured {A.shape} and nominal {B.shape} must both be (n, 3)")
    if len(A) < 3:
        raise InputError(f"point pairs: {len(A)} pairs; pick at least 3")
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise InputError("point pairs: coordinates must be finite")
    for name, P in (("measured", A), ("nominal", B)):
        sv = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)
        if not sv[0] > 0 or sv[1] < 1e-6 * sv[0]:
            raise GeometryError(f"point pairs: the {name} points lie on one line; pick three that span a triangle")
    T = umeyama(A, B, scale)
    res = np.linalg.norm(apply(T, A) - B, axis=1)
    rms = float(np.sqrt(np.mean(res**2)))
    return Alignment(
        T,
        True,
        "pairs" + ("+scale" if scale else ""),
        rms=rms,
        rms_all=rms,
        n_points=len(A),
        n_inliers=len(A),
        overlap=float("nan"),
        stages=[{"stage": "pairs", "residuals": res.tolist(), "rms": rms}],
    )


# --------------------------------------------------------------------------- global
def global_registration(
    points: np.ndarray,
    nominal: Nominal,
    scale: bool = False,
    voxel: float | None = None,
    seed: int = 0,
    min_fitness: float = 0.2,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Coarse transform from FPFH feature matches and RANSAC (Open3D).

    ``voxel`` (default 1/60 of the nominal's diagonal) sets the downsampling; normals are
    estimated within 2 voxels and FPFH features within 5. Returns (4×4 transform, info)
    with info keys ``fitness``, ``inlier_rmse``, ``ok``, ``voxel``, ``prescale``.
    """
    import open3d as o3d

    reg = o3d.pipelines.registration
    voxel = float(voxel or nominal.diag / 60.0)
    P = np.asarray(points, dtype=float)
    pre = np.eye(4)
    prescale = 1.0
    tgt_pts, tgt_n = nominal.sample(max(20000, int(40 * (nominal.diag / voxel) ** 2)), seed)
    if scale:
        rm = np.sqrt(np.mean(np.sum((P - P.mean(axis=0)) ** 2, axis=1)))
        rn = np.sqrt(np.mean(np.sum((tgt_pts - tgt_pts.mean(axis=0)) ** 2, axis=1)))
        if not rm > 0:
            raise GeometryError("global registration: the measured points all coincide")
        prescale = float(rn / rm)
        pre = similarity(prescale, np.eye(3), -prescale * P.mean(axis=0) + P.mean(axis=0))
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(apply(pre, P)))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(tgt_pts))
    tgt.normals = o3d.utility.Vector3dVector(tgt_n)
    src = src.voxel_down_sample(voxel)
    tgt = tgt.voxel_down_sample(voxel)
    src.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    if not tgt.has_normals():
        tgt.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    feat = o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100)
    # open3d's stub makes the optional ``indices`` required
    fs = reg.compute_fpfh_feature(src, feat)  # type: ignore[call-arg]
    ft = reg.compute_fpfh_feature(tgt, feat)  # type: ignore[call-arg]
    if len(src.points) < 10 or len(tgt.points) < 10:
        return pre, {
            "ok": False,
            "fitness": 0.0,
            "inlier_rmse": None,
            "voxel": voxel,
            "prescale": prescale,
            "reason": "too few points after downsampling for features",
        }
    o3d.utility.random.seed(int(seed))
    dist = 1.5 * voxel
    # Open3D prints a warning on stdout when the mutual filter leaves few matches (and
    # then uses all matches): keep stdout clean for `--json`
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        res = reg.registration_ransac_based_on_feature_matching(
            src,
            tgt,
            fs,
            ft,
            True,
            dist,
            reg.TransformationEstimationPointToPoint(bool(scale)),
            3,
            [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(dist)],
            reg.RANSACConvergenceCriteria(100000, 0.999),
        )
    T = np.asarray(res.transformation) @ pre
    ok = bool(res.fitness >= min_fitness)
    info: dict[str, Any] = {
        "ok": ok,
        "fitness": float(res.fitness),
        "inlier_rmse": float(res.inlier_rmse),
        "voxel": voxel,
        "prescale": prescale,
        "n_source": len(src.points),
        "n_target": len(tgt.points),
    }
    if not ok:
        info["reason"] = (
            f"global registration: only {100 * res.fitness:.1f} % of the downsampled points found a "
            f"consistent feature match (need {100 * min_fitness:.0f} %); the clouds may not overlap"
        )
    return T, info


# --------------------------------------------------------------------------- ICP
def _in_box(x: np.ndarray, region: np.ndarray | None) -> np.ndarray:
    if region is None:
        return np.ones(len(x), dtype=bool)
    lo, hi = region[:3], region[3:]
    return np.all((x >= lo) & (x <= hi), axis=1)


def _weights(r: np.ndarray, kernel: str, k: float) -> np.ndarray:
    if kernel == "tukey":
        u = r / k
        return np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)
    if kernel == "huber":
        a = np.abs(r)
        return np.where(a <= k, 1.0, k / np.maximum(a, 1e-300))
    return np.ones_like(r)


_DOF_NAMES = (
    "rotation about x",
    "rotation about y",
    "rotation about z",
    "translation along x",
    "translation along y",
    "translation along z",
    "scale",
)


def _jacobian_t(
    x: np.ndarray,
    n: np.ndarray,
    w: np.ndarray,
    scale: bool,
    L: float,
    centre: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The Jacobian transposed, (6 or 7, N), built row by row in contiguous memory:
    ``np.cross`` and ``np.hstack`` on (N, 3) columns cost several times as much."""
    c = (w @ x) / w.sum() if centre is None else centre
    X = [x[:, i] - c[i] for i in range(3)]
    Nn = [np.ascontiguousarray(n[:, i]) for i in range(3)]
    Jt = np.empty((7 if scale else 6, len(x))) if out is None else out
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        np.multiply(X[j], Nn[k], out=Jt[i])
        Jt[i] -= X[k] * Nn[j]
        Jt[i] *= 1.0 / L
        Jt[3 + i] = Nn[i]
    if scale:
        Jt[6] = (X[0] * Nn[0] + X[1] * Nn[1] + X[2] * Nn[2]) / L
    return Jt, c


def _recentre(c: np.ndarray, s: np.ndarray, L: float, m: int) -> np.ndarray:
    """K with J(about s) = J(about c) @ K: (x - s) × n = (x - c) × n + (c - s) × n and
    n · (x - s) = n · (x - c) + n · (c - s), both linear in n's columns."""
    d = c - s
    K = np.eye(m)
    K[3:6, 0:3] = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]]).T / L
    if m > 6:
        K[3:6, 6] = d / L
    return K


def _n_weak(Hs: np.ndarray, cond: float = HOLD_COND) -> int:
    """Directions the (smooth normals') normal matrix leaves (numerically) undetermined."""
    lam = np.linalg.eigvalsh(Hs)
    return int(np.sum(lam <= cond * lam.max()))


@dataclass
class _Rows:
    """The Jacobian (m, N) of the residuals (facet normals) about ``c``, and that of the
    smooth normals (m, k) at the rows ``pos`` (for the held directions)."""

    J: np.ndarray
    Js: np.ndarray
    pos: np.ndarray
    c: np.ndarray


def _stacked_jacobian(x: np.ndarray, n: np.ndarray, pos: np.ndarray, ns: np.ndarray, scale: bool, L: float) -> _Rows:
    """:class:`_Rows` of the points ``x`` (N, 3) on planes of normals ``n``, the smooth
    normals ``ns`` given at the rows ``pos``, both about the centroid of ``x``."""
    J, c = _jacobian_t(x, n, np.ones(len(x)), scale, L)
    Js, _ = _jacobian_t(x[pos], ns, np.ones(len(pos)), scale, L, centre=c)
    return _Rows(J, Js, pos, c)


def _normal_matrices(
    S: _Rows, r: np.ndarray, w: np.ndarray, Hs: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H (facet normals), g and Hs (smooth normals; unless given) of the weighted least
    squares; the normal matrices are normalised by the weights' sum (only the ratios of
    Hs's eigenvalues are used)."""
    sw = w / w.sum()
    Jw = S.J * np.sqrt(sw)
    H = Jw @ Jw.T  # A Aᵀ: numpy hands it to BLAS's syrk (half the work of a general product)
    g = S.J @ (r * sw)
    if Hs is None:
        ws = w[S.pos]
        ws = ws / ws.sum() if ws.sum() > 0 else np.full(len(ws), 1.0 / max(len(ws), 1))
        Hs = S.Js @ (S.Js * ws).T
    return H, g, Hs


def _subspace_step(
    H: np.ndarray, g: np.ndarray, Hs: np.ndarray, c: np.ndarray, L: float, scale: bool, cond: float = HOLD_COND
) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray, np.ndarray]:
    """One Gauss-Newton step in the determined subspace, from the normal matrices about c.

    ``H``, ``g``: of the residuals (facet normals); ``Hs``: of the smooth normals, for
    finding the undetermined directions. Returns the step (ω [rad], τ [mm], σ), the
    centre (mm) it is taken about, the held directions by axis, the held directions as
    columns (scaled coordinates: ω × L, τ, σ × L), and the step in scaled coordinates
    about the given c (the residuals change by J(c) times it).
    """
    m = H.shape[0]
    lam, vec = np.linalg.eigh(Hs)
    keep = lam > cond * lam.max()
    K = np.eye(m)
    if (~keep).any():
        # take the step about the held rotations' axis point s: there the held directions
        # are pure rotations (and pure translations), so holding them keeps the part's turn
        # about s and its slide along the held axes exactly; about the centroid the
        # determined subspace would mix in a turn about s that the facets then pick up
        s_axis = c + _axis_offset(vec[:, ~keep], L)
        K = _recentre(c, s_axis, L, m)
        c = s_axis
        H, g, Hs = K.T @ H @ K, K.T @ g, K.T @ Hs @ K
        lam, vec = np.linalg.eigh(Hs)
        keep = lam > cond * lam.max()
    B = vec[:, keep]
    # least squares, not solve: the subspace is chosen on the smooth normals, and the facet
    # normals' matrix can still be singular in it (a sphere's cloud inside a box)
    delta = -B @ np.linalg.lstsq(B.T @ H @ B, B.T @ g, rcond=None)[0]
    weak = []
    for i in np.flatnonzero(~keep):
        v = vec[:, i]
        j = int(np.argmax(np.abs(v)))
        weak.append(f"{_DOF_NAMES[j]} (share {v[j] ** 2:.2f})")
    lin = K @ delta
    delta[:3] /= L
    if scale:
        delta[6] /= L
    return delta, c, weak, vec[:, ~keep], lin


def _vec(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{a:.4f}" for a in np.where(np.abs(v) < 5e-5, 0.0, v)) + ")"


def _split_held(null: np.ndarray, L: float) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """Held directions split into rotations and pure translations: (number of rotations,
    their ω (3, nr) in rad per unit, their τ with the pure translations taken out
    (3, nr), orthonormal pure translations (3, m))."""
    om, tau = null[:3], null[3:6]
    _, S, Vt = np.linalg.svd(om)
    nr = int(np.sum(S > 1e-6))
    Tr = tau @ Vt[nr:].T  # held pure translations (3, k - nr)
    Qt = np.zeros((3, 0))
    if Tr.size:
        Qt = np.linalg.svd(Tr, full_matrices=False)[0][:, : np.linalg.matrix_rank(Tr, 1e-6)]
    W = om @ Vt[:nr].T / L
    Tt = tau @ Vt[:nr].T
    return nr, W, Tt - Qt @ (Qt.T @ Tt), Qt


def _axis_offset(null: np.ndarray, L: float) -> np.ndarray:
    """u = s - c (mm): the held rotations' axis point s nearest the centre c about which
    ``null`` is expressed. τ = ω × (c - s) = -(ω × u) = -[ω]ₓ u, solved by least squares."""
    nr, W, Tt, _ = _split_held(null, L)
    if not nr:
        return np.zeros(3)
    A = np.vstack([np.array([[0, -wi[2], wi[1]], [wi[2], 0, -wi[0]], [-wi[1], wi[0], 0]]) for wi in W.T])
    return np.linalg.lstsq(A, -Tt.T.ravel(), rcond=1e-9)[0]


def describe_held(null: np.ndarray, c: np.ndarray, L: float) -> list[str]:
    """The held directions in words.

    ``null``: (6 or 7, k) held directions in scaled coordinates (ω × L, τ, [σ × L]) about
    the centroid ``c`` (mm, nominal coordinates). A rotation ω about an axis through s
    moves x by ω × (x - s) = ω × (x - c) + ω × (c - s): the rotational part's axis point
    is the least-squares s (nearest to c) with τ = ω × (c - s), once the pure
    translations have been taken out of τ.
    """
    if null.size == 0:
        return []
    out = []
    nr, W, _, Qt = _split_held(null, L)
    if nr:
        s = c + _axis_offset(null, L)
        if nr == 3:
            out.append(f"rotation about any axis through {_vec(s)} mm")
        elif nr == 1:
            d = W[:, 0] / np.linalg.norm(W[:, 0])
            d = d * np.sign(d[np.argmax(np.abs(d))])
            out.append(f"rotation about the axis through {_vec(s)} mm along {_vec(d)}")
        else:
            d = np.cross(W[:, 0], W[:, 1])
            d /= np.linalg.norm(d)
            out.append(f"rotation about any axis through {_vec(s)} mm perpendicular to {_vec(d)}")
    m = Qt.shape[1]
    if m == 1:
        d = Qt[:, 0] * np.sign(Qt[np.argmax(np.abs(Qt[:, 0])), 0])
        out.append(f"translation along {_vec(d)}")
    elif m == 2:
        d = np.cross(Qt[:, 0], Qt[:, 1])
        d = d * np.sign(d[np.argmax(np.abs(d))])
        out.append(f"translation in the plane normal to {_vec(d)}")
    elif m == 3:
        out.append("translation in any direction")
    if null.shape[0] > 6 and (np.abs(null[6]) > 1e-6).any() and not out:
        out.append("scale")
    return out


def _increment(delta: np.ndarray, c: np.ndarray, scale: bool) -> np.ndarray:
    """The 4×4 of x' = c + e^σ R(ω) (x - c) + τ."""
    R = _rodrigues(delta[:3])
    s = float(np.exp(delta[6])) if scale else 1.0
    D = np.eye(4)
    D[:3, :3] = s * R
    D[:3, 3] = c + delta[3:6] - s * R @ c
    return D


def _compose(T: np.ndarray, delta: np.ndarray, c: np.ndarray, scale: bool) -> np.ndarray:
    """x' = c + e^σ R(ω) (x - c) + τ applied after T."""
    return _increment(delta, c, scale) @ T


def _residuals(
    nom: Nominal, x: np.ndarray, d_in: float, closest: tuple[np.ndarray, ...] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Distances (mm) of aligned points to the nominal, and whether each lies on its rim.

    Against a reference cloud the nearest point lies up to half a point spacing away
    sideways, which would inflate rms, sigma and overlap for a correct alignment: there
    the distance is taken along the reference normal (point to plane, as the ICP does)
    where the nearest point is close; far points keep their full distance so that clouds
    that do not overlap still fail. ``closest``: ``nom.closest(x)`` when it is at hand.
    """
    q, qn, rim = nom.closest(x) if closest is None else closest
    e = np.linalg.norm(x - q, axis=1)
    if nom.mesh is None:
        plane = np.abs(np.einsum("ij,ij->i", x - q, qn))
        e = np.where(e <= 3.0 * d_in, plane, e)
    return e, rim


@dataclass
class _Step:
    """One robust Gauss-Newton step (see :func:`_robust_step`)."""

    delta: np.ndarray | None = None
    c: np.ndarray = field(default_factory=lambda: np.zeros(3))
    weak: list[str] = field(default_factory=list)
    held: np.ndarray = field(default_factory=lambda: np.zeros((6, 0)))
    k: float = 0.0
    sig: float = 0.0
    move: float = 0.0
    lin: np.ndarray = field(default_factory=lambda: np.zeros(6))
    Hs: np.ndarray | None = None
    fail: str = ""


def _robust_step(
    S: _Rows,
    r: np.ndarray,
    kernel: str,
    kernel_k: float | None,
    scale: bool,
    L: float,
    need: int,
    diag: float,
    Hs: np.ndarray | None = None,
) -> _Step:
    """The IRLS step for residuals ``r`` with the stacked Jacobian ``S`` about ``c`` (see
    :func:`_stacked_jacobian`). ``move``: how far the step moves the part (mm at its
    size), ``sig``: the residuals' robust σ (mm, about zero). ``Hs``: the smooth normals'
    normal matrix of an earlier step on the same planes (their weights barely differ:
    which directions are held does not change between such steps); ``st.Hs`` returns it."""
    sig = 1.4826 * float(np.median(np.abs(r)))  # about zero: an offset is a residual too
    if kernel_k:
        k = float(kernel_k)
    else:
        k = max((_TUKEY_C if kernel == "tukey" else _HUBER_C) * sig, 1e-6 * diag)  # float32 floor
    w = _weights(r, kernel, k)
    st = _Step(k=k, sig=sig)
    if (w > 0).sum() >= need:
        H, g, st.Hs = _normal_matrices(S, r, w, Hs)
        st.delta, st.c, st.weak, st.held, st.lin = _subspace_step(H, g, st.Hs, S.c, L, scale)
    else:
        st.weak = ["all"]
    if st.weak and kernel != "none" and not kernel_k:
        # the kernel must not leave a direction undetermined that the data fix: with
        # exact data where a face really deviates, the adaptive scale can shrink
        # below that deviation and reject every face that holds, say, z
        geo = _n_weak(_normal_matrices(S, r, np.ones(len(r)))[2])
        for _ in range(40):
            if (w > 0).sum() >= need and _n_weak(_normal_matrices(S, r, w)[2]) <= geo:
                break
            k *= 2.0
            w = _weights(r, kernel, k)
        st.k = k
        if (w > 0).sum() >= need:
            H, g, st.Hs = _normal_matrices(S, r, w)
            st.delta, st.c, st.weak, st.held, st.lin = _subspace_step(H, g, st.Hs, S.c, L, scale)
    if (w > 0).sum() < need or st.delta is None:
        st.fail = "the robust kernel rejected all but a few correspondences"
        return st
    d = st.delta
    st.move = float(L * (np.linalg.norm(d[:3]) + (abs(d[6]) if scale else 0.0)) + np.linalg.norm(d[3:6]))
    return st


def icp(
    points: Any,
    nominal: Nominal | TriangleMesh | PointCloud,
    init: Any = None,
    scale: bool = False,
    max_distance: float | None = None,
    kernel: str = "tukey",
    kernel_k: float | None = None,
    region: Any = None,
    max_iterations: int = 100,
    tolerance: float = 1e-9,
    max_points: int = 10_000,
    inlier_distance: float | None = None,
    min_overlap: float = 0.5,
    seed: int = 0,
    max_scale_change: float = 0.1,
    method: str | None = None,
) -> Alignment:
    """Point-to-plane ICP (rigid, or similarity with ``scale=True``) with a robust kernel.

    ``points``: measured (N, 3) mm. ``init``: 4×4 start (measured -> nominal), identity by
    default. ``max_distance``: correspondences farther apart are ignored (default 5 % of
    the nominal's size). ``kernel``: tukey | huber | none; ``kernel_k`` fixes its scale in
    mm (default adaptive, see the module docstring). ``region``: [xmin, ymin, zmin, xmax,
    ymax, zmax] in nominal coordinates: only measured points inside it take part (and
    count for rms/overlap). The iterations run coarse to fine: on ``COARSE_POINTS``
    (10 000) points, then on at most ``max_points`` (seeded random subsets), each until
    its steps fall below the σ/√n its optimum is known to, then on all points until a
    step would move the part by less than 1e-3 σ; that step is not taken, and the query
    that found it gives the final rms and overlap (no extra pass over all points).
    ``inlier_distance`` (default 1 % of the nominal's size) and ``min_overlap`` decide
    success, see :class:`Alignment`. With ``scale``, a scale that moves more than
    ``max_scale_change`` (relative) away from the start's is a failure too: a cloud that
    shrinks onto a patch of the nominal fits it well and means nothing.
    """
    nom = nominal if isinstance(nominal, Nominal) else Nominal(nominal)
    P = np.asarray(points, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3:
        raise InputError(f"ICP: points must have shape (N, 3), got {P.shape}")
    if kernel not in KERNELS:
        raise ParameterError(f"ICP kernel {kernel!r}: choose one of {', '.join(KERNELS)}")
    T = np.eye(4) if init is None else _check_transform(init)
    s0 = float(np.cbrt(np.linalg.det(T[:3, :3])))
    box = None
    if region is not None:
        box = np.asarray(region, dtype=float).ravel()
        if box.size != 6 or np.any(box[3:] <= box[:3]):
            raise ParameterError("region must be [xmin, ymin, zmin, xmax, ymax, zmax] with max > min")
    dmax = float(max_distance) if max_distance else 0.05 * nom.diag
    d_in = float(inlier_distance) if inlier_distance else 0.01 * nom.diag
    need = 7 if scale else 6
    label = method or ("similarity" if scale else "icp")
    rng = np.random.default_rng(seed)
    # Z-curve order, kept by the subsets: the closest-point queries walk the BVH coherently
    P = P[spatial_order(P)] if len(P) >= 20_000 else P
    # coarse to fine: COARSE_POINTS, then max_points (seeded random subsets, the first
    # inside the second), then all points. A subset's optimum is known to about σ/√n, so
    # its iterations stop once a step is below that; the last phase goes to 1e-3 σ.
    phases: list[np.ndarray] = []
    if len(P) > max_points:
        pick = rng.choice(len(P), max_points, replace=False)
        if max_points > 2 * COARSE_POINTS:
            phases.append(P[np.sort(pick[:COARSE_POINTS])])
        phases.append(P[np.sort(pick)])
    elif len(P) > 2 * COARSE_POINTS:
        phases.append(P[np.sort(rng.choice(len(P), COARSE_POINTS, replace=False))])
    phases.append(P)
    L = 0.5 * nom.diag
    it_total, settled = 0, False
    weak: list[str] = []
    held = np.zeros((need, 0))
    c_last = np.zeros(3)
    fail = ""
    last: dict[str, Any] = {}
    final: tuple[np.ndarray, ...] | None = None  # the last query, when it was made at the returned T
    for pts in phases:
        settled = False
        is_last = pts is P
        for _ in range(max_iterations):  # queries in this phase
            x = apply(T, pts)
            use = _in_box(x, box)
            xi = x if box is None else x[use]
            if len(xi) < need:
                fail = (
                    f"only {len(xi)} measured points inside the region"
                    if box is not None
                    else f"only {len(xi)} measured points"
                )
                break
            # the held directions are judged on the smooth normals of a spatially even
            # share of the points (every k-th in Z order, at least SMOOTH_POINTS): the shape's
            # symmetries show on 10 000 points as on all, at a twentieth of the cost
            every = max(1, len(xi) // SMOOTH_POINTS)
            q, n, ns_every, rim = nom.closest_smooth(xi, every)
            dq = xi - q
            e = np.sqrt(np.einsum("ij,ij->i", dq, dq))
            good = (e <= dmax) & ~rim
            if good.sum() < need:
                fail = (
                    f"no overlap: {int(good.sum())} of {len(xi)} measured points lie within max_distance "
                    f"{dmax:.4g} mm of the nominal"
                )
                break
            if good.all():
                xg, qg, ng, pos, nsg = xi, q, n, np.arange(0, len(xi), every), ns_every
            else:
                keep_s = good[::every]
                pos = (np.cumsum(good) - 1)[::every][keep_s]  # the kept smooth rows in xg
                xg, qg, ng, nsg = xi[good], q[good], n[good], ns_every[keep_s]
            r = np.einsum("ij,ij->i", ng, dq if ng is n else xg - qg)
            S = _stacked_jacobian(xg, ng, pos, nsg, scale, L)
            last = {"e": e, "n_region": len(xi)}
            # Gauss-Newton steps on these tangent planes until they settle, then a new query.
            # A plane's residual n·(x - q) stays the exact point-to-triangle distance while
            # the point's closest triangle stays the same, which the next query checks; a
            # step that query leaves (below the threshold at once) ends the phase. Between
            # queries the residuals follow the steps linearly, r + J δ; the planes are kept
            # only while the part has moved less than σ/2 since the query (near the end the
            # steps are ~1e-5 rad and ~1e-4 mm: the second-order term is far below 1e-3 σ;
            # a larger move, as from a far start, takes a new query after each step).
            moved = prev = 0.0  # mm the part moved since the query; the last step's move
            Hs = None
            for inner in range(INNER_STEPS):
                st = _robust_step(S, r, kernel, kernel_k, scale, L, need, nom.diag, Hs)
                Hs = st.Hs
                if st.fail:
                    fail = st.fail
                    break
                weak, held, c_last, last["k"] = st.weak, st.held, st.c, st.k
                # settled when the update moves the part by far less than its noise: in mm at
                # the part's size, below 1e-3 of the robust residual scale (or ``tolerance`` ×
                # size for noise-free data); on a subset, below the σ/√n its optimum is known to
                thr = max(tolerance * L, 1e-3 * st.sig, 0.0 if is_last else st.sig / np.sqrt(len(pts)))
                small = st.move < thr
                assert st.delta is not None  # a step was found (else st.fail)
                if small and inner == 0:
                    settled = True
                    if is_last:
                        # the step left untaken is below 1e-3 σ: T stays, and this query
                        # (made at T on all points) is the final evaluation's
                        final = (x, use, q, n, rim)
                    else:
                        T = _compose(T, st.delta, st.c, scale)
                        it_total += 1
                    break
                T = _compose(T, st.delta, st.c, scale)
                it_total += 1
                moved += st.move
                # the steps shrink geometrically (IRLS: by ~0.2 a step); once the next one is
                # predicted below half the threshold, the query that checks it comes now
                rate = min(st.move / prev, 0.9) if prev > 0 else 1.0
                if small or st.move * rate < 0.5 * thr or not moved < 0.5 * st.sig:
                    break  # settled on these planes, or moved too far to keep them
                prev = st.move
                r = r + S.J.T @ st.lin
            if fail or settled:
                break
        if fail:
            break
    al = Alignment(
        T,
        False,
        label,
        iterations=it_total,
        weak_directions=weak,
        held_dofs=describe_held(held, c_last, L) if weak and weak != ["all"] else [],
        inlier_distance=d_in,
        n_points=int(last.get("n_region", 0)),
    )
    if fail:
        al.reason = fail
        return al
    # final evaluation on all points (in the region)
    if final is None:
        x = apply(T, P)
        use = _in_box(x, box)
        e, rim = _residuals(nom, x[use], d_in)
    else:
        x, use, q, n, rim = final
        e, rim = _residuals(nom, x[use], d_in, (q, n, rim))
    inl = (e <= d_in) & ~rim
    al.n_points = int(use.sum())
    al.n_inliers = int(inl.sum())
    al.overlap = float(inl.mean()) if e.size else 0.0
    al.rms = float(np.sqrt(np.mean(e[inl] ** 2))) if inl.any() else float("nan")
    al.rms_all = float(np.sqrt(np.mean(e**2))) if e.size else float("nan")
    corr = e[(e <= dmax) & ~rim]
    al.sigma = float(1.4826 * np.median(corr)) if corr.size else float("nan")
    al.stages.append(
        {
            "stage": label,
            "iterations": it_total,
            "kernel": kernel,
            "kernel_k": last.get("k"),
            "max_distance": dmax,
            "max_points": max_points,
            "region": None if box is None else box.tolist(),
        }
    )
    s = al.scale
    if not settled:
        al.reason = f"the iterations did not settle within {max_iterations} (and as many on all points)"
    elif al.overlap < min_overlap:
        al.reason = (
            f"low overlap: {100 * al.overlap:.1f} % of the measured points lie within {d_in:.4g} mm of the "
            f"nominal (need {100 * min_overlap:.0f} %); the clouds may not overlap or the start was too far off"
        )
    elif not al.sigma * BAND <= d_in:
        al.reason = (
            f"the residuals are too wide for a match: their robust standard deviation {al.sigma:.4g} mm is more "
            f"than 1/{BAND:g} of the inlier distance {d_in:.4g} mm. Either the clouds do not overlap and ICP "
            f"slid one over the other, or the part deviates that much: then give a larger inlier_distance"
        )
    elif not (1e-3 < s < 1e3):
        al.reason = f"implausible scale {s:.4g}"
    elif scale and abs(np.log(s / s0)) > np.log1p(max_scale_change):
        al.reason = (
            f"the scale moved from {s0:.6g} to {s:.6g} (more than {100 * max_scale_change:.0f} %): the cloud "
            f"shrank or grew onto the nominal instead of matching it; give a better start (pairs, global)"
        )
    else:
        al.converged = True
        if weak:
            al.reason = (
                f"converged; the part's shape leaves {len(weak)} degree(s) of freedom undetermined, held at the "
                "start value: " + "; ".join(al.held_dofs or weak)
            )
    return al


# --------------------------------------------------------------------------- one call
METHODS = ("none", "icp", "similarity", "global+icp", "global+similarity", "pairs", "pairs+icp", "pairs+similarity")


def align(
    points: Any,
    nominal: Nominal | TriangleMesh | PointCloud,
    method: str = "icp",
    init: Any = None,
    pairs: dict[str, Any] | None = None,
    **icp_args: Any,
) -> Alignment:
    """Coarse + fine alignment in one call.

    ``method``: none | icp | similarity | global+icp | global+similarity | pairs |
    pairs+icp | pairs+similarity. ``pairs`` = {"measured": [[x, y, z] ...], "nominal":
    [...]} for the pairs methods (scale estimated for +similarity). ``icp_args`` go to
    :func:`icp`. ``stages`` of the result record every stage.
    """
    if method not in METHODS:
        raise ParameterError(f"alignment method {method!r}: choose one of {', '.join(METHODS)}")
    nom = nominal if isinstance(nominal, Nominal) else Nominal(nominal)
    P = np.asarray(points, dtype=float)
    T0 = np.eye(4) if init is None else _check_transform(init)
    stages: list[dict[str, Any]] = []
    scale = method.endswith("similarity")
    if method.startswith("pairs"):
        if not pairs or "measured" not in pairs or "nominal" not in pairs:
            raise ParameterError(f"alignment {method!r} needs pairs={{'measured': [...], 'nominal': [...]}}")
        pa = align_point_pairs(pairs["measured"], pairs["nominal"], scale=scale)
        T0 = pa.transform
        stages += pa.stages
        if method == "pairs":
            return _evaluate(P, nom, T0, "pairs", stages, icp_args)
    if method == "none":
        return _evaluate(P, nom, T0, "none", stages, icp_args)
    if method.startswith("global"):
        T0, info = global_registration(apply(T0, P), nom, scale=scale, seed=icp_args.get("seed", 0))
        stages.append({"stage": "global", **info})
        if not info["ok"]:
            al = Alignment(T0, False, method, reason=info["reason"], stages=stages)
            return al
        icp_args.setdefault("max_distance", 3 * info["voxel"])
    else:
        T0 = _coarse_start(P, nom, T0, icp_args, scale, stages)
    if scale and method.startswith("pairs"):
        # the pairs' scale held while a rigid ICP settles the pose, then freed: from a start
        # a few mm off, a free scale can slide a self-similar part onto itself (a stepped
        # pyramid whose steps are 0.73 x the one below shrank onto its next step)
        rigid = icp(P, nom, init=T0, scale=False, method="icp (pairs' scale held)", **icp_args)
        if np.isfinite(rigid.overlap):  # evaluated, i.e. not stopped early for want of points
            T0 = rigid.transform
            stages += rigid.stages
    al = icp(P, nom, init=T0, scale=scale, method=method, **icp_args)
    al.stages = stages + al.stages
    al.iterations += sum(int(st.get("iterations", 0)) for st in stages if st.get("stage") == "icp wide")
    return al


def _coarse_start(P: np.ndarray, nom: Nominal, T0: np.ndarray, icp_args: dict, scale: bool, stages: list) -> np.ndarray:
    """The start for ICP when the clouds do not overlap at ``T0``.

    If fewer than ``COARSE_SHARE`` of (a subset of) the measured points lie within
    ``max_distance`` of the nominal, the measured centroid is moved onto the nominal's
    area centroid and a wide ICP pass (correspondences up to the 95th percentile of the
    distances there) brings the cloud close; the normal ICP then starts from it. The
    stages ``coarse`` and ``icp wide`` record both. Returns the start (4×4).
    """
    dmax = float(icp_args.get("max_distance") or 0.05 * nom.diag)
    rng = np.random.default_rng(int(icp_args.get("seed", 0)))
    if len(P) == 0:
        return T0
    sub = P if len(P) <= 5000 else P[rng.choice(len(P), 5000, replace=False)]
    e0 = np.linalg.norm(apply(T0, sub) - nom.closest(apply(T0, sub))[0], axis=1)
    share = float(np.mean(e0 <= dmax))
    if share >= COARSE_SHARE:
        return T0
    target = nom.sample(20000, int(icp_args.get("seed", 0)))[0].mean(axis=0)
    T1 = T0.copy()
    T1[:3, 3] += target - apply(T0, P).mean(axis=0)
    e1 = np.linalg.norm(apply(T1, sub) - nom.closest(apply(T1, sub))[0], axis=1)
    wide = max(dmax, float(np.percentile(e1, 95)))
    stages.append(
        {
            "stage": "coarse",
            "kind": "centroids",
            "why": f"{100 * share:.1f} % of the measured points lie within max_distance {dmax:.4g} mm at the start",
            "translation": (T1[:3, 3] - T0[:3, 3]).tolist(),
        }
    )
    args = {k: v for k, v in icp_args.items() if k not in ("max_distance", "method")}
    pre = icp(P, nom, init=T1, scale=scale, max_distance=wide, method="icp wide", **args)
    info = pre.stages[-1] if pre.stages else {"stage": "icp wide", "iterations": pre.iterations}
    info.update({"stage": "icp wide", "reason": pre.reason, "iterations": pre.iterations})
    stages.append(info)
    if pre.reason.startswith(("no overlap", "only", "the robust kernel")):
        return T1
    return pre.transform


def _evaluate(P: np.ndarray, nom: Nominal, T: np.ndarray, method: str, stages: list, args: dict) -> Alignment:
    """An alignment given, not fitted: its rms and overlap, converged by definition."""
    d_in = float(args.get("inlier_distance") or 0.01 * nom.diag)
    box = args.get("region")
    x = apply(T, P)
    use = _in_box(x, None if box is None else np.asarray(box, dtype=float).ravel())
    e, rim = _residuals(nom, x[use], d_in)
    return evaluation(T, e, rim, nom, method, stages, args)


def evaluation(
    T: np.ndarray, e: np.ndarray, rim: np.ndarray, nom: Nominal, method: str, stages: list, args: dict
) -> Alignment:
    """The :class:`Alignment` of a transform given, not fitted (converged by definition),
    from the aligned points' distances ``e`` (mm) to the nominal and whether each closest
    point is on its rim (see :func:`_residuals`); ``args``: ``inlier_distance``."""
    d_in = float(args.get("inlier_distance") or 0.01 * nom.diag)
    inl = (e <= d_in) & ~rim
    return Alignment(
        T,
        True,
        method,
        reason="no fitting requested",
        rms=float(np.sqrt(np.mean(e[inl] ** 2))) if inl.any() else float("nan"),
        rms_all=float(np.sqrt(np.mean(e**2))) if e.size else float("nan"),
        overlap=float(inl.mean()) if e.size else 0.0,
        inlier_distance=d_in,
        n_points=int(e.size),
        n_inliers=int(inl.sum()),
        stages=stages,
    )
