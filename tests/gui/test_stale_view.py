"""Nothing stale on screen (issue 30), without a browser: the shared 3-D view shows the
scene of the page shown and never another page's (the Acceptance page showed Inspect's
SPH101 deviations, later a CSI map); Inspect's result panel follows the item selected
(it kept "Sphere fit #26" beside a 307 200-point height map); a page's message goes
when its cause is resolved (the Devices "move before homing" error stayed after homing,
after a successful move and after a reload); changes another tab makes reach the view.

The reference for "what is shown" is the view's own record (``SceneView.shown.key``, the
key of the geometry drawn) and the state the widgets read, not the page's bookkeeping.
"""

from __future__ import annotations

import asyncio
import os

import numpy as np
import pytest

from camcmm.model import PointCloud

pytest.importorskip("trame")
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
pytestmark = pytest.mark.slow  # each test builds a GUI server (~3 s)


def ball(n: int = 2000, r: float = 10.0, seed: int = 3) -> PointCloud:
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return PointCloud(d * (r + 0.002 * rng.normal(size=n))[:, None], name="ball")


def plate(n: int = 1500, seed: int = 4) -> PointCloud:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-20, 20, size=(n, 2))
    return PointCloud(np.c_[xy, 0.001 * rng.normal(size=n)], name="plate")


def deviations(n: int = 800) -> PointCloud:
    """An acceptance position's deviation cloud (its own geometry, not a project item)."""
    rng = np.random.default_rng(5)
    pts = rng.uniform(-5, 5, size=(n, 3))
    return PointCloud(
        pts, fields={"deviation": 0.01 * rng.normal(size=n)}, field_units={"deviation": "mm"}, name="SPH1"
    )


def enter(server, page):
    """The toolbar's page switch: the state ``page`` changes and its listeners run."""
    server.state.page = page
    server.session.page_entered(page)  # what the change listener does once the state is flushed


def test_the_view_shows_the_page_shown(gui_app, tmp_path):
    from camcmm import io as cio
    from camcmm.gui import pages
    from camcmm.gui.pages import Page
    from camcmm.gui.session import ITEM_GONE, ITEM_HINT
    from camcmm.project import Project

    cio.write(ball(), tmp_path / "ball.ply")
    cio.write(plate(), tmp_path / "plate.ply")
    # a lab's own page beside the view, which says nothing of it: it gets an empty view too
    pages.register(Page("lab", "Lab notes", "mdi-note", lambda server, session: object(), lambda o: None, full=False))
    try:
        server, s = gui_app()
    finally:
        pages.unregister("lab")
    state, view = server.state, s.view
    acceptance = server.pages["acceptance"]
    assert state.page == "inspect" and view.shown is None and state.view_hint == ITEM_HINT  # an empty project
    a = s.import_file(tmp_path / "ball.ply")
    b = s.import_file(tmp_path / "plate.ply")
    assert state.info_message.startswith("imported plate.ply") and state.info_visible
    s.select_item(a)
    assert view.shown.key == a and state.view_hint == ""

    # Acceptance: its own empty view, never Inspect's item
    enter(server, "acceptance")
    assert view.shown is None and state.view_owner == "acceptance"
    assert state.view_hint.startswith("No deviations shown yet") and state.color_fields == []
    acceptance.actions.show_cloud("wizard:7", deviations())
    assert view.shown.key == "wizard:7" and state.legend_title.startswith("deviation")
    assert state.display_note.startswith("SPH1: ")
    s.select_item(b)  # an item chosen for Inspect elsewhere (a page's "send to Inspect") is not drawn here
    assert view.shown.key == "wizard:7" and state.selected_item == b

    # back on Inspect: its item, coloured as before; and a full page leaves the view as it is
    enter(server, "inspect")
    assert view.shown.key == b and state.view_hint == "" and state.display_note.startswith("showing all")
    assert "deviation" not in {f["value"] for f in state.color_fields}
    enter(server, "devices")
    assert view.shown.key == b
    enter(server, "acceptance")
    assert view.shown.key == "wizard:7"
    enter(server, "lab")
    assert view.shown is None and state.view_hint == "Nothing from the Lab notes page is shown here yet."
    enter(server, "inspect")

    # another tab (here another connection to the project) hides the plate shown on Inspect
    other = Project.open(s.project.path)
    other.set_measurement_hidden(int(b))
    assert s.check_project()
    assert state.selected_item is None and view.shown is None and state.view_hint == ITEM_GONE
    assert state.info_message == "" and not state.info_visible  # "imported plate.ply" went with it
    enter(server, "acceptance")
    assert view.shown.key == "wizard:7"
    enter(server, "inspect")
    assert view.shown is None and state.view_hint == ITEM_HINT  # the reason was for that moment only


