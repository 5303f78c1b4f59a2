"""The "Calibration" page's widgets, around a :class:`.page.CalibrationPage`.

Left, the inputs: one camera or a stereo pair; the board images from the project's
image items, an upload (which becomes image items) or a folder on the server; the board
form (type, points across and down, square size with its unit — required —, ChArUco
marker and dictionary) with the board's drawing and the board looked for in the first
image; the distortion model and the outlier factor; Run
with progress and Cancel; then the downloads and "use this calibration" for a measuring
system with the project's systems and their calibrations. Right, the results: the
summary, the image list (thumbnails with the board drawn, found / not found / left out
with the reason and each view's RMS), the selected image with its detected board, the
per-view error chart, the numbers with standard deviations, the projection-uncertainty
heat map at a working distance, and for a pair its pose, the epipolar statistics and
the rectified pair with horizontal epipolar lines.

Here the page and its inputs card; the cards shown once there is a calibration (save
and use, the results) are in :mod:`.cards`. One function per card or section of a card,
each with the handlers it wires.
"""

from __future__ import annotations

from typing import Any

from ...jobs import in_background
from ...widgets import tid
from .. import shown
from . import cards
from .cards import CARD
from .inputs import IMAGE_EXTS

RUN_ARGS = (
    "[{mode: cal_mode, source: cal_source, left: cal_left_items, right: cal_right_items, folder: cal_folder, "
    "left_pattern: cal_left_pattern, right_pattern: cal_right_pattern, model: cal_model, "
    "outlier_factor: cal_outlier, name: cal_name, board_form: {kind: cal_board_kind, cols: cal_board_cols, "
    "rows: cal_board_rows, square: cal_board_square, unit: cal_board_unit, marker: cal_board_marker, "
    "dictionary: cal_board_dict}}]"
)
#: what the two counts of the board are, per kind (JS, for the fields' labels)
COUNTED = "({chessboard: 'Inner corners', charuco: 'Squares', circles: 'Circles', acircles: 'Circles'}[cal_board_kind])"
CIRCLES = "['circles', 'acircles'].includes(cal_board_kind)"
MISSING_SIZE = "(cal_board_square === '' || cal_board_square === null)"
STEREO = "cal_mode === 'stereo'"


def _image_select(v: Any, html: Any, model: str, label: str, testid: str) -> None:
    """A multiple choice among the project's image items; ``label`` is a JS expression."""
    with v.VSelect(
        v_model=(model, []),
        items=("items.filter(i => i.kind === 'image')",),
        item_title="name",
        item_value="id",
        label=(label,),
        multiple=True,
        density="compact",
        variant="outlined",
        hide_details=True,
        classes="mb-2",
        disabled=("cal_running",),
        title="The calibration images among the project's image items",
        raw_attrs=tid(testid),
    ):
        with v.Template(v_slot_selection="{ item, index }"):
            v.VChip("{{ item.title }}", v_if="index < 2", size="small")
            html.Span(f"(+{{{{ {model}.length - 2 }}}} more)", v_if="index === 2", classes="text-caption ml-1")


def _inputs(v: Any, html: Any, page: Any) -> None:
    """The inputs card: camera or pair, where the images come from, the board, Run."""
    _watch_uploads(page)
    with v.VCard(variant="outlined", classes=CARD, raw_attrs=tid("cal-inputs")):
        with v.VCardText():
            _mode_and_source(v)
            _from_items(v, html, page)
            _from_upload(v, html)
            _from_folder(v, html)
            _board_and_model(v, html)
            _run_controls(v, html, page)


