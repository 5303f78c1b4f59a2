"""Device plugins through the host: manifest entries, PluginHost.device(), the CLI."""

from __future__ import annotations

import subprocess
import sys

import pytest

from camcmm.errors import ParameterError, PluginError
from camcmm.host import PluginHost, default_host
from helpers.cli import main_json

ROLES = {"camera", "stage", "interferometer", "speckle", "projector", "sequence"}


def test_every_device_entry_loads():
    host = default_host()
    devices = [s for s in host.all() if s.id.startswith("devices.")]
    assert len(devices) >= 16
    for spec in devices:
        assert spec.kind == "device" and spec.role in ROLES, spec.id
        host.load(spec.id)  # GenICam's module imports without harvesters installed
        assert spec.status == "ok", (spec.id, spec.status)


def test_host_creates_a_device_with_validated_config():
    host = default_host()
    cam = host.device("devices.camera.simulated", {"size": [32, 24], "name": "c1"})
    assert cam.name == "c1" and cam.size == (32, 24) and not cam.connected
    assert cam.connect().grab().data.shape == (24, 32)
    stage = host.device("devices.stage.zaber-linear", {"port": "socket://127.0.0.1:9", "resolution": 0.001})
    assert stage.unit == "mm" and stage.resolution == 0.001 and stage.port == "socket://127.0.0.1:9"
    rot = host.device("devices.stage.zaber-rotary", {"port": "/dev/ttyUSB0"})
    assert rot.unit == "deg" and rot.resolution == 0.000234375  # the class default is kept
    with pytest.raises(ParameterError, match="parameter 'port' is required"):
        host.device("devices.stage.zaber-linear", {})
    with pytest.raises(ParameterError, match="unknown parameter 'prot'"):
        host.device("devices.stage.zaber-linear", {"prot": "x"})
    with pytest.raises(ParameterError, match="'address' = 0 is below its minimum"):
        host.device("devices.stage.zaber-linear", {"port": "x", "address": 0})
    with pytest.raises(PluginError, match="is a algorithm, not a device"):
        host.device("cloud.downsample", {})


def test_host_passes_objects_through(tmp_path):
    host = default_host()
    stage = host.device("devices.stage.simulated", {"unit": "deg"}).connect()
    cam = host.device("devices.camera.simulated", {"size": [16, 12]}, stages=[stage]).connect()
    seq = host.device(
        "devices.sequence.turntable",
        {"n_images": 4, "span_deg": 90},
        store=lambda img, meta: None,
        stage=stage,
        cameras=[cam],
    )
    assert list(seq.angles) == [0.0, 22.5, 45.0, 67.5]
    seq.start()
    assert seq.wait(timeout=10) == "done"
    assert cam.positions[stage.name] == pytest.approx(67.5)
    with pytest.raises(PluginError, match="'n_images' given both as a setting and as an object"):
        host.device("devices.sequence.turntable", {"n_images": 4}, n_images=5)


def test_a_broken_device_class_is_one_line(tmp_path, monkeypatch):
    pkg = tmp_path / "labdev"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("class Bad:\n    def __init__(self, port):\n        raise RuntimeError('boom')\n")
    (pkg / "plugin.yaml").write_text(
        "name: labdev\nplugins:\n  - {id: lab.bad, kind: device, name: Bad, entry: 'labdev:Bad',"
        " parameters: [{name: port, type: str, default: x}]}\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib.metadata as md

    host = PluginHost([md.EntryPoint("labdev", "labdev:plugin.yaml", "camcmm.plugins")])
    with pytest.raises(PluginError, match="device 'lab.bad' could not be created: RuntimeError: boom"):
        host.device("lab.bad")


def test_cli_devices_list(capfd):
    doc = main_json(capfd, "devices", "list", "--json")  # in-process (the CLI's main): only the output counts
    ids = {d["id"]: d for d in doc["devices"]}
    assert ids["devices.stage.zaber-simulated"]["simulated"] is True
    assert ids["devices.stage.zaber-rotary"]["role"] == "stage"


def test_cli_simulate_stage_serves_the_protocol(tmp_path):
    link = tmp_path / "stage"
    proc = subprocess.Popen(
        [sys.executable, "-m", "camcmm.cli.main", "devices", "simulate-stage", "--link", str(link)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout.readline().strip() == f"STAGE {link}"
        assert proc.stdout.readline().strip() == "READY"
        from camcmm_plugins.devices.zaber import ZaberStage

        st = ZaberStage(str(link), resolution=0.001).connect()
        assert st.home() == 0.0 and st.move_abs(1.5) == pytest.approx(1.5)
        st.disconnect()
    finally:
        proc.kill()
        proc.wait()


def test_simulated_zaber_stage_starts_its_own_simulator():
    host = default_host()
    stage = host.device("devices.stage.zaber-simulated", {"speed": 500.0})
    try:
        stage.connect()
        assert stage.port and stage.interferometer_port
        laser = host.device("devices.interferometer.serial", {"port": stage.interferometer_port}).connect()
        stage.home()
        laser.zero()
        x = stage.move_abs(12.5)
        assert x == pytest.approx(12.5) and laser.read() == pytest.approx(x, abs=1e-9)
        laser.disconnect()
    finally:
        stage.close_simulator()
    assert stage.simulator.proc.poll() is not None
