"""Dense cloud on the CPU (issue 16): rectified pairs + SGBM + depth-map fusion.

References nobody here wrote: a sphere with a solid (3-D) texture rendered analytically for
known cameras (exact by construction: every point's true distance to the surface is known),
and the Middlebury templeRing views with the gantry's calibrated cameras and the published
bounding box of the temple.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest

from camcmm.api import Cancelled, InputError
from camcmm_plugins.photogrammetry.dense import dense_cloud

F, W, H = 500.0, 320, 240
RADIUS = 0.15  # sphere at the origin, world units (m); cameras at distance 1
DIST = np.array([-0.05, 0.01, 0.0, 0.0, 0.0])


def _look_at(centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    z = -centre / np.linalg.norm(centre)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    R = np.array([x, np.cross(z, x), z])
    return R, -R @ centre


def _views(n: int = 5, step: float = 8.0, elevation: float = 20.0) -> list[dict]:
    K = np.array([[F, 0, W / 2 - 3.5], [0, F * 1.01, H / 2 + 2.5], [0, 0, 1]])
    out = []
    for k in range(n):
        a, e = np.radians((k - (n - 1) / 2) * step), np.radians(elevation)
        C = np.array([np.sin(a) * np.cos(e), np.sin(e), -np.cos(a) * np.cos(e)])
        R, t = _look_at(C)
        out.append({"K": K, "dist": DIST, "R": R, "t": t})
    return out


_rng = np.random.default_rng(16)
_FREQ = _rng.normal(size=(40, 3))
_FREQ *= (2 * np.pi / _rng.uniform(0.005, 0.012, 40) / np.linalg.norm(_FREQ, axis=1))[:, None]
_PHASE = _rng.uniform(0, 2 * np.pi, 40)


def _undistort(view: dict, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Normalised rays of distorted pixels: fixed-point inversion of OpenCV's radial model
    (converged to < 1e-9 for these small coefficients; the tangential terms are zero)."""
    K, (k1, k2, _, _, k3) = view["K"], view["dist"]
    xd, yd = (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]
    x, y = xd.copy(), yd.copy()
    for _ in range(20):
        r2 = x * x + y * y
        g = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        x, y = xd / g, yd / g
    return np.c_[x, y]


def _render(view: dict, ss: int = 2) -> np.ndarray:
    """The solid-textured sphere through a distorted camera, ``ss`` x ``ss`` supersampled."""
    g = (np.arange(W * ss) + 0.5) / ss - 0.5, (np.arange(H * ss) + 0.5) / ss - 0.5
    u, v = np.meshgrid(*g)
    n = _undistort(view, u.ravel(), v.ravel())
    d = np.c_[n, np.ones(len(n))] @ view["R"]  # world ray directions
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    C = -view["R"].T @ view["t"]
    b = d @ C
    disc = b * b - (C @ C - RADIUS**2)
    hit = disc > 0
    s = -b[hit] - np.sqrt(disc[hit])
    X = C + s[:, None] * d[hit]
    val = np.zeros(len(d))
    val[hit] = 128 + 90 * np.sin(X @ _FREQ.T + _PHASE).mean(1) * np.sqrt(2) * 1.5
    img = val.reshape(H * ss, W * ss).reshape(H, ss, W, ss).mean((1, 3))
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


# One xdist work unit: the tests share the rendered sphere views and their dense cloud (module
# fixtures), built once per run instead of once per worker (under --dist loadgroup an ungrouped
# test is scheduled alone).
pytestmark = pytest.mark.xdist_group("photogrammetry-dense")


@pytest.fixture(scope="module")
def sphere():
    views = _views()
    return [_render(v) for v in views], views


@pytest.fixture(scope="module")
def sphere_cloud(sphere):
    return dense_cloud(*sphere)


