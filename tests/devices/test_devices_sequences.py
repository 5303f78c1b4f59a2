"""Acquisition sequences with simulated devices into a real camcmm Project: turntable
(with the stage simulator killed mid-run), fringe with two cameras, the scale run."""

from __future__ import annotations

import functools
import json
import time

import numpy as np
import pytest

from camcmm.api import read
from camcmm.project import Project
from camcmm_plugins.devices.acquisition import FringeSequence, ScaleRunSequence, TurntableSequence, turntable_angles
from camcmm_plugins.devices.interferometer import SerialInterferometer, SimulatedInterferometer
from camcmm_plugins.devices.projector import SimulatedProjector, SpeckleProjector
from camcmm_plugins.devices.simulated import SimulatedCamera, synthetic_frame
from camcmm_plugins.devices.simulator import SimulatorProcess
from camcmm_plugins.devices.stage import SimulatedStage
from camcmm_plugins.devices.zaber import ZaberLinearStage, ZaberRotaryStage


@pytest.fixture
def project(tmp_path):
    p = Project.create(tmp_path / "proj")
    yield p
    p.close()


def _views(project):
    return [m["meta"]["view"] for m in project.measurements()]


def test_turntable_angles_as_in_the_thesis():
    a = turntable_angles(30, 180.0)  # ch. 4.5: thirty images through 180 degrees
    assert len(a) == 30 and a[0] == 0 and np.allclose(np.diff(a), 6.0) and a[-1] == 174.0
    b = turntable_angles(30, 180.0, 10.0, endpoint=True)
    assert b[0] == 10.0 and b[-1] == 190.0 and np.allclose(np.diff(b), 180 / 29)
    with pytest.raises(Exception, match="n_images"):
        turntable_angles(0)


@pytest.mark.slow
def test_killed_stage_pauses_the_turntable_run_without_losing_frames(tmp_path, project):
    sim = SimulatorProcess("--rotary", "--speed", "180", folder=tmp_path / "sim")
    try:
        stage = ZaberRotaryStage(sim.stage_port, name="turntable", resolution=0.001, timeout=1.0).connect()
        cam = SimulatedCamera("dslr", size=(160, 120), stages=[stage]).connect()
        speckle = SpeckleProjector(prompt=lambda msg: True, settle_s=0).connect()
        seq = TurntableSequence(project, stage, [cam], n_images=30, span_deg=180, speckle=speckle)
        frames, states = [], []
        seq.events.on("frame", lambda img, meta: frames.append(meta))
        seq.events.on("state", lambda s: states.append((time.monotonic(), s["state"], s["reason"])))
        seq.start()
        deadline = time.monotonic() + 20
        while len(frames) < 8 and time.monotonic() < deadline:
            time.sleep(0.002)
        t_kill = time.monotonic()
        sim.kill()
        assert seq.wait(timeout=5) == "paused"
        t_paused = next(t for t, s, _ in states if s == "paused")
        assert t_paused - t_kill < 2.0, f"fault reported {t_paused - t_kill:.2f} s after the kill"
        assert "stage 'turntable'" in seq.reason and sim.stage_port in seq.reason
        # every frame taken before the fault is in the store, with its file
        n_before = len(frames)
        stored = project.measurements()
        assert n_before >= 8 and len(stored) == n_before
        assert all(project.file_path(m["hash"]).is_file() for m in stored)
        assert project.get_state("devices.sequence.turntable")["state"] == "paused"
        # resume before the device is back: stays paused, with the reason
        seq.resume()
        assert seq.wait(timeout=5) == "paused" and "cannot open the port" in seq.reason
        sim.restart()
        seq.resume()
        assert seq.wait(timeout=30) == "done", seq.reason
        views = _views(project)
        assert sorted(views) == list(range(30))  # nothing lost, nothing doubled
        assert len(frames) == 30
        ms = project.measurements()
        angles = [m["meta"]["angle_deg"] for m in sorted(ms, key=lambda m: m["meta"]["view"])]
        assert np.allclose(angles, np.arange(30) * 6.0, atol=0.001)
        # the frame of view k shows the scene turned by the stage's angle
        m = ms[-1]
        img = read(project.file_path(m["hash"])).data
        assert img.shape == (120, 160)
        assert m["meta"]["stage_positions"]["turntable"] == pytest.approx(m["meta"]["angle_deg"])
        assert speckle.is_on is False  # switched off after the run
    finally:
        sim.kill()