def test_the_result_panel_follows_the_item_selected_and_other_tabs_runs(gui_app, tmp_path):
    from camcmm import io as cio
    from camcmm.project import Project

    cio.write(ball(), tmp_path / "ball.ply")
    cio.write(plate(), tmp_path / "plate.ply")
    server, s = gui_app()
    state, inspect = server.state, server.pages["inspect"]
    a = s.import_file(tmp_path / "ball.ply")
    b = s.import_file(tmp_path / "plate.ply")
    # a fit of the ball stays beside the ball and beside its residuals, goes beside the
    # plate, and comes back with the ball (its newest result) and with the residuals (made by it)
    s.select_item(a)
    inspect.select_plugin("fit.sphere")
    assert asyncio.run(inspect.run_plugin("fit.sphere", {}, {"cloud": a})) is not None
    fit = inspect.result_id
    residuals = state.selected_item
    assert residuals not in (a, b) and state.result_title.startswith("Sphere") and state.report_rows
    s.select_item(a)
    assert inspect.result_id == fit and state.report_rows
    s.select_item(b)
    assert state.result is None and state.report_rows == [] and state.result_title == ""
    s.select_item(residuals)  # made by the fit: the fit is what it shows
    assert inspect.result_id == fit
    s.select_item(a)
    assert inspect.result_id == fit and state.result_title.startswith(f"result #{fit}:")

    # another tab (here another connection to the project) fits the ball again
    other = Project.open(s.project.path)
    run = dict(s.project.result(fit))
    run["outputs"] = {"radius": 10.5}
    newer = other.add_result(run, measurement_ids=[int(a)])
    assert s.check_project()
    assert inspect.result_id == newer  # the ball's newest result, as the other tab left it
    s.select_item(b)
    assert state.result is None


def test_the_devices_refusal_goes_when_its_cause_is_resolved(gui_app):
    server, s = gui_app()
    page, state = server.pages["devices"], server.state

    def act(key, *args, **kw):  # the page's device action, awaited as its buttons await it
        return asyncio.run(page.act(key, *args, **kw))

    s.error("plugin discovery failed: a broken plugin", page="inspect")  # at the start, before any tab
    key = page.add("devices.stage.simulated", {"unit": "mm", "name": "x"})
    assert key is not None and act(key, "connect")
    s.client_connected()  # the page's first load: nothing to drop

    def refused():
        assert act(key, "abs", "5") is None
        line = s.page_error("devices")
        assert (
            line == state.dev_error
            and "not homed" in line
            and line.endswith("home it first (or confirm a move without homing)")
        )
        assert "allow_unhomed" not in line and "=" not in line  # no code keyword where a person reads
        assert state.dev_unhomed == {"key": key, "action": "abs", "arg": "5", "label": page.devices[key].label}

    # homing resolves it
    refused()
    assert act(key, "home") is not None
    assert s.page_error("devices") == "" and state.dev_error == "" and state.dev_unhomed is None

    # a move confirmed without homing resolves it too (and moves: the position reads 5 mm)
    page.devices[key].homed = False
    refused()
    assert asyncio.run(page.move_unhomed()) is not None
    assert page.devices[key].position() == pytest.approx(5.0)
    assert s.page_error("devices") == "" and state.dev_error == "" and state.dev_unhomed is None

    # another device's failure is not resolved by this stage's move; a reload drops both
    refused()
    page.devices[key].homed = True
    s.error("camera 'c': no frame", page="devices", cause="device d9: grab")
    assert act(key, "rel", "1") is not None  # the stage's motion: not the camera's cause
    assert s.page_error("devices") == "camera 'c': no frame" == state.dev_error
    page.devices[key].homed = False
    refused()
    s.client_connected()  # a reload
    assert s.page_error("devices") == "" and state.dev_error == "" and state.dev_unhomed is None
    assert state.info_message == ""
    assert s.page_error("inspect").startswith("plugin discovery failed")  # about the start: kept
