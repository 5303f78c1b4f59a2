"""The inspection report: one :class:`camcmm.api.Report` rendered as HTML, PDF and JSON.

A report for the customer: its head the order's fields (customer, part number, order,
drawing revision, operator, instrument, date, temperature; ``camcmm inspect --customer``
…). Body: the result (the overall verdict, the profile of the surface as on a drawing),
summary, deviations (colour map, histogram), coverage, signature fields. Appendix: the
comparison's notes, alignment, deviation statistics, material ratio (Abbott-Firestone
curve with its ISO 13565-2 construction), provenance.

Two charts are drawn here because ``camcmm.api.charts`` has no equivalent: the colour
map of a general 3-D part (``charts.deviation_map`` projects onto a sphere or a plane;
it is used as well when the part is flat) and the material-ratio curve. Both use
matplotlib's Agg canvas directly (no pyplot), the report's diverging colour scale
(RdBu_r, symmetric about zero) and its display units (mm, µm or nm).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from camcmm.api import Report, charts, numbers

_CMAP = "RdBu_r"
_DPI = 150
_MM = 1 / 25.4


def _unit(max_abs_mm: float) -> tuple[str, float]:
    """Display unit and factor mm -> unit: 0.05 mm reads as 50 µm (as the report's charts)."""
    if max_abs_mm >= 0.1 or max_abs_mm == 0:
        return "mm", 1.0
    if max_abs_mm >= 1e-4:
        return "µm", 1e3
    return "nm", 1e6


def _figure(width_mm: float, height_mm: float):
    from matplotlib.figure import Figure

    return Figure(figsize=(width_mm * _MM, height_mm * _MM), dpi=_DPI)


def _png(fig, info: dict) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI)
    return charts.ChartPNG(buf.getvalue(), info)


def _rc():
    import matplotlib as mpl

    return mpl.rc_context(
        {
            "font.size": 7.5,
            "axes.titlesize": 8,
            "axes.labelsize": 7.5,
            "xtick.labelsize": 7,
            "ytick.labelsize": 7,
            "legend.fontsize": 6.5,
            "axes.linewidth": 0.6,
        }
    )


