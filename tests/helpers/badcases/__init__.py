"""Bad-input families added with issue 26, one module a topic, each a ``cases()`` list of
:class:`helpers.badinputs.Case` (building blocks from :mod:`helpers.badinputs`).

A module listed in :data:`FAMILIES` that does not exist yet is skipped, so the families
can land one at a time; :func:`helpers.badinputs.all_cases` joins them.
"""

from __future__ import annotations

import importlib

#: the modules of this package, in the order their cases are listed
FAMILIES = (
    "photogrammetry",
    "heightmaps",
    "speckle_lightfield",
    "studies_part3",
    "gdt",
    "cad",
    "qif",
    "qifout",
    "gdt_batch",
    "report",
    "crop",
    "bigcloud",
    "fusion",
    "calibration_board",
)


def cases() -> list:
    out: list = []
    for name in FAMILIES:
        try:
            module = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            continue
        out += module.cases()
    return out
