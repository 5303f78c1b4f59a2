"""Cameras (OpenCV on an image sequence, GenICam through a stand-in for harvesters,
simulated), settings validation, live view; the projector model and the speckle relay."""

from __future__ import annotations

import os
import sys
import threading
import time
import tty
import types

import cv2
import numpy as np
import pytest

from camcmm.api import DeviceError, DeviceTimeout, ParameterError
from camcmm_plugins.devices.camera import OpenCVCamera
from camcmm_plugins.devices.genicam import GenICamCamera
from camcmm_plugins.devices.projector import PatternProjector, SimulatedProjector, SpeckleProjector
from camcmm_plugins.devices.simulated import SimulatedCamera


@pytest.fixture
def frames_on_disk(tmp_path):
    rng = np.random.default_rng(5)
    frames = [rng.integers(0, 256, (48, 64, 3), dtype=np.uint8) for _ in range(3)]
    for k, f in enumerate(frames):
        cv2.imwrite(str(tmp_path / f"frame_{k:03d}.png"), f)
    return str(tmp_path / "frame_%03d.png"), frames


def test_opencv_camera_reads_the_frames_exactly(frames_on_disk):
    pattern, frames = frames_on_disk
    cam = OpenCVCamera(pattern, name="usb", loop=True).connect()
    assert cam.settings()["trigger"] == "free-run" and cam.sensor_size == (64, 48)
    got = []
    cam.events.on("frame", got.append)
    for k in range(3):
        img = cam.grab()
        np.testing.assert_array_equal(img.data, frames[k])
        assert img.metadata["camera"] == "usb" and img.metadata["frame"] == k + 1
        assert img.metadata["exposure_ms"] == 10.0 and img.metadata["roi"] == [0, 0, 64, 48]
        assert img.metadata["time"].endswith("+00:00")
    np.testing.assert_array_equal(cam.grab().data, frames[0])  # looped to the start
    assert len(got) == 4
    cam.configure(roi=[8, 4, 16, 20])
    img = cam.grab()
    np.testing.assert_array_equal(img.data, frames[1][4:24, 8:24])
    assert img.metadata["roi"] == [8, 4, 16, 20]
    cam.disconnect()
    assert cam.status().state == "disconnected"


def test_camera_settings_are_validated(frames_on_disk):
    cam = OpenCVCamera(frames_on_disk[0], name="usb").connect()
    with pytest.raises(ParameterError, match="camera 'usb' on .*: no setting 'shutter'"):
        cam.configure(shutter=3)
    with pytest.raises(ParameterError, match="'exposure_ms' = 0.0 is below its minimum"):
        cam.configure(exposure_ms=0)
    with pytest.raises(ParameterError, match="trigger 'software' is not supported; this camera offers free-run"):
        cam.configure(trigger="software")
    with pytest.raises(ParameterError, match="roi .* exceeds the sensor 64x48 px"):
        cam.configure(roi=[60, 0, 10, 10])
    assert cam.settings()["exposure_ms"] == 10.0  # a refused setting changes nothing
    caps = cam.capabilities()
    assert caps["kind"] == "camera" and caps["trigger_modes"] == ["free-run"]
    assert {p["name"] for p in caps["settings"]} >= {"exposure_ms", "gain_db", "trigger", "roi"}


def test_opencv_camera_end_of_file_and_missing_source(frames_on_disk, tmp_path):
    cam = OpenCVCamera(frames_on_disk[0], name="usb").connect()
    for _ in range(3):
        cam.grab()
    with pytest.raises(DeviceError, match="camera 'usb' on .*: no frame"):
        cam.grab()
    assert cam.status().state == "fault"
    with pytest.raises(DeviceError, match="cannot open"):
        OpenCVCamera(str(tmp_path / "none_%03d.png"), name="gone").connect()


def test_genicam_without_harvesters_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "harvesters", None)
    monkeypatch.setitem(sys.modules, "harvesters.core", None)
    cam = GenICamCamera(cti="/opt/maker/producer.cti", serial="123", name="left")
    with pytest.raises(
        DeviceError, match=r"camera 'left' on .*: GenICam cameras need the optional package 'harvesters'"
    ):
        cam.connect()


class _Node:
    def __init__(self, value=None, log=None, name=""):
        self._value, self.log, self.name = value, log, name
        self.max = value

    @property
    def value(self):
        return self._value

    @value.setter
    def value(self, v):
        self.log.append((self.name, v))
        self._value = v

    def execute(self):
        self.log.append((self.name, "execute"))


