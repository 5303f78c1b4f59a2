"""The example lab device (examples/lab_device): found through its entry point like an
installed package's, made by the host from its manifest, homed and moved in whole motor
steps, and offered by the Devices page with the stages — with no change to camcmm.

The package is not pip-installed: its folder goes on ``sys.path`` and the host is given
the entry point its ``pyproject.toml`` declares.
"""

from __future__ import annotations

import asyncio
import importlib.metadata as md
import re
import tomllib
from pathlib import Path

import pytest

from camcmm.api import DeviceError, ParameterError
from camcmm.host import PluginHost

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_device"


def _entry_point() -> md.EntryPoint:
    """The ``camcmm.plugins`` entry point exactly as the example's pyproject.toml declares it."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())
    ((name, value),) = project["project"]["entry-points"]["camcmm.plugins"].items()
    return md.EntryPoint(name=name, value=value, group="camcmm.plugins")


@pytest.fixture
def host(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLE))
    return PluginHost([*md.entry_points(group="camcmm.plugins"), _entry_point()])


def test_the_lab_device_connects_homes_and_moves_in_whole_steps(host):
    spec = host.get("lab.lift")
    assert (spec.kind, spec.status, spec.role, spec.simulated, spec.warnings) == ("device", "ok", "stage", True, [])
    lift = host.device("lab.lift", {"step_um": 2.5, "travel_mm": 40.0})
    assert lift.kind == "stage" and lift.unit == "mm" and not lift.connected
    lift.configure(speed=200.0)  # mm/s: the test need not wait
    positions = []
    lift.events.on("position", positions.append)
    with lift:
        with pytest.raises(DeviceError, match=r"^stage 'lab-lift': not homed yet; home it first"):
            lift.move_abs(10.0)
        assert lift.home() == 0.0 and lift.homed
        assert lift.move_abs(12.3456) == pytest.approx(12.345, abs=1e-12)  # 4938 steps of 2.5 um
        assert lift.move_rel(-2.3456) == pytest.approx(10.0, abs=1e-12)
        assert lift.position() == pytest.approx(10.0, abs=1e-12)
        with pytest.raises(DeviceError, match=r"target 45 mm is outside the travel 0 \.\. 40 mm"):
            lift.move_abs(45.0)
        assert lift.status().state == "ready" and lift.capabilities()["step_um"] == pytest.approx(2.5)
    assert positions and positions[-1] == pytest.approx(10.0)
    assert not lift.connected
    with pytest.raises(ParameterError, match="step_um"):
        host.device("lab.lift", {"step_um": 0})  # the manifest's limits are checked before the class runs


@pytest.mark.slow
def test_the_devices_page_offers_adds_and_moves_the_lab_device(host, gui_app):
    server, _ = gui_app(host=host)
    page = server.pages["devices"]
    s = page.state
    row = next(d for d in s.dev_catalogue if d["id"] == "lab.lift")
    assert row["role"] == "stage" and row["simulated"]
    assert row["title"] == "Lab lift (z axis, lead screw) (simulated)"
    page.choose_plugin("lab.lift")
    assert [f["name"] for f in s.dev_add_fields] == ["name", "step_um", "travel_mm"]
    assert s.dev_add_values["step_um"] == 2.5
    key = page.add("lab.lift", {**s.dev_add_values, "name": "z"})
    assert key is not None, s.dev_error
    act = lambda *a: asyncio.run(page.act(key, *a))  # noqa: E731 -- as the page's buttons await it
    assert act("connect") and act("home") == 0.0
    assert act("abs", "7.0001") == pytest.approx(7.0)
    row = next(d for d in s.dev_list if d["key"] == key)
    assert (row["name"], row["kind"], row["state"]) == ("z", "stage", "ready")
    assert re.fullmatch(r"7\.0000 mm", row["position"])
    # a sequence that needs a stage takes the lab's (the scale run also needs an interferometer)
    assert page.start_sequence("devices.sequence.scale-run", {"n_steps": 2}) is None
    assert s.dev_error == "devices.sequence.scale-run: connect an interferometer first"
