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

#: How a row is entered: a standard uncertainty u, a half-width a with its distribution, or
#: an expanded uncertainty U with its coverage factor k (the plugin converts: GUM 4.3.3-4.3.9).
KINDS = [
    {"value": "u", "title": "u (standard)"},
    {"value": "a", "title": "a (half-width)"},
    {"value": "U", "title": "U (expanded, k)"},
]
#: The distributions each kind takes (for u it only records how u was evaluated).
DISTRIBUTIONS = {
    "u": ["normal", "rectangular", "triangular", "u-shaped", "student-t"],
    "a": ["rectangular", "triangular", "u-shaped"],
    "U": ["normal", "student-t"],
}
EMPTY_ROW = {"name": "", "kind": "u", "value": "", "distribution": "normal", "k": "", "c": "1", "dof": "inf"}


def _text(x: Any) -> str:
    return "" if x is None else str(x)


def rows_from_doc(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Editor rows (strings, as typed) from a budget document. An entry's ``u``,
    ``half_width`` (``a``) or ``expanded`` (``U``) gives the row's kind and value; a
    half-width with a normal distribution is an expanded U with its k (as the plugin reads it)."""
    rows = []
    for c in doc.get("contributions") or []:
        if not isinstance(c, dict):
            continue
        dof = c.get("dof", "inf")
        dist = str(c.get("distribution") or "normal")
        k = c.get("k", c.get("k_a"))
        if c.get("half_width", c.get("a")) is not None:
            kind, value = "a", c.get("half_width", c.get("a"))
            if dist in DISTRIBUTIONS["U"]:
                kind, k = "U", 2 if k is None else k
        elif c.get("expanded", c.get("U")) is not None:
            kind, value = "U", c.get("expanded", c.get("U"))
        else:
            kind, value = "u", c.get("u")
        rows.append(
            {
                "name": str(c.get("name", "")),
                "kind": kind,
                "value": _text(value),
                "distribution": dist,
                "k": _text(k) if kind == "U" else "",
                "c": str(c.get("c", 1)),
                "dof": "inf" if dof is None or (isinstance(dof, float) and math.isinf(dof)) else str(dof),
                "unit": _text(c.get("unit")),  # the input's own unit (kept; the conversion shows it)
            }
        )
    return rows


def budget_doc(quantity: str, unit: str, p: Any, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The budget file's form (the contract of ``camcmm uncertainty budget``) from the editor:
    each row as ``u``, ``half_width`` + ``distribution`` or ``expanded`` + ``k``."""
    contributions = []
    for r in rows:
        kind = str(r.get("kind")) if r.get("kind") in ("u", "a", "U") else "u"
        value = r.get("value", r.get("u"))  # rows of an older page held "u"
        c: dict[str, Any] = {"name": str(r.get("name") or "").strip()}
        c[{"u": "u", "a": "half_width", "U": "expanded"}[kind]] = value
        if kind == "U" and _text(r.get("k")).strip():
            c["k"] = r.get("k")
        c["dof"] = r.get("dof") or "inf"
        c["distribution"] = r.get("distribution") or ("rectangular" if kind == "a" else "normal")
        if str(r.get("c", "")).strip() not in ("", "1"):
            c["c"] = r.get("c")
        if _text(r.get("unit")).strip():
            c["unit"] = str(r["unit"]).strip()
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
        # per editor row, in order: the standard uncertainty the plugin used and how it
        # came from what was entered ("a = 2 µm, rectangular → u = a/√3 = 1.155 µm")
        "rows": [
            {"u": figs.fmt(c["u"], 4), "conversion": c.get("conversion", ""), "entered_as": c.get("entered_as", "u")}
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
            f"expanded (k = {res['k']:.3g}, p = {res['coverage_probability']:g})",
            None,
            None,
            None,
            None,
            res["expanded"],
            None,
            None,
        ]
    )
    header = ["name", f"u ({res.get('unit', '')})", "c", "dof", "distribution", "|c·u|", "share", "entered as"]
    links = [
        offered.offer(f"{name}.yaml", data=yaml.safe_dump(doc, sort_keys=False, allow_unicode=True).encode()),
        offered.offer(f"{name}.csv", data=table_csv(header, rows)),
        offered.offer(f"{name}.json", data=json.dumps(to_jsonable(res), indent=1, default=str).encode()),
        offered.offer(f"{name}.png", data=figs.figure_png(figs.budget_figure(res))),
    ]
    return [link for link in links if link]
