"""A page is added by registering it (:func:`camcmm.gui.pages.register`), with no edit
anywhere else: it gets its page object, a toolbar button after the others and its
widgets, in a built server and in a real browser (the server imports the registering
module named by ``$CAMCMM_GUI_PRELOAD``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from helpers.browsing import MARKS, launch  # noqa: E402

pytest.importorskip("trame")
pytest.importorskip("pyvista")

from camcmm.gui import pages  # noqa: E402

FIXTURE = Path(__file__).parents[1] / "helpers" / "pages_fixture.py"
BUILT_IN = [
    "inspect",
    "acceptance",
    "compare",
    "uncertainty",
    "calibration",
    "photogrammetry",
    "fuse",
    "studies",
    "series",
    "devices",
]


@pytest.fixture
def hello():
    from helpers import pages_fixture

    yield pages.register(pages_fixture.HELLO)
    pages.unregister("hello")


def toolbar(server) -> list[str]:
    """The page buttons' test ids in the built layout, in order."""
    return re.findall(r'data-testid="page-([a-z]+)"', server.state["trame__template_main"])


def test_built_in_pages_in_order_and_the_drawer_open_on_inspect(gui_app):
    server, _ = gui_app()
    assert [k for k in toolbar(server) if k != "switch"] == BUILT_IN
    assert list(server.pages) == BUILT_IN
    assert server.state.main_drawer and server.state.drawer_pages == ["inspect"]


def test_a_registered_page_appears_in_a_built_server(gui_app, hello):
    from camcmm.gui.app import close

    server, _ = gui_app()
    page = server.pages["hello"]
    assert [k for k in toolbar(server) if k != "switch"] == BUILT_IN + ["hello"]
    html = server.state["trame__template_main"]
    assert 'data-testid="hello"' in html and "page === 'hello'" in html
    assert "hello" in server.state.full_pages and "hello" not in server.state.drawer_pages
    page.click()
    assert server.state.hello_clicks == 1
    close(server)
    assert page.closed


def test_unregistered_it_is_gone(gui_app, hello):
    pages.unregister("hello")
    server, _ = gui_app()
    assert "hello" not in server.pages and "hello" not in toolbar(server)


def browser_test(fn):
    """The marks of every browser test (skipped without Chromium), and slow."""
    for mark in [*MARKS, pytest.mark.slow]:
        fn = mark(fn)
    return fn


@browser_test
def test_a_registered_page_in_the_browser(tmp_path, hello):
    # hello: importing pages_fixture registers its page in this process too; the fixture takes it
    # out again after the test, or a later test here (another xdist order) sees a page 'hello'
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (python) is not installed")
    from camcmm.gui.process import GuiProcess
    from helpers.pages_fixture import TEXT

    server = GuiProcess(tmp_path / "proj", preload=(FIXTURE,))
    try:
        with sync_api.sync_playwright() as p:
            browser = launch(p)
            try:
                page = browser.new_page(
                    viewport={"width": 2000, "height": 900}
                )  # room for the buttons with their words
                page.set_default_timeout(30_000)
                page.goto(server.url)
                button = page.locator('[data-testid="page-hello"]')
                button.wait_for(timeout=90_000)  # the first load builds the app
                assert button.inner_text().strip().lower() == "hello"  # uppercase by Vuetify's CSS
                assert page.locator('[data-testid="hello"]').count() == 0  # not shown before it is chosen
                button.click()
                page.wait_for_selector(f'[data-testid="hello"]:has-text("{TEXT}")')
                page.locator('[data-testid="hello-wave"]').click()
                page.wait_for_selector('[data-testid="hello-wave"]:has-text("Wave (1)")')
                page.locator('[data-testid="page-inspect"]').click()
                page.wait_for_selector('[data-testid="hello"]', state="detached")
            finally:
                browser.close()
    finally:
        server.stop()
