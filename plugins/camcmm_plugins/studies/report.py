"""The report of a ``studies.speckle`` run (HTML/PDF/JSON through camcmm.api's Report):
tables 6.1 (std of the deviations from CAD, µm) and 6.2 (point counts) in the thesis's
layout — a row per artefact, per material a non-speckle and a speckle column — the
area-coverage table (total and per face class), the summary per material and the
deviation maps with and without speckle side by side (figs. 6.10-6.13)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from camcmm.api import Report

LABEL = {"am_pyramid": "Pyramid", "am_recess": "Recess", "am_sphere": "Sphere", "am_pillars": "Pillars"}
MAT = {"nylon12": "Nylon", "abs": "ABS plastic", "ti6al4v": "Titanium"}


def _grid(cases: list[dict[str, Any]]) -> tuple[list[str], list[str], dict]:
    arts = list(dict.fromkeys(c["artefact"] for c in cases))
    mats = list(dict.fromkeys(c["material"] for c in cases))
    by = {(c["artefact"], c["material"], c["condition"]): c for c in cases}
    return arts, mats, by


def thesis_table(cases: list[dict[str, Any]], key: str, fmt) -> tuple[list[str], list[list[Any]]]:
    """Columns and rows of table 6.1 / 6.2 for the value ``key`` of each case."""
    arts, mats, by = _grid(cases)
    cols = ["Artefact"] + [f"{MAT.get(m, m)} {c}" for m in mats for c in ("non-speckle", "speckle")]
    rows = []
    for a in arts:
        row: list[Any] = [LABEL.get(a, a)]
        for m in mats:
            for cond in ("off", "on"):
                c = by.get((a, m, cond))
                if c is not None and "error" in c:
                    row.append("failed")  # the reason is in the summary's warnings
                else:
                    row.append(fmt(c[key]) if c is not None and c.get(key) is not None else None)
        rows.append(row)
    return cols, rows


def coverage_table(cases: list[dict[str, Any]]) -> tuple[list[str], list[list[Any]]]:
    classes = ["top", "side", "curved"]
    cols = ["Case", "covered area (%)"] + [f"{k} (%)" for k in classes] + ["points"]
    rows = []
    for c in cases:
        if "coverage_area_fraction" not in c:
            continue
        f = c["coverage_by_face"]
        rows.append(
            [c["id"], f"{100 * c['coverage_area_fraction']:.1f}"]
            + [None if f.get(k) is None else f"{100 * f[k]:.1f}" for k in classes]
            + [c["n_points"]]
        )
    return cols, rows


def deviation_pair_figure(off, on, title: str) -> bytes:
    """Top views of the two deviation clouds (colour = deviation, common scale), off left."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    clouds = [c for c in (off, on) if c is not None]
    dev = np.concatenate([np.asarray(c.fields["deviation"]) for c in clouds]) * 1000
    lim = float(np.percentile(np.abs(dev), 99)) or 1.0
    fig, axes = plt.subplots(1, 2, figsize=(170 / 25.4, 80 / 25.4))
    for ax, c, name in zip(axes, (off, on), ("without speckle", "with speckle")):
        ax.set_title(name, fontsize=8)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=6)
        if c is None:
            ax.set_axis_off()
            continue
        p, d = c.points, np.asarray(c.fields["deviation"]) * 1000
        k = np.random.default_rng(0).permutation(len(p))[:40000]  # enough to see, small to draw
        k = k[np.argsort(p[k, 2])]  # higher points drawn last, as seen from above
        im = ax.scatter(p[k, 0], p[k, 1], c=d[k], s=0.5, cmap="RdBu_r", vmin=-lim, vmax=lim, linewidths=0)
        ax.set_xlabel("x (mm)", fontsize=7)
        ax.set_ylabel("y (mm)", fontsize=7)
    cb = fig.colorbar(im, ax=list(axes), shrink=0.8)
    cb.set_label("deviation from CAD (µm)", fontsize=7)
    cb.ax.tick_params(labelsize=6)
    fig.suptitle(title, fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    return buf.getvalue()


def build_report(o: dict[str, Any], run=None, **_: Any) -> Report:
    """The report of a ``studies.speckle`` run's outputs ``o``."""
    cases = [c for c in o["cases"] if "std_um" in c]
    st = o["study"]
    rep = Report(
        "Laser speckle on AM artefacts",
        subtitle=f"{st['name']}: {len(cases)} case(s)",
        meta={"study": st["file"], "work folder": st["work"]},
    )
    sec = rep.section("Deviation from CAD (table 6.1)")
    cols, rows = thesis_table(o["cases"], "std_um", lambda v: round(v))
    sec.table(cols, rows, caption="Standard deviation (µm) of the point cloud from the CAD, without and with speckle")
    sec = rep.section("Point counts (table 6.2)")
    cols, rows = thesis_table(o["cases"], "n_points", lambda v: f"{v:,}")
    sec.table(cols, rows, caption="Points in each reconstruction")
    sec = rep.section("Coverage by area")
    sec.paragraph(
        "Covered share of the CAD surface's area (a surface sample counts when a measured point lies within "
        "the coverage distance), over the area a camera above the table can see, and per face class."
    )
    cols, rows = coverage_table(cases)
    sec.table(cols, rows, caption="Area coverage per case")
    sec = rep.section("Summary: mean change with speckle per material")
    sec.table(
        ["Material", "artefacts", "std change (µm)", "relative", "points change", "coverage change (%)"],
        [
            [
                MAT.get(m, m),
                s["n_artefacts"],
                None if not s["n_artefacts"] else f"{s['std_um_change']:+.0f}",
                None if not s["n_artefacts"] else f"{100 * s['std_um_relative_change']:+.0f} %",
                None if not s["n_artefacts"] else f"{s['n_points_change']:+,.0f}",
                None if not s["n_artefacts"] else f"{100 * s['coverage_area_fraction_change']:+.1f}",
            ]
            for m, s in o["summary"].items()
        ],
    )
    for c in o["cases"]:
        if "error" in c:
            sec.warning(f"{c['id']}: {c['error']}")
    arts, mats, by = _grid(cases)
    clouds = o.get("deviation_clouds") or {}
    sec = rep.section("Deviation maps, without and with speckle (figs. 6.10-6.13)")
    for a in arts:
        for m in mats:
            off, on = by.get((a, m, "off")), by.get((a, m, "on"))
            co = clouds.get(off["id"]) if off else None
            cn = clouds.get(on["id"]) if on else None
            if co is None and cn is None:
                continue
            sec.figure(
                deviation_pair_figure(co, cn, f"{LABEL.get(a, a)}, {MAT.get(m, m)}: top view"),
                caption=f"{a}, {m}: deviation from CAD (µm) without (left) and with speckle (right)",
            )
    if run is not None:
        rep.provenance(
            plugins=[{"id": run.plugin_id, "version": run.plugin_version, "params": run.params}],
            extra={"started": run.started, "finished": run.finished},
        )
    rep.data = {"cases": o["cases"], "summary": o["summary"]}
    return rep
