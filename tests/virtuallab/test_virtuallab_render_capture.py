"""``camcmm simulate``: scene files, written frames, calibration with switchable
systematic errors, truth, reproducibility, bad input.

References: the devices' poses recomputed here from the scene's geometry, OpenCV's
projectPoints for where the truth lies in the images, the error definitions applied by
hand to the true calibration.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import yaml

from camcmm.api import InputError, TriangleMesh, read, read_calibration, write
from camcmm.cli.main import main
from camcmm_plugins.virtuallab import capture, render, scene_file

SEQ = {
    "projector": {"width": 1280, "height": 800},
    "bit_depth": 8,
    "frames": [
        "white",
        "black",
        {"type": "phase", "direction": "vertical", "steps": 4, "period": 16},
        {"type": "gray", "direction": "vertical", "period": 16},
    ],
}


def _scene(tmp_path, **extra):
    (tmp_path / "seq.yaml").write_text(yaml.safe_dump(SEQ))
    doc = {
        "name": "test",
        "seed": 3,
        "artefacts": [
            {"type": "sphere", "center": [10, -5, 5], "diameter": 20.0},
            {"type": "plane", "center": [0, 0, -40], "length": 300, "width": 300, "albedo": 0.4},
        ],
        "rig": {"preset": "stereo_fringe", "image_size": [320, 240]},
        "render": {"supersample": 1},
        "sequence": "seq.yaml",
        "patterns": ["diffuse"],
        **extra,
    }
    p = tmp_path / "scene.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


# One xdist work unit: the tests share the simulated capture (module fixtures), built once per run
# instead of once per worker (under --dist loadgroup an ungrouped test is scheduled alone).
pytestmark = pytest.mark.xdist_group("virtuallab-capture")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    d = tmp_path_factory.mktemp("sim")
    scene = _scene(
        d, errors={"focal_length": {"camera": "camera2", "relative": 0.01}, "baseline": {"relative": -0.005}}
    )
    assert main(["simulate", str(scene), "--out", str(d / "out"), "--json"]) == 0
    return d, scene


def test_simulate_writes_the_sequence_per_camera(simulated, capsys):
    d, _ = simulated
    out = d / "out"
    n_seq = 2 + 4 + 7  # white, black, 4 phase steps, 7 Gray bits (80 stripes)
    for cam in ("camera1", "camera2"):
        frames = sorted((out / cam).glob("frame*.png"))
        assert len(frames) == n_seq
        assert len(list((out / cam / "extra").glob("frame*.png"))) == 1  # the diffuse frame
        img = read(frames[0])
        assert img.data.shape == (240, 320) and img.data.dtype == np.uint8
    white, black = (read(out / "camera1" / f"frame00{k}.png").data.astype(int) for k in (0, 1))
    assert (white - black).mean() > 20
    assert (out / "sequence.yaml").is_file()
    truth = json.loads((out / "truth.json").read_text())
    assert truth["artefacts"][0]["diameter"] == 20.0
    assert [f["kind"] for f in truth["frames"]][:2] == ["white", "black"]


def test_calibration_frame_is_camera_1_and_errors_are_exactly_applied(simulated):
    d, scene_path = simulated
    true = read_calibration(d / "out" / "calibration_true.yaml")
    told = read_calibration(d / "out" / "calibration.yaml")
    c1, c2, pj = true["cameras"]
    assert [c.name for c in true["cameras"]] == ["camera1", "camera2", "projector"]
    assert np.allclose(c1.rotation, np.eye(3)) and np.allclose(c1.translation, 0)
    # camera 2 relative to camera 1 from the rig's geometry: baseline 199.35 mm along camera 1's x
    C2 = -c2.rotation.T @ c2.translation
    assert np.linalg.norm(C2) == pytest.approx(199.35, abs=1e-9)
    angle = np.degrees(np.arccos(np.clip(c2.rotation[2] @ [0, 0, 1], -1, 1)))
    assert angle == pytest.approx(2 * np.degrees(np.arcsin(199.35 / 2 / 301)), abs=1e-9)  # 38.64 deg
    # errors: fx, fy of camera 2 x 1.01, all translations x 0.995, nothing else
    k_true, k_told = c2.camera_matrix, told["cameras"][1].camera_matrix
    assert k_told[0, 0] == pytest.approx(1.01 * k_true[0, 0]) and k_told[1, 1] == pytest.approx(1.01 * k_true[1, 1])
    assert np.array_equal(k_told[:2, 2], k_true[:2, 2])
    assert np.array_equal(told["cameras"][0].camera_matrix, c1.camera_matrix)
    for a, b in zip(true["cameras"][1:], told["cameras"][1:]):
        assert np.allclose(b.translation, 0.995 * a.translation) and np.allclose(b.rotation, a.rotation)
    assert np.allclose(told["T"], 0.995 * true["T"])


def test_truth_is_where_the_images_show_it(tmp_path):
    # ambient light only: the sphere (albedo 0.8) shows as a uniform disc on a dark plane
    p = _scene(tmp_path, lighting={"ambient": 0.6}, patterns=["dark"])
    doc = yaml.safe_load(p.read_text())
    doc.pop("sequence")
    doc["artefacts"][1]["albedo"] = 0.1
    p.write_text(yaml.safe_dump(doc))
    assert main(["simulate", str(p), "--out", str(tmp_path / "out")]) == 0
    out = tmp_path / "out"
    truth = json.loads((out / "truth.json").read_text())
    cal = read_calibration(out / "calibration_true.yaml")
    sph = truth["artefacts_calibration"][0]
    for cam in cal["cameras"][:2]:
        p, _ = cv2.projectPoints(
            np.array([sph["center"]], float),
            cv2.Rodrigues(cam.rotation)[0],
            cam.translation,
            cam.camera_matrix,
            cam.dist_coeffs,
        )
        img = read(out / cam.name / "frame000.png").data.astype(float)
        bright = img > 0.5 * (0.48 + 0.06) * 255  # between sphere and plane levels
        ys, xs = np.nonzero(bright)
        assert abs(xs.mean() - p[0, 0, 0]) < 0.5 and abs(ys.mean() - p[0, 0, 1]) < 0.5
        # its apparent radius: 10 mm at the centre's depth (the outline of a sphere off the
        # axis is a slightly larger ellipse: within 3 %)
        depth = (cam.rotation @ sph["center"] + cam.translation)[2]
        r_px = cam.camera_matrix[0, 0] * 10.0 / depth
        assert np.sqrt(bright.sum() / np.pi) == pytest.approx(r_px, rel=0.03)


def test_same_seed_same_images_other_seed_other_noise(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    s1 = scene_file.load_scene(_scene(a))
    s2 = scene_file.load_scene(_scene(b, seed=4))
    f = [fr for fr in capture.scene_frames(s1) if fr["kind"] == "diffuse"]
    v = capture.prepare_views(s1)
    x1 = capture.render_frame(s1, v[0], 0, 0, f[0])
    x2 = capture.render_frame(s1, v[0], 0, 0, f[0])
    x3 = capture.render_frame(s2, v[0], 0, 0, f[0])
    assert np.array_equal(x1, x2) and not np.array_equal(x1, x3)
    assert np.abs(x1.astype(int) - x3.astype(int)).mean() < 3  # noise only


def test_projector_gamma_error_bends_the_grey_levels(tmp_path):
    s = scene_file.load_scene(_scene(tmp_path, errors={"projector_gamma": 2.2}))
    assert s.lighting.gamma == 2.2
    v = render.prepare(s.primitives, s.albedo, s.cameras[0].model, s.projector.model, s.lighting, 1)
    shape = (800, 1280)
    zero, half, full = (render.radiance(v, np.full(shape, x), s.lighting) for x in (0.0, 0.5, 1.0))
    lit = v.lit == 1
    ratio = (half - zero)[lit] / (full - zero)[lit]
    assert np.allclose(ratio, 0.5**2.2)


def test_gauge_blocks_and_a_mesh_from_a_file(tmp_path):
    # a 20 x 30 x 10 mm box as an STL, placed by rotation and translation
    V = np.array([[x, y, z] for x in (-10, 10) for y in (-15, 15) for z in (-5, 5)], float)
    F = np.array(
        [
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ]
    )
    write(TriangleMesh(V, F), tmp_path / "box.stl")
    doc = {
        "artefacts": [
            {
                "type": "gauge_blocks",
                "center": [0, 0, -20],
                "platen": [150, 100, 20],
                "blocks": [{"length": 10, "at": [-30, 0]}, {"length": 25, "at": [30, 10]}],
            },
            {"type": "mesh", "file": "box.stl", "position": [0, -30, -10], "rotation_deg": [0, 0, 90]},
        ],
        "rig": {"preset": "camera_projector", "image_size": [320, 240]},
        "render": {"supersample": 1},
        "patterns": ["white"],
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    s = scene_file.load_scene(tmp_path / "s.yaml")
    blocks = s.artefacts[0]["blocks"]
    assert [b["size"] for b in blocks] == [[30.0, 9.0], [35.0, 9.0]]  # ISO 3650 sections
    cam = s.cameras[0].model
    v = render.prepare(s.primitives, s.albedo, cam, s.projector.model, s.lighting, 1)
    for b in blocks:  # the camera's depth at each free face's centre
        X = np.array(b["top_center"])
        p, _ = cv2.projectPoints(
            X[None], cv2.Rodrigues(cam.rotation)[0], cam.translation, cam.camera_matrix, cam.dist_coeffs
        )
        u, w = np.rint(p[0, 0]).astype(int)
        Zc = (cam.rotation @ X + cam.translation)[2]
        assert v.depth[w, u] == pytest.approx(Zc, abs=0.3)  # pixel footprint on the tilted view
        assert X[2] == pytest.approx(-20 + b["length"])
    mesh_ids = [i for i, p in enumerate(s.primitives) if type(p).__name__ == "Mesh"]
    assert (v.primitive == mesh_ids[0]).sum() > 100
    assert s.artefacts[1]["area"] == pytest.approx(2 * (20 * 30 + 30 * 10 + 10 * 20))


@pytest.mark.parametrize(
    "doc,match",
    [
        ({"artefacts": []}, "artefacts"),
        ({"artefacts": [{"type": "cone"}]}, "cone"),
        ({"artefacts": [{"type": "sphere"}]}, "diameter"),
        ({"artefacts": [{"type": "sphere", "diameter": 20}], "errors": {"scale": 0.01}}, "errors.scale"),
        ({"artefacts": [{"type": "sphere", "diameter": 20}], "sensor": {"bitz": 8}}, "sensor.bitz"),
        ({"artefacts": [{"type": "sphere", "diameter": 20}], "sensor": {"bits": 3}}, "sensor.bits 3"),
        (
            {"artefacts": [{"type": "sphere", "diameter": 20}], "cameras": [{"name": "c", "image_size": [10, 10]}]},
            "camera_matrix",
        ),
    ],
)
def test_bad_scene_files_name_the_entry(tmp_path, doc, match):
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=match) as e:
        scene_file.load_scene(p)
    assert "bad.yaml" in str(e.value) and "\n" not in str(e.value)


def test_a_sequence_for_another_projector_is_refused(tmp_path, capsys):
    p = _scene(tmp_path)
    (tmp_path / "seq.yaml").write_text(yaml.safe_dump({**SEQ, "projector": {"width": 912, "height": 1140}}))
    assert main(["simulate", str(p), "--out", str(tmp_path / "o")]) != 0
    assert "912 x 1140" in capsys.readouterr().err


def test_virtual_system_moves_artefacts_and_images_them_where_the_truth_says(tmp_path):
    from camcmm_plugins.virtuallab.lab import VirtualSystem

    doc = {
        "seed": 2,
        "artefacts": [
            {"type": "ball_bar", "center": [0, 0, 0], "direction": [1, 0, 0], "length": 50.0, "sphere_diameter": 12.0},
            {
                "type": "gauge_blocks",
                "center": [0, 0, -30],
                "platen": [120, 100, 10],
                "blocks": [{"length": 10, "at": [30, 30]}],
            },
        ],
        "rig": {"preset": "stereo_fringe", "image_size": [320, 240]},
        "render": {"supersample": 1},
        "lighting": {"ambient": 0.6},
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    lab = VirtualSystem.from_file(tmp_path / "s.yaml")
    assert lab.cameras == ["camera1", "camera2"] and lab.projector_size == (1280, 800)
    before = lab.frame("camera1")
    lab.move(rotation_deg=[0, 0, 90], translation=[5, 0, 2])
    tr = lab.truth()["artefacts"]
    c1, c2 = (np.array(s["center"]) for s in tr[0]["spheres"])
    assert np.allclose(c1, [5, -25, 2]) and np.allclose(c2, [5, 25, 2])  # x -> y, then shifted
    assert np.allclose(tr[1]["blocks"][0]["top_center"], [-25, 30, -20 + 2])
    # the truth per pixel lies on the moved spheres
    cam = lab.scene.cameras[0].model
    pt = render.pixel_truth(lab.scene.primitives, cam)
    for k, c in enumerate((c1, c2)):
        X = pt["points"][pt["primitive"] == k]
        assert len(X) > 50 and np.abs(np.linalg.norm(X - c, axis=1) - 6.0).max() < 1e-9
    after = lab.frame("camera1")
    assert after.shape == (240, 320) and not np.array_equal(before, after)
    with pytest.raises(InputError, match="camera3"):
        lab.frame("camera3")
    with pytest.raises(InputError, match="projector shows"):
        lab.frame("camera1", np.zeros((10, 10)))


def test_capture_warns_of_unseen_artefacts_and_saturation(tmp_path, capsys):
    doc = {
        "artefacts": [
            {"type": "sphere", "center": [0, 0, 0], "diameter": 20.0},
            {"type": "sphere", "center": [400, 0, 0], "diameter": 20.0, "label": "far away"},
        ],
        "rig": {"preset": "stereo_fringe", "image_size": [160, 120]},
        "render": {"supersample": 1},
        "sensor": {"exposure": 4.0},
        "patterns": ["white"],
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert any("'far away' is outside every camera's view" in w for w in res["warnings"])
    assert any("saturate" in w for w in res["warnings"])
    pix = res["coverage"]["camera1"]["artefact_pixels"]
    assert pix["far away"] == 0 and pix["sphere 1"] > 100


@pytest.mark.parametrize(
    "art",
    [
        {"type": "sphere", "center": [10, -5, 5], "diameter": 20.0},
        {"type": "ball_bar", "center": [0, 0, 0], "direction": [1, 1, 1], "length": 49.944, "sphere_diameter": 20.0},
        {"type": "ball_plate", "center": [0, 0, 0], "lengths": [25, 30, 35], "sphere_diameter": 10.0, "rotation": 30},
    ],
)
def test_every_pixel_on_a_sphere_lies_on_the_true_sphere(tmp_path, art):
    (tmp_path / "s.yaml").write_text(
        yaml.safe_dump({"artefacts": [art], "patterns": ["white"], "rig": {"image_size": [320, 240]}})
    )
    s = scene_file.load_scene(tmp_path / "s.yaml")
    spheres = s.artefacts[0]["spheres"]
    for dev in s.cameras:
        pt = render.pixel_truth(s.primitives, dev.model, s.projector.model)
        for k, sph in enumerate(spheres):  # the spheres come first in each builder
            X = pt["points"][pt["primitive"] == k]
            assert len(X) > 30
            assert np.abs(np.linalg.norm(X - sph["center"], axis=1) - sph["diameter"] / 2).max() < 1e-9
        assert pt["lit"].any()
    if art["type"] == "ball_plate":
        c = [np.array(x["center"]) for x in spheres]
        assert [np.linalg.norm(c[(i + 1) % 3] - c[i]) for i in range(3)] == pytest.approx([25, 30, 35])


def test_any_pattern_image_lands_where_the_projector_sends_it(tmp_path):
    """A speckle pattern (any image) on a flat: the camera sees, pixel by pixel, the
    pattern value at the true projector coordinate of the surface point."""
    from camcmm_plugins.virtuallab.speckle import speckle

    doc = {
        "artefacts": [{"type": "flat", "center": [0, 0, 0], "length": 120, "width": 90}],
        "rig": {"preset": "camera_projector", "image_size": [320, 240]},
        "lighting": {"ambient": 0.0, "falloff": False},
        "render": {"supersample": 1},
        "patterns": ["white", {"speckle": {"grain": 40, "seed": 3, "mean": 0.4}}],
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    s = scene_file.load_scene(tmp_path / "s.yaml")
    frames = capture.scene_frames(s)
    v = capture.prepare_views(s)[0]
    white, spk = (render.radiance(v, f["pattern"], s.lighting) for f in frames)
    pt = render.pixel_truth(s.primitives, s.cameras[0].model, s.projector.model)
    ok = pt["lit"] & (white > 0)
    u, w_ = np.rint(pt["projector_uv"][ok]).astype(int).T
    want = speckle((800, 1280), 40, 3, 0.4)[w_, u]
    got = spk[ok] / white[ok]
    assert np.corrcoef(got, want)[0, 1] > 0.99
    assert np.median(np.abs(got - want)) < 0.01


def test_the_sequence_may_sit_in_the_scene_file(tmp_path):
    doc = {
        "artefacts": [{"type": "sphere", "diameter": 20.0}],
        "sequence": SEQ,
        "rig": {"image_size": [160, 120]},
        "render": {"supersample": 1},
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    assert main(["simulate", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o")]) == 0
    assert len(list((tmp_path / "o" / "camera2").glob("frame*.png"))) == 13
    assert yaml.safe_load((tmp_path / "o" / "sequence.yaml").read_text()) == SEQ


def test_frame_plugin_renders_what_a_simulated_camera_asks_for(tmp_path):
    """virtuallab.frame takes a simulated camera's state (devices.SimulatedCamera) and
    renders the scene with the stages' positions, the projector's pattern, exposure."""
    from camcmm.api import get_algorithm

    doc = {
        "seed": 1,
        "artefacts": [{"type": "sphere", "center": [20, 0, 0], "diameter": 16.0, "stem": False}],
        "rig": {"preset": "stereo_fringe", "image_size": [320, 240]},
        "render": {"supersample": 1},
        "lighting": {"ambient": 0.0, "projector": 0.4},
        "stages": {"table": {"type": "rotary"}},
        "speckle": {"grain": 8},
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    frame = get_algorithm("virtuallab.frame")
    white = np.full((800, 1280), 255, np.uint8)
    state = {
        "camera": "camera1",
        "camera_model": None,
        "size": (320, 240),
        "exposure_ms": 10.0,
        "gain_db": 0.0,
        "pattern": white,
        "pattern_index": 0,
        "stage_positions": {"table": 0.0},
        "stage_units": {"table": "deg"},
        "speckle": False,
        "frame": 1,
        "seed": 0,
    }
    a = frame(scene=str(tmp_path / "s.yaml"), **state)["image"].astype(float)
    b = frame(scene=str(tmp_path / "s.yaml"), **{**state, "stage_positions": {"table": 90.0}})["image"].astype(float)
    s = scene_file.load_scene(tmp_path / "s.yaml")
    cam = s.cameras[0].model
    for img, centre in ((a, [20, 0, 0]), (b, [0, 20, 0])):  # 90 deg about z takes x to y
        p, _ = cv2.projectPoints(
            np.array([centre], float),
            cv2.Rodrigues(cam.rotation)[0],
            cam.translation,
            cam.camera_matrix,
            cam.dist_coeffs,
        )
        ys, xs = np.nonzero(img > 0.3 * img.max())
        assert np.hypot(xs.mean() - p[0, 0, 0], ys.mean() - p[0, 0, 1]) < 3  # lit part of the sphere
    twice = frame(scene=str(tmp_path / "s.yaml"), **{**state, "exposure_ms": 20.0})["image"].astype(float)
    lit = a > 20
    assert np.median(twice[lit] / a[lit]) == pytest.approx(2.0, rel=0.05)
    dark = frame(scene=str(tmp_path / "s.yaml"), **{**state, "pattern": None, "speckle": True})["image"]
    assert dark[lit].std() > 5  # speckle texture on the sphere
    with pytest.raises(InputError, match="320 x 240"):
        frame(scene=str(tmp_path / "s.yaml"), **{**state, "size": (640, 480)})
