"""A page added from outside camcmm, as a lab would add its own: importing this module
registers it. ``tests/test_pages.py`` registers :data:`HELLO` in a fixture; the browser
test has the GUI server import this file (``GuiProcess(preload=(this file,))``)."""

from __future__ import annotations

from typing import Any

from camcmm.gui.pages import Page, register, shown

TEXT = "Hello from a page registered by a test"


class Hello:
    """The page's state and handlers: a counter the button raises."""

    def __init__(self, server: Any, session: Any):
        self.state = session.state
        self.state.hello_clicks = 0
        self.closed = False

    def click(self) -> None:
        self.state.hello_clicks += 1

    def close(self) -> None:
        self.closed = True


def _build(page: Hello) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    from camcmm.gui.widgets import tid

    with html.Div(v_if=shown("hello"), classes="pa-4", raw_attrs=tid("hello")):
        html.Div(TEXT, classes="text-h6")
        v.VBtn("Wave ({{ hello_clicks }})", click=page.click, raw_attrs=tid("hello-wave"))


HELLO = Page("hello", "Hello", "mdi-hand-wave", Hello, _build, order=60)
register(HELLO)