@pytest.mark.slow
def test_sphere_depth_error_within_the_matching_precision(sphere, sphere_cloud):
    r = sphere_cloud
    assert len(r.points) > 3000, r.warnings
    err = np.abs(np.linalg.norm(r.points, axis=1) - RADIUS)
    footprint = (1 - RADIUS) / F  # lateral size of a pixel on the sphere's front, m
    # A disparity error of 1/4 px is a depth error of z/B * footprint / 4 (B/z = 2 sin 4 deg).
    expected = footprint * 0.25 / (2 * np.sin(np.radians(4)))
    assert np.median(err) < expected, (np.median(err) / footprint, expected / footprint)
    assert np.percentile(err, 95) < 4 * expected
    assert r.points.dtype == np.float64 and r.colours.dtype == np.uint8
    assert r.n_views.min() >= 3 and r.quality.min() >= 0 and r.quality.max() <= 1
    # colour from the reference image: the texture's grey, never the black background
    assert r.colours.shape == r.points.shape and np.median(r.colours) > 40


@pytest.mark.slow
def test_a_wrong_pose_lowers_the_consistent_count(sphere, sphere_cloud):
    images, views = sphere
    bad = [dict(v) for v in views]
    rot = cv2.Rodrigues(np.array([0.0, np.radians(1.0), 0.0]))[0]  # 1 deg about the camera's y
    bad[2] = {**bad[2], "R": rot @ bad[2]["R"], "t": rot @ bad[2]["t"]}
    wrong = dense_cloud(images, bad)
    assert len(wrong.points) < 0.8 * len(sphere_cloud.points), (len(wrong.points), len(sphere_cloud.points))
    ok = {(s["ref"], s["src"]): s["consistent"] / max(s["valid"], 1) for s in sphere_cloud.pairs}
    ko = {(s["ref"], s["src"]): s["consistent"] / max(s["valid"], 1) for s in wrong.pairs}
    assert ko[(2, 1)] < 0.5 * ok[(2, 1)]  # the wrong view's own depth maps find no confirmation


@pytest.mark.slow
def test_min_views_is_applied(sphere, sphere_cloud):
    loose = dense_cloud(*sphere, min_views=2, voxel=0)
    assert loose.n_views.min() == 2 and len(loose.points) > len(sphere_cloud.points)


@pytest.mark.slow
def test_depth_range_per_view(sphere, sphere_cloud):
    zr = [(1 - RADIUS - 0.02, 1 + 0.02)] * len(sphere[1])  # the sphere's true depth span, per view
    r = dense_cloud(*sphere, depth_range=zr)
    assert abs(len(r.points) - len(sphere_cloud.points)) < 0.1 * len(sphere_cloud.points)
    assert np.median(np.abs(np.linalg.norm(r.points, axis=1) - RADIUS)) < 0.5 * (1 - RADIUS) / F
    with pytest.raises(InputError, match="depth_range"):
        dense_cloud(*sphere, depth_range=[(1.0, 0.5)] * len(sphere[1]))
    # searched 53-69 px; the sphere lies at 70-82 px of disparity
    cut = dense_cloud(*sphere, depth_range=(0.01, 1.2), max_disparities=16)
    assert any("near end was cut" in w for w in cut.warnings)
    with pytest.raises(InputError, match="one pair per view"):
        dense_cloud(*sphere, depth_range=[0.5, 1.0, 2.0])


