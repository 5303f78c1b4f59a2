"""Monte Carlo simulation of a stereo camera system (thesis ch. 3.2-3.3, table 3.1/3.2).

A grid of points filling the measuring volume is projected with the ideal system; for
each trial the influence factors under study are perturbed by their distributions,
the image points are corrected with the perturbed parameters, triangulated with the
perturbed cameras, the centroid shift is removed (as the thesis does: only the shape of
the point set counts) and the errors accumulated per point.

Influence factors (``uncertainties`` in the input; standard uncertainties; per camera as
a list of two lists, or one list for both cameras):

==========================  =====================================  ================
factor                      value                                   default distr.
==========================  =====================================  ================
``feature_location``        sigma in px (u and v, both cameras)     normal
``focal_length``            u(fu), u(fv) in px                      rectangular
``principal_point``         u(u0), u(v0) in px (distortion centre)  rectangular
``radial_distortion``       u(k1), u(k2), u(k3) -> u(b) (eq. 3.14)  rectangular
``tangential_distortion``   u(p1), u(p2)                            rectangular
``rotation``                u(theta), u(phi), u(rho) rad, camera 2  rectangular
``translation``             u(Tx), u(Ty), u(Tz) mm -> direction     rectangular
==========================  =====================================  ================

``distributions`` and ``dof`` map factor names to overrides. A rectangular distribution
of standard uncertainty u spans ±√3 u.

Each factor is simulated on its own (its contribution in x, y and z, as in table 3.2);
per axis the contribution is the RMS over the grid of the per-point standard
deviations. The combined standard uncertainty is the root sum of squares (eq. 3.23),
with Welch–Satterthwaite dof, Student-t k and U per axis. The study ``joint`` perturbs
all factors at once.

Limits, checked before any trial runs (one line naming the value): ``iterations`` 2 ..
``MAX_ITERATIONS``, ``seed`` >= 0, at most ``MAX_POINTS`` grid points, and the memory
estimate (``TRIAL_BYTES`` per trial and point of a chunk, ``POINT_BYTES`` per grid point,
48 B per point of each chunk's statistics, kept until merged) within
``camcmm.api.check_budget``.

Work is split into chunks of ``chunk`` trials, each with its own random stream spawned
from ``np.random.SeedSequence(seed)`` (per factor, then per chunk) and the chunk
statistics are merged in chunk order (Chan et al.'s pairwise update): the local run and
a Dask run with the same seed give identical numbers.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import InputError, check_budget

from . import gum
from . import stereo_model as sm
from . import triangulation as tri

FACTORS = (
    "feature_location",
    "focal_length",
    "principal_point",
    "radial_distortion",
    "tangential_distortion",
    "rotation",
    "translation",
)
DEFAULT_DIST = {f: ("normal" if f == "feature_location" else "rectangular") for f in FACTORS}
UNITS = {"mm": 1.0, "um": 1e3, "µm": 1e3, "nm": 1e6}
STUDIES = ("convergence", "sweep", "volume_maps", "spatial", "joint")
#: Most trials per factor (the thesis ran 10^4 .. 10^5) and the largest seed: as the
#: plugin declares them (plugin.yaml), for values that come from the input file.
MAX_ITERATIONS = 100_000_000
MAX_SEED = 2**32 - 1
#: Most grid points (a 100 x 100 x 100 grid).
MAX_POINTS = 1_000_000
#: Memory per trial and grid point of a chunk (offsets, image points, triangulation,
#: errors; tracemalloc: 307 B linear, 361 B optimal) and per grid point of the set-up.
TRIAL_BYTES = 400
POINT_BYTES = 600


def _whole(value: Any, what: str, lo: int, hi: int) -> int:
    """A whole number lo .. hi from a file or the command line, or an error naming it."""
    try:
        x = float(value)
        ok = not isinstance(value, bool) and math.isfinite(x) and x == int(x)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"{what} = {value!r} is not a whole number")
    if not lo <= int(x) <= hi:
        raise InputError(f"{what} = {int(x)} must lie in {lo} .. {hi}")
    return int(x)


@dataclass
class Setup:
    """Everything a chunk needs (plain arrays: cheap to send to Dask workers)."""

    system: sm.StereoSystem
    points: np.ndarray  # (P, 3) grid, mm, camera-1 frame
    grid_shape: tuple[int, ...]
    stds: dict[str, np.ndarray]  # factor -> (V, n) or (n,) standard uncertainties
    distributions: dict[str, str]
    dofs: dict[str, float]
    method: str = "linear"
    chunk: int = 250
    unit: str = "um"
    # derived, per camera
    und: np.ndarray = field(init=False, repr=False)  # (V, P, 2) ideal undistorted pixels
    xd: np.ndarray = field(init=False, repr=False)  # (V, P, 2) ideal distorted normalised coordinates

    def __post_init__(self):
        pix, norm, _ = self.system.project(self.points, distorted=False)
        self.und = pix
        xd = []
        for v, cam in enumerate(self.system.cameras):
            xd.append(np.column_stack(sm.distort(norm[v, :, 0], norm[v, :, 1], cam.k, cam.p)))
        self.xd = np.array(xd)

    @property
    def factors(self) -> list[str]:
        return [f for f in FACTORS if f in self.stds and np.any(np.asarray(self.stds[f]) > 0)]


# ------------------------------------------------------------------ input
def _vec(v, n, what) -> np.ndarray:
    try:
        a = np.atleast_1d(np.asarray(v, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected {n} finite numbers, got {v!r}") from None
    if a.size == 1:
        a = np.repeat(a, n)
    if a.size != n or not np.all(np.isfinite(a)):
        raise InputError(f"{what}: expected {n} finite numbers, got {v!r}")
    return a


def _per_camera(value, n, what) -> np.ndarray:
    """(2, n) standard uncertainties: one list for both cameras or a list per camera."""
    if value is None:
        raise InputError(f"uncertainties.{what}: missing value")
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, (list, tuple)) for v in value):
        arr = np.array([_vec(v, n, f"uncertainties.{what}") for v in value])
    else:
        a = _vec(value, len(value) if isinstance(value, (list, tuple)) else 1, f"uncertainties.{what}")
        arr = np.vstack(
            [_vec(np.pad(a, (0, max(0, n - a.size))) if 1 < a.size < n else a, n, f"uncertainties.{what}")] * 2
        )
    if np.any(arr < 0):
        raise InputError(f"uncertainties.{what}: standard uncertainties must be >= 0, got {value!r}")
    return arr


def _mapping(doc: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    v = doc.get(key) or {}
    if not isinstance(v, Mapping):
        raise InputError(f"{key}: expected a mapping, got {v!r}")
    return v


def setup_from_dict(doc: Mapping[str, Any], method: str | None = None) -> Setup:
    """Parse and validate a Monte Carlo input document (see ``tests/data/uncertainty``)."""
    if not isinstance(doc, Mapping):
        raise InputError("Monte Carlo file: expected a mapping")
    if "calibration" in doc:
        doc = {**_from_calibration(doc["calibration"]), **{k: v for k, v in doc.items() if k != "calibration"}}
    cams = doc.get("cameras")
    if cams is None and doc.get("camera") is not None:
        cams = [doc["camera"], doc["camera"]]
    if not isinstance(cams, list) or len(cams) != 2:
        raise InputError("cameras: expected a list of two cameras (fu, fv, u0, v0, k, p, image_size)")
    c1, c2 = (sm.Camera.from_dict(c, f"camera {i + 1}") for i, c in enumerate(cams))
    st = doc.get("stereo", {})
    if not isinstance(st, Mapping):
        raise InputError("stereo: expected a mapping (baseline + angle_deg, or rotation + translation)")
    if "R" in st or "rotation_matrix" in st:
        R = _vec(st.get("R", st.get("rotation_matrix")), 9, "stereo.R").reshape(3, 3)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InputError("stereo.R is not a rotation matrix (R R^T = I, det R = +1)")
        system = sm.StereoSystem(c1, c2, R, _vec(st.get("T", st.get("translation")), 3, "stereo.T"))
    elif "translation" in st:
        ang = np.radians(_vec(st.get("rotation_deg", [0, 0, 0]), 3, "stereo.rotation_deg"))
        system = sm.StereoSystem(c1, c2, sm.rot_xyz(*ang), _vec(st["translation"], 3, "stereo.translation"))
    elif "baseline" in st:
        b, a = _vec(st["baseline"], 1, "stereo.baseline")[0], _vec(st.get("angle_deg", 0.0), 1, "stereo.angle_deg")[0]
        if not b > 0:
            raise InputError(f"stereo.baseline = {b:g} must be > 0 mm")
        system = sm.StereoSystem.from_baseline_angle(c1, c2, b, a)
    else:
        raise InputError("stereo: give baseline (mm) and angle_deg, or rotation_deg and translation, or R and T")
    if np.linalg.norm(system.T) == 0:
        raise InputError("stereo: the two cameras coincide (zero translation)")
    g = _mapping(doc, "grid")
    center = _vec(g.get("center", system.convergence_point()), 3, "grid.center")
    size = _vec(g.get("size", 50.0), 3, "grid.size")
    n = _vec(g.get("n", 10), 3, "grid.n").astype(int)
    if np.any(n < 1) or np.any(size < 0):
        raise InputError("grid: n must be >= 1 and size >= 0 along every axis")
    if np.any((size == 0) & (n > 1)):
        raise InputError(f"grid: size {size.tolist()} with n {n.tolist()} puts several points at one place")
    n_points = int(np.prod(n.astype(float)))
    if n_points > MAX_POINTS:
        raise InputError(f"grid.n {n.tolist()} makes {n_points} points; the limit is {MAX_POINTS}")
    axes = [np.linspace(c - s / 2, c + s / 2, k) if k > 1 else np.array([c]) for c, s, k in zip(center, size, n)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    if len(pts) < 2:
        raise InputError("grid: need at least two points")
    system.check_views(pts)
    unc = doc.get("uncertainties")
    if not isinstance(unc, Mapping) or not unc:
        raise InputError("uncertainties: missing (standard uncertainties per influence factor, table 3.1)")
    unknown = sorted(set(unc) - set(FACTORS))
    if unknown:
        raise InputError(f"uncertainties.{unknown[0]}: unknown factor; use {', '.join(FACTORS)}")
    stds: dict[str, np.ndarray] = {}
    for f, val in unc.items():
        if val is None:
            raise InputError(f"uncertainties.{f}: missing value")
        if f == "feature_location":
            stds[f] = _per_camera(val, 2, f)
        elif f in ("focal_length", "principal_point", "tangential_distortion"):
            stds[f] = _per_camera(val, 2, f)
        elif f == "radial_distortion":
            uk = _per_camera(val, 3, f)
            stds[f] = np.array([sm.inverse_uncertainty(cam.k, u) for cam, u in zip(system.cameras, uk)])
            stds["_radial_k"] = uk
        elif f == "rotation":
            stds[f] = _vec(val, 3, "uncertainties.rotation")
        elif f == "translation":
            uT = _vec(val, 3, "uncertainties.translation")
            stds[f] = np.array(sm.polar_uncertainty(system.T, uT))
            stds["_translation_xyz"] = uT
        if np.any(np.asarray(stds[f]) < 0):
            raise InputError(f"uncertainties.{f}: standard uncertainties must be >= 0, got {val!r}")
    dists = dict(DEFAULT_DIST)
    for f, d in _mapping(doc, "distributions").items():
        if f not in FACTORS:
            raise InputError(f"distributions.{f}: unknown factor")
        if d not in ("normal", "rectangular"):
            raise InputError(f"distributions.{f}: {d!r}; use normal or rectangular")
        dists[f] = d
    dofs = {f: math.inf for f in FACTORS}
    for f, d in _mapping(doc, "dof").items():
        if f not in FACTORS:
            raise InputError(f"dof.{f}: unknown factor")
        x = gum._number(d, f"dof.{f}")
        if not x > 0:
            raise InputError(f"dof.{f} = {x:g} must be > 0 (inf for exactly known)")
        dofs[f] = x
    m = method or doc.get("method", "linear")
    if m not in ("linear", "optimal"):
        raise InputError(f"method {m!r}: use linear or optimal")
    unit = str(doc.get("unit", "um"))
    if unit not in UNITS:
        raise InputError(f"unit {unit!r}: use mm, um or nm")
    chunk = _whole(doc.get("chunk", 250), "chunk", 1, MAX_ITERATIONS)
    return Setup(system, pts, tuple(int(k) for k in n), stds, dists, dofs, m, chunk, unit)


def _from_calibration(cal: Mapping[str, Any]) -> dict[str, Any]:
    """Cameras and standard deviations from a stereo calibration result.

    Expected keys (OpenCV's names): ``cameras`` [two {camera_matrix, dist_coeffs,
    image_size, std_intrinsics: [fx, fy, cx, cy, k1, k2, p1, p2, k3]}], ``R``, ``T`` (camera
    2 relative to camera 1, mm), ``std_extrinsics`` [rx, ry, rz (rad), tx, ty, tz (mm)],
    optional ``dof`` (e.g. number of observations minus parameters) and
    ``feature_location`` (px, e.g. the RMS reprojection error)."""
    if not isinstance(cal, Mapping) or "cameras" not in cal:
        raise InputError("calibration: expected a mapping with cameras, R, T and their standard deviations")
    cams = cal["cameras"]
    if len(cams) != 2:
        raise InputError("calibration: a stereo calibration has two cameras")
    std = [np.asarray(c.get("std_intrinsics", [0] * 9), float).ravel().tolist() + [0.0] * 9 for c in cams]
    ext = np.asarray(cal.get("std_extrinsics", [0] * 6), float).ravel().tolist() + [0.0] * 6
    unc = {
        "focal_length": [s[0:2] for s in std],
        "principal_point": [s[2:4] for s in std],
        "radial_distortion": [[s[4], s[5], s[8]] for s in std],
        "tangential_distortion": [s[6:8] for s in std],
        "rotation": ext[0:3],
        "translation": ext[3:6],
    }
    if cal.get("feature_location") is not None:
        unc["feature_location"] = cal["feature_location"]
    out: dict[str, Any] = {
        "cameras": [dict(c) for c in cams],
        "stereo": {"R": cal["R"], "T": cal["T"]},
        "uncertainties": unc,
    }
    if cal.get("dof") is not None:
        out["dof"] = {f: cal["dof"] for f in unc if f != "feature_location"}
    return out


# ------------------------------------------------------------------ the measurement model
def _draw(rng: np.random.Generator, dist: str, std: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    std = np.asarray(std, float)
    if dist == "normal":
        return rng.standard_normal(shape + std.shape) * std
    return rng.uniform(-1.0, 1.0, shape + std.shape) * (math.sqrt(3.0) * std)


def sample_offsets(
    setup: Setup, factors: Sequence[str], B: int, rng: np.random.Generator, scale: Mapping[str, float] | None = None
) -> dict[str, np.ndarray]:
    """Random offsets of the given factors for B trials (drawn in a fixed order)."""
    off = {}
    P = len(setup.points)
    for f in factors:
        std = setup.stds[f] * (scale or {}).get(f, 1.0)
        if f == "feature_location":  # (B, V, P, 2)
            d = _draw(rng, setup.distributions[f], np.ones(2), (B, 2, P))
            off[f] = d * np.asarray(std)[None, :, None, :]
        else:
            off[f] = _draw(rng, setup.distributions[f], std, (B,))
    return off


def measure(
    setup: Setup,
    off: Mapping[str, np.ndarray],
    B: int,
    points: np.ndarray | None = None,
    und: np.ndarray | None = None,
    xd: np.ndarray | None = None,
) -> np.ndarray:
    """Triangulated points (B, P, 3) for B trials with the given parameter offsets."""
    sys_ = setup.system
    und = setup.und if und is None else und
    xd = setup.xd if xd is None else xd
    P = und.shape[1]
    x = np.empty((B, P, 2, 2))
    for v, cam in enumerate(sys_.cameras):
        u = np.broadcast_to(und[v, :, 0], (B, P)).copy()
        w = np.broadcast_to(und[v, :, 1], (B, P)).copy()
        if "feature_location" in off:
            u += off["feature_location"][:, v, :, 0]
            w += off["feature_location"][:, v, :, 1]
        xdv, ydv = xd[v, :, 0], xd[v, :, 1]
        r2 = xdv * xdv + ydv * ydv
        if "radial_distortion" in off:  # eq. 3.9 with b1..b4
            db = off["radial_distortion"][:, v, :]  # (B, 4)
            s = sum(db[:, n, None] * r2[None, :] ** (n + 1) for n in range(4))
            u += cam.fu * xdv * s
            w += cam.fv * ydv * s
        if "tangential_distortion" in off:  # first order: the change of the forward term, removed
            dp = off["tangential_distortion"][:, v, :]
            u -= cam.fu * (2 * dp[:, 0, None] * xdv * ydv + dp[:, 1, None] * (r2 + 2 * xdv**2))
            w -= cam.fv * (dp[:, 0, None] * (r2 + 2 * ydv**2) + 2 * dp[:, 1, None] * xdv * ydv)
        if "principal_point" in off:  # the distortion correction about a shifted centre
            b = sm.inverse_coefficients(cam.k)
            dc = off["principal_point"][:, v, :]
            ud = cam.fu * xdv + cam.u0
            vd = cam.fv * ydv + cam.v0
            x2 = (ud[None, :] - cam.u0 - dc[:, 0, None]) / cam.fu
            y2 = (vd[None, :] - cam.v0 - dc[:, 1, None]) / cam.fv
            r2s = x2 * x2 + y2 * y2
            g2 = sum(bn * r2s ** (n + 1) for n, bn in enumerate(b))
            g1 = sum(bn * r2 ** (n + 1) for n, bn in enumerate(b))
            u += cam.fu * (x2 * g2 - xdv * g1)
            w += cam.fv * (y2 * g2 - ydv * g1)
        fu: float | np.ndarray = cam.fu
        fv: float | np.ndarray = cam.fv
        if "focal_length" in off:
            fu = cam.fu + off["focal_length"][:, v, 0, None]
            fv = cam.fv + off["focal_length"][:, v, 1, None]
        x[:, :, v, 0] = (u - cam.u0) / fu
        x[:, :, v, 1] = (w - cam.v0) / fv
    Pm = np.zeros((B, 2, 3, 4))
    Pm[:, 0, :, :3] = np.eye(3)
    R = np.broadcast_to(sys_.R, (B, 3, 3))
    T = np.broadcast_to(sys_.T, (B, 3))
    if "rotation" in off:
        a = off["rotation"]
        R = sm.rot_xyz(a[:, 0], a[:, 1], a[:, 2]) @ sys_.R
    if "translation" in off:
        Tr, th, ph = sm.to_polar(sys_.T)
        T = sm.from_polar(Tr, th + off["translation"][:, 0], ph + off["translation"][:, 1])
    Pm[:, 1, :, :3] = R
    Pm[:, 1, :, 3] = T
    if setup.method == "optimal":
        # residuals in pixels: weight each view's normalised residual by its focal length
        return tri.optimal(Pm[:, None], x, weights=np.array([c.fu for c in sys_.cameras]))
    return tri.linear(Pm[:, None], x)


def errors(setup: Setup, X: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
    """Errors (B, P, 3) in mm with each trial's centroid shift removed."""
    E = X - (setup.points if points is None else points)
    return E - E.mean(axis=1, keepdims=True)


