"""The Monte Carlo tab's documents: the form's values checked by the plugin's own
declaration, the stored result (summary row + JSON file), the table and the exports.

Every number comes from the plugin providing ``monte-carlo-uncertainty``; this module
checks the form through :func:`camcmm.params.validate`, stores, formats and offers.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from ....errors import InputError
from ....jsonable import to_jsonable
from ....params import form_schema, validate
from ....yamlfile import load_yaml
from ...downloads import Downloads, table_csv
from . import figures as figs

STUDIES = ["convergence", "sweep", "volume_maps", "spatial"]
#: The form's first values of the run (the plugin's own defaults are the file's or 10000
#: iterations: a first run in the page should take seconds).
START = {"iterations": 2000, "seed": 1, "method": "linear", "scheduler": ""}
RUN = tuple(START)
#: The project state key naming the last stored run ({"result": id, "file": hash}).
MC_KEY = "uncertainty.montecarlo.current"
#: Outputs too large for the result row: they are in the stored JSON file only.
ARRAYS = ("per_point", "per_point_norm", "studies", "system", "form")


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


def _shown(value: Any) -> Any:
    """A declared default as the form shows it (a vector as "16.74, 16.66")."""
    if isinstance(value, (list, tuple)):
        return ", ".join(f"{x:g}" if isinstance(x, float) else str(x) for x in value)
    return value


def start_values(groups: dict[str, list[dict[str, Any]]], values: dict[str, Any] | None = None) -> dict[str, Any]:
    """The form's values: the declared defaults (the thesis system), the run's :data:`START`,
    then ``values`` (e.g. a stored run's form)."""
    out = {f["name"]: _shown(f.get("default")) for fs in groups.values() for f in fs}
    out.update(START)
    out.update({k: _shown(v) for k, v in (values or {}).items() if k in out})
    return out


def inputs(form: dict[str, Any], plugin: Any, system: Any = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The plugin's inputs (``{"spec": system}`` for a loaded file, else none: the fields are
    the system) and the form's values checked against ``plugin``'s declared parameters;
    a one-line :class:`InputError` / ParameterError naming what is wrong. With a loaded
    file only the run's fields are sent (the file is the system)."""
    if system is not None and not isinstance(system, dict):
        raise InputError("system description: expected a mapping (cameras, stereo, grid, uncertainties)")
    declared = {p.name for p in plugin.parameters}
    given = {k: v for k, v in form.items() if k in declared and k != "studies"}
    if system is not None:
        given = {k: v for k, v in given.items() if k in RUN}
    given["scheduler"] = str(given.get("scheduler") or "").strip() or None
    given["studies"] = ",".join(str(x) for x in (form.get("studies") or []))
    values = validate(plugin.parameters, given, owner=f"plugin {plugin.id!r}")
    if system is not None:
        values = {k: v for k, v in values.items() if k in RUN or k == "studies"}
    return ({"spec": system} if system is not None else {}), {k: v for k, v in values.items() if v is not None}


def load_system(text: str | bytes, name: str) -> dict[str, Any]:
    """A system file (YAML/JSON) read for the form's "load YAML" option (one line if bad)."""
    doc = load_yaml(text or "", name=name)
    if not isinstance(doc, dict):
        raise InputError(f"{name}: expected a mapping (cameras, stereo, grid, uncertainties)")
    return doc


def store(project: Any, run: Any, doc: dict[str, Any] | None, form: dict[str, Any] | None = None) -> tuple[int, str]:
    """The summary as the result row, everything (arrays too, the system simulated and
    the form's values when it came from the fields) as a JSON file; the project remembers
    it as the page's current run. Returns (result id, file hash)."""
    full = to_jsonable({**({"system": doc} if doc is not None else {}), **run.outputs, "form": form})
    folder = Path(tempfile.mkdtemp(prefix="camcmm-mc-"))
    try:
        path = folder / "montecarlo.json"
        path.write_text(json.dumps(full), encoding="utf-8")
        h = project.add_file(path)
    finally:
        for p in folder.iterdir():
            p.unlink()
        folder.rmdir()
    summary = dict(run.to_json())
    summary["outputs"] = {k: v for k, v in full.items() if k not in ARRAYS}
    rid = project.add_result(summary, files={"montecarlo": h}, label="Monte Carlo of a stereo system")
    project.set_state(MC_KEY, {"result": rid, "file": h})
    return rid, h


def read(project: Any, h: str) -> dict[str, Any]:
    """A stored run's full result (the JSON file of :func:`store`)."""
    return json.loads(project.file_path(h).read_text("utf-8"))


def done_message(full: dict[str, Any]) -> str:
    elapsed = full.get("elapsed_s")
    return (
        f"done: {full.get('iterations')} iterations × {full.get('n_points')} points"
        + (f" in {elapsed:.1f} s" if isinstance(elapsed, (int, float)) else "")
        + (f" ({full.get('executor')})" if full.get("executor") else "")
    )


def table_rows(full: dict[str, Any]) -> list[dict[str, Any]]:
    """The table of thesis table 3.2: one row per factor (u in x, y, z, dof, distribution),
    then combined u, effective dof, k and U (rows with ``total``)."""
    rows = []
    for f, u in (full.get("contributions") or {}).items():
        rows.append(
            {
                "factor": figs.factor_title(f),
                "x": figs.fmt(u[0], 3),
                "y": figs.fmt(u[1], 3),
                "z": figs.fmt(u[2], 3),
                "dof": figs.fmt((full.get("factor_dof") or {}).get(f), 4),
                "distribution": (full.get("factor_distribution") or {}).get(f, ""),
            }
        )
    for key, title in (
        ("combined", "combined u"),
        ("dof_eff", "effective dof"),
        ("k", "k"),
        ("expanded", f"U ({100 * float(full.get('coverage_probability', 0.95)):g} %)"),
    ):
        v = full.get(key) or [None] * 3
        rows.append(
            {
                "factor": title,
                "x": figs.fmt(v[0], 3),
                "y": figs.fmt(v[1], 3),
                "z": figs.fmt(v[2], 3),
                "dof": "",
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