class _FakeHarvester:
    """A stand-in for harvesters.core.Harvester with one 32x24 Mono8 camera."""

    log: list = []

    def __init__(self):
        self.device_info_list = []

    def add_file(self, path):
        self.log.append(("add_file", path))

    def update(self):
        self.device_info_list = [{"serial_number": "123"}]

    def create(self, key):
        self.log.append(("create", key))
        return _FakeAcquirer(self.log)

    def reset(self):
        self.log.append(("reset",))


class _FakeAcquirer:
    def __init__(self, log):
        self.log, self.acq, self.n = log, False, 0
        names = (
            "ExposureTime",
            "Gain",
            "TriggerMode",
            "TriggerSource",
            "TriggerSoftware",
            "OffsetX",
            "OffsetY",
            "DeviceVendorName",
        )
        nm = types.SimpleNamespace(**{n: _Node(0, log, n) for n in names})
        nm.Width, nm.Height = _Node(32, log, "Width"), _Node(24, log, "Height")
        nm.WidthMax, nm.HeightMax = _Node(32, log, "WidthMax"), _Node(24, log, "HeightMax")
        nm.DeviceTemperature = _Node(41.5, log, "DeviceTemperature")
        self.remote_device = types.SimpleNamespace(node_map=nm)

    def is_acquiring(self):
        return self.acq

    def start(self):
        self.acq = True

    def stop(self):
        self.acq = False

    def destroy(self):
        self.log.append(("destroy",))

    def fetch(self, timeout):
        nm = self.remote_device.node_map
        w, h = nm.Width.value, nm.Height.value
        self.n += 1
        data = (np.arange(w * h) + self.n).astype(np.uint8)
        comp = types.SimpleNamespace(data=data, width=w, height=h, num_components_per_pixel=1)
        buf = types.SimpleNamespace(payload=types.SimpleNamespace(components=[comp]), timestamp=123456)

        class _Ctx:
            def __enter__(self_):
                return buf

            def __exit__(self_, *a):
                return False

        return _Ctx()


def test_genicam_camera_drives_the_sfnc_features(monkeypatch):
    core = types.ModuleType("harvesters.core")
    core.Harvester = _FakeHarvester
    monkeypatch.setitem(sys.modules, "harvesters", types.ModuleType("harvesters"))
    monkeypatch.setitem(sys.modules, "harvesters.core", core)
    _FakeHarvester.log = log = []
    cam = GenICamCamera(cti="/opt/p.cti", serial="123", name="left").connect()
    assert ("create", {"serial_number": "123"}) in log
    assert ("ExposureTime", 10000.0) in log  # 10 ms in the SFNC's microseconds
    assert ("TriggerMode", "On") in log and ("TriggerSource", "Software") in log
    img = cam.grab()
    assert ("TriggerSoftware", "execute") in log
    assert img.data.shape == (24, 32) and img.data[0, 0] == 1
    assert img.metadata["temperature_c"] == 41.5 and img.metadata["device_timestamp"] == 123456
    cam.configure(roi=[4, 2, 16, 8], exposure_ms=2.5, trigger="hardware")
    assert ("Width", 16) in log and ("OffsetX", 4) in log and ("ExposureTime", 2500.0) in log
    assert ("TriggerSource", "Line1") in log
    img = cam.grab()
    assert img.data.shape == (8, 16)  # the camera crops; no second crop here
    cam.disconnect()
    assert ("destroy",) in log and ("reset",) in log


def test_simulated_camera_live_view_and_exposure():
    cam = SimulatedCamera("sim", size=(40, 30)).connect()
    frames = []
    cam.events.on("frame", frames.append)
    cam.start_live(fps=50)
    deadline = time.monotonic() + 5
    while len(frames) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    cam.stop_live()
    assert len(frames) >= 3 and not cam.live
    a = cam.grab().data.astype(float).mean()
    cam.configure(exposure_ms=5.0)
    b = cam.grab().data.astype(float).mean()
    assert b == pytest.approx(a / 2, rel=0.05)  # brightness ~ exposure in the synthetic scene