@pytest.mark.slow
def test_hung_stage_is_detected_by_its_reply_timeout(tmp_path, project):
    sim = SimulatorProcess("--rotary", "--speed", "360", folder=tmp_path / "sim")
    try:
        stage = ZaberRotaryStage(sim.stage_port, name="rot", resolution=0.001, timeout=1.0).connect()
        cam = SimulatedCamera("c", size=(64, 48), stages=[stage]).connect()
        seq = TurntableSequence(project, stage, [cam], n_images=12, span_deg=360)
        count = []
        seq.events.on("frame", lambda img, meta: count.append(1))
        seq.start()
        while len(count) < 3:
            time.sleep(0.002)
        # a second client on the pty asks the controller to stop answering (a hung firmware)
        side = ZaberRotaryStage(sim.stage_port, name="side", timeout=1.0)
        side._link.url = sim.stage_port
        side._link.open()
        t0 = time.monotonic()
        side._link._ser.write(b"/1 0 sim hang\n")
        assert seq.wait(timeout=5) == "paused"
        latency = time.monotonic() - t0
        side._link.close()
        assert latency < 2.0 and "no reply" in seq.reason
        n = len(project.measurements())
        assert n == len(count) >= 3
        seq.abort()
        assert seq.state == "aborting"
        assert seq.wait(timeout=5) == "aborted"
        assert len(project.measurements()) == n  # the aborted run keeps what it stored
    finally:
        sim.kill()


def test_fringe_sequence_with_two_cameras(project):
    h, w = 80, 128
    x = np.arange(w)
    shifts = [0, np.pi / 2, np.pi, 3 * np.pi / 2]
    patterns = [
        np.tile(np.round(127.5 + 127.5 * np.cos(2 * np.pi * x / 32 + d)).astype(np.uint8), (h, 1)) for d in shifts
    ]
    patterns += [np.zeros((h, w), np.uint8), np.full((h, w), 255, np.uint8)]
    proj = SimulatedProjector(size=(w, h)).connect()
    noiseless = functools.partial(synthetic_frame, noise=0.0)
    cams = [SimulatedCamera(n, size=(128, 80), projector=proj, renderer=noiseless).connect() for n in ("left", "right")]
    for c in cams:
        c.configure(exposure_ms=10.0)
    shown = []
    proj.events.on("pattern", lambda i, v: shown.append(i))
    seq = FringeSequence(project, proj, cams, patterns=patterns, position="P1")
    seq.start()
    assert seq.wait(timeout=20) == "done", seq.reason
    ms = project.measurements()
    assert len(ms) == 12
    pairs = {(m["meta"]["pattern_index"], m["meta"]["camera"]) for m in ms}
    assert pairs == {(k, c) for k in range(6) for c in ("left", "right")}
    assert shown == [0, 1, 2, 3, 4, 5, None]  # each pattern once, then blank
    assert all(m["meta"]["position"] == "P1" for m in ms)
    # the frames show the pattern that was on display: the phase recovered from the
    # four phase-shifted frames (eq. 5.3) is the projected phase (camera = projector grid)
    frames = {
        (m["meta"]["pattern_index"], m["meta"]["camera"]): read(project.file_path(m["hash"])).data.astype(float)
        for m in ms
    }
    I = np.stack([frames[(k, "left")] for k in range(4)])
    num = sum(I[k] * np.sin(shifts[k]) for k in range(4))
    den = sum(I[k] * np.cos(shifts[k]) for k in range(4))
    phase = np.arctan2(-num, den)
    expected = np.angle(np.exp(1j * 2 * np.pi * x / 32))
    err = np.angle(np.exp(1j * (phase[40] - expected)))
    assert np.abs(err).max() < 0.03  # 8-bit quantisation of pattern and frame
    assert frames[(4, "right")].mean() < frames[(5, "right")].mean() / 5  # black vs white


def test_scale_run_against_the_simulated_interferometer(tmp_path, project):
    scale_ppm, res = 120.0, 0.0001
    sim = SimulatorProcess(
        "--resolution",
        str(res),
        "--speed",
        "500",
        "--scale-error",
        str(scale_ppm),
        folder=tmp_path / "sim",
        interferometer=True,
    )
    try:
        stage = ZaberLinearStage(sim.stage_port, name="actuator", resolution=res).connect()
        laser = SerialInterferometer(sim.interferometer_port, name="xl80").connect()
        cam = SimulatedCamera("cam", size=(64, 48), stages=[stage]).connect()
        seq = ScaleRunSequence(project, stage, laser, [cam], start_mm=5, stop_mm=95, n_steps=7, samples=3)
        seq.start()
        assert seq.wait(timeout=30) == "done", seq.reason
        rows = seq.table()
        assert [r["target_mm"] for r in rows] == pytest.approx(np.linspace(5, 95, 7))
        # the laser was zeroed at the first target and sees the true travel (1 + s) x
        for r in rows:
            travel = r["stage_mm"] - rows[0]["stage_mm"]
            assert r["interferometer_mm"] == pytest.approx(travel * (1 + scale_ppm * 1e-6), abs=1e-6)
        slope = np.polyfit([r["stage_mm"] for r in rows], [r["interferometer_mm"] for r in rows], 1)[0]
        assert slope - 1 == pytest.approx(scale_ppm * 1e-6, rel=1e-3)
        images = [m for m in project.measurements() if m["kind"] == "image"]
        assert len(images) == 7 and all("interferometer_mm" in m["meta"] for m in images)
        table = project.measurement(seq.table_measurement)
        doc = json.loads(project.file_path(table["hash"]).read_text())
        assert doc["unit"] == "mm" and len(doc["rows"]) == 7
        assert doc["rows"][3]["measurement_ids"] == [images[3]["id"]]
    finally:
        sim.kill()


