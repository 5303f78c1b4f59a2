"""The "Series" page: one GD&T plan over several parts (issue 28) — pick the plan (the
project's, made on the Compare page, or a YAML file on the server) and the parts (project
clouds, files on the server), Run; a parts × characteristics table coloured by verdict
(ISO 14253-1); a click on a cell shows that part's labels (its characteristics with value,
U and verdict, and their flags where they sit on the part) and the characteristic's run
chart (values, tolerance limits, mean, control limits) with Cp/Cpk and their confidence
intervals beside it.

``page.py`` holds the state and handlers (the headless task :mod:`camcmm.tasks.series`),
``layout.py`` the widgets, ``figures.py`` the run chart and the part's labels.
"""

from __future__ import annotations

from typing import Any

from .. import Page


def _mount(server: Any, session: Any) -> Any:
    from .page import mount

    return mount(server, session)


def _build(page: Any) -> None:
    from .layout import build

    build(page)


PAGE = Page("series", "Series", "mdi-chart-timeline-variant", _mount, _build, order=49)
