"""The virtual lab's simulator: exact surfaces, what a sensor sees, distortion, seeds.

Every check is against geometry computed here independently (distances to known
centres, an own ray test), not against the simulator's own bookkeeping.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from camcmm.api import ParameterError, read
from camcmm.host import default_host
from camcmm_plugins.virtuallab.distortion import VolumeDistortion
from camcmm_plugins.virtuallab.scene import Cylinder, Rectangle, Sphere
from camcmm_plugins.virtuallab.sensor import stereo_fringe


@pytest.fixture(scope="module")
def cloud():
    return default_host().algorithm("virtuallab.artefact-cloud")


def _dist(points, centre):
    return np.linalg.norm(points - np.asarray(centre), axis=1)


def test_noise_free_sphere_lies_exactly_on_its_surface(cloud):
    out = cloud(artefact="sphere", center=[5, -3, 10], diameter=20.0, noise=0.0, sensor="full", n_points=3000)
    pts = out["cloud"].points
    assert len(pts) == 3000
    assert np.abs(_dist(pts, [5, -3, 10]) - 10.0).max() < 1e-12
    assert out["truth"]["spheres"][0]["diameter"] == 20.0


def test_scanner_sees_only_the_side_facing_all_three_viewpoints(cloud):
    out = cloud(artefact="sphere", diameter=20.0, noise=0.0, n_points=4000)
    pts = out["cloud"].points
    n = pts / 10.0  # unit normals of a sphere at the origin
    for vp in stereo_fringe().viewpoints:
        d = vp - pts
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        assert (np.einsum("ij,ij->i", n, d) >= np.cos(np.radians(75)) - 1e-9).all()
    assert pts[:, 2].min() > -5.0  # nothing of the lower half is seen
    assert pts[:, 2].max() > 9.9  # the top is


def _blocked_by(points, target, sphere_centre, radius):
    """Own ray test: does the segment point -> target pass through the sphere?"""
    d = target - points
    length = np.linalg.norm(d, axis=1)
    d /= length[:, None]
    w = points - sphere_centre
    b = np.einsum("ij,ij->i", d, w)
    c = np.einsum("ij,ij->i", w, w) - radius**2
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0))
    return (disc > 0) & (t > 1e-6) & (t < length)


def test_ball_bar_self_occlusion(cloud):
    out = cloud(
        artefact="ball_bar", direction=[0, 0.5, 0.866], length=49.944, diameter=20.0, noise=0.0, n_points=20000, seed=3
    )
    pts, lab = out["cloud"].points, out["cloud"].fields["primitive"]
    s1, s2 = (np.array(s["center"]) for s in out["truth"]["spheres"])
    assert np.abs(_dist(pts[lab == 0], s1) - 10).max() < 1e-9
    assert np.abs(_dist(pts[lab == 1], s2) - 10).max() < 1e-9
    assert (lab == 2).any()  # bar points are part of the cloud
    lower = pts[lab == 0]  # s1 is the lower sphere
    for vp in stereo_fringe().viewpoints:
        assert not _blocked_by(lower, vp, s2, 10.0).any()
    # the upper sphere hides part of the lower one: fewer points on it
    assert (lab == 0).sum() < (lab == 1).sum()


def test_seeded_and_reproducible(cloud):
    a = cloud(artefact="flat", length=150, width=60, noise=0.01, n_points=2000, seed=7)["cloud"].points
    b = cloud(artefact="flat", length=150, width=60, noise=0.01, n_points=2000, seed=7)["cloud"].points
    c = cloud(artefact="flat", length=150, width=60, noise=0.01, n_points=2000, seed=8)["cloud"].points
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_normal_noise_gives_radial_residuals_of_sigma(cloud):
    out = cloud(artefact="sphere", diameter=20.0, noise=0.01, sensor="full", n_points=50000, seed=1)
    r = _dist(out["cloud"].points, [0, 0, 0]) - 10.0
    assert abs(r.std() - 0.01) < 3e-4
    assert abs(r.mean()) < 3e-4


def test_scale_error_scales_everything_about_the_volume_centre(cloud):
    s = 0.003
    out = cloud(
        artefact="ball_bar",
        center=[10, 5, 0],
        direction=[1, 1, 0],
        length=50.0,
        diameter=20.0,
        noise=0.0,
        scale_error=s,
        n_points=5000,
    )
    truth = out["truth"]
    assert truth["length_distorted"] == pytest.approx(50.0 * (1 + s), abs=1e-12)
    pts, lab = out["cloud"].points, out["cloud"].fields["primitive"]
    c1 = np.array(truth["spheres"][0]["center"]) * (1 + s)
    assert np.abs(_dist(pts[lab == 0], c1) - 10 * (1 + s)).max() < 1e-9
    assert truth["spheres"][0]["diameter_distorted"] == pytest.approx(20 * (1 + s), abs=1e-9)


def test_nonlinear_distortion_varies_the_local_scale():
    d = VolumeDistortion(quadratic=1e-3, amplitude=0.01, wavelength=40.0, reference_radius=86.6)
    assert not d.is_identity
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [50.0, 0, 0], [51.0, 0, 0]])
    y = d.apply(x)
    local = [np.linalg.norm(y[1] - y[0]), np.linalg.norm(y[3] - y[2])]
    assert abs(local[0] - local[1]) > 1e-4  # the local scale differs across the volume
    assert np.array_equal(VolumeDistortion().apply(x), x)


def test_reconstruction_scale_and_metres(cloud):
    base = cloud(artefact="sphere", noise=0.0, n_points=500, seed=2)["cloud"].points
    scaled = cloud(artefact="sphere", noise=0.0, n_points=500, seed=2, reconstruction_scale=0.37)["cloud"].points
    metres = cloud(artefact="sphere", noise=0.0, n_points=500, seed=2, unit="m")["cloud"].points
    assert np.allclose(scaled, base * 0.37, atol=1e-12)
    assert np.allclose(metres, base / 1000, atol=1e-15)


def test_primitive_intersections_are_exact():
    o = np.array([[0.0, 0, 10], [3.0, 0, 10], [20.0, 0, 10]])
    d = np.tile([0.0, 0, -1], (3, 1))
    t = Sphere([0, 0, 0], 5.0).intersect(o, d)
    assert t[0] == pytest.approx(5.0) and t[1] == pytest.approx(10 - 4.0) and np.isinf(t[2])
    cyl = Cylinder([0, -10, 0], [0, 10, 0], 2.0)  # axis along y
    t = cyl.intersect(o, d)
    assert t[0] == pytest.approx(8.0) and np.isinf(t[1]) and np.isinf(t[2])
    rect = Rectangle([0, 0, 0], [1, 0, 0], [0, 0, 1], 10.0, 4.0)
    t = rect.intersect(o, d)
    assert t[0] == pytest.approx(10.0) and t[1] == pytest.approx(10.0) and np.isinf(t[2])


def test_bad_ball_plate_lengths_are_a_parameter_error(cloud):
    with pytest.raises(ParameterError, match="triangle"):
        cloud(artefact="ball_plate", lengths=[1, 2, 10])


@pytest.mark.parametrize(
    "standard,counts",
    [("vdi2634-2", {"sphere": 10, "ball_bar": 7, "flat": 6}), ("vdi2634-3", {"sphere": 5, "ball_plate": 7})],
)
def test_acceptance_set_writes_plan_files_and_truth(tmp_path, standard, counts):
    out = (
        default_host()
        .run(
            "virtuallab.acceptance-set",
            {},
            {
                "directory": str(tmp_path),
                "standard": standard,
                "n_sphere": 500,
                "n_ball_bar": 500,
                "n_flat": 500,
                "n_ball_plate": 600,
                "repeats": 2,
                "random_scale": True,
            },
        )
        .outputs
    )
    plan = yaml.safe_load((tmp_path / "plan.yaml").read_text())
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert plan["standard"] == standard
    repeats = 2 if standard == "vdi2634-3" else 1
    for test, n in counts.items():
        entries = plan["measurements"][test]
        assert len(entries) == n
        names = [x for e in entries for x in (e if isinstance(e, list) else [e])]
        assert len(names) == n * repeats
        for name in names:
            assert (tmp_path / name).is_file()
            assert truth[name]["test"] == test
    assert len(out["files"]) == sum(counts.values()) * repeats
    first = next(iter(truth))
    assert read(tmp_path / first).n_points == truth[first]["n_points"]
    if standard == "vdi2634-3":
        assert plan["scaling"] == {"sphere": "radii", "ball_plate": "lengths"}
        assert len({t["reconstruction_scale"] for t in truth.values()}) > 1  # arbitrary scale per reconstruction
