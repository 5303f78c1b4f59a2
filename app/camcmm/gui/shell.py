"""The shell's widgets around the pages: the toolbar (app name, project, one button per
page, the import controls :mod:`camcmm.gui.app` gives, the shortcuts' list), the drawer
(the error of the page shown, the pages' drawers), the footer (version, project folder,
the page's message, connection). No toast floats over a page (one covered the Inspect
view's controls): a page's error stands in its drawer's alert or, without one, in the
footer. resources/ui/shell.js fits the toolbar to the window and handles the keyboard
shortcuts (docs/architecture.md, "Keyboard"); shell.css styles both.

A message belongs to the page that raised it (:meth:`Session.error`, state
``page_messages``): the alert and the footer show the current page's only.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .pages import shown
from .widgets import tid


def _page_switch(pages: list[Any], first: str) -> None:
    """The toolbar's page toggle: one button per page, its icon and (when there is room,
    see resources/ui/shell.js) its title; the tooltip names it and its shortcut Alt+N.
    The drawer opens on pages that have one."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VBtnToggle(
        v_model=("page", first),
        mandatory=True,
        density="compact",
        variant="outlined",
        divided=True,
        color="primary",
        classes="ml-3",
        update_modelValue="main_drawer = drawer_pages.includes($event)",
        raw_attrs=tid("page-switch"),
    ):
        for i, p in enumerate(pages):
            keys = f" (Alt+{i + 1})" if i < 9 else ""
            with v.VBtn(
                value=p.key,
                prepend_icon=p.icon,
                classes="cmm-page-btn text-none",
                raw_attrs=[
                    *tid(f"page-{p.key}"),
                    f'data-page-key="{p.key}"',
                    f'data-page-title="{_attr(p.title)}"',
                    f'aria-label="{_attr(p.title)}"',
                ],
            ):
                html.Span(p.title, classes="cmm-page-title")
                v.VTooltip(activator="parent", location="bottom", text=p.title + keys)


def _attr(text: str) -> str:
    """``text`` inside a double-quoted HTML attribute."""
    return str(text).replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


# the current page's error ("" when none) and the handler that clears it, as JavaScript
PAGE_ERROR = "(page_messages || {})[page]"
CLEAR_PAGE_ERROR = "page_messages = Object.assign({}, page_messages, {[page]: ''})"


def _page_alert() -> None:
    """The drawer's alert: the error of the page shown, not another page's."""
    from trame.widgets import vuetify3 as v

    v.VAlert(
        v_if=PAGE_ERROR,
        text=(PAGE_ERROR,),
        type="error",
        density="compact",
        closable=True,
        classes="ma-2",
        click_close=CLEAR_PAGE_ERROR,
        raw_attrs=tid("error-alert"),
    )


