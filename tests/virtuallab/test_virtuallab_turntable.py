"""The chapter-4 turntable series of the virtual lab (issue 16; thesis ch. 4.2-4.3, 6.2):
DSLR geometry, speckle physics, the images with and without speckle, the devices'
turntable sequence feeding it, and structure from motion defeated without speckle and
succeeding with it."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from camcmm.api import InputError, default_host
from camcmm_plugins.virtuallab import speckle as sp
from camcmm_plugins.virtuallab.dslr import Dslr
from camcmm_plugins.virtuallab.turntable import SeriesSpec, TurntableRenderer, TurntableSeries

#: A small series: 0.3 MP, one ray per pixel, grains ~10 px (D = 0.1 mm).
SMALL = dict(downscale=9, supersample=1, diffuser_mm=0.1)


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def test_speckle_physics_formulas():
    # objective grain λ z / D: 532 nm, 80 mm, 0.25 mm -> 170.24 µm
    assert sp.objective_grain(532, 80, 0.25) == pytest.approx(0.17024, rel=1e-12)
    # subjective grain 2.44 λ F (1 + M): F/8, M = 1 -> 20.77 µm; F/11 is 11/8 larger
    g8, g11 = sp.subjective_grain(532, 8, 1.0), sp.subjective_grain(532, 11, 1.0)
    assert g8 == pytest.approx(2.44 * 532e-6 * 8 * 2, rel=1e-12) and g11 / g8 == pytest.approx(11 / 8)
    # contrast: 1 for grains far above the pixel, sqrt(A_c / A_px) far below, and the
    # lower f-number of ch. 4 (F/8) gives less than F/11 (ch. 6.2)
    assert sp.subjective_contrast(1.0, 0.0039) == pytest.approx(1.0, abs=1e-4)
    small = 1e-4
    assert sp.subjective_contrast(small, 0.0039) == pytest.approx(np.sqrt(np.pi * small**2 / 4) / 0.0039, rel=1e-3)
    assert sp.subjective_contrast(g8, 0.0351) < sp.subjective_contrast(g11, 0.0351) < 1
    with pytest.raises(ValueError, match="must all be > 0"):
        sp.objective_grain(532, 80, 0)


@pytest.mark.parametrize("grain, contrast", [(0.5, 0.4), (8.0, 0.7)])
def test_subjective_field_has_the_contrast_asked_for(grain, contrast):
    f = sp.subjective_field((400, 400), grain, contrast, seed=1)
    # sampling error of a std over ~1e5 (fine grain) or ~3e3 (8 px grain) samples
    assert f.mean() == pytest.approx(1.0, abs=0.03)
    assert f.std() == pytest.approx(contrast, rel=0.06)


def test_fast_defocus_agrees_with_the_lab_defocus():
    from camcmm_plugins.virtuallab import imaging
    from camcmm_plugins.virtuallab.dslr import defocus

    rng = np.random.default_rng(2)
    img = cv2.GaussianBlur(rng.random((160, 200)), (0, 0), 1.5)
    c = np.tile(np.linspace(0.0, 24.0, 200), (160, 1))  # blur circles 0 .. 24 px across
    ref = imaging.defocus(img, c)  # levels 0.5 px apart everywhere
    got = defocus(img.astype(np.float32)[..., None], c)[..., 0]
    # geometric levels (1.2 apart above 2 px) interpolate σ within 10 %: on a texture that is
    # already blurred that moves values by well under 2 % of its range
    assert np.abs(got - ref).max() < 0.02 * np.ptp(img)
    assert np.abs(got - ref)[:, :16].max() < 1e-4  # below 2 px the same levels (float32)


def test_dslr_geometry_and_turntable_views_are_a_rotation_about_the_axis():
    d = Dslr(downscale=4, f_number=8, magnification=0.5)
    assert d.size == (1500, 1000) and d.pitch == pytest.approx(0.0156)
    assert d.object_distance == pytest.approx(180.0) and d.principal_distance == pytest.approx(90.0)
    s = TurntableSeries(SeriesSpec(artefact="sphere_with_scale", n_images=30, elevation_deg=40, **SMALL))
    assert np.allclose(np.diff(s.angles), 6.0)  # ch. 4: 30 images through 180 degrees
    c0 = s.camera(0)
    for k in (1, 7, 29):
        ck = s.camera(k)
        # the table turned by θ: x_cam = R0 Rz(θ) X + t0, the same camera on a turned object
        assert np.allclose(ck.rotation, c0.rotation @ _rz(s.angles[k]), atol=1e-12)
        assert np.allclose(ck.translation, c0.translation, atol=1e-9)
    C = -c0.rotation.T @ c0.translation
    rel = C - s.target
    assert np.linalg.norm(rel) == pytest.approx(s.dslr.object_distance)
    assert np.degrees(np.arcsin(rel[2] / np.linalg.norm(rel))) == pytest.approx(40.0)
    assert s.target[:2].tolist() == [0.0, 0.0]  # the aim lies on the table's axis
    # every sphere projects into every image, for the ball plate (ch. 4.3's lengths) too
    plate = TurntableSeries(SeriesSpec(artefact="ball_plate", n_images=30, **SMALL))
    c = [np.array(q["center"]) for q in plate.artefact_truth["spheres"]]
    lengths = [np.linalg.norm(c[0] - c[1]), np.linalg.norm(c[1] - c[2]), np.linalg.norm(c[2] - c[0])]
    assert np.allclose(lengths, [5.942, 7.956, 9.957], atol=1e-12)
    for ser in (s, plate):
        for k in range(0, 30, 5):
            cam = ser.camera(k)
            for sph in ser.artefact_truth["spheres"]:
                x = cam.camera_matrix @ (cam.rotation @ np.array(sph["center"]) + cam.translation)
                u, v = x[:2] / x[2]
                assert 0 < u < cam.image_size[0] and 0 < v < cam.image_size[1]


def test_bad_settings_are_refused_in_one_line():
    with pytest.raises(InputError, match="artefact 'cube'"):
        TurntableSeries(SeriesSpec(artefact="cube"))
    with pytest.raises(InputError, match="projector must stand above"):
        TurntableSeries(SeriesSpec(distance_mm=5.0))
    with pytest.raises(InputError, match="needs more than 4096 projector px"):
        TurntableSeries(SeriesSpec(grain_mm=0.001))


def _sift_count(img: np.ndarray) -> int:
    return len(cv2.SIFT_create().detect(img, None))


@pytest.mark.slow
def test_series_written_with_truth_and_textureless_without_speckle(tmp_path):
    host = default_host()
    common = {"artefact": "sphere", "n_images": 3, "arc_deg": 30, "downscale": 9, "supersample": 1}
    on = host.run("virtuallab.turntable-series", {}, {**common, "out": str(tmp_path / "on"), "diffuser": 0.1})
    off = host.run("virtuallab.turntable-series", {}, {**common, "out": str(tmp_path / "off"), "speckle": False})
    truth = json.loads((tmp_path / "on" / "truth.json").read_text())
    assert [v["image"] for v in truth["views"]] == ["image000.png", "image001.png", "image002.png"]
    assert truth["spheres"][0]["diameter"] == 10.0 and truth["camera"]["width"] == 667
    assert [v["angle_deg"] for v in truth["views"]] == [0.0, 10.0, 20.0]
    assert truth["speckle"]["objective_grain_mm"] == pytest.approx(0.4256)
    assert (tmp_path / "on" / "calibration.yaml").is_file() and on.outputs["warnings"] == []
    a = cv2.imread(on.outputs["files"][0], cv2.IMREAD_GRAYSCALE)
    b = cv2.imread(off.outputs["files"][0], cv2.IMREAD_GRAYSCALE)
    assert a.shape == b.shape == (444, 667)
    # polished carbide under the lamp: shading only, the sphere's centre region is smooth
    K, R, t = (np.array(truth["views"][0][k]) for k in ("K", "R", "t"))
    x = K @ t  # the sphere's centre (the origin)
    u, v = int(round(x[0] / x[2])), int(round(x[1] / x[2]))
    patch_off, patch_on = b[v - 40 : v + 40, u - 40 : u + 40], a[v - 40 : v + 40, u - 40 : u + 40]
    hp = lambda p: float(np.std(p.astype(float) - cv2.GaussianBlur(p.astype(float), (0, 0), 3)))
    assert hp(patch_off) < 1.5 < 10 < hp(patch_on)
    assert _sift_count(b) < 0.1 * _sift_count(a)
    # a small grain warns that SIFT will not follow it
    warn = host.run("virtuallab.turntable-series", {}, {**common, "n_images": 1, "out": str(tmp_path / "w")})
    assert any("SIFT follows few grains" in w for w in warn.outputs["warnings"])


class _Sink:
    def __init__(self):
        self.frames = []

    def __call__(self, image, meta):
        self.frames.append((np.asarray(image.data if hasattr(image, "data") else image), dict(meta)))
        return len(self.frames)


@pytest.mark.slow
def test_devices_turntable_sequence_with_the_speckle_relay_feeds_the_series():
    from camcmm_plugins.devices.acquisition import TurntableSequence
    from camcmm_plugins.devices.projector import SpeckleProjector
    from camcmm_plugins.devices.simulated import SimulatedCamera
    from camcmm_plugins.devices.stage import SimulatedStage

    spec = SeriesSpec(artefact="sphere", n_images=3, arc_deg=30, **SMALL)
    renderer = TurntableRenderer(spec)
    stage = SimulatedStage("turntable", unit="deg", speed=5000.0).connect()
    relay = SpeckleProjector(prompt=lambda msg: True, settle_s=0).connect()
    size = renderer.series.dslr.size
    cam = SimulatedCamera("dslr", size=size, stages=[stage], renderer=renderer, speckle=relay).connect()
    sink = _Sink()
    seq = TurntableSequence(sink, stage, [cam], n_images=3, span_deg=30, speckle=relay)
    seq.start()
    assert seq.wait(timeout=120) == "done", seq.reason
    assert relay.is_on is False and len(sink.frames) == 3
    series = TurntableSeries(spec)
    for k, (img, meta) in enumerate(sink.frames):
        assert meta["angle_deg"] == pytest.approx(10.0 * k)
        ref = series.image(k)  # the same view; only the sensor noise differs
        assert img.shape == ref.shape
        assert np.corrcoef(img.ravel().astype(float), ref.ravel().astype(float))[0, 1] > 0.99
    # the relay off: the lamp's texture-less image, far from the speckled one
    d = cam.grab().data
    assert np.corrcoef(d.ravel().astype(float), series.image(2).ravel().astype(float))[0, 1] < 0.9
    assert np.corrcoef(d.ravel().astype(float), series.image(2, speckle_on=False).ravel().astype(float))[0, 1] > 0.99
    with pytest.raises(InputError, match="asks for 640 x 480 px"):
        renderer(size=(640, 480))


@pytest.mark.slow
def test_textureless_sphere_defeats_sfm_without_speckle_and_not_with_it(tmp_path):
    """Issue 16: the polished carbide sphere without speckle gives structure from motion
    nothing to hold on to (a one-line refusal); with the speckle on the table, most views
    register, at the true turntable angles. 12 views through 132 degrees, 0.3 MP."""
    host = default_host()
    common = {"artefact": "sphere", "n_images": 12, "arc_deg": 132, "downscale": 9, "supersample": 1, "diffuser": 0.1}
    runs = {}
    for on in (False, True):
        out = tmp_path / ("on" if on else "off")
        res = host.run("virtuallab.turntable-series", {}, {**common, "speckle": on, "out": str(out)})
        runs[on] = (res.outputs["files"], str(out / "calibration.yaml"))
    files, cal = runs[False]
    with pytest.raises(InputError, match="photogrammetry: (no texture|no overlap|nothing registered)") as exc:
        host.run("photogrammetry.reconstruct", {"images": files, "calibration": cal}, {"dense": False})
    assert "\n" not in str(exc.value)
    files, cal = runs[True]
    res = host.run("photogrammetry.reconstruct", {"images": files, "calibration": cal}, {"dense": False})
    rec = res.outputs["reconstruction"]
    assert rec["n_registered"] >= 10, rec["unregistered"]
    # the registered cameras turn by the table's angles (11 degrees apart); measured: up to
    # 0.3 degrees off at 0.79 px reprojection RMS — a 12-degree field of view at 0.3 MP couples
    # each view's rotation with its position
    R = {v["image"]: np.array(v["R"]) for v in rec["views"]}
    names = sorted(R)
    truth = {f"image{k:03d}.png": 11.0 * k for k in range(12)}
    for a, b in zip(names, names[1:]):
        rel = R[b] @ R[a].T
        angle = np.degrees(np.arccos(np.clip((np.trace(rel) - 1) / 2, -1, 1)))
        assert angle == pytest.approx(truth[b] - truth[a], abs=1.0)
