"""The Monte Carlo tab's documents: the form's fields from the plugin's declaration, the
table and the exports.

Every number comes from the plugin providing ``monte-carlo-uncertainty``; checking the
form, running, storing and reading a run back is the task's
(:mod:`camcmm.tasks.uncertainty`; ``inputs``, ``store``, ``read``, ``load_system``,
``done_message`` re-exported here). This module formats and offers.
"""

from __future__ import annotations

import json
from typing import Any

from .... import numbers as num
from ....params import form_schema
from ....tasks.uncertainty import ARRAYS, MC_KEY, RUN, done_message, inputs, load_system, read
from ....tasks.uncertainty import store_montecarlo as store
from ...downloads import Downloads, table_csv
from . import figures as figs

__all__ = ["ARRAYS", "MC_KEY", "STUDIES", "done_message", "exports", "form_fields", "inputs", "load_system", "read"]
__all__ += ["start_values", "store", "table_rows"]

STUDIES = ["convergence", "sweep", "volume_maps", "spatial"]
#: the studies as the page offers them (the values stay the plugin's keys)
STUDY_TITLES = {
    "convergence": "convergence with iterations",
    "sweep": "feature-location sweep",
    "volume_maps": "volume maps",
    "spatial": "spatial variation",
}
#: The form's first values of the run, the task's ``RUN`` fields (the plugin's own defaults
#: are the file's or 10000 iterations: a first run in the page should take seconds).
START = {"iterations": 2000, "seed": 1, "method": "linear", "scheduler": ""}


def form_fields(plugin: Any) -> dict[str, list[dict[str, Any]]]:
    """The form of ``plugin``'s declared parameters (:func:`camcmm.params.form_schema`)
    in three groups: ``run`` (iterations, seed, method, scheduler), ``system`` (cameras,
    stereo, grid) and ``errors`` (the influence factors' u and dof: ``u_*``, ``dof_*``);
    ``studies`` is offered as a list to tick (:data:`STUDIES`). Labels as form_schema
    makes them (the unit once, in brackets)."""
    groups: dict[str, list[dict[str, Any]]] = {"run": [], "system": [], "errors": []}
    for f in form_schema(plugin.parameters):
        if f["name"] == "studies":
            continue
        key = "run" if f["name"] in RUN else "errors" if f["name"].startswith(("u_", "dof_")) else "system"
        groups[key].append(f)
    return groups


def _typed(x: float) -> str:
    """A number as one types it into a field: never an exponent (1e-05 reads 0.00001), an
    ASCII minus (the field is parsed back)."""
    return num.significant(x, 6).replace(num.MINUS, "-")


def _shown(value: Any) -> Any:
    """A declared default as the form shows it (a vector as "16.74, 16.66")."""
    if isinstance(value, (list, tuple)):
        return ", ".join(_typed(x) if isinstance(x, float) else str(x) for x in value)
    if isinstance(value, float):
        return _typed(value)
    return value


def start_values(groups: dict[str, list[dict[str, Any]]], values: dict[str, Any] | None = None) -> dict[str, Any]:
    """The form's values: the declared defaults (the thesis system), the run's :data:`START`,
    then ``values`` (e.g. a stored run's form)."""
    out = {f["name"]: _shown(f.get("default")) for fs in groups.values() for f in fs}
    out.update(START)
    out.update({k: _shown(v) for k, v in (values or {}).items() if k in out})
    return out


def table_rows(full: dict[str, Any]) -> list[dict[str, Any]]:
    """The table of thesis table 3.2: one row per factor (standard uncertainty u in x, y, z
    with two significant digits, dof, distribution), then the combined u_c and U (rows with
    ``total``). The effective dof and the coverage factor k are not lengths: they go in the
    dof column and in U's name ("U = k·u_c (k = 2.03 / 2.05 / 2.03, 95 %)"), not in the
    µm columns beside the uncertainties."""
    rows = []
    for f, u in (full.get("contributions") or {}).items():
        rows.append(
            {
                "factor": figs.factor_title(f),
                "x": figs.u_text(u[0]),
                "y": figs.u_text(u[1]),
                "z": figs.u_text(u[2]),
                "dof": figs.fmt((full.get("factor_dof") or {}).get(f), 4),
                "distribution": (full.get("factor_distribution") or {}).get(f, ""),
            }
        )
    dof = [figs.fmt(x, 3) for x in (full.get("dof_eff") or [])]
    ks = [num.plain(x, 3) for x in (full.get("k") or [])]
    k_text = ks[0] if ks and len(set(ks)) == 1 else " / ".join(ks)
    p = num.percentile(100 * float(full.get("coverage_probability", 0.95)))
    for key, title, dof_text in (
        ("combined", "combined standard uncertainty u_c", ("ν_eff " + " / ".join(dict.fromkeys(dof))) if dof else ""),
        ("expanded", f"expanded U = k·u_c (k = {k_text}, {p})" if ks else f"expanded U ({p})", ""),
    ):
        v = full.get(key) or [None] * 3
        rows.append(
            {
                "factor": title,
                "x": figs.u_text(v[0]),
                "y": figs.u_text(v[1]),
                "z": figs.u_text(v[2]),
                "dof": dof_text,
                "distribution": "",
                "total": True,
            }
        )
    return rows


def exports(
    offered: Downloads, full: dict[str, Any], rid: int | None, rows: list[dict[str, Any]], axis: str
) -> list[dict[str, str]]:
    """Offer the table (CSV), the whole result (JSON) and each chart drawn (PNG)."""
    name = f"montecarlo-{rid if rid is not None else 'unsaved'}"
    header = ["factor", "u_x", "u_y", "u_z", "dof", "distribution"]
    unit = full.get("unit", "um")
    table = [[r["factor"], r["x"], r["y"], r["z"], r["dof"], r["distribution"]] for r in rows]
    studies = full.get("studies") or {}
    links = [
        offered.offer(
            f"{name}.csv",
            replace=True,
            data=table_csv([header[0]] + [f"{h} ({unit})" for h in header[1:4]] + header[4:], table),
        ),
        offered.offer(f"{name}.json", data=json.dumps(full).encode(), replace=True),
        offered.offer(f"{name}-contributions.png", replace=True, data=figs.figure_png(figs.contributions_figure(full))),
    ]
    charts = {
        "convergence": lambda s: figs.convergence_figure(s, unit, axis),
        "sweep": lambda s: figs.sweep_figure(s, unit),
        "spatial": lambda s: figs.spatial_figure(s, unit),
    }
    for key, draw in charts.items():
        if studies.get(key):
            links.append(offered.offer(f"{name}-{key}.png", replace=True, data=figs.figure_png(draw(studies[key]))))
    return [link for link in links if link]
