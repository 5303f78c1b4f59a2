"""The Zaber-ASCII serial stage against the stage simulator running as a separate process
on a pseudo-terminal (and on socket://): motion, read-back, refusals and faults."""

from __future__ import annotations

import time

import pytest

from camcmm.api import DeviceDisconnected, DeviceError, DeviceMonitor, DeviceTimeout
from camcmm_plugins.devices.simulator import SimulatorProcess
from camcmm_plugins.devices.zaber import (
    ZaberLinearStage,
    ZaberRotaryStage,
    ZaberStage,
    checksum,
    format_command,
    parse_reply,
)

RES = 0.000047625  # mm per microstep of a Zaber linear stage (data sheet value)


@pytest.fixture
def sim(tmp_path):
    s = SimulatorProcess("--resolution", str(RES), "--speed", "400", "--travel", "100", folder=tmp_path)
    yield s
    s.kill()


@pytest.fixture
def stage(sim):
    st = ZaberLinearStage(sim.stage_port, name="x", resolution=RES, timeout=0.5).connect()
    yield st
    st.disconnect()


# -- the protocol, without a device ---------------------------------------------------------
def test_command_lines_follow_the_manual():
    assert format_command(1, 1, "move abs 1000") == b"/1 1 move abs 1000\n"
    assert format_command(1, 1, "get pos", 12) == b"/1 1 12 get pos\n"
    assert format_command(2, 0, "") == b"/2 0\n"


def test_checksum_makes_the_byte_sum_zero():
    # The manual's definition: sum of the message bytes plus the checksum is 0 mod 256.
    for body in ("01 tools echo", "1 1 move abs 1000", "01 0 OK IDLE -- 0"):
        assert (sum(body.encode()) + int(checksum(body), 16)) % 256 == 0
    line = format_command(1, 1, "get pos", 3, with_checksum=True).decode().strip()
    body, cc = line[1:].split(":")
    assert (sum(body.encode()) + int(cc, 16)) % 256 == 0


def test_replies_parse_as_documented():
    r = parse_reply("@01 0 OK IDLE -- 0\r\n")  # the example of Zaber's protocol article
    assert (r.device, r.axis, r.msg_id, r.ok, r.busy, r.warning, r.value) == (1, 0, None, True, False, "--", 0)
    r = parse_reply("@01 1 12 RJ BUSY WR BADDATA")
    assert (r.msg_id, r.ok, r.busy, r.warning, r.data) == (12, False, True, "WR", "BADDATA")
    body = "01 1 OK IDLE -- 1234"
    assert parse_reply(f"@{body}:{checksum(body)}").value == 1234
    assert parse_reply("#01 1 some info") is None
    with pytest.raises(ValueError, match="bad checksum"):
        parse_reply(f"@{body}:00")
    with pytest.raises(ValueError, match="not a Zaber reply"):
        parse_reply("@01 1 OK B~#~")


# -- against the simulator ------------------------------------------------------------------
def test_home_moves_and_read_back(stage):
    assert stage.status().state == "ready"
    assert not stage.homed  # the simulator starts without a reference, as a stage after power-up
    assert stage.limits == pytest.approx((0.0, round(100 / RES) * RES))
    assert stage.home() == 0.0 and stage.homed
    # read-back is the microstep count times the resolution, the target rounded to a step
    n = round(12.345 / RES)
    assert stage.move_abs(12.345) == pytest.approx(n * RES, abs=1e-12)
    assert stage.request("get pos").value == n  # what the controller holds, in microsteps
    assert stage.move_rel(-2.0) == pytest.approx(round((n * RES - 2.0) / RES) * RES, abs=1e-12)
    assert stage.position() == pytest.approx(12.345 - 2.0, abs=RES)
    positions = []
    stage.events.on("position", positions.append)
    stage.move_abs(50.0, wait=False)
    assert stage.is_busy()
    assert stage.wait_idle() == pytest.approx(50.0, abs=RES)
    assert len(positions) >= 2 and positions[0] < positions[-1]  # positions were reported during the move


def test_refusals_name_the_device_and_port(stage, sim):
    with pytest.raises(DeviceError, match=r"stage 'x' on .*stage: target 150 mm is outside the travel"):
        stage.move_abs(150)
    with pytest.raises(DeviceError, match="refused 'frobnicate': BADCOMMAND"):
        stage.request("frobnicate")
    wide = ZaberStage(sim.stage_port, name="wide", resolution=RES, travel=(-1000, 1000)).connect()
    try:
        wide.home()
        with pytest.raises(DeviceError, match=r"refused 'move abs -\d+': BADDATA"):
            wide.move_abs(-5)  # the device's own limit refuses it
    finally:
        wide.disconnect()
    with pytest.raises(DeviceError, match="not a finite number"):
        stage.move_abs(float("nan"))


