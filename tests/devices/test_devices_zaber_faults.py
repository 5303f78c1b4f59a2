"""The faults a lab sees on a Zaber-ASCII stage, against the stage simulator in its own
process: the cable pulled during a move, a move that never ends, alert and truncated
lines among the replies, and a controller reset (no reference: moves refused until
homed). Every wait is bounded by the device layer's own time-outs and counts."""

from __future__ import annotations

import pytest

from camcmm.api import DeviceDisconnected, DeviceError, DeviceTimeout
from camcmm_plugins.devices.simulator import SimulatorProcess
from camcmm_plugins.devices.zaber import ZaberLinearStage

RES = 0.000047625  # mm per microstep of a Zaber linear stage (data sheet value)
NOT_HOMED = r"not homed since the controller reset; home it first \(or confirm a move without homing\)$"


@pytest.fixture(params=["pty", "tcp"])
def sim(request, tmp_path):
    s = SimulatorProcess(
        "--resolution", str(RES), "--speed", "400", "--travel", "100", folder=tmp_path, pty=request.param == "pty"
    )
    yield s
    s.kill()


@pytest.fixture
def stage(sim):
    st = ZaberLinearStage(sim.stage_port, name="x", resolution=RES, timeout=0.5).connect()
    yield st
    st.disconnect()


@pytest.mark.slow
def test_cable_pulled_during_a_move(stage, sim):
    stage.configure(speed=5.0)  # 80 mm take 16 s: the port goes long before the end
    stage.home()
    positions = []
    stage.events.on("position", positions.append)
    # commands from here: 'warnings' (reference check), 'move abs', a poll; the
    # simulator process ends when the next poll arrives
    stage.request("sim exit 4")
    with pytest.raises(DeviceDisconnected, match=r"^stage 'x' on \S+: port lost \(.*\)$"):
        stage.move_abs(80.0)
    assert len(positions) == 1 and positions[0] < 80.0  # it was moving
    status = stage.status()
    assert status.state == "fault" and "port lost" in status.message and "\n" not in status.message
    with pytest.raises(DeviceDisconnected):
        stage.position()  # the dead port stays dead until reconnected
    sim.restart()  # the cable back in: the controller was power-cycled with it
    stage.reconnect()
    assert stage.status().state == "ready" and not stage.homed
    with pytest.raises(DeviceError, match=NOT_HOMED):
        stage.move_abs(10.0)
    stage.home()
    assert stage.move_abs(10.0) == pytest.approx(10.0, abs=RES)


def test_a_move_that_never_ends_is_stopped_after_move_timeout(stage):
    stage.home()
    stage.configure(move_timeout_s=0.3)
    stage.request("sim stall")  # the next move stays BUSY at its start until 'stop'
    faults = []
    stage.events.on("fault", faults.append)
    with pytest.raises(DeviceTimeout, match=r"^stage 'x' on \S+: still moving after 0.3 s; stopped$"):
        stage.move_abs(40.0)
    assert stage.status().state == "fault" and len(faults) == 1
    assert not stage.is_busy() and stage.position() == 0.0  # stopped where it stuck
    assert stage.move_abs(40.0) == pytest.approx(40.0, abs=RES)  # the next move works
    assert stage.status().state == "ready"


def test_alerts_and_truncated_lines_among_the_replies(stage):
    stage.home()
    stage.request("sim alerts 3")  # an alert and an info line before each of 3 replies
    stage.request("sim noise 6")  # 3 unreadable pieces around each of the 3 replies after them
    n = round(12.5 / RES)
    assert stage.move_abs(12.5) == pytest.approx(n * RES, abs=1e-12)
    assert stage.request("get pos").value == n  # each reply still goes with its command
    stage.configure(speed=30.0)
    assert stage.request("get maxspeed").value == round(30.0 / RES * 1.6384)
    assert stage.move_abs(3.0) == pytest.approx(round(3.0 / RES) * RES, abs=1e-12)
    health = stage.status().health
    assert stage.status().state == "ready"
    assert health["alerts"] == 3 and health["last_alert"] == "!01 1 IDLE --"
    assert health["garbled_lines"] == 3 * 6  # skipped and reported, none taken for a reply
    assert health["last_garbled"]


