"""The "Devices" page's widgets around a :class:`~camcmm.gui.pages.devices.page.DevicesPage`.

Left: add a device (real or simulated, its form from the manifest) and the list of
devices with their state. Centre: the selected device — settings, a camera's live
image, a stage's moves, a projector's patterns. Right: acquisition sequences with
progress, pause, resume and abort; a device fault pauses the sequence and shows the reason.
"""

from __future__ import annotations

from typing import Any

from ...shell import CLEAR_PAGE_ERROR
from ...widgets import dyn_tid, param_form, tid
from .. import shown

# the colour of a device's state chip (JavaScript, for the device ``d`` of a v_for)
STATE_COLOUR = "({ready: 'success', busy: 'primary', fault: 'error', disconnected: 'grey'})[d.state] || 'grey'"
SEQUENCE_ACTIONS = (
    ("pause", "mdi-pause", "Pause after the current step (the devices stay where they are)"),
    ("resume", "mdi-play-pause", "Go on from where the sequence paused"),
    ("abort", "mdi-stop", "Stop the sequence; the frames stored so far stay in the project"),
)


def build(page: Any) -> None:
    """The page's three columns, shown while ``page === 'devices'``."""
    from trame.widgets import html

    with html.Div(
        v_if=shown("devices"),
        classes="d-flex ga-3 pa-3",
        raw_attrs=tid("devices"),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); overflow-y: auto;",
    ):
        with html.Div(style="flex: 0 0 340px; max-width: 340px;"):
            _add(page)
            _list(page)
        with html.Div(style="flex: 1 1 0; min-width: 0;", raw_attrs=tid("dev-detail")):
            _detail(page)
        with html.Div(style="flex: 0 0 360px; max-width: 360px;", raw_attrs=tid("dev-sequences")):
            _sequences(page)


def _unhomed(page: Any) -> None:
    """Under a move refused for want of a reference: "Move without homing", asked first
    (the travel limits are then only the controller's count: the carriage may reach an
    end stop)."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_confirm() -> None:
        page.state.dev_unhomed_ask = False
        await page.move_unhomed()

    with html.Div(v_if="dev_unhomed", classes="d-flex justify-end mb-2"):
        v.VBtn(
            "Move without homing",
            size="small",
            variant="tonal",
            color="warning",
            prepend_icon="mdi-alert-outline",
            click="dev_unhomed_ask = true",
            title="Do the move refused above without a reference position (asks first)",
            raw_attrs=tid("dev-move-unhomed"),
        )
    with v.VDialog(v_model=("dev_unhomed_ask", False), max_width=520):
        with v.VCard(v_if="dev_unhomed", raw_attrs=tid("dev-unhomed-dialog")):
            v.VCardTitle("Move {{ dev_unhomed.label }} without homing?", classes="text-subtitle-1")
            v.VCardText(
                "Without a reference position the stage does not know where its carriage is: its "
                "travel limits are checked against a count that may be wrong, and the move can run "
                "into an end stop. Home the stage instead unless you know where the carriage is."
            )
            with v.VCardActions():
                v.VSpacer()
                v.VBtn("Cancel", variant="text", click="dev_unhomed_ask = false", title="Do not move")
                v.VBtn(
                    "Move without homing",
                    color="warning",
                    click=on_confirm,
                    title="Move now, without a reference position",
                    raw_attrs=tid("dev-unhomed-confirm"),
                )


def _add(page: Any) -> None:
    """The error line, the plugin to add and its form."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_add(pid: str, values: dict[str, Any]) -> None:
        key = page.add(pid, values)
        if key is not None:
            await page.act(key, "connect")

    v.VAlert(
        v_if="dev_error",
        text=("dev_error",),
        type="error",
        density="compact",
        closable=True,
        classes="mb-2",
        click_close=f"dev_error = ''; dev_unhomed = null; {CLEAR_PAGE_ERROR}",  # the footer's line too
        raw_attrs=tid("dev-error"),
    )
    _unhomed(page)
    # the buttons sit above their forms: a field's hint folds away when it loses focus, and a
    # button below would move from under the pointer between press and release (a lost click)
    with html.Div(classes="d-flex align-center mb-1"):
        html.Div("Add a device", classes="text-subtitle-2")
        v.VSpacer()
        v.VBtn(
            "Add and connect",
            prepend_icon="mdi-connection",
            color="primary",
            size="small",
            disabled=("!dev_add_id",),
            click=(on_add, "[dev_add_id, dev_add_values]"),
            title="Make the device from the plugin and the values below, then connect it",
            raw_attrs=tid("dev-add"),
        )
    v.VSelect(
        model_value=("dev_add_id",),
        items=("dev_catalogue.filter(d => d.role !== 'sequence')",),
        item_title="title",
        item_value="id",
        label="Device plugin",
        title="The device to add: a real one or a simulated one (no hardware needed)",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        update_modelValue=(page.choose_plugin, "[$event]"),
        raw_attrs=tid("dev-add-plugin"),
    )
    param_form("dev_add_fields", "dev_add_values", "dev-add", sync=True)