def test_settings_are_validated_and_reach_the_device(stage):
    stage.configure(speed=25.0)
    data = stage.request("get maxspeed").value
    assert data == pytest.approx(25.0 / RES * 1.6384, rel=1e-6)
    with pytest.raises(Exception, match="speed"):
        stage.configure(speed=-1)
    with pytest.raises(Exception, match="no setting 'sped'"):
        stage.configure(sped=1)


@pytest.mark.slow
def test_no_reply_is_a_timeout_and_the_late_reply_is_not_taken_for_the_next(stage):
    stage.home()
    stage.move_abs(10.0)
    stage.request("sim delay 0.8")  # replies come 0.8 s late; the timeout is 0.5 s
    t0 = time.monotonic()
    with pytest.raises(DeviceTimeout, match=r"no reply to 'get pos' within 0.5 s"):
        stage.position()
    assert time.monotonic() - t0 < 0.7
    assert stage.status().state == "fault"
    stage._link.timeout = 2.0
    stage.request("sim delay 0")  # the late 'get pos' reply arrives meanwhile and is skipped by its id
    stage._link.timeout = 0.5
    stage.move_abs(20.0)
    assert stage.position() == pytest.approx(20.0, abs=RES)
    assert stage.ping().state == "ready"


def test_garbled_replies(stage):
    stage.home()
    stage.request("sim garble 1")
    assert stage.position() == 0.0  # a query is safe to repeat: retried once
    stage.request("sim garble 1 move")
    with pytest.raises(DeviceError, match="garbled reply to 'move abs"):
        stage.move_abs(5.0)  # a move is not repeated blindly
    assert stage.status().state == "fault"
    assert stage.move_abs(5.0) == pytest.approx(5.0, abs=RES)  # the next move works again


@pytest.mark.slow
def test_mute_and_hang(stage):
    stage.request("sim mute 1")
    with pytest.raises(DeviceTimeout):
        stage.position()
    assert stage.position() == 0.0
    stage.request("sim hang")
    with pytest.raises(DeviceTimeout, match="stage 'x'"):
        stage.home()


def test_disconnection_and_restart(stage, sim):
    stage.home()
    stage.move_abs(30.0)
    faults = []
    stage.events.on("fault", faults.append)
    sim.kill()
    t0 = time.monotonic()
    with pytest.raises(DeviceDisconnected, match="port lost"):
        stage.position()
    assert time.monotonic() - t0 < 0.5
    assert stage.status().state == "fault" and faults
    sim.restart()  # a power-cycled controller on the same port: position lost, no reference
    stage.reconnect()
    assert stage.status().state == "ready"
    assert not stage.homed and stage.position() == 0.0


def test_exit_command_is_a_disconnection(stage):
    with pytest.raises(DeviceError):
        stage.request("sim exit")
    with pytest.raises(DeviceDisconnected):
        stage.position()


def test_monitor_reports_an_idle_device_that_stops_answering(stage):
    states = []
    stage.events.on("status", lambda s: states.append((time.monotonic(), s.state)))
    mon = DeviceMonitor([stage], interval=0.2)
    try:
        stage.request("sim hang")
        t0 = time.monotonic()
        deadline = t0 + 5
        while stage.status().state != "fault" and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        mon.stop()
    assert stage.status().state == "fault"
    first_fault = next(t for t, s in states if s == "fault")
    assert first_fault - t0 < 2.0  # the operator is told within 2 s (interval + reply timeout)


@pytest.mark.slow
def test_rotary_stage_over_tcp(tmp_path):
    with SimulatorProcess(
        "--rotary", "--resolution", "0.000234375", "--speed", "720", pty=False, folder=tmp_path
    ) as sim:
        assert sim.stage_port.startswith("socket://")
        st = ZaberRotaryStage(sim.stage_port, name="turntable").connect()
        try:
            assert st.unit == "deg" and st.limits is None
            st.home()
            assert st.move_abs(186.0) == pytest.approx(186.0, abs=0.000234375)
            assert st.move_rel(-6.0) == pytest.approx(180.0, abs=0.0005)
            sim.kill()
            with pytest.raises(DeviceDisconnected):
                st.position()
            sim.restart()  # same TCP port
            st.reconnect()
            assert st.position() == 0.0
        finally:
            st.disconnect()


def test_open_failure_names_the_port(tmp_path):
    st = ZaberLinearStage(str(tmp_path / "nothing-here"), name="y")
    with pytest.raises(DeviceDisconnected, match=r"stage 'y' on .*nothing-here: cannot open the port"):
        st.connect()
    assert st.status().state == "fault"