# ------------------------------------------------------------------ chunks and merging
def simulate_chunk(
    setup: Setup, factors: Sequence[str], n: int, seed: np.random.SeedSequence, scale: Mapping[str, float] | None = None
) -> tuple[int, np.ndarray, np.ndarray]:
    """n trials with the given factors perturbed: (n, mean (P, 3), M2 (P, 3)) in mm."""
    rng = np.random.default_rng(seed)
    E = errors(setup, measure(setup, sample_offsets(setup, factors, n, rng, scale), n))
    mean = E.mean(axis=0)
    return n, mean, ((E - mean) ** 2).sum(axis=0)


def merge(a, b):
    """Chan et al.'s pairwise merge of (n, mean, M2)."""
    na, ma, Ma = a
    nb, mb, Mb = b
    n = na + nb
    d = mb - ma
    return n, ma + d * (nb / n), Ma + Mb + d * d * (na * nb / n)


def plan(iterations: int, chunk: int, seed_seq: np.random.SeedSequence) -> list[tuple[int, np.random.SeedSequence]]:
    """Chunk sizes and their spawned seeds; depends only on iterations, chunk and seed."""
    sizes = [chunk] * (iterations // chunk) + ([iterations % chunk] if iterations % chunk else [])
    return list(zip(sizes, seed_seq.spawn(len(sizes))))


def reduce_chunks(results: Sequence[tuple[int, np.ndarray, np.ndarray]], scale: float) -> dict[str, Any]:
    """Merge chunk statistics in order; per-point std (P, 3) and the convergence curve."""
    acc = results[0]
    conv_n, conv_u = [], []
    for i, r in enumerate(results):
        acc = r if i == 0 else merge(acc, r)
        n, _, M2 = acc
        if n > 1:
            conv_n.append(n)
            conv_u.append(np.sqrt((M2 / (n - 1)).mean(axis=0)) * scale)
    n, mean, M2 = acc
    std = np.sqrt(M2 / (n - 1)) * scale
    return {
        "n": int(n),
        "std": std,
        "bias": mean * scale,
        "u": np.sqrt((std**2).mean(axis=0)),
        "convergence_iterations": np.array(conv_n),
        "convergence": np.array(conv_u).reshape(-1, 3),
    }


class LocalExecutor:
    """Runs chunks in this process, in order (vectorised inside each chunk)."""

    def map(self, fn: Callable, tasks: Sequence[tuple], progress: Callable | None = None) -> list:
        out = []
        for i, t in enumerate(tasks):
            out.append(fn(*t))
            if progress is not None:
                progress((i + 1) / len(tasks), "Monte Carlo")
        return out


def run_factors(
    setup: Setup,
    groups: Mapping[str, Sequence[str]],
    iterations: int,
    seed: int,
    executor=None,
    progress: Callable | None = None,
    scale: Mapping[str, float] | None = None,
) -> dict[str, dict[str, Any]]:
    """Simulate each named group of factors; seeds: SeedSequence(seed).spawn per group
    (in the order of :data:`FACTORS`, then extra groups by name), then per chunk."""
    if iterations < 2:
        raise InputError(f"iterations = {iterations}: need at least 2")
    executor = executor or LocalExecutor()
    root = np.random.SeedSequence(seed)
    names = list(groups)
    children = dict(zip(names, root.spawn(len(names))))
    tasks, owners = [], []
    for name in names:
        for n, ss in plan(iterations, setup.chunk, children[name]):
            tasks.append((setup, tuple(groups[name]), n, ss, scale))
            owners.append(name)
    results = executor.map(simulate_chunk, tasks, progress)
    unit = UNITS[setup.unit]
    return {name: reduce_chunks([r for r, o in zip(results, owners) if o == name], unit) for name in names}


def group_names(setup: Setup) -> dict[str, list[str]]:
    return {f: [f] for f in setup.factors}


def summarise(setup: Setup, per_factor: Mapping[str, Mapping[str, Any]], p: float = 0.95) -> dict[str, Any]:
    """Table 3.2: contributions, combined (RSS), WS dof, k and U per axis."""
    names = [f for f in setup.factors if f in per_factor]
    U = np.array([per_factor[f]["u"] for f in names])  # (F, 3)
    dofs = [setup.dofs[f] for f in names]
    combined = np.sqrt((U**2).sum(axis=0))
    nu = np.atleast_1d(gum.welch_satterthwaite(U, dofs))
    k = np.array([gum.coverage_factor(float(v), p) for v in nu])
    return {
        "contributions": {f: U[i].tolist() for i, f in enumerate(names)},
        "combined": combined.tolist(),
        "dof_eff": nu.tolist(),
        "k": k.tolist(),
        "expanded": (k * combined).tolist(),
        "coverage_probability": p,
        "factor_dof": {f: setup.dofs[f] for f in names},
        "factor_distribution": {f: setup.distributions[f] for f in names},
    }


# ------------------------------------------------------------------ first-order propagation
def _param_offsets(setup: Setup, f: str, j: int, h: float) -> dict[str, np.ndarray]:
    std = np.asarray(setup.stds[f], float)
    d = np.zeros((1,) + std.shape)
    d.reshape(1, -1)[0, j] = h
    return {f: d}


def propagate(setup: Setup, factor: str, rel_step: float = 1e-3) -> dict[str, Any]:
    """First-order (GUM) propagation of one factor through the triangulation Jacobian,
    including the centroid removal: per-point std (P, 3) and the RMS per axis, in the
    output unit. Central differences with steps of ``rel_step`` standard uncertainties."""
    unit = UNITS[setup.unit]
    std = np.asarray(setup.stds[factor], float)
    P = len(setup.points)
    if factor == "feature_location":
        var = np.zeros((P, 3))
        for v in range(2):
            for c in range(2):
                s = std[v, c]
                if s == 0:
                    continue
                h = rel_step * s
                d = np.zeros((1, 2, P, 2))
                d[0, v, :, c] = h
                Jp = (measure(setup, {factor: d}, 1)[0] - measure(setup, {factor: -d}, 1)[0]) / (2 * h)  # (P, 3)
                C = (Jp * s) ** 2
                var += (1 - 2 / P) * C + C.sum(axis=0) / P**2
        per_point = np.sqrt(var) * unit
    else:
        var = np.zeros((P, 3))
        for j, s in enumerate(std.ravel()):
            if s == 0:
                continue
            h = rel_step * s
            ep = errors(setup, measure(setup, _param_offsets(setup, factor, j, h), 1))[0]
            em = errors(setup, measure(setup, _param_offsets(setup, factor, j, -h), 1))[0]
            var += ((ep - em) / (2 * h) * s) ** 2
        per_point = np.sqrt(var) * unit
    return {"std": per_point, "u": np.sqrt((per_point**2).mean(axis=0))}


# ------------------------------------------------------------------ studies
def volume_maps(setup: Setup, multiple: float = 1.0) -> dict[str, Any]:
    """Figs. 3.5-3.8: the error field of the grid (centroid removed) under a systematic
    offset of +``multiple`` standard uncertainties in every parameter of each factor.

    Each factor gives ``errors`` (P, 3) in the result's unit, ``norm`` (P,) their
    lengths, ``offset`` (the parameters' offsets) and ``range`` (3,) max - min per axis."""
    unit = UNITS[setup.unit]
    out = {}
    for f in setup.factors:
        if f == "feature_location":
            continue
        off = {f: (multiple * np.asarray(setup.stds[f], float))[None]}
        E = errors(setup, measure(setup, off, 1))[0] * unit
        out[f] = {
            "errors": E,
            "norm": np.linalg.norm(E, axis=1),
            "offset": off[f][0],
            "range": (E.max(axis=0) - E.min(axis=0)).tolist(),
        }
    return {"points": setup.points, "grid_shape": list(setup.grid_shape), "multiple": multiple, "factors": out}


def feature_sweep(setup: Setup, iterations: int, seed: int, levels: Sequence[float], executor=None) -> dict[str, Any]:
    """Fig. 3.4: the feature-location contribution for sigma from 0 to 1 px."""
    try:
        sigmas = np.asarray(levels, float)
    except (TypeError, ValueError):
        sigmas = np.zeros((0, 0))
    if sigmas.ndim != 1 or not 1 <= len(sigmas) <= 1000 or not np.all(np.isfinite(sigmas)) or np.any(sigmas < 0):
        raise InputError("sweep_levels: expected a list of 1 .. 1000 feature-location sigmas >= 0 px")
    stds = dict(setup.stds)
    stds["feature_location"] = np.ones((2, 2))
    sub = Setup(
        setup.system,
        setup.points,
        setup.grid_shape,
        stds,
        setup.distributions,
        setup.dofs,
        setup.method,
        setup.chunk,
        setup.unit,
    )
    groups = {f"{s:g}px": ["feature_location"] for s in sigmas}
    # each level is simulated (same streams per level: common random numbers, so the
    # curve is smooth) with the noise scaled to that level
    u = []
    for s_px in sigmas:
        r = run_factors(
            sub,
            {"feature_location": ["feature_location"]},
            iterations,
            seed,
            executor,
            scale={"feature_location": float(s_px)},
        )
        u.append(r["feature_location"]["u"])
    del groups
    return {"sigma_px": sigmas, "u": np.array(u), "iterations": iterations}


def spatial_variation(
    setup: Setup, iterations: int, seed: int, axis: str = "x", n: int = 21, executor=None
) -> dict[str, Any]:
    """Fig. 3.9: per-point standard deviation (all factors at once) along a line of
    points through the grid centre parallel to ``axis``."""
    i = "xyz".index(axis)
    c = setup.points.mean(axis=0)
    lo, hi = setup.points[:, i].min(), setup.points[:, i].max()
    line = np.repeat(c[None], n, axis=0)
    line[:, i] = np.linspace(lo, hi, n)
    sub = Setup(
        setup.system, line, (n,), setup.stds, setup.distributions, setup.dofs, setup.method, setup.chunk, setup.unit
    )
    res = run_factors(sub, {"joint": sub.factors}, iterations, seed, executor)["joint"]
    return {"axis": axis, "position": line[:, i], "points": line, "std": res["std"], "iterations": iterations}


# ------------------------------------------------------------------ the study
def run_study(
    doc: Mapping[str, Any],
    iterations: int | None = None,
    seed: int | None = None,
    method: str | None = None,
    scheduler: str | None = None,
    studies: Sequence[str] = (),
    progress: Callable | None = None,
    warn: Callable | None = None,
    executor=None,
) -> dict[str, Any]:
    """The whole Monte Carlo study; returns the JSON-able result (arrays as numpy).

    Besides the table (``contributions``, ``combined``, ``dof_eff``, ``k``, ``expanded``,
    per axis, in ``unit``): ``per_point`` (``points`` (P, 3) mm and per factor the (P, 3)
    standard deviations), ``per_point_norm`` (per factor (P,): the length of each point's
    (x, y, z) standard deviations) and ``studies`` (see :func:`volume_maps` and the others).
    """
    # absurd magnitudes (1e308 mm) overflow inside the model: numpy's warnings would
    # clutter stderr, the non-finite result is refused below in one line instead
    with np.errstate(all="ignore"):
        out = _run_study(doc, iterations, seed, method, scheduler, studies, progress, warn, executor)
    bad = [f for f, u in out["contributions"].items() if not np.all(np.isfinite(u))]
    if bad or not np.all(np.isfinite(out["combined"])):
        raise InputError(
            f"the model gives non-finite errors{' for ' + bad[0] if bad else ''}; "
            "check the magnitudes of the cameras, stereo, grid and uncertainties"
        )
    return out


def _run_study(doc, iterations, seed, method, scheduler, studies, progress, warn, executor) -> dict[str, Any]:
    N = _whole(iterations if iterations is not None else doc.get("iterations", 10000), "iterations", 2, MAX_ITERATIONS)
    s = _whole(seed if seed is not None else doc.get("seed", 0), "seed", 0, MAX_SEED)
    setup = setup_from_dict(doc, method)
    studies = list(studies) or list(doc.get("studies", []) or [])
    if "all" in studies:
        studies = list(STUDIES)
    bad = [x for x in studies if x not in STUDIES]
    if bad:
        raise InputError(f"study {bad[0]!r}: use {', '.join(STUDIES)} or all")
    if not setup.factors:
        raise InputError("uncertainties: every factor is zero; nothing to simulate")
    P = len(setup.points)
    groups_n = len(setup.factors) + ("joint" in studies)
    chunks = -(-N // setup.chunk)
    check_budget(
        f"Monte Carlo of {N} iterations x {P} grid points (chunk {setup.chunk})",
        TRIAL_BYTES * min(setup.chunk, N) * P + POINT_BYTES * P + 48.0 * chunks * groups_n * P,
    )
    own_client = None
    if executor is None and scheduler:
        from .distributed import DaskExecutor

        executor = own_client = DaskExecutor(scheduler, float(doc.get("scheduler_timeout", 30)))
    t0 = time.perf_counter()
    try:
        groups = group_names(setup)
        if "joint" in studies:
            groups["joint"] = setup.factors
        res = run_factors(setup, groups, N, s, executor, progress)
        out = summarise(setup, res, float(doc.get("coverage_probability", 0.95)))
        out.update(
            {
                "iterations": N,
                "seed": s,
                "method": setup.method,
                "unit": setup.unit,
                "n_points": len(setup.points),
                "grid_shape": list(setup.grid_shape),
                "executor": "dask"
                if (scheduler or executor is not None and not isinstance(executor, LocalExecutor))
                else "local",
            }
        )
        out["per_point"] = {"points": setup.points, **{f: r["std"] for f, r in res.items()}}
        # each point's standard uncertainties (x, y, z) as one length, the magnitude a map shows
        out["per_point_norm"] = {f: np.sqrt((r["std"] ** 2).sum(axis=1)) for f, r in res.items()}
        extra: dict[str, Any] = {}
        if "joint" in res:
            out["combined_joint"] = res["joint"]["u"].tolist()
        if "convergence" in studies:
            extra["convergence"] = {
                f: {"iterations": r["convergence_iterations"], "u": r["convergence"]} for f, r in res.items()
            }
        if "volume_maps" in studies:
            extra["volume_maps"] = volume_maps(setup, float(doc.get("volume_map_multiple", 1.0)))
        if "sweep" in studies:
            n_sweep = _whole(doc.get("sweep_iterations", 2000), "sweep_iterations", 2, MAX_ITERATIONS)
            extra["sweep"] = feature_sweep(
                setup, min(N, n_sweep), s + 1, doc.get("sweep_levels", np.linspace(0, 1, 11)), executor
            )
        if "spatial" in studies:
            sp = doc.get("spatial", {}) or {}
            if sp.get("axis", "x") not in ("x", "y", "z"):
                raise InputError(f"spatial.axis {sp.get('axis')!r}: use x, y or z")
            extra["spatial"] = spatial_variation(
                setup,
                min(N, _whole(sp.get("iterations", N), "spatial.iterations", 2, MAX_ITERATIONS)),
                s + 2,
                sp.get("axis", "x"),
                _whole(sp.get("n", 21), "spatial.n", 2, 10_000),
                executor,
            )
        out["studies"] = extra
        out["elapsed_s"] = time.perf_counter() - t0
        return out
    finally:
        if own_client is not None:
            own_client.close()


def write_outputs(result: Mapping[str, Any], out_dir: str | Path) -> dict[str, str]:
    """``montecarlo.json`` (the summary) and ``montecarlo.npz`` (every array)."""
    import json

    d = check_out_dir(out_dir)
    arrays: dict[str, Any] = {}  # name -> array (np.savez's keywords)

    def walk(x, key):
        if isinstance(x, Mapping):
            return {k: walk(v, f"{key}.{k}" if key else str(k)) for k, v in x.items()}
        if isinstance(x, np.ndarray):
            arrays[key] = x
            return x.tolist()
        if isinstance(x, (list, tuple)):
            return [walk(v, key) for v in x]
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, np.generic):
            return x.item()
        return x

    doc = walk(result, "")
    try:
        (d / "montecarlo.json").write_text(json.dumps(doc, indent=1))
        np.savez_compressed(d / "montecarlo.npz", **arrays)
    except OSError as exc:
        raise InputError(f"--out {d}: cannot write montecarlo.json/.npz there ({exc.strerror or exc})") from None
    return {"json": str(d / "montecarlo.json"), "npz": str(d / "montecarlo.npz")}


def check_out_dir(out_dir: str | Path, create: bool = True) -> Path:
    """The output folder, created if missing (``create``); a one-line InputError naming it
    when it is a file or cannot be created (callers check before a long study, not after)."""
    d = Path(out_dir)
    if d.exists() and not d.is_dir():
        raise InputError(f"--out {d}: exists and is not a folder")
    if not create:
        return d
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {d}: cannot create the folder ({exc.strerror or exc})") from None
    return d
