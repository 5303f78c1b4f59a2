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
    page, state = server.pages["acceptance"], server.state
    page.choose_standard("vdi2634-2", state.wz_form)
    form = json.loads(json.dumps(state.wz_form))
    form["system_name"] = "Virtual stereo fringe system"
    form["mpe"] = {"PF": "0.186", "PS": "0.143", "SD": "0.096", "F": "0.243"}
    form["measuring_volume"] = [100, 100, 100]
    assert page.start(form), state.wz_setup_error
    yield page, state
    close(server)


@pytest.mark.slow
def test_negative_focal_length_is_one_line_and_the_next_measurement_works(wizard):
    page, state = wizard
    page.set_source(
        "virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector", "focal_error": -2.0}
    )
    assert asyncio.run(page.acquire_async("sphere", "sphere-01")) is None
    line = state.error_message
    assert "\n" not in line and "sphere-01: virtuallab.fringe-system could not measure" in line, line
    # refused by the parameter's declaration (a relative error <= -1 makes fx <= 0), before any work
    assert "focal_error" in line and "-2" in line, line
    page.set_source("virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector"})
    card = asyncio.run(page.acquire_async("sphere", "sphere-01"))
    assert card is not None and card["status"] == "done", state.error_message


UNCHECKED_YAML = """
name: unchecked-lab
plugins:
  - id: unchecked.fringe-system
    kind: algorithm
    acquires: pointcloud
    name: The simulated stereo fringe system with the camera checks switched off
    entry: {pkg}.run:measure
    inputs: [{{name: placement, type: json}}]
"""

UNCHECKED_PY = '''
import camcmm.io.calibration as ic
import camcmm.model as mm
import camcmm_plugins.fringe.calib as fc
import camcmm_plugins.virtuallab.capture as cap
import camcmm_plugins.virtuallab.scene_file as sf
from camcmm_plugins.virtuallab.plugin import fringe_system

def measure(ctx, placement):
    """What issue 13 saw before the checks: fx < 0 reaches OpenCV's rectification maps."""
    saved = (mm.camera_problem, ic.camera_problem, ic.check_calibration, cap.check_calibration,
             fc.check_calibration, sf._errors)
    mm.camera_problem = ic.camera_problem = lambda *a, **k: None
    ic.check_calibration = cap.check_calibration = fc.check_calibration = lambda cal, name="": cal
    sf._errors = lambda d: dict(d or {})
    try:  # the plugin's function itself: its declared limits would refuse -2 before it runs
        return fringe_system(ctx, placement=placement, method="stereo", preset="stereo_fringe", focal_error=-2.0)
    finally:
        (mm.camera_problem, ic.camera_problem, ic.check_calibration, cap.check_calibration,
         fc.check_calibration, sf._errors) = saved
'''


@pytest.mark.slow
def test_the_native_crash_of_issue_13_ends_the_worker_not_the_server(tmp_path, monkeypatch):
    """The checks switched off in a lab plugin: the negative focal length crashes OpenCV
    (SIGSEGV, exit 139 in the CLI) inside the worker; the wizard shows one line and the
    next measurement, with the built-in system, works in a fresh worker."""
    import importlib.metadata as md

    from camcmm.host import PluginHost

    pkg = f"unchecked_lab_{os.getpid()}_{next(_names)}"
    root = tmp_path / "labsrc" / pkg
    root.mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "plugin.yaml").write_text(UNCHECKED_YAML.format(pkg=pkg))
    (root / "run.py").write_text(UNCHECKED_PY)
    monkeypatch.syspath_prepend(str(tmp_path / "labsrc"))
    lab = md.EntryPoint(name="unchecked-lab", value=f"{pkg}:plugin.yaml", group="camcmm.plugins")
    host = PluginHost(entry_points=[*md.entry_points(group="camcmm.plugins"), lab])
    server, session = build(f"test-wgui-{os.getpid()}-{next(_names)}", tmp_path / "proj", host=host)
    server.state.ready()
    try:
        page, state = server.pages["acceptance"], server.state
        page.choose_standard("vdi2634-2", state.wz_form)
        form = json.loads(json.dumps(state.wz_form))
        form["system_name"] = "Virtual stereo fringe system"
        form["mpe"] = {"PF": "0.186", "PS": "0.143", "SD": "0.096", "F": "0.243"}
        form["measuring_volume"] = [100, 100, 100]
        assert page.start(form), state.wz_setup_error
        page.set_source("unchecked.fringe-system")
        assert asyncio.run(page.acquire_async("sphere", "sphere-01")) is None
        line = state.error_message
        assert "\n" not in line and "the worker process died (SIGSEGV); the server keeps running" in line, line
        page.set_source("virtuallab.fringe-system", {"method": "projector", "preset": "camera_projector"})
        card = asyncio.run(page.acquire_async("sphere", "sphere-01"))
        assert card is not None and card["status"] == "done", state.error_message
    finally:
        close(server)


@pytest.mark.slow
def test_a_negative_focal_length_calibration_file_through_the_inspect_form(tmp_path):
    """The issue's own path: fringe.reconstruct run from the page's plugin form on a
    calibration file with fx = -800 px (once SIGSEGV in cv2.initUndistortRectifyMap, which
    took the server down). One line naming the file and value; the server's session runs on."""
    import cv2
    import yaml

    from camcmm_plugins.fringe.patterns import generate_patterns
    from helpers.camera_pairs import K1, _pair, _with, _write_yaml

    server, session = build(f"test-wgui-{os.getpid()}-{next(_names)}", tmp_path / "proj")
    try:
        server.state.ready()
        folder = tmp_path / "proj" / "capture"  # inside the project: the page may read it
        frames = folder / "frames"
        frames.mkdir(parents=True)
        seq = {
            "projector": {"width": 64, "height": 48},
            "frames": ["white", "black", {"type": "phase", "direction": "vertical", "steps": 4, "period": 16}],
        }
        (folder / "seq.yaml").write_text(yaml.safe_dump(seq))
        for i, f in enumerate(generate_patterns(seq)):
            cv2.imwrite(str(frames / f"img{i:02d}.png"), f)
        cal = folder / "cal.yaml"
        _write_yaml(
            cal,
            _pair(k1=_with(K1, 0, 0, -800), size1=[64, 48], size2=[64, 48], k2=[[80.0, 0, 32], [0, 80, 24], [0, 0, 1]]),
        )
        inputs = {
            "sequence": str(folder / "seq.yaml"),
            "images": sorted(str(p) for p in frames.iterdir()),
            "calibration": str(cal),
        }
        page = server.pages["inspect"]
        assert asyncio.run(page.run_plugin("fringe.reconstruct", {}, inputs)) is None
        line = server.state.error_message
        assert "\n" not in line and "cal.yaml" in line and "fx = -800 px must be positive and finite" in line, line
        # the same session runs the next plugin (in a worker that may be new or the same)
        import numpy as np

        from camcmm.api import PointCloud, write

        pts = np.random.default_rng(1).uniform(0, 10, (2000, 3))
        write(PointCloud(pts), folder / "cloud.ply")
        assert session.import_file(folder / "cloud.ply") is not None
        page.select_plugin("cloud.downsample")
        res = asyncio.run(page.run_plugin("cloud.downsample", {"voxel_size": 2.0}))
        assert res is not None and 0 < len(res.outputs["cloud"].points) < 2000, server.state.error_message
    finally:
        close(server)