def _mode_and_source(v: Any) -> None:
    """One camera or a stereo pair; the images from the project, an upload or a folder."""
    with v.VBtnToggle(
        v_model=("cal_mode", "camera"),
        mandatory=True,
        density="compact",
        color="primary",
        divided=True,
        classes="mb-3",
        disabled=("cal_running",),
    ):
        v.VBtn(
            "One camera",
            value="camera",
            prepend_icon="mdi-camera",
            title="Calibrate one camera: intrinsics and distortion",
            raw_attrs=tid("cal-mode-camera"),
        )
        v.VBtn(
            "Stereo pair",
            value="stereo",
            prepend_icon="mdi-camera-burst",
            title="Calibrate two cameras and the pose between them from simultaneous views",
            raw_attrs=tid("cal-mode-stereo"),
        )
    with v.VBtnToggle(
        v_model=("cal_source", "items"),
        mandatory=True,
        density="compact",
        divided=True,
        variant="outlined",
        color="primary",
        classes="mb-3 d-flex",
        disabled=("cal_running",),
    ):
        v.VBtn(
            "Project",
            value="items",
            prepend_icon="mdi-image-multiple-outline",
            size="small",
            title="Images from the project's image items",
            raw_attrs=tid("cal-source-items"),
        )
        v.VBtn(
            "Upload",
            value="upload",
            prepend_icon="mdi-upload",
            size="small",
            title="Images uploaded from this computer (they become image items of the project)",
            raw_attrs=tid("cal-source-upload"),
        )
        v.VBtn(
            "Folder",
            value="folder",
            prepend_icon="mdi-folder-outline",
            size="small",
            title="Images in a folder on the server (inside the project or a data folder)",
            raw_attrs=tid("cal-source-folder"),
        )


def _from_items(v: Any, html: Any, page: Any) -> None:
    """The source "Project": the image items per camera, or picked by name."""

    def on_pick():
        page.pick_by_name()

    with html.Div(v_if="cal_source === 'items'"):
        _image_select(v, html, "cal_left_items", f"{STEREO} ? 'Left images' : 'Images'", "cal-left-items")
        with html.Div(v_if=STEREO):
            _image_select(v, html, "cal_right_items", "'Right images (same order)'", "cal-right-items")
        v.VBtn(
            (
                "{{ " + STEREO + " ? 'Split the image items by name: left… / right…' : "
                "'All image items of the project' }}"
            ),
            size="small",
            variant="tonal",
            prepend_icon="mdi-auto-fix",
            click=on_pick,
            disabled=("cal_running",),
            title="Fill the image lists from the project's image items (by name for a pair)",
            raw_attrs=tid("cal-pick"),
        )


def _watch_uploads(page: Any) -> None:
    """Files put in an upload field (``cal_upload_left``/``_right``) become image items."""

    def uploaded(side):
        def handler(**kw):
            files = kw.get(f"cal_upload_{side}")
            if files:
                page.add_uploads(files, side)
                page.state[f"cal_upload_{side}"] = None

        return handler

    page.state.change("cal_upload_left")(uploaded("left"))
    page.state.change("cal_upload_right")(uploaded("right"))


def _from_upload(v: Any, html: Any) -> None:
    """The source "Upload": a file field per camera (read by :func:`_watch_uploads`)."""
    with html.Div(v_if="cal_source === 'upload'"):
        html.Div("Uploaded images become image items of the project.", classes="text-caption mb-2")
        for side, label in (("left", f"{STEREO} ? 'Left images' : 'Images'"), ("right", "'Right images'")):
            extra = {"v_if": STEREO} if side == "right" else {}
            v.VFileInput(
                v_model=(f"cal_upload_{side}", None),
                **extra,
                label=(label,),
                multiple=True,
                accept=",".join(IMAGE_EXTS),
                density="compact",
                variant="outlined",
                hide_details=True,
                classes="mb-2",
                prepend_icon="mdi-image-multiple",
                disabled=("cal_running",),
                title="Choose image files to upload",
                raw_attrs=tid(f"cal-upload-{side}"),
            )


def _from_folder(v: Any, html: Any) -> None:
    """The source "Folder": a folder on the server and a glob per camera."""
    with html.Div(v_if="cal_source === 'folder'"):
        v.VTextField(
            v_model=("cal_folder", ""),
            label="Folder on the server",
            density="compact",
            variant="outlined",
            hide_details=True,
            classes="mb-2",
            disabled=("cal_running",),
            placeholder="/data/calibration/2024-05-02",
            title="A folder on the machine that runs camcmm, inside the project or a data folder",
            raw_attrs=tid("cal-folder"),
        )
        with html.Div(classes="d-flex ga-2 mb-2"):
            v.VTextField(
                v_model=("cal_left_pattern", "*"),
                label=(f"{STEREO} ? 'Left images (glob)' : 'Images (glob)'",),
                density="compact",
                variant="outlined",
                hide_details=True,
                disabled=("cal_running",),
                title="Which files of the folder: a pattern such as left*.png",
                raw_attrs=tid("cal-left-pattern"),
            )
            v.VTextField(
                v_if=STEREO,
                v_model=("cal_right_pattern", "right*"),
                label="Right images (glob)",
                density="compact",
                variant="outlined",
                hide_details=True,
                disabled=("cal_running",),
                title="The right camera's files, in the same order as the left's",
                raw_attrs=tid("cal-right-pattern"),
            )


