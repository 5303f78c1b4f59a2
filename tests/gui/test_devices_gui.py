"""The Devices page's logic without a browser: simulated devices are added from their
manifests, a camera grabs into the live image, a stage moves, and a turntable sequence
through the real Zaber serial code (the stage simulator in its own process) stores its
frames in the project; killing the simulator mid-run shows the fault and the paused
sequence within 2 s, and after the simulator is back the operator's Resume completes it."""

from __future__ import annotations

import asyncio
import time

import pytest

pytest.importorskip("trame")
pytest.importorskip("serial")


@pytest.fixture
def page(gui_app):
    server, _ = gui_app()
    return server.pages["devices"]


def act(page, key, action, arg=None):
    """The page's device action, awaited as the layout's handlers await it."""
    return asyncio.run(page.act(key, action, arg))


def add(page, plugin_id, values):
    """Add and connect, as the page's "Add and connect" button does."""
    key = page.add(plugin_id, values)
    assert key is not None and act(page, key, "connect"), page.state.dev_error
    return key


def wait_for(test, timeout: float) -> float:
    t0 = time.monotonic()
    while not test():
        if time.monotonic() - t0 > timeout:
            return float("inf")
        time.sleep(0.02)
    return time.monotonic() - t0


@pytest.mark.slow
def test_catalogue_add_grab_move_and_bad_settings(page):
    s = page.state
    ids = {d["id"]: d for d in s.dev_catalogue}
    assert ids["devices.camera.simulated"]["role"] == "camera" and ids["devices.camera.simulated"]["simulated"]
    page.choose_plugin("devices.camera.simulated")
    assert {f["name"] for f in s.dev_add_fields} >= {"name", "size"}
    stage = add(page, "devices.stage.simulated", {"unit": "mm", "name": "x"})
    cam = add(page, "devices.camera.simulated", {"size": [64, 48], "name": "cam"})
    assert [d["state"] for d in s.dev_list] == ["ready", "ready"]
    page.select(cam)
    assert act(page, cam, "grab") and s.dev_live.startswith("data:image/png;base64,")
    assert "64×48 px" in s.dev_live_note
    page.select(stage)
    act(page, stage, "home")
    act(page, stage, "abs", "12.5")
    row = [d for d in s.dev_list if d["key"] == stage][0]
    assert row["position"].startswith("12.5")
    assert act(page, stage, "rel", "many") is None
    assert "not a number" in s.dev_error and "\n" not in s.dev_error
    page.select(cam)
    assert not asyncio.run(page.apply_settings(cam, {"exposure_ms": -5}))
    assert "exposure" in s.dev_error
    assert asyncio.run(page.apply_settings(cam, {"exposure_ms": "20", "gain_db": ""}))  # empty: left as it is
    assert (s.dev_settings_values["exposure_ms"], s.dev_settings_values["gain_db"]) == (20.0, 0.0)
    asyncio.run(page.remove(stage))
    assert [d["name"] for d in s.dev_list] == ["cam"] and s.dev_selected == cam
    asyncio.run(page.disconnect(cam))
    assert [(d["state"], d["connected"]) for d in s.dev_list] == [("disconnected", False)]
    assert page.add("devices.camera.simulated", {"size": "wide"}) is None
    assert "size" in s.dev_error


@pytest.mark.slow
def test_turntable_through_the_serial_stage_pauses_on_a_killed_simulator_and_resumes(page):
    s = page.state
    stage = add(page, "devices.stage.zaber-simulated", {"rotary": True, "speed": 720.0, "name": "turntable"})
    add(page, "devices.camera.simulated", {"size": [32, 24], "name": "cam"})
    page.choose_sequence("devices.sequence.turntable")
    seq = page.start_sequence("devices.sequence.turntable", {"n_images": 12, "span_deg": 180.0, "name": "tt-gui"})
    assert seq is not None, s.dev_error
    assert wait_for(lambda: (s.dev_seq or {}).get("frames", 0) >= 3, 20) < 20
    dev = page.devices[stage]
    dev.simulator.kill()
    latency = wait_for(lambda: (s.dev_seq or {}).get("state") == "paused", 5)
    assert latency < 2.0, f"the fault showed after {latency:.2f} s"
    assert "turntable" in s.dev_seq["reason"] and "sequence paused" in s.dev_error
    frames_before = s.dev_seq["frames"]
    stored = [m for m in page.project.measurements() if m["kind"] == "image"]
    assert len(stored) == frames_before  # every frame taken before the kill is in the store
    assert act(page, stage, "connect")  # the simulator comes back (as a power-cycled controller)
    page.sequence_action("resume")
    assert wait_for(lambda: (s.dev_seq or {}).get("state") == "done", 30) < 30, s.dev_seq
    images = [m for m in page.project.measurements() if m["kind"] == "image"]
    assert len(images) == 12
