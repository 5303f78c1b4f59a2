"""A calibration with a negative focal length through the GUI (issue 13): the wizard's
simulated fringe system with its focal-length error set to -2 (the calibration believes
fx = -1 x the true one) gives one line naming the value, and the next measurement works.
The run happens in the plugin worker process, never in the server's."""

from __future__ import annotations

import asyncio
import itertools
import json
import os

import pytest

pytest.importorskip("trame")
pytest.importorskip("cv2")

from camcmm.gui.app import build, close  # noqa: E402

_names = itertools.count()


@pytest.fixture
def wizard(tmp_path):
    server, session = build(f"test-wgui-{os.getpid()}-{next(_names)}", tmp_path / "proj")
    server.state.ready()
    page, state = server.wizard, server.state
    page.choose_standard("vdi2634-2", state.wz_form)
    form = json.loads(json.dumps(state.wz_form))
    form["system_name"] = "Virtual stereo fringe system"
    form["mpe"] = {"PF": "0.186", "PS": "0.143", "SD": "0.096", "F": "0.243"}
    form["measuring_volume"] = [100, 100, 100]
    assert page.start(form), state.wz_setup_error
    yield page, state
    close(server)


def test_negative_focal_length_is_one_line_and_the_next_measurement_works(wizard):
    page, state = wizard
    page.set_source("virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector",
                                                 "focal_error": -2.0})
    assert asyncio.run(page.acquire_async("sphere", "sphere-01")) is None
    line = state.error_message
    assert "\n" not in line and "sphere-01: virtuallab.fringe-system could not measure" in line, line
    assert "focal length fx = -" in line and "must be positive and finite" in line, line
    page.set_source("virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector"})
    card = asyncio.run(page.acquire_async("sphere", "sphere-01"))
    assert card is not None and card["status"] == "done", state.error_message
