"""The "Calibration" page: one camera or a stereo pair from images of a target."""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from ... import calibration_page

    return calibration_page.mount(server, session)


def _build(page: Any) -> None:
    from ... import calibration_layout

    calibration_layout.build_panel(page)


PAGE = Page("calibration", "Calibration", "mdi-checkerboard", _mount, _build, order=40)