def _list(page: Any) -> None:
    """The devices added, with their state; a click selects one."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    v.VDivider(classes="my-3")
    html.Div("Devices ({{ dev_list.length }})", classes="text-subtitle-2 mb-1")
    with v.VList(density="compact", nav=True, raw_attrs=tid("dev-list")):
        with v.VListItem(
            v_for="d in dev_list",
            key="d.key",
            active=("d.key === dev_selected",),
            click=(page.select, "[d.key]"),
            raw_attrs=dyn_tid("'dev-item-' + d.name"),
        ):  # (a VListItem's title= is its heading, not a tooltip)
            v.VTooltip(
                activator="parent",
                location="end",
                text=("`${d.label}: ${d.state}${d.position ? ', at ' + d.position : ''} (click to show it)`",),
            )
            v.VListItemTitle("{{ d.name }} · {{ d.kind }}")
            v.VListItemSubtitle("{{ d.message || d.label }}")  # the position is in the device's panel, whole
            with html.Template(v_slot_append=True):
                v.VChip(
                    "{{ d.state }}",
                    size="x-small",
                    variant="flat",
                    color=(STATE_COLOUR,),
                    raw_attrs=dyn_tid("'dev-state-' + d.name"),
                )
        html.Div(
            "No device yet: add one above (a simulated one needs no hardware).",
            v_if="!dev_list.length",
            classes="text-caption text-medium-emphasis px-4 py-2",
        )


def _detail(page: Any) -> None:
    """The selected device: connect/remove, its fault, settings and the controls of its kind."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_connect(key: str, on: bool) -> None:
        await page.act(key, "connect" if on else "disconnect")

    with html.Template(v_for="d in dev_list.filter(x => x.key === dev_selected)", key="d.key"):
        with html.Div(classes="d-flex align-center ga-2 mb-2"):
            html.Div("{{ d.label }}", classes="text-subtitle-1")
            v.VChip("{{ d.state }}", size="small", variant="flat", color=(STATE_COLOUR,))
            v.VSpacer()
            v.VBtn(
                "{{ d.connected ? 'Disconnect' : 'Connect' }}",
                size="small",
                variant="tonal",
                click=(on_connect, "[d.key, !d.connected]"),
                title=("d.connected ? 'Close the connection to this device' : 'Open the connection to this device'",),
                raw_attrs=tid("dev-connect"),
            )
            v.VBtn(
                "Remove",
                size="small",
                variant="text",
                click=(page.remove, "[d.key]"),
                title="Disconnect this device and take it off the list",
            )
        v.VAlert(
            v_if="d.state === 'fault'",
            text=("d.message",),
            type="error",
            density="compact",
            classes="mb-2",
            raw_attrs=tid("dev-fault"),
        )
        with html.Div(v_if="dev_settings_fields.length", classes="mb-2"):
            with html.Div(classes="d-flex align-center mb-1"):  # Apply above the fields, as Add
                html.Div("Settings", classes="text-subtitle-2")
                v.VSpacer()
                v.VBtn(
                    "Apply",
                    size="small",
                    color="primary",
                    variant="tonal",
                    click=(page.apply_settings, "[d.key, dev_settings_values]"),
                    title="Send the settings below to the device (empty fields stay as they are)",
                    raw_attrs=tid("dev-apply"),
                )
            param_form("dev_settings_fields", "dev_settings_values", "dev-setting", sync=True)
        _camera(page)
        _stage(page)
        _projector(page)
    html.Div("Select a device on the left.", v_if="!dev_selected", classes="text-caption")


