"""A page shows only its own messages and results (issue 15: a stage error from Devices
appeared in the Inspect panel; a new acceptance test showed "Last shown: flat-03" of the
old one). Without a browser: the session's state as the shell's alert reads it
(``page_messages[page]``)."""

from __future__ import annotations

import json

import pytest

from camcmm.gui.pages import Page

pytestmark = pytest.mark.slow  # each test builds a GUI server (~5 s)

MPE = {"PF": 0.186, "PS": 0.143, "SD": 0.096, "F": 0.243}


def test_a_devices_error_is_not_the_inspect_pages(gui_app):
    server, session = gui_app()
    state = server.state
    state.page = "inspect"  # the operator looks at Inspect while the Devices page fails
    devices = server.pages["devices"]
    assert devices.add("devices.no-such-stage") is None  # raised by the Devices page's own code
    line = session.page_error("devices")
    assert "devices.no-such-stage" in line
    assert not (state.page_messages or {}).get("inspect")  # what Inspect's alert shows
    assert session.page_error("inspect") == ""
    assert state.error_message == line and state.error_page == "devices"  # the brief notice names it


def test_each_page_keeps_its_own_message_and_clearing_one_keeps_the_other(gui_app):
    server, session = gui_app()
    state = server.state
    state.page = "devices"
    server.pages["devices"].add("devices.no-such-stage")
    server.pages["inspect"].select_plugin("devices.stage.simulated")  # refused by the Inspect page: a device
    assert "devices.stage.simulated" in session.page_error("inspect")
    assert "no-such-stage" in session.page_error("devices")
    session.clear_error(page="inspect")
    assert session.page_error("inspect") == ""
    assert "no-such-stage" in session.page_error("devices")


def test_a_message_from_outside_the_pages_goes_to_the_page_shown(gui_app):
    """The toolbar's import is the shell's: its message belongs to the page the operator is on."""
    server, session = gui_app()
    server.state.page = "compare"
    assert session.import_file(b"not a cloud\n", "broken.xyz") is None
    assert "broken.xyz" in session.page_error("compare")
    assert session.page_error("inspect") == ""


def test_a_registered_pages_messages_are_its_own(gui_app, tmp_path):
    """A page from outside camcmm (a lab's, here this test module's) is found by its module."""
    from camcmm.gui import pages

    def mount(server, session):
        class Hello:
            def fail(self):
                session.error("hello failed")

        return Hello()

    page = pages.register(Page("hello", "Hello", "mdi-hand-wave", mount, lambda obj: None, order=200))
    try:
        assert page.package() == __name__
        assert Page("x", "X", "mdi-x", server_pages_mount, lambda o: None).package() == "camcmm.gui.pages.inspect"
        server, session = gui_app()
        server.state.page = "inspect"
        server.pages["hello"].fail()
        assert session.page_error("hello") == "hello failed" and session.page_error("inspect") == ""
    finally:
        pages.unregister("hello")


def server_pages_mount(server, session):  # stands for a page module's mount
    return None


server_pages_mount.__module__ = "camcmm.gui.pages.inspect.page"


def test_a_new_acceptance_test_does_not_show_the_old_ones_last_position(gui_app, tmp_path):
    server, session = gui_app()
    state = server.state
    page = server.pages["acceptance"]
    page.choose_standard("vdi2634-2", state.wz_form)
    form = json.loads(json.dumps(state.wz_form))
    form["system_name"], form["mpe"] = "Scanner", {k: str(v) for k, v in MPE.items()}
    # what the page shows after a position of the old test was evaluated
    state.wz_detail = {"title": "flat-03", "file": "flat_03.ply", "rows": [], "warnings": []}
    page.last_card = {"key": "flat-03"}
    assert page.start(form), state.wz_setup_error
    assert state.wz_detail is None and page.last_card is None
    assert state.wz_step == "positions"