def _board_and_model(v: Any, html: Any) -> None:
    """The board form, the distortion model, the outlier factor, the name."""
    _board_form(v, html)
    with html.Div(classes="d-flex ga-2 mb-2"):
        v.VSelect(
            v_model=("cal_model", "standard"),
            items=("cal_models",),
            item_title="title",
            item_value="value",
            label="Distortion model",
            density="compact",
            variant="outlined",
            hide_details=True,
            disabled=("cal_running",),
            title="Which lens distortion terms are estimated",
            raw_attrs=tid("cal-model"),
        )
        v.VTextField(
            v_model=("cal_outlier", 3.0),
            label="Outlier × median",
            type="number",
            min=0,
            step="0.5",
            density="compact",
            variant="outlined",
            hide_details=True,
            style="max-width: 130px;",
            disabled=("cal_running",),
            title="Leave out views whose RMS exceeds this times the median (0 keeps all)",
            raw_attrs=tid("cal-outlier"),
        )
    v.VTextField(
        v_model=("cal_name", ""),
        label="Name of the calibration (optional)",
        density="compact",
        variant="outlined",
        hide_details=True,
        disabled=("cal_running",),
        title="A name to find this calibration by later (empty: one is made)",
        raw_attrs=tid("cal-name"),
    )


def _number_field(v: Any, model: str, label: Any, testid: str, title: str, **kw: Any) -> None:
    v.VTextField(
        v_model=(model, ""),
        label=label,
        type="number",
        min=0,
        density="compact",
        variant="outlined",
        hide_details="auto",
        disabled=("cal_running",),
        title=title,
        raw_attrs=tid(testid),
        **kw,
    )


def _select(v: Any, model: tuple[str, str], items: str, label: str, testid: str, title: str, **kw: Any) -> None:
    """A compact select of the board form (held while a calibration runs); ``items`` is a
    state key of ``{title, value}`` entries or plain strings."""
    v.VSelect(
        v_model=model,
        items=(items,),
        label=label,
        density="compact",
        variant="outlined",
        hide_details=True,
        disabled=("cal_running",),
        title=title,
        raw_attrs=tid(testid),
        **kw,
    )


def _board_form(v: Any, html: Any) -> None:
    """The board: its type, the points across and down, the square size (circle spacing)
    with its unit — required, it sets the scale of every length — the ChArUco marker and
    dictionary; the board's drawing, its code as the command line takes it, and the board
    looked for in the first image (:meth:`.page.CalibrationPage.check_board_async`)."""
    with html.Div(classes="mt-1 mb-2", raw_attrs=tid("cal-board-form")):
        html.Div("Calibration board", classes="text-subtitle-2 mb-1")
        _select(
            v, ("cal_board_kind", "chessboard"), "cal_board_kinds", "Board type", "cal-board-kind",
            "The kind of calibration target in the images", item_title="title", item_value="value", classes="mb-2",
        )  # fmt: skip
        with html.Div(classes="d-flex ga-2 mb-2 align-center"):
            _number_field(
                v, "cal_board_cols", (f"{COUNTED} + ' across'",), "cal-board-cols",
                "Along the board's long side: inner corners of a chessboard (where four squares meet), squares of "
                "a ChArUco board, circles of a circle grid (per row for the asymmetric grid)",
                step=1,
            )  # fmt: skip
            html.Span("×")
            _number_field(
                v, "cal_board_rows", (f"{COUNTED} + ' down'",), "cal-board-rows",
                "Along the board's short side, counted as across", step=1,
            )  # fmt: skip
        with html.Div(classes="d-flex ga-2 mb-2 align-start"):
            _number_field(
                v, "cal_board_square", (f"{CIRCLES} ? 'Circle spacing' : 'Square size'",), "cal-board-square",
                "Measured on the printed board: it sets the scale of every length the calibration gives",
                step="any", error_messages=(f"{MISSING_SIZE} ? ['required: measure it on the board'] : []",),
            )  # fmt: skip
            _select(
                v, ("cal_board_unit", "mm"), "cal_board_units", "Unit", "cal-board-unit",
                "The unit of the square size (and of the marker size)", style="max-width: 92px;",
            )  # fmt: skip
        with html.Div(v_if="cal_board_kind === 'charuco'", classes="d-flex ga-2 mb-2"):
            _number_field(
                v, "cal_board_marker", "Marker size", "cal-board-marker",
                "The side of the black ArUco marker inside a white square, in the unit above", step="any",
                style="max-width: 120px;",
            )  # fmt: skip
            _select(
                v, ("cal_board_dict", "DICT_5X5_100"), "cal_board_dicts", "Marker dictionary", "cal-board-dict",
                "The marker dictionary the board was generated with: bits per marker side, markers in it",
                item_title="title", item_value="value",
            )  # fmt: skip
        html.Img(
            src=("cal_board_svg",),
            v_if="cal_board_svg",
            alt="drawing of the board",
            style="display: block; max-width: 100%; margin: 4px auto;",
            raw_attrs=tid("cal-board-drawing"),
        )
        html.Div(  # a missing square size is said by its field; other faults here
            "{{ cal_board ? cal_board_words + ' — board code for the command line: ' + cal_board : cal_board_error }}",
            v_if=f"cal_board || !({MISSING_SIZE})",
            classes=("cal_board ? 'text-caption' : 'text-caption text-error'",),
            raw_attrs=tid("cal-board-code"),
        )
        with html.Div(v_if="cal_board_check.text", classes="d-flex ga-2 align-center mt-1",
                      raw_attrs=tid("cal-board-check")):  # fmt: skip
            html.Img(v_if="cal_board_check.image", src=("cal_board_check.image",), style="width: 120px;")
            v.VIcon(
                "{{ cal_board_check.state === 'ok' ? 'mdi-check-circle' : "
                "(cal_board_check.state === 'missing' ? 'mdi-alert' : 'mdi-information-outline') }}",
                color=("cal_board_check.state === 'ok' ? 'success' : "
                       "(cal_board_check.state === 'missing' ? 'warning' : undefined)",),
                size="small",
            )  # fmt: skip
            html.Span("{{ cal_board_check.text }}", classes="text-caption", raw_attrs=tid("cal-board-check-text"))


