"""The Photogrammetry page's right column: the series as thumbnails with the plugin's
feature and match counts per image; an unregistered image is flagged with the reason."""

from __future__ import annotations

from ...widgets import tid

COLUMN = "height: calc(100vh - 48px - 24px); overflow-y: auto;"


def images_column() -> None:
    """The series as thumbnails with the counts; unregistered ones flagged with the reason."""
    from trame.widgets import html
    from trame.widgets import vuetify3 as v

    with html.Div(
        classes="pa-2",
        style=f"flex: 0 0 250px; max-width: 250px; border-left: 1px solid rgba(0,0,0,0.12); {COLUMN}",
        raw_attrs=tid("pg-images"),
    ):
        html.Div("Images", classes="text-subtitle-2 mb-1")
        html.Div(
            "none yet: choose a folder or image items and press Show",
            v_if="!pg_images.length",
            classes="text-caption text-medium-emphasis",
        )
        with v.VCard(
            v_for="im in pg_images",
            key="im.name",
            variant="outlined",
            classes="mb-1",
            color=("im.status === 'unregistered' ? 'error' : undefined",),
            raw_attrs=[*tid("pg-image"), ':data-status="im.status"', ':data-name="im.name"'],
        ):
            with html.Div(classes="d-flex ga-2 pa-1"):
                html.Img(
                    v_if="im.thumb",
                    src=("im.thumb",),
                    style="width: 72px; height: auto; flex: 0 0 72px;",
                    raw_attrs=[':alt="im.name"'],
                )
                with html.Div(classes="text-caption", style="min-width: 0; overflow-wrap: anywhere;"):
                    html.Div("{{ im.name }}", classes="font-weight-medium")
                    html.Div(
                        "{{ im.n_features }} features · {{ im.n_matched }} matched",
                        v_if="im.n_features !== null && im.n_features !== undefined",
                        raw_attrs=tid("pg-image-counts"),
                    )
                    html.Div(
                        "registered",
                        v_if="im.status === 'registered'",
                        classes="text-success",
                    )
                    html.Div(
                        "not registered: {{ im.reason }}",
                        v_if="im.status === 'unregistered'",
                        classes="text-error",
                        raw_attrs=tid("pg-image-reason"),
                    )
