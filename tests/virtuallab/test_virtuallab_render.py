"""The image-rendering virtual lab: lens model, ray casting, projector lighting and
shadows, speckle, defocus, sensor noise.

References are independent of the renderer: OpenCV's projectPoints/undistortPoints for
the lens model and the analytic projector coordinate of a plane, closed-form ray-surface
geometry written out here, Goodman's speckle statistics (exponential intensity, Airy²
autocovariance), the thin-lens blur circle, Poisson + Gaussian noise variances.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import j1

from camcmm.api import CameraModel
from camcmm_plugins.virtuallab import imaging, optics, render, rig, speckle
from camcmm_plugins.virtuallab.raycast import Box, Mesh, cast
from camcmm_plugins.virtuallab.scene import Cylinder, Rectangle, Sphere

SIZE = (640, 480)


@pytest.fixture(scope="module")
def devices():
    cams, proj = rig.preset("stereo_fringe", {"image_size": list(SIZE)})
    cam = rig.device_from_dict(cams[0], "camera1").model
    pj = rig.device_from_dict({**proj, "dist_coeffs": [0.03, -0.01, 0.001, 0.0005, 0.0]}, "projector").model
    return cam, pj


def _cv_project(cam: CameraModel, X: np.ndarray) -> np.ndarray:
    p, _ = cv2.projectPoints(
        np.ascontiguousarray(X), cv2.Rodrigues(cam.rotation)[0], cam.translation, cam.camera_matrix, cam.dist_coeffs
    )
    return p.reshape(-1, 2)


def _cv_rays(cam: CameraModel, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    x = cv2.undistortPoints(
        np.stack([u.ravel(), v.ravel()], -1).reshape(-1, 1, 2).astype(float),
        cam.camera_matrix,
        cam.dist_coeffs,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15),
    ).reshape(-1, 2)
    d = np.column_stack([x, np.ones(len(x))]) @ cam.rotation
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# -- lens model ----------------------------------------------------------------------------
def test_projection_matches_opencv_with_all_distortion_terms():
    rng = np.random.default_rng(1)
    K = np.array([[1500.0, 0.3, 650.0], [0, 1490.0, 470.0], [0, 0, 1]])
    dist = np.array([-0.12, 0.2, 0.001, -0.0007, -0.05, 0.01, 0.003, -0.002, 1e-3, -2e-4, 5e-4, 1e-4])
    R, t = optics.look_at([30, -20, 300], [0, 0, 0])
    cam = CameraModel(K, dist, R, t, (1300, 960))
    X = rng.uniform(-60, 60, (5000, 3))
    u, v, Z = optics.project(cam, X)
    ref = _cv_project(cam, X)
    assert np.abs(np.column_stack([u, v]) - ref).max() < 1e-9
    assert np.all(Z > 0)


def test_pixel_rays_invert_the_projection_to_machine_precision():
    K = np.array([[1400.0, 0, 640.0], [0, 1400.0, 480.0], [0, 0, 1]])
    cam = CameraModel(
        K, [-0.135, 0.24, 0.001, -0.0005, 0.02], *optics.look_at([0, 0, 300], [0, 0, 0]), image_size=(1280, 960)
    )
    u, v = np.meshgrid(np.linspace(0, 1279, 41), np.linspace(0, 959, 31))
    d = optics.pixel_rays(cam, u.ravel(), v.ravel())
    pu, pv, _ = optics.project(cam, optics.centre(cam) + 250 * d)
    assert np.abs(pu - u.ravel()).max() < 1e-9 and np.abs(pv - v.ravel()).max() < 1e-9
    # and agrees with OpenCV's undistortion run to convergence
    assert np.abs(d - _cv_rays(cam, u, v)).max() < 1e-10


def test_grid_rays_reach_their_subpixel_centres(devices):
    cam, _ = devices
    s = 2
    d = optics.grid_rays(cam, s)
    us, vs = optics.subpixel_grid(cam.image_size, s)
    pu, pv, _ = optics.project(cam, optics.centre(cam) + 300 * d)
    assert np.abs(pu - us.ravel()).max() < 1e-6  # the spline interpolation's error, px
    assert np.abs(pv - vs.ravel()).max() < 1e-6
    assert us[0, :2].tolist() == [-0.25, 0.25]  # 2 x 2 samples at +-1/4 px about each centre


# -- ray casting ---------------------------------------------------------------------------
def test_cast_finds_the_nearest_surface_with_outward_normals(devices):
    cam, _ = devices
    scene = [
        Sphere([0, 0, 10], 10.0),
        Box([30, 20, -15], np.eye(3), [35, 9, 10]),
        Cylinder([0, -30, -20], [0, 30, -20], 5.0),
        Rectangle([0, 0, -40], [1, 0, 0], [0, 0, 1], 300, 300),
    ]
    d = optics.grid_rays(cam, 1)
    C = optics.centre(cam)
    t, idx, n = cast(scene, C, d)
    X = C + t[:, None] * d
    on = {k: idx == k for k in range(4)}
    assert all(m.sum() > 500 for m in on.values())
    assert np.abs(np.linalg.norm(X[on[0]] - [0, 0, 10], axis=1) - 10).max() < 1e-9
    q = np.abs(X[on[1]] - [30, 20, -15]) / [17.5, 4.5, 5.0]
    assert np.abs(q.max(axis=1) - 1).max() < 1e-9 and q.max() < 1 + 1e-9
    r = np.hypot(X[on[2]][:, 0], X[on[2]][:, 2] + 20)
    assert np.abs(r - 5).max() < 1e-9
    assert np.abs(X[on[3]][:, 2] + 40).max() < 1e-9
    # outward normals face the camera on every visible closed surface
    for k in range(3):
        assert (np.einsum("ij,ij->i", n[on[k]], d[on[k]]) < 1e-9).all()
    assert np.allclose(n[on[0]], (X[on[0]] - [0, 0, 10]) / 10)
    # nearest hit: no ray that ends on the plane meets the sphere on its way
    w = C - np.array([0, 0, 10.0])
    b = d[on[3]] @ w
    disc = b * b - (w @ w - 100)
    entry = -b - np.sqrt(np.maximum(disc, 0))
    assert not np.any((disc > 1e-6) & (entry > 0) & (entry < t[on[3]]))


@pytest.mark.parametrize("origin", [[0, 0, 60.0], [3, -2, 1.0], [150, 3, 1.0]])
def test_shared_origin_forms_equal_the_primitives_own_intersections(origin):
    from camcmm_plugins.virtuallab.raycast import _shared_origin

    rng = np.random.default_rng(0)
    o = np.array(origin)
    d = rng.normal(size=(100000, 3))
    d[:3000] = np.eye(3)[rng.integers(0, 3, 3000)] * rng.choice([-1, 1], (3000, 1))  # axis-parallel rays
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    prims = [
        Sphere([3, -2, 1], 8.0),
        Cylinder([0, -10, -5], [5, 12, 3], 4.0),
        Rectangle([1, 2, 0], [1, 1, 0], [0.2, 0, 1], 30, 12),
        Box([3, -2, 1], [[1, 1, 0], [-1, 1, 0], [0, 0, 1]], [20, 10, 5]),
    ]
    for p in prims:
        t1 = p.intersect(np.broadcast_to(o, d.shape), d)
        t2 = _shared_origin(p, o, d)
        assert np.array_equal(np.isfinite(t1), np.isfinite(t2)), type(p).__name__
        hit = np.isfinite(t1)
        assert hit.sum() > 100
        assert np.abs(t1[hit] - t2[hit]).max() < 1e-9


def test_mesh_box_casts_like_the_analytic_box(devices):
    cam, _ = devices
    box = Box([5, -4, 0], [[1, 1, 0], [-1, 1, 0], [0, 0, 1]], [40, 30, 20])
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]) * box.size / 2
    V = corners @ box.axes + box.center
    faces = []
    for ax in range(3):  # two triangles per face, outward
        for sgn in (-1, 1):
            idx = [i for i, c in enumerate(corners) if np.sign(c[ax]) == sgn]
            a, b = [(ax + 1) % 3, (ax + 2) % 3]
            ring = sorted(idx, key=lambda i: np.arctan2(corners[i][b], corners[i][a]))
            tri = [[ring[0], ring[1], ring[2]], [ring[0], ring[2], ring[3]]]
            faces += tri if sgn > 0 else [f[::-1] for f in tri]
    mesh = Mesh(V, faces)
    d = optics.grid_rays(cam, 1)
    C = optics.centre(cam)
    t1, i1, n1 = cast([box], C, d)
    t2, i2, n2 = cast([mesh], C, d)
    assert np.array_equal(i1 >= 0, i2 >= 0) or np.mean((i1 >= 0) != (i2 >= 0)) < 2e-4  # float32 at edges
    both = (i1 >= 0) & (i2 >= 0)
    assert both.sum() > 1000
    assert np.abs(t1[both] - t2[both]).max() < 2e-3  # Open3D casts in float32 (~300 mm away)
    assert np.median(np.abs(np.einsum("ij,ij->i", n1[both], n2[both]))) == pytest.approx(1.0)


# -- projector light, shadows, radiance -----------------------------------------------------
@pytest.mark.slow
def test_phase_of_a_rendered_flat_is_the_analytic_projector_column(devices):
    """4-step phase shifting on a tilted plane: the decoded projector column equals the
    plane point's projection into the (distorted) projector by OpenCV."""
    cam, pj = devices
    n = np.array([0.2, -0.1, 1.0])
    n /= np.linalg.norm(n)
    plane = Rectangle([5, -3, -10], [1, 0, 0], n, 400, 400)
    light = render.Lighting(ambient=0.05, projector=0.8, falloff=False)
    view = render.prepare([plane], 1.0, cam, pj, light, supersample=3)
    T = 16.0
    pw, ph = pj.image_size
    u = np.arange(pw)
    I = [
        render.radiance(view, np.tile(0.5 + 0.5 * np.cos(2 * np.pi * u / T + k * np.pi / 2), (ph, 1)), light)
        for k in range(4)
    ]
    phi = np.arctan2(I[3] - I[1], I[0] - I[2])  # I_k = a + b cos(phi + k pi/2)
    measured = np.mod(phi, 2 * np.pi) * T / (2 * np.pi)
    w, h = SIZE
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    d = _cv_rays(cam, uu, vv)
    C = -cam.rotation.T @ cam.translation
    X = C + (((plane.center - C) @ n) / (d @ n))[:, None] * d
    truth = _cv_project(pj, X)[:, 0].reshape(h, w)
    err = np.mod(measured - truth + T / 2, T) - T / 2
    ok = (view.lit == 1) & (truth > 1) & (truth < pw - 2)
    assert ok.mean() > 0.8
    # bilinear sampling of a 16-px sinusoid: phase error below 0.004 px
    assert np.abs(err[ok]).max() < 0.006
    assert abs(err[ok].mean()) < 1e-3