def _toolbar(session: Any, pages: list[Any], first: str, import_controls: Callable[[Any], None]) -> None:
    """App name, project (may truncate: its tooltip holds it whole), pages, import."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("camcmm", classes="cmm-app-title font-weight-medium", title="camcmm — camera-based coordinate metrology")
    with html.Div(classes="cmm-project-box ml-3", title=("`Project ${project_name}: ${project_path}`",)):
        v.VIcon("mdi-folder-outline", size="small", classes="mr-1")
        html.Span("{{ project_name }}", classes="cmm-project text-subtitle-1", raw_attrs=tid("project-name"))
    _page_switch(pages, first)
    v.VSpacer()
    with html.Div(
        classes="cmm-import ml-2",
        title="Import a point cloud, mesh or image into the project (a file here, or a path on the server)",
        raw_attrs=tid("import-box"),
    ):
        import_controls(session)
    with v.VBtn(
        icon=True,
        size="small",
        variant="text",
        raw_attrs=[*tid("shortcut-help-open"), "data-shortcut-help", 'aria-label="Keyboard shortcuts"'],
    ):
        v.VIcon("mdi-keyboard-outline")  # a child replaces the icon= prop's icon: name it here
        v.VTooltip(activator="parent", location="bottom", text="Keyboard shortcuts (?)")


def _footer(layout: Any) -> None:
    """camcmm's own footer: version, project folder, the page's message (its error, else
    the newest note), connection. One line of fixed height: nothing moves when a message comes."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    from .. import __version__

    footer = layout.footer
    footer.clear()
    footer.classes = "cmm-footer px-3 py-0 d-flex align-center text-medium-emphasis"
    _raw_attrs(footer, tid("footer"))
    with footer:
        v.VProgressCircular(indeterminate=("!!trame__busy",), color="primary", size=12, width=2, title="busy")
        html.Span(f"camcmm {__version__}", raw_attrs=tid("footer-version"), title="camcmm version")
        html.Span(
            "{{ project_path }}",
            classes="cmm-footer-path",
            title=("`Project folder: ${project_path}`",),
            raw_attrs=tid("footer-project"),
        )
        with html.Div(classes="cmm-footer-message d-flex align-center"):
            with html.Template(v_if=f"{PAGE_ERROR} && !(main_drawer && drawer_pages.includes(page))"):
                v.VIcon("mdi-alert-circle", color="error", size="small", classes="mr-1")
                html.Span(
                    "{{ " + PAGE_ERROR + " }}",
                    classes="text-error",
                    title=(PAGE_ERROR,),
                    raw_attrs=tid("footer-error"),
                )
                with v.VBtn(icon=True, size="x-small", variant="text", click=CLEAR_PAGE_ERROR, classes="ml-1"):
                    v.VIcon("mdi-close")
                    v.VTooltip(activator="parent", location="top", text="Dismiss this message")
            html.Span(
                "{{ info_message }}",
                v_else_if="info_message && info_page === page",  # the page's own note, as its errors
                title=("info_message",),
                raw_attrs=tid("footer-info"),
            )
        with html.Span(classes="d-flex align-center", raw_attrs=tid("footer-connection")):
            v.VIcon("mdi-lan-connect", size="small", color="success", classes="mr-1")
            html.Span("connected", title="This page is connected to its camcmm server")


def _raw_attrs(elem: Any, attrs: list[str]) -> None:
    """``raw_attrs`` on a widget the layout made (setting the keyword after construction
    renders nothing: trame reads it only in the constructor)."""
    for i, attr in enumerate(attrs):
        elem._attributes[f"_raw_shell_{i}"] = attr


def _shell_assets(server: Any) -> None:
    """resources/ui: the toolbar's fit and the keyboard shortcuts (shell.js), the 3-D
    view drawn in the browser (cloudview.js, :mod:`camcmm.gui.clientview`), their styles."""
    from ..assets import resources_dir

    server.enable_module(
        {
            "serve": {"__camcmm_ui": str(resources_dir() / "ui")},
            "scripts": ["__camcmm_ui/shell.js", "__camcmm_ui/cloudview.js"],
            "styles": ["__camcmm_ui/shell.css", "__camcmm_ui/cloudview.css"],
        }
    )


def layout(server: Any, session: Any, pages: list[Any], import_controls: Callable[[Any], None]) -> None:
    """The shell: toolbar (project, pages, import), drawer (the page's error, the pages'
    drawers), the pages' content, the footer."""
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    first = pages[0].key if pages else ""
    opened = bool(pages) and pages[0].drawer is not None  # the first page shown has its drawer open
    with SinglePageWithDrawerLayout(server, width=400, show_drawer=opened, theme=("theme", "light")) as layout:
        layout.title.hide()
        layout.icon.v_show = "drawer_pages.includes(page)"  # no empty drawer to open elsewhere
        with layout.icon:  # a child replaces the default icon: give it back
            v.VIcon("mdi-menu")
            v.VTooltip(activator="parent", location="bottom", text="Show or hide the side panel")
        with layout.toolbar:
            layout.toolbar.density = "compact"
            layout.toolbar.classes = "cmm-toolbar"
            _raw_attrs(layout.toolbar, tid("toolbar"))
            _toolbar(session, pages, first, import_controls)
        with layout.drawer as drawer:
            _raw_attrs(drawer, tid("drawer"))
            _page_alert()
            for p in pages:
                if p.drawer is not None:
                    with html.Div(v_show=shown(p.key)):  # kept in the page, as the drawer is
                        p.drawer(server.pages[p.key])
        with layout.content:
            layout.content.classes = "d-flex"
            for p in pages:
                p.build(server.pages[p.key])
        _footer(layout)
    _shell_assets(server)  # after the widgets' modules: shell.css comes after Vuetify's styles