def _camera(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_grab(key: str) -> None:
        await page.act(key, "grab")

    with html.Div(v_if="d.kind === 'camera'", classes="mt-2"):
        with html.Div(classes="d-flex ga-2 mb-1"):
            v.VBtn(
                "Grab",
                size="small",
                prepend_icon="mdi-camera",
                click=(on_grab, "[d.key]"),
                disabled=("!d.connected",),
                title="Take one frame and show it",
                raw_attrs=tid("dev-grab"),
            )
            v.VBtn(
                "{{ d.live ? 'Stop live' : 'Live view' }}",
                size="small",
                prepend_icon="mdi-video",
                click=(page.live, "[d.key, !d.live]"),
                disabled=("!d.connected",),
                title="Show the camera's frames as they come (a few per second)",
                raw_attrs=tid("dev-live"),
            )
        html.Img(
            v_if="dev_live",
            src=("dev_live",),
            style="max-width: 100%; border: 1px solid #ccc;",
            raw_attrs=tid("dev-live-image"),
        )
        html.Div("{{ dev_live_note }}", classes="text-caption")


def _stage(page: Any) -> None:
    """A stage's position (in the panel, whole: the list beside it is too narrow) and its moves."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_move(key: str, how: str, value: Any) -> None:
        await page.act(key, how, value)

    with html.Div(v_if="d.kind === 'stage'", classes="mt-2"):
        with html.Div(classes="d-flex align-baseline ga-2 mb-2"):
            html.Span("Position", classes="text-subtitle-2")
            html.Span(
                "{{ d.position || (d.connected ? 'not known (home it)' : 'not connected') }}",
                classes="text-h6 font-weight-regular",
                style="white-space: nowrap; font-variant-numeric: tabular-nums;",
                title="The stage's position as it last reported it",
                raw_attrs=tid("dev-position"),
            )
        with html.Div(classes="d-flex align-center flex-wrap ga-2"):
            v.VBtn(
                "Home",
                size="small",
                click=(on_move, "[d.key, 'home', null]"),
                title="Find the reference position",
                raw_attrs=tid("dev-home"),
            )
            v.VTextField(
                v_model=("dev_move", "10"),
                label=("`Target / step [${d.unit || 'mm'}]`",),
                density="compact",
                variant="outlined",
                hide_details=True,
                style="max-width: 160px;",
                title="Where to move to (Move to) or how far (Move by)",
                raw_attrs=tid("dev-move-value"),
            )
            v.VBtn(
                "Move to",
                size="small",
                click=(on_move, "[d.key, 'abs', dev_move]"),
                title="Move to the position given",
                raw_attrs=tid("dev-move-abs"),
            )
            v.VBtn(
                "Move by",
                size="small",
                click=(on_move, "[d.key, 'rel', dev_move]"),
                title="Move by the distance given (negative: back)",
            )
            v.VBtn(
                "Stop",
                size="small",
                color="error",
                variant="tonal",
                click=(on_move, "[d.key, 'stop', null]"),
                title="Stop the stage now",
            )


def _projector(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    async def on_load(key: str, path: str) -> None:
        await page.act(key, "load", path)

    async def on_show(key: str, index: Any) -> None:
        await page.act(key, "show", index)

    with html.Div(v_if="d.kind === 'projector'", classes="mt-2", raw_attrs=tid("dev-projector-panel")):
        html.Div(
            "{{ d.patterns }} patterns loaded{{ d.index !== null && d.index !== undefined ? ', "
            "showing ' + d.index : '' }}. Open <a href='projector' target='_blank'>the projector "
            "page</a> full-screen on the projector's display.",
            classes="text-caption mb-1",
        )
        with html.Div(classes="d-flex align-center ga-2"):
            v.VTextField(
                v_model=("dev_sequence_file", ""),
                label="Sequence file (empty: the shipped one)",
                density="compact",
                variant="outlined",
                hide_details=True,
                title="A fringe sequence file (YAML) in the project or a data folder; empty: the one camcmm ships",
                raw_attrs=tid("dev-sequence-file"),
            )
            v.VBtn(
                "Load",
                size="small",
                click=(on_load, "[d.key, dev_sequence_file]"),
                title="Make the sequence's patterns and give them to the projector",
                raw_attrs=tid("dev-load-patterns"),
            )
        with html.Div(classes="d-flex align-center ga-2 mt-1"):
            v.VTextField(
                v_model=("dev_pattern", "0"),
                label="Pattern",
                density="compact",
                variant="outlined",
                hide_details=True,
                style="max-width: 100px;",
                title="Number of the pattern to show (0 is the first)",
                raw_attrs=tid("dev-pattern"),
            )
            v.VBtn(
                "Show",
                size="small",
                click=(on_show, "[d.key, dev_pattern]"),
                disabled=("!d.patterns",),
                title="Project this pattern",
                raw_attrs=tid("dev-show-pattern"),
            )
            v.VBtn(
                "Blank",
                size="small",
                variant="text",
                click=(on_show, "[d.key, null]"),
                title="Project nothing (a black image)",
            )


def _sequences(page: Any) -> None:
    """The sequence to run, its form, the run's buttons and its progress."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    html.Div("Acquisition sequences", classes="text-subtitle-2 mb-1")
    html.Div(
        "Frames are stored in the project as they arrive; a device fault pauses the run.", classes="text-caption mb-2"
    )
    v.VSelect(
        model_value=("dev_seq_id",),
        items=("dev_catalogue.filter(d => d.role === 'sequence')",),
        item_title="title",
        item_value="id",
        label="Sequence",
        title="The acquisition sequence to run with the connected devices it needs",
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        update_modelValue=(page.choose_sequence, "[$event]"),
        raw_attrs=tid("dev-seq-plugin"),
    )
    with html.Div(classes="d-flex flex-wrap ga-1 mb-2"):  # above the form, as Add
        v.VBtn(
            "Start",
            size="small",
            color="primary",
            prepend_icon="mdi-play",
            disabled=("!dev_seq_id",),
            click=(page.start_sequence, "[dev_seq_id, dev_seq_values]"),
            title="Start the sequence (Ctrl+Enter); its frames are stored in the project as they come",
            raw_attrs=[*tid("dev-seq-start"), 'data-shortcut="run"'],
        )
        for action, icon, what in SEQUENCE_ACTIONS:
            v.VBtn(
                action.capitalize(),
                size="small",
                variant="tonal",
                prepend_icon=icon,
                disabled=("!dev_seq",),
                click=(page.sequence_action, f"['{action}']"),
                title=what,
                raw_attrs=tid(f"dev-seq-{action}"),
            )
    param_form("dev_seq_fields", "dev_seq_values", "dev-seq", sync=True)
    with v.VCard(v_if="dev_seq", variant="tonal", classes="mt-2", raw_attrs=tid("dev-seq-status")):
        with v.VCardText(classes="py-2"):
            html.Div(
                "{{ dev_seq.name }}: {{ dev_seq.state }} — {{ dev_seq.label }} · {{ dev_seq.frames }} frames",
                raw_attrs=tid("dev-seq-state"),
            )
            v.VProgressLinear(
                model_value=("dev_seq.progress",),
                height=10,
                rounded=True,
                classes="my-1",
                color=("dev_seq.state === 'paused' ? 'warning' : 'primary'",),
            )
            html.Div("{{ dev_seq.reason }}", v_if="dev_seq.reason", classes="text-caption text-error")