def test_controller_reset_refuses_moves_until_homed(stage):
    with pytest.raises(DeviceError, match=r"^stage 'x' on \S+: not homed yet; home it first"):
        stage.move_abs(10.0)  # never homed since power-up
    stage.home()
    stage.move_abs(30.0)
    stage._link.request(1, 0, "sim reset")  # a power blip the stage's own code does not see
    assert stage.homed  # nothing has told it yet: the check before a move asks the controller
    with pytest.raises(DeviceError, match=r"^stage 'x' on \S+: " + NOT_HOMED):
        stage.move_abs(20.0)
    assert not stage.homed and stage.status().state == "ready"  # a refusal, not a device fault
    with pytest.raises(DeviceError, match=NOT_HOMED):
        stage.move_rel(1.0)  # the travel check is meaningless without a reference too
    assert stage.position() == 0.0  # the controller counts from where it stopped
    # the operator confirmed (e.g. to jog off a limit switch): the move goes out
    assert stage.move_rel(2.0, allow_unhomed=True) == pytest.approx(2.0, abs=RES)
    assert not stage.homed
    stage.home()
    assert stage.homed and stage.move_abs(20.0) == pytest.approx(20.0, abs=RES)


def test_controller_reset_during_a_move_is_not_a_finished_move(stage):
    stage.configure(speed=5.0)
    stage.home()
    stage.request("sim reset 3")  # 'warnings', 'move abs', then the reset before the first poll's reply
    with pytest.raises(DeviceError, match=r"lost its reference during the motion \(the controller reset\) at 0 mm"):
        stage.move_abs(50.0)  # it ends IDLE at 0: no answer to "where is the axis now"
    assert stage.status().state == "fault" and not stage.homed
    with pytest.raises(DeviceError, match=NOT_HOMED):
        stage.move_abs(50.0)


@pytest.mark.slow
def test_devices_page_shows_the_refusal_as_one_line(gui_app):
    pytest.importorskip("trame")
    import asyncio

    server, _ = gui_app()
    page = server.pages["devices"]

    def act(*args):  # the page's device action, awaited as its buttons await it
        return asyncio.run(page.act(key, *args))

    key = page.add("devices.stage.zaber-simulated", {"name": "x", "speed": 500.0})
    assert key is not None and act("connect"), page.state.dev_error
    assert act("abs", "10") is None
    assert page.state.dev_error.startswith("stage 'x' on ")
    assert "not homed yet; home it first (or confirm a move without homing)" in page.state.dev_error
    assert "\n" not in page.state.dev_error
    assert act("home") == 0.0 and act("abs", "10") == pytest.approx(10.0)
    page.devices[key]._link.request(1, 0, "sim reset")
    assert act("rel", "1") is None
    assert page.state.dev_error.endswith(
        "not homed since the controller reset; home it first (or confirm a move without homing)"
    )


def test_a_reply_lost_in_line_noise(stage):
    stage.home()
    stage.request("sim noise 1")
    stage.request("sim mute 1")  # the next command is lost; two unreadable lines arrive instead
    with pytest.raises(
        DeviceTimeout,
        match=r"no reply to 'get pos' within 0.5 s \(2 unreadable lines meanwhile, "
        r"last '\\x00\\x7f~%&\\x15 ='\)$",
    ):
        stage.position()
    # a garbled reply glued to the remains of a truncated alert is still this command's reply:
    # an error for a move (not repeated blindly), not an alert line to skip
    stage.request("sim garble 1 move")
    stage.request("sim noise 1")
    with pytest.raises(
        DeviceError, match=r"garbled reply to 'move abs 104987': not a Zaber reply: '@01 1 \d+ O\S*~#~'"
    ):
        stage.request("move abs 104987")  # 5 mm
    assert stage.wait_idle() == pytest.approx(104987 * RES, abs=1e-12)