@pytest.mark.slow
def test_templering_points_lie_in_the_published_bounding_box(shared_data):
    folder = shared_data / "middlebury_mvs_templering"
    rows = [ln.split() for ln in (folder / "templeR_par.txt").read_text().splitlines()[1:] if ln.strip()]
    rows = rows[:8]  # consecutive views along the ring: keep the test short
    lat = {r[2]: float(r[0]) for r in (ln.split() for ln in (folder / "templeR_ang.txt").read_text().splitlines()) if r}
    images, views = [], []
    for row in rows:
        v = np.array(row[1:], float)
        img = cv2.cvtColor(cv2.imread(str(folder / row[0])), cv2.COLOR_BGR2RGB)
        # positive latitudes are stored turned by 180 deg against their published cameras
        # (README; benchmarks/bench_dense.py shows the epipolar check)
        images.append(np.ascontiguousarray(img[::-1, ::-1]) if lat[row[0]] > 0 else img)
        views.append({"K": v[:9].reshape(3, 3), "dist": np.zeros(5), "R": v[9:18].reshape(3, 3), "t": v[18:]})
    # The temple stands on a dark textured cloth (grey 25-55), a real surface outside the
    # published box: not matched, like the black background.
    r = dense_cloud(images, views, min_intensity=60)
    lo, hi = np.array([-0.023121, -0.038009, -0.091940]), np.array([0.078626, 0.121636, -0.017395])
    inside = np.all((r.points >= lo - 1e-3) & (r.points <= hi + 1e-3), axis=1)
    assert len(r.points) > 30000
    assert inside.mean() >= 0.99, inside.mean()


def test_bad_input_is_a_one_line_reason():
    img = np.zeros((40, 50), np.uint8)
    views = _views(3)
    with pytest.raises(InputError, match="at least 3"):
        dense_cloud([img, img], views[:2])
    with pytest.raises(InputError, match="different sizes"):
        dense_cloud([img, img, np.zeros((41, 50), np.uint8)], views)
    with pytest.raises(InputError, match="one view per image"):
        dense_cloud([img] * 3, views[:2])
    with pytest.raises(InputError, match="image 2: needs uint8"):
        dense_cloud([img, img, np.zeros((40, 50, 4), np.uint8)], views)
    with pytest.raises(InputError, match="unknown options"):
        dense_cloud([img] * 3, views, min_view=3)
    with pytest.raises(InputError, match="view 1: R is not a rotation"):
        dense_cloud([img] * 3, [views[0], {**views[1], "R": np.eye(3) * 2}, views[2]])
    with pytest.raises(InputError, match="no view pair"):
        dense_cloud([img] * 3, views, min_angle=40, max_angle=50)


def test_cancel_stops_before_the_first_pair():
    views = _views(3)
    ev = threading.Event()
    ev.set()
    with pytest.raises(Cancelled):
        dense_cloud([np.zeros((H, W), np.uint8)] * 3, views, cancel=ev)


def test_no_texture_gives_no_points_and_a_warning():
    views = _views(3)
    seen = []
    r = dense_cloud([np.full((H, W), 128, np.uint8)] * 3, views, progress=lambda f, m: seen.append(f))
    assert len(r.points) == 0 and any("consistently" in w for w in r.warnings)
    assert seen[-1] == 1.0 and seen == sorted(seen)


@pytest.mark.slow
def test_dask_gives_the_same_points_as_the_local_run(sphere, sphere_cloud):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None, silence_logs=40
    ) as cl:
        remote = dense_cloud(*sphere, scheduler=cl.scheduler_address)
    assert np.array_equal(remote.points, sphere_cloud.points)
    assert np.array_equal(remote.n_views, sphere_cloud.n_views)
    with pytest.raises(InputError, match="Dask scheduler"):
        dense_cloud(*sphere, scheduler="tcp://127.0.0.1:9", scheduler_timeout=2)


def test_depth_range_from_sparse_points():
    from camcmm_plugins.photogrammetry.dense import depth_range_from_points

    views = _views(3)
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(2000, 3))
    pts *= RADIUS / np.linalg.norm(pts, axis=1, keepdims=True)
    zr = depth_range_from_points(pts, views, margin=0.1)
    # cameras at distance 1 from the centre: visible depths span 1 - R .. 1 + R (both caps)
    assert zr.shape == (3, 2)
    assert np.all(zr[:, 0] < 1 - RADIUS + 0.01) and np.all(zr[:, 0] > 1 - RADIUS - 0.05)
    assert np.all(zr[:, 1] > 1 + RADIUS - 0.01) and np.all(zr[:, 1] < 1 + RADIUS + 0.05)
    with pytest.raises(InputError, match="fewer than 10"):
        depth_range_from_points(pts[:5], views)
