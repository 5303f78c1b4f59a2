"""The GUM budget tab's documents: the editor's rows, the budget file they make, and
what the page shows and exports of the plugin's result.

The rows hold the cells as typed (strings); the plugin providing ``uncertainty-budget``
checks them and computes everything (u_c, ν_eff, k, U, the shares). Nothing here
computes: it arranges and formats the plugin's numbers. The rows <-> budget file are the
task's (:mod:`camcmm.tasks.uncertainty`: ``rows_from_doc``, ``budget_doc``, re-exported).
"""

from __future__ import annotations

import json
from typing import Any

from .... import numbers as num
from ....jsonable import to_jsonable
from ....tasks.uncertainty import DISTRIBUTIONS, budget_doc, rows_from_doc
from ...downloads import Downloads, table_csv
from . import figures as figs

__all__ = ["DISTRIBUTIONS", "EMPTY_ROW", "KINDS", "budget_doc", "exports", "rows_from_doc", "shown"]

#: How a row is entered: a standard uncertainty u, a half-width a with its distribution, or
#: an expanded uncertainty U with its coverage factor k (the plugin converts: GUM 4.3.3-4.3.9).
KINDS = [
    {"value": "u", "title": "u (standard)"},
    {"value": "a", "title": "a (half-width)"},
    {"value": "U", "title": "U (expanded, k)"},
]
#: The distributions each kind takes (for u it only records how u was evaluated).
EMPTY_ROW = {"name": "", "kind": "u", "value": "", "distribution": "normal", "k": "", "c": "1", "dof": "∞"}


def shown(res: dict[str, Any]) -> dict[str, Any]:
    """The result card's texts (``unc_b_result``) from the plugin's outputs: u_c and U
    with two significant digits (GUM 7.2.6), k and ν_eff as plain numbers, each share as
    a percentage of the combined variance u_c² (:data:`figures.SHARE_MEANING`)."""
    return {
        "combined": figs.u_text(res["combined"]),
        "dof_eff": figs.fmt(res["dof_eff"], 3),
        "k": num.plain(res["k"], 3),  # a coverage factor keeps its three digits: 2.00
        "expanded": figs.u_text(res["expanded"]),
        "p": num.percentile(100 * float(res["coverage_probability"])),
        "unit": figs.shown_unit(res.get("unit")),
        "share_meaning": figs.SHARE_MEANING,
        "shares": [
            {
                "name": c["name"],
                "contribution": figs.u_text(c["contribution"]),
                "share": num.percent(float(c["share"])),
            }
            for c in res["contributions"]
        ],
        # per editor row, in order: the standard uncertainty the plugin used and how it
        # came from what was entered ("a = 2 µm, rectangular → u = a/√3 = 1.155 µm"): an
        # intermediate of the budget, with the conversion's four digits (GUM 7.2.6 allows
        # more than two where later sums would otherwise round)
        "rows": [
            {
                "u": num.significant(c["u"], 4),
                "conversion": c.get("conversion", ""),
                "entered_as": c.get("entered_as", "u"),
            }
            for c in res["contributions"]
        ],
    }


def exports(offered: Downloads, name: str, doc: dict[str, Any], res: dict[str, Any]) -> list[dict[str, str]]:
    """Offer the budget as YAML (the file ``camcmm uncertainty budget`` reads), the table
    as CSV, the plugin's outputs as JSON and the chart as PNG; the links offered."""
    import yaml

    rows = [
        [c["name"], c["u"], c["c"], c["dof"], c["distribution"], c["contribution"], c["share"], c.get("conversion")]
        for c in res["contributions"]
    ]
    rows.append(["combined", None, None, res["dof_eff"], None, res["combined"], 1.0, None])
    rows.append(
        [
            f"expanded (k = {figs.fmt(res['k'], 3)}, p = {num.percentile(100 * float(res['coverage_probability']))})",
            None,
            None,
            None,
            None,
            res["expanded"],
            None,
            None,
        ]
    )
    unit = figs.shown_unit(res.get("unit"))
    header = ["name", f"u ({unit})", "c", "dof", "distribution", f"|c·u| ({unit})", "share of u_c²", "entered as"]
    links = [
        offered.offer(f"{name}.yaml", data=yaml.safe_dump(doc, sort_keys=False, allow_unicode=True).encode()),
        offered.offer(f"{name}.csv", data=table_csv(header, rows)),
        offered.offer(f"{name}.json", data=json.dumps(to_jsonable(res), indent=1, default=str).encode()),
        offered.offer(f"{name}.png", data=figs.figure_png(figs.budget_figure(res))),
    ]
    return [link for link in links if link]