def test_projector_waits_for_the_page():
    proj = PatternProjector(size=(8, 4), ack_timeout_s=0.2, settle_s=0).connect()
    pats = [np.full((4, 8), v, np.uint8) for v in (0, 128, 255)]
    assert proj.load(pats) == 3
    with pytest.raises(DeviceTimeout, match="projector page did not show pattern 1 within 0.2 s"):
        proj.show(1)

    def page(index, version):  # what the web page does: draw, then acknowledge
        threading.Timer(0.02, proj.acknowledge, args=(version,)).start()

    proj.events.on("pattern", page)
    proj.show(2)
    assert proj.index == 2
    np.testing.assert_array_equal(cv2.imdecode(np.frombuffer(proj.png(), np.uint8), cv2.IMREAD_UNCHANGED), pats[2])
    with pytest.raises(DeviceError, match="no pattern 3; 3 are loaded"):
        proj.show(3)
    proj.blank()
    assert proj.current() is None


def test_projector_loads_patterns_from_a_plugin_by_id():
    proj = SimulatedProjector().connect()

    def fake_patterns(sequence):  # the fringe plugin's contract: patterns + frames
        return {"patterns": np.zeros((2, 5, 7), np.uint8), "frames": [{"name": "a"}, {"name": "b"}]}

    assert proj.load_sequence({"any": 1}, algorithm=fake_patterns) == 2
    assert proj.names == ["a", "b"] and proj.size == (7, 5)


def test_speckle_relay_over_a_serial_line_and_by_hand():
    master, slave = os.openpty()
    tty.setraw(slave)
    try:
        sp = SpeckleProjector(os.ttyname(slave), settle_s=0).connect()
        sp.on()
        time.sleep(0.05)
        assert os.read(master, 64) == bytes.fromhex("A00101A2")
        sp.off()
        time.sleep(0.05)
        assert os.read(master, 64) == bytes.fromhex("A00100A1") and sp.is_on is False
        sp.disconnect()
        text = SpeckleProjector(
            os.ttyname(slave), on_command="LASER ON", off_command="LASER OFF", encoding="text", settle_s=0
        ).connect()
        text.on()
        time.sleep(0.05)
        assert os.read(master, 64) == b"LASER ON\n"
        text.disconnect()
    finally:
        os.close(master)
        os.close(slave)
    asked = []
    manual = SpeckleProjector(prompt=lambda msg: asked.append(msg) or True, settle_s=0).connect()
    manual.on()
    assert manual.is_on and "ON" in asked[0]
    manual.prompt = lambda msg: False
    with pytest.raises(DeviceError, match="did not confirm switching it off"):
        manual.off()
    with pytest.raises(DeviceError, match="no operator prompt is set"):
        SpeckleProjector(settle_s=0).connect().on()
    with pytest.raises(DeviceError, match="not hex bytes"):
        SpeckleProjector("/dev/null", on_command="zz")


def test_capture_replay_feeds_a_fringe_pair_from_a_rendering_plugin(tmp_path):
    from camcmm.project import Project
    from camcmm_plugins.devices.acquisition import FringeSequence
    from camcmm_plugins.devices.simulated import CaptureReplay

    calls = []

    def fake_capture(scene, out):  # the virtual lab's contract: frames per camera, in sequence order
        calls.append(scene)
        files = {}
        for cam in ("camera1", "camera2"):
            files[cam] = []
            for k in range(3):
                path = tmp_path / f"{cam}_{k}.png"
                cv2.imwrite(str(path), np.full((6, 8), 10 * k + (1 if cam == "camera2" else 0), np.uint8))
                files[cam].append(str(path))
        return {"files": files}

    replay = CaptureReplay(
        "scene.yaml", str(tmp_path / "render"), algorithm=fake_capture, cameras={"left": "camera1", "right": "camera2"}
    )
    proj = SimulatedProjector(size=(8, 6)).connect()
    cams = [SimulatedCamera(n, size=(8, 6), projector=proj, renderer=replay).connect() for n in ("left", "right")]
    with Project.create(tmp_path / "p") as p:
        seq = FringeSequence(p, proj, cams, patterns=[np.zeros((6, 8), np.uint8)] * 3)
        seq.start()
        assert seq.wait(timeout=10) == "done", seq.reason
        got = {
            (m["meta"]["camera"], m["meta"]["pattern_index"]): int(cv2.imread(str(p.file_path(m["hash"])), 0)[0, 0])
            for m in p.measurements()
        }
    assert got == {(c, k): 10 * k + (c == "right") for c in ("left", "right") for k in range(3)}
    assert calls == ["scene.yaml"]  # rendered once
    bad = SimulatedCamera("middle", projector=proj, renderer=replay).connect()
    with pytest.raises(DeviceError, match="no rendered camera 'middle'"):
        bad.grab()