@pytest.mark.slow
def test_shadow_of_a_sphere_on_a_plane_is_where_geometry_puts_it(devices):
    cam, pj = devices
    sph = Sphere([0, 5, 0], 10.0)
    plane = Rectangle([0, 0, -30], [1, 0, 0], [0, 0, 1], 300, 300)
    view = render.prepare([sph, plane], 0.5, cam, pj, render.Lighting(), supersample=1)
    w, h = SIZE
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    d = _cv_rays(cam, uu, vv)
    C = -cam.rotation.T @ cam.translation
    on_plane = view.primitive.ravel() == 1
    X = C + ((-30 - C[2]) / d[:, 2])[:, None] * d
    P = -pj.rotation.T @ pj.translation
    L = P - X
    dist = np.linalg.norm(L, axis=1)
    L /= dist[:, None]
    wv = X - sph.center
    b = np.einsum("ij,ij->i", L, wv)
    disc = b * b - (np.einsum("ij,ij->i", wv, wv) - 100)
    shadow = (disc > 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0)
    lit = view.lit.ravel()
    pu = _cv_project(pj, X)
    in_proj = (pu[:, 0] > 1) & (pu[:, 0] < pj.image_size[0] - 2) & (pu[:, 1] > 1) & (pu[:, 1] < pj.image_size[1] - 2)
    on_plane &= in_proj
    assert (on_plane & shadow).sum() > 500
    # margin: pixels whose segment grazes the sphere are left out
    clear_in = on_plane & shadow & (disc > 4)
    clear_out = on_plane & ~shadow & ((disc < -4) | (-b < 0))
    assert np.all(lit[clear_in] == 0)
    assert np.all(lit[clear_out] == 1)


