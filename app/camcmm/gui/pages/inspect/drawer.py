"""The Inspect page's drawer: the project — its items with the tidy (rename, hide,
delete, undo) and its stored results. The plugins and their form have a panel of their
own in the main area (:mod:`.form_view`), so a long item list never pushes them away."""

from __future__ import annotations

from typing import Any

from ...widgets import tid

_ICON = ("item.kind === 'mesh' ? 'mdi-vector-triangle' : (item.kind === 'image' ? 'mdi-image' : 'mdi-dots-hexagon')",)


def _tip(expr: str) -> None:
    """A tooltip on the parent (a list row: its ``title`` attribute is Vuetify's title prop)."""
    from trame.widgets import vuetify3 as v

    v.VTooltip(activator="parent", text=(expr,), location="end", open_delay=600)


def _menu_item(title: str, icon: str, click: Any, testid: str, tip: str, **kw: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VListItem(title=title, prepend_icon=icon, click=click, raw_attrs=tid(testid), **kw):
        _tip(repr(tip))


def _item_menu(page: Any) -> None:
    """The ⋮ menu of one item row (inside ``v-for="item in …"``)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(raw_attrs=["@click.stop"]):  # a click on the menu does not select the row
        with v.VMenu(location="end"):
            with v.Template(v_slot_activator="{ props }"):
                v.VBtn(
                    icon="mdi-dots-vertical",
                    variant="text",
                    size="small",
                    density="comfortable",
                    v_bind="props",
                    title="Rename, hide or delete this item",
                    raw_attrs=tid("item-menu"),
                )
            with v.VList(density="compact"):
                _menu_item(
                    "Rename …",
                    "mdi-pencil-outline",
                    (page.tidy.ask_rename, "[item.id]"),
                    "item-rename",
                    "Give this item another name",
                )
                _menu_item(
                    "Hide",
                    "mdi-eye-off-outline",
                    (page.tidy.set_hidden, "[item.id, true]"),
                    "item-hide",
                    "Keep it out of the lists and pickers (not deleted)",
                    v_if="!item.hidden",
                )
                _menu_item(
                    "Show again",
                    "mdi-eye-outline",
                    (page.tidy.set_hidden, "[item.id, false]"),
                    "item-unhide",
                    "List it again",
                    v_else=True,
                )
                _menu_item(
                    "Delete …",
                    "mdi-delete-outline",
                    (page.tidy.ask_delete, "[item.id]"),
                    "item-delete",
                    "Delete it from the project (undo until this session ends; results keep their record)",
                )


def _row(page: Any, source: str, testid: str) -> None:
    from trame.widgets import vuetify3 as v

    with v.VListItem(
        v_for=f"item in {source}",
        key="item.id",
        title=("item.name",),
        subtitle=("item.subtitle",),
        active=("item.id === selected_item",),
        color="primary",
        prepend_icon=_ICON,
        click=(page.select_item, "[item.id]"),
        classes="item-row",
        raw_attrs=tid(testid) + [':data-item-id="item.id"'],
    ):
        _tip("'Show ' + item.name + ' in the 3D view'")
        with v.Template(v_slot_append=True):
            _item_menu(page)


def _undo_bar(page: Any) -> None:
    """A fixed-height slot: the last tidy action and Undo (nothing moves when it fills)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(classes="d-flex align-center px-3 ga-2", style="height: 36px;", raw_attrs=tid("tidy-bar")):
        html.Span(
            "{{ tidy_undo || 'Rename, hide or delete an item from its ⋮ menu.' }}",
            classes="text-caption text-truncate",
            style="flex: 1 1 auto; min-width: 0;",
            raw_attrs=tid("tidy-undo-text"),
            title=("tidy_undo || 'The last rename, hide or delete shows here, with Undo'",),
        )
        v.VBtn(
            "Undo",
            size="small",
            variant="tonal",
            prepend_icon="mdi-undo",
            disabled=("!tidy_can_undo",),
            click=page.tidy.undo,
            title="Undo the last rename, hide or delete (possible until this session ends)",
            raw_attrs=tid("tidy-undo"),
        )


def _items(page: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, raw_attrs=tid("items")):
        v.VListSubheader("Items in the project ({{ items.length }})")
        _undo_bar(page)
        _row(page, "items", "item")
        v.VListItem(v_if="!items.length", subtitle="No items yet: import a file above.")
        v.VSwitch(
            v_model=("show_hidden", False),
            label=("'Show hidden items (' + hidden_items.length + ')'",),
            density="compact",
            hide_details=True,
            color="primary",
            classes="px-3",
            disabled=("!hidden_items.length",),
            title="List the items you hid, to show them again",
            raw_attrs=tid("show-hidden"),
        )
        with v.Template(v_if="show_hidden"):
            _row(page, "hidden_items", "hidden-item")


def _dialogs(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with v.VDialog(model_value=("!!tidy_rename",), update_modelValue="!$event && (tidy_rename = null)", max_width=420):
        with v.VCard(v_if="tidy_rename", title="Rename item", raw_attrs=tid("rename-dialog")):
            with v.VCardText():
                v.VTextField(
                    v_model=("tidy_new_name", ""),
                    label="New name",
                    density="compact",
                    variant="outlined",
                    autofocus=True,
                    hide_details=True,
                    title="The name the lists show; results keep referring to the item",
                    raw_attrs=tid("rename-name"),
                )
            with v.VCardActions():
                v.VSpacer()
                v.VBtn("Cancel", click=page.tidy.cancel, title="Keep the old name", raw_attrs=tid("rename-cancel"))
                v.VBtn(
                    "Rename",
                    color="primary",
                    click=(page.tidy.rename, "[tidy_rename.id, tidy_new_name]"),
                    title="Save the new name",
                    raw_attrs=tid("rename-save"),
                )
    with v.VDialog(
        model_value=("!!tidy_confirm",), update_modelValue="!$event && (tidy_confirm = null)", max_width=520
    ):
        with v.VCard(v_if="tidy_confirm", raw_attrs=tid("delete-dialog")):
            v.VCardTitle("Delete '{{ tidy_confirm.name }}'?")
            with v.VCardText():
                html.Div(
                    "Stored results used this item as an input. They stay in the project with its record; "
                    "the item leaves the lists (Undo brings it back until this session ends).",
                    classes="text-body-2 mb-2",
                )
                with html.Ul(classes="ml-4", raw_attrs=tid("delete-results")):
                    html.Li("{{ r }}", v_for="r in tidy_confirm.results", key="r", classes="text-body-2")
            with v.VCardActions():
                v.VSpacer()
                v.VBtn("Cancel", click=page.tidy.cancel, title="Keep the item", raw_attrs=tid("delete-cancel"))
                v.VBtn(
                    "Delete anyway",
                    color="error",
                    click=(page.tidy.delete, "[tidy_confirm.id, true]"),
                    title="Delete it; the results above keep their record of it",
                    raw_attrs=tid("delete-confirm"),
                )


def _results(page: Any) -> None:
    from trame.widgets import vuetify3 as v

    with v.VList(density="compact", nav=True, raw_attrs=tid("results")):
        v.VListSubheader("Results in the project ({{ results.length }})")
        with v.VListItem(
            v_for="r in results",
            key="r.id",
            title=("'#' + r.id + ' ' + (r.title || r.plugin)",),
            subtitle=("r.subtitle || r.time",),
            click=(page.show_result, "[r.id]"),
            classes="result-row",
            raw_attrs=tid("result-row"),
        ):
            _tip("'Show result #' + r.id + ' as stored in the project'")


def drawer(page: Any) -> None:
    """The side drawer: the project's items (with the tidy) and its results."""
    from trame.widgets import vuetify3 as v

    _items(page)
    _dialogs(page)
    v.VDivider()
    _results(page)
