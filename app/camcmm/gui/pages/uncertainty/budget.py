"""The GUM budget tab's documents: the editor's rows, the budget file they make, and
what the page shows and exports of the plugin's result.

The rows hold the cells as typed (strings); the plugin providing ``uncertainty-budget``
checks them and computes everything (u_c, ν_eff, k, U, the shares). Nothing here
computes: it arranges and formats the plugin's numbers.
"""

from __future__ import annotations

import json
import math
from typing import Any

from ....jsonable import to_jsonable
from ...downloads import Downloads, table_csv
from . import figures as figs

DISTRIBUTIONS = ["normal", "rectangular", "triangular", "u-shaped", "student-t"]
EMPTY_ROW = {"name": "", "u": "", "c": "1", "dof": "inf", "distribution": "normal"}


def rows_from_doc(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Editor rows (strings, as typed) from a budget document."""
    rows = []
    for c in doc.get("contributions") or []:
        dof = c.get("dof", "inf")
        rows.append(
            {
                "name": str(c.get("name", "")),
                "u": str(c.get("u", "")),
                "c": str(c.get("c", 1)),
                "dof": "inf" if dof is None or (isinstance(dof, float) and math.isinf(dof)) else str(dof),
                "distribution": str(c.get("distribution", "normal")),
            }
        )
    return rows


def budget_doc(quantity: str, unit: str, p: Any, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The budget file's form (the contract of ``camcmm uncertainty budget``) from the editor."""
    contributions = []
    for r in rows:
        c = {
            "name": str(r.get("name") or "").strip(),
            "u": r.get("u"),
            "dof": r.get("dof") or "inf",
            "distribution": r.get("distribution") or "normal",
        }
        if str(r.get("c", "")).strip() not in ("", "1"):
            c["c"] = r.get("c")
        contributions.append(c)
    return {"quantity": quantity, "unit": unit, "coverage_probability": p, "contributions": contributions}


def shown(res: dict[str, Any]) -> dict[str, Any]:
    """The result card's texts (``unc_b_result``) from the plugin's outputs."""
    return {
        "combined": figs.fmt(res["combined"]),
        "dof_eff": figs.fmt(res["dof_eff"], 3),
        "k": figs.fmt(res["k"], 3),
        "expanded": figs.fmt(res["expanded"]),
        "p": f"{100 * float(res['coverage_probability']):g} %",
        "unit": figs.shown_unit(res.get("unit")),
        "shares": [
            {
                "name": c["name"],
                "contribution": figs.fmt(c["contribution"]),
                "share": f"{100 * float(c['share']):.1f} %",
            }
            for c in res["contributions"]
        ],
    }


def exports(offered: Downloads, name: str, doc: dict[str, Any], res: dict[str, Any]) -> list[dict[str, str]]:
    """Offer the budget as YAML (the file ``camcmm uncertainty budget`` reads), the table
    as CSV, the plugin's outputs as JSON and the chart as PNG; the links offered."""
    import yaml

    rows = [
        [c["name"], c["u"], c["c"], c["dof"], c["distribution"], c["contribution"], c["share"]]
        for c in res["contributions"]
    ]
    rows.append(["combined", None, None, res["dof_eff"], None, res["combined"], 1.0])
    rows.append(
        [
            f"expanded (k = {res['k']:.3g}, p = {res['coverage_probability']:g})",
            None,
            None,
            None,
            None,
            res["expanded"],
            None,
        ]
    )
    header = ["name", f"u ({res.get('unit', '')})", "c", "dof", "distribution", "|c·u|", "share"]
    links = [
        offered.offer(f"{name}.yaml", data=yaml.safe_dump(doc, sort_keys=False, allow_unicode=True).encode()),
        offered.offer(f"{name}.csv", data=table_csv(header, rows)),
        offered.offer(f"{name}.json", data=json.dumps(to_jsonable(res), indent=1, default=str).encode()),
        offered.offer(f"{name}.png", data=figs.figure_png(figs.budget_figure(res))),
    ]
    return [link for link in links if link]