def test_lambertian_radiance_of_a_white_frame(devices):
    cam, pj = devices
    n = np.array([0.3, 0.2, 1.0])
    n /= np.linalg.norm(n)
    plane = Rectangle([0, 0, 0], [1, 0, 0], n, 400, 400)
    light = render.Lighting(ambient=0.03, projector=0.7, falloff=True)
    rho = 0.6
    view = render.prepare([plane], rho, cam, pj, light, supersample=1)
    img = render.radiance(view, np.ones((pj.image_size[1], pj.image_size[0])), light)
    w, h = SIZE
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    d = _cv_rays(cam, uu, vv)
    C = -cam.rotation.T @ cam.translation
    X = C + ((-C @ n) / (d @ n))[:, None] * d
    P = -pj.rotation.T @ pj.translation
    L = P - X
    r = np.linalg.norm(L, axis=1)
    d_ref = np.linalg.norm(P)  # projector aims at the origin
    want = rho * (light.ambient + light.projector * (L @ n) / r * (d_ref / r) ** 2)
    ok = view.lit.ravel() == 1
    assert ok.mean() > 0.8
    assert np.abs(img.ravel()[ok] - want[ok]).max() < 1e-6  # weights kept as float32
    dark = render.radiance(view, None, light)
    assert np.allclose(dark.ravel()[ok], rho * light.ambient)