def _subsample(dev: np.ndarray, n_max: int, seed: int = 0) -> np.ndarray:
    """At most ``n_max`` indices: the largest tenth of |dev| always, a seeded sample of the rest."""
    n = dev.size
    if n <= n_max:
        return np.arange(n)
    order = np.argsort(np.abs(dev), kind="stable")
    top = order[n - n_max // 10 :]
    rest = np.random.default_rng(seed).choice(order[: n - n_max // 10], n_max - n_max // 10, replace=False)
    return np.concatenate([rest, top])


VIEWS = ((np.array([1.0, -1.0, 0.8]), "view from +x −y +z"), (np.array([-1.0, 1.0, 0.8]), "view from −x +y +z"))
VIEWS3 = VIEWS + ((np.array([0.6, -0.8, -1.0]), "view from below"),)


def _project(p: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthographic screen coordinates (x right, y up) and depth (larger = nearer) for
    a viewer in direction ``d`` with +z up."""
    d = d / np.linalg.norm(d)
    up = np.array([0.0, 0.0, 1.0])
    ex = np.cross(up, d)
    ex = ex / np.linalg.norm(ex)
    ey = np.cross(d, ex)
    return p @ ex, p @ ey, p @ d


def deviation_views(
    points: np.ndarray,
    values: np.ndarray,
    limit: float | None = None,
    title: str | None = None,
    views: Sequence[tuple[np.ndarray, str]] = VIEWS,
    categorical: dict | None = None,
    max_points: int = 60_000,
    width_mm: float = 170.0,
) -> bytes:
    """Colour map of a 3-D part: orthographic views, nearer points drawn over farther ones.

    ``values`` in mm on the diverging scale ±``limit`` (default max|value|); or with
    ``categorical`` = {value: (colour, label)} discrete colours (e.g. covered / not).
    """
    p = np.asarray(points, dtype=float)
    v = np.asarray(values, dtype=float)
    idx = _subsample(v if categorical is None else np.zeros(len(v)), max_points)
    p, v = p[idx], v[idx]
    c0 = 0.5 * (p.min(axis=0) + p.max(axis=0))
    p = p - c0
    proj = [_project(p, d) for d, _ in views]
    span_x = max(float(x.max() - x.min()) for x, _, _ in proj) or 1.0
    span_y = max(float(y.max() - y.min()) for _, y, _ in proj) or 1.0
    n = len(views)
    bar = 19.0 if categorical is None else 0.0
    top = 9.0 if title else 5.0
    panel_w = (width_mm - bar - 4.0) / n
    panel_h = float(np.clip(panel_w * span_y / span_x, 35.0, 95.0))
    height_mm = panel_h + top + 3.0 + (6.0 if categorical else 0.0)
    info: dict[str, Any] = {
        "chart": "deviation_views",
        "views": [lab for _, lab in views],
        "n_points": int(len(values)),
        "n_drawn": int(len(idx)),
    }
    if categorical is None:
        vmax = float(limit) if limit else float(np.abs(v).max()) or 1.0
        unit, f = _unit(vmax)
        info.update({"display_unit": unit, "vmin": -vmax * f, "vmax": vmax * f, "colormap": _CMAP})
    with _rc():
        fig = _figure(width_mm, height_mm)
        if title:
            fig.text(0.01, 1 - 1.5 / height_mm, title, ha="left", va="top", fontsize=8, fontweight="bold")
        sc = None
        for i, ((x, y, depth), (_, label)) in enumerate(zip(proj, views)):
            left = (2.0 + i * panel_w) / width_mm
            bottom = (3.0 + (6.0 if categorical else 0.0)) / height_mm
            ax = fig.add_axes((left, bottom, panel_w / width_mm * 0.98, panel_h / height_mm))
            o = np.argsort(depth, kind="stable")
            area_pt2 = (panel_w * _MM * 72) * (panel_h * _MM * 72)
            s = float(np.clip(3.0 * area_pt2 / max(len(o), 1), 0.05, 20.0))
            if categorical is None:
                sc = ax.scatter(
                    x[o],
                    y[o],
                    c=v[o] * f,
                    s=s,
                    marker="s" if len(o) > 5000 else "o",
                    cmap=_CMAP,
                    vmin=-vmax * f,
                    vmax=vmax * f,
                    linewidths=0,
                )
            else:
                cols = np.empty(len(o), dtype=object)
                for key, (col, _) in categorical.items():
                    cols[v[o] == key] = col
                ax.scatter(x[o], y[o], c=list(cols), s=s, marker="s" if len(o) > 5000 else "o", linewidths=0)
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xticks([])
            ax.set_yticks([])
            for sp in ax.spines.values():
                sp.set_visible(False)
            ax.set_title(label, fontsize=6.5, color="#555", pad=1.5)
            # axis triad: the projected x, y, z unit vectors in the lower left
            d = views[i][0] / np.linalg.norm(views[i][0])
            ex = np.cross([0, 0, 1.0], d)
            ex /= np.linalg.norm(ex)
            ey = np.cross(d, ex)
            for k, (name, col) in enumerate((("x", "#c62828"), ("y", "#2e7d32"), ("z", "#1565c0"))):
                e = np.eye(3)[k]
                ax.annotate(
                    "",
                    xy=(0.06 + 0.05 * (e @ ex), 0.08 + 0.05 * (e @ ey)),
                    xytext=(0.06, 0.08),
                    xycoords="axes fraction",
                    arrowprops={"arrowstyle": "-|>", "color": col, "lw": 0.6},
                )
                ax.text(
                    0.06 + 0.065 * (e @ ex),
                    0.08 + 0.065 * (e @ ey),
                    name,
                    transform=ax.transAxes,
                    fontsize=5.5,
                    color=col,
                    ha="center",
                    va="center",
                )
        if categorical is None and sc is not None:
            cax = fig.add_axes(
                ((width_mm - bar + 2.0) / width_mm, 4.0 / height_mm, 2.6 / width_mm, (panel_h - 4.0) / height_mm)
            )
            over = bool(np.abs(values).max() > vmax * (1 + 1e-12))
            cb = fig.colorbar(sc, cax=cax, extend="both" if over else "neither")
            cb.set_label(f"deviation [{unit}]")
            cb.ax.tick_params(length=2)
        elif categorical:
            from matplotlib.lines import Line2D

            handles = [Line2D([], [], marker="s", ls="", color=col, label=lab) for col, lab in categorical.values()]
            fig.legend(handles=handles, loc="lower center", ncol=len(handles), frameon=False, fontsize=6.5)
        png = _png(fig, info)
    return png


def material_ratio_chart(
    mr: dict[str, Any],
    interval: Sequence[float] | None = None,
    title: str | None = None,
    width_mm: float = 82.0,
    height_mm: float = 62.0,
    what: str = "deviation",
) -> bytes:
    """The Abbott-Firestone curve with the ISO 13565-2 construction drawn in.

    Curve (material ratio on x, height on y), the 40 % secant of least gradient and its
    extension (the equivalent straight line) to 0 and 100 %, C1 and C2 with Smr1 and
    Smr2, the equal-area triangles of height Spk and Svk; ``interval`` (p2.5, p97.5)
    marks the band holding 95 % of the values.
    """
    from matplotlib.patches import Polygon

    curve = mr["curve"]
    x = np.asarray(curve["mr_percent"], dtype=float)
    h = np.asarray(curve["height"], dtype=float)
    unit, f = _unit(float(np.abs(h).max()))
    y = h * f
    C1, C2 = mr["C1"] * f, mr["C2"] * f
    s1, s2 = mr["Smr1"], mr["Smr2"]
    info = {"chart": "material_ratio", "display_unit": unit, **{k: mr[k] for k in ("Sk", "Spk", "Svk", "Smr1", "Smr2")}}
    with _rc():
        fig = _figure(width_mm, height_mm)
        top = 9.0 if title else 4.0
        ax = fig.add_axes((12.5 / width_mm, 9.5 / height_mm, 1 - 15.5 / width_mm, 1 - (9.5 + top) / height_mm))
        if title:
            fig.text(0.012, 1 - 1.2 / height_mm, title, ha="left", va="top", fontsize=8, fontweight="bold")
        ax.fill_between(x, y, C1, where=y > C1, color="#f4b6b6", lw=0, zorder=1)
        ax.fill_between(x, y, C2, where=y < C2, color="#b8cde8", lw=0, zorder=1)
        ax.add_patch(
            Polygon(
                [[0, C1], [0, C1 + mr["Spk"] * f], [s1, C1]], closed=True, fill=False, ec="#c62828", lw=0.8, zorder=3
            )
        )
        ax.add_patch(
            Polygon(
                [[100, C2], [100, C2 - mr["Svk"] * f], [s2, C2]],
                closed=True,
                fill=False,
                ec="#1565c0",
                lw=0.8,
                zorder=3,
            )
        )
        ax.plot(x, y, color="#111", lw=1.0, zorder=4, label="material-ratio curve")
        ax.plot([0, 100], [C1, C2], color="#6a1b9a", lw=0.7, ls="--", zorder=3, label="equivalent straight line")
        a, b = mr["secant_start"], mr["secant_end"]
        ya, yb = np.interp([a, b], x, y)
        ax.plot([a, b], [ya, yb], color="#6a1b9a", lw=1.8, zorder=5, label="40 % secant of least gradient")
        ax.hlines([C1, C2], [0, 0], [s1, s2], color="#555", lw=0.5, ls=":", zorder=2)
        ax.vlines([s1, s2], [y.min()] * 2, [C1, C2], color="#555", lw=0.5, ls=":", zorder=2)
        if interval is not None:
            lo, hi = interval[0] * f, interval[1] * f
            ax.axhspan(lo, hi, xmin=0, xmax=1, color="#e8f5e9", zorder=0, lw=0)
            ax.text(
                50,
                hi,
                f"95 % within {hi:+.3g} / {lo:+.3g} {unit}".replace("-", "\u2212"),
                ha="center",
                va="bottom",
                fontsize=6,
                color="#2e7d32",
            )
        ax.set_xlim(0, 100)
        pad = 0.06 * (y.max() - y.min() or 1.0)
        ax.set_ylim(min(y.min(), C2 - mr["Svk"] * f) - pad, max(y.max(), C1 + mr["Spk"] * f) + pad)
        ax.set_xlabel("material ratio [%]")
        ax.set_ylabel(f"{what} [{unit}]")
        ax.grid(color="#e3e6ea", lw=0.5, zorder=0)
        ax.tick_params(length=2)
        txt = (
            f"Sk {numbers.significant(mr['Sk'] * f, 3)}  Spk {numbers.significant(mr['Spk'] * f, 3)}  "
            f"Svk {numbers.significant(mr['Svk'] * f, 3)} {unit}\n"
            f"Smr1 {s1:.2f} %  Smr2 {s2:.2f} %"
        )
        ax.text(
            0.98,
            0.97,
            txt,
            transform=ax.transAxes,
            ha="right",
            va="top",
            fontsize=6,
            bbox={"boxstyle": "round,pad=0.3", "fc": "white", "ec": "#ccc", "lw": 0.5},
        )
        ax.legend(loc="lower left", frameon=False, fontsize=5.5, handlelength=1.6)
        png = _png(fig, info)
    return png


def _is_flat(points: np.ndarray) -> bool:
    c = points.mean(axis=0)
    sv = np.linalg.svd((points - c)[:: max(1, len(points) // 20000)], compute_uv=False)
    return bool(sv[2] < 0.05 * sv[0])


def _fmt_mm(x: float | None) -> str:
    """A deviation or a small distance (mm) by the number rule: µm below 1 mm, else mm."""
    if x is None or x != x:
        return "—"
    return numbers.deviation(x, signed=False) if abs(x) < 1.0 else numbers.length(x)


#: the statistics table's rows in words (the JSON keeps its keys: they are the contract)
_STAT_WORDS = {
    "n": "points",
    "mean": "mean",
    "std": "standard deviation",
    "rms": "RMS",
    "min": "minimum",
    "max": "maximum",
}


def build_report(
    o: dict[str, Any],
    cloud_file: str | None = None,
    nominal_file: str | None = None,
    run=None,
    tolerance: float | None = None,
    customer: dict[str, str] | None = None,
) -> Report:
    """The customer report of an ``inspect.compare`` result ``o`` (its outputs dict).

    Head: the order's fields ``customer`` (checked, e.g. by ``Report.customer_fields``).
    Body: the overall verdict and the characteristic (the profile of the surface: every
    deviation within ±``tolerance``), the summary, the deviations, the coverage, the
    signature fields. Appendix: alignment, deviation statistics, material ratio,
    provenance."""
    dev_cloud = o["deviations"]
    st, mr, a = o["stats"], o["material_ratio"], o["alignment"]
    measured = dev_cloud.name.removesuffix(" deviations")
    r = Report(
        "Inspection against the nominal",
        subtitle=f"{measured} against {Path(nominal_file).name}" if nominal_file else measured,
        meta={
            "Measured data": Path(cloud_file).name if cloud_file else dev_cloud.name,
            "Nominal": Path(nominal_file).name if nominal_file else "\u2014",
            "Points": dev_cloud.n_points,
            "Tolerance": "\u2014" if tolerance is None else f"±{tolerance} mm",
        },
    ).customer(dict(customer or {}))

    failed = not a["converged"]
    held = list(o.get("held_dofs") or a.get("held_dofs") or [])
    word = _result_section(r, st, tolerance, failed)
    s = r.section("Summary")
    if failed:
        s.warning(
            f"alignment failed: {a['reason']}. The alignment did not converge, so no deviations are reported: "
            "they would rest on a wrong alignment. The numbers under 'Unaligned comparison' are a diagnosis only."
        )
    s.keyvalues(_summary_rows(o, a, st, mr, tolerance, held, failed))
    warnings = list(run.warnings) if run is not None else []
    if warnings:  # the plugin's words may name parameters: listed in the appendix
        s.paragraph(f"The comparison noted {len(warnings)} point(s) to check; they are listed in the appendix.")

    if failed:
        _unaligned_section(r, o, st)
    else:
        _deviation_sections(r, o, st, mr)
    r.section("Signatures").signature((("Inspected by", (customer or {}).get("operator", "")), ("Approved by", "")))

    if warnings:
        s = r.section("Notes of the comparison", appendix=True)
        for w in warnings:
            s.warning(w)
    s = r.section("Alignment", appendix=True)
    s.paragraph(
        "The transform maps measured coordinates onto nominal ones: x_nominal = s·R·x_measured + t; "
        "the matrix below holds s·R and t."
    )
    s.table(
        ["", "1", "2", "3", "4"],
        # 9 decimals (R to 1e-9, t to the nanometre), never an exponent (issue 30: 5.8819457e-07)
        [[f"row {i + 1}", *[numbers.mm(v, default=9) for v in row]] for i, row in enumerate(a["transform"])],
        caption="Transform measured → nominal (4×4)",
    )
    kv = [
        ("method", a["method"]),
        ("converged", a["converged"]),
        ("reason", a["reason"] or "—"),
        ("scale s", f"{a['scale']:.9f}"),
        ("rotation angle", f"{a['rotation_angle_deg']:.6f}°"),
        ("translation t", "(" + ", ".join(f"{v:.5f}" for v in a["translation"]) + ") mm"),
        ("iterations", a["iterations"]),
        ("points used / overlapping", f"{a['n_points']} / {a['n_inliers']}"),
        ("RMS of the overlapping points", _fmt_mm(a["rms"])),
        ("RMS of all points", _fmt_mm(a["rms_all"])),
    ]
    if held:
        kv.append(("held (the part's symmetry leaves them undetermined)", "; ".join(held)))
    elif a["weak_directions"]:
        kv.append(("not determined by the data", "; ".join(a["weak_directions"])))
    for stg in a["stages"]:
        if stg.get("stage") == "global":
            kv.append(
                (
                    "global registration",
                    f"RANSAC fitness {stg['fitness']:.3f}, voxel {numbers.significant(stg['voxel'], 4)} mm, "
                    f"prescale {numbers.significant(stg['prescale'], 6)}",
                )
            )
        elif stg.get("stage") == "pairs":
            kv.append(("point pairs", f"{len(stg['residuals'])} pairs, RMS {_fmt_mm(stg['rms'])}"))
        elif "kernel" in stg:
            kv.append(
                (
                    "ICP",
                    f"kernel {stg['kernel']} (k = {_fmt_mm(stg['kernel_k'])}), max distance "
                    f"{_fmt_mm(stg['max_distance'])}" + (f", region {stg['region']}" if stg.get("region") else ""),
                )
            )
    s.keyvalues(kv)
    if not failed:
        _appendix_sections(r, st, mr)

    if run is not None:
        r.provenance(
            plugins=[{"id": run.plugin_id, "version": run.plugin_version, "params": run.params}],
            extra={"started": run.started, "finished": run.finished},
        )
    # the report hashes the files itself (SHA-256 of the bytes read)
    r.provenance(inputs=[{"file": str(f)} for f in (cloud_file, nominal_file) if f and Path(str(f)).is_file()])
    c = o["coverage_info"]
    r.data = {
        "transform": a["transform"],
        "scale": a["scale"],
        "rms": a["rms"],
        "overlap": a["overlap"],
        "converged": a["converged"],
        "reason": a["reason"],
        "stats": st,
        "coverage": o["coverage"],
        "coverage_info": c,
        "material_ratio": {k: v for k, v in mr.items() if k != "curve"},
        "histogram": o["histogram"],
        "alignment": a,
        "held_dofs": held,
        "aligned": not failed,
        "customer": dict(customer or {}),
        "verdict": word,
    }
    if failed:  # as `camcmm inspect --json`: the unaligned numbers only under "unaligned"
        keys = ("stats", "coverage", "coverage_info", "material_ratio", "histogram")
        r.data["failure"] = f"alignment failed: {a['reason']}"
        r.data["unaligned"] = {"note": UNALIGNED_NOTE, **{k: r.data[k] for k in keys}}
        r.data.update(dict.fromkeys(keys))
    return r


def _result_section(r: Report, st: dict[str, Any], tolerance: float | None, failed: bool) -> str:
    """The overall verdict and the characteristic as on a drawing: the profile of the
    surface, every measured deviation within ±``tolerance`` (no measurement uncertainty is
    stated, so the simple rule decides). Returns the badge word."""
    s = r.section("Result")
    if failed:
        s.verdict("Part", "incomplete", note="the alignment failed")
        s.paragraph("No verdict: the alignment failed, so no deviation was measured.")
        return "incomplete"
    lo, hi = st["min"], st["max"]
    if tolerance is None:
        s.paragraph("No tolerance was given: the deviations are reported without a verdict.")
        word, verdict = "incomplete", "not evaluated"
    else:
        inside = lo >= -tolerance and hi <= tolerance
        word, verdict = ("pass", "conform") if inside else ("fail", "not conform")
        out = 100.0 * (1.0 - st["within_tolerance"]) if st.get("within_tolerance") is not None else None
        s.verdict("Part", word, value=f"{_fmt_mm(lo)} … {_fmt_mm(hi)}", limit=f"±{tolerance} mm")
        s.paragraph(
            "Every measured deviation is in tolerance."
            if inside
            else f"Out of tolerance: the surface profile ({out:.2f} % of the points outside ±{tolerance} mm)."
            if out is not None
            else f"Out of tolerance: the surface profile (beyond ±{tolerance} mm)."
        )
    s.table(
        ["No.", "", "Characteristic", "Datums", "Tolerance mm", "Value mm (min / max)", "U mm", "Verdict"],
        [
            [
                "1",
                "\u25e0",
                "Profile of the surface (every measured point)",
                "\u2014 (best fit)",
                "\u2014" if tolerance is None else f"±{numbers.significant(tolerance, 6)}",
                f"{lo:+.4f} / {hi:+.4f}",
                "\u2014",
                verdict,
            ]
        ],
        caption="As on the drawing; no measurement uncertainty is stated, so the verdict is the simple one "
        "(the deviations against the limits).",
        align=["left", "center", "left", "left", "right", "right", "right", "left"],
    )
    return word


UNALIGNED_NOTE = (
    "statistics of the unaligned comparison (the cloud where the failed alignment left it); "
    "for diagnosis only, not results"
)


def _summary_rows(o, a, st, mr, tolerance, held, failed) -> list[tuple[str, Any]]:
    """The summary: the alignment, then (only when it converged) the deviations."""
    rows: list[tuple[str, Any]] = [
        ("alignment", f"{a['method']}: " + ("converged" if not failed else f"FAILED ({a['reason']})")),
        ("scale applied to the measured cloud", f"{a['scale']:.8f}"),
        ("alignment RMS (overlapping points)", _fmt_mm(a["rms"])),
        (
            "overlap",
            "—"
            if a["overlap"] != a["overlap"]
            else f"{100 * a['overlap']:.1f} % within {_fmt_mm(a['inlier_distance'])}",
        ),
    ]
    if held:
        rows.append(("held by the part's symmetry", "; ".join(held)))
    if failed:
        return rows + [("deviations", "none: alignment failed")]
    return rows + [
        ("deviation mean ± std", f"{_fmt_mm(st['mean'])} ± {_fmt_mm(st['std'])}"),
        ("deviation RMS", _fmt_mm(st["rms"])),
        ("min / max", f"{_fmt_mm(st['min'])} / {_fmt_mm(st['max'])}"),
        ("95 % of the deviations within", f"{_fmt_mm(st['p2_5'])} … {_fmt_mm(st['p97_5'])}"),
        *(
            [("within tolerance", f"{100 * st['within_tolerance']:.2f} % within ±{tolerance} mm")]
            if tolerance is not None
            else []
        ),
        ("coverage of the nominal area", f"{o['coverage_info']['percent']:.2f} %"),
        ("Sk / Spk / Svk", f"{_fmt_mm(mr['Sk'])} / {_fmt_mm(mr['Spk'])} / {_fmt_mm(mr['Svk'])}"),
        ("Smr1 / Smr2", f"{mr['Smr1']:.2f} % / {mr['Smr2']:.2f} %"),
    ]


def _unaligned_section(r: Report, o: dict[str, Any], st: dict[str, Any]) -> None:
    """A failed alignment: the distances where it left the cloud, labelled as a diagnosis;
    no colour map, histogram, material ratio or coverage (they would read as results)."""
    s = r.section("Unaligned comparison (diagnosis only, not results)")
    s.paragraph(
        "The alignment failed, so the distances below are those of the cloud where the failed alignment "
        "left it. They say how far off it is, not how the part deviates."
    )
    s.keyvalues(
        [
            ("points", st["n"]),
            ("distance mean / RMS", f"{_fmt_mm(st['mean'])} / {_fmt_mm(st['rms'])}"),
            ("largest |distance|", _fmt_mm(st["max_abs"])),
        ]
    )


def _deviation_sections(r: Report, o: dict[str, Any], st: dict[str, Any], mr: dict[str, Any]) -> None:
    """Deviations, material ratio and coverage of a converged comparison."""
    dev_cloud = o["deviations"]
    dev = dev_cloud.fields["deviation"]
    limit = o["colour_limit"]
    s = r.section("Deviations")
    s.paragraph(
        f"Signed distance of every measured point to the nominal ({o['distance_method']}). Positive: outside "
        "the material (red), negative: inside (blue). Colours saturate at ±" + _fmt_mm(limit) + "."
    )
    chord = (o.get("nominal_info") or {}).get("chordal")
    if chord:  # a mesh standing for a known surface: the bias its facets put into every deviation
        s.paragraph(
            f"The nominal mesh's vertices lie on one {chord['surface']} (radius {_fmt_mm(chord['radius'])}); its "
            f"facets lie up to {_fmt_mm(chord['error'])} inside it (chordal error), and every deviation carries "
            "up to that bias. Compare with the exact surface (a STEP file) to remove it."
        )
    P = dev_cloud.points
    s.figure(deviation_views(P, dev, limit, title="Deviation colour map"), caption="Deviations, two views")
    if _is_flat(P):
        s.figure(
            charts.deviation_map(P, dev, kind="plane", limit=limit, title="Deviation map (in-plane)"),
            caption="Deviations over the plane of the part",
        )
    s.figure(
        charts.histogram(dev, limit=limit, title="Histogram"),
        caption="Histogram of the deviations",
        data={"edges": o["histogram"]["edges"], "counts": o["histogram"]["counts"]},
    )
    s.figure(
        material_ratio_chart(mr, st["interval95"], title="Abbott-Firestone curve"),
        caption="Material-ratio curve of the deviations (ISO 13565-2 construction)",
        data={"mr_percent": mr["curve"]["mr_percent"][::10], "height_mm": mr["curve"]["height"][::10]},
    )
    c = o["coverage_info"]
    s = r.section("Coverage")
    s.paragraph(
        "Share of the nominal surface area with a measured point nearby: the nominal surface is sampled "
        "uniformly by area and a sample counts as covered when a measured point lies within the coverage "
        "distance (area, not point count: thesis ch. 6.2.4)."
    )
    s.keyvalues(
        [
            ("covered", f"{c['percent']:.2f} % (standard error {100 * c['std_error']:.2f} %)"),
            ("covered area", "—" if c["area"] is None else f"{c['covered_area']:.1f} of {c['area']:.1f} mm²"),
            ("coverage distance", _fmt_mm(c["distance"])),
            ("samples", c["n_samples"]),
            ("method", c["method"]),
        ]
    )
    cc = o.get("coverage_cloud")
    if cc is not None:
        s.figure(
            deviation_views(
                cc.points,
                cc.fields["covered"].astype(float),
                title="Coverage of the nominal",
                views=VIEWS3,
                categorical={1.0: ("#4f8f63", "covered"), 0.0: ("#c9ccd1", "not covered")},
            ),
            caption="Nominal surface samples: covered (green) or not (grey)",
        )


def _appendix_sections(r: Report, st: dict[str, Any], mr: dict[str, Any]) -> None:
    """The statistics table (keys as in the JSON) and the material-ratio construction."""
    s = r.section("Deviation statistics", appendix=True)
    keys = ["n", "mean", "std", "rms", "min", "max", "p0_5", "p2_5", "p5", "p25", "p50", "p75", "p95", "p97_5", "p99_5"]
    s.table(
        ["statistic", "value"],
        [
            [
                _STAT_WORDS.get(k) or f"percentile {numbers.percentile_key(k)}",
                numbers.count(st[k]) if k == "n" else numbers.deviation(st[k], signed=k not in ("std", "rms")),
            ]
            for k in keys
        ],
        caption="Deviation statistics in µm (percentiles: Hazen plotting position)",
        align=["left", "right"],
    )

    s = r.section("Material ratio (ISO 13565-2 / ISO 25178-2)", appendix=True)
    s.paragraph(
        "Construction: the material-ratio curve (share of points at or above each height) is cut by the "
        "secant over 40 % of material ratio with the least gradient; extended to 0 % and 100 % it gives C1 "
        "and C2 (Sk = C1 − C2). Smr1 and Smr2 are the material ratios where the curve crosses C1 and C2. The "
        "areas of the curve above C1 and below C2 are replaced by right-angled triangles of the same area on "
        "the bases Smr1 and 100 % − Smr2; their heights are Spk and Svk."
    )
    s.table(
        ["parameter", "value", "unit"],
        [
            ["Sk", numbers.micro(mr["Sk"]), "µm"],
            ["Spk", numbers.micro(mr["Spk"]), "µm"],
            ["Svk", numbers.micro(mr["Svk"]), "µm"],
            ["Smr1", numbers.plain(mr["Smr1"], 4), "%"],
            ["Smr2", numbers.plain(mr["Smr2"], 4), "%"],
            ["C1", numbers.micro(mr["C1"], signed=True), "µm"],
            ["C2", numbers.micro(mr["C2"], signed=True), "µm"],
            ["secant", f"{numbers.plain(mr['secant_start'], 3)} … {numbers.plain(mr['secant_end'], 3)}", "%"],
            [
                "Smc(2.5 %) / Smc(97.5 %)",
                f"{numbers.micro(mr['Smc']['2.5'], True)} / {numbers.micro(mr['Smc']['97.5'], True)}",
                "µm",
            ],
            [
                "Vmp / Vmc / Vvc / Vvv",
                " / ".join(numbers.micro(mr[k]) for k in ("Vmp", "Vmc", "Vvc", "Vvv")),
                "µm³/µm²",
            ],
        ],
        caption="Material-ratio parameters of the deviations",
        align=["left", "right", "left"],
    )
