"""The "Devices" page: the Vuetify layout around a :class:`camcmm.gui.devices_page.DevicesPage`.

Left: add a device (real or simulated, its form from the manifest) and the list of
devices with their state. Centre: the selected device — settings, a camera's live
image, a stage's moves. Right: acquisition sequences with progress, pause, resume and
abort; a device fault pauses the sequence and shows the reason.
"""

from __future__ import annotations

from typing import Any


def _tid(name: str) -> list[str]:
    return [f'data-testid="{name}"']


def _assign(var: str, key: str = "f.name") -> str:
    # trame hands out plain objects: replace the dict so the change re-renders and syncs
    return f"{var} = Object.assign({{}}, {var}, {{[{key}]: $event}})"


def page_switch(v: Any, toolbar: Any) -> None:
    from trame.widgets import vuetify3

    for child in reversed(list(getattr(toolbar, "children", []) or [])):
        if isinstance(child, vuetify3.VBtnToggle):
            with child:
                v.VBtn("Devices", value="devices", prepend_icon="mdi-camera-iris", raw_attrs=_tid("page-devices"))
            return


def _form(v: Any, html: Any, fields: str, values: str, testid: str, disabled: str = "false") -> None:
    with html.Template(v_for=f"f in {fields}", key="f.name"):
        v.VSwitch(v_if="f.widget === 'switch'", model_value=(f"{values}[f.name]",), label=("f.label",),
                  density="compact", hide_details=True, color="primary", disabled=(disabled,),
                  update_modelValue=_assign(values))
        v.VSelect(v_else_if="f.widget === 'select'", model_value=(f"{values}[f.name]",), items=("f.choices",),
                  label=("f.label",), density="compact", variant="outlined", hide_details=True, classes="mb-1",
                  disabled=(disabled,), update_modelValue=_assign(values))
        v.VTextField(v_else=True, model_value=(f"{values}[f.name]",), label=("f.label",), hint=("f.help",),
                     density="compact", variant="outlined", hide_details="auto", classes="mb-1",
                     disabled=(disabled,), update_modelValue=_assign(values),
                     raw_attrs=[f':data-testid="\'{testid}-\' + f.name"'])