def test_supersampling_antialiases_a_silhouette(devices):
    cam, pj = devices
    sph = Sphere([0, 0, 0], 10.0)
    light = render.Lighting(ambient=1.0, projector=0.0)
    one = render.prepare([sph], 1.0, cam, None, light, supersample=1)
    four = render.prepare([sph], 1.0, cam, None, light, supersample=4)
    assert set(np.unique(one.base)) <= {0.0, 1.0}
    edge = (four.base > 0) & (four.base < 1)
    assert edge.sum() > 100  # partial pixels along the outline
    # the covered area agrees with the sphere's apparent disc (pixel count vs 4x4 samples)
    assert abs(four.coverage.sum() - one.coverage.sum()) < 0.02 * one.coverage.sum()


# -- speckle -------------------------------------------------------------------------------
@pytest.mark.parametrize("grain", [6.0, 10.0])
def test_speckle_is_fully_developed_with_the_airy_grain(grain):
    I = speckle.speckle_intensity((768, 1024), grain, seed=4)
    assert I.std() / I.mean() == pytest.approx(1.0, abs=0.02)  # contrast 1
    for t in (0.5, 1.0, 2.0, 3.0):  # P(I > t<I>) = exp(-t)
        assert (I > t * I.mean()).mean() == pytest.approx(np.exp(-t), rel=0.03)
    c = speckle.autocovariance(I)
    rho = speckle.pupil_radius(grain)
    for lag in (1, 2, 3):
        x = 2 * np.pi * rho * lag
        want = (2 * j1(x) / x) ** 2
        assert (c[0, lag] + c[lag, 0]) / 2 == pytest.approx(want, abs=0.02)
    assert abs(c[0, int(round(grain / 2))]) < 0.03  # first zero at grain / 2


def test_speckle_grain_grows_as_the_pupil_shrinks():
    def half_width(g):  # lag (px) where the autocovariance falls to 1/2
        c = speckle.autocovariance(speckle.speckle_intensity((1024, 1024), g, seed=1))
        prof = (c[0, :40] + c[:40, 0]) / 2
        k = int(np.argmax(prof < 0.5))
        return k - 1 + (prof[k - 1] - 0.5) / (prof[k - 1] - prof[k])

    # Airy^2 [2 J1(x)/x]^2 = 1/2 at x = 2 pi rho lag: the half width in px for grain 12
    x_half = brentq(lambda x: (2 * j1(x) / x) ** 2 - 0.5, 0.1, 3.0)
    w6, w12 = half_width(6.0), half_width(12.0)
    assert w12 / w6 == pytest.approx(2.0, rel=0.08)  # half the pupil radius, twice the grain
    assert w12 == pytest.approx(x_half / (2 * np.pi * speckle.pupil_radius(12.0)), rel=0.05)