def _run_controls(v: Any, html: Any, page: Any) -> None:
    """Calibrate and Cancel, the progress bar and the message."""

    def on_run(req):
        in_background(page.run_async(req or {}), page.state)  # returns at once: Cancel must reach the server

    def on_cancel():
        page.cancel()

    with html.Div(classes="d-flex ga-2 mt-3"):
        v.VBtn(
            "Calibrate",
            color="primary",
            prepend_icon="mdi-play",
            loading=("cal_running",),
            disabled=("cal_running",),
            click=(on_run, RUN_ARGS),
            title="Run the calibration (Ctrl+Enter)",
            raw_attrs=[*tid("cal-run"), 'data-shortcut="run"'],
        )
        v.VBtn(
            "Cancel",
            v_if="cal_running",
            variant="text",
            click=on_cancel,
            title="Stop the calibration; nothing is stored",
            raw_attrs=tid("cal-cancel"),
        )
    with v.VProgressLinear(
        v_show="cal_running || cal_progress > 0",
        model_value=("cal_progress",),
        height=18,
        rounded=True,
        classes="mt-2",
        color=("cal_running ? 'primary' : 'success'",),
        raw_attrs=tid("cal-progress"),
    ):
        html.Span("{{ Math.round(cal_progress) }} %", classes="text-caption")
    html.Div("{{ cal_message }}", classes="text-caption mt-1", raw_attrs=tid("cal-message"))


def build(page: Any) -> None:
    """The page inside the current layout context (shown while it is the page shown)."""
    from trame.widgets import html
    from trame.widgets import plotly as tplotly
    from trame.widgets import vuetify3 as v

    with html.Div(
        v_if=shown("calibration"),
        classes="pa-3 d-flex ga-3",
        raw_attrs=tid("calibration"),
        style="flex: 1 1 0; min-width: 0; height: calc(100vh - 48px - 24px); overflow-y: auto;",
    ):
        with html.Div(style="flex: 0 0 380px; max-width: 380px;"):
            _inputs(v, html, page)
            cards.save(v, html, page)
        with html.Div(style="flex: 1 1 0; min-width: 0;"):
            v.VAlert(
                v_if="cal_error",
                text=("cal_error",),
                type="error",
                density="compact",
                closable=True,
                classes="mb-2",
                click_close="cal_error = ''",
                raw_attrs=tid("cal-error"),
            )
            cards.results(v, html, tplotly, page)