def test_a_new_sequence_continues_a_crashed_one_from_the_store(tmp_path):
    # The app died mid-run: a new sequence of the same name, on the same project,
    # continues after the frames already stored.
    path = tmp_path / "proj"
    stage = SimulatedStage("lin", speed=1000.0, limits=(0, 100)).connect()
    laser = SimulatedInterferometer(follow=stage, noise=0.0).connect()
    cam = SimulatedCamera("cam", size=(32, 24), stages=[stage]).connect()
    with Project.create(path) as p1:
        seq = ScaleRunSequence(p1, stage, laser, [cam], start_mm=0, stop_mm=50, n_steps=6, samples=1)
        seq.start()
        seen = []
        seq.events.on("frame", lambda img, meta: seen.append(meta))
        while len(seen) < 2:
            time.sleep(0.001)
        seq.pause()
        assert seq.wait(timeout=5) == "paused"
        done = len(p1.measurements())
    with Project.open(path) as p2:
        again = ScaleRunSequence(p2, stage, laser, [cam], start_mm=0, stop_mm=50, n_steps=6, samples=1)
        again.start()
        assert again.wait(timeout=20) == "done", again.reason
        images = [m for m in p2.measurements() if m["kind"] == "image"]
        assert done >= 2 and len(images) == 6
        assert sorted(m["meta"]["index"] for m in images) == list(range(6))
        assert len(again.table()) == 6 and again.run_id == seq.run_id


def test_sink_callable_and_operator_pause(project):
    stage = SimulatedStage("rot", unit="deg", speed=5000.0).connect()
    cam = SimulatedCamera("cam", size=(32, 24), stages=[stage]).connect()
    got = []
    seq = TurntableSequence(
        lambda img, meta: got.append((img.data.shape, meta["view"])) or len(got), stage, [cam], n_images=5, span_deg=100
    )
    seq.start()
    assert seq.wait(timeout=10) == "done"
    assert [v for _, v in got] == [0, 1, 2, 3, 4] and seq.measurement_ids == [1, 2, 3, 4, 5]
    with pytest.raises(Exception, match="one or two cameras"):
        FringeSequence(project, SimulatedProjector().connect(), [], patterns=[np.zeros((4, 4))])


def test_scale_run_with_the_laser_softwares_csv_survives_a_fault(tmp_path, project):
    # The laser software recorded two readings per target; the stage dies after a few
    # targets. After resume every row must still carry the readings of its own target.
    targets = np.linspace(0, 40, 5)
    readings = np.repeat(targets * (1 + 3e-5), 2) + np.tile([-1e-5, 1e-5], 5)
    csv = tmp_path / "laser.csv"
    csv.write_text(
        "Target (mm),Reading (mm)\n" + "\n".join(f"{t},{r:.7f}" for t, r in zip(np.repeat(targets, 2), readings))
    )
    from camcmm_plugins.devices.interferometer import CsvInterferometer

    sim = SimulatorProcess("--resolution", "0.0001", "--speed", "200", folder=tmp_path / "sim")
    try:
        stage = ZaberLinearStage(sim.stage_port, name="act", resolution=0.0001).connect()
        laser = CsvInterferometer(str(csv)).connect()
        cam = SimulatedCamera("cam", size=(32, 24), stages=[stage]).connect()
        seq = ScaleRunSequence(project, stage, laser, [cam], targets=targets, samples=2)
        seen = []
        seq.events.on("frame", lambda img, meta: seen.append(meta))
        seq.start()
        while len(seen) < 2:
            time.sleep(0.001)
        sim.kill()
        assert seq.wait(timeout=5) == "paused"
        sim.restart()
        seq.resume()
        assert seq.wait(timeout=30) == "done", seq.reason
        rows = seq.table()
        expected = readings.reshape(5, 2).mean(axis=1)
        assert [r["interferometer_mm"] for r in rows] == pytest.approx(list(expected), abs=1e-12)
        assert [len(r["measurement_ids"]) for r in rows] == [1] * 5
    finally:
        sim.kill()