def test_speckle_pattern_for_the_projector():
    p = speckle.speckle((200, 300), 3.0, seed=2, mean=0.3)  # oversampled (grain < 4.88 px)
    assert p.shape == (200, 300) and p.min() >= 0 and p.max() <= 1
    assert p.mean() == pytest.approx(0.3, rel=0.1)
    assert np.array_equal(p, speckle.speckle((200, 300), 3.0, seed=2, mean=0.3))


# -- defocus and sensor --------------------------------------------------------------------
def test_thin_lens_blur_circle():
    # f 16 mm at f/8 focused at 300 mm: c = f^2 |Z - s| / (N Z (s - f)) on the sensor
    c = imaging.blur_diameter(np.array([300.0, 350.0, 250.0]), 16.0, 8.0, 300.0, 0.005)
    want = [0.0, 256 * 50 / (8 * 350 * 284) / 0.005, 256 * 50 / (8 * 250 * 284) / 0.005]
    assert np.allclose(c, want)


@pytest.mark.parametrize("psf", ["gaussian", "disc"])
def test_defocus_psf_has_the_second_moment_of_its_blur_circle(psf):
    img = np.zeros((81, 81))
    img[40, 40] = 1.0
    for c in (3.0, 6.0):
        out = imaging.defocus(img, np.full(img.shape, c), psf)
        assert out.sum() == pytest.approx(1.0, abs=1e-9)  # energy kept
        y, x = np.mgrid[:81, :81] - 40
        sigma = np.sqrt((out * x * x).sum())
        # a disc of diameter c has sigma c/4 per axis; the Gaussian is matched to it
        assert sigma == pytest.approx(c / 4, rel=0.06 if psf == "disc" else 0.01)


def test_sensor_noise_and_quantisation():
    rng = np.random.default_rng(5)
    s = imaging.Sensor(bits=12, full_well=10000, read_noise=20.0)
    L = np.full((400, 400), 0.3)
    img = imaging.expose(L, s, rng)
    assert img.dtype == np.uint16 and img.max() <= 4095
    dn = img.astype(float)
    gain = 4095 / 10000  # DN per electron
    assert dn.mean() == pytest.approx(0.3 * 4095, abs=0.5)
    var = gain**2 * (0.3 * 10000 + 20.0**2) + 1 / 12  # shot + read + quantisation
    assert dn.var() == pytest.approx(var, rel=0.03)
    sat = imaging.expose(np.full((10, 10), 1.5), imaging.Sensor(bits=8), rng)
    assert sat.dtype == np.uint8 and np.all(sat == 255)
    clean = imaging.expose(L, s, None)
    assert np.all(clean == round(0.3 * 4095))


@pytest.mark.slow
def test_projector_defocus_lowers_the_fringe_modulation_as_its_blur_circle_says(devices):
    cam, pj = devices
    plane = Rectangle([0, 0, -60], [1, 0, 0], [0, 0, 1], 400, 400)  # 361 mm from the projector
    light = render.Lighting(ambient=0.0, projector=0.8, falloff=False)
    lens = imaging.Lens(f_number=2.0, focus_distance=301.0)
    sharp = render.prepare([plane], 1.0, cam, pj, light, 1)
    soft = render.prepare([plane], 1.0, cam, pj, light, 1, projector_lens=lens)
    T = 16.0
    pw, ph = pj.image_size
    u = np.arange(pw)

    def modulation(view):
        I = [
            render.radiance(view, np.tile(0.5 + 0.5 * np.cos(2 * np.pi * u / T + k * np.pi / 2), (ph, 1)), light)
            for k in range(4)
        ]
        return np.hypot(I[0] - I[2], I[1] - I[3]) / 2

    ok = (sharp.lit == 1) & (soft.lit == 1)
    ratio = np.median(modulation(soft)[ok] / modulation(sharp)[ok])
    f = pj.camera_matrix[0, 0] * pj.pixel_pitch
    c = f * f * 60 / (2.0 * 361 * (301 - f)) / pj.pixel_pitch  # blur circle, projector px
    want = np.exp(-2 * np.pi**2 * (c / 4) ** 2 / T**2)  # Gaussian of sigma c/4 on a sinusoid
    assert c > 4
    assert ratio == pytest.approx(want, abs=0.02)