def build_panel(page: Any) -> None:
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    def on_choose(pid):
        page.choose_plugin(pid)

    async def on_add(pid, values):
        key = page.add(pid, values, connect=False)
        if key is not None:
            await page.act_async(key, "connect")

    def on_select(key):
        page.select(key)

    async def on_connect(key, on):
        if on:
            await page.act_async(key, "connect")
        else:
            page.disconnect(key)

    def on_remove(key):
        page.remove(key)

    def on_apply(key, values):
        page.apply_settings(key, values)

    async def on_grab(key):
        await page.act_async(key, "grab")

    def on_live(key, on):
        page.live(key, on)

    async def on_move(key, how, value):
        await page.act_async(key, how, value)

    async def on_load(key, path):
        await page.act_async(key, "load", path)

    async def on_show(key, index):
        await page.act_async(key, "show", index)

    def on_seq_choose(pid):
        page.choose_sequence(pid)

    def on_seq_start(pid, values):
        page.start_sequence(pid, values)

    def on_seq(action):
        page.sequence_action(action)

    state_colour = "({ready: 'success', busy: 'primary', fault: 'error', disconnected: 'grey'})[d.state] || 'grey'"
    with html.Div(v_if="page === 'devices'", classes="d-flex ga-3 pa-3", raw_attrs=_tid("devices"),
                  style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); overflow-y: auto;"):
        # -- left: add + list ---------------------------------------------------------------
        with html.Div(style="flex: 0 0 340px; max-width: 340px;"):
            v.VAlert(v_if="dev_error", text=("dev_error",), type="error", density="compact", closable=True,
                     classes="mb-2", click_close="dev_error = ''", raw_attrs=_tid("dev-error"))
            html.Div("Add a device", classes="text-subtitle-2 mb-1")
            v.VSelect(model_value=("dev_add_id",), items=("dev_catalogue.filter(d => d.role !== 'sequence')",),
                      item_title="title", item_value="id", label="Device plugin", density="compact",
                      variant="outlined", hide_details=True, classes="mb-2",
                      update_modelValue=(on_choose, "[$event]"), raw_attrs=_tid("dev-add-plugin"))
            _form(v, html, "dev_add_fields", "dev_add_values", "dev-add")
            v.VBtn("Add and connect", prepend_icon="mdi-connection", color="primary", size="small", classes="mt-1",
                   disabled=("!dev_add_id",), click=(on_add, "[dev_add_id, dev_add_values]"),
                   raw_attrs=_tid("dev-add"))
            v.VDivider(classes="my-3")
            html.Div("Devices ({{ dev_list.length }})", classes="text-subtitle-2 mb-1")
            with v.VList(density="compact", nav=True, raw_attrs=_tid("dev-list")):
                with v.VListItem(v_for="d in dev_list", key="d.key", active=("d.key === dev_selected",),
                                 click=(on_select, "[d.key]"), raw_attrs=[':data-testid="\'dev-item-\' + d.name"']):
                    v.VListItemTitle("{{ d.name }} · {{ d.kind }}")
                    v.VListItemSubtitle("{{ d.message || d.label }}{{ d.position ? ' · ' + d.position : '' }}")
                    with html.Template(v_slot_append=True):
                        v.VChip("{{ d.state }}", size="x-small", variant="flat", color=(state_colour,),
                                raw_attrs=[':data-testid="\'dev-state-\' + d.name"'])
                v.VListItem(v_if="!dev_list.length", subtitle="No device yet: add one above (a simulated one needs "
                                                               "no hardware).")
        # -- centre: the selected device ----------------------------------------------------------
        with html.Div(style="flex: 1 1 0; min-width: 0;", raw_attrs=_tid("dev-detail")):
            with html.Template(v_for="d in dev_list.filter(x => x.key === dev_selected)", key="d.key"):
                with html.Div(classes="d-flex align-center ga-2 mb-2"):
                    html.Div("{{ d.label }}", classes="text-subtitle-1")
                    v.VChip("{{ d.state }}", size="small", variant="flat", color=(state_colour,))
                    v.VSpacer()
                    v.VBtn("{{ d.connected ? 'Disconnect' : 'Connect' }}", size="small", variant="tonal",
                           click=(on_connect, "[d.key, !d.connected]"), raw_attrs=_tid("dev-connect"))
                    v.VBtn("Remove", size="small", variant="text", click=(on_remove, "[d.key]"))
                v.VAlert(v_if="d.state === 'fault'", text=("d.message",), type="error", density="compact",
                         classes="mb-2", raw_attrs=_tid("dev-fault"))
                with html.Div(v_if="dev_settings_fields.length", classes="mb-2"):
                    html.Div("Settings", classes="text-subtitle-2 mb-1")
                    _form(v, html, "dev_settings_fields", "dev_settings_values", "dev-setting")
                    v.VBtn("Apply", size="small", color="primary", variant="tonal",
                           click=(on_apply, "[d.key, dev_settings_values]"), raw_attrs=_tid("dev-apply"))
                with html.Div(v_if="d.kind === 'camera'", classes="mt-2"):
                    with html.Div(classes="d-flex ga-2 mb-1"):
                        v.VBtn("Grab", size="small", prepend_icon="mdi-camera", click=(on_grab, "[d.key]"),
                               disabled=("!d.connected",), raw_attrs=_tid("dev-grab"))
                        v.VBtn("{{ d.live ? 'Stop live' : 'Live view' }}", size="small", prepend_icon="mdi-video",
                               click=(on_live, "[d.key, !d.live]"), disabled=("!d.connected",),
                               raw_attrs=_tid("dev-live"))
                    html.Img(v_if="dev_live", src=("dev_live",), style="max-width: 100%; border: 1px solid #ccc;",
                             raw_attrs=_tid("dev-live-image"))
                    html.Div("{{ dev_live_note }}", classes="text-caption")
                with html.Div(v_if="d.kind === 'stage'", classes="d-flex align-center ga-2 mt-2"):
                    v.VBtn("Home", size="small", click=(on_move, "[d.key, 'home', null]"), raw_attrs=_tid("dev-home"))
                    v.VTextField(v_model=("dev_move", "10"), label="Target / step", density="compact",
                                 variant="outlined", hide_details=True, style="max-width: 140px;",
                                 raw_attrs=_tid("dev-move-value"))
                    v.VBtn("Move to", size="small", click=(on_move, "[d.key, 'abs', dev_move]"),
                           raw_attrs=_tid("dev-move-abs"))
                    v.VBtn("Move by", size="small", click=(on_move, "[d.key, 'rel', dev_move]"))
                    v.VBtn("Stop", size="small", color="error", variant="tonal", click=(on_move, "[d.key, 'stop', null]"))
                with html.Div(v_if="d.kind === 'projector'", classes="mt-2", raw_attrs=_tid("dev-projector-panel")):
                    html.Div("{{ d.patterns }} patterns loaded{{ d.index !== null && d.index !== undefined ? ', "
                             "showing ' + d.index : '' }}. Open <a href='projector' target='_blank'>the projector "
                             "page</a> full-screen on the projector's display.", classes="text-caption mb-1")
                    with html.Div(classes="d-flex align-center ga-2"):
                        v.VTextField(v_model=("dev_sequence_file", ""), label="Sequence file (empty: the shipped one)",
                                     density="compact", variant="outlined", hide_details=True,
                                     raw_attrs=_tid("dev-sequence-file"))
                        v.VBtn("Load", size="small", click=(on_load, "[d.key, dev_sequence_file]"),
                               raw_attrs=_tid("dev-load-patterns"))
                    with html.Div(classes="d-flex align-center ga-2 mt-1"):
                        v.VTextField(v_model=("dev_pattern", "0"), label="Pattern", density="compact",
                                     variant="outlined", hide_details=True, style="max-width: 100px;",
                                     raw_attrs=_tid("dev-pattern"))
                        v.VBtn("Show", size="small", click=(on_show, "[d.key, dev_pattern]"),
                               disabled=("!d.patterns",), raw_attrs=_tid("dev-show-pattern"))
                        v.VBtn("Blank", size="small", variant="text", click=(on_show, "[d.key, null]"))
            html.Div("Select a device on the left.", v_if="!dev_selected", classes="text-caption")
        # -- right: sequences --------------------------------------------------------------------
        with html.Div(style="flex: 0 0 360px; max-width: 360px;", raw_attrs=_tid("dev-sequences")):
            html.Div("Acquisition sequences", classes="text-subtitle-2 mb-1")
            html.Div("Frames are stored in the project as they arrive; a device fault pauses the run.",
                     classes="text-caption mb-2")
            v.VSelect(model_value=("dev_seq_id",), items=("dev_catalogue.filter(d => d.role === 'sequence')",),
                      item_title="title", item_value="id", label="Sequence", density="compact", variant="outlined",
                      hide_details=True, classes="mb-2", update_modelValue=(on_seq_choose, "[$event]"),
                      raw_attrs=_tid("dev-seq-plugin"))
            _form(v, html, "dev_seq_fields", "dev_seq_values", "dev-seq")
            with html.Div(classes="d-flex flex-wrap ga-1 mt-1"):
                v.VBtn("Start", size="small", color="primary", prepend_icon="mdi-play", disabled=("!dev_seq_id",),
                       click=(on_seq_start, "[dev_seq_id, dev_seq_values]"), raw_attrs=_tid("dev-seq-start"))
                for action, icon in (("pause", "mdi-pause"), ("resume", "mdi-play-pause"), ("abort", "mdi-stop")):
                    v.VBtn(action.capitalize(), size="small", variant="tonal", prepend_icon=icon,
                           disabled=("!dev_seq",), click=(on_seq, f"['{action}']"), raw_attrs=_tid(f"dev-seq-{action}"))
            with v.VCard(v_if="dev_seq", variant="tonal", classes="mt-2", raw_attrs=_tid("dev-seq-status")):
                with v.VCardText(classes="py-2"):
                    html.Div("{{ dev_seq.name }}: {{ dev_seq.state }} — {{ dev_seq.label }} · {{ dev_seq.frames }} frames",
                             raw_attrs=_tid("dev-seq-state"))
                    v.VProgressLinear(model_value=("dev_seq.progress",), height=10, rounded=True, classes="my-1",
                                      color=("dev_seq.state === 'paused' ? 'warning' : 'primary'",))
                    html.Div("{{ dev_seq.reason }}", v_if="dev_seq.reason", classes="text-caption text-error")
